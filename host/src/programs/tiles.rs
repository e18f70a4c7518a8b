//! Tile sleeping of one cloth (`drape_kernels::tiles`): its tiles' buffers, which tiles its
//! springs join, and its two passes: the frame's start decides which tiles sleep, the frame's
//! end measures how far each moved.

use crate::cloth::{Cloth, ClothTopology};
use crate::graph::{BufferId, Dispatch, Handle, Resources, Step};
use crate::kernels::tiles::{DECIDE_TILES, MEASURE_TILES};
use crate::motion::Sleep;
use drape_kernels::cloth::{SPRINGS, neighbour};
use drape_kernels::lbvh::morton_code;
use drape_kernels::tiles::{TILE_PARTICLES, tile_workgroups};
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
    /// Tile `t`'s particles are `members[member_offsets[t]..member_offsets[t + 1]]`
    /// (`TilePartition`).
    pub member_offsets: Handle<u32>,
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

/// A cloth's particles in tiles of at most `TILE_PARTICLES`: tile `t` holds
/// `members[offsets[t]..offsets[t + 1]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct TilePartition {
    pub offsets: Vec<u32>,
    pub members: Vec<u32>,
}

impl TilePartition {
    /// A grid's tiles are runs of its indices (its rows: a SIMD group of the integrator holds
    /// particles of one tile). A mesh's are runs of Morton order (of where its vertices start)
    /// within each piece of it (the particles its springs join), so a tile is a compact patch of
    /// one piece whatever order the file lists the vertices in: a run of the file's order can
    /// span the whole cloth, and a run of Morton order across pieces joins two layers that lie
    /// apart (a piece's last tile may hold fewer than `TILE_PARTICLES`).
    pub fn of(cloth: &Cloth) -> Self {
        let n = cloth.particle_count() as u32;
        if matches!(cloth.topology, ClothTopology::Grid) {
            let offsets = (0..n.div_ceil(TILE_PARTICLES)).map(|t| t * TILE_PARTICLES).chain([n]).collect();
            return TilePartition { offsets, members: (0..n).collect() };
        }
        // Pieces: union-find over the springs, each named by its smallest particle.
        let mut parent: Vec<u32> = (0..n).collect();
        fn root(parent: &mut [u32], mut i: u32) -> u32 {
            while parent[i as usize] != i {
                parent[i as usize] = parent[parent[i as usize] as usize];
                i = parent[i as usize];
            }
            i
        }
        for_each_spring(cloth, |a, b| {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra.max(rb) as usize] = ra.min(rb);
        });
        let piece: Vec<u32> = (0..n).map(|i| root(&mut parent, i)).collect();
        let points: Vec<Vec3> = cloth.positions.iter().map(|p| p.truncate()).collect();
        let lo = points.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
        let hi = points.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
        let mut members: Vec<u32> = (0..n).collect();
        members.sort_by_key(|&i| (piece[i as usize], morton_code(points[i as usize], lo, hi), i));
        let mut offsets = vec![0];
        let mut run = 0;
        for (slot, &i) in members.iter().enumerate().skip(1) {
            run += 1;
            if run == TILE_PARTICLES || piece[i as usize] != piece[members[slot - 1] as usize] {
                offsets.push(slot as u32);
                run = 0;
            }
        }
        offsets.push(n);
        TilePartition { offsets, members }
    }

    pub fn tile_count(&self) -> u32 {
        self.offsets.len() as u32 - 1
    }
}

/// Calls `visit(a, b)` for each spring of `cloth` from each of its ends `a`.
fn for_each_spring(cloth: &Cloth, mut visit: impl FnMut(u32, u32)) {
    match &cloth.topology {
        ClothTopology::Springs(s) => {
            for (a, range) in s.particles.iter().enumerate() {
                for spring in &s.springs[range.first as usize..(range.first + range.count) as usize] {
                    visit(a as u32, spring.other);
                }
            }
        }
        ClothTopology::Grid => {
            let p = &cloth.params;
            for (row, col) in (0..p.rows).flat_map(|row| (0..p.cols).map(move |col| (row, col))) {
                for other in SPRINGS.into_iter().filter_map(|s| neighbour(p, row, col, s)) {
                    visit(row * p.cols + col, other);
                }
            }
        }
    }
}

