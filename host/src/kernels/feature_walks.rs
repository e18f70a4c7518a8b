//! A pass's collider features from the cloth's side (`drape_kernels::feature_walks`): the
//! frame's choice of side, and each cloth triangle's walk of the collider's tree.

use crate::graph::{BindingSpec, HostBuffer, HostDispatch, Kernel, KernelSpec};
use drape_kernels::contact::{CONTACT_THREADS, substep_motion};
use drape_kernels::feature_reach::{LISTED_FAR, TAKE_EVERY_LISTED};
use drape_kernels::feature_walks::{choose_feature_walks_at, collider_features_of_cloth_triangle_at};
use drape_kernels::self_contact::arm_second_refit;
use drape_types::{Aabb, BvhNode, ColliderParams, ColliderPose, ContactPush, DispatchArgs, Health, SimParams};
use glam::{UVec4, Vec4};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// One thread: the pass's dispatches from the collider's side and from the cloth's; push
/// constants: a `DispatchArgs` whose `x` is the mode (`drape_kernels::feature_walks::WALKS_*`).
pub static CHOOSE_FEATURE_WALKS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "feature_walks::choose_feature_walks",
        bindings: &[
            read("self_params"),
            read("listed_args"),
            write("from_collider"),
            write("from_cloth"),
            write("health"),
        ],
        push_constant_size: size_of::<DispatchArgs>() as u32,
        workgroup_size: 1,
    },
    cpu: choose_cpu,
};

/// Each cloth triangle against the listed collider triangles near it; push constants:
/// `ContactPush` (the pass's span of the frame).
pub static COLLIDER_FEATURES_FROM_CLOTH: Kernel = Kernel {
    spec: KernelSpec {
        entry: "feature_walks::collider_features_from_cloth",
        bindings: &[
            read("params"),
            read("self_params"),
            read("collider"),
            read("pose"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("features"),
            read("listed"),
            read("collider_nodes"),
            read("collider_aabbs"),
            read("collider_leaves"),
            read("order"),
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
            write("pushes"),
            write("health"),
            write("features_found"),
        ],
        push_constant_size: size_of::<ContactPush>() as u32,
        workgroup_size: CONTACT_THREADS,
    },
    cpu: from_cloth_cpu,
};

/// Each cloth triangle that escaped its region in the pass against the listed collider
/// triangles out of the cloth's reach, while the collider's side walks; push constants:
/// `ContactPush`.
pub static COLLIDER_FEATURES_FROM_WALKERS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "feature_walks::collider_features_from_walkers",
        bindings: &[
            read("params"),
            read("self_params"),
            read("collider"),
            read("pose"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("features"),
            read("listed"),
            read("collider_nodes"),
            read("collider_aabbs"),
            read("collider_leaves"),
            read("order"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("owned"),
            read("x"),
            read("x_prev"),
            read("v"),
            read("walkers"),
            read("walk_args"),
            read("from_cloth"),
            write("delta"),
            write("velocity_changes"),
            write("pushes"),
            write("health"),
            write("features_found"),
        ],
        push_constant_size: size_of::<ContactPush>() as u32,
        workgroup_size: CONTACT_THREADS,
    },
    cpu: from_walkers_cpu,
};

fn choose_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let mode: DispatchArgs = d.push_as();
    if d.invocations() == 0 {
        return Ok(());
    }
    let [self_params, listed_args, from_collider, from_cloth, health] = d.bindings()?;
    let cloth_triangles = self_params.first::<ColliderParams>()?.leaf_count;
    let listed: DispatchArgs = listed_args.first()?;
    let (from_collider, from_cloth) = (from_collider.first_mut()?, from_cloth.first_mut()?);
    if choose_feature_walks_at(mode.x, &listed, cloth_triangles, (from_collider, from_cloth)) {
        health.first_mut::<Health>()?.feature_walks_from_cloth += 1;
    }
    Ok(())
}

