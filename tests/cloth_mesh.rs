//! Cloths built from triangle meshes (issue 8, item 1): the spring list (structural springs on
//! edges, bend springs across shared edges, rest lengths and area masses from the mesh), its
//! kernels against the CPU twin and against the grid's fast path, pins, normals, OBJ input and
//! output with texture coordinates, and the CLI's `--cloth-mesh`.

mod common;

use common::{assert_fused_contact_equals_walk_and_cpu, assert_validation_clean, context, max_distance, sheet_obj};
use drape::cloth_mesh::SpringTopology;
use drape::reference::ReferenceCloth;
use drape::stability::{SpringProfile, spectral_bounds};
use drape::{
    Cloth, ClothBuilder, ClothId, ClothMesh, ClothTopology, Collider, CpuSolver, Error, Mesh, Model, SimSettings,
    Solver,
};
use drape_kernels::cloth::{BEND, STRUCTURAL, acceleration_springs};
use glam::{Mat4, Vec3, Vec4};

const CLOTH: ClothId = ClothId::new(0);

/// A disc of `rings` rings of `around` vertices around a centre, each ring turned half a step
/// from the last, so triangles differ in shape and size and the centre has `around` neighbours.
fn disc(rings: u32, around: u32, radius: f32) -> ClothMesh {
    let mut vertices = vec![Vec3::ZERO];
    for i in 1..=rings {
        let r = radius * i as f32 / rings as f32;
        for j in 0..around {
            let a = std::f32::consts::TAU * (j as f32 + 0.5 * i as f32) / around as f32;
            vertices.push(Vec3::new(r * a.cos(), 0.0, r * a.sin()));
        }
    }
    let index = |i: u32, j: u32| 1 + (i - 1) * around + j % around;
    let mut triangles = Vec::new();
    for j in 0..around {
        triangles.push([0, index(1, j + 1), index(1, j)]);
    }
    for i in 1..rings {
        for j in 0..around {
            let (a, b, c, d) = (index(i, j), index(i, j + 1), index(i + 1, j + 1), index(i + 1, j));
            triangles.push([a, b, d]);
            triangles.push([b, c, d]);
        }
    }
    ClothMesh::from_parts(vertices, triangles).unwrap()
}

fn springs_of(cloth: &Cloth) -> &SpringTopology {
    match &cloth.topology {
        ClothTopology::Springs(s) => s,
        ClothTopology::Grid => panic!("expected a spring-list cloth"),
    }
}

/// A unit square of two triangles: 5 edges (structural), 1 bend spring joining the corners
/// opposite the diagonal, each stored at both ends; the mass splits by area.
#[test]
fn a_mesh_cloth_has_springs_on_its_edges_and_across_them() {
    let vertices = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z];
    let mesh = ClothMesh::from_parts(vertices, vec![[0, 2, 1], [0, 3, 2]]).unwrap();
    let cloth = ClothBuilder::from_mesh(mesh).mass(0.6).build().unwrap();
    let s = springs_of(&cloth);
    let count = |family| s.springs.iter().filter(|x| x.family == family).count();
    assert_eq!((count(STRUCTURAL), count(BEND)), (10, 2));
    let bend: Vec<_> = s.springs.iter().filter(|x| x.family == BEND).map(|x| (x.other, x.rest)).collect();
    assert_eq!(bend, vec![(3, 2f32.sqrt()), (1, 2f32.sqrt())], "1 and 3 face each other across the diagonal");
    let diagonal = s.springs.iter().find(|x| x.family == STRUCTURAL && x.rest > 1.1).unwrap();
    assert!((diagonal.rest - 2f32.sqrt()).abs() < 1e-6);
    // Corners 0 and 2 belong to both triangles: a third of 0.3 kg from each.
    let masses: Vec<f32> = s.particles.iter().map(|p| 1.0 / p.inverse_mass).collect();
    for (m, expected) in masses.iter().zip([0.2, 0.1, 0.2, 0.1]) {
        assert!((m - expected).abs() < 1e-6, "{masses:?}");
    }
    assert_eq!(cloth.structural_springs().len(), 5);
}

/// Rest lengths come from the mesh as placed: a cloth at rest without gravity feels no force,
/// at any particle of an irregular mesh, under any transform.
#[test]
fn a_mesh_cloth_at_rest_feels_no_force() {
    let transform = Mat4::from_scale_rotation_translation(
        Vec3::splat(1.7),
        glam::Quat::from_rotation_x(0.9),
        Vec3::new(0.3, 2.0, -1.0),
    );
    let cloth = ClothBuilder::from_mesh(disc(6, 24, 0.5)).gravity(Vec3::ZERO).transform(transform).build().unwrap();
    let s = springs_of(&cloth);
    let mut params = cloth.params;
    params.spring_damping = 0.1;
    for i in 0..cloth.particle_count() as u32 {
        let a = acceleration_springs(&params, i, &cloth.positions, &cloth.velocities, &s.particles, &s.springs);
        assert!(a.length() < 1e-4, "particle {i}: {a}");
    }
}

