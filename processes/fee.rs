//! `taiji-fee`: wiring only — see `taiji::process::fee`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-fee",
    version,
    about = "Calibration process set: the fee stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::process::main_of("taiji-fee", || taiji::process::fee::run(&args.stage))
}
