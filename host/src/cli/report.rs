//! What a run reports: the setup, the schedule (substeps, sleep), the accuracy and the
//! intersections, as text on stdout and as the JSON of `--json`.

use super::args::Args;
use super::say;
use drape::metrics::Accuracy;
use drape::metrics::intersections::Intersections;
use drape::timing::TimingReport;
use drape::{ClothBuilder, ClothId, SimSettings, Solver, Stability};
use serde_json::{Value, json};

/// The largest count of each kind of intersection over the frames, and the frame it came at.
#[derive(Default)]
pub(crate) struct WorstIntersections {
    pub(crate) frames_with_any: u32,
    /// The first frame with any intersection.
    pub(crate) first_frame: Option<u32>,
    pub(crate) cloth_cloth: (usize, u32),
    pub(crate) cloth_edges: (usize, u32),
    pub(crate) collider_edges: (usize, u32),
}

impl WorstIntersections {
    pub(crate) fn record(&mut self, frame: u32, found: drape::metrics::intersections::Intersections) {
        if found.total() > 0 {
            self.frames_with_any += 1;
            self.first_frame.get_or_insert(frame);
        }
        for (worst, count) in [
            (&mut self.cloth_cloth, found.cloth_cloth),
            (&mut self.cloth_edges, found.cloth_edges_through_collider),
            (&mut self.collider_edges, found.collider_edges_through_cloth),
        ] {
            if count > worst.0 {
                *worst = (count, frame);
            }
        }
    }
}

/// Self-collision's fail-safe over the run: the particles put back where their frame started (or
/// carried with a moving collider), the frames that put any back, the cloths put back whole,
/// and the pairs found of a cloth triangle and a collider's (`drape_kernels::self_failsafe`).
#[derive(Default)]
pub(crate) struct Rollbacks {
    particles: u64,
    frames: u32,
    whole: u32,
    first_frame: Option<u32>,
    collider_pairs: u64,
    carried: u64,
}

impl Rollbacks {
    pub(crate) fn record(&mut self, r: &drape::FrameReport, frame: u32) {
        self.particles += u64::from(r.self_rollbacks);
        self.whole += r.self_rollbacks_whole;
        self.collider_pairs += u64::from(r.self_rollback_collider_pairs);
        self.carried += u64::from(r.self_rollbacks_carried);
        if r.self_rollbacks > 0 {
            self.frames += 1;
            self.first_frame.get_or_insert(frame);
        }
    }

    pub(crate) fn line(&self, frames: u32, on: bool) -> String {
        if !on {
            return "self-collision fail-safe: off".into();
        }
        let first = self.first_frame.map_or(String::new(), |f| format!(", the first at frame {f}"));
        format!(
            "self-collision fail-safe: {} particles put back where their frame started ({} of them carried with a \
             moving collider), in {} of {frames} frames{first}; \
             whole cloth put back {} times; {} cloth triangles found through a collider's",
            self.particles, self.carried, self.frames, self.whole, self.collider_pairs
        )
    }

    pub(crate) fn json(&self) -> Value {
        json!({
            "particles_rolled_back": self.particles,
            "frames_with_rollbacks": self.frames,
            "first_frame": self.first_frame,
            "whole_cloth_rollbacks": self.whole,
            "collider_pairs_found": self.collider_pairs,
            "particles_carried": self.carried,
        })
    }
}

/// What the setup line says the cloth is.
pub(crate) fn cloth_description(args: &Args, builder: &ClothBuilder) -> String {
    let shape = match (&args.cloth_mesh, &builder.mesh) {
        (paths, Some(mesh)) => format!(
            "mesh {} ({} particles, {} triangles{})",
            if paths.is_empty() {
                "of the scene".to_string()
            } else {
                paths.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" + ")
            },
            mesh.vertices.len(),
            mesh.triangles.len(),
            if mesh.uvs.is_some() { ", UVs" } else { "" }
        ),
        _ => format!(
            "{} x {} particles{}",
            builder.rows,
            builder.cols,
            if args.listed_springs { " (listed springs)" } else { "" }
        ),
    };
    let mut materials = String::new();
    for (piece, m) in builder.own_piece_materials() {
        let mut own = Vec::new();
        if let Some(k) = m.stiffness {
            own.push(format!("stiffness {},{},{} N/m", k.x, k.y, k.z));
        }
        if let Some(d) = m.density {
            own.push(format!("{d} kg/m^2"));
        }
        materials += &format!(", piece {} ({})", piece + 1, own.join(", "));
    }
    match builder.self_collision {
        Some(t) => {
            format!("{shape}{materials}, self-collision on ({:.1} mm, friction {})", t * 1e3, builder.self_friction)
        }
        None => format!("{shape}{materials}, self-collision off"),
    }
}

