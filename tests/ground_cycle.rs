//! The set operated from the ground, a whole cycle over the real UDP link with real
//! packets: `taiji-supervisor --ground` in standby → ping → start → housekeeping and
//! events → end-of-campaign event → apply → a second campaign from the onboard table →
//! shutdown, exit 0. Campaign 1 is bit-identical to the in-process run of the same
//! scenario and seed; the estimate decoded from housekeeping equals report.json's bit
//! for bit; campaign 2's priors are campaign 1's estimates. Then: a restart of the set
//! keeps the table and refuses a replayed telecommand; `kill -9` of the TMTC process
//! mid-campaign is restarted with nothing lost.

mod common;
mod support;
mod tmpdir;

use common::{estimates, in_process, pids_with, prefix, report, serial};
use std::collections::BTreeMap;
use std::net::UdpSocket;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use taiji::ground::auth::{encode_signed_tc, Key};
use taiji::ground::dictionary::{Failure, APID};
use taiji::ground::packet::{decode_tm, TcHeader, MAX_PACKET_LEN};
use taiji::sim::scenario::Scenario;

const SUPERVISOR: &str = env!("CARGO_BIN_EXE_taiji-supervisor");
const SHORT: &str = "name = \"short\"\nseed = 11\nduration_s = 3000.0\n";

/// One telemetry packet as the test reads it.
#[derive(Debug, Clone)]
struct Tm {
    service: u8,
    subtype: u8,
    data: Vec<u8>,
}

impl Tm {
    fn u16_at(&self, i: usize) -> u16 {
        u16::from_be_bytes([self.data[i], self.data[i + 1]])
    }
    /// A verification report's failure code (1,2 / 1,4 / 1,8).
    fn failure(&self) -> Option<Failure> {
        (self.data.len() >= 6).then(|| Failure::from_code(self.u16_at(4)).unwrap())
    }
}

/// A ground station of the test's own: one socket, the key, a sequence counter.
struct Ground {
    sock: UdpSocket,
    to: String,
    key: Key,
    seq: u32,
    count: u16,
    /// Everything heard so far.
    heard: Vec<Tm>,
}

impl Ground {
    fn new(to: &str, key: &Path, seq: u32) -> Ground {
        let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
        sock.set_read_timeout(Some(Duration::from_millis(50)))
            .unwrap();
        Ground {
            sock,
            to: to.into(),
            key: Key::load(key).unwrap(),
            seq,
            count: 0,
            heard: Vec::new(),
        }
    }

    /// Send telecommand (service, subtype) with `app_data`; its request ID.
    fn send(&mut self, service: u8, subtype: u8, app_data: &[u8]) -> [u8; 4] {
        self.seq += 1;
        self.count += 1;
        let h = TcHeader {
            apid: APID,
            sequence_count: self.count,
            ack_flags: 0xF,
            service,
            subtype,
            source_id: 7,
        };
        let mut buf = vec![0u8; MAX_PACKET_LEN];
        let n = encode_signed_tc(&mut buf, &h, app_data, self.seq, &self.key).unwrap();
        self.sock.send_to(&buf[..n], &self.to).unwrap();
        [buf[0], buf[1], buf[2], buf[3]]
    }

    /// Listen until `until` holds for what was heard, or fail after `timeout`.
    fn wait(&mut self, what: &str, timeout: Duration, until: impl Fn(&[Tm]) -> bool) {
        let heard = self.listen(timeout, until);
        assert!(
            heard,
            "no {what} within {timeout:?}; heard (service, subtype, first u16) {:?}",
            self.summary()
        );
    }

    /// Listen for at most `d` until `until` holds for what was heard; whether it does.
    fn listen(&mut self, d: Duration, until: impl Fn(&[Tm]) -> bool) -> bool {
        let t0 = Instant::now();
        let mut buf = vec![0u8; MAX_PACKET_LEN];
        while t0.elapsed() < d && !until(&self.heard) {
            if let Ok((n, _)) = self.sock.recv_from(&mut buf) {
                let tm = decode_tm(&buf[..n], APID).expect("telemetry decodes, CRC checked");
                self.heard.push(Tm {
                    service: tm.header.service,
                    subtype: tm.header.subtype,
                    data: tm.source_data.to_vec(),
                });
            }
        }
        until(&self.heard)
    }

