//! What changes while a solver runs, as values: every cloth's positions, velocities and motion
//! history (its substeps and sleep) and every collider's pose. The live state stays on the GPU (the solver's vertex buffers); a
//! `State` is read with `Solver::state` and restored with `Solver::set_state` (checkpoints,
//! rewinds, a scene reset, the same start on the GPU and the CPU twin).

use crate::controls::Controls;
use crate::error::{Error, Result};
use crate::graph::Handle;
use crate::model::ColliderId;
use crate::motion::ClothMotion;
use crate::program::SolverProgram;
use drape_types::RigidPose;
use glam::Vec4;

/// One cloth's particles.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ClothState {
    /// xyz position (m), w = pin weight (0 pinned, 1 free).
    pub positions: Vec<Vec4>,
    /// xyz velocity (m/s), w = 0.
    pub velocities: Vec<Vec4>,
    /// Its motion history (the substeps contact needs, sleep).
    pub motion: ClothMotion,
}

/// A solver's state: index `i` of `cloths` is `ClothId` i, of `collider_poses` `ColliderId` i.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct State {
    pub cloths: Vec<ClothState>,
    /// Where each collider's frame is in the world.
    pub collider_poses: Vec<RigidPose>,
}

impl State {
    /// The state of `program` under `controls`, with `read(buffer, count)` reading a buffer of
    /// the executor that runs it.
    pub(crate) fn read(
        program: &SolverProgram,
        controls: &Controls,
        mut read: impl FnMut(Handle<Vec4>, usize) -> Result<Vec<Vec4>>,
    ) -> Result<State> {
        let cloths = program
            .cloths
            .iter()
            .zip(&controls.cloths)
            .map(|(b, c)| {
                let n = b.particles as usize;
                Ok(ClothState { positions: read(b.x, n)?, velocities: read(b.v, n)?, motion: c.motion.clone() })
            })
            .collect::<Result<_>>()?;
        Ok(State { cloths, collider_poses: controls.collider_poses() })
    }

    /// Restores this state into `program`'s buffers with `upload` (at once) and puts the
    /// colliders at their poses without sweeping there (from the next frame on).
    pub(crate) fn restore(
        &self,
        program: &SolverProgram,
        controls: &mut Controls,
        mut upload: impl FnMut(Handle<Vec4>, &[Vec4]) -> Result<()>,
    ) -> Result<()> {
        self.check(program)?;
        for (i, (cloth, b)) in self.cloths.iter().zip(&program.cloths).enumerate() {
            upload(b.x, &cloth.positions)?;
            upload(b.v, &cloth.velocities)?;
            controls.restore_motion(i, cloth.motion.clone());
        }
        for (i, pose) in self.collider_poses.iter().enumerate() {
            controls.teleport_collider(ColliderId(i), *pose)?;
        }
        Ok(())
    }

    /// Whether the state fits `program` (same cloths, particle counts and colliders) and holds
    /// finite values.
    pub(crate) fn check(&self, program: &SolverProgram) -> Result<()> {
        let bad = |problem: String| Err(Error::InvalidParameter { name: "state", problem });
        if self.cloths.len() != program.cloths.len() || self.collider_poses.len() != program.colliders.len() {
            return bad(format!(
                "it holds {} cloths and {} colliders, the model {} and {}",
                self.cloths.len(),
                self.collider_poses.len(),
                program.cloths.len(),
                program.colliders.len()
            ));
        }
        for (i, (c, b)) in self.cloths.iter().zip(&program.cloths).enumerate() {
            let n = b.particles as usize;
            if c.positions.len() != n || c.velocities.len() != n {
                return bad(format!(
                    "cloth {i} has {n} particles, the state {} positions and {} velocities",
                    c.positions.len(),
                    c.velocities.len()
                ));
            }
            if !c.positions.iter().chain(&c.velocities).all(|v| v.is_finite()) {
                return bad(format!("cloth {i}: positions and velocities must be finite"));
            }
        }
        Ok(())
    }
}
