//! `replay` and `export`: the estimator over a recording, and a recording exported.

use super::args::MethodArg;
use super::error::CliError;
use super::output::{check_out, finish, out_dir};
use crate::analysis::progress::Bar;
use crate::analysis::report::Report;
use crate::sim::estimate::Method;
use std::process::ExitCode;

/// How `replay` reads its recording.
pub(crate) struct ReplayHow {
    pub(crate) method: Option<MethodArg>,
    /// Follow a growing file, waiting this long for each new row.
    pub(crate) follow: Option<std::time::Duration>,
    /// A truncated recording is an error.
    pub(crate) complete: bool,
}

/// A truncated recording said plainly; an error where the user asked for a whole one.
pub(crate) fn truncated(
    path: &std::path::Path,
    t: crate::telemetry::read::Truncation,
    complete: bool,
) -> Result<(), CliError> {
    let what = format!(
        "{}: a truncated recording: {} of {} samples, the last at tick {} (its writer stopped before the end)",
        path.display(),
        t.rows,
        t.expected,
        t.last_tick
    );
    if complete {
        return Err(CliError::Truncated {
            what: format!("{what}; --complete asks for a whole one"),
        });
    }
    eprintln!("warning: {what}; replaying those samples");
    Ok(())
}

/// `replay`: the estimator on a recording's sensor channels.
pub(crate) fn replay(
    telemetry: &std::path::Path,
    out: &std::path::Path,
    how: ReplayHow,
) -> Result<ExitCode, CliError> {
    let t0 = std::time::Instant::now();
    check_out(out)?;
    let rec = match how.follow {
        Some(idle) => crate::telemetry::read::open_following(telemetry, idle)?,
        None => crate::telemetry::read::open(telemetry)?,
    };
    if let (Some(t), None) = (rec.truncation(), how.follow) {
        truncated(telemetry, t, how.complete)?;
    }
    let method: Method = match (how.method, rec.method.as_deref()) {
        (Some(m), _) => m.into(),
        (None, Some(name)) => crate::runtime::process::parse_method(name).map_err(|source| {
            CliError::MethodAttribute {
                path: telemetry.to_path_buf(),
                source: Box::new(source),
            }
        })?,
        (None, None) => Method::Joint,
    };
    let bar = Bar::new(1000, "replay");
    let res = crate::analysis::replay::run(&rec, method, |f| bar.set((f * 1000.0) as u64))?;
    bar.finish();
    // The bound and the requirements of the samples replayed: a truncated recording's
    // campaign ends at its last row.
    let mut s = rec.scenario.clone();
    s.seed = rec.seed;
    if let Some(t) = rec.truncation() {
        if how.follow.is_some() {
            truncated(telemetry, t, how.complete)?;
        }
        s.duration_s = t.rows as f64 / s.sample_rate_hz;
    }
    let bounds = match (crate::analysis::plan::bounds(&s), rec.truncation()) {
        (Some(b), _) => b,
        // Too short a piece of the campaign to bound every parameter: no bound.
        (None, Some(_)) => crate::analysis::crlb::Bounds {
            run: crate::analysis::crlb::Crlb::INFINITE,
            maneuver: None,
        },
        (None, None) => return Err(CliError::Unexcited),
    };
    let mut report = Report::with_bounds(
        &s,
        rec.seed,
        "replay",
        method.name(),
        &res.estimate,
        &bounds,
    );
    report.faults = res.faults.map(|f| f.summary());
    report.wall_time_s = Some(t0.elapsed().as_secs_f64());
    finish(out, &report, false)
}

/// `export`: a recording as the C library's inputs.
pub(crate) fn export(
    telemetry: &std::path::Path,
    out: &std::path::Path,
) -> Result<ExitCode, CliError> {
    check_out(out)?;
    let rec = crate::telemetry::read::open(telemetry)?;
    if let Some(t) = rec.truncation() {
        truncated(telemetry, t, false)?;
    }
    out_dir(out)?;
    let n = crate::analysis::export::write(&rec, out)?;
    println!(
        "exported {n} samples and the estimator table to {}",
        out.display()
    );
    Ok(ExitCode::SUCCESS)
}
