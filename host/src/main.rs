//! `drape`: runs a built-in scene on the GPU, prints per-kernel GPU timings, the LBVH build time,
//! the stability figures and the accuracy against the true mesh, and can write OBJ frames.

use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser, ValueEnum};
use drape::mesh::Mesh;
use drape::metrics::intersections::count_intersections;
use drape::metrics::{Accuracy, TriangleBvh, accuracy_of_cloth};
use drape::scenes::{DrapeScene, SETTLE_FRAMES, default_mesh, find_model};
use drape::timing::TimingReport;
use drape::{
    ClothBuilder, ClothId, ClothMesh, ContactSearch, Context, Integrator, Model, SimSettings, Solver, Validation,
};
use glam::Vec3;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Copy, Clone, Debug, ValueEnum, PartialEq)]
enum SceneArg {
    /// A cloth falls onto a mesh collider (the standard benchmark scene).
    Drape,
    /// A cloth pinned at two corners swings under gravity and wind (no collider).
    Swing,
    /// A long strip falls upright onto the ground and folds onto itself (`--grid` particles
    /// along it, a quarter of that across).
    Pile,
    /// An open tube of cloth (a skirt, `--grid` particles around) falls over a body that turns
    /// about its vertical axis.
    Garment,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum ContactArg {
    /// The paper's proxy: one sphere per non-empty voxel (`--voxels`).
    Spheres,
    /// The mesh's own triangles.
    Triangles,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum SearchArg {
    /// A broad phase once per frame gives each particle a short list of nearby leaves; each
    /// substep tests only the list (a particle that leaves its query box walks the LBVH).
    Lists,
    /// Walk the LBVH every substep.
    Traverse,
    /// Test every leaf every substep (the baseline).
    BruteForce,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum HolesArg {
    /// Fill holes up to half the mesh's bounds diagonal in perimeter (a scan's, like the
    /// bunny's base) so the collider is the solid the mesh depicts; larger openings stay open.
    Close,
    /// Collide with the triangles exactly as given (the cloth can pass through holes).
    Keep,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(Copy, Clone, Debug, ValueEnum)]
enum IntegratorArg {
    Rk4,
    Euler,
}

/// Simulate a scene: by default a 64x64 cloth falling onto a procedural icosphere for 2 s.
#[derive(Parser, Debug)]
#[command(name = "drape", version, about)]
struct Args {
    #[arg(long, value_enum, default_value = "drape")]
    scene: SceneArg,
    /// Collider mesh: icosphere, torus, bunny, dragon (from ../shared/models) or an OBJ path.
    #[arg(long, default_value = "icosphere")]
    mesh: String,
    /// What the cloth collides with: the mesh's triangles or the paper's voxel spheres.
    #[arg(long, value_enum, default_value = "triangles")]
    contact: ContactArg,
    /// The collider mesh's small holes: closed (default) or kept as given.
    #[arg(long, value_enum, default_value = "close")]
    holes: HolesArg,
    /// Collider voxels per axis (one sphere per non-empty voxel; `--contact spheres`).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=256))]
    voxels: u32,
    /// Contact thickness (m), in (0, 0.5].
    #[arg(long, default_value_t = drape::scenes::DEFAULT_THICKNESS, value_parser = parse_thickness, allow_hyphen_values = true)]
    thickness: f32,
    /// Coulomb friction coefficient of the contact, in [0, 10] (0 = the paper's frictionless
    /// response).
    #[arg(long, default_value_t = drape::scenes::DEFAULT_FRICTION, value_parser = parse_friction, allow_hyphen_values = true)]
    friction: f32,
    /// How contact finds the leaves each particle touches (same contacts, different cost).
    #[arg(long, value_enum, default_value = "lists")]
    search: SearchArg,
    /// Test every leaf (sphere or triangle) instead of traversing the LBVH (baseline; the same
    /// as `--search brute-force`).
    #[arg(long, conflicts_with = "search")]
    brute_force: bool,
    /// Particles per side (rows = cols), 2..=2048.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(2..=2048))]
    grid: u32,
    /// The cloth from a triangle mesh (OBJ): one particle per vertex in the file's order, springs
    /// on its edges and across them, UVs kept. In the drape scene it is centred over the
    /// collider, its lowest point 5 cm above the top; in the swing scene it stays where the
    /// file puts it.
    #[arg(long, conflicts_with = "grid")]
    cloth_mesh: Option<PathBuf>,
    /// Pin these particles (vertex indices, comma separated; a grid's are row * cols + col).
    #[arg(long, value_delimiter = ',')]
    pin_vertices: Vec<u32>,
    /// Pin every particle inside this box, given as MIN_X,MIN_Y,MIN_Z,MAX_X,MAX_Y,MAX_Z in the
    /// cloth's own coordinates (a mesh's file coordinates), e.g. `--pin-box=-1,0.9,-1,1,1,1`.
    #[arg(long, value_parser = parse_box, allow_hyphen_values = true)]
    pin_box: Option<(Vec3, Vec3)>,
    /// Self-collision: the cloth's particles keep `--thickness` from its own triangles (vertex
    /// against triangle). Default: on in the pile scene, off elsewhere.
    #[arg(long, value_enum)]
    self_collision: Option<OnOff>,
    /// Build the grid with listed springs (the kernels of mesh cloths) instead of its fast path:
    /// the same cloth, to measure one path against the other.
    #[arg(long, conflicts_with = "cloth_mesh")]
    listed_springs: bool,
    /// Put the cloth to sleep (its frames run nothing until something wakes it) once its fastest
    /// particle has moved slower than this (m/s) for 30 frames, in [0, 10]; 0 = never.
    #[arg(long, default_value_t = drape::Sleep::default().speed, value_parser = parse_sleep, allow_hyphen_values = true)]
    sleep: f32,
    /// Raise automatic substeps so no particle moves more than the contact thickness per
    /// substep (from the last frame's fastest particle and the colliders' motion).
    #[arg(long, value_enum, default_value = "on")]
    contact_substeps: OnOff,
    /// Frames to simulate (1/60 s each).
    #[arg(long, default_value_t = SETTLE_FRAMES, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Substeps per frame, 1..=100000; default: automatic from the stability bound.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    substeps: Option<u32>,
    /// Time integrator.
    #[arg(long, value_enum, default_value = "rk4")]
    integrator: IntegratorArg,
    /// Structural, shear and bend stiffness (N/m) as K_STRUCT,K_SHEAR,K_BEND, each in
    /// [0, 1e6].
    #[arg(long, value_parser = parse_stiffness, default_value = "40,10,2")]
    stiffness: Vec3,
    /// Damping along spring axes (N s/m), in [0, 100].
    #[arg(long, default_value_t = 0.002, value_parser = parse_spring_damping, allow_hyphen_values = true)]
    spring_damping: f32,
    /// Wind: constant force on the whole cloth (N) as X,Y,Z, e.g. `--wind -1,0,0` (swing
    /// scene).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0.3,0,0.5")]
    wind: Vec3,
    /// The cloth's initial velocity (m/s) as X,Y,Z, e.g. `--velocity=0,-10,0` (a throw).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    velocity: Option<Vec3>,
    /// Skip vertex normals.
    #[arg(long)]
    no_normals: bool,
    /// Write frames as OBJ into this directory (the final frame unless --obj-every is given).
    #[arg(long)]
    obj_dir: Option<PathBuf>,
    /// Write every n-th frame (with --obj-dir).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    obj_every: Option<u32>,
    /// Count the exact intersections after every frame (not only the last) and report the
    /// worst frame of each kind.
    #[arg(long)]
    check_every_frame: bool,
    /// Skip GPU timestamp queries (they cost tens of µs per pass on lavapipe).
    #[arg(long)]
    no_timestamps: bool,
    /// Load the Vulkan validation layer (also: DRAPE_VALIDATION=1).
    #[arg(long)]
    validate: bool,
}

/// The library logs through `log`; the CLI prints its records to stderr. `DRAPE_LOG` sets the
/// level (error, warn, info, debug, trace; default warn).
struct StderrLogger;

impl log::Log for StderrLogger {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::max_level()
    }
    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            eprintln!("[{} {}] {}", record.level(), record.target(), record.args());
        }
    }
    fn flush(&self) {}
}

