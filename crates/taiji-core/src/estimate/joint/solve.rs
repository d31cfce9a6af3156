//! The solve: Gauss–Newton normal equations from the Gram statistics, the step, the
//! covariance, χ²/dof per group and the status word.

use super::*;

/// The Gauss–Newton sums a residual group adds to: H and g. (Each group's χ² is
/// `group_costs`'s.)
pub(super) struct Sums<'a> {
    pub(super) hm: &'a mut SMatrix<f64, NP, NP>,
    pub(super) g: &'a mut Par,
}

/// Gauss–Newton normal equations at a parameter vector: H (priors as asked) and g.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(super) struct Normal {
    pub(super) hm: SMatrix<f64, NP, NP>,
    pub(super) g: Par,
}

/// One residual group's products (`add_group`): its Jacobian rows, their transposes,
/// and a 30 × 30 product.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(super) struct GroupScratch {
    d: SMatrix<f64, NS, NP>,
    md: SMatrix<f64, NS, NP>,
    t: SMatrix<f64, NP, NS>,
    prod: SMatrix<f64, NP, NP>,
    v: Par,
}

/// Scratch memory of a solve and of `finish` (about 110 kB): the Jacobian of every
/// coefficient by each parameter, the normal equations, H⁻¹ and the products of one
/// residual group. Nothing in it outlives a call, so it is neither sealed nor
/// checkpointed: the C ABI takes it from the caller beside the state, and the solve's
/// stack holds no matrix larger than one 30 × 30 (the Cholesky factor).
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct SolveWork {
    /// The coefficients at the solution and at ± a step of one parameter.
    pub(super) c0: Coeffs,
    pub(super) cp: Coeffs,
    pub(super) cm: Coeffs,
    pub(super) dc: [Coeffs; NP],
    pub(super) n: Normal,
    pub(super) hinv: SMatrix<f64, NP, NP>,
    pub(super) hs: SMatrix<f64, NP, NP>,
    pub(super) gram: Gram,
    pub(super) group: GroupScratch,
}

impl SolveWork {
    /// Zeroed scratch (its contents never matter between calls).
    pub fn zeroed() -> Self {
        <Self as bytemuck::Zeroable>::zeroed()
    }
}

