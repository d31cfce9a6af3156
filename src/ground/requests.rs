//! The telecommands' application data (before the authentication trailer), decoded and
//! checked against the dictionary without touching the heap: each parser returns the
//! dictionary's failure for a wrong length, an unknown ID or an out-of-range value. The
//! builders at the end write the same layouts for ground tools.
//!
//! | TC | application data |
//! |---|---|
//! | 3,5 / 3,6 / 3,27 | N (u8), N structure IDs (u16) |
//! | 3,31 | N (u8), N × (structure ID u16, interval ms u32), 100 … 3 600 000 |
//! | 5,5 / 5,6 | N (u8), N event IDs (u16) |
//! | 8,1 | function ID (u16), its arguments (`dictionary::parse_function`) |
//! | 17,1 | none |
//! | 20,1 | N (u8), N parameter IDs (u16) |
//! | 20,3 | N (u8), N × (parameter ID u16, value in its kind) |

use super::dictionary::{read_bits, write_bits, Failure, Function, IdList, Kind};
use super::events::event;
use super::housekeeping::structure_name;
use super::parameters::{in_range, parameter, ParamDef, INTERVAL_RANGE_MS};

/// A field of a telecommand's application data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TcField {
    pub name: &'static str,
    /// Its kind; `None`: the kind of the parameter the entry names (20,3's value).
    pub kind: Option<Kind>,
    pub unit: &'static str,
    pub meaning: &'static str,
}

/// A telecommand the set takes and its application data (before the trailer): the
/// fields of `head`, then, with `entry`, N (u8) and N entries of its fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TcLayout {
    pub service: u8,
    pub subtype: u8,
    pub name: &'static str,
    pub meaning: &'static str,
    pub head: &'static [TcField],
    pub entry: Option<&'static [TcField]>,
}

const fn field(
    name: &'static str,
    kind: Kind,
    unit: &'static str,
    meaning: &'static str,
) -> TcField {
    TcField {
        name,
        kind: Some(kind),
        unit,
        meaning,
    }
}

const STRUCTURE_ID: TcField = field("structure_id", Kind::U16, "", "a housekeeping structure ID");
const EVENT_ID: TcField = field("event_id", Kind::U16, "", "an event ID");
const PARAMETER_ID: TcField = field("parameter_id", Kind::U16, "", "a parameter ID");

/// Every telecommand the set takes, in service order (`dictionary::SERVICES`).
pub const TELECOMMANDS: &[TcLayout] = &[
    TcLayout {
        service: 3,
        subtype: 5,
        name: "enable_housekeeping",
        meaning: "enable the periodic reports of the structures",
        head: &[],
        entry: Some(&[STRUCTURE_ID]),
    },
    TcLayout {
        service: 3,
        subtype: 6,
        name: "disable_housekeeping",
        meaning: "disable the periodic reports of the structures",
        head: &[],
        entry: Some(&[STRUCTURE_ID]),
    },
    TcLayout {
        service: 3,
        subtype: 27,
        name: "report_housekeeping",
        meaning: "one report of each structure now",
        head: &[],
        entry: Some(&[STRUCTURE_ID]),
    },
    TcLayout {
        service: 3,
        subtype: 31,
        name: "change_housekeeping_interval",
        meaning: "change the structures' report intervals",
        head: &[],
        entry: Some(&[
            STRUCTURE_ID,
            field(
                "interval",
                Kind::U32,
                "ms",
                "the report interval, 100 to 3600000",
            ),
        ]),
    },
    TcLayout {
        service: 5,
        subtype: 5,
        name: "enable_events",
        meaning: "enable the reports of the events",
        head: &[],
        entry: Some(&[EVENT_ID]),
    },
    TcLayout {
        service: 5,
        subtype: 6,
        name: "disable_events",
        meaning: "disable the reports of the events",
        head: &[],
        entry: Some(&[EVENT_ID]),
    },
    TcLayout {
        service: 8,
        subtype: 1,
        name: "perform_function",
        meaning: "perform a function; its arguments follow its ID (the functions table)",
        head: &[field("function_id", Kind::U16, "", "the function's ID")],
        entry: None,
    },
    TcLayout {
        service: 17,
        subtype: 1,
        name: "are_you_alive",
        meaning: "connection test: answered with 17,2",
        head: &[],
        entry: None,
    },
    TcLayout {
        service: 20,
        subtype: 1,
        name: "report_parameters",
        meaning: "report the parameters' values (20,2)",
        head: &[],
        entry: Some(&[PARAMETER_ID]),
    },
    TcLayout {
        service: 20,
        subtype: 3,
        name: "set_parameters",
        meaning: "set the parameters' values, each range-checked; all or none are set",
        head: &[],
        entry: Some(&[
            PARAMETER_ID,
            TcField {
                name: "value",
                kind: None,
                unit: "",
                meaning: "the value, in the parameter's kind",
            },
        ]),
    },
];

