//! The GPU solver: uploads a model once, records its frame once, and advances its state frame
//! by frame. The state stays on the GPU between frames; positions, velocities and normals are
//! read back only when asked.

use crate::controls::Controls;
use crate::error::{Error, Result};
use crate::gpu::recording::encode_frame;
use crate::gpu::status_ring::StatusRing;
use crate::gpu::{Command, Context, Engine, FrameTimings, RecordedFrame};
use crate::graph::Barrier;
use crate::lbvh;
use crate::model::{ClothId, ColliderId, Model};
use crate::program::SolverProgram;
use crate::state::State;
use drape_types::{CollisionStatus, Health};
use glam::Vec4;
use std::sync::Arc;

/// What a frame reports besides timings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReport {
    pub timings: FrameTimings,
    /// Substeps whose collision traversal ran / was skipped (all colliders together): by the
    /// culling pass's root-box test, or, where the narrow phase over candidate lists runs
    /// inside the last integration stage (a cloth's first collider), skipped when the frame's
    /// broad phase listed no particle (`CollisionStatus::skipped`).
    pub collision_ran: u32,
    pub collision_skipped: u32,
    /// Particle-substeps whose candidate list did not cover their motion, answered by a full
    /// LBVH walk instead (`ContactSearch::CandidateLists`).
    pub collision_fallbacks: u32,
    /// Particle-substeps the narrow phase handed to the crowded pass, a workgroup each
    /// (`SimSettings::crowded_contact`).
    pub collision_crowded: u32,
    /// Particle-substeps whose narrow phase was crowded, handed over or not (the cloths'
    /// `Health::crowded_contacts`; counted unless `SimSettings::crowded_contact` is off).
    pub crowded_contacts: u32,
    /// Particles the frame's broad phase gave candidates (`ContactSearch::CandidateLists`,
    /// all colliders together): when a collider has any, its culling passes (where there are
    /// any) say run at once.
    pub collision_listed: u32,
    /// Self-collision: the triangles' tests over the frame's passes (triangles x passes, all
    /// self-colliding cloths together), and how many of those walked the tree instead of
    /// testing the frame's pair list (they left their predicted region, or their list was
    /// full; `drape_kernels::self_pairs`).
    pub self_triangle_passes: u32,
    pub self_walks: u32,
    /// Of `self_triangle_passes`, those of frames that ran no pair lists (a cloth whose
    /// triangles are too small for them at its thickness: `programs::self_contact::lists_pay`),
    /// where every triangle walks.
    pub self_passes_without_lists: u32,
    /// Self-collision's fail-safe (`drape_kernels::self_failsafe`): particles put back where
    /// the frame started (carried with a collider that moved) because a pair of the cloth's
    /// triangles, or one of them and a collider's triangle, crossed over it, and cloths put back whole
    /// (its last round still found a crossing).
    pub self_rollbacks: u32,
    pub self_rollbacks_whole: u32,
    /// Of the pairs the fail-safe found, those of a cloth triangle and a collider triangle (a
    /// collider's vertex or edge through a cloth cell, or a cloth edge through its face).
    pub self_rollback_collider_pairs: u32,
    /// Of the particles put back, those carried with a moving collider.
    pub self_rollbacks_carried: u32,
    /// Triangle colliders whose sharp vertices and edges the frame's self-collision passes
    /// tested by walks from the cloth's side (`FeatureWalks`), counted once per collider and
    /// self-colliding cloth.
    pub feature_walks_from_cloth: u32,
    /// Listed collider triangles that the lists of a span of the frame put out of the cloth's
    /// reach (summed over the spans and colliders): the passes walked the cloth's tree from the
    /// others, and the cloth's escaped triangles took these (`drape_kernels::feature_reach`).
    pub collider_features_out_of_reach: u32,
    /// Cloths that slept through the frame (ran nothing).
    pub cloths_asleep: u32,
    /// Tiles of the awake cloths that slept through the frame (`SimSettings::tile_sleep`),
    /// and the tiles of those cloths.
    pub tiles_asleep: u32,
    pub tiles: u32,
}

/// Frames recorded into callers' command buffers whose status can be pending at once.
const STATUS_SLOTS: usize = 8;

