//! `report.md` and a standalone `report.html`: the result table, requirements, CRLB,
//! timing and the figures (the HTML inlines the SVGs, so it is one self-contained file).

use crate::analysis::report::{Report, ReportError};
use crate::sim::files::FileError;
use std::fmt::Write;
use std::path::Path;

/// (file stem, caption) of every figure, in report order.
pub const FIGURES: [(&str, &str); 7] = [
    (
        "fig3_torque_attitude",
        "Torque (applied per axis; commanded black, dashed) and attitude angle",
    ),
    (
        "fig4_voltages_star_tracker",
        "IS1 drive voltages and the star-tracker angular acceleration (0.05 Hz low-pass)",
    ),
    (
        "fig5_is_accelerations_srp",
        "IS1 angular and linear accelerations, SRP and its detrended part",
    ),
    (
        "fig6_beta_convergence",
        "Convergence of β per axis from the first solve: the whole campaign on a symmetric-log \
         scale, then from a fifth of it on a linear scale; IS1 solid with a shaded ±1σ band, \
         IS2 dashed with its band's edges",
    ),
    (
        "fig7_com_convergence",
        "Convergence of r1, r2 per axis from the first solve, drawn as β's",
    ),
    (
        "fig8_coupling_acceleration",
        "Measured linear acceleration vs the identified CoM coupling A(ω, ω̇) r̂",
    ),
    (
        "fig9_noise_asd",
        "Amplitude spectral densities of the noises against their models",
    ),
];

fn header(r: &Report) -> String {
    format!(
        "Scenario `{}`, seed {}, {} s, {} run, {} estimator",
        r.scenario, r.seed, r.duration_s, r.mode, r.method
    )
}

fn notes(r: &Report) -> Vec<String> {
    let mut v = vec![format!(
        "Requirements (scale factor < {:.0} ppm, CoM < {:.0} µm per axis): **{}**",
        r.requirements.scale_factor_rel * 1e6,
        r.requirements.com_offset_m * 1e6,
        if r.requirements.met { "met" } else { "NOT met" }
    )];
    if let Some(st) = &r.estimator_status {
        v.push(format!(
            "Estimator status: {}{}",
            st.text,
            if r.requirements.verified {
                ""
            } else {
                " (result NOT verified by the estimator)"
            }
        ));
    }
    if let Some(m) = &r.maneuver {
        v.push(m.line());
    }
    if let Some(line) = crate::analysis::report::prediction_line(r) {
        v.push(line);
    }
    for w in &r.warnings {
        v.push(format!("**Warning**: {w}"));
    }
    v.push(format!(
        "Samples used {}, rejected {}",
        r.samples_used, r.samples_rejected
    ));
    if let Some(t) = &r.timing {
        v.push(format!("Timing: `{t}`"));
    }
    if let Some(x) = &r.restarts {
        v.push(format!("Restarts: `{x}`"));
    }
    if let Some(a) = r.estimator_loop_allocations {
        v.push(format!(
            "Heap allocations in the estimator's filter loop: {a}"
        ));
    }
    if let Some(w) = r.wall_time_s {
        v.push(format!("Wall time: {w:.2} s"));
    }
    v
}

/// One result table: a kind of parameter, the unit of its truth and estimate columns,
/// and whether its 1σ, error, CRLB and requirement are relative (shown in ppm) or in
/// the unit of the values.
struct Group {
    title: &'static str,
    symbol: &'static str,
    unit: &'static str,
    /// Factor from SI to `unit`.
    scale: f64,
    relative: bool,
}

const GROUPS: [Group; 3] = [
    Group {
        title: "Angular scale factors β",
        symbol: "β",
        unit: "rad s⁻² V⁻¹",
        scale: 1.0,
        relative: true,
    },
    Group {
        title: "Linear scale factors k",
        symbol: "k",
        unit: "m s⁻² V⁻¹",
        scale: 1.0,
        relative: true,
    },
    Group {
        title: "Centre-of-mass offsets r",
        symbol: "r",
        unit: "µm",
        scale: 1e6,
        relative: false,
    },
];

