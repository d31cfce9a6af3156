//! The ground supervisor's loop: the TMTC process's requests executed, its answers and
//! events sent, the mode and table said every 100 ms, one campaign at a time run on its
//! own thread while the link stays served.

use super::tmtc::{Health, Tmtc};
use super::Up;
use crate::analysis::report::Report;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, BusError, Pub, Sub};
use crate::ground::dictionary::{Failure, Mode};
use crate::ground::table::{Entry, TableStore};
use crate::runtime::process::set::SupervisorArgs;
use crate::runtime::process::supervisor::locks::{claim, Janitor};
use crate::runtime::process::supervisor::{campaign, write_reports, Hold, Outcome, Prepared};
use crate::sim::msg::{
    EstimateMsg, GroundNote, GroundRequest, GroundState, Header, Progress, Request, SetStatus,
    NOTE_DONE, NOTE_EVENT, NOTE_STARTED, PROC_TMTC, REQ_STOP, SET_RUNNING,
};
use crate::sim::trend;
use std::collections::VecDeque;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The events the supervisor raises (`ground::events`; the others are the TMTC
/// process's own).
pub(super) mod event {
    use crate::ground::events as e;
    pub const MODE_CHANGED: u32 = e::EV_MODE_CHANGED as u32;
    pub const REQUIREMENT_MET: u32 = e::EV_REQUIREMENT_MET as u32;
    pub const REQUIREMENT_MISSED: u32 = e::EV_REQUIREMENT_MISSED as u32;
    pub const TABLE_APPLIED: u32 = e::EV_TABLE_APPLIED as u32;
    pub const TABLE_RESTORED: u32 = e::EV_TABLE_RESTORED as u32;
    pub const TABLE_FILE_REFUSED: u32 = e::EV_TABLE_FILE_REFUSED as u32;
    pub const CAMPAIGN_ENDED_EARLY: u32 = e::EV_CAMPAIGN_ENDED_EARLY as u32;
}

/// Function IDs of service 8 (TMTC.md).
mod function {
    pub const START: u32 = 1;
    pub const STOP: u32 = 2;
    pub const APPLY: u32 = 3;
    pub const RESTORE: u32 = 4;
    pub const SHUTDOWN: u32 = 5;
}

/// Why a campaign ended before its end (event 10's reason).
const ENDED_STOPPED: u64 = 1;
const ENDED_FAILED: u64 = 2;
const ENDED_SIGNAL: u64 = 3;

/// How often the mode and table are said.
const STATE_EVERY: Duration = Duration::from_millis(100);
/// After function 5: time left to the TMTC process to send its last reports.
const LAST_WORDS: Duration = Duration::from_millis(500);

/// The running campaign.
struct Running {
    n: u32,
    /// Its epoch [mission day].
    epoch_day: f64,
    thread: JoinHandle<Outcome>,
    /// The start request, answered once the set runs.
    start: Option<u64>,
    /// A stop request, answered when the campaign ended.
    stop: Option<u64>,
    /// Where its reports go.
    args: SupervisorArgs,
    /// Its estimates, handed over by its thread.
    relay: std::sync::Arc<crate::runtime::process::supervisor::watch::Relay>,
}

/// The ports of the ground supervisor's node.
struct Ports {
    requests: Sub<GroundRequest>,
    beats: Sub<Progress>,
    status: Sub<SetStatus>,
    notes: Pub<GroundNote>,
    state: Pub<GroundState>,
    stop: Pub<Request>,
}

struct Desk<'a> {
    args: &'a SupervisorArgs,
    prepared: Prepared,
    table: TableStore,
    tmtc: Tmtc,
    mode: Mode,
    /// The last campaign's number (0: none yet).
    campaign: u32,
    running: Option<Running>,
    /// The last campaign's number, report and epoch [mission day], when it completed
    /// (function 3 applies it).
    result: Option<(u32, Box<Report>, f64)>,
    stage_restarts: u32,
    /// Notes waiting for the TMTC process to be heard.
    pending: VecDeque<GroundNote>,
    seq: u64,
    /// The campaign's latest estimate and status, relayed in `GroundState`.
    estimate: EstimateMsg,
    set: SetStatus,
}

