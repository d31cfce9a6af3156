//! Noise generators: white noise of a given ASD and streaming power-law noise built
//! from a bank of first-order (AR(1)) filters. The estimator reuses the bank as the
//! state-space model that whitens the coloured SRP noise.

#[allow(unused_imports)]
use crate::math::{self, Real};
#[cfg(feature = "std")]
use crate::rng::{gauss, Rng};

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
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[cfg_attr(feature = "std", derive(serde::Serialize, serde::Deserialize))]
#[repr(C)]
pub struct PowerLawBank {
    pub n: usize,
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
    /// `psd_exponent` γ: PSD ∝ f^-γ (SRP: γ = 2/3). Lowest corner 10 µHz.
    pub fn new(asd_ref: f64, f_ref: f64, psd_exponent: f64, fs: f64) -> Self {
        let (f_lo, per_decade) = (1.0e-5_f64, 3.0);
        let n = ((math::log10(fs / f_lo) * per_decade).ceil() as usize + 1).min(MAX_POLES);
        let mut b = PowerLawBank {
            n,
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
        (0..self.n)
            .map(|k| {
                let a = self.a[k];
                2.0 * self.s[k] * self.s[k] / self.fs / (1.0 - 2.0 * a * c + a * a)
            })
            .sum()
    }

    #[cfg(feature = "std")]
    /// Draw the state from the stationary distribution (no start-up transient).
    pub fn init_stationary(&mut self, rng: &mut Rng) {
        for k in 0..self.n {
            self.x[k] = self.var[k].sqrt() * gauss(rng);
        }
    }

    #[cfg(feature = "std")]
    /// Output of this sample, then advance one sample.
    pub fn next(&mut self, rng: &mut Rng) -> f64 {
        let mut y = 0.0;
        for k in 0..self.n {
            y += self.x[k];
            self.x[k] = self.a[k] * self.x[k] + self.s[k] * gauss(rng);
        }
        y
    }
}

/// Welch estimate of the one-sided ASD of `x` sampled at `fs`: Hann window, segments of
/// `seg` samples (a power of two is fastest), 50 % overlap. Returns (f, ASD) pairs
/// without the DC bin.
#[cfg(feature = "std")]
pub fn welch_asd(x: &[f64], fs: f64, seg: usize) -> Vec<(f64, f64)> {
    use rustfft::{num_complex::Complex, FftPlanner};
    let seg = seg.min(x.len());
    let fft = FftPlanner::<f64>::new().plan_fft_forward(seg);
    let w: Vec<f64> = (0..seg)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / seg as f64).cos())
        .collect();
    let wss: f64 = w.iter().map(|v| v * v).sum();
    let mut acc = vec![0.0; seg / 2 + 1];
    let mut count = 0;
    let mut buf = vec![Complex::new(0.0, 0.0); seg];
    let mut start = 0;
    while start + seg <= x.len() {
        let mean = x[start..start + seg].iter().sum::<f64>() / seg as f64;
        for i in 0..seg {
            buf[i] = Complex::new((x[start + i] - mean) * w[i], 0.0);
        }
        fft.process(&mut buf);
        for (k, a) in acc.iter_mut().enumerate() {
            *a += buf[k].norm_sqr();
        }
        count += 1;
        start += seg / 2;
    }
    (1..seg / 2)
        .map(|k| {
            (
                k as f64 * fs / seg as f64,
                (2.0 * acc[k] / (count as f64 * fs * wss)).sqrt(),
            )
        })
        .collect()
}

#[cfg(feature = "std")]
/// Mean ASD of a Welch estimate over the band [f0, f1] (power-averaged).
pub fn band_asd(asd: &[(f64, f64)], f0: f64, f1: f64) -> f64 {
    let sel: Vec<f64> = asd
        .iter()
        .filter(|(f, _)| *f >= f0 && *f <= f1)
        .map(|(_, a)| a * a)
        .collect();
    (sel.iter().sum::<f64>() / sel.len().max(1) as f64).sqrt()
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::rng::{stream, Stream};

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

    #[test]
    fn power_law_welch_asd_within_25_percent_from_0_1_mhz_to_0_1_fs() {
        let fs = 10.0;
        let mut b = PowerLawBank::new(1.1e-11, 3e-3, 2.0 / 3.0, fs);
        let mut rng = stream(7, Stream::Srp);
        b.init_stationary(&mut rng);
        let x: Vec<f64> = (0..1usize << 22).map(|_| b.next(&mut rng)).collect();
        let asd = welch_asd(&x, fs, 1 << 18);
        for &(f0, f1) in &[
            (0.9e-4, 1.6e-4),
            (3e-4, 4e-4),
            (1e-3, 1.2e-3),
            (3e-3, 3.5e-3),
            (1e-2, 1.2e-2),
            (0.1, 0.12),
            (0.9, 1.0),
        ] {
            let fc = f64::sqrt(f0 * f1);
            let target = 1.1e-11 * f64::powf(3e-3 / fc, 1.0 / 3.0);
            let got = band_asd(&asd, f0, f1);
            assert!(
                (got / target - 1.0).abs() < 0.25,
                "band {f0}-{f1}: {got:e} vs {target:e}"
            );
        }
    }

    #[test]
    fn white_noise_welch_asd_within_25_percent() {
        let fs = 10.0;
        let asd_target = 3e-15;
        let sigma = white_sigma(asd_target, fs);
        let mut rng = stream(3, Stream::InertialSensor);
        let x: Vec<f64> = (0..1usize << 20).map(|_| sigma * gauss(&mut rng)).collect();
        let asd = welch_asd(&x, fs, 1 << 14);
        for &(f0, f1) in &[(1e-3, 2e-3), (1e-2, 2e-2), (0.1, 0.2), (0.5, 1.0)] {
            let got = band_asd(&asd, f0, f1);
            assert!(
                (got / asd_target - 1.0).abs() < 0.25,
                "band {f0}-{f1}: {got:e}"
            );
        }
    }
}
