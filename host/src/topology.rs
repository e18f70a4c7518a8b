//! The edges of a triangle mesh: whether it is closed (has an inside), its boundary loops (the
//! holes of an open mesh), and closing the small ones so a scanned model with a few holes (the
//! Stanford bunny's base) collides as the solid it depicts.

use crate::mesh::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// How often each undirected edge (smaller index first) is used by a triangle.
fn edge_uses(mesh: &Mesh) -> HashMap<(u32, u32), u32> {
    let mut uses = HashMap::with_capacity(3 * mesh.triangles.len() / 2);
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    uses
}

/// Whether the mesh encloses an inside: every edge is shared by an even number of triangles
/// (2 on a manifold; back-to-back duplicate faces, as on the dragon, give 4). Only then is
/// "inside" (ray parity) defined.
pub fn is_closed(mesh: &Mesh) -> bool {
    edge_uses(mesh).values().all(|&n| n % 2 == 0)
}

/// Edges used by exactly one triangle.
pub fn boundary_edge_count(mesh: &Mesh) -> usize {
    edge_uses(mesh).values().filter(|&&n| n == 1).count()
}

/// The holes of a mesh: each boundary loop as the triangles' boundary edges `(from, to)` in
/// the direction the triangles run them, chained end to start. Chains that do not close (a
/// boundary whose triangles disagree on orientation) are left out.
pub fn boundary_loops(mesh: &Mesh) -> Vec<Vec<(u32, u32)>> {
    let uses = edge_uses(mesh);
    let mut next: HashMap<u32, Vec<u32>> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if uses.get(&(a.min(b), a.max(b))) == Some(&1) {
                next.entry(a).or_default().push(b);
            }
        }
    }
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable(); // deterministic loop order
    let mut loops = Vec::new();
    for start in starts {
        while let Some(first) = next.get_mut(&start).and_then(Vec::pop) {
            let mut chain = vec![(start, first)];
            let mut at = first;
            let closed = loop {
                if at == start {
                    break true;
                }
                match next.get_mut(&at).and_then(Vec::pop) {
                    Some(to) => {
                        chain.push((at, to));
                        at = to;
                    }
                    None => break false,
                }
            };
            if closed {
                loops.push(chain);
            }
        }
    }
    loops
}

/// What `Mesh::close_holes` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HolesClosed {
    /// Loops filled.
    pub closed: usize,
    /// Boundary loops left open (longer than the limit, or not closing).
    pub left_open: usize,
    /// Longest perimeter filled (m).
    pub longest_filled: f32,
}

impl Mesh {
    /// The mesh with every boundary loop whose perimeter is at most `max_perimeter` filled by a
    /// fan of triangles around the loop's centroid (one new vertex per hole), wound like the
    /// triangles around it, so the result is closed when every loop was filled. Longer loops (a
    /// bowl's rim, a plane's border) stay open. Meant for small, nearly flat holes such as a
    /// scan's; a fan over a strongly curved loop would not be the surface a user expects.
    pub fn close_holes(&self, max_perimeter: f32) -> (Mesh, HolesClosed) {
        let mut mesh = self.clone();
        let mut report = HolesClosed::default();
        for chain in boundary_loops(self) {
            let point = |i: u32| self.vertices[i as usize];
            let perimeter: f32 = chain.iter().map(|&(a, b)| point(a).distance(point(b))).sum();
            if perimeter > max_perimeter || chain.len() < 3 {
                report.left_open += 1;
                continue;
            }
            let centre = chain.iter().map(|&(a, _)| point(a)).sum::<Vec3>() / chain.len() as f32;
            let Ok(c) = u32::try_from(mesh.vertices.len()) else {
                report.left_open += 1;
                continue;
            };
            mesh.vertices.push(centre);
            // A boundary edge a -> b of a triangle is run b -> a by the filling triangle.
            mesh.triangles.extend(chain.iter().map(|&(a, b)| [b, a, c]));
            report.closed += 1;
            report.longest_filled = report.longest_filled.max(perimeter);
        }
        (mesh, report)
    }

    /// `close_holes` with the limit the CLI and the standard scene use: half the diagonal of
    /// the mesh's bounds (the bunny's five base holes are up to 0.46 of it; a bowl's rim or a
    /// plane's border is longer than the diagonal).
    pub fn close_small_holes(&self) -> (Mesh, HolesClosed) {
        let (lo, hi) = self.bounds();
        self.close_holes(SMALL_HOLE_FRACTION * lo.distance(hi))
    }
}

/// Holes up to this share of the bounds' diagonal (in perimeter) are "small".
pub const SMALL_HOLE_FRACTION: f32 = 0.5;
