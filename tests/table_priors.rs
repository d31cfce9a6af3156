//! A campaign that starts from the onboard calibration table: campaign 1 as
//! `taiji-calib run` flies it, its result applied (function 3's rule, through the
//! table's file), then second campaigns from the table over many seeds. Their priors
//! are campaign 1's estimates bit for bit, their reports say where the priors came
//! from, and their σ stays honest: (err/σ)² averages near 1, as for campaign 1.

mod support;
mod tmpdir;
use taiji::analysis::campaign::Threads;
use taiji::analysis::crlb::{run_with_bound, Bounds};
use taiji::analysis::montecarlo::{run_seeds, summarise};
use taiji::analysis::plan::{maneuver_bound, resolve};
use taiji::analysis::report::{table_values, PriorsSource, Report};
use taiji::ground::table::{Entry, TableStore};
use taiji::sim::estimate::Method;
use taiji::sim::msg::TableValues;
use taiji::sim::scenario::{k_from_beta, Scenario};
use taiji::sim::trend;

/// Seeds of the second campaigns (and of campaign 1's, for comparison).
const SEEDS: u64 = 40;

fn bits(v: [f64; 3]) -> [u64; 3] {
    v.map(f64::to_bits)
}

/// Mean (err/σ)² per group (β, k, r) and over all, of seeds `2..2 + SEEDS` of `s`.
fn honesty(s: &Scenario, bound: &Bounds) -> ([f64; 3], f64, Vec<Report>) {
    let seeds: Vec<u64> = (2..2 + SEEDS).collect();
    let reports = run_seeds(s, &seeds, Method::Joint, bound, |_| Ok(())).unwrap();
    let mc = summarise(&s.name, 2, 2, SEEDS, "joint", reports.clone());
    let (mut sum, mut n) = (0.0, 0);
    for r in &reports {
        for row in r.rows() {
            sum += row.z * row.z;
            n += 1;
        }
    }
    (mc.chi2_by_group, sum / n as f64, reports)
}

#[test]
fn a_campaign_from_the_onboard_table_starts_from_its_values_with_an_honest_sigma() {
    // Campaign 1: the default scenario, planned, seed 1, as `taiji-calib run`.
    let s = resolve(Scenario::load_or_default(None).unwrap()).unwrap().0;
    let (res, run) =
        run_with_bound(&s, 1, Method::Joint, Threads::available(), |_| {}, None).unwrap();
    let bounds = Bounds {
        run: run.unwrap(),
        maneuver: maneuver_bound(&s),
    };
    let r1 = Report::with_bounds(&s, 1, "in-process", "joint", &res.estimate, &bounds);
    assert_eq!(r1.priors_source, PriorsSource::Scenario);
    let v = serde_json::to_value(&r1).unwrap();
    assert_eq!(v["priors_source"], "scenario");
    assert_eq!(
        v["inertial_sensors"][1]["k"]["prior"]
            .as_array()
            .unwrap()
            .len(),
        3
    );

    // Applied, through the table's file, and read back as after a restart.
    let dir = support::tmp("store");
    let (mut store, problem) = TableStore::open(&dir);
    assert!(problem.is_none());
    // Function 3's way: the result starts the trends (no drift: constant parameters).
    let mut trends = [[[None; 3]; 3]; 2];
    let mid = trend::campaign_middle(0.0, s.duration_s);
    trend::take_in(&mut trends, &s, &table_values(&r1).unwrap(), mid);
    store.apply(Entry::from_trends(1, trends)).unwrap();
    drop(store);
    let (store, problem) = TableStore::open(&dir);
    assert!(problem.is_none());
    let campaign = store.current().map(|(_, c)| c);
    assert_eq!(campaign, Some(1));
    // The priors of campaign 2, a day later: the trends' prediction.
    let t: TableValues = store.entry().unwrap().at(1.0);

    // Campaign 2's scenario, as the process set's stages load it (TOML, validated).
    let s2 = s.with_onboard_priors(&t);
    let s2 = Scenario::from_toml_str(&toml::to_string(&s2).unwrap()).unwrap();
    assert_eq!(s2.priors_source, PriorsSource::OnboardTable);
    assert_eq!(s2.maneuver, s.maneuver, "the maneuver planned for the file");
    let cfg = s2.estimator_config(&s2.priors());
    for (i, is) in r1.inertial_sensors.iter().enumerate() {
        assert_eq!(
            bits(cfg.beta_prior[i]),
            bits(is.beta.estimate),
            "IS{} β",
            i + 1
        );
        assert_eq!(
            bits(cfg.com_prior_m[i]),
            bits(is.com_offset.estimate),
            "IS{} r",
            i + 1
        );
    }

    let (z2_table, all_table, reports) = honesty(&s2, &bounds);
    let (z2_first, all_first, first) = honesty(&s, &bounds);
    // How far the table's priors moved the estimates from those of the scenario's
    // priors (the same seeds' noise), in σ: the priors differ, the data dominate.
    let moved = reports
        .iter()
        .zip(&first)
        .flat_map(|(a, b)| a.rows().into_iter().zip(b.rows()))
        .map(|(a, b)| (a.z - b.z).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "mean (err/σ)² over {SEEDS} seeds, β / k / r / all: from the table {z2_table:.3?} {all_table:.3}; from the scenario's priors {z2_first:.3?} {all_first:.3}; estimates moved by the table's priors at most {moved:.2e} σ"
    );
    assert!(moved > 0.0, "the table's priors changed nothing");
    for r in &reports {
        let v = serde_json::to_value(r).unwrap();
        assert_eq!(v["priors_source"], "onboard_table");
        for (i, is) in r.inertial_sensors.iter().enumerate() {
            let r1is = &r1.inertial_sensors[i];
            assert_eq!(bits(is.beta.prior), bits(r1is.beta.estimate));
            assert_eq!(
                bits(is.k.prior),
                bits(k_from_beta(
                    &s.inertial_sensor[i].geometry_m,
                    &r1is.beta.estimate
                ))
            );
            assert_eq!(bits(is.com_offset.prior), bits(r1is.com_offset.estimate));
        }
        assert!(
            r.requirements.met && r.requirements.verified,
            "{}",
            r.table()
        );
        // Each result could be applied in turn.
        assert!(table_values(r).is_ok(), "seed {}\n{}", r.seed, r.table());
    }
    for (g, z) in ["β", "k", "r"].iter().zip(z2_table) {
        assert!((0.4..=2.0).contains(&z), "{g}: mean (err/σ)² {z:.2}");
    }
    assert!((0.5..=1.6).contains(&all_table), "all: {all_table:.2}");
}

