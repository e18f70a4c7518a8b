//! The triangle leaf kind: closest points against an f64 reference, the LBVH over triangles
//! finding exactly what a loop over all triangles finds, a cloth resting at the thickness on an
//! open mesh from either side, and a deforming mesh collider refit on the GPU, GPU == CPU.

mod common;

use common::{Rng, assert_validation_clean, context};
use drape::lbvh::{build_mesh_cpu, build_swept_mesh_cpu, mesh_collider_params, triangle_boxes};
use drape::{ClothBuilder, ClothId, Collider, ColliderId, CpuSolver, Mesh, Model, SimSettings, Solver};
use drape_kernels::contact::{brute_force, traverse};
use drape_kernels::triangles::{Triangles, closest_on_triangle, swept_aabb, swept_triangle_leaf};
use drape_types::Triangle;
use glam::{DVec3, Mat4, Vec3, Vec4};

const CLOTH: ClothId = ClothId::new(0);
const BODY: ColliderId = ColliderId::new(0);

fn triangle(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
    drape_kernels::triangles::triangle_leaf(a, b, c)
}

/// f64 reference: the closest point of segment a..b to p.
fn segment64(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 == 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}

/// f64 reference distance from p to triangle abc: the plane projection when it falls inside
/// (barycentric coordinates by areas), else the nearest edge.
fn distance64(p: DVec3, t: &Triangle) -> f64 {
    let [a, b, c] = [t.a, t.b, t.c].map(|v| v.truncate().as_dvec3());
    let n = (b - a).cross(c - a);
    let edges = [segment64(p, a, b), segment64(p, b, c), segment64(p, c, a)];
    let mut best = edges.iter().map(|q| (p - *q).length()).fold(f64::INFINITY, f64::min);
    if n.length_squared() > 0.0 {
        let q = p - n * ((p - a).dot(n) / n.length_squared());
        let inside = [(a, b), (b, c), (c, a)].iter().all(|(u, v)| (*v - *u).cross(q - *u).dot(n) >= 0.0);
        if inside {
            best = best.min((p - q).length());
        }
    }
    best
}

/// Closest points on random, thin, degenerate (collinear, coincident) triangles agree with the
/// f64 reference to f32 rounding, and lie on the triangle.
#[test]
fn closest_points_match_an_f64_reference() {
    let mut rng = Rng::new(11);
    let mut v = |s: f32| Vec3::new(rng.range(-s, s), rng.range(-s, s), rng.range(-s, s));
    let mut worst = 0.0f64;
    for i in 0..20_000 {
        let (a, b, c) = (v(1.0), v(1.0), v(1.0));
        let t = match i % 5 {
            0 => triangle(a, b, c),
            1 => triangle(a, b, a + (b - a) * 0.37), // collinear: zero area
            2 => triangle(a, a, a),                  // a point
            3 => triangle(a, b, a + (b - a) * 0.5 + v(1e-4)), // a sliver
            _ => triangle(a, b, b),                  // two corners coincide
        };
        let p = v(2.0);
        let q = closest_on_triangle(p, &t);
        let reference = distance64(p.as_dvec3(), &t);
        let got = (p - q).as_dvec3().length();
        let on_triangle = distance64(q.as_dvec3(), &t);
        worst = worst.max((got - reference).abs()).max(on_triangle);
        assert!(
            (got - reference).abs() <= 1e-5 && on_triangle <= 1e-5,
            "case {i}: {t:?}, p {p}: {got} vs {reference}, off by {on_triangle}"
        );
    }
    assert!(worst > 0.0, "the comparison must see f32 rounding");
    // A long sliver (smallest angle 0.46 degrees) with the closest point inside it, 5 mm
    // above: its edges alone would answer 5.4 mm.
    let sliver = triangle(Vec3::ZERO, Vec3::X, Vec3::new(0.5, 0.0, 0.004));
    let p = Vec3::new(0.5, 0.005, 0.002);
    let d = (p - closest_on_triangle(p, &sliver)).length();
    assert!((d - 0.005).abs() < 1e-6, "sliver: {d}");
}

