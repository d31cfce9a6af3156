//! The process set in one table: every process (its stage id, its wake-up event, its
//! neighbours in the credit chain) and every service (its payload, who publishes and
//! who subscribes). Launch descriptions, the stages' links, the supervisor, the set
//! over hosts (which services cross the link) and `tools/launch --graph` all read it;
//! nothing else names a neighbour.

use crate::bus::wiring::{self, Payload};
use crate::sim::msg::{
    Control, EstimateMsg, GroundNote, GroundRequest, GroundState, Progress, Request, SensorSample,
    SetStatus, TorqueCommand, TruthState, PROC_COMMANDER, PROC_ESTIMATOR, PROC_FEE, PROC_PLANT,
    PROC_RECORDER, PROC_TMTC,
};

/// One process of the set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stage {
    /// Binary and iceoryx2 node name.
    pub process: &'static str,
    /// `PROC_*`, carried in its heartbeats.
    pub id: u32,
    /// Short name: its wake-up event is `taiji/wake/<name>`.
    pub name: &'static str,
    /// The stage whose credit it returns (it wakes that one when it consumed).
    pub upstream: Option<&'static str>,
    /// The stage whose credit it obeys (it wakes that one when it published).
    pub downstream: Option<&'static str>,
    /// Every campaign needs it (the recorder runs only with `--record`).
    pub required: bool,
    /// One of a campaign's processes (the TMTC process lives across campaigns, outside
    /// the services every stage uses).
    pub in_campaign: bool,
}

/// The supervisor's node name (it is no stage: it starts, watches and stops them).
pub const SUPERVISOR: &str = "supervisor";

/// The stages, upstream first.
pub const STAGES: [Stage; 6] = [
    Stage {
        process: "taiji-commander",
        id: PROC_COMMANDER,
        name: "commander",
        upstream: None,
        downstream: Some("plant"),
        required: true,
        in_campaign: true,
    },
    Stage {
        process: "taiji-plant",
        id: PROC_PLANT,
        name: "plant",
        upstream: Some("commander"),
        downstream: Some("fee"),
        required: true,
        in_campaign: true,
    },
    Stage {
        process: "taiji-fee",
        id: PROC_FEE,
        name: "fee",
        upstream: Some("plant"),
        downstream: Some("estimator"),
        required: true,
        in_campaign: true,
    },
    Stage {
        process: "taiji-estimator",
        id: PROC_ESTIMATOR,
        name: "estimator",
        upstream: Some("fee"),
        downstream: None,
        required: true,
        in_campaign: true,
    },
    // The recorder's credit paces the commander when recording.
    Stage {
        process: "taiji-recorder",
        id: PROC_RECORDER,
        name: "recorder",
        upstream: Some("commander"),
        downstream: None,
        required: false,
        in_campaign: true,
    },
    // The ground link (`--ground` only): outside the credit chain, it lives across
    // campaigns and speaks UDP to the ground (docs/ground.md).
    Stage {
        process: "taiji-tmtc",
        id: PROC_TMTC,
        name: "tmtc",
        upstream: None,
        downstream: None,
        required: false,
        in_campaign: false,
    },
];

/// Who publishes or subscribes: named processes, or every stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Users {
    Some(&'static [&'static str]),
    EveryStage,
}

/// One publish–subscribe service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Service {
    pub name: &'static str,
    /// The payload's versioned bus type name.
    pub payload: &'static str,
    pub publishers: Users,
    pub subscribers: Users,
    /// The supervisor subscribes too.
    pub supervisor_subscribes: bool,
    /// The supervisor publishes.
    pub supervisor_publishes: bool,
    /// Outside clients (`taiji-calib monitor`) use it, from any host: on a set over
    /// hosts it crosses the link whoever else uses it.
    pub outside: bool,
}

