//! The ground link's parsers, onboard and on the ground.
//!
//! Onboard: `Onboard::datagram` (src/ground/onboard.rs) with a fixed key, fed
//! unauthenticated datagrams (any bytes, and well-formed packets with a wrong MAC) and
//! correctly authenticated ones whose service, subtype, flags and application data are
//! fuzzed (the HMAC is computed over the fuzzed bytes, as the ground station would, so
//! the request parsers behind the authentication are reached), interleaved with the
//! estimates, supervisor states and clock ticks the TMTC process hands it. Every packet
//! the onboard side puts in its outbox must decode on the ground (`decode_tm`, then
//! `describe`, without an error value).
//!
//! On the ground: `packet::decode_tc`, `decode_tm`, `housekeeping::decode_structure`,
//! `events::decode_event`, `parameters::decode_report`, `readback::{estimate, health}`,
//! `describe::describe` and the saved-stream reader on any bytes: Ok or an error,
//! never a panic.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::OnceLock;
use taiji::ground::auth::{encode_signed_tc, Key, KEY_LEN};
use taiji::ground::client::saved;
use taiji::ground::describe::describe;
use taiji::ground::dictionary::{Mode, APID};
use taiji::ground::events::decode_event;
use taiji::ground::housekeeping::decode_structure;
use taiji::ground::onboard::Onboard;
use taiji::ground::packet::{decode_tc, decode_tm, TcHeader};
use taiji::ground::parameters::decode_report;
use taiji::ground::readback;
use taiji::ground::replay::ReplayGuard;
use taiji::sim::msg::{EstimateMsg, GroundState};

fn key() -> Key {
    Key::from_bytes([0x5A; KEY_LEN])
}

/// This process's folder for the anti-replay state (tmpfs when there is one: the
/// guard syncs its file on every accepted telecommand).
fn state_file() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| taiji_fuzz::scratch("telecommand").join("tc-sequence.state"))
}

#[derive(Arbitrary, Debug)]
enum Seq {
    /// One more than the last used: fresh.
    Next,
    /// The last used again: a replay.
    Same,
    Any(u32),
}

#[derive(Arbitrary, Debug)]
enum Step {
    /// Any bytes as a datagram.
    Raw(Vec<u8>),
    /// A well-formed, authenticated telecommand with fuzzed contents.
    Signed {
        service: u8,
        subtype: u8,
        ack_flags: u8,
        source_id: u16,
        seq: Seq,
        app: Vec<u8>,
        /// Flip one bit of the packet after signing it (the CRC resealed or not).
        flip: Option<(u16, u8, bool)>,
    },
    /// Well-formed, but signed with another key.
    WrongKey {
        service: u8,
        subtype: u8,
        app: Vec<u8>,
    },
    /// The estimator's latest estimate (any values).
    Estimate([u64; 8], u64),
    /// The supervisor's ground state.
    State {
        mode: u8,
        campaign: u32,
        table_valid: u32,
        table: [u64; 4],
        restarts: u32,
    },
    Tick(u32),
    /// The ground decoders on any bytes.
    Ground {
        subtype: u8,
        data: Vec<u8>,
    },
}

#[derive(Arbitrary, Debug)]
struct Input {
    steps: Vec<Step>,
}

fn ground_decoders(subtype: u8, data: &[u8]) {
    let _ = decode_tc(data, APID);
    let _ = decode_tm(data, APID);
    let _ = decode_structure(data);
    let _ = decode_event(subtype, data);
    let _ = decode_report(data, |_, _| {});
    let _ = readback::estimate(data);
    let _ = readback::health(data);
    let d = describe(data);
    assert!(!d.text.is_empty(), "describe gives a line");
    let (packets, _) = saved::read(data);
    for p in packets {
        let _ = describe(p);
    }
}

/// Every packet the onboard side queued decodes on the ground.
fn drain(ob: &mut Onboard) {
    for i in 0..ob.outbox_len() {
        let p = ob.outbox_packet(i).expect("a queued packet").to_vec();
        if let Err(e) = decode_tm(&p, APID) {
            panic!("the onboard side sent a packet the ground cannot decode: {e} ({p:02x?})");
        }
        let d = describe(&p);
        assert!(
            !d.is_error(),
            "the onboard side sent a packet the ground cannot describe: {} ({p:02x?})",
            d.text
        );
        ob.sent(true);
    }
    ob.clear_outbox();
}

