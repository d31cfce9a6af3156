//! The onboard side of the ground link as a state machine: datagrams in, telemetry
//! packets out (into `downlink`'s fixed outbox) and, for an accepted function of
//! service 8, a `GroundRequest` for the supervisor. It reads the set through the bus
//! messages the TMTC process hands it (`EstimateMsg`, `SetStatus`, `GroundState`,
//! `GroundNote`) and owns no socket and no clock: the process passes the sender's address
//! and a monotonic time. Everything it needs is allocated at construction; handling a
//! datagram, a message or a tick touches no heap.
//!
//! A datagram passes, in order: the packet checks (`packet::decode_tc`), the MAC
//! (`auth::verify`), the anti-replay check (`replay`), the routing
//! (`dictionary::route`), its application data (`requests`) and, for 8,1, the set's
//! mode and the start's duration limits (parameters 3 and 4). The first check it fails
//! refuses it: a 1,2 report with the failure code (sent whatever the acknowledgement
//! flags ask), a `tc_refused` event and a count in housekeeping structure 2; it is never
//! executed. A datagram that passes is accepted: its sequence number is kept on disk
//! first (else `state_not_saved`, refused), then its sender becomes the telemetry's
//! destination, and it is executed. Telemetry goes only to the sender of the last
//! accepted telecommand: a refused datagram (unauthenticated or not) never changes it,
//! and its 1,2 report goes to the current destination, if there is one (else nowhere).
//! Success reports (1,1 / 1,3 / 1,7) follow the acknowledgement flags; failure reports
//! are always sent. A function of service 8 is answered 1,1 here, and 1,3 and 1,7 / 1,8
//! when the supervisor's `GroundNote`s for its token arrive.

use super::auth::{verify, Key};
use super::dictionary::{
    route, verification_data, write_bits, Failure, Function, IdList, Mode, APID, N_FAILURES,
    REQUEST_ID_LEN,
};
use super::downlink::Downlink;
use super::events::{self as ev, encode_event, event, EVENTS};
use super::health::{encode_health, Health, HEALTH_LEN, STAGES, STRUCTURE_HEALTH};
use super::housekeeping::{encode_estimate, Source, ESTIMATE_LEN, STRUCTURE_ESTIMATE};
use super::packet::{decode_tc, CdsShort, Tc, TcHeader};
use super::parameters::{self as par, parameter, ParamDef};
use super::replay::ReplayGuard;
use super::requests::{self, Intervals, Values};
use crate::sim::msg::{
    EstimateMsg, GroundNote, GroundRequest, GroundState, Header, SetStatus, MAX_MEMBERS, NOTE_DONE,
    NOTE_EVENT, NOTE_STARTED, PROC_ESTIMATOR, PROC_TMTC,
};
use std::net::SocketAddr;

/// Acknowledgement flags (TC secondary header): bit 0 acceptance, 1 start, 3 completion.
pub const ACK_ACCEPTANCE: u8 = 0b0001;
pub const ACK_START: u8 = 0b0010;
pub const ACK_COMPLETION: u8 = 0b1000;

/// Requests forwarded to the supervisor and not answered yet, at most (the oldest is
/// forgotten when a newer one needs its slot).
pub const MAX_PENDING: usize = 8;

/// A `SetStatus` older than this says nothing about heartbeats any more [ns].
const STATUS_STALE_NS: u64 = 1_000_000_000;

/// A forwarded request waiting for its `GroundNote`s.
#[derive(Debug, Clone, Copy)]
struct Pending {
    token: u64,
    request: [u8; REQUEST_ID_LEN],
    flags: u8,
    source_id: u16,
}

