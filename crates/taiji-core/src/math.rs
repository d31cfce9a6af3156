//! Floating-point functions of the core, from libm in every build: the `no_std`
//! library behind the C ABI and the std binaries then compute bit-identical results
//! (the platform's `exp` or `powf` may differ from libm's in the last bit).
//!
//! `Real` gives `f64` the methods `std` would, under the same names, so the maths
//! reads as usual. Where std is linked anywhere in the build (the std binaries, unit
//! tests), its inherent methods win for these exact operations (`sqrt`, `round`,
//! `ceil`; a test checks they agree bit for bit); the no_std builds (the C library,
//! bare metal) run these. The transcendental functions are called through this
//! module's functions explicitly, so every build runs libm's.

/// Methods `core` lacks on `f64`; exact operations only (identical in every build).
pub trait Real: Sized {
    fn sqrt(self) -> Self;
    fn round(self) -> Self;
    fn ceil(self) -> Self;
    fn floor(self) -> Self;
    /// Integer power by repeated multiplication (`powi(2)` is exactly x·x).
    fn powi(self, n: i32) -> Self;
}

impl Real for f64 {
    #[inline]
    fn sqrt(self) -> f64 {
        libm::sqrt(self)
    }
    #[inline]
    fn round(self) -> f64 {
        libm::round(self)
    }
    #[inline]
    fn ceil(self) -> f64 {
        libm::ceil(self)
    }
    #[inline]
    fn floor(self) -> f64 {
        libm::floor(self)
    }
    #[inline]
    fn powi(self, n: i32) -> f64 {
        let mut r = 1.0;
        for _ in 0..n.unsigned_abs() {
            r *= self;
        }
        if n < 0 {
            1.0 / r
        } else {
            r
        }
    }
}

#[inline]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}
#[inline]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}
#[inline]
pub fn log10(x: f64) -> f64 {
    libm::log10(x)
}
#[inline]
pub fn powf(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}
#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}
#[inline]
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn powi_is_repeated_multiplication() {
        let x = 1.234_567_891_f64;
        assert_eq!(Real::powi(x, 2), x * x);
        assert_eq!(Real::powi(x, 3), x * x * x);
        assert_eq!(Real::powi(x, -1), 1.0 / x);
        assert_eq!(Real::powi(x, 0), 1.0);
    }

    #[test]
    fn exact_functions_agree_with_the_platform() {
        for &x in &[0.0, 1e-300, 2.0, 3.3, 1e300, 0.5, 2.5, -2.5] {
            assert_eq!(Real::sqrt(x).to_bits(), f64::sqrt(x).to_bits());
            assert_eq!(Real::round(x).to_bits(), f64::round(x).to_bits());
            assert_eq!(Real::ceil(x).to_bits(), f64::ceil(x).to_bits());
        }
    }
}
