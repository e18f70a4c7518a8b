//! One frame (1/60 s, automatic substeps, RK4) of the default swinging cloth on whatever Vulkan
//! driver is installed (lavapipe in CI). Criterion measures the wall time per frame at
//! 32^2..256^2; then a table gives, at 64^2..512^2, the GPU time per frame and the throughput in
//! particle-substeps per second (how the cost grows with the cloth), the GPU time per kernel at
//! 64^2 (timestamp queries, medians), and a 2x2 cloth run with the 64^2 schedule separates fixed
//! per-dispatch cost from arithmetic.

use criterion::{Criterion, criterion_group, criterion_main};
use drape::timing::TimingReport;
use drape::{ClothId, Context, Model, SimSettings, Solver, Validation};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

const SIZES: [u32; 4] = [32, 64, 128, 256];
/// Sizes of the throughput table (512^2 = 262k particles).
const TABLE_SIZES: [u32; 4] = [64, 128, 256, 512];
/// Frames per table row at most, and the time after which a row stops (after 2 frames).
const FRAMES: u32 = 60;
const BUDGET: Duration = Duration::from_secs(5);

fn simulation(ctx: &Arc<Context>, grid: u32, settings: SimSettings) -> Solver {
    let cloth = drape::scenes::swinging_cloth(grid).build().expect("cloth");
    Solver::new(ctx, &Model::single(&cloth, &[], settings).unwrap()).expect("simulation")
}

/// Median timings over up to `frames` frames (after 3 warm-up frames), stopping early (after at
/// least 2) once `budget` has passed: a few frames of 512^2 on lavapipe, many on a GPU.
fn measure(sim: &mut Solver, frames: u32, budget: Duration) -> TimingReport {
    for _ in 0..3 {
        sim.step().expect("stable");
    }
    let mut report = TimingReport::default();
    let begun = Instant::now();
    for i in 0..frames {
        if i >= 2 && begun.elapsed() > budget {
            break;
        }
        let start = Instant::now();
        let timings = sim.step().expect("stable");
        report.add(&timings, start.elapsed());
    }
    report
}

fn frame(c: &mut Criterion) {
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    println!("device: {} ({})", ctx.info().name, ctx.info().driver);
    let untimed = SimSettings::default().with_timestamps(false);
    let mut group = c.benchmark_group("frame");
    group.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    for grid in SIZES {
        let mut sim = simulation(&ctx, grid, untimed);
        group.bench_function(format!("{grid}x{grid}"), |b| b.iter(|| sim.step().expect("stable")));
    }
    group.finish();

    println!(
        "\nPer size (medians; GPU ms/frame = the passes' sum, span = the frame's first pass start to \
         last pass end, barriers and gaps included; wall = submit to fence, with and without \
         timestamp queries):"
    );
    println!(
        "{:>9} {:>9} {:>11} {:>14} {:>14} {:>14} {:>14} {:>14} {:>12} {:>16} {:>16} {:>18}",
        "cloth",
        "substeps",
        "dispatches",
        "GPU µs/stage",
        "GPU ms/frame",
        "GPU ms (min)",
        "span ms",
        "span ms (min)",
        "wall ms",
        "wall ms (no ts)",
        "min ms (no ts)",
        "M particle-sub/s"
    );
    let mut stage_64 = 0.0;
    let mut substeps_64 = 0;
    for grid in TABLE_SIZES {
        let mut sim = simulation(&ctx, grid, SimSettings::default());
        let timed = measure(&mut sim, FRAMES, BUDGET);
        let mut sim = simulation(&ctx, grid, untimed);
        let plain = measure(&mut sim, FRAMES, BUDGET);
        let rows = timed.rows();
        let dispatches: u32 = rows.iter().map(|r| r.1).sum();
        let stage = timed.median_dispatch_micros("rk4: k2");
        if grid == 64 {
            stage_64 = stage;
            substeps_64 = sim.stability(CLOTH).unwrap().substeps;
            println!("{}", timed.table());
        }
        let substeps = sim.stability(CLOTH).unwrap().substeps;
        // Particle-substeps per second of the frame's GPU span: flat when the cost grows only
        // with the work.
        let throughput = (grid * grid) as f64 * substeps as f64 / (timed.median_span_micros() * 1e-6) / 1e6;
        println!(
            "{:>9} {:>9} {:>11} {:>14.1} {:>14.3} {:>14.3} {:>14.3} {:>14.3} {:>12.3} {:>16.3} {:>16.3} {:>18.1}",
            format!("{grid}^2"),
            substeps,
            dispatches,
            stage,
            timed.median_gpu_micros() / 1e3,
            timed.min_gpu_micros() / 1e3,
            timed.median_span_micros() / 1e3,
            timed.min_span_micros() / 1e3,
            timed.median_wall_ms(),
            plain.median_wall_ms(),
            plain.min_wall_ms(),
            throughput
        );
    }

    // Fixed cost: the 64^2 schedule (same dispatch count) on a 2x2 cloth, which has no work,
    // a dispatch a stage (a GPU would run so small a cloth's frame in one workgroup).
    let tiny = drape::scenes::swinging_cloth(2).build().expect("cloth");
    let fixed = untimed.with_substeps(Some(substeps_64)).with_one_workgroup_substeps(Some(false));
    let mut sim = Solver::new(&ctx, &Model::single(&tiny, &[], fixed).unwrap()).expect("simulation");
    let overhead = measure(&mut sim, FRAMES, BUDGET);
    let mut sim =
        Solver::new(&ctx, &Model::single(&tiny, &[], fixed.with_timestamps(true)).unwrap()).expect("simulation");
    let overhead_timed = measure(&mut sim, FRAMES, BUDGET);
    let dispatches = 4 * substeps_64 + 2;
    println!(
        "\n64^2 frame: {dispatches} dispatches. Fixed cost per dispatch (2x2 cloth, same schedule): \
         {:.1} µs wall without timestamps, {:.1} µs with; GPU-timed per stage {:.1} µs (2x2) vs {:.1} µs (64^2)",
        overhead.median_wall_ms() * 1e3 / dispatches as f64,
        overhead_timed.median_wall_ms() * 1e3 / dispatches as f64,
        overhead_timed.median_dispatch_micros("rk4: k2"),
        stage_64,
    );
    let one_workgroup = fixed.with_one_workgroup_substeps(Some(true));
    let mut sim = Solver::new(&ctx, &Model::single(&tiny, &[], one_workgroup).unwrap()).expect("simulation");
    let fused = measure(&mut sim, FRAMES, BUDGET);
    println!(
        "The same 2x2 frame with its substeps in one workgroup (one dispatch for the {} stages): {:.1} µs wall \
         without timestamps, against {:.1} a dispatch a stage",
        4 * substeps_64,
        fused.median_wall_ms() * 1e3,
        overhead.median_wall_ms() * 1e3,
    );
}

criterion_group!(benches, frame);
criterion_main!(benches);
