//! The run's colliders: the scene's own (the drape scene's mesh, the pile's ground, the
//! garment's turning body) and those a scene file adds as `[[collider]]` tables, each a mesh
//! placed by a transform and moved by a spin about its centre and a constant velocity, or a
//! sequence of OBJ files, one per frame (an animated body exported frame by frame), that
//! deforms it.

use drape::mesh::Mesh;
use drape::scenes::{default_mesh, find_model, ground};
use glam::{EulerRot, Mat4, Quat, Vec3};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};

/// A `[[collider]]` table of a scene file (f64, as TOML reads it: printed back exactly).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub(crate) struct ColliderTable {
    /// icosphere, torus, plane (a 6 m ground), bunny, dragon, or an OBJ path (or empty, with
    /// `mesh-sequence`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub(crate) mesh: String,
    /// OBJ files, one per frame, with a run of `#` where the file's number goes, zero-padded to
    /// the run's width (`walk/body_####.obj`): the collider deforms through them (the same
    /// triangles in every file, their vertices moved), instead of `mesh`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) mesh_sequence: Option<String>,
    /// The number of the sequence's file that holds the collider at the run's start (default
    /// 1): frame f of the run ends on file `sequence-start + f`; past the last file it stays.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) sequence_start: Option<u32>,
    /// The sequence's files per second (default: one per frame of the run); a frame that ends
    /// between two files takes the mix of both.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) sequence_rate: Option<f64>,
    /// Play the sequence over and over (a walk cycle): the file after the last is the first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) sequence_loop: Option<bool>,
    /// Uniform scale, or per axis as [x, y, z].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) scale: Option<Scale>,
    /// Degrees about X, then Y, then Z.
    #[serde(default, deserialize_with = "three", skip_serializing_if = "Option::is_none")]
    pub(crate) rotate: Option<[f64; 3]>,
    /// Metres.
    #[serde(default, deserialize_with = "three", skip_serializing_if = "Option::is_none")]
    pub(crate) translate: Option<[f64; 3]>,
    /// The axis it spins about, through its centre (default +Y).
    #[serde(default, deserialize_with = "three", skip_serializing_if = "Option::is_none")]
    pub(crate) spin_axis: Option<[f64; 3]>,
    /// Radians per second about `spin-axis`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) spin_rate: Option<f64>,
    /// Metres per second.
    #[serde(default, deserialize_with = "three", skip_serializing_if = "Option::is_none")]
    pub(crate) velocity: Option<[f64; 3]>,
}

#[derive(Copy, Clone, Debug, Serialize, PartialEq)]
#[serde(untagged)]
pub(crate) enum Scale {
    Uniform(f64),
    PerAxis([f64; 3]),
}

/// A number or exactly three (serde's untagged enum would name neither in its error).
impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Given {
            One(f64),
            Several(Vec<f64>),
        }
        let wrong = || D::Error::custom("`scale` takes a number or three numbers [x, y, z]");
        match Given::deserialize(deserializer).map_err(|_| wrong())? {
            Given::One(s) => Ok(Scale::Uniform(s)),
            Given::Several(v) => <[f64; 3]>::try_from(v.as_slice()).map(Scale::PerAxis).map_err(|_| wrong()),
        }
    }
}

/// Exactly three numbers, `[x, y, z]` (serde's own arrays take the first three of a longer list
/// and drop the rest).
fn three<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Option<[f64; 3]>, D::Error> {
    let given = Vec::<f64>::deserialize(deserializer)?;
    <[f64; 3]>::try_from(given.as_slice())
        .map(Some)
        .map_err(|_| D::Error::custom(format!("expected three numbers [x, y, z], got {}", given.len())))
}

/// How a collider moves: a spin about an axis through `pivot` and a drift.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct Motion {
    pub(crate) pivot: Vec3,
    pub(crate) axis: Vec3,
    /// rad/s
    pub(crate) spin_rate: f32,
    /// m/s
    pub(crate) velocity: Vec3,
}

impl Motion {
    pub(crate) fn is_static(&self) -> bool {
        self.spin_rate == 0.0 && self.velocity == Vec3::ZERO
    }

