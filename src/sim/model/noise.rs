//! Noise generators of the simulation: the flight core's power-law bank
//! (`taiji_core::model::noise`) driven by the simulation's random streams, and the Welch
//! ASD estimate the tests and figures measure noise with.

pub use taiji_core::model::noise::*;

use crate::sim::rng::{gauss, Rng};

/// Drawing a bank's noise from one of the simulation's random streams.
pub trait Generate {
    /// Draw the state from the stationary distribution (no start-up transient).
    fn init_stationary(&mut self, rng: &mut Rng);
    /// Output of this sample, then advance one sample.
    fn next(&mut self, rng: &mut Rng) -> f64;
}

impl Generate for PowerLawBank {
    fn init_stationary(&mut self, rng: &mut Rng) {
        self.init_stationary_with(|| gauss(rng));
    }

    fn next(&mut self, rng: &mut Rng) -> f64 {
        self.next_with(|| gauss(rng))
    }
}

/// Welch estimate of the one-sided ASD of `x` sampled at `fs`: Hann window, segments of
/// `seg` samples (a power of two is fastest), 50 % overlap. Returns (f, ASD) pairs
/// without the DC bin.
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

/// Mean ASD of a Welch estimate over the band [f0, f1] (power-averaged).
pub fn band_asd(asd: &[(f64, f64)], f0: f64, f1: f64) -> f64 {
    let sel: Vec<f64> = asd
        .iter()
        .filter(|(f, _)| *f >= f0 && *f <= f1)
        .map(|(_, a)| a * a)
        .collect();
    (sel.iter().sum::<f64>() / sel.len().max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng::{stream, Stream};
    use taiji_core::tuning::{SRP_PSD_EXPONENT, SRP_REF_HZ};

    #[test]
    fn power_law_welch_asd_within_25_percent_from_0_1_mhz_to_0_1_fs() {
        let fs = 10.0;
        let mut b = PowerLawBank::new(1.1e-11, SRP_REF_HZ, SRP_PSD_EXPONENT, fs);
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
