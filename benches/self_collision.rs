//! Issue 8's cost of self-collision, measured in one run: the standard scene (the icosphere, no
//! file needed) at 32^2, 64^2 and 128^2 (and 256^2 on a GPU) and the pile, each built twice,
//! with self-collision on and off, the two solvers stepped in turn frame by frame so the
//! machine's noise falls on both alike. Per scene: the medians and fastest of the GPU span per
//! frame (timestamps: the first pass's start to the last one's end) and of the wall time, the
//! ratio on / off, the substeps; the whole run's totals (the ratio of the mean frames); the
//! median frame of each third of the run; then the self-collision solver's passes at 64^2, over
//! the whole run and in each third of it (with the triangles that walked the tree). On a CPU
//! driver it also gives the process's CPU time per frame (every thread's, the driver's workers
//! included: the frame's work, which another tenant's load on the machine moves less than the
//! wall time, the same code's wall ratio having ranged 2.27x-2.70x at 64^2 on this VM).
//!
//! `cargo bench --bench self_collision` runs every scene; `-- 64 pile` only those named; add
//! `no-timestamps` to run the solvers without timestamp queries (wall times only: on lavapipe a
//! timestamp pair costs each dispatch tens of µs, and a frame with self-collision has twice the
//! dispatches). `DRAPE_BENCH_DUMP=FILE` writes the 64^2 solver's passes frame by frame (frame,
//! pass, GPU µs, the frame's walking triangle-passes; tab-separated), to find where a stretch of
//! the run spends its time.

use drape::cloth::ClothBuilder;
use drape::scenes::{DrapeScene, SETTLE_FRAMES, default_mesh, pile};
use drape::timing::{TimingReport, median};
use drape::{ClothId, Context, Model, SimSettings, Solver, Validation};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The only cloth of the models here.
const CLOTH: ClothId = ClothId::new(0);

/// A scene of the table: its name, its cloth and collider mesh, and how many frames it runs.
struct Case {
    name: String,
    scene: DrapeScene,
    frames: u32,
}

/// The standard scenes at `grids` and the pile at 64 particles along (its default), each for
/// its whole settle where a frame is cheap, the first frames (the fall) where it is not.
fn cases(grids: &[u32]) -> Vec<Case> {
    let mut cases: Vec<Case> = grids
        .iter()
        .map(|&grid| Case {
            name: format!("icosphere {grid}^2"),
            scene: DrapeScene::standard(&default_mesh(), grid),
            frames: if grid <= 64 { SETTLE_FRAMES } else { 30 },
        })
        .collect();
    cases.push(Case { name: "pile 64 x 16".into(), scene: pile(64), frames: 200 });
    cases
}

fn solver(ctx: &Arc<Context>, scene: &DrapeScene, self_collision: bool, timestamps: bool) -> Solver {
    let cloth: ClothBuilder = scene.cloth.clone().self_collision(self_collision.then_some(scene.thickness));
    let cloth = cloth.build().expect("cloth");
    let mut settings = SimSettings::default();
    settings.timestamps = timestamps;
    let model = Model::single(&cloth, &[scene.triangle_collider()], settings).expect("model");
    Solver::new(ctx, &model).expect("simulation")
}

/// The CPU time this process has used, all its threads together (`CLOCK_PROCESS_CPUTIME_ID`).
fn process_cpu_time() -> Duration {
    let mut now = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes the timespec it is given and reads nothing else.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut now) };
    assert_eq!(status, 0, "clock_gettime(CLOCK_PROCESS_CPUTIME_ID)");
    Duration::new(now.tv_sec as u64, now.tv_nsec as u32)
}

/// The frames of third `k` (0, 1, 2) of a run of `n`.
fn third_of(n: usize, k: usize) -> std::ops::Range<usize> {
    k * n / 3..(k + 1) * n / 3
}

/// What one solver's frames measured.
struct Run {
    report: TimingReport,
    substeps: Vec<f64>,
    /// The process's CPU time per frame (ms).
    cpu_ms: Vec<f64>,
    /// Per frame: each pass label's GPU µs (with timestamps), and the self-collision triangles
    /// that walked the tree over the frame's passes (`FrameReport::self_walks`).
    passes: Vec<Vec<(&'static str, f64)>>,
    walks: Vec<f64>,
}

impl Run {
    fn new() -> Self {
        Run {
            report: TimingReport::default(),
            substeps: Vec::new(),
            cpu_ms: Vec::new(),
            passes: Vec::new(),
            walks: Vec::new(),
        }
    }

    fn step(&mut self, sim: &mut Solver) {
        let (start, cpu_start) = (Instant::now(), process_cpu_time());
        let frame = sim.step_report().expect("stable");
        let (wall, cpu) = (start.elapsed(), process_cpu_time() - cpu_start);
        self.report.add(&frame.timings, wall);
        self.cpu_ms.push(cpu.as_secs_f64() * 1e3);
        self.substeps.push(f64::from(sim.stability(CLOTH).expect("the cloth").substeps));
        self.passes.push(frame.timings.by_label().into_iter().map(|(label, _, micros)| (label, micros)).collect());
        self.walks.push(f64::from(frame.self_walks));
    }

