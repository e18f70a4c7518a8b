//! The triangle leaf kind's kernels (`drape_kernels::triangles`): leaf boxes for the LBVH build,
//! the triangles' corners gathered into the tree's order, and contact detection over them.

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
use drape_kernels::triangles::{Triangles, corner_motions_at, swept_aabb, triangle_at};
use drape_types::{Aabb, ColliderParams, Triangle};
use glam::Vec4;

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}

pub static TRIANGLE_BOUNDS: Kernel = Kernel {
    spec: KernelSpec::new(
        "triangles::triangle_bounds",
        &[read("collider"), read("vertices"), read("previous"), read("indices"), BindingSpec::write("bounds")],
        THREADS,
    ),
    cpu: bounds_cpu,
};
pub static GATHER_TRIANGLES: Kernel = Kernel {
    spec: KernelSpec::new(
        "triangles::gather_triangles",
        &[
            read("collider"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("order"),
            BindingSpec::write("sorted"),
        ],
        THREADS,
    ),
    cpu: gather_cpu,
};
pub static DETECT_TRIANGLES: Kernel =
    Kernel { spec: contact_spec("triangles::detect", DETECT_BINDINGS, CONTACT_THREADS), cpu: detect_cpu::<Triangles> };
pub static BROAD_PHASE_TRIANGLES: Kernel =
    Kernel { spec: broad_phase_spec("triangles::broad_phase"), cpu: broad_phase_cpu::<Triangles> };
pub static DETECT_TRIANGLES_CANDIDATES: Kernel = Kernel {
    spec: contact_spec("triangles::detect_candidates", DETECT_CANDIDATES_BINDINGS, CONTACT_THREADS),
    cpu: detect_candidates_cpu::<Triangles>,
};
/// The crowded particles the narrow phase over triangles hands over, a workgroup each.
pub static DETECT_TRIANGLES_CROWDED: Kernel = Kernel {
    spec: contact_spec("triangles::detect_crowded", DETECT_CROWDED_BINDINGS, CROWDED_THREADS),
    cpu: detect_crowded_cpu::<Triangles>,
};
/// The integrator's last stage and the narrow phase over triangles in one pass (grid cloth).
pub static UPDATE_CONTACT_TRIANGLES: Kernel = Kernel {
    spec: contact_spec("triangles::update_contact", UPDATE_CONTACT_BINDINGS, CONTACT_THREADS),
    cpu: update_contact_cpu::<Triangles>,
};
/// `UPDATE_CONTACT_TRIANGLES` for a spring-list cloth.
pub static UPDATE_CONTACT_TRIANGLES_SPRINGS: Kernel = Kernel {
    spec: contact_spec("triangles::update_contact_springs", UPDATE_CONTACT_SPRINGS_BINDINGS, CONTACT_THREADS),
    cpu: update_contact_springs_cpu::<Triangles>,
};
pub static DETECT_TRIANGLES_BRUTE_FORCE: Kernel = Kernel {
    spec: contact_spec("triangles::detect_brute_force", DETECT_BRUTE_FORCE_BINDINGS, CONTACT_THREADS),
    cpu: detect_brute_force_cpu::<Triangles>,
};

fn bounds_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, vertices, previous, indices, bounds] = d.bindings()?;
    let c: ColliderParams = collider.first()?;
    let (vertices, previous, indices) = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>());
    let bounds = bounds.slice_mut::<Aabb>();
    for i in 0..threads.min(c.leaf_count) {
        bounds[i as usize] = swept_aabb(&triangle_at(i, vertices, previous, indices));
    }
    Ok(())
}

fn gather_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [collider, vertices, previous, indices, order, sorted] = d.bindings()?;
    let c: ColliderParams = collider.first()?;
    let (vertices, previous, indices) = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>());
    let (order, sorted) = (order.slice::<u32>(), sorted.slice_mut::<Triangle>());
    for i in 0..threads.min(c.leaf_count) {
        let t = order[i as usize];
        sorted[i as usize] = triangle_at(t, vertices, previous, indices);
        sorted[(c.leaf_count + i) as usize] = corner_motions_at(t, vertices, previous, indices);
    }
    Ok(())
}
