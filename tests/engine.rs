//! The Vulkan engine: binding tables against the SPIR-V, timing reports, RAII teardown under
//! validation, and the error a machine without a driver gets.

mod common;

use common::{assert_validation_clean, context};
use drape::gpu::portability::pointer_values;
use drape::gpu::reflect::{EXECUTION_MODEL_FRAGMENT, EXECUTION_MODEL_GL_COMPUTE, EXECUTION_MODEL_VERTEX, reflect};
use drape::{ClothBuilder, ClothId, Collider, ContactSearch, Integrator, Mesh, Model, SimSettings, Solver};

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

/// Each kernel's binding table (written once, in `drape::kernels`) equals what the SPIR-V
/// declares: same bindings in the same order, same names, same writability, push constants.
#[test]
fn binding_tables_match_the_spirv() {
    // Each module holds its own entry point and no other.
    let mut reflected = std::collections::HashMap::new();
    for &(name, spirv) in drape::KERNEL_MODULES {
        let module = reflect(spirv).unwrap();
        assert_eq!(module.keys().collect::<Vec<_>>(), [name], "the module of {name}");
        reflected.extend(module);
    }
    let compute: Vec<_> = reflected.iter().filter(|(_, e)| e.execution_model == EXECUTION_MODEL_GL_COMPUTE).collect();
    assert_eq!(compute.len(), drape::kernels::ALL.len(), "compute entry points: {compute:?}");
    // The surface shaders a renderer binds: vertex and fragment stage, push constants only.
    for (name, model) in
        [("render::surface_vertex", EXECUTION_MODEL_VERTEX), ("render::surface_fragment", EXECUTION_MODEL_FRAGMENT)]
    {
        let entry = reflected.get(name).unwrap_or_else(|| panic!("no entry point {name}"));
        assert_eq!(entry.execution_model, model, "{name}");
        assert!(entry.bindings.is_empty() && entry.uses_push_constants, "{name}: {entry:?}");
    }
    assert_eq!(reflected.len(), compute.len() + 2, "entry points: {:?}", reflected.keys());
    for kernel in drape::kernels::ALL {
        let spec = kernel.spec;
        let entry = reflected.get(spec.entry).unwrap_or_else(|| panic!("no entry point {}", spec.entry));
        assert!(drape::ENTRY_POINTS.contains(&spec.entry));
        assert_eq!(entry.bindings.len(), spec.bindings.len(), "{}: binding count", spec.entry);
        for (i, (declared, actual)) in spec.bindings.iter().zip(&entry.bindings).enumerate() {
            assert_eq!((actual.set, actual.binding), (0, i as u32), "{}: {}", spec.entry, declared.name);
            assert_eq!(actual.name, declared.name, "{} binding {i}", spec.entry);
            assert_eq!(
                actual.writable, declared.writable,
                "{} binding {i} ({}) writability",
                spec.entry, declared.name
            );
        }
        assert_eq!(entry.uses_push_constants, spec.push_constant_size > 0, "{}: push constants", spec.entry);
        assert_eq!(entry.workgroup_size, [spec.workgroup_size, 1, 1], "{}: workgroup size", spec.entry);
    }
}

/// No kernel holds a pointer as data: NVIDIA's shader compiler (driver 580, H100) crashed
/// creating the pipelines of the eight kernels that did (every LBVH walk: a query struct of
/// slices and counters carried through the walk's loop as a phi, or a visitor kept in a local
/// variable because a struct held a reference to it), while lavapipe ran them.
#[test]
fn no_kernel_holds_a_pointer_as_data() {
    let mut per_kernel: std::collections::BTreeMap<(&str, String, &str), usize> = Default::default();
    for &(name, spirv) in drape::KERNEL_MODULES {
        for value in pointer_values(spirv).unwrap() {
            *per_kernel.entry((name, value.function, value.kind)).or_default() += 1;
        }
    }
    assert!(per_kernel.is_empty(), "pointers held as data (module, function, what: count): {per_kernel:?}");
}

