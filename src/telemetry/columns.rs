//! The datasets of `telemetry.h5` as the writer fills them: one column per dataset,
//! where its values come from in the messages, its rows written and buffered, and its
//! handle in the file (`write.rs` creates the datasets and streams the rows).

use super::layout as l;
use crate::sim::msg::{EstimateMsg, SensorSample, TruthState};

/// Element type of a dataset: little-endian IEEE double, unsigned 64- or 8-bit integer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    F64,
    U64,
    U8,
}

/// Where a column's values come from.
#[derive(Debug, Clone, Copy)]
pub(super) enum Src {
    Time,
    Tick,
    TorqueCmd,
    Torque,
    Attitude,
    Omega,
    OmegaDot,
    TmAcc,
    SrpAcc,
    StarQ,
    StarValid,
    Volts(usize),
    Flags(usize),
    EstTime,
    EstTick,
    Beta,
    BetaSigma,
    K,
    KSigma,
    R,
    RSigma,
    NUsed,
    NRejected,
    Final,
    Status,
    ByCause,
    Chi2,
}

/// Rows not yet written, in the dataset's element type.
pub(super) enum Buf {
    F64(Vec<f64>),
    U64(Vec<u64>),
    U8(Vec<u8>),
}

impl Buf {
    fn len(&self) -> usize {
        match self {
            Buf::F64(v) => v.len(),
            Buf::U64(v) => v.len(),
            Buf::U8(v) => v.len(),
        }
    }

    pub(super) fn clear(&mut self) {
        match self {
            Buf::F64(v) => v.clear(),
            Buf::U64(v) => v.clear(),
            Buf::U8(v) => v.clear(),
        }
    }
}

/// One dataset: its rows in the file and its buffered ones.
pub(super) struct Column {
    pub(super) path: &'static str,
    pub(super) kind: Kind,
    pub(super) src: Src,
    /// Dimensions after the first.
    pub(super) row_shape: Vec<usize>,
    /// Elements per row.
    pub(super) row_len: usize,
    /// Rows in the file.
    pub(super) rows: u64,
    /// Rows not yet written.
    pub(super) buf: Buf,
    /// The dataset, once the file has it.
    pub(super) ds: Option<hdf5::Dataset>,
}

impl Column {
    pub(super) fn new(path: &'static str, kind: Kind, src: Src, row_shape: &[usize]) -> Self {
        Column {
            path,
            kind,
            src,
            row_len: row_shape.iter().product(),
            row_shape: row_shape.to_vec(),
            rows: 0,
            buf: match kind {
                Kind::F64 => Buf::F64(Vec::new()),
                Kind::U64 => Buf::U64(Vec::new()),
                Kind::U8 => Buf::U8(Vec::new()),
            },
            ds: None,
        }
    }

    /// Do the column's values repeat or step rather than carry noise? Integers, times,
    /// the commanded torque and the estimates do: deflate shrinks them 30–100×, while
    /// the sensor and truth floats keep 70–90 % of their size (docs/telemetry.md).
    pub(super) fn steps(&self) -> bool {
        self.kind != Kind::F64
            || matches!(self.src, Src::Time | Src::TorqueCmd)
            || self.path.starts_with("estimate/")
    }

    /// Buffered rows.
    pub(super) fn pending(&self) -> u64 {
        (self.buf.len() / self.row_len.max(1)) as u64
    }

    /// Room for `rows` buffered rows, so that recording does not allocate per row.
    pub(super) fn reserve(&mut self, rows: usize) {
        let n = rows * self.row_len;
        match &mut self.buf {
            Buf::F64(v) => v.reserve(n),
            Buf::U64(v) => v.reserve(n),
            Buf::U8(v) => v.reserve(n),
        }
    }

    pub(super) fn f64s(&mut self, v: &[f64]) {
        if let Buf::F64(b) = &mut self.buf {
            b.extend_from_slice(v);
        }
    }

    pub(super) fn u64s(&mut self, v: &[u64]) {
        if let Buf::U64(b) = &mut self.buf {
            b.extend_from_slice(v);
        }
    }

    fn byte(&mut self, x: u8) {
        if let Buf::U8(b) = &mut self.buf {
            b.push(x);
        }
    }

