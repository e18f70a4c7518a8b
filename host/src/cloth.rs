//! Cloth description: a `rows x cols` particle grid with structural, shear and bend springs,
//! or any triangle mesh (`ClothMesh`) with springs on its edges and across them, built by
//! `ClothBuilder` and validated before anything reaches the GPU.

use crate::cloth_mesh::{ClothMesh, ClothUvs, SpringTopology, StiffnessFactors, lumped_masses};
use crate::error::{Error, Result};
use crate::rest_gap::closest_unshared_features;
use drape_types::{SimParams, integrator};
use glam::{Mat4, Vec2, Vec3, Vec4};

/// The most particles a cloth may have: a kernel runs one thread per particle in workgroups of
/// 256, and a 1-D dispatch reaches at most 65,535 workgroups on every Vulkan device.
pub const MAX_PARTICLES: u32 = 65_535 * drape_kernels::WORKGROUP_SIZE;

/// Coulomb friction between a self-colliding cloth's layers unless set: fabric on fabric is
/// about 0.3 to 0.6.
pub const DEFAULT_SELF_FRICTION: f32 = 0.5;

/// A piece's own material, where it differs from its cloth's: a mesh cloth joined from pieces
/// (`ClothMesh::join`: a stiff coat over a soft shirt, a heavy lining) gives each piece one
/// (`ClothBuilder::piece_material`). The pieces stay one cloth, so self-collision keeps them
/// apart.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PieceMaterial {
    /// Structural, shear and bend stiffness (N/m) in place of the cloth's
    /// (`ClothBuilder::stiffness`; a mesh cloth has no shear springs). The piece's springs take
    /// them as multiples of the cloth's, so their damping scales with them as every scaled
    /// spring's does (`Spring::stiffness_scale`), and a stiffness set at run time scales every
    /// piece alike.
    pub stiffness: Option<Vec3>,
    /// Areal density (kg/m^2) in place of the cloth's (its `mass` over its area).
    pub density: Option<f32>,
}

/// Builder for a cloth: a rectangular grid (`new`), the fast path whose springs the kernels
/// derive from the grid, or a triangle mesh (`from_mesh`), whose springs are listed. The grid
/// lies in the local XZ plane (columns along +X, rows along +Z, normal +Y), centred on the
/// origin; a mesh keeps its own coordinates; then `transform` places either in the world.
#[derive(Clone, Debug)]
pub struct ClothBuilder {
    /// Grid particles per column and row (unused for a mesh cloth).
    pub rows: u32,
    pub cols: u32,
    /// Grid side length (m) along X, and along Z unless `length` is set (unused for a mesh
    /// cloth).
    pub size: f32,
    /// Grid side length (m) along Z (the rows' direction), for a rectangular cloth.
    pub length: Option<f32>,
    /// Total mass (kg): split evenly over a grid's particles, by area over a mesh's.
    pub mass: f32,
    /// The mesh of a mesh cloth (`None`: the grid).
    pub mesh: Option<ClothMesh>,
    /// The mesh's pieces' own materials, by piece (`ClothMesh::triangle_pieces`); a piece past
    /// the end, or a field `None`, takes the cloth's.
    pub piece_materials: Vec<PieceMaterial>,
    /// Self-collision thickness (m): the cloth keeps its particles this far from its own
    /// triangles (`None`: off).
    pub self_collision: Option<f32>,
    /// Coulomb friction coefficient between the cloth's own layers where self-collision
    /// holds them apart (0: they slide freely).
    pub self_friction: f32,
    /// Build a grid with listed springs (the mesh cloths' kernels) instead of its fast path:
    /// the same springs, for measuring and checking one path against the other.
    pub listed_springs: bool,
    /// Spring stiffness (N/m): structural, shear, bend.
    pub k_struct: f32,
    pub k_shear: f32,
    pub k_bend: f32,
    /// Damping along spring axes (N s/m).
    pub spring_damping: f32,
    /// The paper's velocity damping `f = -c_d v` (N s/m per particle).
    pub velocity_damping: f32,
    /// Gravity (m/s^2).
    pub gravity: Vec3,
    /// Constant external force on the whole cloth (N), e.g. wind; split evenly over particles.
    pub external_force: Vec3,
    /// Pinned grid particles as (row, col).
    pub pins: Vec<(u32, u32)>,
    /// Pinned particles by index (grid: row * cols + col; mesh: vertex index).
    pub pinned_vertices: Vec<u32>,
    /// Particles pinned by a box (min, max) in the cloth's own coordinates (before `transform`).
    pub pin_boxes: Vec<(Vec3, Vec3)>,
    /// Initial velocity of every free particle (m/s), e.g. a throw.
    pub velocity: Vec3,
    /// Local-to-world placement (the paper's `trsMatrix`).
    pub transform: Mat4,
}

