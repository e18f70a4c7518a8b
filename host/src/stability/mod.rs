//! Explicit-integration stability bound (design.md §1) and the automatic substep count.
//!
//! The linearised cloth x'' = -(K/m) x - (C/m) x' has modes with eigenvalues lambda,
//! lambda^2 + gamma lambda + omega^2 = 0, where omega^2 ranges over the eigenvalues of K/m
//! (stiffness) and gamma over those of C/m (spring and velocity damping). The bound needs the
//! largest of each:
//! - **Lanczos** (`spectrum`, the default): matrix-free on the kernels' own force function at the
//!   cloth's state, so it is as tight as the estimate (a Ritz value plus its residual).
//! - **Gershgorin** (`spectral_bounds`, shown beside it and the fallback): twice a particle's
//!   summed stiffness over its mass, `omega_max^2 = 2 sum(k) / m`, and
//!   `gamma_max = (2 sum(c_s) + c_d) / m`; needs no state, over-estimates omega by up to sqrt(2)
//!   on a grid (a substep 1.4x shorter than needed).
//!
//! From (omega_max, gamma_max):
//! - RK4 is stable iff every mode's h lambda lies in its region |R(z)| <= 1 (`rk4_region`):
//!   2 sqrt(2) / omega for an undamped cloth, 2.785 / gamma for an overdamped one.
//! - Semi-implicit Euler on one damped mode is stable iff `h^2 omega^2 + 2 h gamma < 4`.
//!
//! Automatic substeps take `safety` (default 0.9) of the bound: the margin covers a cloth that
//! stretches stiffer than the state the bound was taken at. Blow-up detection (`check_health`)
//! stays the safety net.

pub mod diagnosis;
pub mod rk4_region;
pub mod spectrum;

pub use spectrum::{Linearisation, Spectrum};

use crate::cloth::{Cloth, ClothTopology};
use drape_kernels::cloth::{BEND, SHEAR, SPRINGS, STRUCTURAL};
use drape_types::{SimParams, integrator};
use std::sync::{Arc, Mutex};

/// Default fraction of the stability bound that automatic substeps use.
pub const DEFAULT_SAFETY: f32 = 0.9;

/// The stability figures of a cloth at a given substep.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Stability {
    /// The stiffest mode's angular frequency (rad/s).
    pub omega_max: f32,
    /// The largest damping rate (1/s).
    pub gamma_max: f32,
    /// Where omega_max and gamma_max come from.
    pub source: BoundSource,
    /// Gershgorin's omega_max, for comparison (rad/s).
    pub omega_gershgorin: f32,
    /// Largest stable substep (s).
    pub max_substep: f32,
    /// Chosen substep (s) and count per frame.
    pub substep: f32,
    pub substeps: u32,
    /// The count the stability bound alone chose (fewer than `substeps` when motion near
    /// contact raised it: `motion`).
    pub bound_substeps: u32,
    /// substep / max_substep (> 1 means the run may blow up).
    pub ratio: f32,
}

/// What the bound needs of a cloth's springs beyond its parameters: for a grid nothing (an
/// interior particle has 4 springs per family and the mean mass); for a spring list, the
/// distinct (summed stiffness scales per family, inverse mass) of its particles (a spring of
/// scale 1 counts once: `Spring::stiffness_scale`), so stiffness changes at run time get an
/// exact Gershgorin bound without the list.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SpringProfile {
    #[default]
    Grid,
    Listed(Vec<([f32; 3], f32)>),
}

impl SpringProfile {
    pub fn of(cloth: &Cloth) -> Self {
        let ClothTopology::Springs(topology) = &cloth.topology else {
            return SpringProfile::Grid;
        };
        let mut classes: Vec<([f32; 3], f32)> = topology
            .particles
            .iter()
            .map(|p| {
                let mut scales = [0f32; 3];
                for s in &topology.springs[p.first as usize..(p.first + p.count) as usize] {
                    scales[s.family.min(2) as usize] += s.stiffness_scale;
                }
                (scales, p.inverse_mass)
            })
            .collect();
        let by_scales =
            |a: &[f32; 3], b: &[f32; 3]| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])).then(a[2].total_cmp(&b[2]));
        classes.sort_unstable_by(|a, b| by_scales(&a.0, &b.0).then(a.1.total_cmp(&b.1)));
        classes.dedup();
        // Of two classes with the same scales only the lighter particle can be the stiffest.
        classes.dedup_by(|later, kept| {
            let same = later.0 == kept.0;
            if same {
                kept.1 = kept.1.max(later.1);
            }
            same
        });
        SpringProfile::Listed(classes)
    }

    /// 1 / the lightest particle's mass (1/kg): what a force accelerates most. 0 for a grid
    /// whose `p.particle_mass` is not positive.
    pub fn lightest_inverse_mass(&self, p: &SimParams) -> f32 {
        match self {
            SpringProfile::Grid if p.particle_mass > 0.0 => 1.0 / p.particle_mass,
            SpringProfile::Grid => 0.0,
            SpringProfile::Listed(classes) => classes.iter().map(|c| c.1).fold(0.0, f32::max),
        }
    }
}

/// Gershgorin's omega_max and gamma_max for a cloth's parameters and springs.
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
                let k_sum = structural * k(STRUCTURAL) + shear * k(SHEAR) + bend * k(BEND);
                let c_sum = (structural + shear + bend) * p.spring_damping;
                omega2 = omega2.max(2.0 * k_sum * inverse_mass);
                gamma = gamma.max(2.0 * c_sum * inverse_mass);
            }
            // Velocity damping acts per unit of the mean mass (`cloth::acceleration_springs`).
            (omega2.sqrt(), gamma + p.velocity_damping / p.particle_mass)
        }
    }
}

