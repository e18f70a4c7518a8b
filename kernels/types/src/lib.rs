//! GPU structs shared by drape's kernels (SPIR-V) and its host (x86_64): each is defined once,
//! here. Rules: `#[repr(C)]`, only 4-byte scalars and `Vec4`, explicit padding, size asserted at
//! compile time, so the SPIR-V layout (std430) and the host layout cannot drift apart.
#![cfg_attr(target_arch = "spirv", no_std)]

pub use spirv_std::glam;
use spirv_std::glam::Vec4;

/// Which integrator a simulation uses (`SimParams::integrator`).
pub mod integrator {
    /// Classical 4-stage Runge-Kutta on (x, v): 4 stage dispatches per substep.
    pub const RK4: u32 = 0;
    /// Semi-implicit (symplectic) Euler, the paper's eq. 3: 2 dispatches per substep.
    pub const SEMI_IMPLICIT_EULER: u32 = 1;
}

/// Everything the cloth kernels need to know about a cloth, constant over a run.
/// Lives in a read-only storage buffer (binding 0 of the cloth kernels).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SimParams {
    /// Particles along the row direction (grid is `rows x cols`, index = row * cols + col).
    pub rows: u32,
    pub cols: u32,
    pub particle_count: u32,
    /// `integrator::RK4` or `integrator::SEMI_IMPLICIT_EULER`.
    pub integrator: u32,
    /// Gravity acceleration (m/s^2), w unused.
    pub gravity: Vec4,
    /// Constant external force on every free particle (N), e.g. wind; w unused.
    pub external_force: Vec4,
    /// Spring stiffness (N/m) per family.
    pub k_struct: f32,
    pub k_shear: f32,
    pub k_bend: f32,
    /// Damping along each spring's axis (N s/m): damps stretching, not rigid motion.
    pub spring_damping: f32,
    /// The paper's eq. 2 damping `f = -c_d v` (N s/m).
    pub velocity_damping: f32,
    /// Mass of one particle (kg).
    pub particle_mass: f32,
    /// Substep length h (s).
    pub substep: f32,
    pub _pad0: u32,
    /// Rest lengths (m): x = one column step, y = one row step, z = diagonal (+row,+col),
    /// w = anti-diagonal (+row,-col). Bend springs are two steps: twice x and y.
    pub rest: Vec4,
}

/// Per-dispatch constants of the cloth integrator kernel.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct StagePush {
    /// 0..=3: which Runge-Kutta stage (or 0 = evaluate / 3 = commit for Euler).
    pub stage: u32,
    pub _pad: [u32; 3],
}

/// Per-dispatch constants of the one-workgroup integrator (`integrate::integrate_substeps`):
/// a frame's substeps in one dispatch.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SubstepsPush {
    /// Substeps to run, each all of its integrator's stages.
    pub substeps: u32,
    pub _pad: [u32; 3],
}

