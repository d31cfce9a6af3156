//! A test's temporary folder, removed when the test ends, also when it fails: the suite
//! runs on every change, and folders named after the pid would otherwise pile up in
//! /tmp (309 MB per run before this guard). `tools/test` checks that nothing is left.
//!
//! `TAIJI_KEEP_TMP=1` keeps the folder of a failing test for a post-mortem; the failure
//! output says which folder, and that the variable exists.

use std::ffi::OsStr;
use std::ops::Deref;
use std::path::{Path, PathBuf};

/// `$TMPDIR/taiji-<name>-<pid>`, empty at the start, removed on drop.
pub struct TmpDir(PathBuf);

impl TmpDir {
    /// A fresh, empty folder (a leftover of the same name is removed first).
    pub fn new(name: &str) -> TmpDir {
        let d = std::env::temp_dir().join(format!("taiji-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        TmpDir(d)
    }

    /// The path, no longer removed on drop (a folder shared by the tests of a file,
    /// which removes it itself at exit).
    #[allow(dead_code)]
    pub fn keep(self) -> PathBuf {
        let d = self.0.clone();
        std::mem::forget(self);
        d
    }
}

impl Deref for TmpDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for TmpDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<OsStr> for TmpDir {
    fn as_ref(&self) -> &OsStr {
        self.0.as_os_str()
    }
}

impl Drop for TmpDir {
    fn drop(&mut self) {
        // A failing test unwinds through here: its folder may be what explains it.
        if std::thread::panicking() {
            if std::env::var_os("TAIJI_KEEP_TMP").is_some_and(|v| v == "1") {
                eprintln!("kept {} (TAIJI_KEEP_TMP=1)", self.0.display());
                return;
            }
            eprintln!(
                "removed {}; run with TAIJI_KEEP_TMP=1 to keep a failing test's folder",
                self.0.display()
            );
        }
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