fn run(input: &Input) {
    let path = state_file();
    let _ = std::fs::remove_file(path);
    let guard = ReplayGuard::open(path).expect("a fresh anti-replay state");
    let mut ob = Onboard::new(key(), guard, 1000);
    let ground: SocketAddr = "127.0.0.1:7400".parse().unwrap();
    let mut now: u64 = 1_000_000_000;
    let mut seq: u32 = 0;
    let mut count: u16 = 0;
    let mut buf = vec![0u8; 70_000];
    for step in input.steps.iter().take(256) {
        now += 1_000_000;
        match step {
            Step::Raw(bytes) => {
                let _ = ob.datagram(bytes, ground, now);
            }
            Step::Signed {
                service,
                subtype,
                ack_flags,
                source_id,
                seq: s,
                app,
                flip,
            } => {
                count = (count + 1) & 0x3FFF;
                let n = match s {
                    Seq::Next => {
                        seq = seq.saturating_add(1);
                        seq
                    }
                    Seq::Same => seq,
                    Seq::Any(v) => *v,
                };
                let h = TcHeader {
                    apid: APID,
                    sequence_count: count,
                    ack_flags: ack_flags & 0x0F,
                    service: *service,
                    subtype: *subtype,
                    source_id: *source_id,
                };
                let Ok(len) = encode_signed_tc(&mut buf, &h, app, n, &key()) else {
                    continue;
                };
                let mut p = buf[..len].to_vec();
                let mut changed = false;
                if let Some((at, bit, reseal)) = flip {
                    let i = usize::from(*at) % len;
                    // The CRC's own bits, resealed, give back the packet signed.
                    changed = i < len - 2 || !*reseal;
                    p[i] ^= 1 << (bit % 8);
                    if *reseal {
                        let c = taiji::ground::crc::crc16(&p[..len - 2]);
                        p[len - 2..].copy_from_slice(&c.to_be_bytes());
                    }
                }
                let req = ob.datagram(&p, ground, now);
                if changed {
                    assert!(
                        req.is_none(),
                        "a telecommand changed after signing was accepted"
                    );
                }
            }
            Step::WrongKey {
                service,
                subtype,
                app,
            } => {
                count = (count + 1) & 0x3FFF;
                let h = TcHeader {
                    apid: APID,
                    sequence_count: count,
                    ack_flags: 0x0F,
                    service: *service,
                    subtype: *subtype,
                    source_id: 1,
                };
                let other = Key::from_bytes([0xA5; KEY_LEN]);
                seq = seq.saturating_add(1);
                if let Ok(len) = encode_signed_tc(&mut buf, &h, app, seq, &other) {
                    let p = buf[..len].to_vec();
                    let before = ob.destination();
                    assert!(ob
                        .datagram(&p, "10.0.0.9:1".parse().unwrap(), now)
                        .is_none());
                    assert_eq!(
                        ob.destination(),
                        before,
                        "a refused datagram moved the telemetry"
                    );
                }
            }
            Step::Estimate(words, status) => {
                let mut e = EstimateMsg::default();
                e.header.seq = words[0];
                e.header.sim_time_ns = words[1] as i64;
                e.beta[0][0] = f64::from_bits(words[2]);
                e.beta_sigma[1][2] = f64::from_bits(words[3]);
                e.r_b[0][1] = f64::from_bits(words[4]);
                e.chi2_per_dof[0] = f64::from_bits(words[5]);
                e.n_used = words[6];
                e.rejected_by_cause[3] = words[7];
                e.status = *status;
                ob.on_estimate(&e);
            }
            Step::State {
                mode,
                campaign,
                table_valid,
                table,
                restarts,
            } => {
                let mut g = GroundState {
                    mode: u32::from(*mode % (Mode::ALL.len() as u8 + 1)),
                    campaign: *campaign,
                    table_valid: *table_valid,
                    tmtc_restarts: *restarts,
                    ..GroundState::default()
                };
                g.table.beta[0][0] = f64::from_bits(table[0]);
                g.table.r_sigma[1][2] = f64::from_bits(table[1]);
                g.table.k[1][0] = f64::from_bits(table[2]);
                g.table.beta_sigma[0][1] = f64::from_bits(table[3]);
                ob.on_ground_state(&g);
            }
            Step::Tick(dt) => {
                now += u64::from(*dt) * 1000;
                ob.tick(now);
            }
            Step::Ground { subtype, data } => ground_decoders(*subtype, data),
        }
        drain(&mut ob);
    }
}

fuzz_target!(|input: Input| {
    run(&input);
});
