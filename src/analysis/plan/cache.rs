//! The plan cache. A plan is a deterministic function of the scenario (its physics,
//! priors, limits and window) and of the code that simulates and bounds it; the search
//! takes ~0.3 s, as long as the default campaign itself. So a resolved plan is kept,
//! keyed by a hash of both, and a later run of the same scenario by the same build
//! flies the same maneuver without searching again (the report says `cached`).
//!
//! Where: `$TAIJI_PLAN_CACHE` (`off` disables it), else `$XDG_CACHE_HOME/taiji-calib/
//! plans`, else `~/.cache/taiji-calib/plans`. A missing, unreadable or corrupt entry
//! is only a miss: the plan is made again. Entries are written whole (rename).

use super::PlanInfo;
use crate::sim::estimate::snapshot::fnv1a;
use crate::sim::scenario::{Maneuver, Scenario};
use std::path::PathBuf;

/// The sources whose behaviour a plan depends on: a different build of any of them is
/// a different key, so a stale plan is never reused.
const SOURCES: &[&[u8]] = &[
    include_bytes!("mod.rs"),
    include_bytes!("cache.rs"),
    include_bytes!("search.rs"),
    include_bytes!("../../sim/scenario/maneuver.rs"),
    include_bytes!("../crlb.rs"),
    include_bytes!("../campaign.rs"),
    include_bytes!("../../sim/commander.rs"),
    include_bytes!("../../sim/fee.rs"),
    include_bytes!("../../sim/scenario/mod.rs"),
    include_bytes!("../../sim/scenario/check.rs"),
    include_bytes!("../../sim/scenario/limits.rs"),
    include_bytes!("../../sim/scenario/faults.rs"),
    include_bytes!("../../sim/model/plant.rs"),
    include_bytes!("../../sim/model/thruster.rs"),
    include_bytes!("../../sim/model/noise.rs"),
    include_bytes!("../../tuning.rs"),
    // Every source of the flight core (the estimator, its models), hashed by build.rs.
    env!("TAIJI_CORE_SOURCE_HASH").as_bytes(),
];

#[derive(serde::Serialize, serde::Deserialize)]
struct Entry {
    key: String,
    maneuver: Maneuver,
    info: PlanInfo,
}

fn dir() -> Option<PathBuf> {
    match std::env::var_os("TAIJI_PLAN_CACHE") {
        Some(v) if v == "off" => return None,
        Some(v) if !v.is_empty() => return Some(PathBuf::from(v)),
        _ => {}
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("taiji-calib").join("plans"))
}

/// The key of `s`'s plan: its planning inputs (everything but the name and the faults,
/// which the planner ignores) and the code.
pub fn key(s: &Scenario) -> String {
    let mut norm = s.clone();
    norm.name = String::new();
    norm.faults = Default::default();
    norm.maneuver = Maneuver {
        max_attitude_rad: s.maneuver.max_attitude_rad,
        max_rate_rad_s: s.maneuver.max_rate_rad_s,
        ..Maneuver::default()
    };
    let text = toml::to_string(&norm).unwrap_or_default();
    let mut code = Vec::new();
    for src in SOURCES {
        code.extend_from_slice(&fnv1a(src).to_le_bytes());
    }
    format!(
        "{:016x}{:016x}-{}",
        fnv1a(text.as_bytes()),
        fnv1a(&code),
        env!("CARGO_PKG_VERSION")
    )
}

fn path(s: &Scenario) -> Option<(PathBuf, String)> {
    let k = key(s);
    Some((dir()?.join(format!("{k}.json")), k))
}

/// The cached plan of `s`, if this build made one.
pub fn load(s: &Scenario) -> Option<(Maneuver, PlanInfo)> {
    let (p, k) = path(s)?;
    let text = std::fs::read_to_string(&p).ok()?;
    let e: Entry = serde_json::from_str(&text).ok()?;
    if e.key != k {
        return None;
    }
    let mut info = e.info;
    info.cached = true;
    Some((e.maneuver, info))
}

/// Keep `s`'s plan; failures only cost the next run a search.
pub fn store(s: &Scenario, m: &Maneuver, info: &PlanInfo) {
    let Some((p, k)) = path(s) else { return };
    let write = || -> std::io::Result<()> {
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d)?;
        }
        let text = serde_json::to_string(&Entry {
            key: k,
            maneuver: m.clone(),
            info: info.clone(),
        })
        .map_err(std::io::Error::other)?;
        let tmp = p.with_extension(format!("tmp{}", std::process::id()));
        std::fs::write(&tmp, text)?;
        std::fs::rename(&tmp, &p)
    };
    if let Err(e) = write() {
        log::debug!("plan cache: cannot write {}: {e}", p.display());
    }
}
