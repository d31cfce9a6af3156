//! `taiji-tmtc`: wiring only — see `taiji::runtime::process::tmtc`.
use clap::Parser;

#[derive(Parser)]
#[command(
    name = "taiji-tmtc",
    version,
    about = "Calibration process set: the ground link (CCSDS space packets, PUS services, over UDP)"
)]
struct Args {
    #[command(flatten)]
    tmtc: taiji::runtime::process::tmtc::TmtcArgs,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    taiji::runtime::process::main_of("taiji-tmtc", || {
        taiji::runtime::process::tmtc::run(&args.tmtc)
    })
}

/// Count every heap allocation, so the loop can report (and a test can check) that it
/// made none after its warm-up.
#[global_allocator]
static ALLOC: taiji::bus::alloc_count::CountingAlloc = taiji::bus::alloc_count::CountingAlloc;
