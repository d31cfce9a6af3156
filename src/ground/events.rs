//! The events of service 5 as data: their IDs, names, severities (the report's subtype:
//! 5,1 info, 5,2 low, 5,3 medium, 5,4 high) and auxiliary data. An event report's source
//! data are the event ID (u16), then its arguments, each in its `Kind`, big-endian, no
//! padding. Every event is enabled at start; 5,6 disables an ID and 5,5 enables it again.

use super::dictionary::{read_bits, write_bits, Kind};
use super::packet::EncodeError;

/// An argument of an event (its auxiliary data, in order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EventArg {
    pub name: &'static str,
    pub kind: Kind,
    pub unit: &'static str,
    pub meaning: &'static str,
}

/// An event: its ID, name, severity (the subtype of its report) and arguments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EventDef {
    pub id: u16,
    pub name: &'static str,
    /// 1 info, 2 low, 3 medium, 4 high: the report's subtype (5,1 … 5,4).
    pub severity: u8,
    pub args: &'static [EventArg],
    pub meaning: &'static str,
}

pub const EV_MODE_CHANGED: u16 = 1;
pub const EV_STATUS_CHANGED: u16 = 2;
pub const EV_PROCESS_RESTARTED: u16 = 3;
pub const EV_REQUIREMENT_MET: u16 = 4;
pub const EV_REQUIREMENT_MISSED: u16 = 5;
pub const EV_TABLE_APPLIED: u16 = 6;
pub const EV_TABLE_RESTORED: u16 = 7;
pub const EV_TC_REFUSED: u16 = 8;
pub const EV_TABLE_FILE_REFUSED: u16 = 9;
pub const EV_CAMPAIGN_ENDED_EARLY: u16 = 10;

/// The severities by subtype, as names.
pub const SEVERITY_NAMES: [&str; 4] = ["info", "low", "medium", "high"];

/// The name of severity (subtype) `s`, "?" when it is none.
pub fn severity_name(s: u8) -> &'static str {
    SEVERITY_NAMES
        .get(usize::from(s).wrapping_sub(1))
        .copied()
        .unwrap_or("?")
}

/// Arguments an event has at most.
pub const MAX_EVENT_ARGS: usize = 4;

const fn arg(
    name: &'static str,
    kind: Kind,
    unit: &'static str,
    meaning: &'static str,
) -> EventArg {
    EventArg {
        name,
        kind,
        unit,
        meaning,
    }
}

const CAMPAIGN: EventArg = arg("campaign", Kind::U32, "", "the campaign's number");

/// Every event, by ID.
pub const EVENTS: &[EventDef] = &[
    EventDef {
        id: EV_MODE_CHANGED,
        name: "mode_changed",
        severity: 1,
        args: &[
            arg(
                "from",
                Kind::U8,
                "",
                "the mode before (0 standby, 1 running, 2 shutting down)",
            ),
            arg("to", Kind::U8, "", "the mode now"),
            CAMPAIGN,
        ],
        meaning: "the set's mode changed",
    },
    EventDef {
        id: EV_STATUS_CHANGED,
        name: "status_changed",
        severity: 2,
        args: &[
            CAMPAIGN,
            arg("old", Kind::U64, "", "the estimator's status word before"),
            arg(
                "new",
                Kind::U64,
                "",
                "the status word now (0: a verified solution)",
            ),
        ],
        meaning: "the estimate's status word changed",
    },
    EventDef {
        id: EV_PROCESS_RESTARTED,
        name: "process_restarted",
        severity: 3,
        args: &[
            arg(
                "process",
                Kind::U8,
                "",
                "the process (1 commander, 2 plant, 3 front-end, 4 estimator, 5 recorder, 6 TMTC)",
            ),
            arg("restarts", Kind::U32, "", "times it has been restarted"),
        ],
        meaning: "the supervisor restarted a process",
    },
    EventDef {
        id: EV_REQUIREMENT_MET,
        name: "requirement_met",
        severity: 1,
        args: &[CAMPAIGN],
        meaning: "a campaign ended with its result verified against the requirement",
    },
    EventDef {
        id: EV_REQUIREMENT_MISSED,
        name: "requirement_missed",
        severity: 3,
        args: &[
            CAMPAIGN,
            arg(
                "verified",
                Kind::U8,
                "",
                "1 when the result was verified, else 0",
            ),
        ],
        meaning: "a campaign ended without meeting its requirement",
    },
    EventDef {
        id: EV_TABLE_APPLIED,
        name: "table_applied",
        severity: 1,
        args: &[arg(
            "campaign",
            Kind::U32,
            "",
            "the campaign whose result the table now holds",
        )],
        meaning: "function 3 copied a campaign's result into the onboard calibration table",
    },
    EventDef {
        id: EV_TABLE_RESTORED,
        name: "table_restored",
        severity: 1,
        args: &[arg(
            "campaign",
            Kind::U32,
            "",
            "the campaign whose result the table now holds (0: none)",
        )],
        meaning: "function 4 restored the table's previous values",
    },
    EventDef {
        id: EV_TC_REFUSED,
        name: "tc_refused",
        severity: 2,
        args: &[
            arg("failure", Kind::U16, "", "the failure code"),
            arg(
                "service",
                Kind::U8,
                "",
                "the telecommand's service (0 when unreadable)",
            ),
            arg("subtype", Kind::U8, "", "its subtype (0 when unreadable)"),
        ],
        meaning: "a telecommand was refused",
    },
    EventDef {
        id: EV_TABLE_FILE_REFUSED,
        name: "table_file_refused",
        severity: 4,
        args: &[arg(
            "copy",
            Kind::U8,
            "",
            "1: the table file was bad, its last good copy is used; 2: both were bad, no table",
        )],
        meaning: "the onboard calibration table's file failed its checks",
    },
    EventDef {
        id: EV_CAMPAIGN_ENDED_EARLY,
        name: "campaign_ended_early",
        severity: 4,
        args: &[
            CAMPAIGN,
            arg(
                "reason",
                Kind::U8,
                "",
                "1 stopped by function 2, 2 the set failed, 3 a signal",
            ),
        ],
        meaning: "a campaign ended before its last sample",
    },
];

