//! `taiji-fee`: wiring only — see `taiji::runtime::process::fee`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-fee",
    version,
    about = "Calibration process set: the fee stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::runtime::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::runtime::process::main_of("taiji-fee", || {
        taiji::runtime::process::fee::run(&args.stage)
    })
}
