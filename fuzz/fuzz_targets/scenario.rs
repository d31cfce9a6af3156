//! The scenario parser (`Scenario::from_toml_str`, src/sim/scenario/check.rs) on any
//! text: Ok or an error with a message, never a panic. A file that is not UTF-8 is
//! refused by `Scenario::load` before the parser sees it; here its bytes go in lossily
//! converted, so every input is text. A scenario accepted is then used as `run` uses
//! it first: its sample count, priors and the estimator's table, which must pass the
//! table's own check (a valid scenario never makes an invalid table).
#![no_main]

use libfuzzer_sys::fuzz_target;
use taiji::sim::scenario::Scenario;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match Scenario::from_toml_str(&text) {
        Ok(s) => {
            let n = s.n_samples();
            assert!(n > 0, "an accepted scenario has samples");
            assert!(s.dt().is_finite() && s.dt() > 0.0);
            let _ = s.sun_unit();
            let _ = s.axis_order();
            let priors = s.priors();
            assert_eq!(priors.len(), s.inertial_sensor.len());
            let cfg = s.estimator_config(&priors);
            if let Err(e) = cfg.check() {
                panic!("an accepted scenario makes a table its check refuses: {e:?}");
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.trim().is_empty(), "an error without a message");
        }
    }
});
