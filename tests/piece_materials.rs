//! Pieces of one cloth with materials of their own (issue 8: a stiff coat over a soft shirt):
//! `ClothMesh::join` remembers each triangle's piece, `PieceMaterial` gives a piece its own
//! stiffness and areal density, the springs and masses follow (a seam between two materials
//! takes both), the GPU equals the CPU twin on such a cloth, the stability bound follows the
//! stiffest and lightest piece, and the CLI's `--piece-stiffness` and `--piece-density` (flags
//! and scene files).

mod common;

use common::{assert_validation_clean, context, sheet, sheet_obj};
use drape::cloth_mesh::SpringTopology;
use drape::{
    Cloth, ClothBuilder, ClothId, ClothMesh, ClothTopology, CpuSolver, Error, Model, PieceMaterial, SimSettings, Solver,
};
use drape_kernels::cloth::{BEND, STRUCTURAL};
use glam::{Vec3, Vec4};

const CLOTH: ClothId = ClothId::new(0);

/// A strip hanging in the XY plane: `columns x rows` vertices, `width` across and `length`
/// down from its top row at y = 0, its left edge at `x`.
fn hanging_strip(columns: u32, rows: u32, (width, length): (f32, f32), x: f32) -> ClothMesh {
    let mut mesh = sheet(columns, rows, (width, length), Vec3::ZERO);
    for v in &mut mesh.vertices {
        *v = Vec3::new(x + v.x, -v.z, 0.0);
    }
    mesh
}

fn springs_of(cloth: &Cloth) -> &SpringTopology {
    match &cloth.topology {
        ClothTopology::Springs(s) => s,
        ClothTopology::Grid => panic!("expected a spring-list cloth"),
    }
}

/// Each spring once (i < j) as (i, j, family, stiffness scale).
fn springs_once(cloth: &Cloth) -> Vec<(u32, u32, u32, f32)> {
    let s = springs_of(cloth);
    let mut out = Vec::new();
    for (i, p) in s.particles.iter().enumerate() {
        for spring in &s.springs[p.first as usize..(p.first + p.count) as usize] {
            if (i as u32) < spring.other {
                out.push((i as u32, spring.other, spring.family, spring.stiffness_scale));
            }
        }
    }
    out
}

/// The mass (kg) of particles `range` of a built mesh cloth.
fn mass_of(cloth: &Cloth, range: std::ops::Range<usize>) -> f32 {
    springs_of(cloth).particles[range].iter().map(|p| 1.0 / p.inverse_mass).sum()
}

/// `join` numbers the pieces in order, a joined mesh joined again keeping its own; welding
/// keeps each remaining triangle's piece.
#[test]
fn joined_pieces_remember_each_triangle_s_piece() {
    let one = sheet(2, 2, (1.0, 1.0), Vec3::ZERO);
    let two = sheet(3, 2, (1.0, 1.0), Vec3::X);
    let inner = ClothMesh::join(&[one.clone(), two.clone()]);
    assert_eq!((inner.triangle_pieces.clone(), inner.piece_count()), (vec![0, 0, 1, 1, 1, 1], 2));
    let joined = ClothMesh::join(&[two.clone(), inner, one.clone()]);
    assert_eq!(joined.triangle_pieces, vec![0, 0, 0, 0, 1, 1, 2, 2, 2, 2, 3, 3]);
    assert_eq!(joined.piece_count(), 4);
    assert_eq!((one.piece_count(), one.piece_of(1)), (1, 0), "a mesh of its own is piece 0");
    // `one` ends at x = 1 where `two` starts: welded, the pieces are sewn and keep their pieces.
    let (welded, merged) = ClothMesh::join(&[one, two]).weld_coincident();
    assert_eq!(merged, 2);
    assert_eq!(welded.triangle_pieces, vec![0, 0, 1, 1, 1, 1]);
}

/// A piece's own density gives its particles its mass; the other piece keeps the cloth's mean
/// density (its mass over its area), and the cloth's mass is their sum.
#[test]
fn a_piece_s_own_density_gives_its_particles_their_mass() {
    let lower = sheet(6, 4, (1.0, 0.5), Vec3::ZERO);
    let upper = sheet(6, 4, (1.0, 0.5), Vec3::new(0.0, 0.1, 0.0));
    let mesh = ClothMesh::join(&[lower, upper]);
    let plain = ClothBuilder::from_mesh(mesh.clone()).build().unwrap();
    let heavy = ClothBuilder::from_mesh(mesh)
        .piece_material(1, PieceMaterial { density: Some(0.5), ..Default::default() })
        .build()
        .unwrap();
    let close = |a: f32, b: f32| (a - b).abs() < 1e-5 * b;
    // 0.2 kg/m^2, the default, over 0.5 m^2 per piece.
    for cloth in [&plain, &heavy] {
        assert!(close(mass_of(cloth, 0..24), 0.1), "the lower piece weighs {} kg", mass_of(cloth, 0..24));
    }
    assert!(close(mass_of(&plain, 24..48), 0.1));
    assert!(close(mass_of(&heavy, 24..48), 0.25), "the upper piece weighs {} kg", mass_of(&heavy, 24..48));
    assert!(close(heavy.params.particle_mass * 48.0, 0.35), "mean mass {}", heavy.params.particle_mass);
}

