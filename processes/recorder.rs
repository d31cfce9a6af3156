//! `taiji-recorder`: wiring only — see `taiji::runtime::process::recorder`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-recorder",
    version,
    about = "Calibration process set: records every stream to telemetry.h5"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::runtime::process::StageArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::runtime::process::main_of("taiji-recorder", || {
        taiji::runtime::process::recorder::run(&args.stage)
    })
}
