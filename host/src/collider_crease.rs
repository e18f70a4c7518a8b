//! Which triangles of a triangle collider lie on a ridge sharper than the cloth's cells,
//! measured over a cell's reach rather than one edge: a rounded edge or crease tessellated
//! finer than the cloth. Their vertices and edges are tested against a self-colliding cloth's
//! faces and edges whatever their folds (`drape_kernels::self_contact::CURLED_BIT`, which
//! `collider_curl` sets where the surface wraps round).
//!
//! The fold test (`drape_kernels::self_contact::sharp_for`) takes one edge at a time: a cloth
//! edge of length L lying across a collider edge folded by f dips about L f / 4 towards it, and
//! the edge is tested where that reaches half the thickness. A box whose edges are rounded in 5
//! mm and 8 segments folds 11 degrees at each (0.2 rad, under the 0.32 the standard scene's
//! cloth asks), yet turns a right angle within a cell: under the standard scene's 64^2 cloth
//! its rims went through the cloth in 84 of 90 frames, 122,936 particles put back by the
//! fail-safe. The same measure over a cell's reach: cut the surface with the plane across the
//! edge (through its midpoint, normal to it) and follow the cut half a cloth edge each way; the
//! edge is a ridge at the cloth's scale where both ends lie the thickness below its tangent
//! plane (a cell across it, its corners at the thickness from the surface, sags onto it; one
//! sharp fold f drops (L / 2) sin(f / 2), about L f / 4). A smooth body is a ridge where its
//! radius of curvature is under L^2 / 8t; the two ends' drops, a cell apart, are not moved by a tilt of the
//! tangent plane, and a scan's noise moves them by its amplitude, not its slope. Seen from
//! either side (a mesh's orientation does not say where the cloth comes from): a concave crease
//! counts too, as the fold test counts concave folds.
//!
//! Measured once, when a solver is built, on the mesh as given: a collider deformed later
//! (`set_collider_vertices`) keeps the marks of its first shape (its deforming triangles are
//! listed every frame anyway, `drape_kernels::sharp_features::may_be_sharp`).

use crate::collider_surface::{OPEN, Surface, mark_every_feature};
use drape_kernels::self_contact::{fold, sharp_for};
use glam::{UVec4, Vec3};

/// How far below its tangent plane, in thicknesses, the cut across an edge must end on both
/// sides for the edge to be a ridge: a cell lying over it, its corners at the thickness from
/// the surface, sags onto it (the reach is already the longest cloth edge's, stretched). Half
/// a thickness, as the fold test asks of one sharp fold, listed the bunny's curved regions
/// too (16,260 of its 69,674 triangles against 3,762, the dragon's 79,241 against 35,819, both
/// before the fold test's own edges were left out), and a box rounded in 8 steps of 11 degrees
/// was not crossed with either.
const RIDGE_DROP: f32 = 1.0;

/// The most triangles a cut crosses on each side: on a mesh much finer than the cloth it stops
/// there and measures the drop where it stopped (at a fraction of the reach, so less of it).
/// Round a wire thinner than the reach the cut turns back past the far side: a wire of 2
/// triangles a side does within the budget up to about 790 sides.
const CUT_BUDGET: usize = 1024;

/// A cut turned back once its distance from the midpoint falls under this fraction of the
/// most it reached (round a wire, about 52 degrees past its far side): the cross-section of a
/// surface with a side moves away from the midpoint, however bumpy.
const TURNED_BACK: f32 = 0.9;

/// Sets `CURLED_BIT` in the `features` words (`programs::self_contact::collider_features`) of
/// the triangles on a ridge at the scale `radius` (`ridge_triangles`); returns how many.
pub fn mark_ridges(
    features: &mut [UVec4],
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    radius: f32,
    thickness: f32,
) -> usize {
    mark_every_feature(features, &ridge_triangles(vertices, triangles, radius, thickness))
}

