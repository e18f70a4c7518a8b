//! A cloth's self-collision as a sub-graph over handles: at the frame's start, each particle's
//! anchor (its predicted path over the frame), an LBVH over the cloth's own triangles' regions
//! (built by the generic builder, from a Morton box the GPU measures) and each triangle's list
//! of the pairs it may have within the frame (`drape_kernels::self_pairs`); in each pass (after
//! the collider's response of the substep it ends), the tree refit to the pass, the collider
//! features (vertices into the pass's sums, edges' pushes applied at once), the vertex-triangle
//! and edge-edge tests of the lists, the walks of the triangles that left their region (one
//! indirect dispatch over those alone) and the application of the summed corrections
//! (`drape_kernels::self_contact`). A pass sweeps from where the last
//! one left the particles (`start`), so passes may be several substeps apart: `pass_due`.

use super::contact::{ColliderBuffers, ColliderLeaves, substep_span};
use super::empty_dispatch;
use super::lbvh::LbvhBuffers;
use super::self_failsafe::FailsafeBuffers;
use crate::graph::{BufferId, Dispatch, Handle, Resources, Step};
use crate::kernels::feature_reach::MARK_OUT_OF_REACH;
use crate::kernels::feature_walks::{
    CHOOSE_FEATURE_WALKS, COLLIDER_FEATURES_FROM_CLOTH, COLLIDER_FEATURES_FROM_WALKERS,
};
use crate::kernels::self_contact::{
    APPLY_COLLIDER_PUSHES, APPLY_SELF_CONTACT, COLLIDER_FEATURE_CONTACT, GATHER_CLOTH_TRIANGLES, SELF_SCENE_BOUNDS,
};
use crate::kernels::self_pairs::{
    ANCHOR_WINDOW, CLOTH_TRIANGLE_BOUNDS, CLOTH_TRIANGLE_STARTS, LIST_SELF_PAIRS, LISTED_SELF_PAIRS, PACK_WALK_NODES,
    REGATHER_CLOTH_TRIANGLES, SELF_TRIANGLE_CONTACT, TEST_QUEUED_PAIRS, WALK_SELF_PAIRS,
};
use crate::kernels::self_pass_tree::{DERIVE_PASS_TREE, TRIANGLE_BOUNDS_AND_PASS_TREE, WIDEN_PASS_TREE};
use crate::kernels::sharp_features::LIST_SHARP_FEATURES;
use drape_kernels::feature_walks::{WALKS_AUTOMATIC, WALKS_FROM_CLOTH, WALKS_FROM_COLLIDER};
use drape_kernels::self_contact::{CORRECTION_WORDS, NO_NEIGHBOUR, PUSH_WORDS, VERTEX_OWNED_BIT};
use drape_kernels::self_pairs::{
    ANCHOR_WORDS, FIND_WALKERS, LIST_ENTRY_WORDS, QUEUED_PAIR_WORDS, QUEUED_PAIRS_MOST, QUEUED_PAIRS_PER_TRIANGLE,
    SELF_LIST_CAPACITY, SLOP_THICKNESS,
};
use drape_types::{
    Aabb, ColliderParams, ContactPush, DispatchArgs, Health, SelfAnchorPush, SelfListPush, SelfPassPush, SimParams,
    WalkNode,
};
use glam::{UVec4, Vec4};
use std::collections::{HashMap, HashSet};

/// The buffers of one cloth's self-collision.
pub struct SelfContactBuffers {
    pub tree: LbvhBuffers,
    /// Each sorted leaf's corners (xyz) and triangle (w).
    pub sorted: Handle<UVec4>,
    /// Per particle: the summed corrections (3 fixed-point words) and their count, then those
    /// of the corrections that undo a crossing (`CORRECTION_WORDS`).
    pub delta: Handle<u32>,
    /// Per particle: the summed velocity changes of its pairs' friction (3 fixed-point words)
    /// and their count.
    pub velocity_changes: Handle<u32>,
    /// Per particle: the collider edges' largest pushes per axis direction (`PUSH_WORDS`).
    pub pushes: Handle<u32>,
    /// Where each particle was when the last pass ended (the frame's start before the first):
    /// what a pass sweeps from.
    pub start: Handle<Vec4>,
    /// Per triangle, which of its edges (bit k: edge k, from corner k to corner k + 1) and
    /// corners (bit `VERTEX_OWNED_BIT << k`) it owns: each particle and each edge belongs to
    /// the first triangle that has it, so each pair is handled once.
    pub owned: Handle<u32>,
    /// Per particle, where it lies in the cloth's rest shape (xyz; the positions it was built
    /// with): the pairs within the thickness there answer only a crossing
    /// (`drape_kernels::self_contact::touched_at_rest_vertex_face`).
    pub rest_shape: Handle<Vec4>,
    /// Per particle, `ANCHOR_WORDS` words: where it starts the frame with its slop, and its
    /// predicted motion over the frame (`drape_kernels::self_pairs::anchor_at`).
    pub anchors: Handle<Vec4>,
    /// Per triangle: whether it left its predicted region in the pass (1) or not (0), and how
    /// far its corners strayed from their predicted paths (f32).
    pub escaped: Handle<u32>,
    pub strays: Handle<f32>,
    /// Per sorted leaf, and per internal node of the frame's tree: the box of its corners'
    /// predicted motions over the frame (the tree holds the boxes at the frame's start; the
    /// lists walk with both, `drape_kernels::self_pairs::RelativeMotion`).
    pub leaf_motions: Handle<Aabb>,
    pub motion_aabbs: Handle<Aabb>,
    /// The frame's tree's internal nodes packed for the lists' walk.
    pub walk_nodes: Handle<WalkNode>,
    /// The lists' tree's internal start boxes, kept for the passes' trees after the passes
    /// overwrite the tree's boxes (`drape_kernels::self_pass_tree`).
    pub span_aabbs: Handle<Aabb>,
    /// Per sorted leaf: the frame's list of later leaves it may touch, `SELF_LIST_CAPACITY`
    /// entries of `LIST_ENTRY_WORDS` (leaf, primitive pairs, their smallest gap), and its count.
    pub lists: Handle<u32>,
    pub counts: Handle<u32>,
    /// Per triangle, its sorted leaf (the inverse of the tree's order).
    pub leaf_of: Handle<u32>,
    /// The pass's walkers (sorted leaves that escaped or whose list overflowed) and their
    /// indirect dispatch (count in `_pad`).
    pub walkers: Handle<u32>,
    pub walk_args: Handle<DispatchArgs>,
    /// The pairs of triangles the pass's walkers found (`QUEUED_PAIR_WORDS` each: the earlier
    /// leaf, the later) and the indirect dispatch of their tests (count in `_pad`).
    pub pair_queue: Handle<u32>,
    pub queue_args: Handle<DispatchArgs>,
    /// A pass's second run of the triangle boxes and refit, after the collider features'
    /// pushes: dispatched over the triangles when a collider edge pushed a cloth edge in the
    /// pass, else over none (`drape_kernels::self_contact::arm_second_refit`).
    pub features_found: Handle<DispatchArgs>,
    /// A pass's refit of the tree: every leaf where something walks it in the pass, else none
    /// (`drape_kernels::self_pairs::note_pass_tree`; emptied before each pass).
    pub pass_refit: Handle<DispatchArgs>,
    /// Nonzero when every pass of the frame walks the tree (a list overflowed, a collider listed
    /// a possibly sharp triangle); zeroed at the frame's start.
    pub tree_every_pass: Handle<u32>,
    /// The frame's closing check for crossings (`super::self_failsafe`).
    pub failsafe: FailsafeBuffers,
    /// Per collider (in the model's order), for a triangle collider: its triangles that may
    /// have a feature sharp for this cloth in the frame (`declare_sharp_features`).
    pub sharp: Vec<Option<SharpFeatures>>,
    particles: u32,
}

