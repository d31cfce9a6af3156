//! `taiji-supervisor`: wiring only — see `taiji::process::supervisor`.
use clap::Parser;
use taiji::process::supervisor::{run, Outcome, SupervisorArgs};

fn main() -> std::process::ExitCode {
    taiji::process::init_logging();
    let args = SupervisorArgs::parse();
    let outcome = run(&args);
    match &outcome {
        Outcome::Completed { report, .. } => {
            if let Err(e) = taiji::report::write(&args.out, report) {
                eprintln!("taiji-supervisor: error: {e}");
                return std::process::ExitCode::from(2);
            }
            print!("{}", report.table());
            println!("Report: {}", args.out.join("report.json").display());
            if args.record {
                println!(
                    "Telemetry: {}",
                    args.out
                        .join(taiji::process::recorder::TELEMETRY_FILE)
                        .display()
                );
            }
        }
        Outcome::UserError(e) => eprintln!("taiji-supervisor: error: {e}"),
        Outcome::SetFailed(e) => eprintln!("taiji-supervisor: the process set failed: {e}"),
        Outcome::Interrupted => eprintln!("taiji-supervisor: interrupted; every process stopped"),
    }
    std::process::ExitCode::from(outcome.exit_code())
}
