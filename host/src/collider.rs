//! The paper's automatic collider (§2.4.1): the mesh's bounding box cut into `n x n x n` voxels,
//! one sphere per voxel that holds part of the surface.
//!
//! The paper encloses the *vertices* in each voxel. A long triangle can cross a voxel that holds
//! none of its vertices, and that piece of surface then has no sphere: cloth falls through it.
//! Here every triangle is clipped to every voxel it crosses and the sphere encloses the clipped
//! pieces, so every point of the surface lies in some sphere.

use crate::error::{Error, Result};
use crate::mesh::{Mesh, validate};
use glam::{DVec3, Vec4};

/// The largest `n`: 256^3 voxel indices still fit in a u32 and a 256^3 grid is already far
/// finer than any collider worth traversing.
pub const MAX_VOXELS_PER_AXIS: u32 = 256;

/// A triangle clipped to a box has at most 3 + 6 vertices (each of the 6 planes adds at most
/// one); the rest is headroom for rounding.
const MAX_POLYGON: usize = 16;

/// One sphere per non-empty voxel of the mesh's AABB cut into n x n x n voxels: xyz = centre, w = radius.
///
/// A voxel is non-empty if any part of any triangle lies in it (voxels are closed boxes, so a
/// triangle that only touches a voxel's face counts for it too). The sphere's centre is the
/// bounding-box centre of the surface pieces in the voxel, its radius the farthest of them,
/// enlarged by a relative 1e-5 and an absolute 1e-7 of the box diagonal plus two f32 ulps of the
/// largest coordinate, so f32 rounding (here and in the caller's own arithmetic) cannot put a
/// surface point outside. Spheres come in voxel order (x fastest, then y, then z).
///
/// Errors: `n` outside 1..=256 (`Error::InvalidParameter`); a mesh without triangles, with an
/// index out of range or a non-finite vertex (`Error::Mesh`).
pub fn voxel_spheres(mesh: &Mesh, n: u32) -> Result<Vec<Vec4>> {
    if !(1..=MAX_VOXELS_PER_AXIS).contains(&n) {
        return Err(Error::InvalidParameter {
            name: "n",
            problem: format!("voxels per axis must be in 1..={MAX_VOXELS_PER_AXIS}, got {n}"),
        });
    }
    validate(&mesh.vertices, &mesh.triangles).map_err(|problem| Error::Mesh { path: "<memory>".into(), problem })?;
    let grid = Grid::new(mesh, n);
    let vertex = |i: u32| mesh.vertices[i as usize].as_dvec3();

    // (voxel index, point): every used vertex once, in the voxel that holds it...
    let mut points: Vec<(u32, DVec3)> = Vec::with_capacity(mesh.vertices.len() * 2);
    let mut seen = vec![false; mesh.vertices.len()];
    for &i in mesh.triangles.iter().flatten() {
        if !std::mem::replace(&mut seen[i as usize], true) {
            let p = vertex(i);
            points.push((grid.index(grid.cell_of(p)), p));
        }
    }
    // ...then, for triangles that span several voxels, the corners of their piece in each one.
    // A triangle inside one voxel is already enclosed by its vertices: the common case, cheap.
    for &[a, b, c] in &mesh.triangles {
        let tri = [vertex(a), vertex(b), vertex(c)];
        let lo = grid.cell_of(tri[0].min(tri[1]).min(tri[2]));
        let hi = grid.cell_of(tri[0].max(tri[1]).max(tri[2]));
        if lo == hi {
            continue;
        }
        let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let offset = normal.dot(tri[0]);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let cell = [x, y, z];
                    if !grid.plane_may_cross(cell, normal, offset) {
                        continue;
                    }
                    let (polygon, len) = grid.clip(cell, tri);
                    let index = grid.index(cell);
                    points.extend(polygon[..len].iter().map(|&p| (index, p)));
                }
            }
        }
    }

    // Group by voxel; within a group the order does not matter (min, max and the farthest
    // distance do not depend on it), so the unstable sort still gives a deterministic result.
    points.sort_unstable_by_key(|&(index, _)| index);
    let mut spheres = Vec::new();
    for group in points.chunk_by(|p, q| p.0 == q.0) {
        let (mut min, mut max) = (group[0].1, group[0].1);
        for &(_, p) in group {
            min = min.min(p);
            max = max.max(p);
        }
        // The radius is measured from the centre as stored (f32), not the exact one.
        let centre = ((min + max) * 0.5).as_vec3();
        let c = centre.as_dvec3();
        let farthest = group.iter().map(|&(_, p)| p.distance_squared(c)).fold(0.0, f64::max).sqrt();
        let radius = farthest * (1.0 + 1e-5) + grid.epsilon;
        let mut r = radius as f32;
        if (r as f64) < radius {
            r = r.next_up();
        }
        spheres.push(centre.extend(r));
    }
    Ok(spheres)
}