static LOGGER: StderrLogger = StderrLogger;

fn init_logging() {
    let level = std::env::var("DRAPE_LOG").ok().and_then(|l| l.parse().ok()).unwrap_or(log::LevelFilter::Warn);
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(level);
    }
}

fn main() -> ExitCode {
    init_logging();
    let matches = Args::command().get_matches();
    let args = Args::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    if let Err(problem) = check_flags(&args, &matches) {
        Args::command().error(clap::error::ErrorKind::ArgumentConflict, problem).exit();
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            end_progress_line();
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn load_mesh(name: &str) -> drape::Result<Mesh> {
    match name {
        "icosphere" => Ok(default_mesh()),
        "torus" => Ok(Mesh::torus(0.35, 0.12, 48, 24)),
        "bunny" => Mesh::load_obj(&find_model("stanford-bunny.obj")?),
        "dragon" => Mesh::load_obj(&find_model("stanford-dragon-res2.obj")?),
        path => Mesh::load_obj(std::path::Path::new(path)),
    }
}

/// Whether the user typed `id` (not its default).
fn given(matches: &ArgMatches, id: &str) -> bool {
    matches.value_source(id) == Some(ValueSource::CommandLine)
}

/// Flags a scene or mode would silently ignore are usage errors naming both.
fn check_flags(args: &Args, matches: &ArgMatches) -> Result<(), String> {
    let collider_flags = ["mesh", "contact", "holes", "voxels", "thickness", "friction", "search", "brute_force"];
    let flag = |id: &str| format!("--{}", id.replace('_', "-"));
    for id in collider_flags {
        if args.scene == SceneArg::Swing && given(matches, id) {
            return Err(format!(
                "{} does nothing in the swing scene, which has no collider: drop it, or use --scene drape or pile",
                flag(id)
            ));
        }
    }
    for id in ["mesh", "holes"] {
        if args.scene == SceneArg::Pile && given(matches, id) {
            return Err(format!("{} does nothing in the pile scene, whose collider is the ground plane", flag(id)));
        }
        if args.scene == SceneArg::Garment && given(matches, id) {
            return Err(format!("{} does nothing in the garment scene, whose collider is its body", flag(id)));
        }
    }
    if args.scene != SceneArg::Swing && given(matches, "wind") {
        return Err(format!("--wind only applies to the swing scene, not the {:?} scene", args.scene).to_lowercase());
    }
    if args.contact == ContactArg::Triangles && given(matches, "voxels") {
        return Err("--voxels only applies with --contact spheres (triangle contact has no voxels)".into());
    }
    if args.obj_every.is_some() && args.obj_dir.is_none() {
        return Err("--obj-every needs --obj-dir (the directory to write the frames into)".into());
    }
    Ok(())
}

/// A finite number in `lo..=hi` (`lo` excluded when `open_low`), or a message with the range.
fn number_in(text: &str, lo: f32, hi: f32, open_low: bool) -> Result<f32, String> {
    let value: f32 = text.trim().parse().map_err(|e| format!("`{text}`: {e}"))?;
    let low_ok = if open_low { value > lo } else { value >= lo };
    if value.is_finite() && low_ok && value <= hi {
        Ok(value)
    } else {
        Err(format!("must be in {}{lo}, {hi}], got {text}", if open_low { "(" } else { "[" }))
    }
}

fn parse_thickness(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 0.5, true)
}

fn parse_sleep(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 10.0, false)
}

