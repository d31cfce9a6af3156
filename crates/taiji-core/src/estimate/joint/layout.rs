//! The joint estimator's layout: which data signal and which parameter sits at which
//! index of the fixed-size vectors and Gram matrices.

use super::*;

/// Signals of the linear group.
pub const NS: usize = 38;
/// Parameters.
pub const NP: usize = 30;
/// Noise regimes of the linear channels (by the dominant rotation axis).
pub(super) const N_REG: usize = 3;

pub(super) const S_SUM: usize = 0; // + 3 i + j : ΣV_ij − reference [V]
pub(super) const S_DV: usize = 6; // + 3 l + a : ΔV_la [V]
pub(super) const S_PHI: usize = 12; // + a : Φ1_a interval mean [V s²]
pub(super) const S_PP: usize = 15; // + prod(a, b) : Ψ1_a Ψ1_b [V² s²]
pub(super) const S_ONE: usize = 21;
pub(super) const S_T: usize = 22;
/// W_jm at `S_W + 3 j + m` = (R̂ᵀ − I + [Φ̂]×)_jm [rad]: the SRP's turn beyond first
/// order in the propagated angle, exact in the attitude (R̂ propagated with the running
/// β̂ and pulled onto the star tracker after data gaps).
pub(super) const S_W: usize = 23;
/// (θ̂ × a_ε)_j at `S_TF + j` [m/s²]: the SRP's change since the reference sample,
/// a_ε,m = k̂_1m ε_m with ε_m = ΣV_1m − ΣV_1m,ref − (A r̂)_m/k̂_m + (θ̂ × b̂)_m/k̂_m (IS1's
/// channel m with the maneuver's acceleration and the SRP's turn at the running
/// solution taken out: the inertial SRP's fluctuation and its DC against the
/// reference sample), turned by the running attitude θ̂ = β̂1 Φ1. That change is
/// small (the fluctuation, ~10⁻¹² m/s², and what the reference sample's own A r left,
/// ≲10⁻⁹) and turned by ≲10⁻³ rad, so the running β̂, k̂ in it err by ≲10⁻¹⁷ m/s².
pub(super) const S_TF: usize = 32;
/// Φ1_a at `S_PHI0 + a` before the SRP's level is fixed, 0 after [V s²]: those
/// samples turn the fitted DC, not the level.
pub(super) const S_PHI0: usize = 35;

pub const P_BETA: usize = 0; // + 3 i + a
pub const P_R: usize = 6; // + 3 i + a
pub(super) const P_TH0: usize = 12;
pub(super) const P_THD: usize = 15;
pub(super) const P_B: usize = 18; // + 3 i + j
pub(super) const P_AL: usize = 24; // + 3 i + j

pub(super) type Sig = SVector<f64, NS>;
pub(super) type Par = SVector<f64, NP>;
pub(super) type Gram = SMatrix<f64, NS, NS>;

/// Elements of a symmetric NS × NS matrix's upper triangle.
pub(super) const NS_PACKED: usize = NS * (NS + 1) / 2;

/// A Gram matrix of the state: its upper triangle alone, column by column ((i, j),
/// i ≤ j, at j (j + 1)/2 + i), half the bytes of the full matrix (and of the seal's
/// passes over it), with the same numbers in the same columns as the full matrix's
/// upper triangle, so every sum takes the same operations in the same order.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub(super) struct Packed(#[serde(with = "super::array_serde")] [f64; NS_PACKED]);

impl Packed {
    /// Column j's part above and on the diagonal: rows 0..=j.
    pub(super) fn column_mut(&mut self, j: usize) -> &mut [f64] {
        let start = j * (j + 1) / 2;
        let end = (start + j + 1).min(NS_PACKED);
        &mut self.0[start.min(end)..end]
    }

    /// Element (i, j) of the symmetric matrix.
    pub(super) fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = (i.min(j), i.max(j));
        self.0[(j * (j + 1) / 2 + i).min(NS_PACKED - 1)]
    }
}

pub(super) fn prod(a: usize, b: usize) -> usize {
    match (a.min(b), a.max(b)) {
        (0, 0) => 0,
        (1, 1) => 1,
        (2, 2) => 2,
        (0, 1) => 3,
        (0, 2) => 4,
        _ => 5,
    }
}

/// k index permutation of eq. 2: k_j = G_{PERM[j]} β_{PERM[j]}.
pub(super) const PERM: [usize; 3] = [2, 0, 1];