/// A piece's own stiffness scales its springs as multiples of the cloth's, structural and bend
/// each by its own ratio; a seam sewn between two materials takes their mean by area.
#[test]
fn a_piece_s_own_stiffness_scales_its_springs_and_a_seam_takes_both() {
    let left = sheet(5, 5, (0.4, 0.4), Vec3::ZERO);
    let right = sheet(5, 5, (0.4, 0.4), Vec3::new(0.4, 0.0, 0.0));
    let (mesh, _) = ClothMesh::join(&[left, right]).weld_coincident();
    let stiff = PieceMaterial { stiffness: Some(Vec3::new(120.0, 10.0, 1.0)), ..Default::default() };
    let plain = ClothBuilder::from_mesh(mesh.clone()).stiffness(40.0, 10.0, 2.0).build().unwrap();
    let mixed =
        ClothBuilder::from_mesh(mesh.clone()).stiffness(40.0, 10.0, 2.0).piece_material(1, stiff).build().unwrap();
    let (plain, mixed) = (springs_once(&plain), springs_once(&mixed));
    assert_eq!(plain.len(), mixed.len());
    let x = |i: u32| mesh.vertices[i as usize].x;
    let (mut seam, mut right_side) = (0, 0);
    for (&(a, b, family, scale), &(_, _, _, mixed_scale)) in plain.iter().zip(&mixed) {
        // The seam is x = 0.4: a spring with both ends on it is a seam edge, a bend spring with
        // an end on each side crosses it, and the rest lie on one side.
        let (lo, hi) = (x(a).min(x(b)), x(a).max(x(b)));
        let (on_left, on_right) = (hi <= 0.4 + 1e-6, lo >= 0.4 - 1e-6);
        let expected = match (family, on_left, on_right) {
            (STRUCTURAL, true, true) => 2.0, // a left and a right triangle of equal area
            (_, false, false) => 0.75,       // a bend spring crossing: 1 and 0.5 by area
            (_, true, false) => 1.0,
            (BEND, false, true) => 0.5,
            (_, false, true) => 3.0,
            (_, true, true) => unreachable!("only structural springs lie along the seam"),
        };
        seam += usize::from(on_left == on_right);
        right_side += usize::from(on_right && !on_left);
        let ratio = mixed_scale / scale;
        assert!((ratio - expected).abs() < 1e-5, "spring {a}-{b} (family {family}): {ratio}x, expected {expected}x");
    }
    assert!(seam >= 8 && right_side > 40, "{seam} seam springs, {right_side} on the right");
}

/// Two strips hang side by side from their pinned top rows, one four times as stiff as the
/// other: every frame on the GPU equals the CPU twin bit for bit, and about where they settle
/// the stiffer strip has stretched about a quarter as far under the same weight.
#[test]
fn a_two_material_cloth_on_the_gpu_equals_the_cpu_twin_and_the_stiffer_piece_stretches_less() {
    let (columns, rows, size) = (3, 21, (0.1, 1.0));
    let soft = hanging_strip(columns, rows, size, 0.0);
    let stiff = hanging_strip(columns, rows, size, 0.3);
    let cloth = ClothBuilder::from_mesh(ClothMesh::join(&[soft, stiff]))
        .piece_material(1, PieceMaterial { stiffness: Some(Vec3::new(160.0, 10.0, 2.0)), ..Default::default() })
        .spring_damping(0.05)
        .pin_within(Vec3::new(-1.0, -0.01, -1.0), Vec3::ONE)
        .build()
        .unwrap();
    let per_strip = (columns * rows) as usize;
    assert_eq!(cloth.positions.iter().filter(|p| p.w == 0.0).count(), 2 * columns as usize);
    let ctx = context();
    let model = Model::single(&cloth, &[], SimSettings::default()).unwrap();
    let mut gpu = Solver::new(&ctx, &model).unwrap();
    let mut cpu = CpuSolver::new(&model).unwrap();
    // How far each strip's bottom row hangs below where it started, summed over the last 60
    // frames (the strips still swing up and down about where they settle).
    let drop = |x: &[Vec4], strip: usize| {
        let bottom = (strip * per_strip + per_strip - columns as usize)..(strip + 1) * per_strip;
        bottom.map(|i| cloth.positions[i].y - x[i].y).sum::<f32>() / columns as f32
    };
    let (mut soft_drop, mut stiff_drop) = (0.0, 0.0);
    for frame in 1..=150 {
        gpu.step().unwrap();
        cpu.step().unwrap();
        let x = gpu.positions(CLOTH).unwrap();
        assert_eq!(x, cpu.positions(CLOTH).unwrap(), "frame {frame}: positions");
        assert_eq!(gpu.velocities(CLOTH).unwrap(), cpu.velocities(CLOTH).unwrap(), "frame {frame}: velocities");
        if frame > 90 {
            (soft_drop, stiff_drop) = (soft_drop + drop(&x, 0) / 60.0, stiff_drop + drop(&x, 1) / 60.0);
        }
    }
    println!("the strips stretched {soft_drop} m (soft) and {stiff_drop} m (4x as stiff)");
    assert!(
        stiff_drop > 0.0 && (3.0..=5.0).contains(&(soft_drop / stiff_drop)),
        "{soft_drop} m against {stiff_drop} m"
    );
    assert_validation_clean(&ctx);
}

