//! What the host changes between frames: parameters (gravity, wind, stiffness, damping, `dt`),
//! collider poses, deformed collider leaves, pins. Setters check the value and only note it;
//! the next frame starts with the writes that bring the GPU (or CPU) buffers up to date, so a
//! change re-records nothing, allocates nothing on the GPU, and never waits on the queue. Both
//! the GPU `Simulation` and the `CpuSimulation` drive their frames through this.

use crate::error::{Error, Result};
use crate::graph::Step;
use crate::program::ClothProgram;
use crate::programs::cloth::{FramePlan, frame_steps};
use crate::sim::SimSettings;
use crate::stability::Stability;
use drape_types::{ColliderParams, ColliderPose, RigidPose, SimParams};
use glam::{Quat, Vec3, Vec4};

/// A particle's pin change, applied at the start of the next frame.
#[derive(Copy, Clone, Debug, PartialEq)]
enum PinChange {
    /// Pin where it is.
    Here,
    /// Pin at this position (moves it there: an animated pin when set every frame).
    At(Vec3),
    Unpin,
}

/// One collider's host-side values.
struct ColliderControl {
    params: ColliderParams,
    params_dirty: bool,
    /// The pose the last frame ended at, and the one the next frame ends at.
    end_of_last_frame: RigidPose,
    target: RigidPose,
    /// What the GPU's pose buffer holds.
    written: ColliderPose,
    /// New leaves (collider frame) for the next frame: written, then the LBVH is refit.
    deformed: Option<Vec<Vec4>>,
}

/// Host-side values of a simulation and the writes that publish them.
pub(crate) struct Controls {
    pub params: SimParams,
    pub settings: SimSettings,
    pub stability: Stability,
    params_dirty: bool,
    colliders: Vec<ColliderControl>,
    pins: Vec<(u32, PinChange)>,
}

fn invalid(name: &'static str, problem: String) -> Error {
    Error::InvalidParameter { name, problem }
}

fn finite_vec(name: &'static str, v: Vec3) -> Result<()> {
    if v.is_finite() { Ok(()) } else { Err(invalid(name, format!("must be finite, got {v}"))) }
}

fn non_negative(name: &'static str, values: &[f32]) -> Result<()> {
    match values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        Some(v) => Err(invalid(name, format!("must be finite and >= 0, got {v}"))),
        None => Ok(()),
    }
}

impl Controls {
    pub fn new(
        params: SimParams,
        settings: SimSettings,
        stability: Stability,
        colliders: &[(ColliderParams, RigidPose)],
    ) -> Self {
        let colliders = colliders
            .iter()
            .map(|&(params, pose)| ColliderControl {
                params,
                params_dirty: false,
                end_of_last_frame: pose,
                target: pose,
                written: ColliderPose { previous: pose, current: pose },
                deformed: None,
            })
            .collect();
        Controls { params, settings, stability, params_dirty: false, colliders, pins: Vec::new() }
    }

    /// The frame schedule for the current values.
    pub fn plan(&self) -> FramePlan {
        self.settings.plan(&self.params, &self.stability)
    }

    pub fn set_gravity(&mut self, gravity: Vec3) -> Result<()> {
        finite_vec("gravity", gravity)?;
        self.params.gravity = gravity.extend(0.0);
        self.params_dirty = true;
        Ok(())
    }

    pub fn set_external_force(&mut self, force: Vec3) -> Result<()> {
        finite_vec("external_force", force)?;
        self.params.external_force = force.extend(0.0);
        self.params_dirty = true;
        Ok(())
    }

    /// New spring stiffnesses; returns whether the substep count changed.
    pub fn set_stiffness(&mut self, k_struct: f32, k_shear: f32, k_bend: f32) -> Result<bool> {
        non_negative("stiffness", &[k_struct, k_shear, k_bend])?;
        let mut params = self.params;
        (params.k_struct, params.k_shear, params.k_bend) = (k_struct, k_shear, k_bend);
        self.restabilise(params, self.settings)
    }

    /// New spring-axis and velocity damping; returns whether the substep count changed.
    pub fn set_damping(&mut self, spring: f32, velocity: f32) -> Result<bool> {
        non_negative("damping", &[spring, velocity])?;
        let mut params = self.params;
        (params.spring_damping, params.velocity_damping) = (spring, velocity);
        self.restabilise(params, self.settings)
    }

    /// New simulated time per frame; returns whether the substep count changed.
    pub fn set_frame_dt(&mut self, frame_dt: f32) -> Result<bool> {
        let settings = SimSettings { frame_dt, ..self.settings };
        self.restabilise(self.params, settings)
    }