/// A grid's side (m) unless `ClothBuilder::size` or `dimensions` sets it.
const DEFAULT_GRID_SIZE: f32 = 1.0;

/// The least a cloth may span (m; a grid's side, a mesh's box's longest side).
pub const MIN_CLOTH_EXTENT: f32 = 1e-3;

/// The longest side of the box around the `vertices` that `triangles` use.
fn extent(vertices: &[Vec3], triangles: &[[u32; 3]]) -> f32 {
    let (lo, hi) = crate::mesh::used_bounds(vertices, triangles);
    (hi - lo).max_element()
}

impl ClothBuilder {
    /// A `rows x cols` cloth, 1 m square, 0.2 kg/m^2, moderately stiff, with gravity, no pins.
    pub fn new(rows: u32, cols: u32) -> Self {
        ClothBuilder {
            rows,
            cols,
            size: DEFAULT_GRID_SIZE,
            length: None,
            mass: 0.2,
            mesh: None,
            piece_materials: Vec::new(),
            self_collision: None,
            self_friction: DEFAULT_SELF_FRICTION,
            listed_springs: false,
            k_struct: 40.0,
            k_shear: 10.0,
            k_bend: 2.0,
            spring_damping: 0.002,
            velocity_damping: 0.0,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            external_force: Vec3::ZERO,
            pins: Vec::new(),
            pinned_vertices: Vec::new(),
            pin_boxes: Vec::new(),
            velocity: Vec3::ZERO,
            transform: Mat4::IDENTITY,
        }
    }

    /// A cloth of `mesh`'s triangles (one particle per vertex, in its order), 0.2 kg/m^2.
    pub fn from_mesh(mesh: ClothMesh) -> Self {
        let area = mesh.area();
        let mut builder = ClothBuilder::new(2, 2).mass(0.2 * area);
        builder.mesh = Some(mesh);
        builder
    }

    /// Self-collision at `thickness` (m), or `None` for off (the default: off costs nothing).
    pub fn self_collision(mut self, thickness: Option<f32>) -> Self {
        self.self_collision = thickness;
        self
    }

    /// Coulomb friction between the cloth's layers under self-collision (default
    /// `DEFAULT_SELF_FRICTION`; 0: frictionless).
    pub fn self_friction(mut self, friction: f32) -> Self {
        self.self_friction = friction;
        self
    }

    /// Builds the grid with listed springs (`listed_springs`).
    pub fn listed_springs(mut self, listed: bool) -> Self {
        self.listed_springs = listed;
        self
    }

