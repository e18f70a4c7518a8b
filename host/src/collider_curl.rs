//! Which triangles of a triangle collider lie where its surface wraps round within a
//! cloth cell: a rod, a wire, a thin wall's rim, narrower than the cloth's cells. Their
//! vertices and edges are tested against a self-colliding cloth's faces and edges whatever
//! their folds (`drape_kernels::self_contact::CURLED_BIT`).
//!
//! The fold test (`drape_kernels::self_contact::sharp_for`) takes one edge at a time: an edge
//! whose two faces, reaching half a cloth edge either side, would lift a cloth edge lying across
//! it by half the thickness. A rod tessellated finely folds a little at each of its edges and
//! turns right round within a cloth cell: a cloth cell draped over it hangs on both sides, no
//! particle touches it, and no edge folds enough to be tested, so it cut the cloth (a rod of 3
//! mm radius in 48 sides under the standard scene's 64^2 cloth: 192 of its edges through the
//! cloth at frame 7, 51 of 90 frames crossed; with the fail-safe the whole cloth went back in
//! 35 frames and hung there). Where the surface within half a cloth edge of a triangle has a
//! side (its normals do not cancel out), a cloth cell over it rests on it, and the fold test
//! stands: a scan's bumps and ridges are as curved as a rod at that scale, but the cloth rests
//! on the body around them.
//!
//! Measured once, when a solver is built, on the mesh as given: a collider deformed later
//! (`set_collider_vertices`) keeps the marks of its first shape (its deforming triangles are
//! listed every frame anyway, `drape_kernels::sharp_features::may_be_sharp`).

use crate::cloth::Cloth;
use crate::collider_surface::{OPEN, Surface, mark_every_feature};
use drape_kernels::self_contact::EDGE_GROWTH2;
use glam::{UVec4, Vec3};

/// The radius a collider's curl is measured over for `cloths`: half the longest edge, at rest,
/// of those that collide with themselves (grown as the passes grow the cloth's longest edge
/// within a frame, `EDGE_GROWTH2`); `None` when none does (nothing tests the features).
pub fn curl_radius(cloths: &[Cloth]) -> Option<f32> {
    cloths
        .iter()
        .filter(|cloth| cloth.self_collision.is_some())
        .map(|cloth| 0.5 * (cloth.longest_edge2() * EDGE_GROWTH2).sqrt())
        .reduce(f32::max)
}

/// Sets `CURLED_BIT` in the `features` words (`programs::self_contact::collider_features`) of
/// the triangles where the surface wraps round within `radius` (`curled_triangles`); returns
/// how many.
pub fn mark_curled(features: &mut [UVec4], vertices: &[Vec3], triangles: &[[u32; 3]], radius: f32) -> usize {
    mark_every_feature(features, &curled_triangles(vertices, triangles, radius))
}

/// Per triangle of `triangles` (over `vertices`), whether the surface within `radius` of its
/// centroid (the triangles reachable across shared edges through triangles within `radius` of
/// it) wraps round: its normals, weighted by area, mostly cancel out (`NET_SIDE`),
/// so it has no side a cloth cell could rest on. A rod or a wire, a thin wall's rim, a small
/// closed body do; a flat or gently curved patch, however noisy, does not. Open and non-manifold
/// edges are not crossed (their own edges are always tested: `sharp_for`).
pub fn curled_triangles(vertices: &[Vec3], triangles: &[[u32; 3]], radius: f32) -> Vec<bool> {
    let surface = Surface::new(vertices, triangles);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, 8);
    let chunk = triangles.len().div_ceil(threads).max(1);
    let mut curled = vec![false; triangles.len()];
    std::thread::scope(|scope| {
        for (c, out) in curled.chunks_mut(chunk).enumerate() {
            let surface = &surface;
            scope.spawn(move || {
                let mut patch = Patch::new(triangles.len());
                for (i, curls) in out.iter_mut().enumerate() {
                    *curls = patch.curls(surface, c * chunk + i, radius);
                }
            });
        }
    });
    curled
}

/// A surface curls where its area-weighted normals sum to less than this fraction of its area:
/// its area seen from the best side, against all of it (1 for a flat patch). A cylinder's patch
/// spanning an angle 2a around it keeps sin(a) / a, under a half beyond a = 1.9 rad: within 2
/// cm, a rod or bar of radius up to 1 cm. The scans' patches keep more: within half the
/// standard scene's cloth edge (1.9 cm), 15 of the bunny's 69451 triangles sum under a half
/// and 11332 of the dragon's 202520 (its claws, horns and teeth).
const NET_SIDE: f32 = 0.5;

/// The most triangles one triangle's measure takes in: on a mesh much finer than the cloth
/// (its triangles a few millimetres, the radius centimetres) the patch is cut to the triangles
/// nearest by steps across edges (a disc of about 9 rings), so the measure costs at most this
/// many visits a triangle: an icosphere of 1.3 M triangles (0.93 m across) at the standard
/// scene's radius took 16 s, each patch about a thousand triangles, and takes 3.7 s (2 threads).
/// A wire in more than about 100 sides does not wrap within it; `collider_crease`'s cut across
/// its long edges turns back round it, which marks it.
const PATCH_BUDGET: usize = 256;

