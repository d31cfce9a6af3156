//! Stale shared memory of killed processes is cleaned without hanging, even when a
//! process died half-way through making a connection (an empty, unreadable object that
//! iceoryx2 0.9.3 would wait on forever); a released prefix leaves nothing in /dev/shm;
//! a bus prefix is held by one claimant at a time, and freed when it dies.

use std::os::unix::fs::PermissionsExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use taiji::bus::wiring;
use taiji::sim::msg::Control;

const CHILD_ENV: &str = "TAIJI_BUS_TEST_CHILD";
const PREFIX_ENV: &str = "TAIJI_BUS_TEST_PREFIX";
const SERVICE: &str = "taiji/test/cleanup";

/// This test binary runs without libtest's harness (`harness = false` in Cargo.toml):
/// started with `CHILD_ENV` set, it is one of the child processes the tests start and
/// kill; otherwise it runs the tests.
fn main() {
    if let (Ok(role), Ok(prefix)) = (std::env::var(CHILD_ENV), std::env::var(PREFIX_ENV)) {
        bus_child(&role, &prefix);
        return;
    }
    let tests: [(&str, fn()); 3] = [
        (
            "cleanup_of_a_connection_abandoned_half_made_does_not_hang",
            cleanup_of_a_connection_abandoned_half_made_does_not_hang,
        ),
        (
            "a_prefix_is_held_by_one_claimant_and_freed_when_it_dies",
            a_prefix_is_held_by_one_claimant_and_freed_when_it_dies,
        ),
        (
            "sweep_removes_only_empty_unreadable_objects_old_enough",
            sweep_removes_only_empty_unreadable_objects_old_enough,
        ),
    ];
    // `cargo test --test bus_cleanup -- NAME` runs the tests whose name contains NAME.
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let mut failed = 0;
    for (name, test) in tests {
        if !filter.is_empty() && !filter.iter().any(|f| name.contains(f.as_str())) {
            continue;
        }
        let ok = std::panic::catch_unwind(test).is_ok();
        println!("test {name} ... {}", if ok { "ok" } else { "FAILED" });
        failed += usize::from(!ok);
    }
    if failed > 0 {
        println!("test result: FAILED. {failed} failed");
        std::process::exit(101);
    }
    println!("test result: ok.");
}

