//! The CPU twin of `Solver`: the same program (buffers, LBVH build, frame steps) and the same
//! runtime controls, run by the CPU executor with the kernels' own functions.

use crate::controls::Controls;
use crate::cpu::CpuExecutor;
use crate::error::Result;
use crate::graph::Handle;
use crate::model::{ClothId, Model};
use crate::program::SolverProgram;
use crate::programs::cloth::ClothBuffers;
use crate::solver::teleported;
use crate::state::State;
use drape_types::{CollisionStatus, Health};
use glam::Vec4;

/// Advances a model's state on the CPU with the kernels' own functions.
pub struct CpuSolver {
    executor: CpuExecutor,
    program: SolverProgram,
    controls: Controls,
    frames_done: u64,
}

impl CpuSolver {
    /// Like `Solver::new`, with the LBVHs built by the CPU executor.
    pub fn new(model: &Model) -> Result<Self> {
        let (program, controls) = SolverProgram::with_controls(model)?;
        let mut executor = CpuExecutor::new(&program.resources);
        for (id, data) in &program.initial {
            executor.upload_bytes(*id, data)?;
        }
        executor.run(&program.build_steps())?;
        Ok(CpuSolver { executor, program, controls, frames_done: 0 })
    }

    /// Runs one frame; `Error::Unstable` on blow-up, like the GPU.
    pub fn step(&mut self) -> Result<()> {
        let leading = self.controls.begin_frame(&self.program);
        let replan = self.controls.take_replan();
        self.replan(replan)?;
        for i in self.controls.asleep_unplaced() {
            let b = &self.program.cloths[i];
            let x = self.executor.read(b.x, b.particles as usize)?;
            self.controls.rest_at(i, &x);
        }
        self.executor.run(&leading)?;
        self.executor.run(&self.program.frame)?;
        self.frames_done += 1;
        for (i, cloth) in self.program.cloths.iter().enumerate() {
            if self.controls.cloths[i].motion.asleep {
                continue;
            }
            let health: Health = self.executor.read(cloth.health, 1)?[0];
            self.controls.check_health(&health, self.frames_done, i)?;
            self.controls.observe(i, &health, self.frames_done);
        }
        Ok(())
    }

    fn replan(&mut self, substeps_changed: bool) -> Result<()> {
        if substeps_changed {
            self.program.frame = self.controls.frame_steps(&self.program);
        }
        Ok(())
    }

    /// Collision counters of the last frame (all cloths and colliders together).
    pub fn collision_status(&self) -> CollisionStatus {
        let mut total = CollisionStatus::default();
        for contact in self.program.contacts.iter().flatten() {
            if let Ok(s) = self.executor.read(contact.status, 1) {
                total.ran += s[0].ran;
                total.skipped += s[0].skipped;
                total.fallbacks += s[0].fallbacks;
                total.listed += s[0].listed;
                total.crowded += s[0].crowded;
            }
        }
        total
    }

    /// Teleports `cloth` (see `Solver::teleport`).
    pub fn teleport(&mut self, cloth: ClothId, positions: &[glam::Vec3], velocities: &[glam::Vec3]) -> Result<()> {
        let (x, v) = teleported(&self.positions(cloth)?, positions, velocities)?;
        self.controls.set_moving(cloth, &v)?;
        let b = &self.program.cloths[cloth.index()];
        self.executor.upload(b.x, &x)?;
        self.executor.upload(b.v, &v)
    }

    /// What changes (see `Solver::state`).
    pub fn state(&self) -> Result<State> {
        State::read(&self.program, &self.controls, &self.executor)
    }

    /// Restores a state (see `Solver::set_state`).
    pub fn set_state(&mut self, state: &State) -> Result<()> {
        let executor = &mut self.executor;
        state.restore(&self.program, &mut self.controls, |buffer, data| executor.upload_bytes(buffer, data))
    }

    fn vec4s(&self, cloth: ClothId, pick: fn(&ClothBuffers) -> Handle<Vec4>) -> Result<Vec<Vec4>> {
        self.controls.cloth(cloth)?;
        let b = &self.program.cloths[cloth.index()];
        self.executor.read(pick(b), b.particles as usize)
    }
    pub fn positions(&self, cloth: ClothId) -> Result<Vec<Vec4>> {
        self.vec4s(cloth, |b| b.x)
    }
    pub fn velocities(&self, cloth: ClothId) -> Result<Vec<Vec4>> {
        self.vec4s(cloth, |b| b.v)
    }
    pub fn normals(&self, cloth: ClothId) -> Result<Vec<Vec4>> {
        self.vec4s(cloth, |b| b.normals)
    }
}

crate::controls::runtime_setters!(CpuSolver);