/// A triangle collider's triangles that may have a vertex or an edge sharp enough to test
/// against a self-colliding cloth in the frame (`drape_kernels::sharp_features`), listed at the
/// frame's start, and the passes' indirect dispatch over them.
pub struct SharpFeatures {
    pub list: Handle<u32>,
    pub args: Handle<DispatchArgs>,
    /// Per collider triangle, `LISTED` where the frame listed it (what a cloth triangle's walk
    /// of the collider's tree looks up), `LISTED_FAR` where the span's lists put it out of the
    /// cloth's reach (`drape_kernels::feature_reach`).
    pub listed: Handle<u32>,
    /// The passes' dispatches from the collider's side (over the list) and from the cloth's
    /// (over its triangles): one of them over no workgroup (`drape_kernels::feature_walks`).
    pub from_collider: Handle<DispatchArgs>,
    pub from_cloth: Handle<DispatchArgs>,
    /// With the frame's pair lists: the listed triangles within the cloth's reach over the
    /// lists' span and their indirect dispatch, what the collider's side of the span's passes
    /// runs over (`drape_kernels::feature_reach`).
    pub near: Handle<u32>,
    pub near_args: Handle<DispatchArgs>,
    /// Per collider triangle, its edges' folds as last measured (w 1 once measured; zeros
    /// before the first frame), which the list reads while the collider's vertices stay
    /// unwritten (`drape_kernels::sharp_features::may_be_sharp_cached`).
    pub folds: Handle<Vec4>,
}

/// The timing table's line of the frame's list of a collider's possibly sharp triangles.
pub const SHARP_FEATURES_LABEL: &str = "self: collider sharp triangles";

/// Which side walks a self-collision pass's collider features against the cloth
/// (`drape_kernels::feature_walks`): the same pairs, each tested once by the same function, so
/// the same frames bit for bit; different costs.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum FeatureWalks {
    /// Frame by frame, the side measured cheaper: the cloth's triangles when the collider lists
    /// more than `drape_kernels::feature_walks::CLOTH_SIDE_RATIO` sharp triangles per cloth
    /// triangle (a scanned collider such as the dragon), else the listed collider triangles.
    #[default]
    Automatic,
    /// Each listed collider triangle walks the cloth's tree.
    FromCollider,
    /// Each cloth triangle walks the collider's tree for the listed triangles near it.
    FromCloth,
}

/// The timing table's line of the frame's choice of the side the collider features walk from.
pub const CHOOSE_FEATURE_WALKS_LABEL: &str = "self: collider features' side";
/// A span of the frame's lists marks the listed collider triangles out of the cloth's reach
/// (`drape_kernels::feature_reach`) when it has at least this many passes: the marking walks
/// the lists' tree once per listed triangle, about what one pass's walks from the collider's
/// side cost, and each pass then walks from about half of them (the bunny under the 64^2
/// cloth, lavapipe: 3.8 ms a span against 3.8 ms a pass before, 2.2 after, plus 0.26 ms of
/// the escaped triangles' walks).
pub const REACH_FILTER_PASSES: u32 = 4;

/// Whether a frame of `passes` self-collision passes in `windows` spans of its lists (none
/// without `lists`) marks the colliders' listed triangles out of the cloth's reach.
pub fn reach_filter_pays(lists: bool, passes: u32, windows: u32) -> bool {
    lists && passes >= REACH_FILTER_PASSES * windows.max(1)
}

/// The timing table's line of the marking of the listed collider triangles out of the cloth's
/// reach, at each span of the lists.
pub const OUT_OF_REACH_LABEL: &str = "self: collider triangles out of reach";
/// The timing table's line of the escaped cloth triangles' walks of the collider's tree for
/// those.
pub const COLLIDER_FEATURES_FROM_WALKERS_LABEL: &str = "self: collider vertices + edges (escaped's walks)";

/// The timing table's line of the collider features walked from the cloth's side.
pub const COLLIDER_FEATURES_FROM_CLOTH_LABEL: &str = "self: collider vertices + edges (cloth's walks)";

/// Per triangle, the edges (bit k: edge k, from corner k to corner k + 1) and corners (bit
/// `VERTEX_OWNED_BIT << k`) it owns: those no earlier triangle has (so one walk per triangle
/// covers each edge and each particle once).
pub fn owned_primitives(triangles: &[[u32; 3]]) -> Vec<u32> {
    let mut seen_corners = HashSet::new();
    let mut seen_edges = HashSet::new();
    let mut owned = Vec::with_capacity(triangles.len());
    for corners in triangles {
        let mut bits = 0;
        for k in 0..3 {
            let (p, q) = (corners[k], corners[(k + 1) % 3]);
            if seen_edges.insert(edge_key(p, q)) {
                bits |= 1 << k;
            }
            if seen_corners.insert(corners[k]) {
                bits |= VERTEX_OWNED_BIT << k;
            }
        }
        owned.push(bits);
    }
    owned
}

/// Each undirected edge of `triangles` (`edge_key`) with what `side(t, k)` gives for each
/// triangle t whose edge k (from corner k to k + 1) it is: the sides a surface meets at it.
pub fn edge_sides<T>(triangles: &[[u32; 3]], side: impl Fn(usize, usize) -> T) -> HashMap<(u32, u32), Vec<T>> {
    let mut sides: HashMap<(u32, u32), Vec<T>> = HashMap::new();
    for (t, corners) in triangles.iter().enumerate() {
        for k in 0..3 {
            sides.entry(edge_key(corners[k], corners[(k + 1) % 3])).or_default().push(side(t, k));
        }
    }
    sides
}

/// The key of the edge between particles or vertices `p` and `q`, either way round.
pub fn edge_key(p: u32, q: u32) -> (u32, u32) {
    (p.min(q), p.max(q))
}

/// Per collider triangle: the apex of its neighbour across each edge (xyz; `NO_NEIGHBOUR` at a
/// boundary or an edge shared by more than two triangles) and the vertices and edges it owns
/// (w, as `owned_primitives`): what the collider's features are tested with, each edge pushing
/// only where the surface folds enough at it (`drape_kernels::self_contact::sharp_for`).
pub fn collider_features(triangles: &[[u32; 3]]) -> Vec<UVec4> {
    let sides = edge_sides(triangles, |t, k| triangles[t][(k + 2) % 3]);
    let owned = owned_primitives(triangles);
    triangles
        .iter()
        .zip(owned)
        .map(|(corners, bits)| {
            let across = |k: usize| {
                let (p, q, apex) = (corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]);
                match sides.get(&edge_key(p, q)).map(Vec::as_slice) {
                    Some(&[a, b]) if a == apex => b,
                    Some(&[a, b]) if b == apex => a,
                    _ => NO_NEIGHBOUR,
                }
            };
            UVec4::new(across(0), across(1), across(2), bits)
        })
        .collect()
}

