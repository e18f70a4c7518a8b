//! The CPU executor: runs a frame's pass list (the same `program::cloth_frame` the GPU records)
//! with the kernel crate's own functions, one invocation after another. It is the GPU's twin in
//! tests: same schedule, same math, same f32 arithmetic up to instruction selection (FMA).

use crate::cloth::Cloth;
use crate::error::{Error, Result};
use crate::kernels::KernelId;
use crate::lbvh::{Lbvh, build_cpu, collider_params};
use crate::program::{BufferId, CollisionMode, FrameStep, Pass, cloth_frame};
use crate::sim::{Collider, SimSettings, check_health};
use crate::stability::Stability;
use drape_kernels::collide::{aabbs_overlap, collide_at, collide_brute_force_at, root_aabb, swept_bounds};
use drape_kernels::health::check_health_at;
use drape_kernels::integrate::{StageBuffers, integrate_stage_at};
use drape_kernels::normals::vertex_normal_at;
use drape_types::{ColliderParams, CollisionStatus, Health, SimParams};
use glam::Vec4;
use std::collections::HashMap;

/// An error of the CPU executor (a schedule it cannot run).
fn cpu_error(problem: impl Into<String>) -> Error {
    Error::Kernel { kernel: "cpu".into(), problem: problem.into() }
}

/// A cloth simulation on the CPU with the kernels' own functions.
pub struct CpuSimulation {
    params: SimParams,
    settings: SimSettings,
    stability: Stability,
    steps: Vec<FrameStep>,
    buffers: HashMap<BufferId, Vec<Vec4>>,
    health: Health,
    collider: Option<(ColliderParams, Lbvh)>,
    status: CollisionStatus,
    /// Set by the culling pass: whether this substep's traversal runs.
    traverse: bool,
    frames_done: u64,
}

impl CpuSimulation {
    pub fn new(cloth: &Cloth, settings: SimSettings) -> Result<Self> {
        Self::with_collider(cloth, settings, None)
    }

    /// Like `Simulation::with_collider`, with the LBVH built by the CPU twin.
    pub fn with_collider(cloth: &Cloth, settings: SimSettings, collider: Option<&Collider>) -> Result<Self> {
        let (params, stability) = settings.resolve(cloth)?;
        let mut plan = settings.plan(&params, &stability);
        let mut built = None;
        if let Some(c) = collider {
            let collider_params = collider_params(&c.spheres, c.thickness, c.friction)?;
            built = Some((collider_params, build_cpu(&c.spheres, &collider_params)));
            plan.collision = if c.use_bvh { CollisionMode::Bvh } else { CollisionMode::BruteForce };
        }
        let steps = cloth_frame(plan);
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
            collider: built,
            status: CollisionStatus::default(),
            traverse: false,
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
        check_health(&self.health, self.frames_done, &self.settings, &self.stability)?;
        if self.status.overflows > 0 {
            return Err(Error::TraversalOverflow { frame: self.frames_done, particles: self.status.overflows });
        }
        Ok(())
    }

    /// Collision counters of the last frame.
    pub fn collision_status(&self) -> CollisionStatus {
        self.status
    }

    fn take(&mut self, id: BufferId) -> Result<Vec<Vec4>> {
        self.buffers.remove(&id).ok_or_else(|| cpu_error(format!("buffer {id:?} missing or bound twice")))
    }

    fn run(&mut self, step: &FrameStep) -> Result<()> {
        let pass: &Pass = match step {
            FrameStep::Fill { buffer: BufferId::Health, .. } => {
                self.health = Health::default();
                return Ok(());
            }
            FrameStep::Fill { buffer: BufferId::CollisionStatus, .. } => {
                self.status = CollisionStatus::default();
                return Ok(());
            }
            FrameStep::Fill { buffer, .. } => {
                return Err(cpu_error(format!("cannot fill {buffer:?}")));
            }
            FrameStep::Skip { .. } => return Ok(()),
            FrameStep::Run(pass) => pass,
        };
        // Only the particle buffers (X, V, stages, normals) are taken out and put back; params,
        // health, collider and collision status live in their own fields.
        let ids: Vec<BufferId> = pass.bindings.iter().copied().filter(|id| self.buffers.contains_key(id)).collect();
        let threads = self.params.particle_count;
        let unsupported = || cpu_error(format!("{:?} needs a collider", pass.kernel));
        let mut bound: Vec<Vec<Vec4>> = ids.iter().map(|&id| self.take(id)).collect::<Result<_>>()?;
        let p = self.params;
        match pass.kernel {
            KernelId::IntegrateStage => {
                let stage = pass.push.map(|push| push[0]).unwrap_or(0);
                let [x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev] = &mut bound[..] else {
                    return Err(cpu_error("integrate binds 9 buffers"));
                };
                let mut b = StageBuffers { x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev };
                for i in 0..threads {
                    integrate_stage_at(&p, stage, i, &mut b);
                }
            }
            KernelId::VertexNormals => {
                let [x, normals] = &mut bound[..] else {
                    return Err(cpu_error("normals binds 2 buffers"));
                };
                for i in 0..threads {
                    normals[i as usize] = vertex_normal_at(&p, i, x).extend(0.0);
                }
            }
            KernelId::CheckHealth => {
                let [x, v] = &bound[..] else {
                    return Err(cpu_error("health binds 2 buffers"));
                };
                for i in 0..threads {
                    check_health_at(&p, i, x, v, &mut self.health);
                }
            }
            KernelId::CullCollision => {
                let [x, x_prev] = &bound[..] else {
                    return Err(cpu_error("cull binds 2 particle buffers"));
                };
                let (c, tree) = self.collider.as_ref().ok_or_else(unsupported)?;
                // One "workgroup" of lanes; min/max reduction is order independent.
                let cloth = swept_bounds(x, x_prev, threads, 0, 1);
                let root = root_aabb(c, &tree.aabbs, &tree.spheres);
                self.traverse = aabbs_overlap(&cloth, &root, c.thickness);
                if self.traverse {
                    self.status.ran += 1;
                } else {
                    self.status.skipped += 1;
                }
            }
            KernelId::Collide => {
                let [x, v, x_prev] = &mut bound[..] else {
                    return Err(cpu_error("collide binds 3 particle buffers"));
                };
                let (c, tree) = self.collider.as_ref().ok_or_else(unsupported)?;
                if self.traverse {
                    for i in 0..threads {
                        if collide_at(i, c, &tree.nodes, &tree.aabbs, &tree.spheres, x, v, x_prev) {
                            self.status.overflows += 1;
                        }
                    }
                }
            }
            KernelId::CollideBruteForce => {
                let [x, v, x_prev] = &mut bound[..] else {
                    return Err(cpu_error("collide binds 3 particle buffers"));
                };
                let (c, tree) = self.collider.as_ref().ok_or_else(unsupported)?;
                for i in 0..threads {
                    collide_brute_force_at(i, c, &tree.spheres, x, v, x_prev);
                }
            }
            other => {
                return Err(cpu_error(format!("{other:?} is not part of a cloth frame")));
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
