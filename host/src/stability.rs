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

use crate::cloth::{Cloth, ClothTopology};
use drape_kernels::cloth::{BEND, SHEAR, SPRINGS, STRUCTURAL};
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

/// What the bound needs of a cloth's springs beyond its parameters: for a grid nothing (an
/// interior particle has 4 springs per family and the mean mass); for a spring list, the
/// distinct (springs per family, inverse mass) of its particles, so stiffness changes at run
/// time get an exact Gershgorin bound without the list.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SpringProfile {
    #[default]
    Grid,
    Listed(Vec<([u32; 3], f32)>),
}

impl SpringProfile {
    pub fn of(cloth: &Cloth) -> Self {
        let ClothTopology::Springs(topology) = &cloth.topology else {
            return SpringProfile::Grid;
        };
        let mut classes: Vec<([u32; 3], f32)> = topology
            .particles
            .iter()
            .map(|p| {
                let mut counts = [0u32; 3];
                for s in &topology.springs[p.first as usize..(p.first + p.count) as usize] {
                    counts[s.family.min(2) as usize] += 1;
                }
                (counts, p.inverse_mass)
            })
            .collect();
        classes.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        classes.dedup();
        // Of two classes with the same counts only the lighter particle can be the stiffest.
        classes.dedup_by(|later, kept| {
            let same = later.0 == kept.0;
            if same {
                kept.1 = kept.1.max(later.1);
            }
            same
        });
        SpringProfile::Listed(classes)
    }
}

/// omega_max and gamma_max for a cloth's parameters and springs.
pub fn spectral_bounds(p: &SimParams, profile: &SpringProfile) -> (f32, f32) {
    let k = |family| drape_kernels::cloth::stiffness(p, family);
    match profile {
        SpringProfile::Grid => {
            let k_sum: f32 = SPRINGS.iter().map(|s| k(s.family)).sum();
            let c_sum = SPRINGS.len() as f32 * p.spring_damping;
            let omega = (2.0 * k_sum / p.particle_mass).sqrt();
            let gamma = (2.0 * c_sum + p.velocity_damping) / p.particle_mass;
            (omega, gamma)
        }
        SpringProfile::Listed(classes) => {
            let (mut omega2, mut gamma): (f32, f32) = (0.0, 0.0);
            for &([structural, shear, bend], inverse_mass) in classes {
                let k_sum = structural as f32 * k(STRUCTURAL) + shear as f32 * k(SHEAR) + bend as f32 * k(BEND);
                let c_sum = (structural + shear + bend) as f32 * p.spring_damping;
                omega2 = omega2.max(2.0 * k_sum * inverse_mass);
                gamma = gamma.max(2.0 * c_sum * inverse_mass);
            }
            // Velocity damping acts per unit of the mean mass (`cloth::acceleration_springs`).
            (omega2.sqrt(), gamma + p.velocity_damping / p.particle_mass)
        }
    }
}

/// Largest stable substep for `integrator` (infinite when nothing is stiff).
pub fn max_stable_substep(p: &SimParams, profile: &SpringProfile, integrator_kind: u32) -> f32 {
    let (omega, gamma) = spectral_bounds(p, profile);
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
    choose_for(&cloth.params, &SpringProfile::of(cloth), integrator_kind, frame_dt, requested, safety)
}

/// `choose` for a cloth's parameters.
pub fn choose_for(
    params: &SimParams,
    profile: &SpringProfile,
    integrator_kind: u32,
    frame_dt: f32,
    requested: Option<u32>,
    safety: f32,
) -> Stability {
    let (omega, gamma) = spectral_bounds(params, profile);
    let max_substep = max_stable_substep(params, profile, integrator_kind);
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
