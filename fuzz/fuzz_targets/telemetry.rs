//! The telemetry reader (src/telemetry/read.rs) on mutated HDF5 files, as `replay` and
//! the report read them: each input is written to a file in this process's own folder
//! (tmpfs when there is one), opened with `read::open`, and everything a user reads is
//! read — the scenario, seed, method, fault log, row counts, truncation and every
//! sample — then the truth streams and the fault log (`truth::full`,
//! `truth::fault_log`). Each must give a value or an error with a message.
//!
//! libhdf5 is C and not instrumented for coverage. The reader's documented defences
//! are part of what is tested: it has a forked child make the same reads first and
//! refuses a file the child crashed or hung on (`telemetry::isolate`; the
//! child's limit is cut to 2 s here), and it catches a panic of the HDF5 binding
//! (`read::guarded`). A crash, hang or panic that gets past them — in this process —
//! is a finding.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::cell::RefCell;
use std::path::PathBuf;
use std::sync::OnceLock;
use taiji::telemetry::{read, truth};

fn file() -> &'static PathBuf {
    static FILE: OnceLock<PathBuf> = OnceLock::new();
    FILE.get_or_init(|| taiji_fuzz::scratch("telemetry").join("telemetry.h5"))
}

thread_local! {
    /// The last panic's message and place (a panic the reader catches leaves it here).
    static LAST_PANIC: RefCell<String> = const { RefCell::new(String::new()) };
}

fn read_everything(path: &std::path::Path) {
    match read::open(path) {
        Ok(rec) => {
            let _ = rec.scenario.n_samples();
            let _ = (rec.seed, rec.method.as_deref(), rec.faults.len());
            assert!(rec.n > 0 && rec.n <= rec.expected.max(rec.n));
            let _ = rec.truncation();
            let mut k = 0u64;
            for s in rec.samples() {
                match s {
                    Ok(_) => k += 1,
                    Err(e) => {
                        assert!(!e.to_string().is_empty());
                        break;
                    }
                }
                assert!(k <= rec.n, "more samples than the recording's rows");
            }
            let _ = rec.truncation();
        }
        Err(e) => assert!(!e.to_string().is_empty(), "an error without a message"),
    }
    match truth::fault_log(path) {
        Ok((recs, det)) => assert!(det.is_empty() || det.len() == recs.len()),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
    if let Err(e) = truth::full(path) {
        assert!(!e.to_string().is_empty());
    }
}

fuzz_target!(
    init: {
        taiji::telemetry::set_read_check_limit(std::time::Duration::from_secs(2));
        // libfuzzer-sys aborts on every panic, caught or not; the reader's own
        // catch_unwind is part of what is tested, so panics unwind here and only one
        // that escapes the reader aborts (below).
        std::panic::set_hook(Box::new(|info| {
            let msg = format!("{info}");
            LAST_PANIC.with(|p| *p.borrow_mut() = msg);
        }));
    },
    |data: &[u8]| {
        let path = file();
        std::fs::write(path, data).expect("the input written to its file");
        let r = std::panic::catch_unwind(|| read_everything(path));
        if r.is_err() {
            LAST_PANIC.with(|p| eprintln!("panic that escaped the telemetry reader: {}", p.borrow()));
            std::process::abort();
        }
    }
);
