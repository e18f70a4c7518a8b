//! Triangle contact in whole scenes: the standard drape scene settles on the true surface of
//! scanned and procedural meshes with no particle inside at any time; contact never adds
//! energy; particles shot at a closed mesh from every direction at up to 20 m/s never get in.

mod common;

use common::{Rng, assert_validation_clean, context};
use drape::metrics::{TriangleBvh, accuracy_on_triangles};
use drape::reference::energy;
use drape::scenes::{DrapeScene, SETTLE_FRAMES, shared_model};
use drape::{ClothBuilder, ClothId, Collider, CpuSolver, Mesh, Model, SimSettings, Solver};
use glam::{Mat4, Quat, Vec3, Vec4Swizzles};

const CLOTH: ClothId = ClothId::new(0);

/// A shared model, failing with where it looked when it is missing.
fn shared(file: &str) -> Mesh {
    let path = shared_model(file);
    assert!(path.exists(), "{} not found: this test needs ../shared/models beside the repository", path.display());
    Mesh::load_obj(&path).unwrap()
}

/// The standard scene (64 x 64 cloth, 2 s, thickness 5 mm) with triangle contact on the
/// bunny (its base holes closed), the dragon (back-to-back duplicate faces), an icosphere, a
/// torus and a 1 cm plate: at every 10th frame no particle is inside the mesh, and at 2 s the
/// resting particles' mean gap to the true surface is within [0.5, 1.5] x thickness.
#[test]
fn the_drape_scene_settles_on_the_true_surface_of_every_mesh() {
    let ctx = context();
    let meshes = [
        ("bunny", shared("stanford-bunny.obj")),
        ("dragon", shared("stanford-dragon-res2.obj")),
        ("icosphere", Mesh::icosphere(0.5, 3)),
        ("torus", Mesh::torus(0.35, 0.12, 48, 24)),
        ("plate", common::slab(Vec3::new(1.0, 0.01, 0.6))),
    ];
    for (name, mesh) in meshes {
        let mut scene = DrapeScene::standard(&mesh, 64);
        scene.mesh = scene.mesh.close_small_holes().0;
        let bvh = TriangleBvh::new(&scene.mesh);
        assert!(bvh.is_closed(), "{name}: inside must be defined");
        let cloth = scene.cloth.build().unwrap();
        let model = Model::single(&cloth, &[scene.triangle_collider()], SimSettings::default().with_timestamps(false));
        let mut sim = Solver::new(&ctx, &model.unwrap()).unwrap();
        let p = *sim.params(CLOTH).unwrap();
        for frame in 1..=SETTLE_FRAMES {
            sim.step().unwrap();
            if frame % 10 == 0 {
                let x = sim.positions(CLOTH).unwrap();
                let a = accuracy_on_triangles(&bvh, scene.thickness, (p.rows, p.cols, p.rest.x, p.rest.y), &x);
                assert!(a.all_finite, "{name}, frame {frame}: {a:?}");
                assert_eq!(a.inside_fraction, 0.0, "{name}, frame {frame}: particles inside: {a:?}");
                if frame == SETTLE_FRAMES {
                    println!("{name}: {a:?}");
                    let t = scene.thickness;
                    assert!(a.resting > 100, "{name}: only {} particles rest on the mesh", a.resting);
                    assert!((0.5 * t..=1.5 * t).contains(&a.gap_mean), "{name}: resting gap {} m", a.gap_mean);
                }
            }
        }
    }
    assert_validation_clean(&ctx);
}

