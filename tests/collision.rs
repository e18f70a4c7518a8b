//! LBVH build on the GPU (radix sort, Karras nodes, bottom-up boxes) against its CPU twin and
//! the tree invariants, and cloth-collider contact: GPU = CPU, BVH = brute force, culling.

mod common;

use common::{Rng, assert_validation_clean, context};
use drape::lbvh::{GpuLbvh, Lbvh, build_cpu, collider_params};
use drape::{ClothBuilder, ClothId, Collider, ColliderId, CpuSolver, Model, SimSettings, Solver};
use drape_kernels::contact::{brute_force, traverse};
use drape_kernels::spheres::Spheres;
use drape_types::{BvhNode, ColliderParams, LEAF_BIT};
use glam::{Mat4, Vec3, Vec4};

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

fn random_spheres(rng: &mut Rng, n: usize, spread: f32) -> Vec<Vec4> {
    (0..n)
        .map(|_| {
            Vec4::new(
                rng.range(-spread, spread),
                rng.range(-spread, spread),
                rng.range(-spread, spread),
                rng.range(0.01, 0.1),
            )
        })
        .collect()
}

/// GPU-built trees for many inputs: valid, and identical to the CPU twin (same sort order,
/// same nodes, bit-identical boxes).
#[test]
fn gpu_lbvh_is_valid_and_equals_the_cpu_twin() {
    let ctx = context();
    let mut rng = Rng::new(7);
    let mut inputs: Vec<(String, Vec<Vec4>)> = Vec::new();
    for n in [1usize, 2, 3, 4, 5, 17, 255, 256, 257, 1000, 4097, 20_000] {
        inputs.push((format!("random {n}"), random_spheres(&mut rng, n, 1.0)));
    }
    // All-equal Morton codes (every centre identical): Karras' index fallback must still give a
    // valid tree.
    for n in [2usize, 3, 64, 1000] {
        inputs.push((format!("all equal {n}"), vec![Vec4::new(0.5, 0.5, 0.5, 0.1); n]));
    }
    // Many duplicates: points on a coarse lattice.
    let lattice: Vec<Vec4> =
        (0..3000).map(|i| Vec4::new((i % 3) as f32, ((i / 3) % 2) as f32, 0.0, 0.05 + (i % 7) as f32 * 0.01)).collect();
    inputs.push(("lattice duplicates".into(), lattice));
    // A flat collider (zero extent in y).
    inputs.push(("flat".into(), (0..500).map(|i| Vec4::new((i % 25) as f32, 0.0, (i / 25) as f32, 0.5)).collect()));
    for (name, spheres) in &inputs {
        let gpu = GpuLbvh::build(&ctx, spheres, 0.01).unwrap();
        let tree = gpu.download().unwrap();
        tree.validate(spheres).unwrap_or_else(|e| panic!("{name}: {e}"));
        let cpu = build_cpu(spheres, &gpu.params).unwrap();
        cpu.validate(spheres).unwrap_or_else(|e| panic!("{name} (cpu): {e}"));
        assert_eq!(tree, cpu, "{name}: GPU and CPU trees differ");
        // The radix sort is a stable sort by Morton code.
        let mut expected: Vec<u32> = (0..spheres.len() as u32).collect();
        expected.sort_by_key(|&i| cpu.codes[cpu.order.iter().position(|&o| o == i).unwrap()]);
        assert_eq!(tree.order, expected, "{name}: sort is not stable");
    }
    assert_validation_clean(&ctx);
}

/// A random key set of 100k: sorted codes equal std's sort.
#[test]
fn gpu_radix_sort_sorts_100k_keys() {
    let ctx = context();
    let mut rng = Rng::new(11);
    let spheres = random_spheres(&mut rng, 100_000, 10.0);
    let gpu = GpuLbvh::build(&ctx, &spheres, 0.0).unwrap();
    let tree = gpu.download().unwrap();
    let params = collider_params(&spheres, 0.0, 0.0).unwrap();
    let mut codes: Vec<u32> = spheres
        .iter()
        .map(|s| {
            drape_kernels::lbvh::morton_code(s.truncate(), params.scene_min.truncate(), params.scene_max.truncate())
        })
        .collect();
    codes.sort_unstable();
    assert_eq!(tree.codes, codes);
    tree.validate(&spheres).unwrap();
    assert_validation_clean(&ctx);
}

