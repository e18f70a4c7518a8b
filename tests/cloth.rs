//! Cloth simulation on the GPU (lavapipe in CI) against its CPU twin, an f64 reference and
//! physics it must obey. Validation layers are on in every test.

mod common;

use common::{assert_validation_clean, context, max_distance};
use drape::reference::{ReferenceCloth, energy};
use drape::{Cloth, ClothBuilder, ClothId, CpuSolver, Error, Integrator, Model, SimSettings, Solver};
use glam::{Vec3, Vec4};

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

/// The default scene's cloth at a smaller size: pinned at two corners, wind, default springs.
fn swinging(n: u32) -> Cloth {
    ClothBuilder::new(n, n).external_force(Vec3::new(0.3, 0.0, 0.5)).pin_top_corners().build().unwrap()
}

fn run_gpu(cloth: &Cloth, settings: SimSettings, frames: u32) -> (Vec<Vec4>, Vec<Vec4>) {
    let ctx = context();
    let mut sim = Solver::new(&ctx, &Model::single(cloth, &[], settings).unwrap()).unwrap();
    for _ in 0..frames {
        sim.step().unwrap();
    }
    let out = (sim.positions(CLOTH).unwrap(), sim.velocities(CLOTH).unwrap());
    drop(sim);
    assert_validation_clean(&ctx);
    out
}

fn error_vs_reference(x: &[Vec4], reference: &ReferenceCloth) -> f64 {
    x.iter().zip(&reference.x).map(|(p, q)| (p.truncate().as_dvec3() - *q).length()).fold(0.0, f64::max)
}

/// GPU and CPU run the same kernel functions on the same schedule. They may differ only where
/// LLVM (llvmpipe's JIT vs rustc) contracts a*b+c into an FMA or evaluates sqrt/division with a
/// different rounding: at most a few ulp per operation. After one frame (20 substeps x 4 stages)
/// that is < 1e-5 m on a 1 m cloth; after 100 frames of a swinging, wind-driven cloth the
/// differences are amplified by the dynamics, and 1e-3 m (0.1% of the cloth) bounds them.
#[test]
fn gpu_equals_cpu_after_one_and_100_frames() {
    let cloth = swinging(32);
    let settings = SimSettings::default();
    let ctx = context();
    let mut gpu = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
    let mut cpu = CpuSolver::new(&Model::single(&cloth, &[], settings).unwrap()).unwrap();
    gpu.step().unwrap();
    cpu.step().unwrap();
    let one = max_distance(&gpu.positions(CLOTH).unwrap(), &cpu.positions(CLOTH).unwrap());
    assert!(one <= 1e-5, "after 1 frame GPU and CPU differ by {one} m");
    for _ in 1..100 {
        gpu.step().unwrap();
        cpu.step().unwrap();
    }
    let hundred = max_distance(&gpu.positions(CLOTH).unwrap(), &cpu.positions(CLOTH).unwrap());
    let velocity = max_distance(&gpu.velocities(CLOTH).unwrap(), &cpu.velocities(CLOTH).unwrap());
    println!("GPU vs CPU: {one:e} m after 1 frame, {hundred:e} m / {velocity:e} m/s after 100");
    assert!(hundred <= 1e-3, "after 100 frames GPU and CPU differ by {hundred} m");
    // The cloth did move (this is not a comparison of two frozen states).
    let moved = max_distance(&gpu.positions(CLOTH).unwrap(), &cloth.positions);
    assert!(moved > 0.3, "cloth moved only {moved} m");
    drop(gpu);
    assert_validation_clean(&ctx);
}

