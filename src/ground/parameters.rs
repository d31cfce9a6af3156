//! The parameters of service 20 as data: their IDs, names, kinds, units, ranges,
//! whether 20,3 may set them, and the settable ones' defaults. A 20,2 report's source
//! data are N (u8), then N × (parameter ID u16, value in its `Kind`), big-endian.

use super::dictionary::{read_bits, value_f64, Kind};

/// A parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamDef {
    pub id: u16,
    pub name: &'static str,
    pub kind: Kind,
    pub unit: &'static str,
    /// Inclusive range of the values 20,3 may set (a non-finite f64 is out of range).
    pub range: Option<(f64, f64)>,
    /// Whether 20,3 may set it (else it fails with `read_only`).
    pub settable: bool,
    /// The value at start (settable parameters; the others are read from the set).
    pub default: Option<f64>,
    pub meaning: &'static str,
}

pub const PAR_HK1_INTERVAL_MS: u16 = 1;
pub const PAR_HK2_INTERVAL_MS: u16 = 2;
pub const PAR_START_MIN_DURATION_S: u16 = 3;
pub const PAR_START_MAX_DURATION_S: u16 = 4;
/// The epoch function 1 starts a campaign at [mission day].
pub const PAR_CAMPAIGN_EPOCH_DAY: u16 = 5;
/// The first table value: `table_beta_is1_x`; the 36 values run in the order β, σ(β), k,
/// σ(k), r, σ(r), each per IS and axis (is1_x … is2_z).
pub const PAR_TABLE_FIRST: u16 = 10;
/// The last table value: `table_r_sigma_is2_z`.
pub const PAR_TABLE_LAST: u16 = 45;
pub const PAR_TABLE_CAMPAIGN: u16 = 46;
pub const PAR_TABLE_VALID: u16 = 47;

/// The range of a housekeeping interval [ms].
pub const INTERVAL_RANGE_MS: (u32, u32) = (100, 3_600_000);
const INTERVAL: Option<(f64, f64)> = Some((INTERVAL_RANGE_MS.0 as f64, INTERVAL_RANGE_MS.1 as f64));
const DURATION: Option<(f64, f64)> = Some((1.0, 1e7));
/// The range of a campaign's epoch [days]: a mission's longest (`timeline.days`).
pub const EPOCH_RANGE_DAYS: (f64, f64) = (0.0, crate::sim::scenario::mission::MAX_MISSION_DAYS);

/// 36 table values: `table_<quantity>_is<i>_<axis>`, read-only.
macro_rules! table_values {
    ($( ($id0:expr, $q:literal, $unit:literal, $m:literal) ),*) => {
        [$( table_values!(@one $id0, $q, $unit, $m) ),*]
    };
    (@one $id0:expr, $q:literal, $unit:literal, $m:literal) => {
        [
            table_values!(@el $id0, 0, $q, "is1_x", $unit, $m),
            table_values!(@el $id0, 1, $q, "is1_y", $unit, $m),
            table_values!(@el $id0, 2, $q, "is1_z", $unit, $m),
            table_values!(@el $id0, 3, $q, "is2_x", $unit, $m),
            table_values!(@el $id0, 4, $q, "is2_y", $unit, $m),
            table_values!(@el $id0, 5, $q, "is2_z", $unit, $m),
        ]
    };
    (@el $id0:expr, $i:expr, $q:literal, $el:literal, $unit:literal, $m:literal) => {
        ParamDef {
            id: $id0 + $i,
            name: concat!("table_", $q, "_", $el),
            kind: Kind::F64,
            unit: $unit,
            range: None,
            settable: false,
            default: None,
            meaning: concat!("the onboard calibration table's ", $m, " (", $el, ") at the last apply's epoch"),
        }
    };
}

