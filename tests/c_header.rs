//! `include/taiji_estimator.h` is generated from the Rust sources by cbindgen and must
//! match them: a stale header would let a C host misread the messages. Regenerate with
//! `TAIJI_BLESS=1 cargo test --release --test c_header`.

use std::path::Path;

fn generate() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(root.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut out = Vec::new();
    cbindgen::Builder::new()
        .with_config(config)
        .with_src(root.join("crates/taiji-core/src/capi.rs"))
        .with_src(root.join("crates/taiji-core/src/msg.rs"))
        .with_src(root.join("crates/taiji-core/src/estimate/config.rs"))
        // The set's own messages (truth, progress, control), for outside bus clients.
        .with_src(root.join("src/sim/msg.rs"))
        .generate()
        .expect("cbindgen parses the C ABI")
        .write(&mut out);
    String::from_utf8(out).expect("utf-8 header")
}

#[test]
fn c_header_is_up_to_date() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("include/taiji_estimator.h");
    let fresh = generate();
    if std::env::var_os("TAIJI_BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write the header");
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == fresh,
        "include/taiji_estimator.h is stale: regenerate it with \
         TAIJI_BLESS=1 cargo test --release --test c_header"
    );
}

#[test]
fn c_header_declares_the_whole_abi() {
    let h = generate();
    for f in [
        "taiji_estimator_size",
        "taiji_estimator_align",
        "taiji_estimator_init",
        "taiji_estimator_update",
        "taiji_estimator_solve",
        "taiji_estimator_estimate",
        "taiji_estimator_finish",
        "taiji_estimator_checkpoint",
        "taiji_estimator_restore",
        "taiji_layout_version",
        "TaijiSensorSample",
        "TaijiEstimateMsg",
        "TaijiEstimatorConfig",
        "TAIJI_LAYOUT_VERSION",
    ] {
        assert!(h.contains(f), "header lacks {f}");
    }
}