    /// What the run prints of it: its spin and its drift, those it has.
    pub(crate) fn describe(&self) -> String {
        let [x, y, z] = self.axis.to_array();
        let [px, py, pz] = self.pivot.to_array();
        let spin = format!("spinning at {} rad/s about ({x}, {y}, {z}) through ({px}, {py}, {pz})", self.spin_rate);
        let [vx, vy, vz] = self.velocity.to_array();
        let drift = format!("drifting at ({vx}, {vy}, {vz}) m/s");
        match (self.spin_rate != 0.0, self.velocity != Vec3::ZERO) {
            (true, true) => format!("{spin}, {drift}"),
            (true, false) => spin,
            (false, true) => drift,
            (false, false) => "still".into(),
        }
    }

    /// The rigid pose at time `t` (s): rest vertex v goes to rotation * v + translation.
    pub(crate) fn pose(&self, t: f32) -> (Quat, Vec3) {
        let rotation = Quat::from_axis_angle(self.axis, self.spin_rate * t);
        (rotation, self.pivot - rotation * self.pivot + self.velocity * t)
    }
}

/// A collider of the run.
pub(crate) struct SceneCollider {
    /// Its name in caches and messages (a USD prim name: letters, digits, underscores).
    pub(crate) name: String,
    /// The mesh at rest, in the world (a sequence's: its shape at the last frame loaded).
    pub(crate) mesh: Mesh,
    pub(crate) motion: Motion,
    /// The files it deforms through, if any.
    pub(crate) sequence: Option<MeshSequence>,
}

impl SceneCollider {
    /// The mesh where it stands at time `t` (a sequence's as its last frame loaded it).
    pub(crate) fn posed(&self, t: f32) -> Mesh {
        if self.motion.is_static() {
            return self.mesh.clone();
        }
        let (rotation, translation) = self.motion.pose(t);
        self.mesh.transformed(Mat4::from_rotation_translation(rotation, translation))
    }

