//! Moving and deforming colliders, and runtime parameter changes: the contact follows the
//! collider's motion substep by substep, deformed leaves are refit on the GPU, and the GPU run
//! stays bit-identical to its CPU twin through all of it.

mod common;

use common::{assert_validation_clean, context};
use drape::{Cloth, ClothBuilder, ClothId, Collider, ColliderId, CpuSolver, Model, SimSettings, Solver};
use glam::{Mat4, Quat, Vec3, Vec4};

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

/// A rod of `n` separate spheres of radius `r` along x, 2.5 r apart (gaps wider than the
/// contact thickness, so pushing a particle out of one cannot push it into another).
fn rod(n: u32, r: f32) -> Vec<Vec4> {
    (0..n).map(|i| Vec3::new((i as f32 - (n - 1) as f32 / 2.0) * 2.5 * r, 0.0, 0.0).extend(r)).collect()
}

/// A flat plate in the collider's xz plane: `n` x `n` spheres of radius `r`, `spacing` apart
/// (2 r thick). With `spacing` > 2 r + 2 x thickness the spheres are separate, so pushing a
/// particle out of one cannot push it into another (the sphere proxy resolves one contact per
/// particle and substep); gaps far smaller than the cloth's cells keep the plate solid to it.
fn plate(n: u32, r: f32, spacing: f32) -> Vec<Vec4> {
    let half = (n - 1) as f32 / 2.0;
    let mut spheres = Vec::new();
    for i in 0..n {
        for k in 0..n {
            spheres.push(Vec4::new((i as f32 - half) * spacing, 0.0, (k as f32 - half) * spacing, r));
        }
    }
    spheres
}

/// A horizontal, fairly stiff cloth at height `y`, pinned at its four corners.
fn trampoline(n: u32, y: f32) -> Cloth {
    ClothBuilder::new(n, n)
        .stiffness(400.0, 100.0, 5.0)
        .pin(0, 0)
        .pin(0, n - 1)
        .pin(n - 1, 0)
        .pin(n - 1, n - 1)
        .transform(Mat4::from_translation(Vec3::new(0.0, y, 0.0)))
        .build()
        .unwrap()
}

/// Smallest (distance to a sphere's centre - its radius) over all particles and spheres, with
/// the spheres placed by `pose`: negative means a particle is inside a sphere.
fn clearance(positions: &[Vec4], spheres: &[Vec4], rotation: Quat, translation: Vec3) -> f32 {
    let mut worst = f32::INFINITY;
    for s in spheres {
        let centre = rotation * s.truncate() + translation;
        for p in positions {
            worst = worst.min((p.truncate() - centre).length() - s.w);
        }
    }
    worst
}

/// Particles over the plate's footprint (in its frame, |x|, |z| < `half`) that are below its
/// mid-plane: the plate passed through them.
fn below_plate(positions: &[Vec4], rotation: Quat, translation: Vec3, half: f32) -> usize {
    positions
        .iter()
        .map(|p| rotation.inverse() * (p.truncate() - translation))
        .filter(|l| l.x.abs() < half && l.z.abs() < half && l.y < 0.0)
        .count()
}

/// The plate's pose at frame `f`: rising 2 cm per frame from below the cloth and turning
/// about the vertical.
fn plate_pose(f: u32) -> (Quat, Vec3) {
    (Quat::from_rotation_y(0.05 * f as f32), Vec3::new(0.0, -0.15 + 0.02 * f as f32, 0.0))
}

/// A turning plate of separate spheres rises under a pinned cloth and lifts it: no particle
/// ends a frame inside any of its spheres. (Whether particles slip through the holes between
/// the spheres is the fast-plate test's business, with a solid plate.)
#[test]
fn a_rising_turning_collider_lifts_the_cloth_without_entering_it() {
    let ctx = context();
    let spheres = plate(6, 0.03, 0.072);
    let (q0, t0) = plate_pose(0);
    let collider = Collider::new(spheres.clone(), 0.005).with_pose(q0, t0);
    let mut sim = Solver::new(
        &ctx,
        &Model::single(&trampoline(24, 0.0), std::slice::from_ref(&collider), SimSettings::default()).unwrap(),
    )
    .unwrap();
    let mut worst = f32::INFINITY;
    for f in 1..=30 {
        let (rotation, translation) = plate_pose(f);
        sim.set_collider_pose(ColliderId::new(0), rotation, translation).unwrap();
        sim.step().unwrap();
        worst = worst.min(clearance(&sim.positions(CLOTH).unwrap(), &spheres, rotation, translation));
    }
    assert!(worst > -1e-4, "a particle ended {:.2} mm inside the moving plate", -worst * 1e3);
    let top = sim.positions(CLOTH).unwrap().iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(top > plate_pose(30).1.y, "the cloth was not lifted (top {top})");
    assert_validation_clean(&ctx);
}

