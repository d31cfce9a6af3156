//! The link-time proof that no panic is reachable from the C ABI (`tools/panic-proof`),
//! and its negative test: with a deliberately reachable panic the same link fails.

use std::path::Path;
use std::process::Command;

fn proof(args: &[&str]) -> std::process::Output {
    Command::new(Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/panic-proof"))
        .args(args)
        .output()
        .expect("tools/panic-proof runs")
}

#[test]
fn no_panic_is_reachable_from_the_c_abi() {
    let out = proof(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("no panic is reachable"));
}

#[test]
fn the_proof_fails_on_a_deliberately_reachable_panic() {
    let out = proof(&["--probe"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("undefined reference to `taiji_a_panic_is_reachable'"),
        "{stderr}"
    );
    assert!(
        stderr.contains("a panic is reachable from the C ABI"),
        "{stderr}"
    );
}
