//! Contact kernels shared by every leaf kind (`drape_kernels::contact`): the culling pass that
//! writes the detect and respond passes' indirect dispatch, the respond pass, and the generic
//! CPU adapters of a leaf kind's detect passes (`detect_cpu::<K>`, `detect_brute_force_cpu::<K>`;
//! each leaf kind's file declares its own detect `Kernel`s with them).

use crate::graph::{BindingSpec, HostBuffer, HostDispatch, Kernel, KernelSpec};
use drape_kernels::candidates::{broad_phase_at, detect_candidates_particle, frame_motion};
use drape_kernels::contact::{
    CONTACT_THREADS, CULL_THREADS, LeafKind, aabbs_overlap, detect_at, detect_brute_force_at, record_cull, respond_at,
    root_aabb, substep_motion, swept_bounds,
};
use drape_kernels::crowded::detect_crowded_alone;
use drape_kernels::integrate::{ClothForces, GridSprings, SpringList};
use drape_kernels::update_contact::update_and_contact_particle;
use drape_types::{
    Aabb, BroadPhasePush, BvhNode, ColliderParams, ColliderPose, CollisionStatus, Contact, ContactPush, ContactQuery,
    DispatchArgs, Health, ParticleSprings, SimParams, Spring,
};
use glam::Vec4;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// Push-constant bytes of every contact pass.
pub const CONTACT_PUSH: u32 = size_of::<ContactPush>() as u32;

/// The interface of a contact pass (push constants: `ContactPush`).
pub const fn contact_spec(entry: &'static str, bindings: &'static [BindingSpec], workgroup_size: u32) -> KernelSpec {
    KernelSpec { entry, bindings, push_constant_size: CONTACT_PUSH, workgroup_size }
}

/// The binding table of every leaf kind's LBVH detect pass (the kernel names its leaves
/// `leaves`, whatever they are).
pub const DETECT_BINDINGS: &[BindingSpec] = &[
    read("params"),
    read("collider"),
    read("pose"),
    read("nodes"),
    read("aabbs"),
    read("leaves"),
    read("x"),
    read("x_prev"),
    write("contacts"),
];

/// The binding table of every leaf kind's broad phase (push constants: `BroadPhasePush`).
pub const BROAD_PHASE_BINDINGS: &[BindingSpec] = &[
    read("params"),
    read("collider"),
    read("pose"),
    read("nodes"),
    read("aabbs"),
    read("leaf_bounds"),
    read("leaves"),
    read("x"),
    read("v"),
    write("queries"),
    write("candidates"),
    write("status"),
];

/// The interface of a leaf kind's broad phase.
pub const fn broad_phase_spec(entry: &'static str) -> KernelSpec {
    KernelSpec {
        entry,
        bindings: BROAD_PHASE_BINDINGS,
        push_constant_size: size_of::<BroadPhasePush>() as u32,
        workgroup_size: CONTACT_THREADS,
    }
}

/// The binding table of every leaf kind's narrow-phase pass (over candidate lists): detects
/// and responds in one dispatch.
pub const DETECT_CANDIDATES_BINDINGS: &[BindingSpec] = &[
    read("params"),
    read("collider"),
    read("pose"),
    read("nodes"),
    read("aabbs"),
    read("leaves"),
    read("queries"),
    read("candidates"),
    write("x"),
    read("x_prev"),
    write("v"),
    write("contacts"),
    write("status"),
    write("crowded"),
    write("crowded_args"),
    write("health"),
];

/// The binding table of every leaf kind's crowded pass (`drape_kernels::crowded`): the
/// narrow phase's, the crowded particles and their count read.
pub const DETECT_CROWDED_BINDINGS: &[BindingSpec] = &[
    read("params"),
    read("collider"),
    read("pose"),
    read("nodes"),
    read("aabbs"),
    read("leaves"),
    read("queries"),
    read("candidates"),
    write("x"),
    read("x_prev"),
    write("v"),
    write("contacts"),
    write("status"),
    read("crowded"),
    read("crowded_args"),
];

