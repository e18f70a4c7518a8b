//! The CLI's answers to bad input (issue 10): usage errors exit with 2 and name the flag and
//! the allowed values before any work starts; runtime errors exit with 1 and name the file;
//! nothing panics. And the vector flags take X,Y,Z with negatives.

use std::process::{Command, Output};

fn drape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().unwrap()
}

/// A directory of this process's own under the temporary directory, made if missing.
fn scratch_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("drape-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `text` to `name` in `dir`; returns its path as a string (an argument).
fn write_in(dir: &std::path::Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// Every bad input gets its exit code and a message naming the cause.
#[test]
fn bad_input_gets_a_clear_message_and_the_right_exit_code() {
    let usage = 2;
    let runtime = 1;
    let cases: &[(&[&str], i32, &str)] = &[
        (&["--scene", "swing", "--mesh", "bunny"], usage, "--mesh does nothing in the swing scene"),
        (
            &["--scene", "swing", "--self-collision", "off", "--friction", "0.1"],
            usage,
            "--friction does nothing in the swing scene",
        ),
        (
            &["--scene", "swing", "--self-collision", "off", "--thickness", "0.002"],
            usage,
            "--thickness does nothing in the swing scene",
        ),
        (&["--wind", "1,0,0"], usage, "--wind only applies to the swing scene"),
        (&["--scene", "pile", "--holes", "keep"], usage, "--holes does nothing in the pile scene"),
        (&["--voxels", "8"], usage, "--voxels only applies with --contact spheres"),
        (&["--weld"], usage, "--weld only applies to a cloth from --cloth-mesh"),
        (&["--obj-every", "3"], usage, "--obj-every needs --obj-dir"),
        (&["--scene", "garment", "--grid", "4"], usage, "--grid 4 is too few particles around the garment"),
        (&["--thickness", "1000"], usage, "[0.0001, 0.5]"),
        (&["--thickness", "1e-8"], usage, "[0.0001, 0.5]"),
        (&["--friction", "-1"], usage, "[0, 10]"),
        (&["--stiffness", "1e30,1,1"], usage, "[0, 1000000]"),
        (&["--stiffness", "40"], usage, "K_STRUCT,K_SHEAR,K_BEND"),
        (&["--wind", "1,0"], usage, "X,Y,Z"),
        (&["--velocity", "0,-1e9,0"], usage, "at most 1000 m/s"),
        (&["--substeps", "0"], usage, "1..=100000"),
        (&["--grid", "4096"], usage, "2..=2048"),
        (&["--grid", "8", "--grid", "9"], usage, "cannot be used multiple times"),
        (&["--frames", "0"], usage, "--frames"),
        (&["--pin-box", "1,1,1,0,0,0"], usage, "min <= max"),
        (&["--mesh", "/nonexistent/model.obj", "--frames", "1"], runtime, "/nonexistent/model.obj"),
        (&["--cloth-mesh", "/nonexistent/cloth.obj", "--frames", "1"], runtime, "/nonexistent/cloth.obj"),
        (&["--obj-dir", "/proc/drape-cannot-write-here", "--frames", "1"], runtime, "--obj-dir"),
        (&["--json", "/nonexistent/dir/report.json", "--frames", "1"], runtime, "--json"),
        (
            &["--json", "/dev/full", "--frames", "1", "--grid", "8"],
            runtime,
            "`--json`: the report could not be written",
        ),
        (&["--usd", "/nonexistent/dir/cloth.usda", "--frames", "1"], runtime, "--usd"),
        (&["--sleep", "-1"], usage, "[0, 10]"),
        (&["--contact-substeps", "maybe"], usage, "--contact-substeps"),
        (&["--png-every", "5"], usage, "--png-every needs --png-dir"),
        (&["--png-size", "320x240"], usage, "--png-size needs --png-dir"),
        (&["--png-dir", "/tmp/drape-unused", "--png-size", "8x8"], usage, "16..=4096"),
        (&["--png-dir", "/tmp/drape-unused", "--png-size", "640"], usage, "WIDTHxHEIGHT"),
        (&["--png-dir", "/tmp/drape-unused", "--no-normals"], usage, "--no-normals"),
        (&["--png-dir", "/proc/drape-cannot-write-here", "--frames", "1"], runtime, "--png-dir"),
        // Flags that would do nothing with the others given.
        (
            &["--self-collision", "off", "--self-failsafe", "off"],
            usage,
            "--self-failsafe only applies with --self-collision on",
        ),
        (
            &["--self-collision", "off", "--self-list-windows", "off"],
            usage,
            "--self-list-windows only applies with --self-collision on",
        ),
        (
            &["--self-collision", "off", "--feature-walks", "cloth"],
            usage,
            "--feature-walks only applies with --self-collision on",
        ),
        (&["--scene", "swing", "--crowded-contact", "on"], usage, "--crowded-contact does nothing in the swing scene"),
        (
            &["--one-workgroup-substeps", "on"],
            usage,
            "--one-workgroup-substeps only applies to a cloth with no collider",
        ),
        (
            &["--self-collision", "off", "--substeps", "3", "--contact-substeps", "off"],
            usage,
            "--contact-substeps does nothing with --substeps",
        ),
        (&["--scene", "pile", "--grid", "4"], usage, "--grid 4 is too few particles along the pile scene's strip"),
        (&["--scene", "swing", "--wind=1e37,0,0"], usage, "at most 1e6 N"),
        (&["--grid", "8", "--pin-box=-10,-10,-10,10,10,10", "--frames", "1"], runtime, "they pin all 64 particles"),
        (
            &["--grid", "8", "--pin-vertices", "64", "--frames", "1"],
            runtime,
            "`--pin-vertices`: particle 64 does not exist: the cloth has 64 particles, numbered 0 to 63",
        ),
        (
            &["--obj-dir", concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"), "--frames", "1"],
            runtime,
            "it is a file, not a directory",
        ),
        (
            &["--usd", "/dev/full", "--frames", "1", "--grid", "8"],
            runtime,
            "`--usd`: the USD cache could not be written",
        ),
    ];
    for &(args, code, needle) in cases {
        let output = drape(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(code), "{args:?}: exit code\n{stderr}");
        assert!(stderr.contains(needle), "{args:?}: the message must say `{needle}`:\n{stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

/// `--thickness` and `--friction` are what a self-colliding cloth keeps from itself and feels
/// between its layers, so the swing scene (no collider) takes them with `--self-collision on`
/// (and refuses them without, above).
#[test]
fn thickness_and_friction_set_the_swing_scene_self_collision() {
    let args = ["--scene", "swing", "--grid", "8", "--frames", "2", "--self-collision", "on", "--thickness", "0.002"];
    let output = drape(&[&args[..], &["--friction", "0.25"]].concat());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("self-collision on (2.0 mm, friction 0.25)"), "{stdout}");
}

/// `--feature-walks` picks the side the collider features' pass walks from, and the run says
/// which side walked: over a 16^2 cloth the icosphere lists its triangles (all 1,280 are sharp
/// at the cloth's 6.7 cm edges) from the first frame, so the cloth's side walks in every frame
/// when asked to, and in none when the collider's side is asked.
#[test]
fn feature_walks_pick_the_side_the_collider_features_are_walked_from() {
    let run = |walks: &str| {
        let args = ["--grid", "16", "--frames", "4", "--self-collision", "on", "--no-timestamps", "--feature-walks"];
        let output = drape(&[&args[..], &[walks]].concat());
        let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
        assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
        let line = stdout.lines().find(|l| l.starts_with("self-collision collider vertices + edges:"));
        line.map(str::to_owned).unwrap_or(stdout)
    };
    let cloth = run("cloth");
    assert!(cloth.contains("walked from the cloth's side in 4 of 4 collider-frames (--feature-walks cloth"), "{cloth}");
    let collider = run("collider");
    assert!(collider.contains("walked from the cloth's side in 0 of 4 collider-frames"), "{collider}");
}

/// The self-collision line says when the cloth runs no pair lists (its triangles too small at
/// the thickness: every triangle walks the tree, by design) rather than counting every walk as
/// a triangle that left its predicted region.
#[test]
fn the_self_collision_line_says_when_a_cloth_runs_no_pair_lists() {
    let run = |thickness: &str| {
        let args = ["--scene", "swing", "--grid", "16", "--frames", "2", "--self-collision", "on"];
        let output = drape(&[&args[..], &["--thickness", thickness]].concat());
        let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
        assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
        stdout.lines().find(|l| l.starts_with("self-collision pair lists:")).map(str::to_owned).unwrap_or(stdout)
    };
    // Cells of 6.7 cm (a 1 m cloth, 16 particles a side): lists pay at 5 mm, not at 5 cm.
    let coarse = run("0.05");
    // Every pass walks all 450 triangles (the passes a frame runs follow the motion).
    let walked = coarse.split("): all ").nth(1).and_then(|r| r.split(' ').next()?.parse::<u32>().ok());
    assert!(
        coarse.starts_with("self-collision pair lists: none (")
            && coarse.ends_with("triangle-passes walked the tree")
            && walked.is_some_and(|n| n > 0 && n % 450 == 0),
        "{coarse}"
    );
    let fine = run("0.005");
    assert!(fine.contains("triangle-passes walked the tree instead") && !fine.contains("without lists"), "{fine}");
}

/// `--wind -1,0,0` and `--stiffness 40,10,2`: vectors as X,Y,Z, negatives included (the swing
/// scene's cloth drifts towards -X under a -X wind and towards +X under a +X one).
#[test]
fn vector_flags_take_comma_separated_values_with_negatives() {
    let mean_x = |wind: &str| {
        let dir = std::env::temp_dir().join(format!("drape-wind-{}-{wind}", std::process::id()));
        let args = ["--scene", "swing", "--grid", "8", "--frames", "30", "--no-timestamps", "--wind", wind];
        let output = Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(args)
            .args(["--stiffness", "40,10,2", "--obj-dir"])
            .arg(&dir)
            .output()
            .unwrap();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let frame = std::fs::read_to_string(dir.join("frame_00030.obj")).unwrap();
        let xs: Vec<f32> = frame
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| l.split(' ').next().unwrap().parse().unwrap())
            .collect();
        std::fs::remove_dir_all(&dir).ok();
        xs.iter().sum::<f32>() / xs.len() as f32
    };
    let (west, east) = (mean_x("-1,0,0"), mean_x("1,0,0"));
    assert!(west < -0.01 && east > 0.01, "mean x under -X wind {west}, under +X wind {east}");
}

/// Models are found at run time: `DRAPE_MODELS` first (a moved binary finds them there).
#[test]
fn drape_models_points_the_cli_at_its_models() {
    let dir = std::env::temp_dir().join(format!("drape-models-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A tetrahedron standing in for the bunny: 4 vertices, 4 triangles.
    let tetrahedron = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    std::fs::write(dir.join("stanford-bunny.obj"), tetrahedron).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--mesh", "bunny", "--grid", "4", "--frames", "1", "--no-timestamps"])
        .env("DRAPE_MODELS", &dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("(4 vertices, 4 triangles)"), "DRAPE_MODELS was not used:\n{stdout}");
    std::fs::remove_dir_all(dir).ok();
}

/// `--json FILE --quiet`: nothing on stdout, and the report holds the run (its frames, the
/// substeps and bound, the per-pass timings, the final intersections).
#[test]
fn json_report_and_quiet() {
    let path = std::env::temp_dir().join(format!("drape-report-{}.json", std::process::id()));
    let output =
        drape(&["--scene", "swing", "--grid", "16", "--frames", "4", "--quiet", "--json", path.to_str().unwrap()]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(output.stdout.is_empty(), "--quiet printed: {}", String::from_utf8_lossy(&output.stdout));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!(report["frames"], 4);
    assert_eq!(report["scene"], "swing");
    assert_eq!(report["cloth"]["particles"], 256);
    let substeps = report["stability"]["substeps"].as_u64().unwrap();
    assert!(substeps >= 1 && report["stability"]["source"].as_str().unwrap().starts_with("Lanczos"));
    let passes = report["timings"]["passes"].as_array().unwrap();
    let k1 = passes.iter().find(|p| p["pass"] == "rk4: k1").expect("rk4: k1 in the passes");
    assert_eq!(k1["dispatches"].as_u64(), Some(substeps));
    assert_eq!(report["intersections_final_frame"]["cloth_cloth"], 0);
}

/// `--json` gives each awake frame's wall time and GPU span and the substeps it ran, in order,
/// with the frame numbers: one entry per frame of a swing that never sleeps, their median the
/// report's median, every frame at the bound's substeps (nothing raises them: no collider, no
/// self-collision).
#[test]
fn json_report_gives_every_frame_s_times_and_substeps() {
    let report = json_report(
        "per-frame",
        &["--scene", "swing", "--grid", "16", "--frames", "6", "--sleep", "0", "--self-collision", "off"],
    );
    let numbers = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array().unwrap_or_else(|| panic!("an array, got {v}")).iter().map(|x| x.as_f64().unwrap()).collect()
    };
    let (timings, schedule) = (&report["timings"], &report["schedule"]);
    let walls = numbers(&timings["wall_ms_per_frame"]);
    let spans = numbers(&timings["gpu_us_frame_span_per_frame"]);
    assert_eq!((walls.len(), spans.len()), (6, 6), "{timings}");
    assert!(walls.iter().chain(&spans).all(|&t| t > 0.0), "{timings}");
    let mut sorted = walls.clone();
    sorted.sort_by(f64::total_cmp);
    let median = 0.5 * (sorted[2] + sorted[3]);
    assert!((median - timings["wall_ms_median"].as_f64().unwrap()).abs() < 1e-9, "{timings}");
    assert_eq!(numbers(&schedule["awake_frame_numbers"]), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], "{schedule}");
    let bound = report["stability"]["substeps"].as_f64().unwrap();
    assert_eq!(numbers(&schedule["substeps_per_frame"]), vec![bound; 6], "{schedule}");
}

/// The JSON report of a quiet run with `args` (`name` keeps runs of parallel tests apart).
fn json_report(name: &str, args: &[&str]) -> serde_json::Value {
    let path = std::env::temp_dir().join(format!("drape-{name}-{}.json", std::process::id()));
    let mut all = args.to_vec();
    all.extend(["--quiet", "--json", path.to_str().unwrap()]);
    let output = drape(&all);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    std::fs::remove_file(&path).ok();
    report
}

/// `--sleep`: the settling pile sleeps once its motion stays under 0.5 m/s (from about frame
/// 150 of this strip), and never with `--sleep 0`.
#[test]
fn sleep_flag_puts_the_settled_pile_to_sleep_or_not() {
    let asleep = |sleep: &str| {
        let args = ["--scene", "pile", "--grid", "16", "--frames", "400", "--sleep", sleep];
        json_report(&format!("sleep-{sleep}"), &args)["schedule"]["frames_asleep"].as_u64().unwrap()
    };
    let slept = asleep("0.5");
    assert!(slept > 0, "the pile must settle and sleep within 250 frames");
    assert_eq!(asleep("0"), 0, "--sleep 0 never sleeps");
}

/// `--tile-sleep`: in `scenes/swing-ground.toml` the part of the cloth lying on the ground
/// sleeps tile by tile while the part hanging from the pins moves (the cloth as a whole never
/// sleeps); `--tile-sleep off` sleeps no tile.
#[test]
fn tile_sleep_flag_sleeps_the_resting_part_of_the_cloth_or_not() {
    let tiles = |on: &str| {
        let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/swing-ground.toml");
        let args = ["--scene-file", scene, "--grid", "24", "--frames", "150", "--tile-sleep", on];
        let report = json_report(&format!("tiles-{on}"), &args);
        assert_eq!(report["schedule"]["frames_asleep"].as_u64(), Some(0), "the hanging part keeps the cloth awake");
        report["schedule"]["tiles_asleep_max"].as_f64()
    };
    let most = tiles("on").expect("tile sleeping is on: the report gives the share of tiles asleep");
    assert!(most > 0.3, "most of the resting part must sleep within 150 frames (at most {most} of the tiles)");
    assert_eq!(tiles("off"), None, "--tile-sleep off declares no tiles");
}

/// `--tile-sleep on` in the settling pile: its resting tiles sleep from frame 315 while its upper
/// layers still push on them, and no cloth edge goes through the ground in any frame (a pushed
/// sleeping particle wakes and collides; when it stayed asleep, pushes carried its lower layer
/// through the ground: 197 of 600 frames had crossings, up to 4 edges).
#[test]
fn tile_sleep_keeps_the_pushed_layers_of_the_pile_out_of_the_ground() {
    let args = ["--scene", "pile", "--frames", "450", "--tile-sleep", "on", "--check-every-frame", "--no-timestamps"];
    let report = json_report("pile-tiles", &args);
    assert!(report["schedule"]["tiles_asleep_max"].as_f64().unwrap() > 0.0, "the pile's tiles must sleep");
    let every = &report["intersections_every_frame"];
    assert_eq!(every["worst_cloth_edges_through_collider"]["count"].as_u64(), Some(0), "{every}");
}

/// An open tube (48 x 24 vertices, radius 0.35 m, 0.7 m long: cells of 46 x 29 mm, written
/// here) crumpled on the standard sphere: its passes alone (`--self-failsafe off`) keep it free
/// of crossings in every one of 120 frames. Before a particle undoing a crossing moved by those
/// corrections alone, this tube crossed in 29 of these 120 frames (from frame 92): two creased
/// quads' diagonals closed 0.3 mm a frame under the mean of their particles' 20-odd corrections.
/// Not a guarantee for every tube: written with other last bits in its coordinates (numpy's f32
/// cosines), its passes alone still cross in 24 of 120 frames, a pair squeezed within the
/// thickness (4 -> 2 mm over 17 frames) before anything crosses, which this does not reach; the
/// fail-safe then ends every frame clean (before, 39 of 240 frames ended crossed).
#[test]
fn the_passes_alone_keep_a_crumpled_tube_free_of_crossings() {
    let (around, rings, radius, length) = (48usize, 24usize, 0.35f32, 0.7f32);
    let mut obj = String::new();
    for j in 0..=rings {
        for i in 0..around {
            let a = std::f32::consts::TAU * i as f32 / around as f32;
            let y = 1.0 + length * j as f32 / rings as f32;
            obj += &format!("v {} {y} {}\n", radius * a.cos(), radius * a.sin());
        }
    }
    for j in 0..rings {
        for i in 0..around {
            let (a, b) = (j * around + i + 1, j * around + (i + 1) % around + 1);
            let (c, d) = (a + around, b + around);
            obj += &format!("f {a} {c} {b}\nf {b} {c} {d}\n");
        }
    }
    let path = std::env::temp_dir().join(format!("drape-tube-{}.obj", std::process::id()));
    std::fs::write(&path, obj).unwrap();
    let args = [
        "--cloth-mesh",
        path.to_str().unwrap(),
        "--self-collision",
        "on",
        "--self-failsafe",
        "off",
        "--frames",
        "120",
        "--check-every-frame",
        "--no-timestamps",
    ];
    let report = json_report("tube-passes", &args);
    std::fs::remove_file(&path).ok();
    let every = &report["intersections_every_frame"];
    assert_eq!(every["frames_with_any"].as_u64(), Some(0), "{every}");
}

/// The 48-particle pile's passes alone keep its layers apart (`--self-failsafe off`): no two
/// cloth triangles intersect at the end of any of 200 frames. Squeezed as they fold, a pair's
/// undoing of a crossing used to be diluted in the mean of all of its particles' corrections,
/// and layers crossed from frame 146 on, in all 55 frames left (the fail-safe put 78 particles
/// back in 13 frames); a particle that undoes a crossing now moves by those corrections alone
/// (`drape_kernels::self_contact::correction_of`). With its lists built once per frame
/// (`--self-list-windows off`), the course that crossed.
#[test]
fn the_passes_alone_keep_the_pile_free_of_crossings() {
    let args = [
        "--scene",
        "pile",
        "--grid",
        "48",
        "--frames",
        "200",
        "--self-failsafe",
        "off",
        "--self-list-windows",
        "off",
        "--check-every-frame",
        "--no-timestamps",
    ];
    let report = json_report("pile-passes", &args);
    let every = &report["intersections_every_frame"];
    assert_eq!(every["worst_cloth_cloth"]["count"].as_u64(), Some(0), "{every}");
    assert_eq!(every["frames_with_any"].as_u64(), Some(0), "{every}");
}

/// `--self-failsafe on` with a 64^2 cloth landing flat on a cube (an OBJ written here): nothing
/// goes back. Its triangles lie a few f32 steps apart in height, and pairs whose boxes touch at
/// a corner took random f32 orientation signs; counted as touching, they "crossed" at frame 6
/// and the fail-safe put the whole cloth back (the exact check found no crossing). Nor does the
/// check against the cube's triangles (all listed: its edges are sharp) find a cloth triangle
/// through one.
#[test]
fn a_cloth_landing_flat_on_a_cube_is_not_put_back() {
    let dir = std::env::temp_dir().join(format!("drape-cube-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cube = dir.join("cube.obj");
    let corners: String =
        (0..8).map(|i| format!("v {} {} {}\n", i >> 2 & 1, i >> 1 & 1, i & 1)).collect::<Vec<_>>().concat();
    let faces =
        "f 1 2 4\nf 1 4 3\nf 5 7 8\nf 5 8 6\nf 1 5 6\nf 1 6 2\nf 3 4 8\nf 3 8 7\nf 1 3 7\nf 1 7 5\nf 2 6 8\nf 2 8 4\n";
    std::fs::write(&cube, format!("{corners}{faces}")).unwrap();
    let args = [
        "--mesh",
        cube.to_str().unwrap(),
        "--self-collision",
        "on",
        "--self-failsafe",
        "on",
        "--frames",
        "12",
        "--check-every-frame",
        "--no-timestamps",
    ];
    let report = json_report("cube-failsafe", &args);
    std::fs::remove_dir_all(&dir).ok();
    let failsafe = &report["self_collision_failsafe"];
    assert_eq!(failsafe["whole_cloth_rollbacks"].as_u64(), Some(0), "{failsafe}");
    assert_eq!(failsafe["particles_rolled_back"].as_u64(), Some(0), "{failsafe}");
    assert_eq!(failsafe["collider_pairs_found"].as_u64(), Some(0), "{failsafe}");
    assert_eq!(report["intersections_every_frame"]["frames_with_any"].as_u64(), Some(0), "{report}");
    assert!(report["lowest_particle_y_m"].as_f64().unwrap() < 0.9, "the cloth must have landed and draped");
}

/// Self-collision is on without `--self-collision`, in the swing scene too: a 16^2 cloth
/// flapping in `scenes/swing-wind.toml`'s wind ends no frame through itself, where with
/// `--self-collision off` it does (from frame 78: 23 of 100 frames crossed, up to 96 pairs).
#[test]
fn self_collision_is_on_by_default_and_keeps_the_flapping_cloth_from_itself() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/swing-wind.toml");
    let run = |flags: &[&str]| {
        let args = ["--scene-file", scene, "--grid", "16", "--frames", "100", "--check-every-frame", "--no-timestamps"];
        let report = json_report(&format!("flapping{}", flags.len()), &[&args[..], flags].concat());
        (
            report["cloth"]["description"].as_str().unwrap_or_default().to_owned(),
            report["intersections_every_frame"].clone(),
        )
    };
    let (cloth, every) = run(&[]);
    assert!(cloth.contains("self-collision on"), "{cloth}");
    assert_eq!(every["frames_with_any"].as_u64(), Some(0), "{every}");
    let (cloth, every) = run(&["--self-collision", "off"]);
    assert!(cloth.contains("self-collision off"), "{cloth}");
    assert!(every["frames_with_any"].as_u64().is_some_and(|n| n > 0), "off must show what on prevents: {every}");
}

/// Every example scene in scenes/ runs (2 frames here; flags override the file) and its report
/// says it ran the file's scene.
#[test]
fn every_example_scene_runs() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 4, "scenes/ holds the examples ({} found in {})", files.len(), dir.display());
    let out = std::env::temp_dir().join(format!("drape-scenes-{}", std::process::id()));
    for file in files {
        let json = out.join("report.json");
        std::fs::create_dir_all(&out).unwrap();
        let output = drape(&[
            "--scene-file",
            file.to_str().unwrap(),
            "--frames",
            "2",
            "--quiet",
            "--json",
            json.to_str().unwrap(),
            "--obj-dir",
            out.join("obj").to_str().unwrap(),
            "--png-dir",
            out.join("png").to_str().unwrap(),
            "--png-size",
            "64x48",
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{}: {stderr}", file.display());
        let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let text = std::fs::read_to_string(&file).unwrap();
        let scene = text.lines().find_map(|l| l.strip_prefix("scene = ")).unwrap().trim_matches('"');
        assert_eq!(report["scene"], scene, "{}", file.display());
        assert_eq!(report["frames"], 2, "{}: the flag overrides the file", file.display());
    }
    std::fs::remove_dir_all(&out).ok();
}

/// `--print-scene` refuses a path whose bytes are not UTF-8 (a usage error naming the flag): a
/// scene file is TOML, which holds only UTF-8, and the lossy copy it once wrote named another
/// file (`bad\u{FFFD}.obj` for `bad\xff.obj`), so the printed scene failed when run.
#[cfg(unix)]
#[test]
fn print_scene_refuses_a_path_that_is_not_utf8() {
    use std::os::unix::ffi::OsStrExt;
    let dir = scratch_dir("print-scene-utf8");
    let path = dir.join(std::ffi::OsStr::from_bytes(b"bad\xff.obj"));
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n").unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .arg("--cloth-mesh")
        .arg(&path)
        .arg("--print-scene")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--cloth-mesh") && stderr.contains("not UTF-8"), "{stderr}");
    assert!(output.stdout.is_empty(), "nothing printed: {}", String::from_utf8_lossy(&output.stdout));
    std::fs::remove_dir_all(&dir).ok();
}

/// `--print-scene` writes the effective scene, which read back as a scene file prints the same;
/// command-line flags override the file; bad files get usage errors naming the file, line and
/// key (unknown keys, values out of range, the wrong kind of value), an unreadable one a
/// runtime error naming it.
#[test]
fn scene_files_round_trip_override_and_explain_their_errors() {
    let dir = scratch_dir("scene-file");
    let write = |name: &str, text: &str| write_in(&dir, name, text);
    let printed = drape(&["--scene", "swing", "--wind=-1,0,0.5", "--grid", "24", "--print-scene"]);
    assert!(printed.status.success());
    let first = String::from_utf8(printed.stdout).unwrap();
    assert!(first.contains("wind = [-1, 0, 0.5]") && first.contains("grid = 24"), "{first}");
    let file = write("printed.toml", &first);
    let again = String::from_utf8(drape(&["--scene-file", &file, "--print-scene"]).stdout).unwrap();
    assert_eq!(again, first, "a printed scene reads back as itself");
    let overridden =
        String::from_utf8(drape(&["--scene-file", &file, "--grid", "12", "--print-scene"]).stdout).unwrap();
    assert!(overridden.contains("grid = 12\n"), "{overridden}");

    let cases: &[(&str, i32, &[&str])] = &[
        ("scene = \"swing\"\ngird = 16\n", 2, &["line 2", "unknown key `gird`"]),
        ("scene = \"swing\"\n\ngrid = 5000\n", 2, &["line 3", "key `grid`", "2..=2048"]),
        ("grid = \"abc\"\n", 2, &["line 1", "key `grid`"]),
        ("scene = \"swing\"\ngrid = -3\n", 2, &["line 2", "key `grid`", "-3"]),
        ("scene = { name = \"swing\" }\n", 2, &["line 1", "`scene` takes one of"]),
        ("no-timestamps = 3\n", 2, &["line 1", "switch"]),
        ("grid = [1,\n", 2, &["line 1"]),
        ("grid = 8\n[[collider]]\nmesh = \"torus\"\nspin = 3\n", 2, &["line 4", "unknown field `spin`"]),
        ("[[collider]]\nscale = 2\n", 2, &["line 1", "give `mesh`", "or `mesh-sequence`"]),
        ("[[collider]]\nmesh = \"torus\"\nmesh-sequence = \"a_##.obj\"\n", 2, &["line 1", "not both"]),
        ("[[collider]]\nmesh = \"torus\"\nsequence-start = 3\n", 2, &["line 1", "`sequence-start` needs"]),
        ("[[collider]]\nmesh = \"torus\"\nsequence-loop = true\n", 2, &["line 1", "`sequence-loop` needs"]),
        ("[[collider]]\nmesh-sequence = \"b_#.obj\"\nsequence-rate = 0\n", 2, &["line 1", "(0, 10000]"]),
        ("[[collider]]\nmesh-sequence = \"/nonexistent/body.obj\"\n", 1, &["/nonexistent/body.obj", "no `#`"]),
        ("[[collider]]\nmesh-sequence = \"/nonexistent/body_####.obj\"\n", 1, &["/nonexistent/body_0001.obj"]),
        ("[[collider]]\nmesh-sequence = \"/nonexistent/a_#/b_#.obj\"\n", 1, &["`#` in its directory"]),
        ("[[collider]]\nmesh-sequence = \"/nonexistent/b_#_#.obj\"\n", 1, &["more than one run of `#`"]),
        ("grid = 8\n\n[[collider]]\nmesh = \"torus\"\nscale = 0\n", 2, &["line 3", "`scale` must be above 0"]),
        ("[[collider]]\nmesh = \"torus\"\nscale = [1, 2]\n", 2, &["line 3", "a number or three numbers"]),
        ("scene = \"swing\"\nusd = 5\n", 2, &["line 2", "`usd` takes a path: a string"]),
        ("[[collider]]\nmesh = \"torus\"\nscale = 1e30\n", 2, &["line 1", "below 1e30"]),
        ("[[collider]]\nmesh = \"torus\"\ntranslate = [1, 2, 3, 4]\n", 2, &["line 3", "three numbers", "got 4"]),
        ("grid = 8\n[collider]\nmesh = \"torus\"\n", 2, &["line 2", "`[[collider]]` table, in double brackets"]),
        ("[[collider]]\nmesh = \"torus\"\nvelocity = [1, 2]\n", 2, &["line 3", "velocity"]),
        ("[[collider]]\nmesh = \"/nonexistent/rock.obj\"\n", 1, &["/nonexistent/rock.obj"]),
    ];
    for (i, &(text, code, needles)) in cases.iter().enumerate() {
        let file = write(&format!("bad{i}.toml"), text);
        let output = drape(&["--scene-file", &file, "--frames", "1"]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(code), "{text:?}: {stderr}");
        assert!(stderr.contains(&file), "{text:?}: the message names the file: {stderr}");
        for needle in needles {
            assert!(stderr.contains(needle), "{text:?}: expected `{needle}` in: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    let missing = dir.join("missing.toml");
    let output = drape(&["--scene-file", missing.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&output.stderr).contains("missing.toml"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `--usd`: the cache read back holds, at every frame, the positions the OBJ frames of the same
/// run hold (both print f32 in full), the cloth's triangles, and the turning body's pose per
/// frame.
#[test]
fn usd_cache_reads_back_as_the_frames() {
    let dir = std::env::temp_dir().join(format!("drape-usd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let usd = dir.join("garment.usda");
    let frames = 3;
    let output = drape(&[
        "--scene",
        "garment",
        "--grid",
        "16",
        "--frames",
        "3",
        "--quiet",
        "--usd",
        usd.to_str().unwrap(),
        "--obj-dir",
        dir.to_str().unwrap(),
        "--obj-every",
        "1",
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let text = std::fs::read_to_string(&usd).unwrap();
    assert!(text.starts_with("#usda 1.0"));
    // The cloth's samples: `N: [(x, y, z), ...],` lines inside `points.timeSamples = {`.
    let samples = text
        .split("point3f[] points.timeSamples = {")
        .nth(1)
        .expect("points.timeSamples")
        .split("\n        }")
        .next()
        .unwrap();
    let parse_points = |list: &str| -> Vec<[f32; 3]> {
        list.trim()
            .trim_start_matches('[')
            .trim_end_matches(',')
            .trim_end_matches(']')
            .split("), (")
            .map(|p| {
                let v: Vec<f32> =
                    p.trim_matches(|c| c == '(' || c == ')').split(", ").map(|x| x.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect()
    };
    let mut seen = 0;
    for line in samples.lines().filter(|l| l.contains(": [")) {
        let (frame, list) = line.trim().split_once(": ").unwrap();
        let frame: u32 = frame.parse().unwrap();
        let obj = std::fs::read_to_string(dir.join(format!("frame_{frame:05}.obj"))).unwrap();
        let from_obj: Vec<[f32; 3]> = obj
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f32> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        assert_eq!(parse_points(list), from_obj, "frame {frame}");
        seen += 1;
    }
    assert_eq!(seen, frames, "one sample per frame");
    // Triangles: the OBJ's faces, in order.
    let obj = std::fs::read_to_string(dir.join("frame_00001.obj")).unwrap();
    let faces: Vec<u32> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .flat_map(|l| {
            l.split(' ').map(|c| c.split('/').next().unwrap().parse::<u32>().unwrap() - 1).collect::<Vec<_>>()
        })
        .collect();
    let indices = text.split("int[] faceVertexIndices = [").nth(1).unwrap().split(']').next().unwrap();
    let indices: Vec<u32> = indices.split(", ").map(|x| x.parse().unwrap()).collect();
    assert_eq!(indices, faces);
    assert!(text.contains("primvars:st"), "the cloth's UVs");
    let orient =
        text.split("quatf xformOp:orient.timeSamples = {").nth(1).expect("the body's pose").split('}').next().unwrap();
    assert_eq!(orient.lines().filter(|l| l.contains(": (")).count(), frames as usize);
    std::fs::remove_dir_all(&dir).ok();
}

/// Redirected (not a terminal), the run draws no progress bar: no carriage returns in its
/// output, and its report is on stdout.
#[test]
fn a_redirected_run_has_no_carriage_returns() {
    let output = drape(&["--scene", "swing", "--grid", "8", "--frames", "3"]);
    assert!(output.status.success());
    assert!(!output.stderr.contains(&b'\r') && !output.stdout.contains(&b'\r'));
    assert!(String::from_utf8_lossy(&output.stdout).contains("GPU time per kernel"));
}

/// `--png-dir` draws the scene offscreen: the requested frames at the requested size, the
/// cloth (red-dominant) and the collider (blue-dominant) both in view, the cloth moving
/// between the pictures, and the report lists the files.
#[test]
fn png_dir_writes_pictures_of_the_scene() {
    let dir = std::env::temp_dir().join(format!("drape-png-{}", std::process::id()));
    let json = dir.with_extension("json");
    let output = Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--grid", "16", "--frames", "20", "--png-every", "10", "--png-size", "160x120", "--quiet"])
        .arg("--png-dir")
        .arg(&dir)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let read = |frame: u32| {
        let path = dir.join(format!("frame_{frame:05}.png"));
        let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        assert_eq!((info.width, info.height, info.color_type), (160, 120, png::ColorType::Rgba));
        pixels
    };
    let (first, last) = (read(10), read(20));
    let share = |pixels: &[u8], keep: fn(&[u8; 4]) -> bool| {
        pixels.as_chunks::<4>().0.iter().filter(|p| keep(p)).count() as f64 / (160.0 * 120.0)
    };
    let cloth = |p: &[u8; 4]| p[0] > 100 && p[0] > p[2] + 40;
    let collider = |p: &[u8; 4]| p[2] > 100 && p[2] > p[0] + 40;
    for pixels in [&first, &last] {
        assert!(share(pixels, cloth) > 0.05, "the cloth covers {:.3} of the picture", share(pixels, cloth));
        assert!(share(pixels, collider) > 0.005, "the collider covers {:.4}", share(pixels, collider));
    }
    let changed = first.iter().zip(&last).filter(|(a, b)| a != b).count();
    assert!(changed > 2000, "the cloth moves between frames 10 and 20 ({changed} bytes differ)");
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["pictures"].as_array().map(Vec::len), Some(2), "{}", report["pictures"]);
    assert!(!dir.join("frame_00005.png").exists(), "only every 10th frame is drawn");
    // A run shorter than --png-every still draws its last frame.
    std::fs::remove_dir_all(&dir).ok();
    let output = Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--grid", "8", "--frames", "3", "--png-every", "10", "--png-size", "32x32", "--quiet", "--png-dir"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(dir.join("frame_00003.png").is_file(), "the last frame is drawn");
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_file(&json).ok();
}

/// A scene file's `[[collider]]` tables are simulated: a plane placed at y = 0.5 under the
/// swinging cloth (which swings below y = 0 at t = 0.5 s without it) holds it up, and a plane rising from y = 0.1
/// at 0.4 m/s lifts it to y = 0.5 by t = 1 s; the tables survive `--print-scene`.
#[test]
fn scene_file_colliders_are_placed_and_move() {
    let dir = std::env::temp_dir().join(format!("drape-colliders-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lowest = |name: &str, frames: u32, tables: &str| {
        let file = dir.join(format!("{name}.toml"));
        let json = dir.join(format!("{name}.json"));
        let text = format!("scene = \"swing\"\ngrid = 16\nframes = {frames}\nno-timestamps = true\n{tables}");
        std::fs::write(&file, text).unwrap();
        let output = drape(&["--scene-file", file.to_str().unwrap(), "--quiet", "--json", json.to_str().unwrap()]);
        assert!(output.status.success(), "{name}: {}", String::from_utf8_lossy(&output.stderr));
        let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        report["lowest_particle_y_m"].as_f64().unwrap()
    };
    let free = lowest("free", 30, "");
    let held = lowest("held", 60, "[[collider]]\nmesh = \"plane\"\ntranslate = [0, 0.5, 0]\n");
    let lifted =
        lowest("lifted", 60, "[[collider]]\nmesh = \"plane\"\ntranslate = [0, 0.1, 0]\nvelocity = [0, 0.4, 0]\n");
    eprintln!("lowest particle: free {free:.3} m, held {held:.3} m, lifted {lifted:.3} m");
    assert!(free < 0.3, "without a collider the cloth hangs low ({free})");
    assert!((0.49..0.6).contains(&held), "the placed plane holds the cloth at y = 0.5 ({held})");
    assert!((0.49..0.6).contains(&lifted), "the rising plane lifts the cloth to y = 0.5 by t = 1 s ({lifted})");

    let file = dir.join("lifted.toml");
    let printed = String::from_utf8(drape(&["--scene-file", file.to_str().unwrap(), "--print-scene"]).stdout).unwrap();
    assert!(printed.contains("[[collider]]") && printed.contains("velocity = [0.0, 0.4, 0.0]"), "{printed}");
    let again_file = dir.join("printed.toml");
    std::fs::write(&again_file, &printed).unwrap();
    let again = String::from_utf8(drape(&["--scene-file", again_file.to_str().unwrap(), "--print-scene"]).stdout);
    assert_eq!(again.unwrap(), printed, "a printed scene with colliders reads back as itself");
    std::fs::remove_dir_all(&dir).ok();
}

/// A cloth whose file splits it at every seam (each of its 2 x 2 quads has its own 4 vertices,
/// as exporters that write one vertex per UV do): hung from one corner in the swing scene, it
/// comes apart without `--weld` (drape warns, and the three loose quads fall away) and holds
/// together with it (9 particles, the cloth hangs from the pin).
#[test]
fn weld_joins_a_cloth_its_file_split_at_the_seams() {
    let dir = std::env::temp_dir().join(format!("drape-weld-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("split.obj");
    let mut text = String::new();
    let mut faces = String::new();
    for (q, (i, j)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        for (di, dj) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
            text += &format!("v {} 1 {}\n", 0.2 * (i + di) as f32, 0.2 * (j + dj) as f32);
        }
        let b = 4 * q + 1;
        faces += &format!("f {} {} {}\nf {} {} {}\n", b, b + 3, b + 2, b, b + 2, b + 1);
    }
    std::fs::write(&obj, text + &faces).unwrap();
    let run = |weld: bool| {
        let json = dir.join(format!("report-{weld}.json"));
        let mut command = Command::new(env!("CARGO_BIN_EXE_drape"));
        command.args(["--scene", "swing", "--frames", "30", "--pin-vertices", "0", "--no-timestamps", "--cloth-mesh"]);
        command.arg(&obj).arg("--json").arg(&json);
        if weld {
            command.arg("--weld");
        }
        let output = command.output().unwrap();
        let (stdout, stderr) = (String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        assert!(output.status.success(), "{stdout}\n{stderr}");
        let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (stdout.into_owned(), stderr.into_owned(), report["lowest_particle_y_m"].as_f64().unwrap())
    };
    let (stdout, stderr, lowest) = run(false);
    assert!(stdout.contains("(16 particles, 8 triangles"), "{stdout}");
    assert!(stderr.contains("7 vertices lie exactly on earlier ones") && stderr.contains("--weld"), "{stderr}");
    assert!(lowest < 0.0, "the loose quads must fall away (lowest particle at {lowest} m)");
    let (stdout, stderr, lowest) = run(true);
    assert!(stdout.contains("--weld joined 7 vertices into others (9 particles left)"), "{stdout}");
    assert!(stdout.contains("(9 particles, 8 triangles"), "{stdout}");
    assert!(!stderr.contains("lie exactly on earlier ones"), "{stderr}");
    assert!(lowest > 0.3, "the welded cloth must hang from its pin (lowest particle at {lowest} m)");
    std::fs::remove_dir_all(&dir).ok();
}

/// The meshes a scene file names are found beside it, wherever drape runs from: a scene in
/// `DIR/scene/` with `cloth-mesh = "models/cloth.obj"` and a `[[collider]]` mesh
/// `models/ground.obj`, run from another directory, loads both; `--print-scene` writes them
/// as absolute paths, so the printed scene reads back as itself from anywhere.
#[test]
fn a_scene_file_finds_its_meshes_beside_it() {
    let dir = std::env::temp_dir().join(format!("drape-scene-paths-{}", std::process::id()));
    let models = dir.join("scene").join("models");
    std::fs::create_dir_all(&models).unwrap();
    std::fs::write(models.join("cloth.obj"), "v 0 1 0\nv 0.2 1 0\nv 0.2 1 0.2\nv 0 1 0.2\nf 1 4 3\nf 1 3 2\n").unwrap();
    std::fs::write(models.join("ground.obj"), "v -2 0.5 -2\nv 2 0.5 -2\nv 2 0.5 2\nv -2 0.5 2\nf 1 4 3\nf 1 3 2\n")
        .unwrap();
    let scene = dir.join("scene").join("scene.toml");
    // No wind: it would blow so light a cloth off the ground before it lands.
    let text = "scene = \"swing\"\nframes = 60\nno-timestamps = true\nwind = [0, 0, 0]\ncloth-mesh = \"models/cloth.obj\"\n\n\
                [[collider]]\nmesh = \"models/ground.obj\"\n";
    std::fs::write(&scene, text).unwrap();
    let run = |args: &[&str]| {
        let output = Command::new(env!("CARGO_BIN_EXE_drape"))
            .current_dir(&dir)
            .arg("--scene-file")
            .arg(&scene)
            .args(args)
            .output();
        let output = output.unwrap();
        let (stdout, stderr) = (String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        assert!(output.status.success(), "{stdout}\n{stderr}");
        stdout.into_owned()
    };
    let json = dir.join("report.json");
    let stdout = run(&["--json", json.to_str().unwrap()]);
    assert!(stdout.contains("(4 particles, 2 triangles"), "{stdout}");
    assert!(stdout.contains("collider: collider1 (4 vertices, 2 triangles)"), "{stdout}");
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let lowest = report["lowest_particle_y_m"].as_f64().unwrap();
    assert!(lowest > 0.49, "the ground beside the scene file holds the cloth (lowest particle at {lowest} m)");
    let printed = run(&["--print-scene"]);
    let absolute = |name: &str| std::path::absolute(models.join(name)).unwrap().display().to_string();
    for name in ["cloth.obj", "ground.obj"] {
        assert!(printed.contains(&format!("\"{}\"", absolute(name))), "{name} must print absolute:\n{printed}");
    }
    let elsewhere = dir.join("printed.toml");
    std::fs::write(&elsewhere, &printed).unwrap();
    let again = drape(&["--scene-file", elsewhere.to_str().unwrap(), "--print-scene"]);
    assert_eq!(String::from_utf8_lossy(&again.stdout), printed, "the printed scene reads back as itself");
    std::fs::remove_dir_all(&dir).ok();
}

/// A quiet run with `args` writing its JSON report and its OBJ frames under `dir` (in files named
/// after `name`): the report and the final frame `frame`'s OBJ.
fn report_and_final_obj(dir: &std::path::Path, name: &str, args: &[&str], frame: u32) -> (serde_json::Value, Vec<u8>) {
    let (json, objs) = (dir.join(format!("{name}.json")), dir.join(name));
    std::fs::create_dir_all(&objs).unwrap();
    let output =
        drape(&[args, &["--quiet", "--json", json.to_str().unwrap(), "--obj-dir", objs.to_str().unwrap()]].concat());
    assert!(output.status.success(), "{name}: {}", String::from_utf8_lossy(&output.stderr));
    let report = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (report, std::fs::read(objs.join(format!("frame_{frame:05}.obj"))).unwrap())
}

/// `--crowded-contact`: `on` hands the crowded particles of a cloth thrown at the dense torus
/// to a workgroup each, `off` counts none, and `auto` counts them without handing any over on
/// a CPU driver (lavapipe); the cloth ends bit for bit the same (the final frame's OBJ).
#[test]
fn cli_crowded_contact_hands_crowded_particles_over_with_the_same_result() {
    let dir = std::env::temp_dir().join(format!("drape-crowded-{}", std::process::id()));
    let run = |choice: &str| {
        let args = ["--mesh", "torus", "--grid", "24", "--frames", "40", "--crowded-contact", choice];
        let (report, obj) = report_and_final_obj(&dir, choice, &args, 40);
        let count = |key: &str| report["collision"][key].as_u64().unwrap_or_else(|| panic!("{choice}: no {key}"));
        let on_cpu = report["device"].to_string().contains("llvmpipe");
        (count("crowded_particle_substeps"), count("crowded_handed_to_workgroups"), obj, on_cpu)
    };
    let (on, off, auto) = (run("on"), run("off"), run("auto"));
    std::fs::remove_dir_all(&dir).ok();
    assert!(on.0 > 0 && on.1 == on.0, "on: {} crowded, {} handed over", on.0, on.1);
    assert_eq!((off.0, off.1), (0, 0), "off counts nothing");
    // On a GPU the automatic choice may hand them over in some frames; on lavapipe never.
    let handed = if auto.3 { auto.1 == 0 } else { auto.1 <= auto.0 };
    assert!(auto.0 == on.0 && handed, "auto: {} crowded, {} handed over", auto.0, auto.1);
    assert!(on.2 == off.2 && on.2 == auto.2, "the final frames differ");
}

/// `--one-workgroup-substeps`: `on` runs the swinging cloth's substeps as one dispatch a frame
/// (self-collision off, whose passes run between the stages; the timing table's "substeps in
/// one workgroup", no RK4 stage of its own), `off` and `auto`
/// (on lavapipe, a CPU driver) a dispatch a stage; the cloth ends bit for bit the same.
#[test]
fn cli_one_workgroup_substeps_runs_the_frame_as_one_dispatch_with_the_same_result() {
    let dir = std::env::temp_dir().join(format!("drape-one-workgroup-{}", std::process::id()));
    let run = |choice: &str| {
        let args = [
            "--scene",
            "swing",
            "--self-collision",
            "off",
            "--grid",
            "20",
            "--frames",
            "12",
            "--one-workgroup-substeps",
            choice,
        ];
        let (report, obj) = report_and_final_obj(&dir, choice, &args, 12);
        let passes = report["timings"]["passes"].as_array().unwrap_or_else(|| panic!("{choice}: no passes"));
        let ran = |label: &str| passes.iter().any(|p| p["pass"] == label);
        let on_cpu = report["device"].to_string().contains("llvmpipe");
        (ran("substeps in one workgroup"), ran("rk4: k1"), obj, on_cpu)
    };
    let (on, off, auto) = (run("on"), run("off"), run("auto"));
    std::fs::remove_dir_all(&dir).ok();
    assert!(on.0 && !on.1, "on: one dispatch a frame, no stage of its own");
    assert!(!off.0 && off.1, "off: a dispatch a stage");
    // On a GPU the automatic choice takes one workgroup for this 400-particle cloth.
    assert!(if auto.3 { !auto.0 && auto.1 } else { auto.0 && !auto.1 }, "auto chose {:?}", (auto.0, auto.1));
    // Bit for bit where both kernels round alike (lavapipe; NVIDIA contracts them differently).
    if on.3 {
        assert!(on.2 == off.2 && on.2 == auto.2, "the final frames differ");
    }
}

/// A `[[collider]]`'s `mesh-sequence` (one OBJ file a frame, as an animated body is exported)
/// deforms the collider through the files: a ground whose files rise from y = 0.1 at 0.4 m/s
/// lifts the swinging cloth as the same ground moved by `velocity` does (to y = 0.5 by t = 1 s,
/// within a millimetre of it), and so do files at half the run's rate (`sequence-rate = 30`,
/// frames between two files taking their mix); a loop (`sequence-loop`) starts over after its
/// last file; past its last file a sequence that does not loop stays, with a warning naming the
/// file it did not find; the `--usd` cache holds its points per frame. A later file with other
/// triangles, or the sequence with `--contact spheres`, is an error that says so.
#[test]
fn scene_file_mesh_sequence_deforms_a_collider() {
    let dir = std::env::temp_dir().join(format!("drape-sequence-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A 3 m ground of 4 x 4 squares at height `y`; `torn` leaves its last square out.
    let ground = |y: f32, torn: bool| {
        let mut text = String::new();
        for i in 0..5 {
            for k in 0..5 {
                text += &format!("v {} {y} {}\n", -1.5 + 0.75 * i as f32, -1.5 + 0.75 * k as f32);
            }
        }
        for i in 0..4 {
            for k in (0..4).filter(|&k| !(torn && i == 3 && k == 3)) {
                let at = |i: u32, k: u32| i * 5 + k + 1;
                text += &format!("f {} {} {}\n", at(i, k), at(i, k + 1), at(i + 1, k + 1));
                text += &format!("f {} {} {}\n", at(i, k), at(i + 1, k + 1), at(i + 1, k));
            }
        }
        text
    };
    const FILES: u32 = 61; // the run's start and 60 frames
    for n in 1..=FILES {
        let y = 0.1 + 0.4 * (n - 1) as f32 / 60.0;
        std::fs::write(dir.join(format!("ground_{n:03}.obj")), ground(y, false)).unwrap();
    }
    let run = |name: &str, frames: u32, table: &str, extra: &[&str]| {
        let file = dir.join(format!("{name}.toml"));
        let json = dir.join(format!("{name}.json"));
        let text = format!("scene = \"swing\"\ngrid = 16\nframes = {frames}\nno-timestamps = true\n{table}");
        std::fs::write(&file, text).unwrap();
        let mut args = vec!["--scene-file", file.to_str().unwrap(), "--quiet", "--json", json.to_str().unwrap()];
        args.extend_from_slice(extra);
        let output = drape(&args);
        // A run that failed leaves its report empty.
        let report =
            std::fs::read_to_string(&json).ok().and_then(|r| serde_json::from_str::<serde_json::Value>(&r).ok());
        (output, report)
    };
    let first = dir.join("ground_001.obj");
    let moved = format!("[[collider]]\nmesh = \"{}\"\nvelocity = [0, 0.4, 0]\n", first.display());
    let sequence = "[[collider]]\nmesh-sequence = \"ground_###.obj\"\n";
    let usd = dir.join("sequence.usda");
    let (by_velocity, velocity_report) = run("velocity", 60, &moved, &[]);
    let (by_files, files_report) = run("files", 60, sequence, &["--usd", usd.to_str().unwrap()]);
    for output in [&by_velocity, &by_files] {
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    }
    let lowest = |report: Option<serde_json::Value>| report.unwrap()["lowest_particle_y_m"].as_f64().unwrap();
    let (moved, deformed) = (lowest(velocity_report), lowest(files_report));
    eprintln!("lowest particle after 1 s: ground moved by velocity {moved:.4} m, by its files {deformed:.4} m");
    assert!((0.49..0.6).contains(&deformed), "the rising files lift the cloth to y = 0.5 by t = 1 s ({deformed})");
    assert!((deformed - moved).abs() < 1e-3, "by its files {deformed}, by velocity {moved}");
    let cache = std::fs::read_to_string(&usd).unwrap();
    assert!(cache.contains("point3f[] points.timeSamples"), "the cache holds the deforming collider's points");
    assert!(cache.contains("            60: [(-1.5, 0.5, -1.5)"), "frame 60's ground at y = 0.5 in the cache");

    // At its own rate: 30 files a second (a frame of the run's 60 ends on a file or halfway
    // between two, which it mixes) lift the cloth as the same motion does.
    for n in 1..=31 {
        let y = 0.1 + 0.4 * (n - 1) as f32 / 30.0;
        std::fs::write(dir.join(format!("half_{n:02}.obj")), ground(y, false)).unwrap();
    }
    let half_rate = "[[collider]]\nmesh-sequence = \"half_##.obj\"\nsequence-rate = 30\n";
    let (by_half_rate, half_report) = run("half", 60, half_rate, &[]);
    assert!(by_half_rate.status.success(), "{}", String::from_utf8_lossy(&by_half_rate.stderr));
    let half = lowest(half_report);
    assert!((half - moved).abs() < 1e-3, "at 30 files a second {half}, by velocity {moved}");

    // Looping: ten files played over and over; frame 25 ends on the sixth (offset 25 mod 10).
    for n in 1..=10 {
        let y = 0.1 + 0.01 * (n - 1) as f32;
        std::fs::write(dir.join(format!("cycle_{n:02}.obj")), ground(y, false)).unwrap();
    }
    let cycle = "[[collider]]\nmesh-sequence = \"cycle_##.obj\"\nsequence-loop = true\n";
    let cycle_usd = dir.join("cycle.usda");
    let (looped, _) = run("cycle", 25, cycle, &["--usd", cycle_usd.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&looped.stderr);
    assert!(looped.status.success() && !stderr.contains("mesh sequence: no"), "a loop does not run out: {stderr}");
    let cache = std::fs::read_to_string(&cycle_usd).unwrap();
    let sixth = 0.1 + 0.01 * 5.0f32;
    assert!(cache.contains(&format!("            25: [(-1.5, {sixth}, -1.5)")), "frame 25 ends on the sixth file");
    assert!(cache.contains("            20: [(-1.5, 0.1, -1.5)"), "frame 20 ends on the first file again");

    // Past the last file it stays where the last one put it.
    let (past, report) = run("past", 70, sequence, &[]);
    let stderr = String::from_utf8_lossy(&past.stderr);
    assert!(past.status.success(), "{stderr}");
    assert!(stderr.contains("ground_062.obj"), "the warning names the file it did not find: {stderr}");
    assert!((0.49..0.6).contains(&lowest(report)), "the ground stays at 0.5 after its last file");

    // Bad input: a file with other triangles; the sequence with sphere contact.
    std::fs::write(dir.join("ground_031.obj"), ground(0.3, true)).unwrap();
    let (changed, _) = run("changed", 60, sequence, &[]);
    let stderr = String::from_utf8_lossy(&changed.stderr);
    assert_eq!(changed.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("ground_031.obj") && stderr.contains("30 triangles"), "{stderr}");
    let mut turned = ground(0.3, false);
    turned = turned.replacen("f 1 2 7\n", "f 2 7 1\n", 1); // the same triangle, its corners turned
    std::fs::write(dir.join("ground_031.obj"), turned).unwrap();
    let (reordered, _) = run("reordered", 60, sequence, &[]);
    let stderr = String::from_utf8_lossy(&reordered.stderr);
    assert_eq!(reordered.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("ground_031.obj") && stderr.contains("its triangles are not the first file's"), "{stderr}");
    std::fs::remove_file(dir.join("ground_031.obj")).unwrap();
    std::fs::create_dir(dir.join("ground_031.obj")).unwrap();
    let (directory, _) = run("directory", 60, sequence, &[]);
    let stderr = String::from_utf8_lossy(&directory.stderr);
    assert_eq!(directory.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("ground_031.obj: is not a file"), "{stderr}");
    let (spheres, _) = run("spheres", 5, sequence, &["--contact", "spheres"]);
    let stderr = String::from_utf8_lossy(&spheres.stderr);
    assert_eq!(spheres.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--contact triangles"), "{stderr}");
    for output in [&changed, &reordered, &directory, &spheres] {
        assert!(!String::from_utf8_lossy(&output.stderr).contains("panicked"));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad files and values found by fuzzing the CLI: an output that names an input (or the other
/// output) is refused before anything is written, so the input survives; a collider's spin
/// axis of 1e20 runs (normalised in f64); scales, meshes and densities that f32 turns into
/// nothing are refused with the fix; `--weld` keeps `--pin-vertices` on the file's vertices;
/// a scene file's key given twice in its two spellings, or quoted, is answered at its line.
#[test]
fn outputs_inputs_and_degenerate_values_are_answered() {
    let dir = scratch_dir("cli-fuzzed");
    let file = |name: &str, text: &str| write_in(&dir, name, text);
    let square = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3\nf 1 3 4\n";
    let cloth = file("cloth.obj", square);
    let quick = ["--frames", "1", "--no-timestamps", "--quiet"];
    let run = |args: &[&str]| {
        let output = drape(&[args, &quick[..]].concat());
        (output.status.code(), String::from_utf8_lossy(&output.stderr).into_owned())
    };
    let shear0 = ["--stiffness", "40,0,2"];
    let (code, stderr) = run(&[&["--cloth-mesh", &cloth, "--json", &cloth][..], &shear0[..]].concat());
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("is the file --cloth-mesh reads"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&cloth).unwrap(), square, "the input must be left as it was");
    let out = dir.join("same.out");
    let (code, stderr) = run(&["--grid", "8", "--json", out.to_str().unwrap(), "--usd", out.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("--json and --usd both write"), "{stderr}");
    let scene = file("scene.toml", "grid = 8\n");
    let (code, stderr) = run(&["--scene-file", &scene, "--json", &scene]);
    assert_eq!(code, Some(2), "{stderr}");
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), "grid = 8\n");

    let spin = file(
        "spin.toml",
        "scene = \"swing\"\ngrid = 8\n[[collider]]\nmesh = \"torus\"\ntranslate = [0, 0.5, 0]\nspin-axis = [1e20, 0, 0]\n\
         spin-rate = 1\n",
    );
    let (code, stderr) = run(&["--scene-file", &spin]);
    assert_eq!(code, Some(0), "a spin axis of 1e20 is an axis: {stderr}");
    let tiny_scale = file("scale.toml", "scene = \"swing\"\n[[collider]]\nmesh = \"torus\"\nscale = 1e-300\n");
    let (code, stderr) = run(&["--scene-file", &tiny_scale]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("`scale` must be within [1e-6, 1e6]"), "{stderr}");
    let twice = file("twice.toml", "listed_springs = true\nlisted-springs = false\n");
    let (code, stderr) = run(&["--scene-file", &twice]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("both set --listed-springs: keep one"), "{stderr}");
    let quoted = file("quoted.toml", "grid = 8\n\"substeps\" = 0\n");
    let (code, stderr) = run(&["--scene-file", &quoted]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("line 2, key `substeps`"), "{stderr}");
    // A file's flag that the command line makes pointless is said of the file's line.
    let windy = file("windy.toml", "scene = \"swing\"\nwind = [1, 0, 0]\n");
    let (code, stderr) = run(&["--scene-file", &windy, "--scene", "drape"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("--wind only applies to the swing scene") && stderr.contains("(`wind` on line 2 of"),
        "{stderr}"
    );
    let not_tables = file("colliders.toml", "collider = [1, 2]\n");
    let (code, stderr) = run(&["--scene-file", &not_tables]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("a collider is a `[[collider]]` table") && !stderr.contains("struct"), "{stderr}");

    let tiny_cloth = file("tiny.obj", "v 0 0 0\nv 1e-10 0 0\nv 0 0 1e-10\nf 1 2 3\n");
    let (code, stderr) = run(&[&["--cloth-mesh", &tiny_cloth][..], &shear0[..]].concat());
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("spans only 1e-10 m") && stderr.contains("give the mesh in metres"), "{stderr}");
    let flat_collider =
        file("speck.obj", "v 0 0 0\nv 1e-40 0 0\nv 0 1e-40 0\nv 0 0 1e-40\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n");
    let (code, stderr) = run(&["--mesh", &flat_collider, "--grid", "8"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("`--mesh`") && stderr.contains("its vertices span"), "{stderr}");
    let (code, stderr) = run(&[&["--cloth-mesh", &cloth, "--piece-density", "1=1e-45"][..], &shear0[..]].concat());
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("[0.001, 1000]"), "{stderr}");

    // Two triangles split along their shared edge: file vertices 3 and 4 repeat 1 and 2.
    let split = file("split.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 3\nf 4 6 5\n");
    let frames = dir.join("frames");
    // Self-collision off: the two triangles share their vertices (nothing to collide), and its
    // passes would raise the substeps near the sphere, slowing the 10 frames' fall measured here.
    let args = ["--cloth-mesh", &split, "--weld", "--pin-vertices", "3", "--self-collision", "off"];
    let args = [&args[..], &["--obj-dir", frames.to_str().unwrap()]].concat();
    let output = drape(&[&args[..], &shear0[..], &["--frames", "10", "--no-timestamps", "--quiet"][..]].concat());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let last = std::fs::read_to_string(frames.join("frame_00010.obj")).unwrap();
    let heights: Vec<f32> = last
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|v| v.split(' ').nth(1).unwrap().parse().unwrap())
        .collect();
    // File vertex 3 is file vertex 1, welded particle 1: it stays where the scene put it.
    assert_eq!(heights.len(), 4);
    assert!(heights[1] > heights[0] + 0.1 && heights[1] > heights[2] + 0.1, "particle 1 is pinned: {heights:?}");
    let (code, stderr) = run(&[&["--cloth-mesh", &split, "--weld", "--pin-vertices", "6"][..], &shear0[..]].concat());
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("the --cloth-mesh files have 6 vertices"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
