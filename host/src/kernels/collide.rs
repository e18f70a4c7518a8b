//! Cloth-vs-collider contact kernels (`drape_kernels::collide`): the culling pass that writes the
//! traversal's indirect dispatch, the LBVH traversal, and the brute-force baseline.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::collide::{
    COLLIDE_THREADS, CULL_THREADS, aabbs_overlap, collide_at, collide_brute_force_at, root_aabb, substep_motion,
    swept_bounds,
};
use drape_types::{Aabb, BvhNode, ColliderParams, ColliderPose, CollisionStatus, ContactPush, DispatchArgs, SimParams};
use glam::Vec4;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

const CONTACT_PUSH: u32 = size_of::<ContactPush>() as u32;

pub static COLLIDE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "collide::collide",
        bindings: &[
            read("params"),
            read("collider"),
            read("pose"),
            read("nodes"),
            read("aabbs"),
            read("spheres"),
            write("x"),
            write("v"),
            read("x_prev"),
            write("status"),
        ],
        push_constant_size: CONTACT_PUSH,
        workgroup_size: COLLIDE_THREADS,
    },
    cpu: collide_cpu,
};

pub static COLLIDE_BRUTE_FORCE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "collide::collide_brute_force",
        bindings: &[
            read("params"),
            read("collider"),
            read("pose"),
            read("spheres"),
            write("x"),
            write("v"),
            read("x_prev"),
        ],
        push_constant_size: CONTACT_PUSH,
        workgroup_size: COLLIDE_THREADS,
    },
    cpu: brute_force_cpu,
};

pub static CULL_COLLISION: Kernel = Kernel {
    spec: KernelSpec {
        entry: "collide::cull_collision",
        bindings: &[
            read("params"),
            read("collider"),
            read("pose"),
            read("aabbs"),
            read("leaf_bounds"),
            read("x"),
            read("x_prev"),
            write("args"),
            write("status"),
        ],
        push_constant_size: CONTACT_PUSH,
        workgroup_size: CULL_THREADS,
    },
    cpu: cull_cpu,
};

fn collide_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let push: ContactPush = d.push_as();
    let [params, collider, pose, nodes, aabbs, spheres, x, v, x_prev, status] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let (nodes, aabbs, spheres) = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), spheres.slice::<Vec4>());
    let (x, v, x_prev) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>(), x_prev.slice::<Vec4>());
    let status = status.first_mut::<CollisionStatus>()?;
    for i in 0..threads.min(p.particle_count) {
        if collide_at(i, &c, &motion, nodes, aabbs, spheres, x, v, x_prev) {
            status.overflows += 1;
        }
    }
    Ok(())
}

fn brute_force_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let push: ContactPush = d.push_as();
    let [params, collider, pose, spheres, x, v, x_prev] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let (x, v, x_prev) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>(), x_prev.slice::<Vec4>());
    for i in 0..threads.min(p.particle_count) {
        collide_brute_force_at(i, &c, &motion, spheres.slice(), x, v, x_prev);
    }
    Ok(())
}

/// One workgroup: the lanes' swept bounds reduced (min/max is exact in any order), the root-box
/// test, and the indirect dispatch size, as the kernel does.
fn cull_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: ContactPush = d.push_as();
    let [params, collider, pose, aabbs, leaf_bounds, x, x_prev, args, status] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let (x, x_prev) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>());
    let cloth = (0..CULL_THREADS)
        .map(|lane| swept_bounds(&motion, x, x_prev, p.particle_count, lane, CULL_THREADS))
        .reduce(|a, b| Aabb { min: a.min.min(b.min), max: a.max.max(b.max) })
        .ok_or("cull: no lanes")?;
    let root = root_aabb(&c, aabbs.slice(), leaf_bounds.slice());
    let run = aabbs_overlap(&cloth, &root, c.thickness);
    *args.first_mut::<DispatchArgs>()? =
        DispatchArgs { x: if run { p.particle_count.div_ceil(COLLIDE_THREADS) } else { 0 }, y: 1, z: 1, _pad: 0 };
    let status = status.first_mut::<CollisionStatus>()?;
    if run {
        status.ran += 1;
    } else {
        status.skipped += 1;
    }
    Ok(())
}