/// Per triangle of `triangles` (over `vertices`), whether one of its edges is a ridge at the
/// scale `radius` (half a cloth edge) for a cloth resting at `thickness`: the cut across the
/// edge ends, `radius` away on both sides (or where it leaves the surface: a boundary, a fin),
/// at least `RIDGE_DROP` thicknesses below the edge's tangent plane (the mean of its two
/// faces' planes). Both triangles of a ridge edge are marked.
pub fn ridge_triangles(vertices: &[Vec3], triangles: &[[u32; 3]], radius: f32, thickness: f32) -> Vec<bool> {
    let surface = Surface::new(vertices, triangles);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, 8);
    let chunk = triangles.len().div_ceil(threads).max(1);
    let mut found = vec![Vec::new(); threads];
    std::thread::scope(|scope| {
        for (c, ridges) in found.iter_mut().enumerate() {
            let surface = &surface;
            scope.spawn(move || {
                for t in (c * chunk)..((c + 1) * chunk).min(triangles.len()) {
                    for k in 0..3 {
                        let u = surface.across[t][k];
                        // Each edge once, from the earlier of its triangles.
                        if u != OPEN && (u as usize) > t && is_ridge(surface, (t, k), radius, thickness) {
                            ridges.push([t as u32, u]);
                        }
                    }
                }
            });
        }
    });
    let mut marked = vec![false; triangles.len()];
    for [t, u] in found.into_iter().flatten() {
        marked[t as usize] = true;
        marked[u as usize] = true;
    }
    marked
}

/// Whether edge `k` of triangle `t` (shared with the triangle across it) is a ridge the fold
/// test misses: it folds less than the fold test asks at the reach, and the surface's cut
/// across it ends `RIDGE_DROP` thicknesses below its tangent plane on both sides.
fn is_ridge(surface: &Surface<'_>, (t, k): (usize, usize), radius: f32, thickness: f32) -> bool {
    let corners = surface.triangles[t];
    let u = surface.across[t][k] as usize;
    let ends = (corners[k], corners[(k + 1) % 3]);
    let across = surface.triangles[u][(entry_of(surface, u, ends) + 2) % 3];
    let [p, q, apex, across_apex] =
        [ends.0, ends.1, corners[(k + 2) % 3], across].map(|i| surface.vertices[i as usize]);
    let along = q - p;
    let (mine, theirs) = (surface.normals[t].normalize_or_zero(), surface.normals[u].normalize_or_zero());
    let sum = mine + theirs;
    if along.length_squared() <= 0.0 || sum.length_squared() < 0.01 {
        // A degenerate edge or triangle, or one folded back on itself: the fold test takes it
        // as folded shut.
        return false;
    }
    let normal = sum.normalize();
    // An edge folded enough for the fold test is tested there, each pass, at its own cloth
    // edge's length; marked, its triangles' other features would be too (a cone's rim
    // marked its long sides, whose tip and edges then raised its substeps from 29 to 39).
    if sharp_for(fold(p, q, apex, across_apex), 4.0 * radius * radius, thickness) {
        return false;
    }
    let along = along.normalize();
    let midpoint = 0.5 * (p + q);
    let cut = Cut { surface, midpoint, along, radius };
    let entry = |triangle: usize| entry_of(surface, triangle, ends);
    // Each side's first triangle: the one whose apex lies that way across the edge; a surface
    // folded so that both lie one way is measured into each anyway.
    let sideways = normal.cross(along);
    let (ahead, behind) = if (apex - midpoint).dot(sideways) >= 0.0 { (t, u) } else { (u, t) };
    let drop = RIDGE_DROP * thickness;
    let drop_at = |end: Vec3| (midpoint - end).dot(normal);
    let side_drop = |end: CutEnd| match end {
        CutEnd::Reached(p) | CutEnd::Stopped(p) => drop_at(p),
        // The surface wraps round within the reach (a wire, a rim): a cell over it hangs
        // past it on both sides however thin it is (as deep as the drop's side).
        CutEnd::TurnedBack(p) => f32::INFINITY.copysign(drop_at(p)),
    };
    let (one, other) = (side_drop(cut.end(ahead, entry(ahead))), side_drop(cut.end(behind, entry(behind))));
    // A ridge seen from either side: a mesh's orientation does not say which side the cloth
    // comes from (the fold test counts both too).
    one.min(other) >= drop || one.max(other) <= -drop
}

/// The index in `triangle` of its edge between vertices `ends` (either way round).
fn entry_of(surface: &Surface<'_>, triangle: usize, (a, b): (u32, u32)) -> usize {
    let corners = surface.triangles[triangle];
    (0..3)
        .find(|&k| {
            let (p, q) = (corners[k], corners[(k + 1) % 3]);
            (p == a && q == b) || (p == b && q == a)
        })
        .unwrap_or(0)
}

