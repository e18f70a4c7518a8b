//! What a cloth's motion decides (`drape::motion`): a still cloth sleeps and cannot drift until
//! something wakes it; fast motion near contact without CCD raises the substeps.

mod common;

use common::{assert_validation_clean, context};
use drape::{ClothBuilder, ClothId, Collider, ColliderId, CpuSolver, Mesh, Model, SimSettings, Sleep, Solver};
use glam::{Quat, Vec3};

const CLOTH: ClothId = ClothId::new(0);
const GROUND: ColliderId = ColliderId::new(0);

/// A 16 x 16, 0.5 m cloth lying 2 cm over a ground square (two triangles) with friction.
fn cloth_over_ground() -> (drape::Cloth, Collider) {
    let cloth = ClothBuilder::new(16, 16)
        .size(0.5)
        .transform(glam::Mat4::from_translation(Vec3::new(0.0, 0.02, 0.0)))
        .build()
        .unwrap();
    let h = 1.0;
    let ground = Mesh {
        vertices: vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)],
        triangles: vec![[0, 2, 1], [0, 3, 2]],
    };
    (cloth, Collider::mesh(&ground, 0.005).with_friction(0.8))
}

fn settings() -> SimSettings {
    SimSettings::default().with_timestamps(false).with_sleep(Some(Sleep { speed: 0.05, frames: 20 }))
}

/// Steps until the cloth sleeps (at most `limit` frames); returns the frame it first slept in.
fn until_asleep(sim: &mut Solver, limit: u32) -> u32 {
    for frame in 1..=limit {
        let report = sim.step_report().unwrap();
        if report.cloths_asleep == 1 {
            assert!(sim.asleep(CLOTH).unwrap());
            return frame;
        }
    }
    panic!("the cloth did not fall asleep in {limit} frames");
}

/// The cloth lands, settles and sleeps; asleep, its frames run no pass (the timings list the
/// sleeping cloth as skipped) and its positions stay bit for bit; a collider that moves wakes
/// it and it moves again.
#[test]
fn a_settled_cloth_sleeps_without_drifting_until_a_collider_moves() {
    let ctx = context();
    let (cloth, ground) = cloth_over_ground();
    let model = Model::single(&cloth, std::slice::from_ref(&ground), settings()).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    let first = until_asleep(&mut sim, 300);
    println!("asleep at frame {first}");
    assert!(first > 20, "it cannot sleep before it landed and stayed still for 20 frames");
    let resting = sim.positions(CLOTH).unwrap();
    for _ in 0..60 {
        let report = sim.step_report().unwrap();
        assert_eq!(report.cloths_asleep, 1);
        assert!(report.timings.passes.is_empty(), "a sleeping cloth runs nothing: {:?}", report.timings.passes);
        assert!(!report.timings.skipped.is_empty(), "the sleeping cloth is listed as skipped");
    }
    assert_eq!(sim.positions(CLOTH).unwrap(), resting, "a sleeping cloth must not drift");
    // The ground rises 1 cm over the next frame: the cloth wakes and is lifted.
    sim.set_collider_pose(GROUND, Quat::IDENTITY, Vec3::new(0.0, 0.01, 0.0)).unwrap();
    let report = sim.step_report().unwrap();
    assert_eq!(report.cloths_asleep, 0, "a moving collider wakes the cloth");
    assert!(!report.timings.passes.is_empty());
    for _ in 0..5 {
        sim.step().unwrap();
    }
    let lifted = sim.positions(CLOTH).unwrap();
    let mean_rise = lifted.iter().zip(&resting).map(|(a, b)| a.y - b.y).sum::<f32>() / lifted.len() as f32;
    assert!(mean_rise > 0.008, "the woken cloth must follow the ground up 1 cm (rose {mean_rise} m)");
    assert_validation_clean(&ctx);
}