/// The shortest height of the cloth's triangles (a corner to the opposite side; on a flat cloth
/// the distance from a vertex to the faces beside it), at `positions`.
pub fn shortest_height(positions: &[Vec4], triangles: &[[u32; 3]]) -> f32 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].truncate());
            crate::mesh::triangle_height(a, b, c).unwrap_or(0.0)
        })
        .fold(f32::INFINITY, f32::min)
}

/// Whether a cloth whose triangles are at least `shortest_height` high tests frame pair lists
/// at `thickness` (`drape_kernels::self_pairs`). When a vertex lies within the thickness and
/// two slops of the faces beside it, the lists would fill with neighbours at rest: each
/// triangle walks the tree every pass instead, in one kernel as before the lists (a 128^2
/// cloth of 1 m at 5 mm ran 1.3x slower through the lists' kernels).
pub fn lists_pay(shortest_height: f32, thickness: f32) -> bool {
    shortest_height >= thickness * (1.0 + 2.0 * SLOP_THICKNESS)
}

/// Frames between rebuilds of a self-colliding cloth's tree (from the Morton codes of its
/// triangles' boxes); the frames between refit it. A cloth keeps its neighbours: in a CPU replay
/// of the frames' list walks, a tree 7 frames old tested up to 15 % more boxes than a fresh one
/// in the pile's folds and about as many in the swing (a tree built once, over the flat cloth,
/// tested fewer there, and up to 30 % more in the pile), while the build's Morton codes, sort
/// and nodes are 22 of a frame's dispatches.
pub const SELF_TREE_REBUILD_FRAMES: u32 = 8;

/// The timing table's line of a pass's pair search (vertex-triangle and edge-edge) from the
/// frame's lists.
pub const SELF_PAIRS_LABEL: &str = "self: vertex-triangle + edge-edge";
/// The timing table's line of a pass's walks (the triangles that left their predicted region
/// or whose list overflowed).
pub const SELF_WALKS_LABEL: &str = "self: walks (escaped, full lists)";
/// Pairs a pass's queue of the walkers' pairs holds for a cloth of `triangles` triangles
/// (`drape_kernels::self_pairs::QUEUED_PAIRS_PER_TRIANGLE`, at most `QUEUED_PAIRS_MOST`).
pub fn queue_capacity(triangles: u32) -> u32 {
    QUEUED_PAIRS_PER_TRIANGLE.saturating_mul(triangles).clamp(1, QUEUED_PAIRS_MOST)
}

/// The timing table's line of the tests of the pairs the walkers found.
pub const SELF_QUEUED_PAIRS_LABEL: &str = "self: walkers' pair tests";
/// The timing table's line of a pass's collider features (vertices and edges) against the
/// cloth.
pub const COLLIDER_FEATURES_LABEL: &str = "self: collider vertices + edges";

/// What the self-collision passes of one cloth read and write.
pub struct SelfContactCloth {
    pub params: Handle<SimParams>,
    pub x: Handle<Vec4>,
    pub v: Handle<Vec4>,
    pub indices: Handle<u32>,
    /// The frame's health record (counts the self-contacts).
    pub health: Handle<Health>,
}

/// How far a self-collision pass may let its pairs close, as a fraction (numerator,
/// denominator) of the thickness they may close by (`motion::CONTACT_REACH`): 3/2. Passes end
/// substeps, so a need of 8 in 14 substeps has gaps of 1.75 substeps to fit, which with no
/// slack took a pass at every substep (the 64^2 swing's frames needing 8-13 passes ran 14). A
/// pass that lets a pair through the thickness has its crossing tests undo it, and the need is
/// the last frame's approach anyway (`motion::ClothMotion::self_passes`).
const PASS_REACH: (u32, u32) = (3, 2);

/// The passes a frame of `substeps` runs when the motion needs `needed` (each may span 1/`needed`
/// of the frame): the fewest, at least `needed`, whose spread (`pass_due`: gaps of at most
/// ceil(substeps / passes) substeps) keeps every pass within `PASS_REACH` of that.
pub fn passes_for(substeps: u32, needed: u32) -> u32 {
    let substeps = substeps.max(1);
    let needed = needed.clamp(1, substeps);
    let (numerator, denominator) = PASS_REACH;
    let fits = |passes: u32| denominator * substeps.div_ceil(passes) * needed <= numerator * substeps;
    // A pass at every substep always fits: one substep is within the budget (needed <= substeps).
    (needed..=substeps).find(|&p| fits(p)).unwrap_or(substeps)
}

/// Whether substep `substep` of `substeps` ends with one of a frame's `passes` self-collision
/// passes: spread evenly, the last substep always one (so the frame ends resolved). `passes`
/// is clamped to 1..=substeps.
pub fn pass_due(substep: u32, substeps: u32, passes: u32) -> bool {
    let passes = passes.clamp(1, substeps.max(1));
    let done = |s: u32| (u64::from(s) * u64::from(passes)) / u64::from(substeps.max(1));
    done(substep + 1) > done(substep)
}

/// The substeps whose passes end the windows of a frame of `substeps` substeps, `passes`
/// passes and `windows` list builds (`FramePlan::self_windows`): the windows split the passes
/// as evenly as they can, the last ending with the frame; a window holds at least one pass.
pub fn window_ends(substeps: u32, passes: u32, windows: u32) -> Vec<u32> {
    let due: Vec<u32> = (0..substeps).filter(|&s| pass_due(s, substeps, passes)).collect();
    let windows = (windows.max(1) as usize).min(due.len().max(1));
    (1..=windows).filter_map(|w| due.get((w * due.len()).div_ceil(windows).checked_sub(1)?).copied()).collect()
}

