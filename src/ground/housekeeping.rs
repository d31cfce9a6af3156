//! The housekeeping structures as data: structure 1, the latest estimate, its fields in
//! wire order, each read from the estimator's `EstimateMsg` (or the set's mode) by the
//! same entry that names it in the dictionary; structure 2, the set's health
//! (`health`). A 3,25 report's source data are the structure ID (u16), then the
//! structure's fields, big-endian. Encoding writes into the caller's buffer.
//! `columns` lists either structure's values, one per element, as decoders and the
//! dictionary read them.

use super::dictionary::{read_bits, Kind, Mode};
pub use super::health::{encode_health, Health, HealthField, HEALTH, HEALTH_LEN, STRUCTURE_HEALTH};
pub use super::layout::{data_len_of, Elements, STAGES, STAGE_NAMES};
use super::packet::EncodeError;
use crate::sim::msg::EstimateMsg;

/// The structure ID of the latest estimate.
pub const STRUCTURE_ESTIMATE: u16 = 1;

/// What a report of structure 1 is made from.
#[derive(Debug, Clone, Copy)]
pub struct Source<'a> {
    pub estimate: &'a EstimateMsg,
    pub mode: Mode,
}

/// A field of a housekeeping structure.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    pub name: &'static str,
    pub kind: Kind,
    pub elements: Elements,
    pub unit: &'static str,
    pub meaning: &'static str,
    /// Element `i`'s value as wire bits (binary64 as its bits).
    pub read: fn(&Source, usize) -> u64,
}

fn axis(a: &[[f64; 3]; 2], i: usize) -> u64 {
    a[i / 3][i % 3].to_bits()
}

/// Structure 1, in wire order.
pub const ESTIMATE: &[Field] = &[
    Field {
        name: "beta",
        kind: Kind::F64,
        elements: Elements::IsAxis,
        unit: "rad s^-2 V^-1",
        meaning: "angular scale factor",
        read: |s, i| axis(&s.estimate.beta, i),
    },
    Field {
        name: "beta_sigma",
        kind: Kind::F64,
        elements: Elements::IsAxis,
        unit: "rad s^-2 V^-1",
        meaning: "its 1σ",
        read: |s, i| axis(&s.estimate.beta_sigma, i),
    },
    Field {
        name: "k",
        kind: Kind::F64,
        elements: Elements::IsAxis,
        unit: "m s^-2 V^-1",
        meaning: "linear scale factor",
        read: |s, i| axis(&s.estimate.k, i),
    },
    Field {
        name: "k_sigma",
        kind: Kind::F64,
        elements: Elements::IsAxis,
        unit: "m s^-2 V^-1",
        meaning: "its 1σ",
        read: |s, i| axis(&s.estimate.k_sigma, i),
    },
    Field {
        name: "r",
        kind: Kind::F64,
        elements: Elements::IsAxis,
        unit: "m",
        meaning: "centre-of-mass offset, body frame",
        read: |s, i| axis(&s.estimate.r_b, i),
    },
    Field {
        name: "r_sigma",
        kind: Kind::F64,
        elements: Elements::IsAxis,
        unit: "m",
        meaning: "its 1σ",
        read: |s, i| axis(&s.estimate.r_sigma, i),
    },
    Field {
        name: "status",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "the status word (0: a verified solution)",
        read: |s, _| s.estimate.status,
    },
    Field {
        name: "chi2_per_dof",
        kind: Kind::F64,
        elements: Elements::Group,
        unit: "",
        meaning: "χ² per degree of freedom of the residual group",
        read: |s, i| s.estimate.chi2_per_dof[i].to_bits(),
    },
    Field {
        name: "samples_used",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "ticks whose IS data entered the estimate",
        read: |s, _| s.estimate.n_used,
    },
    Field {
        name: "samples_rejected",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "ticks whose IS data did not (rejected, invalid or missing)",
        read: |s, _| s.estimate.n_rejected,
    },
    Field {
        name: "tick",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "the campaign's tick of this estimate",
        read: |s, _| s.estimate.header.tick,
    },
    Field {
        name: "solved_tick",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "the tick of the last solve",
        read: |s, _| s.estimate.solved_tick,
    },
    Field {
        name: "flags",
        kind: Kind::U64,
        elements: Elements::One,
        unit: "",
        meaning: "estimate flags (bit 0: the campaign's final estimate)",
        read: |s, _| s.estimate.flags,
    },
    Field {
        name: "mode",
        kind: Kind::U8,
        elements: Elements::One,
        unit: "",
        meaning: "the set's mode (0 standby, 1 running, 2 shutting down)",
        read: |s, _| s.mode as u64,
    },
];

