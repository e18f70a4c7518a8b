//! Self-collision kernels (`drape_kernels::self_contact`): the cloth's bounds for the tree's
//! Morton box (and the frame's first pass's start), its triangles' boxes and their tree order,
//! the vertex-triangle, edge-edge and collider-vertex passes and the application of their
//! summed corrections (which also records where the next pass starts).

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::contact::CONTACT_THREADS;
use drape_kernels::contact::substep_motion;
use drape_kernels::self_contact::{
    EVERY_CLOTH_LEAF, PairResponse, SCENE_THREADS, apply_collider_push_at, apply_self_contact_at, arm_second_refit,
    collider_feature_contact_at, copy_start, count_self_contact, forget_walkers, frame_of, gather_cloth_triangle,
    longest_edge2, report_scene, tested_features, write_scene,
};
use drape_kernels::self_pairs::anchor_particles;
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, ContactPush, DispatchArgs, Health, SelfAnchorPush, SimParams,
};
use glam::{UVec4, Vec4};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}
const fn spec(entry: &'static str, bindings: &'static [BindingSpec], workgroup_size: u32) -> KernelSpec {
    KernelSpec { entry, bindings, push_constant_size: 0, workgroup_size }
}

/// One workgroup: every particle's anchor for the frame's first window (`self_pairs::anchor_at`),
/// their bounds (at their starts and predicted ends over the frame) grown by the thickness as the
/// tree's Morton box; and the positions copied to where the frame's first pass sweeps from. Push
/// constants: `SelfAnchorPush` (the window's substeps and the frame's).
pub static SELF_SCENE_BOUNDS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_contact::self_scene_bounds",
        bindings: &[
            read("params"),
            read("x"),
            read("v"),
            read("indices"),
            write("self_params"),
            write("start"),
            write("anchors"),
            write("health"),
        ],
        push_constant_size: size_of::<SelfAnchorPush>() as u32,
        workgroup_size: SCENE_THREADS,
    },
    cpu: scene_cpu,
};

pub static GATHER_CLOTH_TRIANGLES: Kernel = Kernel {
    spec: spec(
        "self_contact::gather_cloth_triangles",
        &[
            read("self_params"),
            read("indices"),
            read("order"),
            read("anchors"),
            write("sorted"),
            write("leaf_of"),
            write("leaf_motions"),
        ],
        WORKGROUP_SIZE,
    ),
    cpu: gather_cpu,
};

/// A triangle collider's triangles (the vertices and edges each owns) against the cloth's
/// faces and edges; push constants: `ContactPush` (the pass's span of the frame).
pub static COLLIDER_FEATURE_CONTACT: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_contact::collider_feature_contact",
        bindings: &[
            read("params"),
            read("self_params"),
            read("collider"),
            read("pose"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("features"),
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
            read("sharp"),
            read("sharp_args"),
            write("health"),
            write("features_found"),
        ],
        push_constant_size: size_of::<ContactPush>() as u32,
        workgroup_size: CONTACT_THREADS,
    },
    cpu: collider_feature_contact_cpu,
};

pub static APPLY_SELF_CONTACT: Kernel = Kernel {
    spec: spec(
        "self_contact::apply_self_contact",
        &[
            read("params"),
            write("x"),
            write("v"),
            read("delta"),
            read("velocity_changes"),
            read("pushes"),
            write("start"),
            write("health"),
            read("self_params"),
        ],
        WORKGROUP_SIZE,
    ),
    cpu: apply_cpu,
};

/// The collider edges' pushes moved into the positions, before the pass's pair search (the
/// pass's walkers emptied: the boxes' second run finds them anew).
pub static APPLY_COLLIDER_PUSHES: Kernel = Kernel {
    spec: spec(
        "self_contact::apply_collider_pushes",
        &[read("params"), write("x"), write("v"), read("pushes"), write("walk_args")],
        WORKGROUP_SIZE,
    ),
    cpu: apply_pushes_cpu,
};

