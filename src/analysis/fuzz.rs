//! Property test of the estimator's step on arbitrary input: real campaign samples
//! mixed with random bytes, flipped bits, special values and wild tick orders. Used by
//! the integration tests and by `cargo run --release --example fuzz_estimator -- N`.
//! The property: no panic, and every estimate and σ it prints is finite.

use crate::analysis::campaign::Stages;
use crate::sim::estimate::Method;
use crate::sim::msg::{EstimateMsg, SensorSample};
use crate::sim::scenario::Scenario;

/// What a fuzz run saw.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FuzzStats {
    /// Samples stepped.
    pub steps: u64,
    /// Estimates with a non-finite value or σ (must be 0).
    pub non_finite: u64,
    /// Samples the estimator rejected for some cause.
    pub rejected: u64,
    /// The estimator's final count by cause.
    pub causes: [u64; crate::sim::msg::N_CAUSES],
}

/// SplitMix64: cheap, seeded bits (the fuzz and upset campaigns draw from it).
pub(crate) struct Bits(pub(crate) u64);

impl Bits {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub(crate) fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

const SPECIALS: [f64; 9] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    f64::MIN,
    f64::MIN_POSITIVE,
    5e-324,
    -0.0,
    1e6,
];

/// Every f64 field of a sample the estimator reads, by index (12 voltages, 4
/// quaternion components).
fn field(s: &mut SensorSample, k: u64) -> &mut f64 {
    let k = (k % 16) as usize;
    if k < 12 {
        &mut s.is[k / 6].volts[(k % 6) / 2][k % 2]
    } else {
        &mut s.star.q_bn[k - 12]
    }
}

fn finite(e: &EstimateMsg) -> bool {
    let all = |v: &[[f64; 3]; 2]| v.iter().flatten().all(|x| x.is_finite());
    all(&e.beta)
        && all(&e.beta_sigma)
        && all(&e.k)
        && all(&e.k_sigma)
        && all(&e.r_b)
        && all(&e.r_sigma)
        && e.chi2_per_dof.iter().all(|x| x.is_finite())
        && e.sigma_inflation.is_finite()
}

/// Step `cases` samples through the joint estimator of the default scenario.
pub fn run(cases: u64, seed: u64) -> FuzzStats {
    let s = Scenario::default();
    let n = s.n_samples();
    let mut st = Stages::new(&s, seed, Method::Joint);
    let mut bits = Bits(seed);
    let mut stats = FuzzStats::default();
    let mut tick = 0u64;
    for _ in 0..cases {
        let t = tick % n;
        let cmd = st.commander.step(t);
        let truth = st.plant.step(t, &cmd.torque_cmd_b);
        let mut m = st.fee.step(&truth);
        m.header.tick = tick;
        match bits.below(24) {
            0 => {
                // Random bytes in every field.
                for k in 0..16 {
                    *field(&mut m, k) = f64::from_bits(bits.next());
                }
                m.is[0].flags = bits.next() as u8;
                m.is[1].flags = bits.next() as u8;
                m.star.valid = bits.next() as u8;
                m.header.seq = bits.next();
                m.header.tick = bits.next();
            }
            1 | 2 => {
                let k = bits.next();
                let b = bits.below(64);
                let v = field(&mut m, k);
                *v = f64::from_bits(v.to_bits() ^ (1 << b));
            }
            3 => {
                let k = bits.next();
                *field(&mut m, k) = SPECIALS[bits.below(SPECIALS.len() as u64) as usize];
            }
            4 => m.is[bits.below(2) as usize].flags ^= 1 << bits.below(8),
            5 => m.star.valid = bits.next() as u8,
            6 => m.header.tick = tick.saturating_sub(1 + bits.below(3)),
            7 => {
                m.header.tick =
                    [u64::MAX, u64::MAX - 1, tick + (1 << 40), 0][bits.below(4) as usize]
            }
            8 => {
                // Stuck: the previous voltages again (approximately: same bits).
                let k = bits.below(12);
                *field(&mut m, k) = 1.0;
            }
            _ => {}
        }
        let e = st.estimator.step(&m);
        stats.steps += 1;
        stats.non_finite += u64::from(!finite(&e));
        stats.rejected += u64::from(e.tick_rejections != 0);
        // Usually the next tick; sometimes a gap (lost on the bus: the plant and the
        // front-end go on, so the stream stays physically consistent).
        let step = if bits.below(50) == 0 {
            1 + bits.below(700)
        } else {
            1
        };
        for k in 1..step {
            let t = (tick + k) % n;
            let cmd = st.commander.step(t);
            let truth = st.plant.step(t, &cmd.torque_cmd_b);
            st.fee.step(&truth);
        }
        tick += step;
    }
    let e = st.estimator.finish();
    stats.non_finite += u64::from(!finite(&e));
    stats.causes = e.rejected_by_cause;
    stats
}
