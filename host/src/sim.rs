//! The GPU simulation: uploads a cloth once, records its frame once, and runs frames. State stays
//! on the GPU between frames; positions, velocities and normals are read back only when asked.

use crate::cloth::Cloth;
use crate::controls::Controls;
use crate::error::{Error, Result};
use crate::gpu::recording::encode_frame;
use crate::gpu::status_ring::StatusRing;
use crate::gpu::{Command, Context, Engine, FrameTimings, RecordedFrame};
use crate::lbvh;
use crate::program::ClothProgram;
use crate::programs::cloth::FramePlan;
use crate::stability::{self, DEFAULT_SAFETY, Stability};
use drape_types::{CollisionStatus, Health, RigidPose, SimParams, integrator};
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
        let n = cloth.params.rows as usize * cloth.params.cols as usize;
        if cloth.positions.len() != n || cloth.velocities.len() != n || cloth.params.particle_count as usize != n {
            return bad("cloth", format!("state arrays must hold rows x cols = {n} particles"));
        }
        if !cloth.positions.iter().chain(&cloth.velocities).all(|p| p.is_finite()) {
            return bad("cloth", "positions and velocities must be finite".into());
        }
        self.resolve_params(&cloth.params)
    }

    /// Checks the settings and chooses the substep for a cloth's `params`.
    pub fn resolve_params(&self, params: &SimParams) -> Result<(SimParams, Stability)> {
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
        if self.max_stretch.is_nan() || self.max_stretch <= 1.0 {
            return bad("max_stretch", format!("must be > 1, got {}", self.max_stretch));
        }
        let stability = stability::choose_for(params, self.integrator.id(), self.frame_dt, self.substeps, self.safety);
        if stability.substeps > 100_000 {
            return bad(
                "stiffness/mass",
                format!(
                    "the stability bound {:.3e} s needs {} substeps per frame; lower the stiffness or raise the mass",
                    stability.max_substep, stability.substeps
                ),
            );
        }
        let mut params = *params;
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

/// A collider: spheres (xyz centre, w radius, e.g. from `collider::voxel_spheres`) in the
/// collider's own frame, its initial pose in the world, and the contact thickness (m).
#[derive(Clone, Debug, PartialEq)]
pub struct Collider {
    pub spheres: Vec<Vec4>,
    pub thickness: f32,
    /// Coulomb friction coefficient (0 = the paper's frictionless response).
    pub friction: f32,
    /// Traverse the LBVH (true) or test every sphere (the brute-force baseline).
    pub use_bvh: bool,
    /// Where the collider's frame is in the world at the start (identity: spheres are in world
    /// coordinates). Move it per frame with `Simulation::set_collider_pose`.
    pub pose: RigidPose,
}

impl Collider {
    pub fn new(spheres: Vec<Vec4>, thickness: f32) -> Self {
        Collider { spheres, thickness, friction: 0.0, use_bvh: true, pose: RigidPose::IDENTITY }
    }

    /// The same collider starting at `rotation`, `translation`.
    pub fn with_pose(mut self, rotation: glam::Quat, translation: glam::Vec3) -> Self {
        self.pose = rigid_pose(rotation, translation);
        self
    }
}

/// A `RigidPose` from glam types.
pub fn rigid_pose(rotation: glam::Quat, translation: glam::Vec3) -> RigidPose {
    RigidPose { rotation: Vec4::from(rotation), translation: translation.extend(0.0) }
}

/// What a frame reports besides timings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReport {
    pub timings: FrameTimings,
    /// Substeps whose collision traversal ran / was skipped by the root-box test (all
    /// colliders together).
    pub collision_ran: u32,
    pub collision_skipped: u32,
}

/// Frames recorded into callers' command buffers whose status can be pending at once.
const STATUS_SLOTS: usize = 8;

/// A cloth simulation on the GPU.
pub struct Simulation {
    // Field order is drop order: the status ring goes first (it waits for frames recorded into
    // callers' command buffers that are still running), then the frame, then what it binds.
    status: StatusRing,
    frame: RecordedFrame,
    /// The frame's passes, encoded once (again when the substep count changes).
    frame_commands: Vec<Command>,
    /// drape's own command buffer holds outdated leading writes, or an outdated frame.
    own_frame_stale: bool,
    engine: Engine,
    program: ClothProgram,
    controls: Controls,
    lbvh_timings: Option<FrameTimings>,
    frames_done: u64,
    /// Frames whose blow-up and overflow status has been read.
    frames_checked: u64,
}