/// Advances a model's state on the GPU: every cloth, each colliding with every collider.
pub struct Solver {
    // Field order is drop order: the status ring goes first (it waits for frames recorded into
    // callers' command buffers that are still running), then the frame, then what it binds.
    status: StatusRing,
    frame: RecordedFrame,
    /// The frame's passes, encoded once (again when the substep count changes).
    frame_commands: Vec<Command>,
    /// drape's own command buffer holds outdated leading writes, or an outdated frame.
    own_frame_stale: bool,
    engine: Engine,
    program: SolverProgram,
    controls: Controls,
    lbvh_timings: Option<FrameTimings>,
    frames_done: u64,
    /// Frames whose blow-up status has been read.
    frames_checked: u64,
}

impl Solver {
    /// Uploads `model`, builds every collider's LBVH on the GPU and records the frame.
    pub fn new(ctx: &Arc<Context>, model: &Model) -> Result<Self> {
        let is_gpu = ctx.info().device_type != ash::vk::PhysicalDeviceType::CPU;
        Self::on_device(ctx, model, is_gpu)
    }

    /// `new`, with the choices that depend on the device made as for a GPU even on a CPU driver
    /// (`SimSettings::crowded_contact`): what drape's tests use to run a GPU's choices on
    /// lavapipe. The same results, only the cost differs.
    #[cfg(feature = "internals")]
    #[doc(hidden)]
    pub fn new_as_gpu(ctx: &Arc<Context>, model: &Model) -> Result<Self> {
        Self::on_device(ctx, model, true)
    }