/// A soup of `n` small random triangles (some degenerate) in the unit cube.
fn soup(rng: &mut Rng, n: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..n {
        let centre = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let mut corner = || centre + Vec3::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), rng.range(-0.1, 0.1));
        let (a, b) = (corner(), corner());
        let c = if i % 17 == 0 { a } else { corner() };
        let base = vertices.len() as u32;
        vertices.extend([a, b, c]);
        triangles.push([base, base + 1, base + 2]);
    }
    (vertices, triangles)
}

/// The traversal over the triangle LBVH finds exactly the contact (hit parameter and triangle) a
/// loop over all triangles finds, for random motions (kernel functions, run on the CPU).
#[test]
fn triangle_bvh_finds_the_brute_force_contacts() {
    let mut rng = Rng::new(5);
    let mut contacts = 0;
    for n in [1usize, 2, 7, 500, 3000] {
        let (vertices, triangles) = soup(&mut rng, n);
        let params = mesh_collider_params(&vertices, &triangles, 0.02, 0.0).unwrap();
        let tree = build_mesh_cpu(&vertices, &triangles, &params).unwrap();
        let boxes = triangle_boxes(&vertices, &triangles);
        tree.validate_boxes(&boxes).unwrap();
        for _ in 0..2000 {
            let p1 = Vec3::new(rng.range(-1.1, 1.1), rng.range(-1.1, 1.1), rng.range(-1.1, 1.1));
            let p0 = p1 + Vec3::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), rng.range(-0.1, 0.1));
            let bvh = traverse::<Triangles>(&params, &tree.nodes, &tree.aabbs, &tree.triangles, p0, p1);
            let brute = brute_force::<Triangles>(&params, &tree.triangles, p0, p1);
            assert_eq!((bvh.t, bvh.leaf), (brute.t, brute.leaf), "n {n}, p0 {p0}, p1 {p1}");
            contacts += (brute.t <= 1.0) as u32;
        }
    }
    assert!(contacts > 300, "only {contacts} contacts: the test must exercise hits");
}

/// A 2-triangle square of side `side` in the xz plane at height 0 (an open mesh).
fn square(side: f32) -> Mesh {
    let h = side / 2.0;
    Mesh {
        vertices: vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)],
        triangles: vec![[0, 2, 1], [0, 3, 2]],
    }
}

const THICKNESS: f32 = 0.01;

/// A cloth falling onto an open square from above rests at the thickness above it; the same
/// cloth falling upwards (gravity reversed) onto it from below rests at the thickness below it:
/// the surface is two-sided and the particle stays on the side it came from. GPU == CPU twin.
#[test]
fn cloth_rests_at_the_thickness_on_either_side_of_an_open_mesh() {
    let ctx = context();
    for side in [1.0f32, -1.0] {
        let cloth = ClothBuilder::new(20, 20)
            .size(0.8)
            .gravity(Vec3::new(0.0, -9.81 * side, 0.0))
            .transform(Mat4::from_translation(Vec3::new(0.0, 0.1 * side, 0.0)))
            .build()
            .unwrap();
        let collider = Collider::mesh(&square(2.0), THICKNESS).with_friction(0.5);
        let model = Model::single(&cloth, &[collider], SimSettings::default().with_timestamps(false)).unwrap();
        let mut gpu = Solver::new(&ctx, &model).unwrap();
        let mut cpu = CpuSolver::new(&model).unwrap();
        for frame in 0..60 {
            gpu.step().unwrap();
            cpu.step().unwrap();
            let diff = common::max_distance(&gpu.positions(CLOTH).unwrap(), &cpu.positions(CLOTH).unwrap());
            assert!(diff <= 1e-5, "side {side}, frame {frame}: GPU and CPU differ by {diff}");
        }
        let heights: Vec<f32> = gpu.positions(CLOTH).unwrap().iter().map(|p| p.y * side).collect();
        let (lo, hi) = heights.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &h| (lo.min(h), hi.max(h)));
        assert!(
            lo >= 0.5 * THICKNESS && hi <= 1.5 * THICKNESS,
            "side {side}: resting heights {lo}..{hi} m, expected within [0.5, 1.5] x {THICKNESS}"
        );
    }
    assert_validation_clean(&ctx);
}

