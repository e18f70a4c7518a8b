//! The model / solver / state API: several cloths and colliders in one solver, each cloth with
//! its own substeps; a `State` read back and restored; ids and states that do not fit the model
//! answered with errors.

mod common;

use common::{assert_validation_clean, context};
use drape::{ClothBuilder, ClothId, Collider, ColliderId, CpuSolver, Error, Model, SimSettings, Solver, State};
use glam::{Mat4, Quat, Vec3, Vec4};

/// A ball of radius `r` made of a 5 x 5 x 5 block of small spheres, at `centre`.
fn ball(centre: Vec3, r: f32) -> Vec<Vec4> {
    let mut spheres = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..5 {
                let p = (Vec3::new(i as f32, j as f32, k as f32) / 4.0 * 2.0 - 1.0) * r;
                if p.length() <= r {
                    spheres.push((centre + p).extend(0.3 * r));
                }
            }
        }
    }
    spheres
}

/// Two cloths that differ in everything a cloth can: size, stiffness (so their automatic
/// substeps differ), pins; each falls onto its own ball, and both balls are in every cloth's
/// way of colliding.
fn two_cloths() -> (drape::Cloth, drape::Cloth, Vec<Collider>) {
    let soft = ClothBuilder::new(16, 16)
        .size(0.6)
        .transform(Mat4::from_translation(Vec3::new(-0.6, 0.4, 0.0)))
        .build()
        .unwrap();
    let stiff = ClothBuilder::new(12, 20)
        .size(0.5)
        .stiffness(900.0, 200.0, 10.0)
        .pin(0, 0)
        .transform(Mat4::from_translation(Vec3::new(0.6, 0.45, 0.0)))
        .build()
        .unwrap();
    let colliders = vec![
        Collider::new(ball(Vec3::new(-0.6, 0.0, 0.0), 0.2), 0.01).with_friction(0.3),
        Collider::new(ball(Vec3::new(0.6, 0.0, 0.0), 0.2), 0.01),
    ];
    (soft, stiff, colliders)
}

/// Two cloths in one solver run exactly as each does alone with the same colliders (cloths do
/// not interact yet), each with its own automatic substeps; the GPU equals the CPU twin.
#[test]
fn two_cloths_in_one_solver_each_match_their_own_solver() {
    let ctx = context();
    let (soft, stiff, colliders) = two_cloths();
    let settings = SimSettings::default().with_timestamps(false);
    let mut builder = Model::builder();
    let a = builder.add_cloth(soft.clone());
    let b = builder.add_cloth(stiff.clone());
    for c in &colliders {
        builder.add_collider(c.clone());
    }
    let model = builder.settings(settings).build().unwrap();
    let mut both = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let (substeps_a, substeps_b) = (both.stability(a).unwrap().substeps, both.stability(b).unwrap().substeps);
    assert_ne!(substeps_a, substeps_b, "the test needs cloths with different substep counts");

    let mut alone_a = Solver::new(&ctx, &Model::single(&soft, &colliders, settings).unwrap()).unwrap();
    let mut alone_b = Solver::new(&ctx, &Model::single(&stiff, &colliders, settings).unwrap()).unwrap();
    let only = ClothId::new(0);
    assert_eq!(alone_a.stability(only).unwrap().substeps, substeps_a);
    let mut contacts = 0;
    for frame in 0..40 {
        contacts += both.step_report().unwrap().collision_ran;
        cpu.step().unwrap();
        alone_a.step().unwrap();
        alone_b.step().unwrap();
        let same = |x: Vec<Vec4>, y: Vec<Vec4>| x == y;
        assert!(same(both.positions(a).unwrap(), alone_a.positions(only).unwrap()), "frame {frame}: cloth a differs");
        assert!(same(both.positions(b).unwrap(), alone_b.positions(only).unwrap()), "frame {frame}: cloth b differs");
        assert!(same(both.velocities(b).unwrap(), alone_b.velocities(only).unwrap()), "frame {frame}: cloth b differs");
        for cloth in [a, b] {
            let diff = common::max_distance(&both.positions(cloth).unwrap(), &cpu.positions(cloth).unwrap());
            assert!(diff <= 1e-5, "frame {frame}: GPU and CPU differ by {diff} on {cloth:?}");
        }
    }
    assert!(contacts > 0, "the cloths must reach the balls");
    // Each cloth's vertex buffers are its own.
    let (va, vb) = (both.vertex_buffers(a).unwrap(), both.vertex_buffers(b).unwrap());
    assert_ne!(va.positions, vb.positions);
    assert_eq!((va.vertex_count, vb.vertex_count), (16 * 16, 12 * 20));
    // A per-cloth change touches that cloth only.
    both.set_stiffness(a, 100.0, 20.0, 3.0).unwrap();
    assert_eq!(both.params(a).unwrap().k_struct, 100.0);
    assert_eq!(both.params(b).unwrap().k_struct, 900.0);
    assert_validation_clean(&ctx);
}