impl JointEstimator {
    /// One residual group's row: its Gauss–Newton terms into (H, g).
    /// Where the CPU has AVX2 its matrix products (most of a solve's ~10⁶
    /// multiply-adds) run compiled for it, like [`Self::update_linear`]: the same bits.
    #[inline(always)]
    pub(super) fn add_group(
        row: &SVector<f64, 6>,
        m: &Gram,
        weight: f64,
        lin: &Linearised,
        out: &mut Sums,
        sc: &mut GroupScratch,
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::has_avx2() {
            // SAFETY: the CPU has AVX2, checked just now.
            unsafe { Self::add_group_avx2(row, m, weight, lin, out, sc) };
            return;
        }
        Self::add_group_portable(row, m, weight, lin, out, sc);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    /// # Safety
    /// The CPU must support AVX2 (`simd::has_avx2`).
    pub(super) unsafe fn add_group_avx2(
        row: &SVector<f64, 6>,
        m: &Gram,
        weight: f64,
        lin: &Linearised,
        out: &mut Sums,
        sc: &mut GroupScratch,
    ) {
        Self::add_group_portable(row, m, weight, lin, out, sc);
    }

    /// The products go through `sc` (`mul_to`, the same gemm as `*`: the same bits),
    /// so no 30 × 35 matrix is a temporary on the stack.
    #[inline(always)]
    pub(super) fn add_group_portable(
        row: &SVector<f64, 6>,
        m: &Gram,
        weight: f64,
        lin: &Linearised,
        out: &mut Sums,
        sc: &mut GroupScratch,
    ) {
        let (c0, dc) = (lin.c0, lin.dc);
        let c: Sig = c0.lin.transpose() * row;
        if c.iter().all(|v| *v == 0.0) {
            return;
        }
        for k in 0..NP {
            for s in 0..NS {
                sc.d[(s, k)] = (0..6).map(|r| row[r] * dc[k].lin[(r, s)]).sum();
            }
        }
        // H += dᵀ (m d) w; g += (m d)ᵀ c w.
        mul_into(m, &sc.d, &mut sc.md);
        sc.d.transpose_to(&mut sc.t);
        mul_into(&sc.t, &sc.md, &mut sc.prod);
        for (h, x) in out.hm.iter_mut().zip(sc.prod.iter()) {
            *h += x * weight;
        }
        sc.md.transpose_to(&mut sc.t);
        mul_into(&sc.t, &c, &mut sc.v);
        for (g, x) in out.g.iter_mut().zip(sc.v.iter()) {
            *g += x * weight;
        }
    }

    /// Gauss–Newton normal equations (H, g) at `p`; with `priors`, the weak ground priors are
    /// included (they only matter before every axis has been excited). Each group
    /// enters with its weight (1, or 1/(χ²/dof) when its noise proved larger than
    /// modelled).
    pub(super) fn normal_equations(&self, p: &Par, priors: bool, w: &mut SolveWork) {
        debug_assert!(
            self.grams_flushed(),
            "the Grams are read with samples waiting"
        );
        let SolveWork {
            c0,
            cp,
            cm,
            dc,
            n,
            gram,
            group,
            ..
        } = w;
        *c0 = self.coeffs(p);
        self.jacobian(p, dc, [cp, cm]);
        let c0 = &*c0;
        n.hm = SMatrix::zeros();
        n.g = Par::zeros();
        let Normal { hm, g } = n;
        if priors {
            for k in 0..NP {
                let w = 1.0 / self.p_sigma[k].powi(2);
                hm[(k, k)] += w;
                g[k] += w * (p[k] - self.p_prior[k]);
            }
        } else {
            // Parameters of an absent IS are not part of the problem.
            for k in 0..NP {
                if !self.param_used(k) {
                    hm[(k, k)] += 1.0 / self.p_sigma[k].powi(2);
                }
            }
        }
        let gw = self.group_weight;
        let lin = Linearised { c0, dc };
        let mut out = Sums { hm, g };
        let h = self.srp_direction(p);
        for reg in 0..N_REG {
            let Some(rows) = self.regime_rows(p, reg, &h, gram) else {
                continue;
            };
            for t in 0..3 {
                let row = rows.row(t).transpose();
                Self::add_group(&row, gram, gw[GROUP_LINEAR], &lin, &mut out, group);
            }
        }
        if let Some(rows) = self.turn_rows(p) {
            for t in 0..2 {
                symmetric_into(&self.m_turn[t], gram);
                let row = rows.row(t).transpose();
                Self::add_group(&row, gram, gw[GROUP_LINEAR], &lin, &mut out, group);
            }
        }
        symmetric_into(&self.m_filt, gram);
        Self::add_group(
            &self.t_u,
            gram,
            gw[GROUP_COMMON_MODE],
            &lin,
            &mut out,
            group,
        );
        let Sums { hm, g, .. } = out;
        self.add_star_and_angular(c0, dc, hm, g, &mut group.prod);
    }

    /// The Jacobian of every coefficient by each parameter (central differences) into
    /// `dc`. Out of line, as the other parts of
    /// the normal equations: their frames then never add up on the solve's stack.
    #[inline(never)]
    fn jacobian(&self, p: &Par, dc: &mut [Coeffs; NP], [cp, cm]: [&mut Coeffs; 2]) {
        for (k, d) in dc.iter_mut().enumerate() {
            let hk = 1e-6 * self.p_sigma[k];
            let mut pp = *p;
            pp[k] += hk;
            *cp = self.coeffs(&pp);
            pp[k] -= 2.0 * hk;
            *cm = self.coeffs(&pp);
            let f = 0.5 / hk;
            // (cp − cm) f, element by element, as the matrix expression computes it.
            for ((x, a), b) in d.lin.iter_mut().zip(cp.lin.iter()).zip(cm.lin.iter()) {
                *x = (a - b) * f;
            }
            for a in 0..3 {
                d.star[a] = (cp.star[a] - cm.star[a]) * f;
                d.ang[a] = (cp.ang[a] - cm.ang[a]) * f;
            }
        }
    }

    /// The star-tracker and angular-consistency groups' terms into (H, g).
    #[inline(never)]
    fn add_star_and_angular(
        &self,
        c0: &Coeffs,
        dc: &[Coeffs; NP],
        hm: &mut SMatrix<f64, NP, NP>,
        g: &mut Par,
        prod: &mut SMatrix<f64, NP, NP>,
    ) {
        let gw = self.group_weight;
        for a in 0..3 {
            let m = symmetric(&self.m_star[a]);
            let d = SMatrix::<f64, 5, NP>::from_fn(|s, k| dc[k].star[a][s]);
            let md = m * d;
            d.transpose().mul_to(&md, prod);
            add_scaled(hm, prod, gw[GROUP_STAR]);
            *g += md.transpose() * c0.star[a] * gw[GROUP_STAR];
            let m = symmetric(&self.m_ang[a]);
            let d = SMatrix::<f64, 2, NP>::from_fn(|s, k| dc[k].ang[a][s]);
            let md = m * d;
            d.transpose().mul_to(&md, prod);
            add_scaled(hm, prod, gw[GROUP_ANGULAR]);
            *g += md.transpose() * c0.ang[a] * gw[GROUP_ANGULAR];
        }
    }

    /// The SRP-free whitened rows (5 × 6) of regime `reg`'s linear residuals at `p`,
    /// with its Gram matrix; `None` for an empty regime or a singular noise model.
    pub(super) fn regime_rows(
        &self,
        p: &Par,
        reg: usize,
        h: &SVector<f64, 6>,
        gram: &mut Gram,
    ) -> Option<SMatrix<f64, 3, 6>> {
        let (cnt, msq, wsq) = self.regime_stats(p, reg);
        if cnt < 1.0 {
            return None;
        }
        let r = self.white_cov(p, &msq, &wsq);
        let (linv, _, _) = Self::whitening(&r, h)?;
        symmetric_into(&self.m_raw[reg.min(N_REG - 1)], gram);
        let cm = core::array::from_fn(|j| self.direction_in_volts(p, &Vector3::ith(j.min(2), 1.0)));
        Some(Self::differential_rows(&linv, &cm))
    }

    /// Degrees of freedom of each group's χ² (residuals accumulated).
    pub(super) fn group_dof(&self) -> [f64; N_GROUPS] {
        let n = self.n_is();
        let cnt: f64 = self.m_raw.iter().map(|m| m.get(S_ONE, S_ONE)).sum();
        [
            (3 * n - 1) as f64 * cnt,
            cnt,
            3.0 * self.n_star as f64,
            if n == 2 { 3.0 * cnt } else { 0.0 },
        ]
    }

    /// Judge each group's χ²/dof: a group whose residuals are larger than its noise
    /// model allows is inconsistent; it is then weighted with its observed noise (so
    /// σ grows by √(χ²/dof)) instead of printing a tight σ the data do not support.
    #[inline(never)]
    pub(super) fn judge_consistency(&mut self, cost: &[f64; N_GROUPS]) {
        let dof = self.group_dof();
        let mut inconsistent = false;
        let mut inflation: f64 = 1.0;
        for k in 0..N_GROUPS {
            self.chi2[k] = if dof[k] > 0.0 { cost[k] / dof[k] } else { 0.0 };
            let limit = 1.0
                + self
                    .cfg
                    .chi2_tolerance
                    .max(tuning::CHI2_SPREAD_SIGMAS * (2.0 / dof[k].max(1.0)).sqrt());
            if dof[k] >= tuning::CHI2_MIN_DOF && nan_or_above(self.chi2[k], limit) {
                inconsistent = true;
                let x = if self.chi2[k].is_finite() {
                    self.chi2[k]
                } else {
                    1e300
                };
                self.group_weight[k] = 1.0 / x;
                inflation = inflation.max(x.sqrt());
            } else {
                self.group_weight[k] = 1.0;
            }
        }
        self.inflation = inflation;
        if inconsistent {
            self.status |= ST_INCONSISTENT;
        } else {
            self.status &= !ST_INCONSISTENT;
        }
    }

    pub(super) fn param_used(&self, k: usize) -> bool {
        let second = (P_BETA + 3..P_BETA + 6).contains(&k)
            || (P_R + 3..P_R + 6).contains(&k)
            || (P_B + 3..P_B + 6).contains(&k)
            || (P_AL + 3..P_AL + 6).contains(&k);
        !(second && self.n_is() < 2)
    }

    /// Solve H δ = −g with Jacobi scaling; H⁻¹ into `hinv` (`hs`: scratch for the
    /// scaled H and its Cholesky factor). The same operations as nalgebra's
    /// `Cholesky::new`, `solve` and `inverse` (the same bits), in the caller's matrices:
    /// no 30 × 30 matrix on the stack.
    #[inline(never)]
    pub(super) fn newton_step(
        hm: &SMatrix<f64, NP, NP>,
        g: &Par,
        hs: &mut SMatrix<f64, NP, NP>,
        hinv: &mut SMatrix<f64, NP, NP>,
    ) -> Option<Par> {
        let sc = Par::from_fn(|k, _| 1.0 / hm[(k, k)].max(1e-300).sqrt());
        for j in 0..NP {
            for i in 0..NP {
                hs[(i, j)] = hm[(i, j)] * sc[i] * sc[j];
            }
        }
        if !cholesky_in_place(hs) {
            return None;
        }
        let mut gs = g.component_mul(&sc);
        hs.solve_lower_triangular_unchecked_mut(&mut gs);
        hs.ad_solve_lower_triangular_unchecked_mut(&mut gs);
        let delta = -gs.component_mul(&sc);
        hinv.fill_with_identity();
        hs.solve_lower_triangular_unchecked_mut(hinv);
        hs.ad_solve_lower_triangular_unchecked_mut(hinv);
        for j in 0..NP {
            for i in 0..NP {
                hinv[(i, j)] = hinv[(i, j)] * sc[i] * sc[j];
            }
        }
        Some(delta)
    }

    /// Variance of the estimate [parameter units²]: H⁻¹'s diagonal (the step's own
    /// inverse); None if any is not finite. The SRP's turn counts as evidence about β
    /// like every other term, its attitude error a noise of the turn rows' filters
    /// (`turn_time_update`), so no part of the Jacobian is left out to be carried
    /// separately.
    pub(super) fn estimate_var(hinv: &SMatrix<f64, NP, NP>) -> Option<Par> {
        let var = Par::from_fn(|k, _| hinv[(k, k)]);
        var.iter().all(|v| v.is_finite()).then_some(var)
    }

    /// Gauss–Newton iterations from the current solution, until converged (no
    /// parameter moved by `tuning::CONVERGED_STEP` of its σ). Returns the last step's largest
    /// move in σ of its parameter, the step's before it (∞ after one step), the cosine
    /// between the two steps in σ units (0 after one step), and the same move and
    /// cosine one step earlier (∞ and 0 when there was none); None when a step failed
    /// (singular normal equations, a non-finite step), which keeps the previous
    /// solution and says so in the status word.
    pub fn solve(
        &mut self,
        iterations: usize,
        priors: bool,
        w: &mut SolveWork,
    ) -> Option<[f64; 5]> {
        self.flush_grams();
        let mut moved = f64::INFINITY;
        let mut before = f64::INFINITY;
        let mut earlier = f64::INFINITY;
        let mut cos = 0.0;
        let mut cos_before = 0.0;
        let mut last = Par::zeros();
        for _ in 0..iterations {
            self.normal_equations(&self.p, priors, w);
            let step = Self::newton_step(&w.n.hm, &w.n.g, &mut w.hs, &mut w.hinv)
                .filter(|d| d.iter().all(|x| x.is_finite()))
                .and_then(|d| Some((d, Self::estimate_var(&w.hinv)?)));
            let Some((delta, var)) = step else {
                self.status |= ST_SOLVE_FAILED;
                return None;
            };
            self.p += delta;
            self.sigma = var.map(|v| v.max(0.0).sqrt());
            self.status &= !(ST_SOLVE_FAILED | ST_NO_SOLUTION);
            let cost = self.group_costs(&self.p, &mut w.gram);
            self.judge_consistency(&cost);
            self.refresh_gate();
            earlier = before;
            before = moved;
            moved = largest_move(&delta, &self.sigma);
            cos_before = cos;
            let step = delta.component_div(&self.sigma.map(|s| s.max(1e-300)));
            let norms = step.norm() * last.norm();
            cos = if norms > 0.0 {
                step.dot(&last) / norms
            } else {
                0.0
            };
            last = step;
            if moved < tuning::CONVERGED_STEP {
                break;
            }
        }
        Some([moved, before, cos, earlier, cos_before])
    }

    /// Each group's χ² at `p`, with the rows `normal_equations` uses.
    #[inline(never)]
    pub(super) fn group_costs(&self, p: &Par, gram: &mut Gram) -> [f64; N_GROUPS] {
        let c0 = self.coeffs(p);
        let mut cost = [0.0; N_GROUPS];
        let lin = |row: &SVector<f64, 6>, m: &Gram| {
            let c: Sig = c0.lin.transpose() * row;
            c.dot(&(m * c))
        };
        let h = self.srp_direction(p);
        for reg in 0..N_REG {
            let Some(rows) = self.regime_rows(p, reg, &h, gram) else {
                continue;
            };
            for t in 0..3 {
                cost[GROUP_LINEAR] += lin(&rows.row(t).transpose(), gram);
            }
        }
        if let Some(rows) = self.turn_rows(p) {
            for t in 0..2 {
                symmetric_into(&self.m_turn[t], gram);
                cost[GROUP_LINEAR] += lin(&rows.row(t).transpose(), gram);
            }
        }
        symmetric_into(&self.m_filt, gram);
        cost[GROUP_COMMON_MODE] = lin(&self.t_u, gram);
        for a in 0..3 {
            cost[GROUP_STAR] += c0.star[a].dot(&(symmetric(&self.m_star[a]) * c0.star[a]));
            cost[GROUP_ANGULAR] += c0.ang[a].dot(&(symmetric(&self.m_ang[a]) * c0.ang[a]));
        }
        cost
    }

    /// The linear input test follows the new solution: its residual rows change, and
    /// its tracks' levels move with them (at the last accepted sample).
    #[inline(never)]
    pub(super) fn refresh_gate(&mut self) {
        let new = self.coeffs(&self.p).lin;
        let raw = (new - self.gate_c) * self.gate_s;
        let shift = self.gate_w * raw;
        for k in 0..6 {
            self.lin_track[k].shift(shift[k]);
            self.lone_track[k].shift(raw[k]);
        }
        self.gate_c = new;
    }
}

/// `out = a b`, column by column as nalgebra's gemm computes `a * b` (out's column j
/// = a's column 0 times b[0, j], then each further column of a times its b[k, j]
/// added: the same products and sums in the same order, the same bits; a unit test),
/// over contiguous columns. Out of line: as a function's `&mut` parameter the output
/// provably aliases neither factor, so the inner loops keep their registers (inlined,
/// with the three in one struct, a Cortex-M7 solve took 61 % more instructions). On
/// x86-64 it is inlined into the AVX2 path instead (out of line it would be compiled
/// without AVX2: 47 % more there). The column's loop differs by target
/// (`column_product`), the bits do not.
#[cfg_attr(target_arch = "x86_64", inline(always))]
#[cfg_attr(not(target_arch = "x86_64"), inline(never))]
fn mul_into<const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<f64, R, K>,
    b: &SMatrix<f64, K, C>,
    out: &mut SMatrix<f64, R, C>,
) {
    let a = a.as_slice();
    for (col, bj) in out
        .as_mut_slice()
        .chunks_exact_mut(R)
        .zip(b.as_slice().chunks_exact(K))
    {
        column_product(col, a, bj);
    }
}

