//! The run's colliders: the scene's own (the drape scene's mesh, the pile's ground, the
//! garment's turning body) and those a scene file adds as `[[collider]]` tables, each a mesh
//! placed by a transform and moved by a spin about its centre and a constant velocity.

use drape::mesh::Mesh;
use drape::scenes::{default_mesh, find_model, ground};
use glam::{EulerRot, Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

/// A `[[collider]]` table of a scene file (f64, as TOML reads it: printed back exactly).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub(crate) struct ColliderTable {
    /// icosphere, torus, plane (a 6 m ground), bunny, dragon, or an OBJ path.
    pub(crate) mesh: String,
    /// Uniform scale, or per axis as [x, y, z].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) scale: Option<Scale>,
    /// Degrees about X, then Y, then Z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) rotate: Option<[f64; 3]>,
    /// Metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) translate: Option<[f64; 3]>,
    /// The axis it spins about, through its centre (default +Y).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) spin_axis: Option<[f64; 3]>,
    /// Radians per second about `spin-axis`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) spin_rate: Option<f64>,
    /// Metres per second.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) velocity: Option<[f64; 3]>,
}

#[derive(Copy, Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub(crate) enum Scale {
    Uniform(f64),
    PerAxis([f64; 3]),
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
    /// The mesh at rest, in the world.
    pub(crate) mesh: Mesh,
    pub(crate) motion: Motion,
}

impl SceneCollider {
    /// The mesh where it stands at time `t`.
    pub(crate) fn posed(&self, t: f32) -> Mesh {
        if self.motion.is_static() {
            return self.mesh.clone();
        }
        let (rotation, translation) = self.motion.pose(t);
        self.mesh.transformed(Mat4::from_rotation_translation(rotation, translation))
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
        path => Mesh::load_obj(std::path::Path::new(path)),
    }
}

impl ColliderTable {
    /// Checks the numbers (finite, a scale above zero, a spin axis of non-zero length).
    pub(crate) fn check(&self) -> Result<(), String> {
        let finite = |name: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite() && x.abs() < 1e30) {
                Ok(())
            } else {
                Err(format!("`{name}` must be finite numbers"))
            }
        };
        let scale = self.scale_vector();
        finite("scale", &scale)?;
        if scale.iter().any(|&s| s <= 0.0) {
            return Err(format!("`scale` must be above 0, got {scale:?}"));
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
        let mesh = load_mesh(&self.mesh)?.transformed(self.transform());
        let (lo, hi) = mesh.bounds();
        let motion = Motion {
            pivot: 0.5 * (lo + hi),
            axis: vec3(self.spin_axis.unwrap_or([0.0, 1.0, 0.0])).normalize(),
            spin_rate: self.spin_rate.unwrap_or(0.0) as f32,
            velocity: vec3(self.velocity.unwrap_or_default()),
        };
        Ok(SceneCollider { name: format!("collider{}", index + 1), mesh, motion })
    }
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
