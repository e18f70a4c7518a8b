//! The broad phase once per frame and the narrow phase over candidate lists give exactly the
//! contacts of a full search: against brute force for single particles (kernel functions on the
//! CPU, triangles and spheres, with motions that stay in their query box, leave it, and lists
//! that overflow), and whole GPU frames equal the LBVH walk every substep and the CPU twin.

mod common;

use common::{Rng, assert_fused_contact_equals_walk_and_cpu, assert_validation_clean, context};
use drape::lbvh::{Lbvh, build_cpu, build_mesh_cpu, collider_params, mesh_collider_params};
use drape::{Cloth, ClothBuilder, ClothId, Collider, ContactSearch, CpuSolver, Mesh, Model, SimSettings, Solver};
use drape_kernels::candidates::{NarrowOutcome, broad_phase_at, detect_candidates_at};
use drape_kernels::contact::{LeafKind, detect_brute_force_at};
use drape_kernels::pose::SubstepMotion;
use drape_kernels::spheres::Spheres;
use drape_kernels::triangles::Triangles;
use drape_types::{
    CANDIDATES_OVERFLOWED, ColliderParams, ColliderPose, Contact, ContactQuery, MAX_CANDIDATES, SimParams,
};
use glam::{Mat4, Vec3, Vec4};

const CLOTH: ClothId = ClothId::new(0);
const FRAME: f32 = 1.0 / 60.0;
const SUBSTEPS: u32 = 10;

/// What happened over many particles.
#[derive(Default, Debug)]
struct Tally {
    contacts: u32,
    from_list: u32,
    fell_back: u32,
    overflowed_lists: u32,
}

/// Runs the broad phase for a particle at `x` with velocity `v` (frame start), then the narrow
/// phase for one substep `p0 -> p1`, and checks it against the brute-force detect.
#[allow(clippy::too_many_arguments)]
fn check_particle<K: LeafKind>(
    params: &ColliderParams,
    tree: &Lbvh,
    leaves: &[K::Leaf],
    (x, v): (Vec3, Vec3),
    (p0, p1): (Vec3, Vec3),
    tally: &mut Tally,
    case: usize,
) {
    let sim = SimParams { gravity: Vec4::new(0.0, -9.81, 0.0, 0.0), particle_count: 1, ..Default::default() };
    let frame = SubstepMotion::of(&ColliderPose::default(), 0.0, 1.0, FRAME);
    let mut queries = [ContactQuery::default()];
    let mut candidates = vec![0u32; MAX_CANDIDATES as usize];
    let tree_in = (tree.nodes.as_slice(), tree.aabbs.as_slice(), tree.leaf_bounds.as_slice(), leaves);
    broad_phase_at::<K>(
        0,
        &sim,
        params,
        &frame,
        tree_in,
        (&[x.extend(1.0)], &[v.extend(0.0)]),
        &mut queries,
        &mut candidates,
    );
    let substep = SubstepMotion::of(&ColliderPose::default(), 0.0, 1.0, FRAME / SUBSTEPS as f32);
    let (xs, x_prev) = ([p1.extend(1.0)], [p0.extend(1.0)]);
    let (mut listed, mut brute) = ([Contact::NONE], [Contact::NONE]);
    let outcome: NarrowOutcome = detect_candidates_at::<K>(
        0,
        params,
        &substep,
        (&tree.nodes, &tree.aabbs, leaves),
        (&queries, &candidates),
        (&xs, &x_prev),
        &mut listed,
        (0, false),
    );
    detect_brute_force_at::<K>(0, params, &substep, leaves, &xs, &x_prev, &mut brute);
    assert_eq!(listed[0], brute[0], "case {case}: {p0} -> {p1} (x {x}, v {v}), {outcome:?}");
    tally.contacts += brute[0].is_some() as u32;
    tally.fell_back += outcome.fell_back as u32;
    tally.from_list += !outcome.fell_back as u32;
    tally.overflowed_lists += (queries[0].count == CANDIDATES_OVERFLOWED) as u32;
}

/// A particle near `surface`'s point with velocity up to 3 m/s, and one substep of its frame:
/// usually the predicted one with a little jitter (stays in the box), sometimes pushed off the
/// prediction (leaves it).
fn frame_and_substep(rng: &mut Rng, near: Vec3, i: usize) -> ((Vec3, Vec3), (Vec3, Vec3)) {
    let mut random = |scale: f32| Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale;
    let x = near + random(0.03);
    let v = random([0.0, 0.05, 0.5, 3.0][i % 4]);
    let k = (i / 4 % SUBSTEPS as usize) as f32;
    let h = FRAME / SUBSTEPS as f32;
    let p0 = x + v * (k * h) + random(1e-4);
    let off = if i.is_multiple_of(7) { random(0.05) } else { random(1e-4) };
    let p1 = p0 + v * h + Vec3::new(0.0, -9.81 * h * h, 0.0) + off;
    ((x, v), (p0, p1))
}