/// Column j of `a b` (`a` column-major with R rows, `bj` = b's column j) into `col`:
/// whole columns of `a` scaled and added, k ascending (AVX2 vectorises them).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn column_product(col: &mut [f64], a: &[f64], bj: &[f64]) {
    let mut terms = a.chunks_exact(col.len().max(1)).zip(bj);
    if let Some((a0, &b0)) = terms.next() {
        for (y, x) in col.iter_mut().zip(a0) {
            *y = x * b0;
        }
    }
    for (ak, &bk) in terms {
        for (y, x) in col.iter_mut().zip(ak) {
            *y += x * bk;
        }
    }
}

/// Column j of `a b` (as above): four rows at a time, held in registers over every k (k
/// ascending: each element's products and sums in the same order), then the rows
/// left. On a CPU without vector registers this halves the loads and stores of the
/// column-at-a-time loop, whose unrolling also depended on R (a Cortex-M7 solve:
/// 10.98 M instructions that way at 38 signals, 5.91 M this way).
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn column_product(col: &mut [f64], a: &[f64], bj: &[f64]) {
    column_product_blocked(col, a, bj);
}

/// `column_product` of the CPUs without vector registers (also unit-tested on x86-64).
#[cfg(any(not(target_arch = "x86_64"), test))]
#[inline(always)]
fn column_product_blocked(col: &mut [f64], a: &[f64], bj: &[f64]) {
    let r_len = col.len().max(1);
    let mut rows = col.chunks_exact_mut(4);
    let mut i = 0;
    for y in &mut rows {
        let mut acc = [0.0; 4];
        for (k, (ak, &bk)) in a.chunks_exact(r_len).zip(bj).enumerate() {
            let Some(x) = ak.get(i..i + 4) else { break };
            for ((s, x), first) in acc.iter_mut().zip(x).zip([k == 0; 4]) {
                *s = if first { x * bk } else { *s + x * bk };
            }
        }
        y.copy_from_slice(&acc);
        i += 4;
    }
    for (r, y) in rows.into_remainder().iter_mut().enumerate() {
        let mut terms = a
            .chunks_exact(r_len)
            .zip(bj)
            .filter_map(|(ak, &bk)| Some(ak.get(i + r)? * bk));
        let mut s = terms.next().unwrap_or(0.0);
        for t in terms {
            s += t;
        }
        *y = s;
    }
}

