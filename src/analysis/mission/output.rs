//! A mission's files: `timeline.json` (every field: docs/mission.md), `report.md`
//! (its "Mission timeline" section) and the figures; and the summary printed.

use super::Mission;
use crate::analysis::report::ReportError;
use crate::sim::files::FileError;
use std::fmt::Write as _;
use std::path::Path;

/// `DIR/timeline.json`.
pub fn write_json(m: &Mission, dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir)
        .map_err(|source| ReportError::from(FileError::create(dir, source)))?;
    let path = dir.join("timeline.json");
    let text = serde_json::to_string_pretty(m)?;
    std::fs::write(&path, text + "\n")
        .map_err(|source| ReportError::from(FileError::write(path, source)))
}

/// The mission's section of report.md (`figures`: the figures' file stems, in
/// `plots/`).
pub fn markdown(m: &Mission, figures: &[String]) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "## Mission timeline\n");
    let flown = m.campaigns.iter().filter(|c| c.report.is_some()).count();
    let applied = m.campaigns.iter().filter(|c| c.applied).count();
    let _ = writeln!(
        o,
        "Scenario `{}`, mission seed {}, {} days, schedule {} (confidence {}): {} campaigns flown, {} applied; science time spent calibrating {:.4} % of the mission.\n",
        m.scenario,
        m.seed,
        m.days,
        m.schedule,
        m.confidence,
        flown,
        applied,
        100.0 * m.science_time_fraction
    );
    let _ = writeln!(
        o,
        "| group | parameter-days | requirement met | mean (err/σ)² |\n|---|---|---|---|"
    );
    for g in &m.summary {
        let _ = writeln!(
            o,
            "| {} | {} | {:.2} % | {:.2} |",
            g.param,
            g.parameter_days,
            100.0 * g.requirement_met_share,
            g.mean_z2
        );
    }
    let _ = writeln!(
        o,
        "\n| campaign | day | seed | status | requirements met | applied |\n|---|---|---|---|---|---|"
    );
    for (n, c) in m.campaigns.iter().enumerate() {
        let (status, met) = c
            .report
            .as_ref()
            .map_or(("not flown".to_string(), "—"), |r| {
                (
                    r.estimator_status
                        .as_ref()
                        .map_or("—".to_string(), |s| s.text.clone()),
                    if r.requirements.met { "yes" } else { "no" },
                )
            });
        let applied = match (&c.refused, c.applied) {
            (_, true) => "yes".to_string(),
            (Some(why), false) => format!("no: {why}"),
            (None, false) => "no".to_string(),
        };
        let _ = writeln!(
            o,
            "| {} | {:.2} | {} | {} | {} | {} |",
            n + 1,
            c.day,
            c.seed,
            status,
            met,
            applied
        );
    }
    if m.model_misfits.is_empty() {
        let _ = writeln!(o, "\nNo model misfit.");
    } else {
        let _ = writeln!(
            o,
            "\nModel misfits (the trend restarted from that campaign):\n\n| day | IS | parameter | axis | innovation [σ] |\n|---|---|---|---|---|"
        );
        for f in &m.model_misfits {
            let _ = writeln!(
                o,
                "| {:.2} | {} | {} | {} | {:.1} |",
                f.day, f.is, f.param, f.axis, f.innovation_sigma
            );
        }
    }
    for w in &m.warnings {
        let _ = writeln!(o, "\n**Warning:** {w}");
    }
    for f in figures {
        let _ = writeln!(o, "\n![{f}](plots/{f}.png)");
    }
    o
}

/// `DIR/report.md`: the mission's section.
pub fn write_markdown(m: &Mission, dir: &Path, figures: &[String]) -> Result<(), ReportError> {
    let path = dir.join("report.md");
    let text = format!("# Mission report\n\n{}", markdown(m, figures));
    std::fs::write(&path, text).map_err(|source| ReportError::from(FileError::write(path, source)))
}

/// The summary printed at the end.
pub fn summary_text(m: &Mission) -> String {
    let mut o = String::new();
    let flown = m.campaigns.iter().filter(|c| c.report.is_some()).count();
    let days: Vec<String> = m
        .campaigns
        .iter()
        .map(|c| format!("{:.0}", c.day))
        .collect();
    let _ = writeln!(
        o,
        "Mission {:?}, seed {}, {} days: {} campaigns (days {}), science time {:.4} %",
        m.scenario,
        m.seed,
        m.days,
        flown,
        days.join(", "),
        100.0 * m.science_time_fraction
    );
    for g in &m.summary {
        let _ = writeln!(
            o,
            "  {:<10} requirement met on {:.2} % of {} parameter-days, mean (err/σ)² {:.2}",
            g.param,
            100.0 * g.requirement_met_share,
            g.parameter_days,
            g.mean_z2
        );
    }
    for f in &m.model_misfits {
        let _ = writeln!(
            o,
            "  model misfit: day {:.1}, IS{} {} {} at {:.1} σ",
            f.day, f.is, f.param, f.axis, f.innovation_sigma
        );
    }
    for w in &m.warnings {
        let _ = writeln!(o, "  warning: {w}");
    }
    o
}