impl Group {
    fn quantity<'a>(
        &self,
        is: &'a crate::analysis::report::IsReport,
    ) -> &'a crate::analysis::report::Quantity {
        match self.symbol {
            "β" => &is.beta,
            "k" => &is.k,
            _ => &is.com_offset,
        }
    }

    /// Column headers, every number's unit in its header.
    fn columns(&self) -> [String; 11] {
        let d = if self.relative { "ppm" } else { self.unit };
        [
            "parameter".into(),
            format!("truth [{}]", self.unit),
            format!("estimate [{}]", self.unit),
            format!("1σ [{d}]"),
            format!("error [{d}]"),
            format!("CRLB [{d}]"),
            format!("CRLB with prior [{d}]"),
            "data share".into(),
            format!("requirement [{d}]"),
            "pass".into(),
            "error/σ".into(),
        ]
    }

    /// One row per IS and axis; pass and error/σ as the report's own rows judge them.
    fn rows(&self, r: &Report) -> Vec<[String; 11]> {
        let judged: std::collections::HashMap<String, crate::analysis::report::Row> = r
            .rows()
            .into_iter()
            .map(|row| (row.name.clone(), row))
            .collect();
        let mut out = Vec::new();
        for is in &r.inertial_sensors {
            let q = self.quantity(is);
            for (a, axis) in ["x", "y", "z"].iter().enumerate() {
                let name = format!("IS{} {}{axis}", is.id, self.symbol);
                let (pass, z) = judged.get(&name).map_or(("?", f64::NAN), |row| {
                    (if row.pass { "ok" } else { "FAIL" }, row.z)
                });
                let err = q.estimate[a] - q.truth[a];
                // Absolute values to the nm: the z offsets' σ is tens of nm.
                let (value, derived, dp): (fn(f64) -> String, f64, usize) = if self.relative {
                    (|v| sci(v, 7), 1e6 / q.truth[a], 2)
                } else {
                    (|v| format!("{v:.3}"), self.scale, 3)
                };
                let req = if self.relative {
                    r.requirements.scale_factor_rel * 1e6
                } else {
                    r.requirements.com_offset_m * self.scale
                };
                out.push([
                    name,
                    value(q.truth[a] * self.scale),
                    value(q.estimate[a] * self.scale),
                    format!("{:.dp$}", (q.sigma[a] * derived).abs()),
                    format!("{:+.dp$}", err * derived),
                    format!("{:.dp$}", (q.crlb[a] * derived).abs()),
                    if q.crlb_with_prior[a].is_nan() {
                        "—".into()
                    } else {
                        format!("{:.dp$}", (q.crlb_with_prior[a] * derived).abs())
                    },
                    if q.data_share[a].is_nan() {
                        "—".into()
                    } else {
                        format!("{:.1} %", 100.0 * q.data_share[a])
                    },
                    format!("{req:.0}"),
                    pass.into(),
                    format!("{z:+.2}"),
                ]);
            }
        }
        out
    }
}

/// `v` with `digits` significant digits as "5.521430×10⁻⁸" (plain from 0.01 to 10⁴).
fn sci(v: f64, digits: usize) -> String {
    let a = v.abs();
    if a == 0.0 || !a.is_finite() {
        return format!("{v}");
    }
    if (1e-2..1e4).contains(&a) {
        let decimals = digits as i32 - 1 - a.log10().floor() as i32;
        return format!("{v:.*}", decimals.max(0) as usize);
    }
    let s = format!("{v:.*e}", digits.saturating_sub(1));
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let exp: String = e
        .to_string()
        .chars()
        .map(|c| match c.to_digit(10) {
            Some(d) => SUP[d as usize],
            None => '⁻',
        })
        .collect();
    format!("{m}×10{exp}")
}

const TABLE_NOTE: &str = "Relative quantities in ppm of the truth. CRLB: the 1σ \
     Cramér–Rao bound of the scenario for the full problem. error/σ: the estimate's \
     error in units of its own 1σ.";

/// The Markdown report; figures linked from `plots/` when `with_figures`.
pub fn markdown(r: &Report, with_figures: bool) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "# Inertial-sensor calibration report\n\n{}\n", header(r));
    for g in &GROUPS {
        let cols = g.columns();
        let _ = writeln!(o, "## {}\n", g.title);
        let _ = writeln!(o, "| {} |", cols.join(" | "));
        let _ = writeln!(o, "|---|{}", "--:|".repeat(cols.len() - 1));
        for row in g.rows(r) {
            let _ = writeln!(o, "| {} |", row.join(" | "));
        }
        let _ = writeln!(o);
    }
    let _ = writeln!(o, "{TABLE_NOTE}\n");
    for n in notes(r) {
        let _ = writeln!(o, "- {n}");
    }
    if with_figures {
        let _ = writeln!(o, "\n## Figures\n");
        for (stem, caption) in FIGURES {
            let _ = writeln!(o, "### {caption}\n\n![{caption}](plots/{stem}.png)\n");
        }
    }
    o
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The report's inline Markdown (`code`, **bold**) as HTML, everything else escaped.
fn inline_html(s: &str) -> String {
    let mut o = String::new();
    // Split on backticks: odd pieces are code, taken literally.
    for (i, piece) in escape(s).split('`').enumerate() {
        if i % 2 == 1 {
            let _ = write!(o, "<code>{piece}</code>");
        } else {
            for (j, part) in piece.split("**").enumerate() {
                if j % 2 == 1 {
                    let _ = write!(o, "<strong>{part}</strong>");
                } else {
                    o.push_str(part);
                }
            }
        }
    }
    o
}

