//! `taiji-supervisor`: starts the set from a launch description, waits until every
//! process is ready, starts the campaign, watches liveness (child exit and progress
//! heartbeats), restarts what may be restarted, stops everything cleanly, and writes
//! the report.

mod checkpoint;
pub mod ground;
mod locks;
mod spawn;
mod watch;

use crate::analysis::report::Report;
use crate::bus::timing::monotonic_ns;
use crate::bus::wiring::{self, BusError};
use crate::runtime::launch::{LaunchDescription, Restart};
pub use crate::runtime::process::set::SupervisorArgs;
use crate::runtime::process::set::SupervisorError;
pub use crate::runtime::process::set::{SetError, SpawnError, UserError};
use crate::runtime::process::status::StatusBoard;
use crate::runtime::process::timing_report::{timing_json, MemberSummary};
use crate::sim::msg::{
    Control, EstimateMsg, Header, Progress, CMD_STOP, PROC_ESTIMATOR, SET_FINISHED, SET_STOPPING,
};
use crate::sim::scenario::Scenario;
use checkpoint::{fresh_checkpoint, settle_checkpoint};
use locks::{claim, Janitor};
use serde_json::json;
use spawn::{new_set, spawn_members};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};
use watch::{Ports, Watch};

/// How a supervised run ended, with its process exit code.
#[derive(Debug)]
pub enum Outcome {
    /// The campaign completed; `met` says whether the requirements were met.
    Completed { report: Box<Report>, met: bool },
    /// Bad arguments, scenario or launch description (exit 2).
    UserError(UserError),
    /// A process of the set failed and could not be restarted (exit 3).
    SetFailed(SetError),
    /// SIGINT / SIGTERM (exit 130).
    Interrupted,
    /// A host that is not in charge: its processes ran until the one in charge said
    /// stop (exit 0).
    HostStopped(String),
}

impl Outcome {
    pub fn exit_code(&self) -> u8 {
        match self {
            Outcome::Completed { met: true, .. } => 0,
            Outcome::Completed { met: false, .. } => 1,
            Outcome::UserError(_) => 2,
            Outcome::SetFailed(_) => 3,
            Outcome::Interrupted => 130,
            Outcome::HostStopped(_) => 0,
        }
    }
}

/// The scenario every stage is given, in the run folder: the user's, with its
/// maneuver planned when it had none.
pub const PLANNED_SCENARIO_FILE: &str = "scenario.toml";

/// What a run is made of, checked before anything starts: the scenario (as the user
/// gave it, and resolved: its maneuver planned, `--seed` applied), the plan's search,
/// the launch description and, on a set over hosts, this host's name.
#[derive(Clone)]
pub struct Prepared {
    pub given: Scenario,
    pub s: Scenario,
    pub plan: Option<crate::analysis::plan::PlanInfo>,
    pub launch: LaunchDescription,
    pub me: Option<String>,
}

/// Check the run's arguments, scenario and launch description; plan the maneuver.
pub fn prepare(args: &SupervisorArgs) -> Result<Prepared, UserError> {
    let given = Scenario::load_or_default(args.scenario.as_deref())?;
    let (s, plan) = crate::analysis::plan::resolve(given.clone())?;
    // `--seed` is the scenario's seed from here on: every noise stream and the priors'
    // ground-calibration draw, as `run` and the Monte Carlo's run of that seed (the
    // maneuver stays the one planned for the file).
    let s = Scenario {
        seed: args.seed.unwrap_or(s.seed),
        ..s
    };
    let launch = LaunchDescription::load_or_default(args.launch.as_deref())?;
    crate::runtime::process::parse_method(&args.method)?;
    if args.realtime && !(args.time_scale.is_finite() && args.time_scale > 0.0) {
        return Err(crate::runtime::process::ProcessError::TimeScale {
            time_scale: args.time_scale,
        }
        .into());
    }
    let me = crate::runtime::process::hosts::my_host(args, &launch)?;
    if me.is_some() && args.record {
        return Err(UserError::RecordOverHosts);
    }
    Ok(Prepared {
        given,
        s,
        plan,
        launch,
        me,
    })
}

/// Run the campaign through the process set.
pub fn run(args: &SupervisorArgs) -> Outcome {
    match prepare(args) {
        Ok(p) => campaign(args, &p, Hold::Claim),
        Err(e) => Outcome::UserError(e),
    }
}

/// Who holds the bus prefix and the output folder during a campaign.
#[derive(Debug, Clone)]
pub(crate) enum Hold {
    /// The campaign claims them, and releases them at its end.
    Claim,
    /// A caller holds them across campaigns (the ground link's standby), and takes
    /// the campaign's estimates from the relay.
    Held(std::sync::Arc<watch::Relay>),
}

impl Hold {
    /// Where the campaign's estimates go on to, when a caller takes them.
    fn relay(&self) -> Option<&watch::Relay> {
        match self {
            Hold::Held(r) => Some(r),
            Hold::Claim => None,
        }
    }
}