/// Blow-up detector, written by the `check_health` kernel once per frame (atomics).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Health {
    /// Count of particles whose position or velocity is not finite.
    pub non_finite: u32,
    /// Largest structural-spring stretch (length / rest), as `f32::to_bits` (positive floats
    /// order like their bits, so `atomic_u_max` on the bits is a float max).
    pub max_stretch_bits: u32,
    /// Largest particle speed (m/s) at the end of the frame, as `f32::to_bits` (the contact
    /// substep bound).
    pub max_speed_bits: u32,
    /// Largest distance (m) a particle moved over the frame's last substep, contact included,
    /// as `f32::to_bits` (sleeping: a particle resting on a collider has speed g h at a
    /// substep's end, but does not move).
    pub max_moved_bits: u32,
    /// Self-collision corrections applied over the frame (particles moved, summed over its
    /// passes; written by `apply_self_contact`): a cloth in contact with itself runs a pass
    /// every substep (each pass is also an iteration of its contacts).
    pub self_contacts: u32,
    /// Cloth triangles that walked the self-collision tree because they left their predicted
    /// region, summed over the frame's passes (`self_pairs`).
    pub self_walks: u32,
    /// Cloth triangles whose self-collision pair list was full this frame (or that are too
    /// small for one): they walk at every pass (`self_pairs`).
    pub self_full_lists: u32,
    /// The cloth's tiles that slept this frame (`drape_kernels::tiles`): their particles
    /// neither integrated nor collided.
    pub tiles_asleep: u32,
    /// Particles self-collision's fail-safe put back where the frame started (two of the cloth's
    /// triangles, or one and a collider's, intersected at its end: `drape_kernels::self_failsafe`).
    pub self_rollbacks: u32,
    /// 1 when the fail-safe's last round still found a crossing pair and the whole cloth went
    /// back to the frame's start.
    pub self_rollback_all: u32,
    /// Largest relative motion over the frame (m, as `f32::to_bits`) its velocities predicted
    /// at its start for two primitives of the cloth that its pair lists found may touch
    /// (`drape_kernels::self_pairs`): what its passes had to resolve, a thickness at a time,
    /// while the cloth touches itself (its layers slide over each other's faces and folds).
    pub self_pair_motion_bits: u32,
    /// The same pairs' largest approach (m, as `f32::to_bits`): how far their ends close along
    /// the direction they were apart in at the frame's start. What the passes of a cloth that
    /// does not touch itself must resolve: a pair that only slides past another never closes.
    pub self_pair_approach_bits: u32,
    /// Largest push a collider vertex gave a cloth face in one self-collision pass, in
    /// thicknesses of that collider's contact (as `f32::to_bits`; `drape_kernels::self_contact`):
    /// a face within the thickness takes at most 1, so more means the face passed the vertex
    /// within the pass (a spike's tip holding the cloth up), by the excess.
    pub collider_feature_push_bits: u32,
    /// Pairs of a cloth triangle and a collider triangle that self-collision's fail-safe found
    /// crossed at the frame's end (summed over its rounds; `drape_kernels::self_failsafe`): a
    /// collider's vertex or edge through a cloth cell, or a cloth edge through its face.
    pub self_rollback_collider_pairs: u32,
    /// Of the particles self-collision's fail-safe put back (`self_rollbacks`), those carried
    /// with a moving collider (its surface under them, or its pose for a pair of the cloth's own
    /// near it).
    pub self_rollbacks_carried: u32,
    /// Particle-substeps whose narrow phase over candidate lists was crowded (see
    /// `ContactPush::crowded`; counted only where the frame asks): what the host's choice of
    /// handing them to a workgroup each follows (`SimSettings::crowded_contact`).
    pub crowded_contacts: u32,
    /// Triangle colliders whose sharp features this frame's self-collision passes tested by
    /// walks from the cloth's side (`drape_kernels::feature_walks`; one a collider a frame).
    pub feature_walks_from_cloth: u32,
    /// The box around a self-colliding cloth at the frame's start and where its velocities
    /// carry it over the frame, grown by its thickness (the self-collision tree's Morton box,
    /// `ColliderParams::scene_min`/`scene_max`): xyz, with w = 1 where the frame wrote it (0: a
    /// cloth without self-collision). The host tells by it which moving colliders come near the
    /// cloth.
    pub self_scene_low: [f32; 4],
    pub self_scene_high: [f32; 4],
    /// A triangle collider's possibly sharp triangles that no cloth triangle keeping to its
    /// predicted region could reach over a span of the frame's self-collision lists, summed over
    /// the spans (`drape_kernels::feature_reach`): the passes walk the cloth's tree from the others.
    pub collider_features_out_of_reach: u32,
}

/// One spring of a spring-list cloth (a cloth built from a triangle mesh), as seen from one of
/// its ends: every spring is stored at both ends, so each particle gathers its own force and
/// no thread writes another's. Its stiffness and damping are its family's (`SimParams::k_struct`,
/// ..., `SimParams::spring_damping`) times its `stiffness_scale`, so runtime stiffness changes
/// apply to every cloth alike.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Spring {
    /// The particle at the other end.
    pub other: u32,
    /// Rest length (m).
    pub rest: f32,
    /// Spring family: `drape_kernels::cloth::{STRUCTURAL, SHEAR, BEND}`.
    pub family: u32,
    /// What share of its family's stiffness and damping the spring has: 1 for a grid's and a
    /// bend spring; for a structural spring on a mesh's edge, the area of the edge's triangles
    /// over its squared rest length (Van Gelder 1998), 1 on a square grid's sides, so a mesh of
    /// long thin triangles is the same material as a regular one.
    pub stiffness_scale: f32,
}