/// The BVH traversal finds exactly the contact a loop over all spheres finds, for random
/// segments against random sphere sets (kernel functions, run on the CPU).
#[test]
fn bvh_traversal_finds_the_brute_force_contacts() {
    let mut rng = Rng::new(3);
    let mut contacts = 0;
    for n in [1usize, 2, 3, 50, 2000] {
        let spheres = random_spheres(&mut rng, n, 1.0);
        let params = collider_params(&spheres, 0.02, 0.0).unwrap();
        let tree = build_cpu(&spheres, &params).unwrap();
        for _ in 0..2000 {
            let p1 = Vec3::new(rng.range(-1.2, 1.2), rng.range(-1.2, 1.2), rng.range(-1.2, 1.2));
            let p0 = p1 + Vec3::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), rng.range(-0.1, 0.1));
            contacts += traversal_hits_as_brute_force(&params, &tree, (p0, p1), &format!("n {n}")) as u32;
        }
    }
    assert!(contacts > 400, "only {contacts} contacts: the test must exercise hits");
}

/// A deep, lopsided tree is walked completely: spheres at 1 - 2^-k along three edges of a unit
/// cube (where codes differ in one more bit, one more leaf splits off: combs as deep as the
/// codes' 10 bits an axis allow) and 300 spheres sharing its far corner (equal codes, split by
/// index below them): 21 levels, over twice a balanced tree's 9. The walk has no stack to run
/// out of: its escapes check out against a depth-first walk with a stack (`validate`), and
/// every segment finds the contact a loop over all spheres finds.
#[test]
fn a_deep_lopsided_tree_is_walked_completely() {
    let comb = |k: u32| 1.0 - (-(k as f32)).exp2();
    let mut spheres: Vec<Vec4> = (0..12).map(|k| Vec4::new(comb(k), 0.0, 0.0, 0.004)).collect();
    spheres.extend((0..12).map(|k| Vec4::new(1.0, comb(k), 0.0, 0.004)));
    spheres.extend((0..12).map(|k| Vec4::new(1.0, 1.0, comb(k), 0.004)));
    spheres.extend((0..300).map(|k| Vec4::new(1.0, 1.0, 1.0, 0.001 + 1e-5 * k as f32)));
    let params = collider_params(&spheres, 0.001, 0.0).unwrap();
    let tree = build_cpu(&spheres, &params).unwrap();
    tree.validate(&spheres).unwrap();
    let (depth, balanced) = (tree_depth(&tree.nodes, 0), spheres.len().ilog2() + 1);
    assert!(depth > 2 * balanced, "the tree must be deep: {depth} levels, a balanced one {balanced}");
    let mut rng = Rng::new(11);
    let mut contacts = 0;
    for k in 0..2000 {
        // Along each comb, and a quarter of the segments at the shared point.
        let along = if k % 4 == 3 { 1.0 } else { rng.range(0.0, 1.0) };
        let on_line = match k % 4 {
            0 => Vec3::new(along, 0.0, 0.0),
            1 => Vec3::new(1.0, along, 0.0),
            2 => Vec3::new(1.0, 1.0, along),
            _ => Vec3::ONE,
        };
        let p1 = on_line + Vec3::new(rng.range(-0.005, 0.005), rng.range(-0.005, 0.005), rng.range(-0.005, 0.005));
        let p0 = p1 + Vec3::new(rng.range(-0.01, 0.01), rng.range(-0.005, 0.005), rng.range(-0.005, 0.005));
        contacts += traversal_hits_as_brute_force(&params, &tree, (p0, p1), "deep tree") as u32;
    }
    assert!(contacts > 100, "only {contacts} contacts: the test must exercise hits");
}

/// Checks that the traversal of `tree` finds the contact of `p0 -> p1` a loop over all its
/// spheres finds; returns whether there is one.
fn traversal_hits_as_brute_force(params: &ColliderParams, tree: &Lbvh, (p0, p1): (Vec3, Vec3), case: &str) -> bool {
    let bvh = traverse::<Spheres>(params, &tree.nodes, &tree.aabbs, &tree.spheres, p0, p1);
    let brute = brute_force::<Spheres>(params, &tree.spheres, p0, p1);
    assert_eq!((bvh.t, bvh.leaf), (brute.t, brute.leaf), "{case}: p0 {p0}, p1 {p1}");
    brute.t <= 1.0
}

