//! Run time against error for the contact modes (issue "Accurate contact", item 8): the standard
//! scene (64 x 64 cloth, 2 s settle) on the bunny and the dragon, with the paper's voxel spheres
//! (n = 1, 3, 5, 16, 32, 64; thickness 5 mm) and with the mesh's triangles (thickness 2 and
//! 5 mm). For each: frame time (median and fastest over the run's 120 frames) against (a) the
//! share of particles inside the mesh, (b) the max penetration, (c) the resting gap's mean.
//! Contact searches candidate lists (broad phase once per frame); spheres n = 5 and triangles
//! 5 mm also run with an LBVH walk every substep ("walk"), the search the lists replaced.
//!
//! Every configuration's solver is created first, then frame k of every configuration runs
//! back to back (round robin), so the machine's load drifts over all of them alike and the
//! frame-time ratios within one run mean something on a noisy machine.
//!
//! Writes `target/pareto/pareto.csv` and `target/pareto/pareto.png` (or `$DRAPE_PARETO_DIR`).
//! The plot's text needs a TrueType font: `$DRAPE_FONT`, else DejaVu Sans or Liberation Sans
//! from the usual system paths; without one the plot is drawn without text (and says so).

#[path = "../common/font.rs"]
mod font;
mod plot;

use drape::metrics::{Accuracy, TriangleBvh, accuracy, accuracy_on_triangles};
use drape::scenes::{DrapeScene, SETTLE_FRAMES, shared_model};
use drape::timing::median;
use drape::{ClothId, Collider, ContactSearch, Context, Mesh, Model, SimSettings, Solver, Validation};
use std::path::PathBuf;
use std::time::Instant;

const CLOTH: ClothId = ClothId::new(0);
const SPHERE_GRIDS: [u32; 6] = [1, 3, 5, 16, 32, 64];
const SPHERE_THICKNESS: f32 = 0.005;
const TRIANGLE_THICKNESSES: [f32; 2] = [0.002, 0.005];

/// One configuration's result.
pub struct Point {
    pub mesh: &'static str,
    /// "spheres" or "triangles".
    pub contact: &'static str,
    /// "lists" (candidate lists) or "walk" (LBVH walk every substep).
    pub search: &'static str,
    /// Voxels per axis (spheres), 0 for triangles.
    pub voxels: u32,
    pub thickness: f32,
    pub leaves: usize,
    pub median_ms: f64,
    pub fastest_ms: f64,
    pub accuracy: Accuracy,
}

impl Point {
    pub fn label(&self) -> String {
        let what = match self.contact {
            "spheres" => format!("spheres n={}", self.voxels),
            _ => format!("triangles {} mm", self.thickness * 1e3),
        };
        match self.search {
            "walk" => format!("{what}, walk"),
            _ => what,
        }
    }
}

/// A configuration being run.
struct Run {
    contact: &'static str,
    search: &'static str,
    voxels: u32,
    collider: Collider,
    solver: Solver,
    walls: Vec<f64>,
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    println!("device: {} ({})", ctx.info().name, ctx.info().driver);
    println!("standard scene: 64x64 cloth, 2 s settle ({SETTLE_FRAMES} frames of 1/60 s), auto substeps, RK4");
    let mut points = Vec::new();
    for (name, file) in [("bunny", "stanford-bunny.obj"), ("dragon", "stanford-dragon-res2.obj")] {
        let path = shared_model(file);
        let mesh = Mesh::load_obj(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (the Pareto bench needs ../shared/models)", path.display()));
        let mut scene = DrapeScene::standard(&mesh, 64);
        // The solid the mesh depicts: the bunny's five base holes closed (both contact modes and
        // the inside measure use it).
        scene.mesh = scene.mesh.close_small_holes().0;
        let bvh = TriangleBvh::new(&scene.mesh);
        assert!(bvh.is_closed(), "{name}: inside must be defined");
        points.extend(measure(&ctx, name, &scene, &bvh));
    }
    print_table(&points);
    let dir = std::env::var_os("DRAPE_PARETO_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/pareto"));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let csv = dir.join("pareto.csv");
    std::fs::write(&csv, to_csv(&points)).unwrap_or_else(|e| panic!("{}: {e}", csv.display()));
    println!("\nwrote {}", csv.display());
    let png = dir.join("pareto.png");
    match plot::draw(&png, &points) {
        Ok(note) => println!("wrote {}{note}", png.display()),
        Err(e) => panic!("{}: {e}", png.display()),
    }
}