/// A particle of a spring-list cloth: its springs are `springs[first..first + count]`.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct ParticleSprings {
    pub first: u32,
    pub count: u32,
    /// 1 / mass (1/kg): a mesh's particles carry the mass of their share of its area.
    pub inverse_mass: f32,
    pub _pad: u32,
}

const _: () = assert!(core::mem::size_of::<SimParams>() == 96);
const _: () = assert!(core::mem::size_of::<Spring>() == 16);
const _: () = assert!(core::mem::size_of::<ParticleSprings>() == 16);
const _: () = assert!(core::mem::size_of::<StagePush>() == 16);
const _: () = assert!(core::mem::size_of::<SubstepsPush>() == 16);
const _: () = assert!(core::mem::size_of::<Health>() == 104);
const _: () = assert!(core::mem::size_of::<FailsafePush>() == 16);
const _: () = assert!(core::mem::size_of::<CarrierPush>() == 16);
const _: () = assert!(core::mem::size_of::<ColliderPose>() == 80);
const _: () = assert!(core::mem::size_of::<TileParams>() == 32);
const _: () = assert!(core::mem::size_of::<SphereLeaf>() == 32);

/// Marks a child index in `BvhNode` as a leaf (sorted sphere index) rather than an internal node.
pub const LEAF_BIT: u32 = 0x8000_0000;
/// "No node" (the root's parent).
pub const NO_NODE: u32 = u32::MAX;

/// An internal node of the LBVH (Karras 2012 layout: N-1 internal nodes for N leaves, node 0 is
/// the root). Children are internal node indices, or sorted leaf indices with `LEAF_BIT` set.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct BvhNode {
    pub left: u32,
    pub right: u32,
    /// Where a depth-first walk goes after this node's subtree: the subtree that starts at the
    /// leaf after its last (an internal node, or a leaf with `LEAF_BIT`), or `NO_NODE` when it
    /// ends the tree. A stackless walk follows it when the node's box fails its query.
    pub escape: u32,
    /// Where a depth-first walk goes after the leaf of the same index (`escape` for that leaf;
    /// the last leaf has no node of its index: its walk ends).
    pub leaf_escape: u32,
}

/// Axis-aligned box: `min.xyz`, `max.xyz` (w unused). Internal node bounds of the LBVH. The
/// bottom-up refit writes these through device atomics as 8 u32 words per box.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Aabb {
    pub min: Vec4,
    pub max: Vec4,
}

/// u32 words per `Aabb` (as the refit kernel addresses them).
pub const AABB_WORDS: u32 = 8;

/// An internal node of a self-colliding cloth's tree as its pair lists' walk reads it
/// (`self_pairs::pack_walk_node_at`): its start box and motion box in 16-bit fixed point over
/// the root's, rounded outwards (two coordinates a word: the start box's min xyz and max xyz,
/// then the motion box's), its left child and its escape. Two loads where the node and its two
/// boxes took five: llvmpipe loads a per-lane address lane by lane, once per load.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct WalkNode {
    /// Start box min x | y, min z | max x, max y | z, motion box min x | y (low | high 16 bits).
    pub boxes: glam::UVec4,
    /// Motion box min z | max x, max y | z, then the left child and the escape (`BvhNode`).
    pub motions_and_links: glam::UVec4,
}

/// Constants of a collider (LBVH over spheres) and of the contact model.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct ColliderParams {
    /// Number of leaves (spheres), N >= 1.
    pub leaf_count: u32,
    /// Contact thickness (m): a particle closer than radius + thickness to a sphere's centre
    /// is in contact.
    pub thickness: f32,
    /// Coulomb friction coefficient of the contact (0 = the paper's frictionless response).
    pub friction: f32,
    /// A triangle collider's: how far each of its covered features (the host's
    /// `collider_cover`) lies at most from a kept one, all of them always tested (measured on
    /// its first shape, grown by twice the farthest a vertex has since moved from it); the passes
    /// skip the covered ones while this is at most `COVER_LIMIT` of the thickness (0: none).
    pub cover_reach: f32,
    /// Box that normalises leaf centres for Morton codes (the spheres' centre bounds).
    pub scene_min: Vec4,
    pub scene_max: Vec4,
}