    /// Send and wait for the request's completion report; returns it.
    fn command(&mut self, service: u8, subtype: u8, app_data: &[u8], timeout: Duration) -> Tm {
        let id = self.send(service, subtype, app_data);
        let done = |h: &[Tm]| {
            h.iter()
                .any(|t| t.service == 1 && matches!(t.subtype, 2 | 7 | 8) && t.data[..4] == id)
        };
        self.wait("completion report", timeout, done);
        self.heard
            .iter()
            .rev()
            .find(|t| t.service == 1 && matches!(t.subtype, 2 | 7 | 8) && t.data[..4] == id)
            .unwrap()
            .clone()
    }

    /// What was heard, as (service, subtype, first two bytes) for a failure's message.
    fn summary(&self) -> Vec<(u8, u8, u16)> {
        self.heard
            .iter()
            .map(|t| {
                (
                    t.service,
                    t.subtype,
                    if t.data.len() >= 2 { t.u16_at(0) } else { 0 },
                )
            })
            .collect()
    }

    fn events(&self, id: u16) -> usize {
        self.heard
            .iter()
            .filter(|t| t.service == 5 && t.u16_at(0) == id)
            .count()
    }
}

fn function(id: u16, args: &[u8]) -> Vec<u8> {
    let mut v = id.to_be_bytes().to_vec();
    v.extend_from_slice(args);
    v
}

fn start_args(seed: u64, duration_s: f64) -> Vec<u8> {
    let mut a = seed.to_be_bytes().to_vec();
    a.extend_from_slice(&duration_s.to_be_bytes());
    function(1, &a)
}

/// The set under test: stopped (SIGTERM, then SIGKILL) if the test fails first.
struct Set(Option<Child>);

