//! `taiji-commander`: wiring only — see `taiji::process::commander`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-commander",
    version,
    about = "Calibration process set: the commander stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::process::main_of("taiji-commander", || {
        taiji::process::commander::run(&args.stage)
    })
}
