//! `taiji-supervisor`: wiring only — see `taiji::runtime::process::supervisor`.
use clap::Parser;
use taiji::runtime::process::supervisor::{run, Outcome, SupervisorArgs};

fn main() -> std::process::ExitCode {
    taiji::runtime::process::init_logging();
    let mut args = SupervisorArgs::parse();
    if let Some(format) = args.graph {
        print!("{}", taiji::bus::topology::graph(format));
        return std::process::ExitCode::SUCCESS;
    }
    args.record |= args.plots;
    let outcome = run(&args);
    match &outcome {
        Outcome::Completed { report, .. } => {
            if let Err(e) = write_reports(&args, report) {
                eprintln!("taiji-supervisor: error: {e}");
                return std::process::ExitCode::from(2);
            }
            print!("{}", report.table());
            println!(
                "Report: {}",
                report_dir(&args).join("report.json").display()
            );
            if args.record {
                println!(
                    "Telemetry: {}",
                    args.out
                        .join(taiji::runtime::process::recorder::TELEMETRY_FILE)
                        .display()
                );
            }
        }
        Outcome::UserError(e) => eprintln!("taiji-supervisor: error: {e}"),
        Outcome::SetFailed(e) => eprintln!("taiji-supervisor: the process set failed: {e}"),
        Outcome::Interrupted => eprintln!("taiji-supervisor: interrupted; every process stopped"),
        Outcome::HostStopped(m) => println!("taiji-supervisor: {m}"),
    }
    std::process::ExitCode::from(outcome.exit_code())
}

/// Why the reports of a completed run could not be written (exit 2).
#[derive(Debug, thiserror::Error)]
enum ReportsError {
    #[error(transparent)]
    Report(#[from] taiji::analysis::report::ReportError),
    /// The recording could not be read back for the figures.
    #[error(transparent)]
    Telemetry(#[from] taiji::telemetry::TelemetryError),
    #[error(transparent)]
    Plot(#[from] taiji::analysis::plots::PlotError),
}

/// report.json, report.md, report.html, and the figures from the recording.
fn write_reports(
    args: &SupervisorArgs,
    report: &taiji::analysis::report::Report,
) -> Result<(), ReportsError> {
    let dir = report_dir(args);
    taiji::analysis::report::write(dir, report)?;
    // The figures live beside the recording; report.html links them only from there.
    let plots = args.plots && dir == args.out;
    if plots {
        let path = args
            .out
            .join(taiji::runtime::process::recorder::TELEMETRY_FILE);
        let (tel, s) = taiji::telemetry::truth::full(&path)?;
        taiji::analysis::plots::write_all(&tel, &s, &args.out)?;
    }
    Ok(taiji::analysis::report_doc::write(report, dir, plots)?)
}

/// Where the reports go: `--report-dir`, else `--out`.
fn report_dir(args: &SupervisorArgs) -> &std::path::Path {
    args.report_dir.as_deref().unwrap_or(&args.out)
}
