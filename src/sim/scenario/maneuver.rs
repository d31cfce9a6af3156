//! The calibration maneuver as a timeline — which axis is rocked when, with which
//! square wave — and the envelope it drives: the peak test-mass acceleration
//! |A(ω, ω̇) r|, attitude excursion, body rate and torque that the constraints bound.
//!
//! Every stretch of rocking is a whole number of periods of a square wave; with the
//! cosine phase (+A for T/4, −A for T/2, +A for T/4) rate and angle come back to zero at
//! the end of every period, so stretches may be separated by quiet time (star-tracker
//! outages) without leaving the spacecraft turning.

use crate::sim::scenario::{Scenario, Schedule};
use nalgebra::{Matrix3, Vector3};

/// One stretch of whole square-wave periods on one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stretch {
    /// First tick.
    pub start_tick: u64,
    /// Ticks in the stretch: the periods, rounded to whole ticks.
    pub ticks: u64,
    pub periods: u64,
}

/// Where the square wave of each axis runs, in ticks of the sample clock.
#[derive(Debug, Clone, PartialEq)]
pub struct Timeline {
    /// Per axis, its stretches in time order.
    pub stretches: [Vec<Stretch>; 3],
    /// Per axis: ticks per period (not necessarily whole).
    pub ticks_per_period: [f64; 3],
    /// Per axis: torque amplitude [N m].
    pub amplitude_nm: [f64; 3],
    /// Phase at the start of every stretch [periods].
    pub start_phase: f64,
    /// Sample rate [Hz].
    pub fs: f64,
}

/// Why a maneuver does not fit its window.
#[derive(Debug, Clone, PartialEq)]
pub struct NoFit {
    /// The axis that got no whole period.
    pub axis: usize,
    /// Its period [s].
    pub period_s: f64,
}

impl Timeline {
    /// Lay the scenario's maneuver out over its window.
    pub fn new(s: &Scenario) -> Result<Self, NoFit> {
        let mv = &s.maneuver;
        let fs = s.sample_rate_hz;
        let end = s.n_samples();
        let start = (mv.start_s * fs).ceil().max(0.0) as u64;
        let blocked = if mv.pause_in_outages {
            outage_ticks(s)
        } else {
            Vec::new()
        };
        let usable_s = s.duration_s - mv.start_s - blocked_seconds(&blocked, start, end, fs);
        let freq = axis_frequencies(s);
        let tpp = freq.map(|f| fs / f);
        let mut stretches: [Vec<Stretch>; 3] = Default::default();
        match mv.schedule {
            Schedule::Sequential => {
                let f = mv.frequency_hz;
                // As many periods per axis as fit, one axis after the other (`whole`:
                // 6×10⁻⁴ Hz over 10⁴ s is 2 periods an axis, not 1.999… → 1).
                let mut n = whole(usable_s * f / 3.0);
                loop {
                    if n == 0 {
                        let axis = s.axis_order()[0];
                        return Err(NoFit {
                            axis,
                            period_s: 1.0 / f,
                        });
                    }
                    let mut cursor = start;
                    let mut ok = true;
                    let mut out: [Vec<Stretch>; 3] = Default::default();
                    for axis in s.axis_order() {
                        match place(cursor, n, tpp[axis], end, &blocked) {
                            Some((st, after)) => {
                                out[axis] = st;
                                cursor = after;
                            }
                            None => {
                                ok = false;
                                break;
                            }
                        }
                    }
                    if ok {
                        stretches = out;
                        break;
                    }
                    n -= 1;
                }
            }
            Schedule::Simultaneous => {
                for axis in 0..3 {
                    let mut n = whole(usable_s * freq[axis]);
                    loop {
                        if n == 0 {
                            return Err(NoFit {
                                axis,
                                period_s: 1.0 / freq[axis],
                            });
                        }
                        if let Some((st, _)) = place(start, n, tpp[axis], end, &blocked) {
                            stretches[axis] = st;
                            break;
                        }
                        n -= 1;
                    }
                }
            }
        }
        Ok(Timeline {
            stretches,
            ticks_per_period: tpp,
            amplitude_nm: mv.torque_amplitude_nm,
            start_phase: mv.start_phase,
            fs,
        })
    }

