//! Whitening: the white-noise covariance of the six linear residuals, its Cholesky
//! rows, and the causal innovations filter of the coloured SRP that every signal of
//! the linear group passes through before it enters the Gram matrices.

use super::*;

/// Symmetric rank-one update of the upper triangle: m += w v vᵀ, a column whose
/// multiplier is zero skipped. What a Gram matrix took sample by sample before its
/// updates were deferred (`defer::rank_n` gives the same bits, a test shows).
#[cfg(test)]
pub(super) fn rank1_packed(m: &mut Packed, v: &Sig, w: f64) {
    let v = v.as_slice();
    for (j, &vj) in v.iter().enumerate() {
        let vj = vj * w;
        if vj == 0.0 {
            continue;
        }
        for (mij, vi) in m.column_mut(j).iter_mut().zip(v) {
            *mij += vi * vj;
        }
    }
}

/// The same update of a small matrix's upper triangle (the star-tracker and angular
/// groups).
#[inline(always)]
pub(super) fn rank1_upper<const N: usize>(m: &mut SMatrix<f64, N, N>, v: &SVector<f64, N>, w: f64) {
    let v = v.as_slice();
    for (j, col) in m.as_mut_slice().chunks_exact_mut(N).enumerate() {
        let vj = v[j] * w;
        if vj == 0.0 {
            continue;
        }
        for (mij, vi) in col[..=j].iter_mut().zip(&v[..=j]) {
            *mij += vi * vj;
        }
    }
}

/// A sample's drive against the first sample's (`JointEstimator::drive`).
#[derive(Default)]
pub(super) struct Drive {
    sum_sq: [f64; 6],
    wdot_sq: [f64; 3],
}

pub(super) fn symmetric<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    SMatrix::from_fn(|i, j| if i <= j { m[(i, j)] } else { m[(j, i)] })
}

impl JointEstimator {
    /// White-noise covariance of the six linear residuals [V²], given per-slot mean
    /// squared voltage and per-IS, per-axis mean squared angular acceleration.
    pub(super) fn white_cov(
        &self,
        p: &Par,
        mean_sq_sum: &[f64; 6],
        mean_sq_wdot: &[[f64; 3]; 2],
    ) -> SMatrix<f64, 6, 6> {
        let c = &self.cfg;
        let mut r = SMatrix::<f64, 6, 6>::identity();
        let n = self.n_is();
        let mut v = [0.0; 3];
        for (a, va) in v.iter_mut().enumerate() {
            for (l, msq) in mean_sq_wdot.iter().enumerate().take(n) {
                *va +=
                    self.w(l).powi(2) * (c.sigma_angular.powi(2) + c.sigma_ripple.powi(2) * msq[a]);
            }
        }
        for s in 0..3 * n {
            for s2 in 0..3 * n {
                // Clamped indices and a plain loop from −0 (as `Iterator::sum`, the same
                // bits): inlined into `turn_rows`, the iterator's closure kept an index
                // check the C ABI could reach.
                let (i, j, i2, j2) = ((s / 3).min(1), s % 3, (s2 / 3).min(1), s2 % 3);
                let (k, k2) = (self.k_of(p, i, j), self.k_of(p, i2, j2));
                let xi = -skew(&Vector3::from_fn(|a, _| p[P_R + 3 * i + a.min(2)]));
                let xi2 = -skew(&Vector3::from_fn(|a, _| p[P_R + 3 * i2 + a.min(2)]));
                let mut acc = -0.0;
                for a in 0..3 {
                    acc += xi[(j.min(2), a)] * xi2[(j2.min(2), a)] * v[a];
                }
                let mut val = acc / (k * k2);
                if j == j2 {
                    val += c.sigma_force.powi(2) / (k * k2);
                }
                if s == s2 {
                    val += (c.sigma_linear / k).powi(2) + c.sigma_ripple.powi(2) * mean_sq_sum[s];
                }
                r[(s, s2)] = val;
            }
        }
        r
    }

    /// Each row of `rows` (`gate_w`, `turn_w`) its lever on ω̇'s noise per axis
    /// (`gate_lever`, `turn_lever`): Σ over the slots of the row times that slot's row
    /// of ω̇ × r / k, at the priors, as `white_cov` builds the angular term (so the
    /// row's variance of it is Σ_a lever_a² v_a).
    pub(super) fn row_levers<const R: usize>(&self, rows: &SMatrix<f64, R, 6>) -> [[f64; 3]; R] {
        let p = &self.p;
        let mut out = [[0.0; 3]; R];
        for s in 0..3 * self.n_is() {
            let (i, j) = ((s / 3).min(1), s % 3);
            let xi = -skew(&Vector3::from_fn(|b, _| p[P_R + 3 * i + b]));
            let k_ij = self.k_of(p, i, j);
            // Plain loops with clamped indices: no index check is linked.
            for (k, lever) in out.iter_mut().enumerate() {
                for (a, g) in lever.iter_mut().enumerate() {
                    *g += rows[(k.min(R - 1), s.min(5))] * xi[(j.min(2), a.min(2))] / k_ij;
                }
            }
        }
        out
    }

