//! Rigid-body attitude dynamics (docs/physics.md): I ω̇ + ω × (I ω) = τ, q̇ = ½ q ⊗ (0, ω).

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Spacecraft attitude state, integrated with RK4 for piecewise-constant torque.
#[derive(Debug, Clone, Copy)]
pub struct RigidBody {
    /// Inertia tensor, body frame [kg m²].
    pub inertia: Matrix3<f64>,
    inertia_inv: Matrix3<f64>,
    /// Attitude of the body frame B relative to inertial N (vector in B → in N).
    pub q_bn: UnitQuaternion<f64>,
    /// Angular velocity of B relative to N, in B [rad/s].
    pub omega_b: Vector3<f64>,
}

impl RigidBody {
    /// At rest, aligned with the inertial frame. `inertia` must be positive definite.
    pub fn new(inertia: Matrix3<f64>) -> Self {
        let inertia_inv = inertia
            .try_inverse()
            .expect("inertia validated positive definite");
        RigidBody {
            inertia,
            inertia_inv,
            q_bn: UnitQuaternion::identity(),
            omega_b: Vector3::zeros(),
        }
    }

    /// Euler's equation: ω̇ = I⁻¹ (τ − ω × I ω) [rad/s²].
    #[inline(always)]
    pub fn omega_dot(&self, omega: &Vector3<f64>, torque: &Vector3<f64>) -> Vector3<f64> {
        self.inertia_inv * (torque - omega.cross(&(self.inertia * omega)))
    }

    /// q̇ = ½ q ⊗ (0, ω): nalgebra's product written out without the terms of the zero
    /// scalar part, which change no bit of the attitude (they only add ±0; a zero
    /// component of q stays +0 whatever the sign of a zero rate).
    #[inline(always)]
    fn q_dot(q: &Quaternion<f64>, omega: &Vector3<f64>) -> Quaternion<f64> {
        let (w, x, y, z) = (q.w, q.i, q.j, q.k);
        let (p, r, s) = (omega.x, omega.y, omega.z);
        Quaternion::new(
            -(x * p) - y * r - z * s,
            w * p + y * s - z * r,
            w * r - x * s + z * p,
            w * s + x * r - y * p,
        ) * 0.5
    }