/// Serve the link until function 5 or a signal; returns the exit code.
pub(super) fn serve(args: &SupervisorArgs, up: Up) -> u8 {
    let hold_args = args.clone();
    let (_hold, _janitor) = match claim(&hold_args) {
        Ok(h) => match Janitor::start(&args.bus_prefix) {
            Ok(j) => (h, j),
            Err(e) => {
                eprintln!("taiji-supervisor: the process set failed: {e}");
                return 3;
            }
        },
        Err(crate::runtime::process::set::SupervisorError::User(e)) => {
            eprintln!("taiji-supervisor: error: {e}");
            return 2;
        }
        Err(crate::runtime::process::set::SupervisorError::Set(e)) => {
            eprintln!("taiji-supervisor: the process set failed: {e}");
            return 3;
        }
    };
    match serve_held(args, up) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("taiji-supervisor: the ground link failed: {e}");
            3
        }
    }
}

fn serve_held(args: &SupervisorArgs, up: Up) -> Result<u8, BusError> {
    let node = wiring::node("taiji-supervisor", &args.bus_prefix)?;
    let ports = Ports {
        requests: wiring::subscriber(&node, wiring::SVC_GROUND_REQUEST)?,
        beats: wiring::subscriber(&node, wiring::SVC_GROUND_BEAT)?,
        status: wiring::subscriber(&node, wiring::SVC_STATUS)?,
        notes: wiring::publisher(&node, wiring::SVC_GROUND_NOTE)?,
        state: wiring::publisher(&node, wiring::SVC_GROUND_STATE)?,
        stop: wiring::publisher(&node, wiring::SVC_REQUEST)?,
    };
    let (table, problem) = TableStore::open(&args.out);
    let tmtc = match Tmtc::start(args, &up) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("taiji-supervisor: error: {e}");
            return Ok(2);
        }
    };
    let mut desk = Desk {
        args,
        prepared: up.prepared,
        table,
        tmtc,
        mode: Mode::Standby,
        campaign: last_campaign(&args.out),
        running: None,
        result: None,
        stage_restarts: 0,
        pending: VecDeque::new(),
        seq: 0,
        estimate: EstimateMsg::default(),
        set: SetStatus {
            state: 0,
            ..Default::default()
        },
    };
    if let Some(p) = problem {
        eprintln!("taiji-supervisor: {p}");
        desk.event(event::TABLE_FILE_REFUSED, [u64::from(p.copy()), 0, 0, 0]);
    }
    println!(
        "Ground link: TMTC on {} (APID 0x120, key {}); standby. Output: {}/campaign-N",
        up.addr,
        up.key.display(),
        args.out.display()
    );
    let code = desk.run(&node, &ports);
    desk.tmtc
        .stop(Duration::from_secs_f64(desk.prepared.launch.stop_timeout_s));
    Ok(code)
}

/// The highest N of the `campaign-N` folders already in `out` (0: none).
fn last_campaign(out: &std::path::Path) -> u32 {
    std::fs::read_dir(out)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter_map(|e| {
                    e.file_name()
                        .to_str()
                        .and_then(|n| n.strip_prefix("campaign-"))
                        .and_then(|n| n.parse::<u32>().ok())
                })
                .max()
                .unwrap_or(0)
        })
        .unwrap_or(0)
}

