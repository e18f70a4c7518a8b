//! Tile sleeping of one cloth (`drape_kernels::tiles`): its tiles' buffers, which tiles its
//! springs join, and its two passes: the frame's start decides which tiles sleep, the frame's
//! end measures how far each moved.

use crate::cloth::{Cloth, ClothTopology};
use crate::graph::{BufferId, Dispatch, Handle, Resources, Step};
use crate::kernels::tiles::{DECIDE_TILES, MEASURE_TILES};
use crate::motion::Sleep;
use drape_kernels::cloth::{SPRINGS, spring_offset};
use drape_kernels::lbvh::morton_code;
use drape_kernels::tiles::{TILE_PARTICLES, tile_count};
use drape_types::{Aabb, Health, TileParams};
use glam::{Vec3, Vec4};
use std::collections::BTreeSet;

/// Moving colliders' boxes a frame hands the tiles; more are merged into their union.
pub const MOVING_BOXES: u32 = 16;

/// The timing table's line of the frame's start (which tiles sleep).
pub const DECIDE_LABEL: &str = "sleep: tiles";
/// The timing table's line of the frame's end (each tile's motion).
pub const MEASURE_LABEL: &str = "sleep: tile motion";

/// One cloth's tiles.
pub struct TileBuffers {
    pub tiles: u32,
    /// The parameters as declared (no collider moving).
    pub start: TileParams,
    pub params: Handle<TileParams>,
    /// Tile `t`'s particles are `members[TILE_PARTICLES t..]` (`tile_members`).
    pub members: Handle<u32>,
    /// Positions at the last frame's end.
    pub rest: Handle<Vec4>,
    /// Each tile's motion over the last frame (squared, m^2) and its box at its end.
    pub motion: Handle<f32>,
    pub bounds: Handle<Aabb>,
    /// Tile `t`'s neighbours are `neighbours[offsets[t]..offsets[t + 1]]`.
    pub offsets: Handle<u32>,
    pub neighbours: Handle<u32>,
    /// This frame's moving colliders' swept boxes (`TileParams::moving_colliders` of them).
    pub moving: Handle<Aabb>,
    /// Frames each tile has been calm.
    pub frames: Handle<u32>,
}

/// The particles of `cloth` in tile order (tile `t` holds `TILE_PARTICLES` of them from
/// `TILE_PARTICLES t` on): a grid's in index order (its tiles are runs of rows, and a SIMD
/// group of the integrator holds particles of one tile); a mesh's in Morton order of where
/// they start, so each tile is a compact patch whatever order the file lists its vertices in
/// (ties by index).
pub fn tile_members(cloth: &Cloth) -> Vec<u32> {
    let n = cloth.particle_count() as u32;
    match cloth.topology {
        ClothTopology::Grid => (0..n).collect(),
        ClothTopology::Springs(_) => {
            let points: Vec<Vec3> = cloth.positions.iter().map(|p| p.truncate()).collect();
            let lo = points.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
            let hi = points.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
            let mut order: Vec<u32> = (0..n).collect();
            order.sort_by_key(|&i| (morton_code(points[i as usize], lo, hi), i));
            order
        }
    }
}

/// The tiles each tile's springs reach (`members` gives the tiles, `tile_members`): CSR
/// offsets (one per tile, plus one) and the list, each tile's neighbours ascending.
pub fn tile_graph(cloth: &Cloth, members: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let n = cloth.particle_count() as u32;
    let mut tile_of = vec![0u32; n as usize];
    for (slot, &i) in members.iter().enumerate() {
        tile_of[i as usize] = slot as u32 / TILE_PARTICLES;
    }
    let mut joined: Vec<BTreeSet<u32>> = vec![BTreeSet::new(); tile_count(n) as usize];
    let mut join = |a: u32, b: u32| {
        let (ta, tb) = (tile_of[a as usize], tile_of[b as usize]);
        if ta != tb {
            joined[ta as usize].insert(tb);
            joined[tb as usize].insert(ta);
        }
    };
    match &cloth.topology {
        ClothTopology::Springs(s) => {
            for (a, range) in s.particles.iter().enumerate() {
                for spring in &s.springs[range.first as usize..(range.first + range.count) as usize] {
                    join(a as u32, spring.other);
                }
            }
        }
        ClothTopology::Grid => {
            let (rows, cols) = (cloth.params.rows as i32, cloth.params.cols as i32);
            for index in 0..n as i32 {
                let (r, c) = (index / cols, index % cols);
                for s in 0..SPRINGS.len() as u32 {
                    let o = spring_offset(s);
                    let (r2, c2) = (r + o.d_row, c + o.d_col);
                    if (0..rows).contains(&r2) && (0..cols).contains(&c2) {
                        join(index as u32, (r2 * cols + c2) as u32);
                    }
                }
            }
        }
    }
    let mut offsets = vec![0];
    let mut list = Vec::new();
    for set in joined {
        list.extend(set);
        offsets.push(list.len() as u32);
    }
    (offsets, list)
}