/// Contact is inelastic along the normal and Coulomb friction only removes tangential speed: a
/// damped cloth thrown at a tilted plane, with and without friction, never gains energy
/// (kinetic + gravitational + spring) from one frame to the next, and ends on the plane's side
/// it came from.
#[test]
fn contact_never_adds_energy() {
    let ctx = context();
    let tilt = Quat::from_rotation_z(0.35);
    let h = 4.0; // the cloth stays over it, sliding without friction
    let plane = Mesh {
        vertices: [(-h, -h), (h, -h), (h, h), (-h, h)].map(|(x, z)| tilt * Vec3::new(x, 0.0, z)).to_vec(),
        triangles: vec![[0, 2, 1], [0, 3, 2]],
    };
    let up = tilt * Vec3::Y;
    for friction in [0.0, 0.5] {
        let cloth = ClothBuilder::new(16, 16)
            .size(0.5)
            .spring_damping(0.005)
            .velocity_damping(0.0005)
            .velocity(Vec3::new(0.5, -2.0, 0.0))
            .transform(Mat4::from_translation(up * 0.1))
            .build()
            .unwrap();
        let collider = Collider::mesh(&plane, 0.005).with_friction(friction);
        let model = Model::single(&cloth, &[collider], SimSettings::default().with_timestamps(false)).unwrap();
        let mut sim = Solver::new(&ctx, &model).unwrap();
        let mut previous = energy(&cloth, &cloth.positions, &cloth.velocities);
        let mut contacts = 0;
        for frame in 0..90 {
            let report = sim.step_report().unwrap();
            let (x, v) = (sim.positions(CLOTH).unwrap(), sim.velocities(CLOTH).unwrap());
            let e = energy(&cloth, &x, &v);
            // f32 positions carry ~1e-7 relative rounding into the potential energy.
            let slack = 1e-6 * previous.abs().max(1e-3);
            assert!(e <= previous + slack, "friction {friction}, frame {frame}: energy rose from {previous} to {e} J");
            previous = e;
            let lowest = x.iter().map(|p| p.xyz().dot(up)).fold(f32::INFINITY, f32::min);
            assert!(lowest > 0.0025, "friction {friction}, frame {frame}: a particle {lowest} m from the plane");
            contacts += (lowest < 0.006) as u32 * report.collision_ran;
        }
        assert!(contacts > 0, "friction {friction}: the cloth must reach the plane");
    }
    assert_validation_clean(&ctx);
}

/// Free particles (a cloth with no springs) shot from all around at a closed mesh at up to
/// 20 m/s (up to 33 cm per substep, ~0.7 x the mesh's size), re-aimed every 10 frames, never end
/// inside it, and the GPU equals the CPU twin: no path crosses the surface.
#[test]
fn particles_shot_at_a_mesh_never_get_inside() {
    let ctx = context();
    let mut rng = Rng::new(41);
    let mesh = drape::scenes::default_mesh(); // icosphere, radius 0.5
    let torus = Mesh::torus(0.35, 0.12, 48, 24);
    for (name, mesh) in [("icosphere", mesh), ("torus", torus)] {
        let bvh = TriangleBvh::new(&mesh);
        // Springs without stiffness or damping, 100 m long (their health check never sees a
        // stretch), no velocity damping: each particle flies on its own.
        let cloth = ClothBuilder::new(24, 24)
            .size(2400.0)
            .stiffness(0.0, 0.0, 0.0)
            .spring_damping(0.0)
            .velocity_damping(0.0)
            .gravity(Vec3::ZERO)
            .build()
            .unwrap();
        let model =
            Model::single(&cloth, &[Collider::mesh(&mesh, 0.005)], SimSettings::default().with_timestamps(false))
                .unwrap();
        let mut gpu = Solver::new(&ctx, &model).unwrap();
        let mut cpu = CpuSolver::new(&model).unwrap();
        let n = 24 * 24;
        let substeps = gpu.stability(CLOTH).unwrap().substeps;
        assert!(substeps <= 2, "{name}: {substeps} substeps: the motions must be long");
        let mut touching = 0;
        for round in 0..6 {
            // Start on a sphere of radius 1 around the mesh, aimed at a point near a random vertex.
            let mut x = Vec::with_capacity(n);
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                let dir =
                    Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::X);
                let vertex = mesh.vertices[rng.next_u32() as usize % mesh.vertices.len()];
                let aim = vertex + Vec3::new(rng.range(-0.05, 0.05), rng.range(-0.05, 0.05), rng.range(-0.05, 0.05));
                let from = dir * 1.0;
                x.push(from);
                v.push((aim - from).normalize_or(Vec3::X) * rng.range(1.0, 20.0));
            }
            gpu.teleport(CLOTH, &x, &v).unwrap();
            cpu.teleport(CLOTH, &x, &v).unwrap();
            for frame in 0..10 {
                gpu.step().unwrap();
                cpu.step().unwrap();
                let positions = gpu.positions(CLOTH).unwrap();
                let diff = common::max_distance(&positions, &cpu.positions(CLOTH).unwrap());
                assert!(diff <= 1e-4, "{name}, round {round}, frame {frame}: GPU and CPU differ by {diff}");
                let inside = positions.iter().filter(|p| bvh.is_inside(p.xyz())).count();
                assert_eq!(inside, 0, "{name}, round {round}, frame {frame}: particles inside");
                touching += positions.iter().filter(|p| bvh.closest_point(p.xyz()).0 < 0.0075).count();
            }
        }
        assert!(touching > 2 * n, "{name}: only {touching} particle-frames at the surface: the shots must hit");
    }
    assert_validation_clean(&ctx);
}
