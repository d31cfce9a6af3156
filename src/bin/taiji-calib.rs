//! `taiji-calib`: the command line (src/cli/).

fn main() -> std::process::ExitCode {
    taiji::cli::main()
}
