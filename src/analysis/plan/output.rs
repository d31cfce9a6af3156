//! What `taiji-calib plan` prints and writes: the best candidates, the chosen
//! `[maneuver]` as TOML, plan.json, and the figure of the bound against frequency and
//! torque amplitude.

use super::{maneuver_toml, Candidate, Plan, PlanError};
use crate::analysis::plots::render::{self, Figure, Panel, Series};
use crate::sim::files::FileError;
use crate::sim::scenario::{Scenario, Schedule};
use std::fmt::Write as _;
use std::path::Path;

fn row(c: &Candidate) -> String {
    let f = match c.maneuver.schedule {
        Schedule::Sequential => format!("{:.3e}", c.frequencies_hz[0]),
        Schedule::Simultaneous => format!(
            "{:.2e}/{:.2e}/{:.2e}",
            c.frequencies_hz[0], c.frequencies_hz[1], c.frequencies_hz[2]
        ),
    };
    format!(
        "{:<12} {:<4} {:>5} {:<26} {:>13} {:>26} {:>9.2e} {:>9.2e} {:>8.4} {:<9} {}",
        c.maneuver.schedule.name(),
        if c.maneuver.schedule == Schedule::Sequential {
            c.maneuver.axis_order.as_str()
        } else {
            "-"
        },
        c.maneuver.start_phase,
        f,
        format!("{:?}", c.periods),
        format!(
            "{:.2e} {:.2e} {:.2e}",
            c.maneuver.torque_amplitude_nm[0],
            c.maneuver.torque_amplitude_nm[1],
            c.maneuver.torque_amplitude_nm[2]
        ),
        c.peak_acceleration_m_s2,
        c.peak_attitude_rad,
        c.worst_ratio,
        c.worst_parameter.split(' ').next().unwrap_or(""),
        c.binding
    )
}

/// The printed summary of a plan.
pub fn summary(s: &Scenario, p: &Plan, top: usize, margin: Option<f64>) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Maneuver plan for scenario {:?}, window {} s: {} candidates in {:.2} s (bounds at {} Hz in the search)",
        s.name,
        p.duration_s,
        p.candidates.len(),
        p.elapsed_s,
        p.search_rate_hz
    );
    let _ = writeln!(
        o,
        "{:<12} {:<4} {:>5} {:<26} {:>13} {:>26} {:>9} {:>9} {:>8} {:<9} binding",
        "schedule",
        "axes",
        "phase",
        "frequency [Hz]",
        "periods",
        "torque [N m]",
        "|A r|max",
        "att.max",
        "CRLB/req",
        "worst"
    );
    for c in p
        .candidates
        .iter()
        .filter(|c| c.amplitude_fraction == 1.0)
        .take(top)
    {
        let _ = writeln!(o, "{}", row(c));
    }
    for (sch, r) in &p.best_by_schedule {
        let _ = writeln!(
            o,
            "best {} (search bound): CRLB/requirement {r:.4}",
            sch.name()
        );
    }
    if !super::schedules(s).contains(&Schedule::Sequential) {
        let rocking = super::torque_noise_rocking(s);
        let how = if rocking == 0.0 {
            "have no torque noise".to_string()
        } else {
            format!(
                "rock the spacecraft {rocking:.1e}× the estimator's test for motion on every axis (under {})",
                crate::tuning::QUIET_ROCKING
            )
        };
        let _ = writeln!(
            o,
            "sequential not weighed: the thrusters {how}, and the estimator would fix the SRP's level only once the last axis rocks (docs/planning.md)"
        );
    }
    let c = &p.chosen;
    let _ = writeln!(o, "Chosen, bound at {} Hz:", c.rate_hz);
    if let Some(b) = &c.crlb {
        for (i, prior) in s.priors().iter().enumerate() {
            let rel: Vec<String> = (0..3)
                .map(|a| format!("{:.2e}", b.beta[i][a] / prior.beta[a]))
                .collect();
            let r: Vec<String> = (0..3)
                .map(|a| format!("{:.3}", b.com_offset_m[i][a] * 1e6))
                .collect();
            let _ = writeln!(
                o,
                "  IS{}  β relative [{}] (req 3.0e-4)   r [{}] µm (req 75)",
                i + 1,
                rel.join(", "),
                r.join(", ")
            );
        }
    }
    let _ = writeln!(
        o,
        "  worst CRLB/requirement {:.4} ({}): margin {:.0}× on the bound; peak |A r| {:.3e} m/s² (limit {:.1e}), attitude {:.3e} rad, rate {:.3e} rad/s; torque bound by {}",
        c.worst_ratio,
        c.worst_parameter,
        1.0 / c.worst_ratio,
        c.peak_acceleration_m_s2,
        s.front_end.maneuver_limit_m_s2,
        c.peak_attitude_rad,
        c.peak_rate_rad_s,
        c.binding
    );
    if let Some(m) = margin {
        let _ = writeln!(
            o,
            "Shortest window meeting every requirement with margin {m} on the bound: {} s",
            p.duration_s
        );
    }
    o
}