/// How a cut across an edge ended on one side.
enum CutEnd {
    /// At the reach: this point.
    Reached(Vec3),
    /// Back towards the midpoint within the reach, the surface wrapping round (a wire, a rim;
    /// the distance from the midpoint fell under `TURNED_BACK` of the most it reached): the
    /// farthest point.
    TurnedBack(Vec3),
    /// Where it left the surface (a boundary, a fin) or the budget ran out: the farthest point.
    Stopped(Vec3),
}

/// The surface cut by the plane through `midpoint` normal to `along` (an edge's direction),
/// followed from the midpoint to `radius` away.
struct Cut<'s, 'a> {
    surface: &'s Surface<'a>,
    midpoint: Vec3,
    along: Vec3,
    radius: f32,
}

impl Cut<'_, '_> {
    /// Which side of the plane vertex `i` lies on (on it counts as ahead: every edge the cut
    /// crosses then has one end each side, and each triangle it enters has one other).
    fn side(&self, i: u32) -> (bool, f32) {
        let s = (self.surface.vertices[i as usize] - self.midpoint).dot(self.along);
        (s >= 0.0, s)
    }

    /// Where the cut, entering `triangle` through its edge `entry`, ends (`CutEnd`).
    fn end(&self, mut triangle: usize, mut entry: usize) -> CutEnd {
        let (mut at, mut farthest, mut farthest2) = (self.midpoint, self.midpoint, 0.0);
        for _ in 0..CUT_BUDGET {
            let corners = self.surface.triangles[triangle];
            let sides = corners.map(|i| self.side(i));
            let Some(exit) = (0..3).find(|&j| j != entry && sides[j].0 != sides[(j + 1) % 3].0) else {
                return CutEnd::Stopped(farthest);
            };
            let (a, b) = (corners[exit], corners[(exit + 1) % 3]);
            let (sa, sb) = (sides[exit].1, sides[(exit + 1) % 3].1);
            let (va, vb) = (self.surface.vertices[a as usize], self.surface.vertices[b as usize]);
            let next = va + (vb - va) * (sa / (sa - sb));
            let distance2 = next.distance_squared(self.midpoint);
            if distance2 >= self.radius * self.radius {
                return CutEnd::Reached(self.at_radius(at, next));
            }
            if distance2 < TURNED_BACK * TURNED_BACK * farthest2 {
                return CutEnd::TurnedBack(farthest);
            }
            if distance2 > farthest2 {
                (farthest, farthest2) = (next, distance2);
            }
            at = next;
            let across = self.surface.across[triangle][exit];
            if across == OPEN {
                return CutEnd::Stopped(farthest);
            }
            triangle = across as usize;
            entry = entry_of(self.surface, triangle, (a, b));
        }
        CutEnd::Stopped(farthest)
    }