/// A rigid transform: rotate by the unit quaternion `rotation` (xyz = vector part, w = scalar
/// part), then translate by `translation.xyz` (w unused). Maps a collider's own frame, where
/// its LBVH is built, to the world.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct RigidPose {
    pub rotation: Vec4,
    pub translation: Vec4,
}

impl RigidPose {
    /// The identity transform.
    pub const IDENTITY: RigidPose = RigidPose { rotation: Vec4::new(0.0, 0.0, 0.0, 1.0), translation: Vec4::ZERO };
}

impl Default for RigidPose {
    fn default() -> Self {
        RigidPose::IDENTITY
    }
}

/// A collider's pose at the start and at the end of the frame. Contact interpolates between
/// them per substep and tests the particle's motion relative to the collider's, so a moving
/// collider sweeps the cloth instead of jumping through it.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct ColliderPose {
    pub previous: RigidPose,
    pub current: RigidPose,
    /// x: how far any point of the collider's surface moves over the frame at most (m), by its
    /// pose and its leaves' own motion together; 0 when it stands still. What self-collision's
    /// fail-safe reaches by for the particles the collider may carry. y: 1 when the frame's
    /// start wrote the collider's vertices (it deforms, stopped deforming or was given a new
    /// shape), else 0: what its cached folds are measured anew by
    /// (`drape_kernels::sharp_features`). zw: 0.
    pub sweep: Vec4,
}

/// Push constants of the contact passes: the substep's span as fractions of the frame
/// (`from` = s / S, `to` = (s + 1) / S for substep s of S), and what the narrow phase over
/// candidate lists does with its crowded particles (`drape_kernels::crowded`): with `crowded` >
/// 0 those that walk the tree and those whose lists hold at least `crowded` leaves are crowded,
/// counted in the cloth's `Health::crowded_contacts`, and with `hand_over` = 1 handed to a
/// workgroup each; with `crowded` = 0 nothing is counted or handed over.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct ContactPush {
    pub from: f32,
    pub to: f32,
    pub crowded: u32,
    pub hand_over: u32,
}

/// Push constants of a self-collision pass's triangle boxes: the pass's span as fractions of the
/// frame (as `ContactPush`), and whether this run of the boxes also finds the triangles that
/// walk in the pass: 0 no, 1 yes (`drape_kernels::self_pairs::FIND_WALKERS`; a second run after
/// the collider edges' pushes finds them anew). `beyond`: how far past its slop a corner that
/// did not escape may lie, as a share of the thickness (0 for a pass; the fail-safe's check lets
/// its corners end `LIST_CHECK_BEYOND` past them), which a tree derived for the span
/// (`drape_kernels::self_pass_tree`) takes in.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SelfPassPush {
    pub from: f32,
    pub to: f32,
    pub find_walkers: u32,
    pub beyond: f32,
}

/// Push constants of a self-collision list build (`drape_kernels::self_pairs`): what scales the
/// motion its window measures to the frame (the frame's substeps over the window's; 1 for lists
/// over the whole frame).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SelfListPush {
    pub to_frame: f32,
    pub _pad: [u32; 3],
}

/// Push constants of a round of self-collision's fail-safe (`drape_kernels::self_failsafe`):
/// which round, its flags (`drape_kernels::self_failsafe::LAST_ROUND`, `WITH_LISTS`; for the
/// boxes, `WINDOWED`), and the
/// workgroups of the next round's boxes and check, and of its roll-back (dispatched only when
/// this round put a particle back).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct FailsafePush {
    pub round: u32,
    pub flags: u32,
    pub check_groups: u32,
    pub rollback_groups: u32,
}

/// Push constants of the fail-safe's carriers pass (`drape_kernels::self_failsafe`): which of
/// the model's colliders the pass queries (its slot in the carrier poses).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct CarrierPush {
    pub slot: u32,
    pub _pad: [u32; 3],
}