    pub(super) fn put_sample(&mut self, t: &TruthState, s: &SensorSample, fs: f64, ni: usize) {
        match self.src {
            Src::Time => self.f64s(&[(t.header.tick + 1) as f64 / fs]),
            Src::Tick => self.u64s(&[t.header.tick]),
            Src::TorqueCmd => self.f64s(&t.torque_cmd_b),
            Src::Torque => self.f64s(&t.torque_b),
            Src::Attitude => self.f64s(&t.q_bn),
            Src::Omega => self.f64s(&t.omega_b),
            Src::OmegaDot => self.f64s(&t.omega_dot_b),
            Src::TmAcc => {
                for a in &t.a_tm_b[..ni] {
                    self.f64s(a);
                }
            }
            Src::SrpAcc => self.f64s(&t.a_srp_b),
            Src::StarQ => self.f64s(&s.star.q_bn),
            Src::StarValid => self.byte(s.star.valid),
            Src::Volts(i) => {
                for v in &s.is[i].volts {
                    self.f64s(v);
                }
            }
            Src::Flags(i) => self.byte(s.is[i].flags),
            _ => unreachable!("{} is not a sample column", self.path),
        }
    }

    pub(super) fn put_estimate(&mut self, e: &EstimateMsg, fs: f64, ni: usize) {
        let per_is = |c: &mut Self, v: &[[f64; 3]; 2]| {
            for x in &v[..ni] {
                c.f64s(x);
            }
        };
        match self.src {
            Src::EstTime => self.f64s(&[(e.header.tick + 1) as f64 / fs]),
            Src::EstTick => self.u64s(&[e.solved_tick]),
            Src::Beta => per_is(self, &e.beta),
            Src::BetaSigma => per_is(self, &e.beta_sigma),
            Src::K => per_is(self, &e.k),
            Src::KSigma => per_is(self, &e.k_sigma),
            Src::R => per_is(self, &e.r_b),
            Src::RSigma => per_is(self, &e.r_sigma),
            Src::NUsed => self.u64s(&[e.n_used]),
            Src::NRejected => self.u64s(&[e.n_rejected]),
            Src::Final => self.byte(u8::from(e.flags & crate::sim::msg::EST_FINAL != 0)),
            Src::Status => self.u64s(&[e.status]),
            Src::ByCause => self.u64s(&e.rejected_by_cause),
            Src::Chi2 => self.f64s(&e.chi2_per_dof),
            _ => unreachable!("{} is not an estimate column", self.path),
        }
    }
}

pub(super) fn sample_columns(ni: usize) -> Vec<Column> {
    use Kind::*;
    let mut c = vec![
        Column::new(l::TIME, F64, Src::Time, &[]),
        Column::new(l::TICK, U64, Src::Tick, &[]),
        Column::new(l::TORQUE_CMD, F64, Src::TorqueCmd, &[3]),
        Column::new(l::TORQUE, F64, Src::Torque, &[3]),
        Column::new(l::ATTITUDE, F64, Src::Attitude, &[4]),
        Column::new(l::OMEGA, F64, Src::Omega, &[3]),
        Column::new(l::OMEGA_DOT, F64, Src::OmegaDot, &[3]),
        Column::new(l::TM_ACC, F64, Src::TmAcc, &[ni, 3]),
        Column::new(l::SRP_ACC, F64, Src::SrpAcc, &[3]),
        Column::new(l::STAR_Q, F64, Src::StarQ, &[4]),
        Column::new(l::STAR_VALID, U8, Src::StarValid, &[]),
    ];
    for i in 0..ni {
        c.push(Column::new(l::IS_VOLTAGE[i], F64, Src::Volts(i), &[3, 2]));
        c.push(Column::new(l::IS_FLAGS[i], U8, Src::Flags(i), &[]));
    }
    c
}

pub(super) fn estimate_columns(ni: usize) -> Vec<Column> {
    use Kind::*;
    vec![
        Column::new(l::EST_TIME, F64, Src::EstTime, &[]),
        Column::new(l::EST_TICK, U64, Src::EstTick, &[]),
        Column::new(l::EST_BETA, F64, Src::Beta, &[ni, 3]),
        Column::new(l::EST_BETA_SIGMA, F64, Src::BetaSigma, &[ni, 3]),
        Column::new(l::EST_K, F64, Src::K, &[ni, 3]),
        Column::new(l::EST_K_SIGMA, F64, Src::KSigma, &[ni, 3]),
        Column::new(l::EST_R, F64, Src::R, &[ni, 3]),
        Column::new(l::EST_R_SIGMA, F64, Src::RSigma, &[ni, 3]),
        Column::new(l::EST_N_USED, U64, Src::NUsed, &[]),
        Column::new(l::EST_N_REJECTED, U64, Src::NRejected, &[]),
        Column::new(l::EST_FINAL, U8, Src::Final, &[]),
        Column::new(l::EST_STATUS, U64, Src::Status, &[]),
        Column::new(
            l::EST_REJECTED_BY_CAUSE,
            U64,
            Src::ByCause,
            &[crate::sim::msg::N_CAUSES],
        ),
        Column::new(l::EST_CHI2, F64, Src::Chi2, &[crate::sim::msg::N_GROUPS]),
    ]
}