/// The IDs of an ID list, each checked by `known`, else `unknown`.
fn checked_ids(
    app_data: &[u8],
    known: impl Fn(u16) -> bool,
    unknown: Failure,
) -> Result<IdList<'_>, Failure> {
    let l = IdList::parse(app_data)?;
    if l.iter().all(known) {
        Ok(l)
    } else {
        Err(unknown)
    }
}

/// 3,5 / 3,6 / 3,27: housekeeping structure IDs.
pub fn parse_structures(app_data: &[u8]) -> Result<IdList<'_>, Failure> {
    checked_ids(
        app_data,
        |id| structure_name(id).is_some(),
        Failure::UnknownStructure,
    )
}

/// 5,5 / 5,6: event IDs.
pub fn parse_events(app_data: &[u8]) -> Result<IdList<'_>, Failure> {
    checked_ids(app_data, |id| event(id).is_some(), Failure::UnknownEvent)
}

/// 20,1: parameter IDs.
pub fn parse_parameter_ids(app_data: &[u8]) -> Result<IdList<'_>, Failure> {
    checked_ids(
        app_data,
        |id| parameter(id).is_some(),
        Failure::UnknownParameter,
    )
}

/// 3,31's entries: structure ID and interval [ms], each checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Intervals<'a>(&'a [u8]);

/// Bytes of one 3,31 entry.
const INTERVAL_ENTRY: usize = 6;

impl<'a> Intervals<'a> {
    pub fn len(&self) -> usize {
        self.0.len() / INTERVAL_ENTRY
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// (structure ID, interval ms), in order.
    pub fn iter(&self) -> impl Iterator<Item = (u16, u32)> + 'a {
        self.0.chunks_exact(INTERVAL_ENTRY).map(|c| {
            (
                u16::from_be_bytes([c[0], c[1]]),
                u32::from_be_bytes([c[2], c[3], c[4], c[5]]),
            )
        })
    }
}

/// 3,31: N × (structure ID, interval ms); an unknown structure fails first, then an
/// interval outside 100 … 3 600 000 ms.
pub fn parse_intervals(app_data: &[u8]) -> Result<Intervals<'_>, Failure> {
    let l = match app_data.split_first() {
        Some((&n, e)) if e.len() == INTERVAL_ENTRY * usize::from(n) => Intervals(e),
        _ => return Err(Failure::BadLength),
    };
    if l.iter().any(|(id, _)| structure_name(id).is_none()) {
        return Err(Failure::UnknownStructure);
    }
    let (lo, hi) = INTERVAL_RANGE_MS;
    if l.iter().any(|(_, ms)| !(lo..=hi).contains(&ms)) {
        return Err(Failure::OutOfRange);
    }
    Ok(l)
}

/// 20,3's entries: parameter and value (wire bits), each checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Values<'a> {
    n: u8,
    entries: &'a [u8],
}

impl<'a> Values<'a> {
    pub fn len(&self) -> usize {
        self.n.into()
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// (parameter, value as wire bits), in order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static ParamDef, u64)> + 'a {
        let mut rest = self.entries;
        (0..self.n).map_while(move |_| {
            let id = u16::from_be_bytes([*rest.first()?, *rest.get(1)?]);
            let def = parameter(id)?;
            let bits = read_bits(def.kind, rest.get(2..2 + def.kind.size())?);
            rest = &rest[2 + def.kind.size()..];
            Some((def, bits))
        })
    }
}

