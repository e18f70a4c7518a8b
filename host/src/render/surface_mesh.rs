//! A mesh's vertex buffers for the renderer (a collider, a ground): positions and area-weighted
//! normals as `Vec4`s at stride 16 (drape's vertex layout), `u32` indices, in host-visible
//! memory so a deforming mesh is updated in place.

use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context};
use glam::{Vec3, Vec4};
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// A triangle mesh in GPU buffers, drawn by [`super::Renderer`].
pub struct SurfaceMesh {
    /// The device the buffers live on (a renderer draws only its own device's meshes).
    pub(crate) ctx: Arc<Context>,
    pub(crate) positions: Buffer,
    pub(crate) normals: Buffer,
    pub(crate) indices: Buffer,
    pub(crate) vertex_count: u32,
    pub(crate) index_count: u32,
}

impl SurfaceMesh {
    /// Uploads `vertices` and `triangles` (indices must be below `vertices.len()`).
    pub fn new(ctx: &Arc<Context>, vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<Self> {
        if let Some(t) = triangles.iter().find(|t| t.iter().any(|&i| i as usize >= vertices.len())) {
            return Err(Error::InvalidParameter {
                name: "triangles",
                problem: format!("triangle {t:?} indexes past the {} vertices", vertices.len()),
            });
        }
        let bytes = (vertices.len() * size_of::<Vec4>()) as u64;
        let mut indices = Buffer::new(ctx, "surface indices", (triangles.len() * 12) as u64, MemoryLocation::CpuToGpu)?;
        write(&mut indices, bytemuck::cast_slice(triangles))?;
        let mut mesh = SurfaceMesh {
            ctx: ctx.clone(),
            positions: Buffer::new(ctx, "surface positions", bytes, MemoryLocation::CpuToGpu)?,
            normals: Buffer::new(ctx, "surface normals", bytes, MemoryLocation::CpuToGpu)?,
            indices,
            vertex_count: vertices.len() as u32,
            index_count: 3 * triangles.len() as u32,
        };
        mesh.write_vertices(vertices, triangles)?;
        Ok(mesh)
    }

    /// New vertex positions (a deforming mesh); the normals follow. Not while a command buffer
    /// that draws the mesh is pending (`Renderer::render` waits for its own).
    pub fn set_vertices(&mut self, vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<()> {
        if vertices.len() != self.vertex_count as usize || 3 * triangles.len() != self.index_count as usize {
            return Err(Error::InvalidParameter {
                name: "vertices",
                problem: format!(
                    "the mesh has {} vertices and {} triangles, got {} and {}",
                    self.vertex_count,
                    self.index_count / 3,
                    vertices.len(),
                    triangles.len()
                ),
            });
        }
        self.write_vertices(vertices, triangles)
    }

    fn write_vertices(&mut self, vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<()> {
        let positions: Vec<Vec4> = vertices.iter().map(|v| v.extend(1.0)).collect();
        write(&mut self.positions, bytemuck::cast_slice(&positions))?;
        write(&mut self.normals, bytemuck::cast_slice(&vertex_normals(vertices, triangles)))
    }
}

/// Copies `bytes` to the start of a host-visible buffer (visible to the next submission).
fn write(buffer: &mut Buffer, bytes: &[u8]) -> Result<()> {
    let mapped = buffer.mapped_mut().ok_or_else(|| Error::Kernel {
        kernel: "surface mesh".into(),
        problem: "vertex buffer is not host-visible".into(),
    })?;
    mapped[..bytes.len()].copy_from_slice(bytes);
    Ok(())
}

/// Per-vertex normals: the sum of the adjacent faces' area-weighted normals, unit length.
pub fn vertex_normals(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec4> {
    let mut normals = vec![Vec3::ZERO; vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    normals.into_iter().map(|n| n.normalize_or_zero().extend(0.0)).collect()
}