    /// Each row of `gate_w`'s white variance at this sample's drive (signals `s`), in
    /// units of the first sample's (`white_var_of_row`); the last is the common-mode
    /// channel's.
    /// Rows 6 and 7: the rows across the SRP (`turn_w`), for the turn filter.
    pub(super) fn row_white_vars(&self, s: &Sig) -> [f64; 8] {
        let d = self.drive(s);
        core::array::from_fn(|k| match k {
            0..=5 => Self::white_var_of_row(
                self.cfg.sigma_ripple,
                &self.gate_w,
                k,
                &self.gate_lever[k.min(5)],
                &d,
            ),
            _ => Self::white_var_of_row(
                self.cfg.sigma_ripple,
                &self.turn_w,
                k - 6,
                &self.turn_lever[(k - 6).min(1)],
                &d,
            ),
        })
    }

    /// How far this sample's drive is from the first sample's, which the rows of
    /// `gate_w` whiten: per slot ΣV² − ΣV²_ref [V²] (signals `s`), per axis the mean
    /// angular acceleration's square Σ_l w_l² (β_l,prior ΔV_l)² [rad² s⁻⁴].
    fn drive(&self, s: &Sig) -> Drive {
        let c = &self.cfg;
        let n = self.n_is();
        let mut d = Drive::default();
        for slot in 0..3 * n {
            let rf = self.sum_ref[(slot / 3).min(1)][slot % 3];
            let sum = s[S_SUM + slot.min(5)] + rf;
            d.sum_sq[slot.min(5)] = sum * sum - rf * rf;
        }
        for (a, w2) in d.wdot_sq.iter_mut().enumerate() {
            for l in 0..n {
                let l = l.min(1);
                *w2 += (self.w(l) * c.beta_prior[l][a] * s[S_DV + (3 * l + a).min(5)]).powi(2);
            }
        }
        d
    }

    /// White variance of row `k` of `gate_w` (5: the common-mode channel) at a
    /// sample's `drive`, in units of the first sample's (to which the rows whiten):
    /// the drive ripple scales with the drive, so its share grows with the linear and
    /// angular voltages. Held at the first sample's, it would misjudge a maneuver that
    /// drives a slot of little white noise (a sunless axis).
    fn white_var_of_row<const R: usize>(
        ripple: f64,
        rows: &SMatrix<f64, R, 6>,
        k: usize,
        levers: &[f64; 3],
        d: &Drive,
    ) -> f64 {
        let k = k.min(R - 1);
        let mut v = 0.0;
        for (slot, sq) in d.sum_sq.iter().enumerate() {
            v += rows[(k, slot)].powi(2) * sq;
        }
        for (lever, w2) in levers.iter().zip(&d.wdot_sq) {
            v += lever.powi(2) * w2;
        }
        1.0 + ripple.powi(2) * v
    }

    /// Whitening rows: `L⁻¹` of the white covariance, and the unit direction of the
    /// coloured SRP in the whitened space, with its gain |L⁻¹ h|.
    pub(super) fn whitening(
        r: &SMatrix<f64, 6, 6>,
        h: &SVector<f64, 6>,
    ) -> Option<(SMatrix<f64, 6, 6>, SVector<f64, 6>, f64)> {
        // nalgebra's `r.cholesky()?.l()`, the same bits (`cholesky_in_place`).
        let mut l = *r;
        if !cholesky_in_place(&mut l) {
            return None;
        }
        l.fill_upper_triangle(0.0, 1);
        let linv = crate::math::lu_inverse(&l)?;
        let hp = linv * h;
        let hn = hp.norm();
        Some((linv, hp / hn, hn))
    }

    /// Rows spanning the complement of `u` (Householder), times `linv`: 5 × 6.
    pub(super) fn complement_rows(
        linv: &SMatrix<f64, 6, 6>,
        u: &SVector<f64, 6>,
    ) -> SMatrix<f64, 5, 6> {
        let mut e1 = SVector::<f64, 6>::zeros();
        e1[0] = if u[0] >= 0.0 { 1.0 } else { -1.0 };
        let v = u - e1;
        let hh = if v.norm() < 1e-12 {
            SMatrix::<f64, 6, 6>::identity()
        } else {
            SMatrix::<f64, 6, 6>::identity() - v * v.transpose() * (2.0 / v.norm_squared())
        };
        let rows: SMatrix<f64, 5, 6> = hh.fixed_rows::<5>(1).into_owned();
        rows * linv
    }

