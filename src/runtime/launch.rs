//! Launch description: which processes form the set, in which order they start, their
//! extra arguments and restart policy, and the supervisor's liveness timeouts (TOML).

use serde::Deserialize;
use std::path::Path;

/// Restart policy of one process.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Restart {
    /// Its death stops the set with an error.
    Never,
    /// Restarted when it dies before the set is stopped (non-zero exit or a signal).
    OnFailure,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProcessSpec {
    /// Binary name, looked up beside the supervisor's own executable.
    pub name: String,
    /// Extra arguments after the common ones the supervisor passes.
    #[serde(default)]
    pub args: Vec<String>,
    #[serde(default = "never")]
    pub restart: Restart,
    #[serde(default = "three")]
    pub max_restarts: u32,
    #[serde(default = "hundred")]
    pub restart_delay_ms: u64,
    /// Started only when the run records telemetry (`--record`).
    #[serde(default)]
    pub record_only: bool,
    /// Started only when the set is operated from the ground (`--ground`): it lives
    /// across campaigns and is never one of a campaign's processes.
    #[serde(default)]
    pub ground_only: bool,
    /// SCHED_FIFO priority in real-time runs (1–99; 0 = normal scheduling).
    #[serde(default)]
    pub rt_priority: u8,
    /// CPU to pin the process to in real-time runs (none: not pinned).
    #[serde(default)]
    pub cpu: Option<usize>,
    /// Host it runs on (a `[[host]]` name; none: the first host, which is in charge).
    #[serde(default)]
    pub host: Option<String>,
}

/// One host of a set spread over hosts joined by a network link (`src/runtime/process/hosts.rs`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostSpec {
    pub name: String,
    /// Zenoh endpoint its tunnel listens on, e.g. `tcp/10.231.7.1:7447`; the other
    /// hosts' tunnels connect to the first host's.
    pub endpoint: String,
}

fn never() -> Restart {
    Restart::Never
}
fn three() -> u32 {
    3
}
fn hundred() -> u64 {
    100
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaunchDescription {
    /// A process silent (no progress message) for this long is declared hung [s]:
    /// restarted if restartable, otherwise the set stops.
    pub heartbeat_timeout_s: f64,
    /// Every process must report ready within this time of being started [s].
    pub ready_timeout_s: f64,
    /// After the stop command, processes still running after this are killed [s].
    pub stop_timeout_s: f64,
    /// Started in this order; every process in the set must be listed once.
    pub process: Vec<ProcessSpec>,
    /// Hosts of the set (none: one host, no tunnel); the first is in charge: its
    /// supervisor starts the campaign, watches every host and writes the report.
    #[serde(default)]
    pub host: Vec<HostSpec>,
    /// A link to a host silent this long (no heartbeat crossed it) stops the set [s];
    /// a shorter silence is a link stall the set resumes from.
    #[serde(default = "link_timeout")]
    pub link_timeout_s: f64,
}

fn link_timeout() -> f64 {
    30.0
}

/// The default launch description (the same as `tools/launch.toml`).
pub const DEFAULT: &str = include_str!("../../tools/launch.toml");

/// The longest timeout a description may give [s] (about 32 years): the supervisor
/// waits each as a `Duration`, which holds less than 2⁶⁴ s (a longer one would panic
/// there).
pub const MAX_TIMEOUT_S: f64 = 1e9;

/// The recorder: optional, started with `--record` only.
pub const RECORDER: &str = "taiji-recorder";

/// The processes a set must contain (`topology::STAGES` marks them required).
pub fn required() -> impl Iterator<Item = &'static str> {
    crate::bus::topology::STAGES
        .iter()
        .filter(|s| s.required)
        .map(|s| s.process)
}

/// A launch description that could not be read or is not a valid process set.
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    #[error("cannot read launch description {}: {source}", path.display())]
    Read {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "launch description {origin}: {at}: {}",
        crate::sim::scenario::toml_message(source)
    )]
    Parse {
        origin: String,
        at: String,
        #[source]
        source: Box<toml::de::Error>,
    },
    /// Valid TOML, but not a process set this software can run.
    #[error("launch description {origin}: {problem}")]
    Invalid {
        origin: String,
        #[source]
        problem: LaunchProblem,
    },
}

