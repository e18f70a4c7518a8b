//! Self-collision pair kernels (`drape_kernels::self_pairs`): the triangles' regions over the
//! frame (the frame's tree), the frame's pair lists, each pass's triangle boxes with whether
//! each triangle escaped its region, and the pass's pairs (lists, or walks of the tree).

use crate::graph::{BindingSpec, HostBuffer, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::contact::CONTACT_THREADS;
use drape_kernels::self_contact::PairResponse;
use drape_kernels::self_contact::frame_of;
use drape_kernels::self_contact::self_triangle_contact_at;
use drape_kernels::self_pairs::{
    LIST_OVERFLOWED, QUEUE_THREADS, WALK_THREADS, anchor_window_at, count_full_list, list_self_pairs_at,
    listed_self_pairs_at, note_pair_motion, pack_walk_node_at, queued_pairs, regather_cloth_triangle,
    test_queued_pair_at, triangle_bounds_at, triangle_start_at, walk_self_pairs_at,
};
use drape_types::{
    Aabb, BvhNode, ColliderParams, DispatchArgs, Health, SelfAnchorPush, SelfListPush, SelfPassPush, SimParams,
    WalkNode,
};
use glam::{UVec4, Vec4};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// Each particle's prediction over a window of the frame that starts now (its frame start
/// stays); push constants: `SelfAnchorPush` (the window's substeps).
pub static ANCHOR_WINDOW: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::anchor_window",
        bindings: &[read("params"), read("self_params"), read("x"), read("v"), write("anchors")],
        push_constant_size: size_of::<SelfAnchorPush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: window_cpu,
};

fn window_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SelfAnchorPush = d.push_as();
    let threads = d.invocations();
    let [params, self_params, x, v, anchors] = d.bindings()?;
    let p: SimParams = params.first()?;
    let frame = frame_of(&p, &self_params.first::<ColliderParams>()?, push.window_substeps);
    let (x, v, anchors) = (x.slice::<Vec4>(), v.slice::<Vec4>(), anchors.slice_mut::<Vec4>());
    for i in 0..threads.min(p.particle_count) {
        anchor_window_at(i, (x, v), frame, anchors);
    }
    Ok(())
}

/// Each triangle's box at the frame's start, its corners grown by their slops (the frame's
/// tree is built over these).
pub static CLOTH_TRIANGLE_STARTS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::cloth_triangle_starts",
        bindings: &[read("self_params"), read("anchors"), read("indices"), write("bounds")],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: starts_cpu,
};

/// Each sorted leaf's triangle, leaf, start box and motion box where the tree keeps its order
/// (`drape_kernels::self_pairs::regather_cloth_triangle`).
pub static REGATHER_CLOTH_TRIANGLES: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::regather_cloth_triangles",
        bindings: &[
            read("self_params"),
            read("indices"),
            read("order"),
            read("anchors"),
            write("sorted"),
            write("leaf_of"),
            write("sorted_bounds"),
            write("leaf_motions"),
        ],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: regather_cpu,
};

/// Each triangle's box over the pass and, in a run that finds them (`SelfPassPush`'s
/// `find_walkers`), whether it escaped its region and the pass's walkers (escaped, or with an
/// overflowed list); push constants: `SelfPassPush`.
pub static CLOTH_TRIANGLE_BOUNDS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::cloth_triangle_bounds",
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
        ],
        push_constant_size: size_of::<SelfPassPush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: bounds_cpu,
};

/// The frame's tree's internal nodes packed for the lists' walk (`WalkNode`): 16-bit boxes
/// and the links, after the motion boxes' refit; and their start boxes kept for the passes'
/// trees (`drape_kernels::self_pass_tree`).
pub static PACK_WALK_NODES: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::pack_walk_nodes",
        bindings: &[
            read("self_params"),
            read("nodes"),
            read("aabbs"),
            read("motion_aabbs"),
            write("walk_nodes"),
            write("span_aabbs"),
        ],
        push_constant_size: 0,
        workgroup_size: 256,
    },
    cpu: pack_cpu,
};

