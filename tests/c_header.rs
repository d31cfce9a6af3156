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

/// The sizes the header's MEMORY paragraph states, as the library reports them: each
/// marker in cbindgen.toml is followed by its number in parentheses.
fn sizes() -> [(&'static str, usize); 4] {
    use taiji_core::capi::{taiji_checkpoint_size, taiji_estimator_size, taiji_solve_work_size};
    let (state, work) = (taiji_estimator_size(), taiji_solve_work_size());
    [
        ("taiji_estimator_size() bytes (", state),
        ("taiji_checkpoint_size() bytes (", taiji_checkpoint_size()),
        ("taiji_solve_work_size() bytes (", work),
        ("In all (", state + work),
    ]
}

/// `n` as the header writes it: thousands apart by a space.
fn spaced(n: usize) -> String {
    let d = n.to_string();
    let mut out = String::new();
    for (i, c) in d.chars().enumerate() {
        if i > 0 && (d.len() - i) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// cbindgen.toml with every stated size set to the library's.
fn with_sizes(config: &str) -> String {
    let mut s = config.to_string();
    for (marker, n) in sizes() {
        let at = s
            .find(marker)
            .unwrap_or_else(|| panic!("cbindgen.toml lacks {marker:?}"))
            + marker.len();
        let end = at + s[at..].find(')').expect("a closing parenthesis");
        s.replace_range(at..end, &spaced(n));
    }
    s
}

#[test]
fn the_header_states_the_librarys_sizes() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cbindgen.toml");
    let config = std::fs::read_to_string(&path).unwrap();
    let fresh = with_sizes(&config);
    if std::env::var_os("TAIJI_BLESS").is_some() && fresh != config {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    assert!(
        fresh == config,
        "cbindgen.toml states other sizes than the library's {:?}: \
         TAIJI_BLESS=1 cargo test --release --test c_header (twice: the sizes, then the header)",
        sizes()
    );
    assert_eq!(spaced(62_848), "62 848");
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