impl Simulation {
    /// Uploads `cloth` and records its frame (no collider).
    pub fn new(ctx: &Arc<Context>, cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        Self::with_colliders(ctx, cloth, settings, &[])
    }

    /// Uploads `cloth`, builds the collider's LBVH on the GPU (if any) and records the frame.
    pub fn with_collider(
        ctx: &Arc<Context>,
        cloth: &Cloth,
        settings: SimSettings,
        collider: Option<&Collider>,
    ) -> Result<Self> {
        Self::with_colliders(ctx, cloth, settings, collider.map(std::slice::from_ref).unwrap_or(&[]))
    }

    /// Uploads `cloth`, builds every collider's LBVH on the GPU and records the frame; the
    /// cloth collides with each collider after every substep, in order.
    pub fn with_colliders(
        ctx: &Arc<Context>,
        cloth: &Cloth,
        settings: SimSettings,
        colliders: &[Collider],
    ) -> Result<Self> {
        let (program, controls) = ClothProgram::with_controls(cloth, settings, colliders)?;
        let mut engine = Engine::new(ctx)?;
        engine.allocate(&program.resources)?;
        for (id, data) in &program.initial {
            engine.upload_bytes(*id, data)?;
        }
        let lbvh_timings =
            if colliders.is_empty() { None } else { Some(engine.record(&program.build_steps(), true)?.submit()?) };
        let bindings = engine.bind(&[&program.frame, &program.refit_steps()])?;
        let frame_commands = engine.encode(&bindings, &program.frame)?;
        let frame = RecordedFrame::new(ctx, bindings, &frame_commands, settings.timestamps)?;
        let status = StatusRing::new(ctx, STATUS_SLOTS, 16 * (1 + colliders.len() as u64))?;
        Ok(Simulation {
            status,
            frame,
            frame_commands,
            own_frame_stale: false,
            engine,
            program,
            controls,
            lbvh_timings,
            frames_done: 0,
            frames_checked: 0,
        })
    }

    /// Runs one frame in drape's own command buffer and waits for it; returns its per-pass GPU
    /// timings, or `Error::Unstable` on blow-up.
    pub fn step(&mut self) -> Result<FrameTimings> {
        Ok(self.step_report()?.timings)
    }

    /// Runs one frame; returns its timings and collision counters.
    pub fn step_report(&mut self) -> Result<FrameReport> {
        let leading = self.controls.begin_frame(&self.program);
        if !leading.is_empty() || self.own_frame_stale {
            let mut writes = self.engine.encode(self.frame.bindings(), &leading)?;
            if !writes.is_empty() {
                writes.push(Command::Barrier);
            }
            self.frame.rerecord(&[&writes, &self.frame_commands])?;
            // A frame that starts with writes must not replay them next time.
            self.own_frame_stale = !leading.is_empty();
        }
        let timings = self.frame.submit()?;
        self.frames_done += 1;
        self.frames_checked = self.frames_done;
        let health: Health = self.engine.read_mapped(self.program.cloth.health)?;
        check_health(&health, self.frames_done, &self.controls.settings, &self.controls.stability)?;
        let mut report = FrameReport { timings, ..FrameReport::default() };
        for c in &self.program.colliders {
            let status: CollisionStatus = self.engine.read_mapped(c.contact.status)?;
            check_collision(&status, self.frames_done)?;
            report.collision_ran += status.ran;
            report.collision_skipped += status.skipped;
        }
        Ok(report)
    }

