//! `drape`: runs a built-in scene on the GPU, prints per-kernel GPU timings and the stability
//! figures, and can write frames as OBJ.

use clap::{Parser, ValueEnum};
use drape::timing::TimingReport;
use drape::{Context, Integrator, SimSettings, Simulation, Validation};
use glam::Vec3;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Copy, Clone, Debug, ValueEnum)]
enum IntegratorArg {
    Rk4,
    Euler,
}

/// Simulate the default scene: a cloth pinned at two corners, swinging under gravity and wind.
#[derive(Parser, Debug)]
#[command(name = "drape", version, about)]
struct Args {
    /// Particles per side (rows = cols).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(2..=4096))]
    grid: u32,
    /// Frames to simulate (1/60 s each).
    #[arg(long, default_value_t = 120)]
    frames: u32,
    /// Substeps per frame; default: automatic from the stability bound.
    #[arg(long)]
    substeps: Option<u32>,
    /// Time integrator.
    #[arg(long, value_enum, default_value = "rk4")]
    integrator: IntegratorArg,
    /// Cloth side length (m).
    #[arg(long, default_value_t = 1.0)]
    size: f32,
    /// Total cloth mass (kg).
    #[arg(long, default_value_t = 0.2)]
    mass: f32,
    /// Structural, shear and bend stiffness (N/m), comma separated.
    #[arg(long, value_delimiter = ',', num_args = 3, default_values_t = [40.0, 10.0, 2.0])]
    stiffness: Vec<f32>,
    /// Damping along spring axes (N s/m).
    #[arg(long, default_value_t = 0.002)]
    spring_damping: f32,
    /// Wind: constant force on the whole cloth (N), x,y,z.
    #[arg(long, value_delimiter = ',', num_args = 3, default_values_t = [0.3, 0.0, 0.5])]
    wind: Vec<f32>,
    /// Skip vertex normals.
    #[arg(long)]
    no_normals: bool,
    /// Write frames as OBJ into this directory (the final frame unless --obj-every is given).
    #[arg(long)]
    obj_dir: Option<PathBuf>,
    /// Write every n-th frame (with --obj-dir).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    obj_every: Option<u32>,
    /// Skip GPU timestamp queries (they cost tens of µs per pass on lavapipe).
    #[arg(long)]
    no_timestamps: bool,
    /// Load the Vulkan validation layer (also: DRAPE_VALIDATION=1).
    #[arg(long)]
    validate: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &Args) -> drape::Result<()> {
    let validation = if args.validate { Validation::Required } else { Validation::from_env() };
    let ctx = Context::new(validation)?;
    let info = ctx.info();
    println!("device: {} ({})", info.name, info.driver);

    let cloth = drape::scenes::swinging_cloth(args.grid)
        .size(args.size)
        .mass(args.mass)
        .stiffness(args.stiffness[0], args.stiffness[1], args.stiffness[2])
        .spring_damping(args.spring_damping)
        .external_force(Vec3::from_slice(&args.wind))
        .build()?;
    let settings = SimSettings {
        substeps: args.substeps,
        integrator: match args.integrator {
            IntegratorArg::Rk4 => Integrator::Rk4,
            IntegratorArg::Euler => Integrator::SemiImplicitEuler,
        },
        normals: !args.no_normals,
        timestamps: !args.no_timestamps,
        ..SimSettings::default()
    };
    let mut sim = Simulation::new(&ctx, &cloth, settings)?;
    let s = *sim.stability();
    println!(
        "cloth: {g} x {g} particles, {:?}, {} substeps/frame of {:.3e} s",
        settings.integrator,
        s.substeps,
        s.substep,
        g = args.grid
    );
    println!(
        "stability: omega_max {:.0} rad/s, gamma_max {:.0} 1/s, bound {:.3e} s, substep/bound {:.2}{}",
        s.omega_max,
        s.gamma_max,
        s.max_substep,
        s.ratio,
        if args.substeps.is_none() { format!(" (auto, safety {})", settings.safety) } else { String::new() }
    );
    if let Some(w) = s.warning() {
        eprintln!("warning: {w}");
    }
    if let Some(dir) = &args.obj_dir {
        std::fs::create_dir_all(dir).map_err(|source| drape::Error::Io { path: dir.clone(), source })?;
    }

    let mut report = TimingReport::default();
    for frame in 1..=args.frames {
        let start = Instant::now();
        let timings = sim.step()?;
        report.add(&timings, start.elapsed());
        progress(frame, args.frames);
        let write_this = match args.obj_every {
            Some(n) => frame % n == 0,
            None => frame == args.frames,
        };
        if let (Some(dir), true) = (&args.obj_dir, write_this) {
            let path = dir.join(format!("frame_{frame:05}.obj"));
            drape::obj::write_cloth_obj(&path, args.grid, args.grid, &sim.positions()?, &sim.normals()?)?;
        }
    }
    eprintln!();
    println!("\nGPU time per kernel (timestamp queries, median over frames):");
    print!("{}", report.table());
    let x = sim.positions()?;
    let lowest = x.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    println!("final: lowest particle at y = {lowest:.3} m, {} frames simulated", sim.frames_done());
    ctx.check_validation()
}

fn progress(frame: u32, total: u32) {
    let width = 40;
    let done = (frame as usize * width) / total.max(1) as usize;
    eprint!("\r[{}{}] {frame}/{total} frames", "#".repeat(done), " ".repeat(width - done));
    let _ = std::io::stderr().flush();
}
