//! The truths as functions of mission time (`[drift]`, docs/mission.md): each IS's β
//! and CoM offset r are the file's values moved by a rate, a random walk and steps;
//! k follows β through the geometry (eq. 2). The walks are drawn from the mission's
//! seed (`Stream::Drift`), not a campaign's, on a grid of [`GRID_DAYS`], and
//! interpolated linearly between its points: every campaign of one mission, and every
//! stage of one campaign, sees one history, continuous in time but at the steps.

use crate::sim::rng::{gauss, stream_n, Stream};
use crate::sim::scenario::{k_from_beta, Drift, Scenario};

/// Seconds per day.
pub const DAY_S: f64 = 86_400.0;
/// Grid of the random walks [days]: one hour.
pub const GRID_DAYS: f64 = 1.0 / 24.0;

/// The truths of both IS at one moment (IS 2's rows unused with one IS).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truths {
    pub beta: [[f64; 3]; 2],
    pub k: [[f64; 3]; 2],
    pub com_offset_m: [[f64; 3]; 2],
}

/// One mission's truth history.
#[derive(Debug, Clone)]
pub struct History {
    beta0: [[f64; 3]; 2],
    geometry: [[f64; 3]; 2],
    com0: [[f64; 3]; 2],
    drift: Drift,
    /// The walks at the grid's points (relative for β, metres for r); empty when the
    /// walk's σ is 0.
    walk_beta: Vec<[[f64; 3]; 2]>,
    walk_com: Vec<[[f64; 3]; 2]>,
}

/// A random walk of `sigma` per √day on the grid, from 0 at day 0 to `until_day`, for
/// both IS and every axis (the draws in that order, point after point): a longer
/// history starts with the same points.
fn walk(seed: u64, sub: u64, sigma: f64, until_day: f64) -> Vec<[[f64; 3]; 2]> {
    if sigma == 0.0 {
        return Vec::new();
    }
    let n = (until_day.max(0.0) / GRID_DAYS).ceil() as usize + 2;
    let mut rng = stream_n(seed, Stream::Drift, sub);
    let step = sigma * GRID_DAYS.sqrt();
    let mut w = [[0.0; 3]; 2];
    let mut out = Vec::with_capacity(n);
    out.push(w);
    for _ in 1..n {
        for v in w.iter_mut().flatten() {
            *v += step * gauss(&mut rng);
        }
        out.push(w);
    }
    out
}

/// The walk at `day`, linear between grid points (0 before day 0, the last point
/// beyond the end).
fn walk_at(w: &[[[f64; 3]; 2]], day: f64) -> [[f64; 3]; 2] {
    if w.is_empty() || day <= 0.0 {
        return [[0.0; 3]; 2];
    }
    let x = day / GRID_DAYS;
    let j = x.floor() as usize;
    if j + 1 >= w.len() {
        return w[w.len() - 1];
    }
    let f = x - j as f64;
    std::array::from_fn(|i| std::array::from_fn(|a| w[j][i][a] + f * (w[j + 1][i][a] - w[j][i][a])))
}

impl History {
    /// The history of `s`'s `[drift]` (None without one) from day 0 to `until_day`,
    /// its walks drawn from the mission's seed (`s.mission_seed`, else `s.seed`).
    pub fn of(s: &Scenario, until_day: f64) -> Option<History> {
        let drift = s.drift.clone()?;
        let seed = s.mission_seed.unwrap_or(s.seed);
        let mut h = History {
            beta0: [[1.0; 3]; 2],
            geometry: [[1.0; 3]; 2],
            com0: [[0.0; 3]; 2],
            walk_beta: walk(seed, 0, drift.beta_rel_per_sqrt_day, until_day),
            walk_com: walk(seed, 1, drift.com_m_per_sqrt_day, until_day),
            drift,
        };
        for (i, is) in s.inertial_sensor.iter().enumerate().take(2) {
            h.beta0[i] = is.beta;
            h.geometry[i] = is.geometry_m;
            h.com0[i] = is.com_offset_m;
        }
        Some(h)
    }

    /// The history a campaign's stages need: to its end.
    pub fn for_campaign(s: &Scenario) -> Option<History> {
        History::of(s, s.epoch_day + s.duration_s / DAY_S)
    }

