//! The scenario's `[faults]` section: which faults to inject, and at what rates. The
//! injector that applies them is `crate::sim::faults`.

use serde::{Deserialize, Serialize};

/// The `[faults]` section; every rate and count defaults to 0 (no faults).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FaultsConfig {
    /// Probability per sample of one single-event upset: one random bit of one random
    /// field (an IS voltage or flag byte, a star-tracker quaternion component or its
    /// validity byte).
    pub upset_rate: f64,
    /// Samples with one IS voltage replaced by ±`outlier_volts`.
    pub outliers: u32,
    pub outlier_volts: f64,
    /// IS voltage channels that hold their value for `stuck_duration_s`.
    pub stuck_channels: u32,
    pub stuck_duration_s: f64,
    /// Star-tracker attitude jumps: this many, each rotating `star_jump_samples`
    /// consecutive star-tracker samples by `star_jump_rad` about a random axis.
    pub star_jumps: u32,
    pub star_jump_rad: f64,
    pub star_jump_samples: u32,
    /// Probability per sample that an IS delivers nothing (flagged dropout, NaN volts).
    pub is_dropout_rate: f64,
    /// Probability per star-tracker sample that it is missing (invalid).
    pub star_dropout_rate: f64,
    /// Bus faults between front-end and estimator, probability per tick: the sample
    /// sent twice; sent after the next one (odd ticks); not sent at all.
    pub duplicate_rate: f64,
    pub reorder_rate: f64,
    pub missing_rate: f64,
    /// Messages with a garbage header (random bytes) sent before a tick's sample.
    pub garbage_headers: u32,
}

impl Default for FaultsConfig {
    fn default() -> Self {
        FaultsConfig {
            upset_rate: 0.0,
            outliers: 0,
            outlier_volts: 1e6,
            stuck_channels: 0,
            stuck_duration_s: 300.0,
            star_jumps: 0,
            star_jump_rad: 1e-3,
            star_jump_samples: 1,
            is_dropout_rate: 0.0,
            star_dropout_rate: 0.0,
            duplicate_rate: 0.0,
            reorder_rate: 0.0,
            missing_rate: 0.0,
            garbage_headers: 0,
        }
    }
}

/// Most scheduled events of each counted kind (fixed memory).
pub const MAX_EVENTS: usize = 256;

impl FaultsConfig {
    /// Any fault at all?
    pub fn any(&self) -> bool {
        self.upset_rate > 0.0
            || self.outliers > 0
            || self.stuck_channels > 0
            || self.star_jumps > 0
            || self.is_dropout_rate > 0.0
            || self.star_dropout_rate > 0.0
            || self.bus_any()
    }

    /// Does the campaign lose data (dropouts, ticks the bus never delivers)? Its
    /// Cramér–Rao bound is then that of the data a run keeps (`crlb`).
    pub fn loses_data(&self) -> bool {
        self.is_dropout_rate > 0.0 || self.star_dropout_rate > 0.0 || self.missing_rate > 0.0
    }

    /// Any bus fault?
    pub fn bus_any(&self) -> bool {
        self.duplicate_rate > 0.0
            || self.reorder_rate > 0.0
            || self.missing_rate > 0.0
            || self.garbage_headers > 0
    }

    /// Check every key; the error names it.
    pub fn validate(&self) -> Result<(), super::ScenarioError> {
        let e = |k: &str, m: &str| Err(super::ScenarioError::key(format!("faults.{k}"), m));
        for (k, v) in [
            ("upset_rate", self.upset_rate),
            ("is_dropout_rate", self.is_dropout_rate),
            ("star_dropout_rate", self.star_dropout_rate),
            ("duplicate_rate", self.duplicate_rate),
            ("reorder_rate", self.reorder_rate),
            ("missing_rate", self.missing_rate),
        ] {
            if !(0.0..=0.5).contains(&v) {
                return e(k, &format!("must be a probability in [0, 0.5], got {v}"));
            }
        }
        for (k, v) in [
            ("outliers", self.outliers),
            ("stuck_channels", self.stuck_channels),
            ("star_jumps", self.star_jumps),
            ("garbage_headers", self.garbage_headers),
        ] {
            if v as usize > MAX_EVENTS {
                return e(k, &format!("at most {MAX_EVENTS}, got {v}"));
            }
        }
        if !self.outlier_volts.is_finite() {
            return e("outlier_volts", "must be finite");
        }
        if !(self.stuck_duration_s.is_finite() && self.stuck_duration_s > 0.0) {
            return e("stuck_duration_s", "must be > 0");
        }
        if !(self.star_jump_rad.is_finite() && self.star_jump_rad.abs() < 1.0) {
            return e("star_jump_rad", "must be finite and below 1 rad");
        }
        if self.star_jump_samples == 0 || self.star_jump_samples > 1000 {
            return e("star_jump_samples", "must be 1 to 1000");
        }
        Ok(())
    }
}
