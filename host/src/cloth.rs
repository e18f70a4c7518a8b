//! Cloth description: a `rows x cols` particle grid with structural, shear and bend springs,
//! built by `ClothBuilder` and validated before anything reaches the GPU.

use crate::error::{Error, Result};
use drape_types::{SimParams, integrator};
use glam::{Mat4, Vec3, Vec4};

/// Builder for a rectangular cloth. The grid lies in the local XZ plane (columns along +X, rows
/// along +Z, normal +Y), centred on the origin, then `transform` places it in the world.
#[derive(Clone, Debug)]
pub struct ClothBuilder {
    pub rows: u32,
    pub cols: u32,
    /// Side length (m) along X and Z.
    pub size: f32,
    /// Total mass (kg), split evenly over the particles.
    pub mass: f32,
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
    /// Pinned particles as (row, col).
    pub pins: Vec<(u32, u32)>,
    /// Initial velocity of every free particle (m/s), e.g. a throw.
    pub velocity: Vec3,
    /// Local-to-world placement (the paper's `trsMatrix`).
    pub transform: Mat4,
}

impl ClothBuilder {
    /// A `rows x cols` cloth, 1 m square, 0.2 kg/m^2, moderately stiff, with gravity, no pins.
    pub fn new(rows: u32, cols: u32) -> Self {
        ClothBuilder {
            rows,
            cols,
            size: 1.0,
            mass: 0.2,
            k_struct: 40.0,
            k_shear: 10.0,
            k_bend: 2.0,
            spring_damping: 0.002,
            velocity_damping: 0.0,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            external_force: Vec3::ZERO,
            pins: Vec::new(),
            velocity: Vec3::ZERO,
            transform: Mat4::IDENTITY,
        }
    }

    pub fn size(mut self, size: f32) -> Self {
        self.size = size;
        self
    }
    pub fn mass(mut self, mass: f32) -> Self {
        self.mass = mass;
        self
    }
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
        if self.rows < 2 || self.cols < 2 {
            return bad("rows/cols", format!("need at least 2 x 2 particles, got {} x {}", self.rows, self.cols));
        }
        let count = self.rows as u64 * self.cols as u64;
        if count > 1 << 24 {
            return bad("rows/cols", format!("{count} particles is more than the supported 16,777,216"));
        }
        let positive = [("size", self.size), ("mass", self.mass)];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return bad(name, format!("must be finite and > 0, got {value}"));
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
        for &(r, c) in &self.pins {
            if r >= self.rows || c >= self.cols {
                return bad("pins", format!("({r}, {c}) is outside the {} x {} grid", self.rows, self.cols));
            }
        }

        let dx = self.size / (self.cols - 1) as f32;
        let dz = self.size / (self.rows - 1) as f32;
        let origin = Vec3::new(-0.5 * self.size, 0.0, -0.5 * self.size);
        let mut positions = Vec::with_capacity(count as usize);
        for r in 0..self.rows {
            for c in 0..self.cols {
                let local = origin + Vec3::new(c as f32 * dx, 0.0, r as f32 * dz);
                positions.push(self.transform.transform_point3(local).extend(1.0));
            }
        }
        for &(r, c) in &self.pins {
            positions[(r * self.cols + c) as usize].w = 0.0;
        }
        // Rest lengths are the world-space grid steps, so any TRS keeps the cloth at rest.
        let col_step = self.transform.transform_vector3(Vec3::new(dx, 0.0, 0.0));
        let row_step = self.transform.transform_vector3(Vec3::new(0.0, 0.0, dz));
        let particle_mass = self.mass / count as f32;
        let params = SimParams {
            rows: self.rows,
            cols: self.cols,
            particle_count: count as u32,
            integrator: integrator::RK4,
            gravity: self.gravity.extend(0.0),
            external_force: (self.external_force / count as f32).extend(0.0),
            k_struct: self.k_struct,
            k_shear: self.k_shear,
            k_bend: self.k_bend,
            spring_damping: self.spring_damping,
            velocity_damping: self.velocity_damping,
            particle_mass,
            substep: 0.0,
            _pad0: 0,
            rest: Vec4::new(
                col_step.length(),
                row_step.length(),
                (col_step + row_step).length(),
                (row_step - col_step).length(),
            ),
        };
        // Pinned particles (w = 0) stay at rest.
        let velocities = positions.iter().map(|p| (self.velocity * p.w).extend(0.0)).collect();
        Ok(Cloth { params, positions, velocities })
    }
}

/// A built cloth: GPU parameters (without a substep yet) and the initial state.
#[derive(Clone, Debug)]
pub struct Cloth {
    pub params: SimParams,
    /// xyz = position (m), w = 1 for a free particle, 0 for a pinned one.
    pub positions: Vec<Vec4>,
    pub velocities: Vec<Vec4>,
}

impl Cloth {
    pub fn particle_count(&self) -> usize {
        self.positions.len()
    }

    /// Triangles of the grid (CCW seen from +Y in local space), for export and metrics.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        grid_triangles(self.params.rows, self.params.cols)
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
