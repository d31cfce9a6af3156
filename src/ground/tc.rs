//! The telecommands the ground tools send, built from what an operator types: each
//! request's service, subtype and application data (before the authentication
//! trailer), with parameters and events named by ID or by name, values read in the
//! parameter's kind, and what reply ends the exchange.

use super::dictionary::{Function, Kind};
use super::events::EVENTS;
use super::housekeeping::{structure_name, STRUCTURES};
use super::parameters::{ParamDef, PARAMETERS};
use super::requests::{function_call, id_list, interval_list, value_list};

/// Why an operator's request cannot be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TcError {
    #[error("no parameter {0:?} in the dictionary (`taiji-calib ground dictionary` lists them)")]
    UnknownParameter(String),
    #[error("no event {0:?} in the dictionary (`taiji-calib ground dictionary` lists them)")]
    UnknownEvent(String),
    #[error("{0:?} is no housekeeping structure (1 or estimate, 2 or health)")]
    BadStructure(String),
    #[error("{0:?}: expected NAME_OR_ID=VALUE")]
    NotAnAssignment(String),
    #[error("{name}: {value:?} is not a {kind} value")]
    BadValue {
        name: String,
        value: String,
        kind: &'static str,
    },
    #[error("{0} items in one telecommand, at most 255")]
    TooMany(usize),
    #[error("nothing to send: give at least one ID")]
    Empty,
}

/// A request an operator makes of the set.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// 17,1.
    Ping,
    /// 8,1.
    Function(Function),
    /// 3,5.
    HkEnable(Vec<u16>),
    /// 3,6.
    HkDisable(Vec<u16>),
    /// 3,31: (structure, interval in ms).
    HkInterval(Vec<(u16, u32)>),
    /// 3,27.
    HkNow(Vec<u16>),
    /// 5,5.
    EventEnable(Vec<u16>),
    /// 5,6.
    EventDisable(Vec<u16>),
    /// 20,1.
    Get(Vec<u16>),
    /// 20,3: (parameter, wire bits in its kind).
    Set(Vec<(&'static ParamDef, u64)>),
}

/// The report, besides verification, that answers a request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    None,
    /// 17,2.
    Pong,
    /// 20,2.
    Parameters,
    /// 3,25 of each of these structures.
    Housekeeping(Vec<u16>),
}

fn at_most_255<T>(v: Option<T>, n: usize) -> Result<T, TcError> {
    v.ok_or(TcError::TooMany(n))
}

impl Request {
    /// The service and subtype.
    pub fn service(&self) -> (u8, u8) {
        match self {
            Request::Ping => (17, 1),
            Request::Function(_) => (8, 1),
            Request::HkEnable(_) => (3, 5),
            Request::HkDisable(_) => (3, 6),
            Request::HkInterval(_) => (3, 31),
            Request::HkNow(_) => (3, 27),
            Request::EventEnable(_) => (5, 5),
            Request::EventDisable(_) => (5, 6),
            Request::Get(_) => (20, 1),
            Request::Set(_) => (20, 3),
        }
    }

    /// The application data, before the trailer.
    pub fn app_data(&self) -> Result<Vec<u8>, TcError> {
        match self {
            Request::Ping => Ok(Vec::new()),
            Request::Function(f) => Ok(function_call(f)),
            Request::HkEnable(ids)
            | Request::HkDisable(ids)
            | Request::HkNow(ids)
            | Request::EventEnable(ids)
            | Request::EventDisable(ids)
            | Request::Get(ids) => at_most_255(id_list(ids), ids.len()),
            Request::HkInterval(pairs) => at_most_255(interval_list(pairs), pairs.len()),
            Request::Set(values) => {
                let entries: Vec<(u16, u64)> = values.iter().map(|(p, b)| (p.id, *b)).collect();
                at_most_255(value_list(&entries), entries.len())
            }
        }
    }

    /// The report that answers it besides verification.
    pub fn reply(&self) -> Reply {
        match self {
            Request::Ping => Reply::Pong,
            Request::Get(_) => Reply::Parameters,
            Request::HkNow(ids) => Reply::Housekeeping(ids.clone()),
            _ => Reply::None,
        }
    }
}

/// The parameter named `s`, or of ID `s`.
pub fn parameter(s: &str) -> Result<&'static ParamDef, TcError> {
    let found = match s.parse::<u16>() {
        Ok(id) => PARAMETERS.iter().find(|p| p.id == id),
        Err(_) => PARAMETERS.iter().find(|p| p.name == s),
    };
    found.ok_or_else(|| TcError::UnknownParameter(s.to_string()))
}

/// Parameter IDs from names or IDs; every parameter when `list` is empty.
pub fn parameter_ids(list: &[String]) -> Result<Vec<u16>, TcError> {
    if list.is_empty() {
        return Ok(PARAMETERS.iter().map(|p| p.id).collect());
    }
    list.iter().map(|s| parameter(s).map(|p| p.id)).collect()
}

/// Event IDs from names or IDs.
pub fn event_ids(list: &[String]) -> Result<Vec<u16>, TcError> {
    if list.is_empty() {
        return Err(TcError::Empty);
    }
    list.iter()
        .map(|s| {
            let found = match s.parse::<u16>() {
                Ok(id) => EVENTS.iter().find(|e| e.id == id),
                Err(_) => EVENTS.iter().find(|e| e.name == s),
            };
            found
                .map(|e| e.id)
                .ok_or_else(|| TcError::UnknownEvent(s.clone()))
        })
        .collect()
}