impl SelfContactBuffers {
    pub fn declare(resources: &mut Resources, name: &str, particles: u32, triangles: u32) -> Self {
        let name = format!("{name} self-collision");
        SelfContactBuffers {
            tree: LbvhBuffers::declare(resources, &name, triangles),
            sorted: resources.device(format!("{name}: sorted triangles"), triangles),
            delta: resources.device(format!("{name}: corrections"), CORRECTION_WORDS * particles),
            velocity_changes: resources.device(format!("{name}: friction"), 4 * particles),
            pushes: resources.device(format!("{name}: collider pushes"), PUSH_WORDS * particles),
            start: resources.device(format!("{name}: pass start"), particles),
            owned: resources.device(format!("{name}: owned edges and corners"), triangles),
            rest_shape: resources.device(format!("{name}: rest shape"), particles),
            anchors: resources.device(format!("{name}: anchors"), ANCHOR_WORDS * particles),
            escaped: resources.device(format!("{name}: escaped"), triangles),
            strays: resources.device(format!("{name}: strays"), triangles),
            leaf_motions: resources.device(format!("{name}: leaf motions"), triangles),
            motion_aabbs: resources.device(format!("{name}: node motions"), triangles.saturating_sub(1).max(1)),
            walk_nodes: resources.device(format!("{name}: packed nodes"), triangles.saturating_sub(1).max(1)),
            span_aabbs: resources.device(format!("{name}: lists' node boxes"), triangles.saturating_sub(1).max(1)),
            lists: resources.device(format!("{name}: pair lists"), LIST_ENTRY_WORDS * SELF_LIST_CAPACITY * triangles),
            counts: resources.device(format!("{name}: pair list counts"), triangles),
            leaf_of: resources.device(format!("{name}: leaf of each triangle"), triangles),
            walkers: resources.device(format!("{name}: walkers"), triangles),
            walk_args: resources.device(format!("{name}: walk dispatch"), 1),
            pair_queue: resources
                .device(format!("{name}: walkers' pairs"), QUEUED_PAIR_WORDS * queue_capacity(triangles)),
            queue_args: resources.device(format!("{name}: walkers' pairs dispatch"), 1),
            features_found: resources.device(format!("{name}: second refit dispatch"), 1),
            pass_refit: resources.device(format!("{name}: pass refit dispatch"), 1),
            tree_every_pass: resources.device(format!("{name}: tree at every pass"), 1),
            failsafe: FailsafeBuffers::declare(resources, &name, particles),
            sharp: Vec::new(),
            particles,
        }
    }

    /// Declares, for each of `colliders` that has triangles, the frame's list of those that may
    /// be sharp for this cloth (`SharpFeatures`); `name` is the cloth's.
    pub fn declare_sharp_features(&mut self, resources: &mut Resources, name: &str, colliders: &[ColliderBuffers]) {
        self.sharp = colliders
            .iter()
            .enumerate()
            .map(|(j, c)| {
                let (_, count) = c.features?;
                let name = format!("{name} self-collision: collider {j} sharp triangles");
                Some(SharpFeatures {
                    list: resources.device(name.clone(), count.max(1)),
                    args: resources.device(format!("{name} dispatch"), 1),
                    listed: resources.device(format!("{name} flags"), count.max(1)),
                    from_collider: resources.device(format!("{name}: walks from the collider"), 1),
                    from_cloth: resources.device(format!("{name}: walks from the cloth"), 1),
                    near: resources.device(format!("{name} within the cloth's reach"), count.max(1)),
                    near_args: resources.device(format!("{name} within the cloth's reach: dispatch"), 1),
                    folds: resources.device(format!("{name}: folds"), count.max(1)),
                })
            })
            .collect();
    }

    /// At the frame's start, after the cloth's bounds (`frame_start_steps`: the longest edge the
    /// sharpness is measured for): collider `index`'s possibly sharp triangles, which side the
    /// passes walk them from (`walks`; counted in the cloth's `health`), and, where the frame
    /// marks those out of the cloth's reach (`reach`, `reach_filter_pays`), that marking.
    pub fn sharp_feature_steps(
        &self,
        (collider, index): (&ColliderBuffers, usize),
        (walks, health, reach): (FeatureWalks, Handle<Health>, bool),
        steps: &mut Vec<Step>,
    ) {
        let (ColliderLeaves::Triangles(mesh), Some((features, count)), Some(Some(sharp))) =
            (&collider.leaves, collider.features, self.sharp.get(index))
        else {
            return;
        };
        steps.push(empty_dispatch(sharp.args));
        steps.push(Step::run(
            SHARP_FEATURES_LABEL,
            &LIST_SHARP_FEATURES,
            vec![
                self.tree.collider.id(),
                mesh.tree.collider.id(),
                mesh.vertices.id(),
                mesh.previous.id(),
                mesh.indices.id(),
                features.id(),
                sharp.list.id(),
                sharp.args.id(),
                self.tree_every_pass.id(),
                sharp.listed.id(),
                collider.pose.id(),
                sharp.folds.id(),
            ],
            Dispatch::Threads(count),
        ));
        let mode = match walks {
            FeatureWalks::Automatic => WALKS_AUTOMATIC,
            FeatureWalks::FromCollider => WALKS_FROM_COLLIDER,
            FeatureWalks::FromCloth => WALKS_FROM_CLOTH,
        };
        steps.push(Step::run_with(
            CHOOSE_FEATURE_WALKS_LABEL,
            &CHOOSE_FEATURE_WALKS,
            vec![
                self.tree.collider.id(),
                sharp.args.id(),
                sharp.from_collider.id(),
                sharp.from_cloth.id(),
                health.id(),
            ],
            bytemuck::cast(DispatchArgs { x: mode, y: 0, z: 0, _pad: 0 }),
            Dispatch::Threads(1),
        ));
        if reach {
            steps.extend(self.out_of_reach_steps((collider, index), health));
        }
    }

    /// After the lists of a span of the frame (its start, or a window's) and the frame's choice
    /// of side: collider `index`'s listed triangles that no cloth triangle keeping to its
    /// predicted region can reach over the span, marked so that the passes walk from the
    /// others, listed again (`drape_kernels::feature_reach`; counted in the cloth's `health`).
    /// None for a collider with no sharp list.
    pub fn out_of_reach_steps(
        &self,
        (collider, index): (&ColliderBuffers, usize),
        health: Handle<Health>,
    ) -> Vec<Step> {
        let (ColliderLeaves::Triangles(mesh), Some(Some(sharp))) = (&collider.leaves, self.sharp.get(index)) else {
            return Vec::new();
        };
        let t = &self.tree;
        let mark = Step::run(
            OUT_OF_REACH_LABEL,
            &MARK_OUT_OF_REACH,
            vec![
                t.collider.id(),
                mesh.tree.collider.id(),
                collider.pose.id(),
                mesh.vertices.id(),
                mesh.previous.id(),
                mesh.indices.id(),
                sharp.list.id(),
                sharp.args.id(),
                t.nodes.id(),
                t.aabbs.id(),
                t.sorted_bounds.id(),
                self.motion_aabbs.id(),
                self.leaf_motions.id(),
                self.walk_nodes.id(),
                self.anchors.id(),
                sharp.listed.id(),
                sharp.near.id(),
                sharp.near_args.id(),
                health.id(),
            ],
            // The collider's side's dispatch over the list: none when the cloth's side walks.
            Dispatch::Indirect(sharp.from_collider),
        );
        vec![empty_dispatch(sharp.near_args), mark]
    }

    /// The cloth's particles.
    pub fn particles(&self) -> u32 {
        self.particles
    }

    /// The tree's parameters (the Morton box and longest edge are the GPU's to write at each
    /// frame's start): the thickness the cloth keeps from itself and the friction between its
    /// layers.
    pub fn params(triangles: u32, thickness: f32, friction: f32) -> ColliderParams {
        ColliderParams { leaf_count: triangles, thickness, friction, ..Default::default() }
    }

    /// The triangles' boxes over the pass spanning `span` and, when `find_walkers` is
    /// `drape_kernels::self_pairs::FIND_WALKERS`, whether each escaped its region and the pass's
    /// walkers, over `dispatch`.
    fn triangle_bounds(
        &self,
        cloth: &SelfContactCloth,
        (span, find_walkers): (ContactPush, u32),
        dispatch: Dispatch,
        steps: &mut Vec<Step>,
    ) {
        let push = pass_push(span, find_walkers);
        let bindings = self.triangle_bound_bindings(cloth);
        steps.push(Step::run_with(
            "self: triangle boxes",
            &CLOTH_TRIANGLE_BOUNDS,
            bindings,
            bytemuck::cast(push),
            dispatch,
        ));
    }