/// Triangles: a torus (some particles start within the thickness, some paths are blocked), and
/// a dense patch whose lists overflow.
#[test]
fn candidate_lists_give_the_brute_force_triangle_contacts() {
    let mut tally = Tally::default();
    let mut rng = Rng::new(91);
    for (mesh, thickness) in [(Mesh::torus(0.35, 0.12, 32, 16), 0.01), (Mesh::torus(0.35, 0.12, 256, 128), 0.02)] {
        let params = mesh_collider_params(&mesh.vertices, &mesh.triangles, thickness, 0.0).unwrap();
        let tree = build_mesh_cpu(&mesh.vertices, &mesh.triangles, &params).unwrap();
        for i in 0..12_000 {
            let angle = rng.range(0.0, std::f32::consts::TAU);
            let ring = Vec3::new(angle.cos(), 0.0, angle.sin()) * 0.35;
            let dir = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::Y);
            let near = ring + dir * 0.12;
            let (state, motion) = frame_and_substep(&mut rng, near, i);
            check_particle::<Triangles>(&params, &tree, &tree.triangles, state, motion, &mut tally, i);
        }
    }
    println!("{tally:?}");
    assert!(tally.contacts > 3_000, "{tally:?}: contacts must be exercised");
    assert!(tally.from_list > 10_000 && tally.fell_back > 2_000, "{tally:?}: both paths must be exercised");
    assert!(tally.overflowed_lists > 200, "{tally:?}: overflowing lists must be exercised");
}

/// Spheres: random sphere sets, the same motions.
#[test]
fn candidate_lists_give_the_brute_force_sphere_contacts() {
    let mut tally = Tally::default();
    let mut rng = Rng::new(17);
    for n in [1usize, 3, 2000] {
        let spheres: Vec<Vec4> = (0..n)
            .map(|_| Vec4::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), rng.range(0.01, 0.08)))
            .collect();
        let params = collider_params(&spheres, 0.01, 0.0).unwrap();
        let tree = build_cpu(&spheres, &params).unwrap();
        for i in 0..6_000 {
            let s = spheres[i % n];
            let near = s.truncate() + Vec3::X * s.w;
            let (state, motion) = frame_and_substep(&mut rng, near, i);
            check_particle::<Spheres>(&params, &tree, &tree.spheres, state, motion, &mut tally, i);
        }
    }
    println!("{tally:?}");
    assert!(tally.contacts > 2_000, "{tally:?}: contacts must be exercised");
    assert!(tally.from_list > 5_000 && tally.fell_back > 1_000, "{tally:?}: both paths must be exercised");
}