/// The data and control services, and the monitors' two. Truth goes to the front end
/// and the recorder only: never to the estimator, to a monitor, or across the link to
/// a flight host. A monitor reads the estimates (published off the estimator's loop
/// thread, `process::outbox`) and the supervisor's status, and asks the supervisor
/// for control actions: it never opens a port where a stage's loop would have to
/// connect to it.
pub const SERVICES: [Service; 12] = [
    Service {
        name: wiring::SVC_TORQUE,
        payload: TorqueCommand::TYPE_NAME,
        publishers: Users::Some(&["taiji-commander"]),
        subscribers: Users::Some(&["taiji-plant"]),
        supervisor_subscribes: false,
        supervisor_publishes: false,
        outside: false,
    },
    Service {
        name: wiring::SVC_TRUTH,
        payload: TruthState::TYPE_NAME,
        publishers: Users::Some(&["taiji-plant"]),
        subscribers: Users::Some(&["taiji-fee", "taiji-recorder"]),
        supervisor_subscribes: false,
        supervisor_publishes: false,
        outside: false,
    },
    Service {
        name: wiring::SVC_SENSOR,
        payload: SensorSample::TYPE_NAME,
        publishers: Users::Some(&["taiji-fee"]),
        subscribers: Users::Some(&["taiji-estimator", "taiji-recorder"]),
        supervisor_subscribes: false,
        supervisor_publishes: false,
        outside: false,
    },
    Service {
        name: wiring::SVC_ESTIMATE,
        payload: EstimateMsg::TYPE_NAME,
        publishers: Users::Some(&["taiji-estimator"]),
        subscribers: Users::Some(&["taiji-recorder"]),
        supervisor_subscribes: true,
        supervisor_publishes: false,
        outside: true,
    },
    Service {
        name: wiring::SVC_PROGRESS,
        payload: Progress::TYPE_NAME,
        publishers: Users::EveryStage,
        subscribers: Users::EveryStage,
        supervisor_subscribes: true,
        supervisor_publishes: false,
        outside: false,
    },
    Service {
        name: wiring::SVC_CONTROL,
        payload: Control::TYPE_NAME,
        publishers: Users::Some(&[]),
        subscribers: Users::EveryStage,
        supervisor_subscribes: false,
        supervisor_publishes: true,
        outside: false,
    },
    Service {
        name: wiring::SVC_STATUS,
        payload: SetStatus::TYPE_NAME,
        publishers: Users::Some(&[]),
        subscribers: Users::Some(&[]),
        supervisor_subscribes: false,
        supervisor_publishes: true,
        outside: true,
    },
    Service {
        name: wiring::SVC_REQUEST,
        payload: Request::TYPE_NAME,
        publishers: Users::Some(&[]),
        subscribers: Users::Some(&[]),
        supervisor_subscribes: true,
        supervisor_publishes: false,
        outside: true,
    },
    Service {
        name: wiring::SVC_GROUND_REQUEST,
        payload: GroundRequest::TYPE_NAME,
        publishers: Users::Some(&["taiji-tmtc"]),
        subscribers: Users::Some(&[]),
        supervisor_subscribes: true,
        supervisor_publishes: false,
        outside: false,
    },
    Service {
        name: wiring::SVC_GROUND_NOTE,
        payload: GroundNote::TYPE_NAME,
        publishers: Users::Some(&[]),
        subscribers: Users::Some(&["taiji-tmtc"]),
        supervisor_subscribes: false,
        supervisor_publishes: true,
        outside: false,
    },
    Service {
        name: wiring::SVC_GROUND_BEAT,
        payload: Progress::TYPE_NAME,
        publishers: Users::Some(&["taiji-tmtc"]),
        subscribers: Users::Some(&[]),
        supervisor_subscribes: true,
        supervisor_publishes: false,
        outside: false,
    },
    Service {
        name: wiring::SVC_GROUND_STATE,
        payload: GroundState::TYPE_NAME,
        publishers: Users::Some(&[]),
        subscribers: Users::Some(&["taiji-tmtc"]),
        supervisor_subscribes: false,
        supervisor_publishes: true,
        outside: false,
    },
];