    fn on_device(ctx: &Arc<Context>, model: &Model, is_gpu: bool) -> Result<Self> {
        let max_workgroup = ctx.info().max_workgroup_invocations;
        let (program, controls) = SolverProgram::with_controls_on(model, is_gpu, max_workgroup)?;
        let mut engine = Engine::new(ctx)?;
        engine.allocate(&program.resources)?;
        for (id, data) in &program.initial {
            engine.upload_bytes(*id, data)?;
        }
        let lbvh_timings = if program.colliders.is_empty() {
            None
        } else {
            Some(engine.record(&program.build_steps(), true)?.submit()?)
        };
        // The frame as it is planned now, and what later plans may add: colliders' refits,
        // lists built again within a frame, crowded particles handed over.
        let later = [program.refit_steps(), program.self_window_steps(), program.crowded_steps(&controls.plans())];
        let bindings = engine.bind(&[&program.frame, &later[0], &later[1], &later[2]])?;
        let frame_commands = engine.encode(&bindings, &program.frame)?;
        let settings = controls.settings;
        let frame = RecordedFrame::new(ctx, bindings, &frame_commands, settings.timestamps)?;
        // A slot holds every status buffer of a frame, back to back.
        let slot_bytes =
            program.status_buffers().into_iter().map(|id| engine.buffer(id).map(|b| b.size())).sum::<Result<u64>>()?;
        let status = StatusRing::new(ctx, STATUS_SLOTS, slot_bytes)?;
        Ok(Solver {
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
        let replan = self.controls.take_replan();
        self.replan(replan)?;
        // A cloth that just fell asleep lies where the last (waited-for) frame left it: read it
        // once, so colliders moving elsewhere do not wake it. (`record` cannot read back: the
        // caller may not have submitted its frames; there any moving collider wakes it.)
        for i in self.controls.asleep_unplaced() {
            let b = &self.program.cloths[i];
            let x = self.engine.download(b.x, b.particles as usize)?;
            self.controls.rest_at(i, &x);
        }
        if !leading.is_empty() || self.own_frame_stale {
            let mut writes = self.engine.encode(self.frame.bindings(), &leading)?;
            if !writes.is_empty() {
                writes.push(Command::Barrier(Barrier::FULL));
            }
            self.frame.rerecord(&[&writes, &self.frame_commands])?;
            // A frame that starts with writes must not replay them next time.
            self.own_frame_stale = !leading.is_empty();
        }
        let timings = self.frame.submit()?;
        self.frames_done += 1;
        self.frames_checked = self.frames_done;
        let mut report = FrameReport { timings, ..FrameReport::default() };
        let plans = self.controls.plans();
        for (i, (cloth, contacts)) in self.program.cloths.iter().zip(&self.program.contacts).enumerate() {
            if self.controls.cloths[i].motion.asleep {
                report.cloths_asleep += 1;
                continue; // nothing ran: its status buffers hold its last awake frame's
            }
            let health: Health = self.engine.read_mapped(cloth.health)?;
            report.tiles_asleep += health.tiles_asleep;
            report.crowded_contacts += health.crowded_contacts;
            report.tiles += cloth.tiles.as_ref().map_or(0, |t| t.tiles);
            if let (Some(s), Some(plan)) = (&cloth.self_contact, plans.get(i)) {
                report.self_rollbacks += health.self_rollbacks;
                report.self_rollbacks_whole += health.self_rollback_all;
                report.self_rollback_collider_pairs += health.self_rollback_collider_pairs;
                report.self_rollbacks_carried += health.self_rollbacks_carried;
                report.feature_walks_from_cloth += health.feature_walks_from_cloth;
                report.collider_features_out_of_reach += health.collider_features_out_of_reach;
                let passes = plan.self_passes.clamp(1, plan.substeps.max(1));
                report.self_triangle_passes += s.tree.leaves * passes;
                // Without lists every triangle walks; with them, those that escaped and those
                // whose list was full (counted once per frame).
                report.self_walks += if plan.self_lists {
                    health.self_walks + health.self_full_lists * passes
                } else {
                    report.self_passes_without_lists += s.tree.leaves * passes;
                    s.tree.leaves * passes
                };
            }
            self.controls.check_health(&health, self.frames_done, i)?;
            self.controls.observe(i, &health, self.frames_done);
            for contact in contacts {
                let status: CollisionStatus = self.engine.read_mapped(contact.status)?;
                report.collision_ran += status.ran;
                report.collision_skipped += status.skipped;
                report.collision_fallbacks += status.fallbacks;
                report.collision_crowded += status.crowded;
                report.collision_listed += status.listed;
            }
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
    /// compute shaders (`SHADER_READ`), transfers and the host. The cloths' health (a blow-up)
    /// is copied to a ring drape reads without stalling: the next `record` (or `poll_status`)
    /// reports a failed frame as the same `Error::Unstable` as `step`, once that frame has
    /// finished on the GPU (one frame late with double buffering). At most 8 recorded frames
    /// may be unfinished at once.
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
        let replan = self.controls.take_replan();
        self.replan(replan)?;
        let mut writes = self.engine.encode(self.frame.bindings(), &leading)?;
        if !writes.is_empty() {
            writes.push(Command::Barrier(Barrier::FULL));
        }
        // The own command buffer may hold writes this frame supersedes.
        self.own_frame_stale = true;
        let device = &self.engine.context().device;
        let frame = self.frames_done + 1;
        let sources = self
            .program
            .status_buffers()
            .into_iter()
            .map(|id| self.engine.buffer(id).map(|b| &**b))
            .collect::<Result<Vec<_>>>()?;
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
    /// waiting; returns how many were read, or the first failure (`Error::Unstable`) with its
    /// frame number.
    pub fn poll_status(&mut self) -> Result<u32> {
        let mut read = 0;
        while let Some((frame, bytes)) = self.status.poll()? {
            read += 1;
            self.frames_checked = frame;
            // Each cloth's health.
            let mut rest = bytes.as_slice();
            let mut take = |n: usize| {
                let (head, tail) = rest.split_at_checked(n).unwrap_or((&[], &[]));
                rest = tail;
                (head.len() == n).then_some(head)
            };
            for i in 0..self.program.cloths.len() {
                if let Some(health) = take(size_of::<Health>()) {
                    let health: Health = bytemuck::pod_read_unaligned(health);
                    self.controls.check_health(&health, frame, i)?;
                    self.controls.observe(i, &health, frame);
                }
            }
        }
        Ok(read)
    }

    /// Frames recorded with `record` whose status has not been read yet.
    pub fn frames_in_flight(&self) -> usize {
        self.status.pending()
    }

    fn cloth_buffers(&self, cloth: ClothId) -> Result<&crate::programs::cloth::ClothBuffers> {
        self.controls.cloth(cloth)?;
        Ok(&self.program.cloths[cloth.index()])
    }

    fn read_vec4s(
        &self,
        cloth: ClothId,
        pick: fn(&crate::programs::cloth::ClothBuffers) -> crate::graph::Handle<Vec4>,
    ) -> Result<Vec<Vec4>> {
        let buffers = self.cloth_buffers(cloth)?;
        self.engine.download(pick(buffers), buffers.particles as usize)
    }

    /// `cloth`'s positions (xyz, w = pin weight), read back from the GPU (after every submitted
    /// frame).
    pub fn positions(&self, cloth: ClothId) -> Result<Vec<Vec4>> {
        self.read_vec4s(cloth, |b| b.x)
    }
    /// `cloth`'s velocities, read back from the GPU (w = 1 for a particle whose tile sleeps,
    /// `SimSettings::tile_sleep`; else 0).
    pub fn velocities(&self, cloth: ClothId) -> Result<Vec<Vec4>> {
        self.read_vec4s(cloth, |b| b.v)
    }
    /// `cloth`'s integrator stage buffers: the substep's start positions and the two
    /// ping-pong pairs (x a, x b, v a, v b). For drape's tests (`internals`).
    #[cfg(feature = "internals")]
    #[doc(hidden)]
    pub fn stage_buffers(&self, cloth: ClothId) -> Result<[Vec<Vec4>; 5]> {
        Ok([
            self.read_vec4s(cloth, |b| b.x_prev)?,
            self.read_vec4s(cloth, |b| b.xa)?,
            self.read_vec4s(cloth, |b| b.xb)?,
            self.read_vec4s(cloth, |b| b.va)?,
            self.read_vec4s(cloth, |b| b.vb)?,
        ])
    }
    /// `cloth`'s vertex normals of the last frame (zero before the first frame or with normals
    /// off).
    pub fn normals(&self, cloth: ClothId) -> Result<Vec<Vec4>> {
        self.read_vec4s(cloth, |b| b.normals)
    }
    /// What changes, read back: every cloth's positions and velocities, every collider's pose.
    pub fn state(&self) -> Result<State> {
        State::read(&self.program, &self.controls, &self.engine)
    }
    /// Restores a state (e.g. one `state` returned): every cloth's positions (with their pin
    /// weights) and velocities are uploaded at once, and its motion history (substeps, sleep)
    /// comes back with them; the colliders are put at their poses
    /// without sweeping there.
    pub fn set_state(&mut self, state: &State) -> Result<()> {
        let engine = &mut self.engine;
        state.restore(&self.program, &mut self.controls, |buffer, data| engine.upload_bytes(buffer, data))
    }
    /// `collider`'s LBVH as built (and refit) on the GPU, in the collider's own frame.
    pub fn collider_bvh(&self, collider: ColliderId) -> Result<lbvh::Lbvh> {
        match self.program.colliders.get(collider.index()) {
            Some(c) => lbvh::download(&self.engine, &c.leaves),
            None => {
                Err(Error::InvalidParameter { name: "collider", problem: format!("no collider {}", collider.index()) })
            }
        }
    }
    /// GPU time of the LBVH builds per stage (None without a collider).
    pub fn lbvh_timings(&self) -> Option<&FrameTimings> {
        self.lbvh_timings.as_ref()
    }
    /// `cloth`'s vertex and index buffers, for a renderer to bind.
    pub fn vertex_buffers(&self, cloth: ClothId) -> Result<VertexBuffers> {
        let cloth = self.cloth_buffers(cloth)?;
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

    /// Teleports `cloth`: new positions (xyz; w is kept, so pins stay) and velocities.
    /// Uploads at once (ordered after every frame submitted so far).
    pub fn teleport(&mut self, cloth: ClothId, positions: &[glam::Vec3], velocities: &[glam::Vec3]) -> Result<()> {
        let old = self.positions(cloth)?;
        let (x, v) = teleported(&old, positions, velocities)?;
        self.controls.set_moving(cloth, &v)?;
        let b = &self.program.cloths[cloth.index()];
        self.engine.upload(b.x, &x)?;
        self.engine.upload(b.v, &v)
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
    /// Frames run by `step` or recorded by `record`.
    pub fn frames_done(&self) -> u64 {
        self.frames_done
    }
    /// The last frame whose blow-up status has been read (equal to `frames_done`
    /// after `step`; behind it while recorded frames are in flight).
    pub fn frames_checked(&self) -> u64 {
        self.frames_checked
    }
    pub fn context(&self) -> &Arc<Context> {
        self.engine.context()
    }
}

crate::controls::runtime_setters!(Solver);

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