pub(crate) fn print_setup(
    args: &Args,
    description: &str,
    sim: &Solver,
    cloth: ClothId,
    settings: &SimSettings,
) -> drape::Result<()> {
    let s = sim.stability(cloth)?;
    say!("cloth: {description}, {:?}, {} substeps/frame of {:.3e} s", settings.integrator, s.substeps, s.substep);
    say!(
        "stability: omega_max {:.0} rad/s, gamma_max {:.0} 1/s, bound {:.3e} s, substep/bound {:.2}{}",
        s.omega_max,
        s.gamma_max,
        s.max_substep,
        s.ratio,
        if args.substeps.is_none() { format!(" (auto, safety {})", settings.safety) } else { String::new() }
    );
    say!("  bound from {} (Gershgorin: omega_max {:.0} rad/s)", s.source, s.omega_gershgorin);
    if let Some(w) = s.warning() {
        eprintln!("warning: {w}");
    }
    Ok(())
}

pub(crate) fn print_accuracy(a: &Accuracy, frames: u32, seconds: f64) {
    say!("accuracy at t = {:.2} s against the true triangle mesh ({:.2} s on the CPU):", frames as f32 / 60.0, seconds);
    if a.inside_defined {
        say!(
            "  particles inside the mesh   {:.3} %  (max penetration {:.2} mm, p99 {:.2} mm)",
            100.0 * a.inside_fraction,
            a.max_penetration * 1e3,
            a.p99_penetration * 1e3
        );
    } else {
        say!("  particles inside the mesh   n/a (open mesh: no inside)");
    }
    say!("  within thickness of surface {:.3} %", 100.0 * a.within_thickness_fraction);
    say!(
        "  resting on the collider     {} particles, gap to true surface mean {:.2} mm, max {:.2} mm",
        a.resting,
        a.gap_mean * 1e3,
        a.gap_max * 1e3
    );
    say!(
        "  spring stretch              max {:.3}, p99 {:.3}; all finite: {}",
        a.max_stretch,
        a.p99_stretch,
        a.all_finite
    );
}

/// What the frames ran: substeps per frame (raised for contact, `drape::motion`) and sleep.
#[derive(Default)]
pub(crate) struct Schedule {
    pub(crate) substeps: Vec<u32>,
    /// The number of each awake frame (from 1), as `substeps`.
    pub(crate) awake_frames: Vec<u32>,
    pub(crate) asleep: u32,
    pub(crate) first_asleep: Option<u32>,
    pub(crate) asleep_wall_ms: Vec<f64>,
    /// Per awake frame: the share of its tiles that slept (`SimSettings::tile_sleep`), and the
    /// first frame a tile slept.
    pub(crate) tiles_asleep: Vec<f64>,
    pub(crate) first_tile_asleep: Option<u32>,
}

impl Schedule {
    pub(crate) fn record(&mut self, substeps: u32, asleep: bool, frame: u32) {
        if asleep {
            self.asleep += 1;
            self.first_asleep.get_or_insert(frame);
        } else {
            self.substeps.push(substeps);
            self.awake_frames.push(frame);
        }
    }

    /// An awake frame in which `asleep` of its `tiles` slept.
    pub(crate) fn record_tiles(&mut self, asleep: u32, tiles: u32, frame: u32) {
        if tiles > 0 {
            self.tiles_asleep.push(f64::from(asleep) / f64::from(tiles));
        }
        if asleep > 0 {
            self.first_tile_asleep.get_or_insert(frame);
        }
    }

    /// The share of tiles asleep over the awake frames: median and largest.
    fn tile_shares(&self) -> Option<(f64, f64)> {
        let mut sorted = self.tiles_asleep.clone();
        sorted.sort_by(f64::total_cmp);
        Some((*sorted.get(sorted.len() / 2)?, *sorted.last()?))
    }

    pub(crate) fn print(&self, bound: u32, frames: u32, awake_median_ms: f64) {
        let mut sorted = self.substeps.clone();
        sorted.sort_unstable();
        if let (Some(lo), Some(hi)) = (sorted.first(), sorted.last()) {
            let raised = sorted.iter().filter(|&&n| n > bound).count();
            say!(
                "substeps per awake frame: min {lo}, median {}, max {hi} (stability bound {bound}; raised for contact in {raised} frames)",
                sorted[sorted.len() / 2]
            );
        }
        match self.first_asleep {
            Some(first) => {
                let asleep_ms = drape::timing::median(&self.asleep_wall_ms);
                say!(
                    "sleeping: {} of {frames} frames ran nothing (first asleep at frame {first}); wall time of a \
                     sleeping frame: median {asleep_ms:.3} ms, {:.4}x an awake frame's median",
                    self.asleep,
                    asleep_ms / awake_median_ms
                )
            }
            None => say!("sleeping: the cloth never slept"),
        }
        match (self.first_tile_asleep, self.tile_shares()) {
            (Some(first), Some((median, most))) => say!(
                "sleeping tiles (of {} particles, in awake frames): median {:.1} %, at most {:.1} % (first at frame {first})",
                drape_kernels::tiles::TILE_PARTICLES,
                100.0 * median,
                100.0 * most
            ),
            (None, Some(_)) => say!("sleeping tiles: none slept"),
            _ => {}
        }
    }
}