    /// What a pass's triangle boxes bind (`CLOTH_TRIANGLE_BOUNDS`, and the first of a second
    /// run's, `TRIANGLE_BOUNDS_AND_PASS_TREE`).
    fn triangle_bound_bindings(&self, cloth: &SelfContactCloth) -> Vec<BufferId> {
        let t = &self.tree;
        vec![
            t.collider.id(),
            cloth.x.id(),
            self.start.id(),
            cloth.indices.id(),
            self.anchors.id(),
            self.leaf_of.id(),
            t.sorted_bounds.id(),
            self.escaped.id(),
            self.strays.id(),
            self.walkers.id(),
            self.walk_args.id(),
            self.tree_every_pass.id(),
            self.pass_refit.id(),
        ]
    }

    /// At the frame of `substeps` substeps' start: the particles' anchors and the Morton box,
    /// then the tree over the triangles' start boxes (built anew with `rebuild`, else refit:
    /// `SELF_TREE_REBUILD_FRAMES`), the triangles' corners in the tree's order, and
    /// (with `lists`) their motion boxes and each triangle's list of the pairs it may have
    /// within the frame.
    pub fn frame_start_steps(
        &self,
        cloth: &SelfContactCloth,
        (horizon, substeps): (u32, u32),
        (lists, rebuild): (bool, bool),
        steps: &mut Vec<Step>,
    ) {
        let t = &self.tree;
        // Raised by the lists that overflow and the colliders' sharp triangles.
        steps.push(Step::fill(self.tree_every_pass, 0));
        steps.push(Step::run_with(
            "self: cloth bounds",
            &SELF_SCENE_BOUNDS,
            vec![
                cloth.params.id(),
                cloth.x.id(),
                cloth.v.id(),
                cloth.indices.id(),
                t.collider.id(),
                self.start.id(),
                self.anchors.id(),
                cloth.health.id(),
            ],
            bytemuck::cast(SelfAnchorPush { window_substeps: horizon, frame_substeps: substeps, _pad: [0; 2] }),
            Dispatch::Workgroups(1),
        ));
        let starts = self.starts_step(cloth);
        if !lists {
            // A rebuilt tree's leaves are in a new order: the gather follows the build. A refit
            // keeps the order: the start boxes go to the leaves they had.
            let gather = self.gather_step(cloth);
            if rebuild {
                steps.extend(t.build_around(starts, gather));
            } else {
                steps.extend(t.refit_around(starts, gather));
            }
            return;
        }
        if rebuild {
            steps.push(starts);
            steps.extend(t.build_shape_steps());
            steps.push(self.gather_step(cloth));
        } else {
            steps.push(self.regather_step(cloth));
        }
        self.list_steps(cloth, (horizon, substeps), steps);
    }

    /// Each triangle's box at the start of the anchors' span, its corners grown by their slops
    /// (what the tree is built or refit over).
    fn starts_step(&self, cloth: &SelfContactCloth) -> Step {
        let t = &self.tree;
        Step::run(
            "self: triangle start boxes",
            &CLOTH_TRIANGLE_STARTS,
            vec![t.collider.id(), self.anchors.id(), cloth.indices.id(), t.bounds.id()],
            Dispatch::Threads(t.leaves),
        )
    }

    /// The triangles' corners in the tree's order, their sorted leaves and motion boxes.
    fn gather_step(&self, cloth: &SelfContactCloth) -> Step {
        let t = &self.tree;
        Step::run(
            "self: gather triangles",
            &GATHER_CLOTH_TRIANGLES,
            vec![
                t.collider.id(),
                cloth.indices.id(),
                t.order.id(),
                self.anchors.id(),
                self.sorted.id(),
                self.leaf_of.id(),
                self.leaf_motions.id(),
            ],
            Dispatch::Threads(t.leaves),
        )
    }

    /// After the pass that ends a window of the frame (`window_ends`), the lists again for the
    /// next window, of `horizon` of the frame's `substeps` substeps: each particle's prediction
    /// from where it is now (its frame start stays: the fail-safe's), the tree refit to the
    /// triangles' start boxes, the triangles' corners and motion boxes, and the lists.
    pub fn window_start_steps(&self, cloth: &SelfContactCloth, (horizon, substeps): (u32, u32), steps: &mut Vec<Step>) {
        let t = &self.tree;
        steps.push(Step::run_with(
            "self: window anchors",
            &ANCHOR_WINDOW,
            vec![cloth.params.id(), t.collider.id(), cloth.x.id(), cloth.v.id(), self.anchors.id()],
            bytemuck::cast(SelfAnchorPush { window_substeps: horizon, frame_substeps: substeps, _pad: [0; 2] }),
            Dispatch::Threads(self.particles),
        ));
        steps.push(self.regather_step(cloth));
        self.list_steps(cloth, (horizon, substeps), steps);
    }

    /// Where the tree keeps its leaf order (a refit, or a window's lists): the triangles'
    /// corners, start boxes and motion boxes in that order, in one pass.
    fn regather_step(&self, cloth: &SelfContactCloth) -> Step {
        let t = &self.tree;
        Step::run(
            "self: triangles in tree order",
            &REGATHER_CLOTH_TRIANGLES,
            vec![
                t.collider.id(),
                cloth.indices.id(),
                t.order.id(),
                self.anchors.id(),
                self.sorted.id(),
                self.leaf_of.id(),
                t.sorted_bounds.id(),
                self.leaf_motions.id(),
            ],
            Dispatch::Threads(t.leaves),
        )
    }

    /// Once the triangles' corners, start boxes and motion boxes are in the tree's leaf order:
    /// the tree refit to its start boxes and their motions in one climb, and each triangle's
    /// list, over `horizon` of the frame's `substeps` substeps (the pairs' measured motion
    /// scaled to the frame).
    fn list_steps(&self, cloth: &SelfContactCloth, (horizon, substeps): (u32, u32), steps: &mut Vec<Step>) {
        let t = &self.tree;
        steps.extend(t.refit_with_steps("self: refit starts + motions", (self.leaf_motions, self.motion_aabbs)));
        steps.push(Step::run(
            "self: pack nodes",
            &PACK_WALK_NODES,
            vec![
                t.collider.id(),
                t.nodes.id(),
                t.aabbs.id(),
                self.motion_aabbs.id(),
                self.walk_nodes.id(),
                self.span_aabbs.id(),
            ],
            Dispatch::Threads(t.leaves),
        ));
        let to_frame = substeps as f32 / horizon.max(1) as f32;
        steps.push(Step::run_with(
            "self: pair lists",
            &LIST_SELF_PAIRS,
            vec![
                t.collider.id(),
                t.nodes.id(),
                t.aabbs.id(),
                t.sorted_bounds.id(),
                self.sorted.id(),
                self.owned.id(),
                self.anchors.id(),
                self.motion_aabbs.id(),
                self.leaf_motions.id(),
                self.walk_nodes.id(),
                self.lists.id(),
                self.counts.id(),
                cloth.health.id(),
                self.tree_every_pass.id(),
            ],
            bytemuck::cast(SelfListPush { to_frame, _pad: [0; 3] }),
            Dispatch::Threads(t.leaves),
        ));
    }