/// The body of the child processes (publisher, subscriber or prefix holder).
fn bus_child(role: &str, prefix: &str) {
    if role == "lock" {
        // Hold the prefix until killed.
        let _lock = match wiring::claim_prefix(prefix).unwrap() {
            wiring::Claim::Won(lock) => lock,
            wiring::Claim::Held { pid } => panic!("prefix held by {pid:?}"),
        };
        loop {
            std::thread::sleep(Duration::from_secs(1));
        }
    }
    let node = wiring::node(&format!("child-{role}"), prefix).unwrap();
    if role == "pub" {
        let p = wiring::publisher::<Control>(&node, SERVICE).unwrap();
        for i in 0.. {
            let mut c = Control::default();
            c.header.seq = i;
            wiring::publish(&p, c).unwrap();
            std::thread::sleep(Duration::from_millis(5));
        }
    } else {
        let s = wiring::subscriber::<Control>(&node, SERVICE).unwrap();
        loop {
            while wiring::receive(&s).unwrap().is_some() {}
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

fn child(role: &str, prefix: &str) -> Child {
    Command::new(std::env::current_exe().unwrap())
        .env(CHILD_ENV, role)
        .env(PREFIX_ENV, prefix)
        .stdout(Stdio::null())
        .spawn()
        .unwrap()
}

fn connections(prefix: &str) -> Vec<(PathBuf, u64)> {
    std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .filter(|e| {
            let n = e.file_name().to_string_lossy().to_string();
            n.starts_with(prefix) && n.ends_with(".connection")
        })
        .map(|e| (e.path(), e.metadata().map(|m| m.len()).unwrap_or(0)))
        .collect()
}

fn cleanup_of_a_connection_abandoned_half_made_does_not_hang() {
    let prefix = format!("tjbus{}_", std::process::id());
    let mut kids = [child("sub", &prefix), child("pub", &prefix)];
    let t0 = Instant::now();
    while connections(&prefix).iter().all(|(_, len)| *len == 0) {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "the children never connected"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    for k in &mut kids {
        k.kill().unwrap();
        k.wait().unwrap();
    }
    // Make the connection look as a process killed between creating and sizing it
    // leaves it: empty and write-only, created a while ago.
    let conns = connections(&prefix);
    assert_eq!(conns.len(), 1, "{conns:?}");
    let path = &conns[0].0;
    let f = std::fs::OpenOptions::new().write(true).open(path).unwrap();
    f.set_len(0).unwrap();
    f.set_modified(std::time::SystemTime::now() - 2 * wiring::ABANDONED_AFTER)
        .unwrap();
    drop(f);
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o200)).unwrap();

    // The cleanup must come back (on a thread, so a hang fails the test instead).
    let (tx, rx) = std::sync::mpsc::channel();
    let p = prefix.clone();
    std::thread::spawn(move || tx.send(wiring::cleanup_stale(&p)));
    let survey = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the cleanup hung on the abandoned connection")
        .unwrap();
    assert_eq!(survey.removed_dead, 2);
    assert!(survey.alive.is_empty(), "{:?}", survey.alive);
    assert!(!path.exists(), "{} left behind", path.display());
    // With no node left, the prefix's global object goes too: nothing of it remains.
    let released = wiring::release(&prefix).unwrap();
    assert_eq!(released.global_mgmt, 1);
    assert!(shm_of(&prefix).is_empty(), "{:?}", shm_of(&prefix));
}

fn shm_of(prefix: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

fn a_prefix_is_held_by_one_claimant_and_freed_when_it_dies() {
    let prefix = format!("tjlock{}_", std::process::id());
    let mut holder = child("lock", &prefix);
    let path = wiring::lock_path(&prefix).unwrap();
    let pid = holder.id();
    let t0 = Instant::now();
    while std::fs::read_to_string(&path).ok() != Some(pid.to_string()) {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "the child never locked"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(matches!(
        wiring::claim_prefix(&prefix).unwrap(),
        wiring::Claim::Held { pid: Some(p) } if p == pid
    ));
    // kill -9: no chance to unlock, yet the kernel releases the lock with the process.
    holder.kill().unwrap();
    holder.wait().unwrap();
    let wiring::Claim::Won(lock) = wiring::claim_prefix(&prefix).unwrap() else {
        panic!("the prefix is still held after its holder died");
    };
    // Held, even against this same process; released and its file gone when dropped.
    assert!(matches!(
        wiring::claim_prefix(&prefix).unwrap(),
        wiring::Claim::Held { .. }
    ));
    drop(lock);
    assert!(!path.exists());
    let wiring::Claim::Won(again) = wiring::claim_prefix(&prefix).unwrap() else {
        panic!("the prefix is still held after its lock was dropped");
    };
    drop(again);
    // A release with no global object to remove removes nothing.
    assert_eq!(wiring::release(&prefix).unwrap().global_mgmt, 0);
}

fn sweep_removes_only_empty_unreadable_objects_old_enough() {
    let prefix = format!("tjsweep{}_", std::process::id());
    let make = |name: &str, len: u64, mode: u32, age: Duration| {
        let path = PathBuf::from("/dev/shm").join(format!("{prefix}{name}"));
        let f = std::fs::File::create(&path).unwrap();
        f.set_len(len).unwrap();
        f.set_modified(std::time::SystemTime::now() - age).unwrap();
        drop(f);
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
        path
    };
    let old = 2 * wiring::ABANDONED_AFTER;
    let abandoned = make("abandoned", 0, 0o200, old);
    let young = make("young", 0, 0o200, Duration::ZERO);
    let readable = make("readable", 0, 0o600, old);
    let sized = make("sized", 64, 0o200, old);
    assert_eq!(wiring::sweep_abandoned(&prefix, wiring::ABANDONED_AFTER), 1);
    assert!(!abandoned.exists());
    for p in [young, readable, sized] {
        assert!(p.exists(), "{} removed", p.display());
        std::fs::remove_file(p).unwrap();
    }
}