/// Page style. Figures are [`crate::analysis::plots::render::FIGURE_WIDTH`] px wide and shown at
/// that size (scrolling sideways in a narrower window): scaled down, their labels
/// become unreadable.
const STYLE: &str = "body{font-family:sans-serif;max-width:1280px;margin:1em auto;padding:0 1em}\
     table{border-collapse:collapse;margin-bottom:1em}\
     td,th{border:1px solid #bbb;padding:2px 8px;text-align:right}\
     td:first-child,th:first-child{text-align:left}.FAIL{color:#b00;font-weight:bold}\
     code{background:#f3f3f3;padding:0 3px;overflow-wrap:anywhere}\
     figure{margin:1.5em 0}.fig{overflow-x:auto}\
     .fig svg{display:block;max-width:none;height:auto}";

/// The standalone HTML report, SVG figures inlined from `dir/plots/`.
pub fn html(r: &Report, dir: &Path, with_figures: bool) -> String {
    let mut o = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">\
         <title>Calibration report</title>\n<style>{STYLE}</style>\n</head><body>\n"
    );
    let _ = writeln!(
        o,
        "<h1>Inertial-sensor calibration report</h1>\n<p>{}</p>",
        inline_html(&header(r))
    );
    for g in &GROUPS {
        let _ = writeln!(
            o,
            "<h2>{}</h2>\n<table>\n<tr>{}</tr>",
            escape(g.title),
            g.columns()
                .map(|c| format!("<th>{}</th>", escape(&c)))
                .join("")
        );
        for row in g.rows(r) {
            let cells: String = row
                .iter()
                .enumerate()
                .map(|(i, v)| match (i, v.as_str()) {
                    (7, "FAIL") => "<td class=\"FAIL\">FAIL</td>".to_string(),
                    _ => format!("<td>{}</td>", escape(v)),
                })
                .collect();
            let _ = writeln!(o, "<tr>{cells}</tr>");
        }
        let _ = writeln!(o, "</table>");
    }
    let _ = writeln!(o, "<p>{}</p>\n<ul>", escape(TABLE_NOTE));
    for n in notes(r) {
        let _ = writeln!(o, "<li>{}</li>", inline_html(&n));
    }
    let _ = writeln!(o, "</ul>");
    if with_figures {
        let _ = writeln!(o, "<h2>Figures</h2>");
        for (stem, caption) in FIGURES {
            let svg = std::fs::read_to_string(dir.join("plots").join(format!("{stem}.svg")))
                .unwrap_or_else(|_| format!("<p>(figure {stem} missing)</p>"));
            let _ = writeln!(
                o,
                "<figure id=\"{stem}\"><figcaption><h3>{}</h3></figcaption>\
                 <div class=\"fig\">\n{}</div></figure>",
                escape(caption),
                svg
            );
        }
    }
    o + "</body></html>\n"
}

/// Write `dir/report.md` and `dir/report.html`.
pub fn write(r: &Report, dir: &Path, with_figures: bool) -> Result<(), ReportError> {
    for (name, text) in [
        ("report.md", markdown(r, with_figures)),
        ("report.html", html(r, dir, with_figures)),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text)
            .map_err(|source| ReportError::from(FileError::write(p, source)))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_markdown_becomes_html_without_backticks() {
        let h = inline_html("Scenario `a<b`, **met**, `{\"x\": 1}`");
        assert_eq!(
            h,
            "Scenario <code>a&lt;b</code>, <strong>met</strong>, <code>{&quot;x&quot;: 1}</code>"
        );
    }

    #[test]
    fn scientific_cells_use_powers_of_ten() {
        assert_eq!(sci(5.52143e-8, 7), "5.521430×10⁻⁸");
        assert_eq!(sci(-1.128834e-9, 7), "-1.128834×10⁻⁹");
        assert_eq!(sci(216.4, 4), "216.4");
    }
}
