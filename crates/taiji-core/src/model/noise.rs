//! Noise generators: white noise of a given ASD and streaming power-law noise built
//! from a bank of first-order (AR(1)) filters. The estimator reuses the bank as the
//! state-space model that whitens the coloured SRP noise.

// Unused where std is linked anywhere in the build (the std binaries, unit tests):
// std's inherent f64 methods then win for these exact operations, with the same bits.
#[allow(unused_imports)]
use crate::math::{self, Real};

/// Standard deviation of one sample of white noise with one-sided ASD `asd`
/// sampled (as interval means) at `fs` [Hz]: σ = ASD √(fs/2).
pub fn white_sigma(asd: f64, fs: f64) -> f64 {
    asd * (0.5 * fs).sqrt()
}

/// Most poles a bank may have (three per decade from 10 µHz to 100 kHz).
pub const MAX_POLES: usize = 32;

/// Streaming power-law noise, ASD(f) = asd_ref (f_ref / f)^(γ/2), as the sum of AR(1)
/// processes with log-spaced corners (3 per decade) and weights ∝ f_k^(1-γ), the
/// continuous-time construction that makes a sum of Lorentzians follow f^-γ.
#[derive(
    Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable, serde::Serialize, serde::Deserialize,
)]
#[repr(C)]
pub struct PowerLawBank {
    /// Poles in use (u64, not usize: the same layout on 32- and 64-bit targets).
    pub n: u64,
    /// AR(1) coefficients a_k = exp(−2π f_k / fs).
    pub a: [f64; MAX_POLES],
    /// Innovation standard deviation per pole, per sample.
    pub s: [f64; MAX_POLES],
    /// Stationary variance per pole.
    pub var: [f64; MAX_POLES],
    pub x: [f64; MAX_POLES],
    pub fs: f64,
}

impl PowerLawBank {
    /// Poles in use, never more than `MAX_POLES` (whatever `n` holds).
    pub fn poles(&self) -> usize {
        (self.n as usize).min(MAX_POLES)
    }

    /// `psd_exponent` γ: PSD ∝ f^-γ (SRP: γ = 2/3). Lowest corner 10 µHz.
    pub fn new(asd_ref: f64, f_ref: f64, psd_exponent: f64, fs: f64) -> Self {
        let (f_lo, per_decade) = (1.0e-5_f64, 3.0);
        let n = ((math::log10(fs / f_lo) * per_decade).ceil() as usize + 1).min(MAX_POLES);
        let mut b = PowerLawBank {
            n: n as u64,
            a: [0.0; MAX_POLES],
            s: [0.0; MAX_POLES],
            var: [0.0; MAX_POLES],
            x: [0.0; MAX_POLES],
            fs,
        };
        for k in 0..n {
            let fk = f_lo * math::powf(10.0, k as f64 / per_decade);
            let a = math::exp(-2.0 * core::f64::consts::PI * fk / fs);
            let v = math::powf(fk, 1.0 - psd_exponent);
            b.a[k] = a;
            b.var[k] = v;
            b.s[k] = (v * (1.0 - a * a)).sqrt();
        }
        // Scale so the model PSD matches the target in the log-mean over the band of use.
        let (mut acc, mut m) = (0.0, 0);
        let mut f = 1.0e-4;
        while f <= 0.1 * fs {
            let target = asd_ref * asd_ref * math::powf(f_ref / f, psd_exponent);
            acc += math::ln(target / b.psd(f));
            m += 1;
            f *= 1.1;
        }
        let scale = math::exp(acc / m as f64);
        for k in 0..n {
            b.var[k] *= scale;
            b.s[k] *= scale.sqrt();
        }
        b
    }

    /// One-sided PSD of the bank's output at `f` [Hz] (exact for the discrete process).
    pub fn psd(&self, f: f64) -> f64 {
        let c = math::cos(2.0 * core::f64::consts::PI * f / self.fs);
        (0..self.poles())
            .map(|k| {
                let a = self.a[k];
                2.0 * self.s[k] * self.s[k] / self.fs / (1.0 - 2.0 * a * c + a * a)
            })
            .sum()
    }

    /// Draw the state from the stationary distribution (no start-up transient);
    /// `gauss` gives unit normal deviates (the simulation's random stream).
    pub fn init_stationary_with(&mut self, mut gauss: impl FnMut() -> f64) {
        for k in 0..self.poles() {
            self.x[k] = self.var[k].sqrt() * gauss();
        }
    }

    /// Output of this sample, then advance one sample, driven by unit normal deviates.
    pub fn next_with(&mut self, mut gauss: impl FnMut() -> f64) -> f64 {
        let mut y = 0.0;
        for k in 0..self.poles() {
            y += self.x[k];
            self.x[k] = self.a[k] * self.x[k] + self.s[k] * gauss();
        }
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bank_psd_follows_the_power_law_within_8_percent() {
        let b = PowerLawBank::new(1.1e-11, 3e-3, 2.0 / 3.0, 10.0);
        let mut f: f64 = 1e-4;
        while f <= 0.5 {
            let target: f64 = 1.1e-11 * (3e-3 / f).powf(1.0 / 3.0);
            let asd = b.psd(f).sqrt();
            assert!(
                (asd / target - 1.0).abs() < 0.08,
                "f = {f}: {asd} vs {target}"
            );
            f *= 1.3;
        }
    }
}