/// The check finds a pointer-holding phi and local variable, and only those, in a hand-made
/// module: a struct of a storage-buffer pointer and an int.
#[test]
fn pointer_check_finds_pointers_held_as_data() {
    let op = |opcode: u32, ops: &[u32]| {
        let mut words = vec![((ops.len() as u32 + 1) << 16) | opcode];
        words.extend_from_slice(ops);
        words
    };
    let mut words = vec![0x0723_0203, 0x0001_0500, 0, 20, 0];
    let (function, storage_buffer) = (7, 12);
    words.extend(op(21, &[1, 32, 0])); // %1 = OpTypeInt 32 0
    words.extend(op(32, &[2, storage_buffer, 1])); // %2 = OpTypePointer StorageBuffer %1
    words.extend(op(30, &[3, 2, 1])); // %3 = OpTypeStruct %2 %1
    words.extend(op(32, &[4, function, 3])); // %4 = OpTypePointer Function %3
    words.extend(op(32, &[12, function, 1])); // %12 = OpTypePointer Function %1
    words.extend(op(19, &[5])); // %5 = OpTypeVoid
    words.extend(op(33, &[6, 5])); // %6 = OpTypeFunction %5
    words.extend(op(5, &[7, u32::from_le_bytes(*b"kern"), 0])); // OpName %7 "kern"
    words.extend(op(54, &[5, 7, 0, 6])); // %7 = OpFunction %5 None %6
    words.extend(op(248, &[8])); // %8 = OpLabel
    words.extend(op(59, &[4, 9, function])); // %9 = OpVariable %4 Function: holds a pointer
    words.extend(op(59, &[12, 13, function])); // %13 = OpVariable %12 Function: an int
    words.extend(op(245, &[3, 10, 11, 8])); // %10 = OpPhi %3 ...: holds a pointer
    words.extend(op(245, &[1, 14, 11, 8])); // %14 = OpPhi %1 ...: an int
    words.extend(op(253, &[])); // OpReturn
    words.extend(op(56, &[])); // OpFunctionEnd
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let found = pointer_values(&bytes).unwrap();
    let kinds: Vec<(&str, &str)> = found.iter().map(|v| (v.function.as_str(), v.kind)).collect();
    assert_eq!(kinds, [("kern", "function variable"), ("kern", "OpPhi")]);
}

/// An entry point that no embedded module holds is an error that names it and the fix, not a
/// panic.
#[test]
fn a_kernel_without_a_module_is_an_error() {
    assert!(drape::kernel_module("no::such_kernel").is_none());
    assert!(drape::ENTRY_POINTS.iter().all(|entry| drape::kernel_module(entry).is_some()));
    let ctx = context();
    let error = drape::gpu::ShaderModule::for_entry(&ctx, "no::such_kernel").err().expect("an error");
    let message = error.to_string();
    assert!(message.contains("no::such_kernel") && message.contains("kernels/spirv"), "{message}");
    assert_validation_clean(&ctx);
}

#[test]
fn reflection_rejects_garbage() {
    assert!(reflect(b"not spirv at all....").is_err());
    assert!(reflect(&[]).is_err());
}

/// Every recorded pass gets a GPU time; skipped passes are listed as skipped.
#[test]
fn frame_timings_name_every_pass() {
    let ctx = context();
    let cloth = ClothBuilder::new(16, 16).pin_top_corners().build().unwrap();
    let settings = SimSettings::default().with_substeps(Some(3)).with_normals(false);
    let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
    let timings = sim.step().unwrap();
    let labels: Vec<_> = timings.by_label().iter().map(|(l, n, _)| (*l, *n)).collect();
    assert_eq!(
        labels,
        vec![
            ("sleep: tiles", 1),
            ("rk4: k1", 3),
            ("rk4: k2", 3),
            ("rk4: k3", 3),
            ("rk4: k4 + update", 3),
            ("health check", 1),
            ("sleep: tile motion", 1)
        ]
    );
    assert_eq!(timings.skipped, vec!["contact", "normals"]);
    assert!(ctx.info().timestamp_valid_bits > 0, "lavapipe and real GPUs have compute timestamps");
    for pass in &timings.passes {
        let micros = pass.micros.expect("timestamps");
        assert!(micros.is_finite() && micros > 0.0, "{}: {micros} µs", pass.label);
    }
    // Each pass reads what the one before wrote (a barrier between every two), so the frame's
    // span, first start to last end, holds every pass one after another.
    let span = timings.span_micros.expect("timestamps");
    assert!(span >= 0.999 * timings.total_micros(), "span {span} µs, passes {} µs", timings.total_micros());
    assert_validation_clean(&ctx);
}