/// Where a collider is after `frame` frames of its path.
fn path(frame: u32) -> (Quat, Vec3) {
    let t = frame as f32 / 60.0;
    (Quat::from_rotation_y(0.8 * t), Vec3::new(0.2 * (3.0 * t).sin(), 0.0, 0.0))
}

/// A state read after some frames and restored later replays the same frames bit for bit (the
/// cloths and the moving collider's pose); a GPU state restored into the CPU twin runs on as
/// the GPU does.
#[test]
fn a_restored_state_replays_the_same_frames() {
    let ctx = context();
    let (soft, stiff, colliders) = two_cloths();
    let mut builder = Model::builder();
    let a = builder.add_cloth(soft);
    let b = builder.add_cloth(stiff);
    let moving = builder.add_collider(colliders[0].clone());
    builder.add_collider(colliders[1].clone());
    let model = builder.settings(SimSettings::default().with_timestamps(false)).build().unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let run = |gpu: &mut Solver, frames: std::ops::Range<u32>| {
        for frame in frames {
            let (rotation, translation) = path(frame + 1);
            gpu.set_collider_pose(moving, rotation, translation).unwrap();
            gpu.step().unwrap();
        }
    };
    run(&mut gpu, 0..20);
    let saved: State = gpu.state().unwrap();
    let (rotation, translation) = path(20);
    assert_eq!(saved.collider_poses[moving.index()], drape::rigid_pose(rotation, translation));
    run(&mut gpu, 20..40);
    let first = gpu.state().unwrap();
    assert!(first != saved, "the frames after the checkpoint must change the state");
    gpu.set_state(&saved).unwrap();
    assert!(gpu.state().unwrap() == saved, "set_state did not restore the state");
    run(&mut gpu, 20..40);
    let replay = gpu.state().unwrap();
    assert!(replay.cloths == first.cloths, "the replay differs from the first run");
    assert_eq!(replay.collider_poses, first.collider_poses);

    let mut cpu = CpuSolver::new(&model).unwrap();
    cpu.set_state(&saved).unwrap();
    gpu.set_state(&saved).unwrap();
    for frame in 20..30 {
        let (rotation, translation) = path(frame + 1);
        gpu.set_collider_pose(moving, rotation, translation).unwrap();
        cpu.set_collider_pose(moving, rotation, translation).unwrap();
        gpu.step().unwrap();
        cpu.step().unwrap();
        for cloth in [a, b] {
            let diff = common::max_distance(&gpu.positions(cloth).unwrap(), &cpu.positions(cloth).unwrap());
            assert!(diff <= 1e-5, "frame {frame}: GPU and CPU differ by {diff} on {cloth:?}");
        }
    }
    assert_validation_clean(&ctx);
}

/// Ids a model does not have, states of another shape and empty models are errors that say
/// what is wrong, never panics.
#[test]
fn what_does_not_fit_the_model_is_an_error() {
    let ctx = context();
    let (soft, _, colliders) = two_cloths();
    let model = Model::single(&soft, &colliders[..1], SimSettings::default()).unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let stray = ClothId::new(1);
    let invalid = |r: Result<(), Error>| matches!(r, Err(Error::InvalidParameter { .. }));
    assert!(invalid(gpu.positions(stray).map(drop)));
    assert!(invalid(gpu.pin(stray, 0, None)));
    assert!(invalid(gpu.set_collider_pose(ColliderId::new(1), Quat::IDENTITY, Vec3::ZERO)));
    assert!(invalid(gpu.collider_bvh(ColliderId::new(1)).map(drop)));
    let mut state = gpu.state().unwrap();
    state.cloths[0].positions.pop();
    let error = gpu.set_state(&state).unwrap_err();
    assert!(error.to_string().contains("cloth 0 has 256 particles"), "{error}");
    let mut state = gpu.state().unwrap();
    state.collider_poses.clear();
    assert!(invalid(gpu.set_state(&state)));
    let error = Model::builder().build().unwrap_err();
    assert!(error.to_string().contains("add_cloth"), "{error}");
    assert_validation_clean(&ctx);
}
