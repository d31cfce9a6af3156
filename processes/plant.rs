//! `taiji-plant`: wiring only — see `taiji::runtime::process::plant`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-plant",
    version,
    about = "Calibration process set: the plant stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::runtime::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::runtime::process::main_of("taiji-plant", || {
        taiji::runtime::process::plant::run(&args.stage)
    })
}