/// With candidate lists (the default search) a collider's narrow phase runs inside the
/// integrator's last stage, one pass per substep instead of three (stage, cull, detect); a
/// second collider's contact runs after it in passes of its own. Both integrators.
#[test]
fn the_first_colliders_narrow_phase_runs_inside_the_last_stage() {
    let ctx = context();
    let cloth = ClothBuilder::new(16, 16).build().unwrap();
    let colliders =
        [Collider::mesh(&Mesh::icosphere(0.3, 2), 0.01), Collider::mesh(&Mesh::torus(0.3, 0.1, 24, 12), 0.01)];
    let labels = |integrator: Integrator, colliders: &[Collider]| {
        let settings = SimSettings::default().with_substeps(Some(3)).with_normals(false).with_integrator(integrator);
        let mut sim = Solver::new(&ctx, &Model::single(&cloth, colliders, settings).unwrap()).unwrap();
        let timings = sim.step().unwrap();
        timings.by_label().iter().map(|(l, n, _)| (*l, *n)).collect::<Vec<_>>()
    };
    assert_eq!(
        labels(Integrator::Rk4, &colliders[..1]),
        vec![
            ("sleep: tiles", 1),
            ("contact: broad phase", 1),
            ("rk4: k1", 3),
            ("rk4: k2", 3),
            ("rk4: k3", 3),
            ("rk4: k4 + update + contact (lists)", 3),
            ("health check", 1),
            ("sleep: tile motion", 1)
        ]
    );
    assert_eq!(
        labels(Integrator::SemiImplicitEuler, &colliders),
        vec![
            ("sleep: tiles", 1),
            ("contact: broad phase", 2),
            ("euler: evaluate", 3),
            ("euler: commit + contact (lists)", 3),
            ("contact: cull", 3),
            ("contact: detect+respond (lists)", 3),
            ("health check", 1),
            ("sleep: tile motion", 1)
        ]
    );
    // Another search keeps its own passes after the stage.
    let walk = [colliders[0].clone().with_search(ContactSearch::TraverseEverySubstep)];
    let passes = labels(Integrator::Rk4, &walk);
    assert!(passes.contains(&("rk4: k4 + update", 3)) && passes.contains(&("contact: cull", 3)), "{passes:?}");
    assert_validation_clean(&ctx);
}

/// Many simulations created and dropped (and the context last): the validation layer reports
/// no leaked or misordered object destruction.
#[test]
fn objects_are_destroyed_cleanly() {
    let ctx = context();
    for n in [4, 9, 33] {
        let cloth = ClothBuilder::new(n, n + 1).build().unwrap();
        let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
        sim.step().unwrap();
        assert_eq!(sim.positions(CLOTH).unwrap().len(), (n * (n + 1)) as usize);
    }
    assert_validation_clean(&ctx);
    drop(ctx);
}

/// Without any Vulkan driver the CLI fails with a message that names the fix.
#[test]
fn no_driver_gives_a_clear_error() {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--frames", "1"])
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("install a Vulkan driver"), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "stderr: {stderr}");
}

/// Bad CLI values get a clear message, not a panic.
#[test]
fn cli_rejects_invalid_values() {
    for args in [
        &["--grid", "1"][..],
        &["--frames", "x"],
        &["--mass", "-1"],
        &["--substeps", "0"],
        &["--velocity", "-1,0"],
        &["--velocity", "1,inf,0"],
        &["--frames", "0"],
    ] {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().unwrap();
        assert!(!output.status.success(), "{args:?} accepted");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains("error"), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

/// `--velocity X,Y,Z` (negatives included) gives the cloth its initial velocity: thrown down
/// at 3 m/s it is 0.15 m lower after 3 frames than dropped.
#[test]
fn cli_velocity_throws_the_cloth() {
    let lowest = |velocity: &str| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--scene", "swing", "--grid", "8", "--frames", "3", "--no-timestamps", "--velocity", velocity])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout).to_string();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let y = stdout.split("lowest particle at y = ").nth(1).and_then(|r| r.split(" m").next());
        y.and_then(|y| y.trim().parse::<f32>().ok()).unwrap_or_else(|| panic!("no lowest particle in:\n{stdout}"))
    };
    let (thrown, dropped) = (lowest("0,-3,0"), lowest("0,0,0"));
    assert!(dropped - thrown > 0.1, "thrown {thrown} m, dropped {dropped} m");
}

/// Triangles are the default contact: without `--contact` the cloth rests at the thickness on
/// the true surface, with nothing inside; `--contact spheres` (the paper's proxy) holds it off
/// the surface by centimetres.
#[test]
fn cli_contact_triangles_is_the_default_and_rests_on_the_true_surface() {
    let gap = |contact: &[&str]| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--grid", "32", "--frames", "90", "--no-timestamps"])
            .args(contact)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout).to_string();
        assert!(output.status.success(), "{contact:?}: {}", String::from_utf8_lossy(&output.stderr));
        assert!(stdout.contains("particles inside the mesh   0.000 %"), "{contact:?}:\n{stdout}");
        let leaves = if contact.is_empty() { "triangle leaves" } else { "spheres in" };
        assert!(stdout.contains(leaves), "{contact:?} must collide with {leaves}:\n{stdout}");
        let line = stdout.lines().find(|l| l.contains("gap to true surface mean")).expect("a resting line");
        let mean = line.split("mean ").nth(1).and_then(|r| r.split(" mm").next()).unwrap();
        mean.trim().parse::<f32>().unwrap() * 1e-3
    };
    let thickness = drape::scenes::DEFAULT_THICKNESS;
    let triangles = gap(&[]);
    assert!((0.5 * thickness..=1.5 * thickness).contains(&triangles), "triangles: gap {triangles} m");
    assert!(gap(&["--contact", "spheres"]) > 10.0 * thickness, "the sphere proxy must float the cloth");
}