/// A cloth's tile sleeping (`drape_kernels::tiles`): its particles in tiles of
/// `TILE_PARTICLES` consecutive indices, each tile asleep once it and the tiles its springs
/// reach stayed still for `still_frames` frames, with no collider moving near it.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct TileParams {
    pub particle_count: u32,
    pub tile_count: u32,
    /// Consecutive still frames before a tile sleeps (>= 1).
    pub still_frames: u32,
    /// Colliders moving this frame: their swept boxes, grown by their thickness, lead the
    /// moving-box buffer (written by the host at the frame's start).
    pub moving_colliders: u32,
    /// The largest motion over a frame (m) that counts as still.
    pub still_motion: f32,
    pub _pad: [u32; 3],
}

/// Push constants of the broad phase (once per frame, before the substeps).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct BroadPhasePush {
    /// Substeps in the frame (the frame lasts `substeps` x `SimParams::substep`).
    pub substeps: u32,
    pub _pad: [u32; 3],
}

/// Push constants of a self-colliding cloth's anchors (`drape_kernels::self_pairs::anchor_at`):
/// the substeps their predictions span (the frame's, or a window's of it when its lists are
/// built again within the frame) and the frame's substeps (the tree's Morton box spans the
/// frame whatever the window, so the tree does not depend on how the frame is split).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SelfAnchorPush {
    pub window_substeps: u32,
    pub frame_substeps: u32,
    pub _pad: [u32; 2],
}

/// Leaves a particle's candidate list holds at most (the broad phase's output per particle).
pub const MAX_CANDIDATES: u32 = 64;
/// `ContactQuery::count` of a list that would have held more than `MAX_CANDIDATES`.
pub const CANDIDATES_OVERFLOWED: u32 = u32::MAX;

/// A particle's broad-phase query, in the collider's frame: the box its motion is expected to
/// stay in over the frame, and how many leaves near it its candidate list holds. Every leaf
/// the particle can touch while its substep motion stays inside the box is in the list.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct ContactQuery {
    /// The query box (xyz; w unused).
    pub low: Vec4,
    pub high: Vec4,
    /// Leaves in the list, or `CANDIDATES_OVERFLOWED`.
    pub count: u32,
    pub _pad: [u32; 3],
}

/// Push constants of the surface shaders (`render::surface_vertex` / `surface_fragment`): how a
/// renderer draws a cloth or a collider straight from its vertex buffers. 128 bytes, the
/// minimum push-constant size every Vulkan device supports.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SurfacePush {
    /// Columns of the world -> clip matrix.
    pub view_projection: [Vec4; 4],
    /// The drawn object's rigid pose (identity for a cloth: its positions are in the world).
    pub pose: RigidPose,
    /// Linear RGB of the surface, a = ambient share of the light.
    pub color: Vec4,
    /// World direction towards the light (xyz, unit).
    pub light: Vec4,
}

/// Push constants of the sort and scan passes.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SortPush {
    /// Bit offset of this pass's 8-bit digit.
    pub shift: u32,
    /// Number of elements (keys, or scan entries).
    pub count: u32,
    /// Number of tiles (workgroups) of the keys pass.
    pub tiles: u32,
    pub _pad: u32,
}

/// Collision pass counters, reset every frame and read by the host.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct CollisionStatus {
    /// Substeps whose traversal was skipped because the cloth cannot touch the collider (the
    /// culling pass), or, where the narrow phase over candidate lists runs inside the
    /// integrator's last stage (no culling pass), because the frame's broad phase listed no
    /// particle: then only particles that left their query box walk the tree.
    pub skipped: u32,
    /// Substeps whose traversal ran (or whose frame listed particles, as above).
    pub ran: u32,
    /// Particle-substeps the narrow phase answered by a full traversal instead of the
    /// particle's candidate list (it left its query box, or its list had overflowed).
    pub fallbacks: u32,
    /// Particles the frame's broad phase gave a candidate (or an overflowed list): when any,
    /// the cloth is at the collider and the substeps' culling passes, where there are any, do
    /// not test.
    pub listed: u32,
    /// Particle-substeps the narrow phase handed to the crowded pass (a workgroup each:
    /// `drape_kernels::crowded`); their full traversals count in `fallbacks` as the lane's do.
    pub crowded: u32,
    pub _pad: [u32; 3],
}

