//! How close a cloth lies to itself at rest, where self-collision would see it: the distances
//! between its neighbouring features that share no particle (a vertex and a face beside it
//! that does not hold it, two edges of neighbouring triangles with no end in common), the pairs
//! the passes test and push apart to the thickness. A grid's closest is a vertex to the
//! diagonal across the next cell, 0.71 of its edge, not the edge itself. Under a thickness
//! above it those pairs answer only a crossing (the kernels measure each pair at rest:
//! `drape_kernels::self_contact::touched_at_rest_vertex_face`), so the cloth is thinner than
//! the thickness there; the builder logs where.

use drape_kernels::self_contact::{closest_with_weights, collapsed, longest_side2, segments_offset};
use glam::Vec3;

/// The closest neighbouring features sharing no particle at rest (`closest_unshared_features`).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RestGap {
    /// Their distance (m).
    pub distance: f32,
    /// How many triangles have such a feature pair with a neighbour closer than the thickness
    /// asked about.
    pub triangles_within: usize,
}

/// The closest that two features of neighbouring triangles (sharing at least a particle) lie
/// at `positions` while sharing no particle themselves, and how many triangles have a pair
/// closer than `thickness`; `None` when no two triangles are neighbours. Pairs of triangles
/// that share nothing are layers, not the cloth's own shape (`particles_near_own_faces` warns
/// of those), and faces with no area have no side to measure from.
pub fn closest_unshared_features(positions: &[Vec3], triangles: &[[u32; 3]], thickness: f32) -> Option<RestGap> {
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); positions.len()];
    for (t, tri) in triangles.iter().enumerate() {
        for &i in tri {
            around[i as usize].push(t as u32);
        }
    }
    let corners = |t: u32| triangles[t as usize].map(|i| positions[i as usize]);
    // Each triangle's nearest unshared features, each pair of neighbours measured once.
    let mut nearest = vec![f32::INFINITY; triangles.len()];
    let mut neighbours = Vec::new();
    for (t, tri) in triangles.iter().enumerate() {
        neighbours.clear();
        neighbours.extend(tri.iter().flat_map(|&i| around[i as usize].iter().copied()).filter(|&u| u > t as u32));
        neighbours.sort_unstable();
        neighbours.dedup();
        for &u in &neighbours {
            let gap = unshared_gap((*tri, corners(t as u32)), (triangles[u as usize], corners(u)));
            nearest[t] = nearest[t].min(gap);
            nearest[u as usize] = nearest[u as usize].min(gap);
        }
    }
    let closest = nearest.iter().copied().fold(f32::INFINITY, f32::min);
    let triangles_within = nearest.iter().filter(|&&gap| gap < thickness).count();
    closest.is_finite().then_some(RestGap { distance: closest, triangles_within })
}

/// The closest of each triangle's vertices to the other's face (those not among its corners),
/// and of the edges of the two sharing no particle.
fn unshared_gap((a_ids, a): ([u32; 3], [Vec3; 3]), (b_ids, b): ([u32; 3], [Vec3; 3])) -> f32 {
    vertices_to_face((a_ids, a), (b_ids, b))
        .min(vertices_to_face((b_ids, b), (a_ids, a)))
        .min(edges_apart((a_ids, a), (b_ids, b)))
}

/// The closest of `a`'s vertices that are not `b`'s corners to `b`'s face (none when it has no
/// area: no side to measure from).
fn vertices_to_face((a_ids, a): ([u32; 3], [Vec3; 3]), (b_ids, b): ([u32; 3], [Vec3; 3])) -> f32 {
    let mut gap = f32::INFINITY;
    if collapsed((b[1] - b[0]).cross(b[2] - b[0]).length_squared(), longest_side2(b[0], b[1], b[2])) {
        return gap;
    }
    for k in 0..3 {
        if !b_ids.contains(&a_ids[k]) {
            let (closest, _) = closest_with_weights(a[k], b[0], b[1], b[2]);
            gap = gap.min((a[k] - closest).length());
        }
    }
    gap
}

/// The closest of `a`'s and `b`'s edges that share no particle.
fn edges_apart((a_ids, a): ([u32; 3], [Vec3; 3]), (b_ids, b): ([u32; 3], [Vec3; 3])) -> f32 {
    let mut gap = f32::INFINITY;
    for k in 0..3 {
        let k1 = (k + 1) % 3;
        for m in 0..3 {
            let m1 = (m + 1) % 3;
            let b_edge = [b_ids[m], b_ids[m1]];
            if b_edge.contains(&a_ids[k]) || b_edge.contains(&a_ids[k1]) {
                continue;
            }
            gap = gap.min(segments_offset(a[k], a[k1], b[m], b[m1]).length());
        }
    }
    gap
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth_mesh::ClothMesh;

    /// A grid's closest unshared features are a vertex and the diagonal across the next cell,
    /// its edge over sqrt 2; every triangle has them.
    #[test]
    fn a_grid_s_closest_unshared_features_are_a_vertex_and_the_next_diagonal() {
        let mesh = ClothMesh::grid(9, 9, 0.8);
        let edge = 0.1;
        let gap = closest_unshared_features(&mesh.vertices, &mesh.triangles, 0.08).unwrap();
        assert!((gap.distance - edge / 2f32.sqrt()).abs() < 1e-6, "{gap:?}");
        assert_eq!(gap.triangles_within, mesh.triangles.len());
        assert_eq!(closest_unshared_features(&mesh.vertices, &mesh.triangles, 0.07).unwrap().triangles_within, 0);
    }

    /// A lone triangle has no neighbour; of two triangles sharing an edge, folded nearly shut,
    /// the far vertex of each lies over the other's face, and both count.
    #[test]
    fn a_lone_triangle_has_no_gap_and_a_folded_pair_measures_its_fold() {
        let flat = [Vec3::ZERO, Vec3::X, Vec3::Z];
        assert_eq!(closest_unshared_features(&flat, &[[0, 1, 2]], 1.0), None);
        // A second triangle on edge 1-2, folded nearly shut over the first: its far vertex
        // lies 1 cm over the first face.
        let folded = [Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(0.2, 0.01, 0.2)];
        let gap = closest_unshared_features(&folded, &[[0, 1, 2], [1, 3, 2]], 0.02).unwrap();
        assert!((gap.distance - 0.01).abs() < 1e-6, "{gap:?}");
        assert_eq!(gap.triangles_within, 2);
    }
}
