//! What changes while a solver runs, as values: every cloth's positions, velocities and motion
//! history (its substeps and sleep) and every collider's pose. The live state stays on the GPU (the solver's vertex buffers); a
//! `State` is read with `Solver::state` and restored with `Solver::set_state` (checkpoints,
//! rewinds, a scene reset, the same start on the GPU and the CPU twin).

use crate::controls::Controls;
use crate::error::{Error, Result};
use crate::graph::{BufferId, ReadBuffers};
use crate::model::ColliderId;
use crate::motion::ClothMotion;
use crate::program::SolverProgram;
use drape_types::{Aabb, RigidPose};
use glam::Vec4;

/// One cloth's particles.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ClothState {
    /// xyz position (m), w = pin weight (0 pinned, 1 free).
    pub positions: Vec<Vec4>,
    /// xyz velocity (m/s); w = 1 while the particle's tile sleeps (`drape_kernels::tiles`), else 0.
    pub velocities: Vec<Vec4>,
    /// Its motion history (the substeps contact needs, sleep).
    pub motion: ClothMotion,
    /// Its tiles' sleep (`SimSettings::tile_sleep`; `None` when off).
    pub tiles: Option<TileState>,
}

/// A cloth's tiles (`drape_kernels::tiles`): where its particles were at the last frame's end,
/// and each tile's motion over that frame, box and calm frames. Restored with the rest, so the
/// same tiles sleep in a replay.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct TileState {
    pub(crate) rest: Vec<Vec4>,
    pub(crate) motion: Vec<f32>,
    pub(crate) bounds: Vec<Aabb>,
    pub(crate) calm_frames: Vec<u32>,
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
    /// The state of `program` under `controls`, read from the executor that runs it.
    pub(crate) fn read(program: &SolverProgram, controls: &Controls, executor: &impl ReadBuffers) -> Result<State> {
        let cloths = program
            .cloths
            .iter()
            .zip(&controls.cloths)
            .map(|(b, c)| {
                let n = b.particles as usize;
                let tiles = match &b.tiles {
                    Some(t) => {
                        let count = t.tiles as usize;
                        Some(TileState {
                            rest: executor.read(t.rest, n)?,
                            motion: executor.read(t.motion, count)?,
                            bounds: executor.read(t.bounds, count)?,
                            calm_frames: executor.read(t.frames, count)?,
                        })
                    }
                    None => None,
                };
                Ok(ClothState {
                    positions: executor.read(b.x, n)?,
                    velocities: executor.read(b.v, n)?,
                    motion: c.motion.clone(),
                    tiles,
                })
            })
            .collect::<Result<_>>()?;
        Ok(State { cloths, collider_poses: controls.collider_poses() })
    }

    /// Restores this state into `program`'s buffers with `upload` (bytes at the start of a
    /// buffer, at once) and puts the colliders at their poses without sweeping there (from the
    /// next frame on). A state without the tiles the program has (read with tile sleep off)
    /// wakes them all.
    pub(crate) fn restore(
        &self,
        program: &SolverProgram,
        controls: &mut Controls,
        mut upload: impl FnMut(BufferId, &[u8]) -> Result<()>,
    ) -> Result<()> {
        self.check(program)?;
        for (i, (cloth, b)) in self.cloths.iter().zip(&program.cloths).enumerate() {
            upload(b.x.id(), bytemuck::cast_slice(&cloth.positions))?;
            upload(b.v.id(), bytemuck::cast_slice(&cloth.velocities))?;
            let mut tiles_restored = false;
            if let (Some(t), Some(state)) = (&b.tiles, &cloth.tiles) {
                upload(t.rest.id(), bytemuck::cast_slice(&state.rest))?;
                upload(t.motion.id(), bytemuck::cast_slice(&state.motion))?;
                upload(t.bounds.id(), bytemuck::cast_slice(&state.bounds))?;
                upload(t.frames.id(), bytemuck::cast_slice(&state.calm_frames))?;
                // A settled particle's stage buffers must hold it (`drape_kernels::tiles::SETTLED`);
                // an awake particle's are written before they are read.
                for copy in [b.x_prev, b.xa, b.xb] {
                    upload(copy.id(), bytemuck::cast_slice(&cloth.positions))?;
                }
                let still = vec![Vec4::ZERO; cloth.velocities.len()];
                for copy in [b.va, b.vb] {
                    upload(copy.id(), bytemuck::cast_slice(&still))?;
                }
                tiles_restored = true;
            }
            controls.restore_motion(i, cloth.motion.clone(), tiles_restored);
        }
        for (i, pose) in self.collider_poses.iter().enumerate() {
            controls.place_collider(ColliderId(i), *pose)?;
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
            if let (Some(t), Some(state)) = (&b.tiles, &c.tiles) {
                let tiles = t.tiles as usize;
                let sizes = [state.motion.len(), state.bounds.len(), state.calm_frames.len()];
                if state.rest.len() != n || sizes.iter().any(|&len| len != tiles) {
                    return bad(format!(
                        "cloth {i} has {tiles} tiles of {n} particles; the state's tiles do not fit it (read from \
                         another model?)"
                    ));
                }
            }
        }
        Ok(())
    }
}