/// What is wrong with a launch description's contents.
#[derive(Debug, thiserror::Error)]
pub enum LaunchProblem {
    #[error("{key} must be a positive number of seconds, at most {MAX_TIMEOUT_S:e}, not {value}")]
    Timeout { key: &'static str, value: f64 },
    #[error("process {name} must be listed exactly once (found {count})")]
    RequiredCount { name: &'static str, count: usize },
    #[error("unknown process {name:?} (known: {known})")]
    UnknownProcess { name: String, known: String },
    #[error("process {name}: rt_priority must be 0–99, not {priority}")]
    RtPriority { name: String, priority: u8 },
    #[error("host name {name:?} must be letters, digits or '-'")]
    HostName { name: String },
    #[error("host {name:?} is listed twice")]
    HostTwice { name: String },
    #[error("process {process} runs on host {host:?}, which no [[host]] names")]
    NoSuchHost { process: String, host: String },
    #[error("process {RECORDER} is listed more than once")]
    RecorderTwice,
}

impl LaunchDescription {
    pub fn parse(text: &str, origin: &str) -> Result<Self, LaunchError> {
        let d: LaunchDescription = toml::from_str(text).map_err(|source| LaunchError::Parse {
            origin: origin.into(),
            at: crate::sim::scenario::toml_error_at(text, &source),
            source: Box::new(source),
        })?;
        d.check().map_err(|problem| LaunchError::Invalid {
            origin: origin.into(),
            problem,
        })?;
        Ok(d)
    }

    /// The checks TOML cannot express; the first problem found.
    fn check(&self) -> Result<(), LaunchProblem> {
        let d = self;
        for (key, v) in [
            ("heartbeat_timeout_s", d.heartbeat_timeout_s),
            ("ready_timeout_s", d.ready_timeout_s),
            ("stop_timeout_s", d.stop_timeout_s),
            ("link_timeout_s", d.link_timeout_s),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= MAX_TIMEOUT_S) {
                return Err(LaunchProblem::Timeout { key, value: v });
            }
        }
        for name in required() {
            let count = d.process.iter().filter(|p| p.name == name).count();
            if count != 1 {
                return Err(LaunchProblem::RequiredCount { name, count });
            }
        }
        if let Some(p) = d
            .process
            .iter()
            .find(|p| crate::bus::topology::stage(&p.name).is_none())
        {
            return Err(LaunchProblem::UnknownProcess {
                name: p.name.clone(),
                known: crate::bus::topology::processes()
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        if let Some(p) = d.process.iter().find(|p| p.rt_priority > 99) {
            return Err(LaunchProblem::RtPriority {
                name: p.name.clone(),
                priority: p.rt_priority,
            });
        }
        for (i, h) in d.host.iter().enumerate() {
            if h.name.is_empty()
                || !h
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-')
            {
                return Err(LaunchProblem::HostName {
                    name: h.name.clone(),
                });
            }
            if d.host[..i].iter().any(|o| o.name == h.name) {
                return Err(LaunchProblem::HostTwice {
                    name: h.name.clone(),
                });
            }
        }
        if let Some(p) = d.process.iter().find(|p| {
            p.host
                .as_ref()
                .is_some_and(|h| !d.host.iter().any(|x| &x.name == h))
        }) {
            return Err(LaunchProblem::NoSuchHost {
                process: p.name.clone(),
                host: p.host.clone().unwrap_or_default(),
            });
        }
        if d.process.iter().filter(|p| p.name == RECORDER).count() > 1 {
            return Err(LaunchProblem::RecorderTwice);
        }
        Ok(())
    }

    /// The processes of a run, recording or not, in start order.
    pub fn processes(&self, record: bool) -> impl Iterator<Item = &ProcessSpec> {
        self.process
            .iter()
            .filter(move |p| (record || !p.record_only) && !p.ground_only)
    }

    /// The TMTC process of a set operated from the ground, when listed.
    pub fn ground_process(&self) -> Option<&ProcessSpec> {
        self.process.iter().find(|p| p.ground_only)
    }

    /// The host a process runs on ("" when the set has a single host).
    pub fn host_of<'a>(&'a self, p: &'a ProcessSpec) -> &'a str {
        match (&p.host, self.host.first()) {
            (Some(h), _) => h,
            (None, Some(first)) => &first.name,
            (None, None) => "",
        }
    }

    /// The host in charge (the first), when the set spans hosts.
    pub fn in_charge(&self) -> Option<&HostSpec> {
        (self.host.len() > 1).then(|| &self.host[0])
    }

    pub fn load_or_default(path: Option<&Path>) -> Result<Self, LaunchError> {
        match path {
            None => Self::parse(DEFAULT, "(built-in)"),
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|source| LaunchError::Read {
                    path: p.to_path_buf(),
                    source,
                })?;
                Self::parse(&text, &p.display().to_string())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_description_parses_with_estimator_restartable() {
        let d = LaunchDescription::load_or_default(None).unwrap();
        let est = d
            .process
            .iter()
            .find(|p| p.name == "taiji-estimator")
            .unwrap();
        assert_eq!(est.restart, Restart::OnFailure);
        let plant = d.process.iter().find(|p| p.name == "taiji-plant").unwrap();
        assert_eq!(plant.restart, Restart::Never);
    }

    #[test]
    fn the_ground_process_is_in_no_campaign() {
        let d = LaunchDescription::load_or_default(None).unwrap();
        let g = d.ground_process().unwrap();
        assert_eq!(
            (g.name.as_str(), g.restart, g.max_restarts),
            ("taiji-tmtc", Restart::OnFailure, 5)
        );
        for record in [false, true] {
            assert!(d
                .processes(record)
                .all(|p| !p.ground_only && p.name != "taiji-tmtc"));
        }
        assert_eq!(d.processes(true).count(), 5);
    }

    #[test]
    fn bad_descriptions_name_the_problem() {
        let e = LaunchDescription::parse(
            "heartbeat_timeout_s = 1.0\nready_timeout_s = 1.0\nstop_timeout_s = 1.0\nprocess = []",
            "x",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("taiji-commander must be listed"), "{e}");
        let e = LaunchDescription::parse(
            &DEFAULT.replace("restart = \"on-failure\"", "restart = \"sometimes\""),
            "x",
        )
        .unwrap_err()
        .to_string();
        // One line: where, the line itself, the parser's message.
        assert!(
            e.contains("restart") && e.contains("(`restart = \"sometimes\"`)") && !e.contains('\n'),
            "{e}"
        );
        let e = LaunchDescription::parse(
            &DEFAULT.replace("heartbeat_timeout_s = ", "heartbeat_timeout_s = -"),
            "x",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("heartbeat_timeout_s"), "{e}");
    }

    #[test]
    fn a_timeout_no_duration_holds_is_refused_not_a_panic_in_the_supervisor() {
        // Found by the launch fuzz target's oracle: `heartbeat_timeout_s = 1e300` passed
        // the check and made the supervisor's `Duration::from_secs_f64` panic.
        for key in [
            "heartbeat_timeout_s",
            "ready_timeout_s",
            "stop_timeout_s",
            "link_timeout_s",
        ] {
            let text = format!("{key} = 1e300\n{DEFAULT}");
            let text = if key == "link_timeout_s" {
                text
            } else {
                // The key once: drop the default's line.
                let line = DEFAULT.lines().find(|l| l.starts_with(key)).unwrap();
                text.replacen(&format!("\n{line}"), "\n", 1)
            };
            let e = LaunchDescription::parse(&text, "x")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!(
                    "{key} must be a positive number of seconds, at most 1e9"
                )),
                "{e}"
            );
        }
        let ok = DEFAULT.replace("stop_timeout_s = 5.0", "stop_timeout_s = 1e9");
        let d = LaunchDescription::parse(&ok, "x").unwrap();
        assert!(std::time::Duration::try_from_secs_f64(d.stop_timeout_s).is_ok());
    }
}
