//! Tile sleeping: the parts of a cloth that have come to rest stop integrating and colliding
//! while the rest of it moves.
//!
//! A cloth's particles form tiles of at most `TILE_PARTICLES` (tile `t` holds
//! `members[offsets[t]..offsets[t + 1]]`: a grid's consecutive indices, its rows; a mesh's
//! patches grown over its springs, so a tile never spans two pieces of cloth, whatever order its
//! file lists the vertices in). At each frame's end `measure_tile_at` records how far each tile's
//! particles moved over the frame (against where the last frame left them) and the tile's box.
//! At the next frame's start `decide_tile_at` counts the frames each tile has been *calm*: it
//! moved less than `TileParams::still_motion`, so did every tile its springs reach (a tile
//! held by a moving neighbour is not at rest), and no collider moves near its box this frame.
//! A tile calm for `TileParams::still_frames` frames sleeps: its particles carry the sleep flag
//! (`v.w = 1`, `SLEEPING`), which the integrator treats as a pin for the frame (position kept
//! bit for bit, velocity zero) and the contact response skips. Once a substep has copied a
//! sleeping particle into all its stage buffers, its flag becomes `SETTLED` (`v.w = 2`) and the
//! integrator skips it altogether (on lavapipe a sleeping particle's copies cost two thirds of an
//! awake particle's stage); a self-collision push or friction on it wakes it for the rest of the
//! frame (`wake_particle`). A neighbour that moves, a
//! collider moving near, or self-collision pushing one of its particles (a push is motion)
//! wakes the tile at the next frame's start; the host wakes every tile on any change that could
//! move the cloth (a force, a parameter, a pin, a new state).
//!
//! The flag lives in the velocity's unused w so that every kernel that loads a particle's
//! velocity sees it without another binding; kernels that write a velocity keep its w.

use crate::atomics;
use crate::lbvh::box_meets;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, Health, TileParams};
use spirv_std::spirv;

/// Particles per tile, at most.
pub const TILE_PARTICLES: u32 = 64;

/// `v.w` of a particle whose tile sleeps (0 when awake).
pub const SLEEPING: f32 = 1.0;
/// `v.w` of a sleeping particle whose stage buffers (`x_prev`, both ping-pong pairs of the
/// integrator) hold its state: position, and zero velocity. The integrator leaves it alone.
pub const SETTLED: f32 = 2.0;

/// A sleeping particle that something pushed (`v`) wakes for the rest of the frame: it
/// integrates and collides again (a push must not leave it inside a collider, nor its stage
/// buffers stale); the next frame's start decides its tile's sleep anew.
#[inline]
pub fn wake_particle(v: &mut Vec4) {
    v.w = 0.0;
}

/// Whether a particle with velocity `v` sleeps (its tile does).
#[inline]
pub fn sleeping(v: Vec4) -> bool {
    v.w != 0.0
}

/// A cloth's tiles: tile `t` holds particles `members[offsets[t]..offsets[t + 1]]`.
pub type Tiles<'a> = (&'a [u32], &'a [u32]);

/// At a frame's end: the square of the farthest any particle of tile `t` moved since the last
/// frame's end (`rest`, which then takes the positions) into `motion[t]`, and the tile's box.
pub fn measure_tile_at(
    t: u32,
    (offsets, members): Tiles<'_>,
    x: &[Vec4],
    rest: &mut [Vec4],
    motion: &mut [f32],
    bounds: &mut [Aabb],
) {
    let (first, end) = (offsets[t as usize], offsets[t as usize + 1]);
    let mut farthest = 0.0f32;
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut k = first as usize;
    while k < end as usize {
        let i = members[k] as usize;
        let now = x[i];
        farthest = farthest.max((now.xyz() - rest[i].xyz()).length_squared());
        lo = lo.min(now.xyz());
        hi = hi.max(now.xyz());
        rest[i] = now;
        k += 1;
    }
    motion[t as usize] = farthest;
    bounds[t as usize] = Aabb { min: lo.extend(0.0), max: hi.extend(0.0) };
}

/// Whether box `b` meets any of the first `count` boxes of `moving`.
#[inline]
fn near_moving(b: &Aabb, moving: &[Aabb], count: u32) -> bool {
    let mut k = 0;
    while k < count as usize {
        if box_meets(&moving[k], b.min.xyz(), b.max.xyz()) {
            return true;
        }
        k += 1;
    }
    false
}

/// At a frame's start: tile `t`'s calm frames (`frames[t]`: reset unless it, and every tile in
/// `neighbours[joined[t]..joined[t + 1]]`, moved less than the still motion over the last
/// frame and no collider moves near it now), whether it sleeps this frame, and its particles'
/// flags (a sleeping particle's velocity is zero). Counts sleeping tiles in `health`.
#[allow(clippy::too_many_arguments)]
pub fn decide_tile_at(
    t: u32,
    p: &TileParams,
    (offsets, members): Tiles<'_>,
    (motion, bounds): (&[f32], &[Aabb]),
    (joined, neighbours): (&[u32], &[u32]),
    moving: &[Aabb],
    frames: &mut [u32],
    v: &mut [Vec4],
    health: &mut Health,
) {
    let ti = t as usize;
    let still = p.still_motion * p.still_motion;
    let mut calm = motion[ti] < still && !near_moving(&bounds[ti], moving, p.moving_colliders);
    let mut k = joined[ti] as usize;
    while k < joined[ti + 1] as usize && calm {
        calm = motion[neighbours[k] as usize] < still;
        k += 1;
    }
    let count = if calm { frames[ti].min(u32::MAX - 1) + 1 } else { 0 };
    frames[ti] = count;
    let asleep = count >= p.still_frames;
    let (first, end) = (offsets[ti], offsets[ti + 1]);
    let mut k = first as usize;
    while k < end as usize {
        let i = members[k] as usize;
        // A particle that stays asleep keeps `SETTLED` (its buffers still hold it).
        let flag = if v[i].w == SETTLED { SETTLED } else { SLEEPING };
        v[i] = if asleep { Vec4::new(0.0, 0.0, 0.0, flag) } else { v[i].xyz().extend(0.0) };
        k += 1;
    }
    if asleep {
        atomics::add(&mut health.tiles_asleep, 1);
    }
}

/// Threads per workgroup of the tile kernels (a cloth has few tiles).
pub const TILE_THREADS: u32 = 64;

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn measure_tiles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] tile_params: &TileParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] member_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] members: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] rest: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] motion: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] bounds: &mut [Aabb],
) {
    if id.x >= tile_params.tile_count {
        return;
    }
    measure_tile_at(id.x, (member_offsets, members), x, rest, motion, bounds);
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn decide_tiles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] tile_params: &TileParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] member_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] members: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] motion: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] bounds: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] neighbour_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] neighbours: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] moving_boxes: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] calm_frames: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] v: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] health: &mut Health,
) {
    if id.x >= tile_params.tile_count {
        return;
    }
    let (tiles, graph) = ((member_offsets, members), (neighbour_offsets, neighbours));
    decide_tile_at(id.x, tile_params, tiles, (motion, bounds), graph, moving_boxes, calm_frames, v, health);
}
