//! Which vertices and edges of a triangle collider's curled triangles (`CURLED_BIT`: every
//! feature they own is tested against a self-colliding cloth at every pass) lie so near a kept
//! one that the passes may leave them out (`drape_kernels::self_contact::COVERED_SHIFT`).
//!
//! A wire tessellated finer than the thickness is curled all round: the 1024 side triangles of
//! a rod of 3 mm radius in 512 sides each tested their 1.2 m edges at every pass, 650 ms of a
//! frame on lavapipe, though its long edges lie 0.037 mm apart round its 18.8 mm circumference
//! (before the standard scene scales it to 2.3 mm).
//!
//! A vertex is covered by a kept vertex within `reach` of it: the cloth faces the kept one
//! holds at the thickness (at a pass's end) stay the thickness less `reach` from it; a face
//! sweeping past it within a pass, which its own swept test would catch, passes within `reach`
//! of the kept one, and the frame's fail-safe stands behind both. An edge is covered by a
//! kept edge when each of its points lies within `reach` of it (the distance to a segment is
//! convex along another, so it is enough that both of its ends do): the cloth edges the kept
//! one holds at the thickness stay that far from it, and a cloth face can only reach an edge
//! across a cloth edge or at the edge's ends, which are vertices, covered or kept in their own
//! right. Not a vertex by an edge: an edge is tested against cloth edges only, so a wire's end
//! whose rim vertices were all covered by its long edges poked through cloth faces.
//!
//! Measured once, when a solver is built, on the mesh as given. A collider deformed later
//! (`set_collider_vertices`) has the reach grown by twice the farthest any vertex lies from
//! that shape (the host's `ColliderControl::update_cover_reach`); the passes skip the covered
//! features while the reach is at most `COVER_LIMIT` of the thickness
//! (`ColliderParams::cover_reach`).

use drape_kernels::self_contact::{
    COVERED_SHIFT, CURLED_BIT, OWNED_FEATURE_BITS, VERTEX_OWNED_BIT, closest_between_segments,
};
use glam::{IVec3, UVec4, Vec3};
use std::collections::HashMap;

/// How far a covered feature lies at most from the kept one, in thicknesses: the cloth keeps
/// three quarters of the thickness from it (`drape_kernels::self_contact::COVER_LIMIT` allows
/// up to half).
pub const COVER_SHARE: f32 = 0.25;

/// The most samples along a kept feature (half a cell apart) the grid enters: a longer one
/// covers none (it is kept and tested all the same).
const MOST_SAMPLES: usize = 1 << 15;

/// The most kept features a feature is compared with (those entered in the cell of its first
/// end, in the order kept): where many long kept edges meet (a fine cone's tip) the cell holds
/// them all. Past it, the feature is kept.
const MOST_CANDIDATES: usize = 256;

/// The most entries the grid holds (a few tens of megabytes): once full, features are kept
/// without covering others. A mesh of long kept edges over a grid of cells sized to its many
/// short ones would otherwise enter each of them in tens of thousands of cells.
const MOST_ENTRIES: usize = 1 << 22;

/// A curled triangle's owned vertex or edge: the triangle, its owned bit, its ends (a vertex's
/// twice).
struct Feature {
    triangle: usize,
    bit: u32,
    ends: [Vec3; 2],
}

/// Whether owned bit `bit` is a vertex's (else an edge's).
fn is_vertex(bit: u32) -> bool {
    bit >= VERTEX_OWNED_BIT
}

impl Feature {
    fn length(&self) -> f32 {
        self.ends[0].distance(self.ends[1])
    }

    /// The distance from `p` to the feature.
    fn distance_to(&self, p: Vec3) -> f32 {
        let [a, b] = self.ends;
        let (_, t) = closest_between_segments(p, p, a, b);
        p.distance(a + (b - a) * t)
    }

    /// Whether this feature covers `other` at `reach`: of the same kind, every point of
    /// `other` within `reach` of it.
    fn covers(&self, other: &Feature, reach: f32) -> bool {
        is_vertex(self.bit) == is_vertex(other.bit) && other.ends.iter().all(|&p| self.distance_to(p) <= reach)
    }
}