/// The bindings of every leaf kind's update-and-contact pass (the integrator's last stage and
/// the narrow phase in one): the integrator's (`kernels::integrate`), then the narrow phase's,
/// then `$extra`.
macro_rules! update_contact_bindings {
    ($($extra:expr),*) => {
        super::integrate::stage_bindings!(
            read("collider"),
            read("pose"),
            read("nodes"),
            read("aabbs"),
            read("leaves"),
            read("queries"),
            read("candidates"),
            write("contacts"),
            write("status"),
            write("crowded"),
            write("crowded_args"),
            write("health")
            $(, $extra)*
        )
    };
}

/// The binding table of every leaf kind's update-and-contact pass for a grid cloth.
pub const UPDATE_CONTACT_BINDINGS: &[BindingSpec] = update_contact_bindings!();
/// ... and for a spring-list cloth (its particles' spring ranges and the springs last).
pub const UPDATE_CONTACT_SPRINGS_BINDINGS: &[BindingSpec] =
    update_contact_bindings!(read("particles"), read("springs"));

/// The binding table of every leaf kind's brute-force detect pass.
pub const DETECT_BRUTE_FORCE_BINDINGS: &[BindingSpec] =
    &[read("params"), read("collider"), read("pose"), read("leaves"), read("x"), read("x_prev"), write("contacts")];

pub static RESPOND_CONTACTS: Kernel = Kernel {
    spec: contact_spec(
        "contact::respond_contacts",
        &[read("params"), read("collider"), read("pose"), read("contacts"), write("x"), write("v")],
        CONTACT_THREADS,
    ),
    cpu: respond_cpu,
};

pub static CULL_CONTACT: Kernel = Kernel {
    spec: contact_spec(
        "contact::cull_contact",
        &[
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
        CULL_THREADS,
    ),
    cpu: cull_cpu,
};

/// CPU adapter of leaf kind `K`'s LBVH detect pass (bindings: `DETECT_BINDINGS`).
pub fn detect_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let threads = d.invocations();
    let push: ContactPush = d.push_as();
    let [params, collider, pose, nodes, aabbs, leaves, x, x_prev, contacts] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let (nodes, aabbs, leaves) = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaves.slice::<K::Leaf>());
    let (x, x_prev, contacts) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>(), contacts.slice_mut::<Contact>());
    for i in 0..threads.min(p.particle_count) {
        detect_at::<K>(i, &c, &motion, nodes, aabbs, leaves, x, x_prev, contacts);
    }
    Ok(())
}

/// CPU adapter of leaf kind `K`'s broad phase (`BROAD_PHASE_BINDINGS`).
pub fn broad_phase_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let threads = d.invocations();
    let push: BroadPhasePush = d.push_as();
    let [params, collider, pose, nodes, aabbs, leaf_bounds, leaves, x, v, queries, candidates, status] =
        d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let frame = frame_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let tree =
        (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), leaves.slice::<K::Leaf>());
    let (x, v) = (x.slice::<Vec4>(), v.slice::<Vec4>());
    let (queries, candidates) = (queries.slice_mut::<ContactQuery>(), candidates.slice_mut::<u32>());
    let status = status.first_mut::<CollisionStatus>()?;
    for i in 0..threads.min(p.particle_count) {
        if broad_phase_at::<K>(i, &p, &c, &frame, tree, (x, v), queries, candidates) {
            status.listed += 1;
        }
    }
    Ok(())
}