/// The voxel grid over the mesh's bounds, in f64 so clipping adds no error worth speaking of.
struct Grid {
    n: u32,
    min: DVec3,
    max: DVec3,
    cell: DVec3,
    inv_cell: DVec3,
    /// Absolute radius padding.
    epsilon: f64,
}

impl Grid {
    fn new(mesh: &Mesh, n: u32) -> Grid {
        let (min, max) = mesh.bounds();
        let (min, mut max) = (min.as_dvec3(), max.as_dvec3());
        let extent = max - min;
        let largest_coordinate = min.abs().max(max.abs()).max_element();
        // A flat mesh (a cloth-like sheet, a plane) has zero extent on an axis: give that axis a
        // small thickness so the voxels have volume. The sheet then lies on the grid's outer
        // face, not on a face between two voxels, so it fills one layer of voxels, not two.
        let floor =
            if extent.max_element() > 0.0 { extent.max_element() * 1e-4 } else { 1e-6 * largest_coordinate.max(1.0) };
        for axis in 0..3 {
            if extent[axis] < floor {
                max[axis] = min[axis] + floor;
            }
        }
        let cell = (max - min) / n as f64;
        let epsilon = 1e-7 * (max - min).length() + 2.0 * f32::EPSILON as f64 * largest_coordinate;
        Grid { n, min, max, cell, inv_cell: cell.recip(), epsilon }
    }

    /// The voxel holding `p` (points on a face between two voxels go to the upper one; points
    /// outside the grid, by rounding, to the nearest voxel).
    fn cell_of(&self, p: DVec3) -> [u32; 3] {
        let t = ((p - self.min) * self.inv_cell).floor();
        let top = (self.n - 1) as f64;
        [0, 1, 2].map(|axis| t[axis].clamp(0.0, top) as u32)
    }

    /// x fastest, then y, then z.
    fn index(&self, [x, y, z]: [u32; 3]) -> u32 {
        x + self.n * (y + self.n * z)
    }

    /// The coordinate of the face between voxels `i - 1` and `i` on `axis`.
    fn boundary(&self, axis: usize, i: u32) -> f64 {
        if i == self.n { self.max[axis] } else { self.min[axis] + i as f64 * self.cell[axis] }
    }

    /// False when the triangle's plane (`normal . x = offset`) misses the voxel by a clear margin
    /// (a quick rejection before clipping; voxels in a triangle's bounding box mostly miss it).
    fn plane_may_cross(&self, cell: [u32; 3], normal: DVec3, offset: f64) -> bool {
        let lo = DVec3::from_array([0, 1, 2].map(|axis| self.boundary(axis, cell[axis])));
        let hi = DVec3::from_array([0, 1, 2].map(|axis| self.boundary(axis, cell[axis] + 1)));
        let centre = (lo + hi) * 0.5;
        let reach = ((hi - lo) * 0.5).dot(normal.abs());
        let distance = (normal.dot(centre) - offset).abs();
        distance <= reach * (1.0 + 1e-6) + 1e-9 * (offset.abs() + reach)
    }

    /// Sutherland–Hodgman: the part of `tri` inside voxel `cell` (closed box). The grid's outer
    /// faces are not clipped against, so rounding cannot drop a sliver at the mesh's bounds.
    fn clip(&self, cell: [u32; 3], tri: [DVec3; 3]) -> ([DVec3; MAX_POLYGON], usize) {
        let mut polygon = [DVec3::ZERO; MAX_POLYGON];
        polygon[..3].copy_from_slice(&tri);
        let mut len = 3;
        let mut next = [DVec3::ZERO; MAX_POLYGON];
        for axis in 0..3 {
            let i = cell[axis];
            // keep `sign * (x[axis] - value) >= 0`
            let lower = (i > 0).then(|| (1.0, self.boundary(axis, i)));
            let upper = (i + 1 < self.n).then(|| (-1.0, self.boundary(axis, i + 1)));
            for (sign, value) in [lower, upper].into_iter().flatten() {
                let mut out = 0;
                for k in 0..len {
                    if out + 2 > MAX_POLYGON {
                        // Only a polygon made non-convex by rounding can get here. The whole
                        // triangle is a safe (if loose) stand-in for its piece in this voxel.
                        polygon[..3].copy_from_slice(&tri);
                        return (polygon, 3);
                    }
                    let (p, q) = (polygon[k], polygon[(k + 1) % len]);
                    let (dp, dq) = (sign * (p[axis] - value), sign * (q[axis] - value));
                    if dp >= 0.0 {
                        next[out] = p;
                        out += 1;
                    }
                    if (dp >= 0.0) != (dq >= 0.0) {
                        let mut crossing = p + (q - p) * (dp / (dp - dq));
                        crossing[axis] = value;
                        next[out] = crossing;
                        out += 1;
                    }
                }
                std::mem::swap(&mut polygon, &mut next);
                len = out;
                if len == 0 {
                    return (polygon, 0);
                }
            }
        }
        (polygon, len)
    }
}
