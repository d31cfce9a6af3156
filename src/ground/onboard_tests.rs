//! The onboard logic's tests (`onboard.rs`): every class of bad input refused with its
//! failure code and never forwarded, the anti-replay rule, the services, and a flood of
//! random datagrams.

use super::*;
use crate::ground::auth::{encode_signed_tc, KEY_LEN};
use crate::ground::dictionary::Kind;
use crate::ground::events::decode_event;
use crate::ground::housekeeping::decode_structure;
use crate::ground::packet::{decode_tm, encode_tc, CRC_LEN};
use crate::ground::parameters::decode_report;
use crate::ground::requests::{function_call, id_list, interval_list, value_list};
use crate::sim::msg::{MemberStatus, PROC_ESTIMATOR, PROC_PLANT};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;

fn key() -> Key {
    Key::from_bytes([0x5A; KEY_LEN])
}

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("taiji-onboard-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The ground station's address.
fn ground() -> SocketAddr {
    "127.0.0.1:7400".parse().unwrap()
}

fn other() -> SocketAddr {
    "127.0.0.1:7999".parse().unwrap()
}

/// A test bench: the onboard side, its state folder and the next sequence numbers.
struct Bench {
    ob: Onboard,
    dir: PathBuf,
    seq: u32,
    count: u16,
    now: u64,
}

/// A decoded telemetry packet: service, subtype, source data.
type Packet = (u8, u8, Vec<u8>);

impl Bench {
    fn new(tag: &str) -> Bench {
        let dir = dir(tag);
        let g = ReplayGuard::open(&dir.join("tc-sequence.state")).unwrap();
        Bench {
            ob: Onboard::new(key(), g, 1000),
            dir,
            seq: 0,
            count: 0,
            now: 1_000_000_000,
        }
    }

    fn tc_with(&mut self, service: u8, subtype: u8, flags: u8, app: &[u8], seq: u32) -> Vec<u8> {
        self.count = (self.count + 1) & 0x3FFF;
        let h = TcHeader {
            apid: APID,
            sequence_count: self.count,
            ack_flags: flags,
            service,
            subtype,
            source_id: 0x42,
        };
        let mut out = vec![0u8; 4096];
        let n = encode_signed_tc(&mut out, &h, app, seq, &key()).unwrap();
        out.truncate(n);
        out
    }

    /// A fresh, signed telecommand asking for every report.
    fn tc(&mut self, service: u8, subtype: u8, app: &[u8]) -> Vec<u8> {
        self.seq += 1;
        let s = self.seq;
        self.tc_with(service, subtype, 0xF, app, s)
    }

    /// Sends a datagram from `from`; the packets sent and the request forwarded.
    fn send_from(&mut self, d: &[u8], from: SocketAddr) -> (Vec<Packet>, Option<GroundRequest>) {
        let r = self.ob.datagram(d, from, self.now);
        (self.drain(), r)
    }

    fn send(&mut self, d: &[u8]) -> (Vec<Packet>, Option<GroundRequest>) {
        self.send_from(d, ground())
    }

    fn drain(&mut self) -> Vec<Packet> {
        let v = (0..self.ob.outbox_len())
            .map(|i| {
                let p = self.ob.outbox_packet(i).unwrap();
                let t = decode_tm(p, APID).unwrap();
                (t.header.service, t.header.subtype, t.source_data.to_vec())
            })
            .collect();
        for _ in 0..self.ob.outbox_len() {
            self.ob.sent(true);
        }
        self.ob.clear_outbox();
        v
    }

    /// Makes the ground station the destination.
    fn connect(&mut self) {
        let p = self.tc(17, 1, &[]);
        let (tm, r) = self.send(&p);
        assert_eq!(tm.len(), 4);
        assert!(r.is_none());
    }

    fn set_mode(&mut self, mode: Mode) {
        let g = GroundState {
            mode: mode as u32,
            ..self.ob.state
        };
        self.ob.on_ground_state(&g);
    }
}

impl Drop for Bench {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The failure code of a lone 1,2 report (and its tc_refused event) in `tm`.
fn refusal(tm: &[Packet]) -> Failure {
    assert_eq!(tm.len(), 2, "{tm:?}");
    assert_eq!((tm[0].0, tm[0].1), (1, 2));
    let code = u16::from_be_bytes([tm[0].2[4], tm[0].2[5]]);
    let e = decode_event(tm[1].1, &tm[1].2).unwrap();
    assert_eq!(e.def.id, ev::EV_TC_REFUSED);
    assert_eq!(e.args[0], u64::from(code));
    Failure::from_code(code).unwrap()
}

fn types(tm: &[Packet]) -> Vec<(u8, u8)> {
    tm.iter().map(|p| (p.0, p.1)).collect()
}

#[test]
fn a_ping_is_answered_per_its_flags_and_sets_the_destination() {
    let mut b = Bench::new("ping");
    let p = b.tc(17, 1, &[]);
    assert_eq!(b.ob.destination(), None);
    let (tm, r) = b.send(&p);
    assert!(r.is_none());
    assert_eq!(types(&tm), [(1, 1), (1, 3), (17, 2), (1, 7)]);
    assert_eq!(tm[0].2, p[..4]);
    assert_eq!(b.ob.destination(), Some(ground()));
    assert_eq!(b.ob.take_destination_change(), Some(ground()));
    assert_eq!(b.ob.take_destination_change(), None);
    // Only what the flags ask for.
    b.seq += 1;
    let s = b.seq;
    let p = b.tc_with(17, 1, 0, &[], s);
    assert_eq!(types(&b.send(&p).0), [(17, 2)]);
    b.seq += 1;
    let s = b.seq;
    let p = b.tc_with(17, 1, ACK_COMPLETION, &[], s);
    assert_eq!(types(&b.send(&p).0), [(17, 2), (1, 7)]);
    let h = b.ob.health(b.now);
    assert_eq!((h.tc_accepted, h.datagrams, h.tm_sent), (3, 3, 7));
}

#[test]
fn nothing_is_sent_before_a_telecommand_is_accepted() {
    let mut b = Bench::new("silent");
    let (tm, _) = b.send(&[0u8; 3]);
    assert!(tm.is_empty());
    b.ob.on_estimate(&EstimateMsg::default());
    b.ob.tick(b.now);
    assert!(b.drain().is_empty());
    assert_eq!(
        b.ob.health(b.now).tc_refused[Failure::Truncated as usize - 1],
        1
    );
}

/// A valid telecommand with its bytes changed by `f` and its CRC resealed.
fn resealed(p: &[u8], f: impl Fn(&mut Vec<u8>)) -> Vec<u8> {
    let mut q = p.to_vec();
    f(&mut q);
    let n = q.len() - CRC_LEN;
    let c = crate::ground::crc::crc16(&q[..n]);
    q[n..].copy_from_slice(&c.to_be_bytes());
    q
}

#[test]
fn every_bad_input_class_gets_its_failure_code_and_is_never_executed() {
    let mut b = Bench::new("classes");
    b.connect();
    let good = b.tc(17, 1, &[]);
    let mut cases: Vec<(Failure, Vec<u8>)> = vec![
        (Failure::Truncated, good[..8].to_vec()),
        (Failure::LengthMismatch, good[..good.len() - 1].to_vec()),
        (Failure::BadCrc, {
            let mut q = good.clone();
            q[8] ^= 4;
            q
        }),
        (Failure::WrongVersion, resealed(&good, |q| q[0] |= 0x20)),
        (Failure::WrongType, resealed(&good, |q| q[0] &= !0x10)),
        (
            Failure::NoSecondaryHeader,
            resealed(&good, |q| q[0] &= !0x08),
        ),
        (Failure::Segmented, resealed(&good, |q| q[2] &= 0x7F)),
        (Failure::UnknownApid, resealed(&good, |q| q[1] = 0x21)),
        (Failure::WrongPusVersion, resealed(&good, |q| q[6] = 0x1F)),
        (Failure::BadMac, resealed(&good, |q| q[20] ^= 1)),
        (Failure::BadMac, resealed(&good, |q| q[7] = 20)),
    ];
    let mut short = vec![0u8; 64];
    let h = TcHeader {
        apid: APID,
        sequence_count: 1,
        ack_flags: 0xF,
        service: 17,
        subtype: 1,
        source_id: 1,
    };
    let n = encode_tc(&mut short, &h, &[0; 19]).unwrap();
    cases.push((Failure::NoTrailer, short[..n].to_vec()));
    let start = |d: f64| {
        function_call(&Function::Start {
            seed: 1,
            duration_s: d,
        })
    };
    let signed: Vec<(Failure, u8, u8, Vec<u8>)> = vec![
        (Failure::UnknownService, 2, 1, vec![]),
        (Failure::UnknownSubtype, 17, 3, vec![]),
        (Failure::UnknownSubtype, 3, 25, vec![]),
        (Failure::UnknownFunction, 8, 1, vec![0, 9]),
        (Failure::UnknownParameter, 20, 1, id_list(&[1, 6]).unwrap()),
        (Failure::UnknownParameter, 20, 3, vec![1, 0, 48, 0, 0, 0, 0]),
        (Failure::UnknownStructure, 3, 27, id_list(&[3]).unwrap()),
        (Failure::UnknownStructure, 3, 5, id_list(&[0]).unwrap()),
        (Failure::UnknownEvent, 5, 6, id_list(&[11]).unwrap()),
        (Failure::BadLength, 17, 1, vec![0]),
        (Failure::BadLength, 3, 31, vec![1, 0, 1]),
        (Failure::BadLength, 8, 1, vec![0, 1, 2]),
        (Failure::OutOfRange, 8, 1, start(-1.0)),
        (Failure::OutOfRange, 8, 1, start(10.0)),
        (Failure::OutOfRange, 8, 1, start(2e6)),
        (Failure::OutOfRange, 8, 1, start(f64::NAN)),
        (
            Failure::OutOfRange,
            3,
            31,
            interval_list(&[(1, 50)]).unwrap(),
        ),
        (Failure::OutOfRange, 20, 3, value_list(&[(2, 99)]).unwrap()),
        (
            Failure::OutOfRange,
            20,
            3,
            value_list(&[(3, 5e6f64.to_bits())]).unwrap(),
        ),
        (Failure::ReadOnly, 20, 3, value_list(&[(47, 1)]).unwrap()),
        (Failure::NotRunning, 8, 1, function_call(&Function::Stop)),
    ];
    for (f, s, t, app) in signed {
        let p = b.tc(s, t, &app);
        cases.push((f, p));
    }
    let mut want = [0u32; N_FAILURES];
    for (f, p) in &cases {
        let (tm, r) = b.send(p);
        assert!(r.is_none(), "{f:?}");
        assert_eq!(refusal(&tm), *f, "{p:02x?}");
        assert_eq!(tm[0].2[..4], p[..4]);
        want[f.code() as usize - 1] += 1;
    }
    // Running: a start is refused; a stop is forwarded.
    b.set_mode(Mode::Running);
    let p = b.tc(8, 1, &start(0.0));
    assert_eq!(refusal(&b.send(&p).0), Failure::StartWhileRunning);
    want[Failure::StartWhileRunning as usize - 1] += 1;
    let p = b.tc(8, 1, &function_call(&Function::Stop));
    let (tm, r) = b.send(&p);
    assert_eq!(types(&tm), [(1, 1)]);
    assert_eq!(r.map(|r| r.function), Some(2));
    // A refused telecommand did not use up its sequence number.
    let p = b.tc(17, 1, &[0]);
    assert_eq!(refusal(&b.send(&p).0), Failure::BadLength);
    want[Failure::BadLength as usize - 1] += 1;
    let s = b.seq;
    let p = b.tc_with(17, 1, 0xF, &[], s);
    assert_eq!(b.send(&p).0.len(), 4);
    let h = b.ob.health(b.now);
    assert_eq!(h.tc_refused, want);
    assert_eq!(h.tc_accepted, 3);
    assert_eq!(h.datagrams, cases.len() as u64 + 5);
    assert_eq!(b.ob.destination(), Some(ground()));
}

#[test]
fn a_replayed_or_old_sequence_number_is_refused_across_restarts() {
    let mut b = Bench::new("replay");
    let p = b.tc(17, 1, &[]);
    assert_eq!(b.send(&p).0.len(), 4);
    assert_eq!(refusal(&b.send(&p).0), Failure::Replayed);
    let old = b.tc_with(17, 1, 0xF, &[], 0);
    assert_eq!(refusal(&b.send(&old).0), Failure::Replayed);
    b.seq = 41;
    let p41 = b.tc(17, 1, &[]);
    assert_eq!(b.send(&p41).0.len(), 4);
    // A new incarnation reads the last accepted number back.
    let g = ReplayGuard::open(&b.dir.join("tc-sequence.state")).unwrap();
    assert_eq!(g.last(), Some(42));
    b.ob = Onboard::new(key(), g, 2000);
    b.ob.set_destination(ground());
    assert_eq!(refusal(&b.send(&p41).0), Failure::Replayed);
    let p = b.tc(17, 1, &[]);
    assert_eq!(b.send(&p).0.len(), 4);
}

#[test]
fn a_number_that_cannot_be_kept_refuses_the_telecommand() {
    let mut b = Bench::new("notsaved");
    b.connect();
    std::fs::remove_dir_all(&b.dir).unwrap();
    let p = b.tc(17, 1, &[]);
    assert_eq!(refusal(&b.send(&p).0), Failure::StateNotSaved);
    let p = b.tc(8, 1, &function_call(&Function::Shutdown));
    let (tm, r) = b.send(&p);
    assert_eq!(refusal(&tm), Failure::StateNotSaved);
    assert!(r.is_none());
}

#[test]
fn a_refused_datagram_never_moves_the_destination() {
    let mut b = Bench::new("dest");
    b.connect();
    let p = b.tc(17, 1, &[]);
    let bad = resealed(&p, |q| q[20] ^= 1);
    let (tm, _) = b.send_from(&bad, other());
    assert_eq!(refusal(&tm), Failure::BadMac);
    assert_eq!(b.ob.destination(), Some(ground()));
    let p = b.tc(17, 1, &[0]);
    b.send_from(&p, other());
    assert_eq!(b.ob.destination(), Some(ground()));
    let p = b.tc(17, 1, &[]);
    b.send_from(&p, other());
    assert_eq!(b.ob.destination(), Some(other()));
    assert_eq!(b.ob.take_destination_change(), Some(other()));
}

#[test]
fn functions_are_forwarded_and_answered_from_the_supervisors_notes() {
    let mut b = Bench::new("functions");
    b.connect();
    let call = Function::Start {
        seed: 9,
        duration_s: 3600.0,
    };
    let p = b.tc(8, 1, &function_call(&call));
    let (tm, r) = b.send(&p);
    assert_eq!(types(&tm), [(1, 1)]);
    let r = r.unwrap();
    assert_eq!(
        (r.function, r.seed, r.duration_s, r.token),
        (1, 9, 3600.0, 1000)
    );
    let note = |kind, code, token| GroundNote {
        kind,
        code,
        token,
        ..GroundNote::default()
    };
    b.ob.on_note(&note(NOTE_STARTED, 0, 999));
    assert!(b.drain().is_empty());
    b.ob.on_note(&note(NOTE_STARTED, 0, r.token));
    let tm = b.drain();
    assert_eq!((types(&tm), &tm[0].2[..]), (vec![(1, 3)], &p[..4]));
    b.ob.on_note(&note(NOTE_DONE, 0, r.token));
    assert_eq!(types(&b.drain()), [(1, 7)]);
    b.ob.on_note(&note(NOTE_DONE, 0, r.token));
    assert!(b.drain().is_empty());
    // Function 3 refused by the supervisor: 1,8 with its code, counted.
    let p = b.tc(8, 1, &function_call(&Function::Apply));
    let (_, r) = b.send(&p);
    let r = r.unwrap();
    assert_eq!((r.function, r.token), (3, 1001));
    b.ob.on_note(&note(NOTE_DONE, Failure::UnverifiedResult as u32, r.token));
    let tm = b.drain();
    assert_eq!(types(&tm), [(1, 8), (5, 2)]);
    assert_eq!(tm[0].2[4..], [0, 24]);
    let h = b.ob.health(b.now);
    assert_eq!(h.tc_refused[Failure::UnverifiedResult as usize - 1], 1);
    // Zero duration is the scenario's, whatever the limits.
    let p = b.tc(
        8,
        1,
        &function_call(&Function::Start {
            seed: 1,
            duration_s: 0.0,
        }),
    );
    assert!(b.send(&p).1.is_some());
    // More requests than slots: the oldest are forgotten, nothing breaks.
    for _ in 0..3 * MAX_PENDING {
        let p = b.tc(8, 1, &function_call(&Function::Restore));
        assert!(b.send(&p).1.is_some());
    }
}

#[test]
fn housekeeping_is_periodic_at_its_intervals_and_on_request() {
    let mut b = Bench::new("hk");
    b.connect();
    let t0 = b.now;
    b.ob.tick(t0);
    // Structure 1 waits for an estimate.
    let tm = b.drain();
    assert_eq!(types(&tm), [(3, 25)]);
    assert_eq!(decode_structure(&tm[0].2).unwrap().0, 2);
    let mut e = EstimateMsg::default();
    e.header.sim_time_ns = 86_400_000_000_000 + 5_000_000;
    b.ob.on_estimate(&e);
    let mut reports = [0; 2];
    for ms in (0..=10_000).step_by(100) {
        b.ob.tick(t0 + ms * 1_000_000);
        for p in b.drain() {
            reports[decode_structure(&p.2).unwrap().0 as usize - 1] += 1;
        }
    }
    // Structure 1 every 1 s (its schedule ran while it waited), structure 2 every 5 s.
    assert_eq!(reports, [10, 2]);
    // 3,31 and 20,3 set the intervals; 3,6 disables; 3,27 reports once per structure.
    let p = b.tc(3, 31, &interval_list(&[(1, 200)]).unwrap());
    b.send(&p);
    let p = b.tc(3, 6, &id_list(&[2]).unwrap());
    b.send(&p);
    let t1 = b.now;
    let mut n = 0;
    for ms in (100..=1000).step_by(100) {
        b.ob.tick(t1 + ms * 1_000_000);
        n += b.drain().len();
    }
    assert_eq!(n, 5);
    let p = b.tc(3, 27, &id_list(&[2, 1, 2]).unwrap());
    let (tm, _) = b.send(&p);
    assert_eq!(types(&tm), [(1, 1), (1, 3), (3, 25), (3, 25), (1, 7)]);
    let (_, hk1) = decode_structure(&tm[3].2).unwrap();
    assert_eq!(hk1.len(), 47);
    let p = b.tc(20, 1, &id_list(&[1, 2]).unwrap());
    let (tm, _) = b.send(&p);
    let mut vals = vec![];
    decode_report(&tm[2].2, |d, bits| vals.push((d.id, bits))).unwrap();
    assert_eq!(vals, [(1, 200), (2, 5000)]);
}

#[test]
fn parameters_are_reported_and_set_within_their_limits() {
    let mut b = Bench::new("params");
    b.connect();
    let mut g = GroundState {
        table_valid: 1,
        table_campaign: 3,
        ..GroundState::default()
    };
    g.table.k[1][2] = -2.5e-6;
    g.table.r_sigma[1][2] = 1e-4;
    b.ob.on_ground_state(&g);
    let p = b.tc(20, 1, &id_list(&[3, 4, 10, 27, 45, 46, 47]).unwrap());
    let (tm, _) = b.send(&p);
    assert_eq!(types(&tm), [(1, 1), (1, 3), (20, 2), (1, 7)]);
    let mut vals = vec![];
    decode_report(&tm[2].2, |d, bits| vals.push((d.id, bits))).unwrap();
    assert_eq!(
        vals,
        [
            (3, 60f64.to_bits()),
            (4, 1e6f64.to_bits()),
            (10, 0),
            (27, (-2.5e-6f64).to_bits()),
            (45, 1e-4f64.to_bits()),
            (46, 3),
            (47, 1)
        ]
    );
    // A minimum above the maximum is refused and nothing is applied.
    let set = |b: &mut Bench, v: &[(u16, u64)]| {
        let p = b.tc(20, 3, &value_list(v).unwrap());
        b.send(&p).0
    };
    let tm = set(&mut b, &[(4, 100f64.to_bits()), (3, 200f64.to_bits())]);
    assert_eq!(refusal(&tm), Failure::OutOfRange);
    let tm = set(
        &mut b,
        &[(4, 100f64.to_bits()), (3, 50f64.to_bits()), (1, 500)],
    );
    assert_eq!(types(&tm), [(1, 1), (1, 3), (1, 7)]);
    let get = |b: &Onboard, id| b.value(parameter(id).unwrap());
    assert_eq!(get(&b.ob, 3), 50f64.to_bits());
    assert_eq!(get(&b.ob, 1), 500);
    let start = |d| {
        function_call(&Function::Start {
            seed: 1,
            duration_s: d,
        })
    };
    let p = b.tc(8, 1, &start(120.0));
    assert_eq!(refusal(&b.send(&p).0), Failure::OutOfRange);
    let p = b.tc(8, 1, &start(100.0));
    assert_eq!(b.send(&p).1.map(|r| r.epoch_day), Some(0.0));
    // The campaign's epoch: range-checked, then carried by the next start.
    for bad in [-1e-3, 3650.5, f64::NAN, f64::INFINITY] {
        let tm = set(&mut b, &[(5, bad.to_bits())]);
        assert_eq!(refusal(&tm), Failure::OutOfRange, "{bad}");
    }
    assert_eq!(get(&b.ob, 5), 0f64.to_bits());
    let tm = set(&mut b, &[(5, 29.5f64.to_bits())]);
    assert_eq!(types(&tm), [(1, 1), (1, 3), (1, 7)]);
    assert_eq!(get(&b.ob, 5), 29.5f64.to_bits());
    let p = b.tc(8, 1, &start(100.0));
    let r = b.send(&p).1.unwrap();
    assert_eq!((r.seed, r.duration_s, r.epoch_day), (1, 100.0, 29.5));
    assert!(PARAMETERS_READABLE
        .iter()
        .all(|&id| parameter(id).is_some()));
}

const PARAMETERS_READABLE: [u16; 3] = [1, 10, 47];

#[test]
fn events_follow_the_set_and_can_be_disabled() {
    let mut b = Bench::new("events");
    b.ob.on_ground_state(&GroundState {
        tmtc_restarts: 2,
        campaign: 4,
        ..GroundState::default()
    });
    // No destination yet: the restart event went nowhere; a restored destination hears
    // the next ones.
    assert!(b.drain().is_empty());
    b.ob.set_destination(ground());
    let mut e = EstimateMsg {
        status: 0x18,
        ..EstimateMsg::default()
    };
    b.ob.on_estimate(&e);
    assert!(b.drain().is_empty(), "the first estimate is no change");
    e.status = 0x08;
    b.ob.on_estimate(&e);
    let tm = b.drain();
    let ev = decode_event(tm[0].1, &tm[0].2).unwrap();
    assert_eq!((ev.def.id, &ev.args[..3]), (2, &[4, 0x18, 0x08][..]));
    // Stage restarts rising (the first status only sets the counts).
    let mut s = SetStatus {
        n_members: 2,
        ..SetStatus::default()
    };
    s.members[0] = MemberStatus {
        process: PROC_PLANT,
        restarts: 1,
        ..MemberStatus::default()
    };
    s.members[1] = MemberStatus {
        process: PROC_ESTIMATOR,
        ..MemberStatus::default()
    };
    b.ob.on_set_status(&s, b.now);
    assert!(b.drain().is_empty());
    s.members[1].restarts = 1;
    b.ob.on_set_status(&s, b.now);
    let tm = b.drain();
    assert_eq!(types(&tm), [(5, 3)]);
    let ev = decode_event(tm[0].1, &tm[0].2).unwrap();
    assert_eq!(&ev.args[..2], &[4, 1]);
    // The supervisor's events, as they are; unknown IDs are dropped.
    let note = GroundNote {
        kind: NOTE_EVENT,
        code: 10,
        args: [4, 3, 0, 0],
        ..GroundNote::default()
    };
    b.ob.on_note(&note);
    b.ob.on_note(&GroundNote { code: 99, ..note });
    let tm = b.drain();
    assert_eq!(types(&tm), [(5, 4)]);
    assert_eq!(tm[0].2, [0, 10, 0, 0, 0, 4, 3]);
    // 5,6 disables, 5,5 enables again.
    let p = b.tc(5, 6, &id_list(&[10]).unwrap());
    b.send(&p);
    b.ob.on_note(&note);
    assert!(b.drain().is_empty());
    let p = b.tc(5, 5, &id_list(&[10]).unwrap());
    b.send(&p);
    b.ob.on_note(&note);
    assert_eq!(b.drain().len(), 1);
    // A restarted TMTC process that has its destination says so.
    let g = ReplayGuard::open(&b.dir.join("tc-sequence.state")).unwrap();
    let mut ob = Onboard::new(key(), g, 5);
    ob.set_destination(ground());
    ob.on_ground_state(&GroundState {
        tmtc_restarts: 2,
        ..GroundState::default()
    });
    let p = ob.outbox_packet(0).unwrap();
    let t = decode_tm(p, APID).unwrap();
    let ev = decode_event(t.header.subtype, t.source_data).unwrap();
    assert_eq!((ev.def.id, &ev.args[..2]), (3, &[6, 2][..]));
}

#[test]
fn health_reports_the_set_and_the_link() {
    let mut b = Bench::new("health");
    b.connect();
    b.set_mode(Mode::Running);
    let mut s = SetStatus {
        n_members: 1,
        n_samples: 5000,
        ..SetStatus::default()
    };
    s.members[0].process = PROC_ESTIMATOR;
    s.members[0].heard = 1;
    s.members[0].heartbeat_age_ns = 12_500_000;
    s.members[0].last.next_tick = 321;
    s.members[0].last.latency_count = 10;
    s.members[0].last.e2e_latency_us = [50.0, 90.0, 120.0];
    s.members[0].last.samples_lost = 2;
    b.ob.on_set_status(&s, b.now);
    let h = b.ob.health(b.now);
    assert_eq!((h.mode, h.n_samples, h.campaign_tick), (1, 5000, 321));
    assert_eq!(h.heartbeat_age_ms[3], 12.5);
    assert!(h.heartbeat_age_ms[0].is_nan());
    assert_eq!(h.e2e_latency_us, [50.0, 90.0, 120.0]);
    assert_eq!(h.samples_lost[3], 2);
    // Stale: no heartbeat ages.
    assert!(b.ob.health(b.now + 2_000_000_000).heartbeat_age_ms[3].is_nan());
    b.ob.sent(false);
    assert_eq!(b.ob.health(b.now).tm_send_errors, 1);
    let kinds: Vec<Kind> = crate::ground::health::HEALTH
        .iter()
        .map(|f| f.kind)
        .collect();
    assert_eq!(kinds[0], Kind::U8);
}

#[test]
fn a_flood_of_random_datagrams_is_refused_without_a_panic() {
    let mut b = Bench::new("flood");
    b.connect();
    b.set_mode(Mode::Running);
    let mut rng = ChaCha8Rng::seed_from_u64(50);
    let valid = [
        b.tc(17, 1, &[]),
        b.tc(8, 1, &function_call(&Function::Stop)),
        b.tc(20, 3, &value_list(&[(1, 100)]).unwrap()),
    ];
    // Each one accepted first: an unchanged copy in the flood is a replay.
    for v in &valid {
        assert_eq!(b.send(v).0[0].1, 1);
    }
    let n = 100_000;
    let mut buf = vec![0u8; 4096];
    for i in 0..n {
        let len = match i % 4 {
            0 => rng.gen_range(0..40),
            1 => rng.gen_range(0..4096),
            _ => {
                // A valid telecommand (already accepted, or replayed) with a few bytes
                // changed, resealed or not.
                let v = &valid[i % valid.len()];
                buf[..v.len()].copy_from_slice(v);
                for _ in 0..rng.gen_range(1..4) {
                    let at = rng.gen_range(0..v.len());
                    buf[at] = rng.gen();
                }
                if i % 8 == 2 {
                    let k = v.len() - CRC_LEN;
                    let c = crate::ground::crc::crc16(&buf[..k]);
                    buf[k..v.len()].copy_from_slice(&c.to_be_bytes());
                }
                v.len()
            }
        };
        if i % 4 < 2 {
            rng.fill(&mut buf[..len]);
        }
        let r = b.ob.datagram(&buf[..len], other(), b.now);
        assert!(r.is_none(), "datagram {i} was forwarded");
        // Reported one by one up to the limit in its second (all at one time here),
        // then only counted.
        let reported = i < super::MAX_REFUSAL_REPORTS_PER_S as usize;
        assert_eq!(
            b.ob.outbox_len(),
            if reported { 2 } else { 0 },
            "datagram {i}"
        );
        if i % 1000 == 0 {
            b.ob.tick(b.now + i as u64 * 1_000_000);
        }
        for _ in 0..b.ob.outbox_len() {
            b.ob.sent(true);
        }
        b.ob.clear_outbox();
    }
    let h = b.ob.health(b.now);
    assert_eq!(h.datagrams, n as u64 + 4);
    assert_eq!(h.tc_accepted, 4);
    assert_eq!(
        h.tc_refused.iter().map(|&c| u64::from(c)).sum::<u64>(),
        n as u64
    );
    assert_eq!(b.ob.destination(), Some(ground()));
    // The set still answers its ground station.
    let p = b.tc(17, 1, &[]);
    assert_eq!(b.send(&p).0.len(), 4);
}

#[test]
fn refusals_are_reported_up_to_the_limit_each_second_and_always_counted() {
    let mut b = Bench::new("refusal-limit");
    b.connect();
    let limit = super::MAX_REFUSAL_REPORTS_PER_S as usize;
    for second in 0..3u64 {
        let now = b.now + second * 1_000_000_000;
        let mut reported = 0;
        for _ in 0..limit + 7 {
            assert!(b.ob.datagram(&[0u8; 3], other(), now).is_none());
            reported += usize::from(b.ob.outbox_len() > 0);
            b.ob.clear_outbox();
        }
        assert_eq!(reported, limit, "second {second}");
    }
    let h = b.ob.health(b.now);
    let total = h.tc_refused.iter().map(|&c| u64::from(c)).sum::<u64>();
    assert_eq!(total, 3 * (limit as u64 + 7));
}
