//! Micro-thruster torque model (§3.1 of the paper, docs/physics.md): first-order response,
//! edge timing jitter (duty-cycle change), amplitude jitter per half period and
//! overshoot decaying after each edge. Torque noise is added by the plant.

use crate::sim::rng::{gauss, Rng};
use crate::sim::scenario::Thruster as Params;
use rand::Rng as _;

/// One axis: the torque actually produced, as means over integration sub-steps.
#[derive(Debug, Clone, Copy, Default)]
pub struct ThrusterAxis {
    /// Commanded level of the previous interval [N m].
    last_cmd: f64,
    /// Target the lag relaxes to, before / after a pending edge [N m].
    target: f64,
    next_target: f64,
    /// Time of the pending edge [s]; NaN if none.
    edge_t: f64,
    /// First-order lag output [N m].
    lag: f64,
    /// Overshoot amplitude, decays with `overshoot_decay_s` [N m].
    overshoot: f64,
}

#[derive(Debug, Clone, Copy)]
pub struct Thrusters {
    pub axes: [ThrusterAxis; 3],
    p: ParamsCopy,
    decay: Decays,
    stuck: Stuck,
}

/// Mean torques of idle axes (no torque, lag gone, no edge pending) whose overshoot has
/// decayed into the subnormals and stopped there (x e^(−h/τ) rounds back to x below
/// ~25 ulp): the same inputs give the same mean, and subnormal arithmetic is slow.
/// Keyed by the bits of (overshoot, interval length); round-robin.
#[derive(Debug, Clone, Copy)]
struct Stuck {
    key: [(u64, u64); 4],
    mean: [f64; 4],
    next: usize,
}

impl Stuck {
    /// No entry: NaN bits no overshoot has.
    const EMPTY: Stuck = Stuck {
        key: [(u64::MAX, u64::MAX); 4],
        mean: [0.0; 4],
        next: 0,
    };

    fn get(&self, overshoot: f64, len: f64) -> Option<f64> {
        let k = (overshoot.to_bits(), len.to_bits());
        (0..4).find(|&i| self.key[i] == k).map(|i| self.mean[i])
    }

    fn put(&mut self, overshoot: f64, len: f64, mean: f64) {
        self.key[self.next] = (overshoot.to_bits(), len.to_bits());
        self.mean[self.next] = mean;
        self.next = (self.next + 1) % 4;
    }
}

/// The decay factors (e^(−len/τ) of the lag, of the overshoot) of the last two interval
/// lengths `len` [s]. A whole sub-step [t, t + h] is (t + h) − t long, which is h rounded
/// to the spacing of t: one of two values per binade of t. Remembering two lengths
/// saves nearly all of the six `exp` a sub-step would cost; the values are the same.
#[derive(Debug, Clone, Copy)]
struct Decays {
    len: [f64; 2],
    e: [(f64, f64); 2],
    /// The entry the next new length replaces.
    next: usize,
}

impl Decays {
    const EMPTY: Decays = Decays {
        len: [f64::NAN; 2],
        e: [(0.0, 0.0); 2],
        next: 0,
    };

    /// (e^(−len/τ), e^(−len/τ_overshoot)).
    #[inline(always)]
    fn of(&mut self, len: f64, p: &ParamsCopy) -> (f64, f64) {
        if len == self.len[0] {
            return self.e[0];
        }
        if len == self.len[1] {
            return self.e[1];
        }
        let e = ((-len / p.tau).exp(), (-len / p.overshoot_decay).exp());
        self.len[self.next] = len;
        self.e[self.next] = e;
        self.next ^= 1;
        e
    }
}

#[derive(Debug, Clone, Copy)]
struct ParamsCopy {
    tau: f64,
    jitter: f64,
    amp_jitter: f64,
    overshoot_rel: f64,
    overshoot_decay: f64,
}

/// Mean of y(t) = L + (y0 − L) e^(−t/τ) over [0, h], and y(h), given e = e^(−h/τ).
fn relax(y0: f64, level: f64, tau: f64, h: f64, e: f64) -> (f64, f64) {
    let mean = level + (y0 - level) * tau / h * (1.0 - e);
    (mean, level + (y0 - level) * e)
}