impl Schedule {
    /// The schedule's JSON: substeps per awake frame and the sleeping frames.
    pub(crate) fn json(&self, bound: u32) -> Value {
        let mut sorted = self.substeps.clone();
        sorted.sort_unstable();
        json!({
            "substeps_min": sorted.first(),
            "substeps_median": sorted.get(sorted.len() / 2),
            "substeps_max": sorted.last(),
            "stability_bound_substeps": bound,
            "frames_raised_for_contact": sorted.iter().filter(|&&n| n > bound).count(),
            "substeps_per_frame": self.substeps,
            "awake_frame_numbers": self.awake_frames,
            "frames_asleep": self.asleep,
            "first_frame_asleep": self.first_asleep,
            "asleep_wall_ms_median": (!self.asleep_wall_ms.is_empty()).then(|| drape::timing::median(&self.asleep_wall_ms)),
            "tiles_asleep_median": self.tile_shares().map(|s| s.0),
            "tiles_asleep_max": self.tile_shares().map(|s| s.1),
            "first_frame_tile_asleep": self.first_tile_asleep,
        })
    }
}

impl WorstIntersections {
    /// The every-frame check's JSON.
    pub(crate) fn json(&self) -> Value {
        json!({
            "frames_with_any": self.frames_with_any,
            "first_frame_with_any": self.first_frame,
            "worst_cloth_cloth": { "count": self.cloth_cloth.0, "frame": self.cloth_cloth.1 },
            "worst_cloth_edges_through_collider": { "count": self.cloth_edges.0, "frame": self.cloth_edges.1 },
            "worst_collider_edges_through_cloth": { "count": self.collider_edges.0, "frame": self.collider_edges.1 },
        })
    }
}

/// A stability bound's JSON.
pub(crate) fn stability_json(s: &Stability) -> Value {
    json!({
        "substeps": s.substeps,
        "substep_s": s.substep,
        "bound_s": s.max_substep,
        "substep_over_bound": s.ratio,
        "omega_max": s.omega_max,
        "gamma_max": s.gamma_max,
        "omega_max_gershgorin": s.omega_gershgorin,
        "source": s.source.to_string(),
    })
}

/// The frames' timings: per-pass GPU time (when timestamps ran) and the wall times.
pub(crate) fn timings_json(report: &TimingReport, timestamps: bool) -> Value {
    let passes: Vec<Value> = report
        .rows()
        .into_iter()
        .map(|(label, dispatches, micros)| {
            json!({
                "pass": label,
                "dispatches": dispatches,
                "gpu_us_per_frame": micros,
                "gpu_us_per_dispatch_median": report.median_dispatch_micros(label),
                "frames_running": report.frames_running(label),
            })
        })
        .collect();
    json!({
        "awake_frames": report.frames(),
        "wall_ms_median": report.median_wall_ms(),
        "wall_ms_fastest": report.min_wall_ms(),
        "gpu_us_per_frame_median": timestamps.then(|| report.median_gpu_micros()),
        "gpu_us_frame_span_median": timestamps.then(|| report.median_span_micros()),
        "gpu_us_frame_span_fastest": timestamps.then(|| report.min_span_micros()),
        // Frame by frame (awake frames, in order: `schedule.awake_frame_numbers`): which frames
        // cost what (a contact burst, a list rebuild), where the medians hide it.
        "wall_ms_per_frame": report.wall_ms_per_frame(),
        "gpu_us_frame_span_per_frame": timestamps.then(|| report.span_micros_per_frame()),
        "passes": if timestamps { Value::Array(passes) } else { Value::Null },
        "skipped": report.skipped(),
    })
}

/// Accuracy against the true mesh as JSON (lengths in metres).
pub(crate) fn accuracy_json(a: &Accuracy) -> Value {
    json!({
        "particles": a.particles,
        "all_finite": a.all_finite,
        "inside_fraction": a.inside_defined.then_some(a.inside_fraction),
        "max_penetration_m": a.inside_defined.then_some(a.max_penetration),
        "p99_penetration_m": a.inside_defined.then_some(a.p99_penetration),
        "within_thickness_fraction": a.within_thickness_fraction,
        "resting": a.resting,
        "gap_mean_m": a.gap_mean,
        "gap_max_m": a.gap_max,
        "max_stretch": a.max_stretch,
        "p99_stretch": a.p99_stretch,
    })
}

/// Exact intersection counts as JSON.
pub(crate) fn intersections_json(found: &Intersections) -> Value {
    json!({
        "cloth_cloth": found.cloth_cloth,
        "cloth_edges_through_collider": found.cloth_edges_through_collider,
        "collider_edges_through_cloth": found.collider_edges_through_cloth,
    })
}

/// Writes the report to `path`.
pub(crate) fn write_json(path: &std::path::Path, report: serde_json::Map<String, Value>) -> drape::Result<()> {
    let text = serde_json::to_string_pretty(&Value::Object(report)).map_err(|e| drape::Error::InvalidParameter {
        name: "--json",
        problem: format!("the report could not be written as JSON: {e}"),
    })?;
    std::fs::write(path, text + "\n").map_err(|source| drape::Error::InvalidParameter {
        name: "--json",
        problem: format!("the report could not be written to {}: {source}", path.display()),
    })
}