    /// The linear group's statistics take one sample: the Gram matrix of its regime,
    /// the SRP whitening filter and the whitened Gram matrix (most of a sample's work).
    /// Where the CPU has AVX2 the same code runs compiled for it: 4 lanes instead of 2,
    /// the same operations on every element, so the same bits (no fused multiply-add:
    /// Rust never contracts `a * b + c`).
    /// `cm_var`: the common-mode channel's white variance at this sample
    /// (`row_white_vars`). Out of line on the flight CPUs: its arrays in a frame of
    /// their own, so that `process`'s stays small enough for the CPUs' short
    /// stack offsets (a LEON3 reaches ±4 KB from its frame pointer in one instruction,
    /// three beyond).
    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    pub(super) fn update_linear(&mut self, s: &Sig, dv: &[[f64; 3]; 2], var: &[f64; 8]) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::has_avx2() {
            // SAFETY: the CPU has AVX2, checked just now.
            unsafe { self.update_linear_avx2(s, dv, var) };
            return;
        }
        self.update_linear_portable(s, dv, var);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    /// # Safety
    /// The CPU must support AVX2 (`simd::has_avx2`).
    pub(super) unsafe fn update_linear_avx2(
        &mut self,
        s: &Sig,
        dv: &[[f64; 3]; 2],
        var: &[f64; 8],
    ) {
        self.update_linear_portable(s, dv, var);
    }

    #[inline(always)]
    pub(super) fn update_linear_portable(&mut self, s: &Sig, dv: &[[f64; 3]; 2], var: &[f64; 8]) {
        let s = *s;
        let cm_var = var[5];
        self.flush_due();
        self.update_turn(&s, &[var[6], var[7]]);
        let bp = self.cfg.beta_prior[0];
        let mut reg = 0;
        for a in 1..3 {
            if (bp[a] * dv[0][a]).abs() > (bp[reg] * dv[0][reg]).abs() {
                reg = a;
            }
        }
        self.defer(T_RAW, &s, reg);

        // Innovations filter of the common-mode SRP channel, applied to every signal.
        let nb = self.bank.poles();
        let hn = self.hn;
        // Row sums of wp, summed column by column (each row's terms in the same order
        // as `Iterator::sum`, from −0): contiguous, so it vectorises.
        let mut pg = [0.0; MAX_POLES];
        pg[..nb].fill(-0.0);
        let (wp, wx) = (self.wp_in_use(), self.wx_in_use());
        for col in self
            .wp
            .get(wp.clone())
            .unwrap_or(&[])
            .chunks_exact(nb.max(1))
        {
            for (p, w) in pg[..nb].iter_mut().zip(col) {
                *p += w;
            }
        }
        let mut ptot = 0.0;
        for pgi in &pg[..nb] {
            ptot += *pgi;
        }
        let sv = hn * hn * ptot + cm_var;
        let inv_sqrt = 1.0 / sv.sqrt();
        let mut sf = Sig::zeros();
        // Slices of the `nb` poles in use: the loops below vectorise (element by
        // element the same operations in the same order as the plain loops).
        let a = &self.bank.a[..nb];
        let pg = &pg[..nb];
        // Each signal's sum over its poles, in pole order from −0 (`Iterator::sum`),
        // all signals side by side: 38 independent chains instead of one at a time.
        let mut sums = [-0.0; NS];
        for row in self.wx.get(wx.clone()).unwrap_or(&[]).chunks_exact(NS) {
            for (sm, x) in sums.iter_mut().zip(row) {
                *sm += x;
            }
        }
        let mut gain = [0.0; NS];
        for (((f, g), sum), sm) in sf.iter_mut().zip(&mut gain).zip(sums).zip(s.iter()) {
            let pred = sum * hn;
            let innov = sm - pred;
            *f = innov * inv_sqrt;
            *g = hn * innov / sv;
        }
        for ((row, ak), pk) in self
            .wx
            .get_mut(wx)
            .unwrap_or(&mut [])
            .chunks_exact_mut(NS)
            .zip(a)
            .zip(pg)
        {
            for (xk, g) in row.iter_mut().zip(&gain) {
                *xk = ak * (*xk + pk * g);
            }
        }
        let c = hn * hn / sv;
        // Column by column (wp is column-major); row i of column j as before:
        // (wp_ij − c pg_i pg_j) a_i a_j.
        let cpg: [f64; MAX_POLES] = core::array::from_fn(|i| c * pg.get(i).unwrap_or(&0.0));
        for ((col, &pj), &aj) in self
            .wp
            .get_mut(wp)
            .unwrap_or(&mut [])
            .chunks_exact_mut(nb.max(1))
            .zip(pg)
            .zip(a)
        {
            for ((w, ci), ai) in col.iter_mut().zip(&cpg).zip(a) {
                *w = (*w - ci * pj) * ai * aj;
            }
        }
        for (i, &s) in self.bank.s.iter().enumerate().take(nb) {
            if let Some(w) = self.wp.get_mut(i * nb + i) {
                *w += s * s;
            }
        }
        self.defer(T_FILT, &sf, 0);
    }