    /// Per pass label (in first-seen order): its mean GPU µs per frame in each third of the
    /// run (a frame that did not run it counts 0), then the span's and the walks' medians.
    fn thirds_table(&self) -> String {
        let mut labels: Vec<&'static str> = Vec::new();
        for frame in &self.passes {
            for (label, _) in frame {
                if !labels.contains(label) {
                    labels.push(label);
                }
            }
        }
        let n = self.passes.len();
        let thirds: Vec<std::ops::Range<usize>> = (0..3).map(|k| third_of(n, k)).collect();
        let mut out = format!("{:<52} {:>12} {:>12} {:>12}\n", "pass (mean GPU µs a frame)", "first", "second", "last");
        for label in labels {
            let mean = |range: &std::ops::Range<usize>| {
                let frames = &self.passes[range.clone()];
                let sum: f64 = frames.iter().flat_map(|f| f.iter().filter(|(l, _)| *l == label).map(|(_, m)| m)).sum();
                // (+ 0.0: an empty sum is -0.0.)
                sum / frames.len().max(1) as f64 + 0.0
            };
            let cells: String = thirds.iter().map(|r| format!(" {:>12.1}", mean(r))).collect();
            out += &format!("{label:<52}{cells}\n");
        }
        let spans = self.report.span_micros_per_frame();
        let cells: String =
            thirds.iter().map(|r| format!(" {:>12.1}", median(spans.get(r.clone()).unwrap_or(&[])))).collect();
        out += &format!("{:<52}{cells}\n", "GPU span, median (µs)");
        let cells: String = thirds.iter().map(|r| format!(" {:>12.0}", median(&self.walks[r.clone()]))).collect();
        out += &format!("{:<52}{cells}", "triangle-passes that walked, median a frame");
        out
    }

    /// The median and the least CPU time per frame (ms).
    fn cpu_ms(&self) -> (f64, f64) {
        (median(&self.cpu_ms), self.cpu_ms.iter().copied().fold(f64::INFINITY, f64::min))
    }

