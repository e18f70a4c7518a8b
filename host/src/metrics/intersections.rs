//! Exact intersection counts of a cloth state, independent of the kernels: non-adjacent cloth
//! triangles that intersect each other, cloth edges that cross a collider triangle, and collider
//! edges that cross a cloth triangle (a spike or a sharp edge through a cloth cell). Decided with
//! Shewchuk's exact `orient3d` (the `robust` crate) on the f32 coordinates, so no rounding can
//! hide or invent a crossing.
//!
//! A segment crosses a triangle when its ends are on opposite sides of the triangle's plane (or
//! one end on it) and the line through it passes through the closed triangle. A segment lying in
//! the triangle's plane, and a degenerate (zero-area) triangle, cross nothing: coplanar contact
//! has no side to be on. Two non-coplanar triangles intersect exactly when an edge of one crosses
//! the other.

use super::bvh::{self, Bvh};
use glam::{Vec3, Vec4};
use robust::{Coord3D, orient3d};
use std::collections::HashSet;

/// How many pairs intersect.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Intersections {
    /// Pairs of cloth triangles that share no particle and intersect.
    pub cloth_cloth: usize,
    /// (cloth edge, collider triangle) pairs that cross.
    pub cloth_edges_through_collider: usize,
    /// (collider edge, cloth triangle) pairs that cross.
    pub collider_edges_through_cloth: usize,
}

impl Intersections {
    pub fn total(&self) -> usize {
        self.cloth_cloth + self.cloth_edges_through_collider + self.collider_edges_through_cloth
    }
}

fn coord(p: Vec3) -> Coord3D<f64> {
    Coord3D { x: p.x as f64, y: p.y as f64, z: p.z as f64 }
}

/// Sign of the orientation of `d` against the plane through `a`, `b`, `c` (exact).
fn orient(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> i8 {
    let o = orient3d(coord(a), coord(b), coord(c), coord(d));
    if o > 0.0 {
        1
    } else if o < 0.0 {
        -1
    } else {
        0
    }
}

/// Whether segment `p`-`q` crosses triangle `[a, b, c]` (closed; see the module notes).
pub fn segment_crosses_triangle(p: Vec3, q: Vec3, [a, b, c]: [Vec3; 3]) -> bool {
    let (sp, sq) = (orient(a, b, c, p), orient(a, b, c, q));
    if (sp == 0 && sq == 0) || sp * sq > 0 {
        return false;
    }
    let (e0, e1, e2) = (orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a));
    (e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0)
}

/// Whether two triangles intersect (exactly; coplanar overlap is not counted).
pub fn triangles_intersect(t: [Vec3; 3], u: [Vec3; 3]) -> bool {
    let edges = |[a, b, c]: [Vec3; 3]| [(a, b), (b, c), (c, a)];
    edges(t).iter().any(|&(p, q)| segment_crosses_triangle(p, q, u))
        || edges(u).iter().any(|&(p, q)| segment_crosses_triangle(p, q, t))
}

/// A triangle soup with its corners resolved and a BVH over it.
struct Soup {
    triangles: Vec<[Vec3; 3]>,
    boxes: Vec<(Vec3, Vec3)>,
    bvh: Bvh,
}

impl Soup {
    fn new(points: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let triangles: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|i| points[i as usize])).collect();
        let boxes: Vec<(Vec3, Vec3)> = triangles.iter().map(|&[a, b, c]| (a.min(b).min(c), a.max(b).max(c))).collect();
        let bvh = bvh::build(&boxes);
        Soup { triangles, boxes, bvh }
    }

    fn overlapping(&self, lo: Vec3, hi: Vec3, visit: impl FnMut(u32)) {
        self.bvh.for_each_overlapping(lo, hi, &self.boxes, visit);
    }
}

/// Each edge of `triangles` once.
fn edges(triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut seen = HashSet::new();
    let mut out = Vec::new();
    for &[a, b, c] in triangles {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            if seen.insert((p.min(q), p.max(q))) {
                out.push((p.min(q), p.max(q)));
            }
        }
    }
    out
}