fn pack_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, nodes, aabbs, motion_aabbs, walk_nodes, span_aabbs] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let (nodes, boxes) = (nodes.slice::<BvhNode>(), (aabbs.slice::<Aabb>(), motion_aabbs.slice::<Aabb>()));
    let (walk_nodes, span_aabbs) = (walk_nodes.slice_mut::<WalkNode>(), span_aabbs.slice_mut::<Aabb>());
    for i in 0..threads.min(c.leaf_count.saturating_sub(1)) {
        pack_walk_node_at(i, nodes, boxes, walk_nodes);
        span_aabbs[i as usize] = boxes.0[i as usize];
    }
    Ok(())
}

/// Every triangle's list of the later triangles it may touch within the frame (one walk of the
/// frame's tree each).
pub static LIST_SELF_PAIRS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::list_self_pairs",
        bindings: &[
            read("self_params"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("owned"),
            read("anchors"),
            read("motion_aabbs"),
            read("leaf_motions"),
            read("walk_nodes"),
            write("lists"),
            write("counts"),
            write("health"),
            write("tree_every_pass"),
        ],
        push_constant_size: size_of::<SelfListPush>() as u32,
        workgroup_size: CONTACT_THREADS,
    },
    cpu: lists_cpu,
};

/// Every cloth triangle that did not escape: its owned corners against the triangles of its
/// list and its owned edges against their owned edges (through the tree when its list is full).
pub static LISTED_SELF_PAIRS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::listed_self_pairs",
        bindings: &[
            read("self_params"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("owned"),
            read("x"),
            read("x_prev"),
            read("v"),
            read("escaped"),
            read("strays"),
            read("lists"),
            read("counts"),
            write("delta"),
            write("velocity_changes"),
            read("rest_shape"),
        ],
        push_constant_size: size_of::<SelfPassPush>() as u32,
        workgroup_size: CONTACT_THREADS,
    },
    cpu: listed_cpu,
};

/// Every cloth triangle's pairs through the tree (a cloth too fine for lists).
pub static SELF_TRIANGLE_CONTACT: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::self_triangle_contact",
        bindings: &[
            read("self_params"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("owned"),
            read("x"),
            read("x_prev"),
            read("v"),
            write("delta"),
            write("velocity_changes"),
            read("rest_shape"),
        ],
        push_constant_size: 0,
        workgroup_size: CONTACT_THREADS,
    },
    cpu: walk_all_cpu,
};

/// The pass's walkers (indirect): their pairs through the tree.
pub static WALK_SELF_PAIRS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::walk_self_pairs",
        bindings: &[
            read("self_params"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("owned"),
            read("x"),
            read("x_prev"),
            read("v"),
            read("escaped"),
            read("counts"),
            read("walkers"),
            read("walk_args"),
            write("delta"),
            write("velocity_changes"),
            write("queue"),
            write("queue_args"),
            write("health"),
            read("rest_shape"),
        ],
        push_constant_size: 0,
        workgroup_size: WALK_THREADS,
    },
    cpu: walk_cpu,
};

/// The tests of the pairs a pass's walkers queued, one thread each (indirect over
/// `queue_args`).
pub static TEST_QUEUED_PAIRS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_pairs::test_queued_pairs",
        bindings: &[
            read("self_params"),
            read("sorted"),
            read("owned"),
            read("x"),
            read("x_prev"),
            read("v"),
            read("queue"),
            read("queue_args"),
            write("delta"),
            write("velocity_changes"),
            read("rest_shape"),
        ],
        push_constant_size: 0,
        workgroup_size: QUEUE_THREADS,
    },
    cpu: queued_cpu,
};

