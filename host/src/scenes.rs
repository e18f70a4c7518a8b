//! Built-in scenes shared by the CLI, the benchmarks and the tests.

use crate::cloth::ClothBuilder;
use glam::{Mat4, Vec3};

/// The default wind: a constant force on the whole cloth (N).
pub const DEFAULT_WIND: Vec3 = Vec3::new(0.3, 0.0, 0.5);

/// How far along each edge from a pinned corner the swinging cloth is held (m): a peg holds a
/// patch, not a point. A single pinned particle carries the corner's load on the same few
/// springs at every resolution, over a shorter rest length the finer the cloth: at 256^2
/// (3.9 mm apart) they stretched past 10x and the run stopped as unstable at frame 34. Up to
/// 64^2 (15.9 mm apart) the patch is the corner particle alone.
pub const PEG: f32 = 0.015;

/// A `grid x grid`, 1 m, 0.2 kg cloth, 1 m above the origin, pinned at two corners (`PEG`),
/// swinging down under gravity with a light wind.
pub fn swinging_cloth(grid: u32) -> ClothBuilder {
    // The top corners lie at (-0.5, 0, 0.5) and (0.5, 0, 0.5) in the cloth's own frame; each
    // box reaches PEG inwards along both edges and past the corner outwards, so rounding of
    // the grid's positions cannot leave a corner out.
    let peg = |x: f32| {
        let corner = Vec3::new(x, 0.0, 0.5);
        (corner - Vec3::splat(PEG), corner + Vec3::splat(PEG))
    };
    let ((left_lo, left_hi), (right_lo, right_hi)) = (peg(-0.5), peg(0.5));
    ClothBuilder::new(grid, grid)
        .external_force(DEFAULT_WIND)
        .transform(Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)))
        .pin_top_corners()
        .pin_within(left_lo, left_hi)
        .pin_within(right_lo, right_hi)
}

/// The pile scene (issue 8): a long strip, `grid` particles along its 3 m and a quarter of that
/// across its 0.5 m, hanging nearly upright with its lower edge 5 cm above a ground plane,
/// tilted a little and pushed sideways so it folds over onto itself as it falls, rather than
/// buckling straight down. The collider is the ground, a 6 m square of two triangles (open).
pub fn pile(grid: u32) -> DrapeScene {
    let (length, width) = (3.0, 0.5);
    let across = (grid / 4).max(2);
    // Rows run along the strip (local Z); stand it up: local Z -> world Y, tilted 0.15 rad.
    let stand = Mat4::from_rotation_z(0.15) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let lift = Mat4::from_translation(Vec3::new(0.0, 0.05 + 0.5 * length, 0.0));
    let cloth = ClothBuilder::new(grid.max(2), across)
        .dimensions(width, length)
        .mass(0.2 * width * length)
        .velocity(Vec3::new(0.4, 0.0, 0.0))
        .transform(lift * stand);
    DrapeScene { mesh: ground(), cloth, thickness: DEFAULT_THICKNESS, friction: DEFAULT_FRICTION }
}

/// A ground: a 6 m square at y = 0, two triangles facing up (open).
pub fn ground() -> crate::mesh::Mesh {
    let h = 3.0;
    crate::mesh::Mesh {
        vertices: vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)],
        triangles: vec![[0, 2, 1], [0, 3, 2]],
    }
}

/// How fast the garment scene's body turns about its vertical axis (rad/s).
pub const GARMENT_TURN_RATE: f32 = 1.5;

/// The garment scene (issue 8): an open tube of cloth (a skirt, 0.2 m radius, 0.5 m long,
/// `around` particles around it), held level 5 cm above a body (an ellipsoid, 0.32 x 0.5 x
/// 0.2 m semi-axes, standing on y = 0), falls over it, catches on its wider sides, and is
/// carried round as the body turns (`garment_rotation`). Self-collision on at the contact
/// thickness.
pub fn garment(around: u32) -> DrapeScene {
    let around = around.max(8);
    let body = crate::mesh::Mesh::icosphere(1.0, 3)
        .transformed(Mat4::from_translation(Vec3::new(0.0, 0.5, 0.0)) * Mat4::from_scale(Vec3::new(0.32, 0.5, 0.2)));
    let (radius, length) = (0.2, 0.5);
    let tube = crate::cloth_mesh::ClothMesh::tube(radius, length, around, square_rings(radius, length, around));
    let cloth = ClothBuilder::from_mesh(tube)
        .transform(Mat4::from_translation(Vec3::new(0.0, 1.05, 0.0)))
        .self_collision(Some(DEFAULT_THICKNESS));
    DrapeScene { mesh: body, cloth, thickness: DEFAULT_THICKNESS, friction: DEFAULT_FRICTION }
}

/// The layered garment scene's overskirt: its gap outside the skirt (m), its length (m, from
/// the skirt's waist down) and its material, a coat's over a skirt's: four times the default
/// stiffness (`ClothBuilder::new`'s 40, 10, 2 N/m) and twice the density.
pub const OVERSKIRT_GAP: f32 = 0.015;
pub const OVERSKIRT_LENGTH: f32 = 0.3;
pub const OVERSKIRT: crate::PieceMaterial =
    crate::PieceMaterial { stiffness: Some(Vec3::new(160.0, 40.0, 8.0)), density: Some(0.4) };