impl Desk<'_> {
    fn run(
        &mut self,
        node: &iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
        ports: &Ports,
    ) -> u8 {
        let mut last_state: Option<Instant> = None;
        let mut shutdown: Option<(Instant, u8)> = None;
        loop {
            let signalled = node.wait(Duration::from_millis(5)).is_err();
            if signalled && shutdown.is_none() {
                log::warn!("signal: stopping the set");
                self.set_mode(Mode::ShuttingDown);
                shutdown = Some((Instant::now(), 130));
            }
            self.hear(ports);
            match self.tmtc.watch() {
                Health::Up | Health::Restarted => {}
                Health::Interrupted => {
                    if shutdown.is_none() {
                        self.set_mode(Mode::ShuttingDown);
                        shutdown = Some((Instant::now(), 130));
                    }
                }
                Health::Lost(why) => {
                    eprintln!("taiji-supervisor: the ground link failed: {why}");
                    self.stop_campaign(ports);
                    self.join_campaign(true);
                    return 3;
                }
            }
            if shutdown.is_none() {
                while let Ok(Some(r)) = wiring::receive(&ports.requests) {
                    if let Some(code) = self.execute(&r, ports) {
                        shutdown = Some((Instant::now(), code));
                    }
                    // The state after it before its answer: a parameter read after the
                    // completion report sees the table the request left.
                    self.say_state(ports);
                }
            }
            if let Ok(Some(st)) = latest(&ports.status) {
                self.status(&st);
            }
            // The campaign's estimates: each whose status word changed is said at once.
            if let Some(r) = &self.running {
                let (changed, latest) = r.relay.take();
                for e in changed {
                    self.estimate = e;
                    self.say_state(ports);
                }
                if let Some(e) = latest {
                    self.estimate = e;
                }
            }
            if self
                .running
                .as_ref()
                .is_some_and(|r| r.thread.is_finished())
            {
                self.join_campaign(false);
                self.say_final_state(ports);
            }
            if last_state.is_none_or(|t| t.elapsed() >= STATE_EVERY) {
                last_state = Some(Instant::now());
                self.say_state(ports);
            }
            self.flush(ports);
            if let Some((t, code)) = shutdown {
                if self.running.is_some() {
                    self.stop_campaign(ports);
                    if self
                        .running
                        .as_ref()
                        .is_some_and(|r| r.thread.is_finished())
                    {
                        self.join_campaign(code == 130);
                        self.say_final_state(ports);
                        // Its end's reports get their time to go out.
                        shutdown = Some((Instant::now(), code));
                    }
                    continue;
                }
                if t.elapsed() >= LAST_WORDS || !self.tmtc.heard {
                    return code;
                }
            }
        }
    }

    /// Take in the TMTC process's heartbeats.
    fn hear(&mut self, ports: &Ports) {
        while let Ok(Some(p)) = wiring::receive(&ports.beats) {
            if p.process == PROC_TMTC {
                self.tmtc.heard(&p);
            }
        }
    }

    /// Execute one request; `Some(exit code)` when the set is to end.
    fn execute(&mut self, r: &GroundRequest, ports: &Ports) -> Option<u8> {
        let t = r.token;
        match r.function {
            function::START => {
                if self.running.is_some() {
                    self.done(t, Some(Failure::StartWhileRunning));
                } else {
                    self.note(NOTE_STARTED, 0, t, [0; 4]);
                    self.start(t, r.seed, r.duration_s, r.epoch_day);
                }
            }
            function::STOP => {
                if let Some(run) = self.running.as_mut() {
                    run.stop = Some(t);
                    self.note(NOTE_STARTED, 0, t, [0; 4]);
                    self.stop_campaign(ports);
                } else {
                    self.done(t, Some(Failure::NotRunning));
                }
            }
            function::APPLY => {
                self.note(NOTE_STARTED, 0, t, [0; 4]);
                let r = self.apply();
                self.done(t, r.err());
            }
            function::RESTORE => {
                self.note(NOTE_STARTED, 0, t, [0; 4]);
                match self.table.restore() {
                    Ok(n) => {
                        self.event(event::TABLE_RESTORED, [u64::from(n), 0, 0, 0]);
                        self.done(t, None);
                    }
                    Err(e) => self.done(t, Some(e.failure())),
                }
            }
            function::SHUTDOWN => {
                self.note(NOTE_STARTED, 0, t, [0; 4]);
                self.done(t, None);
                self.set_mode(Mode::ShuttingDown);
                return Some(0);
            }
            _ => self.done(t, Some(Failure::UnknownFunction)),
        }
        None
    }

    /// Function 3: the last campaign's result into the table's trends (started from
    /// it when the table has none), as the timeline takes it in.
    fn apply(&mut self) -> Result<(), Failure> {
        let (n, report, epoch_day) = self.result.as_ref().ok_or(Failure::NoResult)?;
        let n = *n;
        let values = crate::analysis::report::table_values(report)?;
        let mut trends = self
            .table
            .entry()
            .and_then(|e| e.trends)
            .unwrap_or([[[None; 3]; 3]; 2]);
        let mid = trend::campaign_middle(*epoch_day, report.duration_s);
        let misfits = trend::take_in(&mut trends, &self.prepared.s, &values, mid);
        self.table
            .apply(Entry::from_trends(n, trends))
            .map_err(|e| e.failure())?;
        for m in misfits {
            println!(
                "Campaign {n}: IS{} {} {} lies {:.1}σ from its trend's prediction (model misfit): its trend restarts from it",
                m.is + 1,
                crate::analysis::mission::GROUPS[m.group],
                crate::analysis::mission::AXES[m.axis],
                m.innovation_sigma
            );
        }
        self.event(event::TABLE_APPLIED, [u64::from(n), 0, 0, 0]);
        Ok(())
    }

    /// Function 1: campaign N+1 on its own thread, at mission day `epoch_day`.
    fn start(&mut self, token: u64, seed: u64, duration_s: f64, epoch_day: f64) {
        self.campaign += 1;
        let n = self.campaign;
        let mut args = self.args.clone();
        args.out = self.args.out.join(format!("campaign-{n}"));
        args.seed = Some(seed);
        args.report_dir = None;
        let mut prepared = self.prepared.clone();
        let table = self.table.entry().map(|e| e.at(epoch_day));
        let run_args = args.clone();
        let relay =
            std::sync::Arc::new(crate::runtime::process::supervisor::watch::Relay::default());
        let hold = Hold::Held(relay.clone());
        let thread = std::thread::Builder::new()
            .name(format!("campaign-{n}"))
            .spawn(move || {
                match prepare_campaign(&mut prepared, seed, duration_s, epoch_day, table) {
                    Ok(()) => campaign(&run_args, &prepared, hold),
                    Err(e) => Outcome::UserError(e),
                }
            });
        match thread {
            Ok(thread) => {
                self.result = None;
                self.running = Some(Running {
                    n,
                    epoch_day,
                    thread,
                    start: Some(token),
                    stop: None,
                    args,
                    relay,
                });
                self.set_mode(Mode::Running);
            }
            Err(e) => {
                log::error!("cannot start campaign {n}: {e}");
                self.done(token, Some(Failure::CampaignFailed));
            }
        }
    }

    /// Ask the running campaign to stop (as a monitor's stop does).
    fn stop_campaign(&mut self, ports: &Ports) {
        if self.running.is_none() {
            return;
        }
        self.seq += 1;
        let _ = wiring::publish(
            &ports.stop,
            Request {
                header: Header {
                    seq: self.seq,
                    publish_ns: monotonic_ns(),
                    ..Default::default()
                },
                command: REQ_STOP,
                requester_pid: std::process::id(),
            },
        );
    }

    /// The campaign's thread ended: its reports, answers and events.
    fn join_campaign(&mut self, signalled: bool) {
        let Some(run) = self.running.take() else {
            return;
        };
        let n = run.n;
        // Its last estimates (the final one among them), before anything is said.
        let (changed, latest) = run.relay.take();
        if let Some(e) = latest.or(changed.last().copied()) {
            self.estimate = e;
        }
        let mut failed = None;
        let Ok(outcome) = run.thread.join() else {
            eprintln!("taiji-supervisor: campaign {n}: its supervision thread panicked");
            if let Some(t) = run.start.or(run.stop) {
                self.done(t, Some(Failure::CampaignFailed));
            }
            self.event(
                event::CAMPAIGN_ENDED_EARLY,
                [u64::from(n), ENDED_FAILED, 0, 0],
            );
            self.set_mode(Mode::Standby);
            return;
        };
        match outcome {
            Outcome::Completed { report, met } => {
                if let Some(r) = &report.restarts {
                    self.stage_restarts += r
                        .as_object()
                        .map_or(0, |m| m.values().filter_map(|v| v.as_u64()).sum::<u64>())
                        as u32;
                }
                match write_reports(&run.args, &report) {
                    Ok(()) => {
                        print!("{}", report.table());
                        println!("Report: {}", run.args.out.join("report.json").display());
                    }
                    Err(e) => log::error!("campaign {n}: its reports could not be written: {e}"),
                }
                if met {
                    self.event(event::REQUIREMENT_MET, [u64::from(n), 0, 0, 0]);
                } else {
                    let verified = u64::from(report.requirements.verified);
                    self.event(event::REQUIREMENT_MISSED, [u64::from(n), verified, 0, 0]);
                }
                self.result = Some((n, report, run.epoch_day));
            }
            Outcome::Interrupted => {
                let why = if run.stop.is_some() {
                    ENDED_STOPPED
                } else if signalled {
                    ENDED_SIGNAL
                } else {
                    ENDED_STOPPED
                };
                println!("Campaign {n} stopped before its end");
                self.event(event::CAMPAIGN_ENDED_EARLY, [u64::from(n), why, 0, 0]);
            }
            Outcome::UserError(e) => {
                eprintln!("taiji-supervisor: campaign {n} refused: {e}");
                failed = Some(Failure::CampaignFailed);
                self.event(
                    event::CAMPAIGN_ENDED_EARLY,
                    [u64::from(n), ENDED_FAILED, 0, 0],
                );
            }
            Outcome::SetFailed(e) => {
                eprintln!("taiji-supervisor: campaign {n}: the process set failed: {e}");
                failed = Some(Failure::CampaignFailed);
                self.event(
                    event::CAMPAIGN_ENDED_EARLY,
                    [u64::from(n), ENDED_FAILED, 0, 0],
                );
            }
            Outcome::HostStopped(m) => println!("taiji-supervisor: {m}"),
        }
        if let Some(t) = run.start {
            self.done(t, failed);
        }
        if let Some(t) = run.stop {
            self.done(t, None);
        }
        self.set.state = 0;
        if self.mode == Mode::Running {
            self.set_mode(Mode::Standby);
        }
    }

    /// The set's status while a campaign runs: its start is answered once it runs.
    fn status(&mut self, st: &SetStatus) {
        self.set = *st;
        if st.state != SET_RUNNING {
            return;
        }
        if let Some(t) = self.running.as_mut().and_then(|r| r.start.take()) {
            self.done(t, None);
        }
    }

    fn set_mode(&mut self, to: Mode) {
        if self.mode == to {
            return;
        }
        let from = self.mode;
        self.mode = to;
        log::info!("mode {} -> {}", from.name(), to.name());
        self.event(
            event::MODE_CHANGED,
            [from as u64, to as u64, u64::from(self.campaign), 0],
        );
    }

    fn done(&mut self, token: u64, failure: Option<Failure>) {
        let code = failure.map_or(0, |f| u32::from(f.code()));
        self.note(NOTE_DONE, code, token, [0; 4]);
    }

    fn event(&mut self, id: u32, args: [u64; 4]) {
        self.note(NOTE_EVENT, id, 0, args);
    }

    fn note(&mut self, kind: u32, code: u32, token: u64, args: [u64; 4]) {
        self.pending.push_back(GroundNote {
            kind,
            code,
            token,
            args,
            ..Default::default()
        });
    }

    /// Send what waits, once the TMTC process's current incarnation was heard.
    fn flush(&mut self, ports: &Ports) {
        if !self.tmtc.heard {
            return;
        }
        while let Some(mut n) = self.pending.pop_front() {
            self.seq += 1;
            n.header = Header {
                seq: self.seq,
                publish_ns: monotonic_ns(),
                ..Default::default()
            };
            if let Err(e) = wiring::publish(&ports.notes, n) {
                log::warn!("ground note not sent: {e}");
                self.pending.push_front(n);
                return;
            }
        }
    }

    /// A campaign's end, said before its events go out (`flush`): the last estimates it
    /// published and the mode after it, so a report asked for on its end event (3,27)
    /// holds the final estimate, report.json's, not one up to 100 ms older.
    fn say_final_state(&mut self, ports: &Ports) {
        self.say_state(ports);
    }

    fn say_state(&mut self, ports: &Ports) {
        let (table, table_campaign) = self.table.current().unwrap_or_default();
        let n = self.running.as_ref().map_or(self.campaign, |r| r.n);
        self.seq += 1;
        let st = GroundState {
            header: Header {
                seq: self.seq,
                publish_ns: monotonic_ns(),
                ..Default::default()
            },
            supervisor_pid: std::process::id(),
            mode: self.mode as u32,
            campaign: n,
            tmtc_restarts: self.tmtc.restarts,
            stage_restarts: self.stage_restarts,
            table_valid: u32::from(self.table.current().is_some()),
            table_campaign,
            table_previous: u32::from(self.table.can_restore()),
            table,
            estimate: self.estimate,
            set: self.set,
        };
        if let Err(e) = wiring::publish(&ports.state, st) {
            log::warn!("ground state not sent: {e}");
        }
    }
}

