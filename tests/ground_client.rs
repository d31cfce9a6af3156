//! `taiji-calib ground`, the real binary, against a fake onboard end (tests/fake_onboard):
//! every subcommand sends its telecommand, signed, with the wire format TMTC fixes, and
//! ends at its reports with its exit code (0 done, 1 a failure report named from the
//! dictionary, 2 bad arguments or key, 3 no answer); the key's sequence counter never
//! gives one number twice, also to clients run at once; a key others can read is
//! refused; `listen` claims the telemetry with keepalive pings, ends on SIGTERM, and
//! what `--save` wrote decodes again.

mod fake_onboard;
mod support;
mod tmpdir;

use fake_onboard::{Behaviour, Fake};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};
use support::{calib, tmp};
use taiji::ground::auth::Key;
use taiji::ground::client::saved;
use taiji::ground::describe::describe;
use taiji::ground::dictionary::Failure;

fn key(dir: &Path) -> (PathBuf, Key) {
    let p = dir.join("ground.key");
    let k = Key::create(&p).unwrap();
    (p, k)
}

fn ground(fake: &Fake, key: &Path, args: &[&str]) -> Output {
    calib()
        .arg("ground")
        .args(args)
        .args(["--to", &fake.to(), "--key"])
        .arg(key)
        .args(["--timeout", "5"])
        .output()
        .unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Arguments, service, subtype, application data, a line stdout must hold.
type Case<'a> = (Vec<&'a str>, u8, u8, Vec<u8>, &'a str);

fn be(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

#[test]
fn each_subcommand_sends_its_telecommand_and_ends_at_its_reports() {
    let dir = tmp("each");
    let (kp, k) = key(&dir);
    let fake = Fake::start(
        k,
        Behaviour {
            check_replay: true,
            ..Default::default()
        },
    );
    let start = be(&[&[0, 1], &42u64.to_be_bytes(), &600.5f64.to_be_bytes()]);
    let set = be(&[
        &[2, 0, 1],
        &500u32.to_be_bytes(),
        &[0, 4],
        &1e5f64.to_be_bytes(),
    ]);
    let cases: Vec<Case> = vec![
        (vec!["ping"], 17, 1, vec![], "connection test report"),
        (
            vec!["start", "--seed", "42", "--duration", "600.5"],
            8,
            1,
            start,
            "start ok",
        ),
        (vec!["stop"], 8, 1, vec![0, 2], "completion ok"),
        (vec!["apply"], 8, 1, vec![0, 3], "completion ok"),
        (vec!["restore"], 8, 1, vec![0, 4], "completion ok"),
        (vec!["shutdown"], 8, 1, vec![0, 5], "completion ok"),
        (
            vec!["hk-enable", "1", "2"],
            3,
            5,
            vec![2, 0, 1, 0, 2],
            "completion ok",
        ),
        (
            vec!["hk-disable", "2"],
            3,
            6,
            vec![1, 0, 2],
            "completion ok",
        ),
        (
            vec!["hk-interval", "2", "250"],
            3,
            31,
            vec![1, 0, 2, 0, 0, 0, 250],
            "completion ok",
        ),
        (
            vec!["hk-now", "estimate", "2"],
            3,
            27,
            vec![2, 0, 1, 0, 2],
            "housekeeping 2 (health)",
        ),
        (
            vec!["event-enable", "mode_changed", "8"],
            5,
            5,
            vec![2, 0, 1, 0, 8],
            "completion ok",
        ),
        (
            vec!["event-disable", "tc_refused"],
            5,
            6,
            vec![1, 0, 8],
            "completion ok",
        ),
        (
            vec!["get", "hk1_interval_ms", "47"],
            20,
            1,
            vec![2, 0, 1, 0, 47],
            "parameters: hk1_interval_ms=1000 ms, table_valid=1",
        ),
        (
            vec!["set", "hk1_interval_ms=500", "start_max_duration_s=1e5"],
            20,
            3,
            set,
            "completion ok",
        ),
    ];
    let mut seqs = Vec::new();
    for (args, service, subtype, app, want) in &cases {
        let o = ground(&fake, &kp, args);
        let (out, err) = (text(&o.stdout), text(&o.stderr));
        assert_eq!(o.status.code(), Some(0), "{args:?}\n{out}\n{err}");
        assert!(out.contains(want), "{args:?}: {want:?} not in\n{out}");
        assert!(out.contains("1,1 #"), "{args:?}: no acceptance\n{out}");
        // The completion report ends it; a start's, its start report (the campaign runs).
        let is_start = args[0] == "start";
        let (end, ack) = if is_start {
            ("1,3 #", 0b0011)
        } else {
            ("1,7 #", 0xF)
        };
        let last = out.lines().last().unwrap_or_default();
        assert!(last.contains(end), "{args:?}: {end} ends it\n{out}");
        let heard = fake.heard();
        let h = heard.last().unwrap();
        assert!(h.mac_ok, "{args:?}");
        assert_eq!(
            (h.service, h.subtype, h.ack),
            (*service, *subtype, ack),
            "{args:?}"
        );
        assert_eq!(&h.app_data, app, "{args:?}");
        assert!(h.from.ip().is_loopback());
        // Before any other telecommand, a ping from the same socket claims the reports.
        if *service != 17 {
            let claim = &heard[heard.len() - 2];
            assert_eq!(
                (claim.service, claim.subtype, claim.ack),
                (17, 1, 0),
                "{args:?}"
            );
            assert_eq!((claim.from, claim.seq + 1), (h.from, h.seq), "{args:?}");
            assert!(out.lines().next().unwrap().contains("17,2 #"), "{out}");
            seqs.push(claim.seq);
        }
        seqs.push(h.seq);
    }
    assert_eq!(fake.heard().len(), seqs.len());

    // One sequence number after the other, from the counter beside the key.
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    let counter = std::fs::read_to_string(dir.join("ground.key.seq")).unwrap();
    assert_eq!(
        counter.trim().parse::<u32>().unwrap(),
        *seqs.last().unwrap()
    );

    // JSON lines: each one a packet; the pong among them.
    let o = calib()
        .args(["ground", "ping", "--json", "--to", &fake.to(), "--key"])
        .arg(&kp)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    let lines: Vec<serde_json::Value> = text(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(lines.iter().any(|v| v["report"] == "connection_test"));
    assert!(lines.iter().all(|v| v["service"].is_u64()));
    // Without a completion flag, the acceptance and the data reply end it.
    let o = ground(&fake, &kp, &["get", "1", "--ack", "acceptance"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("parameters: hk1_interval_ms=1000 ms"));
    assert!(!out.contains("1,7"), "{out}");
    assert_eq!(fake.heard().last().unwrap().ack, 1);
}

#[test]
fn failure_reports_exit_1_naming_the_failure_and_silence_exits_3() {
    let dir = tmp("fail");
    let (kp, k) = key(&dir);
    let fake = Fake::start(
        k,
        Behaviour {
            check_replay: true,
            apply_fails: Some(Failure::UnverifiedResult),
            ..Default::default()
        },
    );
    let o = ground(&fake, &kp, &["apply"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("failed at completion: failure 24 unverified_result: function 3 on a result its report does not call verified"),
        "{err}"
    );
    assert!(text(&o.stdout).contains("completion FAILED"));
    // A replayed sequence number.
    assert_eq!(ground(&fake, &kp, &["ping"]).status.code(), Some(0));
    let o = ground(&fake, &kp, &["ping", "--seq", "5"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("failed at acceptance: failure 12 replayed"));
    // The counter still runs past the last number it gave (and past --seq's).
    assert_eq!(ground(&fake, &kp, &["ping"]).status.code(), Some(0));

    // Another key: the set answers bad_mac.
    let other = dir.join("other.key");
    Key::create(&other).unwrap();
    let o = ground(&fake, &other, &["ping"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains(
            "failure 11 bad_mac: the authentication code does not match the packet and key"
        ),
        "{}",
        text(&o.stderr)
    );
    drop(fake);

    // Nothing answers: exit 3 after the timeout; nothing listens: exit 3 at once.
    let silent = Fake::start(
        Key::load(&kp).unwrap(),
        Behaviour {
            silent: true,
            ..Default::default()
        },
    );
    let t0 = Instant::now();
    let o = calib()
        .args([
            "ground",
            "ping",
            "--timeout",
            "0.5",
            "--to",
            &silent.to(),
            "--key",
        ])
        .arg(&kp)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3));
    assert!(t0.elapsed() >= Duration::from_millis(500));
    assert!(
        text(&o.stderr).contains("nothing heard from"),
        "{}",
        text(&o.stderr)
    );
    let addr = silent.to();
    drop(silent);
    let o = calib()
        .args(["ground", "stop", "--to", &addr, "--key"])
        .arg(&kp)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3));
    assert!(
        text(&o.stderr).contains("nothing listens on"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn bad_arguments_and_a_key_others_can_read_exit_2_sending_nothing() {
    let dir = tmp("args");
    let (kp, k) = key(&dir);
    let fake = Fake::start(k, Behaviour::default());
    std::fs::set_permissions(&kp, std::fs::Permissions::from_mode(0o644)).unwrap();
    let o = ground(&fake, &kp, &["ping"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--key: key file")
            && err.contains("is readable by group or others (mode 0644): chmod 600 it"),
        "{err}"
    );
    std::fs::set_permissions(&kp, std::fs::Permissions::from_mode(0o600)).unwrap();
    for (args, want) in [
        (&["get", "no_such"][..], "no parameter \"no_such\""),
        (&["set", "hk1_interval_ms"][..], "expected NAME_OR_ID=VALUE"),
        (&["set", "hk1_interval_ms=-3"][..], "is not a u32 value"),
        (&["event-enable", "99"][..], "no event \"99\""),
        (&["hk-now", "estimates"][..], "is no housekeeping structure"),
        (&["ping", "--ack", "none"][..], ""),
        (
            &["stop", "--ack", "none"][..],
            "nothing would end the exchange",
        ),
        (&["ping", "--ack", "sometimes"][..], "expected all, none"),
        (&["hk-enable"][..], "required"),
    ] {
        let o = ground(&fake, &kp, args);
        if want.is_empty() {
            // No reports asked for: the pong alone ends a ping.
            assert_eq!(o.status.code(), Some(0), "{args:?}: {}", text(&o.stderr));
            continue;
        }
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(
            text(&o.stderr).contains(want),
            "{args:?}: {}",
            text(&o.stderr)
        );
    }
    let o = calib()
        .args(["ground", "ping", "--to", &fake.to()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--key"));
    let o = calib()
        .args(["ground", "ping", "--timeout=-1", "--key"])
        .arg(&kp)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--timeout: must be seconds ≥ 0, not -1"));
    // Only the ping without reports reached the set.
    let heard = fake.heard();
    assert_eq!(heard.len(), 1, "{heard:?}");
    assert_eq!((heard[0].service, heard[0].ack), (17, 0));
}

#[test]
fn clients_run_at_once_never_share_a_sequence_number() {
    let dir = tmp("concurrent");
    let (kp, k) = key(&dir);
    let fake = Fake::start(k, Behaviour::default());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                for _ in 0..8 {
                    let o = ground(&fake, &kp, &["ping", "--ack", "none"]);
                    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
                }
            });
        }
    });
    let mut seqs: Vec<u32> = fake.heard().iter().map(|h| h.seq).collect();
    assert_eq!(seqs.len(), 16);
    seqs.sort_unstable();
    let first = seqs[0];
    assert_eq!(
        seqs,
        (first..first + 16).collect::<Vec<_>>(),
        "every number once"
    );
    let counter = std::fs::read_to_string(dir.join("ground.key.seq")).unwrap();
    assert_eq!(counter.trim().parse::<u32>().unwrap(), first + 15);
    // A fresh counter starts at the current Unix time.
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs() as u32;
    assert!(first >= now - 60 && first <= now, "{first} vs {now}");
}

#[test]
fn listen_claims_the_telemetry_saves_it_and_ends_on_sigterm() {
    let dir = tmp("listen");
    let (kp, k) = key(&dir);
    let fake = Fake::start(
        k,
        Behaviour {
            stream_every: Some(Duration::from_millis(100)),
            ..Default::default()
        },
    );
    let save = dir.join("tm.bin");
    let child = calib()
        .args([
            "ground",
            "listen",
            "--keepalive",
            "0.4",
            "--to",
            &fake.to(),
            "--key",
        ])
        .arg(&kp)
        .arg("--save")
        .arg(&save)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let o = child.wait_with_output().unwrap();
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    // Keepalive pings (no reports asked for) every 0.4 s: at least 3 in 1.5 s.
    let heard = fake.heard();
    assert!(heard.len() >= 3, "{heard:?}");
    assert!(heard
        .iter()
        .all(|h| (h.service, h.subtype, h.ack) == (17, 1, 0)));
    assert!(out.contains("connection test report"));
    assert!(out.contains("housekeeping 1 (estimate)"));
    assert!(out.contains("housekeeping 2 (health)"));
    assert!(out.contains("event mode_changed (1, info): from=0 to=1 campaign=2"));
    // What --save wrote decodes again, packet by packet, as listen printed it.
    let bytes = std::fs::read(&save).unwrap();
    let (packets, rest) = saved::read(&bytes);
    assert_eq!(rest, None);
    assert_eq!(packets.len(), out.lines().count());
    for (p, line) in packets.iter().zip(out.lines()) {
        let d = describe(p);
        assert!(!d.is_error(), "{}", d.text);
        assert_eq!(d.text, line);
    }
    let est = packets
        .iter()
        .map(|p| describe(p))
        .find(|d| d.value["structure"] == 1)
        .unwrap();
    let want = fake_onboard::estimate();
    assert_eq!(
        est.value["values"]["beta_is2_z"]
            .as_f64()
            .unwrap()
            .to_bits(),
        want.beta[1][2].to_bits()
    );
    // `ground decode` prints the file the same way.
    let o = calib()
        .args(["ground", "decode"])
        .arg(&save)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(text(&o.stdout), out);
    // A second listen appends; --seconds ends it; JSON lines.
    let o = calib()
        .args([
            "ground",
            "listen",
            "--keepalive",
            "0",
            "--seconds",
            "0.5",
            "--json",
        ])
        .args(["--to", &fake.to(), "--key"])
        .arg(&kp)
        .arg("--save")
        .arg(&save)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    let n_json = text(&o.stdout).lines().count();
    for l in text(&o.stdout).lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert!(v.get("error").is_none(), "{l}");
    }
    let bytes = std::fs::read(&save).unwrap();
    assert_eq!(saved::read(&bytes).0.len(), packets.len() + n_json);
    // A file cut inside a record: the whole ones print, then an error.
    std::fs::write(&save, &bytes[..bytes.len() - 3]).unwrap();
    let o = calib()
        .args(["ground", "decode"])
        .arg(&save)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("are left"), "{}", text(&o.stderr));
}

#[test]
fn a_refusal_comes_back_because_a_ping_claims_the_reports_first() {
    let dir = tmp("claim");
    let (kp, k) = key(&dir);
    // As the set does: every report to the sender of the last accepted telecommand.
    let fake = Fake::start(
        k,
        Behaviour {
            set_fails: Some(Failure::OutOfRange),
            to_last_accepted: true,
            ..Default::default()
        },
    );
    assert_eq!(ground(&fake, &kp, &["ping"]).status.code(), Some(0));
    let o = ground(&fake, &kp, &["set", "hk1_interval_ms=50"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("20,3 failed at acceptance: failure 20 out_of_range"),
        "{err}"
    );
    // Alone, from a new socket, its refusal goes to the last accepted sender's.
    let o = calib()
        .args([
            "ground",
            "set",
            "hk1_interval_ms=50",
            "--no-claim",
            "--timeout",
            "0.5",
        ])
        .args(["--to", &fake.to(), "--key"])
        .arg(&kp)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3));
    assert!(
        text(&o.stderr).contains("nothing heard from"),
        "{}",
        text(&o.stderr)
    );
    let heard = fake.heard();
    let last = &heard[heard.len() - 1];
    assert_eq!((last.service, last.subtype), (20, 3));
    assert_ne!(heard[heard.len() - 2].service, 17, "no claiming ping");
    // --seq: the given number is the telecommand's, no ping before it; accepted, it
    // makes its sender the reports' destination.
    let next = last.seq + 10;
    let o = ground(&fake, &kp, &["restore", "--seq", &next.to_string()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let heard = fake.heard();
    assert_eq!(
        (heard.last().unwrap().seq, heard.last().unwrap().service),
        (next, 8)
    );
}