fn parse_friction(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 10.0, false)
}

fn parse_spring_damping(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 100.0, false)
}

/// "K_STRUCT,K_SHEAR,K_BEND", each in [0, 1e6] N/m.
fn parse_stiffness(text: &str) -> Result<Vec3, String> {
    let values: Vec<&str> = text.split(',').collect();
    match values[..] {
        [a, b, c] => Ok(Vec3::new(
            number_in(a, 0.0, 1e6, false)?,
            number_in(b, 0.0, 1e6, false)?,
            number_in(c, 0.0, 1e6, false)?,
        )),
        _ => Err(format!("expected three stiffnesses K_STRUCT,K_SHEAR,K_BEND, got `{text}`")),
    }
}

/// The output directory exists (created if needed) and takes files, checked before any setup.
fn check_output_dir(dir: &std::path::Path) -> drape::Result<()> {
    let io = |source| drape::Error::Io { path: dir.to_path_buf(), source };
    std::fs::create_dir_all(dir).map_err(io)?;
    let probe = dir.join(".drape-write-test");
    std::fs::write(&probe, b"").map_err(io)?;
    std::fs::remove_file(&probe).map_err(io)
}

/// "X,Y,Z" (three finite numbers, negatives allowed) as a vector.
fn parse_vec3(text: &str) -> Result<Vec3, String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [x, y, z] if values.iter().all(|v| v.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers X,Y,Z, got `{text}`")),
    }
}

