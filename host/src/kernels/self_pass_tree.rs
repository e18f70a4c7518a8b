//! A self-collision pass's tree from the lists' tree (`drape_kernels::self_pass_tree`): each
//! internal node's bound over the pass, then the walkers' climbs widening it to their boxes.

use super::self_pairs::triangle_bounds_over;
use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::self_pairs::WALK_THREADS;
use drape_kernels::self_pass_tree::{pass_node_box_at, widen_to_leaf_at};
use drape_types::{Aabb, ColliderParams, DispatchArgs, SelfPassPush};
use glam::Vec4;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// Each internal node's box over the pass from the lists' tree (push constants:
/// `SelfPassPush`, the pass's span).
pub static DERIVE_PASS_TREE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pass_tree::derive_pass_tree",
        bindings: &[read("self_params"), read("span_aabbs"), read("motion_aabbs"), read("anchors"), write("aabbs")],
        push_constant_size: size_of::<SelfPassPush>() as u32,
        workgroup_size: 256,
    },
    cpu: derive_cpu,
};

fn derive_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let span: SelfPassPush = d.push_as();
    let threads = d.invocations();
    let [self_params, span_aabbs, motion_aabbs, anchors, aabbs] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let boxes = (span_aabbs.slice::<Aabb>(), motion_aabbs.slice::<Aabb>());
    let (anchors, aabbs) = (anchors.slice::<Vec4>(), aabbs.slice_mut::<Aabb>());
    for i in 0..threads.min(c.leaf_count.saturating_sub(1)) {
        pass_node_box_at(i, (&span, c.thickness), boxes, anchors, aabbs);
    }
    Ok(())
}

/// A pass's second run (after the collider's pushes): each triangle's box and whether it walks,
/// and each internal node's box over the pass, in one dispatch (push constants:
/// `SelfPassPush`).
pub static TRIANGLE_BOUNDS_AND_PASS_TREE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pass_tree::triangle_bounds_and_pass_tree",
        bindings: &[
            read("self_params"),
            read("x"),
            read("x_prev"),
            read("indices"),
            read("anchors"),
            read("leaf_of"),
            write("leaf_bounds"),
            write("escaped"),
            write("strays"),
            write("walkers"),
            write("walk_args"),
            read("tree_every_pass"),
            write("pass_refit"),
            read("span_aabbs"),
            read("motion_aabbs"),
            write("aabbs"),
        ],
        push_constant_size: size_of::<SelfPassPush>() as u32,
        workgroup_size: 256,
    },
    cpu: bounds_and_tree_cpu,
};

fn bounds_and_tree_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let span: SelfPassPush = d.push_as();
    let threads = d.invocations();
    let [
        self_params,
        x,
        x_prev,
        indices,
        anchors,
        leaf_of,
        leaf_bounds,
        escaped,
        strays,
        walkers,
        walk_args,
        tree_every_pass,
        pass_refit,
        span_aabbs,
        motion_aabbs,
        aabbs,
    ] = d.bindings()?;
    // The derivation below reads the anchors too.
    let bounds = [
        self_params,
        x,
        x_prev,
        indices,
        &mut *anchors,
        leaf_of,
        leaf_bounds,
        escaped,
        strays,
        walkers,
        walk_args,
        tree_every_pass,
        pass_refit,
    ];
    let c = triangle_bounds_over(&span, threads, bounds)?;
    let boxes = (span_aabbs.slice::<Aabb>(), motion_aabbs.slice::<Aabb>());
    let (anchors, aabbs) = (anchors.slice::<Vec4>(), aabbs.slice_mut::<Aabb>());
    for i in 0..threads.min(c.leaf_count.saturating_sub(1)) {
        pass_node_box_at(i, (&span, c.thickness), boxes, anchors, aabbs);
    }
    Ok(())
}

/// Each walker's climb to the root, widening the nodes above it to its box (over the walks'
/// indirect dispatch; nothing where the boxes were not derived before it, `derived`).
pub static WIDEN_PASS_TREE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pass_tree::widen_pass_tree",
        bindings: &[
            read("self_params"),
            read("parents"),
            read("leaf_bounds"),
            read("walkers"),
            read("walk_args"),
            read("derived"),
            write("aabbs"),
        ],
        push_constant_size: 0,
        workgroup_size: WALK_THREADS,
    },
    cpu: widen_cpu,
};

fn widen_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, parents, leaf_bounds, walkers, walk_args, derived, aabbs] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    if derived.first::<DispatchArgs>()?.x == 0 {
        return Ok(());
    }
    let walking = walk_args.first::<DispatchArgs>()?._pad;
    let (parents, leaf_bounds, walkers) = (parents.slice::<u32>(), leaf_bounds.slice::<Aabb>(), walkers.slice::<u32>());
    let words = aabbs.slice_mut::<u32>();
    for k in 0..threads.min(walking) {
        let leaf = *walkers.get(k as usize).ok_or("a walker past the walkers' list")?;
        widen_to_leaf_at(leaf, c.leaf_count, parents, leaf_bounds, words);
    }
    Ok(())
}
