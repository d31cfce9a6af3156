//! Helpers every integration test shares: the CLI binary as a command, a test's
//! temporary folder named after its test file, and a scenario file written into it.
//! Each test file takes what it needs (`mod support;` beside `mod tmpdir;`).
#![allow(dead_code)]

use crate::tmpdir::TmpDir;
use std::path::{Path, PathBuf};
use std::process::Command;

/// `taiji-calib`, the binary under test, as a command to give arguments to.
pub fn calib() -> Command {
    Command::new(env!("CARGO_BIN_EXE_taiji-calib"))
}

/// A fresh temporary folder `taiji-<test file>-<name>-<pid>`, removed on drop.
pub fn tmp(name: &str) -> TmpDir {
    TmpDir::new(&format!("{}-{name}", env!("CARGO_CRATE_NAME")))
}

/// `text` written as `dir/scenario.toml`; its path.
pub fn write_scenario(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("scenario.toml");
    std::fs::write(&p, text).unwrap();
    p
}
