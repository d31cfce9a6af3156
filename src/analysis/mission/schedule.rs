//! The schedule `campaigns = "auto"` makes: each next campaign on the last day on
//! which every value in use still meets its requirement with the stated confidence,
//! its error taken as normal with the trend's predicted σ (zero mean: the value in use
//! is the prediction).

use crate::sim::trend::Trend;

/// Resolution of the search for the last day [days].
pub const STEP_DAYS: f64 = 1.0 / 24.0;

/// z with P(|e| < z σ) = `confidence` for a normal e (the two-sided quantile), by
/// bisection on erf: 2.968 for 0.997, 1.960 for 0.95.
pub fn two_sided_quantile(confidence: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if libm::erf(mid / std::f64::consts::SQRT_2) < confidence {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The first time from `from_day` on (to `until_day`) at which some trend's predicted
/// σ exceeds its requirement over `z`; `until_day` when none does. `trends` pairs each
/// trend with its requirement (the error allowed, in the value's unit).
pub fn requirement_lapses(trends: &[(Trend, f64)], z: f64, from_day: f64, until_day: f64) -> f64 {
    let mut day = from_day;
    while day < until_day {
        if trends.iter().any(|(t, req)| z * t.predict(day).1 > *req) {
            return day;
        }
        day += STEP_DAYS;
    }
    until_day
}

/// The next campaign's day: the whole day on which one that starts then, lasting
/// `campaign_days`, ends before the requirement lapses; never before `earliest`.
pub fn next_campaign(lapse_day: f64, campaign_days: f64, earliest: f64) -> f64 {
    (lapse_day - campaign_days).floor().max(earliest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::trend::TrendModel;

    #[test]
    fn quantiles_are_the_normal_ones() {
        assert!((two_sided_quantile(0.95) - 1.959964).abs() < 1e-5);
        assert!((two_sided_quantile(0.997) - 2.967738).abs() < 1e-5);
    }

    #[test]
    fn the_requirement_lapses_when_the_rate_uncertainty_has_grown_to_it() {
        // σ(t) = 0.01 t: with requirement 1 and z = 2, it lapses at t = 50.
        let m = TrendModel {
            walk_per_day: 0.0,
            rate_sigma: 0.01,
        };
        let t = Trend::start(0.0, 5.0, 0.0, m);
        let lapse = requirement_lapses(&[(t, 1.0)], 2.0, 0.0, 365.0);
        assert!((lapse - 50.0).abs() <= STEP_DAYS, "{lapse}");
        assert_eq!(next_campaign(lapse, 0.2, 1.0), 49.0);
        assert_eq!(requirement_lapses(&[(t, 1.0)], 2.0, 0.0, 30.0), 30.0);
    }
}