/// "MIN_X,MIN_Y,MIN_Z,MAX_X,MAX_Y,MAX_Z" (six finite numbers, min <= max) as a box.
fn parse_box(text: &str) -> Result<(Vec3, Vec3), String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [a, b, c, d, e, f] if values.iter().all(|v| v.is_finite()) && a <= d && b <= e && c <= f => {
            Ok((Vec3::new(a, b, c), Vec3::new(d, e, f)))
        }
        _ => Err(format!(
            "expected six finite numbers MIN_X,MIN_Y,MIN_Z,MAX_X,MAX_Y,MAX_Z with min <= max, got `{text}`"
        )),
    }
}

/// The cloth of `--cloth-mesh`, placed for `scene` (see the flag).
fn mesh_cloth(path: &std::path::Path, scene: Option<&DrapeScene>) -> drape::Result<ClothBuilder> {
    let mesh = ClothMesh::load_obj(path)?;
    let builder = ClothBuilder::from_mesh(mesh.clone());
    let Some(s) = scene else {
        return Ok(builder);
    };
    let (lo, hi) = drape::Mesh { vertices: mesh.vertices.clone(), triangles: mesh.triangles.clone() }.bounds();
    let (mesh_lo, mesh_hi) = s.mesh.bounds();
    let centre = 0.5 * (mesh_lo + mesh_hi);
    let shift = Vec3::new(centre.x - 0.5 * (lo.x + hi.x), mesh_hi.y + 0.05 - lo.y, centre.z - 0.5 * (lo.z + hi.z));
    Ok(builder.transform(glam::Mat4::from_translation(shift)))
}

