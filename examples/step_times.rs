use taiji::campaign::Stages;
use taiji::estimate::Method;
use taiji::scenario::Scenario;
use taiji::timing::{monotonic_ns, LatencyHistogram};
fn main() {
    let s = Scenario::default();
    let mut st = Stages::new(&s, 1, Method::Joint);
    let mut h = LatencyHistogram::default();
    for t in 0..s.n_samples() {
        let c = st.commander.step(t);
        let tr = st.plant.step(t, &c.torque_cmd_b);
        let x = st.fee.step(&tr);
        let a = monotonic_ns();
        st.estimator.step(&x);
        h.record(monotonic_ns() - a);
    }
    println!("{:?}", h.summary_us());
}