/// `--holes close` (the default) fills the bunny's five base holes, so its inside is defined and
/// reported; `--holes keep` collides with the open scan, whose inside the report calls undefined.
#[test]
fn cli_holes_close_the_bunny_or_keep_it_open() {
    let bunny = drape::scenes::shared_model("stanford-bunny.obj");
    assert!(bunny.exists(), "{} not found: this test needs ../shared/models", bunny.display());
    let run = |holes: &[&str]| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
            .args(["--mesh", "bunny", "--grid", "8", "--frames", "2", "--no-timestamps"])
            .args(holes)
            .output()
            .unwrap();
        assert!(output.status.success(), "{holes:?}: {}", String::from_utf8_lossy(&output.stderr));
        String::from_utf8_lossy(&output.stdout).to_string()
    };
    for closed in [run(&[]), run(&["--holes", "close"])] {
        assert!(closed.contains("mesh: bunny (closed 5 small holes): closed"), "{closed}");
        assert!(closed.contains("particles inside the mesh   0.000 %"), "{closed}");
    }
    let open = run(&["--holes", "keep"]);
    assert!(open.contains("mesh: bunny (holes kept): open, 223 boundary edges"), "{open}");
    assert!(open.contains("particles inside the mesh   n/a (open mesh: no inside)"), "{open}");
}

/// Barriers come from declared accesses: independent steps share none, a read after a write, a
/// write after a read and a write after a write each get one.
#[test]
fn barriers_follow_declared_reads_and_writes() {
    use drape::graph::{Access, HazardTracker, Resources};
    let mut resources = Resources::new();
    let a = resources.device::<u32>("a", 4).id();
    let b = resources.device::<u32>("b", 4).id();
    let c = resources.device::<u32>("c", 4).id();
    let mut hazards = HazardTracker::default();
    let mut needs =
        |accesses: &[(drape::graph::BufferId, Access)]| hazards.barrier_before(&access_step(accesses, None)).is_some();
    assert!(!needs(&[(a, Access::Write)]), "first write");
    assert!(!needs(&[(b, Access::Write)]), "independent write");
    assert!(needs(&[(a, Access::Read), (c, Access::Write)]), "read after write");
    assert!(!needs(&[(a, Access::Read)]), "read after read");
    assert!(needs(&[(a, Access::Write)]), "write after read");
    assert!(needs(&[(a, Access::Write)]), "write after write");
}