/// 20,3: N × (parameter ID, value in its kind). Read in order: an unknown parameter
/// fails (its value's length cannot be known), then a wrong total length; then a
/// read-only parameter, then a value out of its range. Whether the values agree with
/// each other (a minimum above a maximum) is the caller's to check.
pub fn parse_values(app_data: &[u8]) -> Result<Values<'_>, Failure> {
    let Some((&n, entries)) = app_data.split_first() else {
        return Err(Failure::BadLength);
    };
    let mut rest = entries;
    for _ in 0..n {
        let Some(id) = rest.first_chunk::<2>() else {
            return Err(Failure::BadLength);
        };
        let def = parameter(u16::from_be_bytes(*id)).ok_or(Failure::UnknownParameter)?;
        rest = rest.get(2 + def.kind.size()..).ok_or(Failure::BadLength)?;
    }
    if !rest.is_empty() {
        return Err(Failure::BadLength);
    }
    let v = Values { n, entries };
    if v.iter().any(|(def, _)| !def.settable) {
        return Err(Failure::ReadOnly);
    }
    if v.iter().any(|(def, bits)| !in_range(def, bits)) {
        return Err(Failure::OutOfRange);
    }
    Ok(v)
}

/// 17,1: no application data.
pub fn parse_empty(app_data: &[u8]) -> Result<(), Failure> {
    if app_data.is_empty() {
        Ok(())
    } else {
        Err(Failure::BadLength)
    }
}

/// Builds an ID list (3,5 / 3,6 / 3,27 / 5,5 / 5,6 / 20,1); `None` for more than 255.
pub fn id_list(ids: &[u16]) -> Option<Vec<u8>> {
    let mut v = vec![u8::try_from(ids.len()).ok()?];
    for id in ids {
        v.extend_from_slice(&id.to_be_bytes());
    }
    Some(v)
}

/// Builds 3,31's application data; `None` for more than 255 entries.
pub fn interval_list(entries: &[(u16, u32)]) -> Option<Vec<u8>> {
    let mut v = vec![u8::try_from(entries.len()).ok()?];
    for (id, ms) in entries {
        v.extend_from_slice(&id.to_be_bytes());
        v.extend_from_slice(&ms.to_be_bytes());
    }
    Some(v)
}

/// Builds 20,3's application data from (parameter ID, value as wire bits of its kind);
/// `None` for an unknown parameter or more than 255 entries.
pub fn value_list(entries: &[(u16, u64)]) -> Option<Vec<u8>> {
    let mut v = vec![u8::try_from(entries.len()).ok()?];
    for &(id, bits) in entries {
        let def = parameter(id)?;
        v.extend_from_slice(&id.to_be_bytes());
        let at = v.len();
        v.resize(at + def.kind.size(), 0);
        write_bits(def.kind, bits, &mut v[at..]);
    }
    Some(v)
}