/// The grid built with listed springs (the mesh cloths' kernel) gets the grid's own springs
/// and stability bound, and moves as the grid's fast path does (to rounding: the two sum the
/// forces over the mass in a different order).
#[test]
fn the_grid_as_a_spring_list_moves_like_the_grid() {
    let grid = |listed: bool| {
        ClothBuilder::new(16, 16)
            .external_force(Vec3::new(0.3, 0.0, 0.5))
            .pin_top_corners()
            .listed_springs(listed)
            .build()
            .unwrap()
    };
    let (fast, listed) = (grid(false), grid(true));
    assert_eq!(springs_of(&listed).springs.len(), 2 * (15 * 16 * 2 + 15 * 15 * 2 + 14 * 16 * 2));
    let (a, b) = (
        spectral_bounds(&fast.params, &SpringProfile::of(&fast)),
        spectral_bounds(&listed.params, &SpringProfile::of(&listed)),
    );
    assert!((a.0 - b.0).abs() <= 1e-3 * a.0 && (a.1 - b.1).abs() <= 1e-3 * a.1, "{a:?} vs {b:?}");
    let ctx = context();
    let settings = SimSettings::default().with_timestamps(false);
    let run = |cloth: &Cloth| {
        let mut sim = Solver::new(&ctx, &Model::single(cloth, &[], settings).unwrap()).unwrap();
        for _ in 0..60 {
            sim.step().unwrap();
        }
        (sim.positions(CLOTH).unwrap(), sim.normals(CLOTH).unwrap())
    };
    let ((x_fast, n_fast), (x_listed, n_listed)) = (run(&fast), run(&listed));
    let moved = max_distance(&x_fast, &fast.positions);
    assert!(moved > 0.3, "the cloth must swing ({moved} m)");
    let apart = max_distance(&x_fast, &x_listed);
    assert!(apart < 1e-4, "listed springs drifted {apart} m from the grid in 60 frames");
    // Mesh normals (area-weighted triangle normals) and grid normals (quad cross products)
    // differ in weighting only: a little where the cloth folds, hardly elsewhere.
    let cosines: Vec<f32> = n_fast.iter().zip(&n_listed).map(|(a, b)| a.truncate().dot(b.truncate())).collect();
    let (worst, mean) =
        (cosines.iter().copied().fold(1.0, f32::min), cosines.iter().sum::<f32>() / cosines.len() as f32);
    assert!(worst > 0.9 && mean > 0.995, "normals disagree: worst cos {worst}, mean {mean}");
    assert_validation_clean(&ctx);
}

/// A mesh cloth's RK4 (automatic substeps, then four times as many) against the f64 reference
/// (its own spring list and masses, 1/24000 s steps): an irregular disc pinned along one side
/// swings down for 0.5 s; the error stays within 0.1% of its size (measured 1.8e-5 m) and falls
/// by more than 8x with 4x the substeps (measured 12x: 4th order down to f32 round-off, ~1e-6 m).
#[test]
fn mesh_cloth_rk4_matches_the_f64_reference() {
    let cloth = ClothBuilder::from_mesh(disc(5, 16, 0.5))
        .pin_within(Vec3::new(0.4, -1.0, -1.0), Vec3::ONE)
        .external_force(Vec3::new(0.0, 0.0, 0.2))
        .build()
        .unwrap();
    let frames = 30;
    let ctx = context();
    let run = |settings: SimSettings| {
        let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
        for _ in 0..frames {
            sim.step().unwrap();
        }
        sim.positions(CLOTH).unwrap()
    };
    let mut reference = ReferenceCloth::new(&cloth);
    reference.run(frames as f64 / 60.0, frames * 400);
    let error = |x: &[Vec4]| {
        x.iter().zip(&reference.x).map(|(p, q)| (p.truncate().as_dvec3() - *q).length()).fold(0.0, f64::max)
    };
    let auto = SimSettings::default().stability(&cloth).unwrap().substeps;
    let coarse = error(&run(SimSettings::default()));
    let fine = error(&run(SimSettings::default().with_substeps(Some(4 * auto))));
    let moved = reference.x.iter().zip(&cloth.positions).map(|(q, p)| (*q - p.truncate().as_dvec3()).length());
    assert!(moved.fold(0.0, f64::max) > 0.3, "the disc must swing");
    println!("mesh cloth RK4 vs f64: {coarse:e} m ({auto} substeps), {fine:e} m ({} substeps)", 4 * auto);
    assert!(coarse < 1e-3, "RK4 error {coarse} m");
    assert!(fine < coarse / 8.0, "error {coarse} -> {fine} with 4x substeps");
    assert_validation_clean(&ctx);
}

