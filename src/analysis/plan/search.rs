//! The planner's search: candidate maneuvers shaped and sized to the limits, their
//! bounds evaluated, ranked, and refined (finer period counts, variants, amplitudes).

use super::*;
use crate::analysis::crlb::{crlb_at_rate, Crlb};
use crate::sim::scenario::maneuver::{
    axis_frequencies, rocking_seconds, torque_boost, Envelope, Timeline,
};
use crate::sim::scenario::{Maneuver, Scenario, Schedule};
use crate::tuning::{MAX_FREQUENCY_HZ, PERIODS, REFINEMENT_GAIN};

/// The scenario with `m` as its maneuver.
pub(super) fn with_maneuver(base: &Scenario, m: &Maneuver) -> Scenario {
    let mut s = base.clone();
    s.maneuver = m.clone();
    s.plan_pending = false;
    s
}

/// Give `m` the largest torque every constraint allows: per axis when the axes take
/// turns, one common scale of torques ∝ the inertia's diagonal (equal angular
/// acceleration) when they rock together. `None` when no torque fits.
pub(super) fn size(base: &Scenario, mut m: Maneuver) -> Option<Candidate> {
    let corners = offset_corners(base);
    let boost = torque_boost(base);
    let inertia = inertia(base);
    let limit = base.front_end.maneuver_limit_m_s2;
    let shape: [f64; 3] = match m.schedule {
        Schedule::Sequential => [1e-6; 3],
        Schedule::Simultaneous => core::array::from_fn(|a| 1e-9 * inertia[(a, a)]),
    };
    // The largest scale of one shape, and the constraint that set it.
    let largest = |m: &Maneuver, unit: [f64; 3]| -> Option<(f64, &'static str)> {
        let mut mm = m.clone();
        mm.torque_amplitude_nm = unit;
        let s = with_maneuver(base, &mm);
        let env = Timeline::new(&s).ok()?.envelope(&inertia);
        let peak_unit = unit.iter().fold(0.0f64, |a, b| a.max(*b));
        let mut bounds: Vec<(f64, &'static str)> = vec![(
            base.thruster.max_torque_nm / (peak_unit * boost),
            "thruster.max_torque_nm",
        )];
        let (att, att_key) = attitude_limit(base);
        if env.peak_attitude_rad > 0.0 {
            bounds.push((att / (env.peak_attitude_rad * boost), att_key));
        }
        if m.max_rate_rad_s > 0.0 && env.peak_rate_rad_s > 0.0 {
            bounds.push((
                m.max_rate_rad_s / (env.peak_rate_rad_s * boost),
                "maneuver.max_rate_rad_s",
            ));
        }
        let (cap, mut why) =
            bounds
                .into_iter()
                .fold((f64::INFINITY, ""), |w, b| if b.0 < w.0 { b } else { w });
        let scale = env.largest_scale(&corners, limit, cap * boost) / boost;
        if scale < cap * (1.0 - 1e-9) {
            why = "front_end.maneuver_limit_m_s2";
        }
        Some((scale, why))
    };
    let mut binding = "";
    match m.schedule {
        Schedule::Sequential => {
            // The axes take turns and come to rest between: each its own largest torque.
            for a in 0..3 {
                let mut unit = [0.0; 3];
                unit[a] = shape[a];
                let (scale, why) = largest(&m, unit)?;
                m.torque_amplitude_nm[a] = scale * shape[a];
                if binding.is_empty() {
                    binding = why;
                }
            }
        }
        Schedule::Simultaneous => {
            let (scale, why) = largest(&m, shape)?;
            m.torque_amplitude_nm = shape.map(|v| v * scale);
            binding = why;
        }
    }
    if m.torque_amplitude_nm
        .iter()
        .any(|v| v.is_nan() || *v <= 0.0)
    {
        return None;
    }
    // Round down to 4 significant digits: a plan written as TOML reads back the same.
    m.torque_amplitude_nm = m.torque_amplitude_nm.map(round_down_4);
    let s = with_maneuver(base, &m);
    let tl = Timeline::new(&s).ok()?;
    let env: Envelope = tl.envelope(&inertia);
    Some(Candidate {
        frequencies_hz: axis_frequencies(&s),
        periods: tl.periods(),
        binding: binding.to_string(),
        peak_acceleration_m_s2: env.peak_acceleration(&corners, boost).1,
        peak_attitude_rad: env.peak_attitude_rad * boost,
        peak_rate_rad_s: env.peak_rate_rad_s * boost,
        maneuver: m,
        crlb: None,
        rate_hz: 0.0,
        worst_ratio: f64::INFINITY,
        worst_parameter: String::new(),
        amplitude_fraction: 1.0,
    })
}

use crate::sim::scenario::maneuver::round_down_4;