    fn median_substeps(&self) -> f64 {
        median(&self.substeps)
    }
}

fn main() {
    // Criterion-style arguments: `--bench` and the like are cargo's; the rest name scenes.
    let words: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    let timestamps = !words.iter().any(|w| w == "no-timestamps");
    let wanted: Vec<String> = words.into_iter().filter(|w| w != "no-timestamps").collect();
    let ctx = Context::new(Validation::Off).expect("a Vulkan driver");
    let info = ctx.info();
    let cpu_driver = info.device_type == ash::vk::PhysicalDeviceType::CPU;
    println!("device: {} ({})", info.name, info.driver);
    // 256^2 at 5 mm is too fine for lists (every triangle walks at every pass): seconds a frame
    // on a CPU driver.
    let grids: &[u32] = if cpu_driver { &[32, 64, 128] } else { &[32, 64, 128, 256] };
    let cases: Vec<Case> = cases(grids)
        .into_iter()
        .filter(|c| wanted.is_empty() || wanted.iter().any(|w| c.name.contains(w.as_str())))
        .collect();
    println!(
        "\nSelf-collision on and off, stepped in turn in one run (GPU span per frame from timestamps, \
         wall from submit to fence; medians over the frames, the fastest in brackets):"
    );
    println!(
        "{:<16} {:>7} {:>10} {:>22} {:>22} {:>12} {:>22} {:>22} {:>12}",
        "scene",
        "frames",
        "substeps",
        "span off (ms)",
        "span on (ms)",
        "span on/off",
        "wall off (ms)",
        "wall on (ms)",
        "wall on/off"
    );
    let mut passes_64 = None;
    let (mut cpu_rows, mut run_rows, mut third_rows) = (Vec::new(), Vec::new(), Vec::new());
    for case in &cases {
        let (mut off, mut on) =
            (solver(&ctx, &case.scene, false, timestamps), solver(&ctx, &case.scene, true, timestamps));
        let (mut runs_off, mut runs_on) = (Run::new(), Run::new());
        let begun = Instant::now();
        for frame in 0..case.frames {
            // Alternate which goes first, so neither always follows the other's work.
            if frame % 2 == 0 {
                runs_off.step(&mut off);
                runs_on.step(&mut on);
            } else {
                runs_on.step(&mut on);
                runs_off.step(&mut off);
            }
            if frame >= 4 && begun.elapsed() > Duration::from_secs(600) {
                println!("({}: stopped after {} frames, 10 minutes)", case.name, frame + 1);
                break;
            }
        }
        let (a, b) = (&runs_off.report, &runs_on.report);
        let spans = |r: &TimingReport| {
            if timestamps {
                format!("{:.3} ({:.3})", r.median_span_micros() / 1e3, r.min_span_micros() / 1e3)
            } else {
                "-".to_string()
            }
        };
        let span_ratio =
            if timestamps { format!("{:.2}x", b.median_span_micros() / a.median_span_micros()) } else { "-".into() };
        println!(
            "{:<16} {:>7} {:>10} {:>22} {:>22} {:>12} {:>22} {:>22} {:>12}",
            case.name,
            a.frames(),
            format!("{} / {}", runs_off.median_substeps(), runs_on.median_substeps()),
            spans(a),
            spans(b),
            span_ratio,
            format!("{:.3} ({:.3})", a.median_wall_ms(), a.min_wall_ms()),
            format!("{:.3} ({:.3})", b.median_wall_ms(), b.min_wall_ms()),
            format!("{:.2}x", b.median_wall_ms() / a.median_wall_ms()),
        );
        let ((cpu_off, least_off), (cpu_on, least_on)) = (runs_off.cpu_ms(), runs_on.cpu_ms());
        cpu_rows.push(format!(
            "{:<16} {:>22} {:>22} {:>12} {:>12}",
            case.name,
            format!("{cpu_off:.3} ({least_off:.3})"),
            format!("{cpu_on:.3} ({least_on:.3})"),
            format!("{:.2}x", cpu_on / cpu_off),
            format!("{:.2}x", least_on / least_off),
        ));
        // Each third of the run's frames apart: where in the run self-collision costs what.
        let third = |r: &Run, k: usize| {
            let walls = r.report.wall_ms_per_frame();
            let n = walls.len();
            median(&walls[third_of(n, k)])
        };
        third_rows.push(format!(
            "{:<16} {}",
            case.name,
            (0..3)
                .map(|k| format!(
                    "{:>26}",
                    format!(
                        "{:.2}x ({:.1} / {:.1})",
                        third(&runs_on, k) / third(&runs_off, k),
                        third(&runs_on, k),
                        third(&runs_off, k)
                    )
                ))
                .collect::<String>()
        ));
        let total = |r: &Run| r.report.wall_ms_per_frame().iter().sum::<f64>();
        let cpu_total = |r: &Run| r.cpu_ms.iter().sum::<f64>();
        run_rows.push(format!(
            "{:<16} {:>14.1} {:>14.1} {:>12} {:>14.1} {:>14.1} {:>12}",
            case.name,
            total(&runs_off),
            total(&runs_on),
            format!("{:.2}x", total(&runs_on) / total(&runs_off)),
            cpu_total(&runs_off),
            cpu_total(&runs_on),
            format!("{:.2}x", cpu_total(&runs_on) / cpu_total(&runs_off)),
        ));
        if timestamps && case.name == "icosphere 64^2" {
            passes_64 = Some((a.table(), b.table(), runs_on.thirds_table()));
            if let Ok(path) = std::env::var("DRAPE_BENCH_DUMP") {
                let mut out = String::new();
                for (f, (frame, walks)) in runs_on.passes.iter().zip(&runs_on.walks).enumerate() {
                    for (label, micros) in frame {
                        out += &format!("{f}\t{label}\t{micros}\t{walks}\n");
                    }
                }
                std::fs::write(&path, out).unwrap_or_else(|e| panic!("writing {path}: {e}"));
            }
        }
    }
    if cpu_driver {
        println!(
            "\nThe process's CPU time per frame (all threads, the driver's included; medians, the least in \
             brackets):"
        );
        println!(
            "{:<16} {:>22} {:>22} {:>12} {:>12}",
            "scene", "cpu off (ms)", "cpu on (ms)", "on/off", "least on/off"
        );
        for row in &cpu_rows {
            println!("{row}");
        }
    }
    // The medians above are of the frames a run mostly has (a cloth hanging calm); its impact
    // and settling frames lie above them and cost several times more: the whole run tells those.
    println!(
        "\nThe whole run: every frame's wall time and the process's CPU time summed (ms), the ratio of the mean frames:"
    );
    println!(
        "{:<16} {:>14} {:>14} {:>12} {:>14} {:>14} {:>12}",
        "scene", "wall off", "wall on", "on/off", "cpu off", "cpu on", "on/off"
    );
    for row in &run_rows {
        println!("{row}");
    }
    println!(
        "\nThe run in thirds of its frames (the first holds a falling cloth's impact, the last a settling one): \
         the median frame's wall time on / off, on and off in ms:"
    );
    println!("{:<16} {:>26}{:>26}{:>26}", "scene", "first third", "second third", "last third");
    for row in &third_rows {
        println!("{row}");
    }
    if let Some((off, on, thirds)) = passes_64 {
        // Both in the same run, so the passes they share (the integrator, the collider's
        // contact) compare without the machine's drift between runs.
        println!("\nThe icosphere 64^2 frame without self-collision, per pass:\n{off}");
        println!("\nThe icosphere 64^2 frame with self-collision, per pass:\n{on}");
        // Where in the run each pass costs: the impact's frames, the settling ones, the calm.
        println!("\nThe icosphere 64^2 with self-collision, per pass in each third of the run:\n{thirds}");
    }
}
