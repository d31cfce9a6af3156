//! The report's `timing` of a supervised run, from the last heartbeat of each member:
//! end-to-end and per-hop latency, missed deadlines by cause, how each stage was
//! scheduled, samples lost.

use super::set::SupervisorArgs;
use crate::runtime::launch::ProcessSpec;
use crate::sim::msg::{
    Progress, PROC_COMMANDER, PROC_ESTIMATOR, PROC_FEE, PROC_PLANT, PROC_RECORDER,
};
use crate::sim::scenario::Scenario;
use serde_json::json;

/// Summary of the last progress each stage published.
pub(crate) struct MemberSummary {
    pub(crate) spec: ProcessSpec,
    pub(crate) id: u32,
    pub(crate) restarts: u32,
    pub(crate) last: Option<Progress>,
}

fn latency_json(v: [f64; 3]) -> serde_json::Value {
    json!({"p50": v[0], "p99": v[1], "max": v[2]})
}

/// The report's `timing`: pacing, latency, deadlines, scheduling, samples lost.
pub(crate) fn timing_json(
    args: &SupervisorArgs,
    s: &Scenario,
    members: &[MemberSummary],
) -> serde_json::Value {
    let get = |id: u32| members.iter().find(|m| m.id == id).and_then(|m| m.last);
    let lost: u64 = members
        .iter()
        .filter_map(|m| m.last.map(|p| p.samples_lost))
        .sum();
    if !args.realtime {
        return json!({"pacing": "accelerated", "samples_lost": lost});
    }
    // A tick misses its deadline when its estimate is published more than one period
    // after the tick was due; the commander's own late starts are one cause of that.
    let est = get(PROC_ESTIMATOR).unwrap_or_default();
    let missed = est.missed_deadlines;
    let commander_late = get(PROC_COMMANDER)
        .map_or(0, |p| p.missed_deadlines)
        .min(missed);
    let scheduling: serde_json::Map<String, serde_json::Value> = members
        .iter()
        .filter(|m| m.id != PROC_RECORDER)
        .filter_map(|m| {
            let p = m.last?;
            let mut policy = match p.rt_priority {
                0 => "normal".to_string(),
                n => format!("SCHED_FIFO {n}"),
            };
            if p.cpu >= 0 {
                policy.push_str(&format!(" on CPU {}", p.cpu));
            }
            Some((m.spec.name.clone(), policy.into()))
        })
        .collect();
    let hop = |id: u32| latency_json(get(id).unwrap_or_default().hop_latency_us);
    json!({
        "pacing": "realtime",
        "time_scale": args.time_scale,
        "period_us": 1e6 / (s.sample_rate_hz * args.time_scale),
        "end_to_end_latency_us": latency_json(est.e2e_latency_us),
        "hop_latency_us": {
            "commander->plant": hop(PROC_PLANT),
            "plant->fee": hop(PROC_FEE),
            "fee->estimator": hop(PROC_ESTIMATOR),
        },
        "latency_samples": est.latency_count,
        "scheduling": scheduling,
        "missed_deadlines": missed,
        "missed_deadlines_by_cause": {
            "commander woke late": commander_late,
            "plant, fee or estimator late": missed - commander_late,
        },
        "samples_lost": lost,
    })
}
