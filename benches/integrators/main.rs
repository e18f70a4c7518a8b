//! Run time against error for the integrators (issue "Speed", item 5): the swinging cloth
//! (`scenes::swinging_cloth`, 32 x 32, pinned at two corners, wind) for 0.5 s, with classical
//! RK4 and semi-implicit Euler (the paper's eq. 3) at several substep counts from each one's
//! automatic count (stability bound x 0.9) upwards. Error: the largest particle distance from the
//! f64 reference (`reference::ReferenceCloth`, RK4 at 1/24000 s steps, itself checked against
//! 1/48000 s) at t = 0.5 s. Frame time: GPU time per frame (timestamp queries), median and fastest
//! over the 30 frames, with every configuration's frame k run back to back so machine load
//! drifts over all alike.
//!
//! Writes `target/integrators/integrators.csv` and `.png` (or `$DRAPE_INTEGRATORS_DIR`).

#[path = "../common/font.rs"]
mod font;
mod plot;

use drape::reference::ReferenceCloth;
use drape::timing::median;
use drape::{ClothId, Context, Integrator, Model, SimSettings, Solver, Validation};
use std::path::PathBuf;

const CLOTH: ClothId = ClothId::new(0);
const GRID: u32 = 32;
const FRAMES: u32 = 30;
/// Substeps per frame as multiples of each integrator's automatic count.
const MULTIPLES: [f32; 6] = [1.0, 1.5, 2.0, 4.0, 8.0, 16.0];

/// One configuration's result.
pub struct Point {
    pub integrator: &'static str,
    pub substeps: u32,
    /// substep / stability bound.
    pub ratio: f32,
    pub median_ms: f64,
    pub fastest_ms: f64,
    pub wall_median_ms: f64,
    /// Largest and RMS distance from the reference at t = 0.5 s (m); None if it blew up.
    pub max_error: Option<f64>,
    pub rms_error: Option<f64>,
}

struct Run {
    point: Point,
    solver: Option<Solver>,
    gpu: Vec<f64>,
    wall: Vec<f64>,
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    println!("device: {} ({})", ctx.info().name, ctx.info().driver);
    let cloth = drape::scenes::swinging_cloth(GRID).build().expect("cloth");
    let duration = FRAMES as f64 / 60.0;
    let started = std::time::Instant::now();
    let mut reference = ReferenceCloth::new(&cloth);
    reference.run(duration, FRAMES * 400);
    let mut finer = ReferenceCloth::new(&cloth);
    finer.run(duration, FRAMES * 800);
    let reference_error = reference.x.iter().zip(&finer.x).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    println!(
        "swinging cloth {GRID}x{GRID}, {duration} s; f64 reference at 1/24000 s differs from 1/48000 s by {reference_error:.2e} m ({:.1} s on the CPU)",
        started.elapsed().as_secs_f64()
    );

    let mut runs = Vec::new();
    for (name, integrator) in [("RK4", Integrator::Rk4), ("semi-implicit Euler", Integrator::SemiImplicitEuler)] {
        let settings = SimSettings::default().with_integrator(integrator);
        let auto = settings.stability(&cloth).expect("bound").substeps;
        for multiple in MULTIPLES {
            let substeps = (auto as f32 * multiple).round() as u32;
            let settings = settings.with_substeps(Some(substeps));
            let solver = Solver::new(&ctx, &Model::single(&cloth, &[], settings).expect("model")).expect("solver");
            let ratio = solver.stability(CLOTH).expect("cloth").ratio;
            let point = Point {
                integrator: name,
                substeps,
                ratio,
                median_ms: f64::NAN,
                fastest_ms: f64::NAN,
                wall_median_ms: f64::NAN,
                max_error: None,
                rms_error: None,
            };
            runs.push(Run { point, solver: Some(solver), gpu: Vec::new(), wall: Vec::new() });
        }
    }
    for _ in 0..FRAMES {
        for run in &mut runs {
            let Some(solver) = &mut run.solver else { continue };
            let start = std::time::Instant::now();
            match solver.step() {
                Ok(timings) => {
                    run.wall.push(start.elapsed().as_secs_f64() * 1e3);
                    run.gpu.push(timings.total_micros() / 1e3);
                }
                Err(e) => {
                    println!("{} {} substeps: {e}", run.point.integrator, run.point.substeps);
                    run.solver = None;
                }
            }
        }
    }
    let mut points = Vec::new();
    for mut run in runs {
        if let Some(solver) = &run.solver {
            let x = solver.positions(CLOTH).expect("positions");
            let errors: Vec<f64> =
                x.iter().zip(&reference.x).map(|(p, q)| (p.truncate().as_dvec3() - *q).length()).collect();
            run.point.max_error = Some(errors.iter().copied().fold(0.0, f64::max));
            run.point.rms_error = Some((errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt());
        }
        if !run.gpu.is_empty() {
            run.point.median_ms = median(&run.gpu);
            run.point.fastest_ms = run.gpu.iter().copied().fold(f64::INFINITY, f64::min);
            run.point.wall_median_ms = median(&run.wall);
        }
        points.push(run.point);
    }
    print_table(&points);
    let dir = std::env::var_os("DRAPE_INTEGRATORS_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/integrators"));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let csv = dir.join("integrators.csv");
    std::fs::write(&csv, to_csv(&points)).unwrap_or_else(|e| panic!("{}: {e}", csv.display()));
    println!("\nwrote {}", csv.display());
    let png = dir.join("integrators.png");
    match plot::draw(&png, &points) {
        Ok(note) => println!("wrote {}{note}", png.display()),
        Err(e) => panic!("{}: {e}", png.display()),
    }
}

fn print_table(points: &[Point]) {
    println!(
        "\n{:<20} {:>8} {:>8} {:>13} {:>14} {:>12} {:>12} {:>12}",
        "integrator", "substeps", "h/bound", "GPU ms (med)", "GPU ms (fast)", "wall ms", "max err m", "rms err m"
    );
    for p in points {
        let error = |e: Option<f64>| e.map_or("blew up".to_string(), |e| format!("{e:.3e}"));
        println!(
            "{:<20} {:>8} {:>8.2} {:>13.2} {:>14.2} {:>12.2} {:>12} {:>12}",
            p.integrator,
            p.substeps,
            p.ratio,
            p.median_ms,
            p.fastest_ms,
            p.wall_median_ms,
            error(p.max_error),
            error(p.rms_error)
        );
    }
}

fn to_csv(points: &[Point]) -> String {
    let mut out = String::from(
        "integrator,substeps,substep_over_bound,gpu_ms_median,gpu_ms_fastest,wall_ms_median,max_error_m,rms_error_m\n",
    );
    for p in points {
        let error = |e: Option<f64>| e.map_or(String::new(), |e| format!("{e:.6e}"));
        out += &format!(
            "{},{},{:.4},{:.4},{:.4},{:.4},{},{}\n",
            p.integrator,
            p.substeps,
            p.ratio,
            p.median_ms,
            p.fastest_ms,
            p.wall_median_ms,
            error(p.max_error),
            error(p.rms_error)
        );
    }
    out
}