/// A pinned disc (pinned by a box around its centre) draped over a triangle collider: every
/// frame on the GPU equals the CPU twin bit for bit (positions, velocities, normals), and the
/// pinned particles stay put.
#[test]
fn mesh_cloth_frames_on_the_gpu_equal_the_cpu_twin() {
    let ctx = context();
    let cloth = ClothBuilder::from_mesh(disc(8, 32, 0.6))
        .pin_within(Vec3::splat(-0.1), Vec3::splat(0.1))
        .pin_vertex(40)
        .transform(Mat4::from_translation(Vec3::new(0.2, 0.65, 0.0)))
        .build()
        .unwrap();
    let pinned: Vec<usize> = (0..cloth.particle_count()).filter(|&i| cloth.positions[i].w == 0.0).collect();
    assert!(pinned.len() > 30 && pinned.contains(&0) && pinned.contains(&40), "{} pinned", pinned.len());
    let collider = Collider::mesh(&Mesh::icosphere(0.5, 3), 0.01).with_friction(0.3);
    let model = Model::single(&cloth, std::slice::from_ref(&collider), SimSettings::default()).unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    let mut contact_frames = 0;
    for frame in 1..=25 {
        let report = gpu.step_report().unwrap();
        cpu.step().unwrap();
        contact_frames += (report.collision_ran > 0) as u32;
        let x = gpu.positions(CLOTH).unwrap();
        assert_eq!(x, cpu.positions(CLOTH).unwrap(), "frame {frame}: positions");
        assert_eq!(gpu.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {frame}: velocities");
        // Normals are for drawing: llvmpipe may fuse their cross products' multiply-adds.
        let normals = max_distance(&gpu.normals(CLOTH).unwrap(), &cpu.normals(CLOTH).unwrap());
        assert!(normals < 1e-6, "frame {frame}: normals differ by {normals}");
        for &i in &pinned {
            assert_eq!(x[i], cloth.positions[i], "frame {frame}: pinned particle {i} moved");
        }
    }
    assert!(contact_frames > 5, "the cloth must reach the collider");
    assert_validation_clean(&ctx);
}

/// Velocity damping and wind act on a mesh cloth per unit of its mean particle mass: with
/// both, every frame on the GPU still equals the CPU twin bit for bit. (Written as
/// `(wind - v c) / m`, lavapipe's frames left the twin's in the last bits from the first frame
/// whenever velocity damping was on; as `wind / m - v (c / m)` they agree.)
#[test]
fn mesh_cloth_with_velocity_damping_and_wind_equals_the_cpu_twin() {
    let ctx = context();
    let cloth = ClothBuilder::from_mesh(disc(6, 24, 0.5))
        .pin_within(Vec3::new(0.35, -1.0, -1.0), Vec3::ONE)
        .velocity_damping(2e-3)
        .external_force(Vec3::new(0.3, 0.1, -0.2))
        .build()
        .unwrap();
    let model = Model::single(&cloth, &[], SimSettings::default()).unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    for frame in 1..=40 {
        gpu.step().unwrap();
        cpu.step().unwrap();
        assert_eq!(gpu.positions(CLOTH).unwrap(), cpu.positions(CLOTH).unwrap(), "frame {frame}: positions");
        assert_eq!(gpu.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {frame}: velocities");
    }
    let x = gpu.positions(CLOTH).unwrap();
    let moved = x.iter().zip(&cloth.positions).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    assert!(moved > 0.2, "the disc must swing: {moved} m");
    assert_validation_clean(&ctx);
}

/// A mesh cloth falling on a sphere collider (the spring-list kernel with the sphere leaf
/// kind's narrow phase inside its last stage): every frame equals the LBVH walk's separate
/// passes and the CPU twin, bit for bit.
#[test]
fn mesh_cloth_on_spheres_equals_the_walk_and_the_cpu_twin() {
    let ctx = context();
    let cloth = ClothBuilder::from_mesh(disc(8, 32, 0.6))
        .transform(Mat4::from_translation(Vec3::new(0.1, 0.4, 0.0)))
        .build()
        .unwrap();
    let spheres = vec![Vec4::new(0.0, 0.0, 0.0, 0.3), Vec4::new(0.25, 0.1, 0.0, 0.12)];
    let collider = Collider::new(spheres, 0.01).with_friction(0.3);
    let contact_frames = assert_fused_contact_equals_walk_and_cpu(&ctx, &cloth, &collider, SimSettings::default(), 25);
    assert!(contact_frames > 5, "the cloth must reach the spheres ({contact_frames} frames)");
    assert_validation_clean(&ctx);
}

/// A flat disc wound counter-clockwise seen from +Y has normals +Y, the other winding -Y; a
/// mirroring transform mirrors them (the builder flips the triangles so they stay outward).
#[test]
fn mesh_normals_follow_the_winding() {
    let up = disc(3, 12, 0.4);
    let down = ClothMesh { triangles: up.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(), ..up.clone() };
    for (mesh, transform, expected) in [
        (up.clone(), Mat4::IDENTITY, Vec3::Y),
        (down, Mat4::IDENTITY, Vec3::NEG_Y),
        (up, Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0)), Vec3::NEG_Y),
    ] {
        let cloth = ClothBuilder::from_mesh(mesh).gravity(Vec3::ZERO).transform(transform).build().unwrap();
        let mut sim = CpuSolver::new(&Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
        sim.step().unwrap();
        for n in sim.normals(CLOTH).unwrap() {
            assert!((n.truncate() - expected).length() < 1e-5, "{n} vs {expected}");
        }
    }
}

/// Bad mesh cloths are refused with the cause: a pin past the last vertex or a grid's pin or size, a mesh without
/// triangles, a mesh whose triangles have no area, an index out of range. A vertex of no triangle is pinned where it is.
#[test]
fn bad_mesh_cloths_are_refused_and_loose_vertices_pinned() {
    let mesh = disc(2, 6, 0.3);
    let n = mesh.vertices.len() as u32;
    let error = ClothBuilder::from_mesh(mesh.clone()).pin_vertex(n).build().unwrap_err();
    assert!(matches!(error, Error::InvalidParameter { name: "pins", .. }), "{error}");
    assert!(error.to_string().contains(&format!("particle {n}")), "{error}");
    // A grid's pins on a mesh, which has no rows: refused, not ignored.
    let corners = ClothBuilder::from_mesh(mesh.clone()).pin_top_corners().build().unwrap_err();
    assert!(matches!(corners, Error::InvalidParameter { name: "pins", .. }), "{corners}");
    assert!(corners.to_string().contains("pin_vertex"), "{corners}");
    // A grid's size on a mesh, whose vertices give its size: refused, not ignored.
    let sized = ClothBuilder::from_mesh(mesh.clone()).size(2.0).build().unwrap_err();
    assert!(matches!(sized, Error::InvalidParameter { name: "size", .. }), "{sized}");
    assert!(sized.to_string().contains("transform"), "{sized}");
    let stretched = ClothBuilder::from_mesh(mesh.clone()).dimensions(1.0, 3.0).build().unwrap_err();
    assert!(matches!(stretched, Error::InvalidParameter { name: "size", .. }), "{stretched}");
    assert!(ClothMesh::from_parts(mesh.vertices.clone(), vec![]).is_err());
    assert!(ClothMesh::from_parts(mesh.vertices.clone(), vec![[0, 1, n]]).is_err());
    let flat = ClothMesh::from_parts(vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X], vec![[0, 1, 2], [0, 0, 1]]).unwrap();
    let no_area = ClothBuilder::from_mesh(flat).build().unwrap_err();
    assert!(matches!(no_area, Error::InvalidParameter { name: "cloth mesh", .. }), "{no_area}");
    assert!(no_area.to_string().contains("no area"), "{no_area}");
    // Finite corners whose area overflows f32 are not "on one line": the message says so.
    let huge = ClothMesh::from_parts(vec![Vec3::ZERO, 1e20 * Vec3::X, 1e20 * Vec3::Z], vec![[0, 1, 2]]).unwrap();
    let overflow = ClothBuilder::from_mesh(huge).build().unwrap_err();
    assert!(matches!(overflow, Error::InvalidParameter { name: "cloth mesh", .. }), "{overflow}");
    assert!(overflow.to_string().contains("beyond f32's range (a coordinate reaches 1e20 m)"), "{overflow}");
    // A mass that underflows at the particles would pin them as if they had none.
    let weightless = ClothBuilder::from_mesh(mesh.clone()).mass(1e-44).build().unwrap_err();
    assert!(weightless.to_string().contains("times their density underflows f32"), "{weightless}");
    // A cloth of 1e-10 m: no contact or spring resolves it in f32.
    let speck = ClothMesh::from_parts(vec![Vec3::ZERO, 1e-10 * Vec3::X, 1e-10 * Vec3::Z], vec![[0, 1, 2]]).unwrap();
    let speck = ClothBuilder::from_mesh(speck).build().unwrap_err();
    assert!(speck.to_string().contains("spans only 1e-10 m"), "{speck}");
    let bad_box = ClothBuilder::from_mesh(mesh.clone()).pin_within(Vec3::ONE, Vec3::ZERO).build().unwrap_err();
    assert!(bad_box.to_string().contains("min <= max"), "{bad_box}");
    // A box beside the cloth pins nothing: refused, with where the cloth is.
    let empty_box =
        ClothBuilder::from_mesh(mesh.clone()).pin_within(Vec3::splat(5.0), Vec3::splat(6.0)).build().unwrap_err();
    assert!(matches!(empty_box, Error::InvalidParameter { name: "pin box", .. }), "{empty_box}");
    assert!(empty_box.to_string().contains("holds none of the cloth's particles"), "{empty_box}");
    let mut loose = mesh;
    loose.vertices.push(Vec3::new(5.0, 5.0, 5.0));
    let cloth = ClothBuilder::from_mesh(loose).build().unwrap();
    assert_eq!(cloth.positions.last().unwrap().w, 0.0, "a vertex of no triangle is pinned");
    let mut sim = CpuSolver::new(&Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    sim.step().unwrap();
    assert_eq!(sim.positions(CLOTH).unwrap().last(), cloth.positions.last());
}

/// A `width x depth` sheet of `columns x rows` vertices in the y = 0 plane centred on the
/// origin, each cell split along its diagonal.
fn sheet(columns: u32, rows: u32, (width, depth): (f32, f32)) -> ClothMesh {
    common::sheet(columns, rows, (width, depth), Vec3::new(-0.5 * width, 0.0, -0.5 * depth))
}

/// The pull (N) a mesh cloth's structural springs give its half beyond its middle when the
/// whole cloth is stretched 1 % along x (no gravity, at rest, bend springs off): the tension
/// across the cut.
fn tension_along_x(mesh: ClothMesh) -> f32 {
    let cloth = ClothBuilder::from_mesh(mesh).gravity(Vec3::ZERO).stiffness(40.0, 10.0, 0.0).build().unwrap();
    let s = springs_of(&cloth);
    let centre = cloth.positions.iter().map(|p| p.x).sum::<f32>() / cloth.positions.len() as f32;
    let stretched: Vec<Vec4> =
        cloth.positions.iter().map(|p| Vec4::new(centre + (p.x - centre) * 1.01, p.y, p.z, p.w)).collect();
    let mut pull = 0.0;
    for i in 0..cloth.particle_count() as u32 {
        if stretched[i as usize].x > centre {
            let a = acceleration_springs(&cloth.params, i, &stretched, &cloth.velocities, &s.particles, &s.springs);
            pull -= a.x / s.particles[i as usize].inverse_mass;
        }
    }
    pull
}

/// Each structural spring stands for the material around it (`cloth_mesh::structural_scale`),
/// so the same 1 x 0.5 m sheet is one material in square cells of 5 cm and in cells 2 cm along
/// x and 12.5 cm across: stretched alike, it pulls back alike. With one stiffness for every
/// spring the thin cells pulled 0.13 of the square ones (a sheet's tension goes as its cells'
/// width over their length), and a strip of cells 5 mm by 50 cm hung 1.6-2.2x stretched over
/// the standard scene's sphere. Van Gelder's weights leave the two at 0.80 (a square cell's
/// diagonal takes a share of the tension, a thin cell's almost none); bend springs keep one
/// stiffness (with them the ratio is 0.69).
#[test]
fn a_mesh_cloth_is_one_material_whatever_its_triangles_shapes() {
    let square = tension_along_x(sheet(21, 11, (1.0, 0.5)));
    let thin = tension_along_x(sheet(51, 5, (1.0, 0.5)));
    let ratio = thin / square;
    assert!(square > 0.0 && (0.75..=1.25).contains(&ratio), "tension {thin} N (thin cells) against {square} N");
}

/// A needle's short edge would take a stiffness that needs many times the substeps: its scale
/// is capped (`MAX_STIFFNESS_SCALE`), counted for the build's warning.
#[test]
fn a_needle_triangle_s_short_edge_is_capped() {
    use drape::cloth_mesh::{MAX_STIFFNESS_SCALE, structural_scale};
    assert_eq!(structural_scale(0.5, 1.0), 0.5);
    assert_eq!(structural_scale(1.0, 1e-4), MAX_STIFFNESS_SCALE);
    assert_eq!(structural_scale(0.0, 1.0), 1.0, "an edge of flat triangles keeps its family's stiffness");
    assert_eq!(structural_scale(1.0, 0.0), 1.0, "an edge of no length too");
    let needle = ClothMesh::from_parts(
        vec![Vec3::ZERO, Vec3::new(0.001, 0.0, 0.0), Vec3::new(0.0005, 0.0, 1.0), Vec3::new(0.0005, 0.0, -1.0)],
        vec![[0, 1, 2], [0, 3, 1]],
    )
    .unwrap();
    let cloth = ClothBuilder::from_mesh(needle).build().unwrap();
    assert_eq!(springs_of(&cloth).capped_edges, 1, "the 1 mm edge between two 1 m needles");
}

/// Runtime stiffness changes reach a mesh cloth's bound: ten times stiffer needs more substeps.
#[test]
fn stiffening_a_mesh_cloth_raises_its_substeps() {
    let cloth = ClothBuilder::from_mesh(disc(4, 16, 0.5)).build().unwrap();
    let model = Model::single(&cloth, &[], SimSettings::default()).unwrap();
    let mut sim = CpuSolver::new(&model).unwrap();
    let before = sim.stability(CLOTH).unwrap().substeps;
    sim.set_stiffness(CLOTH, 400.0, 10.0, 20.0).unwrap();
    let after = sim.stability(CLOTH).unwrap().substeps;
    assert!(after as f32 > 2.5 * before as f32, "{before} -> {after} substeps");
    sim.step().unwrap();
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("drape-cloth-mesh-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The same quad written as exporters that keep one vertex per UV write it: vertex 2 (x = 1)
/// repeated for its second texture coordinate, and a sliver triangle through both copies.
/// `weld_coincident` joins the copy into the first (the order of the rest kept), keeps each
/// corner's UV, and drops the triangle that then has a corner twice.
#[test]
fn weld_joins_a_vertex_split_for_its_uvs_and_keeps_the_uvs() {
    let dir = temp_dir("weld");
    let path = dir.join("split.obj");
    let text = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 1 0 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0\n\
                f 1/1 3/3 2/2\nf 1/1 4/4 3/3\nf 5/5 3/3 4/4\nf 2/2 5/5 3/3\n";
    std::fs::write(&path, text).unwrap();
    let mesh = ClothMesh::load_obj(&path).unwrap();
    assert_eq!((mesh.vertices.len(), mesh.coincident_vertices()), (5, 1));
    let (welded, joined) = mesh.weld_coincident();
    assert_eq!(joined, 1);
    assert_eq!(welded.vertices, vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z]);
    assert_eq!(welded.triangles, vec![[0, 2, 1], [0, 3, 2], [1, 2, 3]]);
    let uvs = welded.uvs.clone().expect("UVs");
    assert_eq!(uvs.triangles, vec![[0, 2, 1], [0, 3, 2], [4, 2, 3]]);
    assert_eq!(welded.coincident_vertices(), 0);
    // Joined, the cloth is one piece: vertex 1's springs now reach vertex 3 across the seam.
    let cloth = ClothBuilder::from_mesh(welded).build().unwrap();
    assert!(cloth.structural_springs().iter().any(|&(a, b, _)| (a.min(b), a.max(b)) == (1, 3)));
    std::fs::remove_dir_all(&dir).ok();
}

/// An OBJ quad whose UV seam gives vertex 1 two texture coordinates: the cloth keeps the four
/// `v` in order (one particle per vertex, no split at the seam), the UVs per corner, and an
/// exported frame carries them back (`f v/vt/vn`).
#[test]
fn an_obj_cloth_keeps_its_vertex_order_and_uvs() {
    let dir = temp_dir("uvs");
    let path = dir.join("quad.obj");
    // (A comment after a face's corners is cut off, not read as a corner.)
    let text = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0\n\
                f 1/1 3/3 2/2 # seam\nf 1/1 4/4 3/3\nf 2/5 3/3 4/4\n";
    std::fs::write(&path, text).unwrap();
    let mesh = ClothMesh::load_obj(&path).unwrap();
    assert_eq!(mesh.vertices, vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z]);
    assert_eq!(mesh.triangles, vec![[0, 2, 1], [0, 3, 2], [1, 2, 3]]);
    let uvs = mesh.uvs.clone().expect("UVs");
    assert_eq!(uvs.triangles, vec![[0, 2, 1], [0, 3, 2], [4, 2, 3]]);
    assert_eq!(uvs.coords[4], glam::Vec2::new(0.5, 0.0));
    let cloth = ClothBuilder::from_mesh(mesh).build().unwrap();
    let out = dir.join("frame.obj");
    let normals = vec![Vec4::Y; 4];
    drape::obj::write_cloth_obj(&out, &cloth, &cloth.positions, &normals).unwrap();
    let written = std::fs::read_to_string(&out).unwrap();
    assert_eq!(written.lines().filter(|l| l.starts_with("vt ")).count(), 5);
    assert!(written.contains("f 2/5/2 3/3/3 4/4/4"), "{written}");
    let again = ClothMesh::load_obj(&out).unwrap();
    assert_eq!(again.uvs.unwrap().triangles, uvs.triangles);
    // A grid cloth's frames carry UVs across the grid.
    let grid = ClothBuilder::new(3, 3).build().unwrap();
    drape::obj::write_cloth_obj(&out, &grid, &grid.positions, &[Vec4::Y; 9]).unwrap();
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(written.contains("vt 0.5 0.5") && written.contains("f 1/1/1 4/4/4 2/2/2"), "{written}");
    std::fs::remove_dir_all(dir).ok();
}

/// `drape --cloth-mesh FILE` drapes a mesh cloth over the collider (nothing inside, resting at
/// the thickness) with pins from `--pin-vertices`, and writes its frames with UVs; a bad box
/// or a grid size beside a mesh cloth is a usage error.
#[test]
fn cli_cloth_mesh_drapes_a_mesh_cloth() {
    let dir = temp_dir("cli");
    let (path, frames) = (dir.join("disc.obj"), dir.join("frames"));
    let mesh = disc(10, 32, 0.7);
    let mut text = String::new();
    for v in &mesh.vertices {
        text += &format!("v {} {} {}\nvt {} {}\n", v.x, v.y, v.z, 0.5 + v.x, 0.5 + v.z);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        text += &format!("f {a}/{a} {b}/{b} {c}/{c}\n");
    }
    std::fs::write(&path, text).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--cloth-mesh", path.to_str().unwrap(), "--pin-vertices", "0", "--frames", "90", "--no-timestamps"])
        .arg("--obj-dir")
        .arg(&frames)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    assert!(
        stdout.contains(&format!("cloth: mesh {} (321 particles, 608 triangles, UVs)", path.display())),
        "{stdout}"
    );
    assert!(stdout.contains("particles inside the mesh   0.000 %"), "{stdout}");
    let gap: f32 = stdout
        .split("gap to true surface mean ")
        .nth(1)
        .and_then(|r| r.split(" mm").next())
        .and_then(|g| g.trim().parse().ok())
        .unwrap_or_else(|| panic!("no gap in\n{stdout}"));
    assert!((2.5..=7.5).contains(&gap), "resting gap {gap} mm for a 5 mm thickness\n{stdout}");
    let frame = std::fs::read_to_string(frames.join("frame_00090.obj")).unwrap();
    assert_eq!(frame.lines().filter(|l| l.starts_with("vt ")).count(), 321);
    for bad in [&["--pin-box", "1,1,1,0,0,0"][..], &["--grid", "8"]] {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--cloth-mesh", path.to_str().unwrap()])
            .args(bad)
            .output()
            .unwrap();
        assert_eq!(output.status.code(), Some(2), "{bad:?} must be a usage error");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains("--pin-box") || stderr.contains("--grid"), "{bad:?}: {stderr}");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// `drape --cloth-mesh` with a cloth that starts through itself (a sheet crossed by another
/// standing through its middle): the run warns before its first frame, since no frame undoes a
/// crossing it did not make; an untangled cloth gets no such warning.
#[test]
fn cli_warns_of_a_cloth_mesh_that_starts_crossed() {
    let dir = temp_dir("starts-crossed");
    let mut obj = String::new();
    // Two 3 x 3 sheets of 2 x 2 cells: one flat (y = 0), one upright (z = 0.05, across the
    // middle of the flat one's cells) from 5 cm below it to 15 cm above.
    for sheet in 0..2 {
        for i in 0..3 {
            for j in 0..3 {
                let (a, b) = (i as f32 * 0.1 - 0.1, j as f32 * 0.1 - 0.1);
                let (x, y, z) = if sheet == 0 { (a, 0.0, b) } else { (a, b + 0.05, 0.05) };
                obj += &format!("v {x} {y} {z}\n");
            }
        }
    }
    let flat_only = obj.clone();
    for sheet in 0..2 {
        for i in 0..2 {
            for j in 0..2 {
                let v = |di: u32, dj: u32| 9 * sheet + 3 * (i + di) + (j + dj) + 1;
                obj += &format!("f {} {} {}\nf {} {} {}\n", v(0, 0), v(1, 0), v(1, 1), v(0, 0), v(1, 1), v(0, 1));
            }
        }
    }
    let run = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--cloth-mesh", path.to_str().unwrap(), "--self-collision", "on", "--frames", "1", "--quiet"])
            .output()
            .unwrap();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let crossed = run("crossed.obj", &obj);
    let pairs: usize = crossed
        .split("the cloth starts crossed: ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no warning in\n{crossed}"));
    assert!(pairs > 0 && !crossed.contains("lie exactly on earlier"), "{crossed}");
    // The flat sheet alone (its 9 vertices and its 8 triangles, the first sheet's faces).
    let faces: String = obj.lines().filter(|l| l.starts_with("f ")).take(8).map(|l| format!("{l}\n")).collect();
    let clean = run("flat.obj", &(flat_only.lines().take(9).map(|l| format!("{l}\n")).collect::<String>() + &faces));
    assert!(!clean.contains("starts crossed"), "{clean}");
    std::fs::remove_dir_all(dir).ok();
}

/// `drape --cloth-mesh` with triangles of no area (a corner twice, corners on one line) beside
/// a good one: it runs, and warns how many it keeps that add nothing.
#[test]
fn cli_warns_of_a_cloth_mesh_with_flat_triangles() {
    let dir = temp_dir("flat-triangles");
    let path = dir.join("flat.obj");
    let obj = "v 0 0 0\nv 0.1 0 0\nv 0 0 0.1\nv 0.2 0 0\nf 1 2 3\nf 1 2 2\nf 1 2 4\n";
    std::fs::write(&path, obj).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--cloth-mesh", path.to_str().unwrap(), "--frames", "1", "--quiet"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("cloth mesh: 2 triangles have no area"), "{stderr}");
    std::fs::remove_dir_all(dir).ok();
}

/// `drape --cloth-mesh` with a face given twice (once in the other winding) and once more
/// with its corners in another order: it runs, and warns how many triangles repeat an earlier
/// one; the same mesh without them does not warn.
#[test]
fn cli_warns_of_a_cloth_mesh_with_repeated_triangles() {
    let dir = temp_dir("repeated-triangles");
    let run = |name: &str, obj: &str| {
        let path = dir.join(name);
        std::fs::write(&path, obj).unwrap();
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--cloth-mesh", path.to_str().unwrap(), "--frames", "1", "--quiet"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "{stderr}");
        stderr
    };
    let square = "v 0 0 0\nv 0.1 0 0\nv 0 0 0.1\nv 0.1 0 0.1\nf 1 2 3\nf 2 4 3\n";
    let repeated = run("repeated.obj", &format!("{square}f 1 3 2\nf 3 4 2\n"));
    assert!(repeated.contains("cloth mesh: 2 triangles repeat an earlier one"), "{repeated}");
    let clean = run("square.obj", square);
    assert!(!clean.contains("repeat an earlier one"), "{clean}");
    std::fs::remove_dir_all(dir).ok();
}

/// A self-collision thickness over the closest that neighbouring features of the cloth sharing
/// no particle lie at rest (the standard 1.4 m cloth at 64 x 64: a vertex 15.66 mm from the
/// diagonal across the next cell) is logged (`DRAPE_LOG=info`) with that distance and the
/// triangles it concerns, whose pairs answer only a crossing; under it, nothing. (The shortest
/// edge, 22.2 mm, is what drape compared with before.)
#[test]
fn cli_logs_a_self_collision_thickness_the_cloth_touches_at_rest() {
    let run = |thickness: &str| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--self-collision", "on", "--thickness", thickness, "--frames", "1", "--quiet"])
            .env("DRAPE_LOG", "info")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "{stderr}");
        stderr
    };
    let thick = run("0.016");
    assert!(
        thick.contains("self-collision thickness 16.00 mm is over 15.66 mm")
            && thick.contains("in 7938 of its 7938 triangles: those pairs answer only a crossing"),
        "{thick}"
    );
    let thin = run("0.015");
    assert!(!thin.contains("self-collision thickness"), "{thin}");
}