fn queued_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, sorted, owned, x, x_prev, v, queue, queue_args, delta, velocity_changes, rest] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let tables = (sorted.slice::<UVec4>(), owned.slice::<u32>());
    let (x, x_prev, v) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>());
    let queue = queue.slice::<u32>();
    let queued = queued_pairs(queue, &queue_args.first::<DispatchArgs>()?);
    let (delta, velocity_changes) = (delta.slice_mut::<u32>(), velocity_changes.slice_mut::<u32>());
    let rest = rest.slice::<Vec4>();
    let mut out = PairResponse::of_cloth(&c, (v, rest), (delta, velocity_changes));
    for i in 0..threads.min(queued) {
        test_queued_pair_at(i, tables, (x, x_prev), queue, &mut out);
    }
    Ok(())
}

fn starts_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, anchors, indices, bounds] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let (anchors, indices, bounds) = (anchors.slice::<Vec4>(), indices.slice::<u32>(), bounds.slice_mut::<Aabb>());
    for t in 0..threads.min(c.leaf_count) {
        bounds[t as usize] = triangle_start_at(t, anchors, indices);
    }
    Ok(())
}

fn regather_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, indices, order, anchors, sorted, leaf_of, sorted_bounds, leaf_motions] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let inputs = (indices.slice::<u32>(), order.slice::<u32>(), anchors.slice::<Vec4>());
    let outputs = (
        sorted.slice_mut::<UVec4>(),
        leaf_of.slice_mut::<u32>(),
        sorted_bounds.slice_mut::<Aabb>(),
        leaf_motions.slice_mut::<Aabb>(),
    );
    for s in 0..threads.min(c.leaf_count) {
        regather_cloth_triangle(s, inputs, (&mut *outputs.0, &mut *outputs.1, &mut *outputs.2, &mut *outputs.3));
    }
    Ok(())
}

fn bounds_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let span: SelfPassPush = d.push_as();
    let threads = d.invocations();
    triangle_bounds_over(&span, threads, d.bindings()?)?;
    Ok(())
}

/// `cloth_triangle_bounds` on the CPU (`triangle_bounds_at` for each of the first `threads`
/// triangles), over its bindings in its order: its twin's and the first of a pass's second
/// run's (`self_pass_tree::TRIANGLE_BOUNDS_AND_PASS_TREE`). Returns the cloth's tree's record.
pub(super) fn triangle_bounds_over(
    span: &SelfPassPush,
    threads: u32,
    [
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
    ]: [&mut HostBuffer; 13],
) -> Result<ColliderParams, String> {
    let c: ColliderParams = self_params.first()?;
    let (x, x_prev, anchors) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), anchors.slice::<Vec4>());
    let (indices, leaf_of) = (indices.slice::<u32>(), leaf_of.slice::<u32>());
    let (leaf_bounds, escaped, strays) =
        (leaf_bounds.slice_mut::<Aabb>(), escaped.slice_mut::<u32>(), strays.slice_mut::<f32>());
    let triangles = threads.min(c.leaf_count);
    let leaves = leaf_of.get(..triangles as usize).ok_or("leaf_of shorter than the triangles")?;
    if leaves.iter().any(|&leaf| leaf as usize >= leaf_bounds.len()) {
        return Err("leaf_of names a leaf past the tree".into());
    }
    let (walkers, walk_args) = (walkers.slice_mut::<u32>(), walk_args.first_mut::<DispatchArgs>()?);
    let tree_every_pass: u32 = tree_every_pass.first()?;
    let pass_refit = pass_refit.first_mut::<DispatchArgs>()?;
    for t in 0..triangles {
        let out = (&mut *leaf_bounds, &mut *escaped, &mut *strays, &mut *walkers, &mut *walk_args);
        let inputs = (x, x_prev, indices, anchors, leaf_of);
        triangle_bounds_at((t, span), &c, inputs, out, (tree_every_pass, &mut *pass_refit));
    }
    Ok(c)
}