    /// Chooses the substep for `params` under `settings` (automatic substeps follow the
    /// stability bound) and adopts both if valid.
    fn restabilise(&mut self, params: SimParams, settings: SimSettings) -> Result<bool> {
        let (resolved, stability) = settings.resolve_params(&params)?;
        if let Some(warning) = stability.warning() {
            log::warn!("{warning}");
        }
        let changed = stability.substeps != self.stability.substeps;
        self.params = resolved;
        self.settings = settings;
        self.stability = stability;
        self.params_dirty = true;
        Ok(changed)
    }

    fn collider(&mut self, index: usize) -> Result<&mut ColliderControl> {
        let count = self.colliders.len();
        self.colliders.get_mut(index).ok_or_else(|| {
            invalid(
                "collider",
                format!("index {index}, but this simulation has {count} colliders; add them with `with_colliders`"),
            )
        })
    }

    pub fn set_contact(&mut self, index: usize, thickness: f32, friction: f32) -> Result<()> {
        let checked = crate::lbvh::collider_params(&[Vec4::ZERO], thickness, friction)?;
        let c = self.collider(index)?;
        c.params.thickness = checked.thickness;
        c.params.friction = checked.friction;
        c.params_dirty = true;
        Ok(())
    }

    /// Where collider `index` is at the end of the next frame (it moves there from where the
    /// last frame left it over the frame's substeps).
    pub fn set_collider_pose(&mut self, index: usize, pose: RigidPose) -> Result<()> {
        let rotation = Quat::from_vec4(pose.rotation);
        if !(rotation.is_finite() && pose.translation.is_finite() && (rotation.length() - 1.0).abs() < 1e-3) {
            return Err(invalid(
                "collider pose",
                format!("rotation must be a unit quaternion and translation finite, got {pose:?}"),
            ));
        }
        let c = self.collider(index)?;
        // The shorter way round: interpolation between q and -q would pass through zero.
        let previous = c.end_of_last_frame.rotation;
        let q = if previous.dot(pose.rotation) < 0.0 { -pose.rotation } else { pose.rotation };
        c.target = RigidPose { rotation: q.normalize(), translation: pose.translation.truncate().extend(0.0) };
        Ok(())
    }

    /// New leaves of collider `index` in its own frame (a deforming collider): same count.
    pub fn set_collider_spheres(&mut self, index: usize, leaves: u32, spheres: &[Vec4]) -> Result<()> {
        if spheres.len() != leaves as usize {
            return Err(invalid("collider spheres", format!("expected {leaves} spheres, got {}", spheres.len())));
        }
        if let Some(s) = spheres.iter().find(|s| !s.is_finite() || s.w < 0.0) {
            return Err(invalid("collider spheres", format!("centres must be finite and radii >= 0, got {s}")));
        }
        self.collider(index)?.deformed = Some(spheres.to_vec());
        Ok(())
    }

    pub fn pin(&mut self, particle: u32, at: Option<Vec3>) -> Result<()> {
        self.check_particle(particle)?;
        if let Some(p) = at {
            finite_vec("pin position", p)?;
        }
        self.pins.push((particle, at.map_or(PinChange::Here, PinChange::At)));
        Ok(())
    }

    pub fn unpin(&mut self, particle: u32) -> Result<()> {
        self.check_particle(particle)?;
        self.pins.push((particle, PinChange::Unpin));
        Ok(())
    }

    fn check_particle(&self, particle: u32) -> Result<()> {
        let n = self.params.particle_count;
        if particle >= n {
            return Err(invalid("particle", format!("index {particle}, but the cloth has {n} particles")));
        }
        Ok(())
    }

    /// The frame's steps when the substep count changed.
    pub fn frame_steps(&self, program: &ClothProgram) -> Vec<Step> {
        frame_steps(self.plan(), &program.cloth, &program.colliders)
    }