/// One campaign of the prepared run through the process set.
pub(crate) fn campaign(args: &SupervisorArgs, p: &Prepared, hold: Hold) -> Outcome {
    let (s, plan, launch, me) = (&p.s, &p.plan, &p.launch, p.me.clone());
    // The bound as the campaign goes, for monitors; its last point is the report's.
    // At the run's seed: a campaign that loses data has the bound of its losses. Beside
    // it the maneuver's bound (its motion alone), for the maneuver's line and the
    // prediction before the run.
    let (curve, maneuver) = std::thread::scope(|sc| {
        let m = sc.spawn(|| crate::analysis::plan::maneuver_bound(s));
        let curve = crate::analysis::crlb::crlb_curve(
            s,
            crate::tuning::BOUND_POINTS,
            crate::analysis::campaign::Threads::available(),
        );
        (
            curve,
            m.join().unwrap_or_else(|e| std::panic::resume_unwind(e)),
        )
    });
    let Some(crlb) = curve.last().and_then(|(_, c)| *c) else {
        return Outcome::UserError(UserError::SingularFisher);
    };
    match supervise(args, s, launch, me.as_deref(), curve, hold) {
        Ok(Supervised::HostStopped(m)) => Outcome::HostStopped(m),
        Ok(Supervised::Done(final_est, members, wall, hosts)) => {
            let bounds = crate::analysis::crlb::Bounds {
                run: crlb,
                maneuver,
            };
            let mut report = Report::with_bounds(
                s,
                s.seed,
                "multi-process",
                &args.method,
                &final_est,
                &bounds,
            );
            if let (Some(m), Some(p)) = (report.maneuver.as_mut(), &plan) {
                m.search = Some(p.search_json());
            }
            report.wall_time_s = Some(wall);
            let mut timing = timing_json(args, s, &members);
            if let (Some(h), Some(t)) = (&hosts, timing.as_object_mut()) {
                t.insert("tunnel_hop_us".into(), h["tunnel_hop_us"].clone());
                t.insert("clocks".into(), h["clocks"].clone());
            }
            report.timing = Some(timing);
            report.hosts = hosts;
            let restarts: BTreeMap<String, u32> = members
                .iter()
                .filter(|m| m.spec.restart != Restart::Never)
                .map(|m| (m.spec.name.clone(), m.restarts))
                .collect();
            report.restarts = Some(json!(restarts));
            report.estimator_loop_allocations = members
                .iter()
                .find(|m| m.id == PROC_ESTIMATOR)
                .and_then(|m| m.last)
                .map(|p| p.loop_allocations);
            // With `[faults]` and a recording, the recorder's fault log scores detection.
            if args.record && s.faults.any() {
                let path = args
                    .out
                    .join(crate::runtime::process::recorder::TELEMETRY_FILE);
                match crate::telemetry::truth::fault_log(&path) {
                    Ok((records, detected)) => {
                        report.faults = Some(
                            crate::sim::faults::FaultScore::from_log(s, records, detected)
                                .summary(),
                        );
                    }
                    Err(e) => log::warn!("taiji-supervisor: no fault score: {e}"),
                }
            }
            let met = report.requirements.met && report.requirements.verified;
            Outcome::Completed {
                report: Box::new(report),
                met,
            }
        }
        Ok(Supervised::Interrupted) => Outcome::Interrupted,
        Err(SupervisorError::User(e)) => Outcome::UserError(*e),
        Err(SupervisorError::Set(e)) => Outcome::SetFailed(e),
    }
}

enum Supervised {
    /// The final estimate, every member, the wall time [s], and (sets over hosts) the
    /// report's `hosts`.
    Done(
        Box<EstimateMsg>,
        Vec<MemberSummary>,
        f64,
        Option<serde_json::Value>,
    ),
    Interrupted,
    HostStopped(String),
}

/// The prefix's and folder's holds and the janitor, when the campaign takes them itself.
fn holds(
    args: &SupervisorArgs,
    hold: &Hold,
) -> Result<Option<(locks::PrefixHold, Janitor)>, SupervisorError> {
    Ok(match hold {
        Hold::Claim => Some((
            claim(args)?,
            Janitor::start(&args.bus_prefix).map_err(SupervisorError::Set)?,
        )),
        Hold::Held(_) => None,
    })
}