    /// Records one frame (every substep, contact, normals, blow-up check) into the caller's
    /// command buffer `cmd`; nothing is submitted and nothing waits.
    ///
    /// Synchronization, all on drape's queue (`Context::queue_family`, the queue given to
    /// `Context::import`): the frame begins with a barrier that orders it after earlier
    /// vertex-input, vertex-shader, compute, transfer and host-write work on the queue (a
    /// renderer that read last frame's positions, say); it ends with one that makes its writes
    /// available to later vertex input (`VERTEX_ATTRIBUTE_READ`, `INDEX_READ`), vertex and
    /// compute shaders (`SHADER_READ`), transfers and the host. The blow-up and
    /// traversal-overflow status is copied to a ring drape reads without stalling: the next
    /// `record` (or `poll_status`) reports a failed frame as the same `Error::Unstable` /
    /// `Error::TraversalOverflow` as `step`, once that frame has finished on the GPU (one frame
    /// late with double buffering). At most 8 recorded frames may be unfinished at once.
    ///
    /// # Safety
    /// - `cmd` is a primary command buffer in the recording state, allocated on drape's device
    ///   from a pool of `Context::queue_family()`, and is submitted exactly once, to drape's
    ///   queue, before this simulation is dropped.
    /// - Nothing else uses the queue while drape's calls that touch it run (`step`, uploads,
    ///   read-backs, `poll_status`, drop): Vulkan requires external synchronization of a queue.
    /// - Dropping the simulation waits for the queue when recorded frames are unfinished;
    ///   a command buffer recorded here must not be submitted after that.
    pub unsafe fn record(&mut self, cmd: ash::vk::CommandBuffer) -> Result<()> {
        self.poll_status()?;
        let leading = self.controls.begin_frame(&self.program);
        let mut writes = self.engine.encode(self.frame.bindings(), &leading)?;
        if !writes.is_empty() {
            writes.push(Command::Barrier);
        }
        // The own command buffer may hold writes this frame supersedes.
        self.own_frame_stale = true;
        let device = &self.engine.context().device;
        let frame = self.frames_done + 1;
        let mut sources = vec![&**self.engine.buffer(self.program.cloth.health.id())?];
        for c in &self.program.colliders {
            sources.push(&**self.engine.buffer(c.contact.status.id())?);
        }
        // SAFETY: the caller's contract for `cmd`; every handle comes from `self.frame`'s
        // bindings or the engine, which live until the ring's drop waits for the queue.
        unsafe {
            let labels = self.engine.context().debug_utils();
            encode_frame(device, labels, cmd, &[&writes, &self.frame_commands], None);
            self.status.record(cmd, &sources, frame)?;
        }
        self.frames_done = frame;
        Ok(())
    }

    /// Reads the status of frames recorded with `record` that have finished on the GPU, without
    /// waiting; returns how many were read, or the first failure (`Error::Unstable`,
    /// `Error::TraversalOverflow`) with its frame number.
    pub fn poll_status(&mut self) -> Result<u32> {
        let mut read = 0;
        while let Some((frame, bytes)) = self.status.poll()? {
            read += 1;
            self.frames_checked = frame;
            let health: Health = bytemuck::pod_read_unaligned(&bytes[..16]);
            check_health(&health, frame, &self.controls.settings, &self.controls.stability)?;
            for chunk in bytes[16..].as_chunks::<16>().0 {
                check_collision(&bytemuck::pod_read_unaligned(chunk.as_slice()), frame)?;
            }
        }
        Ok(read)
    }

    /// Frames recorded with `record` whose status has not been read yet.
    pub fn frames_in_flight(&self) -> usize {
        self.status.pending()
    }

    fn read_vec4s(&self, buffer: crate::graph::Handle<Vec4>) -> Result<Vec<Vec4>> {
        self.engine.download(buffer, self.params().particle_count as usize)
    }

    /// Positions (xyz, w = pin weight), read back from the GPU (after every submitted frame).
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
    /// Collider `index`'s LBVH as built (and refit) on the GPU, in the collider's own frame.
    pub fn collider_bvh(&self, index: usize) -> Result<Option<lbvh::Lbvh>> {
        match self.program.colliders.get(index) {
            Some(c) => Ok(Some(lbvh::download(&self.engine, &c.lbvh)?)),
            None => Ok(None),
        }
    }
    /// GPU time of the LBVH builds per stage (None without a collider).
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

    /// After a change of the substep count: the frame's passes encoded again.
    fn replan(&mut self, substeps_changed: bool) -> Result<()> {
        if substeps_changed {
            self.program.frame = self.controls.frame_steps(&self.program);
            self.frame_commands = self.engine.encode(self.frame.bindings(), &self.program.frame)?;
            self.own_frame_stale = true;
        }
        Ok(())
    }

