//! One figure per parameter group of a mission: per IS and axis, the truth, each
//! campaign's estimate ±σ, the value in use with its confidence band (± z σ), and the
//! requirement around the truth. Values are shown as their change from the file's
//! value: β and k in ppm of it, r in µm.

use super::{Mission, AXES, GROUPS};
use crate::analysis::plots::render::{BandStyle, Figure, Panel, Series, BLACK_INDEX};
use crate::analysis::plots::PlotError;
use crate::sim::files::FileError;
use crate::sim::scenario::Scenario;
use std::path::{Path, PathBuf};

/// The group's title and unit.
const NAMES: [(&str, &str); 3] = [
    ("angular scale factor β", "β − β₀ [ppm of β₀]"),
    ("linear scale factor k", "k − k₀ [ppm of k₀]"),
    ("CoM offset r", "r − r₀ [µm]"),
];

/// The figure of group `g`; `z` the confidence's two-sided quantile.
pub fn figure(m: &Mission, s: &Scenario, g: usize, z: f64) -> Figure {
    let file = Scenario {
        epoch_day: 0.0,
        drift: None,
        ..s.clone()
    }
    .truths();
    let mut panels = Vec::new();
    for i in 0..s.inertial_sensor.len() {
        for (a, axis) in AXES.iter().enumerate() {
            let r0 = [file.beta, file.k, file.com_offset_m][g][i][a];
            // The change from the file's value, in the figure's unit.
            let show = |v: f64| {
                if g == 2 {
                    (v - r0) * 1e6
                } else {
                    (v / r0 - 1.0) * 1e6
                }
            };
            let scale = |sigma: f64| {
                if g == 2 {
                    sigma * 1e6
                } else {
                    sigma / r0 * 1e6
                }
            };
            let rows: Vec<_> = m
                .daily
                .iter()
                .filter(|r| r.is == i + 1 && r.param == GROUPS[g] && r.axis == *axis)
                .collect();
            let mut p = Panel::new(format!("IS{} {}", i + 1, axis), "mission day", NAMES[g].1);
            let req = |t: f64| {
                if g == 2 {
                    crate::analysis::report::REQ_COM_M
                } else {
                    crate::analysis::report::REQ_SCALE_FACTOR_REL * t.abs()
                }
            };
            p.series.push(
                Series::line(
                    format!("in use ± {z:.2} σ"),
                    rows.iter().map(|r| (r.day, show(r.in_use))).collect(),
                    0,
                )
                .with_band(
                    rows.iter()
                        .map(|r| {
                            let c = show(r.in_use);
                            let w = z * scale(r.sigma);
                            (r.day, c - w, c + w)
                        })
                        .collect(),
                    BandStyle::Fill,
                ),
            );
            p.series.push(
                Series::line(
                    "truth",
                    rows.iter().map(|r| (r.day, show(r.truth))).collect(),
                    BLACK_INDEX,
                )
                .dashed(),
            );
            for (sign, label) in [(1.0, "requirement around the truth"), (-1.0, "")] {
                p.series.push(
                    Series::line(
                        label,
                        rows.iter()
                            .map(|r| (r.day, show(r.truth + sign * req(r.truth))))
                            .collect(),
                        3,
                    )
                    .dotted(),
                );
            }
            let mut first = true;
            for c in &m.campaigns {
                let Some(rep) = &c.report else { continue };
                let is = &rep.inertial_sensors[i];
                let q = [&is.beta, &is.k, &is.com_offset][g];
                let (e, sg) = (show(q.estimate[a]), scale(q.sigma[a]));
                let label = if first { "campaign estimate ± σ" } else { "" };
                first = false;
                let color = if c.applied { 1 } else { 2 };
                p.series.push(
                    Series::line(label, vec![(c.day, e - sg), (c.day, e + sg)], color).width(3),
                );
                p.series.push(
                    Series::line("", vec![(c.day - 1.5, e), (c.day + 1.5, e)], color).width(3),
                );
            }
            panels.push(p);
        }
    }
    Figure {
        name: format!("timeline_{}", GROUPS[g]),
        title: format!(
            "Mission: {} — truth, campaign estimates, value in use (confidence {})",
            NAMES[g].0, m.confidence
        ),
        panels,
        cols: 3,
    }
}

/// Write the three figures to `dir/plots/`; their PNG paths.
pub fn write(m: &Mission, s: &Scenario, z: f64, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots)
        .map_err(|source| PlotError::from(FileError::create(plots.clone(), source)))?;
    let mut out = Vec::new();
    for g in 0..3 {
        let f = figure(m, s, g, z);
        crate::analysis::plots::render::write(&f, &plots)?;
        out.push(plots.join(format!("{}.png", f.name)));
    }
    Ok(out)
}