    pub fn size(mut self, size: f32) -> Self {
        self.size = size;
        self
    }
    /// A rectangular grid: `width` (m) along X (columns), `length` along Z (rows).
    pub fn dimensions(mut self, width: f32, length: f32) -> Self {
        (self.size, self.length) = (width, Some(length));
        self
    }
    /// Total mass (kg): a grid's, split evenly; a mesh's, spread by area (its pieces with a
    /// density of their own, `piece_material`, take theirs instead of this one's mean).
    pub fn mass(mut self, mass: f32) -> Self {
        self.mass = mass;
        self
    }
    /// Piece `piece` of the mesh (`ClothMesh::join`'s list, from 0) takes `material` where it
    /// sets one (`PieceMaterial`).
    pub fn piece_material(mut self, piece: usize, material: PieceMaterial) -> Self {
        if self.piece_materials.len() <= piece {
            self.piece_materials.resize(piece + 1, PieceMaterial::default());
        }
        self.piece_materials[piece] = material;
        self
    }
    /// Spring stiffness (N/m) per family. A mesh cloth (`from_mesh`) has structural and bend
    /// springs only, each structural one at `k_struct` times its `Spring::stiffness_scale` (the
    /// area of its edge's triangles over its squared length: 1 on a square grid's inner sides).
    pub fn stiffness(mut self, k_struct: f32, k_shear: f32, k_bend: f32) -> Self {
        (self.k_struct, self.k_shear, self.k_bend) = (k_struct, k_shear, k_bend);
        self
    }
    pub fn spring_damping(mut self, c: f32) -> Self {
        self.spring_damping = c;
        self
    }
    pub fn velocity_damping(mut self, c: f32) -> Self {
        self.velocity_damping = c;
        self
    }
    /// Initial velocity of every free particle (m/s).
    pub fn velocity(mut self, v: Vec3) -> Self {
        self.velocity = v;
        self
    }
    pub fn gravity(mut self, g: Vec3) -> Self {
        self.gravity = g;
        self
    }
    pub fn external_force(mut self, f: Vec3) -> Self {
        self.external_force = f;
        self
    }
    pub fn pin(mut self, row: u32, col: u32) -> Self {
        self.pins.push((row, col));
        self
    }
    /// Pins particle `index` (a mesh's vertex index; a grid's row * cols + col).
    pub fn pin_vertex(mut self, index: u32) -> Self {
        self.pinned_vertices.push(index);
        self
    }
    /// Pins every particle inside the box `min..=max`, in the cloth's own coordinates (before
    /// `transform`).
    pub fn pin_within(mut self, min: Vec3, max: Vec3) -> Self {
        self.pin_boxes.push((min, max));
        self
    }
    /// Pins the two corners of the last row (the paper's demo pins two corners).
    pub fn pin_top_corners(self) -> Self {
        let (r, c) = (self.rows.saturating_sub(1), self.cols.saturating_sub(1));
        self.pin(r, 0).pin(r, c)
    }
    pub fn transform(mut self, m: Mat4) -> Self {
        self.transform = m;
        self
    }