/// The layered garment scene: the garment scene (`garment`) with an overskirt around the skirt
/// (`OVERSKIRT_GAP` outside it, `OVERSKIRT_LENGTH` long from its waist, as many particles
/// around), a piece of the same cloth (`ClothMesh::join`) of its own material (`OVERSKIRT`).
/// The two fall together over the turning body, the overskirt settling onto the skirt, and
/// the cloth's self-collision keeps the layers apart as the body carries them round.
pub fn layered_garment(around: u32) -> DrapeScene {
    let around = around.max(8);
    let mut scene = garment(around);
    let (radius, length) = (0.2 + OVERSKIRT_GAP, OVERSKIRT_LENGTH);
    let mut over = crate::cloth_mesh::ClothMesh::tube(radius, length, around, square_rings(radius, length, around));
    for v in &mut over.vertices {
        v.y += 0.5 - length; // the skirt's waist is at its local y = 0.5
    }
    let skirt = scene.cloth.mesh.take().unwrap_or_default();
    let layered = ClothBuilder::from_mesh(crate::cloth_mesh::ClothMesh::join(&[skirt, over]));
    scene.cloth = ClothBuilder { mesh: layered.mesh, mass: layered.mass, ..scene.cloth }.piece_material(1, OVERSKIRT);
    scene
}

/// The rings a tube of `radius` and `length` (m) with `around` vertices per ring needs for cells
/// about as tall as they are wide.
fn square_rings(radius: f32, length: f32, around: u32) -> u32 {
    ((length / (std::f32::consts::TAU * radius / around as f32)).round() as u32 + 1).max(2)
}

/// The garment scene's body rotation at time `t` (s): turned about +Y by
/// `GARMENT_TURN_RATE * t` (it does not translate).
pub fn garment_rotation(t: f32) -> glam::Quat {
    glam::Quat::from_rotation_y(GARMENT_TURN_RATE * t)
}

/// Contact thickness of the drape scenes (m).
pub const DEFAULT_THICKNESS: f32 = 0.005;

/// The standard benchmark scene (design.md §2): a mesh scaled so its larger horizontal extent
/// is `MESH_EXTENT` and standing on y = 0; a flat square cloth 1.5x that wide, 5 cm above the
/// mesh top, 0.2 kg/m^2, no pins; frames of 1/60 s, settled for 2 s.
pub struct DrapeScene {
    /// The collider mesh, placed.
    pub mesh: crate::mesh::Mesh,
    pub cloth: ClothBuilder,
    pub thickness: f32,
    /// Coulomb friction of the contact.
    pub friction: f32,
}

/// Friction of the drape scenes: enough for cloth to rest on a mesh instead of sliding off
/// within the 2 s settle (the paper's response is frictionless: `--friction 0`).
pub const DEFAULT_FRICTION: f32 = 0.5;

/// Larger horizontal extent of the standard scene's mesh (m): the bunny x6.
pub const MESH_EXTENT: f32 = 0.93;
/// Frames of the standard scene's settle (2 s at 60 frames per second).
pub const SETTLE_FRAMES: u32 = 120;

impl DrapeScene {
    /// The standard scene around `mesh` (any placement) with a `grid x grid` cloth.
    pub fn standard(mesh: &crate::mesh::Mesh, grid: u32) -> Self {
        let mesh = mesh.normalized_for_scene(MESH_EXTENT);
        let (lo, hi) = mesh.bounds();
        let side = 1.5 * (hi.x - lo.x).max(hi.z - lo.z);
        let centre = 0.5 * (lo + hi);
        let cloth = ClothBuilder::new(grid, grid)
            .size(side)
            .mass(0.2 * side * side)
            .transform(Mat4::from_translation(Vec3::new(centre.x, hi.y + 0.05, centre.z)));
        DrapeScene { mesh, cloth, thickness: DEFAULT_THICKNESS, friction: DEFAULT_FRICTION }
    }

    /// The collider of the mesh's own triangles.
    pub fn triangle_collider(&self) -> crate::Collider {
        crate::Collider::mesh(&self.mesh, self.thickness).with_friction(self.friction)
    }

    /// The collider: one sphere per non-empty voxel of an `n x n x n` grid over the mesh.
    pub fn collider(&self, n: u32) -> crate::Result<crate::Collider> {
        let mut collider = crate::Collider::new(crate::collider::voxel_spheres(&self.mesh, n)?, self.thickness);
        collider.friction = self.friction;
        Ok(collider)
    }
}

/// The default scene's mesh: a procedural icosphere (no file needed).
pub fn default_mesh() -> crate::mesh::Mesh {
    crate::mesh::Mesh::icosphere(0.5, 3)
}

/// `../shared/models/<file>` next to the workspace, where the benchmarks and tests read the
/// Stanford models from (they are never committed).
pub fn shared_model(file: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/models").join(file)
}

/// Where a model `file` is found at run time, in this order: `$DRAPE_MODELS/<file>`,
/// `../shared/models/<file>` beside the working directory, then beside the workspace this was
/// built in (`shared_model`). A moved binary finds its models through the first two. The
/// error lists every place looked.
pub fn find_model(file: &str) -> crate::Result<std::path::PathBuf> {
    let mut places = Vec::new();
    if let Some(dir) = std::env::var_os("DRAPE_MODELS") {
        places.push(std::path::PathBuf::from(dir).join(file));
    }
    places.push(std::path::Path::new("../shared/models").join(file));
    places.push(shared_model(file));
    match places.iter().find(|p| p.is_file()) {
        Some(found) => Ok(found.clone()),
        None => Err(crate::Error::Mesh {
            path: std::path::PathBuf::from(file),
            problem: format!(
                "not found; looked in {} (set DRAPE_MODELS to the folder that holds it)",
                places.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
            ),
        }),
    }
}
