//! `taiji-tmtc` alone on its own bus prefix, this test playing the supervisor (it
//! publishes `GroundState` and reads the heartbeats) and the ground station (it sends
//! telecommands over UDP, signed with a key file of mode 0600): a ping answered with
//! 1,1 / 1,3 / 17,2 / 1,7, a wrong MAC refused with 1,2 `bad_mac`, a flood of 10⁴
//! garbage datagrams survived and counted in housekeeping, no heap allocation in its
//! loop after warm-up, SIGTERM → exit 130; then a restart on the same state: the
//! anti-replay number and the telemetry's destination kept, its restart reported as an
//! event, and exit 0 once the supervisor falls silent. Bad arguments exit 2.

mod support;
mod tmpdir;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::net::{SocketAddr, UdpSocket};
use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use taiji::bus::wiring::{self, Pub, Sub};
use taiji::ground::auth::{encode_signed_tc, Key};
use taiji::ground::dictionary::{Failure, APID};
use taiji::ground::events::decode_event;
use taiji::ground::housekeeping::decode_structure;
use taiji::ground::packet::{decode_tm, TcHeader};
use taiji::ground::requests::id_list;
use taiji::sim::msg::{GroundState, Progress, PROC_TMTC, STATE_RUNNING};

const TMTC: &str = env!("CARGO_BIN_EXE_taiji-tmtc");

/// A bus prefix of this test process alone (`tools/test`'s leftover check knows `tjt`).
fn prefix(name: &str) -> String {
    format!("tjt{}{name}_", std::process::id())
}

/// A free UDP port on loopback.
fn free_addr() -> SocketAddr {
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    s.local_addr().unwrap()
}