/// The newest sample waiting on `s` (the older ones dropped).
fn latest<T: wiring::Payload>(s: &Sub<T>) -> Result<Option<T>, BusError> {
    let mut last = None;
    while let Some(x) = wiring::receive(s)? {
        last = Some(x);
    }
    Ok(last)
}

/// Campaign N's scenario: the file's, its duration the telecommand's (0: the file's),
/// its maneuver planned for that file, the telecommand's seed, its epoch
/// `campaign_epoch_day`'s (with `[drift]`, the truths of that day on, their history the
/// launch's seed's: `--seed`, else the file's, as a timeline's of that mission seed),
/// and its priors the onboard calibration table's for that epoch once one was applied.
/// Checked as a timeline's campaign is (`[drift]` over the epoch, the priors).
fn prepare_campaign(
    p: &mut Prepared,
    seed: u64,
    duration_s: f64,
    epoch_day: f64,
    table: Option<crate::sim::msg::TableValues>,
) -> Result<(), crate::runtime::process::set::UserError> {
    let mission_seed = p.s.seed;
    if duration_s > 0.0 && duration_s != p.given.duration_s {
        let mut given = p.given.clone();
        given.duration_s = duration_s;
        let given = given.validated()?;
        let (s, plan) = crate::analysis::plan::resolve(given.clone())?;
        (p.given, p.s, p.plan) = (given, s, plan);
    }
    p.s.mission_seed = Some(mission_seed);
    p.s.seed = seed;
    p.s.epoch_day = epoch_day;
    if let Some(t) = table {
        p.s = p.s.with_onboard_priors(&t);
    }
    p.s = p.s.clone().validated()?;
    Ok(())
}