impl Thrusters {
    pub fn new(p: &Params) -> Self {
        let axis = ThrusterAxis {
            edge_t: f64::NAN,
            ..Default::default()
        };
        Thrusters {
            axes: [axis; 3],
            p: ParamsCopy {
                tau: p.response_time_s,
                jitter: p.edge_jitter_s,
                amp_jitter: p.amplitude_jitter_rel,
                overshoot_rel: p.overshoot_rel,
                overshoot_decay: p.overshoot_decay_s,
            },
            decay: Decays::EMPTY,
            stuck: Stuck::EMPTY,
        }
    }

    /// New command for the interval starting at `t0`: a change schedules an edge after a
    /// delay of jitter ± jitter, with a freshly drawn amplitude.
    pub fn command(&mut self, t0: f64, cmd: &[f64; 3], rng: &mut Rng) {
        for (ax, &c) in self.axes.iter_mut().zip(cmd) {
            if c != ax.last_cmd {
                let delay = self.p.jitter * (1.0 + rng.gen_range(-1.0..1.0));
                ax.edge_t = t0 + delay;
                ax.next_target = c * (1.0 + self.p.amp_jitter * gauss(rng));
                ax.last_cmd = c;
            }
        }
    }

    /// Mean torque per axis over [t, t + h] [N m], advancing the state.
    #[inline(always)]
    pub fn mean_over(&mut self, t: f64, h: f64) -> [f64; 3] {
        let p = self.p;
        let mut out = [0.0; 3];
        for (o, ax) in out.iter_mut().zip(self.axes.iter_mut()) {
            if ax.at_rest() {
                // What the integrals below give at rest, bit for bit: +0, and the state +0.
                (ax.lag, ax.overshoot) = (0.0, 0.0);
                continue;
            }
            // Idle, the mean depends on the overshoot and the length alone (the lag's
            // part is +0 whatever the signs of its zeros), and the lag stays +0.
            let idle = ax.edge_t.is_nan() && ax.target == 0.0 && ax.lag == 0.0;
            let os = ax.overshoot;
            if idle {
                if let Some(m) = self.stuck.get(os, t + h - t) {
                    (*o, ax.lag) = (m, 0.0);
                    continue;
                }
            }
            if ax.edge_t <= t {
                ax.apply_edge(p.overshoot_rel);
            }
            let mut acc = 0.0;
            let mut t_a = t;
            if ax.edge_t < t + h {
                acc += ax.integrate(ax.edge_t - t_a, &p, &mut self.decay);
                t_a = ax.edge_t;
                ax.apply_edge(p.overshoot_rel);
            }
            acc += ax.integrate(t + h - t_a, &p, &mut self.decay);
            *o = acc / h;
            if idle && ax.overshoot.to_bits() == os.to_bits() {
                self.stuck.put(os, t + h - t, *o);
            }
        }
        out
    }
}

impl ThrusterAxis {
    /// No torque, no lag or overshoot left to decay, no edge pending: an idle axis
    /// (two of three most of a campaign).
    fn at_rest(&self) -> bool {
        self.edge_t.is_nan() && self.target == 0.0 && self.lag == 0.0 && self.overshoot == 0.0
    }

    /// The pending edge happens: the target jumps, the overshoot kicks in.
    fn apply_edge(&mut self, overshoot_rel: f64) {
        self.overshoot += overshoot_rel * (self.next_target - self.target);
        self.target = self.next_target;
        self.edge_t = f64::NAN;
    }

    /// Integral of the torque over the next `len` seconds [N m s].
    #[inline(always)]
    fn integrate(&mut self, len: f64, p: &ParamsCopy, decay: &mut Decays) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let (e_lag, e_os) = decay.of(len, p);
        let (m_lag, y) = relax(self.lag, self.target, p.tau, len, e_lag);
        let (m_os, os) = relax(self.overshoot, 0.0, p.overshoot_decay, len, e_os);
        self.lag = y;
        self.overshoot = os;
        (m_lag + m_os) * len
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng::{stream, Stream};