    /// Validates the parameters and lays out the particles.
    pub fn build(&self) -> Result<Cloth> {
        let bad = |name: &'static str, problem: String| Err(Error::InvalidParameter { name, problem });
        // A mesh cloth's default mass is its area's: without area it would read as a bad mass.
        let area = self.mesh.as_ref().map(ClothMesh::area);
        if let (Some(mesh), Some(area)) = (&self.mesh, area)
            && !area.is_finite()
        {
            // Corners far from each other overflow f32's products before the mass does.
            let far = mesh.vertices.iter().map(|v| v.abs().max_element()).fold(0.0f32, f32::max);
            return bad(
                "cloth mesh",
                format!(
                    "its area is beyond f32's range (a coordinate reaches {far:e} m): give the mesh in metres, \
                     scaled down to the size of a cloth"
                ),
            );
        }
        if let (Some(mesh), Some(area)) = (&self.mesh, area)
            && area <= 0.0
            && mesh.triangles.iter().any(|&t| crate::mesh::spans_area(&mesh.vertices, t))
        {
            return bad(
                "cloth mesh",
                format!(
                    "is too small: its triangles' area underflows f32 (it spans {:e} m): give the mesh in metres",
                    extent(&mesh.vertices, &mesh.triangles)
                ),
            );
        }
        if let (Some(mesh), Some(area)) = (&self.mesh, area)
            && area <= 0.0
        {
            return bad(
                "cloth mesh",
                format!(
                    "has no area: each of its {} triangles has its corners on one line or a corner twice; \
                     give a mesh with triangles that span a surface",
                    mesh.triangles.len()
                ),
            );
        }
        let positive = [("size", self.size), ("length", self.length.unwrap_or(self.size)), ("mass", self.mass)];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return bad(name, format!("must be finite and > 0, got {value}"));
            }
        }
        // Smaller, a cloth's contact and springs fall under f32's resolution and its stability
        // bound with them (a 1e-10 m triangle's Lanczos estimate came out 0).
        let sides = [("size", self.size), ("length", self.length.unwrap_or(self.size))];
        if let Some((name, side)) = sides.into_iter().find(|&(_, side)| self.mesh.is_none() && side < MIN_CLOTH_EXTENT)
        {
            return bad(name, format!("must be at least {MIN_CLOTH_EXTENT} m (a cloth in metres), got {side:e}"));
        }
        if let Some(mesh) = &self.mesh {
            let world: Vec<Vec3> = mesh.vertices.iter().map(|&v| self.transform.transform_point3(v)).collect();
            let across = extent(&world, &mesh.triangles);
            if across < MIN_CLOTH_EXTENT {
                return bad(
                    "cloth mesh",
                    format!(
                        "spans only {across:e} m (its box's longest side), under the {MIN_CLOTH_EXTENT} m a cloth \
                         needs: give the mesh in metres"
                    ),
                );
            }
        }
        let non_negative = [
            ("k_struct", self.k_struct),
            ("k_shear", self.k_shear),
            ("k_bend", self.k_bend),
            ("spring_damping", self.spring_damping),
            ("velocity_damping", self.velocity_damping),
        ];
        for (name, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return bad(name, format!("must be finite and >= 0, got {value}"));
            }
        }
        if !self.gravity.is_finite() || !self.external_force.is_finite() || !self.velocity.is_finite() {
            return bad("gravity/external_force/velocity", "must be finite".into());
        }
        if !self.transform.is_finite() || self.transform.determinant().abs() < 1e-12 {
            return bad("transform", "must be finite and invertible".into());
        }
        if let Some(t) = self.self_collision
            && !(t.is_finite() && t > 0.0)
        {
            return bad("self_collision", format!("the thickness must be finite and > 0, got {t}"));
        }
        if !(self.self_friction.is_finite() && self.self_friction >= 0.0) {
            return bad("self_friction", format!("must be finite and >= 0, got {}", self.self_friction));
        }
        self.check_piece_materials()?;
        for &(lo, hi) in &self.pin_boxes {
            if !(lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()) {
                return bad("pin box", format!("needs finite corners with min <= max, got {lo} and {hi}"));
            }
        }
        // A mesh's size is its vertices': a grid's size there scaled nothing, silently.
        if self.mesh.is_some() && (self.size != DEFAULT_GRID_SIZE || self.length.is_some()) {
            return bad(
                "size",
                format!(
                    "{} m is a grid's size, and this cloth is built from a mesh, whose vertices give its size: scale \
                     it with `transform`",
                    self.size
                ),
            );
        }
        // A mesh has no rows: a grid pin there pinned nothing, silently (`pin_top_corners` on
        // a garment left it free to fall).
        if let (Some(_), Some(&(r, c))) = (&self.mesh, self.pins.first()) {
            return bad(
                "pins",
                format!(
                    "({r}, {c}) is a grid's row and column, and this cloth is built from a mesh: pin its vertices \
                     by index (`pin_vertex`) or those inside a box (`pin_within`)"
                ),
            );
        }
        let (mut cloth, local) = match &self.mesh {
            None => self.build_grid()?,
            Some(mesh) => self.build_mesh(mesh)?,
        };
        let count = cloth.positions.len() as u32;
        for &i in &self.pinned_vertices {
            if i >= count {
                return bad(
                    "pins",
                    format!(
                        "particle {i} does not exist: the cloth has {count} particles, numbered 0 to {}",
                        count.saturating_sub(1)
                    ),
                );
            }
            cloth.positions[i as usize].w = 0.0;
        }
        let inside = |l: &Vec3, (lo, hi): (Vec3, Vec3)| l.cmpge(lo).all() && l.cmple(hi).all();
        for (p, l) in cloth.positions.iter_mut().zip(&local) {
            if self.pin_boxes.iter().any(|&b| inside(l, b)) {
                p.w = 0.0;
            }
        }
        // A box that pins nothing is a box in the wrong place, not a request for a free cloth.
        if let Some(&(lo, hi)) = self.pin_boxes.iter().find(|&&b| !local.iter().any(|l| inside(l, b))) {
            let (min, max) =
                local.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), l| (a.min(*l), b.max(*l)));
            return bad(
                "pin box",
                format!(
                    "{lo} to {hi} holds none of the cloth's particles, which span {min} to {max} in its own \
                     coordinates (before its transform): move or widen the box"
                ),
            );
        }
        cloth.self_collision = self.self_collision;
        cloth.self_friction = self.self_friction;
        // Measured only for a reader of the log (0.8 s at 512 x 512).
        if let Some(t) = self.self_collision
            && log::log_enabled!(log::Level::Info)
        {
            let rest: Vec<Vec3> = cloth.positions.iter().map(|p| p.truncate()).collect();
            if let Some(gap) = closest_unshared_features(&rest, &cloth.triangles, t)
                && gap.triangles_within > 0
            {
                log::info!(
                    "self-collision thickness {:.2} mm is over {:.2} mm, the closest that neighbouring features of the \
                     cloth sharing no particle lie at rest (a vertex and the face beside it, two edges), in {} of its {} \
                     triangles: those pairs answer only a crossing, so the cloth is thinner than the thickness there",
                    t * 1e3,
                    gap.distance * 1e3,
                    gap.triangles_within,
                    cloth.triangles.len(),
                );
            }
        }
        // Pinned particles (w = 0) stay at rest.
        cloth.velocities = cloth.positions.iter().map(|p| (self.velocity * p.w).extend(0.0)).collect();
        Ok(cloth)
    }

    /// The pieces (from 0) that have a material of their own, with it.
    pub fn own_piece_materials(&self) -> impl Iterator<Item = (usize, &PieceMaterial)> {
        self.piece_materials.iter().enumerate().filter(|(_, m)| **m != PieceMaterial::default())
    }

    /// Each piece material names a piece the mesh has, with stiffnesses the cloth's can scale
    /// to and a density of some mass.
    fn check_piece_materials(&self) -> Result<()> {
        let bad = |problem: String| Err(Error::InvalidParameter { name: "piece material", problem });
        let pieces = self.mesh.as_ref().map(ClothMesh::piece_count);
        for (piece, material) in self.own_piece_materials() {
            match pieces {
                None => {
                    return bad(format!(
                        "piece {piece} has a material of its own, but a grid cloth is one piece: set its \
                         stiffness and mass instead"
                    ));
                }
                Some(count) if piece >= count => {
                    return bad(format!(
                        "piece {piece} does not exist: the cloth mesh has {count}, counted from 0 (ClothMesh::join's list)"
                    ));
                }
                _ => {}
            }
            if let Some(k) = material.stiffness {
                if !(k.is_finite() && k.cmpge(Vec3::ZERO).all()) {
                    return bad(format!("piece {piece}'s stiffness must be finite and >= 0, got {k}"));
                }
                let cloth = Vec3::new(self.k_struct, self.k_shear, self.k_bend);
                let names = ["structural", "shear", "bend"];
                if let Some(f) = (0..3).find(|&f| k[f] > 0.0 && cloth[f] == 0.0) {
                    return bad(format!(
                        "piece {piece} (from 0)'s {} stiffness is {} where the cloth's is 0: a piece's stiffness is a \
                         multiple of its cloth's, which has none to scale; give the cloth a {} stiffness too",
                        names[f], k[f], names[f]
                    ));
                }
            }
            if let Some(d) = material.density
                && !(d.is_finite() && d > 0.0)
            {
                return bad(format!("piece {piece}'s density must be finite and > 0 (kg/m^2), got {d}"));
            }
        }
        Ok(())
    }

    /// Each triangle's areal density (kg/m^2) and stiffness factors: its piece's material's, or
    /// the cloth's (`mean_density` and 1).
    fn triangle_materials(&self, mesh: &ClothMesh, mean_density: f32) -> (Vec<f32>, Vec<StiffnessFactors>) {
        let ratio = |piece: f32, cloth: f32| if cloth > 0.0 { piece / cloth } else { 1.0 };
        let of_piece: Vec<(f32, StiffnessFactors)> = (0..mesh.piece_count())
            .map(|piece| {
                let material = self.piece_materials.get(piece).copied().unwrap_or_default();
                let factors = material.stiffness.map_or(StiffnessFactors::default(), |k| StiffnessFactors {
                    structural: ratio(k.x, self.k_struct),
                    bend: ratio(k.z, self.k_bend),
                });
                (material.density.unwrap_or(mean_density), factors)
            })
            .collect();
        (0..mesh.triangles.len()).map(|t| of_piece[mesh.piece_of(t) as usize]).unzip()
    }

    /// The parameters every cloth shares (the layout's fields left for the caller).
    fn params(&self, particles: u32, particle_mass: f32) -> SimParams {
        SimParams {
            rows: 1,
            cols: particles,
            particle_count: particles,
            integrator: integrator::RK4,
            gravity: self.gravity.extend(0.0),
            external_force: (self.external_force / particles as f32).extend(0.0),
            k_struct: self.k_struct,
            k_shear: self.k_shear,
            k_bend: self.k_bend,
            spring_damping: self.spring_damping,
            velocity_damping: self.velocity_damping,
            particle_mass,
            substep: 0.0,
            _pad0: 0,
            rest: Vec4::ZERO,
        }
    }

    /// The grid (positions in the world, and in the cloth's own frame for pin boxes).
    fn build_grid(&self) -> Result<(Cloth, Vec<Vec3>)> {
        let bad = |name: &'static str, problem: String| Err(Error::InvalidParameter { name, problem });
        if self.rows < 2 || self.cols < 2 {
            return bad("rows/cols", format!("need at least 2 x 2 particles, got {} x {}", self.rows, self.cols));
        }
        let count = self.rows as u64 * self.cols as u64;
        if count > MAX_PARTICLES as u64 {
            return bad("rows/cols", format!("{count} particles is more than the supported {MAX_PARTICLES}"));
        }
        for &(r, c) in &self.pins {
            if r >= self.rows || c >= self.cols {
                return bad("pins", format!("({r}, {c}) is outside the {} x {} grid", self.rows, self.cols));
            }
        }
        let length = self.length.unwrap_or(self.size);
        let dx = self.size / (self.cols - 1) as f32;
        let dz = length / (self.rows - 1) as f32;
        let origin = Vec3::new(-0.5 * self.size, 0.0, -0.5 * length);
        let mut local = Vec::with_capacity(count as usize);
        for r in 0..self.rows {
            for c in 0..self.cols {
                local.push(origin + Vec3::new(c as f32 * dx, 0.0, r as f32 * dz));
            }
        }
        let mut positions: Vec<Vec4> = local.iter().map(|&l| self.transform.transform_point3(l).extend(1.0)).collect();
        for &(r, c) in &self.pins {
            positions[(r * self.cols + c) as usize].w = 0.0;
        }
        // Rest lengths are the world-space grid steps, so any TRS keeps the cloth at rest.
        let col_step = self.transform.transform_vector3(Vec3::new(dx, 0.0, 0.0));
        let row_step = self.transform.transform_vector3(Vec3::new(0.0, 0.0, dz));
        let mut params = self.params(count as u32, self.mass / count as f32);
        (params.rows, params.cols) = (self.rows, self.cols);
        params.rest = Vec4::new(
            col_step.length(),
            row_step.length(),
            (col_step + row_step).length(),
            (row_step - col_step).length(),
        );
        let triangles = grid_triangles(self.rows, self.cols);
        let uvs = ClothUvs {
            coords: (0..count as u32)
                .map(|i| {
                    let (r, c) = (i / self.cols, i % self.cols);
                    Vec2::new(c as f32 / (self.cols - 1) as f32, r as f32 / (self.rows - 1) as f32)
                })
                .collect(),
            triangles: triangles.clone(),
        };
        let topology = if self.listed_springs {
            ClothTopology::Springs(SpringTopology::of_grid(&params, &triangles))
        } else {
            ClothTopology::Grid
        };
        let cloth = Cloth {
            params,
            positions,
            velocities: Vec::new(),
            triangles,
            uvs: Some(uvs),
            topology,
            self_collision: None,
            self_friction: 0.0,
        };
        Ok((cloth, local))
    }

    /// A mesh cloth (positions in the world, and in the mesh's own coordinates for pin boxes).
    fn build_mesh(&self, mesh: &ClothMesh) -> Result<(Cloth, Vec<Vec3>)> {
        crate::Mesh::from_parts(mesh.vertices.clone(), mesh.triangles.clone())?;
        let count = mesh.vertices.len();
        if count > MAX_PARTICLES as usize {
            return Err(Error::InvalidParameter {
                name: "cloth mesh",
                problem: format!("{count} vertices is more than the supported {MAX_PARTICLES}"),
            });
        }
        let world: Vec<Vec3> = mesh.vertices.iter().map(|&v| self.transform.transform_point3(v)).collect();
        let world_area: f32 = mesh.triangles.iter().map(|&t| crate::cloth_mesh::triangle_area(&world, t)).sum();
        let (densities, stiffness_factors) = self.triangle_materials(mesh, self.mass / world_area);
        let masses = lumped_masses(&world, &mesh.triangles, &densities);
        // A vertex of a triangle whose mass underflowed would be pinned as if it had none.
        let mut in_triangle = vec![false; count];
        mesh.triangles.iter().flatten().for_each(|&i| in_triangle[i as usize] = true);
        if let Some(i) = (0..count).find(|&i| in_triangle[i] && !masses[i].is_normal()) {
            return Err(Error::InvalidParameter {
                name: "cloth mesh",
                problem: format!(
                    "particle {i}'s mass is {:e} kg: the area of its triangles ({world_area:e} m^2 for the whole \
                     cloth) times their density underflows f32; give the cloth more mass (or its pieces a larger \
                     density), or the mesh in metres",
                    masses[i]
                ),
            });
        }
        let mut positions: Vec<Vec4> = world.iter().map(|p| p.extend(1.0)).collect();
        let mut loose = 0;
        for (p, &m) in positions.iter_mut().zip(&masses) {
            if m <= 0.0 {
                p.w = 0.0; // a vertex of no triangle: nothing moves it, so it stays put
                loose += 1;
            }
        }
        if loose > 0 {
            log::info!("cloth mesh: {loose} vertices belong to no triangle; they are pinned where they are");
        }
        let coincident = mesh.coincident_vertices();
        if coincident > 0 {
            log::warn!(
                "cloth mesh: {coincident} vertices lie exactly on earlier ones (the file splits the surface there, as \
                 exporters do at UV or normal seams): the cloth is not joined at them and comes apart there unless \
                 that is meant; join seams with `ClothMesh::weld_coincident` (CLI: --weld), and lay layers that lie \
                 on each other at least the self-collision thickness apart (welded, they would be one)"
            );
        }
        let flat = mesh.triangles.iter().filter(|&&t| crate::cloth_mesh::triangle_area(&world, t) <= 0.0).count();
        if flat > 0 {
            log::warn!(
                "cloth mesh: {flat} triangles have no area (a corner twice, or corners on one line): they add no mass \
                 and no surface to the cloth; remove them from the file unless they are meant"
            );
        }
        let repeated = mesh.repeated_triangles();
        if repeated > 0 {
            log::warn!(
                "cloth mesh: {repeated} triangles repeat an earlier one (the same three vertices): each adds its area's \
                 mass to its corners again and is drawn twice; remove them from the file unless they are meant"
            );
        }
        // A mirroring transform turns the triangles inside out: keep the normals outward.
        let triangles: Vec<[u32; 3]> = if self.transform.determinant() < 0.0 {
            mesh.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect()
        } else {
            mesh.triangles.clone()
        };
        let used = masses.iter().filter(|&&m| m > 0.0).count().max(1);
        // The pieces' own densities make the cloth's mass their sum, not `self.mass`.
        let mass: f32 = masses.iter().sum();
        let mut params = self.params(count as u32, mass / used as f32);
        // The force on the whole cloth is spread over the particles that carry mass.
        params.external_force = (self.external_force / used as f32).extend(0.0);
        let springs = SpringTopology::of_mesh(&world, &triangles, &masses, &stiffness_factors);
        let capped = springs.capped_edges;
        if capped > 0 {
            log::warn!(
                "cloth mesh: {capped} edges are much shorter than their triangles are wide (needle or cap triangles): \
                 their springs are capped at {}x the structural stiffness, so the cloth is softer there than the rest; \
                 remesh to triangles closer to equilateral for one material throughout",
                crate::cloth_mesh::MAX_STIFFNESS_SCALE
            );
        }
        let topology = ClothTopology::Springs(springs);
        let uvs = mesh.uvs.clone().map(|mut uvs| {
            if self.transform.determinant() < 0.0 {
                uvs.triangles = uvs.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect();
            }
            uvs
        });
        let cloth = Cloth {
            params,
            positions,
            velocities: Vec::new(),
            triangles,
            uvs,
            topology,
            self_collision: None,
            self_friction: 0.0,
        };
        Ok((cloth, mesh.vertices.clone()))
    }
}

