//! Per-vertex normals for rendering, once per frame: for a grid, the sum of the cross products
//! of consecutive grid edges around a particle (area-weighted normals of the adjacent quads);
//! for a mesh, the sum of its triangles' area-weighted normals; normalised. They run in the
//! frame's last pass with the blow-up check (`health::normals_and_health`).

use drape_types::SimParams;
use drape_types::glam::{Vec3, Vec4, Vec4Swizzles};

/// Unit normal of particle `index`; +Y for a flat cloth in its local XZ plane (rows along +Z,
/// columns along +X). A fully collapsed neighbourhood yields +Y rather than NaN.
pub fn vertex_normal_at(p: &SimParams, index: u32, pos: &[Vec4]) -> Vec3 {
    let row = index / p.cols;
    let col = index % p.cols;
    let here = pos[index as usize].xyz();
    // Edges to the neighbours in the order right, up (+row), left, down; zero where absent.
    let edge = |ok: bool, j: u32| if ok { pos[j as usize].xyz() - here } else { Vec3::ZERO };
    let right = edge(col + 1 < p.cols, index + 1);
    let up = edge(row + 1 < p.rows, index + p.cols);
    let left = edge(col > 0, index.wrapping_sub(1));
    let down = edge(row > 0, index.wrapping_sub(p.cols));
    let sum = up.cross(right) + left.cross(up) + down.cross(left) + right.cross(down);
    let len = sum.length();
    if len > 0.0 { sum * (1.0 / len) } else { Vec3::Y }
}

/// Unit normal of vertex `index` of a mesh cloth: the sum of the cross products of its
/// triangles (`vertex_triangles[offsets[index]..offsets[index + 1]]`, corners in `indices`),
/// gathered per vertex so no thread writes another's. A vertex of no triangle, or of only
/// collapsed ones, gets +Y rather than NaN.
pub fn mesh_vertex_normal_at(
    index: u32,
    pos: &[Vec4],
    offsets: &[u32],
    vertex_triangles: &[u32],
    indices: &[u32],
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut k = offsets[index as usize];
    let end = offsets[index as usize + 1];
    while k < end {
        let t = vertex_triangles[k as usize] as usize * 3;
        let a = pos[indices[t] as usize].xyz();
        let b = pos[indices[t + 1] as usize].xyz();
        let c = pos[indices[t + 2] as usize].xyz();
        sum += (b - a).cross(c - a);
        k += 1;
    }
    let len = sum.length();
    if len > 0.0 { sum * (1.0 / len) } else { Vec3::Y }
}
