//! Housekeeping structure 2, the set's health, as data: its fields in wire order, each
//! read from a `Health` (which the onboard TMTC logic fills from the supervisor's
//! `GroundState` and `SetStatus` and its own counters) by the entry that names it in the
//! dictionary. Re-exported by `housekeeping`.

use super::dictionary::{write_bits, Kind, N_FAILURES};
use super::layout::{data_len_of, Elements};
pub use super::layout::{STAGES, STAGE_NAMES};
use super::packet::EncodeError;

/// The structure ID of the set's health.
pub const STRUCTURE_HEALTH: u16 = 2;

/// What a report of structure 2 is made from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Health {
    /// `Mode` as its number.
    pub mode: u8,
    pub campaign: u32,
    /// The estimator's next tick.
    pub campaign_tick: u64,
    /// Samples in the campaign.
    pub n_samples: u64,
    pub tmtc_restarts: u32,
    pub stage_restarts: u32,
    /// Per stage (`STAGE_NAMES`).
    pub restarts: [u32; STAGES],
    /// Per stage; NaN when it is not running.
    pub heartbeat_age_ms: [f64; STAGES],
    pub samples_lost: [u64; STAGES],
    /// The estimator's end-to-end latency p50, p99, max; NaN when none.
    pub e2e_latency_us: [f64; 3],
    pub tc_accepted: u32,
    /// Per failure code, in code order.
    pub tc_refused: [u32; N_FAILURES],
    pub datagrams: u64,
    pub tm_sent: u64,
    pub tm_send_errors: u32,
}

impl Default for Health {
    fn default() -> Self {
        Health {
            mode: 0,
            campaign: 0,
            campaign_tick: 0,
            n_samples: 0,
            tmtc_restarts: 0,
            stage_restarts: 0,
            restarts: [0; STAGES],
            heartbeat_age_ms: [f64::NAN; STAGES],
            samples_lost: [0; STAGES],
            e2e_latency_us: [f64::NAN; 3],
            tc_accepted: 0,
            tc_refused: [0; N_FAILURES],
            datagrams: 0,
            tm_sent: 0,
            tm_send_errors: 0,
        }
    }
}

/// A field of structure 2.
#[derive(Debug, Clone, Copy)]
pub struct HealthField {
    pub name: &'static str,
    pub kind: Kind,
    pub elements: Elements,
    pub unit: &'static str,
    pub meaning: &'static str,
    /// Element `i`'s value as wire bits (binary64 as its bits).
    pub read: fn(&Health, usize) -> u64,
}

/// Structure 2, in wire order.
pub const HEALTH: &[HealthField] = &[
    HealthField {
        name: "mode",
        kind: Kind::U8,
        elements: Elements::One,
        unit: "",
        meaning: "the set's mode (0 standby, 1 running, 2 shutting down)",
        read: |h, _| h.mode.into(),
    },
    HealthField {
        name: "campaign",
        kind: Kind::U32,
        elements: Elements::One,
        unit: "",
        meaning: "the running campaign's number, or the last one's (0: none yet)",
        read: |h, _| h.campaign.into(),
    },
    HealthField {
        name: "campaign_tick",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "the estimator's next tick in the campaign",
        read: |h, _| h.campaign_tick,
    },
    HealthField {
        name: "n_samples",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "samples in the campaign",
        read: |h, _| h.n_samples,
    },
    HealthField {
        name: "tmtc_restarts",
        kind: Kind::U32,
        elements: Elements::One,
        unit: "",
        meaning: "times the supervisor restarted the TMTC process",
        read: |h, _| h.tmtc_restarts.into(),
    },
    HealthField {
        name: "stage_restarts",
        kind: Kind::U32,
        elements: Elements::One,
        unit: "",
        meaning: "restarts of the stage processes over every campaign so far",
        read: |h, _| h.stage_restarts.into(),
    },
    HealthField {
        name: "restarts",
        kind: Kind::U32,
        elements: Elements::Stage,
        unit: "",
        meaning: "restarts of the process in this campaign",
        read: |h, i| h.restarts[i].into(),
    },
    HealthField {
        name: "heartbeat_age_ms",
        kind: Kind::F64,
        elements: Elements::Stage,
        unit: "ms",
        meaning: "time since the process's last heartbeat (NaN when not running)",
        read: |h, i| h.heartbeat_age_ms[i].to_bits(),
    },
    HealthField {
        name: "samples_lost",
        kind: Kind::U64,
        elements: Elements::Stage,
        unit: "",
        meaning: "ticks missing in the process's input",
        read: |h, i| h.samples_lost[i],
    },
    HealthField {
        name: "e2e_latency_us",
        kind: Kind::F64,
        elements: Elements::Percentile,
        unit: "us",
        meaning: "the estimator's end-to-end latency, plant to estimate (NaN when none)",
        read: |h, i| h.e2e_latency_us[i].to_bits(),
    },
    HealthField {
        name: "tc_accepted",
        kind: Kind::U32,
        elements: Elements::One,
        unit: "",
        meaning: "telecommands accepted since the TMTC process started",
        read: |h, _| h.tc_accepted.into(),
    },
    HealthField {
        name: "tc_refused",
        kind: Kind::U32,
        elements: Elements::FailureCode,
        unit: "",
        meaning: "telecommands refused with this failure code since the TMTC process started",
        read: |h, i| h.tc_refused[i].into(),
    },
    HealthField {
        name: "datagrams",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "datagrams received",
        read: |h, _| h.datagrams,
    },
    HealthField {
        name: "tm_sent",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "telemetry packets sent",
        read: |h, _| h.tm_sent,
    },
    HealthField {
        name: "tm_send_errors",
        kind: Kind::U32,
        elements: Elements::One,
        unit: "",
        meaning:
            "telemetry packets not sent: refused by the socket, or dropped with the outbox full",
        read: |h, _| h.tm_send_errors.into(),
    },
];

