//! `taiji-supervisor`: wiring only — see `taiji::runtime::process::supervisor`.
use clap::Parser;
use taiji::runtime::process::supervisor::{report_dir, run, write_reports, Outcome, SupervisorArgs};

fn main() -> std::process::ExitCode {
    taiji::runtime::process::init_logging();
    let mut args = SupervisorArgs::parse();
    if let Some(format) = args.graph {
        print!("{}", taiji::bus::topology::graph(format));
        return std::process::ExitCode::SUCCESS;
    }
    args.record |= args.plots;
    if args.ground.is_some() {
        return std::process::ExitCode::from(taiji::runtime::process::supervisor::ground::run(&args));
    }
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