/// The maneuver shapes for `base`'s window with `counts` whole periods per axis
/// (sequential) or of the slow axis (simultaneous, the slow axis each of `slow`).
pub(super) fn shapes(
    base: &Scenario,
    counts: &[u64],
    sched: &[Schedule],
    slow: &[usize],
) -> Vec<Maneuver> {
    let fs = base.sample_rate_hz;
    // Rocking time: the window less the star-tracker outages it waits out.
    let n_ticks = (rocking_seconds(base) * fs).floor().max(0.0);
    let hold = base.spacecraft.attitude_hold_hz;
    let f_hi = MAX_FREQUENCY_HZ.min(fs / 8.0);
    let mut out = Vec::new();
    let template = Maneuver {
        planned: true,
        start_s: 0.0,
        start_phase: 0.0,
        // Known star-tracker outages are a constraint: no rocking while blind.
        pause_in_outages: !base.star_tracker.outages_s.is_empty(),
        ..base.maneuver.clone()
    };
    for &n in counts {
        // Sequential: n periods per axis fill the window (whole ticks per period).
        let tpp = (n_ticks / (3.0 * n as f64)).floor();
        let f = fs / tpp;
        if sched.contains(&Schedule::Sequential) && tpp >= 8.0 && f <= f_hi && f >= 10.0 * hold {
            out.push(Maneuver {
                schedule: Schedule::Sequential,
                frequency_hz: f,
                axis_order: "xyz".into(),
                ..template.clone()
            });
        }
        // Simultaneous: n periods of the slow axis, 2n and 4n of the others.
        let tpp = 4.0 * (n_ticks / (4.0 * n as f64)).floor();
        let f = fs / tpp;
        if sched.contains(&Schedule::Simultaneous)
            && tpp >= 32.0
            && 4.0 * f <= f_hi
            && f >= 10.0 * hold
        {
            for &slow in slow {
                // 1 on the slow axis, then 2 and 4 on the next ones.
                let ratio = core::array::from_fn(|a| [1.0, 2.0, 4.0][(a + 3 - slow) % 3]);
                out.push(Maneuver {
                    schedule: Schedule::Simultaneous,
                    frequency_hz: f,
                    frequency_ratio: ratio,
                    ..template.clone()
                });
            }
        }
    }
    out
}

/// Bound every candidate at `rate` (in parallel on the machine's cores).
pub(super) fn evaluate(base: &Scenario, cands: &mut [Candidate], rate: f64) {
    let workers = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 8);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done: Vec<(usize, Option<Crlb>)> = std::thread::scope(|sc| {
        let work = || {
            let mut out = Vec::new();
            loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(c) = cands.get(i) else { break out };
                out.push((i, crlb_at_rate(&with_maneuver(base, &c.maneuver), rate)));
            }
        };
        let handles: Vec<_> = (0..workers).map(|_| sc.spawn(work)).collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    for (i, b) in done {
        set_bound(base, &mut cands[i], b, rate);
    }
}

/// Give `c` its bound (computed at `rate`) and its worst ratio.
pub(super) fn set_bound(base: &Scenario, c: &mut Candidate, b: Option<Crlb>, rate: f64) {
    let s = with_maneuver(base, &c.maneuver);
    (c.worst_ratio, c.worst_parameter) = match &b {
        Some(b) => worst_ratio(&s, b),
        None => (f64::INFINITY, "singular Fisher information".into()),
    };
    c.crlb = b;
    c.rate_hz = rate;
}

pub(super) fn rank(c: &Candidate) -> f64 {
    let m = &c.maneuver;
    let plain = m.start_phase == 0.0 && m.axis_order == "xyz";
    if plain {
        c.worst_ratio
    } else {
        c.worst_ratio * REFINEMENT_GAIN
    }
}

pub(super) fn best_first(c: &mut [Candidate]) {
    c.sort_by(|a, b| rank(a).total_cmp(&rank(b)));
}

/// The coarse grid's candidates, sized (not yet bounded); the error when the window
/// holds no maneuver or no torque fits.
pub(super) fn coarse_candidates(base: &Scenario) -> Result<Vec<Candidate>, PlanError> {
    let d = base.duration_s;
    let hold = base.spacecraft.attitude_hold_hz;
    let coarse = shapes(base, &PERIODS, schedules(base), &[0]);
    if coarse.is_empty() {
        let f_lo = (3.0 / d).max(10.0 * hold);
        let why = if 10.0 * hold > 3.0 / d {
            format!(
                "the slowest frequency spacecraft.attitude_hold_hz = {hold} Hz allows is {} Hz, and three whole periods (one per axis) of it need {:.0} s",
                10.0 * hold,
                3.0 / f_lo
            )
        } else {
            format!(
                "three whole periods (one per axis) need at least {:.0} s at the fastest frequency searched ({MAX_FREQUENCY_HZ} Hz, or sample_rate_hz / 8)",
                3.0 / MAX_FREQUENCY_HZ.min(base.sample_rate_hz / 8.0)
            )
        };
        return Err(PlanError::WindowTooShort { duration_s: d, why });
    }
    let cands: Vec<Candidate> = coarse.into_iter().filter_map(|m| size(base, m)).collect();
    if cands.is_empty() {
        return Err(PlanError::NoTorque {
            max_torque_nm: base.thruster.max_torque_nm,
            maneuver_limit_m_s2: base.front_end.maneuver_limit_m_s2,
        });
    }
    Ok(cands)
}

