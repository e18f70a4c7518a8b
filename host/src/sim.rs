//! The GPU simulation: uploads a cloth once, records its frame once, and runs frames. State stays
//! on the GPU between frames; positions, velocities and normals are read back only when asked.

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::gpu::{Context, Engine, FrameTimings, RecordedFrame};
use crate::lbvh;
use crate::program::ClothProgram;
use crate::programs::cloth::FramePlan;
use crate::stability::{self, DEFAULT_SAFETY, Stability};
use drape_types::{CollisionStatus, Health, SimParams, integrator};
use glam::Vec4;
use std::sync::Arc;

/// Time integration scheme.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// Classical RK4 (4th order; 4 dispatches per substep).
    Rk4,
    /// Semi-implicit Euler, the paper's eq. 3 (1st order; 2 dispatches per substep).
    SemiImplicitEuler,
}

impl Integrator {
    pub fn id(self) -> u32 {
        match self {
            Integrator::Rk4 => integrator::RK4,
            Integrator::SemiImplicitEuler => integrator::SEMI_IMPLICIT_EULER,
        }
    }
}

/// How a simulation runs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SimSettings {
    /// Simulated time per frame (s).
    pub frame_dt: f32,
    /// Substeps per frame; `None` = automatic from the stability bound.
    pub substeps: Option<u32>,
    /// Fraction of the stability bound that automatic substeps use.
    pub safety: f32,
    pub integrator: Integrator,
    /// Compute vertex normals every frame.
    pub normals: bool,
    /// A structural spring longer than this many rest lengths counts as a blow-up.
    pub max_stretch: f32,
    /// Time every pass with GPU timestamp queries (costs ~tens of µs per pass on lavapipe).
    pub timestamps: bool,
}

impl Default for SimSettings {
    fn default() -> Self {
        SimSettings {
            frame_dt: 1.0 / 60.0,
            substeps: None,
            safety: DEFAULT_SAFETY,
            integrator: Integrator::Rk4,
            normals: true,
            max_stretch: 10.0,
            timestamps: true,
        }
    }
}

impl SimSettings {
    /// Checks the settings and chooses the substep for `cloth`; returns the params to upload.
    pub fn resolve(&self, cloth: &Cloth) -> Result<(SimParams, Stability)> {
        let bad = |name: &'static str, problem: String| Err(Error::InvalidParameter { name, problem });
        if !(self.frame_dt.is_finite() && self.frame_dt > 0.0) {
            return bad("frame_dt", format!("must be finite and > 0, got {}", self.frame_dt));
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return bad("safety", format!("must be in (0, 1], got {}", self.safety));
        }
        if self.substeps == Some(0) || self.substeps.is_some_and(|s| s > 100_000) {
            return bad("substeps", format!("must be in 1..=100000, got {:?}", self.substeps));
        }
        let n = cloth.params.rows as usize * cloth.params.cols as usize;
        if cloth.positions.len() != n || cloth.velocities.len() != n || cloth.params.particle_count as usize != n {
            return bad("cloth", format!("state arrays must hold rows x cols = {n} particles"));
        }
        if !cloth.positions.iter().chain(&cloth.velocities).all(|p| p.is_finite()) {
            return bad("cloth", "positions and velocities must be finite".into());
        }
        if self.max_stretch.is_nan() || self.max_stretch <= 1.0 {
            return bad("max_stretch", format!("must be > 1, got {}", self.max_stretch));
        }
        let stability = stability::choose(cloth, self.integrator.id(), self.frame_dt, self.substeps, self.safety);
        if stability.substeps > 100_000 {
            return bad(
                "stiffness/mass",
                format!(
                    "the stability bound {:.3e} s needs {} substeps per frame; lower the stiffness or raise the mass",
                    stability.max_substep, stability.substeps
                ),
            );
        }
        let mut params = cloth.params;
        params.integrator = self.integrator.id();
        params.substep = stability.substep;
        Ok((params, stability))
    }

    /// The frame schedule for these settings.
    pub fn plan(&self, params: &SimParams, stability: &Stability) -> FramePlan {
        FramePlan { substeps: stability.substeps, integrator: params.integrator, normals: self.normals }
    }
}