/// Bytes of a structure's source data: its ID and its fields.
pub const fn data_len(fields: &[Field]) -> usize {
    let mut n = 2;
    let mut i = 0;
    while i < fields.len() {
        n += data_len_of(fields[i].kind, fields[i].elements);
        i += 1;
    }
    n
}

/// Bytes of structure 1's source data.
pub const ESTIMATE_LEN: usize = data_len(ESTIMATE);

/// Writes structure 1's source data (ID, fields) into `out`; returns its length.
pub fn encode_estimate(src: &Source, out: &mut [u8]) -> Result<usize, EncodeError> {
    if out.len() < ESTIMATE_LEN {
        return Err(EncodeError::BufferTooSmall {
            need: ESTIMATE_LEN,
            have: out.len(),
        });
    }
    out[..2].copy_from_slice(&STRUCTURE_ESTIMATE.to_be_bytes());
    let mut at = 2;
    for f in ESTIMATE {
        let size = f.kind.size();
        for i in 0..f.elements.count() {
            let bits = (f.read)(src, i);
            out[at..at + size].copy_from_slice(&bits.to_be_bytes()[8 - size..]);
            at += size;
        }
    }
    Ok(at)
}

/// Why source data are not a report of structure 1 (or of any structure).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum HkError {
    #[error("structure {0}, not 1")]
    WrongStructure(u16),
    #[error("{len} bytes, where structure 1 has {ESTIMATE_LEN}")]
    WrongLength { len: usize },
    #[error("housekeeping structure {0} is not in the dictionary")]
    UnknownStructure(u16),
    #[error("{len} bytes of source data, where structure {id} has {want}")]
    Length { id: u16, len: usize, want: usize },
    #[error("{len} bytes cannot hold a structure ID")]
    NoId { len: usize },
}

/// A value of a housekeeping structure: one element of a field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    /// The field's name with its element's suffix (`beta_is1_x`, `restarts_plant`).
    pub name: String,
    pub kind: Kind,
    pub unit: &'static str,
    pub meaning: String,
}

fn column(
    name: &str,
    kind: Kind,
    elements: Elements,
    i: usize,
    unit: &'static str,
    meaning: &str,
) -> Column {
    let meaning = match elements {
        Elements::One => meaning.to_string(),
        e => format!("{meaning} ({})", e.suffix(i).trim_start_matches('_')),
    };
    Column {
        name: format!("{name}{}", elements.suffix(i)),
        kind,
        unit,
        meaning,
    }
}

/// The values of structure `structure_id` after its ID, in wire order (`None`: no such
/// structure).
pub fn columns(structure_id: u16) -> Option<Vec<Column>> {
    let mut v = Vec::new();
    match structure_id {
        STRUCTURE_ESTIMATE => {
            for f in ESTIMATE {
                for i in 0..f.elements.count() {
                    v.push(column(f.name, f.kind, f.elements, i, f.unit, f.meaning));
                }
            }
        }
        STRUCTURE_HEALTH => {
            for f in HEALTH {
                for i in 0..f.elements.count() {
                    v.push(column(f.name, f.kind, f.elements, i, f.unit, f.meaning));
                }
            }
        }
        _ => return None,
    }
    Some(v)
}

/// The structure IDs, in order.
pub const STRUCTURES: [u16; 2] = [STRUCTURE_ESTIMATE, STRUCTURE_HEALTH];

/// A structure's name.
pub fn structure_name(structure_id: u16) -> Option<&'static str> {
    match structure_id {
        STRUCTURE_ESTIMATE => Some("estimate"),
        STRUCTURE_HEALTH => Some("health"),
        _ => None,
    }
}

