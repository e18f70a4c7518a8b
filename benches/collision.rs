//! The paper's Table VII on this machine's Vulkan driver: a 64x64 cloth draped over the
//! Stanford Bunny and Dragon (read from ../shared/models; skipped when absent) with n = 1, 3, 5,
//! 16, 32, 64 voxels per axis. Per row: ms per frame (median wall, no timestamps), the GPU split
//! per kernel (timestamps), the LBVH build, and the accuracy at t = 2 s against the true mesh.
//! Then the same frame with a brute-force collision pass, to show what the BVH buys.

use drape::mesh::Mesh;
use drape::metrics::{TriangleBvh, accuracy};
use drape::scenes::{DrapeScene, SETTLE_FRAMES, shared_model};
use drape::timing::{TimingReport, median};
use drape::{ClothId, Collider, Context, Model, SimSettings, Solver, Validation};
use std::time::Instant;

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

const VOXELS: [u32; 6] = [1, 3, 5, 16, 32, 64];

/// The timing table's passes of the "integr." column: the RK4 stages that run alone.
const INTEGRATE_LABELS: [&str; 4] = ["rk4: k1", "rk4: k2", "rk4: k3", "rk4: k4 + update"];
/// ... and of the "contact" column: the broad phase and whichever narrow-phase passes ran (with
/// candidate lists, the default, the narrow phase runs inside RK4's last stage, which this
/// column then includes).
const CONTACT_LABELS: [&str; 5] = [
    "contact: broad phase",
    "rk4: k4 + update + contact (lists)",
    "contact: detect+respond (lists)",
    "contact: detect (BVH)",
    "contact: respond",
];

struct Row {
    spheres: usize,
    wall_ms: f64,
    /// Fastest frame of the second second (cloth resting on the mesh).
    min_ms: f64,
    report: TimingReport,
    lbvh_ms: f64,
    accuracy: drape::metrics::Accuracy,
}

