//! How the housekeeping structures' fields are laid out: a field is one value or one
//! per element of a family (IS and axis, residual group, stage process, latency
//! statistic, failure code), each element named by a suffix.

use super::dictionary::{Failure, Kind, N_FAILURES};
use crate::sim::msg::{GROUP_NAMES, N_GROUPS};

/// The stage processes structure 2 reports on.
pub const STAGES: usize = 5;
/// Their names, in order (`PROC_COMMANDER` … `PROC_RECORDER`).
pub const STAGE_NAMES: [&str; STAGES] = ["commander", "plant", "fee", "estimator", "recorder"];

/// How a field's elements are named.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Elements {
    /// One value.
    One,
    /// Per IS and axis: `is1_x` … `is2_z` (IS 1 first).
    IsAxis,
    /// Per residual group (`GROUP_NAMES`).
    Group,
    /// Per stage process (`STAGE_NAMES`: commander, plant, fee, estimator, recorder).
    Stage,
    /// Latency statistics: p50, p99, max.
    Percentile,
    /// Per failure code, in code order (`Failure::ALL`), by its name.
    FailureCode,
}

impl Elements {
    pub const fn count(self) -> usize {
        match self {
            Elements::One => 1,
            Elements::IsAxis => 6,
            Elements::Group => N_GROUPS,
            Elements::Stage => STAGES,
            Elements::Percentile => 3,
            Elements::FailureCode => N_FAILURES,
        }
    }

    /// The suffix of element `i` (empty for `One`).
    pub fn suffix(self, i: usize) -> String {
        match self {
            Elements::One => String::new(),
            Elements::IsAxis => format!("_is{}_{}", i / 3 + 1, ["x", "y", "z"][i % 3]),
            Elements::Group => format!("_{}", GROUP_NAMES[i]),
            Elements::Stage => format!("_{}", STAGE_NAMES[i]),
            Elements::Percentile => format!("_{}", ["p50", "p99", "max"][i]),
            Elements::FailureCode => format!("_{}", Failure::ALL[i].name()),
        }
    }
}

/// Bytes of a field of `kind` with `elements`.
pub const fn data_len_of(kind: Kind, elements: Elements) -> usize {
    kind.size() * elements.count()
}