/// A deforming mesh collider (its vertices rewritten every frame, the same triangles) is refit
/// on the GPU inside the frame: its LBVH equals a fresh build's invariants for the new vertices,
/// it lifts the cloth resting on it with no particle ending below it, and the GPU run equals the
/// CPU twin.
#[test]
fn a_deforming_mesh_collider_is_refit_on_the_gpu() {
    let ctx = context();
    let mesh = square(2.0);
    let cloth = ClothBuilder::new(16, 16)
        .size(0.8)
        .transform(Mat4::from_translation(Vec3::new(0.0, 0.05, 0.0)))
        .build()
        .unwrap();
    let model =
        Model::single(&cloth, &[Collider::mesh(&mesh, THICKNESS)], SimSettings::default().with_timestamps(false))
            .unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let mut vertices = mesh.vertices.clone();
    for frame in 0..90 {
        // From frame 30 the square bulges up in the middle edge-wise and rises: a tent.
        if frame >= 30 {
            let lift = 0.004 * (frame - 29) as f32;
            for (v, rest) in vertices.iter_mut().zip(&mesh.vertices) {
                v.y = rest.y + lift * if rest.x < 0.0 { 1.0 } else { 0.5 };
            }
            gpu.set_collider_vertices(BODY, &vertices).unwrap();
            cpu.set_collider_vertices(BODY, &vertices).unwrap();
        }
        gpu.step().unwrap();
        cpu.step().unwrap();
        let diff = common::max_distance(&gpu.positions(CLOTH).unwrap(), &cpu.positions(CLOTH).unwrap());
        assert!(diff <= 1e-5, "frame {frame}: GPU and CPU differ by {diff}");
    }
    // The last frame deformed, so its leaves sweep from the previous frame's vertices.
    let tree = gpu.collider_bvh(BODY).unwrap();
    let lift = 0.004 * 59.0;
    let previous: Vec<Vec3> =
        mesh.vertices.iter().map(|v| Vec3::new(v.x, v.y + lift * if v.x < 0.0 { 1.0 } else { 0.5 }, v.z)).collect();
    let boxes: Vec<_> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| i as usize);
            swept_aabb(&swept_triangle_leaf(
                [previous[a], previous[b], previous[c]],
                [vertices[a], vertices[b], vertices[c]],
            ))
        })
        .collect();
    tree.validate_boxes(&boxes).unwrap();
    // The surface under each particle: the plane through the deformed square's triangles.
    let below =
        gpu.positions(CLOTH).unwrap().iter().filter(|p| height_above(&vertices, &mesh.triangles, **p) < 0.0).count();
    assert_eq!(below, 0, "particles below the deformed collider");
    assert!(gpu.positions(CLOTH).unwrap().iter().all(|p| p.y > 0.1), "the rising collider must lift the cloth");
    assert!(gpu.set_collider_vertices(BODY, &vertices[..3]).is_err(), "a vertex count that does not fit");
    assert!(gpu.set_collider_spheres(BODY, &[Vec4::ONE]).is_err(), "spheres for a mesh collider");
    assert_validation_clean(&ctx);
}

/// Signed height of `p` above the triangle of the mesh below it (vertical projection).
fn height_above(vertices: &[Vec3], triangles: &[[u32; 3]], p: Vec4) -> f32 {
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let n = (b - a).cross(c - a);
        let n = if n.y < 0.0 { -n } else { n };
        // Barycentric test in the xz plane.
        let signs = [(a, b), (b, c), (c, a)].map(|(u, v)| (v.x - u.x) * (p.z - u.z) - (v.z - u.z) * (p.x - u.x));
        if signs.iter().all(|s| *s >= 0.0) || signs.iter().all(|s| *s <= 0.0) {
            return (p.truncate() - a).dot(n.normalize());
        }
    }
    f32::INFINITY
}