/// Every configuration of one mesh, frames interleaved.
fn measure(ctx: &std::sync::Arc<Context>, name: &'static str, scene: &DrapeScene, bvh: &TriangleBvh) -> Vec<Point> {
    let cloth = scene.cloth.build().expect("cloth");
    let settings = SimSettings::default().with_timestamps(false);
    let mut runs = Vec::new();
    let mut add = |contact: &'static str, voxels: u32, collider: Collider| {
        let searches: &[_] = match (contact, voxels, collider.thickness) {
            ("spheres", 5, _) | ("triangles", _, 0.005) => {
                &[("lists", ContactSearch::CandidateLists), ("walk", ContactSearch::TraverseEverySubstep)]
            }
            _ => &[("lists", ContactSearch::CandidateLists)],
        };
        for &(search, how) in searches {
            let collider = collider.clone().with_search(how);
            let model = Model::single(&cloth, std::slice::from_ref(&collider), settings).expect("model");
            let solver = Solver::new(ctx, &model).expect("solver");
            runs.push(Run { contact, search, voxels, collider, solver, walls: Vec::new() });
        }
    };
    for n in SPHERE_GRIDS {
        let start = Instant::now();
        let mut scene_n = DrapeScene { mesh: scene.mesh.clone(), cloth: scene.cloth.clone(), ..*scene };
        scene_n.thickness = SPHERE_THICKNESS;
        let collider = scene_n.collider(n).expect("spheres");
        eprintln!(
            "{name}: n = {n}: {} spheres in {:.0} ms",
            collider.leaf_count(),
            start.elapsed().as_secs_f64() * 1e3
        );
        add("spheres", n, collider);
    }
    for thickness in TRIANGLE_THICKNESSES {
        let mut scene_t = DrapeScene { mesh: scene.mesh.clone(), cloth: scene.cloth.clone(), ..*scene };
        scene_t.thickness = thickness;
        add("triangles", 0, scene_t.triangle_collider());
    }
    for frame in 0..SETTLE_FRAMES {
        for run in runs.iter_mut() {
            let start = Instant::now();
            run.solver.step().unwrap_or_else(|e| panic!("{name} {} n={}, frame {frame}: {e}", run.contact, run.voxels));
            run.walls.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    runs.into_iter()
        .map(|run| {
            let x = run.solver.positions(CLOTH).expect("positions");
            let p = *run.solver.params(CLOTH).expect("params");
            let c = &run.collider;
            let shape = (p.rows, p.cols, p.rest.x, p.rest.y);
            let accuracy = match run.contact {
                "spheres" => accuracy(bvh, c.spheres(), c.thickness, p.rows, p.cols, p.rest.x, p.rest.y, &x),
                _ => accuracy_on_triangles(bvh, c.thickness, shape, &x),
            };
            Point {
                mesh: name,
                contact: run.contact,
                search: run.search,
                voxels: run.voxels,
                thickness: c.thickness,
                leaves: c.leaf_count(),
                median_ms: median(&run.walls),
                fastest_ms: run.walls.iter().copied().fold(f64::INFINITY, f64::min),
                accuracy,
            }
        })
        .collect()
}

fn print_table(points: &[Point]) {
    println!(
        "\n{:<7} {:<24} {:>7} {:>10} {:>10} {:>8} {:>10} {:>10} {:>8}",
        "mesh", "contact", "leaves", "median ms", "fastest ms", "inside%", "maxpen mm", "gap mm", "resting"
    );
    for p in points {
        let a = &p.accuracy;
        println!(
            "{:<7} {:<24} {:>7} {:>10.2} {:>10.2} {:>8.3} {:>10.2} {:>10.2} {:>8}",
            p.mesh,
            p.label(),
            p.leaves,
            p.median_ms,
            p.fastest_ms,
            100.0 * a.inside_fraction,
            a.max_penetration * 1e3,
            a.gap_mean * 1e3,
            a.resting
        );
    }
    println!("\nframe time, triangles (5 mm, lists) / spheres n = 5, same run:");
    for mesh in ["bunny", "dragon"] {
        let find = |contact: &str, search: &str, voxels: u32, thickness: f32| {
            points.iter().find(|p| {
                p.mesh == mesh
                    && p.contact == contact
                    && p.search == search
                    && p.voxels == voxels
                    && p.thickness == thickness
            })
        };
        let triangles = find("triangles", "lists", 0, 0.005);
        for sphere_search in ["lists", "walk"] {
            if let (Some(t), Some(s)) = (triangles, find("spheres", sphere_search, 5, SPHERE_THICKNESS)) {
                println!(
                    "  {mesh:<7} vs spheres ({sphere_search:<5}): median {:.2} / {:.2} ms = {:.2}x, fastest {:.2} / {:.2} ms = {:.2}x",
                    t.median_ms,
                    s.median_ms,
                    t.median_ms / s.median_ms,
                    t.fastest_ms,
                    s.fastest_ms,
                    t.fastest_ms / s.fastest_ms
                );
            }
        }
    }
}

fn to_csv(points: &[Point]) -> String {
    let mut out = String::from(
        "mesh,contact,search,voxels,thickness_mm,leaves,frame_ms_median,frame_ms_fastest,inside_percent,max_penetration_mm,\
         p99_penetration_mm,gap_mean_mm,gap_max_mm,resting,max_stretch\n",
    );
    for p in points {
        let a = &p.accuracy;
        out += &format!(
            "{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{:.4}\n",
            p.mesh,
            p.contact,
            p.search,
            p.voxels,
            p.thickness * 1e3,
            p.leaves,
            p.median_ms,
            p.fastest_ms,
            100.0 * a.inside_fraction,
            a.max_penetration * 1e3,
            a.p99_penetration * 1e3,
            a.gap_mean * 1e3,
            a.gap_max * 1e3,
            a.resting,
            a.max_stretch
        );
    }
    out
}