/// A step of a test kernel whose bindings are `accesses` (one read, one write, a read and a
/// write, or two writes), dispatched indirectly from `args` when given.
fn access_step(
    accesses: &[(drape::graph::BufferId, drape::graph::Access)],
    args: Option<drape::graph::Handle<drape_types::DispatchArgs>>,
) -> drape::graph::Step {
    use drape::graph::{Access, BindingSpec, Dispatch, Kernel, KernelSpec, Pass, Step};
    static READ: Kernel =
        Kernel { spec: KernelSpec::new("test::read", &[BindingSpec::read("r")], 64), cpu: |_| Ok(()) };
    static WRITE: Kernel =
        Kernel { spec: KernelSpec::new("test::write", &[BindingSpec::write("w")], 64), cpu: |_| Ok(()) };
    static READ_WRITE: Kernel = Kernel {
        spec: KernelSpec::new("test::read_write", &[BindingSpec::read("r"), BindingSpec::write("w")], 64),
        cpu: |_| Ok(()),
    };
    static WRITE_TWO: Kernel = Kernel {
        spec: KernelSpec::new("test::write_two", &[BindingSpec::write("w0"), BindingSpec::write("w1")], 64),
        cpu: |_| Ok(()),
    };
    let kernel = match accesses {
        [(_, Access::Read)] => &READ,
        [(_, Access::Write)] => &WRITE,
        [(_, Access::Read), (_, Access::Write)] => &READ_WRITE,
        [(_, Access::Write), (_, Access::Write)] => &WRITE_TWO,
        other => panic!("no test kernel for {other:?}"),
    };
    let dispatch = args.map_or(Dispatch::Threads(64), Dispatch::Indirect);
    let bindings = accesses.iter().map(|(id, _)| *id).collect();
    Step::Run(Pass { label: "test", kernel, bindings, push: None, dispatch })
}

/// A kernel writes indirect arguments and `a`, the next reads `a` and writes `b`, then an
/// indirect dispatch over those arguments reads `c` (which nothing wrote).
fn indirect_after_kernels(
    resources: &mut drape::graph::Resources,
) -> (drape::graph::Handle<drape_types::DispatchArgs>, drape::graph::Handle<u32>, Vec<drape::graph::Step>) {
    use drape::graph::Access;
    let args = resources.device::<drape_types::DispatchArgs>("args", 1);
    let (a, b, c) = (resources.device::<u32>("a", 4), resources.device::<u32>("b", 4), resources.device::<u32>("c", 4));
    let steps = vec![
        access_step(&[(args.id(), Access::Write), (a.id(), Access::Write)], None),
        access_step(&[(a.id(), Access::Read), (b.id(), Access::Write)], None),
        access_step(&[(c.id(), Access::Read)], Some(args)),
    ];
    (args, a, steps)
}

/// A barrier covers only the stages where the next step conflicts with earlier accesses: a
/// kernel-to-kernel barrier does not cover a later indirect dispatch's reading of arguments
/// written before it, which gets a barrier of its own; a fill after kernels that wrote and read
/// the buffer waits for them and for the argument read; a barrier's source stages are those of
/// every access still pending for its destination stages.
#[test]
fn barriers_cover_the_stages_that_need_them() {
    use drape::graph::{Access, Barrier, HazardTracker, Resources, Stages, Step};
    let mut resources = Resources::new();
    let (_, a, steps) = indirect_after_kernels(&mut resources);
    let mut hazards = HazardTracker::default();
    let barriers: Vec<_> = steps.iter().map(|step| hazards.barrier_before(step)).collect();
    let kernels = Barrier { before: Stages::KERNEL, after: Stages::KERNEL };
    let arguments = Barrier { before: Stages::KERNEL, after: Stages::INDIRECT };
    assert_eq!(barriers, [None, Some(kernels), Some(arguments)]);
    let fill = Step::fill(a, 0);
    let after_reads = Barrier { before: Stages::KERNEL | Stages::INDIRECT, after: Stages::TRANSFER };
    assert_eq!(hazards.barrier_before(&fill), Some(after_reads));
    // A kernel reading what the fill wrote waits for it (and orders the reads still pending
    // for kernels: every stage is a source).
    let read = access_step(&[(a.id(), Access::Read)], None);
    assert_eq!(hazards.barrier_before(&read), Some(Barrier { before: Stages::ALL, after: Stages::KERNEL }));
}

/// `plan_barriers` widens a barrier by the stages of a later step that would otherwise need a
/// barrier of its own: the indirect dispatch's argument read joins the kernel-to-kernel
/// barrier before it, one barrier where step-by-step tracking places two.
#[test]
fn planned_barriers_cover_later_steps_when_that_spares_a_barrier() {
    use drape::graph::{Barrier, Resources, Stages, plan_barriers};
    let mut resources = Resources::new();
    let (_, _, steps) = indirect_after_kernels(&mut resources);
    let widened = Barrier { before: Stages::KERNEL, after: Stages::KERNEL | Stages::INDIRECT };
    assert_eq!(plan_barriers(&steps), [None, Some(widened), None]);
}

