//! `taiji-tunnel`: wiring only — see `taiji::tunnel`.
use clap::Parser;

fn main() -> std::process::ExitCode {
    taiji::process::init_logging();
    let args = taiji::tunnel::TunnelArgs::parse();
    match taiji::tunnel::run(&args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("taiji-tunnel: error: {e}");
            std::process::ExitCode::from(2)
        }
    }
}