/// A cloth thrown at 10 m/s at a 1 cm plate (each substep moves it further than the plate is
/// thick) does not pass through it: every particle ends above the plate, GPU == CPU twin.
#[test]
fn a_cloth_thrown_at_10_m_per_s_does_not_pass_a_1_cm_plate() {
    let ctx = context();
    let cloth = ClothBuilder::new(16, 16)
        .size(0.6)
        .velocity(Vec3::new(0.0, -10.0, 0.0))
        .transform(Mat4::from_translation(Vec3::new(0.0, 0.3, 0.0)))
        .build()
        .unwrap();
    let plate = Collider::mesh(&common::slab(Vec3::new(1.2, 0.01, 1.2)), 0.002);
    let model = Model::single(&cloth, &[plate], SimSettings::default().with_timestamps(false)).unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let per_substep = 10.0 * SimSettings::default().frame_dt / gpu.stability(CLOTH).unwrap().substeps as f32;
    assert!(per_substep > 0.01, "the throw must move more than the plate's thickness per substep ({per_substep} m)");
    for frame in 0..40 {
        gpu.step().unwrap();
        cpu.step().unwrap();
        let x = gpu.positions(CLOTH).unwrap();
        let diff = common::max_distance(&x, &cpu.positions(CLOTH).unwrap());
        assert!(diff <= 1e-5, "frame {frame}: GPU and CPU differ by {diff}");
        let lowest = x.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
        assert!(lowest > 0.005, "frame {frame}: a particle at y = {lowest} passed the plate's top at 0.005");
    }
    assert_validation_clean(&ctx);
}

/// f64 reference for continuous contact: the first parameter in [0, 1] at which
/// `p0 + (p1 - p0) s` comes within `r` of `t`, or None; and the least distance along the motion.
/// The distance of a point moving on a line to a convex set is convex in `s`: golden-section
/// search finds its minimum, bisection before it the first crossing of `r`.
fn first_contact64(t: &Triangle, p0: DVec3, p1: DVec3, r: f64) -> (Option<f64>, f64) {
    let f = |s: f64| distance64(p0 + (p1 - p0) * s, t);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..120 {
        let (m1, m2) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
        if f(m1) <= f(m2) { hi = m2 } else { lo = m1 }
    }
    let s_min = 0.5 * (lo + hi);
    let least = f(s_min).min(f(0.0)).min(f(1.0));
    if f(0.0) <= r {
        return (Some(0.0), least);
    }
    if least > r {
        return (None, least);
    }
    let end = if f(s_min) <= r { s_min } else { 1.0 };
    let (mut outside, mut within) = (0.0f64, end);
    for _ in 0..100 {
        let mid = 0.5 * (outside + within);
        if f(mid) <= r { within = mid } else { outside = mid }
    }
    (Some(within), least)
}

