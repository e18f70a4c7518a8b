//! Wavefront OBJ export of a cloth frame (positions, texture coordinates, normals, triangles)
//! and of a mesh.

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use glam::Vec4;
use std::io::Write;
use std::path::Path;

/// Writes one frame of `cloth` (`positions` and `normals`, one per particle) as an OBJ mesh:
/// `v` and `vn` per particle in order, `vt` when the cloth has texture coordinates, and its
/// triangles.
pub fn write_cloth_obj(path: &Path, cloth: &Cloth, positions: &[Vec4], normals: &[Vec4]) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = std::io::BufWriter::new(file);
    let mut write = || -> std::io::Result<()> {
        writeln!(out, "# drape cloth, {} particles", positions.len())?;
        for p in positions {
            writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
        }
        if let Some(uvs) = &cloth.uvs {
            for uv in &uvs.coords {
                writeln!(out, "vt {} {}", uv.x, uv.y)?;
            }
        }
        for n in normals {
            writeln!(out, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        for (k, t) in cloth.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| i + 1);
            match cloth.uvs.as_ref().and_then(|uvs| uvs.triangles.get(k)) {
                Some(uv) => {
                    let [ta, tb, tc] = uv.map(|i| i + 1);
                    writeln!(out, "f {a}/{ta}/{a} {b}/{tb}/{b} {c}/{tc}/{c}")?;
                }
                None => writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}")?,
            }
        }
        out.flush()
    };
    write().map_err(io)
}

/// Writes a triangle mesh (e.g. the collider) as OBJ.
pub fn write_mesh_obj(path: &Path, mesh: &crate::mesh::Mesh) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = std::io::BufWriter::new(file);
    let mut write = || -> std::io::Result<()> {
        for v in &mesh.vertices {
            writeln!(out, "v {} {} {}", v.x, v.y, v.z)?;
        }
        for t in &mesh.triangles {
            writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
        }
        out.flush()
    };
    write().map_err(io)
}