/// The event of `id`.
pub fn event(id: u16) -> Option<&'static EventDef> {
    EVENTS.iter().find(|e| e.id == id)
}

/// Bytes of `def`'s report source data.
pub fn data_len(def: &EventDef) -> usize {
    2 + def.args.iter().map(|a| a.kind.size()).sum::<usize>()
}

/// The longest event report's source data.
pub const MAX_EVENT_DATA: usize = 2 + MAX_EVENT_ARGS * 8;

/// Writes the source data of event `def` with arguments `args` (each as wire bits: an
/// integer's value, an f64's bits; missing ones are 0, extra ones ignored) into `out`;
/// returns its length.
pub fn encode_event(def: &EventDef, args: &[u64], out: &mut [u8]) -> Result<usize, EncodeError> {
    let need = data_len(def);
    if out.len() < need {
        return Err(EncodeError::BufferTooSmall {
            need,
            have: out.len(),
        });
    }
    out[..2].copy_from_slice(&def.id.to_be_bytes());
    let mut at = 2;
    for (i, a) in def.args.iter().enumerate() {
        write_bits(a.kind, args.get(i).copied().unwrap_or(0), &mut out[at..]);
        at += a.kind.size();
    }
    Ok(at)
}

/// A decoded event report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EventReport {
    pub def: &'static EventDef,
    /// Its arguments as wire bits, `def.args.len()` of them used.
    pub args: [u64; MAX_EVENT_ARGS],
}

impl EventReport {
    /// Each argument with its value's wire bits.
    pub fn iter(&self) -> impl Iterator<Item = (&'static EventArg, u64)> + '_ {
        self.def.args.iter().zip(self.args)
    }
}

/// Why source data are not an event report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EventError {
    #[error("{len} bytes cannot hold an event ID")]
    Short { len: usize },
    #[error("event ID {0} is not in the dictionary")]
    Unknown(u16),
    #[error("event {id} has {want} bytes of source data, the report {len}")]
    WrongLength { id: u16, want: usize, len: usize },
    #[error("event {id} has severity {want}, the report's subtype is {subtype}")]
    WrongSeverity { id: u16, want: u8, subtype: u8 },
}

/// Reads an event report's source data (5,`subtype`).
pub fn decode_event(subtype: u8, data: &[u8]) -> Result<EventReport, EventError> {
    let Some(id) = data.first_chunk::<2>() else {
        return Err(EventError::Short { len: data.len() });
    };
    let id = u16::from_be_bytes(*id);
    let def = event(id).ok_or(EventError::Unknown(id))?;
    let want = data_len(def);
    if data.len() != want {
        return Err(EventError::WrongLength {
            id,
            want,
            len: data.len(),
        });
    }
    if def.severity != subtype {
        return Err(EventError::WrongSeverity {
            id,
            want: def.severity,
            subtype,
        });
    }
    let mut args = [0u64; MAX_EVENT_ARGS];
    let mut at = 2;
    for (slot, a) in args.iter_mut().zip(def.args) {
        *slot = read_bits(a.kind, &data[at..]);
        at += a.kind.size();
    }
    Ok(EventReport { def, args })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_are_listed_once_in_order_with_their_severity() {
        for (i, e) in EVENTS.iter().enumerate() {
            assert_eq!(usize::from(e.id), i + 1);
            assert!((1..=4).contains(&e.severity));
            assert!(e.args.len() <= MAX_EVENT_ARGS);
            assert!(data_len(e) <= MAX_EVENT_DATA);
        }
        assert_eq!(event(EV_TC_REFUSED).map(|e| e.name), Some("tc_refused"));
        assert_eq!(event(0), None);
        assert_eq!(event(11), None);
        assert_eq!(severity_name(4), "high");
        assert_eq!(severity_name(0), "?");
    }

    #[test]
    fn an_event_report_round_trips() {
        let def = event(EV_STATUS_CHANGED).unwrap();
        let mut out = [0u8; MAX_EVENT_DATA];
        let n = encode_event(def, &[3, 0x18, 0], &mut out).unwrap();
        assert_eq!(n, 2 + 4 + 8 + 8);
        assert_eq!(out[..6], [0, 2, 0, 0, 0, 3]);
        let r = decode_event(2, &out[..n]).unwrap();
        assert_eq!((r.def.id, r.args), (2, [3, 0x18, 0, 0]));
        assert_eq!(r.iter().count(), 3);
        assert_eq!(
            decode_event(3, &out[..n]),
            Err(EventError::WrongSeverity {
                id: 2,
                want: 2,
                subtype: 3
            })
        );
        assert!(matches!(
            decode_event(2, &out[..n - 1]),
            Err(EventError::WrongLength { .. })
        ));
        assert_eq!(decode_event(2, &[0]), Err(EventError::Short { len: 1 }));
        assert_eq!(decode_event(2, &[0, 99]), Err(EventError::Unknown(99)));
        assert!(encode_event(def, &[], &mut out[..5]).is_err());
        // Arguments wider than their field are cut to it.
        let def = event(EV_TC_REFUSED).unwrap();
        let n = encode_event(def, &[0x1_0014, 3, 27], &mut out).unwrap();
        assert_eq!(out[..n], [0, 8, 0, 20, 3, 27]);
    }
}
