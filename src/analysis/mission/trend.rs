//! The trend of one parameter (one IS, group and axis) across campaigns: a Kalman
//! filter of two states, its value and its rate per day, whose measurements are the
//! campaigns' applied estimates with their σ. The value random-walks with the drift
//! model's intensity; the rate is constant, its prior zero-mean with the drift model's
//! stated rate magnitude as σ. Its prediction value + rate (t − epoch) is the value in
//! use onboard, and the predicted σ that of (in use − truth). A campaign whose estimate
//! lies beyond [`MISFIT_SIGMA`] of the prediction is a model misfit: the trend restarts
//! from it.

/// Innovations beyond this many σ are model misfits.
pub const MISFIT_SIGMA: f64 = 5.0;

/// What the drift model says of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrendModel {
    /// Random-walk intensity of the value [unit² per day].
    pub walk_per_day: f64,
    /// Prior σ of the rate [unit per day] (its mean is 0).
    pub rate_sigma: f64,
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