/// Reads the blow-up detector and turns a blow-up into an error.
pub(crate) fn check_health(health: &Health, frame: u64, settings: &SimSettings, stability: &Stability) -> Result<()> {
    let stretch = f32::from_bits(health.max_stretch_bits);
    let detail = if health.non_finite > 0 {
        format!("{} particles have non-finite position or velocity", health.non_finite)
    } else if stretch.is_nan() || stretch > settings.max_stretch {
        format!("a spring stretched to {stretch:.1}x its rest length (limit {})", settings.max_stretch)
    } else {
        return Ok(());
    };
    Err(Error::Unstable {
        frame,
        detail,
        substep: stability.substep,
        bound: stability.max_substep,
        suggested_substeps: stability.min_stable_substeps().max(stability.substeps * 2),
    })
}

/// A rigid collider: spheres (xyz centre, w radius, e.g. from `collider::voxel_spheres`) and
/// the contact thickness (m).
#[derive(Clone, Debug, PartialEq)]
pub struct Collider {
    pub spheres: Vec<Vec4>,
    pub thickness: f32,
    /// Coulomb friction coefficient (0 = the paper's frictionless response).
    pub friction: f32,
    /// Traverse the LBVH (true) or test every sphere (the brute-force baseline).
    pub use_bvh: bool,
}

impl Collider {
    pub fn new(spheres: Vec<Vec4>, thickness: f32) -> Self {
        Collider { spheres, thickness, friction: 0.0, use_bvh: true }
    }
}

/// What a frame reports besides timings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReport {
    pub timings: FrameTimings,
    /// Substeps whose collision traversal ran / was skipped by the root-box test.
    pub collision_ran: u32,
    pub collision_skipped: u32,
}

/// A cloth simulation on the GPU.
pub struct Simulation {
    // Field order is drop order: the recorded frame goes before the engine (it holds what it
    // binds anyway).
    frame: RecordedFrame,
    engine: Engine,
    program: ClothProgram,
    params: SimParams,
    settings: SimSettings,
    stability: Stability,
    lbvh_timings: Option<FrameTimings>,
    frames_done: u64,
}

impl Simulation {
    /// Uploads `cloth` and records its frame (no collider).
    pub fn new(ctx: &Arc<Context>, cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        Self::with_collider(ctx, cloth, settings, None)
    }

    /// Uploads `cloth`, builds the collider's LBVH on the GPU (if any) and records the frame.
    pub fn with_collider(
        ctx: &Arc<Context>,
        cloth: &Cloth,
        settings: SimSettings,
        collider: Option<&Collider>,
    ) -> Result<Self> {
        let (params, stability) = settings.resolve(cloth)?;
        let program = ClothProgram::new(cloth, &params, settings.plan(&params, &stability), collider)?;
        let mut engine = Engine::new(ctx)?;
        engine.allocate(&program.resources)?;
        for (id, data) in &program.initial {
            engine.upload_bytes(*id, data)?;
        }
        let lbvh_timings = match &program.collider {
            Some(c) => Some(engine.record(&c.lbvh.build_steps(), true)?.submit()?),
            None => None,
        };
        let frame = engine.record(&program.frame, settings.timestamps)?;
        Ok(Simulation { frame, engine, program, params, settings, stability, lbvh_timings, frames_done: 0 })
    }

    /// Runs one frame; returns its per-pass GPU timings, or `Error::Unstable` on blow-up.
    pub fn step(&mut self) -> Result<FrameTimings> {
        Ok(self.step_report()?.timings)
    }

    /// Runs one frame; returns its timings and collision counters.
    pub fn step_report(&mut self) -> Result<FrameReport> {
        let timings = self.frame.submit()?;
        self.frames_done += 1;
        let health: Health = self.engine.read_mapped(self.program.cloth.health)?;
        check_health(&health, self.frames_done, &self.settings, &self.stability)?;
        let mut report = FrameReport { timings, ..FrameReport::default() };
        if let Some(c) = &self.program.collider {
            let status: CollisionStatus = self.engine.read_mapped(c.contact.status)?;
            check_collision(&status, self.frames_done)?;
            report.collision_ran = status.ran;
            report.collision_skipped = status.skipped;
        }
        Ok(report)
    }

