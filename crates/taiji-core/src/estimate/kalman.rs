//! Static-state Kalman filter (Φ = I, eq. 3–9) with the Joseph-form covariance update
//! P = (I − K H) P (I − K H)ᵀ + K R Kᵀ (eq. 9 of the paper has a typo).

// Unused where std is linked anywhere in the build (the std binaries, unit tests):
// std's inherent f64 methods then win for these exact operations, with the same bits.
#[allow(unused_imports)]
use crate::math::Real;
use nalgebra::{SMatrix, SVector};

#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct StaticKf<const N: usize> {
    pub x: SVector<f64, N>,
    pub p: SMatrix<f64, N, N>,
}

impl<const N: usize> StaticKf<N> {
    pub fn new(x0: SVector<f64, N>, p0: SMatrix<f64, N, N>) -> Self {
        StaticKf { x: x0, p: p0 }
    }

    /// Scalar measurement y = h·x + v, var(v) = r.
    pub fn update(&mut self, h: &SVector<f64, N>, y: f64, r: f64) {
        let ph = self.p * h;
        let s = h.dot(&ph) + r;
        if !(s.is_finite() && s > 0.0) {
            return;
        }
        let k = ph / s;
        self.x += k * (y - h.dot(&self.x));
        let ikh = SMatrix::<f64, N, N>::identity() - k * h.transpose();
        self.p = ikh * self.p * ikh.transpose() + k * k.transpose() * r;
    }

    pub fn sigma(&self, i: usize) -> f64 {
        self.p[(i, i)].max(0.0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng as _, SeedableRng};

    #[test]
    #[cfg_attr(
        miri,
        ignore = "5000 updates, and nalgebra's own cholesky, which breaks Stacked Borrows (dimforge/nalgebra#1520); no unsafe of ours"
    )]
    fn static_kf_converges_to_batch_least_squares() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut gauss = move || -> f64 { rng.sample(rand_distr::StandardNormal) };
        let truth = SVector::<f64, 3>::new(1.5, -0.3, 2.0);
        let p0 = 1e4;
        let mut kf = StaticKf::new(SVector::zeros(), SMatrix::identity() * p0);
        // Batch least squares in information form, with the filter's (weak) prior.
        let (mut ata, mut atb) = (
            SMatrix::<f64, 3, 3>::identity() * (0.01 / p0),
            SVector::<f64, 3>::zeros(),
        );
        for n in 0..5000 {
            let t = n as f64 * 0.01;
            let h = SVector::<f64, 3>::new(1.0, t, (0.7 * t).sin());
            let y = h.dot(&truth) + 0.1 * gauss();
            kf.update(&h, y, 0.01);
            ata += h * h.transpose();
            atb += h * y;
        }
        let ls = ata.cholesky().unwrap().solve(&atb);
        assert!((kf.x - ls).norm() < 1e-9 * ls.norm(), "{} vs {}", kf.x, ls);
        assert!((kf.x - truth).norm() < 0.05);
        let cov = ata.try_inverse().unwrap() * 0.01;
        for i in 0..3 {
            assert!((kf.sigma(i) / cov[(i, i)].sqrt() - 1.0).abs() < 1e-6);
        }
    }
}
