//! The CLI's answers to bad input (issue 10): usage errors exit with 2 and name the flag and
//! the allowed values before any work starts; runtime errors exit with 1 and name the file;
//! nothing panics. And the vector flags take X,Y,Z with negatives.

use std::process::{Command, Output};

fn drape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().unwrap()
}

/// Every bad input gets its exit code and a message naming the cause.
#[test]
fn bad_input_gets_a_clear_message_and_the_right_exit_code() {
    let usage = 2;
    let runtime = 1;
    let cases: &[(&[&str], i32, &str)] = &[
        (&["--scene", "swing", "--mesh", "bunny"], usage, "--mesh does nothing in the swing scene"),
        (&["--scene", "swing", "--friction", "0.1"], usage, "--friction does nothing in the swing scene"),
        (&["--wind", "1,0,0"], usage, "--wind only applies to the swing scene"),
        (&["--scene", "pile", "--holes", "keep"], usage, "--holes does nothing in the pile scene"),
        (&["--voxels", "8"], usage, "--voxels only applies with --contact spheres"),
        (&["--obj-every", "3"], usage, "--obj-every needs --obj-dir"),
        (&["--thickness", "1000"], usage, "(0, 0.5]"),
        (&["--friction", "-1"], usage, "[0, 10]"),
        (&["--stiffness", "1e30,1,1"], usage, "[0, 1000000]"),
        (&["--stiffness", "40"], usage, "K_STRUCT,K_SHEAR,K_BEND"),
        (&["--wind", "1,0"], usage, "X,Y,Z"),
        (&["--substeps", "0"], usage, "1..=100000"),
        (&["--grid", "4096"], usage, "2..=2048"),
        (&["--grid", "8", "--grid", "9"], usage, "cannot be used multiple times"),
        (&["--frames", "0"], usage, "--frames"),
        (&["--pin-box", "1,1,1,0,0,0"], usage, "min <= max"),
        (&["--mesh", "/nonexistent/model.obj", "--frames", "1"], runtime, "/nonexistent/model.obj"),
        (&["--cloth-mesh", "/nonexistent/cloth.obj", "--frames", "1"], runtime, "/nonexistent/cloth.obj"),
        (&["--obj-dir", "/proc/drape-cannot-write-here", "--frames", "1"], runtime, "--obj-dir"),
    ];
    for &(args, code, needle) in cases {
        let output = drape(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(code), "{args:?}: exit code\n{stderr}");
        assert!(stderr.contains(needle), "{args:?}: the message must say `{needle}`:\n{stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
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
