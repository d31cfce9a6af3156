//! The output folder: checked before any work, made once something is written, and
//! the report written and printed at the end.

use super::error::CliError;
use crate::analysis::report::Report;
use std::process::ExitCode;

/// Refuse an `--out` where no folder can be made (a path through a file) before any
/// work, so a campaign is not run for nothing, but without creating it: a user error
/// found later (a bad scenario, a bad recording) must leave no empty folder behind.
pub(crate) fn check_out(out: &std::path::Path) -> Result<(), CliError> {
    let refuse = |source| CliError::OutDir {
        path: out.to_path_buf(),
        source,
    };
    // The nearest existing ancestor decides (an empty one is the working folder).
    for a in out.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => {
                let why = format!("{} is not a folder", a.display());
                return Err(refuse(std::io::Error::other(why)));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(refuse(e)),
        }
    }
    Ok(())
}

/// Create the output folder, once the inputs are known good and something is about to
/// be written there.
pub(crate) fn out_dir(out: &std::path::Path) -> Result<(), CliError> {
    std::fs::create_dir_all(out).map_err(|source| CliError::OutDir {
        path: out.to_path_buf(),
        source,
    })
}

/// Run `f`, which creates `out`; when it fails and `out` did not exist before, remove
/// what it made: a recording found bad while being read (replay, export) leaves
/// neither an empty folder nor a half-written export.
pub(crate) fn or_remove_new(
    out: &std::path::Path,
    f: impl FnOnce() -> Result<ExitCode, CliError>,
) -> Result<ExitCode, CliError> {
    let existed = out.exists();
    let r = f();
    if r.is_err() && !existed {
        let _ = std::fs::remove_dir_all(out);
    }
    r
}

/// Write report.json, .md and .html, print the table; exit 0 when the requirements
/// are met and the estimator verified its result, else 1.
pub(crate) fn finish(
    out: &std::path::Path,
    report: &Report,
    figures: bool,
) -> Result<ExitCode, CliError> {
    out_dir(out)?;
    crate::analysis::report::write(out, report)?;
    crate::analysis::report_doc::write(report, out, figures)?;
    print!("{}", report.table());
    println!("Report: {}", out.join("report.json").display());
    Ok(if report.requirements.met && report.requirements.verified {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