/// A frame's substeps in one workgroup (`SimSettings::one_workgroup_substeps`: one dispatch a
/// frame, its lanes waiting at a workgroup barrier between stages) give the stage-per-dispatch
/// frame bit for bit on lavapipe, for a grid with RK4 and with semi-implicit Euler and for a
/// spring-list cloth; the CPU twin, which runs the lanes one after another, gets its own
/// stage-per-dispatch frame bit for bit too. Each frame did run as the one dispatch.
#[test]
fn substeps_in_one_workgroup_equal_the_stagewise_frame() {
    let ctx = context();
    let cases = [(false, Integrator::Rk4), (false, Integrator::SemiImplicitEuler), (true, Integrator::Rk4)];
    for (listed, integrator) in cases {
        let cloth = ClothBuilder::new(24, 24)
            .external_force(Vec3::new(0.3, 0.0, 0.5))
            .pin_top_corners()
            .listed_springs(listed)
            .build()
            .unwrap();
        let case = format!("{integrator:?}, listed springs {listed}");
        let model = |one: bool| {
            let settings = SimSettings::default().with_integrator(integrator).with_one_workgroup_substeps(Some(one));
            Model::single(&cloth, &[], settings).unwrap()
        };
        let gpu = |one: bool| {
            let mut sim = Solver::new(&ctx, &model(one)).unwrap();
            let mut one_dispatch_frames = 0;
            for _ in 0..30 {
                let timings = sim.step().unwrap();
                let labels: Vec<&str> = timings.passes.iter().map(|p| p.label).collect();
                if labels.contains(&"substeps in one workgroup") && !labels.iter().any(|l| l.contains("k1")) {
                    one_dispatch_frames += 1;
                }
            }
            (sim.positions(CLOTH).unwrap(), sim.velocities(CLOTH).unwrap(), one_dispatch_frames)
        };
        let cpu = |one: bool| {
            let mut sim = CpuSolver::new(&model(one)).unwrap();
            for _ in 0..30 {
                sim.step().unwrap();
            }
            (sim.positions(CLOTH).unwrap(), sim.velocities(CLOTH).unwrap())
        };
        let ((x_one, v_one, one_frames), (x_staged, v_staged, staged_frames)) = (gpu(true), gpu(false));
        assert_eq!((one_frames, staged_frames), (30, 0), "{case}: frames run as one dispatch");
        let moved = max_distance(&x_one, &cloth.positions);
        assert!(moved > 0.1, "{case}: the cloth must swing ({moved} m)");
        assert!(x_one == x_staged && v_one == v_staged, "{case}: GPU one workgroup vs stagewise");
        assert!(cpu(true) == cpu(false), "{case}: CPU twin one workgroup vs stagewise");
    }
    assert_validation_clean(&ctx);
}

/// The GPU's RK4 with automatic substeps (h near 0.9x the stability bound, where truncation error
/// is largest) against the f64 reference at 1/24000 s steps. Target: within 0.1% of the cloth's
/// size after 0.5 s of swinging (measured: ~1.3e-4 m).
#[test]
fn rk4_matches_f64_reference() {
    let cloth = swinging(12);
    let frames = 30;
    let (x, _) = run_gpu(&cloth, SimSettings::default(), frames);
    let mut reference = ReferenceCloth::new(&cloth);
    reference.run(frames as f64 / 60.0, frames * 400);
    let error = error_vs_reference(&x, &reference);
    println!("RK4 (auto substeps) vs f64 reference after 0.5 s: {error:e} m");
    assert!(error < 1e-3, "RK4 error {error} m");
    // Four times the substeps: the error falls by two orders of magnitude (4th order).
    let auto = SimSettings::default().stability(&cloth).unwrap().substeps;
    let (x, _) = run_gpu(&cloth, SimSettings::default().with_substeps(Some(4 * auto)), frames);
    let finer = error_vs_reference(&x, &reference);
    println!("RK4 ({} substeps/frame) vs f64 reference: {finer:e} m", 4 * auto);
    assert!(finer < error / 50.0, "error {error} -> {finer} with 4x substeps");
}

/// Measured order of convergence: error at t = 0.25 s against the f64 reference for h, h/2,
/// h/4. The cloth gets a checkerboard velocity kick so the stiff in-plane modes carry the
/// truncation error well above f32 round-off (~2e-7 m here).
fn convergence_orders(integrator: Integrator) -> (f64, f64, [f64; 3]) {
    let n = 6;
    let mut cloth =
        ClothBuilder::new(n, n).stiffness(4.0, 1.0, 0.4).spring_damping(0.0).pin_top_corners().build().unwrap();
    for (i, v) in cloth.velocities.iter_mut().enumerate() {
        let sign = if (i as u32 / n + i as u32 % n).is_multiple_of(2) { 1.0 } else { -1.0 };
        if cloth.positions[i].w != 0.0 {
            *v = Vec4::new(0.3 * sign, 0.0, 0.0, 0.0);
        }
    }
    let frames = 15;
    let mut reference = ReferenceCloth::new(&cloth);
    reference.run(frames as f64 / 60.0, frames * 400);
    let errors = [1, 2, 4].map(|substeps| {
        let settings = SimSettings::default().with_substeps(Some(substeps)).with_integrator(integrator);
        let (x, _) = run_gpu(&cloth, settings, frames);
        error_vs_reference(&x, &reference)
    });
    ((errors[0] / errors[1]).log2(), (errors[1] / errors[2]).log2(), errors)
}