/// A plate at 4 m/s (6.7 cm per frame, more than its 6 cm thickness) hits the cloth: because
/// contact interpolates the plate's pose per substep, the cloth is carried instead of the plate
/// jumping through it between frames.
#[test]
fn a_fast_plate_does_not_jump_through_the_cloth_between_frames() {
    let ctx = context();
    let spheres = plate(7, 0.03, 0.03);
    let start = Vec3::new(0.0, -0.1, 0.0);
    let collider = Collider::new(spheres.clone(), 0.005).with_pose(Quat::IDENTITY, start);
    let mut sim = Solver::new(
        &ctx,
        &Model::single(&trampoline(24, 0.0), std::slice::from_ref(&collider), SimSettings::default()).unwrap(),
    )
    .unwrap();
    let per_frame = 4.0 / 60.0;
    assert!(per_frame > 2.0 * 0.03 + 0.005);
    let mut position = start;
    let mut below = 0;
    for _ in 0..6 {
        position.y += per_frame;
        sim.set_collider_pose(ColliderId::new(0), Quat::IDENTITY, position).unwrap();
        sim.step().unwrap();
        below = below.max(below_plate(&sim.positions(CLOTH).unwrap(), Quat::IDENTITY, position, 0.08));
    }
    assert_eq!(below, 0, "particles ended below the fast plate: it jumped through the cloth");
    let top = sim.positions(CLOTH).unwrap().iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(top >= position.y, "cloth top {top}, plate at {}: the plate passed through", position.y);
    assert_validation_clean(&ctx);
}