    #[test]
    fn step_response_settles_to_the_commanded_level_with_decaying_overshoot() {
        let p = Params {
            amplitude_jitter_rel: 0.0,
            edge_jitter_s: 0.0,
            ..Params::default()
        };
        let mut t = Thrusters::new(&p);
        let mut rng = stream(1, Stream::ThrusterEdges);
        t.command(0.0, &[1e-6, 0.0, 0.0], &mut rng);
        let first = t.mean_over(0.0, 0.01)[0];
        assert!(first > 0.0 && first < 1.2e-6);
        let mut last = 0.0;
        for i in 1..2000 {
            last = t.mean_over(i as f64 * 0.01, 0.01)[0];
        }
        assert!((last - 1e-6).abs() < 1e-12, "{last}");
        // Mean over the first second exceeds the level: the overshoot.
        let mut t2 = Thrusters::new(&p);
        t2.command(0.0, &[1e-6, 0.0, 0.0], &mut rng);
        let m: f64 = (0..100)
            .map(|i| t2.mean_over(i as f64 * 0.01, 0.01)[0])
            .sum::<f64>()
            / 100.0;
        assert!(m > 1.0e-6 && m < 1.1e-6, "{m}");
    }

    #[test]
    fn an_axis_at_rest_gives_what_its_integrals_would() {
        // The integrals of an axis at rest, ±0 in its state, are +0 and leave +0.
        let p = Thrusters::new(&Params::default()).p;
        for (lag, os, target) in [(0.0, 0.0, 0.0), (-0.0, -0.0, 0.0), (0.0, -0.0, -0.0)] {
            let mut ax = ThrusterAxis {
                lag,
                overshoot: os,
                target,
                edge_t: f64::NAN,
                ..Default::default()
            };
            assert!(ax.at_rest());
            let mut d = Decays::EMPTY;
            let m = ax.integrate(0.01, &p, &mut d) / 0.01;
            assert_eq!(
                [m, ax.lag, ax.overshoot].map(f64::to_bits),
                [0.0f64; 3].map(f64::to_bits)
            );
        }
        // And a thruster whose axes are idle returns +0 on them.
        let mut t = Thrusters::new(&Params::default());
        let mut rng = stream(2, Stream::ThrusterEdges);
        t.command(0.0, &[1e-6, 0.0, 0.0], &mut rng);
        for k in 0..100 {
            let m = t.mean_over(k as f64 * 0.01, 0.01);
            assert!(m[0] != 0.0 && m[1].to_bits() == 0 && m[2].to_bits() == 0);
        }
    }

    #[test]
    fn remembered_decay_factors_change_no_bit() {
        // Late in a campaign, with jittered edges, and an axis left idle until its
        // overshoot is stuck in the subnormals: the run that remembers must equal one
        // that computes every `exp` and every mean afresh, bit for bit.
        let p = Params::default();
        let mut cached = Thrusters::new(&p);
        let mut fresh = cached;
        let (mut ra, mut rb) = (
            stream(5, Stream::ThrusterEdges),
            stream(5, Stream::ThrusterEdges),
        );
        let (fs, h) = (10.0, 0.01);
        for tick in 90_000u64..95_000 {
            let t0 = tick as f64 / fs;
            let level = if (tick / 250) % 2 == 0 {
                2.5e-6
            } else {
                -2.5e-6
            };
            let cmd = [level, if tick < 90_500 { -level } else { 0.0 }, 0.0];
            cached.command(t0, &cmd, &mut ra);
            fresh.command(t0, &cmd, &mut rb);
            for k in 0..10 {
                let t = t0 + k as f64 * h;
                (fresh.decay, fresh.stuck) = (Decays::EMPTY, Stuck::EMPTY);
                let (a, b) = (cached.mean_over(t, h), fresh.mean_over(t, h));
                assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "tick {tick}");
                for (x, y) in cached.axes.iter().zip(&fresh.axes) {
                    assert_eq!(x.lag.to_bits(), y.lag.to_bits());
                    assert_eq!(x.overshoot.to_bits(), y.overshoot.to_bits());
                }
            }
        }
        let x = cached.axes[1].overshoot;
        assert!(x != 0.0 && x.abs() < f64::MIN_POSITIVE, "{x:e}");
        assert!(cached.stuck.key.iter().any(|k| k.0 == x.to_bits()));
    }
}