#[test]
fn rk4_converges_with_order_four() {
    let (p1, p2, errors) = convergence_orders(Integrator::Rk4);
    println!("RK4 errors {errors:?}, orders {p1:.2} {p2:.2}");
    assert!(p1 >= 3.8 && p2 >= 3.8, "RK4 orders {p1:.2}, {p2:.2} (errors {errors:?})");
}

#[test]
fn semi_implicit_euler_converges_with_order_one() {
    let (p1, p2, errors) = convergence_orders(Integrator::SemiImplicitEuler);
    println!("Euler errors {errors:?}, orders {p1:.2} {p2:.2}");
    for p in [p1, p2] {
        assert!((0.85..=1.15).contains(&p), "Euler orders {p1:.2}, {p2:.2} (errors {errors:?})");
    }
}

#[test]
fn pinned_particles_stay_bit_identical() {
    let cloth = swinging(16);
    for integrator in [Integrator::Rk4, Integrator::SemiImplicitEuler] {
        let (x, v) = run_gpu(&cloth, SimSettings::default().with_integrator(integrator), 40);
        let mut pinned = 0;
        for (i, p) in cloth.positions.iter().enumerate() {
            if p.w == 0.0 {
                pinned += 1;
                assert_eq!(x[i].to_array().map(f32::to_bits), p.to_array().map(f32::to_bits));
                assert_eq!(v[i], Vec4::ZERO);
            }
        }
        assert_eq!(pinned, 2);
        assert!(max_distance(&x, &cloth.positions) > 0.1, "the free particles must move");
    }
}

#[test]
fn free_fall_matches_closed_form() {
    let v0 = Vec3::new(0.5, 2.0, -0.25);
    let mut cloth = ClothBuilder::new(8, 8).build().unwrap();
    for v in &mut cloth.velocities {
        *v = v0.extend(0.0);
    }
    let frames = 30;
    let (x, v) = run_gpu(&cloth, SimSettings::default(), frames);
    let t = frames as f32 / 60.0;
    let g = Vec3::new(0.0, -9.81, 0.0);
    for (i, p0) in cloth.positions.iter().enumerate() {
        let expected = p0.truncate() + v0 * t + 0.5 * g * t * t;
        let error = (x[i].truncate() - expected).length();
        assert!(error < 1e-4, "particle {i}: {error} m from x0 + v0 t + g t^2/2");
        assert!((v[i].truncate() - (v0 + g * t)).length() < 1e-4);
    }
}

#[test]
fn energy_never_rises_with_damping_and_no_driving_force() {
    let cloth =
        ClothBuilder::new(16, 16).spring_damping(0.005).velocity_damping(0.0005).pin_top_corners().build().unwrap();
    let ctx = context();
    let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    let initial = energy(&cloth, &cloth.positions, &cloth.velocities);
    let mut previous = initial;
    for frame in 0..120 {
        sim.step().unwrap();
        let e = energy(&cloth, &sim.positions(CLOTH).unwrap(), &sim.velocities(CLOTH).unwrap());
        // f32 positions carry ~1e-7 relative rounding into the potential energy.
        let slack = 1e-6 * initial.abs().max(1e-3);
        assert!(e <= previous + slack, "frame {frame}: energy rose from {previous} to {e} J");
        previous = e;
    }
    assert!(previous < initial - 0.05, "energy should fall as the cloth swings down: {initial} -> {previous}");
    assert_validation_clean(&ctx);
}

