//! What drove a blow-up, and a value of that quantity that would be stable: the error a user
//! reads when a cloth blows up (`Error::Unstable`).
//!
//! - A substep over the stability bound: the bound is set either by the stiffness (omega_max)
//!   or by the damping (gamma_max), whichever alone allows the shorter substep; the message
//!   names it, its values, and the largest value that would be stable at this substep (omega
//!   grows as sqrt(k), gamma as c).
//! - A substep within the bound: the springs are stable, so a load stretched them past the
//!   limit: the external force or gravity when it exceeds what a particle's structural springs
//!   hold at the stretch limit (an upper limit: the message says the force must be well below
//!   it), or the whole cloth's external force when it exceeds that (pins carry the whole load
//!   through a few springs), else the motion (a fast particle or a contact pushing it), for
//!   which more substeps help.

use super::{Stability, max_stable_substep};
use crate::cloth::{Cloth, ClothTopology};
use drape_kernels::cloth::STRUCTURAL;
use drape_types::SimParams;

/// What a spring-list cloth's structural springs hold against a load on one particle (a grid's
/// follow from its parameters), as the sums over a particle's structural springs of stiffness
/// scale x rest length (m: at stretch s they pull with k_struct x that x (s - 1)): the largest
/// of its free particles' (`reach`, what a force on each particle is compared with: as a grid's
/// interior particle, held by all four), and for its weight the mass (kg) and sum of the free
/// particle whose springs hold most for its mass (`weighed`). Upper limits: a load beyond them
/// drives the cloth apart. A mesh cloth's parameters carry no grid steps: taken from those, its
/// springs held 1.7e-35 N, and every blow-up of a garment blamed its load.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct StructuralHold {
    pub reach: f32,
    pub weighed: (f32, f32),
}

impl StructuralHold {
    /// `None` for a grid cloth (`SimParams::rest` gives its springs) or one with no free
    /// particle on a structural spring.
    pub fn of(cloth: &Cloth) -> Option<Self> {
        let ClothTopology::Springs(topology) = &cloth.topology else { return None };
        let free = topology.particles.iter().zip(&cloth.positions).filter(|(p, x)| x.w > 0.0 && p.inverse_mass > 0.0);
        let held: Vec<(f32, f32)> = free
            .filter_map(|(p, _)| {
                let springs = topology.springs.get(p.first as usize..(p.first + p.count) as usize)?;
                let structural = springs.iter().filter(|s| s.family == STRUCTURAL);
                let reach: f32 = structural.map(|s| s.stiffness_scale * s.rest).sum();
                (reach > 0.0).then_some((1.0 / p.inverse_mass, reach))
            })
            .collect();
        let reach = held.iter().map(|&(_, reach)| reach).reduce(f32::max)?;
        let weighed = held.iter().copied().min_by(|a, b| (a.0 / a.1).total_cmp(&(b.0 / b.1)))?;
        Some(StructuralHold { reach, weighed })
    }

    /// A grid's: a particle's four structural springs, each a grid step (the shorter) long.
    fn of_grid(params: &SimParams) -> Self {
        let reach = 4.0 * params.rest.x.min(params.rest.y).max(f32::MIN_POSITIVE);
        StructuralHold { reach, weighed: (params.particle_mass, reach) }
    }
}

/// The fastest-moving collider of the frame that blew up: its index in the model and how fast
/// any point of its surface moved at most (m/s, by its pose and its vertices).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ColliderMotion {
    pub index: usize,
    pub speed: f32,
}