/// The Cholesky factor L of `a` in its lower triangle (the upper one is left as it
/// was), nalgebra's `Cholesky::new` step for step: the same bits, in place. False when
/// `a` is not positive definite (a zero, negative or NaN pivot), as `new` gives `None`.
/// Also the whitening's 6 × 6 factor: nalgebra's own `Cholesky::new` on a fixed-size
/// matrix breaks Rust's aliasing rules (Miri, Stacked Borrows: its column pair views
/// of one array; dimforge/nalgebra#1520), so the flight core never calls it.
pub(super) fn cholesky_in_place<const N: usize>(a: &mut SMatrix<f64, N, N>) -> bool {
    for j in 0..N {
        for k in 0..j {
            // axpy: y = (factor x) 1 + 1 y, with factor = −L[j, k].
            let factor = -a[(j, k)];
            for r in j..N {
                a[(r, j)] += factor * a[(r, k)];
            }
        }
        let diag = a[(j, j)];
        // `try_sqrt`: None below zero and for NaN (and a zero pivot is refused first).
        if diag == 0.0 || diag.is_nan() || diag < 0.0 {
            return false;
        }
        let denom = libm::sqrt(diag);
        a[(j, j)] = denom;
        for r in j + 1..N {
            a[(r, j)] /= denom;
        }
    }
    true
}