/// How many of a cloth's particles (`positions`, xyz) lie within `distance` of one of its own
/// triangles that does not have them as a corner: layers laid closer than a self-collision
/// thickness, which the first passes push apart (and which, lying exactly on each other, have no
/// side to be pushed to). `None` where the cloth's own triangles are less than twice `distance`
/// high: there the faces beside a particle (not its own, one step across an edge) come that
/// near on a flat cloth, so the count would not tell layers.
pub fn particles_near_own_faces(positions: &[Vec4], triangles: &[[u32; 3]], distance: f32) -> Option<usize> {
    let points: Vec<Vec3> = positions.iter().map(|p| p.truncate()).collect();
    let lowest = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| points[i as usize]);
            crate::mesh::triangle_height(a, b, c).unwrap_or(f32::INFINITY)
        })
        .fold(f32::INFINITY, f32::min);
    if lowest < 2.0 * distance {
        return None;
    }
    let cloth = Soup::new(&points, triangles);
    let reach = Vec3::splat(distance);
    let near = (0..points.len())
        .filter(|&i| {
            let p = points[i];
            let mut near = false;
            cloth.overlapping(p - reach, p + reach, |j| {
                let [a, b, c] = cloth.triangles[j as usize];
                if !near && !triangles[j as usize].contains(&(i as u32)) {
                    let (q, _) = drape_kernels::self_contact::closest_with_weights(p, a, b, c);
                    near = (p - q).length() < distance;
                }
            });
            near
        })
        .count();
    Some(near)
}

