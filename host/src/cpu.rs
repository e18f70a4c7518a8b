//! The CPU executor: runs a frame's pass list (the same `program::cloth_frame` the GPU records)
//! with the kernel crate's own functions, one invocation after another. It is the GPU's twin in
//! tests: same schedule, same math, same f32 arithmetic up to instruction selection (FMA).

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::kernels::KernelId;
use crate::program::{BufferId, FrameStep, Pass, cloth_frame};
use crate::sim::{SimSettings, check_health};
use crate::stability::Stability;
use drape_kernels::health::check_health_at;
use drape_kernels::integrate::{StageBuffers, integrate_stage_at};
use drape_kernels::normals::vertex_normal_at;
use drape_types::{Health, SimParams};
use glam::Vec4;
use std::collections::HashMap;

/// A cloth simulation on the CPU with the kernels' own functions.
pub struct CpuSimulation {
    params: SimParams,
    settings: SimSettings,
    stability: Stability,
    steps: Vec<FrameStep>,
    buffers: HashMap<BufferId, Vec<Vec4>>,
    health: Health,
    frames_done: u64,
}

impl CpuSimulation {
    pub fn new(cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        let (params, stability) = settings.resolve(cloth)?;
        let steps = cloth_frame(settings.plan(&params, &stability));
        let n = cloth.particle_count();
        let mut buffers = HashMap::new();
        for id in [BufferId::V, BufferId::VA, BufferId::VB, BufferId::AccX, BufferId::AccV, BufferId::Normals] {
            buffers.insert(id, vec![Vec4::ZERO; n]);
        }
        for id in [BufferId::X, BufferId::XA, BufferId::XB, BufferId::XPrev] {
            buffers.insert(id, cloth.positions.clone());
        }
        buffers.insert(BufferId::V, cloth.velocities.clone());
        Ok(CpuSimulation {
            params,
            settings,
            stability,
            steps,
            buffers,
            health: Health::default(),
            frames_done: 0,
        })
    }

    /// Runs one frame; `Error::Unstable` on blow-up, like the GPU.
    pub fn step(&mut self) -> Result<()> {
        let steps = std::mem::take(&mut self.steps);
        let result = steps.iter().try_for_each(|step| self.run(step));
        self.steps = steps;
        result?;
        self.frames_done += 1;
        check_health(&self.health, self.frames_done, &self.settings, &self.stability)
    }

    fn take(&mut self, id: BufferId) -> Result<Vec<Vec4>> {
        self.buffers.remove(&id).ok_or_else(|| Error::Kernel {
            kernel: "cpu".into(),
            problem: format!("buffer {id:?} missing or bound twice"),
        })
    }

    fn run(&mut self, step: &FrameStep) -> Result<()> {
        let pass: &Pass = match step {
            FrameStep::ResetHealth => {
                self.health = Health::default();
                return Ok(());
            }
            FrameStep::Skip { .. } => return Ok(()),
            FrameStep::Run(pass) => pass,
        };
        // Params and health live outside the particle buffers; the rest are taken out and put back.
        let ids: Vec<BufferId> =
            pass.bindings.iter().copied().filter(|id| !matches!(id, BufferId::Params | BufferId::Health)).collect();
        let mut bound: Vec<Vec<Vec4>> = ids.iter().map(|&id| self.take(id)).collect::<Result<_>>()?;
        let p = self.params;
        match pass.kernel {
            KernelId::IntegrateStage => {
                let stage = pass.push.map(|push| push.stage).unwrap_or(0);
                let [x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev] = &mut bound[..] else {
                    return Err(Error::Kernel { kernel: "cpu".into(), problem: "integrate binds 9 buffers".into() });
                };
                let mut b = StageBuffers { x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev };
                for i in 0..pass.threads {
                    integrate_stage_at(&p, stage, i, &mut b);
                }
            }
            KernelId::VertexNormals => {
                let [x, normals] = &mut bound[..] else {
                    return Err(Error::Kernel { kernel: "cpu".into(), problem: "normals binds 2 buffers".into() });
                };
                for i in 0..pass.threads {
                    normals[i as usize] = vertex_normal_at(&p, i, x).extend(0.0);
                }
            }
            KernelId::CheckHealth => {
                let [x, v] = &bound[..] else {
                    return Err(Error::Kernel { kernel: "cpu".into(), problem: "health binds 2 buffers".into() });
                };
                for i in 0..pass.threads {
                    check_health_at(&p, i, x, v, &mut self.health);
                }
            }
        }
        for (&id, data) in ids.iter().zip(bound) {
            self.buffers.insert(id, data);
        }
        Ok(())
    }

    fn buffer(&self, id: BufferId) -> Vec<Vec4> {
        self.buffers.get(&id).cloned().unwrap_or_default()
    }
    pub fn positions(&self) -> Vec<Vec4> {
        self.buffer(BufferId::X)
    }
    pub fn velocities(&self) -> Vec<Vec4> {
        self.buffer(BufferId::V)
    }
    pub fn normals(&self) -> Vec<Vec4> {
        self.buffer(BufferId::Normals)
    }
    pub fn params(&self) -> &SimParams {
        &self.params
    }
    pub fn stability(&self) -> &Stability {
        &self.stability
    }
}
