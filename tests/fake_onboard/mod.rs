//! A fake onboard end of the ground link for the ground tools' tests: a UDP socket on a
//! thread that checks each telecommand's MAC with the test's key and answers the way the
//! set does (TMTC.md), with telemetry built by the library's own encoders: 1,1 / 1,3 /
//! 1,7 as the acknowledgement flags ask, 1,2 `bad_mac` or `replayed`, 17,2, 20,2, 3,25,
//! and, once a telecommand was accepted, a stream of housekeeping to its sender.
#![allow(dead_code)]

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use taiji::ground::auth::{self, Key};
use taiji::ground::dictionary::{verification_data, Failure, Kind, Mode, APID};
use taiji::ground::events::{encode_event, event, EV_MODE_CHANGED};
use taiji::ground::health::{encode_health, Health, HEALTH_LEN};
use taiji::ground::housekeeping::{encode_estimate, Source, ESTIMATE_LEN};
use taiji::ground::packet::{decode_tc, encode_tm, CdsShort, TmHeader};
use taiji::ground::parameters::parameter;
use taiji::ground::requests::value_list;
use taiji::sim::msg::EstimateMsg;

/// A telecommand the fake received.
#[derive(Debug, Clone)]
pub struct Heard {
    pub service: u8,
    pub subtype: u8,
    pub ack: u8,
    /// Before the trailer.
    pub app_data: Vec<u8>,
    pub seq: u32,
    pub mac_ok: bool,
    pub from: SocketAddr,
}

/// How the fake answers.
#[derive(Debug, Clone, Default)]
pub struct Behaviour {
    /// Answers nothing at all.
    pub silent: bool,
    /// Refuses a sequence number not larger than the last accepted (1,2 `replayed`).
    pub check_replay: bool,
    /// After the first accepted telecommand: structure 1 and 2 and a `mode_changed`
    /// event this often, to the sender of the last accepted telecommand.
    pub stream_every: Option<Duration>,
    /// Function 3 (apply) ends in this completion failure.
    pub apply_fails: Option<Failure>,
    /// 20,3 is refused at acceptance with this failure.
    pub set_fails: Option<Failure>,
    /// Every report, a refusal's too, goes to the sender of the last accepted
    /// telecommand (none before one), as the set sends them; otherwise a refusal goes
    /// back to its telecommand's sender.
    pub to_last_accepted: bool,
}

pub struct Fake {
    pub addr: SocketAddr,
    heard: Arc<Mutex<Vec<Heard>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Fake {
    pub fn start(key: Key, b: Behaviour) -> Fake {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket
            .set_read_timeout(Some(Duration::from_millis(20)))
            .unwrap();
        let addr = socket.local_addr().unwrap();
        let heard = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (h, s) = (heard.clone(), stop.clone());
        let thread = std::thread::spawn(move || serve(socket, key, b, h, s));
        Fake {
            addr,
            heard,
            stop,
            thread: Some(thread),
        }
    }

    pub fn heard(&self) -> Vec<Heard> {
        self.heard.lock().unwrap().clone()
    }

    pub fn to(&self) -> String {
        self.addr.to_string()
    }
}

impl Drop for Fake {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The estimate the fake reports in structure 1: a distinct value in every field.
pub fn estimate() -> EstimateMsg {
    let mut e = EstimateMsg::default();
    let mut v = 1.0f64;
    for a in [
        &mut e.beta,
        &mut e.beta_sigma,
        &mut e.k,
        &mut e.k_sigma,
        &mut e.r_b,
        &mut e.r_sigma,
    ] {
        for x in a.iter_mut().flatten() {
            v *= -1.37;
            *x = v.abs() * 1e-7;
        }
    }
    e.chi2_per_dof = [0.97, 1.02, 1.5, 0.8];
    e.status = 0x18;
    (e.n_used, e.n_rejected, e.header.tick, e.solved_tick) = (480, 20, 499, 480);
    e
}

/// The health the fake reports in structure 2.
pub fn health() -> Health {
    let mut h = Health {
        mode: Mode::Running as u8,
        campaign: 2,
        campaign_tick: 500,
        n_samples: 1000,
        tmtc_restarts: 0,
        stage_restarts: 3,
        tc_accepted: 5,
        datagrams: 9,
        tm_sent: 40,
        ..Health::default()
    };
    h.restarts = [0, 1, 0, 2, 0];
    h.heartbeat_age_ms = [12.0, 15.0, 18.0, 21.0, f64::NAN];
    h.samples_lost = [0, 0, 0, 7, 0];
    h.e2e_latency_us = [80.0, 120.0, 300.0];
    h
}

struct Tx {
    socket: UdpSocket,
    counter: u16,
    t0: Instant,
}

impl Tx {
    fn send(&mut self, to: SocketAddr, service: u8, subtype: u8, data: &[u8]) {
        self.counter = self.counter.wrapping_add(1);
        let h = TmHeader {
            apid: APID,
            sequence_count: self.counter & 0x3FFF,
            service,
            subtype,
            message_counter: self.counter,
            destination_id: 0,
            time: CdsShort::from_ns(self.t0.elapsed().as_nanos() as i64),
        };
        let mut out = vec![0u8; 2048];
        let n = encode_tm(&mut out, &h, data).unwrap();
        let _ = self.socket.send_to(&out[..n], to);
    }