    fn read_vec4s(&self, buffer: crate::graph::Handle<Vec4>) -> Result<Vec<Vec4>> {
        self.engine.download(buffer, self.params.particle_count as usize)
    }

    /// Positions (xyz, w = pin weight), read back from the GPU.
    pub fn positions(&self) -> Result<Vec<Vec4>> {
        self.read_vec4s(self.program.cloth.x)
    }
    /// Velocities, read back from the GPU.
    pub fn velocities(&self) -> Result<Vec<Vec4>> {
        self.read_vec4s(self.program.cloth.v)
    }
    /// Vertex normals of the last frame (zero before the first frame or with normals off).
    pub fn normals(&self) -> Result<Vec<Vec4>> {
        self.read_vec4s(self.program.cloth.normals)
    }
    /// The collider's LBVH as built on the GPU (None without a collider).
    pub fn collider_bvh(&self) -> Result<Option<lbvh::Lbvh>> {
        match &self.program.collider {
            Some(c) => Ok(Some(lbvh::download(&self.engine, &c.lbvh)?)),
            None => Ok(None),
        }
    }
    /// GPU time of the LBVH build per stage (None without a collider).
    pub fn lbvh_timings(&self) -> Option<&FrameTimings> {
        self.lbvh_timings.as_ref()
    }
    /// The cloth's vertex and index buffers, for a renderer to bind.
    pub fn vertex_buffers(&self) -> Result<VertexBuffers> {
        let cloth = &self.program.cloth;
        Ok(VertexBuffers {
            positions: self.engine.buffer(cloth.x.id())?.handle,
            normals: self.engine.buffer(cloth.normals.id())?.handle,
            indices: self.engine.buffer(cloth.indices.id())?.handle,
            vertex_count: cloth.particles,
            index_count: cloth.indices.len(),
            offset: 0,
            stride: size_of::<Vec4>() as u32,
            format: ash::vk::Format::R32G32B32A32_SFLOAT,
            index_type: ash::vk::IndexType::UINT32,
        })
    }

    /// Sets gravity (m/s^2) from the next frame on. Nothing is re-recorded or allocated.
    pub fn set_gravity(&mut self, gravity: glam::Vec3) -> Result<()> {
        finite_vec("gravity", gravity)?;
        self.params.gravity = gravity.extend(0.0);
        self.upload_params()
    }

    /// Sets the constant external force on every free particle (N), e.g. wind.
    pub fn set_external_force(&mut self, force: glam::Vec3) -> Result<()> {
        finite_vec("external_force", force)?;
        self.params.external_force = force.extend(0.0);
        self.upload_params()
    }

    /// Sets the collider's contact thickness (m) and Coulomb friction coefficient.
    pub fn set_contact(&mut self, thickness: f32, friction: f32) -> Result<()> {
        let c = self.program.collider.as_ref().ok_or(Error::InvalidParameter {
            name: "contact",
            problem: "this simulation has no collider; create it with `Simulation::with_collider`".into(),
        })?;
        let mut params: drape_types::ColliderParams = self.engine.download(c.lbvh.collider, 1)?[0];
        let checked = lbvh::collider_params(&[Vec4::ZERO], thickness, friction)?;
        params.thickness = checked.thickness;
        params.friction = checked.friction;
        self.engine.upload(c.lbvh.collider, &[params])
    }

    /// Teleports the cloth: new positions (xyz; w is kept, so pins stay) and velocities.
    pub fn set_state(&mut self, positions: &[glam::Vec3], velocities: &[glam::Vec3]) -> Result<()> {
        let n = self.params.particle_count as usize;
        if positions.len() != n || velocities.len() != n {
            return Err(Error::InvalidParameter {
                name: "state",
                problem: format!(
                    "expected {n} positions and velocities, got {} and {}",
                    positions.len(),
                    velocities.len()
                ),
            });
        }
        if !positions.iter().chain(velocities).all(|p| p.is_finite()) {
            return Err(Error::InvalidParameter { name: "state", problem: "values must be finite".into() });
        }
        let old = self.positions()?;
        let x: Vec<Vec4> = positions.iter().zip(&old).map(|(p, o)| p.extend(o.w)).collect();
        let v: Vec<Vec4> =
            velocities.iter().zip(&old).map(|(v, o)| if o.w == 0.0 { Vec4::ZERO } else { v.extend(0.0) }).collect();
        self.engine.upload(self.program.cloth.x, &x)?;
        self.engine.upload(self.program.cloth.v, &v)
    }