    /// The point of the segment from `inside` (within the radius) to `outside` (beyond it) at
    /// the radius from the midpoint.
    fn at_radius(&self, inside: Vec3, outside: Vec3) -> Vec3 {
        let (w, d) = (inside - self.midpoint, outside - inside);
        let (a, b, c) = (d.length_squared(), w.dot(d), w.length_squared() - self.radius * self.radius);
        if a <= 0.0 {
            return inside;
        }
        let s = ((-b + (b * b - a * c).max(0.0).sqrt()) / a).clamp(0.0, 1.0);
        inside + d * s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;

    const THICKNESS: f32 = 0.005;
    /// Half a cloth edge of 4 cm.
    const RADIUS: f32 = 0.02;

    fn ridges(mesh: &Mesh) -> Vec<bool> {
        ridge_triangles(&mesh.vertices, &mesh.triangles, RADIUS, THICKNESS)
    }

    fn count(marks: &[bool]) -> usize {
        marks.iter().filter(|&&m| m).count()
    }

    /// A box rounded in 5 mm, 16 steps a quarter: each edge folds 5.6 degrees, less than the
    /// fold test asks for a cloth edge of 4 cm, but the surface turns a right angle within it.
    /// The round's middle is a ridge; the faces away from the rounds are not; seen from inside
    /// (the winding reversed) the marks are the same.
    #[test]
    fn a_rounded_edge_finer_than_a_cell_is_a_ridge() {
        let half = Vec3::new(0.2, 0.1, 0.15);
        let (round, segments) = (0.005, 16);
        let step = std::f32::consts::FRAC_PI_2 / segments as f32;
        assert!(
            !sharp_for(1.0 - step.cos(), (2.0 * RADIUS) * (2.0 * RADIUS), THICKNESS),
            "the round's folds must be under the fold test's"
        );
        let boxed = Mesh::rounded_box(half, round, segments, 0.03);
        let marks = ridges(&boxed);
        let centroid = |t: &[u32; 3]| t.iter().map(|&i| boxed.vertices[i as usize]).sum::<Vec3>() / 3.0;
        let (mut middles, mut faces) = (0, 0);
        for (t, &marked) in boxed.triangles.iter().zip(&marks) {
            let c = centroid(t);
            let out = (c.abs() - half).max(Vec3::ZERO);
            // On a rounded edge away from its ends: two coordinates out, each beyond sin(20 deg).
            let beyond = out.to_array().iter().filter(|&&o| o > 0.34 * round).count();
            if beyond == 2 {
                middles += 1;
                assert!(marked, "a triangle at {c} on the round's middle must be a ridge");
            }
            // Farther than the radius from every rounded edge: within one face, away from its rims.
            let inside = (half - c.abs()).to_array().iter().filter(|&&d| d > RADIUS).count();
            if inside == 2 {
                faces += 1;
                assert!(!marked, "a triangle at {c} on a flat face must not be a ridge");
            }
        }
        assert!(middles > 100 && faces > 50, "the box must have rounds ({middles}) and faces ({faces}) to test");
        let inside_out = Mesh {
            vertices: boxed.vertices.clone(),
            triangles: boxed.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
        };
        assert_eq!(ridges(&inside_out), marks, "the marks must not depend on the winding");
    }

    /// A sphere whose cells sag less than the thickness over it, a flat sheet, and the sheet
    /// with bumps of a fifth of the thickness (a scan's noise) are no ridge; a sphere so small
    /// that a cell's sag over it reaches the thickness is one everywhere.
    #[test]
    fn a_smooth_body_a_flat_sheet_and_noise_are_no_ridges() {
        // Sag over a cell (2 RADIUS) of a sphere of radius r: RADIUS^2 / 2r, the thickness at 4 cm.
        let large = Mesh::icosphere(0.08, 5);
        assert_eq!(count(&ridges(&large)), 0, "a sphere of 8 cm");
        let small = Mesh::icosphere(0.025, 4);
        assert_eq!(count(&ridges(&small)), small.triangles.len(), "a sphere of 2.5 cm");
        let sheet = |bumps: f32| {
            let n = 60u32;
            let height = |i: u32, j: u32| {
                let hash = (i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663)) % 1000;
                bumps * (hash as f32 / 1000.0 - 0.5)
            };
            let vertices = (0..=n)
                .flat_map(|i| (0..=n).map(move |j| (i, j)))
                .map(|(i, j)| Vec3::new(0.005 * i as f32, height(i, j), 0.005 * j as f32))
                .collect();
            let at = |i: u32, j: u32| i * (n + 1) + j;
            let triangles = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .flat_map(|(i, j)| {
                    [[at(i, j), at(i, j + 1), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i + 1, j)]]
                })
                .collect();
            Mesh { vertices, triangles }
        };
        assert_eq!(count(&ridges(&sheet(0.0))), 0, "a flat sheet");
        assert_eq!(count(&ridges(&sheet(0.2 * THICKNESS))), 0, "a sheet with bumps of a fifth of the thickness");
    }

    /// A wire in more sides than the curl's patch reaches round (3 mm in 512 sides, each edge
    /// folding 0.7 degrees; a ring of 0.3 m): the cut across its long edges turns back past its
    /// far side, so each of its triangles is on a ridge.
    #[test]
    fn a_wire_of_many_sides_is_a_ridge_all_round() {
        let wire = Mesh::torus(0.3, 0.003, 48, 512);
        assert_eq!(count(&ridges(&wire)), wire.triangles.len());
    }
}
