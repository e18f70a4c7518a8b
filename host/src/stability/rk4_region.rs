//! RK4's stability region, and the largest substep that keeps a set of damped modes inside it.
//!
//! One mode of the linearised cloth, x'' + gamma x' + omega^2 x = 0, has eigenvalues `lambda`
//! with lambda^2 + gamma lambda + omega^2 = 0. RK4 multiplies it by
//! R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 per substep, z = h lambda, and is stable iff |R(z)| <= 1.
//! The region reaches 2*sqrt(2) along the imaginary axis (an undamped spring), 2.785 along the
//! negative real axis (an overdamped one) and bulges to ~2.94 between them (a lightly damped
//! one), so one radius for all modes wastes up to 5% of the substep; this module finds where
//! each mode's ray `h lambda` leaves the region instead.

/// A complex number, as much of one as the region test needs.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Complex {
    re: f64,
    im: f64,
}

impl Complex {
    fn mul(self, o: Complex) -> Complex {
        Complex { re: self.re * o.re - self.im * o.im, im: self.re * o.im + self.im * o.re }
    }
    fn scale(self, s: f64) -> Complex {
        Complex { re: self.re * s, im: self.im * s }
    }
    fn norm(self) -> f64 {
        self.re.hypot(self.im)
    }
}

/// |R(z)| for classical RK4, by Horner: 1 + z (1 + z/2 (1 + z/3 (1 + z/4))).
fn rk4_amplification(z: Complex) -> f64 {
    let mut acc = Complex { re: 1.0, im: 0.0 };
    for k in [4.0, 3.0, 2.0, 1.0] {
        let t = z.scale(1.0 / k).mul(acc);
        acc = Complex { re: 1.0 + t.re, im: t.im };
    }
    acc.norm()
}

/// The eigenvalues of one damped mode (one or two; a complex pair is represented by the one with
/// positive imaginary part, the region being symmetric about the real axis).
fn mode_eigenvalues(omega: f64, gamma: f64) -> [Complex; 2] {
    let disc = gamma * gamma / 4.0 - omega * omega;
    if disc >= 0.0 {
        let root = disc.sqrt();
        [Complex { re: -gamma / 2.0 - root, im: 0.0 }, Complex { re: -gamma / 2.0 + root, im: 0.0 }]
    } else {
        let z = Complex { re: -gamma / 2.0, im: (-disc).sqrt() };
        [z, z]
    }
}

/// The first h at which `h lambda` leaves RK4's region (infinite for lambda = 0): marched in
/// steps of 1/256 of the region's size, then bisected to f64 precision.
fn first_exit(lambda: Complex) -> f64 {
    let size = lambda.norm();
    if size == 0.0 {
        return f64::INFINITY;
    }
    let unit = lambda.scale(1.0 / size);
    let inside = |r: f64| rk4_amplification(unit.scale(r)) <= 1.0;
    // The region lies within |z| < 3; march out from the origin to the first point outside.
    let step = 3.0 / 256.0;
    let mut r = step;
    while r < 3.5 && inside(r) {
        r += step;
    }
    let (mut lo, mut hi) = (r - step, r);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if inside(mid) { lo = mid } else { hi = mid }
    }
    lo / size
}

/// Modes sampled per axis of the (omega, gamma) rectangle.
const SAMPLES: u32 = 48;

/// Largest substep for which every mode with angular frequency up to `omega_max` and damping
/// rate up to `gamma_max` stays inside RK4's stability region. The two maxima need not belong to
/// the same mode (spring damping and velocity damping have other modes than the stiffness), so
/// the whole rectangle [0, omega_max] x [0, gamma_max] is sampled.
pub fn rk4_max_substep(omega_max: f64, gamma_max: f64) -> f64 {
    let mut h = f64::INFINITY;
    for i in 0..=SAMPLES {
        let omega = omega_max * i as f64 / SAMPLES as f64;
        for j in 0..=SAMPLES {
            let gamma = gamma_max * j as f64 / SAMPLES as f64;
            for lambda in mode_eigenvalues(omega, gamma) {
                h = h.min(first_exit(lambda));
            }
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_limits_of_the_region() {
        // Undamped: the imaginary-axis limit 2 sqrt(2).
        assert!((rk4_max_substep(1.0, 0.0) - 8f64.sqrt()).abs() < 1e-9);
        // Pure damping: the real-axis limit 2.7853.
        assert!((rk4_max_substep(0.0, 1.0) - 2.785_293_563).abs() < 1e-6);
        // Units: twice the frequency, half the substep.
        assert!((rk4_max_substep(2.0, 0.0) - 8f64.sqrt() / 2.0).abs() < 1e-9);
    }

    #[test]
    fn a_substep_inside_the_bound_never_amplifies() {
        for (omega, gamma) in [(1000.0, 0.0), (1000.0, 300.0), (1000.0, 3000.0), (50.0, 900.0)] {
            let h = rk4_max_substep(omega, gamma);
            for i in 0..=40 {
                for j in 0..=40 {
                    for lambda in mode_eigenvalues(omega * i as f64 / 40.0, gamma * j as f64 / 40.0) {
                        let a = rk4_amplification(lambda.scale(h * 0.999));
                        assert!(a <= 1.0 + 1e-12, "omega {omega} gamma {gamma}: |R| {a}");
                    }
                }
            }
            // And just past it some mode grows.
            let grows = (0..=SAMPLES).any(|i| {
                (0..=SAMPLES).any(|j| {
                    mode_eigenvalues(omega * i as f64 / SAMPLES as f64, gamma * j as f64 / SAMPLES as f64)
                        .iter()
                        .any(|l| rk4_amplification(l.scale(h * 1.001)) > 1.0)
                })
            });
            assert!(grows, "omega {omega} gamma {gamma}: the bound is not tight");
        }
    }
}
