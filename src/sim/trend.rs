//! The trend of one parameter (one IS, group and axis) across campaigns: a Kalman
//! filter of two states, its value and its rate per day, whose measurements are the
//! campaigns' applied estimates with their σ. The value random-walks with the drift
//! model's intensity; the rate is constant, its prior zero-mean with the drift model's
//! stated rate magnitude as σ. Its prediction value + rate (t − epoch) is the value in
//! use onboard, and the predicted σ that of (in use − truth). A campaign whose estimate
//! lies beyond [`MISFIT_SIGMA`] of the prediction is a model misfit: the trend restarts
//! from it.
//!
//! The values in use onboard are these trends, whoever flies the campaigns: the
//! timeline (`analysis::mission::run`) and the ground's onboard calibration table
//! (`ground::table`, function 3) take a campaign's result in with [`take_in`] and start
//! the next campaign from [`predicted`], the same code for the same bits.

use crate::sim::drift::DAY_S;
use crate::sim::msg::TableValues;
use crate::sim::scenario::Scenario;

/// Innovations beyond this many σ are model misfits.
pub const MISFIT_SIGMA: f64 = 5.0;

/// Per IS, group (β, k, r) and axis.
pub type Grid<T> = [[[T; 3]; 3]; 2];

/// Every parameter's trend (`None`: not started, or an IS the scenario lacks).
pub type Trends = Grid<Option<Trend>>;

/// A campaign's result beyond [`MISFIT_SIGMA`] of its prediction: the trend of (IS
/// `is`, group `group`, axis `axis`, each from 0) restarted from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Misfit {
    pub is: usize,
    pub group: usize,
    pub axis: usize,
    pub innovation_sigma: f64,
}

/// What the drift model says of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrendModel {
    /// Random-walk intensity of the value [unit² per day].
    pub walk_per_day: f64,
    /// Prior σ of the rate [unit per day] (its mean is 0).
    pub rate_sigma: f64,
}

impl TrendModel {
    /// The drift model of `s` for group `g` (β, k, r) of a parameter of about `scale`
    /// (β, k: the relative figures times it; r: the rates' RMS over every IS and axis:
    /// the model's magnitude, not each axis's value). Without `[drift]`: constant
    /// parameters (no walk, a rate of 0 for sure).
    pub fn of(s: &Scenario, g: usize, scale: f64) -> TrendModel {
        let Some(d) = &s.drift else {
            return TrendModel {
                walk_per_day: 0.0,
                rate_sigma: 0.0,
            };
        };
        if g == 2 {
            let n_is = s.inertial_sensor.len().min(d.com_m_per_day.len());
            let ms: f64 = d.com_m_per_day[..n_is]
                .iter()
                .flatten()
                .map(|v| v * v)
                .sum::<f64>()
                / (3 * n_is).max(1) as f64;
            TrendModel {
                walk_per_day: d.com_m_per_sqrt_day.powi(2),
                rate_sigma: ms.sqrt(),
            }
        } else {
            TrendModel {
                walk_per_day: (d.beta_rel_per_sqrt_day * scale).powi(2),
                rate_sigma: (d.beta_rel_per_day * scale).abs(),
            }
        }
    }
}

/// The day a campaign of `duration_s` that started on `day` measures: its middle (the
/// estimate of constant parameters fits the mean of a linear drift).
pub fn campaign_middle(day: f64, duration_s: f64) -> f64 {
    day + 0.5 * (duration_s / DAY_S)
}

