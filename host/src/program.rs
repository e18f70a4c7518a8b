//! A solver's work as data: the buffers of its cloths, its colliders and each cloth-collider
//! contact, the initial contents of each, the LBVH builds and the frame's steps. The GPU
//! `Solver` and the `CpuSolver` both run exactly this.

use crate::cloth::ClothTopology;
use crate::controls::{ColliderStart, Controls};
use crate::error::Result;
use crate::graph::{BufferId, Resources, Step};
use crate::model::{ColliderShape, ContactSearch, Model};
use crate::programs::cloth::{ClothBuffers, FramePlan, frame_steps};
use crate::programs::contact::{ColliderBuffers, ColliderLeaves, ContactBuffers, ContactMode, Crowded};
use crate::programs::self_contact::SelfContactBuffers;
use crate::programs::spheres::SphereBvh;
use crate::programs::tiles::TileBuffers;
use crate::programs::triangles::TriangleBvh;
use drape_kernels::self_contact::PUSH_WORDS;
use drape_types::{ColliderParams, ColliderPose, RigidPose};

pub(crate) struct SolverProgram {
    pub resources: Resources,
    pub cloths: Vec<ClothBuffers>,
    pub colliders: Vec<ColliderBuffers>,
    /// `contacts[cloth][collider]`: the buffers of that pair's contact.
    pub contacts: Vec<Vec<ContactBuffers>>,
    /// Buffer contents to upload before anything runs.
    pub initial: Vec<(BufferId, Vec<u8>)>,
    pub frame: Vec<Step>,
}

/// What a collider of `shape` starts with (see `ColliderStart`).
fn collider_start(params: ColliderParams, pose: RigidPose, shape: &ColliderShape) -> ColliderStart {
    let (deformable, contents, swept_contact) = match shape {
        ColliderShape::Spheres(s) => ("spheres", s.clone(), false),
        ColliderShape::Triangles { vertices, .. } => {
            ("vertices", vertices.iter().map(|v| v.extend(0.0)).collect(), true)
        }
    };
    ColliderStart { params, pose, deformable, contents, swept_contact }
}

/// Debug-name prefix of item `index` of a kind (the first keeps the plain name).
fn numbered(kind: &str, index: usize) -> String {
    if index == 0 { kind.to_string() } else { format!("{kind} {index}") }
}

impl SolverProgram {
    /// The program of `model`, and the host-side controls holding its starting values (what
    /// both solvers start from).
    pub fn with_controls(model: &Model) -> Result<(Self, Controls)> {
        Self::with_controls_on(model, false, u32::MAX)
    }