#[test]
fn normals_are_unit_and_equal_the_cpu() {
    let cloth = swinging(24);
    let ctx = context();
    let mut gpu = Solver::new(&ctx, &Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    let mut cpu = CpuSolver::new(&Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    for _ in 0..20 {
        gpu.step().unwrap();
        cpu.step().unwrap();
    }
    let (gn, cn) = (gpu.normals(CLOTH).unwrap(), cpu.normals(CLOTH).unwrap());
    for (i, n) in gn.iter().enumerate() {
        assert!((n.truncate().length() - 1.0).abs() < 1e-5, "normal {i} has length {}", n.length());
    }
    let difference = max_distance(&gn, &cn);
    assert!(difference < 1e-4, "GPU and CPU normals differ by {difference}");
    // A flat cloth in its local XZ plane faces +Y.
    let flat = ClothBuilder::new(4, 4).gravity(Vec3::ZERO).build().unwrap();
    let mut sim = Solver::new(&ctx, &Model::single(&flat, &[], SimSettings::default()).unwrap()).unwrap();
    sim.step().unwrap();
    for n in sim.normals(CLOTH).unwrap() {
        assert!((n.truncate() - Vec3::Y).length() < 1e-6, "flat normal {n}");
    }
    assert_validation_clean(&ctx);
}

/// A sweep cloth: `n x n`, stiffness `k` (shear k/4, bend k/20), no spring damping. Slack:
/// pinned at two corners in a side wind. Taut: stretched to 1.15x its rest size and pinned
/// along its border, so every spring starts under tension (stiffer across its axis).
fn sweep_cloth(n: u32, k: f32, taut: bool) -> Cloth {
    let builder = ClothBuilder::new(n, n)
        .stiffness(k, k / 4.0, k / 20.0)
        .spring_damping(0.0)
        .external_force(Vec3::new(0.2, 0.0, 0.0));
    if !taut {
        return builder.pin_top_corners().build().unwrap();
    }
    let mut cloth = builder.build().unwrap();
    let centre = cloth.positions.iter().map(|p| p.truncate()).sum::<Vec3>() / cloth.positions.len() as f32;
    for (i, p) in cloth.positions.iter_mut().enumerate() {
        let (row, col) = (i as u32 / n, i as u32 % n);
        let stretched = centre + (p.truncate() - centre) * Vec3::new(1.15, 1.0, 1.15);
        let border = row == 0 || col == 0 || row == n - 1 || col == n - 1;
        *p = stretched.extend(if border { 0.0 } else { 1.0 });
    }
    cloth
}

/// Stiffness x substep sweep over cloth sizes and tensions: every run at or under the
/// stability bound (Lanczos at the starting state, RK4's region) stays stable for 60 frames,
/// and every run 1.5x or more over it is reported as `Error::Unstable` (never NaN output): the
/// bound is within 1.5x of where blow-up starts.
#[test]
fn stability_bound_separates_stable_from_unstable_runs() {
    let ctx = context();
    for (n, k, taut) in [(8, 20.0, false), (8, 2000.0, true), (24, 20.0, true), (24, 2000.0, false), (16, 200.0, true)]
    {
        let cloth = sweep_cloth(n, k, taut);
        let bound = SimSettings::default().with_safety(1.0).stability(&cloth).unwrap();
        assert!(matches!(bound.source, drape::stability::BoundSource::Lanczos { .. }), "{:?}", bound.source);
        for ratio in [0.5f32, 1.0, 1.5, 3.0] {
            // Substeps per frame that give this ratio of substep to bound (rounded up, so at
            // most the ratio).
            let substeps = ((bound.substeps as f32) * bound.ratio / ratio).ceil().max(1.0) as u32;
            let settings = SimSettings::default().with_substeps(Some(substeps)).with_timestamps(false);
            let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
            let actual = sim.stability(CLOTH).unwrap().ratio;
            let outcome = (0..60).try_for_each(|_| sim.step().map(|_| ()));
            let case = format!("{n}^2, k {k}, taut {taut}: substeps {substeps}, h/bound {actual:.3}");
            println!("{case}: {}", if outcome.is_ok() { "stable" } else { "unstable" });
            if actual <= 1.0 {
                outcome.unwrap_or_else(|e| panic!("{case}: {e}"));
                let x = sim.positions(CLOTH).unwrap();
                assert!(x.iter().all(|p| p.is_finite()), "{case}");
            } else if actual >= 1.5 {
                match outcome {
                    Err(Error::Unstable { .. }) => {}
                    other => panic!("{case}: expected a blow-up error, got {other:?}"),
                }
            }
        }
    }
    assert_validation_clean(&ctx);
}

/// The Lanczos estimate (f32 force function, finite differences) agrees with a dense f64
/// eigen-solve of the exact spring Hessians at the same state within 0.5% (measured: omega
/// 0.03-0.16%, gamma 0.08-0.42%) on slack, taut, damped and mesh cloths; Gershgorin's bound
/// is looser.
#[test]
fn lanczos_bound_matches_a_dense_eigen_solve() {
    let mesh = ClothBuilder::from_mesh(drape::ClothMesh::tube(0.2, 0.4, 10, 6)).build().unwrap();
    let damped = ClothBuilder::new(9, 7).spring_damping(0.3).velocity_damping(0.02).pin_top_corners().build().unwrap();
    for (name, cloth) in [
        ("slack", sweep_cloth(8, 200.0, false)),
        ("taut", sweep_cloth(8, 200.0, true)),
        ("damped", damped),
        ("mesh", mesh),
    ] {
        let s = SimSettings::default().stability(&cloth).unwrap();
        let (omega, gamma) = ReferenceCloth::new(&cloth).stiffest_modes();
        println!(
            "{name}: omega_max {} vs dense {omega:.1} (Gershgorin {}), gamma_max {} vs {gamma:.2}",
            s.omega_max, s.omega_gershgorin, s.gamma_max
        );
        let within = |estimate: f32, truth: f64| (estimate as f64 - truth).abs() <= 5e-3 * truth;
        assert!(within(s.omega_max, omega), "{name}: omega_max {} vs {omega}", s.omega_max);
        assert!(within(s.gamma_max, gamma), "{name}: gamma_max {} vs {gamma}", s.gamma_max);
        assert!(s.omega_gershgorin as f64 >= omega, "{name}: Gershgorin {} below {omega}", s.omega_gershgorin);
    }
}

#[test]
fn blow_up_is_an_error_that_says_what_to_change() {
    let cloth = ClothBuilder::new(8, 8).stiffness(5000.0, 1000.0, 100.0).pin_top_corners().build().unwrap();
    let settings = SimSettings::default().with_substeps(Some(1));
    let ctx = context();
    let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
    assert!(sim.stability(CLOTH).unwrap().warning().is_some(), "a substep over the bound must warn");
    let error = (0..30).find_map(|_| sim.step().err()).expect("must blow up");
    let message = error.to_string();
    assert!(matches!(error, Error::Unstable { .. }), "{message}");
    assert!(message.contains("substeps"), "{message}");
    // Automatic substeps for the same cloth are stable and do not warn.
    let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], SimSettings::default()).unwrap()).unwrap();
    assert!(sim.stability(CLOTH).unwrap().warning().is_none());
    for _ in 0..30 {
        sim.step().unwrap();
    }
}

