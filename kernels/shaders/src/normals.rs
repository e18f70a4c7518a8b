//! Per-vertex normals for rendering, once per frame: for a grid, the sum of the cross products
//! of consecutive grid edges around a particle (area-weighted normals of the adjacent quads);
//! for a mesh, the sum of its triangles' area-weighted normals; normalised.

use drape_types::SimParams;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use spirv_std::spirv;

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

#[spirv(compute(threads(256)))]
pub fn vertex_normals(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] normals: &mut [Vec4],
) {
    if id.x >= params.particle_count {
        return;
    }
    normals[id.x as usize] = vertex_normal_at(params, id.x, x).extend(0.0);
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

#[spirv(compute(threads(256)))]
pub fn mesh_vertex_normals(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] vertex_triangle_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] vertex_triangles: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] normals: &mut [Vec4],
) {
    if id.x >= params.particle_count {
        return;
    }
    normals[id.x as usize] =
        mesh_vertex_normal_at(id.x, x, vertex_triangle_offsets, vertex_triangles, indices).extend(0.0);
}