    fn upload_params(&mut self) -> Result<()> {
        self.engine.upload(self.program.cloth.params, std::slice::from_ref(&self.params))
    }

    /// Bytes of GPU buffers per part of the simulation (cloth, collider, contact), and what
    /// the allocator holds on the whole context.
    pub fn memory_report(&self) -> MemoryReport {
        let mut parts: Vec<(String, u64)> = Vec::new();
        for desc in self.program.resources.descs() {
            let part = desc.name.split(':').next().unwrap_or("other").to_string();
            match parts.iter_mut().find(|(p, _)| *p == part) {
                Some((_, bytes)) => *bytes += desc.bytes,
                None => parts.push((part, desc.bytes)),
            }
        }
        MemoryReport { parts, allocator: self.context().allocator_stats() }
    }

    /// Memory barriers in one recorded frame (derived from the passes' reads and writes).
    pub fn barriers_per_frame(&self) -> u32 {
        self.frame.barrier_count()
    }
    pub fn params(&self) -> &SimParams {
        &self.params
    }
    pub fn stability(&self) -> &Stability {
        &self.stability
    }
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }
    pub fn frames_done(&self) -> u64 {
        self.frames_done
    }
    pub fn context(&self) -> &Arc<Context> {
        self.engine.context()
    }
}

/// GPU memory of a simulation.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct MemoryReport {
    /// (part, bytes of its buffers), e.g. ("cloth", ..), ("collider", ..), ("contact", ..).
    pub parts: Vec<(String, u64)>,
    /// The context's allocator: allocations, memory blocks and their sizes.
    pub allocator: crate::gpu::AllocatorStats,
}

impl std::fmt::Display for MemoryReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (part, bytes) in &self.parts {
            writeln!(f, "  {part:<10} {:>10.1} KiB", *bytes as f64 / 1024.0)?;
        }
        let a = &self.allocator;
        write!(
            f,
            "  allocator  {} allocations, {:.1} KiB used in {} blocks of {:.1} MiB total",
            a.allocations,
            a.allocated_bytes as f64 / 1024.0,
            a.blocks,
            a.capacity_bytes as f64 / (1024.0 * 1024.0)
        )
    }
}

/// Where a renderer finds a cloth's vertex data: buffers created with vertex- and index-buffer
/// usage, the same for the simulation's whole life. Both vertex buffers hold one
/// `R32G32B32A32_SFLOAT` per particle at offset 0, stride 16 (positions: xyz, w = pin weight;
/// normals: xyz, w = 0); the index buffer is a `UINT32` triangle list.
///
/// Synchronization: each frame ends with a barrier that makes its writes available to the
/// vertex input, compute and transfer stages of every later command on the queue, and to the
/// host; `step()` returns after the frame completed.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct VertexBuffers {
    pub positions: ash::vk::Buffer,
    pub normals: ash::vk::Buffer,
    pub indices: ash::vk::Buffer,
    pub vertex_count: u32,
    pub index_count: u32,
    pub offset: u64,
    pub stride: u32,
    pub format: ash::vk::Format,
    pub index_type: ash::vk::IndexType,
}

fn finite_vec(name: &'static str, v: glam::Vec3) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter { name, problem: format!("must be finite, got {v}") })
    }
}

/// Turns a traversal overflow into an error.
pub(crate) fn check_collision(status: &CollisionStatus, frame: u64) -> Result<()> {
    if status.overflows > 0 {
        return Err(Error::TraversalOverflow { frame, particles: status.overflows });
    }
    Ok(())
}