    /// The acceleration an attitude error of 1 rad about each axis turns the SRP `b`
    /// [m/s²] into, −e_a × b = b × e_a, in volts per slot through each slot's k at `p`
    /// [V/rad]: the turn's error in the linear residuals is Σ_a lever_a δθ_a.
    pub(super) fn turn_levers(&self, p: &Par, b: &Vector3<f64>) -> [SVector<f64, 6>; 3] {
        core::array::from_fn(|a| {
            let acc = b.cross(&Vector3::ith(a.min(2), 1.0));
            let mut h = SVector::<f64, 6>::zeros();
            for s in 0..3 * self.n_is() {
                h[s.min(5)] = acc[s % 3] / self.k_of(p, s / 3, s % 3);
            }
            h
        })
    }

    /// The levers (`turn_levers`) in the whitened space of `linv`, with their part along
    /// the SRP's whitened direction `u` taken out (the SRP's own channel has them far
    /// below its fluctuation): they span the plane across the SRP.
    pub(super) fn turn_plane(
        linv: &SMatrix<f64, 6, 6>,
        u: &SVector<f64, 6>,
        levers: &[SVector<f64, 6>; 3],
    ) -> [SVector<f64, 6>; 3] {
        core::array::from_fn(|a| {
            let z = linv * levers[a.min(2)];
            z - u * u.dot(&z)
        })
    }

    /// An orthonormal basis of the plane across the SRP (`turn_plane`): the largest
    /// lever first, then the one that leaves the most across it (two of the three are
    /// nearly parallel: the sun lies near a body plane). Along these two the turn's
    /// error per axis is nearly uncorrelated (the first is one lever's direction, the
    /// second across it), so each takes a filter of its own.
    pub(super) fn plane_basis(z: &[SVector<f64, 6>; 3]) -> Option<[SVector<f64, 6>; 2]> {
        let mut first = 0;
        for a in 1..3 {
            if z[a].norm() > z[first].norm() {
                first = a;
            }
        }
        let e1 = z[first] / z[first].norm();
        let mut e2 = SVector::<f64, 6>::zeros();
        let mut n2 = 0.0;
        for (a, za) in z.iter().enumerate() {
            let w = za - e1 * e1.dot(za);
            if a != first && w.norm() > n2 {
                n2 = w.norm();
                e2 = w;
            }
        }
        // A NaN fails this comparison too.
        let across = n2 > 1e-9 * z[first].norm();
        if !across || !e1.iter().all(|x| x.is_finite()) {
            return None;
        }
        Some([e1, e2 / n2])
    }

    /// The two whitened rows across the SRP at `p` (2 × 6, whitened at the first
    /// sample's drive, as the turn filters'), the SRP's direction from the fitted DC
    /// (as the white rows'): the first sample's holds the maneuver's A r (≈10⁻⁴ of it
    /// at the priors), and the SRP's fluctuation would leak into rows across it.
    /// Whitened with the noise model at `p`, not the first sample's at the priors: the
    /// levers are common to both IS through the k at `p`, and the thrusters' force
    /// noise, common through the true k, is the larger part of the common modes' noise
    /// (10⁻⁷ N/√Hz: 1.7×10⁴ times the readout's). At the priors' k (5×10⁻³ off) its
    /// part across the priors' common modes, 10⁻³ of it, would be whitened as readout,
    /// and the rows' χ²/dof be far above 1.
    pub(super) fn turn_rows(&self, p: &Par) -> Option<SMatrix<f64, 2, 6>> {
        let b = Vector3::from(self.srp_dc(p));
        let mut msq = [0.0; 6];
        for s in 0..3 * self.n_is() {
            msq[s.min(5)] = self.sum_ref[(s / 3).min(1)][s % 3].powi(2);
        }
        let r = self.white_cov(p, &msq, &[[0.0; 3]; 2]);
        let (linv, u, _) = Self::whitening(&r, &self.srp_direction(p))?;
        let z = Self::turn_plane(&linv, &u, &self.turn_levers(p, &b));
        let e = Self::plane_basis(&z)?;
        let l = linv.transpose();
        let mut rows = SMatrix::<f64, 2, 6>::zeros();
        for (k, ek) in e.iter().enumerate() {
            rows.set_row(k, &(l * ek).transpose());
        }
        Some(rows)
    }

