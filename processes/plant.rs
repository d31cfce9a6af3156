//! `taiji-plant`: wiring only — see `taiji::process::plant`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-plant",
    version,
    about = "Calibration process set: the plant stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::process::main_of("taiji-plant", || taiji::process::plant::run(&args.stage))
}
