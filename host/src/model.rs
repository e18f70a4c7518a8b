//! The immutable description of a simulation: its cloths, its colliders and how it runs. A
//! `ModelBuilder` collects them and checks everything once (`build`); a `Solver` (GPU) or a
//! `CpuSolver` is then created from the `Model`, and what changes while it runs lives in the
//! solver's state (`State` snapshots it).

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::settings::SimSettings;
use crate::stability::BoundInputs;
use drape_types::{ColliderParams, RigidPose};
use glam::{Vec3, Vec4};

/// A cloth of a model (returned by `ModelBuilder::add_cloth`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ClothId(pub(crate) usize);

/// A collider of a model (returned by `ModelBuilder::add_collider`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ColliderId(pub(crate) usize);

impl ClothId {
    /// The cloth added `index`-th (from 0) to its model; a solver answers an id its model does
    /// not have with an error.
    pub const fn new(index: usize) -> Self {
        ClothId(index)
    }
    /// Position in the order the cloths were added.
    pub fn index(self) -> usize {
        self.0
    }
}

impl ColliderId {
    /// The collider added `index`-th (from 0) to its model.
    pub const fn new(index: usize) -> Self {
        ColliderId(index)
    }
    /// Position in the order the colliders were added.
    pub fn index(self) -> usize {
        self.0
    }
}

/// What a collider is made of, in its own frame: its contact leaves.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ColliderShape {
    /// Spheres (xyz centre, w radius), e.g. the paper's voxel spheres from
    /// `collider::voxel_spheres`: contact with the spheres grown by the thickness.
    Spheres(Vec<Vec4>),
    /// A triangle mesh: contact with its true surface grown by the thickness on both sides
    /// (open meshes, thin parts and degenerate triangles included).
    Triangles { vertices: Vec<Vec3>, triangles: Vec<[u32; 3]> },
}

/// A collider: its shape in its own frame, its initial pose in the world, and the contact
/// thickness (m) and friction.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Collider {
    pub shape: ColliderShape,
    pub thickness: f32,
    /// Coulomb friction coefficient (0 = the paper's frictionless response).
    pub friction: f32,
    /// How contact finds the leaves a particle touches (same answer, different cost).
    pub search: ContactSearch,
    /// Where the collider's frame is in the world at the start (identity: spheres are in world
    /// coordinates). Move it per frame with `Solver::set_collider_pose`.
    pub pose: RigidPose,
}

impl Collider {
    /// A collider of spheres (xyz centre, w radius).
    pub fn new(spheres: Vec<Vec4>, thickness: f32) -> Self {
        Self::of(ColliderShape::Spheres(spheres), thickness)
    }

    /// A collider of `mesh`'s triangles (its true surface).
    pub fn mesh(mesh: &Mesh, thickness: f32) -> Self {
        Self::of(
            ColliderShape::Triangles { vertices: mesh.vertices.clone(), triangles: mesh.triangles.clone() },
            thickness,
        )
    }

    /// A collider of any shape.
    pub fn of(shape: ColliderShape, thickness: f32) -> Self {
        Collider { shape, thickness, friction: 0.0, search: ContactSearch::default(), pose: RigidPose::IDENTITY }
    }

    /// The spheres of a sphere collider (empty for other shapes).
    pub fn spheres(&self) -> &[Vec4] {
        match &self.shape {
            ColliderShape::Spheres(s) => s,
            _ => &[],
        }
    }

    /// Leaves of its LBVH (spheres or triangles).
    pub fn leaf_count(&self) -> usize {
        match &self.shape {
            ColliderShape::Spheres(s) => s.len(),
            ColliderShape::Triangles { triangles, .. } => triangles.len(),
        }
    }

    /// The LBVH and contact parameters, checked.
    pub(crate) fn params(&self) -> Result<ColliderParams> {
        match &self.shape {
            ColliderShape::Spheres(s) => crate::lbvh::collider_params(s, self.thickness, self.friction),
            ColliderShape::Triangles { vertices, triangles } => {
                crate::lbvh::mesh_collider_params(vertices, triangles, self.thickness, self.friction)
            }
        }
    }

    /// The same collider starting at `rotation`, `translation`.
    pub fn with_pose(mut self, rotation: glam::Quat, translation: glam::Vec3) -> Self {
        self.pose = rigid_pose(rotation, translation);
        self
    }

    /// The same collider with Coulomb friction coefficient `friction`.
    pub fn with_friction(mut self, friction: f32) -> Self {
        self.friction = friction;
        self
    }