fn lists_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SelfListPush = d.push_as();
    let threads = d.invocations();
    let [
        self_params,
        nodes,
        aabbs,
        leaf_bounds,
        sorted,
        owned,
        anchors,
        motion_aabbs,
        leaf_motions,
        walk_nodes,
        lists,
        counts,
        health,
        tree_every_pass,
    ] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let (owned, anchors) = (owned.slice::<u32>(), anchors.slice::<Vec4>());
    let motions = (motion_aabbs.slice::<Aabb>(), leaf_motions.slice::<Aabb>());
    let walk_nodes = walk_nodes.slice::<WalkNode>();
    let (lists, counts) = (lists.slice_mut::<u32>(), counts.slice_mut::<u32>());
    let health = health.first_mut::<Health>()?;
    let tree_every_pass = tree_every_pass.first_mut::<u32>()?;
    for leaf in 0..threads.min(c.leaf_count) {
        let motion =
            list_self_pairs_at(leaf, &c, tree, motions, walk_nodes, owned, anchors, (&mut *lists, &mut *counts));
        count_full_list(leaf, counts, health, tree_every_pass);
        note_pair_motion(motion.per_frame(push.to_frame), health);
    }
    Ok(())
}

fn listed_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let span: SelfPassPush = d.push_as();
    let [
        self_params,
        nodes,
        aabbs,
        leaf_bounds,
        sorted,
        owned,
        x,
        x_prev,
        v,
        escaped,
        strays,
        lists,
        counts,
        delta,
        velocity_changes,
        rest,
    ] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let owned = owned.slice::<u32>();
    let (x, x_prev, v, rest) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>(), rest.slice::<Vec4>());
    let escaped = (escaped.slice::<u32>(), strays.slice::<f32>());
    let lists = (lists.slice::<u32>(), counts.slice::<u32>());
    let (delta, velocity_changes) = (delta.slice_mut::<u32>(), velocity_changes.slice_mut::<u32>());
    for leaf in 0..threads.min(c.leaf_count) {
        let out = PairResponse::of_cloth(&c, (v, rest), (&mut *delta, &mut *velocity_changes));
        listed_self_pairs_at(leaf, &c, tree, owned, (x, x_prev), escaped, lists, &span, out);
    }
    Ok(())
}

fn walk_all_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, nodes, aabbs, leaf_bounds, sorted, owned, x, x_prev, v, delta, velocity_changes, rest] =
        d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let owned = owned.slice::<u32>();
    let (x, x_prev, v, rest) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>(), rest.slice::<Vec4>());
    let (delta, velocity_changes) = (delta.slice_mut::<u32>(), velocity_changes.slice_mut::<u32>());
    for leaf in 0..threads.min(c.leaf_count) {
        let out = PairResponse::of_cloth(&c, (v, rest), (&mut *delta, &mut *velocity_changes));
        self_triangle_contact_at(leaf, &c, tree, owned, (x, x_prev), out);
    }
    Ok(())
}

fn walk_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [
        self_params,
        nodes,
        aabbs,
        leaf_bounds,
        sorted,
        owned,
        x,
        x_prev,
        v,
        escaped,
        counts,
        walkers,
        walk_args,
        delta,
        velocity_changes,
        queue,
        queue_args,
        health,
        rest,
    ] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let walking = walk_args.first::<DispatchArgs>()?._pad;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let owned = owned.slice::<u32>();
    let (x, x_prev, v, rest) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>(), rest.slice::<Vec4>());
    let tables = (escaped.slice::<u32>(), counts.slice::<u32>());
    let walkers = walkers.slice::<u32>();
    let (delta, velocity_changes) = (delta.slice_mut::<u32>(), velocity_changes.slice_mut::<u32>());
    let (queue, queue_args) = (queue.slice_mut::<u32>(), queue_args.first_mut::<DispatchArgs>()?);
    let health = health.first_mut::<Health>()?;
    for i in 0..threads.min(walking) {
        let out = PairResponse::of_cloth(&c, (v, rest), (&mut *delta, &mut *velocity_changes));
        let leaf = walkers[i as usize];
        walk_self_pairs_at(leaf, &c, tree, owned, (x, x_prev), tables, (&mut *queue, &mut *queue_args), out);
        if tables.1[leaf as usize] != LIST_OVERFLOWED {
            health.self_walks += 1;
        }
    }
    Ok(())
}
