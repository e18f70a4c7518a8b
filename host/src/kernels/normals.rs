//! Per-frame cloth kernels after the substeps: vertex normals and the blow-up check
//! (`drape_kernels::{normals, health}`), alone or in one pass.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::health::{check_health_at, particle_health_springs, record_health};
use drape_kernels::normals::{mesh_vertex_normal_at, vertex_normal_at};
use drape_types::{Health, ParticleSprings, SimParams, Spring};
use glam::Vec4;

/// The blow-up check of a spring-list cloth.
pub static CHECK_HEALTH_SPRINGS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "health::check_health_springs",
        bindings: &[
            BindingSpec::read("params"),
            BindingSpec::read("x"),
            BindingSpec::read("v"),
            BindingSpec::read("x_prev"),
            BindingSpec::read("particles"),
            BindingSpec::read("springs"),
            BindingSpec::write("health"),
        ],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: health_springs_cpu,
};

pub static CHECK_HEALTH: Kernel = Kernel {
    spec: KernelSpec {
        entry: "health::check_health",
        bindings: &[
            BindingSpec::read("params"),
            BindingSpec::read("x"),
            BindingSpec::read("v"),
            BindingSpec::read("x_prev"),
            BindingSpec::write("health"),
        ],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: health_cpu,
};

/// Normals and the blow-up check of a grid cloth in one pass.
pub static NORMALS_AND_HEALTH: Kernel = Kernel {
    spec: KernelSpec {
        entry: "health::normals_and_health",
        bindings: &[
            BindingSpec::read("params"),
            BindingSpec::read("x"),
            BindingSpec::read("v"),
            BindingSpec::read("x_prev"),
            BindingSpec::write("normals"),
            BindingSpec::write("health"),
        ],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: normals_and_health_cpu,
};

/// Normals and the blow-up check of a spring-list cloth in one pass.
pub static MESH_NORMALS_AND_HEALTH: Kernel = Kernel {
    spec: KernelSpec {
        entry: "health::mesh_normals_and_health",
        bindings: &[
            BindingSpec::read("params"),
            BindingSpec::read("x"),
            BindingSpec::read("v"),
            BindingSpec::read("x_prev"),
            BindingSpec::read("particles"),
            BindingSpec::read("springs"),
            BindingSpec::read("vertex_triangle_offsets"),
            BindingSpec::read("vertex_triangles"),
            BindingSpec::read("indices"),
            BindingSpec::write("normals"),
            BindingSpec::write("health"),
        ],
        push_constant_size: 0,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: mesh_normals_and_health_cpu,
};

fn normals_and_health_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, x_prev, normals, health] = d.bindings()?;
    let p: SimParams = params.first()?;
    let (x, v, x_prev) = (x.slice::<Vec4>(), v.slice::<Vec4>(), x_prev.slice::<Vec4>());
    let (normals, health) = (normals.slice_mut::<Vec4>(), health.first_mut::<Health>()?);
    for i in 0..threads.min(p.particle_count) {
        normals[i as usize] = vertex_normal_at(&p, i, x).extend(0.0);
        check_health_at(&p, i, x, v, x_prev, health);
    }
    Ok(())
}

fn mesh_normals_and_health_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, x_prev, particles, springs, offsets, vertex_triangles, indices, normals, health] =
        d.bindings()?;
    let p: SimParams = params.first()?;
    let (x, v, x_prev) = (x.slice::<Vec4>(), v.slice::<Vec4>(), x_prev.slice::<Vec4>());
    let (particles, springs) = (particles.slice::<ParticleSprings>(), springs.slice::<Spring>());
    let (offsets, vertex_triangles, indices) =
        (offsets.slice::<u32>(), vertex_triangles.slice::<u32>(), indices.slice::<u32>());
    let (normals, health) = (normals.slice_mut::<Vec4>(), health.first_mut::<Health>()?);
    for i in 0..threads.min(p.particle_count) {
        normals[i as usize] = mesh_vertex_normal_at(i, x, offsets, vertex_triangles, indices).extend(0.0);
        record_health(health, particle_health_springs(i, x, v, x_prev, particles, springs));
    }
    Ok(())
}

fn health_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, x_prev, health] = d.bindings()?;
    let p: SimParams = params.first()?;
    let health = health.first_mut::<Health>()?;
    for i in 0..threads.min(p.particle_count) {
        check_health_at(&p, i, x.slice(), v.slice(), x_prev.slice(), health);
    }
    Ok(())
}

fn health_springs_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, x, v, x_prev, particles, springs, health] = d.bindings()?;
    let p: SimParams = params.first()?;
    let health = health.first_mut::<Health>()?;
    let (particles, springs) = (particles.slice::<ParticleSprings>(), springs.slice::<Spring>());
    for i in 0..threads.min(p.particle_count) {
        record_health(health, particle_health_springs(i, x.slice(), v.slice(), x_prev.slice(), particles, springs));
    }
    Ok(())
}