    /// The turn filters' time step: the attitude error (angle, rate) per row moves on
    /// (angle += dt rate) and takes the error covariance added since (`turn_pq`), per
    /// axis times the row's lever squared (`turn_z`, squared): a sum of independent integrated
    /// random walks is one, of the summed intensity (the two rows' cross terms are
    /// left out: one row holds the sun-plane axes' levers, the other the third's).
    #[inline(always)]
    pub(super) fn turn_time_update(&mut self) {
        let dt = 1.0 / self.cfg.fs;
        for k in 0..2 {
            let z = &self.turn_z[k];
            let mut q = [0.0; 3];
            for (a, pq) in self.turn_pq.iter().enumerate() {
                for (qi, pi) in q.iter_mut().zip(pq) {
                    *qi += z[a] * z[a] * pi;
                }
            }
            let p = &mut self.tp[k];
            // P ← F P Fᵀ + Q, F = [[1, dt], [0, 1]].
            let p00 = p[0][0] + dt * (p[0][1] + p[1][0]) + dt * dt * p[1][1] + q[0];
            let p01 = p[0][1] + dt * p[1][1] + q[1];
            let p11 = p[1][1] + q[2];
            *p = [[p00, p01], [p01, p11]];
            // Column 0 the signals' angles, column 1 their rates: contiguous, so the
            // loop vectorises (each element the same operations as one at a time).
            let (angle, rate) = self.tx[k].as_mut_slice().split_at_mut(NS);
            for (x0, x1) in angle.iter_mut().zip(rate.iter()) {
                *x0 += dt * x1;
            }
        }
        self.turn_pq = [[0.0; 3]; 3];
    }

    /// The turn filters take one sample: their time step, then every signal's
    /// innovation, whitened, into `m_turn`. `white`: each row's white variance at this
    /// sample's drive (`row_white_vars`). Inlined into `update_linear`, so that the
    /// AVX2 path vectorises its rank-one updates too (the same bits).
    ///
    /// The row's white noise and its attitude error share this tick's ω̇ readout
    /// noise: the linear model's ω̇ × r carries it at once (lever `turn_lever`), and the
    /// attitude the IS propagate takes it as the step that ends this tick (½ dt² in
    /// angle, dt in rate, on the lever `turn_z`). Their covariance enters the gain
    /// (`turn_cross`): the rows' white noise tells the attitude error's steps, and a
    /// filter that ignored it would leave β's σ cautious wherever the IS's angular noise
    /// is above its linear noise over r.
    #[inline(always)]
    fn update_turn(&mut self, s: &Sig, white: &[f64; 2]) {
        self.turn_time_update();
        let cross = self.turn_cross();
        let mut sfs = [Sig::zeros(); 2];
        for (k, sf) in sfs.iter_mut().enumerate() {
            let k = k.min(1);
            let p = self.tp[k];
            let mut c = cross[k];
            let mut sv = p[0][0] + white[k] + 2.0 * c[0];
            // A covariance the joint model cannot have (rounding at a degenerate
            // lever) falls back to none.
            if !(sv > 0.0 && sv.is_finite()) {
                c = [0.0; 2];
                sv = p[0][0] + white[k];
            }
            let inv_sqrt = 1.0 / sv.sqrt();
            let (g0, g1) = ((p[0][0] + c[0]) / sv, (p[1][0] + c[1]) / sv);
            let (angle, rate) = self.tx[k].as_mut_slice().split_at_mut(NS);
            for (((f, x0), x1), sm) in sf
                .iter_mut()
                .zip(angle.iter_mut())
                .zip(rate.iter_mut())
                .zip(s.iter())
            {
                let innov = sm - *x0;
                *f = innov * inv_sqrt;
                *x0 += g0 * innov;
                *x1 += g1 * innov;
            }
            // P − S g gᵀ (with c = 0: P − g P[0], as before).
            self.tp[k] = [
                [p[0][0] - sv * g0 * g0, p[0][1] - sv * g0 * g1],
                [p[0][1] - sv * g0 * g1, p[1][1] - sv * g1 * g1],
            ];
        }
        let [s0, s1] = &sfs;
        self.defer(T_TURN, s0, 0);
        self.defer(T_TURN + 1, s1, 0);
    }

    /// Per turn row, the covariance of its white noise with its attitude error's
    /// step this tick (angle, rate) [whitened units², per s]. Both carry IS1's ω̇
    /// readout noise n1 (readout and drive ripple, variance v_a this tick): the row's
    /// residual holds −Σ_a lever_a (Σ_l w_l n_l)_a (the linear model's ω̇ × r / k) and
    /// −Σ_a z_a δθ_a, δθ the propagated attitude's error, which n1 steps by (½ dt²,
    /// dt) n1 (the attitude is IS1's alone). So the covariance is
    /// (½ dt², dt) Σ_a z_a lever_a w_1 v_a.
    #[inline(always)]
    fn turn_cross(&self) -> [[f64; 2]; 2] {
        let dt = 1.0 / self.cfg.fs;
        let w1 = self.w(0);
        let v: [f64; 3] = core::array::from_fn(|a| self.readout_var(0, a, self.dv_last[0][a]));
        core::array::from_fn(|k| {
            let k = k.min(1);
            let mut sum = 0.0;
            for a in 0..3 {
                sum += self.turn_z[k][a] * self.turn_lever[k][a] * w1 * v[a];
            }
            if !sum.is_finite() {
                sum = 0.0;
            }
            [0.5 * dt * dt * sum, dt * sum]
        })
    }