    /// The same collider tested leaf by leaf instead of through its LBVH (the baseline).
    pub fn brute_force(self) -> Self {
        self.with_search(ContactSearch::BruteForce)
    }

    /// The same collider searched with `search`.
    pub fn with_search(mut self, search: ContactSearch) -> Self {
        self.search = search;
        self
    }
}

/// How contact finds the leaves each particle touches. Every choice gives the same contacts
/// (the tests compare them); they differ in cost.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum ContactSearch {
    /// A broad phase once per frame walks the LBVH with each particle's expected motion over
    /// the frame and keeps a short list of nearby leaves; each substep tests only the list (a
    /// particle that leaves its query box walks the LBVH for that substep).
    #[default]
    CandidateLists,
    /// Walk the LBVH every substep.
    TraverseEverySubstep,
    /// Test every leaf every substep (the baseline).
    BruteForce,
}

/// A `RigidPose` from glam types.
pub fn rigid_pose(rotation: glam::Quat, translation: glam::Vec3) -> RigidPose {
    RigidPose { rotation: Vec4::from(rotation), translation: translation.extend(0.0) }
}

/// Collects cloths and colliders; `build` checks them into a `Model`. Every cloth collides with
/// every collider.
#[derive(Clone, Debug, Default)]
pub struct ModelBuilder {
    cloths: Vec<Cloth>,
    colliders: Vec<Collider>,
    settings: SimSettings,
}

impl ModelBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a cloth (from `ClothBuilder::build`).
    pub fn add_cloth(&mut self, cloth: Cloth) -> ClothId {
        self.cloths.push(cloth);
        ClothId(self.cloths.len() - 1)
    }

    /// Adds a collider.
    pub fn add_collider(&mut self, collider: Collider) -> ColliderId {
        self.colliders.push(collider);
        ColliderId(self.colliders.len() - 1)
    }

    /// How the model runs (default: `SimSettings::default()`).
    pub fn settings(&mut self, settings: SimSettings) -> &mut Self {
        self.settings = settings;
        self
    }

    /// Checks every cloth under the settings (and chooses its substeps) and every collider.
    pub fn build(&self) -> Result<Model> {
        if self.cloths.is_empty() {
            return Err(Error::InvalidParameter {
                name: "model",
                problem: "it has no cloth; add one with `ModelBuilder::add_cloth`".into(),
            });
        }
        let mut bounds = Vec::new();
        for cloth in &self.cloths {
            bounds.push(self.settings.resolve(cloth)?.2);
        }
        for c in &self.colliders {
            c.params()?;
        }
        Ok(Model { cloths: self.cloths.clone(), colliders: self.colliders.clone(), settings: self.settings, bounds })
    }
}

/// What a solver simulates, checked and fixed: cloths, colliders, settings. Runtime changes
/// (poses, forces, stiffness, pins, ...) go through the solver and never alter the model.
#[derive(Clone, Debug)]
pub struct Model {
    cloths: Vec<Cloth>,
    colliders: Vec<Collider>,
    settings: SimSettings,
    /// Each cloth's stability inputs, holding the spectrum estimated when the model was built
    /// (solvers of the model start from it instead of estimating again).
    bounds: Vec<BoundInputs>,
}

impl Model {
    pub fn builder() -> ModelBuilder {
        ModelBuilder::new()
    }

    /// A model of one cloth (`ClothId::new(0)`) and `colliders` (`ColliderId::new(i)` for
    /// `colliders[i]`).
    pub fn single(cloth: &Cloth, colliders: &[Collider], settings: SimSettings) -> Result<Self> {
        let mut builder = ModelBuilder::new();
        builder.add_cloth(cloth.clone());
        for c in colliders {
            builder.add_collider(c.clone());
        }
        builder.settings(settings).build()
    }

    pub fn cloths(&self) -> &[Cloth] {
        &self.cloths
    }
    /// Each cloth's stability inputs.
    pub(crate) fn bounds(&self) -> &[BoundInputs] {
        &self.bounds
    }
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }
    /// The ids of the cloths, in the order they were added.
    pub fn cloth_ids(&self) -> impl Iterator<Item = ClothId> + use<> {
        (0..self.cloths.len()).map(ClothId)
    }
    /// The ids of the colliders, in the order they were added.
    pub fn collider_ids(&self) -> impl Iterator<Item = ColliderId> + use<> {
        (0..self.colliders.len()).map(ColliderId)
    }
    /// The first cloth (every model has one).
    pub fn first_cloth(&self) -> ClothId {
        ClothId(0)
    }
}
