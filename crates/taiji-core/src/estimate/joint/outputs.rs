//! Outputs: the estimate message, σ from the Fisher information, and the parameter
//! vectors the bound and the tests use.

use super::*;

impl JointEstimator {
    /// 1σ at `p` without priors, as the solve reports it (`estimate_var`: the Fisher
    /// information of the linear, star-tracker and angular groups). The
    /// Cramér–Rao bound when `p` is the truth and the statistics were accumulated from
    /// noise-free signals.
    /// (Analysis, not flight: its scratch is on the stack.)
    pub fn fisher_sigma(&mut self, p: &Par) -> Option<Par> {
        self.flush_grams();
        let mut w = SolveWork::zeroed();
        self.normal_equations(p, false, &mut w);
        Self::newton_step(&w.n.hm, &w.n.g, &mut w.hs, &mut w.hinv)?;
        Self::estimate_var(&w.hinv).map(|var| var.map(|v| v.max(0.0).sqrt()))
    }

    /// Fit the nuisances (θ0, θ̇0, b', α') with β and r held at their values in `p`,
    /// without priors: the reference point of the Cramér–Rao bound.
    pub fn nuisance_fit(&mut self, mut p: Par) -> Par {
        self.flush_grams();
        let mut w = SolveWork::zeroed();
        for _ in 0..tuning::NUISANCE_ITERATIONS {
            self.normal_equations(&p, false, &mut w);
            let SolveWork { n, hs, hinv, .. } = &mut w;
            let Normal { hm, g, .. } = n;
            for k in P_BETA..P_TH0 {
                for j in 0..NP {
                    hm[(k, j)] = 0.0;
                    hm[(j, k)] = 0.0;
                }
                hm[(k, k)] = 1.0;
                g[k] = 0.0;
            }
            let Some(delta) = Self::newton_step(hm, g, hs, hinv) else {
                break;
            };
            p += delta;
        }
        p
    }

    /// The bound's statistics: every sample will turn the level fixed after the last
    /// (`fix_srp_level_at`), as most of a run's samples turn the level it fixes once its
    /// solution can tell it (`fix_srp_level`). Called before the first sample.
    pub fn level_at_end(&mut self) {
        self.srp_level_set = LEVEL_AT_END;
    }

    /// Turn the SRP level IS1's channels hold at `p` (reference sample plus bias, in
    /// volts) from now on. For the bound: its noise-free statistics never solve, so
    /// never fix the level themselves, and the bound is that of the model a run ends
    /// with.
    pub fn fix_srp_level_at(&mut self, p: &Par) {
        for m in 0..3 {
            self.srp_level[m] = self.sum_ref[0][m] + p[P_B + m];
        }
        self.srp_level_set = LEVEL_SET;
    }

    /// Parameter vector with β, r set (nuisances at their reference values).
    pub fn params_with(&self, beta: &[[f64; 3]; 2], r: &[[f64; 3]; 2]) -> Par {
        let mut p = self.p_prior;
        for i in 0..2 {
            for a in 0..3 {
                p[P_BETA + 3 * i + a] = beta[i][a];
                p[P_R + 3 * i + a] = r[i][a];
            }
        }
        p
    }

    /// The estimate message from the current solution (it counts itself: the next
    /// one's sequence number follows).
    pub fn message(&mut self, tick: u64) -> EstimateMsg {
        let m = self.message_unsent(tick);
        self.seq += 1;
        m
    }

    /// [`Self::message`] without counting it (the state is only read); `message_sent`
    /// counts it.
    pub fn message_unsent(&self, tick: u64) -> EstimateMsg {
        let mut m = EstimateMsg {
            header: Header::at(self.seq, tick, self.cfg.fs),
            ..Default::default()
        };
        Self::fill(&self.cfg, &self.p, &self.sigma, &mut m);
        m.solved_tick = self.solved_tick;
        m.n_used = self.n_used;
        m.n_rejected = self.n_rejected;
        let ticks = self.n_used + self.n_rejected;
        // Samples whose tick was off the timeline are not ticks: they count against
        // the ticks taken (a clock that jumped for good soon outnumbers them; one wild
        // tick early on is outgrown).
        let degraded = self.n_rejected * self.cfg.degraded_one_in > ticks
            || self.causes[CAUSE_TICK_JUMP] * self.cfg.degraded_one_in > ticks.max(1)
            || self.causes[CAUSE_STAR_OUTLIER] * self.cfg.degraded_one_in > self.n_star.max(1);
        m.status = self.status | if degraded { ST_DEGRADED } else { 0 };
        m.rejected_by_cause = self.causes;
        m.tick_rejections = self.tick_mask;
        m.chi2_per_dof = self.chi2;
        m.sigma_inflation = self.inflation;
        m
    }

    /// Counts a message made by [`Self::message_unsent`].
    pub fn message_sent(&mut self) {
        self.seq += 1;
    }

    /// β, k, r and their σ from a parameter vector and its 1σ.
    pub fn fill(cfg: &EstimatorConfig, p: &Par, sigma: &Par, m: &mut EstimateMsg) {
        for i in 0..cfg.n_is.min(2) as usize {
            for a in 0..3 {
                m.beta[i][a] = p[P_BETA + 3 * i + a];
                m.beta_sigma[i][a] = sigma[P_BETA + 3 * i + a];
                m.r_b[i][a] = p[P_R + 3 * i + a];
                m.r_sigma[i][a] = sigma[P_R + 3 * i + a];
            }
            for j in 0..3 {
                let g = cfg.geometry_m[i][PERM[j]];
                m.k[i][j] = g * m.beta[i][PERM[j]];
                m.k_sigma[i][j] = g * m.beta_sigma[i][PERM[j]];
            }
        }
    }
}