/// A collider moving far from the sleeping cloth leaves it asleep; one moving within reach of
/// it wakes it.
#[test]
fn only_a_collider_moving_near_the_cloth_wakes_it() {
    let ctx = context();
    let (cloth, ground) = cloth_over_ground();
    let far = Collider::new(vec![glam::Vec4::new(10.0, 0.5, 0.0, 0.2)], 0.005);
    let mut builder = Model::builder();
    builder.add_cloth(cloth);
    let ground_id = builder.add_collider(ground);
    let far_id = builder.add_collider(far);
    let model = builder.settings(settings()).build().unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    until_asleep(&mut sim, 300);
    let resting = sim.positions(CLOTH).unwrap();
    for frame in 1..=20 {
        // The far ball circles 10 m away.
        let at = Vec3::new(10.0 + (frame as f32 * 0.3).cos(), 0.5, (frame as f32 * 0.3).sin());
        sim.set_collider_pose(far_id, Quat::IDENTITY, at - Vec3::new(10.0, 0.5, 0.0)).unwrap();
        assert_eq!(sim.step_report().unwrap().cloths_asleep, 1, "frame {frame}: a far collider woke the cloth");
    }
    assert_eq!(sim.positions(CLOTH).unwrap(), resting);
    sim.set_collider_pose(ground_id, Quat::IDENTITY, Vec3::new(0.0, 0.005, 0.0)).unwrap();
    assert_eq!(sim.step_report().unwrap().cloths_asleep, 0, "the ground under it moved: it must wake");
    assert_validation_clean(&ctx);
}

/// A force change wakes a sleeping cloth; without sleeping it never sleeps; the CPU twin
/// sleeps at the same frame as the GPU.
#[test]
fn forces_wake_the_cloth_and_the_cpu_twin_sleeps_alike() {
    let ctx = context();
    let (cloth, ground) = cloth_over_ground();
    let model = Model::single(&cloth, std::slice::from_ref(&ground), settings()).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    let first = until_asleep(&mut sim, 300);
    let mut cpu = CpuSolver::new(&model).unwrap();
    for frame in 1..=first {
        cpu.step().unwrap();
        assert_eq!(cpu.asleep(CLOTH).unwrap(), frame == first, "CPU twin at frame {frame}");
    }
    sim.set_external_force(Vec3::new(2.0, 0.0, 0.0)).unwrap();
    assert_eq!(sim.step_report().unwrap().cloths_asleep, 0, "a new force wakes the cloth");

    let never = Model::single(&cloth, std::slice::from_ref(&ground), settings().with_sleep(None)).unwrap();
    let mut sim = Solver::new(&ctx, &never).unwrap();
    for _ in 0..first + 30 {
        assert_eq!(sim.step_report().unwrap().cloths_asleep, 0);
    }
    assert_validation_clean(&ctx);
}

/// The pile falls fast onto itself: self-collision has no CCD, so the substeps rise above the
/// stability bound's while it falls (no particle moves more than the thickness per substep),
/// and come back down once it has settled; off, they stay at the bound's.
#[test]
fn fast_motion_near_self_collision_raises_the_substeps() {
    let ctx = context();
    let scene = drape::scenes::pile(32);
    let cloth = scene.cloth.clone().self_collision(Some(0.005)).build().unwrap();
    let ground = scene.triangle_collider();
    let run = |contact_substeps: bool| {
        let settings =
            SimSettings::default().with_timestamps(false).with_contact_substeps(contact_substeps).with_sleep(None);
        let model = Model::single(&cloth, std::slice::from_ref(&ground), settings).unwrap();
        let mut sim = Solver::new(&ctx, &model).unwrap();
        let counts: Vec<u32> = (0..300)
            .map(|_| {
                sim.step().unwrap();
                sim.stability(CLOTH).unwrap().substeps
            })
            .collect();
        (counts, sim.stability(CLOTH).unwrap().bound_substeps)
    };
    let (raised, bound) = run(true);
    let peak = *raised.iter().max().unwrap();
    println!("substeps: bound {bound}, peak {peak}, last {}", raised.last().unwrap());
    assert!(peak >= 2 * bound, "the falling strip needs more substeps than the bound's {bound} (peak {peak})");
    assert_eq!(*raised.last().unwrap(), bound, "a settled pile comes back to the bound's substeps");
    let (plain, _) = run(false);
    assert!(plain.iter().all(|&n| n == bound), "off, the bound's substeps throughout");
    assert_validation_clean(&ctx);
}
