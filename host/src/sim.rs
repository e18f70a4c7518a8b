//! The GPU simulation: uploads a cloth once, records its frame once, and runs frames. State stays
//! on the GPU between frames; positions, velocities and normals are read back only when asked.

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::gpu::commands::{DescriptorArena, download, upload};
use crate::gpu::{Buffer, Command, Context, FrameTimings, Pipeline, RecordedFrame, ShaderModule};
use crate::kernels::KernelId;
use crate::program::{BufferId, FramePlan, FrameStep, cloth_frame};
use crate::stability::{self, DEFAULT_SAFETY, Stability};
use drape_types::{Health, SimParams, integrator};
use glam::Vec4;
use gpu_allocator::MemoryLocation;
use std::collections::HashMap;
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
        if !(self.max_stretch > 1.0) {
            return bad("max_stretch", format!("must be > 1, got {}", self.max_stretch));
        }
        let stability =
            stability::choose(cloth, self.integrator.id(), self.frame_dt, self.substeps, self.safety);
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
        FramePlan {
            particles: params.particle_count,
            substeps: stability.substeps,
            integrator: params.integrator,
            normals: self.normals,
        }
    }
}

/// Reads the blow-up detector and turns a blow-up into an error.
pub(crate) fn check_health(
    health: &Health,
    frame: u64,
    settings: &SimSettings,
    stability: &Stability,
) -> Result<()> {
    let stretch = f32::from_bits(health.max_stretch_bits);
    let detail = if health.non_finite > 0 {
        format!("{} particles have non-finite position or velocity", health.non_finite)
    } else if !(stretch <= settings.max_stretch) {
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

/// A cloth simulation on the GPU.
pub struct Simulation {
    // Field order is drop order: the recorded frame and sets go before what they reference.
    frame: RecordedFrame,
    _arena: DescriptorArena,
    _pipelines: HashMap<KernelId, Pipeline>,
    buffers: HashMap<BufferId, Buffer>,
    _module: ShaderModule,
    ctx: Arc<Context>,
    params: SimParams,
    settings: SimSettings,
    stability: Stability,
    frames_done: u64,
}

impl Simulation {
    /// Uploads `cloth` and records its frame.
    pub fn new(ctx: &Arc<Context>, cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        let (params, stability) = settings.resolve(cloth)?;
        let groups = params.particle_count.div_ceil(drape_kernels::WORKGROUP_SIZE);
        if groups > ctx.info().max_workgroup_count_x {
            return Err(Error::InvalidParameter {
                name: "rows/cols",
                problem: format!(
                    "{} particles need {groups} workgroups; this device dispatches at most {}",
                    params.particle_count,
                    ctx.info().max_workgroup_count_x
                ),
            });
        }
        let steps = cloth_frame(settings.plan(&params, &stability));
        let module = ShaderModule::new(ctx, crate::KERNELS_SPV)?;
        let mut pipelines = HashMap::new();
        for id in KernelId::ALL {
            pipelines.insert(id, Pipeline::new(ctx, &module, id.spec())?);
        }

        let n = cloth.particle_count() as u64;
        let vec4s = n * size_of::<Vec4>() as u64;
        let mut buffers = HashMap::new();
        for id in [
            BufferId::X,
            BufferId::V,
            BufferId::XA,
            BufferId::VA,
            BufferId::XB,
            BufferId::VB,
            BufferId::AccX,
            BufferId::AccV,
            BufferId::XPrev,
            BufferId::Normals,
        ] {
            buffers.insert(id, Buffer::new(ctx, &format!("{id:?}"), vec4s, MemoryLocation::GpuOnly)?);
        }
        buffers.insert(
            BufferId::Params,
            Buffer::new(ctx, "params", size_of::<SimParams>() as u64, MemoryLocation::GpuOnly)?,
        );
        // Read by the host after every frame: keep it mapped.
        buffers.insert(
            BufferId::Health,
            Buffer::new(ctx, "health", size_of::<Health>() as u64, MemoryLocation::GpuToCpu)?,
        );
        let get = |id: BufferId| {
            buffers.get(&id).ok_or_else(|| Error::Kernel {
                kernel: "simulation".into(),
                problem: format!("buffer {id:?} not allocated"),
            })
        };
        upload(ctx, get(BufferId::Params)?, bytemuck::bytes_of(&params))?;
        upload(ctx, get(BufferId::X)?, bytemuck::cast_slice(&cloth.positions))?;
        upload(ctx, get(BufferId::V)?, bytemuck::cast_slice(&cloth.velocities))?;
        // Stage buffers start as copies of the state so pinned particles read sane values.
        for id in [BufferId::XA, BufferId::XB, BufferId::XPrev] {
            upload(ctx, get(id)?, bytemuck::cast_slice(&cloth.positions))?;
        }

        let (arena, frame) = record_frame(ctx, &steps, &pipelines, &buffers, settings.timestamps)?;
        Ok(Simulation {
            frame,
            _arena: arena,
            _pipelines: pipelines,
            buffers,
            _module: module,
            ctx: ctx.clone(),
            params,
            settings,
            stability,
            frames_done: 0,
        })
    }

    /// Runs one frame; returns its per-pass GPU timings, or `Error::Unstable` on blow-up.
    pub fn step(&mut self) -> Result<FrameTimings> {
        let timings = self.frame.submit()?;
        self.frames_done += 1;
        let health = self.read_health()?;
        check_health(&health, self.frames_done, &self.settings, &self.stability)?;
        Ok(timings)
    }

    fn read_health(&self) -> Result<Health> {
        let bytes = self
            .buffers
            .get(&BufferId::Health)
            .and_then(|b| b.mapped())
            .ok_or_else(|| Error::Kernel { kernel: "health".into(), problem: "not host visible".into() })?;
        Ok(bytemuck::pod_read_unaligned(&bytes[..size_of::<Health>()]))
    }

    fn read_vec4s(&self, id: BufferId) -> Result<Vec<Vec4>> {
        let buffer = self.buffers.get(&id).ok_or_else(|| Error::Kernel {
            kernel: "simulation".into(),
            problem: format!("buffer {id:?} not allocated"),
        })?;
        let bytes = download(&self.ctx, buffer, self.params.particle_count as u64 * 16)?;
        Ok(bytes.chunks_exact(size_of::<Vec4>()).map(bytemuck::pod_read_unaligned).collect())
    }

    /// Positions (xyz, w = pin weight), read back from the GPU.
    pub fn positions(&self) -> Result<Vec<Vec4>> {
        self.read_vec4s(BufferId::X)
    }
    /// Velocities, read back from the GPU.
    pub fn velocities(&self) -> Result<Vec<Vec4>> {
        self.read_vec4s(BufferId::V)
    }
    /// Vertex normals of the last frame (zero before the first frame or with normals off).
    pub fn normals(&self) -> Result<Vec<Vec4>> {
        self.read_vec4s(BufferId::Normals)
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
        &self.ctx
    }
}

/// Creates descriptor sets for every distinct (kernel, buffers) pair and records the frame.
fn record_frame(
    ctx: &Arc<Context>,
    steps: &[FrameStep],
    pipelines: &HashMap<KernelId, Pipeline>,
    buffers: &HashMap<BufferId, Buffer>,
    timed: bool,
) -> Result<(DescriptorArena, RecordedFrame)> {
    let missing = |what: String| Error::Kernel { kernel: "frame".into(), problem: what };
    let mut distinct: Vec<(KernelId, Vec<BufferId>)> = Vec::new();
    for step in steps {
        if let FrameStep::Run(pass) = step {
            let key = (pass.kernel, pass.bindings.clone());
            if !distinct.contains(&key) {
                distinct.push(key);
            }
        }
    }
    let total_bindings: usize = distinct.iter().map(|(_, b)| b.len()).sum();
    let arena = DescriptorArena::new(ctx, distinct.len() as u32, total_bindings as u32)?;
    let mut sets = HashMap::new();
    for (kernel, ids) in &distinct {
        let pipeline = pipelines.get(kernel).ok_or_else(|| missing(format!("no pipeline {kernel:?}")))?;
        let bound: Vec<&Buffer> = ids
            .iter()
            .map(|id| buffers.get(id).ok_or_else(|| missing(format!("no buffer {id:?}"))))
            .collect::<Result<_>>()?;
        sets.insert((*kernel, ids.clone()), arena.bind(pipeline, &bound)?);
    }
    let mut commands = Vec::with_capacity(steps.len());
    for step in steps {
        commands.push(match step {
            FrameStep::ResetHealth => Command::Fill {
                buffer: buffers.get(&BufferId::Health).ok_or_else(|| missing("no health buffer".into()))?.handle,
                value: 0,
            },
            FrameStep::Skip { label } => Command::Skipped { label: *label },
            FrameStep::Run(pass) => {
                let pipeline = pipelines.get(&pass.kernel).ok_or_else(|| missing(format!("{:?}", pass.kernel)))?;
                let key = (pass.kernel, pass.bindings.clone());
                Command::Dispatch {
                    label: pass.label,
                    pipeline,
                    set: sets[&key],
                    push: pass.push.map(|p| bytemuck::bytes_of(&p).to_vec()).unwrap_or_default(),
                    groups: pass.threads.div_ceil(pipeline.spec.workgroup_size),
                }
            }
        });
    }
    let frame = RecordedFrame::record(ctx, &commands, timed)?;
    Ok((arena, frame))
}