/// The cause of a blow-up of a cloth with `params` (and, for a spring list, `hold`) running at
/// `stability`, with `max_stretch` the stretch limit, `speed` the fastest particle of the last
/// healthy frame (m/s) and `collider` the fastest collider of the frame (if any moved).
pub fn cause(
    (params, hold): (&SimParams, Option<StructuralHold>),
    stability: &Stability,
    integrator: u32,
    (max_stretch, speed): (f32, f32),
    collider: Option<ColliderMotion>,
) -> String {
    let (omega, gamma) = (stability.omega_max as f64, stability.gamma_max as f64);
    if stability.ratio > 1.0 {
        let over = stability.ratio as f64;
        let stiffness_limit = max_stable_substep(omega, 0.0, integrator);
        let damping_limit = max_stable_substep(0.0, gamma, integrator);
        return if stiffness_limit <= damping_limit {
            // omega ~ sqrt(k): k / over^2 would put the bound at this substep.
            let scale = 1.0 / (over * over);
            format!(
                "the substep {:.3e} s is {over:.2}x the stability bound {:.3e} s, set by the stiffness (omega_max {:.0} \
                 rad/s from k = {}, {}, {} N/m with particle mass {:.3e} kg): stiffness of at most {:.3e}, {:.3e}, {:.3e} \
                 N/m would be stable at this substep",
                stability.substep,
                stability.max_substep,
                omega,
                params.k_struct,
                params.k_shear,
                params.k_bend,
                params.particle_mass,
                params.k_struct as f64 * scale,
                params.k_shear as f64 * scale,
                params.k_bend as f64 * scale
            )
        } else {
            let mut stable = Vec::new();
            if params.spring_damping > 0.0 {
                stable.push(format!("spring damping {:.3e} N s/m", params.spring_damping as f64 / over));
            }
            if params.velocity_damping > 0.0 {
                stable.push(format!("velocity damping {:.3e} N s/m", params.velocity_damping as f64 / over));
            }
            format!(
                "the substep {:.3e} s is {over:.2}x the stability bound {:.3e} s, set by the damping (gamma_max {:.0} 1/s \
                 from spring damping {} N s/m and velocity damping {} N s/m with particle mass {:.3e} kg): {} at most \
                 would be stable at this substep",
                stability.substep,
                stability.max_substep,
                gamma,
                params.spring_damping,
                params.velocity_damping,
                params.particle_mass,
                stable.join(" and ")
            )
        };
    }
    // Within the bound: a load. What a particle's structural springs hold at the stretch limit.
    let hold = hold.unwrap_or_else(|| StructuralHold::of_grid(params));
    let bears = |reach: f32| params.k_struct * reach * (max_stretch - 1.0);
    let held = bears(hold.reach);
    let force = params.external_force.truncate().length();
    // Gravity's: of the particle held most for its weight.
    let (mass, reach) = hold.weighed;
    let weight = params.gravity.truncate().length() * mass;
    let held_up = bears(reach);
    let particles = params.particle_count.max(1) as f32;
    if force > held {
        format!(
            "the substep is within the stability bound, so the load drove it: the external force, {:.3e} N on the \
             cloth ({force:.3e} N per particle), exceeds the {held:.3e} N per particle that even a particle held by \
             all its structural springs ({} N/m) bears at {max_stretch}x stretch; the cloth as a whole bears \
             less, so use a force well below {:.3e} N on the cloth, or stiffer springs",
            force * particles,
            params.k_struct,
            held * particles
        )
    } else if force * particles > held {
        // Each particle's share is held, but a pinned (or caught) cloth carries its whole load
        // through the few springs at its pins: the swing scene under 1e4 N of wind (2.4 N a
        // particle, 23 N held) blew up in its first frame, and the motion was blamed; under a
        // smaller load it swings ever faster first, which more substeps do not help.
        format!(
            "the substep is within the stability bound, so the load drove it: the external force, {:.3e} N on the \
             cloth, is more than the {held:.3e} N that a particle's structural springs ({} N/m) bear at \
             {max_stretch}x stretch, and a cloth held by pins (or caught on a collider) carries its whole load through \
             the few springs there (its fastest particle moved at {speed:.3e} m/s in the last healthy frame); use a \
             force well below {held:.3e} N on the cloth, or stiffer springs",
            force * particles,
            params.k_struct
        )
    } else if weight > held_up {
        format!(
            "the substep is within the stability bound, but gravity pulls each particle with {weight:.3e} N, more than \
             the springs hold at {max_stretch}x stretch ({held_up:.3e} N): gravity below {:.3e} m/s^2, or stiffer \
             springs, would be stable",
            held_up / mass
        )
    } else if let Some(c) = collider.filter(|c| c.speed > speed) {
        // A collider faster than any particle: what pushed the cloth apart is the collider.
        format!(
            "the substep is within the stability bound, so motion drove it: collider {} (the model's, counted from 0) \
             moved its surface at up to \
             {:.3e} m/s in the frame, faster than any particle of the cloth ({speed:.3e} m/s in the last healthy \
             frame), and pushed the cloth apart; a real cloth would tear. Move it less per frame: a pose or vertices \
             set far from the last frame's (a jump, a teleport, a mesh sequence file far from the one before) is \
             taken as that motion within the frame",
            c.index, c.speed
        )
    } else {
        format!(
            "the substep is within the stability bound, so motion drove it: the fastest particle moved at {speed:.3e} m/s \
             in the last healthy frame (a fast throw, or contact pushing particles apart, e.g. a thickness larger than \
             the cloth's edges); smaller substeps resolve that, but not a cloth pulled apart (pins holding it against \
             a collider that drags it on, or a throw so fast that the impact outruns the springs: a real cloth would \
             tear; if more substeps fail the same way, slow the collider or the throw, loosen the pins, or stiffen \
             the springs)"
        )
    }
}