    /// Rows spanning the complement of the whitened common-mode subspace (`linv` times
    /// the three body axes in volts per slot, `cm`): the differential rows, free of
    /// any acceleration both IS share, the SRP and its turn among them (3 × 6; with one
    /// IS the three empty slots').
    pub(super) fn differential_rows(
        linv: &SMatrix<f64, 6, 6>,
        cm: &[SVector<f64, 6>; 3],
    ) -> SMatrix<f64, 3, 6> {
        let mut basis = [SVector::<f64, 6>::zeros(); 6];
        let mut n = 0;
        let add = |v: SVector<f64, 6>, basis: &mut [SVector<f64, 6>; 6], n: &mut usize| {
            let mut w = v;
            for b in basis.iter().take(*n) {
                w -= b * b.dot(&w);
            }
            let norm = w.norm();
            if norm > 1e-6 * v.norm() && *n < 6 {
                basis[(*n).min(5)] = w / norm;
                *n += 1;
            }
        };
        for c in cm {
            add(linv * c, &mut basis, &mut n);
        }
        let common = n;
        for i in 0..6 {
            add(SVector::<f64, 6>::ith(i, 1.0), &mut basis, &mut n);
        }
        let mut rows = SMatrix::<f64, 3, 6>::zeros();
        for k in 0..3 {
            rows.set_row(k, &basis[(common + k).min(5)].transpose());
        }
        rows * linv
    }

    /// A sample without linear data: the SRP model still evolves.
    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    pub(super) fn whitening_time_update(&mut self) {
        self.turn_time_update();
        let nb = self.bank.poles();
        // Without input (bridged ticks) the states decay geometrically; a value that
        // reached `tuning::FLUSH_BELOW` is 0 from then on, so that no update computes
        // with subnormal numbers (a LEON3's FPU traps on them, an x86-64 takes
        // microcode assists).
        let decay = |x: f64, a: f64| {
            if x < tuning::FLUSH_BELOW && x > -tuning::FLUSH_BELOW {
                0.0
            } else {
                x * a
            }
        };
        let (wp, wx) = (self.wp_in_use(), self.wx_in_use());
        for (row, &a) in self
            .wx
            .get_mut(wx)
            .unwrap_or(&mut [])
            .chunks_exact_mut(NS)
            .zip(&self.bank.a)
        {
            for x in row {
                *x = decay(*x, a);
            }
        }
        for (col, &aj) in self
            .wp
            .get_mut(wp)
            .unwrap_or(&mut [])
            .chunks_exact_mut(nb.max(1))
            .zip(&self.bank.a)
        {
            for (w, &ai) in col.iter_mut().zip(&self.bank.a) {
                *w = decay(*w, ai * aj);
            }
        }
        for (i, &s) in self.bank.s.iter().enumerate().take(nb) {
            if let Some(w) = self.wp.get_mut(i * nb + i) {
                *w += s * s;
            }
        }
    }

    /// The words of `wp` and `wx` the poles in use take (the rest stay 0).
    pub(super) fn wp_in_use(&self) -> core::ops::Range<usize> {
        let nb = self.bank.poles();
        0..nb * nb
    }