    /// Loads its sequence's shape at the end of frame `frame` (of `frame_dt` s) into `mesh`:
    /// true when it changed (false without a sequence, or past the sequence's last file, where
    /// it stays).
    pub(crate) fn advance(&mut self, frame: u32, frame_dt: f32) -> drape::Result<bool> {
        let Some(sequence) = &mut self.sequence else {
            return Ok(false);
        };
        match sequence.load(frame, frame_dt)? {
            Some(mesh) => {
                self.mesh = mesh;
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

/// A collider's OBJ files, one per frame or at their own rate (`ColliderTable::mesh_sequence`).
pub(crate) struct MeshSequence {
    /// The path with its run of `#` split out: before, the run's width, after.
    before: String,
    width: usize,
    after: String,
    /// The file number at the run's start.
    start: u32,
    /// Files per second; `None`: one file per frame of the run.
    rate: Option<f64>,
    /// How many files a loop goes through (the consecutive ones from `start`), when it loops.
    looped: Option<u32>,
    /// The table's placement, applied to every file.
    transform: Mat4,
    /// The first file's triangles (every file must have them).
    triangles: Vec<[u32; 3]>,
    vertex_count: usize,
    /// The files read last (offset from `start`, placed mesh): one is read once however many
    /// frames fall between it and the next.
    cache: Vec<(u32, Mesh)>,
    /// The first frame that found no file (the collider stays as the last one left it).
    pub(crate) ended_at: Option<u32>,
}

/// How a sequence plays: its files per second (`None`: one per frame) and whether it loops.
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct Playback {
    pub(crate) rate: Option<f64>,
    pub(crate) looped: bool,
}

/// The most files a looping sequence counts (a bound on the scan for its end).
const MOST_LOOPED_FILES: u32 = 1_000_000;

impl MeshSequence {
    /// The sequence `pattern` (one run of `#` in its file name) starting at file `start`,
    /// placed by `transform`, and its first file's mesh.
    fn open(pattern: &str, start: u32, playback: Playback, transform: Mat4) -> drape::Result<(Self, Mesh)> {
        let invalid = |problem: String| drape::Error::InvalidParameter { name: "mesh-sequence", problem };
        let name_at = pattern.rfind(['/', '\\']).map_or(0, |i| i + 1);
        let hashes: Vec<usize> = pattern.match_indices('#').map(|(i, _)| i).collect();
        let (Some(&first), Some(&last)) = (hashes.first(), hashes.last()) else {
            return Err(invalid(format!(
                "`{pattern}` has no `#` where the frame's file number goes: write e.g. `body_####.obj` for \
                 body_0001.obj, body_0002.obj, ..."
            )));
        };
        if first < name_at {
            return Err(invalid(format!(
                "`{pattern}` has `#` in its directory: only the file name may hold them, one run where the frame's \
                 number goes (e.g. `walk/body_####.obj`)"
            )));
        }
        if last + 1 - first != hashes.len() {
            return Err(invalid(format!(
                "`{pattern}` has more than one run of `#` in its file name: write one, where the frame's number goes \
                 (e.g. `body_####.obj`)"
            )));
        }
        let mut sequence = MeshSequence {
            before: pattern[..first].to_string(),
            width: hashes.len(),
            after: pattern[last + 1..].to_string(),
            start,
            rate: playback.rate,
            looped: None,
            transform,
            triangles: Vec::new(),
            vertex_count: 0,
            cache: Vec::new(),
            ended_at: None,
        };
        let path = sequence.path(0);
        if !path.is_file() {
            let what = if path.exists() { "is not a file" } else { "does not exist" };
            return Err(invalid(format!(
                "its first file {} (number {start}, `sequence-start`) {what}: check the pattern `{pattern}` and \
                 `sequence-start`",
                path.display()
            )));
        }
        if playback.looped {
            let files = (1..MOST_LOOPED_FILES).find(|&k| !sequence.path(k).exists()).unwrap_or(MOST_LOOPED_FILES);
            sequence.looped = Some(files);
        }
        let mesh = Mesh::load_obj(&path)?.transformed(transform);
        sequence.triangles = mesh.triangles.clone();
        sequence.vertex_count = mesh.vertices.len();
        sequence.cache.push((0, mesh.clone()));
        Ok((sequence, mesh))
    }

    /// The file `offset` files after the sequence's first (`sequence-start`).
    pub(crate) fn path(&self, offset: u32) -> std::path::PathBuf {
        let number = u64::from(self.start) + u64::from(offset);
        format!("{}{number:0width$}{}", self.before, self.after, width = self.width).into()
    }

    /// The collider's mesh at the end of frame `frame` (of `frame_dt` seconds), placed: the file
    /// that time falls on, or between two files the mix of both by where it falls; `None`
    /// once the files run out (the first number missing ends a sequence that does not loop).
    fn load(&mut self, frame: u32, frame_dt: f32) -> drape::Result<Option<Mesh>> {
        if self.ended_at.is_some() {
            return Ok(None);
        }
        // Where the frame's end falls among the files: one a frame, or at the files' own rate.
        let (at, between) = match self.rate {
            None => (u64::from(frame), 0.0),
            Some(rate) => {
                let position = f64::from(frame) * f64::from(frame_dt) * rate;
                (position.floor() as u64, (position - position.floor()) as f32)
            }
        };
        let looped = self.looped;
        let offset = |k: u64| match looped {
            Some(files) => (k % u64::from(files)) as u32,
            None => u32::try_from(k).unwrap_or(u32::MAX),
        };
        let Some(first) = self.file(offset(at))? else {
            log::warn!(
                "mesh sequence: no {} for frame {frame}: the collider stays as frame {} left it",
                self.path(offset(at)).display(),
                frame.saturating_sub(1)
            );
            self.ended_at = Some(frame);
            return Ok(None);
        };
        if between == 0.0 {
            return Ok(Some(first));
        }
        // Past the last file the next is missing: the last one holds until the frame that
        // reaches the missing one ends the sequence.
        let Some(next) = self.file(offset(at + 1))? else {
            return Ok(Some(first));
        };
        let mut mixed = first;
        for (v, w) in mixed.vertices.iter_mut().zip(&next.vertices) {
            *v += (*w - *v) * between;
        }
        Ok(Some(mixed))
    }

    /// File `offset`'s mesh, placed (from the cache when read last); `None` when it does not
    /// exist. A file with other triangles than the first is an error naming it.
    fn file(&mut self, offset: u32) -> drape::Result<Option<Mesh>> {
        if let Some((_, mesh)) = self.cache.iter().find(|(k, _)| *k == offset) {
            return Ok(Some(mesh.clone()));
        }
        let path = self.path(offset);
        if path.exists() && !path.is_file() {
            return Err(drape::Error::Mesh {
                path,
                problem: "is not a file: a mesh sequence's files are OBJ files, one a frame".into(),
            });
        }
        if !path.exists() {
            return Ok(None);
        }
        let mesh = Mesh::load_obj(&path)?.transformed(self.transform);
        let differs = if mesh.vertices.len() != self.vertex_count || mesh.triangles.len() != self.triangles.len() {
            Some(format!(
                "{} vertices and {} triangles, not the first file's {} and {}",
                mesh.vertices.len(),
                mesh.triangles.len(),
                self.vertex_count,
                self.triangles.len()
            ))
        } else {
            mesh.triangles.iter().zip(&self.triangles).position(|(a, b)| a != b).map(|t| {
                format!(
                    "its triangles are not the first file's (from triangle {} on, as drape reads them): faces on \
                     other vertices, in another order, or with their corners in another order",
                    t + 1
                )
            })
        };
        if let Some(problem) = differs {
            return Err(drape::Error::Mesh {
                path,
                problem: format!(
                    "{problem}: a mesh sequence deforms one mesh, every file with the first's triangles in the same \
                     order, its vertices moved"
                ),
            });
        }
        if self.cache.len() == 2 {
            self.cache.remove(0);
        }
        self.cache.push((offset, mesh.clone()));
        Ok(Some(mesh))
    }
}

/// The meshes `load_mesh` knows by name; any other value is an OBJ path (a scene file finds a
/// relative one beside itself, so a name missing here would be looked for as a file).
pub(crate) const BUILT_IN_MESHES: [&str; 5] = ["icosphere", "torus", "plane", "bunny", "dragon"];

/// A mesh by name (built in, a model from ../shared/models) or OBJ path.
pub(crate) fn load_mesh(name: &str) -> drape::Result<Mesh> {
    match name {
        "icosphere" => Ok(default_mesh()),
        "torus" => Ok(Mesh::torus(0.35, 0.12, 48, 24)),
        "plane" => Ok(ground()),
        "bunny" => Mesh::load_obj(&find_model("stanford-bunny.obj")?),
        "dragon" => Mesh::load_obj(&find_model("stanford-dragon-res2.obj")?),
        path if !std::path::Path::new(path).exists() => Err(drape::Error::InvalidParameter {
            name: "mesh",
            problem: format!(
                "`{path}` is neither a built-in mesh ({}) nor a file that exists",
                BUILT_IN_MESHES.join(", ")
            ),
        }),
        path => Mesh::load_obj(std::path::Path::new(path)),
    }
}

impl ColliderTable {
    /// Checks the numbers (finite, a scale above zero, a spin axis of non-zero length).
    pub(crate) fn check(&self) -> Result<(), String> {
        match (self.mesh.is_empty(), &self.mesh_sequence) {
            (true, None) => return Err("give `mesh` (a built-in name or an OBJ path) or `mesh-sequence`".into()),
            (false, Some(_)) => return Err("give `mesh` or `mesh-sequence`, not both".into()),
            _ => {}
        }
        for (key, given) in [
            ("sequence-start", self.sequence_start.is_some()),
            ("sequence-rate", self.sequence_rate.is_some()),
            ("sequence-loop", self.sequence_loop.is_some()),
        ] {
            if given && self.mesh_sequence.is_none() {
                return Err(format!("`{key}` needs `mesh-sequence`"));
            }
        }
        if let Some(rate) = self.sequence_rate
            && !(rate.is_finite() && rate > 0.0 && rate <= 10_000.0)
        {
            return Err(format!("`sequence-rate` must be in (0, 10000] files per second, got {rate}"));
        }
        let finite = |name: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite() && x.abs() < 1e30) {
                Ok(())
            } else {
                Err(format!("`{name}` must be finite numbers below 1e30 in size, got {v:?}"))
            }
        };
        let scale = self.scale_vector();
        finite("scale", &scale)?;
        if scale.iter().any(|&s| s <= 0.0) {
            return Err(format!("`scale` must be above 0, got {scale:?}"));
        }
        // Beyond, a mesh in metres becomes a point or a plane in f32, or a world of its own.
        if scale.iter().any(|&s| !(SCALE_RANGE.0..=SCALE_RANGE.1).contains(&s)) {
            return Err(format!(
                "`scale` must be within [{:e}, {:e}] (scenes are in metres), got {scale:?}",
                SCALE_RANGE.0, SCALE_RANGE.1
            ));
        }
        finite("rotate", &self.rotate.unwrap_or_default())?;
        finite("translate", &self.translate.unwrap_or_default())?;
        finite("velocity", &self.velocity.unwrap_or_default())?;
        finite("spin-rate", &[self.spin_rate.unwrap_or_default()])?;
        let axis = self.spin_axis.unwrap_or([0.0, 1.0, 0.0]);
        finite("spin-axis", &axis)?;
        if axis.iter().map(|a| a * a).sum::<f64>() < 1e-12 {
            return Err("`spin-axis` must not be zero".into());
        }
        Ok(())
    }

    fn scale_vector(&self) -> [f64; 3] {
        match self.scale {
            None => [1.0; 3],
            Some(Scale::Uniform(s)) => [s; 3],
            Some(Scale::PerAxis(s)) => s,
        }
    }

    /// The placement: scale, then rotate (X, Y, Z), then translate.
    pub(crate) fn transform(&self) -> Mat4 {
        let [x, y, z] = self.rotate.unwrap_or_default().map(|d| (d as f32).to_radians());
        Mat4::from_scale_rotation_translation(
            vec3(self.scale_vector()),
            Quat::from_euler(EulerRot::ZYX, z, y, x),
            vec3(self.translate.unwrap_or_default()),
        )
    }

    /// The collider: its mesh loaded and placed, its motion about its placed centre.
    pub(crate) fn build(&self, index: usize) -> drape::Result<SceneCollider> {
        let (mesh, sequence) = match &self.mesh_sequence {
            Some(pattern) => {
                let playback = Playback { rate: self.sequence_rate, looped: self.sequence_loop.unwrap_or(false) };
                let start = self.sequence_start.unwrap_or(1);
                let (sequence, mesh) = MeshSequence::open(pattern, start, playback, self.transform())?;
                (mesh, Some(sequence))
            }
            None => (load_mesh(&self.mesh)?.transformed(self.transform()), None),
        };
        let (lo, hi) = mesh.bounds();
        let motion = Motion {
            pivot: 0.5 * (lo + hi),
            axis: vec3(unit(self.spin_axis.unwrap_or([0.0, 1.0, 0.0]))),
            spin_rate: self.spin_rate.unwrap_or(0.0) as f32,
            velocity: vec3(self.velocity.unwrap_or_default()),
        };
        Ok(SceneCollider { name: format!("collider{}", index + 1), mesh, motion, sequence })
    }
}

/// The scales a `[[collider]]` table may give (each axis).
const SCALE_RANGE: (f64, f64) = (1e-6, 1e6);

/// `v` (not zero) at unit length, in f64: an axis of 1e20 normalised in f32 overflows to 0.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let length = v.iter().map(|a| a * a).sum::<f64>().sqrt();
    v.map(|a| a / length)
}

fn vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// Every collider's triangles at time `t` in one mesh (for the accuracy and intersection
/// checks, which see all colliders at once).
pub(crate) fn union_at(colliders: &[SceneCollider], t: f32) -> Mesh {
    let mut union = Mesh { vertices: Vec::new(), triangles: Vec::new() };
    for c in colliders {
        let posed = c.posed(t);
        let base = union.vertices.len() as u32;
        union.vertices.extend(posed.vertices);
        union.triangles.extend(posed.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    union
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every name `BUILT_IN_MESHES` lists is one `load_mesh` knows, not read as a file (the
    /// models may be missing here: then the error names the model, not a file called `bunny`).
    #[test]
    fn every_built_in_mesh_name_is_known_to_load_mesh() {
        for name in BUILT_IN_MESHES {
            if let Err(e) = load_mesh(name) {
                let message = e.to_string();
                assert!(!message.contains(&format!("mesh {name}:")), "{name} was read as a path: {message}");
            }
        }
    }
}