/// Bytes of structure 2's source data: its ID and its fields.
pub const HEALTH_LEN: usize = {
    let mut n = 2;
    let mut i = 0;
    while i < HEALTH.len() {
        n += data_len_of(HEALTH[i].kind, HEALTH[i].elements);
        i += 1;
    }
    n
};

/// Writes structure 2's source data (ID, fields) into `out`; returns its length.
pub fn encode_health(h: &Health, out: &mut [u8]) -> Result<usize, EncodeError> {
    if out.len() < HEALTH_LEN {
        return Err(EncodeError::BufferTooSmall {
            need: HEALTH_LEN,
            have: out.len(),
        });
    }
    out[..2].copy_from_slice(&STRUCTURE_HEALTH.to_be_bytes());
    let mut at = 2;
    for f in HEALTH {
        for i in 0..f.elements.count() {
            write_bits(f.kind, (f.read)(h, i), &mut out[at..]);
            at += f.kind.size();
        }
    }
    Ok(at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::dictionary::Failure;
    use crate::ground::housekeeping::{columns, decode_structure, HkError};

    #[test]
    fn structure_2_round_trips_through_its_columns() {
        let mut h = Health {
            mode: 1,
            campaign: 3,
            campaign_tick: 12_345,
            n_samples: 86_400,
            tmtc_restarts: 1,
            stage_restarts: 2,
            datagrams: 100_000,
            tm_sent: 77,
            tm_send_errors: 4,
            tc_accepted: 9,
            ..Health::default()
        };
        h.restarts[3] = 2;
        h.heartbeat_age_ms = [1.5, 2.5, 3.5, 4.5, f64::NAN];
        h.samples_lost[4] = 7;
        h.e2e_latency_us = [80.0, 120.0, 300.0];
        h.tc_refused[0] = 99_990;
        h.tc_refused[Failure::ReadOnly as usize - 1] = 1;
        let mut out = [0u8; HEALTH_LEN];
        let n = encode_health(&h, &mut out).unwrap();
        assert_eq!(n, HEALTH_LEN);
        assert_eq!(
            n,
            2 + 1
                + 4
                + 8
                + 8
                + 4
                + 4
                + 5 * 4
                + 5 * 8
                + 5 * 8
                + 3 * 8
                + 4
                + 4 * N_FAILURES
                + 8
                + 8
                + 4
        );
        let (id, vals) = decode_structure(&out).unwrap();
        assert_eq!(id, 2);
        assert_eq!(vals.len(), columns(2).unwrap().len());
        let get = |name: &str| vals.iter().find(|(c, _)| c.name == name).unwrap().1;
        assert_eq!(get("campaign"), 3);
        assert_eq!(get("restarts_estimator"), 2);
        assert_eq!(get("heartbeat_age_ms_plant"), 2.5f64.to_bits());
        assert!(f64::from_bits(get("heartbeat_age_ms_recorder")).is_nan());
        assert_eq!(get("e2e_latency_us_p99"), 120f64.to_bits());
        assert_eq!(get("tc_refused_bad_crc"), 99_990);
        assert_eq!(get("tc_refused_read_only"), 1);
        assert_eq!(get("tm_send_errors"), 4);
        assert_eq!(
            decode_structure(&out[..n - 1]),
            Err(HkError::Length {
                id: 2,
                len: n - 1,
                want: n
            })
        );
        out[1] = 3;
        assert_eq!(decode_structure(&out), Err(HkError::UnknownStructure(3)));
        assert_eq!(decode_structure(&[1]), Err(HkError::NoId { len: 1 }));
        assert!(encode_health(&h, &mut out[..n - 1]).is_err());
    }
}