    pub(super) fn wx_in_use(&self) -> core::ops::Range<usize> {
        0..self.bank.poles() * NS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bridged ticks only decay the whitening filters' states (each pole's factor a
    /// a tick): every state stays 0 or normal, and reaches 0 once below
    /// `FLUSH_BELOW` (far above the subnormal range, 2.2×10⁻³⁰⁸, and hundreds of orders
    /// below the states a campaign carries: its estimates are the same bits).
    #[test]
    #[cfg_attr(miri, ignore = "5000 time steps")]
    fn decaying_states_reach_zero_without_a_subnormal_number() {
        let mut e = JointEstimator::new(test_config());
        let nb = e.bank.poles();
        assert!(nb > 0 && e.bank.a[..nb].iter().all(|&a| a > 1e-20 && a < 1.0));
        e.wx[..nb * NS].fill(1.0);
        for _ in 0..5000 {
            e.whitening_time_update();
            for v in e.wx.iter().chain(e.wp.iter()) {
                assert!(!v.is_subnormal(), "{v:e}");
            }
        }
        // The fastest pole's states are 0 by now, exactly.
        let fast = (0..nb)
            .min_by(|&i, &j| e.bank.a[i].total_cmp(&e.bank.a[j]))
            .unwrap();
        assert!(e.wx[fast * NS..(fast + 1) * NS].iter().all(|&x| x == 0.0));
        const { assert!(tuning::FLUSH_BELOW > 1e20 * f64::MIN_POSITIVE) };
    }

    /// A turn row whose white noise is mostly this tick's ω̇ readout noise (lever L)
    /// and whose attitude error that noise drives (lever z), fitted for the amplitude
    /// of a slow sine (as β's regressor, the attitude, turns the SRP): with their
    /// covariance in the gain the fit's σ is honest over seeds, and the fit gains
    /// information; a filter blind to it (L = 0, the same white variance) claims less
    /// and errs less than it claims.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "300 seeds x 3000 steps; update_turn runs under Miri in the_avx2_update_is_the_portable_one_bit_for_bit and tests/miri_capi.rs"
    )]
    fn a_turn_row_sharing_the_readout_noise_is_honest_and_gains_information() {
        let mut cfg = test_config();
        cfg.n_is = 1;
        let template = JointEstimator::new(cfg);
        let dt = 1.0 / template.cfg.fs;
        let sigma = template.cfg.sigma_angular;
        // 90 % of the row's white noise from ω̇'s readout.
        let (z, lever) = (3e7, 0.9 / sigma);
        let v_other = (1.0 - 0.81f64).sqrt();
        let mut gauss = gaussian(0x2545_f491_4f6c_dd1d);
        let (seeds, n) = (300, 3000);
        let mut sum = [[0.0; 2]; 2]; // per filter: Σ (θ̂/σ)², Σ information
        for _ in 0..seeds {
            let mut e = template;
            e.turn_z = [[0.0, 0.0, z]; 2];
            e.turn_lever = [[0.0, 0.0, lever]; 2];
            let mut blind = e;
            blind.turn_lever = [[0.0; 3]; 2];
            let (mut angle, mut rate) = (0.0, 0.0);
            for t in 0..n {
                let noise = sigma * gauss();
                angle += dt * rate + 0.5 * dt * dt * noise;
                rate += dt * noise;
                let mut s = Sig::zeros();
                s[0] = -z * angle - lever * noise + v_other * gauss();
                s[1] = (core::f64::consts::TAU * t as f64 / 1000.0).sin();
                for f in [&mut e, &mut blind] {
                    f.propagate_model(&[[0.0; 3]; 2]);
                    f.update_turn(&s, &[1.0, 1.0]);
                }
            }
            for (acc, f) in sum.iter_mut().zip([&e, &blind]) {
                let (m01, m11) = (f.m_turn[0].get(0, 1), f.m_turn[0].get(1, 1));
                acc[0] += m01 * m01 / m11;
                acc[1] += m11;
            }
        }
        let [shared, blind] = sum.map(|[z2, info]| [z2 / seeds as f64, info / seeds as f64]);
        // (θ̂/σ)²'s mean over 300 seeds scatters by ±0.08 (measured 0.89); the blind
        // filter's σ is 1.7× cautious (0.36) with 3.4× less information.
        assert!((shared[0] - 1.0).abs() < 0.25, "{shared:?}");
        assert!(blind[0] < 0.6, "{blind:?}");
        assert!(shared[1] > 2.0 * blind[1], "{shared:?} {blind:?}");
    }

    /// A symmetric positive-definite 6 × 6 covariance of unequal scales.
    fn cov() -> SMatrix<f64, 6, 6> {
        let b = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 - 2.0);
        let s = SVector::<f64, 6>::from_fn(|i, _| 10f64.powi(i as i32 % 3 - 1));
        let spd = b * b.transpose() + SMatrix::<f64, 6, 6>::identity() * 3.0;
        SMatrix::from_fn(|i, j| spd[(i, j)] * s[i] * s[j])
    }

    #[test]
    fn whitening_rows_make_the_covariance_the_identity() {
        let r = cov();
        let h = SVector::<f64, 6>::from_fn(|i, _| 1.0 + 0.3 * i as f64);
        let (linv, u, hn) = JointEstimator::whitening(&r, &h).unwrap();
        let white = linv * r * linv.transpose();
        assert!((white - SMatrix::<f64, 6, 6>::identity()).abs().max() < 1e-12);
        // u is the unit SRP direction in the whitened space, hn its gain.
        assert!((u.norm() - 1.0).abs() < 1e-14);
        assert!((linv * h - u * hn).norm() < 1e-12 * hn);
    }

    #[test]
    fn complement_rows_are_white_and_blind_to_the_srp() {
        let r = cov();
        let h = SVector::<f64, 6>::from_fn(|i, _| (i as f64 - 2.5).powi(2) + 0.1);
        let (linv, u, _) = JointEstimator::whitening(&r, &h).unwrap();
        let rows = JointEstimator::complement_rows(&linv, &u);
        // The five rows see the white noise as unit and independent ...
        let white = rows * r * rows.transpose();
        assert!((white - SMatrix::<f64, 5, 5>::identity()).abs().max() < 1e-12);
        // ... and nothing of the coloured SRP along h.
        assert!((rows * h).norm() < 1e-12 * (linv * h).norm());
    }

    /// The per-sample update where the CPU has AVX2 (`update_linear`'s `unsafe` call of
    /// `update_linear_avx2`) leaves the state the portable loops leave, bit for bit.
    /// Natively that compares the two compiled paths; under Miri (`tools/miri`'s run
    /// built with `-Ctarget-feature=+avx2,+fma`) it checks the `unsafe` call.
    #[test]
    #[cfg_attr(
        all(miri, not(target_feature = "avx2")),
        ignore = "the AVX2 path needs a build with +avx2 under Miri (tools/miri runs one)"
    )]
    fn the_avx2_update_is_the_portable_one_bit_for_bit() {
        if !super::super::avx2_here() {
            return;
        }
        let mut gauss = gaussian(0x5851_f42d_4c95_7f2d);
        let mut e = JointEstimator::new(test_config());
        let dv = [[1e-3, -2e-3, 5e-4], [1.1e-3, -1.9e-3, 4e-4]];
        let var = [1.0, 1.1, 0.9, 1.2, 0.8, 1.3, 0.7, 1.4];
        let mut sig = || Sig::from_fn(|i, _| (1.0 + i as f64) * gauss());
        e.update_linear_portable(&sig(), &dv, &var);
        let (mut fast, mut portable) = (e, e);
        for _ in 0..2 {
            let s = sig();
            fast.update_linear(&s, &dv, &var);
            portable.update_linear_portable(&s, &dv, &var);
        }
        assert!(fast.m_filt.get(NS - 1, NS - 1).is_finite());
        assert!(bytemuck::bytes_of(&fast) == bytemuck::bytes_of(&portable));
    }

    #[test]
    fn a_deferred_rank_four_update_is_four_rank_one_updates_to_the_bit() {
        // Zeros in some columns (skipped per sample), a −0 in the matrix (where a
        // skipped +0 product would change the bits), and subsets of the samples.
        let vs: [Sig; PEND] = core::array::from_fn(|k| {
            Sig::from_fn(|i, _| {
                let x = [0.5, 0.0, -2.0, 3.25, 1e-3, -0.0, 7.0][(i + 2 * k) % 7];
                x * (1.0 + i as f64) / (1.0 + k as f64)
            })
        });
        let mut m = <Packed as bytemuck::Zeroable>::zeroed();
        for j in 0..NS {
            for (i, x) in m.column_mut(j).iter_mut().enumerate() {
                *x = ((i * 13 + j * 7) % 11) as f64 / 3.0 - 1.0;
            }
        }
        m.column_mut(5)[2] = -0.0;
        for pick in 0..16u32 {
            let take: [bool; PEND] = core::array::from_fn(|k| pick & (1 << k) != 0);
            let mut one_by_one = m;
            for (v, &t) in vs.iter().zip(&take) {
                if t {
                    rank1_packed(&mut one_by_one, v, 1.0);
                }
            }
            let mut at_once = m;
            rank_n(&mut at_once, &vs, take, 1.0);
            for j in 0..NS {
                for i in 0..=j {
                    assert_eq!(
                        at_once.get(i, j).to_bits(),
                        one_by_one.get(i, j).to_bits(),
                        "({i}, {j}), samples {pick:04b}"
                    );
                }
            }
        }
    }

    #[test]
    fn rank1_packed_adds_w_v_v_transposed_to_the_upper_triangle() {
        let v = Sig::from_fn(|i, _| [0.5, 0.0, -2.0, 3.25, 1e-3][i % 5] * (1.0 + i as f64));
        let mut m0 = <Packed as bytemuck::Zeroable>::zeroed();
        for j in 0..NS {
            for (i, x) in m0.column_mut(j).iter_mut().enumerate() {
                *x = (i * NS + j) as f64;
            }
        }
        let mut m = m0;
        rank1_packed(&mut m, &v, 0.75);
        for j in 0..NS {
            for i in 0..NS {
                let want = m0.get(i, j) + v[i] * v[j] * 0.75;
                assert!(
                    (m.get(i, j) - want).abs() < 1e-12 * want.abs().max(1.0),
                    "({i}, {j})"
                );
                assert_eq!(m.get(i, j), m.get(j, i));
            }
        }
        // Column j holds rows 0..=j, one after another.
        assert_eq!(m0.get(2, 5), (2 * NS + 5) as f64);
        assert_eq!(m0.column_mut(NS - 1).len(), NS);
    }
}