impl TileBuffers {
    /// The buffers of `cloth`'s tiles, and what they start with: every tile awake, its motion
    /// unknown, resting where the cloth starts.
    pub fn declare(
        resources: &mut Resources,
        name: &str,
        cloth: &Cloth,
        params: TileParams,
        initial: &mut Vec<(BufferId, Vec<u8>)>,
    ) -> Self {
        let name = format!("{name} tiles");
        let tiles = params.tile_count;
        let members = tile_members(cloth);
        let (offsets, neighbours) = tile_graph(cloth, &members);
        let b = TileBuffers {
            tiles,
            start: params,
            params: resources.device(format!("{name}: params"), 1),
            members: resources.device(format!("{name}: members"), params.particle_count),
            rest: resources.device(format!("{name}: rest"), params.particle_count),
            motion: resources.device(format!("{name}: motion"), tiles),
            bounds: resources.device(format!("{name}: bounds"), tiles),
            offsets: resources.device(format!("{name}: neighbour offsets"), tiles + 1),
            neighbours: resources.device(format!("{name}: neighbours"), neighbours.len().max(1) as u32),
            moving: resources.device(format!("{name}: moving colliders"), MOVING_BOXES),
            frames: resources.device(format!("{name}: calm frames"), tiles),
        };
        initial.push((b.params.id(), bytemuck::bytes_of(&params).to_vec()));
        initial.push((b.members.id(), bytemuck::cast_slice::<_, u8>(&members).to_vec()));
        initial.push((b.rest.id(), bytemuck::cast_slice::<_, u8>(&cloth.positions).to_vec()));
        initial.push((b.motion.id(), bytemuck::cast_slice::<_, u8>(&vec![f32::MAX; tiles as usize]).to_vec()));
        initial.push((b.offsets.id(), bytemuck::cast_slice::<_, u8>(&offsets).to_vec()));
        if !neighbours.is_empty() {
            initial.push((b.neighbours.id(), bytemuck::cast_slice::<_, u8>(&neighbours).to_vec()));
        }
        b
    }

    /// The parameters of a cloth of `particles` under `sleep`, in frames of `frame_dt` seconds.
    pub fn params(particles: u32, sleep: Sleep, frame_dt: f32) -> TileParams {
        TileParams {
            particle_count: particles,
            tile_count: tile_count(particles),
            still_frames: sleep.frames.max(1),
            moving_colliders: 0,
            still_motion: sleep.speed * frame_dt,
            _pad: [0; 3],
        }
    }

    /// The frame's start: which tiles sleep (their particles' flags in `v`, counted in `health`).
    pub fn decide_step(&self, v: Handle<Vec4>, health: Handle<Health>) -> Step {
        Step::run(
            DECIDE_LABEL,
            &DECIDE_TILES,
            vec![
                self.params.id(),
                self.members.id(),
                self.motion.id(),
                self.bounds.id(),
                self.offsets.id(),
                self.neighbours.id(),
                self.moving.id(),
                self.frames.id(),
                v.id(),
                health.id(),
            ],
            Dispatch::Threads(self.tiles),
        )
    }

    /// The frame's end: each tile's motion over the frame and its box.
    pub fn measure_step(&self, x: Handle<Vec4>) -> Step {
        Step::run(
            MEASURE_LABEL,
            &MEASURE_TILES,
            vec![self.params.id(), self.members.id(), x.id(), self.rest.id(), self.motion.id(), self.bounds.id()],
            Dispatch::Threads(self.tiles),
        )
    }

    /// Every tile awake and calm for no frame (a change that may move the whole cloth): its
    /// motion unknown until the next frame's end.
    pub fn wake_steps(&self) -> [Step; 2] {
        [Step::fill(self.frames, 0), Step::fill(self.motion, f32::MAX.to_bits())]
    }