    /// No rocking at all (a maneuver that does not fit its window).
    pub fn quiet(fs: f64) -> Self {
        Timeline {
            stretches: Default::default(),
            ticks_per_period: [1.0; 3],
            amplitude_nm: [0.0; 3],
            start_phase: 0.0,
            fs,
        }
    }

    /// Commanded torque [N m] on `axis` for the interval starting at `tick`.
    pub fn torque_axis(&self, axis: usize, tick: u64) -> f64 {
        self.level(axis, tick as f64)
    }

    /// The square wave of `axis` at `at` ticks (fractional in continuous time): the
    /// stretch it falls in, its phase there, ±amplitude; 0 outside every stretch.
    fn level(&self, axis: usize, at: f64) -> f64 {
        let st = &self.stretches[axis];
        // The last stretch starting at or before `at`.
        let i = st.partition_point(|x| x.start_tick as f64 <= at);
        let Some(x) = i.checked_sub(1).map(|i| st[i]) else {
            return 0.0;
        };
        let local = at - x.start_tick as f64;
        if local >= x.ticks as f64 {
            return 0.0;
        }
        let phase = (self.start_phase + local / self.ticks_per_period[axis]).fract();
        if (0.25..0.75).contains(&phase) {
            -self.amplitude_nm[axis]
        } else {
            self.amplitude_nm[axis]
        }
    }

    /// Commanded body torque [N m] for the interval starting at `tick`.
    pub fn torque(&self, tick: u64) -> [f64; 3] {
        core::array::from_fn(|a| self.torque_axis(a, tick))
    }

    /// Whole periods per axis.
    pub fn periods(&self) -> [u64; 3] {
        core::array::from_fn(|a| self.stretches[a].iter().map(|x| x.periods).sum())
    }

    /// First and last tick of rocking (any axis).
    pub fn span_ticks(&self) -> (u64, u64) {
        let first = self
            .stretches
            .iter()
            .filter_map(|s| s.first().map(|x| x.start_tick))
            .min()
            .unwrap_or(0);
        let last = self
            .stretches
            .iter()
            .filter_map(|s| s.last().map(|x| x.start_tick + x.ticks))
            .max()
            .unwrap_or(0);
        (first, last)
    }

    /// Breakpoints [s] where any axis's torque may change: stretch ends and the
    /// square wave's edges.
    fn breakpoints(&self) -> Vec<f64> {
        let mut t = Vec::new();
        for a in 0..3 {
            let period = self.ticks_per_period[a] / self.fs;
            for x in &self.stretches[a] {
                let t0 = x.start_tick as f64 / self.fs;
                let t1 = (x.start_tick + x.ticks) as f64 / self.fs;
                t.push(t0);
                t.push(t1);
                // Edges where the phase crosses ¼ and ¾.
                for k in 0..=x.periods {
                    for edge in [0.25, 0.75] {
                        let te = t0 + (k as f64 + edge - self.start_phase) * period;
                        if te > t0 && te < t1 {
                            t.push(te);
                        }
                    }
                }
            }
        }
        t.sort_by(f64::total_cmp);
        t.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        t
    }

    /// Torque [N m] in continuous time (the square wave the ticks sample).
    fn torque_at_time(&self, t: f64) -> Vector3<f64> {
        Vector3::from_fn(|a, _| self.level(a, t * self.fs))
    }