    /// The pass that ends substep `to` of `substeps` and sweeps from the end of substep
    /// `from - 1` (`from` = the substep after the last pass): triangle collider `collider`'s
    /// vertices and edges against the cloth's faces and edges, walked from the collider's side
    /// or from the cloth's, as the frame chose (`sharp_feature_steps`); none for a sphere
    /// collider, whose spheres are smooth.
    pub fn collider_feature_steps(
        &self,
        cloth: &SelfContactCloth,
        (collider, index): (&ColliderBuffers, usize),
        ((from, to, substeps), reach): ((u32, u32, u32), bool),
    ) -> Vec<Step> {
        let (ColliderLeaves::Triangles(mesh), Some((features, _)), Some(Some(sharp))) =
            (&collider.leaves, collider.features, self.sharp.get(index))
        else {
            return Vec::new();
        };
        let span = substep_span(from, to + 1, substeps);
        let t = &self.tree;
        // What a walk from the cloth's side binds: the pass, the collider's mesh, flags and tree,
        // the cloth's pass tree and sweep, then `pick` (which cloth triangles walk), then the sums.
        let cloth_side = |pick: &[BufferId]| {
            let walks = [
                cloth.params.id(),
                t.collider.id(),
                mesh.tree.collider.id(),
                collider.pose.id(),
                mesh.vertices.id(),
                mesh.previous.id(),
                mesh.indices.id(),
                features.id(),
                sharp.listed.id(),
                mesh.tree.nodes.id(),
                mesh.tree.aabbs.id(),
                mesh.tree.sorted_bounds.id(),
                mesh.tree.order.id(),
                t.nodes.id(),
                t.aabbs.id(),
                t.sorted_bounds.id(),
                self.sorted.id(),
                self.owned.id(),
                cloth.x.id(),
                self.start.id(),
                cloth.v.id(),
            ];
            let sums = [
                self.delta.id(),
                self.velocity_changes.id(),
                self.pushes.id(),
                cloth.health.id(),
                self.features_found.id(),
            ];
            [&walks[..], pick, &sums].concat()
        };
        let from_cloth = Step::run_with(
            COLLIDER_FEATURES_FROM_CLOTH_LABEL,
            &COLLIDER_FEATURES_FROM_CLOTH,
            cloth_side(&[]),
            bytemuck::cast(span),
            Dispatch::Indirect(sharp.from_cloth),
        );
        // Where the frame marks what is out of the cloth's reach (`reach_filter_pays`), over
        // the listed triangles within it (left empty when the cloth's side walks); else over
        // every listed one.
        let (over, over_args, dispatch) = if reach {
            (sharp.near, sharp.near_args, sharp.near_args)
        } else {
            (sharp.list, sharp.args, sharp.from_collider)
        };
        let from_collider = Step::run_with(
            COLLIDER_FEATURES_LABEL,
            &COLLIDER_FEATURE_CONTACT,
            vec![
                cloth.params.id(),
                t.collider.id(),
                mesh.tree.collider.id(),
                collider.pose.id(),
                mesh.vertices.id(),
                mesh.previous.id(),
                mesh.indices.id(),
                features.id(),
                t.nodes.id(),
                t.aabbs.id(),
                t.sorted_bounds.id(),
                self.sorted.id(),
                self.owned.id(),
                cloth.x.id(),
                self.start.id(),
                cloth.v.id(),
                self.delta.id(),
                self.velocity_changes.id(),
                self.pushes.id(),
                over.id(),
                over_args.id(),
                cloth.health.id(),
                self.features_found.id(),
            ],
            bytemuck::cast(span),
            Dispatch::Indirect(dispatch),
        );
        if !reach {
            // Nothing is marked out of reach (without lists no triangle's region is known, and
            // the pass finds no walkers).
            return vec![from_collider, from_cloth];
        }
        let from_walkers = Step::run_with(
            COLLIDER_FEATURES_FROM_WALKERS_LABEL,
            &COLLIDER_FEATURES_FROM_WALKERS,
            cloth_side(&[self.walkers.id(), self.walk_args.id(), sharp.from_cloth.id()]),
            bytemuck::cast(span),
            Dispatch::Indirect(self.walk_args),
        );
        vec![from_collider, from_cloth, from_walkers]
    }

    /// A pass, after the collider's response of the substep it ends: refit to the triangles
    /// swept since the last pass; `features` (the colliders' vertices and edges against the
    /// cloth: vertex corrections into the pass's sums, edge pushes applied at once and the tree
    /// refit again, in a pass where a collider edge pushed); then the
    /// pairs, and the mean of the corrections applied (`drape_kernels::self_contact::correction_of`;
    /// it records the next pass's start).
    /// The pairs sweep the pushes with the rest of the pass's motion, so a push through a layer
    /// of cloth is a crossing they undo.
    pub fn substep_steps(
        &self,
        cloth: &SelfContactCloth,
        ((from, to, substeps), lists): ((u32, u32, u32), bool),
        features: Vec<Step>,
        steps: &mut Vec<Step>,
    ) {
        self.windowed_substep_steps(cloth, ((from, to, substeps), (0, substeps), lists), features, steps);
    }

    /// `substep_steps` in the window of the frame that starts at substep `window_from` and spans
    /// `window` substeps: which triangles left their regions is measured against the window's
    /// lists' predictions.
    pub fn windowed_substep_steps(
        &self,
        cloth: &SelfContactCloth,
        ((from, to, substeps), (window_from, window), lists): ((u32, u32, u32), (u32, u32), bool),
        features: Vec<Step>,
        steps: &mut Vec<Step>,
    ) {
        let t = &self.tree;
        debug_assert!(window_from <= from && to < window_from + window && window_from + window <= substeps);
        let span = substep_span(from - window_from, to + 1 - window_from, window);
        if lists {
            steps.push(empty_dispatch(self.walk_args));
            steps.push(empty_dispatch(self.queue_args));
            steps.push(empty_dispatch(self.pass_refit));
        }
        let find = if lists { FIND_WALKERS } else { 0 };
        self.triangle_bounds(cloth, (span, find), Dispatch::Threads(t.leaves), steps);
        if lists {
            // Only where something walks the tree in the pass (`note_pass_tree`).
            self.pass_tree(pass_push(span, 0), self.pass_refit, steps);
        } else {
            steps.extend(t.refit_sorted_steps());
        }
        steps.push(Step::fill(self.delta, 0));
        steps.push(Step::fill(self.velocity_changes, 0));
        if !features.is_empty() {
            // Only the colliders' edges push; without a triangle collider the pushes stay the
            // zeros they start as.
            steps.push(Step::fill(self.pushes, 0));
            // No collider edge has pushed in this pass yet.
            steps.push(empty_dispatch(self.features_found));
            steps.extend(features);
            // The pushes move particles only when a collider edge pushed a cloth edge in the
            // pass: then they are applied (the walkers the first run found forgotten), the boxes
            // and the walkers found after them, and the tree refit to them.
            steps.push(Step::run(
                "self: collider pushes",
                &APPLY_COLLIDER_PUSHES,
                vec![cloth.params.id(), cloth.x.id(), cloth.v.id(), self.pushes.id(), self.walk_args.id()],
                Dispatch::Indirect(self.features_found),
            ));
            if lists {
                self.bounds_and_pass_tree(cloth, pass_push(span, find), self.features_found, steps);
            } else {
                self.triangle_bounds(cloth, (span, find), Dispatch::Indirect(self.features_found), steps);
                steps.extend(t.refit_sorted_again_steps(self.features_found));
            }
        }
        if lists {
            self.listed_and_walked(cloth, span, steps);
        } else {
            // One walk per triangle (a cloth too fine for lists at its thickness: `lists_pay`).
            steps.push(Step::run(
                SELF_PAIRS_LABEL,
                &SELF_TRIANGLE_CONTACT,
                self.pair_bindings(cloth, &[], &[]),
                Dispatch::Threads(t.leaves),
            ));
        }
        self.apply(cloth, steps);
    }

