//! Wavefront OBJ export of a cloth frame (positions, normals, grid triangles).

use crate::cloth::grid_triangles;
use crate::error::{Error, Result};
use glam::Vec4;
use std::io::Write;
use std::path::Path;

/// Writes `positions` and `normals` of a `rows x cols` grid as an OBJ mesh with `vn` lines.
pub fn write_cloth_obj(path: &Path, rows: u32, cols: u32, positions: &[Vec4], normals: &[Vec4]) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = std::io::BufWriter::new(file);
    let mut write = || -> std::io::Result<()> {
        writeln!(out, "# drape cloth {rows} x {cols}")?;
        for p in positions {
            writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
        }
        for n in normals {
            writeln!(out, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        for t in grid_triangles(rows, cols) {
            let [a, b, c] = t.map(|i| i + 1);
            writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}")?;
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