fn tmtc(pfx: &str, dir: &Path, addr: SocketAddr, key: &Path) -> Command {
    let mut c = Command::new(TMTC);
    c.args(["--bus-prefix", pfx])
        .arg("--run-dir")
        .arg(dir)
        .args(["--method", "joint"])
        .args(["--ground", &addr.to_string()])
        .arg("--ground-key")
        .arg(key)
        .arg("--state-dir")
        .arg(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    c
}

/// A telemetry packet as the ground reads it: service, subtype, source data.
type Tm = (u8, u8, Vec<u8>);

/// This test as the supervisor (bus) and the ground station (UDP).
struct Station {
    child: Child,
    state: Pub<GroundState>,
    progress: Sub<Progress>,
    ground: UdpSocket,
    target: SocketAddr,
    key: Key,
    ground_state: GroundState,
    last_state: Instant,
    /// The TMTC process's last heartbeat.
    beat: Option<Progress>,
    seq: u32,
    count: u16,
    /// Node last: dropped after its ports.
    _node: iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
}

impl Station {
    fn start(pfx: &str, dir: &Path, key_path: &Path, g: GroundState) -> Station {
        let node = wiring::node("tmtc-test", pfx).unwrap();
        let state = wiring::publisher::<GroundState>(&node, wiring::SVC_GROUND_STATE).unwrap();
        let progress = wiring::subscriber::<Progress>(&node, wiring::SVC_PROGRESS).unwrap();
        let target = free_addr();
        let child = tmtc(pfx, dir, target, key_path).spawn().unwrap();
        let ground = UdpSocket::bind("127.0.0.1:0").unwrap();
        ground
            .set_read_timeout(Some(Duration::from_millis(5)))
            .unwrap();
        Station {
            child,
            state,
            progress,
            ground,
            target,
            key: Key::load(key_path).unwrap(),
            ground_state: g,
            last_state: Instant::now() - Duration::from_secs(1),
            beat: None,
            seq: 0,
            count: 0,
            _node: node,
        }
    }

    /// The supervisor's side for a moment: its ground state every 100 ms, heartbeats in.
    fn serve_bus(&mut self, supervisor: bool) {
        if supervisor && self.last_state.elapsed() >= Duration::from_millis(100) {
            wiring::publish(&self.state, self.ground_state).unwrap();
            self.last_state = Instant::now();
        }
        while let Some(p) = wiring::receive(&self.progress).unwrap() {
            if p.process == PROC_TMTC {
                self.beat = Some(p);
            }
        }
    }

    /// Serves the bus until `cond` holds (fails after `timeout`).
    fn wait(&mut self, what: &str, timeout: Duration, mut cond: impl FnMut(&mut Self) -> bool) {
        let t0 = Instant::now();
        while !cond(self) {
            assert!(t0.elapsed() < timeout, "timed out waiting for {what}");
            assert!(
                self.child.try_wait().unwrap().is_none(),
                "taiji-tmtc exited"
            );
            self.serve_bus(true);
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn tc_with_seq(&mut self, service: u8, subtype: u8, app: &[u8], seq: u32) -> Vec<u8> {
        self.count += 1;
        let h = TcHeader {
            apid: APID,
            sequence_count: self.count,
            ack_flags: 0xF,
            service,
            subtype,
            source_id: 7,
        };
        let mut out = vec![0u8; 1024];
        let n = encode_signed_tc(&mut out, &h, app, seq, &self.key).unwrap();
        out.truncate(n);
        out
    }

    fn tc(&mut self, service: u8, subtype: u8, app: &[u8]) -> Vec<u8> {
        self.seq += 1;
        let s = self.seq;
        self.tc_with_seq(service, subtype, app, s)
    }

    /// The packets the ground receives until `done` says enough (serving the bus).
    fn receive_until(&mut self, what: &str, mut done: impl FnMut(&[Tm]) -> bool) -> Vec<Tm> {
        let mut got = Vec::new();
        let mut buf = vec![0u8; 70_000];
        let t0 = Instant::now();
        while !done(&got) {
            assert!(
                t0.elapsed() < Duration::from_secs(20),
                "timed out waiting for {what}; got {:?}",
                got.iter().map(|t: &Tm| (t.0, t.1)).collect::<Vec<_>>()
            );
            self.serve_bus(true);
            while let Ok((n, _)) = self.ground.recv_from(&mut buf) {
                let t = decode_tm(&buf[..n], APID).expect("telemetry decodes, CRC checked");
                got.push((t.header.service, t.header.subtype, t.source_data.to_vec()));
            }
        }
        got
    }

    /// Sends `tc`; the verification reports on it (by request ID) and the other packets
    /// until its completion or failure report.
    fn exchange(&mut self, tc: &[u8]) -> Vec<Tm> {
        self.ground.send_to(tc, self.target).unwrap();
        let id = tc[..4].to_vec();
        let ends = |t: &Tm| t.0 == 1 && matches!(t.1, 2 | 4 | 7 | 8) && t.2[..4] == id;
        let got = self.receive_until("the answer to a telecommand", |g| g.iter().any(ends));
        // Only this request's reports and its own packets (not periodic ones, not the
        // flood's refusals).
        got.into_iter()
            .filter(|t| (t.0 == 1 && t.2[..4] == id) || matches!((t.0, t.1), (17, 2) | (20, 2)))
            .collect()
    }

    fn stop(mut self, sig: i32) -> i32 {
        // SAFETY: a signal to our own child.
        unsafe { libc::kill(self.child.id() as i32, sig) };
        let t0 = Instant::now();
        loop {
            if let Some(st) = self.child.try_wait().unwrap() {
                return st.code().unwrap_or(-1);
            }
            assert!(
                t0.elapsed() < Duration::from_secs(10),
                "taiji-tmtc did not stop"
            );
            self.serve_bus(true);
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

fn kinds(tm: &[Tm]) -> Vec<(u8, u8)> {
    tm.iter().map(|t| (t.0, t.1)).collect()
}

#[test]
fn the_tmtc_process_answers_survives_a_flood_and_allocates_nothing() {
    let dir = support::tmp("run");
    let pfx = prefix("tm");
    let key = dir.join("ground.key");
    Key::create(&key).unwrap();
    let mut st = Station::start(&pfx, &dir, &key, GroundState::default());
    st.wait(
        "the first heartbeat, running",
        Duration::from_secs(20),
        |s| s.beat.is_some_and(|b| b.state == STATE_RUNNING),
    );

    // Ping: acceptance, start, the answer, completion, in order.
    let ping = st.tc(17, 1, &[]);
    let tm = st.exchange(&ping);
    assert_eq!(kinds(&tm), [(1, 1), (1, 3), (17, 2), (1, 7)]);
    assert_eq!(tm[0].2, ping[..4]);

    // A wrong MAC: 1,2 bad_mac, and the sequence number is not used up.
    let mut bad = st.tc_with_seq(17, 1, &[], st.seq + 1);
    let n = bad.len();
    bad[n - 3] ^= 0x40; // in the MAC
    let c = taiji::ground::crc::crc16(&bad[..n - 2]);
    bad[n - 2..].copy_from_slice(&c.to_be_bytes());
    let tm = st.exchange(&bad);
    assert_eq!(kinds(&tm), [(1, 2)]);
    assert_eq!(
        u16::from_be_bytes([tm[0].2[4], tm[0].2[5]]),
        Failure::BadMac as u16
    );

    // A flood of garbage from elsewhere: refused, the process stays up.
    let flood = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(50);
    let mut d = [0u8; 300];
    let n_flood = 10_000;
    for i in 0..n_flood {
        let len = rng.gen_range(0..d.len());
        rng.fill(&mut d[..len]);
        if i % 3 == 0 && len > 6 {
            // Some look like our telecommands.
            d[..2].copy_from_slice(&[0x19, 0x20]);
        }
        let _ = flood.send_to(&d[..len], st.target);
        // 10⁴ per second, as the flood (10⁵ in 10 s).
        if i % 10 == 9 {
            st.serve_bus(true);
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    assert!(
        st.child.try_wait().unwrap().is_none(),
        "taiji-tmtc died in the flood"
    );

    // Still answering, its counters adding up: every datagram that reached it is
    // counted once, accepted or refused with its class.
    let p = st.tc(3, 27, &id_list(&[2]).unwrap());
    st.ground.send_to(&p, st.target).unwrap();
    let id = p[..4].to_vec();
    let got = st.receive_until("the health report", |g| {
        g.iter().any(|t| t.0 == 1 && t.1 == 7 && t.2[..4] == id)
    });
    let hk = got
        .iter()
        .rev()
        .find(|t| (t.0, t.1) == (3, 25))
        .expect("a health report");
    let (sid, vals) = decode_structure(&hk.2).unwrap();
    assert_eq!(sid, 2);
    let get = |name: &str| vals.iter().find(|(c, _)| c.name == name).unwrap().1;
    let datagrams = get("datagrams");
    let refused: u64 = vals
        .iter()
        .filter(|(c, _)| c.name.starts_with("tc_refused_"))
        .map(|(_, v)| v)
        .sum();
    assert_eq!(get("tc_accepted"), 2);
    assert_eq!(refused + 2, datagrams);
    assert!(get("tc_refused_bad_mac") >= 1);
    eprintln!(
        "flood: {n_flood} sent at 10⁴/s, {datagrams} received and counted, {refused} refused"
    );
    assert!(
        datagrams > n_flood / 2 && datagrams <= n_flood + 3,
        "{datagrams} datagrams counted"
    );
    // The flood's refusals were reported to the ground station too (tc_refused events).
    assert!(got
        .iter()
        .any(|t| t.0 == 5 && decode_event(t.1, &t.2).is_ok_and(|e| e.def.name == "tc_refused")));

    // No heap allocation in the loop after warm-up, flood included.
    let seen = st.beat.unwrap().header.seq;
    st.wait("a heartbeat after the flood", Duration::from_secs(5), |s| {
        s.beat.is_some_and(|b| b.header.seq > seen + 2)
    });
    assert_eq!(st.beat.unwrap().loop_allocations, 0);

    let ground = st.ground.try_clone().unwrap();
    let seq = st.seq;
    assert_eq!(st.stop(libc::SIGTERM), 130);
    assert!(dir.join("tc-sequence.state").exists());
    assert!(dir.join("tm-destination").exists());

    // Restarted on the same state: the sequence number and the destination are kept.
    let restarted = GroundState {
        tmtc_restarts: 1,
        ..GroundState::default()
    };
    let mut st = Station::start(&pfx, &dir, &key, restarted);
    st.ground = ground;
    st.seq = seq;
    let got = st.receive_until("the restart event", |g| g.iter().any(|t| t.0 == 5));
    let ev = got.iter().find(|t| t.0 == 5).unwrap();
    let ev = decode_event(ev.1, &ev.2).unwrap();
    assert_eq!(
        (ev.def.name, ev.args[0], ev.args[1]),
        ("process_restarted", u64::from(PROC_TMTC), 1)
    );
    let tm = st.exchange(&ping);
    assert_eq!(
        u16::from_be_bytes([tm[0].2[4], tm[0].2[5]]),
        Failure::Replayed as u16
    );
    let p = st.tc(17, 1, &[]);
    assert_eq!(kinds(&st.exchange(&p)), [(1, 1), (1, 3), (17, 2), (1, 7)]);

    // The supervisor falls silent: exit 0 after 5 s.
    let t0 = Instant::now();
    let code = loop {
        st.serve_bus(false);
        if let Some(s) = st.child.try_wait().unwrap() {
            break s.code();
        }
        assert!(t0.elapsed() < Duration::from_secs(15), "still up");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(code, Some(0));
    assert!(t0.elapsed() >= Duration::from_secs(4), "{:?}", t0.elapsed());
    drop(st);
    let _ = wiring::release(&pfx);
}

#[test]
fn bad_arguments_and_an_exposed_key_exit_2() {
    let dir = support::tmp("args");
    let key = dir.join("ground.key");
    Key::create(&key).unwrap();
    let pfx = prefix("ta");
    let run = |c: &mut Command| {
        let o = c.output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    // Not loopback without --ground-remote.
    let (code, err) = run(&mut tmtc(&pfx, &dir, "0.0.0.0:7301".parse().unwrap(), &key));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--ground-remote"), "{err}");
    // A key others can read.
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o644)).unwrap();
    let (code, err) = run(&mut tmtc(&pfx, &dir, free_addr(), &key));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("chmod 600"), "{err}");
    // No such key; not an address.
    let (code, _) = run(&mut tmtc(&pfx, &dir, free_addr(), &dir.join("none")));
    assert_eq!(code, Some(2));
    let (code, _) = run(Command::new(TMTC).args(["--ground", "here", "--ground-key", "k"]));
    assert_eq!(code, Some(2));
    let _ = wiring::release(&pfx);
}