    fn report(&mut self, to: SocketAddr, subtype: u8, tc: &[u8], f: Option<Failure>) {
        let (d, n) = verification_data(tc, f);
        self.send(to, 1, subtype, &d[..n]);
    }

    fn housekeeping(&mut self, to: SocketAddr, structure: u16) {
        match structure {
            1 => {
                let e = estimate();
                let mut d = [0u8; ESTIMATE_LEN];
                let src = Source {
                    estimate: &e,
                    mode: Mode::Running,
                };
                encode_estimate(&src, &mut d).unwrap();
                self.send(to, 3, 25, &d);
            }
            _ => {
                let mut d = [0u8; HEALTH_LEN];
                encode_health(&health(), &mut d).unwrap();
                self.send(to, 3, 25, &d);
            }
        }
    }
}

fn ids(app: &[u8]) -> Vec<u16> {
    app.get(1..)
        .unwrap_or_default()
        .chunks_exact(2)
        .map(|c| u16::from_be_bytes([c[0], c[1]]))
        .collect()
}

fn serve(
    socket: UdpSocket,
    key: Key,
    b: Behaviour,
    heard: Arc<Mutex<Vec<Heard>>>,
    stop: Arc<AtomicBool>,
) {
    let mut tx = Tx {
        socket: socket.try_clone().unwrap(),
        counter: 0,
        t0: Instant::now(),
    };
    let mut buf = vec![0u8; 70_000];
    let mut last: Option<u32> = None;
    let mut ground: Option<SocketAddr> = None;
    let mut next_stream = Instant::now();
    while !stop.load(Ordering::SeqCst) {
        if let (Some(every), Some(to)) = (b.stream_every, ground) {
            if Instant::now() >= next_stream {
                next_stream = Instant::now() + every;
                tx.housekeeping(to, 1);
                tx.housekeeping(to, 2);
                let def = event(EV_MODE_CHANGED).unwrap();
                let mut d = [0u8; 64];
                let n = encode_event(def, &[0, 1, 2], &mut d).unwrap();
                tx.send(to, 5, def.severity, &d[..n]);
            }
        }
        let Ok((n, from)) = socket.recv_from(&mut buf) else {
            continue;
        };
        if b.silent {
            continue;
        }
        let p = buf[..n].to_vec();
        let tc = match decode_tc(&p, APID) {
            Ok(tc) => tc,
            Err(e) => {
                if let Some(to) = if b.to_last_accepted {
                    ground
                } else {
                    Some(from)
                } {
                    tx.report(to, 2, &p, Some(e.into()));
                }
                continue;
            }
        };
        let auth = auth::verify(&key, &tc);
        let (seq, app) = match &auth {
            Ok(a) => (a.seq, a.app_data.to_vec()),
            Err(_) => (0, Vec::new()),
        };
        let h = tc.header;
        heard.lock().unwrap().push(Heard {
            service: h.service,
            subtype: h.subtype,
            ack: h.ack_flags,
            app_data: app.clone(),
            seq,
            mac_ok: auth.is_ok(),
            from,
        });
        let refused = match auth {
            Err(e) => Some(e.into()),
            Ok(_) if b.check_replay && last.is_some_and(|l| seq <= l) => Some(Failure::Replayed),
            Ok(_) if (h.service, h.subtype) == (20, 3) => b.set_fails,
            Ok(_) => None,
        };
        if let Some(f) = refused {
            let to = if b.to_last_accepted {
                ground
            } else {
                Some(from)
            };
            if let Some(to) = to {
                tx.report(to, 2, &p, Some(f));
            }
            continue;
        }
        last = Some(seq);
        ground = Some(from);
        answer(
            &mut tx,
            &b,
            from,
            &p,
            h.service,
            h.subtype,
            h.ack_flags,
            &app,
        );
    }
}

#[allow(clippy::too_many_arguments)]
fn answer(
    tx: &mut Tx,
    b: &Behaviour,
    from: SocketAddr,
    p: &[u8],
    service: u8,
    subtype: u8,
    ack: u8,
    app: &[u8],
) {
    if ack & 1 != 0 {
        tx.report(from, 1, p, None);
    }
    if ack & 2 != 0 {
        tx.report(from, 3, p, None);
    }
    match (service, subtype) {
        (17, 1) => tx.send(from, 17, 2, &[]),
        (20, 1) => {
            let entries: Vec<(u16, u64)> = ids(app)
                .into_iter()
                .filter_map(parameter)
                .map(|d| {
                    let v = d.default.unwrap_or(1.0);
                    let bits = if d.kind == Kind::F64 {
                        v.to_bits()
                    } else {
                        v as u64
                    };
                    (d.id, bits)
                })
                .collect();
            tx.send(from, 20, 2, &value_list(&entries).unwrap());
        }
        (3, 27) => {
            for s in ids(app) {
                tx.housekeeping(from, s);
            }
        }
        (8, 1) if app == [0, 3] => {
            if let Some(f) = b.apply_fails {
                tx.report(from, 8, p, Some(f));
                return;
            }
        }
        _ => {}
    }
    if ack & 8 != 0 {
        tx.report(from, 7, p, None);
    }
}