/// Continuous contact of a particle's motion with a triangle grown by the thickness, against the
/// f64 reference, on random and adversarial motions: aimed at the face, edge-on in the plane,
/// at a corner, parallel to the face or to an edge at about the thickness (grazing), and through
/// zero-area triangles. No false negative: every motion that comes within the thickness is a
/// hit, never later than the reference; a hit is at most the stated slack early (the contact
/// point is within `(1 + CCD_SLACK)` x thickness).
#[test]
fn continuous_contact_matches_an_f64_reference() {
    use drape_kernels::contact::LeafKind;
    use drape_kernels::triangles::CCD_SLACK;
    let mut rng = Rng::new(23);
    let mut v = |s: f32| Vec3::new(rng.range(-s, s), rng.range(-s, s), rng.range(-s, s));
    let (mut hits, mut misses, mut cases_seen) = (0, 0, [0u32; 8]);
    let eps = 2e-5f64;
    for i in 0..40_000 {
        let kind = i % 8;
        let (a, b, c) = (v(1.0), v(1.0), v(1.0));
        let r = 0.002 + 0.1 * (v(1.0).x.abs());
        let mut t = triangle(a, b, c);
        let n = (b - a).cross(c - a).normalize_or_zero();
        let bary = |u: f32, w: f32| a + (b - a) * u + (c - a) * w;
        let (p0, p1) = match kind {
            // Random.
            0 => (v(1.5), v(1.5)),
            // Aimed through a point of the face from a random direction.
            1 => {
                let target = bary(0.3, 0.3);
                let from = target + v(1.0);
                (from, target + (target - from) * 0.5)
            }
            // Edge-on: in the plane, towards a point of edge ab from outside.
            2 => {
                let on_edge = a + (b - a) * 0.4;
                let out = (on_edge - c).normalize_or_zero();
                (on_edge + out * (r + 0.3), on_edge - out * 0.1)
            }
            // At a corner, from outside.
            3 => {
                let away = (a - (b + c) * 0.5).normalize_or_zero();
                let from = a + (away + v(0.3)) * 0.5;
                (from, a - (from - a) * 0.2)
            }
            // Parallel to the face at about the thickness (grazing the slab).
            4 => {
                let h = r * (0.9 + 0.2 * (v(1.0).x.abs()));
                let side = (b - a).normalize_or_zero();
                let mid = bary(0.3, 0.3) + n * h;
                (mid - side * 1.5, mid + side * 1.5)
            }
            // Parallel to edge bc at about the thickness from it (grazing its cylinder).
            5 => {
                let axis = (c - b).normalize_or_zero();
                let off = axis.cross(n).normalize_or_zero() * r * (0.9 + 0.2 * v(1.0).x.abs());
                let off = if off.dot(b - a) < 0.0 { -off } else { off };
                (b + off - axis * 0.5, c + off + axis * 0.5)
            }
            // Zero-area triangles (collinear, a point), motion through them.
            6 => {
                t = if i % 16 < 8 { triangle(a, b, a + (b - a) * 0.37) } else { triangle(a, a, a) };
                let target = a + (b - a) * 0.2;
                let from = target + v(0.5);
                (from, target - (from - target) * 0.5)
            }
            // Grazing a corner's ball: passing the corner at about the thickness.
            _ => {
                let dir = v(1.0).normalize_or_zero();
                let perp = dir.cross(v(1.0)).normalize_or_zero() * r * (0.9 + 0.2 * v(1.0).x.abs());
                (a + perp - dir, a + perp + dir)
            }
        };
        if !(p0.is_finite() && p1.is_finite()) {
            continue;
        }
        let (s, _) = Triangles::hit(t, p0, p1, r);
        let (p0d, p1d, rd) = (p0.as_dvec3(), p1.as_dvec3(), r as f64);
        let (reference, least) = first_contact64(&t, p0d, p1d, rd);
        let (early_ref, _) = first_contact64(&t, p0d, p1d, rd - eps);
        let context = || {
            format!(
                "case {i} (kind {kind}): {t:?}, {p0} -> {p1}, r {r}: kernel {s}, reference {reference:?}, least {least}"
            )
        };
        if least <= rd - eps {
            assert!(s <= 1.0, "false negative: {}", context());
        }
        if s <= 1.0 {
            hits += 1;
            cases_seen[kind] += 1;
            let at = distance64(p0d + (p1d - p0d) * s as f64, &t);
            assert!(at <= rd * (1.0 + CCD_SLACK as f64) + eps, "contact point {at} beyond the slack: {}", context());
            if let Some(early) = early_ref {
                assert!((s as f64) <= early + 1e-6, "later than the reference: {}", context());
            }
        } else {
            misses += 1;
        }
    }
    assert!(hits > 10_000 && misses > 5_000, "{hits} hits, {misses} misses: the cases must exercise both");
    assert!(cases_seen.iter().all(|&n| n > 300), "every kind of case must hit: {cases_seen:?}");
}

