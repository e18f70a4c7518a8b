//! `drape`: runs a built-in scene on the GPU, prints per-kernel GPU timings, the LBVH build time,
//! the stability figures and the accuracy against the true mesh, and can write OBJ frames.

mod cli;

use cli::say;

use clap::{CommandFactory, FromArgMatches, ValueEnum};
use cli::args::{Args, ContactArg, HolesArg, IntegratorArg, OnOff, SceneArg, SearchArg, check_flags, check_outputs};
use cli::colliders::{Motion, SceneCollider, load_mesh, union_at};
use cli::pictures::Pictures;
use cli::progress::Progress;
use cli::report::{
    Rollbacks, Schedule, WorstIntersections, accuracy_json, cloth_description, intersections_json, print_accuracy,
    print_setup, stability_json, timings_json, write_json,
};
use drape::metrics::intersections::{count_intersections, particles_near_own_faces};
use drape::metrics::{TriangleBvh, accuracy_of_cloth};
use drape::scenes::DrapeScene;
use drape::timing::TimingReport;
use drape::{
    ClothBuilder, ClothMesh, Collider, ColliderShape, ContactSearch, Context, Integrator, Model, SimSettings, Solver,
    Validation,
};
use glam::Vec3;
use serde_json::json;
use std::process::ExitCode;
use std::time::Instant;

/// The library logs through `log`; the CLI prints its records to stderr. `DRAPE_LOG` sets the
/// level (error, warn, info, debug, trace; default warn).
struct StderrLogger;

