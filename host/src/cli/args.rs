//! The command line: flags, their parsers and range checks, and the checks across flags.

use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory, Parser, ValueEnum};
use drape::scenes::SETTLE_FRAMES;
use glam::Vec3;
use std::path::PathBuf;

#[derive(Copy, Clone, Debug, ValueEnum, PartialEq)]
pub(crate) enum SceneArg {
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
    /// The garment scene with an overskirt around the skirt: a piece of the same cloth of its
    /// own material (four times as stiff, twice as heavy), kept apart from the skirt by the
    /// cloth's self-collision.
    Layers,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum ContactArg {
    /// The paper's proxy: one sphere per non-empty voxel (`--voxels`).
    Spheres,
    /// The mesh's own triangles.
    Triangles,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum SearchArg {
    /// A broad phase once per frame gives each particle a short list of nearby leaves; each
    /// substep tests only the list (a particle that leaves its query box walks the LBVH).
    Lists,
    /// Walk the LBVH every substep.
    Traverse,
    /// Test every leaf every substep (the baseline).
    BruteForce,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum HolesArg {
    /// Fill holes up to half the mesh's bounds diagonal in perimeter (a scan's, like the
    /// bunny's base) so the collider is the solid the mesh depicts; larger openings stay open.
    Close,
    /// Collide with the triangles exactly as given (the cloth can pass through holes).
    Keep,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum OnOff {
    On,
    Off,
}

/// A choice drape can make for the device, or a forced one.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum AutoOnOff {
    Auto,
    On,
    Off,
}

impl AutoOnOff {
    /// `None` for automatic.
    pub(crate) fn forced(self) -> Option<bool> {
        match self {
            AutoOnOff::Auto => None,
            AutoOnOff::On => Some(true),
            AutoOnOff::Off => Some(false),
        }
    }
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum FeatureWalksArg {
    Auto,
    Collider,
    Cloth,
}

impl FeatureWalksArg {
    pub(crate) fn walks(self) -> drape::FeatureWalks {
        match self {
            FeatureWalksArg::Auto => drape::FeatureWalks::Automatic,
            FeatureWalksArg::Collider => drape::FeatureWalks::FromCollider,
            FeatureWalksArg::Cloth => drape::FeatureWalks::FromCloth,
        }
    }
}

#[derive(Copy, Clone, Debug, ValueEnum)]
pub(crate) enum IntegratorArg {
    Rk4,
    Euler,
}

/// Simulate a scene: by default a 64x64 cloth falling onto a procedural icosphere for 2 s.
#[derive(Parser, Debug)]
#[command(name = "drape", version, about)]
pub(crate) struct Args {
    #[arg(long, value_enum, default_value = "drape")]
    pub(crate) scene: SceneArg,
    /// Read the flags from a TOML scene file (`key = value`, the keys being the long flags'
    /// names, e.g. `grid = 64`, `wind = [-1, 0, 0]`); flags on the command line override it.
    /// Examples in scenes/.
    #[arg(long, value_name = "FILE.toml")]
    pub(crate) scene_file: Option<PathBuf>,
    /// Print the effective scene (scene file, flags and defaults) as a scene file and exit.
    #[arg(long)]
    pub(crate) print_scene: bool,
    /// Collider mesh: icosphere, torus, plane (a 6 m ground), bunny, dragon (from ../shared/models)
    /// or an OBJ path.
    #[arg(long, default_value = "icosphere")]
    pub(crate) mesh: String,
    /// What the cloth collides with: the mesh's triangles or the paper's voxel spheres.
    #[arg(long, value_enum, default_value = "triangles")]
    pub(crate) contact: ContactArg,
    /// The collider mesh's small holes: closed (default) or kept as given.
    #[arg(long, value_enum, default_value = "close")]
    pub(crate) holes: HolesArg,
    /// Collider voxels per axis (one sphere per non-empty voxel; `--contact spheres`).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub(crate) voxels: u32,
    /// Contact thickness (m), in [0.0001, 0.5]: kept from the colliders and, with
    /// `--self-collision on`, by the cloth from itself.
    #[arg(long, default_value_t = drape::scenes::DEFAULT_THICKNESS, value_parser = parse_thickness, allow_hyphen_values = true)]
    pub(crate) thickness: f32,
    /// Coulomb friction coefficient of the contact, in [0, 10] (0 = the paper's frictionless
    /// response): with the colliders and, with `--self-collision on`, between the cloth's
    /// layers.
    #[arg(long, default_value_t = drape::scenes::DEFAULT_FRICTION, value_parser = parse_friction, allow_hyphen_values = true)]
    pub(crate) friction: f32,
    /// How contact finds the leaves each particle touches (same contacts, different cost).
    #[arg(long, value_enum, default_value = "lists")]
    pub(crate) search: SearchArg,
    /// Test every leaf (sphere or triangle) instead of traversing the LBVH (baseline; the same
    /// as `--search brute-force`).
    #[arg(long, conflicts_with = "search")]
    pub(crate) brute_force: bool,
    /// Particles per side (rows = cols), 2..=2048.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(2..=2048))]
    pub(crate) grid: u32,
    /// The cloth from a triangle mesh (OBJ): one particle per vertex in the file's order, springs
    /// on its edges and across them, UVs kept. In the drape scene it is centred over the
    /// collider, its lowest point 5 cm above the top; in the swing scene it stays where the
    /// file puts it. Given again, the files are pieces of one cloth (a skirt and a coat, two
    /// sheets): their vertices follow one another in the order given (pin indices count that
    /// way), and with --self-collision on the pieces keep apart as the cloth does from itself.
    #[arg(long, conflicts_with = "grid", action = clap::ArgAction::Append)]
    pub(crate) cloth_mesh: Vec<PathBuf>,
    /// A `--cloth-mesh` piece's own stiffness (N/m) as PIECE=K_STRUCT,K_SHEAR,K_BEND, PIECE
    /// counting the --cloth-mesh files from 1, e.g. `--piece-stiffness 2=160,0,8` for a coat
    /// four times as stiff as the shirt under it (K_SHEAR 0: a mesh cloth has no shear springs);
    /// given once per piece. The piece's springs take
    /// it as a multiple of --stiffness (so their damping scales with it, and a family the cloth
    /// has at 0 cannot be given); the other pieces keep --stiffness.
    #[arg(long, action = clap::ArgAction::Append, value_parser = parse_piece_stiffness, value_name = "PIECE=K_STRUCT,K_SHEAR,K_BEND")]
    pub(crate) piece_stiffness: Vec<(usize, Vec3)>,
    /// A `--cloth-mesh` piece's own areal density (kg/m^2) as PIECE=DENSITY, PIECE counting the
    /// --cloth-mesh files from 1, e.g. `--piece-density 2=0.4` (a heavy coat), in [0.001, 1000];
    /// given once per piece. The other pieces weigh 0.2 kg/m^2.
    #[arg(long, action = clap::ArgAction::Append, value_parser = parse_piece_density, value_name = "PIECE=DENSITY")]
    pub(crate) piece_density: Vec<(usize, f32)>,
    /// Join the `--cloth-mesh` vertices that lie at exactly the same position, as a file split
    /// at UV or normal seams has them (many exporters write one vertex per UV): without it the
    /// cloth comes apart along those seams (drape warns). The particles are then the joined
    /// vertices in the file's order, the first of each set kept; UVs stay per corner.
    #[arg(long)]
    pub(crate) weld: bool,
    /// Pin these particles (vertex indices, comma separated; a grid's are row * cols + col; a
    /// --cloth-mesh's count the files' vertices from 0, before --weld joins any).
    #[arg(long, value_delimiter = ',')]
    pub(crate) pin_vertices: Vec<u32>,
    /// Pin every particle inside this box, given as MIN_X,MIN_Y,MIN_Z,MAX_X,MAX_Y,MAX_Z in the
    /// cloth's own coordinates (a mesh's file coordinates), e.g. `--pin-box=-1,0.9,-1,1,1,1`.
    #[arg(long, value_parser = parse_box, allow_hyphen_values = true)]
    pub(crate) pin_box: Option<(Vec3, Vec3)>,
    /// Self-collision: the cloth keeps `--thickness` from itself (vertex against triangle, edge
    /// against edge), and from a triangle collider's vertices and edges (so no spike or ridge
    /// cuts a cell between particles). Default: on in every scene (off: the cloth passes through
    /// itself where it folds, as the paper's cloth does, at a fraction of the cost).
    #[arg(long, value_enum)]
    pub(crate) self_collision: Option<OnOff>,
    /// Build the grid with listed springs (the kernels of mesh cloths) instead of its fast path:
    /// the same cloth, to measure one path against the other.
    #[arg(long, conflicts_with = "cloth_mesh")]
    pub(crate) listed_springs: bool,
    /// Put the cloth to sleep (its frames run nothing until something wakes it) once its fastest
    /// particle has moved slower than this (m/s) for 30 frames, in [0, 10]; 0 = never.
    #[arg(long, default_value_t = drape::Sleep::default().speed, value_parser = parse_sleep, allow_hyphen_values = true)]
    pub(crate) sleep: f32,
    /// Let parts of the cloth sleep on their own (tiles of 64 particles, under `--sleep`'s
    /// speed and 30 frames) while the rest of it moves.
    #[arg(long, value_enum, default_value = "on")]
    pub(crate) tile_sleep: OnOff,
    /// With `--self-collision on`, end each frame by checking the cloth for triangles that
    /// intersect each other or a collider's sharp triangles (and did not at the frame's start)
    /// and put their particles back where the frame started, so no frame ends with the cloth
    /// through itself or a spike through the cloth (off: the passes alone, for comparison).
    #[arg(long, value_enum, default_value = "on")]
    pub(crate) self_failsafe: OnOff,
    /// With `--self-collision on`, build the pair lists of a cloth that outruns them again
    /// halfway through a frame (once a fifth of a frame's triangles walked the tree, having left
    /// the regions the lists predicted): the same pairs, fewer walks (off: once per frame, for
    /// comparison).
    #[arg(long, value_enum, default_value = "on")]
    pub(crate) self_list_windows: OnOff,
    /// Raise automatic substeps so no particle moves more than the contact thickness per
    /// substep (from the last frame's fastest particle and the colliders' motion; for
    /// self-collision, from its fastest pair of primitives that may touch, to at most twice the
    /// stability bound's substeps; and while a collider vertex pushes a cloth face more than
    /// the thickness in a pass, as a spike's tip holding the cloth does, or a triangle collider
    /// moves, its edges finding the cloth's by proximity, to at most 4 times),
    /// and run self-collision only as many passes per frame as that needs (off: one per
    /// substep).
    #[arg(long, value_enum, default_value = "on")]
    pub(crate) contact_substeps: OnOff,
    /// Hand each substep's crowded particles (those with 8 or more collider leaves to test, or
    /// a walk of the tree) to a pass that runs a workgroup per particle, its lanes sharing the
    /// tests: the same contacts, bit for bit (auto: on a GPU while a frame has many, 64 a
    /// substep, until it has few, 16; never on a CPU driver such as lavapipe, where a
    /// workgroup's lanes run one after another).
    #[arg(long, value_enum, default_value = "auto")]
    pub(crate) crowded_contact: AutoOnOff,
    /// With `--self-collision on`, which side walks each pass's collider vertices and edges
    /// against the cloth: each sharp collider triangle walks the cloth's tree, or each cloth
    /// triangle walks the collider's. The same frames, bit for bit (auto: frame by frame, the
    /// cloth's side when the collider lists more than 4 sharp triangles per cloth triangle, as a
    /// scanned collider does).
    #[arg(long, value_enum, default_value = "auto")]
    pub(crate) feature_walks: FeatureWalksArg,
    /// Run a frame's substeps in one workgroup, one dispatch for the frame, when nothing runs
    /// between their stages (no collider, no self-collision): the same frame, bit for bit on
    /// lavapipe (auto: on a GPU for a cloth of at most 1024 particles, where a dispatch costs
    /// more than a stage's arithmetic on one multiprocessor, if its workgroups hold 1024
    /// invocations; never on a CPU driver, where a workgroup runs on one core).
    #[arg(long, value_enum, default_value = "auto")]
    pub(crate) one_workgroup_substeps: AutoOnOff,
    /// Print nothing on stdout and draw no progress bar (errors and warnings still go to
    /// stderr; `--json` still writes its report).
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Write the cloth's animation as a USD cache (`.usda`, every frame; Blender and Houdini
    /// import it without add-ons): the cloth's points per frame, its triangles and UVs, and the
    /// collider with its pose per frame. Checked writable before any work.
    #[arg(long, value_name = "FILE.usda")]
    pub(crate) usd: Option<PathBuf>,
    /// Write the run's report as JSON to this file (setup, stability, substeps and sleep,
    /// per-pass GPU timings, wall times, collision counters, accuracy, intersections, and each
    /// awake frame's wall time, GPU span and substeps), for scripts and CI dashboards. Checked
    /// writable before any work.
    #[arg(long, value_name = "FILE")]
    pub(crate) json: Option<PathBuf>,
    /// Frames to simulate (1/60 s each).
    #[arg(long, default_value_t = SETTLE_FRAMES, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) frames: u32,
    /// Substeps per frame, 1..=100000; default: automatic from the stability bound.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub(crate) substeps: Option<u32>,
    /// Time integrator.
    #[arg(long, value_enum, default_value = "rk4")]
    pub(crate) integrator: IntegratorArg,
    /// Structural, shear and bend stiffness (N/m) as K_STRUCT,K_SHEAR,K_BEND, each in
    /// [0, 1e6]. A `--cloth-mesh` has structural and bend springs only, each structural one
    /// scaled by the area of its edge's triangles over its squared length (1 on a square grid's
    /// inner sides), so the mesh is one material whatever its triangles' shapes (its K_SHEAR
    /// does nothing).
    #[arg(long, value_parser = parse_stiffness, default_value = "40,10,2")]
    pub(crate) stiffness: Vec3,
    /// Damping along spring axes (N s/m), in [0, 100].
    #[arg(long, default_value_t = 0.002, value_parser = parse_spring_damping, allow_hyphen_values = true)]
    pub(crate) spring_damping: f32,
    /// Wind: constant force on the whole cloth (N) as X,Y,Z, e.g. `--wind -1,0,0` (swing
    /// scene).
    #[arg(long, value_parser = parse_wind, allow_hyphen_values = true, default_value = "0.3,0,0.5")]
    pub(crate) wind: Vec3,
    /// The cloth's initial velocity (m/s) as X,Y,Z, e.g. `--velocity=0,-10,0` (a throw), at most
    /// 1000 m/s.
    #[arg(long, value_parser = parse_velocity, allow_hyphen_values = true)]
    pub(crate) velocity: Option<Vec3>,
    /// Skip vertex normals.
    #[arg(long)]
    pub(crate) no_normals: bool,
    /// Write frames as OBJ into this directory (the final frame unless --obj-every is given).
    #[arg(long)]
    pub(crate) obj_dir: Option<PathBuf>,
    /// Write every n-th frame, and the last (with --obj-dir).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) obj_every: Option<u32>,
    /// Draw frames as PNG pictures into this directory (offscreen Vulkan: the shaded cloth and
    /// collider from a fixed camera framing the scene; the final frame unless --png-every is
    /// given). Checked writable before any work.
    #[arg(long, value_name = "DIR")]
    pub(crate) png_dir: Option<PathBuf>,
    /// Draw every n-th frame, and the last (with --png-dir).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) png_every: Option<u32>,
    /// Picture size in pixels as WIDTHxHEIGHT, each 16..=4096 (with --png-dir).
    #[arg(long, value_parser = parse_size, default_value = "640x480", value_name = "WxH")]
    pub(crate) png_size: (u32, u32),
    /// Count the exact intersections after every frame (not only the last) and report the
    /// worst frame of each kind.
    #[arg(long)]
    pub(crate) check_every_frame: bool,
    /// Skip GPU timestamp queries (they cost tens of µs per pass on lavapipe).
    #[arg(long)]
    pub(crate) no_timestamps: bool,
    /// Load the Vulkan validation layer (also: DRAPE_VALIDATION=1).
    #[arg(long)]
    pub(crate) validate: bool,
    /// Colliders a scene file adds (`[[collider]]` tables), after the scene's own.
    #[arg(skip)]
    pub(crate) colliders: Vec<super::colliders::ColliderTable>,
}

/// Whether the user typed `id` (not its default).
pub(crate) fn given(matches: &ArgMatches, id: &str) -> bool {
    matches.value_source(id) == Some(ValueSource::CommandLine)
}

/// Flags a scene or mode would silently ignore are usage errors naming both.
pub(crate) fn check_flags(
    args: &Args,
    matches: &ArgMatches,
    file: &super::scene_file::FileFlags,
) -> Result<(), String> {
    for arg in Args::command().get_arguments() {
        let id = arg.get_id().as_str();
        if given(matches, id)
            && let Some(reason) = unused(args, id)
        {
            return Err(format!("{reason}{}", file.origin(id)));
        }
    }
    check_pieces(args)?;
    check_paths_apart(args)?;
    if matches!(args.scene, SceneArg::Garment | SceneArg::Layers) && args.cloth_mesh.is_empty() && args.grid < 8 {
        return Err(format!(
            "--grid {} is too few particles around the {:?} scene's skirt: give 8 or more",
            args.grid, args.scene
        )
        .to_lowercase());
    }
    // The strip is a quarter of its length across, at least 2 particles: under 8 it would be
    // narrower than asked.
    if args.scene == SceneArg::Pile && args.cloth_mesh.is_empty() && args.grid < 8 {
        return Err(format!(
            "--grid {} is too few particles along the pile scene's strip (it is a quarter of that across): give 8 \
             or more",
            args.grid
        ));
    }
    if args.obj_every.is_some() && args.obj_dir.is_none() {
        return Err("--obj-every needs --obj-dir (the directory to write the frames into)".into());
    }
    if args.png_dir.is_some() && args.no_normals {
        return Err("--png-dir shades the cloth with its vertex normals, which --no-normals skips: drop one".into());
    }
    Ok(())
}

/// No file the run writes (`--json`, `--usd`) is one it reads or the other output: it would be
/// overwritten, an input before it is read.
fn check_paths_apart(args: &Args) -> Result<(), String> {
    use std::path::{Path, PathBuf};
    let mut inputs: Vec<(&str, PathBuf)> = args.cloth_mesh.iter().map(|p| ("--cloth-mesh", p.clone())).collect();
    inputs.extend(args.scene_file.iter().map(|p| ("--scene-file", p.clone())));
    if Path::new(&args.mesh).is_file() {
        inputs.push(("--mesh", PathBuf::from(&args.mesh)));
    }
    for table in &args.colliders {
        if Path::new(&table.mesh).is_file() {
            inputs.push(("a [[collider]] table's mesh", PathBuf::from(&table.mesh)));
        }
    }
    let outputs: Vec<(&str, &PathBuf)> = [("--json", &args.json), ("--usd", &args.usd)]
        .into_iter()
        .filter_map(|(n, p)| Some((n, p.as_ref()?)))
        .collect();
    for (k, &(flag, out)) in outputs.iter().enumerate() {
        if let Some((input, _)) = inputs.iter().find(|(_, p)| same_path(out, p)) {
            return Err(format!(
                "{flag} {} is the file {input} reads: the run would overwrite it; give {flag} another path",
                out.display()
            ));
        }
        if let Some((other, _)) = outputs[k + 1..].iter().find(|(_, p)| same_path(out, p)) {
            return Err(format!("{flag} and {other} both write {}: give each its own file", out.display()));
        }
    }
    Ok(())
}

/// Whether two paths name the same file: by their canonical forms when both exist, else by
/// their absolute forms.
fn same_path(a: &std::path::Path, b: &std::path::Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => matches!((std::path::absolute(a), std::path::absolute(b)), (Ok(a), Ok(b)) if a == b),
    }
}

/// Each `--piece-*` flag names one of the --cloth-mesh files, once.
fn check_pieces(args: &Args) -> Result<(), String> {
    let files = args.cloth_mesh.len();
    let named = [
        ("--piece-stiffness", args.piece_stiffness.iter().map(|p| p.0).collect::<Vec<_>>()),
        ("--piece-density", args.piece_density.iter().map(|p| p.0).collect()),
    ];
    for (flag, pieces) in named {
        if let Some(piece) = pieces.iter().find(|&&p| p > files) {
            return Err(format!(
                "{flag} {piece}=...: there is no piece {piece}, the cloth has {files} (one per --cloth-mesh file, \
                 counted from 1)"
            ));
        }
        if let Some(piece) = pieces.iter().enumerate().find(|(i, p)| pieces[..*i].contains(p)).map(|(_, p)| p) {
            return Err(format!("{flag} gives piece {piece} twice: give each piece once"));
        }
    }
    let names = ["structural", "shear", "bend"];
    // A mesh cloth's springs lie along its edges (structural) and across each edge's two
    // triangles (bend): a shear stiffness there would be taken and do nothing.
    if let Some(&(piece, k)) = args.piece_stiffness.iter().find(|p| p.1.y != 0.0) {
        return Err(format!(
            "--piece-stiffness {piece}={},{},{}: a cloth from --cloth-mesh has no shear springs (its springs lie \
             along the mesh's edges, and bend springs across them), so the shear stiffness {} would do nothing: \
             give 0 (e.g. {piece}={},0,{})",
            k.x, k.y, k.z, k.y, k.x, k.z
        ));
    }
    for &(piece, k) in &args.piece_stiffness {
        if let Some(f) = (0..3).find(|&f| k[f] > 0.0 && args.stiffness[f] == 0.0) {
            return Err(format!(
                "--piece-stiffness {piece}=...: its {} stiffness is {} where --stiffness has 0, and a piece's \
                 stiffness is a multiple of the cloth's: give --stiffness a {} stiffness too",
                names[f], k[f], names[f]
            ));
        }
    }
    Ok(())
}

/// Why flag `id` does nothing with these arguments (None: it applies).
pub(crate) fn unused(args: &Args, id: &str) -> Option<String> {
    let collider_flags = ["mesh", "contact", "holes", "voxels", "thickness", "friction", "search", "brute_force"];
    let flag = format!("--{}", id.replace('_', "-"));
    // The thickness and friction are also what a self-colliding cloth keeps from itself.
    let self_thickness = ["thickness", "friction"].contains(&id) && self_collision_on(args);
    if args.scene == SceneArg::Swing && args.colliders.is_empty() && collider_flags.contains(&id) && !self_thickness {
        return Some(format!(
            "{flag} does nothing in the swing scene, which has no collider: drop it, use --scene drape or pile, \
             or add colliders with [[collider]] tables in a --scene-file{}",
            if ["thickness", "friction"].contains(&id) {
                " (or keep the cloth from itself: drop --self-collision off)"
            } else {
                ""
            }
        ));
    }
    if ["mesh", "holes"].contains(&id) {
        if args.scene == SceneArg::Swing {
            return Some(format!(
                "{flag} does nothing in the swing scene, whose colliders are the scene file's [[collider]] tables"
            ));
        }
        if args.scene == SceneArg::Pile {
            return Some(format!("{flag} does nothing in the pile scene, whose collider is the ground plane"));
        }
        if matches!(args.scene, SceneArg::Garment | SceneArg::Layers) {
            let scene = format!("{:?}", args.scene).to_lowercase();
            return Some(format!("{flag} does nothing in the {scene} scene, whose collider is its body"));
        }
    }
    if id == "grid" && !args.cloth_mesh.is_empty() {
        return Some("--grid does nothing with --cloth-mesh, whose mesh is the cloth".into());
    }
    if ["piece_stiffness", "piece_density"].contains(&id) && args.cloth_mesh.is_empty() {
        return Some(format!("{flag} only applies to the pieces of a cloth from --cloth-mesh (one piece per file)"));
    }
    if id == "weld" && args.cloth_mesh.is_empty() {
        return Some("--weld only applies to a cloth from --cloth-mesh (a grid has no seams to join)".into());
    }
    if id == "wind" && args.scene != SceneArg::Swing {
        return Some(format!("--wind only applies to the swing scene, not the {:?} scene", args.scene).to_lowercase());
    }
    if ["png_every", "png_size"].contains(&id) && args.png_dir.is_none() {
        return Some(format!("{flag} needs --png-dir (the directory to write the pictures into)"));
    }
    if id == "tile_sleep" && args.sleep == 0.0 {
        return Some("--tile-sleep follows --sleep's speed, and --sleep 0 turns all sleeping off".into());
    }
    if id == "voxels" && args.contact == ContactArg::Triangles {
        return Some("--voxels only applies with --contact spheres (triangle contact has no voxels)".into());
    }
    let self_collision = self_collision_on(args);
    if ["self_failsafe", "self_list_windows", "feature_walks"].contains(&id) && !self_collision {
        return Some(format!("{flag} only applies with --self-collision on"));
    }
    let colliders = args.scene != SceneArg::Swing || !args.colliders.is_empty();
    if id == "crowded_contact" && !colliders {
        return Some(format!(
            "{flag} does nothing in the swing scene, which has no collider (add [[collider]] tables in a --scene-file)"
        ));
    }
    if id == "one_workgroup_substeps" && (colliders || self_collision) {
        return Some(format!(
            "{flag} only applies to a cloth with no collider and no self-collision (their passes run between the \
             substeps' stages): the swing scene without [[collider]] tables, self-collision off"
        ));
    }
    if id == "contact_substeps" && args.substeps.is_some() && !self_collision {
        return Some(format!(
            "{flag} does nothing with --substeps, which fixes the substeps (it sets the self-collision passes only \
             with --self-collision on): drop one"
        ));
    }
    None
}

/// Whether the cloth collides with itself: `--self-collision`, on by default in every scene,
/// since every built-in scene folds its cloth onto itself somewhere (the drape scene over the
/// collider, the swing scene in its swing) and without it such frames end with the cloth through
/// itself.
pub(crate) fn self_collision_on(args: &Args) -> bool {
    args.self_collision != Some(OnOff::Off)
}

/// A finite number in `lo..=hi` (`lo` excluded when `open_low`), or a message with the range.
pub(crate) fn number_in(text: &str, lo: f32, hi: f32, open_low: bool) -> Result<f32, String> {
    let value: f32 = text.trim().parse().map_err(|e| format!("`{text}`: {e}"))?;
    let low_ok = if open_low { value > lo } else { value >= lo };
    if value.is_finite() && low_ok && value <= hi {
        Ok(value)
    } else {
        Err(format!("must be in {}{lo}, {hi}], got {text}", if open_low { "(" } else { "[" }))
    }
}

/// In [0.1 mm, 0.5 m]: thinner, a contact on a scene of metres falls under f32's resolution
/// there (at 1e-8 m a quarter of the standard scene's cloth ended inside the sphere).
pub(crate) fn parse_thickness(text: &str) -> Result<f32, String> {
    number_in(text, 1e-4, 0.5, false)
}

pub(crate) fn parse_sleep(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 10.0, false)
}

pub(crate) fn parse_friction(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 10.0, false)
}

pub(crate) fn parse_spring_damping(text: &str) -> Result<f32, String> {
    number_in(text, 0.0, 100.0, false)
}

/// "K_STRUCT,K_SHEAR,K_BEND", each in [0, 1e6] N/m.
pub(crate) fn parse_stiffness(text: &str) -> Result<Vec3, String> {
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

/// "PIECE=VALUE" with PIECE a whole number from 1, and the value parsed by `value`.
fn parse_piece<T>(text: &str, what: &str, value: fn(&str) -> Result<T, String>) -> Result<(usize, T), String> {
    let (piece, rest) =
        text.split_once('=').ok_or_else(|| format!("expected PIECE={what} (e.g. 2={what}), got `{text}`"))?;
    match piece.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok((n, value(rest)?)),
        _ => Err(format!("the piece must be a whole number from 1 (the --cloth-mesh files' order), got `{piece}`")),
    }
}

/// "PIECE=K_STRUCT,K_SHEAR,K_BEND" (`parse_stiffness`).
pub(crate) fn parse_piece_stiffness(text: &str) -> Result<(usize, Vec3), String> {
    parse_piece(text, "K_STRUCT,K_SHEAR,K_BEND", parse_stiffness)
}

/// "PIECE=DENSITY", the density in [0.001, 1000] kg/m^2 (lighter than a gram a square metre, a
/// piece's masses underflow to nothing, which the cloth pins).
pub(crate) fn parse_piece_density(text: &str) -> Result<(usize, f32), String> {
    parse_piece(text, "DENSITY", |d| number_in(d, 1e-3, 1000.0, false))
}

/// Every output the flags name can be written, checked before any setup; the error names the
/// flag and what it writes.
pub(crate) fn check_outputs(args: &Args) -> drape::Result<()> {
    type Check = fn(&std::path::Path) -> drape::Result<()>;
    let outputs: [(&Option<PathBuf>, &'static str, &str, Check); 4] = [
        (&args.json, "--json", "the report", check_output_file),
        (&args.usd, "--usd", "the USD cache", check_output_file),
        (&args.obj_dir, "--obj-dir", "the OBJ frames", check_output_dir),
        (&args.png_dir, "--png-dir", "the pictures", check_output_dir),
    ];
    for (path, name, what, check) in outputs {
        if let Some(path) = path {
            check(path).map_err(|e| drape::Error::InvalidParameter {
                name,
                problem: format!("cannot write {what} there: {e}"),
            })?;
        }
    }
    Ok(())
}

/// The output directory exists (created if needed) and takes files, checked before any setup.
pub(crate) fn check_output_dir(dir: &std::path::Path) -> drape::Result<()> {
    let io = |source| drape::Error::Io { path: dir.to_path_buf(), source };
    if dir.exists() && !dir.is_dir() {
        return Err(io(std::io::Error::other("it is a file, not a directory: give a directory (made if missing)")));
    }
    std::fs::create_dir_all(dir).map_err(io)?;
    let probe = dir.join(".drape-write-test");
    std::fs::write(&probe, b"").map_err(io)?;
    std::fs::remove_file(&probe).map_err(io)
}

/// "WIDTHxHEIGHT", each side 16..=4096 pixels.
pub(crate) fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let side = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (16..=4096).contains(&n) => Ok(n),
        _ => Err(format!("expected WIDTHxHEIGHT with each side a whole number in 16..=4096, got `{text}`")),
    };
    let (w, h) =
        text.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, e.g. 640x480, got `{text}`"))?;
    Ok((side(w)?, side(h)?))
}