    /// The truths at mission day `day`.
    pub fn at(&self, day: f64) -> Truths {
        let d = &self.drift;
        let (wb, wc) = (walk_at(&self.walk_beta, day), walk_at(&self.walk_com, day));
        let mut step_b = [[0.0; 3]; 2];
        let mut step_c = [[0.0; 3]; 2];
        for st in d.step.iter().filter(|st| day >= st.day) {
            for i in 0..2 {
                for a in 0..3 {
                    step_b[i][a] += st.beta_rel[i][a];
                    step_c[i][a] += st.com_m[i][a];
                }
            }
        }
        let beta: [[f64; 3]; 2] = std::array::from_fn(|i| {
            std::array::from_fn(|a| {
                self.beta0[i][a] * (1.0 + (d.beta_rel_per_day * day + wb[i][a] + step_b[i][a]))
            })
        });
        let com_offset_m = std::array::from_fn(|i| {
            std::array::from_fn(|a| {
                self.com0[i][a] + (d.com_m_per_day[i][a] * day + wc[i][a] + step_c[i][a])
            })
        });
        Truths {
            k: std::array::from_fn(|i| k_from_beta(&self.geometry[i], &beta[i])),
            beta,
            com_offset_m,
        }
    }
}

impl Scenario {
    /// The truths a campaign's result is judged against: without `[drift]` the file's;
    /// with it, those at the campaign's middle (`epoch_day` + half its duration; the
    /// estimate of constant parameters fits the mean of a linear drift).
    pub fn truths(&self) -> Truths {
        if let Some(h) = History::for_campaign(self) {
            return h.at(self.epoch_day + 0.5 * self.duration_s / DAY_S);
        }
        let mut t = Truths {
            beta: [[1.0; 3]; 2],
            k: [[1.0; 3]; 2],
            com_offset_m: [[0.0; 3]; 2],
        };
        for (i, is) in self.inertial_sensor.iter().enumerate().take(2) {
            t.beta[i] = is.beta;
            t.k[i] = is.k();
            t.com_offset_m[i] = is.com_offset_m;
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scenario::DriftStep;

    fn scenario(d: Drift) -> Scenario {
        Scenario {
            drift: Some(d),
            ..Scenario::default()
        }
    }

    #[test]
    fn rates_move_the_truths_linearly_and_k_follows_beta() {
        let mut d = Drift::none();
        d.beta_rel_per_day = 2e-6;
        d.com_m_per_day = [[1e-6, -2e-6, 3e-6], [0.0, 0.0, -1e-6]];
        let s = scenario(d);
        let h = History::of(&s, 100.0).unwrap();
        let t = h.at(50.0);
        let is = &s.inertial_sensor;
        for a in 0..3 {
            let want = is[0].beta[a] * (1.0 + 1e-4);
            assert!((t.beta[0][a] / want - 1.0).abs() < 1e-14);
        }
        assert!((t.com_offset_m[0][1] - (is[0].com_offset_m[1] - 1e-4)).abs() < 1e-15);
        assert!((t.com_offset_m[1][2] - (is[1].com_offset_m[2] - 5e-5)).abs() < 1e-15);
        assert_eq!(t.k[1], k_from_beta(&is[1].geometry_m, &t.beta[1]));
        // Day 0: the file's truths, bit for bit.
        let t0 = h.at(0.0);
        assert_eq!(t0.beta[0], is[0].beta);
        assert_eq!(t0.com_offset_m[1], is[1].com_offset_m);
    }

    #[test]
    fn a_step_counts_from_its_day_on() {
        let mut d = Drift::none();
        d.step.push(DriftStep {
            day: 40.0,
            com_m: [[0.0, 0.0, 4e-5], [1e-5, 0.0, 0.0]],
            beta_rel: [[0.0, 1e-3, 0.0], [0.0; 3]],
        });
        let s = scenario(d);
        let h = History::of(&s, 100.0).unwrap();
        let (before, after) = (h.at(40.0 - 1e-9), h.at(40.0));
        assert!((after.com_offset_m[0][2] - before.com_offset_m[0][2] - 4e-5).abs() < 1e-15);
        assert!((after.com_offset_m[1][0] - before.com_offset_m[1][0] - 1e-5).abs() < 1e-15);
        assert!((after.beta[0][1] / before.beta[0][1] - 1.001).abs() < 1e-12);
        assert_eq!(after.beta[0][0], before.beta[0][0]);
    }

    #[test]
    fn the_walks_variance_grows_as_t_and_the_history_is_continuous_and_seeded() {
        let mut d = Drift::none();
        d.beta_rel_per_sqrt_day = 1e-5;
        d.com_m_per_sqrt_day = 2e-6;
        let n = 300;
        let (mut vb, mut vc) = ([0.0; 2], [0.0; 2]);
        for seed in 0..n {
            let s = Scenario {
                seed,
                ..scenario(d.clone())
            };
            let h = History::of(&s, 100.0).unwrap();
            for (k, day) in [25.0, 100.0].into_iter().enumerate() {
                let t = h.at(day);
                for i in 0..2 {
                    for a in 0..3 {
                        let b0 = s.inertial_sensor[i].beta[a];
                        vb[k] += (t.beta[i][a] / b0 - 1.0).powi(2);
                        vc[k] +=
                            (t.com_offset_m[i][a] - s.inertial_sensor[i].com_offset_m[a]).powi(2);
                    }
                }
            }
        }
        let m = (6 * n) as f64;
        for (k, day) in [25.0, 100.0].into_iter().enumerate() {
            let rb = vb[k] / m / (1e-10 * day);
            let rc = vc[k] / m / (4e-12 * day);
            // 1800 draws: the variance's estimate is within ±10 % at 3σ.
            assert!((0.9..1.1).contains(&rb), "β at day {day}: {rb}");
            assert!((0.9..1.1).contains(&rc), "r at day {day}: {rc}");
        }
        // Continuous: a second apart, the walk moves by ~σ √(1 s), linearly.
        let s = scenario(d.clone());
        let h = History::of(&s, 10.0).unwrap();
        let (a, b) = (h.at(3.3), h.at(3.3 + 1.0 / DAY_S));
        assert!((a.com_offset_m[0][0] - b.com_offset_m[0][0]).abs() < 1e-8);
        // Seeded by the mission: the same seed, the same history, however far drawn;
        // another seed, another one; the campaign's seed does not enter.
        let longer = History::of(&s, 200.0).unwrap();
        assert_eq!(h.at(7.7), longer.at(7.7));
        let other = History::of(
            &Scenario {
                seed: 9,
                ..s.clone()
            },
            10.0,
        )
        .unwrap();
        assert_ne!(h.at(7.7), other.at(7.7));
        let campaign = Scenario {
            seed: 9,
            mission_seed: Some(s.seed),
            ..s.clone()
        };
        assert_eq!(History::of(&campaign, 10.0).unwrap().at(7.7), h.at(7.7));
    }

    /// Every TM acceleration and IS voltage of `ticks` ticks of `s` at seed 3.
    fn stream(s: &Scenario, ticks: u64) -> Vec<u64> {
        use crate::sim::model::plant::{Plant, PlantNoise};
        let mut cmd = crate::sim::commander::Commander::new(s);
        let mut plant = Plant::new(s, 3, PlantNoise::ALL);
        let mut fee = crate::sim::fee::FrontEnd::new(s, 3, true);
        let mut out = Vec::new();
        for tick in 0..ticks {
            let t = plant.step(tick, &cmd.step(tick).torque_cmd_b);
            let m = fee.step(&t);
            out.extend(t.a_tm_b.iter().flatten().map(|x| x.to_bits()));
            for is in &m.is {
                out.extend(is.volts.iter().flatten().map(|x| x.to_bits()));
            }
        }
        out
    }

    #[test]
    fn a_drift_of_zero_flies_the_campaign_bit_for_bit_and_a_drift_moves_it() {
        let s = Scenario::default();
        let zero = Scenario {
            drift: Some(Drift::none()),
            epoch_day: 123.4,
            ..s.clone()
        };
        let base = stream(&s, 3000);
        assert_eq!(base, stream(&zero, 3000));
        // A rate moves r within the campaign: the TM accelerations change.
        let mut d = Drift::none();
        d.com_m_per_day[0] = [1e-3, 0.0, 0.0];
        assert_ne!(
            base,
            stream(
                &Scenario {
                    drift: Some(d),
                    ..s
                },
                3000
            )
        );
    }

    #[test]
    fn without_drift_the_truths_are_the_files() {
        let s = Scenario::default();
        assert!(History::for_campaign(&s).is_none());
        let t = s.truths();
        assert_eq!(t.beta[0], s.inertial_sensor[0].beta);
        assert_eq!(t.k[1], s.inertial_sensor[1].k());
    }
}