/// A recorded cloth frame has fewer barriers than commands: the resets at the start of the
/// frame run without one, each dependent stage gets one.
#[test]
fn a_cloth_frame_records_only_the_barriers_its_data_needs() {
    let ctx = context();
    let cloth = ClothBuilder::new(16, 16).pin_top_corners().build().unwrap();
    let settings = SimSettings::default().with_substeps(Some(3)).with_normals(true);
    let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
    // fill health, which tiles sleep, 12 stages, normals and health check, each tile's motion
    // = 16 commands: the tiles' decision counts into the health the fill cleared and sets the
    // velocities' flags the first stage reads; the motion only reads x after stage 12, as the
    // normals and the health check do.
    assert_eq!(sim.barriers_per_frame(), 14, "one before the tiles, one before each stage, one before normals+health");
    sim.step().unwrap();
    assert_validation_clean(&ctx);
}

/// A recorded frame holds what it binds: it still runs after its engine is gone.
#[test]
fn a_recorded_frame_outlives_its_engine() {
    let ctx = context();
    let spheres: Vec<glam::Vec4> = (0..300).map(|i| glam::Vec4::new(i as f32, (i % 7) as f32, 0.0, 0.5)).collect();
    let mut lbvh = drape::lbvh::GpuLbvh::build(&ctx, &spheres, 0.0).unwrap();
    let mut frame = lbvh.build_frame(true).unwrap();
    drop(lbvh);
    let timings = frame.submit().unwrap();
    assert!(timings.passes.iter().any(|p| p.label == "refit"));
    drop(frame);
    assert_validation_clean(&ctx);
}

/// The SPIR-V committed for downstream crates (embedded without `rebuild-kernels`) equals this
/// build's fresh rust-gpu modules, entry points included, with no stale module beside them. CI
/// builds with `rebuild-kernels`, so a kernel change without `DRAPE_UPDATE_SPIRV=1` and a commit
/// of `kernels/spirv/` fails here.
#[cfg(feature = "rebuild-kernels")]
#[test]
fn committed_spirv_equals_a_fresh_build() {
    let fix = "run `DRAPE_UPDATE_SPIRV=1 cargo build --release --features rebuild-kernels` and commit kernels/spirv/";
    let dir = std::path::Path::new(env!("DRAPE_COMMITTED_SPIRV_DIR"));
    let read = |name: &str| {
        let path = dir.join(name);
        std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}: {fix}", path.display()))
    };
    let entry_points = String::from_utf8(read("entry_points.txt")).unwrap();
    let committed_entries: Vec<&str> = entry_points.lines().filter(|l| !l.is_empty()).collect();
    assert_eq!(committed_entries, drape::ENTRY_POINTS, "kernels/spirv/entry_points.txt is stale: {fix}");
    let mut expected_files = vec![];
    for &(entry, fresh) in drape::KERNEL_MODULES {
        let file = format!("{}.spv", entry.replace("::", "."));
        let committed = read(&file);
        assert!(
            committed == fresh,
            "kernels/spirv/{file} ({} bytes) differs from the fresh build ({} bytes): {fix}",
            committed.len(),
            fresh.len()
        );
        expected_files.push(file);
    }
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|f| f.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".spv"))
        .collect();
    files.sort();
    expected_files.sort();
    assert_eq!(files, expected_files, "kernels/spirv/ holds modules of no entry point: {fix}");
}

/// A redirected run (stderr not a terminal) gets no progress bar: its log has no carriage
/// returns; `--no-timestamps` omits the per-kernel table (no zeros) and still gives wall times.
#[test]
fn cli_redirected_log_has_no_carriage_returns_and_no_timestamps_omits_the_table() {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--grid", "8", "--frames", "3", "--no-timestamps"])
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "stderr: {stderr}");
    assert!(!stderr.contains('\r') && !stdout.contains('\r'), "carriage return in a redirected log: {stderr:?}");
    assert!(!stdout.contains("GPU time per kernel") && !stdout.contains("total GPU"), "stdout: {stdout}");
    assert!(stdout.contains("GPU timestamps off") && stdout.contains("wall time per frame over 3 frames"), "{stdout}");
    let timed = std::process::Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["--grid", "8", "--frames", "3"])
        .output()
        .unwrap();
    let timed_stdout = String::from_utf8_lossy(&timed.stdout);
    assert!(timed_stdout.contains("GPU time per kernel") && timed_stdout.contains("total GPU"), "{timed_stdout}");
}