#[test]
fn priors_from_the_table_are_checked_finite_not_against_the_truth() {
    let s = Scenario::default();
    let mut t = TableValues::default();
    for (i, is) in s.inertial_sensor.iter().enumerate() {
        t.beta[i] = is.beta.map(|b| b * 1.3);
        // 20 cm nearer the spacecraft's CoM on x: the maneuver stays within the IS
        // design limit at these offsets, which onboard knows and checks.
        let r = is.com_offset_m;
        t.r[i] = [r[0] - 0.2, r[1], r[2]];
    }
    // As a file's priors, 30 % and 20 cm off the truth fly with a warning …
    let mut file = s.clone();
    for (i, is) in file.inertial_sensor.iter_mut().enumerate() {
        is.com_offset_prior_m = Some(t.r[i]);
    }
    let w = file.validated().unwrap().truth_warnings();
    assert!(
        w.iter().any(|w| w.contains("200.0 mm off its prior")),
        "{w:?}"
    );
    // … from the table they are taken as well: onboard nothing knows the truth.
    let s2 = s.with_onboard_priors(&t).validated().unwrap();
    let back = Scenario::from_toml_str(&toml::to_string(&s2).unwrap()).unwrap();
    for s in [&s2, &back] {
        assert_eq!(s.priors()[1].beta, t.beta[1]);
        assert_eq!(s.priors()[0].com_offset_m, t.r[0]);
    }
    // Not finite, or β not positive: refused, naming the key.
    let mut bad = t;
    bad.r[0][2] = f64::NAN;
    let e = s
        .with_onboard_priors(&bad)
        .validated()
        .unwrap_err()
        .to_string();
    assert!(e.contains("inertial_sensor[0].com_offset_prior_m"), "{e}");
    let mut bad = t;
    bad.beta[1][0] = 0.0;
    let e = s
        .with_onboard_priors(&bad)
        .validated()
        .unwrap_err()
        .to_string();
    assert!(e.contains("inertial_sensor[1].beta_prior"), "{e}");
    // The table's source without the table's values.
    let e = Scenario::from_toml_str("priors_source = \"onboard_table\"\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("priors_source"), "{e}");
    // A file's scenario says nothing of it.
    assert!(!toml::to_string(&s).unwrap().contains("priors_source"));
}