/// `drape --scene pile`: a 64 x 16 strip falls upright onto the ground plane and piles up,
/// with self-collision on by default; the run ends with the exact intersection counts of the
/// final frame (cloth-cloth, and both ways between cloth and collider). `--self-collision off`
/// lets the strip pass through itself, and the count says so; it never passes the ground.
#[test]
fn cli_pile_scene_reports_exact_intersections() {
    let run = |extra: &[&str]| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--scene", "pile", "--frames", "120", "--no-timestamps"])
            .args(extra)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout).to_string();
        assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
        let count = |label: &str| -> usize {
            let after = stdout.split(label).nth(1).unwrap_or_else(|| panic!("no `{label}` in\n{stdout}"));
            after.split(|c: char| !c.is_ascii_digit()).find(|w| !w.is_empty()).unwrap().parse().unwrap()
        };
        assert_eq!(count("cloth edges through the collider "), 0, "{stdout}");
        assert_eq!(count("collider edges through the cloth "), 0, "{stdout}");
        assert!(stdout.contains("particles inside the mesh   n/a (open mesh: no inside)"), "{stdout}");
        (count("cloth-cloth "), stdout)
    };
    let (with, stdout) = run(&[]);
    assert!(stdout.contains("cloth: 64 x 16 particles, self-collision on (5.0 mm, friction 0.5)"), "{stdout}");
    let (without, stdout) = run(&["--self-collision", "off"]);
    assert!(stdout.contains("self-collision off"), "{stdout}");
    assert!(without > 500, "without self-collision the strip crosses itself ({without})");
    assert!(with * 20 < without, "self-collision must remove nearly all crossings: {without} -> {with}");
}

