//! What the fuzz targets share.

use std::path::PathBuf;

/// This process's own scratch folder for target `tag`: under `TAIJI_FUZZ_TMP` (the
/// run's folder, which tools/fuzz removes at the end), else under /dev/shm (tmpfs: the
/// targets write a file for every input), else the system's temporary folder. One per
/// process, so parallel jobs never share a file.
pub fn scratch(tag: &str) -> PathBuf {
    let base = match std::env::var_os("TAIJI_FUZZ_TMP") {
        Some(d) => PathBuf::from(d),
        None if std::path::Path::new("/dev/shm").is_dir() => PathBuf::from("/dev/shm"),
        None => std::env::temp_dir(),
    };
    let d = base.join(format!("taiji-fuzz-{tag}-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&d) {
        panic!("cannot create the scratch folder {}: {e}", d.display());
    }
    d
}