/// The owned vertices and edges of the curled triangles, longest first (they cover the most;
/// ties in the triangles' and bits' order, so the result does not depend on a sort's whims).
fn curled_features(features: &[UVec4], vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Feature> {
    let mut found = Vec::new();
    for (t, (feature, corners)) in features.iter().zip(triangles).enumerate() {
        if feature.w & CURLED_BIT == 0 {
            continue;
        }
        let at = |k: usize| vertices[corners[k % 3] as usize];
        for k in 0..3 {
            if feature.w & (1 << k) != 0 {
                found.push(Feature { triangle: t, bit: 1 << k, ends: [at(k), at(k + 1)] });
            }
            if feature.w & (VERTEX_OWNED_BIT << k) != 0 {
                found.push(Feature { triangle: t, bit: VERTEX_OWNED_BIT << k, ends: [at(k), at(k)] });
            }
        }
    }
    found.sort_by(|a, b| b.length().total_cmp(&a.length()).then((a.triangle, a.bit).cmp(&(b.triangle, b.bit))));
    found
}

/// The kept features by the grid cells their points within `reach` fall in.
struct KeptGrid {
    cell: f32,
    reach: f32,
    cells: HashMap<IVec3, Vec<usize>>,
    /// Entries it may still take (`MOST_ENTRIES`).
    room: usize,
}

impl KeptGrid {
    fn cell_of(&self, p: Vec3) -> IVec3 {
        (p / self.cell).floor().as_ivec3()
    }

    /// Enters kept feature `index`, `feature`, in every cell holding a point within `reach` of
    /// it: those round points along it no more than half a cell apart.
    fn enter(&mut self, index: usize, feature: &Feature) {
        let [a, b] = feature.ends;
        let steps = (a.distance(b) / (0.5 * self.cell)).ceil() as usize;
        // Each sample's neighbourhood spans at most 3 cells a side (the cell is at least
        // twice the reach).
        if steps > MOST_SAMPLES || 27 * (steps + 1) > self.room {
            return;
        }
        // A point within `reach` of the segment is within `reach` + a quarter cell of a sample.
        let grow = Vec3::splat(self.reach + 0.25 * self.cell);
        let mut entered = Vec::new();
        for i in 0..=steps {
            let p = a.lerp(b, if steps == 0 { 0.0 } else { i as f32 / steps as f32 });
            let (lo, hi) = (self.cell_of(p - grow), self.cell_of(p + grow));
            for x in lo.x..=hi.x {
                for y in lo.y..=hi.y {
                    for z in lo.z..=hi.z {
                        entered.push(IVec3::new(x, y, z));
                    }
                }
            }
        }
        entered.sort_by_key(|c| (c.x, c.y, c.z));
        entered.dedup();
        self.room -= entered.len();
        for c in entered {
            self.cells.entry(c).or_default().push(index);
        }
    }

    /// The kept features that may hold a point within `reach` of `p`.
    fn near(&self, p: Vec3) -> &[usize] {
        self.cells.get(&self.cell_of(p)).map_or(&[], Vec::as_slice)
    }
}

/// Sets the covered bits (`COVERED_SHIFT`) of the curled triangles' owned features that a kept
/// one covers at `reach` (`Feature::covers`; greedily, longest first: a feature no kept one
/// covers is kept); returns how many of how many were covered.
pub fn cover_curled_features(
    features: &mut [UVec4],
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    reach: f32,
) -> (usize, usize) {
    let curled = curled_features(features, vertices, triangles);
    if curled.is_empty() || reach.is_nan() || reach <= 0.0 {
        return (0, curled.len());
    }
    // Cells of twice the reach (a sample's neighbourhood spans at most 3 a side), or of the
    // median feature when longer (fewer cells for a mesh much coarser than the reach).
    let median = curled[curled.len() / 2].length();
    let mut grid = KeptGrid { cell: (2.0 * reach).max(median), reach, cells: HashMap::new(), room: MOST_ENTRIES };
    let mut covered = 0;
    for (i, feature) in curled.iter().enumerate() {
        let near = grid.near(feature.ends[0]);
        let cover = near.iter().take(MOST_CANDIDATES).any(|&k| curled[k].covers(feature, reach));
        if cover {
            features[feature.triangle].w |= feature.bit << COVERED_SHIFT;
            covered += 1;
        } else {
            grid.enter(i, feature);
        }
    }
    debug_assert!(features.iter().all(|f| (f.w >> COVERED_SHIFT) & !OWNED_FEATURE_BITS == 0));
    (covered, curled.len())
}

#[cfg(test)]
/// An open tube of `radius` round the x axis, `length` long, in `sides` sides and `rings`
/// rings (as the rod under the cloth in the closing note's scene).
pub(crate) fn tube(radius: f32, sides: u32, length: f32, rings: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut vertices = Vec::new();
    for r in 0..rings {
        let x = -0.5 * length + length * r as f32 / (rings - 1) as f32;
        for i in 0..sides {
            let a = std::f32::consts::TAU * i as f32 / sides as f32;
            vertices.push(Vec3::new(x, radius * a.cos(), radius * a.sin()));
        }
    }
    let mut triangles = Vec::new();
    for r in 0..rings - 1 {
        for i in 0..sides {
            let j = (i + 1) % sides;
            let (a, b, c, d) = (r * sides + i, r * sides + j, (r + 1) * sides + j, (r + 1) * sides + i);
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    (vertices, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collider_surface::mark_every_feature;
    use crate::programs::self_contact::collider_features;

    /// A tube of 3 mm round in `sides` sides, 1.2 m long in 3 rings, all its triangles curled.
    fn curled_tube(sides: u32) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<UVec4>) {
        let (vertices, triangles) = tube(0.003, sides, 1.2, 3);
        let mut features = collider_features(&triangles);
        mark_every_feature(&mut features, &vec![true; triangles.len()]);
        (vertices, triangles, features)
    }

    /// Every curled feature's ends, and whether it was covered.
    fn features_of(features: &[UVec4], vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<(Feature, bool)> {
        curled_features(features, vertices, triangles)
            .into_iter()
            .map(|f| {
                let covered = features[f.triangle].w & (f.bit << COVERED_SHIFT) != 0;
                (f, covered)
            })
            .collect()
    }

    #[test]
    fn a_wire_keeps_a_few_features_and_each_covered_one_lies_within_reach_of_a_kept_one() {
        let (vertices, triangles, mut features) = curled_tube(512);
        let reach = 0.25 * 0.005;
        let (covered, count) = cover_curled_features(&mut features, &vertices, &triangles, reach);
        let measured = features_of(&features, &vertices, &triangles);
        assert_eq!(count, measured.len());
        let kept: Vec<&Feature> = measured.iter().filter(|(_, c)| !c).map(|(f, _)| f).collect();
        // Brute force: each covered feature's points, sampled, within reach of one kept feature
        // of its kind (vertices by vertices, edges by edges).
        for (f, _) in measured.iter().filter(|(_, c)| *c) {
            let within = kept
                .iter()
                .filter(|k| is_vertex(k.bit) == is_vertex(f.bit))
                .any(|k| (0..=8).all(|s| k.distance_to(f.ends[0].lerp(f.ends[1], s as f32 / 8.0)) <= reach * 1.0001));
            assert!(within, "a covered feature {:?} lies beyond {reach} m of every kept one", f.ends);
        }
        // Round an 18.8 mm circumference, a kept feature covers 2.5 mm of it: about 8 of each
        // kind per ring (vertices) or per stretch between rings (long edges) are left, of 512.
        let kept_vertices = kept.iter().filter(|k| is_vertex(k.bit)).count();
        println!("kept {} of {count} features ({kept_vertices} vertices)", kept.len());
        assert!((3..=60).contains(&kept_vertices), "kept {kept_vertices} of the 1536 vertices");
        assert!(kept.len() - kept_vertices <= 60, "kept {} edges of {count} features", kept.len() - kept_vertices);
        assert_eq!(covered + kept.len(), count);
    }

    #[test]
    fn features_farther_apart_than_the_reach_and_unmarked_triangles_stay() {
        // A coarse tube (8 sides of 2.3 mm round a 3 mm radius) at a reach of 1.25 mm: its
        // vertices and edges lie farther apart than the reach, so none is covered.
        let (vertices, triangles, mut features) = curled_tube(8);
        let before = features.clone();
        let (covered, count) = cover_curled_features(&mut features, &vertices, &triangles, 0.25 * 0.005);
        assert_eq!((covered, features == before), (0, true), "covered {covered} of {count}");
        // A fine wire whose triangles are not curled: nothing to cover, nothing changed.
        let (vertices, triangles) = tube(0.003, 512, 1.2, 3);
        let mut features = collider_features(&triangles);
        let before = features.clone();
        assert_eq!(cover_curled_features(&mut features, &vertices, &triangles, 0.00125), (0, 0));
        assert!(features == before);
    }
}