/// CPU adapter of leaf kind `K`'s narrow-phase detect + respond pass (`DETECT_CANDIDATES_BINDINGS`).
pub fn detect_candidates_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let threads = d.invocations();
    let push: ContactPush = d.push_as();
    let [
        params,
        collider,
        pose,
        nodes,
        aabbs,
        leaves,
        queries,
        candidates,
        x,
        x_prev,
        v,
        contacts,
        status,
        crowded,
        crowded_args,
        health,
    ] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let pose: ColliderPose = pose.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaves.slice::<K::Leaf>());
    let lists = (queries.slice::<ContactQuery>(), candidates.slice::<u32>());
    let (x, x_prev, v) = (x.slice_mut::<Vec4>(), x_prev.slice::<Vec4>(), v.slice_mut::<Vec4>());
    let (contacts, status) = (contacts.slice_mut::<Contact>(), status.first_mut::<CollisionStatus>()?);
    let (crowded, crowded_args) = (crowded.slice_mut::<u32>(), crowded_args.first_mut::<DispatchArgs>()?);
    let health = health.first_mut::<Health>()?;
    for i in 0..threads.min(p.particle_count) {
        detect_candidates_particle::<K>(
            i,
            &push,
            &p,
            &c,
            &pose,
            tree,
            lists,
            (&mut *x, x_prev, &mut *v),
            contacts,
            (&mut *status, &mut *health, (&mut *crowded, &mut *crowded_args)),
        );
    }
    Ok(())
}

/// CPU adapter of leaf kind `K`'s crowded pass (`DETECT_CROWDED_BINDINGS`): each handed-over
/// particle answered as its lane would have (`crowded::detect_crowded_alone`), which the
/// workgroup's answer equals.
pub fn detect_crowded_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let push: ContactPush = d.push_as();
    let [
        params,
        collider,
        pose,
        nodes,
        aabbs,
        leaves,
        queries,
        candidates,
        x,
        x_prev,
        v,
        contacts,
        status,
        crowded,
        crowded_args,
    ] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let pose: ColliderPose = pose.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaves.slice::<K::Leaf>());
    let lists = (queries.slice::<ContactQuery>(), candidates.slice::<u32>());
    let (x, x_prev, v) = (x.slice_mut::<Vec4>(), x_prev.slice::<Vec4>(), v.slice_mut::<Vec4>());
    let (contacts, status) = (contacts.slice_mut::<Contact>(), status.first_mut::<CollisionStatus>()?);
    let count = crowded_args.first::<DispatchArgs>()?._pad as usize;
    let crowded = crowded.slice::<u32>().get(..count).ok_or("crowded pass: more particles than the queue holds")?;
    for &i in crowded {
        let state = (&mut *x, x_prev, &mut *v);
        detect_crowded_alone::<K>(i, &push, &p, (&c, &pose), tree, lists, state, contacts, status);
    }
    Ok(())
}

/// CPU adapter of leaf kind `K`'s update-and-contact pass for a grid cloth
/// (`UPDATE_CONTACT_BINDINGS`).
pub fn update_contact_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let (threads, push) = (d.invocations(), d.push_as());
    let mut buffers: [&mut HostBuffer; UPDATE_CONTACT_COMMON] = d.bindings()?;
    update_contact_each::<K, _>(threads, &push, &mut buffers, &GridSprings)
}

/// CPU adapter of leaf kind `K`'s update-and-contact pass for a spring-list cloth
/// (`UPDATE_CONTACT_SPRINGS_BINDINGS`).
pub fn update_contact_springs_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let (threads, push) = (d.invocations(), d.push_as());
    let mut buffers: [&mut HostBuffer; UPDATE_CONTACT_COMMON + 2] = d.bindings()?;
    let (common, springs) = buffers.split_at_mut(UPDATE_CONTACT_COMMON);
    let common: &mut [&mut HostBuffer; UPDATE_CONTACT_COMMON] = common.try_into().map_err(|_| "bindings")?;
    let [particles, springs] = springs else { return Err("update-and-contact: no spring bindings".into()) };
    let forces = SpringList { particles: particles.slice::<ParticleSprings>(), springs: springs.slice::<Spring>() };
    update_contact_each::<K, _>(threads, &push, common, &forces)
}

/// The bindings both update-and-contact passes start with.
const UPDATE_CONTACT_COMMON: usize = 22;