fn run(args: &Args) -> drape::Result<()> {
    if let Some(dir) = &args.obj_dir {
        check_output_dir(dir).map_err(|e| drape::Error::InvalidParameter {
            name: "--obj-dir",
            problem: format!("cannot write the OBJ frames there: {e}"),
        })?;
    }
    let validation = if args.validate { Validation::Required } else { Validation::from_env() };
    let ctx = Context::new(validation)?;
    let info = ctx.info();
    println!("device: {} ({})", info.name, info.driver);

    let mut scene = None;
    let builder = match args.scene {
        SceneArg::Swing => drape::scenes::swinging_cloth(args.grid).external_force(args.wind),
        SceneArg::Garment => {
            let s = drape::scenes::garment(args.grid);
            println!(
                "body: an ellipsoid of {} triangles, turning at {} rad/s",
                s.mesh.triangles.len(),
                drape::scenes::GARMENT_TURN_RATE
            );
            let builder = s.cloth.clone();
            scene = Some(s);
            builder
        }
        SceneArg::Pile => {
            let s = drape::scenes::pile(args.grid);
            println!("ground: a 6 m square plane of 2 triangles (open)");
            let builder = s.cloth.clone();
            scene = Some(s);
            builder
        }
        SceneArg::Drape => {
            let mut s = DrapeScene::standard(&load_mesh(&args.mesh)?, args.grid);
            let topology = match args.holes {
                HolesArg::Close => {
                    let (closed, report) = s.mesh.close_small_holes();
                    s.mesh = closed;
                    let open = if report.left_open > 0 {
                        format!(", {} larger ones left open", report.left_open)
                    } else {
                        String::new()
                    };
                    match report.closed {
                        0 if open.is_empty() => "no holes".to_string(),
                        n => format!("closed {n} small holes{open}"),
                    }
                }
                HolesArg::Keep => "holes kept".to_string(),
            };
            let boundary = drape::topology::boundary_edge_count(&s.mesh);
            println!(
                "mesh: {} ({topology}): {}",
                args.mesh,
                if boundary == 0 { "closed".to_string() } else { format!("open, {boundary} boundary edges") }
            );
            let builder = s.cloth.clone();
            scene = Some(s);
            builder
        }
    };
    let builder = match &args.cloth_mesh {
        Some(path) => {
            let wind = if args.scene == SceneArg::Swing { args.wind } else { Vec3::ZERO };
            mesh_cloth(path, scene.as_ref())?.external_force(wind)
        }
        None => builder.listed_springs(args.listed_springs),
    };
    let builder = args.pin_vertices.iter().fold(builder, |b, &i| b.pin_vertex(i));
    let builder = match args.pin_box {
        Some((lo, hi)) => builder.pin_within(lo, hi),
        None => builder,
    };
    let on_by_default = matches!(args.scene, SceneArg::Pile | SceneArg::Garment);
    let self_collision = args.self_collision.unwrap_or(if on_by_default { OnOff::On } else { OnOff::Off });
    let builder = builder.self_collision((self_collision == OnOff::On).then_some(args.thickness));
    let cloth_description = cloth_description(args, &builder);
    let builder = match args.velocity {
        Some(v) => builder.velocity(v),
        None => builder,
    };
    let built = builder
        .stiffness(args.stiffness.x, args.stiffness.y, args.stiffness.z)
        .spring_damping(args.spring_damping)
        .build()?;
    let settings = SimSettings::default()
        .with_substeps(args.substeps)
        .with_integrator(match args.integrator {
            IntegratorArg::Rk4 => Integrator::Rk4,
            IntegratorArg::Euler => Integrator::SemiImplicitEuler,
        })
        .with_normals(!args.no_normals)
        .with_timestamps(!args.no_timestamps)
        .with_contact_substeps(args.contact_substeps == OnOff::On)
        .with_sleep((args.sleep > 0.0).then(|| drape::Sleep { speed: args.sleep, ..drape::Sleep::default() }));
    let collider = match &mut scene {
        Some(s) => {
            s.thickness = args.thickness;
            s.friction = args.friction;
            let start = Instant::now();
            let mut c = match args.contact {
                ContactArg::Spheres => s.collider(args.voxels)?,
                ContactArg::Triangles => s.triangle_collider(),
            };
            c.search = match (args.brute_force, args.search) {
                (true, _) | (_, SearchArg::BruteForce) => ContactSearch::BruteForce,
                (_, SearchArg::Lists) => ContactSearch::CandidateLists,
                (_, SearchArg::Traverse) => ContactSearch::TraverseEverySubstep,
            };
            let leaves = match args.contact {
                ContactArg::Spheres => format!("{n}^3 voxels -> {} spheres", c.spheres().len(), n = args.voxels),
                ContactArg::Triangles => format!("{} triangle leaves", c.leaf_count()),
            };
            println!(
                "collider: {} ({} vertices, {} triangles), {leaves} in {:.1} ms (CPU)",
                match args.scene {
                    SceneArg::Pile => "ground",
                    SceneArg::Garment => "body",
                    _ => &args.mesh,
                },
                s.mesh.vertices.len(),
                s.mesh.triangles.len(),
                start.elapsed().as_secs_f64() * 1e3,
            );
            Some(c)
        }
        None => None,
    };
    let model = Model::single(&built, collider.as_slice(), settings)?;
    let cloth = model.first_cloth();
    let mut sim = Solver::new(&ctx, &model)?;
    print_setup(args, &cloth_description, &sim, cloth, &settings)?;
    println!("GPU memory ({} barriers per frame):\n{}", sim.barriers_per_frame(), sim.memory_report());
    if let Some(t) = sim.lbvh_timings() {
        println!("LBVH build on the GPU: {:.3} ms", t.total_micros() / 1e3);
        for (label, n, micros) in t.by_label() {
            println!("  {label:<16} {n:>3} dispatches {micros:>10.1} µs");
        }
    }
    if let Some(dir) = &args.obj_dir {
        std::fs::create_dir_all(dir).map_err(|source| drape::Error::Io { path: dir.clone(), source })?;
        if let Some(s) = &scene {
            drape::obj::write_mesh_obj(&dir.join("collider.obj"), &s.mesh)?;
        }
    }

    let mut worst = WorstIntersections::default();
    let mut report = TimingReport::default();
    let (mut ran, mut skipped, mut fallbacks) = (0, 0, 0u64);
    let body = model.collider_ids().next();
    let mut schedule = Schedule::default();
    for frame in 1..=args.frames {
        if let (SceneArg::Garment, Some(body)) = (args.scene, body) {
            sim.set_collider_pose(body, drape::scenes::garment_rotation(frame as f32 / 60.0), Vec3::ZERO)?;
        }
        let start = Instant::now();
        let r = sim.step_report()?;
        let asleep = r.cloths_asleep > 0;
        // The substeps the frame ran (its start may have raised them for contact).
        schedule.record(sim.stability(cloth)?.substeps, asleep, frame);
        // Sleeping frames run nothing: timed apart, so the table shows what awake frames cost.
        if asleep {
            schedule.asleep_wall_ms.push(start.elapsed().as_secs_f64() * 1e3);
        } else {
            report.add(&r.timings, start.elapsed());
        }
        ran += r.collision_ran;
        skipped += r.collision_skipped;
        fallbacks += u64::from(r.collision_fallbacks);
        progress(frame, args.frames);
        let write_this = match args.obj_every {
            Some(n) => frame % n == 0,
            None => frame == args.frames,
        };
        if let (Some(dir), true) = (&args.obj_dir, write_this) {
            let path = dir.join(format!("frame_{frame:05}.obj"));
            drape::obj::write_cloth_obj(&path, &built, &sim.positions(cloth)?, &sim.normals(cloth)?)?;
        }
        if args.check_every_frame {
            let posed = scene.as_ref().filter(|_| args.scene == SceneArg::Garment).map(|s| {
                s.mesh.transformed(glam::Mat4::from_quat(drape::scenes::garment_rotation(frame as f32 / 60.0)))
            });
            let solid = match &posed {
                Some(m) => (m.vertices.as_slice(), m.triangles.as_slice()),
                None => solid_of(&scene),
            };
            worst.record(frame, count_intersections(&sim.positions(cloth)?, &built.triangles, solid));
        }
    }
    end_progress_line();
    if args.no_timestamps {
        println!(
            "\nGPU timestamps off (--no-timestamps): wall time per frame over {} frames: median {:.3} ms, min {:.3} ms",
            report.frames(),
            report.median_wall_ms(),
            report.min_wall_ms()
        );
    } else {
        println!("\nGPU time per kernel (timestamp queries, median over frames):");
        print!("{}", report.table());
    }
    schedule.print(sim.stability(cloth)?.bound_substeps, args.frames, report.median_wall_ms());
    if let Some(c) = &collider {
        println!("collision traversal: ran in {ran} substeps, culled (cloth cannot touch) in {skipped}");
        if c.search == ContactSearch::CandidateLists {
            let particle_substeps = u64::from(ran) * built.particle_count() as u64;
            println!(
                "candidate lists: {fallbacks} of {particle_substeps} particle-substeps fell back to a full walk ({:.2} %)",
                100.0 * fallbacks as f64 / particle_substeps.max(1) as f64
            );
        }
    }
    let x = sim.positions(cloth)?;
    // The metrics see the collider where it stands now (the garment's body has turned).
    if let (SceneArg::Garment, Some(s)) = (args.scene, &mut scene) {
        let turn = drape::scenes::garment_rotation(args.frames as f32 / 60.0);
        s.mesh = s.mesh.transformed(glam::Mat4::from_quat(turn));
    }
    if let (Some(s), Some(c)) = (&scene, &collider) {
        let start = Instant::now();
        let bvh = TriangleBvh::new(&s.mesh);
        let spheres = (args.contact == ContactArg::Spheres).then(|| c.spheres());
        let a = accuracy_of_cloth(&bvh, spheres, c.thickness, &built.structural_springs(), &x);
        print_accuracy(&a, args.frames, start.elapsed().as_secs_f64());
    } else {
        let lowest = x.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
        println!("final: lowest particle at y = {lowest:.3} m after {} frames", sim.frames_done());
    }
    if args.check_every_frame {
        println!(
            "intersections (exact, every frame): frames with any {} of {}; worst frames: cloth-cloth {} (frame {}), \
             cloth edges through the collider {} (frame {}), collider edges through the cloth {} (frame {})",
            worst.frames_with_any,
            args.frames,
            worst.cloth_cloth.0,
            worst.cloth_cloth.1,
            worst.cloth_edges.0,
            worst.cloth_edges.1,
            worst.collider_edges.0,
            worst.collider_edges.1
        );
    }
    let start = Instant::now();
    let found = count_intersections(&x, &built.triangles, solid_of(&scene));
    println!(
        "intersections (exact, final frame, {:.2} s on the CPU): cloth-cloth {}, cloth edges through the collider {}, \
         collider edges through the cloth {}",
        start.elapsed().as_secs_f64(),
        found.cloth_cloth,
        found.cloth_edges_through_collider,
        found.collider_edges_through_cloth
    );
    ctx.check_validation()
}