/// Builds 8,1's application data for a function call.
pub fn function_call(f: &Function) -> Vec<u8> {
    let id: u16 = match f {
        Function::Start { .. } => 1,
        Function::Stop => 2,
        Function::Apply => 3,
        Function::Restore => 4,
        Function::Shutdown => 5,
    };
    let mut v = id.to_be_bytes().to_vec();
    if let Function::Start { seed, duration_s } = f {
        v.extend_from_slice(&seed.to_be_bytes());
        v.extend_from_slice(&duration_s.to_be_bytes());
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::dictionary::parse_function;

    #[test]
    fn id_lists_are_checked_against_the_dictionary() {
        let ids = |l: IdList| l.iter().collect::<Vec<_>>();
        assert_eq!(parse_structures(&[2, 0, 1, 0, 2]).map(ids), Ok(vec![1, 2]));
        assert_eq!(parse_structures(&[1, 0, 3]), Err(Failure::UnknownStructure));
        assert_eq!(parse_structures(&[2, 0, 1]), Err(Failure::BadLength));
        assert_eq!(parse_events(&[1, 0, 10]).map(ids), Ok(vec![10]));
        assert_eq!(parse_events(&[1, 0, 11]), Err(Failure::UnknownEvent));
        assert_eq!(parse_events(&[1, 0, 0]), Err(Failure::UnknownEvent));
        assert_eq!(
            parse_parameter_ids(&[2, 0, 47, 0, 4]).map(ids),
            Ok(vec![47, 4])
        );
        assert_eq!(
            parse_parameter_ids(&[1, 0, 6]),
            Err(Failure::UnknownParameter)
        );
        assert_eq!(parse_parameter_ids(&[]), Err(Failure::BadLength));
        assert_eq!(parse_empty(&[]), Ok(()));
        assert_eq!(parse_empty(&[0]), Err(Failure::BadLength));
        assert_eq!(id_list(&[1, 2]).unwrap(), [2, 0, 1, 0, 2]);
        assert!(id_list(&[0; 256]).is_none());
    }

    #[test]
    fn intervals_are_range_checked() {
        let d = interval_list(&[(1, 100), (2, 3_600_000)]).unwrap();
        assert_eq!(
            parse_intervals(&d).map(|l| l.iter().collect::<Vec<_>>()),
            Ok(vec![(1, 100), (2, 3_600_000)])
        );
        assert_eq!(parse_intervals(&d).unwrap().len(), 2);
        for bad in [99, 3_600_001, 0, u32::MAX] {
            let d = interval_list(&[(1, 1000), (2, bad)]).unwrap();
            assert_eq!(parse_intervals(&d), Err(Failure::OutOfRange), "{bad}");
        }
        let d = interval_list(&[(7, 1000)]).unwrap();
        assert_eq!(parse_intervals(&d), Err(Failure::UnknownStructure));
        assert_eq!(parse_intervals(&d[..6]), Err(Failure::BadLength));
        assert_eq!(parse_intervals(&[]), Err(Failure::BadLength));
        assert!(parse_intervals(&[0]).unwrap().is_empty());
    }

    #[test]
    fn values_are_checked_entry_by_entry() {
        let d = value_list(&[(1, 2000), (3, 30f64.to_bits())]).unwrap();
        assert_eq!(d.len(), 1 + 2 + 4 + 2 + 8);
        let v = parse_values(&d).unwrap();
        let got: Vec<_> = v.iter().map(|(p, b)| (p.id, b)).collect();
        assert_eq!(got, [(1, 2000), (3, 30f64.to_bits())]);
        assert_eq!(v.len(), 2);
        assert_eq!(parse_values(&d[..d.len() - 1]), Err(Failure::BadLength));
        let mut long = d.clone();
        long.push(0);
        assert_eq!(parse_values(&long), Err(Failure::BadLength));
        assert_eq!(parse_values(&[1, 0, 9, 0]), Err(Failure::UnknownParameter));
        assert_eq!(parse_values(&[]), Err(Failure::BadLength));
        let ro = value_list(&[(1, 2000), (46, 3)]).unwrap();
        assert_eq!(parse_values(&ro), Err(Failure::ReadOnly));
        let ro = value_list(&[(10, 1f64.to_bits())]).unwrap();
        assert_eq!(parse_values(&ro), Err(Failure::ReadOnly));
        for bad in [
            (1, 99),
            (2, 3_600_001),
            (4, f64::NAN.to_bits()),
            (3, 0f64.to_bits()),
        ] {
            let d = value_list(&[bad]).unwrap();
            assert_eq!(parse_values(&d), Err(Failure::OutOfRange), "{bad:?}");
        }
        assert!(value_list(&[(9, 0)]).is_none());
        assert!(parse_values(&[0]).unwrap().is_empty());
    }

    #[test]
    fn every_telecommand_routed_has_its_layout() {
        use crate::ground::dictionary::SERVICES;
        let routed: Vec<(u8, u8)> = SERVICES
            .iter()
            .flat_map(|s| s.tc.iter().map(move |&t| (s.id, t)))
            .collect();
        let laid: Vec<(u8, u8)> = TELECOMMANDS
            .iter()
            .map(|t| (t.service, t.subtype))
            .collect();
        assert_eq!(routed, laid);
    }

    #[test]
    fn function_calls_round_trip() {
        for f in [
            Function::Start {
                seed: 7,
                duration_s: 3600.0,
            },
            Function::Stop,
            Function::Apply,
            Function::Restore,
            Function::Shutdown,
        ] {
            assert_eq!(parse_function(&function_call(&f)), Ok(f));
        }
    }
}