/// One particle's detect of the substep motion `p0 -> p1` through the LBVH and by the
/// brute-force loop, checked equal.
fn bvh_and_brute_force(
    params: &drape_types::ColliderParams,
    tree: &drape::lbvh::Lbvh,
    motion: &drape_kernels::pose::SubstepMotion,
    (p0, p1): (Vec3, Vec3),
    case: &str,
) -> (drape_types::Contact, drape_types::Contact) {
    use drape_kernels::contact::{detect_at, detect_brute_force_at};
    use drape_types::Contact;
    let (x, x_prev) = ([p1.extend(1.0)], [p0.extend(1.0)]);
    let (mut bvh, mut brute) = ([Contact::NONE], [Contact::NONE]);
    detect_at::<Triangles>(0, params, motion, &tree.nodes, &tree.aabbs, &tree.triangles, &x, &x_prev, &mut bvh);
    detect_brute_force_at::<Triangles>(0, params, motion, &tree.triangles, &x, &x_prev, &mut brute);
    assert_eq!(bvh[0], brute[0], "{case}: {p0} -> {p1}");
    (bvh[0], brute[0])
}

/// The whole detect for a particle (first contact, response target, and the path check that
/// stops it at its first contact when the straight way to the target is blocked, skipped when
/// the path is shorter than the clearance) through the LBVH equals the brute-force detect
/// exactly, on a torus with motions from resting-sized to long, and some paths are blocked.
#[test]
fn triangle_detect_through_the_bvh_equals_brute_force() {
    use drape_kernels::pose::SubstepMotion;
    use drape_types::ColliderPose;
    let mesh = Mesh::torus(0.35, 0.12, 32, 16);
    let thickness = 0.01;
    let params = mesh_collider_params(&mesh.vertices, &mesh.triangles, thickness, 0.0).unwrap();
    let tree = build_mesh_cpu(&mesh.vertices, &mesh.triangles, &params).unwrap();
    let motion = SubstepMotion::of(&ColliderPose::default(), 0.0, 1.0, 1.0 / 60.0);
    let mut rng = Rng::new(77);
    let (mut hits, mut stopped) = (0, 0);
    for i in 0..20_000 {
        // Near the tube's surface, moving by 0.1 mm .. 20 cm.
        let angle = rng.range(0.0, std::f32::consts::TAU);
        let ring = Vec3::new(angle.cos(), 0.0, angle.sin()) * 0.35;
        let dir = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::Y);
        let p0 = ring + dir * rng.range(0.12, 0.16);
        let step = [1e-4, 1e-3, 1e-2, 0.2][i % 4];
        let p1 = p0 + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * step;
        let (bvh, _) = bvh_and_brute_force(&params, &tree, &motion, (p0, p1), &format!("case {i}"));
        if bvh.is_some() {
            hits += 1;
            let first = p0 + (p1 - p0) * bvh.position.w;
            stopped += (bvh.position.truncate() == first && bvh.position.w > 0.0) as u32;
        }
    }
    assert!(hits > 2_000, "only {hits} contacts");
    assert!(stopped > 0, "no path was blocked: the check must be exercised");
}

