//! Per-frame cloth kernels after the substeps: vertex normals and the blow-up check
//! (`drape_kernels::{normals, health}`).

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::health::check_health_at;
use drape_kernels::normals::vertex_normal_at;
use drape_types::{Health, SimParams};
use glam::Vec4;

pub static VERTEX_NORMALS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "normals::vertex_normals",
        bindings: &[BindingSpec::read("params"), BindingSpec::read("x"), BindingSpec::write("normals")],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: normals_cpu,
};

pub static CHECK_HEALTH: Kernel = Kernel {
    spec: KernelSpec {
        entry: "health::check_health",
        bindings: &[
            BindingSpec::read("params"),
            BindingSpec::read("x"),
            BindingSpec::read("v"),
            BindingSpec::write("health"),
        ],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: health_cpu,
};

fn normals_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, normals] = d.bindings()?;
    let p: SimParams = params.first()?;
    let (x, normals) = (x.slice::<Vec4>(), normals.slice_mut::<Vec4>());
    for i in 0..threads.min(p.particle_count) {
        normals[i as usize] = vertex_normal_at(&p, i, x).extend(0.0);
    }
    Ok(())
}

fn health_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, health] = d.bindings()?;
    let p: SimParams = params.first()?;
    let health = health.first_mut::<Health>()?;
    for i in 0..threads.min(p.particle_count) {
        check_health_at(&p, i, x.slice(), v.slice(), health);
    }
    Ok(())
}
