//! Explicit-integration stability bound (design.md §1) and the automatic substep count.
//!
//! A particle's springs give the linearised system x'' = -(K/m) x - (C/m) x'. Gershgorin's
//! theorem bounds the largest eigenvalue of K/m by twice a particle's summed stiffness over its
//! mass: `omega_max^2 = 2 * sum(k) / m`, and likewise the damping rate
//! `gamma_max = (2 * sum(c_s) + c_d) / m`. A mode's eigenvalue has |lambda| = omega when it is
//! underdamped and at most gamma when overdamped, so |lambda| <= max(omega_max, gamma_max).
//! - RK4 is stable inside a region that contains the left half-disc of radius 2.78 (its real-axis
//!   limit is 2.785, its imaginary-axis limit 2*sqrt(2)): `h <= 2.78 / max(omega, gamma)`.
//! - Semi-implicit Euler on one damped mode is stable iff `h^2 omega^2 + 2 h gamma < 4`.
//!
//! Gershgorin over-estimates omega_max, so the bound is conservative: runs at the bound are
//! stable (tests/cloth.rs sweeps this) and blow-up starts at a few times the bound.

use crate::cloth::Cloth;
use drape_kernels::cloth::SPRINGS;
use drape_types::{SimParams, integrator};

/// Radius of the left half-disc inside RK4's stability region.
pub const RK4_STABILITY_RADIUS: f32 = 2.78;

/// Default fraction of the stability bound that automatic substeps use.
pub const DEFAULT_SAFETY: f32 = 0.9;

/// The stability figures of a cloth at a given substep.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Stability {
    /// Upper bound on the stiffest mode's angular frequency (rad/s).
    pub omega_max: f32,
    /// Upper bound on the damping rate (1/s).
    pub gamma_max: f32,
    /// Largest stable substep (s).
    pub max_substep: f32,
    /// Chosen substep (s) and count per frame.
    pub substep: f32,
    pub substeps: u32,
    /// substep / max_substep (> 1 means the run may blow up).
    pub ratio: f32,
}

/// omega_max and gamma_max for a cloth's parameters (interior particle: 4 springs per family).
pub fn spectral_bounds(p: &SimParams) -> (f32, f32) {
    let k_sum: f32 = SPRINGS.iter().map(|s| drape_kernels::cloth::stiffness(p, s.family)).sum();
    let c_sum = SPRINGS.len() as f32 * p.spring_damping;
    let omega = (2.0 * k_sum / p.particle_mass).sqrt();
    let gamma = (2.0 * c_sum + p.velocity_damping) / p.particle_mass;
    (omega, gamma)
}

/// Largest stable substep for `integrator` (infinite when nothing is stiff).
pub fn max_stable_substep(p: &SimParams, integrator_kind: u32) -> f32 {
    let (omega, gamma) = spectral_bounds(p);
    if integrator_kind == integrator::SEMI_IMPLICIT_EULER {
        // Largest h with h^2 w^2 + 2 h g = 4.
        if omega == 0.0 {
            if gamma == 0.0 { f32::INFINITY } else { 2.0 / gamma }
        } else {
            ((gamma * gamma + 4.0 * omega * omega).sqrt() - gamma) / (omega * omega)
        }
    } else {
        let rate = omega.max(gamma);
        if rate == 0.0 { f32::INFINITY } else { RK4_STABILITY_RADIUS / rate }
    }
}

/// Substeps per frame: `requested`, or the fewest that keep `safety * max_substep`.
pub fn choose(cloth: &Cloth, integrator_kind: u32, frame_dt: f32, requested: Option<u32>, safety: f32) -> Stability {
    choose_for(&cloth.params, integrator_kind, frame_dt, requested, safety)
}

/// `choose` for a cloth's parameters.
pub fn choose_for(
    params: &SimParams,
    integrator_kind: u32,
    frame_dt: f32,
    requested: Option<u32>,
    safety: f32,
) -> Stability {
    let (omega, gamma) = spectral_bounds(params);
    let max_substep = max_stable_substep(params, integrator_kind);
    let substeps = requested.unwrap_or_else(|| {
        let n = (frame_dt / (safety * max_substep)).ceil();
        if n.is_finite() { (n as u32).max(1) } else { 1 }
    });
    let substep = frame_dt / substeps as f32;
    Stability { omega_max: omega, gamma_max: gamma, max_substep, substep, substeps, ratio: substep / max_substep }
}

impl Stability {
    /// A warning when the substep exceeds the bound.
    pub fn warning(&self) -> Option<String> {
        (self.ratio > 1.0).then(|| {
            format!(
                "substep {:.3e} s is {:.2}x the stability bound {:.3e} s (omega_max {:.0} rad/s); \
                 the run may blow up: use at least {} substeps per frame or automatic substeps",
                self.substep,
                self.ratio,
                self.max_substep,
                self.omega_max,
                self.min_stable_substeps()
            )
        })
    }

    /// Fewest substeps per frame within the bound.
    pub fn min_stable_substeps(&self) -> u32 {
        (self.substeps as f32 * self.ratio).ceil().max(1.0) as u32
    }
}
