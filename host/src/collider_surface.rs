//! A triangle collider's surface as the walks over it read it once, when a solver is built
//! (`collider_curl`, `collider_crease`): the triangle across each edge, each triangle's
//! normal and centroid.

use crate::programs::self_contact::{edge_key, edge_sides};
use drape_kernels::self_contact::CURLED_BIT;
use glam::{UVec4, Vec3};

/// Sets `CURLED_BIT` (every vertex and edge tested, as if folded shut) in the `features` words
/// (`programs::self_contact::collider_features`) of the triangles `marked`; returns how many.
pub(crate) fn mark_every_feature(features: &mut [UVec4], marked: &[bool]) -> usize {
    let mut count = 0;
    for (feature, _) in features.iter_mut().zip(marked).filter(|(_, m)| **m) {
        feature.w |= CURLED_BIT;
        count += 1;
    }
    count
}

/// Marks an edge shared by other than two triangles (a boundary, a fin).
pub(crate) const OPEN: u32 = u32::MAX;

/// A mesh's triangles with what the walks over it read.
pub(crate) struct Surface<'a> {
    pub(crate) vertices: &'a [Vec3],
    pub(crate) triangles: &'a [[u32; 3]],
    /// The triangle across each edge, or `OPEN`.
    pub(crate) across: Vec<[u32; 3]>,
    /// Each triangle's normal scaled by twice its area.
    pub(crate) normals: Vec<Vec3>,
    /// Each triangle's centroid and the distance from it to its farthest corner.
    pub(crate) centroids: Vec<(Vec3, f32)>,
}

impl<'a> Surface<'a> {
    pub(crate) fn new(vertices: &'a [Vec3], triangles: &'a [[u32; 3]]) -> Self {
        let sides = edge_sides(triangles, |t, _| t as u32);
        let across = triangles
            .iter()
            .enumerate()
            .map(|(t, corners)| {
                std::array::from_fn(|k| {
                    let (p, q) = (corners[k], corners[(k + 1) % 3]);
                    match sides.get(&edge_key(p, q)).map(Vec::as_slice) {
                        Some(&[a, b]) if a as usize == t => b,
                        Some(&[a, b]) if b as usize == t => a,
                        _ => OPEN,
                    }
                })
            })
            .collect();
        let normals = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| vertices[i as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        let centroids = triangles
            .iter()
            .map(|t| {
                let corners = t.map(|i| vertices[i as usize]);
                let centroid = (corners[0] + corners[1] + corners[2]) * (1.0 / 3.0);
                (centroid, corners.iter().map(|c| c.distance(centroid)).fold(0.0, f32::max))
            })
            .collect();
        Surface { vertices, triangles, across, normals, centroids }
    }

    /// Whether triangle `u` comes within `radius` of the centroid of triangle `t`: at once
    /// where `u`'s own centroid does, or where its bounding sphere cannot; else exactly.
    pub(crate) fn near_centroid(&self, t: usize, u: usize, radius: f32) -> bool {
        let (from, _) = self.centroids[t];
        let (centroid, reach) = self.centroids[u];
        let apart = from.distance(centroid);
        if apart < radius {
            return true;
        }
        if apart - reach >= radius {
            return false;
        }
        let [a, b, c] = self.triangles[u].map(|i| self.vertices[i as usize]);
        from.distance(drape_kernels::self_contact::closest_with_weights(from, a, b, c).0) < radius
    }
}