/// The tiles each tile of `tiles` reaches through `cloth`'s springs: CSR offsets (one per
/// tile, plus one) and the list, each tile's neighbours ascending.
pub fn tile_graph(cloth: &Cloth, tiles: &TilePartition) -> (Vec<u32>, Vec<u32>) {
    let mut tile_of = vec![0u32; cloth.particle_count()];
    for t in 0..tiles.tile_count() as usize {
        for &i in &tiles.members[tiles.offsets[t] as usize..tiles.offsets[t + 1] as usize] {
            tile_of[i as usize] = t as u32;
        }
    }
    let mut joined: Vec<BTreeSet<u32>> = vec![BTreeSet::new(); tiles.tile_count() as usize];
    for_each_spring(cloth, |a, b| {
        let (ta, tb) = (tile_of[a as usize], tile_of[b as usize]);
        if ta != tb {
            joined[ta as usize].insert(tb);
            joined[tb as usize].insert(ta);
        }
    });
    let mut offsets = vec![0];
    let mut list = Vec::new();
    for set in joined {
        list.extend(set);
        offsets.push(list.len() as u32);
    }
    (offsets, list)
}

impl TileBuffers {
    /// The buffers of `cloth`'s tiles under `sleep` (frames of `frame_dt` seconds), and what
    /// they start with: every tile awake, its motion unknown, resting where the cloth starts.
    pub fn declare(
        resources: &mut Resources,
        name: &str,
        cloth: &Cloth,
        (sleep, frame_dt): (Sleep, f32),
        initial: &mut Vec<(BufferId, Vec<u8>)>,
    ) -> Self {
        let name = format!("{name} tiles");
        let partition = TilePartition::of(cloth);
        let tiles = partition.tile_count();
        let params = TileParams {
            particle_count: cloth.params.particle_count,
            tile_count: tiles,
            still_frames: sleep.frames.max(1),
            moving_colliders: 0,
            still_motion: sleep.speed * frame_dt,
            _pad: [0; 3],
        };
        let (offsets, neighbours) = tile_graph(cloth, &partition);
        let b = TileBuffers {
            tiles,
            start: params,
            params: resources.device(format!("{name}: params"), 1),
            member_offsets: resources.device(format!("{name}: member offsets"), tiles + 1),
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
        initial.push((b.member_offsets.id(), bytemuck::cast_slice::<_, u8>(&partition.offsets).to_vec()));
        initial.push((b.members.id(), bytemuck::cast_slice::<_, u8>(&partition.members).to_vec()));
        initial.push((b.rest.id(), bytemuck::cast_slice::<_, u8>(&cloth.positions).to_vec()));
        initial.push((b.motion.id(), bytemuck::cast_slice::<_, u8>(&vec![f32::MAX; tiles as usize]).to_vec()));
        initial.push((b.offsets.id(), bytemuck::cast_slice::<_, u8>(&offsets).to_vec()));
        if !neighbours.is_empty() {
            initial.push((b.neighbours.id(), bytemuck::cast_slice::<_, u8>(&neighbours).to_vec()));
        }
        b
    }

    /// The frame's start: which tiles sleep (their particles' flags in `v`, counted in `health`).
    pub fn decide_step(&self, v: Handle<Vec4>, health: Handle<Health>) -> Step {
        Step::run(
            DECIDE_LABEL,
            &DECIDE_TILES,
            vec![
                self.params.id(),
                self.member_offsets.id(),
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
            Dispatch::Workgroups(tile_workgroups(self.tiles)),
        )
    }

    /// The frame's end: each tile's motion over the frame and its box.
    pub fn measure_step(&self, x: Handle<Vec4>) -> Step {
        Step::run(
            MEASURE_LABEL,
            &MEASURE_TILES,
            vec![
                self.params.id(),
                self.member_offsets.id(),
                self.members.id(),
                x.id(),
                self.rest.id(),
                self.motion.id(),
                self.bounds.id(),
            ],
            Dispatch::Workgroups(tile_workgroups(self.tiles)),
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
        let tiles = TilePartition::of(&cloth);
        assert_eq!(tiles.members, (0..256).collect::<Vec<u32>>(), "a grid's tiles are runs of its indices");
        assert_eq!(tiles.offsets, vec![0, 64, 128, 192, 256]);
        let (offsets, list) = tile_graph(&cloth, &tiles);
        assert_eq!(offsets, vec![0, 1, 3, 5, 6]);
        assert_eq!(list, vec![1, 0, 2, 1, 3, 2]);
    }

    /// A tile sleeps after `still_frames` calm frames; a neighbour that moves, or a collider
    /// moving near it, wakes it and restarts its count; a far collider does not.
    #[test]
    fn a_tile_sleeps_when_it_and_its_neighbours_stay_still_and_wakes_when_they_move() {
        let p = TileParams {
            particle_count: 128,
            tile_count: 2,
            still_frames: 3,
            still_motion: 1e-3,
            ..Default::default()
        };
        let (offsets, neighbours) = ([0u32, 1, 2], [1u32, 0]);
        let bounds = [Aabb { min: Vec4::ZERO, max: Vec4::ONE }; 2];
        let mut frames = [0u32; 2];
        let mut v = vec![Vec4::new(0.1, 0.0, 0.0, 0.0); 128];
        let decide = |motion: [f32; 2], moving: &[Aabb], frames: &mut [u32; 2], v: &mut [Vec4]| {
            let mut health = Health::default();
            let boxes: Vec<Aabb> = moving.to_vec();
            let p = TileParams { moving_colliders: boxes.len() as u32, ..p };
            let members: Vec<u32> = (0..128).collect();
            let (tiles, graph) = ((&[0u32, 64, 128][..], &members[..]), (&offsets[..], &neighbours[..]));
            decide_tile_at(0, &p, tiles, (&motion, &bounds), graph, &boxes, frames, v, &mut health);
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
    /// Two patches of one mesh, one 2 m above the other, share no tile (runs of Morton order
    /// joined them).
    #[test]
    fn a_mesh_s_tiles_are_compact_patches_of_one_piece_whatever_its_vertex_order() {
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
        let tiles = TilePartition::of(&cloth);
        let mut sorted = tiles.members.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n as u32).collect::<Vec<_>>(), "each particle in one tile");
        let tile = |t: usize| &tiles.members[tiles.offsets[t] as usize..tiles.offsets[t + 1] as usize];
        let extent = |members: &[u32]| {
            let (lo, hi) = members.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
                let p = cloth.positions[i as usize].truncate();
                (lo.min(p), hi.max(p))
            });
            (hi - lo).max_element()
        };
        let count = tiles.tile_count() as usize;
        let widest = (0..count).map(|t| extent(tile(t))).fold(0.0f32, f32::max);
        let full = (0..count).filter(|&t| tile(t).len() == 64).count();
        println!("{count} tiles, {full} full, the widest {widest} m across");
        assert!(tile_sizes_fit(&tiles) && full == 16, "{count} tiles, {full} of them full");
        assert!(widest <= 0.26, "a tile spans {widest} m of the 1 m cloth");
        let in_file_order: Vec<u32> = (0..n as u32).collect();
        assert!(in_file_order.chunks(64).map(extent).fold(0.0f32, f32::max) > 0.9, "the file's order is scrambled");

        let patch = crate::ClothMesh::grid(8, 8, 0.3);
        let vertices =
            patch.vertices.iter().copied().chain(patch.vertices.iter().map(|v| *v + Vec3::Y * 2.0)).collect();
        let triangles =
            patch.triangles.iter().copied().chain(patch.triangles.iter().map(|t| t.map(|i| i + 64))).collect();
        let two =
            crate::ClothBuilder::from_mesh(crate::ClothMesh::from_parts(vertices, triangles).unwrap()).build().unwrap();
        let tiles = TilePartition::of(&two);
        for t in 0..tiles.tile_count() as usize {
            let members = &tiles.members[tiles.offsets[t] as usize..tiles.offsets[t + 1] as usize];
            assert!(members.iter().all(|&i| i < 64) || members.iter().all(|&i| i >= 64), "tile {t}: {members:?}");
        }
    }

    /// Every tile holds 1..=`TILE_PARTICLES` particles.
    fn tile_sizes_fit(tiles: &TilePartition) -> bool {
        tiles.offsets.windows(2).all(|w| (1..=TILE_PARTICLES).contains(&(w[1] - w[0])))
    }

    /// A sleeping particle that self-collision pushes, or whose velocity its friction changes,
    /// wakes for the rest of the frame (it integrates and collides again); one it leaves alone
    /// stays asleep.
    #[test]
    fn a_push_or_friction_wakes_a_sleeping_particle() {
        use drape_kernels::self_contact::{CORRECTION_WORDS, add_correction, apply_self_contact_at};
        use drape_kernels::tiles::SETTLED;
        let settled = Vec4::new(0.0, 0.0, 0.0, SETTLED);
        let mut x = vec![Vec4::new(0.0, 0.0, 0.0, 1.0); 3];
        let mut v = vec![settled; 3];
        // Particle 0 pushed 1 µm along +y (at a thickness of 5 mm), particle 1's velocity
        // changed (fixed-point sums x, y, z, count), particle 2 left alone.
        let mut delta = vec![0u32; 3 * CORRECTION_WORDS as usize];
        add_correction(&mut delta, 0, Vec3::new(0.0, 1e-6, 0.0), 0, 0.005);
        let mut velocity_changes = vec![0u32; 12];
        (velocity_changes[4], velocity_changes[7]) = (1, 1);
        for i in 0..3 {
            apply_self_contact_at((i, 0.005), &mut x, &mut v, (&delta, &velocity_changes));
        }
        assert_eq!([v[0].w, v[1].w, v[2].w], [0.0, 0.0, SETTLED]);
        assert!(x[0].y > 0.0 && x[1] == x[2]);
    }
}
