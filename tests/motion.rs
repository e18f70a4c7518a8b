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

/// A ball teleported from far away into the sleeping cloth (`teleport_collider`, or its sphere
/// moved by `teleport_collider_spheres`) wakes it, and the cloth is pushed out of the ball.
#[test]
fn a_collider_teleported_into_the_sleeping_cloth_wakes_it() {
    let ctx = context();
    for by_spheres in [false, true] {
        let (cloth, ground) = cloth_over_ground();
        let far = glam::Vec4::new(10.0, 0.5, 0.0, 0.2);
        let mut builder = Model::builder();
        builder.add_cloth(cloth);
        builder.add_collider(ground);
        let ball = builder.add_collider(Collider::new(vec![far], 0.005));
        let mut sim = Solver::new(&ctx, &builder.settings(settings()).build().unwrap()).unwrap();
        until_asleep(&mut sim, 300);
        // Its top 10 cm over the ground, under the cloth's middle.
        let under = glam::Vec4::new(0.0, -0.1, 0.0, 0.2);
        if by_spheres {
            sim.teleport_collider_spheres(ball, &[under]).unwrap();
        } else {
            sim.teleport_collider(ball, Quat::IDENTITY, (under - far).truncate()).unwrap();
        }
        let woke = sim.step_report().unwrap().cloths_asleep == 0;
        for _ in 0..3 {
            sim.step().unwrap();
        }
        let x = sim.positions(CLOTH).unwrap();
        let inside = x.iter().filter(|p| p.truncate().distance(under.truncate()) < under.w - 1e-4).count();
        let top = x.iter().map(|p| p.y).fold(f32::MIN, f32::max);
        assert!(woke, "by spheres {by_spheres}: the teleported ball must wake the cloth");
        assert_eq!(inside, 0, "by spheres {by_spheres}: particles left inside the ball");
        assert!(top > 0.1, "by spheres {by_spheres}: the ball must lift the cloth (top {top} m)");
    }
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

/// One cloth of two 8 x 8 patches, one tile each (`drape_kernels::tiles::TILE_PARTICLES` = 64):
/// patch A (particles 0..64) lies 2 cm over the ground, patch B (64..128) starts 20 m up and
/// falls beside the ground through the whole test.
fn resting_and_falling_patches() -> (drape::Cloth, Collider) {
    let mesh = two_patches(Vec3::new(-0.5, 0.02, 0.0), Vec3::new(1.6, 20.0, 0.0));
    let cloth = ClothBuilder::from_mesh(mesh).build().unwrap();
    let (_, ground) = cloth_over_ground();
    (cloth, ground)
}

/// One mesh of two 8 x 8 patches of 0.3 m (particles 0..64 centred at `a`, 64..128 at `b`).
fn two_patches(a: Vec3, b: Vec3) -> drape::ClothMesh {
    let patch = drape::ClothMesh::grid(8, 8, 0.3);
    let at = |offset: Vec3| patch.vertices.iter().map(move |&v| v + offset);
    let vertices: Vec<Vec3> = at(a).chain(at(b)).collect();
    let triangles: Vec<[u32; 3]> =
        patch.triangles.iter().copied().chain(patch.triangles.iter().map(|t| t.map(|i| i + 64))).collect();
    drape::ClothMesh::from_parts(vertices, triangles).unwrap()
}

/// Whether every particle of `range` carries the sleep flag (`v.w`), or none does.
fn flags(sim: &Solver, range: std::ops::Range<usize>) -> (bool, bool) {
    let v = sim.velocities(CLOTH).unwrap();
    let slept: Vec<bool> = v[range].iter().map(|v| v.w != 0.0).collect();
    (slept.iter().all(|&s| s), slept.iter().all(|&s| !s))
}

/// Part of a cloth sleeps while the rest moves: the patch on the ground settles and its tile
/// sleeps (its particles bit for bit still, their flags set) while the falling patch keeps
/// falling and the cloth as a whole never sleeps; the CPU twin sleeps the same tile at the same
/// frame, bit for bit. A collider moving near it, and a force, wake it.
#[test]
fn a_resting_part_of_a_cloth_sleeps_while_the_rest_moves() {
    let ctx = context();
    let (cloth, ground) = resting_and_falling_patches();
    let model = Model::single(&cloth, std::slice::from_ref(&ground), settings()).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let mut first = None;
    for frame in 1..=150 {
        let report = sim.step_report().unwrap();
        cpu.step().unwrap();
        assert_eq!(report.tiles, 2, "frame {frame}: {report:?}");
        assert_eq!(report.cloths_asleep, 0, "frame {frame}: the falling patch keeps the cloth awake");
        assert_eq!(sim.positions(CLOTH).unwrap(), cpu.positions(CLOTH).unwrap(), "frame {frame}: GPU != CPU twin");
        assert_eq!(sim.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {frame}");
        if report.tiles_asleep > 0 {
            assert_eq!(report.tiles_asleep, 1, "frame {frame}: only the resting patch may sleep");
            first.get_or_insert(frame);
        } else {
            assert!(first.is_none(), "frame {frame}: the resting patch woke by itself");
        }
    }
    let first = first.expect("the resting patch must sleep within 150 frames");
    println!("the resting patch's tile slept from frame {first}");
    assert!(first > 20, "it cannot sleep before it landed and stayed still for 20 frames");
    assert_eq!(flags(&sim, 0..64), (true, false), "the sleeping patch's particles carry the flag");
    assert_eq!(flags(&sim, 64..128), (false, true), "the falling patch's do not");
    let resting = sim.positions(CLOTH).unwrap();
    let falling = resting[64].y;
    for _ in 0..30 {
        assert_eq!(sim.step_report().unwrap().tiles_asleep, 1);
    }
    let now = sim.positions(CLOTH).unwrap();
    assert_eq!(now[..64], resting[..64], "a sleeping tile must not drift");
    assert!(now[64].y < falling - 1.0, "the awake patch keeps falling ({} -> {} m)", falling, now[64].y);
    // The ground rises 1 cm over the next frame: the tile wakes and follows it.
    sim.set_collider_pose(GROUND, Quat::IDENTITY, Vec3::new(0.0, 0.01, 0.0)).unwrap();
    assert_eq!(sim.step_report().unwrap().tiles_asleep, 0, "a collider moving under the tile wakes it");
    assert_eq!(flags(&sim, 0..64), (false, true));
    for _ in 0..5 {
        sim.step().unwrap();
    }
    let lifted = sim.positions(CLOTH).unwrap();
    let rise = lifted[..64].iter().zip(&resting[..64]).map(|(a, b)| a.y - b.y).sum::<f32>() / 64.0;
    assert!(rise > 0.008, "the woken patch must follow the ground up 1 cm (rose {rise} m)");
    // Settled again, a force wakes it.
    let mut slept = false;
    for _ in 0..150 {
        if sim.step_report().unwrap().tiles_asleep == 1 {
            slept = true;
            break;
        }
    }
    assert!(slept, "the lifted patch must settle and sleep again");
    sim.set_external_force(Vec3::new(0.0, 0.0, 0.01)).unwrap();
    assert_eq!(sim.step_report().unwrap().tiles_asleep, 0, "a new force wakes every tile");
    assert_validation_clean(&ctx);
}

/// Tile sleeping off: no tiles, and no particle ever carries the sleep flag.
#[test]
fn tile_sleep_off_declares_no_tiles() {
    let ctx = context();
    let (cloth, ground) = resting_and_falling_patches();
    let model = Model::single(&cloth, std::slice::from_ref(&ground), settings().with_tile_sleep(false)).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    for _ in 0..60 {
        let report = sim.step_report().unwrap();
        assert_eq!((report.tiles, report.tiles_asleep), (0, 0));
    }
    assert_eq!(flags(&sim, 0..128), (false, true));
    assert_validation_clean(&ctx);
}

/// A state read while the resting patch counts its calm frames restores its tiles too: the
/// replay sleeps the same tile in the same frames and ends bit for bit where the first run did
/// (with the tiles woken instead, the patch would count its calm frames again and sleep later).
#[test]
fn a_restored_state_replays_its_sleeping_tiles() {
    let ctx = context();
    let (cloth, ground) = resting_and_falling_patches();
    let model = Model::single(&cloth, std::slice::from_ref(&ground), settings()).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    for _ in 0..15 {
        sim.step().unwrap();
    }
    let saved = sim.state().unwrap();
    let asleep = |sim: &mut Solver| (0..30).map(|_| sim.step_report().unwrap().tiles_asleep).collect::<Vec<_>>();
    let first = asleep(&mut sim);
    assert!(first.contains(&1) && first[0] == 0, "the resting patch falls asleep after the checkpoint: {first:?}");
    let end = sim.state().unwrap();
    sim.set_state(&saved).unwrap();
    assert_eq!(asleep(&mut sim), first, "the replay sleeps the same tiles in the same frames");
    assert!(sim.state().unwrap() == end, "the replay ends where the first run did");
    assert_validation_clean(&ctx);
}

/// A settled particle (asleep and copied into its stage buffers, `v.w = 2`) is skipped by the
/// integrator, so its stage buffers must hold it. One self-colliding cloth of two patches: A
/// rests on the ground and sleeps, B falls onto it from 2.5 m and pushes A's sleeping particles
/// (which wakes A). After every frame each settled particle's substep start and both ping-pong
/// pairs equal its position and zero velocity; the CPU twin agrees bit for bit; no layer
/// crosses the other.
#[test]
fn a_settled_particle_s_stage_buffers_hold_it_while_the_cloth_lands_on_it() {
    let ctx = context();
    let mesh = two_patches(Vec3::new(-0.5, 0.02, 0.0), Vec3::new(-0.45, 2.5, 0.05));
    let triangles = mesh.triangles.clone();
    let cloth = ClothBuilder::from_mesh(mesh).self_collision(Some(0.005)).build().unwrap();
    let (_, ground) = cloth_over_ground();
    let model = Model::single(&cloth, std::slice::from_ref(&ground), settings()).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let (mut settled_frames, mut slept_before_landing, mut woke) = (0, false, false);
    for frame in 1..=90 {
        let report = sim.step_report().unwrap();
        cpu.step().unwrap();
        let (x, v) = (sim.positions(CLOTH).unwrap(), sim.velocities(CLOTH).unwrap());
        assert_eq!(x, cpu.positions(CLOTH).unwrap(), "frame {frame}: GPU != CPU twin");
        assert_eq!(v, cpu.velocities(CLOTH).unwrap(), "frame {frame}");
        let [x_prev, xa, xb, va, vb] = sim.stage_buffers(CLOTH).unwrap();
        let settled: Vec<usize> = (0..x.len()).filter(|&i| v[i].w == 2.0).collect();
        for &i in &settled {
            assert_eq!([x_prev[i], xa[i], xb[i]], [x[i]; 3], "frame {frame}: settled particle {i}'s positions");
            assert_eq!([va[i], vb[i], v[i].truncate().extend(0.0)], [glam::Vec4::ZERO; 3], "frame {frame}: {i}");
        }
        settled_frames += usize::from(!settled.is_empty());
        let landed = x[64..].iter().any(|p| p.y < 0.1);
        slept_before_landing |= report.tiles_asleep == 1 && !landed;
        woke |= slept_before_landing && landed && report.tiles_asleep == 0;
    }
    println!("settled particles in {settled_frames} of 90 frames");
    assert!(slept_before_landing, "the resting patch must sleep before the other lands on it");
    assert!(woke, "the patch landing on it wakes the sleeping patch");
    let x = sim.positions(CLOTH).unwrap();
    assert_eq!(drape::metrics::intersections::count_intersections(&x, &triangles, (&[], &[])).cloth_cloth, 0);
    assert_validation_clean(&ctx);
}