    /// The tree's boxes for a pass spanning `span` of the lists' span, over the internal nodes
    /// `dispatch` covers (none leaves the boxes as they were: nothing walks the tree in the
    /// pass): each node's bound over the pass from the lists' tree, then the pass's walkers'
    /// climbs (`drape_kernels::self_pass_tree`). It stands for a refit (the walks find the same
    /// leaves) at a fraction of its climbs.
    /// A pass's second run with lists (`bounds_and_pass_tree`), for a frame whose first plan had
    /// none (a thickness changed at run time) to find bound from the start.
    pub fn pushed_run_steps(&self, cloth: &SelfContactCloth) -> Vec<Step> {
        let mut steps = Vec::new();
        self.bounds_and_pass_tree(
            cloth,
            pass_push(substep_span(0, 1, 1), FIND_WALKERS),
            self.features_found,
            &mut steps,
        );
        steps
    }

    /// A pass's second run (after the collider's pushes, over `dispatch`): the triangles' boxes
    /// and the pass's tree derived in one dispatch, then the walkers' climbs (`pass_tree`).
    fn bounds_and_pass_tree(
        &self,
        cloth: &SelfContactCloth,
        span: SelfPassPush,
        dispatch: Handle<DispatchArgs>,
        steps: &mut Vec<Step>,
    ) {
        let mut bindings = self.triangle_bound_bindings(cloth);
        bindings.extend([self.span_aabbs.id(), self.motion_aabbs.id(), self.tree.aabbs.id()]);
        let (kernel, push) = (&TRIANGLE_BOUNDS_AND_PASS_TREE, bytemuck::cast(span));
        steps.push(Step::run_with("self: triangle boxes", kernel, bindings, push, Dispatch::Indirect(dispatch)));
        steps.push(self.widen_step(dispatch));
    }

    fn pass_tree(&self, span: SelfPassPush, dispatch: Handle<DispatchArgs>, steps: &mut Vec<Step>) {
        let t = &self.tree;
        steps.push(Step::run_with(
            "refit",
            &DERIVE_PASS_TREE,
            vec![t.collider.id(), self.span_aabbs.id(), self.motion_aabbs.id(), self.anchors.id(), t.aabbs.id()],
            bytemuck::cast(span),
            Dispatch::Indirect(dispatch),
        ));
        steps.push(self.widen_step(dispatch));
    }

    /// The walkers' climbs widening the pass's tree, where `derived` derived it.
    fn widen_step(&self, derived: Handle<DispatchArgs>) -> Step {
        let t = &self.tree;
        Step::run(
            "refit",
            &WIDEN_PASS_TREE,
            vec![
                t.collider.id(),
                t.parents.id(),
                t.sorted_bounds.id(),
                self.walkers.id(),
                self.walk_args.id(),
                derived.id(),
                t.aabbs.id(),
            ],
            Dispatch::Indirect(self.walk_args),
        )
    }

    /// The pairs of a pass spanning `span` of the lists' span, from the lists, and the walks of
    /// the triangles that left their regions.
    fn listed_and_walked(&self, cloth: &SelfContactCloth, span: ContactPush, steps: &mut Vec<Step>) {
        let t = &self.tree;
        // Per triangle, its owned corners against the triangles of its list, its owned edges
        // against their owned edges; then the walkers' (a pass of their own: on lockstep lanes a
        // walk beside list tests would hold its neighbours).
        let push = pass_push(span, 0);
        steps.push(Step::run_with(
            SELF_PAIRS_LABEL,
            &LISTED_SELF_PAIRS,
            self.pair_bindings(cloth, &[self.escaped.id(), self.strays.id(), self.lists.id(), self.counts.id()], &[]),
            bytemuck::cast(push),
            Dispatch::Threads(t.leaves),
        ));
        steps.push(Step::run(
            SELF_WALKS_LABEL,
            &WALK_SELF_PAIRS,
            self.pair_bindings(
                cloth,
                &[self.escaped.id(), self.counts.id(), self.walkers.id(), self.walk_args.id()],
                &[self.pair_queue.id(), self.queue_args.id(), cloth.health.id()],
            ),
            Dispatch::Indirect(self.walk_args),
        ));
        // The walkers' pairs, a thread each.
        steps.push(Step::run(
            SELF_QUEUED_PAIRS_LABEL,
            &TEST_QUEUED_PAIRS,
            vec![
                t.collider.id(),
                self.sorted.id(),
                self.owned.id(),
                cloth.x.id(),
                self.start.id(),
                cloth.v.id(),
                self.pair_queue.id(),
                self.queue_args.id(),
                self.delta.id(),
                self.velocity_changes.id(),
                self.rest_shape.id(),
            ],
            Dispatch::Indirect(self.queue_args),
        ));
    }

    /// What a pass's pair search binds (`drape_kernels::self_pairs`): the tree and its
    /// triangles, the pass's sweep (positions now and at its start, velocities), then `found_by`
    /// (what finds the pairs: lists, walkers), the sums the pairs add to, then `after`, then
    /// the cloth's rest shape (which pairs touched at rest).
    fn pair_bindings(&self, cloth: &SelfContactCloth, found_by: &[BufferId], after: &[BufferId]) -> Vec<BufferId> {
        let t = &self.tree;
        let tree =
            [t.collider.id(), t.nodes.id(), t.aabbs.id(), t.sorted_bounds.id(), self.sorted.id(), self.owned.id()];
        let sweep = [cloth.x.id(), self.start.id(), cloth.v.id()];
        let sums = [self.delta.id(), self.velocity_changes.id()];
        [&tree[..], &sweep, found_by, &sums, after, &[self.rest_shape.id()]].concat()
    }

    /// The mean of the pass's corrections applied (which records the next pass's start).
    fn apply(&self, cloth: &SelfContactCloth, steps: &mut Vec<Step>) {
        steps.push(Step::run(
            "self: apply",
            &APPLY_SELF_CONTACT,
            vec![
                cloth.params.id(),
                cloth.x.id(),
                cloth.v.id(),
                self.delta.id(),
                self.velocity_changes.id(),
                self.pushes.id(),
                self.start.id(),
                cloth.health.id(),
                self.tree.collider.id(),
            ],
            Dispatch::Threads(self.particles),
        ));
    }
}

