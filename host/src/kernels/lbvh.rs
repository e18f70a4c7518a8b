//! LBVH build kernels (`drape_kernels::lbvh`) over leaf boxes: Morton codes, box gather,
//! Karras nodes, refit.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::lbvh::{aabb_centre, build_node_at, gather_at, morton_code, refit_from_leaf, refit_two_from_leaf};
use drape_types::{Aabb, BvhNode, ColliderParams};
use glam::Vec4Swizzles;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}
/// Threads per workgroup of every LBVH kernel (their `threads(256)`).
pub(crate) const THREADS: u32 = 256;

const fn spec(entry: &'static str, bindings: &'static [BindingSpec]) -> KernelSpec {
    KernelSpec::new(entry, bindings, THREADS)
}

pub static MORTON_CODES: Kernel = Kernel {
    spec: spec("lbvh::morton_codes", &[read("collider"), read("bounds"), write("keys"), write("values")]),
    cpu: morton_cpu,
};
pub static GATHER_BOUNDS: Kernel = Kernel {
    spec: spec("lbvh::gather_bounds", &[read("collider"), read("bounds"), read("order"), write("sorted")]),
    cpu: gather_cpu::<Aabb>,
};
pub static BUILD_NODES: Kernel = Kernel {
    spec: spec("lbvh::build_nodes", &[read("collider"), read("codes"), write("nodes"), write("parents")]),
    cpu: build_nodes_cpu,
};
pub static REFIT: Kernel = Kernel {
    spec: spec(
        "lbvh::refit",
        &[read("collider"), read("nodes"), read("parents"), read("leaf_bounds"), write("flags"), write("aabbs")],
    ),
    cpu: refit_cpu,
};
/// Two box sets over one tree in one climb (`drape_kernels::lbvh::refit_two`).
pub static REFIT_TWO: Kernel = Kernel {
    spec: spec(
        "lbvh::refit_two",
        &[
            read("collider"),
            read("nodes"),
            read("parents"),
            read("leaf_bounds"),
            read("other_leaf_bounds"),
            write("flags"),
            write("aabbs"),
            write("other_aabbs"),
        ],
    ),
    cpu: refit_two_cpu,
};

fn morton_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, bounds, keys, values] = d.bindings()?;
    let c: ColliderParams = collider.first()?;
    let (bounds, keys) = (bounds.slice::<Aabb>(), keys.slice_mut::<u32>());
    let values = values.slice_mut::<u32>();
    for i in 0..threads.min(c.leaf_count) {
        keys[i as usize] = morton_code(aabb_centre(&bounds[i as usize]), c.scene_min.xyz(), c.scene_max.xyz());
        values[i as usize] = i;
    }
    Ok(())
}

/// Any gather into the tree's leaf order (bindings: collider, input, order, sorted): the LBVH's
/// leaf boxes, or a leaf kind's own data.
pub(crate) fn gather_cpu<T: bytemuck::Pod>(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, input, order, sorted] = d.bindings()?;
    let c: ColliderParams = collider.first()?;
    let (input, order, sorted) = (input.slice::<T>(), order.slice::<u32>(), sorted.slice_mut::<T>());
    for i in 0..threads.min(c.leaf_count) {
        gather_at(i, input, order, sorted);
    }
    Ok(())
}

fn build_nodes_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, codes, nodes, parents] = d.bindings()?;
    let n = collider.first::<ColliderParams>()?.leaf_count;
    let (codes, nodes, parents) = (codes.slice::<u32>(), nodes.slice_mut::<BvhNode>(), parents.slice_mut::<u32>());
    for i in 0..threads.min(n.saturating_sub(1)) {
        build_node_at(codes, n, i, nodes, parents);
    }
    Ok(())
}

fn refit_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, nodes, parents, leaf_bounds, flags, aabbs] = d.bindings()?;
    let n = collider.first::<ColliderParams>()?.leaf_count;
    if n < 2 {
        return Ok(());
    }
    let (nodes, parents, leaf_bounds) = (nodes.slice::<BvhNode>(), parents.slice::<u32>(), leaf_bounds.slice::<Aabb>());
    let (flags, words) = (flags.slice_mut::<u32>(), aabbs.slice_mut::<u32>());
    for leaf in 0..threads.min(n) {
        refit_from_leaf(leaf, n, nodes, parents, leaf_bounds, flags, words);
    }
    Ok(())
}

fn refit_two_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, nodes, parents, leaf_bounds, other_leaf_bounds, flags, aabbs, other_aabbs] = d.bindings()?;
    let n = collider.first::<ColliderParams>()?.leaf_count;
    if n < 2 {
        return Ok(());
    }
    let (nodes, parents) = (nodes.slice::<BvhNode>(), parents.slice::<u32>());
    let boxes = (leaf_bounds.slice::<Aabb>(), other_leaf_bounds.slice::<Aabb>());
    let (flags, words, other_words) =
        (flags.slice_mut::<u32>(), aabbs.slice_mut::<u32>(), other_aabbs.slice_mut::<u32>());
    for leaf in 0..threads.min(n) {
        refit_two_from_leaf(leaf, n, nodes, parents, boxes, flags, words, other_words);
    }
    Ok(())
}