/// The collider mesh of a scene, for the intersection counts (none: empty).
fn solid_of(scene: &Option<DrapeScene>) -> (&[Vec3], &[[u32; 3]]) {
    match scene {
        Some(s) => (s.mesh.vertices.as_slice(), s.mesh.triangles.as_slice()),
        None => (&[], &[]),
    }
}

/// The largest count of each kind of intersection over the frames, and the frame it came at.
#[derive(Default)]
struct WorstIntersections {
    frames_with_any: u32,
    cloth_cloth: (usize, u32),
    cloth_edges: (usize, u32),
    collider_edges: (usize, u32),
}

impl WorstIntersections {
    fn record(&mut self, frame: u32, found: drape::metrics::intersections::Intersections) {
        self.frames_with_any += (found.total() > 0) as u32;
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

/// What the setup line says the cloth is.
fn cloth_description(args: &Args, builder: &ClothBuilder) -> String {
    let shape = match (&args.cloth_mesh, &builder.mesh) {
        (path, Some(mesh)) => format!(
            "mesh {} ({} particles, {} triangles{})",
            path.as_ref().map_or("of the scene".to_string(), |p| p.display().to_string()),
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
    match builder.self_collision {
        Some(t) => format!("{shape}, self-collision on ({:.1} mm)", t * 1e3),
        None => format!("{shape}, self-collision off"),
    }
}

fn print_setup(
    args: &Args,
    description: &str,
    sim: &Solver,
    cloth: ClothId,
    settings: &SimSettings,
) -> drape::Result<()> {
    let s = sim.stability(cloth)?;
    println!("cloth: {description}, {:?}, {} substeps/frame of {:.3e} s", settings.integrator, s.substeps, s.substep);
    println!(
        "stability: omega_max {:.0} rad/s, gamma_max {:.0} 1/s, bound {:.3e} s, substep/bound {:.2}{}",
        s.omega_max,
        s.gamma_max,
        s.max_substep,
        s.ratio,
        if args.substeps.is_none() { format!(" (auto, safety {})", settings.safety) } else { String::new() }
    );
    println!("  bound from {} (Gershgorin: omega_max {:.0} rad/s)", s.source, s.omega_gershgorin);
    if let Some(w) = s.warning() {
        eprintln!("warning: {w}");
    }
    Ok(())
}

fn print_accuracy(a: &Accuracy, frames: u32, seconds: f64) {
    println!(
        "accuracy at t = {:.2} s against the true triangle mesh ({:.2} s on the CPU):",
        frames as f32 / 60.0,
        seconds
    );
    if a.inside_defined {
        println!(
            "  particles inside the mesh   {:.3} %  (max penetration {:.2} mm, p99 {:.2} mm)",
            100.0 * a.inside_fraction,
            a.max_penetration * 1e3,
            a.p99_penetration * 1e3
        );
    } else {
        println!("  particles inside the mesh   n/a (open mesh: no inside)");
    }
    println!("  within thickness of surface {:.3} %", 100.0 * a.within_thickness_fraction);
    println!(
        "  resting on the collider     {} particles, gap to true surface mean {:.2} mm, max {:.2} mm",
        a.resting,
        a.gap_mean * 1e3,
        a.gap_max * 1e3
    );
    println!(
        "  spring stretch              max {:.3}, p99 {:.3}; all finite: {}",
        a.max_stretch, a.p99_stretch, a.all_finite
    );
}

/// Whether a progress bar is on stderr's current line (so what comes next starts a new one).
static PROGRESS_ON_LINE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The progress bar, redrawn in place: only on a terminal (a redirected log gets no carriage
/// returns).
fn progress(frame: u32, total: u32) {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return;
    }
    let width = 40;
    let done = (frame as usize * width) / total.max(1) as usize;
    eprint!("\r[{}{}] {frame}/{total} frames", "#".repeat(done), " ".repeat(width - done));
    let _ = std::io::stderr().flush();
    PROGRESS_ON_LINE.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Ends the progress bar's line, if one is drawn.
fn end_progress_line() {
    if PROGRESS_ON_LINE.swap(false, std::sync::atomic::Ordering::Relaxed) {
        eprintln!();
    }
}

/// What the frames ran: substeps per frame (raised for contact, `drape::motion`) and sleep.
#[derive(Default)]
struct Schedule {
    substeps: Vec<u32>,
    asleep: u32,
    first_asleep: Option<u32>,
    asleep_wall_ms: Vec<f64>,
}

impl Schedule {
    fn record(&mut self, substeps: u32, asleep: bool, frame: u32) {
        if asleep {
            self.asleep += 1;
            self.first_asleep.get_or_insert(frame);
        } else {
            self.substeps.push(substeps);
        }
    }

    fn print(&self, bound: u32, frames: u32, awake_median_ms: f64) {
        let mut sorted = self.substeps.clone();
        sorted.sort_unstable();
        if let (Some(lo), Some(hi)) = (sorted.first(), sorted.last()) {
            let raised = sorted.iter().filter(|&&n| n > bound).count();
            println!(
                "substeps per awake frame: min {lo}, median {}, max {hi} (stability bound {bound}; raised for contact in {raised} frames)",
                sorted[sorted.len() / 2]
            );
        }
        match self.first_asleep {
            Some(first) => {
                let asleep_ms = drape::timing::median(&self.asleep_wall_ms);
                println!(
                    "sleeping: {} of {frames} frames ran nothing (first asleep at frame {first}); wall time of a \
                     sleeping frame: median {asleep_ms:.3} ms, {:.4}x an awake frame's median",
                    self.asleep,
                    asleep_ms / awake_median_ms
                )
            }
            None => println!("sleeping: the cloth never slept"),
        }
    }
}