/// A telecommand's application data, decoded and checked.
enum Request<'a> {
    Ping,
    Housekeeping(IdList<'a>, bool),
    OneShot(IdList<'a>),
    Intervals(Intervals<'a>),
    Events(IdList<'a>, bool),
    Function(Function),
    Report(IdList<'a>),
    Set(Values<'a>),
}

/// The ground link's onboard state.
pub struct Onboard {
    key: Key,
    replay: ReplayGuard,
    down: Downlink,
    dest: Option<SocketAddr>,
    dest_id: u16,
    dest_changed: bool,
    state: GroundState,
    state_heard: bool,
    estimate: EstimateMsg,
    estimate_heard: bool,
    status: SetStatus,
    status_at_ns: Option<u64>,
    /// Last restart count seen per `PROC_*` (index), from `SetStatus`.
    restarts_seen: [u32; MAX_MEMBERS],
    /// Per structure (index = ID − 1).
    hk_enabled: [bool; 2],
    interval_ms: [u32; 2],
    next_hk_ns: [u64; 2],
    min_duration_s: f64,
    max_duration_s: f64,
    /// The epoch function 1 starts a campaign at [mission day].
    epoch_day: f64,
    /// Per event (index = ID − 1).
    events_enabled: [bool; EVENTS.len()],
    pending: [Option<Pending>; MAX_PENDING],
    next_token: u64,
    request_seq: u64,
    tc_accepted: u32,
    tc_refused: [u32; N_FAILURES],
    datagrams: u64,
    tm_sent: u64,
    tm_send_errors: u32,
    /// The current datagram's time [ns], and the refusals reported in its second.
    now_ns: u64,
    refusal_second: u64,
    refusals_reported: u32,
}

/// Refusals reported one by one per second at most (each a 1,2 and an event); a flood
/// beyond it is counted in housekeeping structure 2's `tc_refused`, not reported.
pub const MAX_REFUSAL_REPORTS_PER_S: u32 = 50;

fn default_of(id: u16) -> f64 {
    parameter(id).and_then(|p| p.default).unwrap_or(0.0)
}

/// The function's ID (`dictionary::FUNCTIONS`).
pub fn function_id(f: &Function) -> u16 {
    match f {
        Function::Start { .. } => 1,
        Function::Stop => 2,
        Function::Apply => 3,
        Function::Restore => 4,
        Function::Shutdown => 5,
    }
}

impl Onboard {
    /// The link's state with `key`, the anti-replay state `replay`, and tokens for the
    /// supervisor counted from `token_base` (a restarted process passes a new base, so
    /// an answer meant for its previous incarnation matches nothing).
    pub fn new(key: Key, replay: ReplayGuard, token_base: u64) -> Onboard {
        Onboard {
            key,
            replay,
            down: Downlink::new(),
            dest: None,
            dest_id: 0,
            dest_changed: false,
            state: GroundState::default(),
            state_heard: false,
            estimate: EstimateMsg::default(),
            estimate_heard: false,
            status: SetStatus::default(),
            status_at_ns: None,
            restarts_seen: [0; MAX_MEMBERS],
            hk_enabled: [true; 2],
            interval_ms: [
                default_of(par::PAR_HK1_INTERVAL_MS) as u32,
                default_of(par::PAR_HK2_INTERVAL_MS) as u32,
            ],
            next_hk_ns: [0; 2],
            min_duration_s: default_of(par::PAR_START_MIN_DURATION_S),
            max_duration_s: default_of(par::PAR_START_MAX_DURATION_S),
            epoch_day: default_of(par::PAR_CAMPAIGN_EPOCH_DAY),
            events_enabled: [true; EVENTS.len()],
            pending: [None; MAX_PENDING],
            next_token: token_base,
            request_seq: 0,
            tc_accepted: 0,
            tc_refused: [0; N_FAILURES],
            datagrams: 0,
            tm_sent: 0,
            tm_send_errors: 0,
            now_ns: 0,
            refusal_second: 0,
            refusals_reported: 0,
        }
    }

    /// Where telemetry goes: the sender of the last accepted telecommand.
    pub fn destination(&self) -> Option<SocketAddr> {
        self.dest
    }

    /// Sets the destination (a restarted process restores the one it kept).
    pub fn set_destination(&mut self, dest: SocketAddr) {
        self.dest = Some(dest);
    }

    /// The destination, when an accepted telecommand changed it since the last call.
    pub fn take_destination_change(&mut self) -> Option<SocketAddr> {
        std::mem::take(&mut self.dest_changed)
            .then_some(self.dest)
            .flatten()
    }

    /// Packets waiting to be sent to `destination()`.
    pub fn outbox_len(&self) -> usize {
        self.down.len()
    }

    /// Packet `i` of those waiting.
    pub fn outbox_packet(&self, i: usize) -> Option<&[u8]> {
        self.down.packet(i)
    }

    /// Empties the outbox (after sending it).
    pub fn clear_outbox(&mut self) {
        self.down.clear();
    }

    /// Counts a packet the process sent (`true`) or the socket refused.
    pub fn sent(&mut self, ok: bool) {
        if ok {
            self.tm_sent += 1;
        } else {
            self.tm_send_errors = self.tm_send_errors.wrapping_add(1);
        }
    }

    /// The set's mode as the supervisor last said it.
    pub fn mode(&self) -> Mode {
        Mode::ALL
            .into_iter()
            .find(|m| *m as u32 == self.state.mode)
            .unwrap_or(Mode::Standby)
    }

    /// Telemetry time: the estimator's simulated time (0 before any estimate).
    fn time(&self) -> CdsShort {
        CdsShort::from_ns(self.estimate.header.sim_time_ns)
    }

    /// Writes a packet to the destination, if there is one.
    fn push(
        &mut self,
        service: u8,
        subtype: u8,
        dest_id: u16,
        len: usize,
        fill: impl FnOnce(&mut [u8]),
    ) {
        if self.dest.is_some() {
            let t = self.time();
            self.down.push(service, subtype, dest_id, t, len, fill);
        }
    }

    /// A verification report on request `request`: a success, or a failure with `code`.
    fn verification(&mut self, subtype: u8, dest_id: u16, request: &[u8], code: Option<u16>) {
        let (mut d, _) = verification_data(request, None);
        let n = match code {
            Some(c) => {
                d[REQUEST_ID_LEN..].copy_from_slice(&c.to_be_bytes());
                REQUEST_ID_LEN + 2
            }
            None => REQUEST_ID_LEN,
        };
        self.push(1, subtype, dest_id, n, |b| b.copy_from_slice(&d[..n]));
    }

    /// Reports event `id` with `args` (wire bits), when the event is enabled.
    pub fn event(&mut self, id: u16, args: &[u64]) {
        let Some(def) = event(id) else { return };
        if !self.events_enabled[usize::from(id) - 1] {
            return;
        }
        let len = ev::data_len(def);
        let dest_id = self.dest_id;
        self.push(5, def.severity, dest_id, len, |b| {
            let _ = encode_event(def, args, b);
        });
    }

    /// Counts a refusal with `code` in housekeeping.
    fn count(&mut self, code: u16) {
        if let Some(slot) = usize::from(code)
            .checked_sub(1)
            .and_then(|i| self.tc_refused.get_mut(i))
        {
            *slot = slot.wrapping_add(1);
        }
    }

    /// Counts a refusal with `code` and reports it as event `tc_refused`.
    fn count_refusal(&mut self, code: u16, service: u8, subtype: u8) {
        self.count(code);
        self.event(
            ev::EV_TC_REFUSED,
            &[code.into(), service.into(), subtype.into()],
        );
    }

    /// Refuses `datagram` (its header, when it decoded) with `f`: 1,2 and the event,
    /// up to `MAX_REFUSAL_REPORTS_PER_S`; always counted.
    fn refuse(&mut self, datagram: &[u8], header: Option<&TcHeader>, f: Failure) {
        let second = self.now_ns / 1_000_000_000;
        if second != self.refusal_second {
            (self.refusal_second, self.refusals_reported) = (second, 0);
        }
        let (service, subtype) = header.map_or((0, 0), |h| (h.service, h.subtype));
        if self.refusals_reported >= MAX_REFUSAL_REPORTS_PER_S {
            self.count(f.code());
            return;
        }
        self.refusals_reported += 1;
        let dest_id = header.map_or(self.dest_id, |h| h.source_id);
        self.verification(2, dest_id, datagram, Some(f.code()));
        self.count_refusal(f.code(), service, subtype);
    }

    /// Handles one datagram from `from` at monotonic time `now_ns`: the request to
    /// forward to the supervisor, for an accepted function of service 8.
    pub fn datagram(
        &mut self,
        bytes: &[u8],
        from: SocketAddr,
        now_ns: u64,
    ) -> Option<GroundRequest> {
        self.datagrams += 1;
        self.now_ns = now_ns;
        let tc = match decode_tc(bytes, APID) {
            Ok(tc) => tc,
            Err(e) => {
                self.refuse(bytes, None, e.into());
                return None;
            }
        };
        let h = tc.header;
        let request = match self.acceptance(&tc) {
            Ok(r) => r,
            Err(f) => {
                self.refuse(bytes, Some(&h), f);
                return None;
            }
        };
        self.tc_accepted = self.tc_accepted.wrapping_add(1);
        if self.dest != Some(from) {
            self.dest = Some(from);
            self.dest_changed = true;
        }
        self.dest_id = h.source_id;
        let mut id = [0u8; REQUEST_ID_LEN];
        id.copy_from_slice(&bytes[..REQUEST_ID_LEN]);
        if h.ack_flags & ACK_ACCEPTANCE != 0 {
            self.verification(1, h.source_id, &id, None);
        }
        if let Request::Function(f) = request {
            return Some(self.forward(f, &h, id, now_ns));
        }
        if h.ack_flags & ACK_START != 0 {
            self.verification(3, h.source_id, &id, None);
        }
        self.execute(request, h.source_id, now_ns);
        if h.ack_flags & ACK_COMPLETION != 0 {
            self.verification(7, h.source_id, &id, None);
        }
        None
    }

    /// The acceptance checks after the packet's: MAC, freshness, routing, application
    /// data, the function's conditions; then the sequence number is kept.
    fn acceptance<'a>(&mut self, tc: &Tc<'a>) -> Result<Request<'a>, Failure> {
        let h = &tc.header;
        let auth = verify(&self.key, tc)?;
        self.replay.check(auth.seq).map_err(|e| Failure::from(&e))?;
        route(h.service, h.subtype)?;
        let request = self.parse(h.service, h.subtype, auth.app_data)?;
        self.replay
            .accept(auth.seq)
            .map_err(|e| Failure::from(&e))?;
        Ok(request)
    }

    /// Decodes and checks a routed telecommand's application data.
    fn parse<'a>(&self, service: u8, subtype: u8, app: &'a [u8]) -> Result<Request<'a>, Failure> {
        Ok(match (service, subtype) {
            (3, 5) => Request::Housekeeping(requests::parse_structures(app)?, true),
            (3, 6) => Request::Housekeeping(requests::parse_structures(app)?, false),
            (3, 27) => Request::OneShot(requests::parse_structures(app)?),
            (3, 31) => Request::Intervals(requests::parse_intervals(app)?),
            (5, 5) => Request::Events(requests::parse_events(app)?, true),
            (5, 6) => Request::Events(requests::parse_events(app)?, false),
            (8, 1) => Request::Function(self.check_function(app)?),
            (20, 1) => Request::Report(requests::parse_parameter_ids(app)?),
            (20, 3) => Request::Set(self.check_values(app)?),
            (17, 1) => {
                requests::parse_empty(app)?;
                Request::Ping
            }
            _ => return Err(Failure::UnknownSubtype),
        })
    }

    /// 8,1: the function, its arguments, the start's limits and the set's mode.
    fn check_function(&self, app: &[u8]) -> Result<Function, Failure> {
        let f = super::dictionary::parse_function(app)?;
        let running = self.mode() == Mode::Running;
        match f {
            Function::Start { duration_s, .. } => {
                if duration_s != 0.0
                    && !(self.min_duration_s..=self.max_duration_s).contains(&duration_s)
                {
                    return Err(Failure::OutOfRange);
                }
                if running {
                    return Err(Failure::StartWhileRunning);
                }
            }
            Function::Stop if !running => return Err(Failure::NotRunning),
            _ => {}
        }
        Ok(f)
    }

    /// 20,3: the values, and the start's limits as they would be after it.
    fn check_values<'a>(&self, app: &'a [u8]) -> Result<Values<'a>, Failure> {
        let v = requests::parse_values(app)?;
        let (mut lo, mut hi) = (self.min_duration_s, self.max_duration_s);
        for (def, bits) in v.iter() {
            match def.id {
                par::PAR_START_MIN_DURATION_S => lo = f64::from_bits(bits),
                par::PAR_START_MAX_DURATION_S => hi = f64::from_bits(bits),
                _ => {}
            }
        }
        if lo > hi {
            return Err(Failure::OutOfRange);
        }
        Ok(v)
    }

    /// Keeps the request for its answers and makes the message for the supervisor.
    fn forward(
        &mut self,
        f: Function,
        h: &TcHeader,
        request: [u8; REQUEST_ID_LEN],
        now_ns: u64,
    ) -> GroundRequest {
        let token = self.next_token;
        self.next_token = self.next_token.wrapping_add(1);
        let p = Pending {
            token,
            request,
            flags: h.ack_flags,
            source_id: h.source_id,
        };
        let slot = match self.pending.iter().position(Option::is_none) {
            Some(i) => i,
            None => {
                // The oldest (smallest token since this base) gives way.
                self.pending.rotate_left(1);
                MAX_PENDING - 1
            }
        };
        self.pending[slot] = Some(p);
        let (seed, duration_s, epoch_day) = match f {
            Function::Start { seed, duration_s } => (seed, duration_s, self.epoch_day),
            _ => (0, 0.0, 0.0),
        };
        let header = Header {
            seq: self.request_seq,
            publish_ns: now_ns,
            ..Header::default()
        };
        self.request_seq += 1;
        GroundRequest {
            header,
            token,
            function: function_id(&f).into(),
            _pad: 0,
            seed,
            duration_s,
            epoch_day,
        }
    }

    /// Executes an accepted telecommand of services 3, 5, 17 and 20.
    fn execute(&mut self, r: Request, dest_id: u16, now_ns: u64) {
        match r {
            Request::Ping => self.push(17, 2, dest_id, 0, |_| {}),
            Request::Housekeeping(ids, on) => {
                for id in ids.iter() {
                    let i = usize::from(id) - 1;
                    self.hk_enabled[i] = on;
                    self.next_hk_ns[i] = now_ns;
                }
            }
            Request::OneShot(ids) => {
                let mut done = [false; 2];
                for id in ids.iter() {
                    let i = usize::from(id) - 1;
                    if !std::mem::replace(&mut done[i], true) {
                        self.report(id, dest_id, now_ns);
                    }
                }
            }
            Request::Intervals(l) => {
                for (id, ms) in l.iter() {
                    let i = usize::from(id) - 1;
                    self.interval_ms[i] = ms;
                    self.next_hk_ns[i] = now_ns + u64::from(ms) * 1_000_000;
                }
            }
            Request::Events(ids, on) => {
                for id in ids.iter() {
                    self.events_enabled[usize::from(id) - 1] = on;
                }
            }
            Request::Report(ids) => self.parameter_report(ids, dest_id),
            Request::Set(values) => {
                for (def, bits) in values.iter() {
                    self.set(def, bits, now_ns);
                }
            }
            Request::Function(_) => {}
        }
    }

    /// A parameter's value as wire bits.
    pub fn value(&self, def: &ParamDef) -> u64 {
        let t = &self.state.table;
        let i = usize::from(def.id.wrapping_sub(par::PAR_TABLE_FIRST));
        match def.id {
            par::PAR_HK1_INTERVAL_MS => self.interval_ms[0].into(),
            par::PAR_HK2_INTERVAL_MS => self.interval_ms[1].into(),
            par::PAR_START_MIN_DURATION_S => self.min_duration_s.to_bits(),
            par::PAR_START_MAX_DURATION_S => self.max_duration_s.to_bits(),
            par::PAR_CAMPAIGN_EPOCH_DAY => self.epoch_day.to_bits(),
            par::PAR_TABLE_CAMPAIGN => self.state.table_campaign.into(),
            par::PAR_TABLE_VALID => self.state.table_valid.min(1).into(),
            par::PAR_TABLE_FIRST..=par::PAR_TABLE_LAST => {
                let q = [t.beta, t.beta_sigma, t.k, t.k_sigma, t.r, t.r_sigma][i / 6];
                q[i % 6 / 3][i % 3].to_bits()
            }
            _ => 0,
        }
    }

    fn set(&mut self, def: &ParamDef, bits: u64, now_ns: u64) {
        match def.id {
            par::PAR_HK1_INTERVAL_MS | par::PAR_HK2_INTERVAL_MS => {
                let i = usize::from(def.id - par::PAR_HK1_INTERVAL_MS);
                self.interval_ms[i] = bits as u32;
                self.next_hk_ns[i] = now_ns + bits * 1_000_000;
            }
            par::PAR_START_MIN_DURATION_S => self.min_duration_s = f64::from_bits(bits),
            par::PAR_START_MAX_DURATION_S => self.max_duration_s = f64::from_bits(bits),
            par::PAR_CAMPAIGN_EPOCH_DAY => self.epoch_day = f64::from_bits(bits),
            _ => {}
        }
    }

    /// 20,2: the listed parameters' values.
    fn parameter_report(&mut self, ids: IdList, dest_id: u16) {
        let len = 1 + ids
            .iter()
            .filter_map(parameter)
            .map(|p| 2 + p.kind.size())
            .sum::<usize>();
        let mut vals = [0u64; 256];
        for (slot, id) in vals.iter_mut().zip(ids.iter()) {
            *slot = parameter(id).map_or(0, |p| self.value(p));
        }
        self.push(20, 2, dest_id, len, |b| {
            b[0] = ids.len() as u8;
            let mut at = 1;
            for (id, bits) in ids.iter().zip(vals) {
                let Some(p) = parameter(id) else { continue };
                b[at..at + 2].copy_from_slice(&id.to_be_bytes());
                write_bits(p.kind, bits, &mut b[at + 2..]);
                at += 2 + p.kind.size();
            }
        });
    }

    /// The set's health as structure 2 reports it, at monotonic time `now_ns`.
    pub fn health(&self, now_ns: u64) -> Health {
        let g = &self.state;
        let mut h = Health {
            mode: g.mode.min(u8::MAX.into()) as u8,
            campaign: g.campaign,
            tmtc_restarts: g.tmtc_restarts,
            stage_restarts: g.stage_restarts,
            tc_accepted: self.tc_accepted,
            tc_refused: self.tc_refused,
            datagrams: self.datagrams,
            tm_sent: self.tm_sent,
            tm_send_errors: self.tm_send_errors.wrapping_add(self.down.dropped),
            ..Health::default()
        };
        if self.status_at_ns.is_none() {
            return h;
        }
        let s = &self.status;
        let fresh = self.mode() == Mode::Running
            && self
                .status_at_ns
                .is_some_and(|t| now_ns.saturating_sub(t) < STATUS_STALE_NS);
        h.n_samples = s.n_samples;
        for m in s.members.iter().take(s.n_members as usize) {
            let Some(i) = (m.process as usize).checked_sub(1).filter(|&i| i < STAGES) else {
                continue;
            };
            h.restarts[i] = m.restarts;
            h.samples_lost[i] = m.last.samples_lost;
            if fresh && m.heard != 0 {
                h.heartbeat_age_ms[i] = m.heartbeat_age_ns as f64 / 1e6;
            }
            if m.process == PROC_ESTIMATOR {
                h.campaign_tick = m.last.next_tick;
                if m.last.latency_count > 0 {
                    h.e2e_latency_us = m.last.e2e_latency_us;
                }
            }
        }
        h
    }

    /// A report of structure `id` now.
    fn report(&mut self, id: u16, dest_id: u16, now_ns: u64) {
        if id == STRUCTURE_HEALTH {
            let h = self.health(now_ns);
            self.push(3, 25, dest_id, HEALTH_LEN, |b| {
                let _ = encode_health(&h, b);
            });
        } else if id == STRUCTURE_ESTIMATE {
            let e = self.estimate;
            let mode = self.mode();
            self.push(3, 25, dest_id, ESTIMATE_LEN, |b| {
                let _ = encode_estimate(&Source { estimate: &e, mode }, b);
            });
        }
    }

    /// The periodic reports due at monotonic time `now_ns`. Structure 1 waits for the
    /// first estimate.
    pub fn tick(&mut self, now_ns: u64) {
        for i in 0..2 {
            if !self.hk_enabled[i] || now_ns < self.next_hk_ns[i] {
                continue;
            }
            let every = u64::from(self.interval_ms[i]) * 1_000_000;
            let next = self.next_hk_ns[i] + every;
            self.next_hk_ns[i] = if next <= now_ns { now_ns + every } else { next };
            if i == 0 && !self.estimate_heard {
                continue;
            }
            let dest_id = self.dest_id;
            self.report(i as u16 + 1, dest_id, now_ns);
        }
    }

    /// The estimator's latest estimate: an event when its status word changed.
    pub fn on_estimate(&mut self, e: &EstimateMsg) {
        let old = self.estimate.status;
        let changed = self.estimate_heard && e.status != old;
        self.estimate = *e;
        self.estimate_heard = true;
        if changed {
            let campaign = self.state.campaign.into();
            self.event(ev::EV_STATUS_CHANGED, &[campaign, old, e.status]);
        }
    }

    /// The supervisor's set status: an event for each stage whose restart count rose
    /// (the first one heard only sets the counts).
    pub fn on_set_status(&mut self, s: &SetStatus, now_ns: u64) {
        let first = self.status_at_ns.is_none();
        for m in s
            .members
            .iter()
            .take((s.n_members as usize).min(MAX_MEMBERS))
        {
            let p = m.process as usize;
            if p == 0 || p >= MAX_MEMBERS || m.process == PROC_TMTC {
                continue;
            }
            let seen = std::mem::replace(&mut self.restarts_seen[p], m.restarts);
            if !first && m.restarts > seen {
                self.event(ev::EV_PROCESS_RESTARTED, &[p as u64, m.restarts.into()]);
            }
        }
        self.status = *s;
        self.status_at_ns = Some(now_ns);
    }

    /// The supervisor's ground state. The first one heard says whether this process was
    /// restarted (an event then).
    pub fn on_ground_state(&mut self, g: &GroundState) {
        let first = !self.state_heard;
        self.state = *g;
        self.state_heard = true;
        if first && g.tmtc_restarts > 0 {
            self.event(
                ev::EV_PROCESS_RESTARTED,
                &[PROC_TMTC.into(), g.tmtc_restarts.into()],
            );
        }
    }

    /// Whether a `GroundState` has been heard.
    pub fn heard_supervisor(&self) -> bool {
        self.state_heard
    }

    /// A note from the supervisor: a forwarded request started or completed, or an
    /// event to report.
    pub fn on_note(&mut self, n: &GroundNote) {
        match n.kind {
            NOTE_EVENT => {
                if let Ok(id) = u16::try_from(n.code) {
                    self.event(id, &n.args);
                }
            }
            NOTE_STARTED | NOTE_DONE => {
                let Some(i) = self
                    .pending
                    .iter()
                    .position(|p| p.is_some_and(|p| p.token == n.token))
                else {
                    return;
                };
                let Some(p) = self.pending[i] else { return };
                if n.kind == NOTE_STARTED {
                    if p.flags & ACK_START != 0 {
                        self.verification(3, p.source_id, &p.request, None);
                    }
                    return;
                }
                self.pending[i] = None;
                if n.code == 0 {
                    if p.flags & ACK_COMPLETION != 0 {
                        self.verification(7, p.source_id, &p.request, None);
                    }
                } else {
                    let code = u16::try_from(n.code).unwrap_or(u16::MAX);
                    self.verification(8, p.source_id, &p.request, Some(code));
                    self.count_refusal(code, 8, 1);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
#[path = "onboard_tests.rs"]
mod tests;