const TABLE: [[ParamDef; 6]; 6] = table_values!(
    (10, "beta", "rad s^-2 V^-1", "angular scale factor"),
    (
        16,
        "beta_sigma",
        "rad s^-2 V^-1",
        "angular scale factor's 1σ"
    ),
    (22, "k", "m s^-2 V^-1", "linear scale factor"),
    (28, "k_sigma", "m s^-2 V^-1", "linear scale factor's 1σ"),
    (34, "r", "m", "centre-of-mass offset, body frame"),
    (40, "r_sigma", "m", "centre-of-mass offset's 1σ")
);

const fn all() -> [ParamDef; 43] {
    let mut v = [ParamDef {
        id: PAR_HK1_INTERVAL_MS,
        name: "hk1_interval_ms",
        kind: Kind::U32,
        unit: "ms",
        range: INTERVAL,
        settable: true,
        default: Some(1000.0),
        meaning: "the interval of housekeeping structure 1's periodic reports",
    }; 43];
    v[1] = ParamDef {
        id: PAR_HK2_INTERVAL_MS,
        name: "hk2_interval_ms",
        default: Some(5000.0),
        meaning: "the interval of housekeeping structure 2's periodic reports",
        ..v[0]
    };
    v[2] = ParamDef {
        id: PAR_START_MIN_DURATION_S,
        name: "start_min_duration_s",
        kind: Kind::F64,
        unit: "s",
        range: DURATION,
        settable: true,
        default: Some(60.0),
        meaning:
            "the shortest duration function 1 may ask for (0, the scenario's, is always allowed)",
    };
    v[3] = ParamDef {
        id: PAR_START_MAX_DURATION_S,
        name: "start_max_duration_s",
        default: Some(1e6),
        meaning: "the longest duration function 1 may ask for",
        ..v[2]
    };
    v[4] = ParamDef {
        id: PAR_CAMPAIGN_EPOCH_DAY,
        name: "campaign_epoch_day",
        kind: Kind::F64,
        unit: "d",
        range: Some(EPOCH_RANGE_DAYS),
        settable: true,
        default: Some(0.0),
        meaning: "the mission day at which function 1 starts a campaign: its truths that day's (with the scenario's drift), its priors the onboard table's trends predicted for it",
    };
    let mut q = 0;
    while q < 6 {
        let mut e = 0;
        while e < 6 {
            v[5 + 6 * q + e] = TABLE[q][e];
            e += 1;
        }
        q += 1;
    }
    v[41] = ParamDef {
        id: PAR_TABLE_CAMPAIGN,
        name: "table_campaign",
        kind: Kind::U32,
        unit: "",
        range: None,
        settable: false,
        default: None,
        meaning: "the campaign whose result the onboard calibration table holds (0: none)",
    };
    v[42] = ParamDef {
        id: PAR_TABLE_VALID,
        name: "table_valid",
        kind: Kind::U8,
        meaning: "1 when the onboard calibration table holds values, else 0",
        ..v[41]
    };
    v
}

const ALL: [ParamDef; 43] = all();

/// Every parameter, by ID.
pub const PARAMETERS: &[ParamDef] = &ALL;

/// The parameter of `id`.
pub fn parameter(id: u16) -> Option<&'static ParamDef> {
    PARAMETERS.iter().find(|p| p.id == id)
}

/// Whether `bits` (wire bits of `def.kind`) is in `def`'s range (always, without one).
pub fn in_range(def: &ParamDef, bits: u64) -> bool {
    match def.range {
        Some((lo, hi)) => (lo..=hi).contains(&value_f64(def.kind, bits)),
        None => true,
    }
}

/// Why source data are not a parameter report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ParamReportError {
    #[error("a parameter report's data end inside its entry {at}")]
    Short { at: usize },
    #[error("parameter ID {0} is not in the dictionary")]
    Unknown(u16),
    #[error("{extra} bytes after the report's {n} entries")]
    Trailing { n: usize, extra: usize },
}