/// Takes an applied campaign's result `result` (function 3's `report::table_values`)
/// of the campaign measuring day `mid` ([`campaign_middle`]) into the trends of the
/// first `s.inertial_sensor.len()` IS: each parameter's trend starts from it
/// (drift model `TrendModel::of(s, …)`), or is updated with it; the misfits, whose
/// trends restarted.
pub fn take_in(trends: &mut Trends, s: &Scenario, result: &TableValues, mid: f64) -> Vec<Misfit> {
    let mut misfits = Vec::new();
    let n_is = s.inertial_sensor.len().min(2);
    for (i, tg) in trends.iter_mut().enumerate().take(n_is) {
        for (g, ta) in tg.iter_mut().enumerate() {
            let (v, sig) = [
                (&result.beta, &result.beta_sigma),
                (&result.k, &result.k_sigma),
                (&result.r, &result.r_sigma),
            ][g];
            for (a, t) in ta.iter_mut().enumerate() {
                let (e, sigma) = (v[i][a], sig[i][a]);
                match t {
                    None => *t = Some(Trend::start(mid, e, sigma, TrendModel::of(s, g, e))),
                    Some(t) => {
                        if let Update::Misfit(nu) = t.update(mid, e, sigma) {
                            misfits.push(Misfit {
                                is: i,
                                group: g,
                                axis: a,
                                innovation_sigma: nu,
                            });
                        }
                    }
                }
            }
        }
    }
    misfits
}

/// The table the trends predict for `day`: each parameter's value and σ at it
/// ([`Trend::predict`]); a parameter without a trend is 0 (as `table_values` leaves an
/// IS the report lacks).
pub fn predicted(trends: &Trends, day: f64) -> TableValues {
    table_by(trends, |t| t.predict(day))
}

/// The table at each trend's epoch (its last measurement): its value and σ there.
pub fn at_epochs(trends: &Trends) -> TableValues {
    table_by(trends, |t| t.predict(t.epoch_day))
}

fn table_by(trends: &Trends, f: impl Fn(&Trend) -> (f64, f64)) -> TableValues {
    let mut tv = TableValues::default();
    for (i, tg) in trends.iter().enumerate() {
        for (g, ta) in tg.iter().enumerate() {
            for (a, t) in ta.iter().enumerate() {
                if let Some(t) = t {
                    let (v, sigma) = f(t);
                    let (vs, ss) = match g {
                        0 => (&mut tv.beta, &mut tv.beta_sigma),
                        1 => (&mut tv.k, &mut tv.k_sigma),
                        _ => (&mut tv.r, &mut tv.r_sigma),
                    };
                    (vs[i][a], ss[i][a]) = (v, sigma);
                }
            }
        }
    }
    tv
}

/// The filter's state after its last measurement, at `epoch_day`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trend {
    pub epoch_day: f64,
    pub value: f64,
    pub rate: f64,
    /// Covariance of (value, rate).
    pub p: [[f64; 2]; 2],
    pub model: TrendModel,
}

/// A measurement against the prediction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Update {
    /// Taken in; the innovation in σ of its prediction.
    Fit(f64),
    /// Beyond [`MISFIT_SIGMA`]: the trend restarted from it.
    Misfit(f64),
}

impl Trend {
    /// A trend from one campaign's estimate `z` ± `sigma` at `day`: no prior on the
    /// value beyond it (the campaign used its own), the rate's prior the model's.
    pub fn start(day: f64, z: f64, sigma: f64, model: TrendModel) -> Trend {
        Trend {
            epoch_day: day,
            value: z,
            rate: 0.0,
            p: [
                [sigma * sigma, 0.0],
                [0.0, model.rate_sigma * model.rate_sigma],
            ],
            model,
        }
    }

    /// State and covariance propagated to `day` (not before the epoch).
    fn propagated(&self, day: f64) -> ([f64; 2], [[f64; 2]; 2]) {
        let d = (day - self.epoch_day).max(0.0);
        let p = &self.p;
        let p00 = p[0][0] + 2.0 * d * p[0][1] + d * d * p[1][1] + self.model.walk_per_day * d;
        let p01 = p[0][1] + d * p[1][1];
        (
            [self.value + self.rate * d, self.rate],
            [[p00, p01], [p01, p[1][1]]],
        )
    }

    /// The value in use at `day` and the σ of its error (in use − truth).
    pub fn predict(&self, day: f64) -> (f64, f64) {
        let (x, p) = self.propagated(day);
        (x[0], p[0][0].max(0.0).sqrt())
    }