/// The same plate at 4 m/s moved by its spheres (`set_collider_spheres`, as a renderer moves
/// sphere proxies on a skinned body's bones) instead of its pose: each centre sweeps from where
/// the last frame left it over the frame's substeps, so the cloth is carried instead of the
/// spheres jumping through it (with the spheres set at the frame's start instead, all 16
/// particles over the plate ended below it from frame 2 on), and the GPU equals its CPU twin
/// and the brute-force contact bit for bit through it.
#[test]
fn fast_deforming_spheres_do_not_jump_through_the_cloth_between_frames() {
    let ctx = context();
    let at = |height: f32| -> Vec<Vec4> {
        plate(7, 0.03, 0.03).iter().map(|s| *s + Vec4::new(0.0, height, 0.0, 0.0)).collect()
    };
    let mut height = -0.1;
    let collider = Collider::new(at(height), 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&trampoline(24, 0.0), std::slice::from_ref(&collider), settings).unwrap();
    let brute = Model::single(&trampoline(24, 0.0), &[collider.clone().brute_force()], settings).unwrap();
    let (mut gpu, mut cpu) = (Solver::new(&ctx, &model).unwrap(), CpuSolver::new(&model).unwrap());
    let mut gpu_brute = Solver::new(&ctx, &brute).unwrap();
    let per_frame = 4.0 / 60.0;
    assert!(per_frame > 2.0 * 0.03 + 0.005);
    let mut below = 0;
    for f in 1..=6 {
        height += per_frame;
        gpu.set_collider_spheres(ColliderId::new(0), &at(height)).unwrap();
        cpu.set_collider_spheres(ColliderId::new(0), &at(height)).unwrap();
        gpu_brute.set_collider_spheres(ColliderId::new(0), &at(height)).unwrap();
        gpu.step().unwrap();
        cpu.step().unwrap();
        gpu_brute.step().unwrap();
        let positions = gpu.positions(CLOTH).unwrap();
        assert_eq!(positions, cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(positions, gpu_brute.positions(CLOTH).unwrap(), "frame {f}: BVH != brute force");
        assert_eq!(gpu.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {f}: GPU != CPU velocities");
        below = below.max(below_plate(&positions, Quat::IDENTITY, Vec3::new(0.0, height, 0.0), 0.08));
    }
    assert_eq!(below, 0, "particles ended below the fast spheres: they jumped through the cloth");
    let top = gpu.positions(CLOTH).unwrap().iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(top >= height, "cloth top {top}, plate at {height}: the plate passed through");
    assert_validation_clean(&ctx);
}

/// A sphere swelling under the pinned cloth (`set_collider_spheres`, its radius 10 -> 16 cm in
/// one frame, 3.6 m/s at its surface) grows over the frame's substeps and pushes the cloth out
/// with its surface's speed, as a deforming mesh's surface does: the particle over its top
/// leaves the frame rising at about that speed, none ends a frame inside it, and the GPU equals
/// its CPU twin bit for bit.
#[test]
fn a_swelling_sphere_pushes_the_cloth_out_with_its_surface() {
    let ctx = context();
    let (n, growth) = (13, 0.06);
    let sphere = |r: f32| vec![Vec4::new(0.0, 0.0, 0.0, r)];
    let collider = Collider::new(sphere(0.1), 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&trampoline(n, 0.11), std::slice::from_ref(&collider), settings).unwrap();
    let (mut gpu, mut cpu) = (Solver::new(&ctx, &model).unwrap(), CpuSolver::new(&model).unwrap());
    let top = (n * n / 2) as usize;
    let (mut radius, mut worst, mut rising) = (0.1, f32::INFINITY, 0.0);
    for f in 1..=8 {
        if f == 5 {
            radius += growth;
            gpu.set_collider_spheres(ColliderId::new(0), &sphere(radius)).unwrap();
            cpu.set_collider_spheres(ColliderId::new(0), &sphere(radius)).unwrap();
        }
        gpu.step().unwrap();
        cpu.step().unwrap();
        let (x, v) = (gpu.positions(CLOTH).unwrap(), gpu.velocities(CLOTH).unwrap());
        assert_eq!(x, cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(v, cpu.velocities(CLOTH).unwrap(), "frame {f}: GPU != CPU velocities");
        worst = worst.min(clearance(&x, &sphere(radius), Quat::IDENTITY, Vec3::ZERO));
        if f == 5 {
            rising = v[top].y;
        }
    }
    let speed = growth * 60.0;
    println!("the top particle rose at {rising:.3} m/s after the growth frame (surface {speed:.1} m/s)");
    assert!(worst > -1e-4, "a particle ended {:.2} mm inside the swelling sphere", -worst * 1e3);
    assert!(rising > 0.5 * speed, "the top particle rose at {rising} m/s, its surface at {speed} m/s");
    assert_validation_clean(&ctx);
}

/// How a collider goes from below the pinned cloth to above it in one frame (`teleport`):
/// moved there, it sweeps up through the cloth and carries it; teleported, it jumps past it.
#[derive(Copy, Clone, Debug, PartialEq)]
enum Passage {
    Moved,
    Teleported,
}

/// A plate of spheres 20 cm under a pinned 12 x 12 cloth goes 40 cm up in frame 11, past the
/// cloth, by its pose (`by_spheres` false) or by its spheres, `passage` saying how; returns the
/// cloth's highest particle three frames later and whether the plate's tree stood still in the
/// frame it went (its leaves' boxes those of its spheres there). The GPU equals its CPU twin
/// in every frame.
fn plate_passing_the_cloth(by_spheres: bool, passage: Passage) -> (f32, bool) {
    let ctx = context();
    let plate_at =
        |y: f32| -> Vec<Vec4> { plate(5, 0.05, 0.05).iter().map(|s| *s + Vec4::new(0.0, y, 0.0, 0.0)).collect() };
    let collider = Collider::new(plate_at(-0.2), 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&trampoline(12, 0.0), std::slice::from_ref(&collider), settings).unwrap();
    let (mut gpu, mut cpu) = (Solver::new(&ctx, &model).unwrap(), CpuSolver::new(&model).unwrap());
    let plate = ColliderId::new(0);
    let mut still = false;
    for f in 1..=14 {
        if f == 11 {
            let (spheres, up) = (plate_at(0.2), Vec3::new(0.0, 0.4, 0.0));
            match (by_spheres, passage) {
                (false, Passage::Moved) => {
                    gpu.set_collider_pose(plate, Quat::IDENTITY, up).unwrap();
                    cpu.set_collider_pose(plate, Quat::IDENTITY, up).unwrap();
                }
                (false, Passage::Teleported) => {
                    gpu.teleport_collider(plate, Quat::IDENTITY, up).unwrap();
                    cpu.teleport_collider(plate, Quat::IDENTITY, up).unwrap();
                }
                (true, Passage::Moved) => {
                    gpu.set_collider_spheres(plate, &spheres).unwrap();
                    cpu.set_collider_spheres(plate, &spheres).unwrap();
                }
                (true, Passage::Teleported) => {
                    gpu.teleport_collider_spheres(plate, &spheres).unwrap();
                    cpu.teleport_collider_spheres(plate, &spheres).unwrap();
                }
            }
        }
        gpu.step().unwrap();
        cpu.step().unwrap();
        assert_eq!(gpu.positions(CLOTH).unwrap(), cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        if f == 11 {
            let standing = if by_spheres { plate_at(0.2) } else { plate_at(-0.2) };
            still = gpu.collider_bvh(plate).unwrap().validate(&standing).is_ok();
        }
    }
    assert_validation_clean(&ctx);
    let top = gpu.positions(CLOTH).unwrap().iter().map(|p| p.y).fold(f32::MIN, f32::max);
    (top, still)
}

/// A collider moved past the cloth in one frame sweeps through it and carries it up; teleported
/// (`teleport_collider`, `teleport_collider_spheres`: a respawn, a cut), it jumps past without
/// touching it, its leaves standing still in that frame.
#[test]
fn a_teleported_collider_jumps_past_the_cloth_that_a_moved_one_carries() {
    for by_spheres in [false, true] {
        let (carried, swept) = plate_passing_the_cloth(by_spheres, Passage::Moved);
        let (left, still) = plate_passing_the_cloth(by_spheres, Passage::Teleported);
        println!("by spheres {by_spheres}: highest particle {carried:.3} m moved, {left:.3} m teleported");
        assert!(carried > 0.15, "moved by spheres {by_spheres}, the plate must carry the cloth up ({carried} m)");
        assert!(left < 0.01, "teleported by spheres {by_spheres}, the plate must leave the cloth ({left} m)");
        assert!(still, "teleported by spheres {by_spheres}, the plate's leaves must stand still");
        assert_eq!(swept, !by_spheres, "moved by its spheres, the plate's leaves sweep in that frame");
    }
}

/// With a moving collider the GPU frame equals its CPU twin bit for bit, and the BVH contact
/// equals the brute-force contact.
#[test]
fn a_moving_collider_gpu_equals_cpu_and_bvh_equals_brute_force() {
    let ctx = context();
    let cloth = trampoline(12, 0.0);
    let (q0, t0) = plate_pose(0);
    let collider = Collider::new(plate(5, 0.05, 0.05), 0.005).with_pose(q0, t0);
    let brute = collider.clone().brute_force();
    let settings = SimSettings::default().with_timestamps(false);
    let mut gpu =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    let mut gpu_brute =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&brute), settings).unwrap()).unwrap();
    let mut cpu = CpuSolver::new(&Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    for f in 1..=20 {
        let (rotation, translation) = plate_pose(f);
        gpu.set_collider_pose(ColliderId::new(0), rotation, translation).unwrap();
        gpu_brute.set_collider_pose(ColliderId::new(0), rotation, translation).unwrap();
        cpu.set_collider_pose(ColliderId::new(0), rotation, translation).unwrap();
        gpu.step().unwrap();
        gpu_brute.step().unwrap();
        cpu.step().unwrap();
        let positions = gpu.positions(CLOTH).unwrap();
        assert_eq!(positions, cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(gpu.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {f}: GPU != CPU velocities");
        assert_eq!(positions, gpu_brute.positions(CLOTH).unwrap(), "frame {f}: BVH != brute force");
    }
    assert!(cpu.positions(CLOTH).unwrap().iter().any(|p| p.y > 0.1), "the plate did not push the cloth");
    assert_validation_clean(&ctx);
}

/// A deforming triangle collider (a ball whose vertices rise and swell under the pinned cloth,
/// set each frame by `set_collider_vertices`, as a skinned mesh's are): the GPU frame equals its
/// CPU twin bit for bit. Its leaves move over the frame, and contact takes the particles back by
/// their remaining motion; written as `q1 - p1`, Mesa's NIR folded that to the motion itself and
/// the GPU parted from the CPU by an f32 step at the first contact.
/// Steps a solver and its CPU twin through frames 1..=`frames`, collider 0 moved to
/// `vertices_at(frame)` before each, asserting they agree bit for bit after each.
fn step_twins_by_vertices(
    (gpu, cpu): (&mut Solver, &mut CpuSolver),
    frames: u32,
    vertices_at: impl Fn(u32) -> Vec<Vec3>,
) {
    for f in 1..=frames {
        let vertices = vertices_at(f);
        gpu.set_collider_vertices(ColliderId::new(0), &vertices).unwrap();
        cpu.set_collider_vertices(ColliderId::new(0), &vertices).unwrap();
        gpu.step().unwrap();
        cpu.step().unwrap();
        assert_eq!(gpu.positions(CLOTH).unwrap(), cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(gpu.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {f}: GPU != CPU velocities");
    }
}

#[test]
fn a_deforming_triangle_collider_gpu_equals_cpu() {
    let ctx = context();
    let cloth = trampoline(12, 0.0);
    let ball = drape::Mesh::icosphere(0.12, 2);
    let deformed = |f: u32| -> Vec<Vec3> {
        let (rise, swell) = (-0.15 + 0.015 * f as f32, 1.0 + 0.01 * f as f32);
        ball.vertices.iter().map(|v| *v * swell + Vec3::new(0.0, rise, 0.0)).collect()
    };
    let collider = Collider::mesh(&drape::Mesh { vertices: deformed(0), triangles: ball.triangles.clone() }, 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap();
    let (mut gpu, mut cpu) = (Solver::new(&ctx, &model).unwrap(), CpuSolver::new(&model).unwrap());
    step_twins_by_vertices((&mut gpu, &mut cpu), 20, deformed);
    assert!(cpu.positions(CLOTH).unwrap().iter().any(|p| p.y > 0.05), "the ball did not push the cloth");
    assert_validation_clean(&ctx);
}

/// A deforming collider (its spheres swell under a draped cloth): the leaves are written and
/// the LBVH refit on the GPU each frame, the refit tree bounds the new leaves, no particle ends
/// inside, and the GPU still equals the CPU.
#[test]
fn a_deforming_collider_is_refit_and_not_entered() {
    let ctx = context();
    let cloth = ClothBuilder::new(20, 20).transform(Mat4::from_translation(Vec3::new(0.0, 0.12, 0.0))).build().unwrap();
    let base = rod(7, 0.04);
    let collider = Collider::new(base.clone(), 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let mut gpu =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    let mut cpu = CpuSolver::new(&Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    let mut worst = f32::INFINITY;
    let (mut previous, mut spheres) = (base.clone(), base.clone());
    for f in 1..=30 {
        previous = spheres.clone();
        // Swell the radii (2.5 r spacing keeps gaps) and bend the rod upwards in the middle.
        spheres = base
            .iter()
            .map(|s| {
                let bend = 0.002 * f as f32 * (1.0 - (s.x / 0.4).powi(2));
                Vec4::new(s.x, bend, s.z, s.w * (1.0 + 0.008 * f as f32))
            })
            .collect();
        gpu.set_collider_spheres(ColliderId::new(0), &spheres).unwrap();
        cpu.set_collider_spheres(ColliderId::new(0), &spheres).unwrap();
        gpu.step().unwrap();
        cpu.step().unwrap();
        let positions = gpu.positions(CLOTH).unwrap();
        assert_eq!(positions, cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        worst = worst.min(clearance(&positions, &spheres, Quat::IDENTITY, Vec3::ZERO));
    }
    assert!(worst > -1e-4, "a particle ended {:.2} mm inside the deforming collider", -worst * 1e3);
    // The last frame deformed, so its spheres sweep from the frame before's; a frame without a
    // change stands them still again.
    let tree = gpu.collider_bvh(ColliderId::new(0)).unwrap();
    tree.validate_swept(&previous, &spheres).expect("the refit tree bounds the sweeping leaves");
    assert!(tree.validate(&spheres).is_err(), "the last frame's leaves must sweep");
    gpu.step().unwrap();
    let tree = gpu.collider_bvh(ColliderId::new(0)).unwrap();
    tree.validate(&spheres).expect("the refit tree bounds the deformed leaves, standing still");
    assert!(gpu.set_collider_spheres(ColliderId::new(0), &spheres[1..]).is_err(), "a different leaf count is refused");
    assert_validation_clean(&ctx);
}

/// A stiffness or `dt` change before the first frame gives exactly the run built with it, and
/// automatic substeps follow the stability bound.
#[test]
fn stiffness_and_dt_changes_equal_building_with_them() {
    let ctx = context();
    let builder = ClothBuilder::new(10, 10).pin_top_corners();
    let settings = SimSettings::default().with_timestamps(false);
    let mut changed =
        Solver::new(&ctx, &Model::single(&builder.clone().build().unwrap(), &[], settings).unwrap()).unwrap();
    let substeps_before = changed.stability(CLOTH).unwrap().substeps;
    changed.set_stiffness(CLOTH, 160.0, 40.0, 8.0).unwrap();
    changed.set_frame_dt(1.0 / 30.0).unwrap();
    let stiff = builder.stiffness(160.0, 40.0, 8.0).build().unwrap();
    let mut built =
        Solver::new(&ctx, &Model::single(&stiff, &[], settings.with_frame_dt(1.0 / 30.0)).unwrap()).unwrap();
    assert_eq!(changed.stability(CLOTH).unwrap(), built.stability(CLOTH).unwrap());
    // 4x stiffness doubles omega; twice the frame time doubles again.
    assert!(
        changed.stability(CLOTH).unwrap().substeps >= 3 * substeps_before,
        "{} vs {substeps_before}",
        changed.stability(CLOTH).unwrap().substeps
    );
    for _ in 0..10 {
        changed.step().unwrap();
        built.step().unwrap();
    }
    assert_eq!(changed.positions(CLOTH).unwrap(), built.positions(CLOTH).unwrap());
    // Damping too; bad values are refused and change nothing.
    changed.set_damping(CLOTH, 0.01, 0.001).unwrap();
    changed.step().unwrap();
    assert!(changed.set_stiffness(CLOTH, -1.0, 0.0, 0.0).is_err());
    assert!(changed.set_frame_dt(0.0).is_err());
    assert!(changed.set_damping(CLOTH, f32::NAN, 0.0).is_err());
    assert_eq!(changed.params(CLOTH).unwrap().spring_damping, 0.01);
    assert_validation_clean(&ctx);
}

/// Unpinned corners fall; an animated pin is exactly where it was put at every frame.
#[test]
fn pins_can_be_released_and_animated() {
    let ctx = context();
    let n = 10u32;
    let cloth = ClothBuilder::new(n, n).pin_top_corners().build().unwrap();
    let corners = [(n - 1) * n, n * n - 1];
    let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    let mut cpu = CpuSolver::new(&Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    let start = sim.positions(CLOTH).unwrap();
    // Animate corner 0 on a circle; release corner 1.
    sim.unpin(CLOTH, corners[1]).unwrap();
    cpu.unpin(CLOTH, corners[1]).unwrap();
    for f in 1..=20 {
        let angle = f as f32 * 0.1;
        let target = start[corners[0] as usize].truncate() + 0.1 * Vec3::new(angle.cos() - 1.0, angle.sin(), 0.0);
        sim.pin(CLOTH, corners[0], Some(target)).unwrap();
        cpu.pin(CLOTH, corners[0], Some(target)).unwrap();
        sim.step().unwrap();
        cpu.step().unwrap();
        let p = sim.positions(CLOTH).unwrap()[corners[0] as usize];
        assert_eq!(p, target.extend(0.0), "frame {f}: the animated pin is not where it was put");
    }
    let end = sim.positions(CLOTH).unwrap();
    assert_eq!(end, cpu.positions(CLOTH).unwrap(), "GPU != CPU with pin changes");
    let released = corners[1] as usize;
    assert!(end[released].y < start[released].y - 0.05, "the released corner did not fall");
    assert_eq!(end[released].w, 1.0);
    // Pin a free particle where it is: it stays there.
    let middle = (n / 2 * n + n / 2) as usize;
    sim.pin(CLOTH, middle as u32, None).unwrap();
    sim.step().unwrap();
    let held = sim.positions(CLOTH).unwrap()[middle];
    sim.step().unwrap();
    assert_eq!(sim.positions(CLOTH).unwrap()[middle], held);
    assert!(sim.pin(CLOTH, n * n, None).is_err(), "out-of-range particle");
    assert_validation_clean(&ctx);
}

/// What a collider moved by its pose and the same moved by its vertices make the cloth do
/// (`by_pose`, `by_vertices`: a speed or a spin, on the collider's own `scale`): moved by its
/// pose it must drive the cloth (more than `least` x `scale`: the scene tests something), and
/// moved by its vertices drive it alike (within `within` x `scale`).
fn assert_alike_by_pose_and_vertices(
    what: &str,
    (by_pose, by_vertices): (f32, f32),
    scale: f32,
    (least, within): (f32, f32),
) {
    assert!(
        by_pose > least * scale,
        "{what}: moved by its pose, the collider must drive the cloth (the scene must test it): {by_pose}"
    );
    assert!(
        (by_vertices - by_pose).abs() < within * scale,
        "{what}: moved by its vertices, the collider drove the cloth to {by_vertices}, by its pose to {by_pose}"
    );
}

/// A ground of `cells` x `cells` squares, `size` m wide, centred at the origin in the xz plane
/// (facing up).
fn ground(size: f32, cells: u32) -> drape::Mesh {
    let step = size / cells as f32;
    let mut vertices = Vec::new();
    for i in 0..=cells {
        for k in 0..=cells {
            vertices.push(Vec3::new(i as f32 * step - size / 2.0, 0.0, k as f32 * step - size / 2.0));
        }
    }
    let at = |i: u32, k: u32| i * (cells + 1) + k;
    let mut triangles = Vec::new();
    for i in 0..cells {
        for k in 0..cells {
            triangles.push([at(i, k), at(i, k + 1), at(i + 1, k + 1)]);
            triangles.push([at(i, k), at(i + 1, k + 1), at(i + 1, k)]);
        }
    }
    drape::Mesh { vertices, triangles }
}

/// A ground sliding sideways under a cloth that rests on it drags the cloth along by friction,
/// moved by its vertices (`set_collider_vertices`, as a skinned body's surface moves) as by its
/// pose: the response takes the touched leaf's own motion into the surface's velocity. Before,
/// a surface moved by its vertices held the cloth still in the world (its friction against a
/// surface at rest) while the ground slid away under it. The GPU equals its CPU twin bit for bit
/// through the sliding run.
#[test]
fn a_ground_sliding_by_its_vertices_drags_the_cloth_as_one_moved_by_its_pose() {
    const SPEED: f32 = 0.5; // m/s along x, from frame SETTLE on
    const SETTLE: u32 = 15;
    const FRAMES: u32 = 60;
    let ctx = context();
    let floor = ground(3.0, 6);
    let cloth = ClothBuilder::new(10, 10).transform(Mat4::from_translation(Vec3::new(0.0, 0.02, 0.0))).build().unwrap();
    let collider = Collider::mesh(&floor, 0.005).with_friction(0.8);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap();
    let shift = |f: u32| Vec3::new(SPEED * f.saturating_sub(SETTLE) as f32 / 60.0, 0.0, 0.0);
    let mean_x_velocity = |v: &[Vec4]| v.iter().map(|v| v.x).sum::<f32>() / v.len() as f32;
    // By its pose.
    let mut posed = Solver::new(&ctx, &model).unwrap();
    for f in 1..=FRAMES {
        posed.set_collider_pose(ColliderId::new(0), Quat::IDENTITY, shift(f)).unwrap();
        posed.step().unwrap();
    }
    let by_pose = mean_x_velocity(&posed.velocities(CLOTH).unwrap());
    // By its vertices, on the GPU and its CPU twin.
    let (mut gpu, mut cpu) = (Solver::new(&ctx, &model).unwrap(), CpuSolver::new(&model).unwrap());
    step_twins_by_vertices((&mut gpu, &mut cpu), FRAMES, |f| floor.vertices.iter().map(|v| *v + shift(f)).collect());
    let x = gpu.positions(CLOTH).unwrap();
    let by_vertices = mean_x_velocity(&gpu.velocities(CLOTH).unwrap());
    println!(
        "cloth's mean x velocity after {FRAMES} frames: by pose {by_pose:.4} m/s, by vertices {by_vertices:.4} m/s (ground {SPEED})"
    );
    assert!(x.iter().all(|p| p.y > 0.0), "the cloth fell through the ground");
    assert_alike_by_pose_and_vertices("sliding ground (m/s)", (by_pose, by_vertices), SPEED, (0.9, 0.05));
    assert_validation_clean(&ctx);
}

/// The skirt's mean angular velocity about the vertical axis through the origin (rad/s): its
/// particles' angular momentum over their moment of inertia, equal masses.
fn spin_about_vertical(x: &[Vec4], v: &[Vec4]) -> f32 {
    let (mut momentum, mut inertia) = (0.0, 0.0);
    for (p, v) in x.iter().zip(v) {
        // (r x v).y for r in the horizontal plane.
        momentum += p.z * v.x - p.x * v.z;
        inertia += p.x * p.x + p.z * p.z;
    }
    momentum / inertia
}

/// The garment scene's skirt on a round body (the scene's, made round about its vertical axis,
/// so only friction can turn the skirt) turning at the scene's rate, by its pose or by its
/// vertices (`set_collider_vertices`, as a skinned body moves): friction turns the skirt with
/// the body either way, to the same spin within a tenth of the body's rate (1.496 rad/s by
/// pose, 1.482 by vertices, the body at 1.5). Before the response took the triangles' own
/// motion into the surface velocity, the skirt on the body turned by its vertices hardly
/// turned (0.021 rad/s).
#[test]
fn a_skirt_turns_with_its_round_body_alike_by_pose_and_by_vertices() {
    const FRAMES: u32 = 90;
    let ctx = context();
    let mut scene = drape::scenes::garment(16);
    scene.mesh = drape::Mesh::icosphere(1.0, 3)
        .transformed(Mat4::from_translation(Vec3::new(0.0, 0.5, 0.0)) * Mat4::from_scale(Vec3::new(0.25, 0.5, 0.25)));
    // Without self-collision: its collider-feature contact (the body's vertices against the
    // skirt's faces) has its own friction, which takes the vertices' motion and turned the
    // skirt before this response did.
    let cloth = scene.cloth.clone().self_collision(None).build().unwrap();
    let collider = scene.triangle_collider();
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap();
    let body = ColliderId::new(0);
    let spin = |deforming: bool| {
        let mut sim = Solver::new(&ctx, &model).unwrap();
        let mut spins = Vec::new();
        for frame in 1..=FRAMES {
            let turn = drape::scenes::garment_rotation(frame as f32 / 60.0);
            if deforming {
                let world: Vec<Vec3> = scene.mesh.vertices.iter().map(|v| turn * *v).collect();
                sim.set_collider_vertices(body, &world).unwrap();
            } else {
                sim.set_collider_pose(body, turn, Vec3::ZERO).unwrap();
            }
            sim.step().unwrap();
            spins.push(spin_about_vertical(&sim.positions(CLOTH).unwrap(), &sim.velocities(CLOTH).unwrap()));
        }
        // The mean over the last third: the skirt has landed and turns with the body.
        spins[2 * FRAMES as usize / 3..].iter().sum::<f32>() / (FRAMES / 3) as f32
    };
    let rate = drape::scenes::garment_rotation(1.0).to_axis_angle().1;
    let (by_pose, by_vertices) = (spin(false), spin(true));
    println!(
        "skirt's spin over the last {} frames: by pose {by_pose:.3} rad/s, by vertices {by_vertices:.3} (body {rate:.3})",
        FRAMES / 3
    );
    assert_alike_by_pose_and_vertices("skirt's spin (rad/s)", (by_pose, by_vertices), rate, (0.5, 0.1));
    assert_validation_clean(&ctx);
}

/// A collider set far from where the last frame left it (here a triangle lifted 50 m through
/// the hanging cloth in one frame, as a teleport or a mesh sequence's jump does) sweeps the
/// cloth with it and tears it apart: the blow-up's message names that collider and its speed,
/// not the cloth's own motion (which was zero).
#[test]
fn a_collider_jumping_through_the_cloth_is_named_in_the_blow_up() {
    let ctx = context();
    let cloth = drape::scenes::swinging_cloth(8).build().unwrap();
    let triangle = drape::Mesh {
        vertices: vec![Vec3::new(0.0, 0.1, 0.0), Vec3::new(1.0, 0.1, 0.0), Vec3::new(0.0, 0.1, 1.0)],
        triangles: vec![[0, 1, 2]],
    };
    let collider = Collider::mesh(&triangle, 0.005);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap();
    let mut sim = Solver::new(&ctx, &model).unwrap();
    sim.set_collider_pose(ColliderId::new(0), Quat::IDENTITY, Vec3::new(0.0, 50.0, 0.0)).unwrap();
    let error = sim.step().expect_err("a collider lifted 50 m through the cloth in a frame must tear it").to_string();
    assert!(error.contains("collider 0 (the model's, counted from 0) moved its surface at up to 3.0"), "{error}");
    assert!(error.contains("Move it less per frame"), "{error}");
    assert_validation_clean(&ctx);
}

/// A turntable of eight large triangles (a fan of 1.5 m radius) spinning at 2 rad/s under a
/// resting cloth, turned by its vertices or by its pose: friction spins the cloth alike either
/// way, within a twentieth of the table's rate. A point of a triangle moves as its corners'
/// mix: a rigid turn's velocity is linear in the point, so the mix is exact, where the
/// triangle's centroid's velocity (what the contact took before) is off by the turn times the
/// point's distance from the centroid, up to about 1.8 m/s at these triangles' corners.
#[test]
fn a_turntable_turned_by_its_vertices_spins_the_cloth_as_one_turned_by_its_pose() {
    const RATE: f32 = 2.0; // rad/s about +y, from frame SETTLE on
    const SETTLE: u32 = 15;
    const FRAMES: u32 = 75;
    let ctx = context();
    let mut vertices = vec![Vec3::ZERO];
    vertices.extend((0..8).map(|k| {
        let a = std::f32::consts::TAU * k as f32 / 8.0;
        Vec3::new(1.5 * a.cos(), 0.0, 1.5 * a.sin())
    }));
    let triangles: Vec<[u32; 3]> = (0..8).map(|k| [0, 1 + (k + 1) % 8, 1 + k]).collect();
    let table = drape::Mesh { vertices, triangles };
    let cloth = ClothBuilder::new(12, 12).transform(Mat4::from_translation(Vec3::new(0.2, 0.02, 0.1))).build().unwrap();
    let collider = Collider::mesh(&table, 0.005).with_friction(0.8);
    let settings = SimSettings::default().with_timestamps(false);
    let model = Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap();
    let turn = |f: u32| Quat::from_rotation_y(RATE * f.saturating_sub(SETTLE) as f32 / 60.0);
    let spin = |deforming: bool| {
        let mut sim = Solver::new(&ctx, &model).unwrap();
        let mut spins = Vec::new();
        for f in 1..=FRAMES {
            if deforming {
                let world: Vec<Vec3> = table.vertices.iter().map(|v| turn(f) * *v).collect();
                sim.set_collider_vertices(ColliderId::new(0), &world).unwrap();
            } else {
                sim.set_collider_pose(ColliderId::new(0), turn(f), Vec3::ZERO).unwrap();
            }
            sim.step().unwrap();
            spins.push(spin_about_vertical(&sim.positions(CLOTH).unwrap(), &sim.velocities(CLOTH).unwrap()));
        }
        spins[FRAMES as usize - 20..].iter().sum::<f32>() / 20.0
    };
    let (by_pose, by_vertices) = (spin(false), spin(true));
    println!("turntable at {RATE} rad/s: the cloth spins at {by_pose:.3} rad/s by pose, {by_vertices:.3} by vertices");
    assert_alike_by_pose_and_vertices("turntable's cloth spin (rad/s)", (by_pose, by_vertices), RATE, (0.9, 0.05));
    assert_validation_clean(&ctx);
}
