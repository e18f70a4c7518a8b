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

/// Member `i` of a tile at a frame's end: the square of how far it moved since the last
/// frame's end (`rest`, which then takes its position) and its position.
#[inline]
pub fn measure_member(i: usize, x: &[Vec4], rest: &mut [Vec4]) -> (f32, Vec3) {
    let now = x[i];
    let moved = (now.xyz() - rest[i].xyz()).length_squared();
    rest[i] = now;
    (moved, now.xyz())
}

/// A tile's motion and box as its members are folded in, in member order (the GPU's lane 0
/// folds its lanes' measures in the same order as this loop, so both give the same bits).
#[derive(Copy, Clone)]
pub struct TileMeasure {
    farthest: f32,
    lo: Vec3,
    hi: Vec3,
}

impl TileMeasure {
    pub const EMPTY: TileMeasure =
        TileMeasure { farthest: 0.0, lo: Vec3::splat(f32::INFINITY), hi: Vec3::splat(f32::NEG_INFINITY) };

    #[inline]
    pub fn with_member(self, (moved, at): (f32, Vec3)) -> TileMeasure {
        TileMeasure { farthest: self.farthest.max(moved), lo: self.lo.min(at), hi: self.hi.max(at) }
    }

    /// Writes tile `t`'s motion (the square of its farthest member's) and box.
    #[inline]
    pub fn store(self, t: u32, motion: &mut [f32], bounds: &mut [Aabb]) {
        motion[t as usize] = self.farthest;
        bounds[t as usize] = Aabb { min: self.lo.extend(0.0), max: self.hi.extend(0.0) };
    }
}

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
    let mut tile = TileMeasure::EMPTY;
    let mut k = first as usize;
    while k < end as usize {
        tile = tile.with_member(measure_member(members[k] as usize, x, rest));
        k += 1;
    }
    tile.store(t, motion, bounds);
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
/// frame and no collider moves near it now), and whether it sleeps this frame (counted in
/// `health`).
#[allow(clippy::too_many_arguments)]
pub fn tile_sleeps(
    t: u32,
    p: &TileParams,
    (motion, bounds): (&[f32], &[Aabb]),
    (joined, neighbours): (&[u32], &[u32]),
    moving: &[Aabb],
    frames: &mut [u32],
    health: &mut Health,
) -> bool {
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
    if asleep {
        atomics::add(&mut health.tiles_asleep, 1);
    }
    asleep
}

/// Particle `i`'s flag for the frame: asleep (velocity zero; one that stays asleep keeps
/// `SETTLED`, its buffers still hold it) or awake.
#[inline]
pub fn flag_member(i: usize, asleep: bool, v: &mut [Vec4]) {
    let flag = if v[i].w == SETTLED { SETTLED } else { SLEEPING };
    v[i] = if asleep { Vec4::new(0.0, 0.0, 0.0, flag) } else { v[i].xyz().extend(0.0) };
}

/// At a frame's start: whether tile `t` sleeps (`tile_sleeps`), and its particles' flags.
#[allow(clippy::too_many_arguments)]
pub fn decide_tile_at(
    t: u32,
    p: &TileParams,
    (offsets, members): Tiles<'_>,
    tiles: (&[f32], &[Aabb]),
    graph: (&[u32], &[u32]),
    moving: &[Aabb],
    frames: &mut [u32],
    v: &mut [Vec4],
    health: &mut Health,
) {
    let asleep = tile_sleeps(t, p, tiles, graph, moving, frames, health);
    let (first, end) = (offsets[t as usize], offsets[t as usize + 1]);
    let mut k = first as usize;
    while k < end as usize {
        flag_member(members[k] as usize, asleep, v);
        k += 1;
    }
}

/// Threads per workgroup of the tile kernels: a workgroup per tile, a lane per member. A thread
/// per tile looping over its members waited on each member's loads in turn (about 30 us a
/// pass on an H100 for a 64^2 cloth's 64 tiles); the lanes load theirs at once.
pub const TILE_THREADS: u32 = TILE_PARTICLES;

/// Workgroups of a tile pass over `tiles` tiles: one per tile, at most `MAX_TILE_GROUPS`
/// (each takes every `MAX_TILE_GROUPS`-th tile after its first; a 2048^2 grid has 65536
/// tiles, more workgroups than a dispatch may have).
pub fn tile_workgroups(tiles: u32) -> u32 {
    tiles.min(MAX_TILE_GROUPS)
}

/// See `tile_workgroups`.
pub const MAX_TILE_GROUPS: u32 = 4096;

#[cfg(target_arch = "spirv")]
fn barrier() {
    spirv_std::arch::workgroup_memory_barrier_with_group_sync();
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn measure_tiles(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(num_workgroups)] groups: UVec3,
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] tile_params: &TileParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] member_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] members: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] rest: &mut [Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] motion: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] bounds: &mut [Aabb],
    #[spirv(workgroup)] moved: &mut [f32; TILE_THREADS as usize],
    #[spirv(workgroup)] at: &mut [Vec4; TILE_THREADS as usize],
) {
    let lane = lid.x;
    // The same in every lane, so every lane reaches each barrier.
    let mut t = group.x;
    while t < tile_params.tile_count {
        let (first, end) = (member_offsets[t as usize], member_offsets[t as usize + 1]);
        if first + lane < end {
            let (m, a) = measure_member(members[(first + lane) as usize] as usize, x, rest);
            moved[lane as usize] = m;
            at[lane as usize] = a.extend(0.0);
        }
        #[cfg(target_arch = "spirv")]
        barrier();
        if lane == 0 {
            let mut tile = TileMeasure::EMPTY;
            let mut k = 0;
            while k < end - first {
                tile = tile.with_member((moved[k as usize], at[k as usize].xyz()));
                k += 1;
            }
            tile.store(t, motion, bounds);
        }
        // Lane 0 has read the lanes' measures before the next tile's overwrite them.
        #[cfg(target_arch = "spirv")]
        barrier();
        t += groups.x;
    }
}

#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn decide_tiles(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(num_workgroups)] groups: UVec3,
    #[spirv(local_invocation_id)] lid: UVec3,
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
    #[spirv(workgroup)] decided: &mut [u32; 1],
) {
    let lane = lid.x;
    // The same in every lane, so every lane reaches each barrier.
    let mut t = group.x;
    while t < tile_params.tile_count {
        if lane == 0 {
            let graph = (neighbour_offsets, neighbours);
            let asleep = tile_sleeps(t, tile_params, (motion, bounds), graph, moving_boxes, calm_frames, health);
            decided[0] = asleep as u32;
        }
        #[cfg(target_arch = "spirv")]
        barrier();
        let (first, end) = (member_offsets[t as usize], member_offsets[t as usize + 1]);
        if first + lane < end {
            flag_member(members[(first + lane) as usize] as usize, decided[0] != 0, v);
        }
        // Every lane has read the decision before the next tile's replaces it.
        #[cfg(target_arch = "spirv")]
        barrier();
        t += groups.x;
    }
}