    /// Take the estimate `z` ± `sigma` of `day` (Joseph form), or restart from it when
    /// it misfits.
    pub fn update(&mut self, day: f64, z: f64, sigma: f64) -> Update {
        let (x, p) = self.propagated(day);
        let r = sigma * sigma;
        let s = p[0][0] + r;
        let nu = z - x[0];
        let innovation = nu / s.sqrt();
        if innovation.abs() > MISFIT_SIGMA || !innovation.is_finite() {
            *self = Trend::start(day, z, sigma, self.model);
            return Update::Misfit(innovation);
        }
        let k = [p[0][0] / s, p[1][0] / s];
        // (I − K H) P (I − K H)ᵀ + K R Kᵀ with H = [1, 0].
        let a = [[1.0 - k[0], 0.0], [-k[1], 1.0]];
        let mut ap = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                ap[i][j] = a[i][0] * p[0][j] + a[i][1] * p[1][j];
            }
        }
        let mut out = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                out[i][j] = ap[i][0] * a[j][0] + ap[i][1] * a[j][1] + k[i] * r * k[j];
            }
        }
        *self = Trend {
            epoch_day: day,
            value: x[0] + k[0] * nu,
            rate: x[1] + k[1] * nu,
            p: out,
            model: self.model,
        };
        Update::Fit(innovation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng as _;

    #[test]
    fn a_line_measured_twice_is_predicted_with_its_rate() {
        let m = TrendModel {
            walk_per_day: 0.0,
            rate_sigma: 1.0,
        };
        let mut t = Trend::start(0.0, 10.0, 1e-6, m);
        assert_eq!(t.predict(5.0), (10.0, (1e-12f64 + 25.0).sqrt()));
        assert!(matches!(t.update(10.0, 12.0, 1e-6), Update::Fit(_)));
        let (v, s) = t.predict(30.0);
        assert!((v - 16.0).abs() < 1e-9 && s < 1e-5, "{v} ± {s}");
        assert!((t.rate - 0.2).abs() < 1e-9);
    }

    #[test]
    fn a_jump_beyond_five_sigma_restarts_the_trend() {
        let m = TrendModel {
            walk_per_day: 1e-4,
            rate_sigma: 1e-3,
        };
        let mut t = Trend::start(0.0, 1.0, 0.01, m);
        let Update::Misfit(n) = t.update(20.0, 1.5, 0.01) else {
            panic!("not a misfit");
        };
        assert!(n > 5.0);
        assert_eq!(t, Trend::start(20.0, 1.5, 0.01, m));
    }

    /// Truths drawn as the model says (a rate from its prior, a walk of its intensity),
    /// campaigns every 30 days with honest σ: the predictions' (err/σ)² averages 1.
    #[test]
    fn the_predicted_sigma_is_honest_when_the_truth_follows_the_model() {
        let m = TrendModel {
            walk_per_day: 4e-4,
            rate_sigma: 0.05,
        };
        let mut rng = crate::sim::rng::stream(11, crate::sim::rng::Stream::Drift);
        let g = |rng: &mut crate::sim::rng::Rng| crate::sim::rng::gauss(rng);
        let (mut sum, mut n) = (0.0, 0);
        for _ in 0..400 {
            let rate = m.rate_sigma * g(&mut rng);
            let mut truth = 3.0;
            let sigma = rng.gen_range(0.01..0.1);
            let mut trend: Option<Trend> = None;
            for day in 0..240 {
                if day > 0 {
                    truth += rate + m.walk_per_day.sqrt() * g(&mut rng);
                }
                if day % 30 == 0 {
                    let z = truth + sigma * g(&mut rng);
                    match &mut trend {
                        None => trend = Some(Trend::start(day as f64, z, sigma, m)),
                        Some(t) => {
                            t.update(day as f64, z, sigma);
                        }
                    }
                }
                let (v, s) = trend.as_ref().unwrap().predict(day as f64);
                sum += ((v - truth) / s).powi(2);
                n += 1;
            }
        }
        let z2 = sum / n as f64;
        assert!((0.9..1.1).contains(&z2), "mean (err/σ)² {z2}");
    }
}