/// `update_and_contact_particle` for every particle in turn (each one's work reads only its own
/// new position, so the order cannot matter; crowded particles are handed over in index order),
/// over the passes' first 22 bindings.
fn update_contact_each<K: LeafKind, F: ClothForces>(
    threads: u32,
    push: &ContactPush,
    buffers: &mut [&mut HostBuffer; UPDATE_CONTACT_COMMON],
    forces: &F,
) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let [
        params,
        x,
        v,
        x_in,
        v_in,
        x_out,
        v_out,
        acc_x,
        acc_v,
        x_prev,
        collider,
        pose,
        nodes,
        aabbs,
        leaves,
        queries,
        candidates,
        contacts,
        status,
        crowded,
        crowded_args,
        health,
    ] = buffers;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let pose: ColliderPose = pose.first()?;
    let (x, v, x_prev) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>(), x_prev.slice_mut::<Vec4>());
    let (x_in, v_in) = (x_in.slice::<Vec4>(), v_in.slice::<Vec4>());
    let (x_out, v_out) = (x_out.slice_mut::<Vec4>(), v_out.slice_mut::<Vec4>());
    let (acc_x, acc_v) = (acc_x.slice_mut::<Vec4>(), acc_v.slice_mut::<Vec4>());
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaves.slice::<K::Leaf>());
    let lists = (queries.slice::<ContactQuery>(), candidates.slice::<u32>());
    let (contacts, status) = (contacts.slice_mut::<Contact>(), status.first_mut::<CollisionStatus>()?);
    let (crowded, crowded_args) = (crowded.slice_mut::<u32>(), crowded_args.first_mut::<DispatchArgs>()?);
    let health = health.first_mut::<Health>()?;
    for i in 0..threads.min(p.particle_count) {
        update_and_contact_particle::<K, F>(
            i,
            push,
            &p,
            forces,
            (&mut *x, &mut *v, &mut *x_prev),
            (x_in, v_in, &mut *x_out, &mut *v_out, &mut *acc_x, &mut *acc_v),
            (&c, &pose),
            tree,
            lists,
            &mut *contacts,
            (&mut *status, &mut *health, (&mut *crowded, &mut *crowded_args)),
        );
    }
    Ok(())
}

/// CPU adapter of leaf kind `K`'s brute-force detect pass (`DETECT_BRUTE_FORCE_BINDINGS`).
pub fn detect_brute_force_cpu<K: LeafKind>(d: &mut HostDispatch<'_>) -> Result<(), String>
where
    K::Leaf: bytemuck::Pod,
{
    let threads = d.invocations();
    let push: ContactPush = d.push_as();
    let [params, collider, pose, leaves, x, x_prev, contacts] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let (leaves, x, x_prev) = (leaves.slice::<K::Leaf>(), x.slice::<Vec4>(), x_prev.slice::<Vec4>());
    let contacts = contacts.slice_mut::<Contact>();
    for i in 0..threads.min(p.particle_count) {
        detect_brute_force_at::<K>(i, &c, &motion, leaves, x, x_prev, contacts);
    }
    Ok(())
}

fn respond_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let push: ContactPush = d.push_as();
    let [params, collider, pose, contacts, x, v] = d.bindings()?;
    let p: SimParams = params.first()?;
    let c: ColliderParams = collider.first()?;
    let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
    let (contacts, x, v) = (contacts.slice::<Contact>(), x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>());
    for i in 0..threads.min(p.particle_count) {
        respond_at(i, &contacts[i as usize], &c, &motion, x, v);
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
    let status = status.first_mut::<CollisionStatus>()?;
    let run = if status.listed != 0 {
        true
    } else {
        let motion = substep_motion(&p, &pose.first::<ColliderPose>()?, &push);
        let (x, x_prev) = (x.slice::<Vec4>(), x_prev.slice::<Vec4>());
        let cloth = (0..CULL_THREADS)
            .map(|lane| swept_bounds(&motion, x, x_prev, p.particle_count, lane, CULL_THREADS))
            .reduce(|a, b| Aabb { min: a.min.min(b.min), max: a.max.max(b.max) })
            .ok_or("cull: no lanes")?;
        let root = root_aabb(&c, aabbs.slice(), leaf_bounds.slice());
        aabbs_overlap(&cloth, &root, c.thickness)
    };
    record_cull(run, &p, args.first_mut::<DispatchArgs>()?, status);
    Ok(())
}