/// Counts the intersections of a cloth (`positions`, xyz; `triangles`) with itself and with a
/// collider mesh (`collider`: vertices and triangles, in the world; empty for none). Indices
/// out of range are a caller's bug and panic.
pub fn count_intersections(
    positions: &[Vec4],
    triangles: &[[u32; 3]],
    collider: (&[Vec3], &[[u32; 3]]),
) -> Intersections {
    let points: Vec<Vec3> = positions.iter().map(|p| p.truncate()).collect();
    let cloth = Soup::new(&points, triangles);
    let mut result = Intersections::default();
    for (i, t) in triangles.iter().enumerate() {
        let (lo, hi) = cloth.boxes[i];
        cloth.overlapping(lo, hi, |j| {
            let j = j as usize;
            let u = &triangles[j];
            let adjacent = t.iter().any(|v| u.contains(v));
            if j > i && !adjacent && triangles_intersect(cloth.triangles[i], cloth.triangles[j]) {
                result.cloth_cloth += 1;
            }
        });
    }
    let (vertices, collider_triangles) = collider;
    if collider_triangles.is_empty() {
        return result;
    }
    let solid = Soup::new(vertices, collider_triangles);
    for (a, b) in edges(triangles) {
        let (p, q) = (points[a as usize], points[b as usize]);
        solid.overlapping(p.min(q), p.max(q), |k| {
            result.cloth_edges_through_collider += segment_crosses_triangle(p, q, solid.triangles[k as usize]) as usize;
        });
    }
    for (a, b) in edges(collider_triangles) {
        let (p, q) = (vertices[a as usize], vertices[b as usize]);
        cloth.overlapping(p.min(q), p.max(q), |k| {
            result.collider_edges_through_cloth += segment_crosses_triangle(p, q, cloth.triangles[k as usize]) as usize;
        });
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    const FLAT: [Vec3; 3] = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];

    /// Two 2 x 2-cell sheets of 10 cm cells, `gap` apart in y (the second shifted half a cell):
    /// every particle of each is within 5 mm of the other's faces at a 1 mm gap, none at 1 cm;
    /// and a sheet of 1 mm cells cannot tell layers at 5 mm (its own faces beside each particle
    /// come that near).
    #[test]
    fn particles_near_own_faces_counts_layers_laid_closer_than_the_distance() {
        let sheets = |cell: f32, gap: f32| {
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for (layer, y) in [0.0, gap].into_iter().enumerate() {
                let shift = 0.5 * cell * layer as f32;
                let base = positions.len() as u32;
                for i in 0..3 {
                    for j in 0..3 {
                        positions.push(Vec4::new(i as f32 * cell + shift, y, j as f32 * cell + shift, 1.0));
                    }
                }
                for i in 0..2 {
                    for j in 0..2 {
                        let v = |di: u32, dj: u32| base + 3 * (i + di) + (j + dj);
                        triangles.push([v(0, 0), v(1, 0), v(1, 1)]);
                        triangles.push([v(0, 0), v(1, 1), v(0, 1)]);
                    }
                }
            }
            (positions, triangles)
        };
        let (positions, triangles) = sheets(0.1, 0.001);
        // Each layer's particles over the other's faces: all but those beyond its edge (the
        // shifted layer's far row and column, and the first layer's near ones).
        let near = particles_near_own_faces(&positions, &triangles, 0.005).unwrap();
        assert_eq!(near, 2 * 4, "{near}");
        let (positions, triangles) = sheets(0.1, 0.01);
        assert_eq!(particles_near_own_faces(&positions, &triangles, 0.005), Some(0));
        let (positions, triangles) = sheets(0.001, 0.01);
        assert_eq!(particles_near_own_faces(&positions, &triangles, 0.005), None);
    }

    #[test]
    fn a_segment_through_the_interior_crosses_and_one_beside_it_does_not() {
        let down = |x: f32, z: f32| (Vec3::new(x, 1.0, z), Vec3::new(x, -1.0, z));
        let (p, q) = down(0.2, 0.2);
        assert!(segment_crosses_triangle(p, q, FLAT));
        let (p, q) = down(0.8, 0.8);
        assert!(!segment_crosses_triangle(p, q, FLAT));
        // Stopping short of the plane, or lying in it, is no crossing.
        assert!(!segment_crosses_triangle(Vec3::new(0.2, 1.0, 0.2), Vec3::new(0.2, 1e-30, 0.2), FLAT));
        assert!(!segment_crosses_triangle(Vec3::new(-1.0, 0.0, 0.2), Vec3::new(2.0, 0.0, 0.2), FLAT));
    }

    #[test]
    fn touching_an_edge_a_vertex_or_the_plane_counts() {
        // Exactly through the hypotenuse's midpoint, through a corner, ending on the face.
        assert!(segment_crosses_triangle(Vec3::new(0.5, 1.0, 0.5), Vec3::new(0.5, -1.0, 0.5), FLAT));
        assert!(segment_crosses_triangle(Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), FLAT));
        assert!(segment_crosses_triangle(Vec3::new(0.2, 1.0, 0.2), Vec3::new(0.2, 0.0, 0.2), FLAT));
        // A hair beyond the hypotenuse misses: exact, where a rounded test could not tell.
        let beyond = 0.5 + f32::EPSILON;
        assert!(!segment_crosses_triangle(Vec3::new(beyond, 1.0, 0.5), Vec3::new(beyond, -1.0, 0.5), FLAT));
    }

    #[test]
    fn degenerate_triangles_cross_nothing() {
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(!segment_crosses_triangle(Vec3::new(0.5, 1.0, 0.0), Vec3::new(0.5, -1.0, 0.0), line));
    }

    #[test]
    fn crossing_triangles_intersect_and_stacked_ones_do_not() {
        let upright = [Vec3::new(0.2, -1.0, 0.2), Vec3::new(0.2, 1.0, 0.2), Vec3::new(0.3, 0.0, -1.0)];
        assert!(triangles_intersect(FLAT, upright));
        assert!(triangles_intersect(upright, FLAT));
        let above = FLAT.map(|v| v + Vec3::Y * 1e-6);
        assert!(!triangles_intersect(FLAT, above));
    }

    /// The BVH counts exactly what testing every pair counts, on random triangle soups.
    #[test]
    fn counts_equal_brute_force() {
        let mut seed = 12345u64;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let n = 90;
        let positions: Vec<Vec4> = (0..3 * n).map(|_| Vec4::new(random(), random(), random(), 1.0)).collect();
        let mut triangles: Vec<[u32; 3]> = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        triangles.push([0, 4, 7]); // shares particles with triangles 0, 1 and 2: adjacent to them
        let solid: Vec<Vec3> = (0..30).map(|_| Vec3::new(random(), random(), random())).collect();
        let solid_triangles: Vec<[u32; 3]> = (0..10).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let got = count_intersections(&positions, &triangles, (&solid, &solid_triangles));
        let corners = |t: &[u32; 3]| t.map(|i| positions[i as usize].truncate());
        let mut expected = Intersections::default();
        for (i, t) in triangles.iter().enumerate() {
            for u in &triangles[i + 1..] {
                let adjacent = t.iter().any(|v| u.contains(v));
                expected.cloth_cloth += (!adjacent && triangles_intersect(corners(t), corners(u))) as usize;
            }
        }
        for (a, b) in edges(&triangles) {
            let (p, q) = (positions[a as usize].truncate(), positions[b as usize].truncate());
            for s in &solid_triangles {
                let tri = s.map(|i| solid[i as usize]);
                expected.cloth_edges_through_collider += segment_crosses_triangle(p, q, tri) as usize;
            }
        }
        for (a, b) in edges(&solid_triangles) {
            for t in &triangles {
                let crosses = segment_crosses_triangle(solid[a as usize], solid[b as usize], corners(t));
                expected.collider_edges_through_cloth += crosses as usize;
            }
        }
        assert_eq!(got, expected);
        assert!(got.cloth_cloth > 20 && got.cloth_edges_through_collider > 5 && got.collider_edges_through_cloth > 5);
    }
}
