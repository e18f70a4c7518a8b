//! Blow-up detection, once per frame: counts non-finite particles and finds the largest
//! structural stretch, so the host can stop with an error instead of returning NaN.

use crate::atomics;
use drape_types::glam::{UVec3, Vec4, Vec4Swizzles};
use drape_types::{Health, SimParams};
use spirv_std::spirv;

/// (is this particle non-finite, largest stretch of its +col and +row structural springs).
pub fn particle_health(p: &SimParams, index: u32, x: &[Vec4], v: &[Vec4]) -> (bool, f32) {
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
    (!finite, stretch)
}

/// Folds one particle into `health` (atomically on the GPU).
pub fn check_health_at(p: &SimParams, index: u32, x: &[Vec4], v: &[Vec4], health: &mut Health) {
    let (non_finite, stretch) = particle_health(p, index, x, v);
    if non_finite {
        atomics::add(&mut health.non_finite, 1);
    } else {
        // NaN stretch cannot happen here: positions are finite and rest lengths positive.
        atomics::max(&mut health.max_stretch_bits, stretch.to_bits());
    }
}

#[spirv(compute(threads(256)))]
pub fn check_health(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] v: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] health: &mut Health,
) {
    if id.x >= params.particle_count {
        return;
    }
    check_health_at(params, id.x, x, v, health);
}