/// How a cloth's kernels find its springs.
#[derive(Clone, Debug, PartialEq)]
pub enum ClothTopology {
    /// Implied by the `rows x cols` grid (the fast path: nothing to load per spring).
    Grid,
    /// Listed per particle (a mesh cloth, or a grid built with `listed_springs`).
    Springs(SpringTopology),
}

/// A built cloth: GPU parameters (without a substep yet), the initial state, its triangles
/// and how its springs are found.
#[derive(Clone, Debug)]
pub struct Cloth {
    pub params: SimParams,
    /// xyz = position (m), w = 1 for a free particle, 0 for a pinned one.
    pub positions: Vec<Vec4>,
    pub velocities: Vec<Vec4>,
    /// The cloth's triangles (a grid's are CCW seen from +Y in local space), for renderers,
    /// export and metrics.
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinates per triangle corner, when the cloth has them.
    pub uvs: Option<ClothUvs>,
    pub topology: ClothTopology,
    /// Self-collision thickness (m), `None` when off.
    pub self_collision: Option<f32>,
    /// Coulomb friction between the cloth's layers under self-collision.
    pub self_friction: f32,
}

impl Cloth {
    pub fn particle_count(&self) -> usize {
        self.positions.len()
    }

    /// The cloth's triangles.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        self.triangles.clone()
    }

    /// The squared length of the cloth's longest triangle edge, at its positions.
    pub fn longest_edge2(&self) -> f32 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize].truncate());
                drape_kernels::self_contact::longest_side2(a, b, c)
            })
            .fold(0.0, f32::max)
    }

    /// Each structural spring once: (i, j, rest length), for stretch measurements.
    pub fn structural_springs(&self) -> Vec<(u32, u32, f32)> {
        match &self.topology {
            ClothTopology::Springs(s) => s.structural_springs(),
            ClothTopology::Grid => {
                let p = &self.params;
                crate::metrics::grid_structural_springs(p.rows, p.cols, p.rest.x, p.rest.y)
            }
        }
    }
}

/// Two triangles per grid quad, wound so their normal agrees with the vertex normals.
pub fn grid_triangles(rows: u32, cols: u32) -> Vec<[u32; 3]> {
    let mut tris = Vec::with_capacity(2 * (rows as usize - 1) * (cols as usize - 1));
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let i = r * cols + c;
            let (right, up, diag) = (i + 1, i + cols, i + cols + 1);
            tris.push([i, up, right]);
            tris.push([right, up, diag]);
        }
    }
    tris
}