/// A cloth thrown at a torus (so particles outrun their query boxes, and the lists of a dense
/// mesh overflow): every frame of the list search on the GPU equals the LBVH walk every
/// substep, the brute-force loop, and the CPU twin, bit for bit.
#[test]
fn candidate_lists_frames_equal_the_full_search_on_the_gpu() {
    let ctx = context();
    let cloth = ClothBuilder::new(24, 24)
        .size(0.9)
        .velocity(Vec3::new(0.0, -4.0, 0.0))
        .transform(Mat4::from_translation(Vec3::new(0.05, 0.3, 0.0)))
        .build()
        .unwrap();
    let collider = Collider::mesh(&Mesh::torus(0.35, 0.12, 192, 96), 0.01).with_friction(0.3);
    let settings = SimSettings::default().with_timestamps(false);
    let solver = |search: ContactSearch| {
        let c = collider.clone().with_search(search);
        Solver::new(&ctx, &Model::single(&cloth, std::slice::from_ref(&c), settings).unwrap()).unwrap()
    };
    let mut lists = solver(ContactSearch::CandidateLists);
    let mut walk = solver(ContactSearch::TraverseEverySubstep);
    let mut brute = solver(ContactSearch::BruteForce);
    let mut cpu = CpuSolver::new(&Model::single(&cloth, std::slice::from_ref(&collider), settings).unwrap()).unwrap();
    let (mut fallbacks, mut contact_frames, mut listed_frames) = (0, 0, 0);
    for f in 1..=30 {
        let report = lists.step_report().unwrap();
        walk.step().unwrap();
        brute.step().unwrap();
        cpu.step().unwrap();
        fallbacks += report.collision_fallbacks;
        contact_frames += (report.collision_ran > 0) as u32;
        let x = lists.positions(CLOTH).unwrap();
        assert_eq!(x, walk.positions(CLOTH).unwrap(), "frame {f}: lists != LBVH walk");
        assert_eq!(x, brute.positions(CLOTH).unwrap(), "frame {f}: lists != brute force");
        assert_eq!(x, cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(lists.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(report.collision_fallbacks, cpu.collision_status().fallbacks, "frame {f}: fallback counts");
        assert_eq!(report.collision_listed, cpu.collision_status().listed, "frame {f}: listed particles");
        let counted = (report.collision_ran, report.collision_skipped);
        assert_eq!(counted, (cpu.collision_status().ran, cpu.collision_status().skipped), "frame {f}: substeps");
        listed_frames += (report.collision_listed > 0) as u32;
    }
    assert!(contact_frames > 10, "the cloth must reach the torus");
    // The list search has no culling pass (its narrow phase runs inside the last integration
    // stage, and a particle with an empty list that stays in its box tests nothing), while the
    // walk and brute-force searches test the cloth's bounds every substep: the same positions
    // above show that skipping the cull changes nothing.
    assert!(listed_frames > 10, "frames with listed particles must be exercised ({listed_frames} frames)");
    assert!(fallbacks > 0, "no particle left its query box: the fallback must be exercised");
    assert_validation_clean(&ctx);
}

/// Semi-implicit Euler's commit with the narrow phase inside it: every frame of a cloth falling
/// onto a mesh equals the LBVH walk's (commit, cull, detect and respond as passes of their own)
/// and the CPU twin, bit for bit.
#[test]
fn euler_commit_with_contact_equals_the_walk_and_the_cpu_twin() {
    let ctx = context();
    let cloth = ClothBuilder::new(16, 16)
        .size(0.8)
        .transform(Mat4::from_translation(Vec3::new(0.05, 0.4, 0.0)))
        .build()
        .unwrap();
    let collider = Collider::mesh(&Mesh::icosphere(0.3, 3), 0.01).with_friction(0.4);
    let settings = SimSettings::default().with_timestamps(false).with_integrator(drape::Integrator::SemiImplicitEuler);
    let contact_frames = assert_fused_contact_equals_walk_and_cpu(&ctx, &cloth, &collider, settings, 30);
    assert!(contact_frames > 10, "the cloth must reach the sphere ({contact_frames} frames)");
    assert_validation_clean(&ctx);
}

/// An `n` x `n` cloth thrown down at 4 m/s onto a dense torus (and `also`, when given): many
/// of its particles crowded by the leaves within their reach.
fn thrown_at_a_dense_torus(n: u32, also: Option<Collider>) -> (Cloth, Vec<Collider>) {
    let cloth = ClothBuilder::new(n, n)
        .size(0.9)
        .velocity(Vec3::new(0.0, -4.0, 0.0))
        .transform(Mat4::from_translation(Vec3::new(0.05, 0.3, 0.0)))
        .build()
        .unwrap();
    let torus = Collider::mesh(&Mesh::torus(0.35, 0.12, 192, 96), 0.01).with_friction(0.3);
    (cloth, std::iter::once(torus).chain(also).collect())
}

/// The scene with the crowded-contact setting `crowded` (`SimSettings::crowded_contact`).
fn with_crowded_contact(cloth: &Cloth, colliders: &[Collider], crowded: Option<bool>) -> Model {
    let settings = SimSettings::default().with_timestamps(false).with_crowded_contact(crowded);
    Model::single(cloth, colliders, settings).unwrap()
}

/// Crowded particles (lists of `CROWDED_LIST` leaves or more, and walks of the tree) handed
/// to a workgroup each give the contacts their lanes give, bit for bit: a cloth thrown at a
/// dense torus, with a dense icosphere as a second collider (whose narrow phase is a pass of
/// its own, not inside the last integration stage), on the GPU with the crowded pass
/// (`--crowded-contact on`), with the automatic choice (on lavapipe: counted, never handed
/// over; on a GPU: handed over while there are many) and without it, and on the CPU twin with
/// it. The automatic run counts the crowded particles the forced one hands over.
#[test]
fn crowded_particles_get_their_lanes_contacts_from_a_workgroup() {
    let ctx = context();
    let ball = Mesh::icosphere(0.15, 5).transformed(Mat4::from_translation(Vec3::new(0.0, -0.05, 0.0)));
    let (cloth, colliders) = thrown_at_a_dense_torus(24, Some(Collider::mesh(&ball, 0.01).with_friction(0.3)));
    let model = |crowded| with_crowded_contact(&cloth, &colliders, crowded);
    let mut shared = Solver::new(&ctx, &model(Some(true))).unwrap();
    let mut automatic = Solver::new(&ctx, &model(None)).unwrap();
    let mut alone = Solver::new(&ctx, &model(Some(false))).unwrap();
    let mut cpu = CpuSolver::new(&model(Some(true))).unwrap();
    let (mut crowded, mut fallbacks) = (0, 0);
    for f in 1..=30 {
        let report = shared.step_report().unwrap();
        let counted = automatic.step_report().unwrap();
        let lanes = alone.step_report().unwrap();
        cpu.step().unwrap();
        let x = shared.positions(CLOTH).unwrap();
        assert_eq!(x, alone.positions(CLOTH).unwrap(), "frame {f}: workgroups != lanes");
        assert_eq!(x, automatic.positions(CLOTH).unwrap(), "frame {f}: workgroups != the automatic choice");
        assert_eq!(x, cpu.positions(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(shared.velocities(CLOTH).unwrap(), alone.velocities(CLOTH).unwrap(), "frame {f}: velocities");
        assert_eq!(shared.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {f}: GPU != CPU");
        assert_eq!(report.collision_fallbacks, lanes.collision_fallbacks, "frame {f}: fallback counts");
        assert_eq!(report.collision_crowded, cpu.collision_status().crowded, "frame {f}: handed-over counts");
        assert_eq!(
            report.crowded_contacts, report.collision_crowded,
            "frame {f}: on, every crowded one is handed over"
        );
        assert_eq!(counted.crowded_contacts, report.collision_crowded, "frame {f}: the automatic choice's count");
        assert_eq!((lanes.collision_crowded, lanes.crowded_contacts), (0, 0), "frame {f}: off, none counted");
        crowded += report.collision_crowded;
        fallbacks += report.collision_fallbacks;
    }
    assert!(
        crowded > fallbacks && fallbacks > 0,
        "walks ({fallbacks}) and long lists ({crowded} in all) must be handed over"
    );
    assert_validation_clean(&ctx);
}

/// The automatic choice on a GPU (run here as on one, `Solver::new_as_gpu`) hands the crowded
/// particles over once a frame has many (the cloth lands on a dense torus) and stops once it
/// has few (the cloth is lifted a metre above it at frame 25), re-encoding the frame each time
/// (with passes bound at setup); every frame equals the run that never hands them over.
#[test]
fn the_automatic_choice_switches_the_crowded_pass_on_and_off_with_the_same_frames() {
    let ctx = context();
    let (cloth, torus) = thrown_at_a_dense_torus(32, None);
    let model = |crowded| with_crowded_contact(&cloth, &torus, crowded);
    let mut automatic = Solver::new_as_gpu(&ctx, &model(None)).unwrap();
    let mut alone = Solver::new(&ctx, &model(Some(false))).unwrap();
    let mut handed = Vec::new();
    for f in 1..=40 {
        if f == 25 {
            let lifted: Vec<Vec3> = alone.positions(CLOTH).unwrap().iter().map(|p| p.truncate() + Vec3::Y).collect();
            let still = vec![Vec3::ZERO; lifted.len()];
            automatic.teleport(CLOTH, &lifted, &still).unwrap();
            alone.teleport(CLOTH, &lifted, &still).unwrap();
        }
        let report = automatic.step_report().unwrap();
        alone.step().unwrap();
        assert_eq!(automatic.positions(CLOTH).unwrap(), alone.positions(CLOTH).unwrap(), "frame {f}");
        assert_eq!(automatic.velocities(CLOTH).unwrap(), alone.velocities(CLOTH).unwrap(), "frame {f}");
        handed.push(report.collision_crowded > 0);
        // Handed over, every crowded particle is; else none.
        assert!(report.collision_crowded == 0 || report.collision_crowded == report.crowded_contacts, "frame {f}");
    }
    let switches = handed.windows(2).filter(|w| w[0] != w[1]).count();
    assert!(handed.iter().any(|&h| h) && switches >= 2, "handed over in frames {handed:?}: on, then off again");
    assert_validation_clean(&ctx);
}