/// The lanes' bounds reduced (min/max is exact in any order), as the kernel does.
fn scene_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SelfAnchorPush = d.push_as();
    let [params, x, v, indices, self_params, start, anchors, health] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = self_params.first()?;
    let triangles = c.leaf_count;
    let spans = (frame_of(&p, &c, push.window_substeps), frame_of(&p, &c, push.frame_substeps));
    for lane in 0..SCENE_THREADS {
        copy_start(x.slice(), start.slice_mut(), p.particle_count, lane, SCENE_THREADS);
    }
    let (x, v, anchors) = (x.slice::<Vec4>(), v.slice::<Vec4>(), anchors.slice_mut::<Vec4>());
    let bounds = (0..SCENE_THREADS)
        .map(|lane| {
            let mut own = anchor_particles((x, v), spans, anchors, p.particle_count, (lane, SCENE_THREADS));
            own.max.w = longest_edge2(x, indices.slice(), triangles, lane, SCENE_THREADS);
            own
        })
        .reduce(|a, b| Aabb { min: a.min.min(b.min), max: a.max.max(b.max) })
        .ok_or("self scene bounds: no lanes")?;
    let scene = self_params.first_mut::<ColliderParams>()?;
    write_scene(scene, &bounds);
    report_scene(scene, health.first_mut::<Health>()?);
    Ok(())
}

fn gather_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, indices, order, anchors, sorted, leaf_of, leaf_motions] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let inputs = (indices.slice::<u32>(), order.slice::<u32>(), anchors.slice::<Vec4>());
    let (sorted, leaf_of, leaf_motions) =
        (sorted.slice_mut::<UVec4>(), leaf_of.slice_mut::<u32>(), leaf_motions.slice_mut::<Aabb>());
    for s in 0..threads.min(c.leaf_count) {
        gather_cloth_triangle(s, inputs, (&mut *sorted, &mut *leaf_of, &mut *leaf_motions));
    }
    Ok(())
}

fn apply_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, delta, velocity_changes, pushes, start, health, self_params] = d.bindings()?;
    let p: SimParams = params.first()?;
    let thickness = self_params.first::<ColliderParams>()?.thickness;
    let (x, v) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>());
    let corrections = (delta.slice::<u32>(), pushes.slice::<u32>());
    let velocity_changes = velocity_changes.slice::<u32>();
    let (start, health) = (start.slice_mut::<Vec4>(), health.first_mut::<Health>()?);
    for i in 0..threads.min(p.particle_count) {
        count_self_contact(i, corrections, health);
        apply_self_contact_at((i, thickness), x, v, (corrections.0, velocity_changes));
        start[i as usize] = x[i as usize];
    }
    Ok(())
}

fn apply_pushes_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, pushes, walk_args] = d.bindings()?;
    let p: SimParams = params.first()?;
    let (x, v, pushes) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>(), pushes.slice::<u32>());
    // Every thread strides over the particles (the dispatch covers the cloth's triangles, or
    // nothing).
    if threads > 0 {
        forget_walkers(walk_args.first_mut::<DispatchArgs>()?);
        for i in 0..p.particle_count {
            apply_collider_push_at(i, x, v, pushes);
        }
    }
    Ok(())
}

fn collider_feature_contact_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: ContactPush = d.push_as();
    let threads = d.invocations();
    let [
        params,
        self_params,
        collider,
        pose,
        vertices,
        previous,
        indices,
        features,
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
        sharp,
        sharp_args,
        health,
        features_found,
    ] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = self_params.first()?;
    let collider: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let mesh = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>());
    let (features, owned) = (features.slice::<UVec4>(), owned.slice::<u32>());
    let (x, x_prev, v) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>());
    let (delta, pushes) = (delta.slice_mut::<u32>(), pushes.slice_mut::<u32>());
    let velocity_changes = velocity_changes.slice_mut::<u32>();
    let (sharp, listed) = (sharp.slice::<u32>(), sharp_args.first::<DispatchArgs>()?._pad);
    let health = health.first_mut::<Health>()?;
    let features_found = features_found.first_mut::<DispatchArgs>()?;
    for i in 0..threads.min(listed) {
        let t = *sharp.get(i as usize).ok_or("the sharp features' count runs past their list")?;
        let mine = *features.get(t as usize).ok_or("a listed sharp feature is past the collider's triangles")?;
        let mine = tested_features(mine, &collider);
        let out = PairResponse {
            thickness: collider.thickness,
            friction: collider.friction,
            v,
            rest: x, // a collider's pairs never read it (the kernel's stand-in too)
            delta: &mut *delta,
            velocity_changes: &mut *velocity_changes,
        };
        let pushed = collider_feature_contact_at(
            t,
            mine,
            mesh,
            &motion,
            &c,
            (tree, EVERY_CLOTH_LEAF),
            owned,
            (x, x_prev),
            (out, &mut *pushes, &mut *health),
        );
        if pushed {
            arm_second_refit(&c, features_found);
        }
    }
    Ok(())
}