/// A pass's push constants (`SelfPassPush`): its span of the lists' span, and whether the run
/// finds the pass's walkers (`drape_kernels::self_pairs::FIND_WALKERS`, or 0).
fn pass_push(span: ContactPush, find_walkers: u32) -> SelfPassPush {
    SelfPassPush { from: span.from, to: span.to, find_walkers, beyond: 0.0 }
}

#[cfg(test)]
mod tests {
    use super::{collider_features, pass_due, passes_for, queue_capacity, window_ends};

    /// The walkers' queue holds 8 pairs a triangle, and never more than an indirect dispatch
    /// of 65,535 workgroups (Vulkan's least limit) tests: a cloth of 2048^2 particles has 8.4 M
    /// triangles.
    #[test]
    fn the_walkers_queue_stays_within_one_dispatch() {
        use drape_kernels::self_pairs::QUEUE_THREADS;
        assert_eq!(queue_capacity(2 * 63 * 63), 8 * 2 * 63 * 63);
        for triangles in [1, 524_287, 524_288, 2 * 511 * 511, 2 * 2047 * 2047, u32::MAX] {
            let pairs = queue_capacity(triangles);
            assert!(pairs >= 1 && pairs.div_ceil(QUEUE_THREADS) <= 65_535, "{triangles} triangles: {pairs} pairs");
        }
        assert_eq!(queue_capacity(2 * 2047 * 2047), 65_535 * QUEUE_THREADS);
    }

    /// A pass's walk dispatch (its walkers: at most the cloth's triangles) needs no more
    /// workgroups than the lists' direct dispatch over every triangle, which the engine checks
    /// against the device's limit before recording: a cloth too large for the device is an
    /// error there, never an indirect dispatch past the limit.
    #[test]
    fn the_walk_dispatch_stays_within_the_lists_checked_dispatch() {
        use crate::kernels::self_pairs::{LIST_SELF_PAIRS, WALK_SELF_PAIRS};
        let (walk, lists) = (WALK_SELF_PAIRS.spec.workgroup_size, LIST_SELF_PAIRS.spec.workgroup_size);
        for triangles in [1, 63, 64, 65, 2 * 63 * 63, 4_194_240, 4_194_241, 2 * 2047 * 2047] {
            assert!(
                u32::div_ceil(triangles, walk) <= u32::div_ceil(triangles, lists),
                "{triangles} walkers: {walk} a workgroup against the lists' {lists}"
            );
        }
    }
    use drape_kernels::self_contact::NO_NEIGHBOUR;
    use glam::UVec4;

    /// Each edge's neighbour apex: the other triangle's third corner across a shared edge, none
    /// at a boundary or where three triangles share the edge; owned bits as a cloth's.
    #[test]
    fn collider_features_name_the_apex_across_each_edge() {
        // A quad split along 0-2: the diagonal has a neighbour, the border none.
        let quad = [[0, 1, 2], [0, 2, 3]];
        let f = collider_features(&quad);
        assert_eq!(f[0], UVec4::new(NO_NEIGHBOUR, NO_NEIGHBOUR, 3, 0b111_111));
        assert_eq!(f[1], UVec4::new(1, NO_NEIGHBOUR, NO_NEIGHBOUR, (0b100 << 3) | 0b110));
        // A tetrahedron: every edge between two faces.
        let tetra = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        for (t, f) in tetra.iter().zip(collider_features(&tetra)) {
            for k in 0..3 {
                let across = [f.x, f.y, f.z][k];
                assert!(across != NO_NEIGHBOUR && !t.contains(&across), "{t:?}: {f}");
            }
        }
        // Three triangles on one edge (0-1): no single neighbour.
        let fan = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        assert!(collider_features(&fan).iter().all(|f| f.x == NO_NEIGHBOUR));
    }

    /// The passes: as many as asked (clamped to 1..=substeps), the last substep always one, and
    /// spread so no two are further apart than the even spacing rounded up; the plan's count
    /// (`SimSettings::plan`) is the fewest passes, at least the need, whose gaps are at most 3/2
    /// of `substeps / needed` substeps.
    /// A frame's windows end at passes, the last with the frame; each holds at least one pass
    /// and their pass counts differ by at most one; one window is the whole frame.
    #[test]
    fn windows_split_the_passes_evenly_and_end_with_the_frame() {
        for substeps in 1..30 {
            for passes in 1..=substeps {
                let due: Vec<u32> = (0..substeps).filter(|&s| pass_due(s, substeps, passes)).collect();
                assert_eq!(window_ends(substeps, passes, 1), vec![substeps - 1]);
                for windows in 2..5 {
                    let ends = window_ends(substeps, passes, windows);
                    let case = format!("{substeps} substeps, {passes} passes, {windows} windows: {ends:?}");
                    assert_eq!(ends.len(), (windows as usize).min(due.len()), "{case}");
                    assert_eq!(ends.last(), Some(&(substeps - 1)), "{case}");
                    assert!(ends.iter().all(|end| due.contains(end)) && ends.is_sorted(), "{case}");
                    let mut from = 0;
                    let held: Vec<usize> = ends
                        .iter()
                        .map(|&end| {
                            let held = due.iter().filter(|&&s| s >= from && s <= end).count();
                            from = end + 1;
                            held
                        })
                        .collect();
                    let (least, most) = (held.iter().min().unwrap(), held.iter().max().unwrap());
                    assert!(*least >= 1 && most - least <= 1, "{case}: {held:?}");
                }
            }
        }
    }

    #[test]
    fn passes_are_spread_evenly_and_end_the_frame() {
        for substeps in 1..40 {
            for asked in 0..45 {
                let due: Vec<u32> = (0..substeps).filter(|&s| pass_due(s, substeps, asked)).collect();
                assert_eq!(due.len() as u32, asked.clamp(1, substeps), "{substeps} substeps, {asked} passes");
                assert_eq!(due.last(), Some(&(substeps - 1)), "{substeps} substeps, {asked} passes: {due:?}");
                let spacing = substeps.div_ceil(asked.clamp(1, substeps));
                let mut from = 0;
                for &s in &due {
                    assert!(s + 1 - from <= spacing, "{substeps} substeps, {asked} passes: {due:?}");
                    from = s + 1;
                }
                // The plan's count for a motion that needs `asked` passes: at least as many, no
                // gap longer than 3/2 of substeps / asked substeps, and no more passes than
                // that takes.
                let needed = asked.clamp(1, substeps);
                let planned = passes_for(substeps, asked);
                assert!((needed..=substeps).contains(&planned));
                let mut from = 0;
                for s in (0..substeps).filter(|&s| pass_due(s, substeps, planned)) {
                    let gap = s + 1 - from;
                    assert!(2 * gap * needed <= 3 * substeps, "{substeps} substeps, {needed} needed: gap at {s}");
                    from = s + 1;
                }
                if planned > needed {
                    let fewer = planned - 1;
                    assert!(2 * substeps.div_ceil(fewer) * needed > 3 * substeps, "{substeps}, {needed}: {planned}");
                }
            }
        }
    }
}
