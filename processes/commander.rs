//! `taiji-commander`: wiring only — see `taiji::runtime::process::commander`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-commander",
    version,
    about = "Calibration process set: the commander stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::runtime::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::runtime::process::main_of("taiji-commander", || {
        taiji::runtime::process::commander::run(&args.stage)
    })
}