/// One thread's walk state, reused from triangle to triangle.
struct Patch {
    /// The triangle whose walk last saw each triangle (+ 1; 0: none yet).
    seen_by: Vec<u32>,
    pending: std::collections::VecDeque<u32>,
}

impl Patch {
    fn new(triangles: usize) -> Self {
        Patch { seen_by: vec![0; triangles], pending: std::collections::VecDeque::new() }
    }

    /// `curled_triangles` for triangle `t`: the patch taken breadth first (nearest by steps
    /// across edges), at most `PATCH_BUDGET` triangles.
    fn curls(&mut self, surface: &Surface<'_>, t: usize, radius: f32) -> bool {
        let stamp = t as u32 + 1;
        self.pending.clear();
        self.pending.push_back(t as u32);
        self.seen_by[t] = stamp;
        let (mut sum, mut area) = (Vec3::ZERO, 0.0);
        let mut taken = 1;
        while let Some(u) = self.pending.pop_front() {
            let normal = surface.normals[u as usize];
            sum += normal;
            area += normal.length();
            for &next in &surface.across[u as usize] {
                if next == OPEN || self.seen_by[next as usize] == stamp || taken == PATCH_BUDGET {
                    continue;
                }
                self.seen_by[next as usize] = stamp;
                if surface.near_centroid(t, next as usize, radius) {
                    self.pending.push_back(next);
                    taken += 1;
                }
            }
        }
        // A patch without area (0 <= 0) has no side either.
        sum.length() <= NET_SIDE * area
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use glam::Mat4;

    /// A cylinder along x of `radius` in `sides`, `length` long, with or without its caps.
    pub(crate) fn cylinder(radius: f32, sides: u32, length: f32, caps: bool) -> Mesh {
        let mut vertices = Vec::new();
        for end in [-0.5, 0.5] {
            for i in 0..sides {
                let a = std::f32::consts::TAU * i as f32 / sides as f32;
                vertices.push(Vec3::new(end * length, radius * a.cos(), radius * a.sin()));
            }
        }
        let mut triangles = Vec::new();
        for i in 0..sides {
            let j = (i + 1) % sides;
            triangles.push([i, j, sides + j]);
            triangles.push([i, sides + j, sides + i]);
        }
        if caps {
            let (c0, c1) = (2 * sides, 2 * sides + 1);
            vertices.extend([Vec3::new(-0.5 * length, 0.0, 0.0), Vec3::new(0.5 * length, 0.0, 0.0)]);
            for i in 0..sides {
                let j = (i + 1) % sides;
                triangles.push([c0, j, i]);
                triangles.push([c1, sides + i, sides + j]);
            }
        }
        Mesh::from_parts(vertices, triangles).expect("a valid cylinder")
    }

    /// A rod narrower than the radius curls everywhere, open or capped; a bar wider than it
    /// does not; a sphere much larger than the radius, a flat sheet and its rim do not; a
    /// sphere within the radius does; a thin wall's rim does, its faces away from the rim do
    /// not.
    #[test]
    fn surfaces_narrower_than_half_a_cloth_edge_curl() {
        let curled = |mesh: &Mesh, radius: f32| curled_triangles(&mesh.vertices, &mesh.triangles, radius);
        let count = |c: &[bool]| c.iter().filter(|&&c| c).count();
        for caps in [true, false] {
            let rod = cylinder(0.003, 48, 1.0, caps);
            let c = curled(&rod, 0.02);
            assert_eq!(count(&c), c.len(), "rod (caps {caps})");
        }
        // A bar of 4 cm radius: none of its sides curls within 2 cm.
        let bar = cylinder(0.04, 48, 1.0, false);
        assert_eq!(count(&curled(&bar, 0.02)), 0, "bar");
        let sphere = Mesh::icosphere(0.5, 4);
        assert_eq!(count(&curled(&sphere, 0.02)), 0, "large sphere");
        let pebble = Mesh::icosphere(0.005, 2);
        assert_eq!(count(&curled(&pebble, 0.02)), pebble.triangles.len(), "small sphere");
        let sheet =
            Mesh::from_parts(vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z], vec![[0, 2, 1], [0, 3, 2]])
                .expect("a quad");
        assert_eq!(count(&curled(&sheet, 0.5)), 0, "flat sheet");
        let wall = Mesh::icosphere(0.2, 4).transformed(Mat4::from_scale(Vec3::new(1.0, 1.0, 0.01)));
        let c = curled(&wall, 0.02);
        let side = |i: &u32| wall.vertices[*i as usize].z > 0.0;
        let rim = wall.triangles.iter().position(|t| t.iter().any(side) && !t.iter().all(side));
        assert!(c[rim.expect("a triangle on the rim")], "wall's rim");
        let middle = wall.triangles.iter().position(|t| t.iter().all(|&i| wall.vertices[i as usize].length() < 0.05));
        assert!(!c[middle.expect("a triangle in the middle")], "wall's face");
    }
}