/// Reads a 3,25 report's source data of any structure: its ID and each value with its
/// wire bits (for ground tools: it allocates).
pub fn decode_structure(data: &[u8]) -> Result<(u16, Vec<(Column, u64)>), HkError> {
    let Some(id) = data.first_chunk::<2>() else {
        return Err(HkError::NoId { len: data.len() });
    };
    let id = u16::from_be_bytes(*id);
    let cols = columns(id).ok_or(HkError::UnknownStructure(id))?;
    let want = 2 + cols.iter().map(|c| c.kind.size()).sum::<usize>();
    if data.len() != want {
        return Err(HkError::Length {
            id,
            len: data.len(),
            want,
        });
    }
    let mut at = 2;
    let mut out = Vec::with_capacity(cols.len());
    for c in cols {
        let bits = read_bits(c.kind, &data[at..]);
        at += c.kind.size();
        out.push((c, bits));
    }
    Ok((id, out))
}

/// Reads structure 1's source data: calls `each(field, element, wire bits)` in order.
pub fn decode_estimate(
    data: &[u8],
    mut each: impl FnMut(&Field, usize, u64),
) -> Result<(), HkError> {
    if data.len() != ESTIMATE_LEN {
        return Err(HkError::WrongLength { len: data.len() });
    }
    let sid = u16::from_be_bytes([data[0], data[1]]);
    if sid != STRUCTURE_ESTIMATE {
        return Err(HkError::WrongStructure(sid));
    }
    let mut at = 2;
    for f in ESTIMATE {
        for i in 0..f.elements.count() {
            each(f, i, read_bits(f.kind, &data[at..]));
            at += f.kind.size();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An estimate with a distinct value in every field structure 1 reads.
    pub(crate) fn sample() -> EstimateMsg {
        let mut e = EstimateMsg::default();
        let mut v = 1.0f64;
        for a in [
            &mut e.beta,
            &mut e.beta_sigma,
            &mut e.k,
            &mut e.k_sigma,
            &mut e.r_b,
            &mut e.r_sigma,
        ] {
            for x in a.iter_mut().flatten() {
                v *= -1.37;
                *x = v * 1e-7;
            }
        }
        e.chi2_per_dof = [0.97, 1.02, 1.5, f64::NAN];
        e.status = 0x18;
        (
            e.n_used,
            e.n_rejected,
            e.header.tick,
            e.solved_tick,
            e.flags,
        ) = (9_000, 12, 9_011, 9_000, 1);
        e
    }

    #[test]
    fn structure_1_round_trips_field_by_field() {
        let e = sample();
        let src = Source {
            estimate: &e,
            mode: Mode::Running,
        };
        let mut out = [0u8; 512];
        let n = encode_estimate(&src, &mut out).unwrap();
        assert_eq!(n, ESTIMATE_LEN);
        assert_eq!(n, 2 + 36 * 8 + 8 + 4 * 8 + 5 * 8 + 1);
        assert_eq!(out[..2], [0, 1]);
        assert_eq!(out[2..10], e.beta[0][0].to_be_bytes());
        assert_eq!(out[2 + 6 * 8..2 + 7 * 8], e.beta_sigma[0][0].to_be_bytes());
        assert_eq!(out[n - 1], 1);
        let mut seen = 0;
        decode_estimate(&out[..n], |f, i, bits| {
            assert_eq!(
                bits,
                (f.read)(&src, i),
                "{}{}",
                f.name,
                f.elements.suffix(i)
            );
            seen += 1;
        })
        .unwrap();
        assert_eq!(seen, 36 + 1 + 4 + 5 + 1);
        assert_eq!(
            decode_estimate(&out[..n - 1], |_, _, _| {}),
            Err(HkError::WrongLength { len: n - 1 })
        );
        out[1] = 2;
        assert_eq!(
            decode_estimate(&out[..n], |_, _, _| {}),
            Err(HkError::WrongStructure(2))
        );
        assert!(matches!(
            encode_estimate(&src, &mut out[..n - 1]),
            Err(EncodeError::BufferTooSmall { .. })
        ));
    }

    #[test]
    fn elements_are_named_by_is_and_axis_or_by_group() {
        assert_eq!(Elements::IsAxis.suffix(0), "_is1_x");
        assert_eq!(Elements::IsAxis.suffix(5), "_is2_z");
        assert_eq!(Elements::Group.suffix(1), "_common_mode");
        assert_eq!(Elements::One.suffix(0), "");
    }
}