/// Levels below internal node `node` (a leaf child counts one).
fn tree_depth(nodes: &[BvhNode], node: u32) -> u32 {
    let child = |c: u32| if c & LEAF_BIT != 0 { 1 } else { 1 + tree_depth(nodes, c) };
    child(nodes[node as usize].left).max(child(nodes[node as usize].right))
}

fn ball_collider() -> Collider {
    let mesh_like: Vec<Vec4> = {
        // A 0.3 m ball made of 7 x 7 x 7 small spheres (a collider with many leaves).
        let mut s = Vec::new();
        for i in 0..7 {
            for j in 0..7 {
                for k in 0..7 {
                    let p = Vec3::new(i as f32, j as f32, k as f32) / 6.0 * 0.6 - 0.3;
                    if p.length() <= 0.3 {
                        s.push(p.extend(0.06));
                    }
                }
            }
        }
        s
    };
    Collider::new(mesh_like, 0.005)
}

fn draped_cloth() -> drape::Cloth {
    ClothBuilder::new(24, 24).size(1.0).transform(Mat4::from_translation(Vec3::new(0.0, 0.45, 0.0))).build().unwrap()
}

/// Cloth falling onto a sphere collider: the GPU equals its CPU twin, and the BVH pass equals
/// the brute-force pass, frame by frame.
#[test]
fn collision_gpu_equals_cpu_and_bvh_equals_brute_force() {
    let ctx = context();
    let cloth = draped_cloth();
    let collider = ball_collider();
    let brute = collider.clone().brute_force();
    let settings = SimSettings::default();
    let mut gpu =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    let mut gpu_brute =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&brute), settings).unwrap()).unwrap();
    let mut cpu = CpuSolver::new(&Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    let mut ran = 0;
    for frame in 0..40 {
        let report = gpu.step_report().unwrap();
        ran += report.collision_ran;
        gpu_brute.step().unwrap();
        cpu.step().unwrap();
        let (a, b, c) =
            (gpu.positions(CLOTH).unwrap(), gpu_brute.positions(CLOTH).unwrap(), cpu.positions(CLOTH).unwrap());
        assert_eq!(a, b, "frame {frame}: BVH and brute force disagree");
        let diff = common::max_distance(&a, &c);
        assert!(diff <= 1e-5, "frame {frame}: GPU and CPU differ by {diff}");
    }
    assert!(ran > 0, "the traversal must have run");
    // The cloth rests on the ball: the centre particle sits on top, not fallen through.
    let x = gpu.positions(CLOTH).unwrap();
    let centre = x[12 * 24 + 12].truncate();
    let top = 0.3 + 0.06 + 0.005;
    assert!(centre.y > top - 0.02 && centre.y < top + 0.05, "centre particle at {centre}");
    let tree = gpu.collider_bvh(ColliderId::new(0)).unwrap();
    tree.validate(collider.spheres()).unwrap();
    drop((gpu, gpu_brute));
    assert_validation_clean(&ctx);
}

/// Skipping: without a collider no collision pass is recorded (and the timing table says so);
/// with a collider far from the cloth every substep counts as skipped (no particle listed near
/// it, so only particles that leave their query box would walk the tree).
#[test]
fn collision_work_is_skipped_when_not_needed() {
    let ctx = context();
    let cloth = draped_cloth();
    let mut plain = Solver::new(&ctx, &Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    let timings = plain.step().unwrap();
    assert!(timings.skipped.contains(&"contact"));
    assert!(timings.passes.iter().all(|p| !p.label.starts_with("contact")));

    let far = Collider::new(vec![Vec4::new(50.0, -50.0, 0.0, 1.0), Vec4::new(52.0, -50.0, 0.0, 1.0)], 0.01);
    let mut sim =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&far), SimSettings::default()).unwrap()).unwrap();
    let substeps = sim.stability(CLOTH).unwrap().substeps;
    for _ in 0..5 {
        let report = sim.step_report().unwrap();
        assert_eq!((report.collision_ran, report.collision_skipped), (0, substeps));
    }
    let near = ball_collider();
    let mut sim =
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&near), SimSettings::default()).unwrap())
            .unwrap();
    let mut ran = 0;
    for _ in 0..30 {
        ran += sim.step_report().unwrap().collision_ran;
    }
    assert!(ran > 0);
    assert_validation_clean(&ctx);
}