/// The blow-up error names the quantity that drove it and a value that would be stable:
/// stiffness or damping when the substep is over the bound (whichever sets it), the external
/// force when the substep is within it.
#[test]
fn blow_up_names_the_quantity_that_drove_it() {
    let ctx = context();
    // Grid cloths pinned at their top corners (a mesh's pins its own vertices).
    let blow_up = |builder: ClothBuilder, substeps: Option<u32>| {
        let cloth = builder.build().unwrap();
        let settings = SimSettings::default().with_substeps(substeps).with_timestamps(false);
        let mut sim = Solver::new(&ctx, &Model::single(&cloth, &[], settings).unwrap()).unwrap();
        let error = (0..60).find_map(|_| sim.step().err()).expect("must blow up");
        assert!(matches!(error, Error::Unstable { .. }), "{error}");
        error.to_string()
    };
    let stiff = blow_up(ClothBuilder::new(8, 8).pin_top_corners().stiffness(5000.0, 1000.0, 100.0), Some(1));
    assert!(stiff.contains("set by the stiffness") && stiff.contains("stiffness of at most"), "{stiff}");
    let damped = blow_up(ClothBuilder::new(8, 8).pin_top_corners().spring_damping(50.0), Some(2));
    assert!(damped.contains("set by the damping") && damped.contains("spring damping"), "{damped}");
    let pushed = blow_up(ClothBuilder::new(8, 8).pin_top_corners().external_force(Vec3::new(1e5, 0.0, 0.0)), None);
    assert!(pushed.contains("within the stability bound") && pushed.contains("external force"), "{pushed}");
    // 1000 N on the pinned 8 x 8 cloth (16 N a particle): under the 206 N a particle's four
    // springs hold at 10x (40 N/m, 1/7 m), but the two pins' springs carry all of it (the swing
    // scene's blow-up at rest under 1e4 N of wind was put down to motion).
    let pinned = blow_up(ClothBuilder::new(8, 8).pin_top_corners().external_force(Vec3::new(1000.0, 0.0, 0.0)), None);
    assert!(pinned.contains("so the load drove it") && pinned.contains("pins"), "{pinned}");
    assert!(pinned.contains("the 2.057e2 N"), "4 springs x 40 N/m x 1/7 m x 9: {pinned}");
    // The same cloth from its triangle mesh: its parameters carry no grid steps, and its springs
    // were taken to hold 1.7e-35 N (every garment's blow-up blamed on its load). An interior
    // vertex holds by four sides (1/7 m) and two diagonals (sqrt 2 / 7 m, half the stiffness,
    // `Spring::stiffness_scale`): 40 N/m x (4 + sqrt 2) / 7 m x 9 = 278.4 N.
    let grid = ClothBuilder::new(8, 8).build().unwrap();
    let vertices = grid.positions.iter().map(|p| p.truncate()).collect();
    let mesh = drape::ClothMesh::from_parts(vertices, grid.triangles.clone()).unwrap();
    let meshed = ClothBuilder::from_mesh(mesh).pin_vertex(0).pin_vertex(7);
    let meshed = blow_up(meshed.external_force(Vec3::new(1000.0, 0.0, 0.0)), None);
    assert!(meshed.contains("so the load drove it") && meshed.contains("pins"), "{meshed}");
    assert!(meshed.contains("the 2.784e2 N") || meshed.contains("the 2.785e2 N"), "{meshed}");
    // Its weight under 1e5 m/s^2 of gravity: the gravity that would be stable is what its
    // springs hold for its mass (it read 1.7e-31 m/s^2).
    let grid = ClothBuilder::new(8, 8).build().unwrap();
    let vertices = grid.positions.iter().map(|p| p.truncate()).collect();
    let mesh = drape::ClothMesh::from_parts(vertices, grid.triangles.clone()).unwrap();
    let crushed = ClothBuilder::from_mesh(mesh).pin_vertex(0).pin_vertex(7);
    let crushed = blow_up(crushed.gravity(Vec3::new(0.0, -1e5, 0.0)), None);
    let stable: f32 = crushed
        .split_once("gravity below ")
        .and_then(|(_, rest)| rest.split_once(" m/s^2"))
        .and_then(|(value, _)| value.parse().ok())
        .unwrap_or_else(|| panic!("no stable gravity named: {crushed}"));
    assert!((10.0..1e5).contains(&stable), "{stable} m/s^2: {crushed}");
    // Automatic substeps ran: the message offers a fixed count, not automatic substeps again.
    assert!(pushed.contains("or fix at least") && !pushed.contains("or automatic substeps"), "{pushed}");
    assert!(stiff.contains("(or automatic substeps)"), "fixed substeps under the bound: {stiff}");
    assert_validation_clean(&ctx);
}

