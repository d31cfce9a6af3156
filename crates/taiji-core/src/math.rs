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

/// Inverse of a small square matrix by LU with partial pivoting; `None` when a pivot
/// is zero. The same operations in the same order as nalgebra's `try_inverse` for
/// sizes above 4 (so the same bits), without its shape assertions and index checks:
/// every index here is a loop bound the compiler sees, so no panic path is linked.
pub fn lu_inverse<const N: usize>(
    m: &nalgebra::SMatrix<f64, N, N>,
) -> Option<nalgebra::SMatrix<f64, N, N>> {
    let mut a = [[0.0f64; N]; N];
    let mut out = [[0.0f64; N]; N];
    for r in 0..N {
        for c in 0..N {
            a[r][c] = m[(r, c)];
        }
        out[r][r] = 1.0;
    }
    for i in 0..N {
        // The first of the largest |a[r][i]|, r ≥ i (a NaN is never the largest).
        let mut piv = i;
        let mut max = a[i][i].abs();
        for (r, row) in a.iter().enumerate().skip(i + 1) {
            if row[i].abs() > max {
                max = row[i].abs();
                piv = r;
            }
        }
        let piv = piv.min(N - 1);
        let diag = a[piv][i];
        if diag == 0.0 {
            return None;
        }
        if piv != i {
            out.swap(i, piv);
            // The row swap of L's columns, the pivot column and the rest alike.
            a.swap(i, piv);
        }
        let inv_diag = 1.0 / diag;
        for r in i + 1..N {
            a[r][i] *= inv_diag;
        }
        for c in i + 1..N {
            let p = a[i][c];
            for r in i + 1..N {
                a[r][c] += -p * a[r][i];
            }
        }
    }
    // L (unit diagonal) then U, column by column of the identity.
    for c in 0..N {
        for i in 0..N {
            let coeff = out[i][c];
            for r in i + 1..N {
                out[r][c] += -coeff * a[r][i];
            }
        }
        for i in (0..N).rev() {
            let coeff = out[i][c] / a[i][i];
            out[i][c] = coeff;
            for r in 0..i {
                out[r][c] += -coeff * a[r][i];
            }
        }
    }
    Some(nalgebra::SMatrix::<f64, N, N>::from_fn(|r, c| out[r][c]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same bits as nalgebra's `try_inverse` (LU for sizes above 4), pivoting
    /// included, on random, badly scaled, triangular and singular matrices.
    #[test]
    #[cfg_attr(
        miri,
        ignore = "2000 inverses against nalgebra's LU; lu_inverse runs under Miri in every update's whitening (tests/miri_capi.rs)"
    )]
    fn lu_inverse_is_nalgebras_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        for case in 0..2000 {
            let m = nalgebra::SMatrix::<f64, 6, 6>::from_fn(|r, c| {
                let x: f64 = rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-8..8));
                match case % 4 {
                    1 if r < c => 0.0,
                    2 if r == 3 => 0.0,
                    _ => x,
                }
            });
            let ours = lu_inverse(&m);
            let theirs = m.try_inverse();
            assert_eq!(ours.is_some(), theirs.is_some(), "case {case}");
            if let (Some(a), Some(b)) = (ours, theirs) {
                for (x, y) in a.iter().zip(b.iter()) {
                    assert_eq!(x.to_bits(), y.to_bits(), "case {case}");
                }
            }
        }
    }

    #[test]
    fn powi_is_repeated_multiplication() {
        let x = 1.234_567_891_f64;
        assert_eq!(Real::powi(x, 2), x * x);
        assert_eq!(Real::powi(x, 3), x * x * x);
        assert_eq!(Real::powi(x, -1), 1.0 / x);
        assert_eq!(Real::powi(x, 0), 1.0);
    }

    /// The same bits, but for a NaN's sign and payload, which Rust leaves unspecified
    /// (Miri draws them at random: `sqrt(-2.5)` there differs in its sign bit).
    #[test]
    fn exact_functions_agree_with_the_platform() {
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for &x in &[
            0.0,
            -0.0,
            1e-300,
            2.0,
            3.3,
            1e300,
            0.5,
            2.5,
            -2.5,
            f64::INFINITY,
        ] {
            assert!(same(Real::sqrt(x), f64::sqrt(x)), "sqrt {x}");
            assert!(same(Real::round(x), f64::round(x)), "round {x}");
            assert!(same(Real::ceil(x), f64::ceil(x)), "ceil {x}");
        }
    }
}