/// Each schedule's best count of periods refined with the counts between its
/// neighbours, and the simultaneous schedule's slow axis (sized, not yet bounded).
pub(super) fn finer_counts(base: &Scenario, ranked: &[Candidate]) -> Vec<Candidate> {
    let mut finer = Vec::new();
    for sch in [Schedule::Sequential, Schedule::Simultaneous] {
        let Some(best) = ranked.iter().find(|c| c.maneuver.schedule == sch) else {
            continue;
        };
        let n = match sch {
            Schedule::Sequential => best.periods[0],
            Schedule::Simultaneous => *best.periods.iter().min().unwrap_or(&1),
        };
        let between: Vec<u64> = ((n / 2 + 1)..(2 * n))
            .filter(|k| !PERIODS.contains(k))
            .collect();
        let between: Vec<u64> = if between.len() > 4 {
            // At most four counts, spread geometrically.
            (1..=4)
                .map(|i| ((n as f64) * 2f64.powf(i as f64 / 5.0 * 2.0 - 1.0)).round() as u64)
                .filter(|k| !PERIODS.contains(k))
                .collect()
        } else {
            between
        };
        finer.extend(shapes(base, &between, &[sch], &[0]));
        if sch == Schedule::Simultaneous {
            finer.extend(shapes(base, &[n], &[sch], &[1, 2]));
        }
    }
    finer.into_iter().filter_map(|m| size(base, m)).collect()
}

/// Variants of the best candidate: the other start phase, the other axis orders
/// (sized, not yet bounded).
pub(super) fn variants_of(base: &Scenario, top: &Candidate) -> Vec<Candidate> {
    let mut variants = Vec::new();
    let mut m = top.maneuver.clone();
    m.start_phase = 0.25;
    variants.push(m);
    if top.maneuver.schedule == Schedule::Sequential {
        for order in ["xzy", "yxz", "yzx", "zxy", "zyx"] {
            let mut m = top.maneuver.clone();
            m.axis_order = order.into();
            variants.push(m);
        }
    }
    variants.into_iter().filter_map(|m| size(base, m)).collect()
}

/// The plain candidates at half and a quarter of their torque (to be bounded).
pub(super) fn amplitude_sweep(cands: &[Candidate]) -> Vec<Candidate> {
    let mut sweep = Vec::new();
    for c in cands.iter().filter(|c| {
        c.maneuver.start_phase == 0.0
            && (c.maneuver.schedule == Schedule::Sequential && c.maneuver.axis_order == "xyz"
                || c.maneuver.schedule == Schedule::Simultaneous)
    }) {
        for frac in [0.5, 0.25] {
            let mut x = c.clone();
            x.maneuver.torque_amplitude_nm = x.maneuver.torque_amplitude_nm.map(|v| v * frac);
            x.amplitude_fraction = frac;
            sweep.push(x);
        }
    }
    sweep
}

/// Why the best maneuver still misses a requirement, naming what binds it.
pub(super) fn infeasible(base: &Scenario, c: &Candidate) -> String {
    let why = match c.binding.as_str() {
        "thruster.max_torque_nm" => format!(
            "the torque is bound by `thruster.max_torque_nm` = {:.3e} N m",
            base.thruster.max_torque_nm
        ),
        "maneuver.max_attitude_rad" => format!(
            "the torque is bound by `maneuver.max_attitude_rad` = {:.3e} rad",
            base.maneuver.max_attitude_rad
        ),
        k if k.starts_with("estimator model") => format!(
            "the torque is bound by the attitude the estimator's model allows ({:.1e} rad, docs/planning.md), so the binding constraint is the window, `duration_s` = {} s (`taiji-calib plan --min-duration` finds the shortest window that works)",
            attitude_limit(base).0,
            base.duration_s
        ),
        "maneuver.max_rate_rad_s" => format!(
            "the torque is bound by `maneuver.max_rate_rad_s` = {:.3e} rad/s",
            base.maneuver.max_rate_rad_s
        ),
        _ => format!(
            "the torque is already at the IS range (`front_end.maneuver_limit_m_s2` = {:.1e} m/s²), so the binding constraint is the window, `duration_s` = {} s (`taiji-calib plan --min-duration` finds the shortest window that works)",
            base.front_end.maneuver_limit_m_s2, base.duration_s
        ),
    };
    format!(
        "no maneuver meets every requirement in this window: the best ({}, {:.3e} Hz, torque [{:.3e}, {:.3e}, {:.3e}] N m) has a Cramér–Rao bound {:.2}× the requirement on {}; {why}",
        c.maneuver.schedule.name(),
        c.maneuver.frequency_hz,
        c.maneuver.torque_amplitude_nm[0],
        c.maneuver.torque_amplitude_nm[1],
        c.maneuver.torque_amplitude_nm[2],
        c.worst_ratio,
        c.worst_parameter
    )
}