    /// Teleports the cloth: new positions (xyz; w is kept, so pins stay) and velocities.
    /// Uploads at once (ordered after every frame submitted so far).
    pub fn set_state(&mut self, positions: &[glam::Vec3], velocities: &[glam::Vec3]) -> Result<()> {
        let old = self.positions()?;
        let (x, v) = teleported(&old, positions, velocities)?;
        self.engine.upload(self.program.cloth.x, &x)?;
        self.engine.upload(self.program.cloth.v, &v)
    }

    /// Bytes of GPU buffers per part of the simulation (cloth, each collider, each contact, the
    /// status ring of recorded frames), and what the allocator holds on the whole context.
    pub fn memory_report(&self) -> MemoryReport {
        let mut parts: Vec<(String, u64)> = Vec::new();
        for desc in self.program.resources.descs() {
            let part = desc.name.split(':').next().unwrap_or("other").to_string();
            match parts.iter_mut().find(|(p, _)| *p == part) {
                Some((_, bytes)) => *bytes += desc.bytes,
                None => parts.push((part, desc.bytes)),
            }
        }
        parts.push(("status ring".into(), self.status.bytes()));
        MemoryReport { parts, allocator: self.context().allocator_stats() }
    }

    /// Memory barriers in drape's own recorded frame (derived from the passes' reads and writes).
    pub fn barriers_per_frame(&self) -> u32 {
        self.frame.barrier_count()
    }
    pub fn params(&self) -> &SimParams {
        &self.controls.params
    }
    pub fn stability(&self) -> &Stability {
        &self.controls.stability
    }
    pub fn settings(&self) -> &SimSettings {
        &self.controls.settings
    }
    /// Frames run by `step` or recorded by `record`.
    pub fn frames_done(&self) -> u64 {
        self.frames_done
    }
    /// The last frame whose blow-up and overflow status has been read (equal to `frames_done`
    /// after `step`; behind it while recorded frames are in flight).
    pub fn frames_checked(&self) -> u64 {
        self.frames_checked
    }
    pub fn context(&self) -> &Arc<Context> {
        self.engine.context()
    }
}

crate::controls::runtime_setters!(Simulation);

/// New positions and velocities for a teleport, keeping each particle's pin weight.
pub(crate) fn teleported(
    old: &[Vec4],
    positions: &[glam::Vec3],
    velocities: &[glam::Vec3],
) -> Result<(Vec<Vec4>, Vec<Vec4>)> {
    let n = old.len();
    if positions.len() != n || velocities.len() != n {
        return Err(Error::InvalidParameter {
            name: "state",
            problem: format!("expected {n} positions and velocities, got {} and {}", positions.len(), velocities.len()),
        });
    }
    if !positions.iter().chain(velocities).all(|p| p.is_finite()) {
        return Err(Error::InvalidParameter { name: "state", problem: "values must be finite".into() });
    }
    let x = positions.iter().zip(old).map(|(p, o)| p.extend(o.w)).collect();
    let v = velocities.iter().zip(old).map(|(v, o)| if o.w == 0.0 { Vec4::ZERO } else { v.extend(0.0) }).collect();
    Ok((x, v))
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
        let width = self.parts.iter().map(|(part, _)| part.len()).max().unwrap_or(0).max("allocator".len());
        for (part, bytes) in &self.parts {
            writeln!(f, "  {part:<width$} {:>10.1} KiB", *bytes as f64 / 1024.0)?;
        }
        let a = &self.allocator;
        write!(
            f,
            "  {:<width$} {} allocations, {:.1} KiB used in {} blocks of {:.1} MiB total",
            "allocator",
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
/// vertex input, vertex/compute shader and transfer stages of every later command on the
/// queue, and to the host; `step()` returns after the frame completed (see `record` for frames
/// in the caller's command buffer).
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

/// Turns a traversal overflow into an error.
pub(crate) fn check_collision(status: &CollisionStatus, frame: u64) -> Result<()> {
    if status.overflows > 0 {
        return Err(Error::TraversalOverflow { frame, particles: status.overflows });
    }
    Ok(())
}