/// Reads a 20,2 report's source data: calls `each(parameter, wire bits)` in order.
pub fn decode_report(
    data: &[u8],
    mut each: impl FnMut(&'static ParamDef, u64),
) -> Result<(), ParamReportError> {
    let Some((&n, mut rest)) = data.split_first() else {
        return Err(ParamReportError::Short { at: 0 });
    };
    for at in 0..usize::from(n) {
        let Some(id) = rest.first_chunk::<2>() else {
            return Err(ParamReportError::Short { at });
        };
        let id = u16::from_be_bytes(*id);
        let def = parameter(id).ok_or(ParamReportError::Unknown(id))?;
        let size = def.kind.size();
        if rest.len() < 2 + size {
            return Err(ParamReportError::Short { at });
        }
        each(def, read_bits(def.kind, &rest[2..]));
        rest = &rest[2 + size..];
    }
    if rest.is_empty() {
        Ok(())
    } else {
        Err(ParamReportError::Trailing {
            n: n.into(),
            extra: rest.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_are_listed_once_in_order() {
        let ids: Vec<u16> = PARAMETERS.iter().map(|p| p.id).collect();
        let want: Vec<u16> = (1..=5).chain(10..=47).collect();
        assert_eq!(ids, want);
        let mut names: Vec<_> = PARAMETERS.iter().map(|p| p.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), PARAMETERS.len());
        assert_eq!(parameter(10).unwrap().name, "table_beta_is1_x");
        assert_eq!(parameter(16).unwrap().name, "table_beta_sigma_is1_x");
        assert_eq!(parameter(45).unwrap().name, "table_r_sigma_is2_z");
        assert_eq!(parameter(2).unwrap().default, Some(5000.0));
        assert_eq!(parameter(4).unwrap().default, Some(1e6));
        assert_eq!(parameter(47).unwrap().kind, Kind::U8);
        for p in PARAMETERS {
            assert_eq!(p.settable, p.default.is_some(), "{}", p.name);
            assert_eq!(p.settable, p.range.is_some(), "{}", p.name);
        }
        assert!(parameter(6).is_none() && parameter(48).is_none());
        let e = parameter(PAR_CAMPAIGN_EPOCH_DAY).unwrap();
        assert_eq!((e.name, e.default), ("campaign_epoch_day", Some(0.0)));
        assert!(in_range(e, 0f64.to_bits()) && in_range(e, 3650f64.to_bits()));
        for bad in [-1e-9, 3650.5, f64::NAN, f64::INFINITY] {
            assert!(!in_range(e, bad.to_bits()), "{bad}");
        }
    }

    #[test]
    fn ranges_are_checked_on_the_value() {
        let p = parameter(PAR_HK1_INTERVAL_MS).unwrap();
        assert!(in_range(p, 100) && in_range(p, 3_600_000));
        assert!(!in_range(p, 99) && !in_range(p, 3_600_001));
        let d = parameter(PAR_START_MIN_DURATION_S).unwrap();
        assert!(in_range(d, 1f64.to_bits()));
        for bad in [0.5, f64::NAN, f64::INFINITY, 1.1e7] {
            assert!(!in_range(d, bad.to_bits()), "{bad}");
        }
    }

    #[test]
    fn a_report_decodes_entry_by_entry() {
        let mut d = vec![2u8, 0, 1, 0, 0, 3, 0xE8, 0, 47, 1];
        let mut seen = vec![];
        decode_report(&d, |p, bits| seen.push((p.id, bits))).unwrap();
        assert_eq!(seen, [(1, 1000), (47, 1)]);
        d.push(0);
        assert_eq!(
            decode_report(&d, |_, _| {}),
            Err(ParamReportError::Trailing { n: 2, extra: 1 })
        );
        assert_eq!(
            decode_report(&d[..8], |_, _| {}),
            Err(ParamReportError::Short { at: 1 })
        );
        assert_eq!(
            decode_report(&[1, 0, 9], |_, _| {}),
            Err(ParamReportError::Unknown(9))
        );
        assert_eq!(
            decode_report(&[], |_, _| {}),
            Err(ParamReportError::Short { at: 0 })
        );
    }
}