/// "X,Y,Z" (three finite numbers, negatives allowed) as a vector.
pub(crate) fn parse_vec3(text: &str) -> Result<Vec3, String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("`{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [x, y, z] if values.iter().all(|v| v.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers X,Y,Z, got `{text}`")),
    }
}

/// The fastest initial velocity `--velocity` takes (m/s): faster than any cloth is thrown, and a
/// frame at it moves the cloth further than its contact substeps can follow.
const FASTEST_THROW: f32 = 1000.0;

/// The strongest wind `--wind` takes (N on the whole cloth): far past what any cloth's
/// stability bound takes, short of the infinities its per-particle share and its diagnosis
/// would otherwise reach.
const STRONGEST_WIND: f32 = 1e6;

/// "X,Y,Z" (N), at most `STRONGEST_WIND` in size.
pub(crate) fn parse_wind(text: &str) -> Result<Vec3, String> {
    let w = parse_vec3(text)?;
    if w.length() > STRONGEST_WIND {
        return Err(format!("a wind of {:e} N: at most {STRONGEST_WIND:e} N on the whole cloth", w.length()));
    }
    Ok(w)
}

/// "X,Y,Z" (`parse_vec3`) no faster than `FASTEST_THROW`.
pub(crate) fn parse_velocity(text: &str) -> Result<Vec3, String> {
    let v = parse_vec3(text)?;
    if v.length() > FASTEST_THROW {
        return Err(format!(
            "a throw of {} m/s: at most {FASTEST_THROW} m/s (a 1/60 s frame would move the cloth {} m)",
            v.length(),
            v.length() / 60.0
        ));
    }
    Ok(v)
}

/// "MIN_X,MIN_Y,MIN_Z,MAX_X,MAX_Y,MAX_Z" (six finite numbers, min <= max) as a box.
pub(crate) fn parse_box(text: &str) -> Result<(Vec3, Vec3), String> {
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

/// The file can be created and written, checked before any work (it is written at the end).
pub(crate) fn check_output_file(path: &std::path::Path) -> drape::Result<()> {
    // Not truncated here: a file the run then fails before writing keeps what it held.
    std::fs::OpenOptions::new()
        .create(true)
        .write(true)
        .truncate(false)
        .open(path)
        .map(drop)
        .map_err(|source| drape::Error::Io { path: path.to_path_buf(), source })
}