    /// `with_controls` for a device that `is_gpu` (or a CPU driver): the settings' automatic
    /// choices that depend on the device made for it (`SimSettings::on_device`).
    pub fn with_controls_on(model: &Model, is_gpu: bool, max_workgroup: u32) -> Result<(Self, Controls)> {
        let settings = model.settings().on_device(is_gpu, max_workgroup);
        settings.check_device()?;
        let mut resolved = Vec::new();
        for (cloth, bound) in model.cloths().iter().zip(model.bounds()) {
            let (params, stability) = settings.resolve_params(&cloth.params, bound)?;
            let self_collision = cloth.self_collision.map(|thickness| (thickness, cloth.self_friction));
            let height = crate::programs::self_contact::shortest_height(&cloth.positions, &cloth.triangles);
            let triangles = cloth.triangles.len() as u32;
            resolved.push((params, stability, bound.clone(), self_collision, (height, triangles)));
        }
        let mut resources = Resources::new();
        let bytes = |data: &[glam::Vec4]| bytemuck::cast_slice::<_, u8>(data).to_vec();
        let mut initial = Vec::new();
        let mut cloths = Vec::new();
        for (i, (cloth, (params, _, _, _, _))) in model.cloths().iter().zip(&resolved).enumerate() {
            let triangles = &cloth.triangles;
            let mut b = ClothBuffers::declare(&mut resources, &numbered("cloth", i), cloth);
            if let Some(sleep) = settings.tile_policy() {
                let policy = (sleep, settings.frame_dt);
                b.tiles =
                    Some(TileBuffers::declare(&mut resources, &numbered("cloth", i), cloth, policy, &mut initial));
            }
            if let (Some(list), ClothTopology::Springs(topology)) = (&b.springs, &cloth.topology) {
                initial.push((list.particles.id(), bytemuck::cast_slice::<_, u8>(&topology.particles).to_vec()));
                initial.push((list.springs.id(), bytemuck::cast_slice::<_, u8>(&topology.springs).to_vec()));
                let offsets = bytemuck::cast_slice::<_, u8>(&topology.vertex_triangle_offsets).to_vec();
                initial.push((list.vertex_triangle_offsets.id(), offsets));
                initial.push((
                    list.vertex_triangles.id(),
                    bytemuck::cast_slice::<_, u8>(&topology.vertex_triangles).to_vec(),
                ));
            }
            initial.push((b.params.id(), bytemuck::bytes_of(params).to_vec()));
            // Stage buffers start as copies of the state so pinned particles read sane values.
            for h in [b.x, b.xa, b.xb, b.x_prev] {
                initial.push((h.id(), bytes(&cloth.positions)));
            }
            initial.push((b.v.id(), bytes(&cloth.velocities)));
            initial.push((b.indices.id(), bytemuck::cast_slice::<_, u8>(triangles).to_vec()));
            if let (Some(s), Some(thickness)) = (&b.self_contact, cloth.self_collision) {
                let params = SelfContactBuffers::params(triangles.len() as u32, thickness, cloth.self_friction);
                initial.push((s.tree.collider.id(), bytemuck::bytes_of(&params).to_vec()));
                let owned = crate::programs::self_contact::owned_primitives(triangles);
                initial.push((s.owned.id(), bytemuck::cast_slice::<_, u8>(&owned).to_vec()));
                initial.push((s.rest_shape.id(), bytes(&cloth.positions)));
                initial.push((s.pushes.id(), vec![0; 4 * (PUSH_WORDS as usize) * cloth.positions.len()]));
            }
            cloths.push(b);
        }
        let mut colliders = Vec::new();
        let mut starts = Vec::new();
        let curl_radius = crate::collider_curl::curl_radius(model.cloths());
        for (i, c) in model.colliders().iter().enumerate() {
            let mut params = c.params()?;
            let name = numbered("collider", i);
            let leaves = match &c.shape {
                ColliderShape::Spheres(spheres) => {
                    let b = SphereBvh::declare(&mut resources, &name, params.leaf_count);
                    initial.push((b.spheres.id(), bytes(spheres)));
                    initial.push((b.previous.id(), bytes(spheres)));
                    ColliderLeaves::Spheres(b)
                }
                ColliderShape::Triangles { vertices, triangles } => {
                    let b = TriangleBvh::declare(&mut resources, &name, vertices.len() as u32, params.leaf_count);
                    let corners: Vec<glam::Vec4> = vertices.iter().map(|v| v.extend(0.0)).collect();
                    initial.push((b.vertices.id(), bytes(&corners)));
                    initial.push((b.previous.id(), bytes(&corners)));
                    initial.push((b.indices.id(), bytemuck::cast_slice::<_, u8>(triangles).to_vec()));
                    ColliderLeaves::Triangles(b)
                }
            };
            let mut b = ColliderBuffers::declare(&mut resources, &name, leaves);
            if let ColliderShape::Triangles { vertices, triangles } = &c.shape {
                let mut features = crate::programs::self_contact::collider_features(triangles);
                if let Some(radius) = curl_radius {
                    let started = std::time::Instant::now();
                    let curled = crate::collider_curl::mark_curled(&mut features, vertices, triangles, radius);
                    let ridges = crate::collider_crease::mark_ridges(
                        &mut features,
                        vertices,
                        triangles,
                        radius,
                        params.thickness,
                    );
                    let reach = crate::collider_cover::COVER_SHARE * params.thickness;
                    let (covered, tested) =
                        crate::collider_cover::cover_curled_features(&mut features, vertices, triangles, reach);
                    if covered > 0 {
                        params.cover_reach = reach;
                    }
                    log::debug!(
                        "{name}: {curled} of {} triangles wrap round within {radius} m, {ridges} lie on ridges at \
                         that scale (their features always tested, but for {covered} of {tested} within {reach} m \
                         of another; measured in {:.0} ms)",
                        triangles.len(),
                        started.elapsed().as_secs_f64() * 1e3
                    );
                }
                let handle = resources.device(format!("{name}: features"), features.len() as u32);
                initial.push((handle.id(), bytemuck::cast_slice::<_, u8>(&features).to_vec()));
                b.features = Some((handle, features.len() as u32));
            }
            initial.push((b.tree().collider.id(), bytemuck::bytes_of(&params).to_vec()));
            let pose = ColliderPose { previous: c.pose, current: c.pose, sweep: glam::Vec4::ZERO };
            initial.push((b.pose.id(), bytemuck::bytes_of(&pose).to_vec()));
            colliders.push(b);
            starts.push(collider_start(params, c.pose, &c.shape));
        }
        for (i, cloth) in cloths.iter_mut().enumerate() {
            if let Some(s) = &mut cloth.self_contact {
                s.declare_sharp_features(&mut resources, &numbered("cloth", i), &colliders);
                // No fold measured yet (w 0): the first frame measures them all.
                for sharp in s.sharp.iter().flatten() {
                    initial.push((sharp.folds.id(), vec![0u8; sharp.folds.len() as usize * size_of::<glam::Vec4>()]));
                }
            }
        }
        let contacts = cloths
            .iter()
            .enumerate()
            .map(|(i, cloth)| {
                model
                    .colliders()
                    .iter()
                    .enumerate()
                    .map(|(j, c)| {
                        // "collider contact" for the first cloth; "cloth 1 / collider 2 contact".
                        let name = match i {
                            0 => format!("{} contact", numbered("collider", j)),
                            _ => format!("{} / {} contact", numbered("cloth", i), numbered("collider", j)),
                        };
                        let mode = match c.search {
                            ContactSearch::CandidateLists => ContactMode::Lists,
                            ContactSearch::TraverseEverySubstep => ContactMode::Bvh,
                            ContactSearch::BruteForce => ContactMode::BruteForce,
                        };
                        ContactBuffers::declare(&mut resources, &name, cloth.particles, mode)
                    })
                    .collect()
            })
            .collect();
        let mut program = SolverProgram { resources, cloths, colliders, contacts, initial, frame: Vec::new() };
        let mut controls = Controls::new(resolved, settings, starts);
        for (i, cloth) in model.cloths().iter().enumerate() {
            controls.set_moving(crate::ClothId::new(i), &cloth.velocities)?;
        }
        program.frame = program.frame_steps(&controls.plans());
        Ok((program, controls))
    }