/// Structure IDs from IDs (an unknown one the set answers with `unknown_structure`)
/// or names (`estimate`, `health`).
pub fn structure_ids(list: &[String]) -> Result<Vec<u16>, TcError> {
    if list.is_empty() {
        return Err(TcError::Empty);
    }
    list.iter()
        .map(|s| match s.parse() {
            Ok(id) => Ok(id),
            Err(_) => STRUCTURES
                .into_iter()
                .find(|&id| structure_name(id) == Some(s.as_str()))
                .ok_or_else(|| TcError::BadStructure(s.clone())),
        })
        .collect()
}

/// A value typed for `kind`, as wire bits: integers in decimal (or 0x hexadecimal),
/// binary64 as any Rust float literal. The set checks the range.
pub fn value_bits(name: &str, kind: Kind, text: &str) -> Result<u64, TcError> {
    let bad = || TcError::BadValue {
        name: name.to_string(),
        value: text.to_string(),
        kind: kind.name(),
    };
    let t = text.trim();
    if kind == Kind::F64 {
        return t.parse::<f64>().map(f64::to_bits).map_err(|_| bad());
    }
    let v = match t.strip_prefix("0x") {
        Some(h) => u64::from_str_radix(h, 16),
        None => t.parse::<u64>(),
    }
    .map_err(|_| bad())?;
    let max = if kind.size() == 8 {
        u64::MAX
    } else {
        (1u64 << (8 * kind.size())) - 1
    };
    if v > max {
        return Err(bad());
    }
    Ok(v)
}

/// `NAME_OR_ID=VALUE` assignments as 20,3's entries.
pub fn assignments(list: &[String]) -> Result<Vec<(&'static ParamDef, u64)>, TcError> {
    if list.is_empty() {
        return Err(TcError::Empty);
    }
    list.iter()
        .map(|a| {
            let (k, v) = a
                .split_once('=')
                .ok_or_else(|| TcError::NotAnAssignment(a.clone()))?;
            let p = parameter(k.trim())?;
            Ok((p, value_bits(p.name, p.kind, v)?))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_carry_the_wire_formats() {
        assert_eq!(Request::Ping.app_data().unwrap(), Vec::<u8>::new());
        let start = Request::Function(Function::Start {
            seed: 42,
            duration_s: 600.5,
        });
        let mut want = vec![0, 1];
        want.extend_from_slice(&42u64.to_be_bytes());
        want.extend_from_slice(&600.5f64.to_be_bytes());
        assert_eq!(start.app_data().unwrap(), want);
        assert_eq!(
            crate::ground::dictionary::parse_function(&want),
            Ok(crate::ground::dictionary::Function::Start {
                seed: 42,
                duration_s: 600.5
            })
        );
        assert_eq!(
            Request::HkNow(vec![1, 2]).app_data().unwrap(),
            [2, 0, 1, 0, 2]
        );
        assert_eq!(
            Request::HkInterval(vec![(2, 250)]).app_data().unwrap(),
            [1, 0, 2, 0, 0, 0, 250]
        );
        let set =
            Request::Set(assignments(&["hk1_interval_ms=500".into(), "3=2.5".into()]).unwrap());
        let mut want = vec![2, 0, 1, 0, 0, 1, 0xF4, 0, 3];
        want.extend_from_slice(&2.5f64.to_be_bytes());
        assert_eq!(set.app_data().unwrap(), want);
        assert_eq!(set.service(), (20, 3));
        assert!(matches!(
            Request::Get((0..256).collect()).app_data(),
            Err(TcError::TooMany(256))
        ));
    }

    #[test]
    fn names_and_values_are_checked_before_sending() {
        assert_eq!(parameter("1").unwrap().name, "hk1_interval_ms");
        assert_eq!(parameter("table_valid").unwrap().id, 47);
        assert!(matches!(
            parameter("nope"),
            Err(TcError::UnknownParameter(_))
        ));
        assert_eq!(parameter_ids(&[]).unwrap().len(), PARAMETERS.len());
        assert_eq!(
            event_ids(&["mode_changed".into(), "8".into()]).unwrap(),
            [1, 8]
        );
        assert!(matches!(
            event_ids(&["99".into()]),
            Err(TcError::UnknownEvent(_))
        ));
        assert!(matches!(
            structure_ids(&["x".into()]),
            Err(TcError::BadStructure(_))
        ));
        assert_eq!(
            structure_ids(&["health".into(), "1".into(), "9".into()]).unwrap(),
            [2, 1, 9]
        );
        assert_eq!(value_bits("p", Kind::U8, "0xff"), Ok(255));
        assert!(value_bits("p", Kind::U8, "256").is_err());
        assert!(value_bits("p", Kind::U32, "-1").is_err());
        assert_eq!(value_bits("p", Kind::F64, "1e3"), Ok(1000f64.to_bits()));
        assert!(matches!(
            assignments(&["hk1_interval_ms".into()]),
            Err(TcError::NotAnAssignment(_))
        ));
        assert!(matches!(
            assignments(&["hk1_interval_ms=fast".into()]),
            Err(TcError::BadValue { .. })
        ));
    }
}
