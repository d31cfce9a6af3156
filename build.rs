//! One hash of the flight core's sources (crates/taiji-core/src), so that the plan
//! cache (src/analysis/plan/cache.rs) never reuses a plan made by another build of the estimator.

use std::path::{Path, PathBuf};

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn main() {
    let root = Path::new("crates/taiji-core/src");
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files = Vec::new();
    sources(root, &mut files);
    files.sort();
    // FNV-1a 64 over every file's path and bytes, in path order.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for f in &files {
        let bytes = std::fs::read(f).unwrap_or_default();
        for b in f.to_string_lossy().as_bytes().iter().chain(&bytes) {
            h = (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    println!("cargo:rustc-env=TAIJI_CORE_SOURCE_HASH={h:016x}");
}