/// Bad colliders are errors when the model is built (before anything reaches the GPU), not
/// panics.
#[test]
fn invalid_colliders_are_errors() {
    let cloth = draped_cloth();
    for (what, collider) in [
        ("empty", Collider::new(vec![], 0.01)),
        ("NaN centre", Collider::new(vec![Vec4::new(f32::NAN, 0.0, 0.0, 1.0)], 0.01)),
        ("negative thickness", Collider::new(vec![Vec4::new(0.0, 0.0, 0.0, 1.0)], -1.0)),
    ] {
        let result = Model::single(&cloth, std::slice::from_ref(&collider), SimSettings::default());
        assert!(matches!(result, Err(drape::Error::InvalidParameter { .. })), "{what}");
    }
}

/// The standard drape scene on a procedural mesh, settled for 2 s: no particle ends inside the
/// true mesh, the cloth rests on the collider, and finer voxels hold it closer to the surface.
#[test]
fn draped_cloth_rests_outside_the_true_mesh_and_finer_voxels_hug_it() {
    use drape::metrics::{TriangleBvh, accuracy};
    use drape::scenes::{DrapeScene, SETTLE_FRAMES, default_mesh};
    let ctx = context();
    let scene = DrapeScene::standard(&default_mesh(), 24);
    let bvh = TriangleBvh::new(&scene.mesh);
    let cloth = scene.cloth.build().unwrap();
    let mut gaps = Vec::new();
    for n in [3, 12] {
        let collider = scene.collider(n).unwrap();
        let mut sim =
            Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&collider), SimSettings::default()).unwrap())
                .unwrap();
        for _ in 0..SETTLE_FRAMES {
            sim.step().unwrap();
        }
        let x = sim.positions(CLOTH).unwrap();
        let p = *sim.params(CLOTH).unwrap();
        let a = accuracy(&bvh, collider.spheres(), collider.thickness, p.rows, p.cols, p.rest.x, p.rest.y, &x);
        println!("n = {n}: {a:?}");
        assert!(a.all_finite);
        assert_eq!(a.inside_fraction, 0.0, "n = {n}: particles inside the mesh");
        assert!(a.resting > 20, "n = {n}: only {} particles rest on the collider", a.resting);
        assert!(a.max_stretch < 1.3, "n = {n}: stretch {}", a.max_stretch);
        gaps.push(a.gap_mean);
    }
    assert!(gaps[1] < gaps[0], "finer voxels must hold the cloth closer: gaps {gaps:?}");
    assert_validation_clean(&ctx);
}

/// Friction keeps cloth on a round collider that it slides off without friction.
#[test]
fn friction_holds_the_cloth_on_the_collider() {
    use drape::scenes::{DrapeScene, SETTLE_FRAMES, default_mesh};
    let ctx = context();
    let scene = DrapeScene::standard(&default_mesh(), 16);
    let mut cloth = scene.cloth.build().unwrap();
    // Break the symmetry a little so the frictionless cloth has a direction to slide in.
    for p in &mut cloth.positions {
        p.x += 0.05;
    }
    let mut highest = Vec::new();
    for friction in [0.0, 0.6] {
        let mut collider = scene.collider(6).unwrap();
        collider.friction = friction;
        let mut sim =
            Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&collider), SimSettings::default()).unwrap())
                .unwrap();
        for _ in 0..SETTLE_FRAMES {
            sim.step().unwrap();
        }
        let x = sim.positions(CLOTH).unwrap();
        highest.push(x.iter().map(|p| p.y).fold(f32::NEG_INFINITY, f32::max));
    }
    // The highest particle: on the collider's top with friction, far below it without.
    assert!(
        highest[1] > 0.5 && highest[0] < highest[1] - 0.2,
        "highest particle: frictionless {}, friction {}",
        highest[0],
        highest[1]
    );
    assert_validation_clean(&ctx);
}