impl Set {
    fn id(&self) -> u32 {
        self.0.as_ref().unwrap().id()
    }
    /// Wait for the supervisor's exit; its status and output.
    fn wait(mut self, timeout: Duration) -> (std::process::ExitStatus, String, String) {
        let mut c = self.0.take().unwrap();
        let t0 = Instant::now();
        while c.try_wait().unwrap().is_none() {
            if t0.elapsed() > timeout {
                let _ = c.kill();
                panic!("the set did not end within {timeout:?}");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let o = c.wait_with_output().unwrap();
        let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
        (o.status, text(&o.stdout), text(&o.stderr))
    }
}

impl Drop for Set {
    fn drop(&mut self) {
        if let Some(c) = self.0.as_mut() {
            signal(c.id() as i32, libc::SIGTERM);
            let t0 = Instant::now();
            while matches!(c.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(10) {
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn launch(sc: &Path, out: &Path, pfx: &str, port: u16) -> Set {
    launch_at(sc, out, pfx, port, 1000)
}

/// The set at real time × `scale`.
fn launch_at(sc: &Path, out: &Path, pfx: &str, port: u16, scale: u32) -> Set {
    let c = Command::new(SUPERVISOR)
        .arg("--scenario")
        .arg(sc)
        .arg("--out")
        .arg(out)
        .args(["--bus-prefix", pfx])
        .args(["--ground", &format!("127.0.0.1:{port}")])
        // Paced, so a campaign runs long enough to be commanded while it runs.
        .args(["--realtime", "--time-scale", &scale.to_string()])
        .env("TAIJI_ALLOC_TRACE", common::alloc_trace_file(out))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    Set(Some(c))
}

/// A free UDP port on loopback.
fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Structure 1 of a 3,25 report, by column name, as wire bits.
fn hk1(tm: &Tm) -> BTreeMap<String, u64> {
    let cols = taiji::ground::housekeeping::columns(1).unwrap();
    let mut at = 2;
    let mut out = BTreeMap::new();
    for c in cols {
        let n = c.kind.size();
        let mut b = [0u8; 8];
        b[8 - n..].copy_from_slice(&tm.data[at..at + n]);
        out.insert(c.name.clone(), u64::from_be_bytes(b));
        at += n;
    }
    assert_eq!(at, tm.data.len());
    out
}

fn ping_until_up(g: &mut Ground) {
    let t0 = Instant::now();
    loop {
        let id = g.send(17, 1, &[]);
        let got = |h: &[Tm]| {
            h.iter()
                .any(|t| t.service == 1 && t.subtype == 7 && t.data[..4] == id)
        };
        g.listen(Duration::from_millis(500), got);
        if got(&g.heard) {
            return;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "the set never answered a ping"
        );
    }
}

fn wait_key(out: &Path) -> std::path::PathBuf {
    let key = out.join("ground.key");
    common::wait_every(
        Duration::from_millis(20),
        "the key file",
        Duration::from_secs(120),
        || key.exists(),
    );
    key
}

#[test]
fn a_whole_cycle_from_the_ground() {
    let _serial = serial();
    let dir = support::tmp("cycle");
    let sc = support::write_scenario(&dir, SHORT);
    let out = dir.join("out");
    let pfx = prefix("gcycle");
    let port = free_port();
    let child = launch(&sc, &out, &pfx, port);
    let key = wait_key(&out);
    let to = format!("127.0.0.1:{port}");
    let mut g = Ground::new(&to, &key, 100);
    ping_until_up(&mut g);
    assert!(g.heard.iter().any(|t| (t.service, t.subtype) == (17, 2)));
    // Refused while nothing ran: apply without a result, stop without a campaign.
    let r = g.command(8, 1, &function(3, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), Some(Failure::NoResult));
    let r = g.command(8, 1, &function(2, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), Some(Failure::NotRunning));
    // Campaign 1, at the seed of a timeline's first campaign (mission seed 5), so that
    // the cycle start, apply, start can be held against the timeline's (issue 51).
    let mission_seed = 5;
    let seed = taiji::analysis::mission::campaign_seed(mission_seed, 0);
    let r = g.command(8, 1, &start_args(seed, 0.0), Duration::from_secs(120));
    assert_eq!((r.subtype, r.failure()), (7, None));
    let r = g.command(8, 1, &start_args(seed, 0.0), Duration::from_secs(10));
    assert_eq!(r.failure(), Some(Failure::StartWhileRunning));
    wait_end(&mut g, 1);
    assert!(g.heard.iter().any(|t| (t.service, t.subtype) == (3, 25)));
    let c1 = out.join("campaign-1");
    let r1 = report(&c1);
    assert_eq!(r1["priors_source"], "scenario");
    assert_eq!(estimates(&r1), in_process(&sc, seed));
    // The estimate in housekeeping is report.json's, bit for bit.
    let mark = g.heard.len();
    let mut sid = vec![1u8];
    sid.extend_from_slice(&1u16.to_be_bytes());
    g.send(3, 27, &sid);
    let one_shot = |t: &Tm| (t.service, t.subtype) == (3, 25) && t.u16_at(0) == 1;
    g.wait("a one-shot report", Duration::from_secs(10), |h| {
        h[mark..].iter().any(one_shot)
    });
    let tm = g.heard[mark..]
        .iter()
        .find(|t| one_shot(t))
        .unwrap()
        .clone();
    let hk = hk1(&tm);
    for (i, is) in r1["inertial_sensors"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            let f = |name: &str| f64::from_bits(hk[&format!("{name}_is{}_{axis}", i + 1)]);
            assert_eq!(f("beta"), is["beta"]["estimate"][a].as_f64().unwrap());
            assert_eq!(f("beta_sigma"), is["beta"]["sigma"][a].as_f64().unwrap());
            assert_eq!(f("r"), is["com_offset"]["estimate"][a].as_f64().unwrap());
        }
    }
    // Apply, then campaign 2 from the table.
    let r = g.command(8, 1, &function(3, &[]), Duration::from_secs(10));
    assert_eq!(
        (r.subtype, r.failure()),
        (7, None),
        "{}",
        r1["requirements"]
    );
    assert_eq!(g.events(6), 1);
    let seed2 = taiji::analysis::mission::campaign_seed(mission_seed, 1);
    let r = g.command(8, 1, &start_args(seed2, 0.0), Duration::from_secs(120));
    assert_eq!(r.failure(), None);
    wait_end(&mut g, 2);
    let r2 = report(&out.join("campaign-2"));
    assert_eq!(r2["priors_source"], "onboard_table");
    for (is1, is2) in r1["inertial_sensors"]
        .as_array()
        .unwrap()
        .iter()
        .zip(r2["inertial_sensors"].as_array().unwrap())
    {
        assert_eq!(is2["beta"]["prior"], is1["beta"]["estimate"]);
        assert_eq!(is2["com_offset"]["prior"], is1["com_offset"]["estimate"]);
    }
    // The first two campaigns of a timeline (mission seed 5, no drift) are these
    // two, bit for bit: the ground cycle start, apply, start is the timeline's.
    let timeline = {
        let mut s = Scenario::load(&sc).unwrap();
        s.timeline = Some(taiji::sim::scenario::MissionTimeline {
            days: 3.0,
            campaigns: taiji::sim::scenario::CampaignDays::Days(vec![0.0, 1.0]),
            ..Default::default()
        });
        let (s, _) = taiji::analysis::plan::resolve(s).unwrap();
        taiji::analysis::mission::run(
            &s,
            mission_seed,
            taiji::sim::estimate::Method::Joint,
            taiji::analysis::campaign::Threads::available(),
            |_| {},
        )
    };
    for (c, r) in timeline.campaigns.iter().zip([&r1, &r2]) {
        let v = serde_json::to_value(c.report.as_ref().unwrap()).unwrap();
        assert_eq!(estimates(&v), estimates(r), "campaign on day {}", c.day);
        assert_eq!(v["priors_source"], r["priors_source"]);
    }
    // Apply campaign 2's result, restore campaign 1's, and no further back.
    let r = g.command(8, 1, &function(3, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), None, "{}", r2["requirements"]);
    let r = g.command(8, 1, &function(4, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), None);
    let restored = g
        .heard
        .iter()
        .rev()
        .find(|t| t.service == 5 && t.u16_at(0) == 7)
        .expect("the table_restored event");
    assert_eq!(
        restored.data[2..6],
        1u32.to_be_bytes(),
        "campaign 1's table again"
    );
    let r = g.command(8, 1, &function(4, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), Some(Failure::NothingToRestore));
    let r = g.command(8, 1, &function(5, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), None);
    let (status, stdout, stderr) = child.wait(Duration::from_secs(30));
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(stdout.contains("campaign-2"), "{stdout}");
    assert!(pids_with(&pfx, "taiji-").is_empty());
    // The set again on the same folder. The anti-replay state survived: the last
    // sequence number accepted before is refused, and its refusal goes to the sender of
    // the last accepted telecommand, kept on disk too.
    let child = launch(&sc, &out, &pfx, port);
    let last = g.seq;
    let t0 = Instant::now();
    loop {
        g.seq = last - 1;
        let id = g.send(17, 1, &[]);
        let refused = |h: &[Tm]| {
            h.iter()
                .any(|t| (t.service, t.subtype) == (1, 2) && t.data[..4] == id)
        };
        g.listen(Duration::from_millis(500), refused);
        if refused(&g.heard) {
            let t = g
                .heard
                .iter()
                .rev()
                .find(|t| (t.service, t.subtype) == (1, 2))
                .unwrap();
            assert_eq!(t.failure(), Some(Failure::Replayed));
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no refusal of the replay"
        );
    }
    // The table survived too.
    g.seq = last + 100;
    let mark = g.heard.len();
    let mut ids = vec![2u8];
    ids.extend_from_slice(&46u16.to_be_bytes());
    ids.extend_from_slice(&47u16.to_be_bytes());
    g.send(20, 1, &ids);
    g.wait("the table's state", Duration::from_secs(10), |h| {
        h[mark..].iter().any(|t| (t.service, t.subtype) == (20, 2))
    });
    let p = g.heard[mark..]
        .iter()
        .find(|t| (t.service, t.subtype) == (20, 2))
        .unwrap();
    assert_eq!(
        p.data,
        [2, 0, 46, 0, 0, 0, 1, 0, 47, 1],
        "campaign 1's table, valid, after a restart"
    );
    signal(child.id() as i32, libc::SIGTERM);
    let (st, _, stderr) = child.wait(Duration::from_secs(30));
    assert_eq!(st.code(), Some(130), "{stderr}");
}

/// A drifting mission's campaigns, short: the drift of scenarios/mission_drift.toml
/// without its step, three campaigns of 3000 s on days 2.5, 29 and 36.
const DRIFTING: &str = "name = \"drift-short\"\nseed = 11\nduration_s = 3000.0\n\n[drift]\nbeta_rel_per_day = 1.5e-6\nbeta_rel_per_sqrt_day = 4.0e-7\ncom_m_per_day = [[0.9e-6, -1.1e-6, 0.4e-6], [0.7e-6, 1.3e-6, 0.2e-6]]\ncom_m_per_sqrt_day = 2.5e-7\n\n[timeline]\ndays = 40.0\ncampaigns = [2.5, 29.0, 36.0]\n";

/// Wait for the end of campaign `n` (its requirement event) and standby after it
/// (mode_changed twice per campaign).
fn wait_end(g: &mut Ground, n: usize) {
    g.wait(
        &format!("campaign {n}'s end and standby"),
        Duration::from_secs(600),
        |h| {
            let ev = |id| {
                h.iter()
                    .filter(|t| t.service == 5 && t.u16_at(0) == id)
                    .count()
            };
            ev(4) + ev(5) == n && ev(1) == 2 * n
        },
    );
}

/// Issue 51: a drifting mission over the ground link. The timeline of the scenario
/// (mission seed 11, the file's, as the set's) flies campaigns on days 2.5, 29 and 36;
/// the set flies set epoch 2.5, start (campaign 1's seed), apply, set epoch 29, start
/// (campaign 2's seed), apply, set epoch 36, start (campaign 3's). Every campaign
/// equals the timeline's bit for bit: estimates and σ, status, the drifted truths it
/// is judged against, and its priors (from campaign 2 on the trends' prediction for its
/// day: campaign 3's are not campaign 2's estimate, the rate moved them).
#[test]
fn a_drifting_timeline_over_the_link_equals_the_timeline() {
    let _serial = serial();
    let dir = support::tmp("drift");
    let sc = support::write_scenario(&dir, DRIFTING);
    let timeline = {
        let s = Scenario::load(&sc).unwrap();
        let (s, _) = taiji::analysis::plan::resolve(s).unwrap();
        taiji::analysis::mission::run(
            &s,
            s.seed,
            taiji::sim::estimate::Method::Joint,
            taiji::analysis::campaign::Threads::available(),
            |_| {},
        )
    };
    let flown: Vec<_> = timeline
        .campaigns
        .iter()
        .map(|c| (c.day, c.seed, c.applied))
        .collect();
    assert_eq!(flown.len(), 3, "{flown:?}");
    assert!(
        flown[0].2 && flown[1].2,
        "campaigns 1 and 2 applied: {flown:?}"
    );
    let out = dir.join("out");
    let pfx = prefix("gdrift");
    let port = free_port();
    let child = launch(&sc, &out, &pfx, port);
    let key = wait_key(&out);
    let mut g = Ground::new(&format!("127.0.0.1:{port}"), &key, 100);
    ping_until_up(&mut g);
    let epoch = |d: f64| {
        taiji::ground::requests::value_list(&[(
            taiji::ground::parameters::PAR_CAMPAIGN_EPOCH_DAY,
            d.to_bits(),
        )])
        .unwrap()
    };
    // An epoch out of range is refused, and changes nothing.
    let r = g.command(20, 3, &epoch(-1.0), Duration::from_secs(10));
    assert_eq!(r.failure(), Some(Failure::OutOfRange));
    let mut reports = Vec::new();
    for (n, (day, seed, _)) in flown.iter().enumerate() {
        let r = g.command(20, 3, &epoch(*day), Duration::from_secs(10));
        assert_eq!((r.subtype, r.failure()), (7, None));
        let r = g.command(8, 1, &start_args(*seed, 0.0), Duration::from_secs(120));
        assert_eq!((r.subtype, r.failure()), (7, None));
        wait_end(&mut g, n + 1);
        let rep = report(&out.join(format!("campaign-{}", n + 1)));
        if n + 1 < flown.len() {
            let r = g.command(8, 1, &function(3, &[]), Duration::from_secs(10));
            assert_eq!(
                (r.subtype, r.failure()),
                (7, None),
                "{}",
                rep["requirements"]
            );
        }
        reports.push(rep);
    }
    let r = g.command(8, 1, &function(5, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), None);
    let (status, _, stderr) = child.wait(Duration::from_secs(30));
    assert_eq!(status.code(), Some(0), "{stderr}");
    let quantity = |r: &serde_json::Value, what: &str| -> Vec<serde_json::Value> {
        r["inertial_sensors"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|is| ["beta", "k", "com_offset"].map(|q| is[q][what].clone()))
            .collect()
    };
    for (c, r) in timeline.campaigns.iter().zip(&reports) {
        let v = serde_json::to_value(c.report.as_ref().unwrap()).unwrap();
        let day = c.day;
        assert_eq!(estimates(&v), estimates(r), "campaign on day {day}");
        assert_eq!(
            v["estimator_status"]["bits"], r["estimator_status"]["bits"],
            "day {day}"
        );
        for what in ["truth", "prior"] {
            assert_eq!(quantity(&v, what), quantity(r, what), "{what}, day {day}");
        }
        assert_eq!(v["priors_source"], r["priors_source"]);
        assert_eq!(v["requirements"], r["requirements"]);
    }
    assert_eq!(timeline.campaigns.len(), reports.len());
    // The drift is there: campaign 2's truths are not campaign 1's; campaign 2 starts
    // from campaign 1's estimate (a trend of one result has no rate yet), campaign 3
    // from the trends' prediction, moved by their rates.
    assert_ne!(
        quantity(&reports[0], "truth"),
        quantity(&reports[1], "truth")
    );
    assert_eq!(reports[1]["priors_source"], "onboard_table");
    assert_eq!(
        quantity(&reports[1], "prior")[2],
        quantity(&reports[0], "estimate")[2]
    );
    assert_ne!(
        quantity(&reports[2], "prior")[2],
        quantity(&reports[1], "estimate")[2],
        "campaign 3 starts from the trend's prediction for its day, not campaign 2's r"
    );
}

fn signal(pid: i32, sig: i32) {
    // SAFETY: sending a signal has no memory-safety preconditions.
    unsafe { libc::kill(pid, sig) };
}

/// The TMTC process's heartbeat, read from the set's bus as the supervisor reads it:
/// the first to come, published before this subscriber's connection (which iceoryx2
/// makes on the publisher's side at its next send, allocating) could count.
fn tmtc_progress(pfx: &str) -> Option<taiji::sim::msg::Progress> {
    use taiji::bus::wiring;
    let node = wiring::node("ground-cycle-test", pfx).ok()?;
    let sub =
        wiring::subscriber::<taiji::sim::msg::Progress>(&node, wiring::SVC_GROUND_BEAT).ok()?;
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(5) {
        while let Ok(Some(p)) = wiring::receive(&sub) {
            if p.process == taiji::sim::msg::PROC_TMTC {
                return Some(p);
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    None
}

#[test]
fn a_flood_and_a_killed_tmtc_process_change_nothing() {
    use rand::{Rng, SeedableRng};
    let _serial = serial();
    let dir = support::tmp("flood");
    let sc = support::write_scenario(&dir, SHORT);
    let out = dir.join("out");
    let pfx = prefix("gflood");
    let port = free_port();
    // × 200: the 3000 s campaign lasts the flood's 10 s and more.
    let child = launch_at(&sc, &out, &pfx, port, 200);
    let key = wait_key(&out);
    let to = format!("127.0.0.1:{port}");
    let mut g = Ground::new(&to, &key, 1000);
    ping_until_up(&mut g);
    let seed = 9;
    let r = g.command(8, 1, &start_args(seed, 0.0), Duration::from_secs(120));
    assert_eq!(r.failure(), None);
    // kill -9 of the TMTC process mid-campaign: the supervisor restarts it.
    let victims = pids_with(&pfx, "taiji-tmtc");
    assert_eq!(victims.len(), 1, "{victims:?}");
    signal(victims[0], libc::SIGKILL);
    // The new one has no destination until a telecommand is accepted again.
    ping_until_up(&mut g);
    g.wait("the restart event", Duration::from_secs(30), |h| {
        h.iter().any(|t| t.service == 5 && t.u16_at(0) == 3)
    });
    // 10⁵ garbage datagrams in 10 s from another socket, while the ground listens:
    // random bytes, and copies of a telecommand signed with another key, some mutated
    // and truncated.
    let target = to.clone();
    let flooder = std::thread::spawn(move || {
        let flood = UdpSocket::bind("127.0.0.1:0").unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(50);
        let mut valid = vec![0u8; MAX_PACKET_LEN];
        let h = TcHeader {
            apid: APID,
            sequence_count: 1,
            ack_flags: 0xF,
            service: 8,
            subtype: 1,
            source_id: 9,
        };
        let wrong = Key::from_bytes([7; 32]);
        let n = encode_signed_tc(&mut valid, &h, &start_args(1, 0.0), 1 << 30, &wrong).unwrap();
        valid.truncate(n);
        let t0 = Instant::now();
        for i in 0..100_000u32 {
            let d: Vec<u8> = match i % 3 {
                0 => (0..rng.gen_range(0..200)).map(|_| rng.gen()).collect(),
                1 => valid.clone(),
                _ => {
                    let mut v = valid.clone();
                    let at = rng.gen_range(0..v.len());
                    v[at] ^= 1 << rng.gen_range(0..8);
                    v.truncate(rng.gen_range(1..=v.len()));
                    v
                }
            };
            let _ = flood.send_to(&d, &target);
            let due = Duration::from_micros(100 * u64::from(i));
            if let Some(w) = due.checked_sub(t0.elapsed()) {
                std::thread::sleep(w);
            }
        }
        t0.elapsed()
    });
    g.wait("the campaign's end", Duration::from_secs(600), |h| {
        h.iter()
            .any(|t| t.service == 5 && matches!(t.u16_at(0), 4 | 5))
    });
    let took = flooder.join().unwrap();
    assert!(took < Duration::from_secs(30), "the flood took {took:?}");
    let p = tmtc_progress(&pfx).expect("the TMTC process's heartbeat");
    assert_eq!(p.loop_allocations, 0, "the TMTC loop allocated");
    let r = report(&out.join("campaign-1"));
    assert_eq!(estimates(&r), in_process(&sc, seed));
    assert_eq!(r["timing"]["samples_lost"], 0);
    assert_eq!(
        r["estimator_loop_allocations"],
        0,
        "{}",
        common::alloc_trace(&out)
    );
    // Refused datagrams are counted in housekeeping structure 2.
    let mut sid = vec![1u8];
    sid.extend_from_slice(&2u16.to_be_bytes());
    g.heard.clear();
    g.send(3, 27, &sid);
    g.wait("the health report", Duration::from_secs(10), |h| {
        h.iter()
            .any(|t| (t.service, t.subtype) == (3, 25) && t.u16_at(0) == 2)
    });
    let r = g.command(8, 1, &function(5, &[]), Duration::from_secs(10));
    assert_eq!(r.failure(), None);
    let (st, _, stderr) = child.wait(Duration::from_secs(30));
    assert_eq!(st.code(), Some(0), "{stderr}");
}