fn supervise(
    args: &SupervisorArgs,
    s: &Scenario,
    launch: &LaunchDescription,
    me: Option<&str>,
    bound: Vec<(u64, Option<crate::analysis::crlb::Crlb>)>,
    hold: Hold,
) -> Result<Supervised, SupervisorError> {
    let set_err = |e: BusError| SupervisorError::Set(e.into());
    let t_start = Instant::now();
    // Declared before every port and node of the run, so dropped after them.
    let _holds = holds(args, &hold)?;
    let ckpt = fresh_checkpoint(args)?;
    let node = wiring::node("taiji-supervisor", &args.bus_prefix).map_err(set_err)?;
    let progress = wiring::subscriber::<Progress>(&node, wiring::SVC_PROGRESS).map_err(set_err)?;
    let estimates =
        wiring::subscriber::<EstimateMsg>(&node, wiring::SVC_ESTIMATE).map_err(set_err)?;
    let control = wiring::publisher::<Control>(&node, wiring::SVC_CONTROL).map_err(set_err)?;
    let send = |command: u32, seq: u64| {
        wiring::publish(
            &control,
            Control {
                header: Header {
                    seq,
                    publish_ns: monotonic_ns(),
                    ..Default::default()
                },
                command,
                _pad: 0,
            },
        )
    };
    let mut set = new_set(args, s)?;
    // Sets over hosts: this host's tunnel; the one in charge also watches the others.
    let in_charge_host = launch.host.first().map(|h| h.name.as_str());
    let agent = me.is_some() && me != in_charge_host;
    let mut hosts = match me {
        Some(_) if !agent => Some(
            crate::runtime::process::hosts::InCharge::start(args, launch, &node, &set.bin_dir)
                .map_err(|e| SupervisorError::user(e.into()))?,
        ),
        _ => None,
    };
    spawn_members(&mut set, launch.processes(args.record), launch, me, agent)?;
    let result = match me {
        Some(m) if agent => {
            crate::runtime::process::hosts::agent_watch(&node, &progress, &mut set, launch, m, args)
                .map_err(SupervisorError::Set)
                .map(|stopped| {
                    stopped.map(|tick| EstimateMsg {
                        header: Header {
                            tick,
                            ..Default::default()
                        },
                        ..Default::default()
                    })
                })
        }
        _ => {
            let ports = Ports {
                node: &node,
                progress: &progress,
                estimates: &estimates,
                send: &send,
                relay: hold.relay(),
            };
            let mut board = StatusBoard::new(&node, args, s, launch, bound).map_err(set_err)?;
            let r =
                Watch::new(launch, s.n_samples()).run(&ports, &mut set, hosts.as_mut(), &mut board);
            let state = match r {
                Ok(Some(_)) => SET_FINISHED,
                _ => SET_STOPPING,
            };
            board.publish(&set, state, true);
            r
        }
    };
    set.bar.finish();
    // Whatever happened: stop everyone. What they left on the bus goes when `_hold` is
    // dropped, after this supervisor's node.
    match hosts.as_mut() {
        // Over hosts: repeated until every other host acknowledged it.
        Some(h) => h.stop_hosts(&node, &progress, &send),
        None => {
            let _ = send(CMD_STOP, 1);
        }
    }
    set.stop_all(Duration::from_secs_f64(launch.stop_timeout_s));
    let wall = t_start.elapsed().as_secs_f64();
    let result = settle_checkpoint(result, &ckpt);
    let hosts_json = hosts.as_ref().map(|h| {
        let placed: Vec<(String, String)> = set
            .members
            .iter()
            .map(|m| (m.spec.name.clone(), m.host.clone()))
            .chain([("taiji-supervisor".to_string(), h.me.clone())])
            .collect();
        h.report(&placed)
    });
    let members = set
        .members
        .into_iter()
        .map(|m| MemberSummary {
            spec: m.spec,
            id: m.id,
            restarts: m.restarts,
            last: m.last,
        })
        .collect();
    match result {
        Ok(Some(est)) if agent => Ok(Supervised::HostStopped(format!(
            "host {}: stopped by the supervisor in charge (last estimate tick {})",
            me.unwrap_or_default(),
            est.header.tick
        ))),
        Ok(Some(est)) => Ok(Supervised::Done(Box::new(est), members, wall, hosts_json)),
        Ok(None) => Ok(Supervised::Interrupted),
        Err(e) => Err(e),
    }
}

/// Why the reports of a completed run could not be written (exit 2).
#[derive(Debug, thiserror::Error)]
pub enum ReportsError {
    #[error(transparent)]
    Report(#[from] crate::analysis::report::ReportError),
    /// The recording could not be read back for the figures.
    #[error(transparent)]
    Telemetry(#[from] crate::telemetry::TelemetryError),
    #[error(transparent)]
    Plot(#[from] crate::analysis::plots::PlotError),
}

/// report.json, report.md, report.html, and the figures from the recording.
pub fn write_reports(args: &SupervisorArgs, report: &Report) -> Result<(), ReportsError> {
    let dir = report_dir(args);
    crate::analysis::report::write(dir, report)?;
    // The figures live beside the recording; report.html links them only from there.
    let plots = args.plots && dir == args.out;
    if plots {
        let path = args
            .out
            .join(crate::runtime::process::recorder::TELEMETRY_FILE);
        let (tel, s) = crate::telemetry::truth::full(&path)?;
        crate::analysis::plots::write_all(&tel, &s, &args.out)?;
    }
    Ok(crate::analysis::report_doc::write(report, dir, plots)?)
}

/// Where the reports go: `--report-dir`, else `--out`.
pub fn report_dir(args: &SupervisorArgs) -> &std::path::Path {
    args.report_dir.as_deref().unwrap_or(&args.out)
}