/// A collider triangle at the end of the frame: its corners (xyz) and unit normal (the
/// corners' w: `a.w`, `b.w`, `c.w` = x, y, z; zero for a degenerate triangle), in the
/// collider's own frame, and how it moved over the frame when the collider deforms: a leaf of
/// the triangle leaf kind, gathered into the tree's order.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Triangle {
    pub a: Vec4,
    pub b: Vec4,
    pub c: Vec4,
    /// xyz: the centroid's displacement over the frame (end minus start); w: how far any corner
    /// moved beyond that translation (zero for a static or rigidly moving collider, whose
    /// motion is its pose's).
    pub sweep: Vec4,
}

/// A collider sphere at the end of the frame (xyz centre, w radius, in the collider's own
/// frame) and how it moved and grew over the frame when the collider deforms: a leaf of the
/// sphere leaf kind, gathered into the tree's order.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SphereLeaf {
    pub sphere: Vec4,
    /// The sphere at the frame's end less the sphere at its start: xyz the centre's
    /// displacement, w the radius's growth (zero for a static or rigidly moving collider, whose
    /// motion is its pose's).
    pub sweep: Vec4,
}

/// "No leaf" in a `Contact`.
pub const NO_LEAF: u32 = u32::MAX;

/// A particle's contact with a collider, in the collider's frame: what a detect pass writes
/// (one per particle per substep) and the respond pass applies.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Contact {
    /// xyz: where the particle goes (on the thickness-grown surface); w: the hit parameter along
    /// the particle's substep motion (0 = it started within the thickness; > 1 = no contact).
    pub position: Vec4,
    /// xyz: the surface's outward unit normal there; w: the leaf kind's tie-break key of the
    /// contact (spheres: how deep the motion ended inside; triangles: distance to the surface).
    pub normal: Vec4,
    /// The leaf touched (tree order), `NO_LEAF` for none.
    pub leaf: u32,
    /// How far the leaf's surface itself moves over the frame at the contact point, in the
    /// collider's frame (a deforming collider's, from its vertices; zero for a leaf that does
    /// not move): the response adds its velocity to the pose's, so friction drags the cloth
    /// along a surface that slides.
    pub leaf_motion: [f32; 3],
}

impl Contact {
    /// No contact.
    pub const NONE: Contact =
        Contact { position: Vec4::new(0.0, 0.0, 0.0, 2.0), normal: Vec4::ZERO, leaf: NO_LEAF, leaf_motion: [0.0; 3] };

    /// Whether there is a contact to respond to.
    #[inline]
    pub fn is_some(&self) -> bool {
        self.position.w <= 1.0
    }
}

/// `vkCmdDispatchIndirect` arguments, written by the culling kernel.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct DispatchArgs {
    pub x: u32,
    pub y: u32,
    pub z: u32,
    pub _pad: u32,
}

const _: () = assert!(core::mem::size_of::<BvhNode>() == 16);
const _: () = assert!(core::mem::size_of::<Aabb>() == 32);
const _: () = assert!(core::mem::size_of::<Aabb>() == AABB_WORDS as usize * 4);
const _: () = assert!(core::mem::size_of::<ColliderParams>() == 48);
const _: () = assert!(core::mem::size_of::<SortPush>() == 16);
const _: () = assert!(core::mem::size_of::<RigidPose>() == 32);
const _: () = assert!(core::mem::size_of::<WalkNode>() == 32);
const _: () = assert!(core::mem::size_of::<ContactPush>() == 16);
const _: () = assert!(core::mem::size_of::<SelfPassPush>() == 16);
const _: () = assert!(core::mem::size_of::<SelfListPush>() == 16);
const _: () = assert!(core::mem::size_of::<BroadPhasePush>() == 16);
const _: () = assert!(core::mem::size_of::<SelfAnchorPush>() == 16);
const _: () = assert!(core::mem::size_of::<ContactQuery>() == 48);
const _: () = assert!(core::mem::size_of::<SurfacePush>() == 128);
const _: () = assert!(core::mem::size_of::<CollisionStatus>() == 32);
const _: () = assert!(core::mem::size_of::<DispatchArgs>() == 16);
const _: () = assert!(core::mem::size_of::<Contact>() == 48);
const _: () = assert!(core::mem::size_of::<Triangle>() == 64);