/// The stability bound follows the stiffest and the lightest piece: nine times the stiffness or
/// a ninth of the density on one piece needs about three times the substeps.
#[test]
fn a_stiffer_or_lighter_piece_raises_the_substeps() {
    let mesh = ClothMesh::join(&[sheet(8, 8, (0.5, 0.5), Vec3::ZERO), sheet(8, 8, (0.5, 0.5), Vec3::Y)]);
    let substeps = |material: PieceMaterial| {
        let cloth = ClothBuilder::from_mesh(mesh.clone()).piece_material(1, material).build().unwrap();
        SimSettings::default().stability(&cloth).unwrap().substeps as f32
    };
    let plain = substeps(PieceMaterial::default());
    let stiff = substeps(PieceMaterial { stiffness: Some(Vec3::new(360.0, 10.0, 18.0)), ..Default::default() });
    let light = substeps(PieceMaterial { density: Some(0.2 / 9.0), ..Default::default() });
    for (what, n) in [("stiffer", stiff), ("lighter", light)] {
        assert!((2.4 * plain..=3.6 * plain).contains(&n), "{what} piece: {n} substeps against {plain}");
    }
}

/// A material for a piece the cloth does not have, for a grid, or that cannot be built is an
/// error naming the piece and the fix.
#[test]
fn bad_piece_materials_are_refused() {
    let mesh = ClothMesh::join(&[sheet(3, 3, (1.0, 1.0), Vec3::ZERO), sheet(3, 3, (1.0, 1.0), Vec3::Y)]);
    let dense = PieceMaterial { density: Some(0.3), ..Default::default() };
    let cases = [
        (ClothBuilder::from_mesh(mesh.clone()).piece_material(2, dense), "piece 2 does not exist"),
        (ClothBuilder::new(4, 4).piece_material(0, dense), "a grid cloth is one piece"),
        (
            ClothBuilder::from_mesh(mesh.clone())
                .piece_material(1, PieceMaterial { density: Some(-1.0), stiffness: None }),
            "density must be finite and > 0",
        ),
        (
            ClothBuilder::from_mesh(mesh.clone())
                .piece_material(0, PieceMaterial { stiffness: Some(Vec3::new(f32::NAN, 0.0, 0.0)), density: None }),
            "stiffness must be finite",
        ),
        (
            ClothBuilder::from_mesh(mesh.clone())
                .stiffness(40.0, 10.0, 0.0)
                .piece_material(1, PieceMaterial { stiffness: Some(Vec3::new(40.0, 10.0, 1.0)), density: None }),
            "bend stiffness is 1 where the cloth's is 0",
        ),
    ];
    for (builder, expected) in cases {
        match builder.build() {
            Err(Error::InvalidParameter { name: "piece material", problem }) => {
                assert!(problem.contains(expected), "`{problem}` should say `{expected}`")
            }
            other => panic!("expected a piece-material error saying `{expected}`, got {other:?}"),
        }
    }
    // A default material is no material: it names no piece.
    assert!(ClothBuilder::new(4, 4).piece_material(3, PieceMaterial::default()).build().is_ok());
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("drape-piece-materials-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn drape(args: &[&str]) -> (Option<i32>, String, String) {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).to_string();
    (output.status.code(), text(&output.stdout), text(&output.stderr))
}

/// The stiffest mode's frequency the run prints (rad/s).
fn omega_max(stdout: &str) -> f32 {
    let line = stdout.lines().find(|l| l.starts_with("stability: omega_max")).unwrap_or_else(|| panic!("{stdout}"));
    line.split_whitespace().nth(2).unwrap().parse().unwrap()
}

/// `--piece-stiffness` and `--piece-density` from the command line and from a scene file (a
/// string or a list of strings) give the second piece its material: the run says so, and its
/// stiffest mode is sqrt(4 / 2) as fast as the plain cloth's (4x the stiffness, 2x the mass);
/// `--print-scene` writes them back and the JSON report lists them; a piece the cloth does not have, one given twice, a value
/// of the wrong kind in the file and the flags without `--cloth-mesh` are usage errors.
#[test]
fn cli_pieces_take_their_own_materials() {
    let dir = temp_dir("cli");
    std::fs::write(dir.join("lower.obj"), sheet_obj(10, 0.6, 0.0)).unwrap();
    std::fs::write(dir.join("upper.obj"), sheet_obj(10, 0.6, 0.02)).unwrap();
    let (lower, upper) = (dir.join("lower.obj"), dir.join("upper.obj"));
    let (lower, upper) = (lower.to_str().unwrap(), upper.to_str().unwrap());
    let run = ["--frames", "2", "--no-timestamps", "--self-collision", "on"];
    let meshes = ["--cloth-mesh", lower, "--cloth-mesh", upper];
    let (code, plain, stderr) = drape(&[&meshes[..], &run[..]].concat());
    assert_eq!(code, Some(0), "{stderr}");
    let json = dir.join("report.json");
    let flags = ["--piece-stiffness", "2=160,0,8", "--piece-density", "2=0.4", "--json", json.to_str().unwrap()];
    let (code, own, stderr) = drape(&[&meshes[..], &run[..], &flags[..]].concat());
    assert_eq!(code, Some(0), "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let expected =
        serde_json::json!([{ "piece": 2, "stiffness_n_per_m": [160.0, 0.0, 8.0], "density_kg_per_m2": 0.4 }]);
    assert_eq!(report["cloth"]["piece_materials"], expected, "{report}");
    assert!(own.contains("piece 2 (stiffness 160,0,8 N/m, 0.4 kg/m^2), self-collision on"), "{own}");
    let ratio = omega_max(&own) / omega_max(&plain);
    assert!((ratio - 2f32.sqrt()).abs() < 0.02, "omega_max {ratio}x the plain cloth's");

    let scene = dir.join("pieces.toml");
    std::fs::write(
        &scene,
        "cloth-mesh = [\"lower.obj\", \"upper.obj\"]\npiece-stiffness = [\"2=160,0,8\"]\npiece-density = \"2=0.4\"\n",
    )
    .unwrap();
    let scene = scene.to_str().unwrap();
    let (code, from_file, stderr) = drape(&[&["--scene-file", scene][..], &run[..]].concat());
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(omega_max(&from_file), omega_max(&own), "{from_file}");
    let (_, printed, _) = drape(&["--scene-file", scene, "--piece-density", "1=0.3", "--print-scene"]);
    assert!(printed.lines().any(|l| l == "piece-stiffness = \"2=160,0,8\""), "{printed}");
    assert!(printed.lines().any(|l| l == "piece-density = \"1=0.3\""), "the flag overrides the file: {printed}");
    let (_, printed, _) = drape(
        &[&meshes[..], &["--piece-density", "1=0.3", "--piece-density", "2=0.1"][..], &["--print-scene"][..]].concat(),
    );
    assert!(printed.lines().any(|l| l == "piece-density = [\"1=0.3\", \"2=0.1\"]"), "{printed}");

    let usage = [
        (vec!["--piece-density", "3=0.3"], "there is no piece 3, the cloth has 2"),
        (vec!["--piece-stiffness", "1=1,1,1", "--piece-stiffness", "1=2,2,2"], "gives piece 1 twice"),
        (vec!["--piece-density", "0=0.3"], "a whole number from 1"),
        (vec!["--stiffness", "40,0,0", "--piece-stiffness", "2=40,0,1"], "where --stiffness has 0"),
        // A mesh cloth has no shear springs: a shear stiffness would do nothing.
        (vec!["--piece-stiffness", "2=160,10,8"], "2=160,10,8: a cloth from --cloth-mesh has no shear springs"),
    ];
    for (flags, expected) in usage {
        let (code, _, stderr) = drape(&[&meshes[..], &flags[..], &["--frames", "1"][..]].concat());
        assert_eq!(code, Some(2), "{flags:?}: {stderr}");
        assert!(stderr.contains(expected), "{flags:?}: `{stderr}` should say `{expected}`");
    }
    let (code, _, stderr) = drape(&["--piece-density", "1=0.3", "--frames", "1"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("only applies to the pieces of a cloth from --cloth-mesh"), "{stderr}");
    std::fs::write(dir.join("bad.toml"), "cloth-mesh = [\"lower.obj\"]\npiece-density = [1]\n").unwrap();
    let (code, _, stderr) = drape(&["--scene-file", dir.join("bad.toml").to_str().unwrap()]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("line 2: `piece-density` takes a string or a list of strings"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
