//! Starting the set: its binaries and arguments, the files the members read from
//! the run folder (the resolved scenario, the estimator's table), and the spawn.

use super::PLANNED_SCENARIO_FILE;
use crate::runtime::launch::{LaunchDescription, ProcessSpec};
use crate::runtime::process::estimator::{EstimatorTable, TABLE_FILE};
pub use crate::runtime::process::set::SupervisorArgs;
pub use crate::runtime::process::set::UserError;
use crate::runtime::process::set::{Member, Set, SupervisorError};
use crate::sim::files::FileError;
use crate::sim::scenario::Scenario;
use std::time::{Duration, Instant};

/// The set to start: its binaries, the arguments every member gets, and the files the
/// members read from the run folder (the resolved scenario, the estimator's table).
pub(super) fn new_set(args: &SupervisorArgs, s: &Scenario) -> Result<Set, SupervisorError> {
    let user = SupervisorError::user;
    let bin_dir = match &args.bin_dir {
        Some(d) => d.clone(),
        None => std::env::current_exe()
            .ok()
            .and_then(|p| p.parent().map(|d| d.to_path_buf()))
            .ok_or(user(UserError::NoBinDir))?,
    };
    let mut common: Vec<String> = vec![
        "--bus-prefix".into(),
        args.bus_prefix.clone(),
        "--run-dir".into(),
        args.out.display().to_string(),
        "--method".into(),
        args.method.clone(),
    ];
    // Every stage flies the same maneuver: the scenario as resolved here (its
    // maneuver planned when the file gave none), written into the run folder.
    let resolved = args.out.join(PLANNED_SCENARIO_FILE);
    let text = toml::to_string(s).map_err(|e| user(UserError::ScenarioToml(e)))?;
    std::fs::write(&resolved, text)
        .map_err(|source| user(UserError::from(FileError::write(resolved.clone(), source))))?;
    let mut scenario_args: Vec<String> = vec!["--scenario".into(), resolved.display().to_string()];
    if let Some(seed) = args.seed {
        scenario_args.extend(["--seed".into(), seed.to_string()]);
    }
    // Not keys of the file: a ground campaign's epoch and its truths' history (Rust
    // prints an f64 so that it reads back to the same bits).
    if s.epoch_day != 0.0 {
        scenario_args.extend(["--epoch-day".into(), s.epoch_day.to_string()]);
    }
    if let Some(m) = s.mission_seed {
        scenario_args.extend(["--mission-seed".into(), m.to_string()]);
    }
    // The estimator process is given its table, never the scenario (truths).
    let table = args.out.join(TABLE_FILE);
    EstimatorTable::of(s)
        .write(&table)
        .map_err(|e| user(e.into()))?;
    let table_args = vec!["--table".into(), table.display().to_string()];
    if args.record {
        common.push("--record".into());
        scenario_args.extend([
            "--record-compression".into(),
            args.record_compression.to_string(),
        ]);
    }
    if args.realtime {
        common.extend([
            "--realtime".into(),
            "--time-scale".into(),
            args.time_scale.to_string(),
        ]);
    }
    Ok(Set {
        members: Vec::new(),
        prefix: args.bus_prefix.clone(),
        common,
        scenario_args,
        table_args,
        realtime: args.realtime,
        bin_dir,
        bar: crate::analysis::progress::Bar::new(s.n_samples(), "process set"),
    })
}

/// Start this host's members of the set (all of them on one host). A host that is
/// not in charge (`agent`) lists only its own.
pub(super) fn spawn_members<'a>(
    set: &mut Set,
    specs: impl IntoIterator<Item = &'a ProcessSpec>,
    launch: &LaunchDescription,
    me: Option<&str>,
    agent: bool,
) -> Result<(), SupervisorError> {
    for spec in specs {
        let host = launch.host_of(spec).to_string();
        let local = me.is_none_or(|m| m == host);
        if agent && !local {
            continue;
        }
        let child = if local {
            set.spawn(spec).map(Some)
        } else {
            Ok(None)
        };
        match child {
            Ok(child) => set.members.push(Member {
                spec: spec.clone(),
                // The launch description's names were checked against the table.
                id: crate::bus::topology::stage(&spec.name).map_or(0, |st| st.id),
                child,
                host,
                restarts: 0,
                last_seen: Instant::now(),
                last: None,
            }),
            Err(e) => {
                set.stop_all(Duration::from_secs_f64(launch.stop_timeout_s));
                return Err(SupervisorError::user(e.into()));
            }
        }
    }
    Ok(())
}
