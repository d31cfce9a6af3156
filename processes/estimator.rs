//! `taiji-estimator`: wiring only — see `taiji::runtime::process::estimator`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-estimator",
    version,
    about = "Calibration process set: the estimator stage"
)]
struct Args {
    #[command(flatten)]
    stage: taiji::runtime::process::estimator::EstimatorArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::runtime::process::main_of("taiji-estimator", || {
        taiji::runtime::process::estimator::run(&args.stage)
    })
}

/// Count every heap allocation, so the filter loop can report (and a test can check)
/// that it made none.
#[global_allocator]
static ALLOC: taiji::bus::alloc_count::CountingAlloc = taiji::bus::alloc_count::CountingAlloc;