fn run(ctx: &std::sync::Arc<Context>, scene: &DrapeScene, collider: &Collider, bvh: &TriangleBvh) -> Row {
    let cloth = scene.cloth.build().expect("cloth");
    // Untimed run: wall time per frame over the whole 2 s settle, and the final state.
    let untimed = SimSettings::default().with_timestamps(false);
    let mut sim =
        Solver::new(ctx, &Model::single(&cloth, std::slice::from_ref(collider), untimed).unwrap()).expect("simulation");
    let mut walls = Vec::new();
    for _ in 0..SETTLE_FRAMES {
        let start = Instant::now();
        sim.step().expect("stable");
        walls.push(start.elapsed().as_secs_f64() * 1e3);
    }
    let x = sim.positions(CLOTH).expect("positions");
    let p = *sim.params(CLOTH).unwrap();
    let accuracy = accuracy(bvh, collider.spheres(), collider.thickness, p.rows, p.cols, p.rest.x, p.rest.y, &x);
    // Timed run (timestamps) for the per-kernel split: 30 frames into the fall.
    let mut timed =
        Solver::new(ctx, &Model::single(&cloth, std::slice::from_ref(collider), SimSettings::default()).unwrap())
            .expect("simulation");
    let lbvh_ms = timed.lbvh_timings().map(|t| t.total_micros() / 1e3).unwrap_or(0.0);
    let mut report = TimingReport::default();
    for frame in 0..60 {
        let start = Instant::now();
        let t = timed.step().expect("stable");
        if frame >= 30 {
            report.add(&t, start.elapsed());
        }
    }
    let min_ms = walls[walls.len() / 2..].iter().copied().fold(f64::INFINITY, f64::min);
    Row { spheres: collider.spheres().len(), wall_ms: median(&walls), min_ms, report, lbvh_ms, accuracy }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    println!("device: {} ({})", ctx.info().name, ctx.info().driver);
    println!("Table VII reproduction: 64x64 cloth, frame = 1/60 s, auto substeps (RK4), thickness 5 mm, 2 s settle.");
    println!("Paper (GTX 1650): Bunny 8 / 12 / 12 ms, Dragon 13 / 13 / 15 ms for n = 1 / 3 / 5.");
    for (name, file) in [("bunny", "stanford-bunny.obj"), ("dragon", "stanford-dragon-res2.obj")] {
        let path = shared_model(file);
        let Ok(mesh) = Mesh::load_obj(&path) else {
            println!("\n{name}: {} not found, skipped", path.display());
            continue;
        };
        let scene = DrapeScene::standard(&mesh, 64);
        // Inside is measured against the mesh with its small holes closed (the bunny's base).
        let bvh = TriangleBvh::new(&scene.mesh.close_small_holes().0);
        println!("\n{name} ({} triangles)", scene.mesh.triangles.len());
        println!(
            "{:>3} {:>7} {:>9} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} | {:>8} {:>8} {:>8} {:>8} {:>8} {:>7}",
            "n",
            "spheres",
            "ms/frame",
            "min ms",
            "GPU ms",
            "integr.",
            "contact",
            "cull",
            "LBVH ms",
            "inside%",
            "maxpen",
            "p99pen",
            "gapmean",
            "gapmax",
            "stretch"
        );
        for n in VOXELS {
            let collider = scene.collider(n).expect("collider");
            let row = run(&ctx, &scene, &collider, &bvh);
            let rows = row.report.rows();
            let sum = |labels: &[&str]| rows.iter().filter(|r| labels.contains(&r.0)).map(|r| r.2).sum::<f64>() / 1e3;
            let a = &row.accuracy;
            println!(
                "{n:>3} {:>7} {:>9.2} {:>8.2} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>8.3} | {:>8.3} {:>7.1}mm {:>7.1}mm {:>7.1}mm {:>7.1}mm {:>7.3}",
                row.spheres,
                row.wall_ms,
                row.min_ms,
                row.report.median_gpu_micros() / 1e3,
                sum(&INTEGRATE_LABELS),
                sum(&CONTACT_LABELS),
                sum(&["contact: cull"]),
                row.lbvh_ms,
                100.0 * a.inside_fraction,
                a.max_penetration * 1e3,
                a.p99_penetration * 1e3,
                a.gap_mean * 1e3,
                a.gap_max * 1e3,
                a.max_stretch
            );
        }
        // What the BVH buys: the same frames with every particle testing every sphere.
        println!("  brute-force collision (same results, every sphere tested), median ms per frame:");
        let cloth = scene.cloth.build().expect("cloth");
        for n in [5, 16, 64] {
            let mut collider = scene.collider(n).expect("collider");
            let timed_bvh = frame_ms(&ctx, &cloth, &collider, 20, 10);
            collider.search = drape::ContactSearch::BruteForce;
            // Brute force costs the same in every frame (it tests every sphere regardless).
            let timed_brute = frame_ms(&ctx, &cloth, &collider, 0, 3);
            println!(
                "  n = {n:>2} ({:>5} spheres): BVH {timed_bvh:>8.2} ms, brute force {timed_brute:>8.2} ms ({:.1}x)",
                collider.spheres().len(),
                timed_brute / timed_bvh
            );
        }
    }
}

/// Median wall ms of `measured` frames after `warmup` frames, without timestamps.
fn frame_ms(
    ctx: &std::sync::Arc<Context>,
    cloth: &drape::Cloth,
    collider: &Collider,
    warmup: u32,
    measured: u32,
) -> f64 {
    let settings = SimSettings::default().with_timestamps(false);
    let mut sim =
        Solver::new(ctx, &Model::single(cloth, std::slice::from_ref(collider), settings).unwrap()).expect("simulation");
    let mut walls = Vec::new();
    for frame in 0..warmup + measured {
        let start = Instant::now();
        sim.step().expect("stable");
        if frame >= warmup {
            walls.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    median(&walls)
}