/// `--cloth-mesh` given twice makes the two files pieces of one cloth (`ClothMesh::join`): a
/// 0.6 m sheet and the same sheet 2 cm above it, dropped on the standard scene's sphere. With
/// self-collision on, no frame has the pieces through each other and the upper one lies on the
/// lower at the end; off, the two rest at the same height, one through the other (the pieces
/// meet only through self-collision). A scene file takes the pieces as a list of paths beside it,
/// and `--print-scene` writes them back as one.
#[test]
fn cli_cloth_mesh_pieces_are_one_cloth_that_keeps_them_apart() {
    let dir = temp_dir("pieces");
    std::fs::write(dir.join("lower.obj"), sheet_obj(12, 0.6, 0.0)).unwrap();
    std::fs::write(dir.join("upper.obj"), sheet_obj(12, 0.6, 0.02)).unwrap();
    std::fs::write(dir.join("pieces.toml"), "cloth-mesh = [\"lower.obj\", \"upper.obj\"]\nframes = 60\n").unwrap();
    // The centre particle's height on the upper piece over the lower's at the last frame.
    let run = |self_collision: &str| {
        let frames = dir.join(format!("frames-{self_collision}"));
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .arg("--scene-file")
            .arg(dir.join("pieces.toml"))
            .args(["--self-collision", self_collision, "--check-every-frame", "--no-timestamps", "--obj-dir"])
            .arg(&frames)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout).to_string();
        assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
        let names = format!("cloth: mesh {} + {} (288 particles, 484 triangles, UVs)", "lower.obj", "upper.obj");
        let shown = stdout.lines().find(|l| l.starts_with("cloth: mesh")).unwrap_or_default().to_string();
        let paths_only = shown.replace(&format!("{}/", std::path::absolute(&dir).unwrap().display()), "");
        assert!(paths_only.starts_with(&names), "{shown}\n{stdout}");
        let frame = std::fs::read_to_string(frames.join("frame_00060.obj")).unwrap();
        let heights: Vec<f32> = frame
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
            .collect();
        assert_eq!(heights.len(), 288);
        let centre = 6 * 12 + 6;
        (heights[144 + centre] - heights[centre], stdout)
    };
    let (apart, stdout) = run("on");
    assert!(stdout.contains("intersections (exact, every frame): frames with any 0 of 60"), "{stdout}");
    assert!(apart > 0.003, "the upper piece lies {apart} m over the lower one, under the 5 mm thickness\n{stdout}");
    let (through, stdout) = run("off");
    assert!(through.abs() < 0.001, "without self-collision the pieces rest {through} m apart\n{stdout}");
    assert!(!stdout.contains("frames with any 0 of 60"), "without self-collision the pieces cross\n{stdout}");
    let printed = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .arg("--scene-file")
        .arg(dir.join("pieces.toml"))
        .arg("--print-scene")
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&printed.stdout);
    let absolute = |name: &str| std::path::absolute(dir.join(name)).unwrap().display().to_string();
    let list = format!("cloth-mesh = [\"{}\", \"{}\"]", absolute("lower.obj"), absolute("upper.obj"));
    assert!(printed.lines().any(|l| l == list), "{printed}");
    for bad in ["[]", "[\"lower.obj\", 3]"] {
        std::fs::write(dir.join("bad.toml"), format!("cloth-mesh = {bad}\n")).unwrap();
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .arg("--scene-file")
            .arg(dir.join("bad.toml"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "cloth-mesh = {bad}: {stderr}");
        assert!(stderr.contains("line 1: `cloth-mesh` takes a path or a list of paths"), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `ClothMesh::join`: each piece's vertices follow the last's, its triangles and texture
/// coordinates renumbered with them; a piece without UVs leaves the whole cloth without.
#[test]
fn joined_pieces_follow_one_another() {
    let quad = |x: f32| {
        let vertices = vec![Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 0.0, 1.0)];
        ClothMesh::from_parts(vertices, vec![[0, 1, 2]]).unwrap()
    };
    let mut a = quad(0.0);
    a.uvs = Some(drape::cloth_mesh::ClothUvs { coords: vec![glam::Vec2::ZERO; 4], triangles: vec![[0, 3, 2]] });
    let mut b = quad(5.0);
    b.uvs = Some(drape::cloth_mesh::ClothUvs { coords: vec![glam::Vec2::ONE; 3], triangles: vec![[2, 1, 0]] });
    let joined = ClothMesh::join(&[a.clone(), b.clone()]);
    assert_eq!(joined.vertices.len(), 6);
    assert_eq!(joined.vertices[3], Vec3::new(5.0, 0.0, 0.0));
    assert_eq!(joined.triangles, vec![[0, 1, 2], [3, 4, 5]]);
    let uvs = joined.uvs.expect("both pieces have UVs");
    assert_eq!((uvs.coords.len(), uvs.triangles), (7, vec![[0, 3, 2], [6, 5, 4]]));
    assert!(ClothMesh::join(&[a, quad(9.0)]).uvs.is_none());
    let cloth = ClothBuilder::from_mesh(ClothMesh::join(&[b.clone(), b])).build().unwrap();
    assert_eq!(cloth.structural_springs().len(), 6, "no spring joins the pieces");
}