/// The figure: worst CRLB / requirement against frequency, one line per schedule and
/// torque fraction, the requirement and the chosen maneuver marked.
fn figure(p: &Plan) -> Figure {
    let mut panel = Panel::new(
        format!(
            "Cramér–Rao bound of the planned maneuver, window {} s",
            p.duration_s
        ),
        "maneuver frequency (slowest axis) [Hz]",
        "worst CRLB / requirement",
    );
    panel.log_log = true;
    let mut color = 0;
    let mut lo = f64::INFINITY;
    let mut hi: f64 = 0.0;
    for sch in [Schedule::Sequential, Schedule::Simultaneous] {
        for frac in [1.0, 0.5, 0.25] {
            let mut xy: Vec<(f64, f64)> = p
                .candidates
                .iter()
                .filter(|c| {
                    c.maneuver.schedule == sch
                        && c.amplitude_fraction == frac
                        && c.maneuver.start_phase == 0.0
                        && (sch == Schedule::Simultaneous || c.maneuver.axis_order == "xyz")
                        && (sch == Schedule::Sequential || c.maneuver.frequency_ratio[0] == 1.0)
                        && c.worst_ratio.is_finite()
                })
                .map(|c| (c.maneuver.frequency_hz, c.worst_ratio))
                .collect();
            xy.sort_by(|a, b| a.0.total_cmp(&b.0));
            if xy.is_empty() {
                continue;
            }
            for (x, _) in &xy {
                lo = lo.min(*x);
                hi = hi.max(*x);
            }
            let label = format!(
                "{}, {} torque",
                sch.name(),
                if frac == 1.0 {
                    "largest".to_string()
                } else {
                    format!("{frac}×")
                }
            );
            let mut s = Series::line(label, xy, color).width(2);
            // Half the torque dashed, a quarter dotted: width alone (it was dashed and
            // thin) looked the same in the legend.
            if frac == 0.5 {
                s = s.dashed();
            } else if frac < 0.5 {
                s = s.dotted();
            }
            panel.series.push(s);
        }
        color += 1;
    }
    if lo.is_finite() {
        // The requirement line reaches a fifth beyond the candidates on either side: the
        // x axis spans the data, and the chosen marker, often the first or last
        // frequency, would otherwise sit on the axis, half clipped.
        panel.series.push(
            Series::line(
                "requirement",
                vec![(lo / 1.2, 1.0), (hi * 1.2, 1.0)],
                render::BLACK_INDEX,
            )
            .dashed(),
        );
        let c = &p.chosen;
        panel.series.push(
            Series::line(
                format!("chosen ({:.4})", c.worst_ratio),
                vec![
                    (c.maneuver.frequency_hz, c.worst_ratio * 0.7),
                    (c.maneuver.frequency_hz, c.worst_ratio / 0.7),
                ],
                2,
            )
            .width(4),
        );
    }
    Figure {
        name: "plan_bound".into(),
        title: "Maneuver planning: the bound against frequency and torque".into(),
        panels: vec![panel],
        cols: 1,
    }
}

/// Print the plan and write DIR/maneuver.toml, DIR/plan.json and the figure.
pub fn write(
    s: &Scenario,
    p: &Plan,
    dir: &Path,
    top: usize,
    margin: Option<f64>,
) -> Result<(), PlanError> {
    print!("{}", summary(s, p, top, margin));
    let toml_path = dir.join("maneuver.toml");
    let mut text = format!(
        "# Planned by taiji-calib plan for a window of {} s (scenario {:?}): worst\n# Cramér–Rao bound / requirement {:.4} ({}). Paste into a scenario.\n",
        p.duration_s, s.name, p.chosen.worst_ratio, p.chosen.worst_parameter
    );
    if margin.is_some() {
        text.push_str(&format!("duration_s = {}\n", p.duration_s));
    }
    text.push_str(&maneuver_toml(&p.chosen.maneuver));
    std::fs::write(&toml_path, text)
        .map_err(|source| PlanError::from(FileError::write(toml_path.clone(), source)))?;
    let json = serde_json::json!({
        "scenario": s.name,
        "duration_s": p.duration_s,
        "search_rate_hz": p.search_rate_hz,
        "elapsed_s": p.elapsed_s,
        "margin": margin,
        "chosen": p.chosen,
        "chosen_crlb": p.chosen.crlb.map(|b| serde_json::json!({
            "beta": b.beta, "k": b.k, "com_offset_m": b.com_offset_m,
        })),
        "candidates": p.candidates,
    });
    let json_path = dir.join("plan.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&json)?)
        .map_err(|source| PlanError::from(FileError::write(json_path.clone(), source)))?;
    render::write(&figure(p), dir)?;
    println!(
        "Wrote {}, {} and {}",
        toml_path.display(),
        json_path.display(),
        dir.join("plan_bound.png").display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chosen marker lies inside the x axis, not on it, and the three torque
    /// fractions of a schedule are drawn in three line styles.
    #[test]
    fn the_chosen_marker_is_inside_the_axes_and_each_torque_has_its_own_style() {
        let s = Scenario::load_or_default(None).unwrap();
        let opts = crate::analysis::plan::PlanOptions {
            duration_s: Some(5000.0),
            amplitude_sweep: true,
            exact: true,
        };
        let p = crate::analysis::plan::plan(&s, &opts).unwrap();
        let f = figure(&p);
        let panel = &f.panels[0];
        let ((x0, x1), _) = crate::analysis::plots::render::panel_ranges(panel);
        let fc = p.chosen.maneuver.frequency_hz;
        assert!(
            x0 < fc / 1.1 && fc * 1.1 < x1,
            "{fc} on the axis [{x0}, {x1}]"
        );
        let style = |frac: &str| {
            let s = panel
                .series
                .iter()
                .find(|s| s.label.ends_with(&format!("{frac} torque")))
                .unwrap_or_else(|| panic!("no {frac} series"));
            (s.dashed, s.dotted)
        };
        let styles = [style("largest"), style("0.5×"), style("0.25×")];
        assert_eq!(styles, [(false, false), (true, false), (false, true)]);
    }
}