    /// The writes (and refits) the next frame starts with; empty when nothing changed. Marks
    /// everything published.
    pub fn begin_frame(&mut self, program: &ClothProgram) -> Vec<Step> {
        let mut steps = Vec::new();
        if std::mem::take(&mut self.params_dirty) {
            steps.push(Step::write(program.cloth.params, 0, &[self.params]));
        }
        for (c, buffers) in self.colliders.iter_mut().zip(&program.colliders) {
            if std::mem::take(&mut c.params_dirty) {
                steps.push(Step::write(buffers.lbvh.tree.collider, 0, &[c.params]));
            }
            let pose = ColliderPose { previous: c.end_of_last_frame, current: c.target };
            if pose != c.written {
                steps.push(Step::write(buffers.pose, 0, &[pose]));
                c.written = pose;
            }
            c.end_of_last_frame = c.target;
            if let Some(spheres) = c.deformed.take() {
                steps.push(Step::write(buffers.lbvh.spheres, 0, &spheres));
                steps.extend(buffers.lbvh.refit_steps());
            }
        }
        let x = program.cloth.x;
        // The last change of each particle wins; one write range per particle.
        let latest: std::collections::BTreeMap<u32, PinChange> = self.pins.drain(..).collect();
        for (particle, change) in latest {
            // w is the pin weight: 0 pinned, 1 free. A pinned particle's velocity is zero.
            let w_offset = (particle as usize * size_of::<Vec4>() + 3 * size_of::<f32>()) as u64;
            match change {
                PinChange::Here => {
                    steps.push(Step::Write { buffer: x.id(), offset: w_offset, bytes: 0f32.to_le_bytes().to_vec() });
                    steps.push(Step::write(program.cloth.v, particle, &[Vec4::ZERO]));
                }
                PinChange::At(p) => {
                    steps.push(Step::write(x, particle, &[p.extend(0.0)]));
                    steps.push(Step::write(program.cloth.v, particle, &[Vec4::ZERO]));
                }
                PinChange::Unpin => {
                    steps.push(Step::Write { buffer: x.id(), offset: w_offset, bytes: 1f32.to_le_bytes().to_vec() })
                }
            }
        }
        steps
    }
}

/// The runtime setters of a simulation type with `controls: Controls`, `program: ClothProgram`
/// and `fn replan(&mut self, substeps_changed: bool) -> Result<()>`: one definition for the GPU
/// simulation and its CPU twin. Each takes effect at the start of the next frame.
macro_rules! runtime_setters {
    ($sim:ty) => {
        impl $sim {
            /// Sets gravity (m/s^2).
            pub fn set_gravity(&mut self, gravity: glam::Vec3) -> $crate::Result<()> {
                self.controls.set_gravity(gravity)
            }

            /// Sets the constant external force on every free particle (N), e.g. wind.
            pub fn set_external_force(&mut self, force: glam::Vec3) -> $crate::Result<()> {
                self.controls.set_external_force(force)
            }

            /// Sets the spring stiffnesses (N/m); automatic substeps follow the stability bound.
            pub fn set_stiffness(&mut self, k_struct: f32, k_shear: f32, k_bend: f32) -> $crate::Result<()> {
                let changed = self.controls.set_stiffness(k_struct, k_shear, k_bend)?;
                self.replan(changed)
            }

            /// Sets the spring-axis damping and the velocity damping (N s/m); automatic
            /// substeps follow the stability bound.
            pub fn set_damping(&mut self, spring: f32, velocity: f32) -> $crate::Result<()> {
                let changed = self.controls.set_damping(spring, velocity)?;
                self.replan(changed)
            }

            /// Sets the simulated time of each following frame (s); automatic substeps are
            /// chosen again from the stability bound (fixed ones keep their count).
            pub fn set_frame_dt(&mut self, frame_dt: f32) -> $crate::Result<()> {
                let changed = self.controls.set_frame_dt(frame_dt)?;
                self.replan(changed)
            }

            /// Sets collider `index`'s contact thickness (m) and Coulomb friction coefficient.
            pub fn set_contact(&mut self, index: usize, thickness: f32, friction: f32) -> $crate::Result<()> {
                self.controls.set_contact(index, thickness, friction)
            }

            /// Moves collider `index`: the next frame ends with it at `rotation`, `translation`
            /// (its frame in the world). Over the frame it moves there from where the last frame
            /// left it, substep by substep, so it sweeps the cloth instead of jumping through it.
            /// A collider not moved in a frame stays where it is.
            pub fn set_collider_pose(
                &mut self,
                index: usize,
                rotation: glam::Quat,
                translation: glam::Vec3,
            ) -> $crate::Result<()> {
                self.controls.set_collider_pose(index, $crate::sim::rigid_pose(rotation, translation))
            }

            /// Deforms collider `index`: new spheres in its own frame, as many as it was built
            /// with. The next frame writes them and refits the LBVH on the GPU (same tree).
            pub fn set_collider_spheres(&mut self, index: usize, spheres: &[glam::Vec4]) -> $crate::Result<()> {
                let leaves = self.program.colliders.get(index).map_or(0, |c| c.lbvh.leaves());
                self.controls.set_collider_spheres(index, leaves, spheres)
            }

            /// Pins particle `particle` where it is (`None`) or at `position` (moving it there:
            /// call every frame for an animated pin).
            pub fn pin(&mut self, particle: u32, position: Option<glam::Vec3>) -> $crate::Result<()> {
                self.controls.pin(particle, position)
            }

            /// Frees particle `particle`.
            pub fn unpin(&mut self, particle: u32) -> $crate::Result<()> {
                self.controls.unpin(particle)
            }
        }
    };
}
pub(crate) use runtime_setters;