impl log::Log for StderrLogger {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::max_level()
    }
    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            cli::progress::eprint_line(&format!("[{} {}] {}", record.level(), record.target(), record.args()));
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
    let (matches, colliders, file_flags) = match cli::scene_file::matches(std::env::args_os().collect()) {
        Ok(found) => found,
        // An unreadable scene file is a runtime error (exit 1), like an unreadable mesh.
        Err(e) if e.kind() == clap::error::ErrorKind::Io => {
            eprintln!("error: {}", e.to_string().trim_start_matches("error: ").lines().next().unwrap_or(""));
            return ExitCode::FAILURE;
        }
        Err(e) => e.exit(),
    };
    let mut args = Args::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    args.colliders = colliders;
    if let Err(problem) = check_flags(&args, &matches, &file_flags) {
        Args::command().error(clap::error::ErrorKind::ArgumentConflict, problem).exit();
    }
    if args.print_scene {
        match cli::scene_file::print(&args, &matches) {
            Ok(scene) => print!("{scene}"),
            Err(problem) => Args::command().error(clap::error::ErrorKind::InvalidUtf8, problem).exit(),
        }
        return ExitCode::SUCCESS;
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The cloth of `--cloth-mesh`, placed for `scene` (see the flag), and `pins` (the files'
/// vertex indices, the pieces' counted one after another) as its particles: with `weld`, a
/// vertex joined into an earlier one is pinned as that one.
fn mesh_cloth(
    paths: &[std::path::PathBuf],
    (weld, pins): (bool, &[u32]),
    scene: Option<&DrapeScene>,
) -> drape::Result<(ClothBuilder, Vec<u32>)> {
    let pieces = paths.iter().map(|p| ClothMesh::load_obj(p)).collect::<drape::Result<Vec<_>>>()?;
    let mut mesh = ClothMesh::join(&pieces);
    let mut pins = pins.to_vec();
    if weld {
        let map = mesh.weld_map();
        if let Some(&i) = pins.iter().find(|&&i| i as usize >= map.len()) {
            return Err(drape::Error::InvalidParameter {
                name: "--pin-vertices",
                problem: format!(
                    "vertex {i} does not exist: the --cloth-mesh files have {} vertices (counted from 0, before \
                     --weld joins any)",
                    map.len()
                ),
            });
        }
        pins = pins.iter().map(|&i| map[i as usize]).collect();
        let (welded, joined) = mesh.weld_coincident();
        say!("cloth mesh: --weld joined {joined} vertices into others ({} particles left)", welded.vertices.len());
        mesh = welded;
    }
    let builder = ClothBuilder::from_mesh(mesh.clone());
    let Some(s) = scene else {
        return Ok((builder, pins));
    };
    let (lo, hi) = drape::Mesh { vertices: mesh.vertices.clone(), triangles: mesh.triangles.clone() }.bounds();
    let (mesh_lo, mesh_hi) = s.mesh.bounds();
    let centre = 0.5 * (mesh_lo + mesh_hi);
    let shift = Vec3::new(centre.x - 0.5 * (lo.x + hi.x), mesh_hi.y + 0.05 - lo.y, centre.z - 0.5 * (lo.z + hi.z));
    Ok((builder.transform(glam::Mat4::from_translation(shift)), pins))
}

/// The `--piece-*` flags as each piece's material, by the library's piece index (from 0).
fn piece_materials(args: &Args) -> std::collections::BTreeMap<usize, drape::PieceMaterial> {
    let mut materials = std::collections::BTreeMap::<usize, drape::PieceMaterial>::new();
    for &(piece, k) in &args.piece_stiffness {
        materials.entry(piece - 1).or_default().stiffness = Some(k);
    }
    for &(piece, density) in &args.piece_density {
        materials.entry(piece - 1).or_default().density = Some(density);
    }
    materials
}

/// The pieces' own materials for the report: each piece that has one (numbered from 1, as
/// `--piece-stiffness` counts), its stiffness (N/m) and density (kg/m^2), null where it takes
/// the cloth's.
fn piece_materials_json(builder: &ClothBuilder) -> serde_json::Value {
    // As typed (0.4, not the f32's 0.4000000059604645 widened).
    let decimal = |x: f32| x.to_string().parse::<f64>().unwrap_or(x as f64);
    builder
        .own_piece_materials()
        .map(|(piece, m)| {
            json!({
                "piece": piece + 1,
                "stiffness_n_per_m": m.stiffness.map(|k| [decimal(k.x), decimal(k.y), decimal(k.z)]),
                "density_kg_per_m2": m.density.map(decimal),
            })
        })
        .collect()
}

fn run(args: &Args) -> drape::Result<()> {
    cli::set_quiet(args.quiet);
    check_outputs(args)?;
    let validation = if args.validate { Validation::Required } else { Validation::from_env() };
    let ctx = Context::new(validation)?;
    let info = ctx.info();
    say!("device: {} ({})", info.name, info.driver);
    let mut json = serde_json::Map::new();
    json.insert("device".into(), json!({ "name": info.name, "driver": info.driver }));
    json.insert("scene".into(), json!(format!("{:?}", args.scene).to_lowercase()));

    let mut scene = None;
    let builder = match args.scene {
        SceneArg::Swing => drape::scenes::swinging_cloth(args.grid).external_force(args.wind),
        SceneArg::Garment | SceneArg::Layers => {
            let s = match args.scene {
                SceneArg::Layers => drape::scenes::layered_garment(args.grid),
                _ => drape::scenes::garment(args.grid),
            };
            say!(
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
            say!("ground: a 6 m square plane of 2 triangles (open)");
            let builder = s.cloth.clone();
            scene = Some(s);
            builder
        }
        SceneArg::Drape => {
            let mesh = load_mesh(&args.mesh)?;
            let (lo, hi) = mesh.bounds();
            let across = (hi - lo).max_element();
            // The scene scales its mesh to its size: from nothing it would scale to nothing.
            if !across.is_normal() {
                return Err(drape::Error::InvalidParameter {
                    name: "--mesh",
                    problem: format!(
                        "{}: its vertices span {across:e} m, too little to scale to the scene's {} m: give the \
                         mesh in metres",
                        args.mesh,
                        drape::scenes::MESH_EXTENT
                    ),
                });
            }
            let mut s = DrapeScene::standard(&mesh, args.grid);
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
            say!(
                "mesh: {} ({topology}): {}",
                args.mesh,
                if boundary == 0 { "closed".to_string() } else { format!("open, {boundary} boundary edges") }
            );
            let builder = s.cloth.clone();
            scene = Some(s);
            builder
        }
    };
    let (builder, pins) = if args.cloth_mesh.is_empty() {
        (builder.listed_springs(args.listed_springs), args.pin_vertices.clone())
    } else {
        let wind = if args.scene == SceneArg::Swing { args.wind } else { Vec3::ZERO };
        let (builder, pins) = mesh_cloth(&args.cloth_mesh, (args.weld, &args.pin_vertices), scene.as_ref())?;
        (builder.external_force(wind), pins)
    };
    let builder = piece_materials(args).into_iter().fold(builder, |b, (piece, m)| b.piece_material(piece, m));
    let builder = pins.iter().fold(builder, |b, &i| b.pin_vertex(i));
    let builder = match args.pin_box {
        Some((lo, hi)) => builder.pin_within(lo, hi),
        None => builder,
    };
    let self_collision = cli::args::self_collision_on(args);
    let builder = builder.self_collision(self_collision.then_some(args.thickness)).self_friction(args.friction);
    let cloth_description = cloth_description(args, &builder);
    let builder = match args.velocity {
        Some(v) => builder.velocity(v),
        None => builder,
    };
    let pieces = piece_materials_json(&builder);
    let built = builder
        .stiffness(args.stiffness.x, args.stiffness.y, args.stiffness.z)
        .spring_damping(args.spring_damping)
        .build()
        .map_err(|e| match e {
            // The pins the builder found out of range are the flag's.
            drape::Error::InvalidParameter { name: "pins", problem } => {
                drape::Error::InvalidParameter { name: "--pin-vertices", problem }
            }
            e => e,
        })?;
    if built.positions.iter().all(|p| p.w == 0.0) {
        return Err(drape::Error::InvalidParameter {
            name: "--pin-vertices / --pin-box",
            problem: format!(
                "they pin all {} particles, so nothing would move: pin fewer (a box round an edge, a few vertices)",
                built.positions.len()
            ),
        });
    }
    let settings = SimSettings::default()
        .with_substeps(args.substeps)
        .with_integrator(match args.integrator {
            IntegratorArg::Rk4 => Integrator::Rk4,
            IntegratorArg::Euler => Integrator::SemiImplicitEuler,
        })
        .with_normals(!args.no_normals)
        .with_timestamps(!args.no_timestamps)
        .with_contact_substeps(args.contact_substeps == OnOff::On)
        .with_sleep((args.sleep > 0.0).then(|| drape::Sleep { speed: args.sleep, ..drape::Sleep::default() }))
        .with_tile_sleep(args.tile_sleep == OnOff::On)
        .with_self_failsafe(args.self_failsafe == OnOff::On)
        .with_self_list_windows(args.self_list_windows == OnOff::On)
        .with_crowded_contact(args.crowded_contact.forced())
        .with_feature_walks(args.feature_walks.walks())
        .with_one_workgroup_substeps(args.one_workgroup_substeps.forced());
    let search = match (args.brute_force, args.search) {
        (true, _) | (_, SearchArg::BruteForce) => ContactSearch::BruteForce,
        (_, SearchArg::Lists) => ContactSearch::CandidateLists,
        (_, SearchArg::Traverse) => ContactSearch::TraverseEverySubstep,
    };
    // The scene's own collider first, then the scene file's.
    let mut scene_colliders = Vec::new();
    if let Some(s) = &mut scene {
        s.thickness = args.thickness;
        s.friction = args.friction;
        let (name, motion) = match args.scene {
            SceneArg::Pile => ("ground", Motion::default()),
            SceneArg::Garment | SceneArg::Layers => {
                ("body", Motion { axis: Vec3::Y, spin_rate: drape::scenes::GARMENT_TURN_RATE, ..Motion::default() })
            }
            _ => ("collider", Motion::default()),
        };
        scene_colliders.push(SceneCollider { name: name.into(), mesh: s.mesh.clone(), motion, sequence: None });
    }
    for (i, table) in args.colliders.iter().enumerate() {
        let file = args.scene_file.as_deref().unwrap_or(std::path::Path::new("")).display();
        scene_colliders.push(table.build(i).map_err(|e| drape::Error::InvalidParameter {
            name: "[[collider]]",
            problem: format!("scene file {file}, [[collider]] number {}: {e}", i + 1),
        })?);
    }
    let mut colliders = Vec::new();
    for sc in &scene_colliders {
        if sc.sequence.is_some() && args.contact == ContactArg::Spheres {
            return Err(drape::Error::InvalidParameter {
                name: "mesh-sequence",
                problem: format!(
                    "{}: a mesh sequence deforms the collider's triangles, which `--contact spheres` does not \
                     collide with: use `--contact triangles`",
                    sc.name
                ),
            });
        }
        let start = Instant::now();
        let c = match args.contact {
            ContactArg::Spheres => {
                Collider::new(drape::collider::voxel_spheres(&sc.mesh, args.voxels)?, args.thickness)
                    .with_friction(args.friction)
            }
            ContactArg::Triangles => Collider::mesh(&sc.mesh, args.thickness).with_friction(args.friction),
        }
        .with_search(search);
        let leaves = match args.contact {
            ContactArg::Spheres => format!("{n}^3 voxels -> {} spheres", c.spheres().len(), n = args.voxels),
            ContactArg::Triangles => format!("{} triangle leaves", c.leaf_count()),
        };
        let name = match (args.scene, sc.name.as_str()) {
            (SceneArg::Drape, "collider") => args.mesh.as_str(),
            (_, name) => name,
        };
        let moving = if sc.motion.is_static() { String::new() } else { format!(", {}", sc.motion.describe()) };
        let moving = match &sc.sequence {
            Some(sequence) => format!("{moving}, deforming through {} ...", sequence.path(0).display()),
            None => moving,
        };
        say!(
            "collider: {name} ({} vertices, {} triangles), {leaves} in {:.1} ms (CPU){moving}",
            sc.mesh.vertices.len(),
            sc.mesh.triangles.len(),
            start.elapsed().as_secs_f64() * 1e3,
        );
        colliders.push(c);
    }
    let model = Model::single(&built, &colliders, settings)?;
    let cloth = model.first_cloth();
    let mut sim = Solver::new(&ctx, &model)?;
    print_setup(args, &cloth_description, &sim, cloth, &settings)?;
    json.insert(
        "cloth".into(),
        json!({
            "description": cloth_description,
            "particles": built.particle_count(),
            "triangles": built.triangles.len(),
            "piece_materials": pieces,
        }),
    );
    json.insert("integrator".into(), json!(format!("{:?}", settings.integrator)));
    json.insert("stability".into(), stability_json(sim.stability(cloth)?));
    json.insert("frames".into(), json!(args.frames));
    say!("GPU memory ({} barriers per frame):\n{}", sim.barriers_per_frame(), sim.memory_report());
    if let Some(t) = sim.lbvh_timings() {
        json.insert("lbvh_build_gpu_ms".into(), json!(t.total_micros() / 1e3));
        say!("LBVH build on the GPU: {:.3} ms", t.total_micros() / 1e3);
        for (label, n, micros) in t.by_label() {
            say!("  {label:<16} {n:>3} dispatches {micros:>10.1} µs");
        }
    }
    if let Some(dir) = &args.obj_dir {
        std::fs::create_dir_all(dir).map_err(|source| drape::Error::Io { path: dir.clone(), source })?;
        for sc in &scene_colliders {
            drape::obj::write_mesh_obj(&dir.join(format!("{}.obj", sc.name)), &sc.mesh)?;
        }
    }

    let mut usd = match &args.usd {
        Some(path) => {
            let mut cache = drape::usd::UsdCache::create(path, &built, args.frames)?;
            for sc in &scene_colliders {
                cache.add_collider(&sc.name, &sc.mesh);
            }
            Some(cache)
        }
        None => None,
    };
    let mut pictures = match &args.png_dir {
        Some(dir) => {
            let meshes: Vec<_> = scene_colliders.iter().map(|c| &c.mesh).collect();
            Some(Pictures::new(&ctx, dir, args.png_every, args.png_size, &built.positions, &meshes)?)
        }
        None => None,
    };
    // The fail-safe undoes the crossings a frame makes, not those the cloth starts with: say so.
    let solid = union_at(&scene_colliders, 0.0);
    let at_start = count_intersections(&built.positions, &built.triangles, (&solid.vertices, &solid.triangles));
    if at_start.total() > 0 {
        log::warn!(
            "the cloth starts crossed: {} pairs of its triangles through each other, {} of its edges through a \
             collider, {} collider edges through it. No frame undoes a crossing it did not make (the fail-safe keeps \
             those particles where they are): untangle the cloth mesh or move the cloth clear of the colliders",
            at_start.cloth_cloth,
            at_start.cloth_edges_through_collider,
            at_start.collider_edges_through_cloth
        );
    }
    if let Some(thickness) = built.self_collision
        && let Some(near) = particles_near_own_faces(&built.positions, &built.triangles, thickness)
        && near > 0
    {
        log::warn!(
            "the cloth starts with {near} particles within its self-collision thickness ({:.1} mm) of its own \
                 faces: its first passes push those layers apart, and layers that lie exactly on each other have no \
                 side to go to and may come out crossed; lay them at least the thickness apart",
            1e3 * thickness
        );
    }
    let mut worst = WorstIntersections::default();
    let mut report = TimingReport::default();
    let (mut ran, mut skipped, mut fallbacks, mut crowded, mut handed_over) = (0, 0, 0u64, 0u64, 0u64);
    let (mut self_walks, mut self_triangle_passes, mut self_unlisted) = (0u64, 0u64, 0u64);
    let mut features_from_cloth = 0u64;
    let mut features_out_of_reach = 0u64;
    let mut rollbacks = Rollbacks::default();
    let collider_ids: Vec<_> = model.collider_ids().collect();
    let frame_dt = sim.settings().frame_dt;
    let mut schedule = Schedule::default();
    let progress = Progress::new(args.frames);
    for frame in 1..=args.frames {
        // Where each collider stands at the end of this frame (it sweeps there over the frame).
        let t = frame as f32 * frame_dt;
        let poses: Vec<_> = scene_colliders.iter().map(|c| c.motion.pose(t)).collect();
        let mut deformed = Vec::new();
        for (i, ((id, sc), &(rotation, translation))) in
            collider_ids.iter().zip(&mut scene_colliders).zip(&poses).enumerate()
        {
            if !sc.motion.is_static() {
                sim.set_collider_pose(*id, rotation, translation)?;
            }
            if sc.advance(frame, frame_dt)? {
                sim.set_collider_vertices(*id, &sc.mesh.vertices)?;
                deformed.push(i);
            }
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
            schedule.record_tiles(r.tiles_asleep, r.tiles, frame);
        }
        ran += r.collision_ran;
        skipped += r.collision_skipped;
        fallbacks += u64::from(r.collision_fallbacks);
        crowded += u64::from(r.crowded_contacts);
        handed_over += u64::from(r.collision_crowded);
        self_walks += u64::from(r.self_walks);
        self_triangle_passes += u64::from(r.self_triangle_passes);
        self_unlisted += u64::from(r.self_passes_without_lists);
        features_from_cloth += u64::from(r.feature_walks_from_cloth);
        features_out_of_reach += u64::from(r.collider_features_out_of_reach);
        rollbacks.record(&r, frame);
        progress.set(frame);
        // Every n-th frame and the last, as the pictures (a run shorter than n still gets one).
        let write_this = frame == args.frames || args.obj_every.is_some_and(|n| frame.is_multiple_of(n));
        if let (Some(dir), true) = (&args.obj_dir, write_this) {
            let path = dir.join(format!("frame_{frame:05}.obj"));
            drape::obj::write_cloth_obj(&path, &built, &sim.positions(cloth)?, &sim.normals(cloth)?)?;
        }
        if let Some(cache) = &mut usd {
            cache.frame(frame, &sim.positions(cloth)?)?;
            for (i, (sc, &(rotation, translation))) in scene_colliders.iter().zip(&poses).enumerate() {
                if !sc.motion.is_static() {
                    cache.collider_pose(i, frame, rotation, translation);
                }
                if deformed.contains(&i) {
                    cache.collider_points(i, frame, &sc.mesh.vertices);
                }
            }
        }
        if let Some(p) = &mut pictures {
            let rigid: Vec<_> = poses.iter().map(|&(r, t)| drape::rigid_pose(r, t)).collect();
            let deforming: Vec<_> = scene_colliders
                .iter()
                .enumerate()
                .filter(|(_, c)| c.sequence.is_some())
                .map(|(i, c)| (i, &c.mesh))
                .collect();
            p.frame(frame, args.frames, (&sim, cloth), &rigid, &deforming)?;
        }
        if args.check_every_frame {
            let solid = union_at(&scene_colliders, t);
            let found =
                count_intersections(&sim.positions(cloth)?, &built.triangles, (&solid.vertices, &solid.triangles));
            worst.record(frame, found);
        }
    }
    drop(progress);
    if let Some(p) = &pictures {
        say!(
            "pictures: {} PNG files in {}",
            p.written.len(),
            args.png_dir.as_deref().unwrap_or(std::path::Path::new("")).display()
        );
        json.insert("pictures".into(), json!(p.written.iter().map(|w| w.display().to_string()).collect::<Vec<_>>()));
    }
    if let Some(cache) = usd {
        cache.finish().map_err(|e| drape::Error::InvalidParameter {
            name: "--usd",
            problem: format!("the USD cache could not be written: {e}"),
        })?;
    }
    if args.no_timestamps {
        say!(
            "\nGPU timestamps off (--no-timestamps): wall time per frame over {} frames: median {:.3} ms, min {:.3} ms",
            report.frames(),
            report.median_wall_ms(),
            report.min_wall_ms()
        );
    } else {
        say!("\nGPU time per kernel (timestamp queries, median over frames):");
        say!("{}", report.table().trim_end());
    }
    let bound_substeps = sim.stability(cloth)?.bound_substeps;
    schedule.print(bound_substeps, args.frames, report.median_wall_ms());
    json.insert("timings".into(), timings_json(&report, !args.no_timestamps));
    json.insert("schedule".into(), schedule.json(bound_substeps));
    if self_triangle_passes > 0 {
        json.insert(
            "self_collision_pairs".into(),
            json!({
                "triangle_passes": self_triangle_passes,
                "walked_the_tree": self_walks,
                "without_lists": self_unlisted
            }),
        );
        if self_unlisted == self_triangle_passes {
            say!(
                "self-collision pair lists: none (the cloth's shortest triangle is under twice the thickness high, so \
                 each list would hold its neighbours): all {self_triangle_passes} triangle-passes walked the tree"
            );
        } else {
            let unlisted = if self_unlisted > 0 {
                format!(", {self_unlisted} of them in frames without lists")
            } else {
                String::new()
            };
            say!(
                "self-collision pair lists: {self_walks} of {self_triangle_passes} triangle-passes walked the tree \
                 instead ({:.2} %: left their predicted region, or their list was full{unlisted})",
                100.0 * self_walks as f64 / self_triangle_passes as f64
            );
        }
        let triangle_colliders =
            colliders.iter().filter(|c| matches!(c.shape, ColliderShape::Triangles { .. })).count();
        if triangle_colliders > 0 {
            let collider_frames = triangle_colliders as u64 * u64::from(args.frames);
            json.insert(
                "collider_feature_walks".into(),
                json!({
                    "from_the_cloth": features_from_cloth,
                    "collider_frames": collider_frames,
                    "out_of_reach": features_out_of_reach,
                }),
            );
            say!(
                "self-collision collider vertices + edges: walked from the cloth's side in {features_from_cloth} of \
                 {collider_frames} collider-frames (--feature-walks {}: the cloth's side when a collider lists over \
                 {} possibly sharp triangles per cloth triangle)",
                args.feature_walks.to_possible_value().map_or(String::new(), |v| v.get_name().to_owned()),
                drape_kernels::feature_walks::CLOTH_SIDE_RATIO
            );
            say!(
                "self-collision collider vertices + edges: {features_out_of_reach} listed triangle-spans out of the \
                 cloth's reach (walked only by the cloth triangles that left their predicted regions)"
            );
        }
        json.insert("self_collision_failsafe".into(), rollbacks.json());
        say!("{}", rollbacks.line(args.frames, args.self_failsafe == OnOff::On));
    }
    if let Some(c) = colliders.first() {
        json.insert(
            "collision".into(),
            json!({
                "substeps_run": ran,
                "substeps_culled": skipped,
                "candidate_list_fallbacks": fallbacks,
                "crowded_particle_substeps": crowded,
                "crowded_handed_to_workgroups": handed_over,
            }),
        );
        if c.search == ContactSearch::CandidateLists {
            // The narrow phase runs in every substep (inside the last integration stage): a
            // particle that left its query box walks the tree even when none was listed.
            say!(
                "collision: particles listed near the collider in {ran} substeps, none in {skipped} (there only \
                 particles that left their query box walk the tree)"
            );
            let particle_substeps = u64::from(ran + skipped) * built.particle_count() as u64;
            say!(
                "candidate lists: {fallbacks} of {particle_substeps} particle-substeps fell back to a full walk ({:.2} %)",
                100.0 * fallbacks as f64 / particle_substeps.max(1) as f64
            );
            let choice = match sim.settings().crowded_contact {
                Some(true) => "--crowded-contact on",
                Some(false) => "off: not counted",
                None if sim.settings().device_is_gpu() => "automatic: while a frame has many",
                None => "automatic: never on a CPU driver",
            };
            say!(
                "crowded particles ({} leaves or more, or a walk): {crowded} particle-substeps, {handed_over} of \
                 them handed to a workgroup each ({choice})",
                drape_kernels::crowded::CROWDED_LIST,
            );
        } else {
            say!("collision traversal: ran in {ran} substeps, culled (cloth cannot touch) in {skipped}");
        }
    }
    let x = sim.positions(cloth)?;
    // The metrics see every collider where it stands now (a moving one has moved).
    let t_end = args.frames as f32 * frame_dt;
    let solid = union_at(&scene_colliders, t_end);
    if !scene_colliders.is_empty() {
        let start = Instant::now();
        let bvh = TriangleBvh::new(&solid);
        let spheres = (args.contact == ContactArg::Spheres).then(|| posed_spheres(&colliders, &scene_colliders, t_end));
        let a = accuracy_of_cloth(&bvh, spheres.as_deref(), args.thickness, &built.structural_springs(), &x);
        print_accuracy(&a, args.frames, start.elapsed().as_secs_f64());
        json.insert("accuracy".into(), accuracy_json(&a));
    }
    let lowest = x.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    json.insert("lowest_particle_y_m".into(), json!(lowest));
    say!("final: lowest particle at y = {lowest:.3} m after {} frames", sim.frames_done());
    if args.check_every_frame {
        json.insert("intersections_every_frame".into(), worst.json());
        say!(
            "intersections (exact, every frame): frames with any {} of {}{}; worst frames: cloth-cloth {} (frame {}), \
             cloth edges through the collider {} (frame {}), collider edges through the cloth {} (frame {})",
            worst.frames_with_any,
            args.frames,
            worst.first_frame.map_or(String::new(), |f| format!(" (the first: frame {f})")),
            worst.cloth_cloth.0,
            worst.cloth_cloth.1,
            worst.cloth_edges.0,
            worst.cloth_edges.1,
            worst.collider_edges.0,
            worst.collider_edges.1
        );
    }
    let start = Instant::now();
    let found = count_intersections(&x, &built.triangles, (&solid.vertices, &solid.triangles));
    say!(
        "intersections (exact, final frame, {:.2} s on the CPU): cloth-cloth {}, cloth edges through the collider {}, \
         collider edges through the cloth {}",
        start.elapsed().as_secs_f64(),
        found.cloth_cloth,
        found.cloth_edges_through_collider,
        found.collider_edges_through_cloth
    );
    json.insert("intersections_final_frame".into(), intersections_json(&found));
    ctx.check_validation()?;
    if let Some(path) = &args.json {
        write_json(path, json)?;
    }
    Ok(())
}

/// Every collider's spheres where it stands at time `t`.
fn posed_spheres(colliders: &[Collider], scene_colliders: &[SceneCollider], t: f32) -> Vec<glam::Vec4> {
    let mut all = Vec::new();
    for (c, sc) in colliders.iter().zip(scene_colliders) {
        let (rotation, translation) = sc.motion.pose(t);
        all.extend(c.spheres().iter().map(|s| (rotation * s.truncate() + translation).extend(s.w)));
    }
    all
}
