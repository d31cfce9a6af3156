use taiji::campaign::{samples, Stages, Threads};
use taiji::estimate::Method;
#[test]
fn early() {
    let dir = std::env::temp_dir().join("zz_early.toml");
    std::fs::write(
        &dir,
        "name = \"mon\"\nseed = 5\nduration_s = 1500.0\n[maneuver]\nfrequency_hz = 1e-2\n",
    )
    .unwrap();
    let s = taiji::scenario::Scenario::load(&dir).unwrap();
    let st = Stages::new(&s, s.seed, Method::Joint);
    let mut est = st.estimator;
    let is0 = &s.inertial_sensor[0];
    let truth = [
        is0.geometry_m[0] + is0.com_offset_m[0],
        is0.geometry_m[1] + is0.com_offset_m[1],
        is0.geometry_m[2] + is0.com_offset_m[2],
    ];
    let mut tick = 0u64;
    samples(&s, st.commander, st.plant, st.fee, Threads::One, |m| {
        let e = est.step(m);
        tick += 1;
        if [
            300u64, 600, 620, 640, 700, 800, 1000, 1200, 1500, 2000, 3000, 5000, 8000, 15000,
        ]
        .contains(&tick)
        {
            eprintln!("tick {tick} solved {} status {:#x} rz {:.4e} sig {:.3e} err/sig {:.2}  ry err/sig {:.2} bx err/sig {:.2} infl {:.2} chi {:?}",
              e.solved_tick, e.status, e.r_b[0][2], e.r_sigma[0][2], (e.r_b[0][2]-truth[2])/e.r_sigma[0][2],
              (e.r_b[0][1]-truth[1])/e.r_sigma[0][1],
              (e.beta[0][0]/ s.inertial_sensor[0].beta[0] - 1.0)/e.beta_sigma[0][0], e.sigma_inflation, e.chi2_per_dof);
        }
    });
}
