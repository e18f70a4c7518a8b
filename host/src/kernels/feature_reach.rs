//! Which listed collider triangles the cloth cannot reach over a span of its self-collision
//! lists (`drape_kernels::feature_reach`).

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::contact::CONTACT_THREADS;
use drape_kernels::feature_reach::mark_out_of_reach_at;
use drape_types::{Aabb, BvhNode, ColliderParams, ColliderPose, DispatchArgs, Health, WalkNode};
use glam::Vec4;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// One thread per listed sharp triangle: marked out of the cloth's reach, or not.
pub static MARK_OUT_OF_REACH: Kernel = Kernel {
    spec: KernelSpec::new(
        "feature_reach::mark_out_of_reach",
        &[
            read("self_params"),
            read("collider"),
            read("pose"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("sharp"),
            read("sharp_args"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("motion_aabbs"),
            read("leaf_motions"),
            read("walk_nodes"),
            read("anchors"),
            write("listed"),
            write("near"),
            write("near_args"),
            write("health"),
        ],
        CONTACT_THREADS,
    ),
    cpu: mark_out_of_reach_cpu,
};

fn mark_out_of_reach_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [
        self_params,
        collider,
        pose,
        vertices,
        previous,
        indices,
        sharp,
        sharp_args,
        nodes,
        aabbs,
        leaf_bounds,
        motion_aabbs,
        leaf_motions,
        walk_nodes,
        anchors,
        listed,
        near,
        near_args,
        health,
    ] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let collider: ColliderParams = collider.first()?;
    let pose: ColliderPose = pose.first()?;
    let mesh = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>());
    let sharp_args: DispatchArgs = sharp_args.first()?;
    let sharp = sharp.slice::<u32>();
    if (sharp_args._pad as usize) > sharp.len() {
        return Err("the sharp features' count runs past their list".into());
    }
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>());
    let motions = (motion_aabbs.slice::<Aabb>(), leaf_motions.slice::<Aabb>());
    let (walk_nodes, anchors) = (walk_nodes.slice::<WalkNode>(), anchors.slice::<Vec4>());
    let (listed, near) = (listed.slice_mut::<u32>(), near.slice_mut::<u32>());
    let near_args = near_args.first_mut::<DispatchArgs>()?;
    let health = health.first_mut::<Health>()?;
    for id in 0..threads {
        mark_out_of_reach_at(
            id,
            (sharp, &sharp_args),
            mesh,
            (&collider, &pose),
            &c,
            tree,
            motions,
            walk_nodes,
            anchors,
            (&mut *listed, &mut *near, &mut *near_args),
            &mut *health,
        );
    }
    Ok(())
}