/// `symmetric(m)` written into `out` (no 35 × 35 temporary).
fn symmetric_into(m: &Packed, out: &mut Gram) {
    for j in 0..NS {
        for i in 0..NS {
            out[(i, j)] = m.get(i, j);
        }
    }
}

/// `h += x w`, element by element (as `h += x * w` would, without its temporary).
fn add_scaled(h: &mut SMatrix<f64, NP, NP>, x: &SMatrix<f64, NP, NP>, w: f64) {
    for (h, x) in h.iter_mut().zip(x.iter()) {
        *h += x * w;
    }
}

/// The step's largest move of a parameter in its σ (out of line: the solve's frames
/// are the deepest stack).
#[inline(never)]
fn largest_move(delta: &Par, sigma: &Par) -> f64 {
    let mut moved: f64 = 0.0;
    for k in 0..NP {
        moved = moved.max(delta[k].abs() / sigma[k].max(1e-300));
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The in-place factor and its solves give nalgebra's `Cholesky` bits, and refuse
    /// what it refuses; at the whitening's 6 × 6 too. (Not under Miri: nalgebra's
    /// `cholesky` on a fixed-size matrix is itself what Miri refuses,
    /// dimforge/nalgebra#1520; `whitening` and the solve run ours under Miri.)
    #[test]
    #[cfg_attr(
        miri,
        ignore = "nalgebra's own cholesky breaks Stacked Borrows (dimforge/nalgebra#1520); ours runs under Miri in every update's whitening and in the solve (tests/miri_capi.rs)"
    )]
    fn the_in_place_cholesky_is_nalgebras_bit_for_bit() {
        // The whitening's: the white covariance of the six linear residuals.
        let b = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 - 2.0);
        let s = SVector::<f64, 6>::from_fn(|i, _| 10f64.powi(i as i32 % 3 - 5));
        let spd = b * b.transpose() + SMatrix::<f64, 6, 6>::identity() * 3.0;
        let r = SMatrix::<f64, 6, 6>::from_fn(|i, j| spd[(i, j)] * s[i] * s[j]);
        let mut l = r;
        assert!(cholesky_in_place(&mut l));
        l.fill_upper_triangle(0.0, 1);
        let want = r.cholesky().unwrap().l();
        assert!(l
            .iter()
            .zip(want.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits()));
        let mut bad = r;
        bad[(3, 3)] = -bad[(3, 3)];
        assert!(!cholesky_in_place(&mut bad.clone()) && bad.cholesky().is_none());
        // And on random covariances of spread scales, some not positive definite.
        let mut gauss = gaussian(0x853c_49e6_748f_ea9b);
        let mut refused = 0;
        for case in 0..2000 {
            let b = SMatrix::<f64, 6, 6>::from_fn(|_, _| gauss());
            let s = SVector::<f64, 6>::from_fn(|_, _| 10f64.powf(4.0 * gauss()));
            let shift = if case % 10 == 0 { -0.5 } else { 1e-3 };
            let spd = b * b.transpose() + SMatrix::<f64, 6, 6>::identity() * shift;
            let r = SMatrix::<f64, 6, 6>::from_fn(|i, j| spd[(i, j)] * s[i] * s[j]);
            let mut l = r;
            let ok = cholesky_in_place(&mut l);
            let want = r.cholesky().map(|c| c.l());
            assert_eq!(ok, want.is_some(), "case {case}");
            refused += usize::from(!ok);
            if let Some(want) = want {
                l.fill_upper_triangle(0.0, 1);
                let same = l
                    .iter()
                    .zip(want.iter())
                    .all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "case {case}");
            }
        }
        assert!((10..200).contains(&refused), "{refused} refused");
        let n = normal();
        let mut a = n.hm;
        assert!(cholesky_in_place(&mut a));
        let ch = n.hm.cholesky().unwrap();
        let l = ch.l();
        for j in 0..NP {
            for i in j..NP {
                assert_eq!(a[(i, j)].to_bits(), l[(i, j)].to_bits(), "L[{i},{j}]");
            }
        }
        let mut x = n.g;
        a.solve_lower_triangular_unchecked_mut(&mut x);
        a.ad_solve_lower_triangular_unchecked_mut(&mut x);
        let y = ch.solve(&n.g);
        assert!(x
            .iter()
            .zip(y.iter())
            .all(|(p, q)| p.to_bits() == q.to_bits()));
        let mut bad = n.hm;
        bad[(4, 4)] = -1.0;
        assert_eq!(
            cholesky_in_place(&mut bad.clone()),
            bad.cholesky().is_some()
        );
        bad[(4, 4)] = f64::NAN;
        assert_eq!(
            cholesky_in_place(&mut bad.clone()),
            bad.cholesky().is_some()
        );
    }

    /// One residual group's Gauss–Newton terms where the CPU has AVX2 (`add_group`'s
    /// `unsafe` call of `add_group_avx2`) are the portable loops' bits. Natively that
    /// compares the two compiled paths; under Miri (`tools/miri`'s run built with
    /// `-Ctarget-feature=+avx2,+fma`) it checks the `unsafe` call.
    #[test]
    #[cfg_attr(
        all(miri, not(target_feature = "avx2")),
        ignore = "the AVX2 path needs a build with +avx2 under Miri (tools/miri runs one)"
    )]
    fn the_avx2_group_terms_are_the_portable_ones_bit_for_bit() {
        if !super::super::avx2_here() {
            return;
        }
        let mut gauss = gaussian(0x9e37_79b9_7f4a_7c15);
        let mut coeffs = || {
            let mut c = <Coeffs as bytemuck::Zeroable>::zeroed();
            c.lin = SMatrix::from_fn(|_, _| gauss());
            c
        };
        let c0 = coeffs();
        let dc: [Coeffs; NP] = core::array::from_fn(|_| coeffs());
        let mut gauss = gaussian(0x2545_f491_4f6c_dd1d);
        let b = Gram::from_fn(|_, _| gauss());
        let m = b.transpose() * b;
        let row = SVector::<f64, 6>::from_fn(|_, _| gauss());
        let lin = Linearised { c0: &c0, dc: &dc };
        let mut out = [(SMatrix::<f64, NP, NP>::identity(), Par::repeat(0.5)); 2];
        let mut sc = [<GroupScratch as bytemuck::Zeroable>::zeroed(); 2];
        let [(h0, g0), (h1, g1)] = &mut out;
        let [s0, s1] = &mut sc;
        let (mut fast, mut portable) = (Sums { hm: h0, g: g0 }, Sums { hm: h1, g: g1 });
        JointEstimator::add_group(&row, &m, 0.75, &lin, &mut fast, s0);
        JointEstimator::add_group_portable(&row, &m, 0.75, &lin, &mut portable, s1);
        let [(h0, g0), (h1, g1)] = &out;
        assert!(h0.iter().all(|x| x.is_finite()) && *h0 != SMatrix::<f64, NP, NP>::identity());
        let bits = |h: &SMatrix<f64, NP, NP>, g: &Par| {
            h.iter()
                .chain(g.iter())
                .map(|x| x.to_bits())
                .collect::<std::vec::Vec<_>>()
        };
        assert!(bits(h0, g0) == bits(h1, g1));
    }

    /// `newton_step` with its own scratch: (δ, H⁻¹).
    fn step(hm: &SMatrix<f64, NP, NP>, g: &Par) -> Option<(Par, SMatrix<f64, NP, NP>)> {
        let (mut hs, mut hinv) = (SMatrix::zeros(), SMatrix::zeros());
        let d = JointEstimator::newton_step(hm, g, &mut hs, &mut hinv)?;
        Some((d, hinv))
    }

    /// A symmetric positive-definite H of widely spread scales (as the parameters'
    /// units make it).
    fn normal() -> Normal {
        let scale = Par::from_fn(|k, _| 10f64.powi((k % 7) as i32 * 2 - 6));
        let b = SMatrix::<f64, NP, NP>::from_fn(|i, j| ((i * 31 + j * 17) % 13) as f64 - 6.0);
        let spd = b * b.transpose() + SMatrix::<f64, NP, NP>::identity() * 50.0;
        let hm = SMatrix::<f64, NP, NP>::from_fn(|i, j| spd[(i, j)] * scale[i] * scale[j]);
        let g = Par::from_fn(|k, _| ((k % 5) as f64 - 2.0) * scale[k]);
        Normal { hm, g }
    }

    /// `mul_into` gives nalgebra's product bit for bit, zeros, signs and rounding alike.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "20 products of 38 x 38 by 30 against nalgebra's; mul_into runs under Miri in the_avx2_group_terms_are_the_portable_ones_bit_for_bit and the C ABI's solve (tests/miri_capi.rs)"
    )]
    fn mul_into_is_nalgebras_product_bit_for_bit() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let x = ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e3;
            if seed % 7 == 0 {
                0.0
            } else {
                x * 10f64.powi((seed % 23) as i32 - 11)
            }
        };
        for _ in 0..20 {
            let a = SMatrix::<f64, NS, NS>::from_fn(|_, _| next());
            let b = SMatrix::<f64, NS, NP>::from_fn(|_, _| next());
            let mut out = SMatrix::<f64, NS, NP>::zeros();
            mul_into(&a, &b, &mut out);
            let want = a * b;
            for (x, y) in out.iter().zip(want.iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
            // The other shape the solve multiplies (30 rows: a remainder of 2).
            let t = SMatrix::<f64, NP, NS>::from_fn(|_, _| next());
            let mut prod = SMatrix::<f64, NP, NP>::zeros();
            mul_into(&t, &b, &mut prod);
            for (x, y) in prod.iter().zip((t * b).iter()) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
            // The flight CPUs' loop, column by column, the same bits.
            for (j, y) in want.column_iter().enumerate() {
                let mut col = [0.0; NS];
                column_product_blocked(&mut col, a.as_slice(), b.column(j).as_slice());
                for (x, y) in col.iter().zip(y.iter()) {
                    assert_eq!(x.to_bits(), y.to_bits());
                }
            }
            for (j, y) in (t * b).column_iter().enumerate() {
                let mut col = [0.0; NP];
                column_product_blocked(&mut col, t.as_slice(), b.column(j).as_slice());
                for (x, y) in col.iter().zip(y.iter()) {
                    assert_eq!(x.to_bits(), y.to_bits());
                }
            }
        }
    }

    /// On a linear least-squares problem one Gauss–Newton step from anywhere lands on
    /// the solution of the normal equations, and its inverse is H⁻¹, whatever the
    /// parameters' scales (the step equilibrates H before its Cholesky).
    #[test]
    fn one_gauss_newton_step_solves_a_linear_least_squares_problem() {
        const M: usize = 45;
        let scale = Par::from_fn(|k, _| 10f64.powi((k % 5) as i32 * 3 - 6));
        let j = SMatrix::<f64, M, NP>::from_fn(|r, c| {
            (((r * 13 + c * 7) % 11) as f64 - 5.0 + if r == c { 9.0 } else { 0.0 }) / scale[c]
        });
        let truth = Par::from_fn(|k, _| (k as f64 - 14.5) * scale[k]);
        let y = j * truth;
        let p0 = Par::from_fn(|k, _| 0.3 * scale[k]);
        let h = j.transpose() * j;
        let g = -(j.transpose() * (y - j * p0));
        let (delta, hinv) = step(&h, &g).unwrap();
        let p1 = p0 + delta;
        for k in 0..NP {
            assert!(
                (p1[k] - truth[k]).abs() < 1e-8 * scale[k],
                "{k}: {} vs {}",
                p1[k],
                truth[k]
            );
        }
        let direct = h.try_inverse().unwrap();
        for k in 0..NP {
            assert!((hinv[(k, k)] / direct[(k, k)] - 1.0).abs() < 1e-8, "{k}");
        }
        // A singular H is refused, not solved.
        let mut sing = h;
        sing.set_column(3, &Par::zeros());
        sing.set_row(3, &Par::zeros().transpose());
        assert!(step(&sing, &g).is_none());
    }
}
