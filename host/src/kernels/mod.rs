//! Every kernel drape dispatches, one file per kernel family: its binding tables (written once,
//! checked against the SPIR-V by `tests/engine.rs`) and its CPU adapter, which runs the kernel's
//! own functions from `drape-kernels` over host buffers. Adding a kernel means adding it to its
//! family's file and to `ALL`.

pub mod contact;
pub mod feature_reach;
pub mod feature_walks;
pub mod integrate;
pub mod lbvh;
pub mod normals;
pub mod self_contact;
pub mod self_failsafe;
pub mod self_pairs;
pub mod self_pass_tree;
pub mod sharp_features;
pub mod sort;
pub mod spheres;
pub mod tiles;
pub mod triangles;

use crate::graph::Kernel;

/// Every kernel in the SPIR-V module.
pub const ALL: [&Kernel; 70] = [
    &integrate::INTEGRATE_STAGE,
    &integrate::INTEGRATE_STAGE_SPRINGS,
    &integrate::INTEGRATE_SUBSTEPS,
    &integrate::INTEGRATE_SUBSTEPS_SPRINGS,
    &normals::NORMALS_AND_HEALTH,
    &normals::MESH_NORMALS_AND_HEALTH,
    &normals::CHECK_HEALTH,
    &normals::CHECK_HEALTH_SPRINGS,
    &self_contact::SELF_SCENE_BOUNDS,
    &self_pairs::ANCHOR_WINDOW,
    &self_pairs::CLOTH_TRIANGLE_STARTS,
    &self_pairs::CLOTH_TRIANGLE_BOUNDS,
    &self_contact::GATHER_CLOTH_TRIANGLES,
    &self_pairs::REGATHER_CLOTH_TRIANGLES,
    &self_pairs::LIST_SELF_PAIRS,
    &self_pairs::PACK_WALK_NODES,
    &self_pairs::LISTED_SELF_PAIRS,
    &self_pairs::SELF_TRIANGLE_CONTACT,
    &self_pairs::WALK_SELF_PAIRS,
    &self_pairs::TEST_QUEUED_PAIRS,
    &self_pass_tree::DERIVE_PASS_TREE,
    &self_pass_tree::WIDEN_PASS_TREE,
    &self_pass_tree::TRIANGLE_BOUNDS_AND_PASS_TREE,
    &sharp_features::LIST_SHARP_FEATURES,
    &self_contact::COLLIDER_FEATURE_CONTACT,
    &feature_walks::CHOOSE_FEATURE_WALKS,
    &feature_walks::COLLIDER_FEATURES_FROM_CLOTH,
    &feature_walks::COLLIDER_FEATURES_FROM_WALKERS,
    &feature_reach::MARK_OUT_OF_REACH,
    &self_contact::APPLY_SELF_CONTACT,
    &self_contact::APPLY_COLLIDER_PUSHES,
    &self_failsafe::FAILSAFE_BOXES,
    &self_failsafe::WIDEN_FAILSAFE_TREE,
    &self_failsafe::FAILSAFE_BOXES_AND_REFIT,
    &self_failsafe::FAILSAFE_CHECK,
    &self_failsafe::FAILSAFE_CARRIERS_TRIANGLES,
    &self_failsafe::FAILSAFE_CARRIERS_SPHERES,
    &self_failsafe::FAILSAFE_COLLIDER_CHECK,
    &self_failsafe::FAILSAFE_ROLL_BACK,
    &sort::RADIX_COUNT,
    &sort::RADIX_SCATTER,
    &sort::SCAN_BLOCKS,
    &sort::SCAN_ADD,
    &lbvh::MORTON_CODES,
    &lbvh::GATHER_BOUNDS,
    &lbvh::BUILD_NODES,
    &lbvh::REFIT,
    &lbvh::REFIT_TWO,
    &spheres::SPHERE_BOUNDS,
    &spheres::GATHER_SPHERES,
    &spheres::DETECT_SPHERES,
    &spheres::DETECT_SPHERES_BRUTE_FORCE,
    &spheres::BROAD_PHASE_SPHERES,
    &spheres::DETECT_SPHERES_CANDIDATES,
    &spheres::DETECT_SPHERES_CROWDED,
    &spheres::UPDATE_CONTACT_SPHERES,
    &spheres::UPDATE_CONTACT_SPHERES_SPRINGS,
    &triangles::TRIANGLE_BOUNDS,
    &triangles::GATHER_TRIANGLES,
    &triangles::DETECT_TRIANGLES,
    &triangles::DETECT_TRIANGLES_BRUTE_FORCE,
    &triangles::BROAD_PHASE_TRIANGLES,
    &triangles::DETECT_TRIANGLES_CANDIDATES,
    &triangles::DETECT_TRIANGLES_CROWDED,
    &triangles::UPDATE_CONTACT_TRIANGLES,
    &triangles::UPDATE_CONTACT_TRIANGLES_SPRINGS,
    &contact::CULL_CONTACT,
    &contact::RESPOND_CONTACTS,
    &tiles::MEASURE_TILES,
    &tiles::DECIDE_TILES,
];