    /// Advance by `h` seconds under constant body torque `torque` [N m] (classic RK4).
    #[inline(always)]
    pub fn step(&mut self, torque: &Vector3<f64>, h: f64) {
        let q0 = *self.q_bn.quaternion();
        let w0 = self.omega_b;
        let k1q = Self::q_dot(&q0, &w0);
        let k1w = self.omega_dot(&w0, torque);
        let q2 = q0 + k1q * (0.5 * h);
        let w2 = w0 + k1w * (0.5 * h);
        let k2q = Self::q_dot(&q2, &w2);
        let k2w = self.omega_dot(&w2, torque);
        let q3 = q0 + k2q * (0.5 * h);
        let w3 = w0 + k2w * (0.5 * h);
        let k3q = Self::q_dot(&q3, &w3);
        let k3w = self.omega_dot(&w3, torque);
        let q4 = q0 + k3q * h;
        let w4 = w0 + k3w * h;
        let k4q = Self::q_dot(&q4, &w4);
        let k4w = self.omega_dot(&w4, torque);
        let q = q0 + (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
        self.omega_b = w0 + (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
        self.q_bn = UnitQuaternion::from_quaternion(q);
    }

    /// Angular momentum in the inertial frame [N m s].
    pub fn angular_momentum_n(&self) -> Vector3<f64> {
        self.q_bn * (self.inertia * self.omega_b)
    }

    /// Rotational kinetic energy [J].
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.omega_b.dot(&(self.inertia * self.omega_b))
    }
}

/// A(ω, ω̇) r ≡ ω̇ × r + ω × (ω × r) (eq. 16): TM acceleration from the CoM offset [m/s²].
#[inline(always)]
pub fn coupling_acceleration(
    omega: &Vector3<f64>,
    omega_dot: &Vector3<f64>,
    r: &Vector3<f64>,
) -> Vector3<f64> {
    omega_dot.cross(r) + omega.cross(&omega.cross(r))
}

/// The matrix A(ω, ω̇) of eq. 16, so that A r = ω̇ × r + ω × (ω × r).
pub fn coupling_matrix(w: &Vector3<f64>, wd: &Vector3<f64>) -> Matrix3<f64> {
    let (wx, wy, wz) = (w.x, w.y, w.z);
    Matrix3::new(
        -(wy * wy + wz * wz),
        wx * wy - wd.z,
        wx * wz + wd.y,
        wx * wy + wd.z,
        -(wx * wx + wz * wz),
        wy * wz - wd.x,
        wx * wz - wd.y,
        wy * wz + wd.x,
        -(wx * wx + wy * wy),
    )
}

/// Small-angle rotation vector of a unit quaternion (log map) [rad].
/// Uses atan2, accurate for tiny angles (acos of the scalar part loses digits).
pub fn rotation_vector(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = q.quaternion();
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let n = v.norm();
    if n < 1e-300 {
        return Vector3::zeros();
    }
    v * (2.0 * crate::math::atan2(n, w) / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inertia() -> Matrix3<f64> {
        Matrix3::new(1000.0, 5.0, -3.0, 5.0, 1100.0, 4.0, -3.0, 4.0, 900.0)
    }

    #[test]
    fn torque_free_body_conserves_momentum_and_energy_over_1e4_s() {
        let mut b = RigidBody::new(inertia());
        b.omega_b = Vector3::new(0.01, -0.02, 0.015);
        let (h0, e0) = (b.angular_momentum_n(), b.kinetic_energy());
        // 10⁴ s natively; 1 s under Miri (interpreted, 10⁶ times slower).
        for _ in 0..if cfg!(miri) { 100 } else { 1_000_000 } {
            b.step(&Vector3::zeros(), 0.01);
        }
        let (h1, e1) = (b.angular_momentum_n(), b.kinetic_energy());
        assert!(
            (h1 - h0).norm() / h0.norm() < 1e-9,
            "momentum drift {}",
            (h1 - h0).norm() / h0.norm()
        );
        assert!(
            (e1 - e0).abs() / e0 < 1e-9,
            "energy drift {}",
            (e1 - e0).abs() / e0
        );
    }

    #[test]
    fn constant_torque_from_rest_matches_closed_form() {
        // Diagonal inertia, torque on a principal axis: ω = τ t / I, θ = τ t² / (2 I).
        let mut b = RigidBody::new(Matrix3::from_diagonal(&Vector3::new(1000.0, 1100.0, 900.0)));
        let tau = Vector3::new(0.0, 0.0, 2.5e-6);
        // 500 s natively; 1 s under Miri (interpreted, 10⁶ times slower).
        let (h, n) = (0.01, if cfg!(miri) { 100 } else { 50_000 });
        for _ in 0..n {
            b.step(&tau, h);
        }
        let t = h * n as f64;
        let w = tau.z * t / 900.0;
        let theta = tau.z * t * t / (2.0 * 900.0);
        assert!((b.omega_b.z - w).abs() < 1e-12 * w.abs().max(1e-30) + 1e-18);
        let rv = rotation_vector(&b.q_bn);
        assert!(
            (rv.z - theta).abs() < 1e-10 * theta,
            "{} vs {}",
            rv.z,
            theta
        );
        assert!(rv.x.abs() < 1e-15 && rv.y.abs() < 1e-15);
    }

    #[test]
    fn q_dot_is_the_quaternion_product() {
        let vals = [0.0, -0.0, 1.0, -0.75, 3.2e-7, -1.1e-9, 0.999_999_999_9];
        let mut n = 0;
        for (i, &w) in vals.iter().enumerate() {
            for &x in &vals[i..] {
                for &y in &vals {
                    for &p in &vals {
                        let q = Quaternion::new(w, x, y, -p);
                        let om = Vector3::new(p, -y, x * 0.5);
                        let full = q * Quaternion::from_parts(0.0, om) * 0.5;
                        let ours = RigidBody::q_dot(&q, &om);
                        // Equal, ±0 aside.
                        assert_eq!(ours.coords, full.coords, "{q:?} {om:?}");
                        n += 1;
                    }
                }
            }
        }
        assert!(n > 1000);
    }

    #[test]
    fn coupling_matrix_equals_cross_product_form() {
        let w = Vector3::new(1.3e-6, -0.7e-6, 2.1e-6);
        let wd = Vector3::new(2.5e-9, -1.1e-9, 0.4e-9);
        for r in [
            Vector3::new(0.2164, -0.1251, 0.0002),
            Vector3::new(-0.3, 0.05, 0.2),
        ] {
            let a = coupling_matrix(&w, &wd) * r;
            let b = coupling_acceleration(&w, &wd, &r);
            assert!((a - b).norm() < 1e-12 * b.norm());
        }
    }
}
