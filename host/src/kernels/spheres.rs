//! The sphere leaf kind's kernels (`drape_kernels::spheres`): leaf boxes for the LBVH build,
//! the spheres gathered into the tree's order, and contact detection over them.

use super::contact::{
    DETECT_BINDINGS, DETECT_BRUTE_FORCE_BINDINGS, DETECT_CANDIDATES_BINDINGS, DETECT_CROWDED_BINDINGS,
    UPDATE_CONTACT_BINDINGS, UPDATE_CONTACT_SPRINGS_BINDINGS, broad_phase_cpu, broad_phase_spec, contact_spec,
    detect_brute_force_cpu, detect_candidates_cpu, detect_cpu, detect_crowded_cpu, update_contact_cpu,
    update_contact_springs_cpu,
};
use super::lbvh::THREADS;
use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::contact::CONTACT_THREADS;
use drape_kernels::crowded::CROWDED_THREADS;
use drape_kernels::spheres::{Spheres, sphere_leaf_at, swept_sphere_aabb};
use drape_types::{Aabb, ColliderParams, SphereLeaf};
use glam::Vec4;

const fn spec(entry: &'static str, bindings: &'static [BindingSpec]) -> KernelSpec {
    KernelSpec::new(entry, bindings, THREADS)
}

pub static SPHERE_BOUNDS: Kernel = Kernel {
    spec: spec(
        "spheres::sphere_bounds",
        &[
            BindingSpec::read("collider"),
            BindingSpec::read("spheres"),
            BindingSpec::read("previous"),
            BindingSpec::write("bounds"),
        ],
    ),
    cpu: bounds_cpu,
};
pub static GATHER_SPHERES: Kernel = Kernel {
    spec: spec(
        "spheres::gather_spheres",
        &[
            BindingSpec::read("collider"),
            BindingSpec::read("spheres"),
            BindingSpec::read("previous"),
            BindingSpec::read("order"),
            BindingSpec::write("sorted"),
        ],
    ),
    cpu: gather_cpu,
};

pub static DETECT_SPHERES: Kernel =
    Kernel { spec: contact_spec("spheres::detect", DETECT_BINDINGS, CONTACT_THREADS), cpu: detect_cpu::<Spheres> };
pub static BROAD_PHASE_SPHERES: Kernel =
    Kernel { spec: broad_phase_spec("spheres::broad_phase"), cpu: broad_phase_cpu::<Spheres> };
pub static DETECT_SPHERES_CANDIDATES: Kernel = Kernel {
    spec: contact_spec("spheres::detect_candidates", DETECT_CANDIDATES_BINDINGS, CONTACT_THREADS),
    cpu: detect_candidates_cpu::<Spheres>,
};
/// The crowded particles the narrow phase over spheres hands over, a workgroup each.
pub static DETECT_SPHERES_CROWDED: Kernel = Kernel {
    spec: contact_spec("spheres::detect_crowded", DETECT_CROWDED_BINDINGS, CROWDED_THREADS),
    cpu: detect_crowded_cpu::<Spheres>,
};
/// The integrator's last stage and the narrow phase over spheres in one pass (grid cloth).
pub static UPDATE_CONTACT_SPHERES: Kernel = Kernel {
    spec: contact_spec("spheres::update_contact", UPDATE_CONTACT_BINDINGS, CONTACT_THREADS),
    cpu: update_contact_cpu::<Spheres>,
};
/// `UPDATE_CONTACT_SPHERES` for a spring-list cloth.
pub static UPDATE_CONTACT_SPHERES_SPRINGS: Kernel = Kernel {
    spec: contact_spec("spheres::update_contact_springs", UPDATE_CONTACT_SPRINGS_BINDINGS, CONTACT_THREADS),
    cpu: update_contact_springs_cpu::<Spheres>,
};
pub static DETECT_SPHERES_BRUTE_FORCE: Kernel = Kernel {
    spec: contact_spec("spheres::detect_brute_force", DETECT_BRUTE_FORCE_BINDINGS, CONTACT_THREADS),
    cpu: detect_brute_force_cpu::<Spheres>,
};

fn bounds_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, spheres, previous, bounds] = d.bindings()?;
    let c: ColliderParams = collider.first()?;
    let (spheres, previous, bounds) = (spheres.slice::<Vec4>(), previous.slice::<Vec4>(), bounds.slice_mut::<Aabb>());
    for i in 0..threads.min(c.leaf_count) as usize {
        bounds[i] = swept_sphere_aabb(previous[i], spheres[i]);
    }
    Ok(())
}

fn gather_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, spheres, previous, order, sorted] = d.bindings()?;
    let c: ColliderParams = collider.first()?;
    let (spheres, previous) = (spheres.slice::<Vec4>(), previous.slice::<Vec4>());
    let (order, sorted) = (order.slice::<u32>(), sorted.slice_mut::<SphereLeaf>());
    for i in 0..threads.min(c.leaf_count) as usize {
        sorted[i] = sphere_leaf_at(order[i] as usize, spheres, previous);
    }
    Ok(())
}