/// Where a stability bound's omega_max and gamma_max come from.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum BoundSource {
    /// Lanczos on the kernels' force function at the cloth's state; steps taken for the
    /// stiffness and the damping.
    Lanczos { steps: (u32, u32) },
    /// Gershgorin's theorem on the springs (no state to linearise at).
    Gershgorin,
}

impl std::fmt::Display for BoundSource {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            BoundSource::Lanczos { steps: (k, c) } => {
                write!(f, "Lanczos on the force function at the cloth's state, {k} + {c} steps")
            }
            BoundSource::Gershgorin => write!(f, "Gershgorin on the springs"),
        }
    }
}

/// What a cloth's bound needs beyond its parameters: its springs (for Gershgorin) and its force
/// function at a state (for Lanczos). Clones share the last estimate, so a runtime change of
/// wind or friction does not estimate again.
#[derive(Clone, Debug, Default)]
pub struct BoundInputs {
    pub profile: SpringProfile,
    pub state: Option<Linearisation>,
    /// What a spring list's structural springs hold, for a blow-up's diagnosis (`None`: a
    /// grid, whose parameters give it).
    pub hold: Option<diagnosis::StructuralHold>,
    last: Arc<Mutex<Option<(SpectrumKey, Spectrum)>>>,
}

/// The parameters the spectrum depends on (bits of stiffness, damping and mass).
type SpectrumKey = [u32; 6];

impl BoundInputs {
    /// Gershgorin and Lanczos inputs of `cloth` at its current state.
    pub fn of(cloth: &Cloth) -> Self {
        BoundInputs {
            profile: SpringProfile::of(cloth),
            state: Some(Linearisation::of(cloth)),
            hold: diagnosis::StructuralHold::of(cloth),
            last: Default::default(),
        }
    }

    /// Gershgorin only.
    pub fn gershgorin(profile: SpringProfile) -> Self {
        BoundInputs { profile, state: None, hold: None, last: Default::default() }
    }

    /// (omega_max, gamma_max) and where they come from.
    pub fn bounds(&self, p: &SimParams) -> (f64, f64, BoundSource) {
        let (omega, gamma) = spectral_bounds(p, &self.profile);
        let gershgorin = (omega as f64, gamma as f64, BoundSource::Gershgorin);
        let Some(state) = &self.state else { return gershgorin };
        let key =
            [p.k_struct, p.k_shear, p.k_bend, p.spring_damping, p.velocity_damping, p.particle_mass].map(f32::to_bits);
        let mut last = self.last.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let spectrum = match *last {
            Some((k, spectrum)) if k == key => spectrum,
            _ => {
                let started = std::time::Instant::now();
                let spectrum = state.spectrum(p);
                log::debug!("stability: {spectrum:?} in {:.1} ms", started.elapsed().as_secs_f64() * 1e3);
                *last = Some((key, spectrum));
                spectrum
            }
        };
        if !(spectrum.omega_max.is_finite() && spectrum.gamma_max.is_finite()) {
            log::warn!("stability: the Lanczos estimate is not finite ({spectrum:?}); using Gershgorin's bound");
            return gershgorin;
        }
        (spectrum.omega_max, spectrum.gamma_max, BoundSource::Lanczos { steps: spectrum.steps })
    }
}

/// Largest stable substep for `integrator` given the modes' omega_max and gamma_max (infinite
/// when nothing is stiff).
pub fn max_stable_substep(omega: f64, gamma: f64, integrator_kind: u32) -> f64 {
    if integrator_kind == integrator::SEMI_IMPLICIT_EULER {
        // Largest h with h^2 w^2 + 2 h g = 4.
        if omega == 0.0 {
            if gamma == 0.0 { f64::INFINITY } else { 2.0 / gamma }
        } else {
            ((gamma * gamma + 4.0 * omega * omega).sqrt() - gamma) / (omega * omega)
        }
    } else {
        rk4_region::rk4_max_substep(omega, gamma)
    }
}

/// Substeps per frame: `requested`, or the fewest that keep `safety * max_substep`.
pub fn choose(cloth: &Cloth, integrator_kind: u32, frame_dt: f32, requested: Option<u32>, safety: f32) -> Stability {
    choose_for(&cloth.params, &BoundInputs::of(cloth), integrator_kind, frame_dt, requested, safety)
}

/// `choose` for a cloth's parameters.
pub fn choose_for(
    params: &SimParams,
    inputs: &BoundInputs,
    integrator_kind: u32,
    frame_dt: f32,
    requested: Option<u32>,
    safety: f32,
) -> Stability {
    let (omega, gamma, source) = inputs.bounds(params);
    let omega_gershgorin = spectral_bounds(params, &inputs.profile).0;
    let max_substep = max_stable_substep(omega, gamma, integrator_kind) as f32;
    let substeps = requested.unwrap_or_else(|| {
        let n = (frame_dt / (safety * max_substep)).ceil();
        if n.is_finite() { (n as u32).max(1) } else { 1 }
    });
    let substep = frame_dt / substeps as f32;
    Stability {
        omega_max: omega as f32,
        gamma_max: gamma as f32,
        source,
        omega_gershgorin,
        max_substep,
        substep,
        substeps,
        bound_substeps: substeps,
        ratio: substep / max_substep,
    }
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