#[test]
fn invalid_parameters_are_errors_not_panics() {
    let cases: Vec<(&str, drape::Result<Cloth>)> = vec![
        ("1 row", ClothBuilder::new(1, 8).build()),
        ("negative mass", ClothBuilder::new(4, 4).mass(-1.0).build()),
        ("NaN stiffness", ClothBuilder::new(4, 4).stiffness(f32::NAN, 1.0, 1.0).build()),
        ("pin outside", ClothBuilder::new(4, 4).pin(4, 0).build()),
        ("zero size", ClothBuilder::new(4, 4).size(0.0).build()),
        ("singular transform", ClothBuilder::new(4, 4).transform(glam::Mat4::ZERO).build()),
    ];
    for (what, result) in cases {
        match result {
            Err(Error::InvalidParameter { .. }) => {}
            other => panic!("{what}: expected InvalidParameter, got {other:?}"),
        }
    }
    let cloth = ClothBuilder::new(4, 4).build().unwrap();
    for settings in [
        SimSettings::default().with_frame_dt(0.0),
        SimSettings::default().with_substeps(Some(0)),
        SimSettings::default().with_safety(1.5),
    ] {
        assert!(matches!(Model::single(&cloth, &[], settings), Err(Error::InvalidParameter { .. })));
    }
    // Absurd stiffness would need millions of substeps: refused up front.
    let stiff = ClothBuilder::new(4, 4).stiffness(1e12, 1e12, 1e12).build().unwrap();
    assert!(matches!(Model::single(&stiff, &[], SimSettings::default()), Err(Error::InvalidParameter { .. })));
}
