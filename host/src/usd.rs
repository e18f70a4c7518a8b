//! An animation cache Blender and Houdini open without add-ons: USD's text form (`.usda`). One
//! `Mesh` prim holds the cloth: its triangles, its texture coordinates (`primvars:st`,
//! face-varying, when the cloth has them) and its points sampled at every frame written (time
//! code = frame number, 60 per second). Each collider is a `Mesh` prim of its rest shape with its
//! pose (translate, then orient) sampled per frame. Frames stream to the file as they come; the
//! colliders and the closing braces are written by `finish`.

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::{Quat, Vec3, Vec4};
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Time codes per second of the cache (drape's frames are 1/60 s).
pub const TIME_CODES_PER_SECOND: u32 = 60;

/// A collider of the cache: its rest shape and its pose per frame.
struct ColliderTrack {
    name: String,
    mesh: Mesh,
    poses: Vec<(u32, Quat, Vec3)>,
    /// A deforming collider's vertices by frame (its own frame's coordinates).
    points: Vec<(u32, Vec<Vec3>)>,
}

/// A `.usda` animation cache being written.
pub struct UsdCache {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    colliders: Vec<ColliderTrack>,
    frames: u32,
}

/// `[(a, b, c), ...]` of the xyz of `points`.
fn point_list(points: impl Iterator<Item = Vec3>) -> String {
    let mut text = String::from("[");
    for (i, p) in points.enumerate() {
        let _ = write!(text, "{}({}, {}, {})", if i == 0 { "" } else { ", " }, p.x, p.y, p.z);
    }
    text.push(']');
    text
}

fn int_list(values: impl Iterator<Item = u32>) -> String {
    let items: Vec<String> = values.map(|v| v.to_string()).collect();
    format!("[{}]", items.join(", "))
}

/// A prim name from any text (letters, digits and underscores; not starting with a digit).
fn prim_name(text: &str) -> String {
    let mut name: String = text.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
    if name.chars().next().is_none_or(|c| c.is_ascii_digit()) {
        name.insert(0, '_');
    }
    name
}

impl UsdCache {
    /// Starts the cache of `cloth` at `path`, for frames `1..=frames` (the stage's time range).
    pub fn create(path: &Path, cloth: &Cloth, frames: u32) -> Result<Self> {
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let file = std::fs::File::create(path).map_err(io)?;
        let mut cache =
            UsdCache { path: path.to_path_buf(), out: std::io::BufWriter::new(file), colliders: Vec::new(), frames };
        let mut head = format!(
            "#usda 1.0\n(\n    defaultPrim = \"drape\"\n    startTimeCode = 1\n    endTimeCode = {frames}\n    \
             timeCodesPerSecond = {TIME_CODES_PER_SECOND}\n    framesPerSecond = {TIME_CODES_PER_SECOND}\n    \
             metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\ndef Xform \"drape\"\n{{\n    def Mesh \"cloth\"\n    {{\n"
        );
        let _ = writeln!(head, "        uniform token subdivisionScheme = \"none\"");
        let _ = writeln!(head, "        int[] faceVertexCounts = {}", int_list(cloth.triangles.iter().map(|_| 3)));
        let _ =
            writeln!(head, "        int[] faceVertexIndices = {}", int_list(cloth.triangles.iter().flatten().copied()));
        if let Some(uvs) = &cloth.uvs {
            let coords: Vec<String> = uvs.coords.iter().map(|c| format!("({}, {})", c.x, c.y)).collect();
            let _ = writeln!(
                head,
                "        texCoord2f[] primvars:st = [{}] (\n            interpolation = \"faceVarying\"\n        )",
                coords.join(", ")
            );
            let _ = writeln!(
                head,
                "        int[] primvars:st:indices = {}",
                int_list(uvs.triangles.iter().flatten().copied())
            );
        }
        let _ = writeln!(head, "        point3f[] points.timeSamples = {{");
        cache.out.write_all(head.as_bytes()).map_err(io)?;
        Ok(cache)
    }

    /// Adds a collider (its rest shape, in its own frame); its poses come with `collider_pose`.
    pub fn add_collider(&mut self, name: &str, mesh: &Mesh) -> usize {
        self.colliders.push(ColliderTrack {
            name: prim_name(name),
            mesh: mesh.clone(),
            poses: Vec::new(),
            points: Vec::new(),
        });
        self.colliders.len() - 1
    }

    /// Collider `index`'s pose at `frame` (rotate, then translate).
    pub fn collider_pose(&mut self, index: usize, frame: u32, rotation: Quat, translation: Vec3) {
        if let Some(c) = self.colliders.get_mut(index) {
            c.poses.push((frame, rotation, translation));
        }
    }

    /// Collider `index`'s vertices at `frame` (a deforming collider: the same triangles).
    pub fn collider_points(&mut self, index: usize, frame: u32, vertices: &[Vec3]) {
        if let Some(c) = self.colliders.get_mut(index) {
            c.points.push((frame, vertices.to_vec()));
        }
    }

    /// The cloth's positions at `frame` (xyz of each particle, in order).
    pub fn frame(&mut self, frame: u32, positions: &[Vec4]) -> Result<()> {
        let line = format!("            {frame}: {},\n", point_list(positions.iter().map(|p| p.truncate())));
        self.out.write_all(line.as_bytes()).map_err(|source| Error::Io { path: self.path.clone(), source })
    }

    /// Closes the cloth's samples, writes the colliders and flushes the file.
    pub fn finish(mut self) -> Result<()> {
        let mut tail = String::from("        }\n    }\n");
        for c in &self.colliders {
            let _ = write!(tail, "\n    def Mesh \"{}\"\n    {{\n", c.name);
            let _ = writeln!(tail, "        uniform token subdivisionScheme = \"none\"");
            let _ = writeln!(tail, "        point3f[] points = {}", point_list(c.mesh.vertices.iter().copied()));
            if !c.points.is_empty() {
                let _ = writeln!(tail, "        point3f[] points.timeSamples = {{");
                for (frame, points) in &c.points {
                    let _ = writeln!(tail, "            {frame}: {},", point_list(points.iter().copied()));
                }
                let _ = writeln!(tail, "        }}");
            }
            let _ = writeln!(tail, "        int[] faceVertexCounts = {}", int_list(c.mesh.triangles.iter().map(|_| 3)));
            let _ = writeln!(
                tail,
                "        int[] faceVertexIndices = {}",
                int_list(c.mesh.triangles.iter().flatten().copied())
            );
            if !c.poses.is_empty() {
                let _ = writeln!(tail, "        float3 xformOp:translate.timeSamples = {{");
                for (frame, _, t) in &c.poses {
                    let _ = writeln!(tail, "            {frame}: ({}, {}, {}),", t.x, t.y, t.z);
                }
                let _ = writeln!(tail, "        }}\n        quatf xformOp:orient.timeSamples = {{");
                for (frame, q, _) in &c.poses {
                    // USD writes a quaternion real part first.
                    let _ = writeln!(tail, "            {frame}: ({}, {}, {}, {}),", q.w, q.x, q.y, q.z);
                }
                let _ = writeln!(tail, "        }}");
                let _ = writeln!(
                    tail,
                    "        uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:orient\"]"
                );
            }
            let _ = writeln!(tail, "    }}");
        }
        tail.push_str("}\n");
        let path = self.path.clone();
        let io = |source| Error::Io { path: path.clone(), source };
        self.out.write_all(tail.as_bytes()).map_err(io)?;
        self.out.flush().map_err(io)?;
        log::debug!("wrote {} ({} frames)", self.path.display(), self.frames);
        Ok(())
    }
}
