//! `report.md` and a standalone `report.html`: the result table, requirements, CRLB,
//! timing and the figures (the HTML inlines the SVGs, so it is one self-contained file).

use crate::report::Report;
use std::fmt::Write;
use std::path::Path;

/// (file stem, caption) of every figure, in report order.
pub const FIGURES: [(&str, &str); 7] = [
    (
        "fig3_torque_attitude",
        "Torque (commanded dashed) and attitude angle",
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
        "Convergence of β per axis, both IS, with ±1σ band; truth dashed",
    ),
    (
        "fig7_com_convergence",
        "Convergence of r1, r2 per axis with ±1σ band; truth dashed",
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
        "Requirements (scale factor < {:.0e} relative, CoM < {:.0} µm per axis): **{}**",
        r.requirements.scale_factor_rel,
        r.requirements.com_offset_m * 1e6,
        if r.requirements.met { "met" } else { "NOT met" }
    )];
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

const COLUMNS: [&str; 9] = [
    "parameter",
    "truth",
    "estimate",
    "1σ",
    "error",
    "CRLB",
    "requirement",
    "pass",
    "error/σ",
];

fn cells(row: &crate::report::Row) -> [String; 9] {
    [
        row.name.clone(),
        format!("{:.6e}", row.truth),
        format!("{:.6e}", row.estimate),
        row.sigma.clone(),
        row.error.clone(),
        row.crlb.clone(),
        row.requirement.clone(),
        if row.pass { "ok" } else { "FAIL" }.into(),
        format!("{:+.2}", row.z),
    ]
}

/// The Markdown report; figures linked from `plots/` when `with_figures`.
pub fn markdown(r: &Report, with_figures: bool) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "# Inertial-sensor calibration report\n\n{}\n", header(r));
    let _ = writeln!(o, "| {} |", COLUMNS.join(" | "));
    let _ = writeln!(o, "|{}", "---|".repeat(COLUMNS.len()));
    for row in r.rows() {
        let _ = writeln!(o, "| {} |", cells(&row).join(" | "));
    }
    let _ = writeln!(
        o,
        "\nβ and k: 1σ, error and CRLB relative to the truth; r: absolute. CRLB: the 1σ \
         Cramér–Rao bound of the scenario for the full problem.\n"
    );
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
}

/// The standalone HTML report, SVG figures inlined from `dir/plots/`.
pub fn html(r: &Report, dir: &Path, with_figures: bool) -> String {
    let mut o = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Calibration report</title>\n\
         <style>body{font-family:sans-serif;max-width:1900px;margin:1em auto;padding:0 1em}\
         table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:2px 8px;text-align:right}\
         td:first-child{text-align:left}.FAIL{color:#b00;font-weight:bold}svg{max-width:100%;height:auto}</style>\n\
         </head><body>\n",
    );
    let _ = writeln!(
        o,
        "<h1>Inertial-sensor calibration report</h1>\n<p>{}</p>\n<table>\n<tr>{}</tr>",
        escape(&header(r)),
        COLUMNS.map(|c| format!("<th>{c}</th>")).join("")
    );
    for row in r.rows() {
        let c = cells(&row);
        let _ = writeln!(
            o,
            "<tr>{}</tr>",
            c.iter()
                .map(|v| format!("<td class=\"{}\">{}</td>", escape(v), escape(v)))
                .collect::<String>()
        );
    }
    let _ = writeln!(
        o,
        "</table>\n<p>β and k: 1σ, error and CRLB relative to the truth; r: absolute.</p>\n<ul>"
    );
    for n in notes(r) {
        let _ = writeln!(o, "<li>{}</li>", escape(&n).replace("**", ""));
    }
    let _ = writeln!(o, "</ul>");
    if with_figures {
        for (stem, caption) in FIGURES {
            let svg = std::fs::read_to_string(dir.join("plots").join(format!("{stem}.svg")))
                .unwrap_or_else(|_| format!("<p>(figure {stem} missing)</p>"));
            let _ = writeln!(o, "<h2>{}</h2>\n{}", escape(caption), svg);
        }
    }
    o + "</body></html>\n"
}

/// Write `dir/report.md` and `dir/report.html`.
pub fn write(r: &Report, dir: &Path, with_figures: bool) -> Result<(), String> {
    for (name, text) in [
        ("report.md", markdown(r, with_figures)),
        ("report.html", html(r, dir, with_figures)),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    }
    Ok(())
}