    /// The rigid-body response to the commanded torques (linear in the amplitudes:
    /// ω̇ = I⁻¹ τ, ω and the small-angle attitude its integrals; the attitude hold and
    /// the gyroscopic term are neglected, both tiny at these rates), sampled at every
    /// breakpoint and three points between.
    pub fn envelope(&self, inertia: &Matrix3<f64>) -> Envelope {
        let inv = inertia.try_inverse().unwrap_or_else(Matrix3::zeros);
        let bp = self.breakpoints();
        let mut samples = Vec::with_capacity(4 * bp.len() + 1);
        let mut w = Vector3::zeros();
        let mut th = Vector3::zeros();
        let mut peak_att: f64 = 0.0;
        let mut peak_rate: f64 = 0.0;
        let mut peak_torque: f64 = 0.0;
        for pair in bp.windows(2) {
            let (t0, t1) = (pair[0], pair[1]);
            let tau = self.torque_at_time(0.5 * (t0 + t1));
            peak_torque = peak_torque.max(tau.amax());
            let wdot = inv * tau;
            let h = t1 - t0;
            for k in 0..4 {
                let dt = h * k as f64 / 3.0;
                let wk = w + wdot * dt;
                let thk = th + w * dt + wdot * (0.5 * dt * dt);
                samples.push((wdot, wk));
                peak_att = peak_att.max(thk.norm());
                peak_rate = peak_rate.max(wk.norm());
            }
            // The angle's turning point inside the piece, per axis.
            for a in 0..3 {
                if wdot[a] != 0.0 {
                    let dt = -w[a] / wdot[a];
                    if dt > 0.0 && dt < h {
                        let thk = th + w * dt + wdot * (0.5 * dt * dt);
                        peak_att = peak_att.max(thk.norm());
                    }
                }
            }
            th += w * h + wdot * (0.5 * h * h);
            w += wdot * h;
        }
        Envelope {
            samples,
            peak_attitude_rad: peak_att,
            peak_rate_rad_s: peak_rate,
            peak_torque_nm: peak_torque,
        }
    }
}

/// The maneuver's rigid-body response at the commanded amplitudes (`scale` 1): a
/// larger or smaller maneuver of the same shape scales ω̇ and ω linearly.
#[derive(Debug, Clone)]
pub struct Envelope {
    /// (ω̇ [rad/s²], ω [rad/s]) at every sample point.
    samples: Vec<(Vector3<f64>, Vector3<f64>)>,
    pub peak_attitude_rad: f64,
    pub peak_rate_rad_s: f64,
    pub peak_torque_nm: f64,
}

impl Envelope {
    /// Worst |ω̇ × r + ω × (ω × r)| [m/s²] over `points` with every torque scaled by
    /// `scale`: (index of the worst point, value).
    pub fn peak_acceleration(&self, points: &[Vector3<f64>], scale: f64) -> (usize, f64) {
        let mut worst = (0, 0.0);
        for (wdot, w) in &self.samples {
            let (wdot, w) = (wdot * scale, w * scale);
            for (i, r) in points.iter().enumerate() {
                let a = (wdot.cross(r) + w.cross(&w.cross(r))).norm();
                if a > worst.1 {
                    worst = (i, a);
                }
            }
        }
        worst
    }

