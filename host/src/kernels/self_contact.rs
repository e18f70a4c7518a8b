//! Self-collision kernels (`drape_kernels::self_contact`): the cloth's bounds for the tree's
//! Morton box (and the frame's first pass's start), its triangles' boxes and their tree order,
//! the vertex-triangle, edge-edge and collider-vertex passes and the application of their
//! summed corrections (which also records where the next pass starts).

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::contact::CONTACT_THREADS;
use drape_kernels::self_contact::{
    PairResponse, SCENE_THREADS, apply_collider_push_at, longest_edge2, apply_self_contact_at, copy_start, count_self_contact, cloth_triangle_bounds_at, gather_cloth_triangle_at, particle_bounds,
    collider_feature_contact_at, self_triangle_contact_at, write_scene,
};
use drape_kernels::contact::substep_motion;
use drape_types::{Aabb, BvhNode, ColliderParams, ColliderPose, ContactPush, Health, SimParams};
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

/// One workgroup: the cloth's bounds grown by the thickness, as the tree's Morton box; and the
/// positions copied to where the frame's first pass sweeps from.
pub static SELF_SCENE_BOUNDS: Kernel = Kernel {
    spec: spec(
        "self_contact::self_scene_bounds",
        &[read("params"), read("x"), read("indices"), write("self_params"), write("start")],
        SCENE_THREADS,
    ),
    cpu: scene_cpu,
};

pub static CLOTH_TRIANGLE_BOUNDS: Kernel = Kernel {
    spec: spec(
        "self_contact::cloth_triangle_bounds",
        &[read("self_params"), read("x"), read("x_prev"), read("indices"), write("bounds")],
        WORKGROUP_SIZE,
    ),
    cpu: triangle_bounds_cpu,
};

pub static GATHER_CLOTH_TRIANGLES: Kernel = Kernel {
    spec: spec(
        "self_contact::gather_cloth_triangles",
        &[read("self_params"), read("indices"), read("order"), write("sorted")],
        WORKGROUP_SIZE,
    ),
    cpu: gather_cpu,
};

/// Every cloth triangle's owned corners against the triangles near it and its owned edges
/// against their owned edges (one walk per triangle).
pub static SELF_TRIANGLE_CONTACT: Kernel = Kernel {
    spec: spec(
        "self_contact::self_triangle_contact",
        &[
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
        ],
        CONTACT_THREADS,
    ),
    cpu: self_triangle_contact_cpu,
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
        ],
        WORKGROUP_SIZE,
    ),
    cpu: apply_cpu,
};

/// The collider edges' pushes moved into the positions, before the pass's pair search.
pub static APPLY_COLLIDER_PUSHES: Kernel = Kernel {
    spec: spec(
        "self_contact::apply_collider_pushes",
        &[read("params"), write("x"), write("v"), read("pushes")],
        WORKGROUP_SIZE,
    ),
    cpu: apply_pushes_cpu,
};

/// The lanes' bounds reduced (min/max is exact in any order), as the kernel does.
fn scene_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let [params, x, indices, self_params, start] = d.bindings()?;
    let p: SimParams = params.first()?;
    let triangles = self_params.first::<ColliderParams>()?.leaf_count;
    for lane in 0..SCENE_THREADS {
        copy_start(x.slice(), start.slice_mut(), p.particle_count, lane, SCENE_THREADS);
    }
    let bounds = (0..SCENE_THREADS)
        .map(|lane| {
            let mut own = particle_bounds(x.slice(), p.particle_count, lane, SCENE_THREADS);
            own.max.w = longest_edge2(x.slice(), indices.slice(), triangles, lane, SCENE_THREADS);
            own
        })
        .reduce(|a, b| Aabb { min: a.min.min(b.min), max: a.max.max(b.max) })
        .ok_or("self scene bounds: no lanes")?;
    write_scene(self_params.first_mut::<ColliderParams>()?, &bounds);
    Ok(())
}

fn triangle_bounds_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, x, x_prev, indices, bounds] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let (x, x_prev) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>());
    let (indices, bounds) = (indices.slice::<u32>(), bounds.slice_mut::<Aabb>());
    for t in 0..threads.min(c.leaf_count) {
        bounds[t as usize] = cloth_triangle_bounds_at(t, (x, x_prev), indices);
    }
    Ok(())
}

fn gather_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, indices, order, sorted] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let (indices, order, sorted) = (indices.slice::<u32>(), order.slice::<u32>(), sorted.slice_mut::<UVec4>());
    for s in 0..threads.min(c.leaf_count) {
        sorted[s as usize] = gather_cloth_triangle_at(s, indices, order);
    }
    Ok(())
}

fn apply_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, delta, velocity_changes, pushes, start, health] = d.bindings()?;
    let p: SimParams = params.first()?;
    let (x, v) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>());
    let corrections = (delta.slice::<u32>(), pushes.slice::<u32>());
    let velocity_changes = velocity_changes.slice::<u32>();
    let (start, health) = (start.slice_mut::<Vec4>(), health.first_mut::<Health>()?);
    for i in 0..threads.min(p.particle_count) {
        count_self_contact(i, corrections, health);
        apply_self_contact_at(i, x, v, (corrections.0, velocity_changes));
        start[i as usize] = x[i as usize];
    }
    Ok(())
}

fn apply_pushes_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, pushes] = d.bindings()?;
    let p: SimParams = params.first()?;
    let (x, v, pushes) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>(), pushes.slice::<u32>());
    for i in 0..threads.min(p.particle_count) {
        apply_collider_push_at(i, x, v, pushes);
    }
    Ok(())
}

fn self_triangle_contact_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, nodes, aabbs, leaf_bounds, sorted, owned, x, x_prev, v, delta, velocity_changes] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let owned = owned.slice::<u32>();
    let (x, x_prev, v) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), v.slice::<Vec4>());
    let (delta, velocity_changes) = (delta.slice_mut::<u32>(), velocity_changes.slice_mut::<u32>());
    for leaf in 0..threads.min(c.leaf_count) {
        let out = PairResponse { thickness: c.thickness, friction: c.friction, v, delta: &mut *delta, velocity_changes: &mut *velocity_changes };
        self_triangle_contact_at(leaf, &c, tree, owned, (x, x_prev), out);
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
    for t in 0..threads.min(features.len() as u32) {
        let mine = features[t as usize];
        let out = PairResponse {
            thickness: collider.thickness,
            friction: collider.friction,
            v,
            delta: &mut *delta,
            velocity_changes: &mut *velocity_changes,
        };
        collider_feature_contact_at(t, mine, mesh, &motion, &c, tree, owned, (x, x_prev), (out, &mut *pushes));
    }
    Ok(())
}