fn from_cloth_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: ContactPush = d.push_as();
    let threads = d.invocations();
    let buffers: [&mut HostBuffer; 26] = d.bindings()?;
    let cloth_triangles = buffers[1].first::<ColliderParams>()?.leaf_count;
    let leaves: Vec<u32> = (0..threads.min(cloth_triangles)).collect();
    walks_from_cloth_cpu(push, buffers, &leaves, TAKE_EVERY_LISTED)
}

fn from_walkers_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: ContactPush = d.push_as();
    let threads = d.invocations();
    // The cloth's side's bindings with the walkers' three before its sums.
    let [walks @ .., walkers, walk_args, from_cloth, delta, velocity_changes, pushes, health, features_found]: [&mut HostBuffer; 29] =
        d.bindings()?;
    // As the kernel: nothing when the cloth's side walks every listed triangle already, or
    // when the frame has marked none out of reach.
    if from_cloth.first::<DispatchArgs>()?.x != 0 || health.first::<Health>()?.collider_features_out_of_reach == 0 {
        return Ok(());
    }
    let count = walk_args.first::<DispatchArgs>()?._pad;
    let walkers = walkers.slice::<u32>();
    let leaves = walkers.get(..threads.min(count) as usize).ok_or("the walkers' count runs past their list")?;
    let sums = [delta, velocity_changes, pushes, health, features_found];
    let buffers: [&mut HostBuffer; 26] = walks
        .into_iter()
        .chain(sums)
        .collect::<Vec<_>>()
        .try_into()
        .map_err(|_| "the cloth's side binds 26 buffers")?;
    walks_from_cloth_cpu(push, buffers, leaves, LISTED_FAR)
}

/// Both kernels' walks from the cloth's side on the CPU: each of `leaves` (the pass tree's
/// sorted leaves) against the listed collider triangles whose flags are in `take`
/// (`collider_features_of_cloth_triangle_at`); `buffers` are `collider_features_from_cloth`'s
/// bindings, in its order.
fn walks_from_cloth_cpu(
    push: ContactPush,
    buffers: [&mut HostBuffer; 26],
    leaves: &[u32],
    take: u32,
) -> Result<(), String> {
    let [
        params,
        self_params,
        collider,
        pose,
        vertices,
        previous,
        indices,
        features,
        listed,
        collider_nodes,
        collider_aabbs,
        collider_leaves,
        order,
        nodes,
        aabbs,
        leaf_bounds,
        sorted,
        owned,
        x,
        x_prev,
        v,
        delta,
        velocity_changes,
        pushes,
        health,
        features_found,
    ] = buffers;
    let p: SimParams = params.first()?;
    let c: ColliderParams = self_params.first()?;
    let collider: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let mesh = (
        vertices.slice::<Vec4>(),
        previous.slice::<Vec4>(),
        indices.slice::<u32>(),
        features.slice::<UVec4>(),
        listed.slice::<u32>(),
    );
    let collider_tree = (
        collider_nodes.slice::<BvhNode>(),
        collider_aabbs.slice::<Aabb>(),
        collider_leaves.slice::<Aabb>(),
        order.slice::<u32>(),
    );
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let state = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>());
    let owned = owned.slice::<u32>();
    let (delta, velocity_changes, pushes) =
        (delta.slice_mut::<u32>(), velocity_changes.slice_mut::<u32>(), pushes.slice_mut::<u32>());
    let health = health.first_mut::<Health>()?;
    let features_found = features_found.first_mut::<DispatchArgs>()?;
    for &leaf in leaves {
        let pushed = collider_features_of_cloth_triangle_at(
            (leaf, take),
            mesh,
            collider_tree,
            &collider,
            &motion,
            &c,
            tree,
            owned,
            state,
            (&mut *delta, &mut *velocity_changes, &mut *pushes, &mut *health),
        );
        if pushed {
            arm_second_refit(&c, features_found);
        }
    }
    Ok(())
}