/// A deforming collider's surface moving through a particle within one frame (10 cm up, the
/// thickness 1 cm) catches it in the substep it arrives and carries it: each substep the
/// particle is tested against the triangle where it stands then, not where it stands at the
/// frame's end. Without the sweep (only the end-of-frame triangle) the particle would be left
/// 5 cm below the surface.
#[test]
fn a_deforming_surface_sweeping_through_a_particle_catches_it() {
    use drape_kernels::contact::detect_brute_force_at;
    use drape_kernels::pose::SubstepMotion;
    use drape_types::{ColliderPose, Contact};
    let (r, substeps) = (0.01, 10);
    let end = [Vec3::new(-1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, -1.0)];
    // One corner rises 1 cm less, so the sweep is not a pure translation.
    let start = [end[0] - Vec3::Y * 0.1, end[1] - Vec3::Y * 0.09, end[2] - Vec3::Y * 0.1];
    let leaf = swept_triangle_leaf(start, end);
    assert!(leaf.sweep.w > 0.0, "the sweep must deform the triangle");
    let params = drape_types::ColliderParams { leaf_count: 1, thickness: r, ..Default::default() };
    let below = Vec3::new(0.0, -0.05, 0.0);
    let mut p = below;
    let mut caught = None;
    for k in 0..substeps {
        let motion = SubstepMotion::of(&ColliderPose::default(), k as f32 / 10.0, (k + 1) as f32 / 10.0, 1.0 / 600.0);
        let mut contact = [Contact::NONE];
        detect_brute_force_at::<Triangles>(
            0,
            &params,
            &motion,
            &[leaf],
            &[p.extend(1.0)],
            &[p.extend(1.0)],
            &mut contact,
        );
        if contact[0].is_some() {
            caught.get_or_insert(k);
            p = contact[0].position.truncate();
        }
    }
    // The surface under the particle rises from -9.5 cm to 0: within the thickness of -5 cm
    // from about 37% of the frame on.
    let caught = caught.expect("the sweeping surface never touched the particle");
    assert!((2..=4).contains(&caught), "caught in substep {caught}, expected when the surface arrives (2..4)");
    // At the frame's end the particle rests on the end triangle near the thickness (the sweep's
    // residual, 0.7 cm at most here, widens the band).
    assert!(p.y >= 0.3 * r && p.y <= 2.0 * r, "particle at y = {}, expected above the surface at ~{r}", p.y);
    let static_leaf = drape_kernels::triangles::triangle_leaf(end[0], end[1], end[2]);
    let motion = SubstepMotion::of(&ColliderPose::default(), 0.9, 1.0, 1.0 / 600.0);
    let mut contact = [Contact::NONE];
    let at = [below.extend(1.0)];
    detect_brute_force_at::<Triangles>(0, &params, &motion, &[static_leaf], &at, &at, &mut contact);
    assert!(!contact[0].is_some(), "the end-of-frame triangle alone does not see the particle 5 cm below it");
}

/// With a deforming torus (every vertex moved by up to 2 cm beyond a 5 cm shift over the frame)
/// the detect through the LBVH over swept leaf boxes, and over candidate lists, equals the
/// brute-force loop for motions in every substep of the frame.
#[test]
fn swept_leaves_through_the_bvh_and_lists_equal_brute_force() {
    use drape_kernels::candidates::{broad_phase_at, detect_candidates_at};
    use drape_kernels::pose::SubstepMotion;
    use drape_types::{ColliderPose, Contact, ContactQuery, MAX_CANDIDATES, SimParams};
    let mesh = Mesh::torus(0.35, 0.12, 32, 16);
    let mut rng = Rng::new(5);
    let shift = Vec3::new(0.03, 0.04, 0.0);
    let previous: Vec<Vec3> = mesh
        .vertices
        .iter()
        .map(|v| *v - shift + Vec3::new(rng.range(-0.02, 0.02), rng.range(-0.02, 0.02), rng.range(-0.02, 0.02)))
        .collect();
    let thickness = 0.01;
    let params = mesh_collider_params(&mesh.vertices, &mesh.triangles, thickness, 0.0).unwrap();
    let tree = build_swept_mesh_cpu(&previous, &mesh.vertices, &mesh.triangles, &params).unwrap();
    assert!(tree.triangles.iter().all(|t| t.sweep.w > 0.0), "every leaf must deform");
    let sim = SimParams { gravity: Vec4::new(0.0, -9.81, 0.0, 0.0), particle_count: 1, ..Default::default() };
    let frame = SubstepMotion::of(&ColliderPose::default(), 0.0, 1.0, 1.0 / 60.0);
    let (mut hits, mut listed) = (0, 0);
    for i in 0..12_000 {
        let angle = rng.range(0.0, std::f32::consts::TAU);
        let ring = Vec3::new(angle.cos(), 0.0, angle.sin()) * 0.35;
        let dir = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::Y);
        let p0 = ring + dir * rng.range(0.1, 0.16);
        let step = [1e-4, 1e-3, 1e-2, 0.05][i % 4];
        let p1 = p0 + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * step;
        let k = (i / 4 % 10) as f32;
        let motion = SubstepMotion::of(&ColliderPose::default(), k / 10.0, (k + 1.0) / 10.0, 1.0 / 600.0);
        let (x, x_prev) = ([p1.extend(1.0)], [p0.extend(1.0)]);
        let (_, brute) = bvh_and_brute_force(&params, &tree, &motion, (p0, p1), &format!("case {i}, substep {k}"));
        let mut lists = [Contact::NONE];
        let mut queries = [ContactQuery::default()];
        let mut candidates = vec![0u32; MAX_CANDIDATES as usize];
        let broad =
            (tree.nodes.as_slice(), tree.aabbs.as_slice(), tree.leaf_bounds.as_slice(), tree.triangles.as_slice());
        let start = p0 - (p1 - p0) * k;
        let v = (p1 - p0) * 600.0;
        broad_phase_at::<Triangles>(
            0,
            &sim,
            &params,
            &frame,
            broad,
            (&[start.extend(1.0)], &[v.extend(0.0)]),
            &mut queries,
            &mut candidates,
        );
        let tree_in = (tree.nodes.as_slice(), tree.aabbs.as_slice(), tree.triangles.as_slice());
        let outcome = detect_candidates_at::<Triangles>(
            0,
            &params,
            &motion,
            tree_in,
            (&queries, &candidates),
            (&x, &x_prev),
            &mut lists,
            (0, false),
        );
        assert_eq!(lists[0], brute, "case {i}: lists, {outcome:?}");
        hits += brute.is_some() as u32;
        listed += !outcome.fell_back as u32;
    }
    assert!(hits > 2_000, "only {hits} contacts");
    assert!(listed > 5_000, "only {listed} answered from lists");
}