    /// The largest scale of the torques keeping |A r| ≤ `limit` at every point
    /// (|A r| grows monotonically with the scale: bisection), at most `cap`.
    pub fn largest_scale(&self, points: &[Vector3<f64>], limit: f64, cap: f64) -> f64 {
        let fits = |s: f64| {
            self.samples.iter().all(|(wdot, w)| {
                let (wdot, w) = (wdot * s, w * s);
                points
                    .iter()
                    .all(|r| (wdot.cross(r) + w.cross(&w.cross(r))).norm() <= limit)
            })
        };
        if fits(cap) {
            return cap;
        }
        let (mut lo, mut hi) = (0.0, cap);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if fits(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }
}

/// `x` rounded down to 4 significant digits (a limit printed or written as TOML that
/// reads back within the limit).
pub fn round_down_4(x: f64) -> f64 {
    if !(x > 0.0 && x.is_finite()) {
        return x;
    }
    let e = x.log10().floor() as i32 - 3;
    let scale = 10f64.powi(-e);
    (x * scale * (1.0 - 1e-12)).floor() / scale
}

/// Whole periods in `x` periods, forgiving the last bits of rounding: a window and a
/// frequency written as round numbers (10⁴ s at 6×10⁻⁴ Hz) multiply to 5.999…, which
/// floored lost a period an axis. Whether the periods fit in whole ticks is `place`'s
/// to say.
fn whole(x: f64) -> u64 {
    (x + 1e-9).floor().max(0.0) as u64
}

/// Each axis's square-wave frequency [Hz].
pub fn axis_frequencies(s: &Scenario) -> [f64; 3] {
    let mv = &s.maneuver;
    match mv.schedule {
        Schedule::Sequential => [mv.frequency_hz; 3],
        Schedule::Simultaneous => mv.frequency_ratio.map(|r| mv.frequency_hz * r),
    }
}

/// Peak torque over the commanded amplitude: 3σ amplitude jitter and the overshoot
/// of an edge (relative to the step, twice the amplitude).
pub fn torque_boost(s: &Scenario) -> f64 {
    let th = &s.thruster;
    1.0 + 3.0 * th.amplitude_jitter_rel + 2.0 * th.overshoot_rel
}

/// Seconds of the window the maneuver can rock in when it pauses in the star
/// tracker's outages (from `start_s` = 0).
pub fn rocking_seconds(s: &Scenario) -> f64 {
    s.duration_s - blocked_seconds(&outage_ticks(s), 0, s.n_samples(), s.sample_rate_hz)
}

/// Star-tracker outages as tick intervals [start, end), merged and sorted.
fn outage_ticks(s: &Scenario) -> Vec<(u64, u64)> {
    let fs = s.sample_rate_hz;
    let mut v: Vec<(u64, u64)> = s
        .star_tracker
        .outages_s
        .iter()
        .map(|o| {
            (
                (o[0] * fs).floor().max(0.0) as u64,
                (o[1] * fs).ceil().max(0.0) as u64 + 1,
            )
        })
        .collect();
    v.sort_unstable();
    let mut out: Vec<(u64, u64)> = Vec::with_capacity(v.len());
    for (a, b) in v {
        match out.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}

/// Seconds of `blocked` inside [start, end) ticks.
fn blocked_seconds(blocked: &[(u64, u64)], start: u64, end: u64, fs: f64) -> f64 {
    blocked
        .iter()
        .map(|&(a, b)| b.min(end).saturating_sub(a.max(start)) as f64 / fs)
        .sum()
}

/// Place `n` whole periods of `tpp` ticks from `cursor`, before `end`, around the
/// `blocked` intervals: the stretches and the tick after the last, or `None`.
fn place(
    mut cursor: u64,
    n: u64,
    tpp: f64,
    end: u64,
    blocked: &[(u64, u64)],
) -> Option<(Vec<Stretch>, u64)> {
    let mut out = Vec::new();
    let mut left = n;
    let ticks_of = |k: u64| (k as f64 * tpp).round() as u64;
    while left > 0 {
        if let Some(&(_, b)) = blocked.iter().find(|&&(a, b)| cursor >= a && cursor < b) {
            cursor = b;
        }
        let limit = blocked
            .iter()
            .map(|&(a, _)| a)
            .filter(|&a| a > cursor)
            .min()
            .unwrap_or(end)
            .min(end);
        if cursor >= end {
            return None;
        }
        let room = limit - cursor;
        let mut k = ((room as f64 / tpp).floor() as u64).min(left);
        while k > 0 && ticks_of(k) > room {
            k -= 1;
        }
        if k == 0 {
            if limit >= end {
                return None;
            }
            cursor = limit;
            continue;
        }
        out.push(Stretch {
            start_tick: cursor,
            ticks: ticks_of(k),
            periods: k,
        });
        cursor += ticks_of(k);
        left -= k;
    }
    Some((out, cursor))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequential_default_matches_three_equal_stretches() {
        let s = Scenario::default();
        let tl = Timeline::new(&s).unwrap();
        let per = (s.duration_s * s.maneuver.frequency_hz / 3.0).floor() as u64;
        assert_eq!(tl.periods(), [per; 3]);
        let ticks = (per as f64 * s.sample_rate_hz / s.maneuver.frequency_hz).round() as u64;
        for (k, a) in s.axis_order().into_iter().enumerate() {
            assert_eq!(tl.stretches[a].len(), 1);
            assert_eq!(tl.stretches[a][0].start_tick, k as u64 * ticks);
            assert_eq!(tl.stretches[a][0].ticks, ticks);
        }
    }

    #[test]
    fn a_round_frequency_gets_every_period_that_fits() {
        // 10⁴ s × 6×10⁻⁴ Hz / 3 is 1.999… in floating point: 2 periods an axis.
        let mut s = Scenario::default();
        s.maneuver.frequency_hz = 6e-4;
        assert_eq!(Timeline::new(&s).unwrap().periods(), [2; 3]);
        s.maneuver.schedule = Schedule::Simultaneous;
        s.maneuver.frequency_ratio = [1.0, 2.0, 4.0];
        assert_eq!(Timeline::new(&s).unwrap().periods(), [6, 12, 24]);
    }

    #[test]
    fn cosine_phase_returns_to_rest_and_bounds_the_angle() {
        // One axis, I = 1000 kg m², A = 2.5e-6 N m, T = 1000 s: the angle peaks at
        // A T² / (16 I) and the rate at A T / (4 I).
        let mut s = Scenario::default();
        s.spacecraft.inertia_kg_m2 = [[1000.0, 0.0, 0.0], [0.0, 1000.0, 0.0], [0.0, 0.0, 1000.0]];
        let tl = Timeline::new(&s).unwrap();
        let inertia = Matrix3::from_fn(|i, j| s.spacecraft.inertia_kg_m2[i][j]);
        let env = tl.envelope(&inertia);
        let (a, t, i) = (2.5e-6, 1000.0, 1000.0);
        assert!((env.peak_attitude_rad / (a * t * t / (16.0 * i)) - 1.0).abs() < 1e-9);
        assert!((env.peak_rate_rad_s / (a * t / (4.0 * i)) - 1.0).abs() < 1e-9);
        // |A r| at r = (0, 0.25, 0) while x rocks: ω̇ r plus the ω² term.
        let r = [Vector3::new(0.0, 0.25, 0.0)];
        let (_, peak) = env.peak_acceleration(&r, 1.0);
        let wdot = a / i;
        let w = wdot * t / 4.0;
        assert!((peak - (wdot * 0.25 * (1.0 + (w * w / wdot).powi(2)).sqrt())).abs() < 1e-3 * peak);
    }

    #[test]
    fn simultaneous_axes_run_the_whole_window_at_their_own_frequency() {
        let mut s = Scenario::default();
        s.maneuver.schedule = Schedule::Simultaneous;
        s.maneuver.frequency_hz = 1e-3;
        let tl = Timeline::new(&s).unwrap();
        assert_eq!(tl.periods(), [10, 20, 40]);
        // Orthogonal square waves: Σ τx τy = 0 over the window.
        let n = s.n_samples();
        let dot: f64 = (0..n)
            .map(|t| tl.torque_axis(0, t) * tl.torque_axis(1, t))
            .sum();
        assert!(dot.abs() < 1e-9 * n as f64 * 2.5e-6 * 2.5e-6, "{dot}");
    }

    #[test]
    fn pauses_keep_the_rocking_out_of_outages() {
        let mut s = Scenario {
            duration_s: 12_000.0,
            ..Scenario::default()
        };
        s.star_tracker.outages_s = vec![[2500.0, 3200.0]];
        s.maneuver.pause_in_outages = true;
        let tl = Timeline::new(&s).unwrap();
        for t in 20_000..32_000 {
            assert_eq!(tl.torque(t), [0.0; 3], "tick {t}");
        }
        // Whole periods only: every stretch's torque sums to zero.
        for a in 0..3 {
            for x in &tl.stretches[a] {
                let sum: f64 = (x.start_tick..x.start_tick + x.ticks)
                    .map(|t| tl.torque_axis(a, t))
                    .sum();
                assert!(sum.abs() < 1e-12);
            }
        }
        assert_eq!(tl.periods(), [3; 3]);
    }

    #[test]
    fn a_window_too_short_names_the_axis() {
        let s = Scenario {
            duration_s: 2500.0,
            ..Scenario::default()
        };
        let e = Timeline::new(&s).unwrap_err();
        assert_eq!(e.period_s, 1000.0);
    }
}
