//! Blow-up detection, once per frame: counts non-finite particles and finds the largest
//! structural stretch, so the host can stop with an error instead of returning NaN; and the
//! largest speed, so the host can put a still cloth to sleep and bound the substep by motion.
//! With vertex normals on, the check and the normals are one pass (`normals_and_health`).

use crate::atomics;
use crate::cloth::STRUCTURAL;
use crate::normals::{mesh_vertex_normal_at, vertex_normal_at};
use drape_types::glam::{UVec3, Vec4, Vec4Swizzles};
use drape_types::{Health, ParticleSprings, SimParams, Spring};
use spirv_std::spirv;

/// One particle's contribution to `Health`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ParticleHealth {
    pub non_finite: bool,
    /// Largest stretch (length / rest) of its structural springs.
    pub stretch: f32,
    pub speed: f32,
    /// Distance moved over the last substep (m).
    pub moved: f32,
}

/// A grid particle's health: its +col and +row structural springs.
pub fn particle_health(p: &SimParams, index: u32, x: &[Vec4], v: &[Vec4], x_prev: &[Vec4]) -> ParticleHealth {
    let i = index as usize;
    let here = x[i].xyz();
    let finite = here.is_finite() && v[i].xyz().is_finite();
    let mut stretch: f32 = 0.0;
    if index % p.cols + 1 < p.cols {
        stretch = stretch.max((x[i + 1].xyz() - here).length() * (1.0 / p.rest.x));
    }
    if index / p.cols + 1 < p.rows {
        stretch = stretch.max((x[i + p.cols as usize].xyz() - here).length() * (1.0 / p.rest.y));
    }
    ParticleHealth {
        non_finite: !finite,
        stretch,
        speed: v[i].xyz().length(),
        moved: (here - x_prev[i].xyz()).length(),
    }
}

/// `particle_health` of a spring-list cloth: the largest stretch of the particle's structural
/// springs (each is seen from both ends; either answer is the same maximum).
pub fn particle_health_springs(
    index: u32,
    x: &[Vec4],
    v: &[Vec4],
    x_prev: &[Vec4],
    particles: &[ParticleSprings],
    springs: &[Spring],
) -> ParticleHealth {
    let i = index as usize;
    let here = x[i].xyz();
    let finite = here.is_finite() && v[i].xyz().is_finite();
    let me = particles[i];
    let mut stretch: f32 = 0.0;
    let mut s = me.first;
    while s < me.first + me.count {
        let spring = springs[s as usize];
        if spring.family == STRUCTURAL && spring.rest > 0.0 {
            stretch = stretch.max((x[spring.other as usize].xyz() - here).length() * (1.0 / spring.rest));
        }
        s += 1;
    }
    ParticleHealth {
        non_finite: !finite,
        stretch,
        speed: v[i].xyz().length(),
        moved: (here - x_prev[i].xyz()).length(),
    }
}

/// Folds one particle's health into `health` (atomically on the GPU).
pub fn record_health(health: &mut Health, particle: ParticleHealth) {
    if particle.non_finite {
        atomics::add(&mut health.non_finite, 1);
    } else {
        // NaN cannot happen here: positions and velocities are finite, rest lengths positive;
        // both are >= 0, so their bits order like their values.
        atomics::max(&mut health.max_stretch_bits, particle.stretch.to_bits());
        atomics::max(&mut health.max_speed_bits, particle.speed.to_bits());
        atomics::max(&mut health.max_moved_bits, particle.moved.to_bits());
    }
}

/// Folds one grid particle into `health`.
pub fn check_health_at(p: &SimParams, index: u32, x: &[Vec4], v: &[Vec4], x_prev: &[Vec4], health: &mut Health) {
    record_health(health, particle_health(p, index, x, v, x_prev));
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn check_health_springs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] particles: &[ParticleSprings],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] springs: &[Spring],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] health: &mut Health,
) {
    if id.x >= params.particle_count {
        return;
    }
    record_health(health, particle_health_springs(id.x, x, v, x_prev, particles, springs));
}

#[spirv(compute(threads(256)))]
pub fn check_health(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] health: &mut Health,
) {
    if id.x >= params.particle_count {
        return;
    }
    check_health_at(params, id.x, x, v, x_prev, health);
}

/// The frame's last pass for a grid cloth: each particle's vertex normal (`normals`) and its
/// share of the blow-up check (`health`) in one dispatch. Both read the frame's final state and
/// neither reads what the other writes; one pass saves a dispatch and a barrier per frame.
#[spirv(compute(threads(256)))]
pub fn normals_and_health(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] normals: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] health: &mut Health,
) {
    if id.x >= params.particle_count {
        return;
    }
    normals[id.x as usize] = vertex_normal_at(params, id.x, x).extend(0.0);
    check_health_at(params, id.x, x, v, x_prev, health);
}

/// `normals_and_health` for a spring-list cloth: its springs (the stretch check) and the
/// triangles around each vertex (its normal).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn mesh_normals_and_health(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] particles: &[ParticleSprings],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] springs: &[Spring],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] vertex_triangle_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] vertex_triangles: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] normals: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] health: &mut Health,
) {
    if id.x >= params.particle_count {
        return;
    }
    normals[id.x as usize] =
        mesh_vertex_normal_at(id.x, x, vertex_triangle_offsets, vertex_triangles, indices).extend(0.0);
    record_health(health, particle_health_springs(id.x, x, v, x_prev, particles, springs));
}