    /// One frame: every cloth's frame (each with its own substeps), in order.
    pub fn frame_steps(&self, plans: &[FramePlan]) -> Vec<Step> {
        let mut steps = Vec::new();
        for ((cloth, contacts), plan) in self.cloths.iter().zip(&self.contacts).zip(plans) {
            let pairs: Vec<_> = self.colliders.iter().zip(contacts).collect();
            steps.extend(frame_steps(*plan, cloth, &pairs));
        }
        steps
    }

    /// The frame under `plans` with every cloth whose crowded particles are only counted
    /// (`Crowded::Counted`: the automatic choice) handing them over instead: the passes a later
    /// plan may add.
    pub fn crowded_steps(&self, plans: &[FramePlan]) -> Vec<Step> {
        let handed: Vec<FramePlan> = plans
            .iter()
            .map(|p| match p.crowded {
                Crowded::Counted => FramePlan { crowded: Crowded::HandedOver, asleep: false, ..*p },
                _ => *p,
            })
            .collect();
        if handed == plans { Vec::new() } else { self.frame_steps(&handed) }
    }

    /// Every collider's LBVH build, in one list.
    pub fn build_steps(&self) -> Vec<Step> {
        self.colliders.iter().flat_map(|c| c.leaves.kind().build_steps()).collect()
    }

    /// Every collider's refit (what a frame that deforms colliders may add).
    pub fn refit_steps(&self) -> Vec<Step> {
        self.colliders.iter().flat_map(|c| c.leaves.kind().refit_steps()).collect()
    }

    /// Each self-colliding cloth's lists built again within a frame (what a frame whose lists
    /// have windows adds: `FramePlan::self_windows`), its fail-safe's first refit either way (a
    /// windowed frame climbs, one whose lists span it derives), a pass's second run with lists
    /// (a thickness changed at run time may turn them on), and its passes' collider
    /// features with and without the listed triangles out of the cloth's reach
    /// (`reach_filter_pays`: a frame's passes and windows choose).
    pub fn self_window_steps(&self) -> Vec<Step> {
        let mut steps = Vec::new();
        for cloth in &self.cloths {
            if let Some(s) = &cloth.self_contact {
                let own = cloth.self_contact_cloth();
                s.window_start_steps(&own, (1, 1), &mut steps);
                steps.extend(s.failsafe.first_refit_steps_either_way(s));
                steps.extend(s.pushed_run_steps(&own));
                for (index, collider) in self.colliders.iter().enumerate() {
                    steps.extend(s.out_of_reach_steps((collider, index), cloth.health));
                    for reach in [false, true] {
                        steps.extend(s.collider_feature_steps(&own, (collider, index), ((0, 0, 1), reach)));
                    }
                }
            }
        }
        steps
    }

    /// The buffers a frame's status is read from, in its layout: each cloth's health.
    pub fn status_buffers(&self) -> Vec<BufferId> {
        self.cloths.iter().map(|cloth| cloth.health.id()).collect()
    }
}