/// Does an outside client use service `name` (it then crosses every link)?
pub fn outside(name: &str) -> bool {
    SERVICES.iter().any(|s| s.name == name && s.outside)
}

/// The stage run by binary `process`.
pub fn stage(process: &str) -> Option<&'static Stage> {
    STAGES.iter().find(|s| s.process == process)
}

/// The stage with short name `name`.
pub fn stage_named(name: &str) -> Option<&'static Stage> {
    STAGES.iter().find(|s| s.name == name)
}

/// The processes of the set, upstream first.
pub fn processes() -> impl Iterator<Item = &'static str> {
    STAGES.iter().map(|s| s.process)
}

fn expand(u: Users) -> Vec<&'static str> {
    match u {
        Users::Some(list) => list.to_vec(),
        Users::EveryStage => STAGES
            .iter()
            .filter(|s| s.in_campaign)
            .map(|s| s.process)
            .collect(),
    }
}

/// Every node that uses service `name` (the supervisor as `SUPERVISOR`); for a
/// stage's wake-up event, the stage and its neighbours in the credit chain. An
/// unknown service is used by everyone (it then crosses every link).
pub fn users(name: &str) -> Vec<&'static str> {
    if let Some(s) = SERVICES.iter().find(|s| s.name == name) {
        let mut out = expand(s.publishers);
        out.extend(expand(s.subscribers));
        if s.supervisor_publishes || s.supervisor_subscribes {
            out.push(SUPERVISOR);
        }
        out.sort_unstable();
        out.dedup();
        return out;
    }
    if let Some(st) = STAGES
        .iter()
        .find(|st| wiring::wake_service(st.name) == name)
    {
        let mut out = vec![st.process];
        out.extend(
            STAGES
                .iter()
                .filter(|o| o.upstream == Some(st.name) || o.downstream == Some(st.name))
                .map(|o| o.process),
        );
        out.sort_unstable();
        out.dedup();
        return out;
    }
    let mut all: Vec<&'static str> = processes().collect();
    all.push(SUPERVISOR);
    all
}

/// Output format of [`graph`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum GraphFormat {
    Mermaid,
    Dot,
}