    /// The writes that hand this frame's moving colliders' boxes (`boxes`, already grown by
    /// their reach) to the tiles, with the count in the parameters.
    pub fn moving_writes(&self, boxes: &[(Vec3, Vec3)]) -> Vec<Step> {
        let mut params = self.start;
        let mut aabbs: Vec<Aabb> =
            boxes.iter().map(|&(lo, hi)| Aabb { min: lo.extend(0.0), max: hi.extend(0.0) }).collect();
        if aabbs.len() > MOVING_BOXES as usize {
            let union = aabbs.iter().fold(aabbs[0], |u, b| Aabb { min: u.min.min(b.min), max: u.max.max(b.max) });
            aabbs = vec![union];
        }
        params.moving_colliders = aabbs.len() as u32;
        let mut steps = vec![Step::write(self.params, 0, &[params])];
        if !aabbs.is_empty() {
            steps.push(Step::write(self.moving, 0, &aabbs));
        }
        steps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drape_kernels::tiles::decide_tile_at;

    /// A grid's tiles are runs of whole rows here (16 columns, 4 rows a tile): its springs reach
    /// two rows, so each tile joins the tiles before and after it, no farther.
    #[test]
    fn a_grid_s_tiles_join_the_tiles_its_springs_reach() {
        let cloth = crate::ClothBuilder::new(16, 16).build().unwrap();
        let members = tile_members(&cloth);
        assert_eq!(members, (0..256).collect::<Vec<u32>>(), "a grid's tiles are runs of its indices");
        let (offsets, list) = tile_graph(&cloth, &members);
        assert_eq!(offsets, vec![0, 1, 3, 5, 6]);
        assert_eq!(list, vec![1, 0, 2, 1, 3, 2]);
    }

    /// A tile sleeps after `still_frames` calm frames; a neighbour that moves, or a collider
    /// moving near it, wakes it and restarts its count; a far collider does not.
    #[test]
    fn a_tile_sleeps_when_it_and_its_neighbours_stay_still_and_wakes_when_they_move() {
        let p = TileParams { particle_count: 128, tile_count: 2, still_frames: 3, still_motion: 1e-3, ..Default::default() };
        let (offsets, neighbours) = ([0u32, 1, 2], [1u32, 0]);
        let bounds = [Aabb { min: Vec4::ZERO, max: Vec4::ONE }; 2];
        let mut frames = [0u32; 2];
        let mut v = vec![Vec4::new(0.1, 0.0, 0.0, 0.0); 128];
        let decide = |motion: [f32; 2], moving: &[Aabb], frames: &mut [u32; 2], v: &mut [Vec4]| {
            let mut health = Health::default();
            let boxes: Vec<Aabb> = moving.to_vec();
            let p = TileParams { moving_colliders: boxes.len() as u32, ..p };
            let members: Vec<u32> = (0..128).collect();
            let graph = (&offsets[..], &neighbours[..]);
            decide_tile_at(0, &p, &members, (&motion, &bounds), graph, &boxes, frames, v, &mut health);
            health.tiles_asleep
        };
        let still = [0.0, 0.0];
        assert_eq!([decide(still, &[], &mut frames, &mut v), decide(still, &[], &mut frames, &mut v)], [0, 0]);
        assert_eq!(decide(still, &[], &mut frames, &mut v), 1, "asleep after 3 calm frames");
        assert!(v[..64].iter().all(|v| *v == Vec4::new(0.0, 0.0, 0.0, 1.0)), "flagged, velocity zero");
        assert!(v[64..].iter().all(|v| v.w == 0.0), "tile 1 is another thread's");
        // The neighbour moves 2 mm (squared motion 4e-6 against 1e-6): tile 0 wakes, count reset.
        assert_eq!(decide([0.0, 4e-6], &[], &mut frames, &mut v), 0);
        assert_eq!(frames[0], 0);
        assert!(v[..64].iter().all(|v| v.w == 0.0));
        for _ in 0..3 {
            decide(still, &[], &mut frames, &mut v);
        }
        assert_eq!(frames[0], 3);
        let far = Aabb { min: Vec4::splat(5.0), max: Vec4::splat(6.0) };
        assert_eq!(decide(still, &[far], &mut frames, &mut v), 1, "a collider moving far away");
        let near = Aabb { min: Vec4::splat(0.5), max: Vec4::splat(2.0) };
        assert_eq!(decide(still, &[far, near], &mut frames, &mut v), 0, "a collider moving through its box");
        assert_eq!(frames[0], 0);
    }

    /// A mesh whose file lists its vertices in a scrambled order still gets compact tiles: a
    /// 32 x 32 grid of 1 m as a mesh, its vertices shuffled, makes 16 tiles of 64, each within
    /// a quarter of the cloth across (in file order each would span all of it).
    #[test]
    fn a_mesh_s_tiles_are_compact_patches_whatever_its_vertex_order() {
        let grid = crate::ClothMesh::grid(32, 32, 1.0);
        let n = grid.vertices.len();
        let shuffle: Vec<usize> = (0..n).map(|i| (i * 389) % n).collect(); // 389 is prime to 1024
        let mut new_index = vec![0u32; n];
        for (new, &old) in shuffle.iter().enumerate() {
            new_index[old] = new as u32;
        }
        let vertices = shuffle.iter().map(|&old| grid.vertices[old]).collect();
        let triangles = grid.triangles.iter().map(|t| t.map(|i| new_index[i as usize])).collect();
        let mesh = crate::ClothMesh::from_parts(vertices, triangles).unwrap();
        let cloth = crate::ClothBuilder::from_mesh(mesh).build().unwrap();
        let members = tile_members(&cloth);
        let extent = |tile: &[u32]| {
            let (lo, hi) = tile.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
                let p = cloth.positions[i as usize].truncate();
                (lo.min(p), hi.max(p))
            });
            (hi - lo).max_element()
        };
        let widest = members.chunks(64).map(extent).fold(0.0f32, f32::max);
        assert!(widest <= 0.26, "a tile spans {widest} m of the 1 m cloth");
        let in_file_order: Vec<u32> = (0..n as u32).collect();
        assert!(in_file_order.chunks(64).map(extent).fold(0.0f32, f32::max) > 0.9, "the file's order is scrambled");
        let (offsets, _) = tile_graph(&cloth, &members);
        let most = offsets.windows(2).map(|w| w[1] - w[0]).max().unwrap();
        assert!(most <= 8, "a compact tile touches its few neighbours, not {most}");
    }
}
