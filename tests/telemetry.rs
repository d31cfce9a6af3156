//! Telemetry: `run --record` writes a telemetry.h5 that h5py opens and that matches the
//! run's report; `replay` reproduces the live estimates bit for bit, reads a file that
//! an independent numpy/h5py simulation wrote, and rejects bad files with a clear error.
//! Needs python3 with numpy and h5py (`.ci/run` installs them).

mod support;
mod tmpdir;
use std::path::Path;
use std::process::{Command, Output};

/// `taiji-calib replay --telemetry FILE --out DIR`, to be run (or given more arguments).
fn replay(file: impl AsRef<std::ffi::OsStr>, out: impl AsRef<std::ffi::OsStr>) -> Command {
    let mut c = support::calib();
    c.args(["replay", "--telemetry"])
        .arg(file)
        .arg("--out")
        .arg(out);
    c
}

fn tool(script: &str) -> Command {
    let mut c = Command::new("python3");
    c.arg(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tools")
            .join(script),
    );
    c
}

fn ok(out: Output, what: &str) -> Output {
    assert!(
        out.status.success(),
        "{what} failed ({:?}):\n{}\n{}\n(the telemetry tests need python3 with numpy and h5py: pip install numpy h5py)",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// The estimates and σ of every IS, and the sample counts.
fn estimates(r: &serde_json::Value) -> Vec<serde_json::Value> {
    let mut v: Vec<serde_json::Value> = r["inertial_sensors"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|is| {
            ["beta", "k", "com_offset"]
                .into_iter()
                .flat_map(move |q| [is[q]["estimate"].clone(), is[q]["sigma"].clone()])
        })
        .collect();
    v.push(r["samples_used"].clone());
    v.push(r["samples_rejected"].clone());
    v
}

const SHORT: &str = r#"
name = "short-other-truth"
seed = 5
duration_s = 3000.0
[[inertial_sensor]]
com_offset_m = [0.18, -0.11, 0.004]
beta = [5.60e-8, 5.48e-8, 7.30e-8]
[[inertial_sensor]]
com_offset_m = [0.19, 0.13, -0.003]
"#;

#[test]
fn recording_opens_in_h5py_matches_the_report_and_replays_bit_for_bit() {
    let dir = support::tmp("record");
    let sc = dir.join("short.toml");
    std::fs::write(&sc, SHORT).unwrap();
    let run = ok(
        support::calib()
            .args(["run", "--record", "--seed", "9", "--scenario"])
            .arg(&sc)
            .arg("--out")
            .arg(&dir)
            .output()
            .unwrap(),
        "taiji-calib run --record",
    );
    assert!(String::from_utf8_lossy(&run.stdout).contains("Requirements met: yes"));
    let check = ok(
        tool("check_telemetry.py").arg(&dir).output().unwrap(),
        "check_telemetry.py",
    );
    assert!(String::from_utf8_lossy(&check.stdout).contains("telemetry check passed"));

    let replay_dir = dir.join("replay");
    ok(
        replay(dir.join("telemetry.h5"), &replay_dir)
            .output()
            .unwrap(),
        "taiji-calib replay",
    );
    let live = report(&dir);
    let replayed = report(&replay_dir);
    assert_eq!(replayed["mode"], "replay");
    assert_eq!(replayed["seed"], 9);
    assert_eq!(replayed["scenario"], "short-other-truth");
    assert_eq!(estimates(&live), estimates(&replayed));
    // The truth in the replayed report comes from the file's scenario attribute.
    assert_eq!(
        live["inertial_sensors"][0]["com_offset"]["truth"],
        replayed["inertial_sensors"][0]["com_offset"]["truth"]
    );
}

#[test]
fn replay_of_an_independently_simulated_h5py_file_meets_the_requirements() {
    let dir = support::tmp("external");
    let file = dir.join("external.h5");
    ok(
        tool("make_external_telemetry.py")
            .arg(&file)
            .output()
            .unwrap(),
        "make_external_telemetry.py",
    );
    // Its SRP fluctuation is white (1.1e-11 /√Hz up to Nyquist), not the f^-1/3 noise
    // the scenario declares: the estimator must notice the misfit (χ² of the common
    // mode far above 1), inflate σ, and say the result is unverified (exit 1) — while
    // still meeting the requirements.
    let out = replay(&file, &dir).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("Requirements met: yes — but the estimator marks the result UNVERIFIED")
    );
    let r = report(&dir);
    assert_eq!(r["scenario"], "external");
    assert!(r["estimator_status"]["text"]
        .as_str()
        .unwrap()
        .contains("inconsistent"));
    assert!(
        r["estimator_status"]["chi2_per_dof"]["common_mode"]
            .as_f64()
            .unwrap()
            > 3.0
    );
    assert!(r["estimator_status"]["sigma_inflation"].as_f64().unwrap() > 1.5);
    // The truths declared by the external file, recovered from its voltages and
    // star-tracker samples alone.
    for is in r["inertial_sensors"].as_array().unwrap() {
        for a in 0..3 {
            let b = &is["beta"];
            let rel = (b["estimate"][a].as_f64().unwrap() - b["truth"][a].as_f64().unwrap())
                / b["truth"][a].as_f64().unwrap();
            assert!(rel.abs() < 1e-4, "β error {rel}");
            let c = &is["com_offset"];
            let err = c["estimate"][a].as_f64().unwrap() - c["truth"][a].as_f64().unwrap();
            assert!(err.abs() < 20e-6, "r error {err}");
        }
    }
    // Without a scenario attribute the file is read against the default scenario at
    // the file's own sample rate and length.
    let bare = dir.join("bare.h5");
    ok(
        tool("make_external_telemetry.py")
            .arg(&bare)
            .args(["--no-scenario", "--duration", "6000"])
            .output()
            .unwrap(),
        "make_external_telemetry.py --no-scenario",
    );
    let out = replay(&bare, dir.join("bare")).output().unwrap();
    // (Unverified for the same reason: exit 1.)
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("Requirements met: yes"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(report(&dir.join("bare"))["duration_s"], 6000.0);
}

fn replay_error(file: &Path) -> String {
    let out = replay(file, file.with_extension("out")).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "{}: {err}", file.display());
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn bad_telemetry_files_get_a_clear_error() {
    let dir = support::tmp("bad");
    // Mis-shaped, missing, non-monotonic and invalid-scenario files from h5py.
    for (kind, expect) in [
        (
            "shape",
            "/is2/voltage has shape [30000, 6], the layout needs [30000, 3, 2]",
        ),
        ("missing", "missing dataset /star_tracker/attitude"),
        ("tick", "/tick is not strictly increasing at row 15000"),
        ("scenario", "root attribute `scenario`: `duration_s`"),
        ("time", "/time is not strictly increasing at row 10000"),
        (
            "version",
            "format_version 99 is not one this build reads (1)",
        ),
    ] {
        let f = dir.join(format!("{kind}.h5"));
        ok(
            tool("make_external_telemetry.py")
                .arg(&f)
                .args(["--duration", "3000", "--break", kind])
                .output()
                .unwrap(),
            "make_external_telemetry.py --break",
        );
        let err = replay_error(&f);
        assert!(err.contains(expect), "{kind}: {err}");
    }
    // A good file, truncated and corrupted.
    let good = dir.join("good.h5");
    ok(
        tool("make_external_telemetry.py")
            .arg(&good)
            .args(["--duration", "3000"])
            .output()
            .unwrap(),
        "make_external_telemetry.py",
    );
    let bytes = std::fs::read(&good).unwrap();
    for frac in [0.001, 0.5, 0.99] {
        let f = dir.join(format!("truncated-{frac}.h5"));
        std::fs::write(&f, &bytes[..(bytes.len() as f64 * frac) as usize]).unwrap();
        let err = replay_error(&f);
        assert!(
            err.contains("truncated") || err.contains("not a readable HDF5 file"),
            "{err}"
        );
    }
    let mut corrupt = bytes.clone();
    for b in &mut corrupt[..8] {
        *b = 0;
    }
    let f = dir.join("no-signature.h5");
    std::fs::write(&f, &corrupt).unwrap();
    assert!(replay_error(&f).contains("not a readable HDF5 file"));
    // Scrambled metadata (the object headers and heaps at the start of the file).
    let mut corrupt = bytes.clone();
    let mut x = 12345u64;
    for _ in 0..200 {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let i = 100 + (x >> 33) as usize % 3000;
        corrupt[i] ^= 0xa5;
    }
    let f = dir.join("scrambled.h5");
    std::fs::write(&f, &corrupt).unwrap();
    replay_error(&f);
    let f = dir.join("text.h5");
    std::fs::write(&f, "time,voltage\n0.1,0.2\n").unwrap();
    assert!(replay_error(&f).contains("not a readable HDF5 file"));
    assert!(replay_error(&dir.join("absent.h5")).contains("cannot read"));
}

#[test]
fn a_recording_of_the_former_hand_written_encoder_still_reads_bit_for_bit() {
    // tests/data/legacy-encoder.h5: 150 s recorded by `run --record` before libhdf5
    // wrote the files (contiguous datasets, written byte by byte). Every stream our
    // reader decodes is what h5py reads from it, bit for bit, and it replays to the
    // end. (Its samples are those of the plant of its day: the tick's SRP then took
    // the attitude at the sub-steps' ends, so a run of its scenario now differs.)
    let h5 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/legacy-encoder.h5");
    let dir = support::tmp("legacy");
    let (ours, _) = taiji::telemetry::truth::full(&h5).unwrap();
    let sets = [
        "truth/attitude",
        "truth/tm_acceleration",
        "truth/srp_acceleration",
        "star_tracker/attitude",
        "is1/voltage",
        "is2/voltage",
    ];
    let py = ok(
        Command::new("python3")
            .args([
                "-c",
                "import h5py, json, sys, numpy as np\n\
                 f = h5py.File(sys.argv[1], 'r')\n\
                 print(json.dumps([np.frombuffer(np.ascontiguousarray(f[k][()], '<f8').tobytes(), '<u8').tolist() for k in sys.argv[2:]]))",
            ])
            .arg(&h5)
            .args(sets)
            .output()
            .unwrap(),
        "reading the recording with h5py",
    );
    let theirs: Vec<Vec<u64>> = serde_json::from_slice(&py.stdout).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    let mine = [
        bits(&ours.attitude),
        bits(&ours.tm_acc),
        bits(&ours.srp_acc),
        bits(&ours.star_q),
        bits(&ours.is_volts[0]),
        bits(&ours.is_volts[1]),
    ];
    for ((name, a), b) in sets.iter().zip(&mine).zip(&theirs) {
        assert!(!a.is_empty(), "{name}: nothing read");
        assert_eq!(a, b, "{name}: our reader and h5py differ");
    }
    // It replays to the end (exit 1: a requirement missed), with its seed.
    let o = replay(&h5, dir.join("replay")).output().unwrap();
    assert!(matches!(o.status.code(), Some(0 | 1)), "{o:?}");
    assert_eq!(report(&dir.join("replay"))["seed"], 11);
}

#[test]
fn corrupted_recordings_are_refused_or_replayed_never_a_crash_a_panic_or_a_hang() {
    // A recording of ours (libhdf5's chunked SWMR layout), corrupted 60 ways: bytes
    // flipped, zeroed or randomised anywhere in the file, or the file cut.
    let dir = support::tmp("fuzz");
    let sc = dir.join("s.toml");
    std::fs::write(
        &sc,
        "name = \"fuzz\"\nduration_s = 300.0\n[maneuver]\nfrequency_hz = 1e-2\n",
    )
    .unwrap();
    let o = support::calib()
        .args(["run", "--record", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(dir.join("good"))
        .output()
        .unwrap();
    assert!(matches!(o.status.code(), Some(0 | 1)), "{o:?}");
    let good = std::fs::read(dir.join("good/telemetry.h5")).unwrap();
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: usize| {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 33) as usize % n
    };
    for case in 0..60 {
        let mut b = good.clone();
        match case % 4 {
            0 => b.truncate(next(good.len())),
            kind => {
                for _ in 0..[1, 8, 64][next(3)] {
                    let i = next(b.len());
                    b[i] = match kind {
                        1 => b[i] ^ (1 << next(8)),
                        2 => 0,
                        _ => next(256) as u8,
                    };
                }
            }
        }
        let f = dir.join(format!("c{case}.h5"));
        std::fs::write(&f, &b).unwrap();
        let mut child = replay(&f, dir.join(format!("o{case}")))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let t0 = std::time::Instant::now();
        let status = loop {
            if let Some(st) = child.try_wait().unwrap() {
                break st;
            }
            if t0.elapsed() > std::time::Duration::from_secs(60) {
                let _ = child.kill();
                panic!("case {case}: replay hung");
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        };
        let mut err = String::new();
        std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
        assert!(
            matches!(status.code(), Some(0..=2)) && !err.contains("panicked"),
            "case {case}: {status:?} {err}"
        );
    }
}

#[test]
fn files_libhdf5_crashes_or_loops_on_are_refused_saying_what_it_did() {
    // Two corrupt global heaps the telemetry fuzz target found (fuzz/known/): libhdf5
    // 1.10.8 copies past a buffer (SIGSEGV) on one and loops for ever on the other. A
    // forked child reads the file first; replay refuses it (exit 2) naming what libhdf5
    // did, and a library caller in this very process gets the same error and lives on.
    let known = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/known");
    let dir = support::tmp("libhdf5_known");
    taiji::telemetry::set_read_check_limit(std::time::Duration::from_secs(2));
    for (file, said) in [
        (
            "libhdf5_global_heap_segv.h5",
            "libhdf5 crashed (signal 11, SIGSEGV)",
        ),
        (
            "libhdf5_global_heap_loop.h5",
            "libhdf5 did not finish reading it",
        ),
    ] {
        let t0 = std::time::Instant::now();
        let o = replay(known.join(file), dir.join(file)).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{file}: {o:?}");
        assert!(
            err.contains(said) && !err.contains("panicked"),
            "{file}: {err}"
        );
        assert!(t0.elapsed() < std::time::Duration::from_secs(60), "{file}");
        for e in [
            taiji::telemetry::truth::full(&known.join(file)).err(),
            taiji::telemetry::read::open(&known.join(file)).err(),
        ] {
            assert!(
                matches!(e, Some(taiji::telemetry::TelemetryError::Hdf5Failed { .. })),
                "{file}: {e:?}"
            );
        }
    }
}

#[test]
fn a_recording_with_bus_faults_replays_bit_for_bit_faults_scored_alike() {
    // Duplicates, reorders, missing samples and garbage headers: the recording holds
    // each tick once, replay delivers them as the live bus did. Upsets at 2×10⁻³ (61 in
    // this run) hit the star tracker's valid byte too (1 → 5, say): the recording keeps
    // the byte as received, so replay rejects those samples as the live run did (it read
    // any nonzero byte as 1 once: 2 star samples fewer rejected, every estimate moved).
    let dir = support::tmp("bus");
    let sc = dir.join("bus.toml");
    std::fs::write(
        &sc,
        "name = \"bus\"\nseed = 6\nduration_s = 3000.0\n[faults]\nduplicate_rate = 3e-3\n\
         reorder_rate = 3e-3\nmissing_rate = 3e-3\ngarbage_headers = 4\nupset_rate = 2e-3\n",
    )
    .unwrap();
    let live = dir.join("live");
    let o = support::calib()
        .args(["run", "--record", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&live)
        .output()
        .unwrap();
    assert!(matches!(o.status.code(), Some(0 | 1)), "{o:?}");
    let again = dir.join("replay");
    let o = replay(live.join("telemetry.h5"), &again).output().unwrap();
    assert!(matches!(o.status.code(), Some(0 | 1)), "{o:?}");
    let (a, b) = (report(&live), report(&again));
    assert_eq!(estimates(&b), estimates(&a));
    assert_eq!(
        b["samples_rejected_by_cause"],
        a["samples_rejected_by_cause"]
    );
    let kinds = a["faults"]["by_kind"].as_object().unwrap();
    for k in ["duplicate", "reorder", "missing", "garbage_header", "upset"] {
        assert!(kinds[k]["injected"].as_u64().unwrap() > 0, "{k}: {kinds:?}");
    }
    assert_eq!(b["faults"], a["faults"]);
}

#[test]
fn the_docs_document_the_layout_the_code_writes() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/telemetry.md"))
            .unwrap();
    assert!(doc.contains(&taiji::telemetry::layout::markdown_table()));
}

/// The bits of every recorded value, truth and sensor streams alike.
fn stream_bits(t: &taiji::telemetry::Telemetry) -> Vec<Vec<u64>> {
    let f = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    let b = |v: &[u8]| v.iter().map(|&x| x as u64).collect::<Vec<u64>>();
    let mut s = vec![
        t.truth_tick.clone(),
        t.sensor_tick.clone(),
        f(&t.torque_cmd),
        f(&t.torque),
        f(&t.attitude),
        f(&t.omega),
        f(&t.omega_dot),
        f(&t.tm_acc),
        f(&t.srp_acc),
        f(&t.star_q),
        b(&t.star_valid),
    ];
    for i in 0..t.n_is {
        s.push(f(&t.is_volts[i]));
        s.push(b(&t.is_flags[i]));
    }
    s
}

/// The recorded fields of an estimate row, as bits.
fn row_bits(e: &taiji::sim::msg::EstimateMsg, n_is: usize) -> Vec<u64> {
    let mut v = vec![
        e.header.tick,
        e.solved_tick,
        e.n_used,
        e.n_rejected,
        e.status,
        e.flags & taiji::sim::msg::EST_FINAL,
    ];
    v.extend(e.rejected_by_cause);
    v.extend(e.chi2_per_dof.iter().map(|x| x.to_bits()));
    for q in [&e.beta, &e.beta_sigma, &e.k, &e.k_sigma, &e.r_b, &e.r_sigma] {
        v.extend(q[..n_is].iter().flatten().map(|x| x.to_bits()));
    }
    v
}

#[test]
fn a_recording_streamed_in_small_chunks_reads_back_identically() {
    use taiji::sim::estimate::Method;
    use taiji::telemetry::{read, Meta, Writer};
    let dir = support::tmp("chunks");
    // With `[faults]`, so that the fault log goes through the writer too.
    let s = taiji::sim::scenario::Scenario::from_toml_str(
        "name = \"chunks\"\nseed = 3\nduration_s = 3000.0\n[faults]\nupset_rate = 1e-4\n\
         star_jumps = 2\nis_dropout_rate = 0.02\nduplicate_rate = 1e-3\n",
    )
    .unwrap();
    let (live, mem) = taiji::analysis::campaign::run_recorded(&s, 3, Method::Joint, |_| {});
    assert!(!mem.faults.is_empty() && mem.estimates.len() > 20);
    // Streamed as the campaign runs, 7 rows at a time (N is not a multiple of 7).
    let path = dir.join("streamed.h5");
    let meta = Meta::of(&s, 3, "joint", "in-process");
    let mut w = Writer::create(&path, &meta, s.n_samples(), 7).unwrap();
    let res = taiji::analysis::campaign::run_into(&s, 3, Method::Joint, |_| {}, &mut w).unwrap();
    let sc = res.faults.unwrap();
    w.finish(&sc.records, &sc.detected).unwrap();
    assert_eq!(
        row_bits(&res.estimate, 2),
        row_bits(&live.estimate, 2),
        "recording changed the estimate"
    );
    // Read back in windows of 5 rows: every stream, estimate row and fault, bit for bit.
    let (back, _) = taiji::telemetry::truth::full(&path).unwrap();
    assert_eq!(stream_bits(&back), stream_bits(&mem));
    let rows = |t: &taiji::telemetry::Telemetry| -> Vec<Vec<u64>> {
        t.estimates.iter().map(|e| row_bits(e, 2)).collect()
    };
    assert_eq!(rows(&back), rows(&mem));
    let faults = |t: &taiji::telemetry::Telemetry| -> Vec<[u64; 8]> {
        t.faults
            .iter()
            .map(|r| {
                let (a, b, c) = (r.before.to_bits(), r.after.to_bits(), r.sigmas.to_bits());
                [
                    r.tick,
                    r.kind as u64,
                    r.field as u64,
                    r.bit as u64,
                    r.samples as u64,
                    a,
                    b,
                    c,
                ]
            })
            .collect()
    };
    assert_eq!(faults(&back), faults(&mem));
    assert_eq!(back.faults_detected, mem.faults_detected);
    // The in-memory writer makes the same recording (its chunks are another size).
    let whole = dir.join("whole.h5");
    mem.write(&whole, &meta).unwrap();
    let (again, _) = taiji::telemetry::truth::full(&whole).unwrap();
    assert_eq!(stream_bits(&again), stream_bits(&back));
    assert_eq!(rows(&again), rows(&back));
    assert_eq!(faults(&again), faults(&back));
    let mut rec = read::open(&path).unwrap();
    rec.chunk_rows = 5;
    let samples: Vec<_> = rec.samples().map(Result::unwrap).collect();
    assert_eq!(samples.len() as u64, s.n_samples());
    assert!(samples
        .iter()
        .enumerate()
        .all(|(k, x)| x.header.tick == k as u64));
}

#[test]
fn replay_reading_in_small_windows_matches_the_live_run_bit_for_bit() {
    use taiji::sim::estimate::Method;
    let dir = support::tmp("windows");
    let s = taiji::sim::scenario::Scenario::from_toml_str(SHORT).unwrap();
    let (live, mem) = taiji::analysis::campaign::run_recorded(&s, 9, Method::Joint, |_| {});
    let path = dir.join("telemetry.h5");
    mem.write(
        &path,
        &taiji::telemetry::Meta::of(&s, 9, "joint", "in-process"),
    )
    .unwrap();
    let live_rows: Vec<Vec<u64>> = mem.estimates.iter().map(|e| row_bits(e, 2)).collect();
    for window in [1, 5, 4096] {
        let mut rec = taiji::telemetry::read::open(&path).unwrap();
        rec.chunk_rows = window;
        let mut rows = Vec::new();
        let r = taiji::analysis::replay::run_with_rows(
            &rec,
            Method::Joint,
            |_| {},
            |e| rows.push(row_bits(e, 2)),
        )
        .unwrap();
        assert_eq!(row_bits(&r.estimate, 2), row_bits(&live.estimate, 2));
        assert_eq!(rows, live_rows, "window of {window} rows");
    }
}

#[test]
fn a_recording_cut_short_keeps_every_written_chunk_and_opens_in_h5py() {
    use taiji::sim::msg::{Header, SensorSample, TruthState};
    let dir = support::tmp("crash");
    let s = taiji::sim::scenario::Scenario::from_toml_str(SHORT).unwrap();
    let path = dir.join("telemetry.h5");
    let meta = taiji::telemetry::Meta::of(&s, 9, "joint", "in-process");
    let mut w = taiji::telemetry::Writer::create(&path, &meta, s.n_samples(), 7).unwrap();
    for k in 0..20u64 {
        let header = Header::at(k, k, s.sample_rate_hz);
        let t = TruthState {
            header,
            omega_b: [k as f64; 3],
            ..Default::default()
        };
        let x = SensorSample {
            header,
            ..Default::default()
        };
        w.record(&t, &x).unwrap();
    }
    // The writer dies (no finish): the two full chunks are in the file, the third lost.
    // Its file is still marked open for SWMR writing: h5py opens it as an SWMR reader.
    std::mem::forget(w);
    let out = ok(
        Command::new("python3")
            .args([
                "-c",
                "import sys, h5py\nf = h5py.File(sys.argv[1], 'r', swmr=True)\n\
                 print(f['time'].shape, f['is2/voltage'].shape, f['truth/angular_velocity'][13, 0],\
                 f['estimate/beta'].shape)",
            ])
            .arg(&path)
            .output()
            .unwrap(),
        "h5py on a recording cut short",
    );
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        "(14,) (14, 3, 2) 13.0 (0, 2, 3)"
    );
    // Replay says so, and refuses it only when asked for a whole recording.
    let said = "a truncated recording: 14 of 30000 samples, the last at tick 13";
    let run = |extra: &[&str]| {
        replay(&path, dir.join(format!("replay{}", extra.len())))
            .args(extra)
            .output()
            .unwrap()
    };
    let whole = run(&["--complete"]);
    let err = String::from_utf8_lossy(&whole.stderr);
    assert_eq!(whole.status.code(), Some(2), "{err}");
    assert!(err.contains(said) && err.contains("--complete"), "{err}");
    let part = run(&[]);
    let err = String::from_utf8_lossy(&part.stderr);
    assert!(matches!(part.status.code(), Some(0 | 1)), "{err}");
    assert!(err.contains(said), "{err}");
}