/// A deforming mesh plate rising at 4 m/s (6.7 cm per frame: more than its 1 cm plus twice the
/// contact thickness) under a cloth: its vertices are rewritten every frame (its pose never
/// changes), and because its triangles sweep from the previous frame's vertices over the
/// substeps, it lifts the cloth instead of jumping through it. GPU == CPU twin.
#[test]
fn a_fast_deforming_plate_does_not_jump_through_the_cloth() {
    let ctx = context();
    let plate = common::slab(Vec3::new(1.2, 0.01, 1.2));
    let cloth = ClothBuilder::new(16, 16)
        .size(0.6)
        .transform(Mat4::from_translation(Vec3::new(0.0, 0.05, 0.0)))
        .build()
        .unwrap();
    let start = -0.1;
    let placed = |y: f32| plate.vertices.iter().map(|v| *v + Vec3::Y * y).collect::<Vec<_>>();
    let mut model_plate = plate.clone();
    model_plate.vertices = placed(start);
    let model =
        Model::single(&cloth, &[Collider::mesh(&model_plate, 0.002)], SimSettings::default().with_timestamps(false))
            .unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let per_frame = 4.0 * SimSettings::default().frame_dt;
    assert!(per_frame > 0.01 + 2.0 * 0.002);
    let mut height = start;
    for frame in 1..=8 {
        height += per_frame;
        gpu.set_collider_vertices(BODY, &placed(height)).unwrap();
        cpu.set_collider_vertices(BODY, &placed(height)).unwrap();
        gpu.step().unwrap();
        cpu.step().unwrap();
        let x = gpu.positions(CLOTH).unwrap();
        let diff = common::max_distance(&x, &cpu.positions(CLOTH).unwrap());
        assert!(diff <= 1e-5, "frame {frame}: GPU and CPU differ by {diff}");
        let below = x.iter().filter(|p| p.y < height).count();
        assert_eq!(below, 0, "frame {frame}: particles below the plate's middle at {height}: it jumped through");
    }
    let lowest = gpu.positions(CLOTH).unwrap().iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    assert!(lowest > height, "the plate at {height} must carry the cloth (lowest particle {lowest})");
    assert_validation_clean(&ctx);
}