/// The data flow as a graph: one edge per (publisher, subscriber) of each data
/// service, labelled with the service and its payload, and the credit each stage
/// returns upstream dashed (the recorder's paces the commander).
pub fn graph(format: GraphFormat) -> String {
    let mut edges: Vec<(&str, &str, String)> = Vec::new();
    for s in SERVICES
        .iter()
        .filter(|s| matches!(s.publishers, Users::Some(p) if !p.is_empty()))
    {
        let mut subs = expand(s.subscribers);
        if s.supervisor_subscribes {
            subs.push(SUPERVISOR);
        }
        let payload = s.payload.rsplit("::").next().unwrap_or(s.payload);
        for p in expand(s.publishers) {
            for q in &subs {
                edges.push((p, q, format!("{} ({payload})", s.name)));
            }
        }
    }
    let id = |n: &str| n.replace('-', "_");
    let mut out = String::new();
    match format {
        GraphFormat::Mermaid => {
            out.push_str("flowchart LR\n");
            for (a, b, label) in &edges {
                out.push_str(&format!("  {}[{a}] -->|{label}| {}[{b}]\n", id(a), id(b)));
            }
            for st in &STAGES {
                if let Some(u) = st.upstream.and_then(stage_named) {
                    out.push_str(&format!(
                        "  {} -.->|credit| {}\n",
                        id(st.process),
                        id(u.process)
                    ));
                }
            }
            out.push_str(&format!(
                "  {SUPERVISOR}[{SUPERVISOR}] -.->|{} (Control)| every_stage([every stage])\n",
                wiring::SVC_CONTROL
            ));
            out.push_str(&format!(
                "  every_stage -.->|{} (Progress)| {SUPERVISOR}\n",
                wiring::SVC_PROGRESS
            ));
        }
        GraphFormat::Dot => {
            out.push_str("digraph taiji {\n  rankdir=LR;\n");
            for (a, b, label) in &edges {
                out.push_str(&format!("  \"{a}\" -> \"{b}\" [label=\"{label}\"];\n"));
            }
            for st in &STAGES {
                if let Some(u) = st.upstream.and_then(stage_named) {
                    out.push_str(&format!(
                        "  \"{}\" -> \"{}\" [label=\"credit\", style=dashed];\n",
                        st.process, u.process
                    ));
                }
            }
            out.push_str(&format!(
                "  \"{SUPERVISOR}\" -> \"every stage\" [label=\"{} (Control)\", style=dashed];\n",
                wiring::SVC_CONTROL
            ));
            out.push_str(&format!(
                "  \"every stage\" -> \"{SUPERVISOR}\" [label=\"{} (Progress)\", style=dashed];\n}}\n",
                wiring::SVC_PROGRESS
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_name_stages_of_the_table_and_agree_both_ways() {
        for st in &STAGES {
            for n in [st.upstream, st.downstream].into_iter().flatten() {
                assert!(
                    stage_named(n).is_some(),
                    "{}: unknown neighbour {n}",
                    st.process
                );
            }
            // A stage's downstream has it as its upstream.
            if let Some(d) = st.downstream.and_then(stage_named) {
                assert_eq!(d.upstream, Some(st.name), "{}", st.process);
            }
        }
        let ids: Vec<u32> = STAGES.iter().map(|s| s.id).collect();
        assert_eq!(ids.len(), 6);
        assert!(ids.windows(2).all(|w| w[0] != w[1]));
    }

    #[test]
    fn users_are_what_the_hosts_module_had_by_hand() {
        assert_eq!(
            users(wiring::SVC_TORQUE),
            ["taiji-commander", "taiji-plant"]
        );
        assert_eq!(
            users(wiring::SVC_TRUTH),
            ["taiji-fee", "taiji-plant", "taiji-recorder"]
        );
        assert_eq!(
            users(wiring::SVC_ESTIMATE),
            ["supervisor", "taiji-estimator", "taiji-recorder"]
        );
        assert_eq!(
            users(&wiring::wake_service("commander")),
            ["taiji-commander", "taiji-plant", "taiji-recorder"]
        );
        assert_eq!(
            users(&wiring::wake_service("estimator")),
            ["taiji-estimator", "taiji-fee"]
        );
        assert_eq!(users(wiring::SVC_PROGRESS).len(), 6);
        // The TMTC process meets no campaign's port.
        for svc in SERVICES
            .iter()
            .filter(|s| users(s.name).contains(&"taiji-tmtc"))
        {
            assert!(svc.name.starts_with("taiji/ground_"), "{}", svc.name);
        }
        // Truth never reaches the estimator.
        assert!(!users(wiring::SVC_TRUTH).contains(&"taiji-estimator"));
    }

    #[test]
    fn the_graph_has_every_data_edge_in_both_formats() {
        let m = graph(GraphFormat::Mermaid);
        assert!(m.starts_with("flowchart LR"));
        assert!(m.contains("taiji_fee[taiji-fee] -->|taiji/sensor (SensorSample)| taiji_estimator[taiji-estimator]"));
        assert!(
            !m.contains("taiji_plant[taiji-plant] -->|taiji/truth (TruthState)| taiji_estimator")
        );
        let d = graph(GraphFormat::Dot);
        assert!(d.contains("\"taiji-plant\" -> \"taiji-fee\" [label=\"taiji/truth (TruthState)\"]"));
        assert!(d.trim_end().ends_with('}'));
    }
}
