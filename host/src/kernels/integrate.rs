//! The cloth integrator kernel (`drape_kernels::integrate`).

use crate::graph::{BindingSpec, HostBuffer, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::integrate::{ClothForces, GridSprings, SpringList, StageBuffers, integrate_stage_at};
use drape_kernels::substeps::{FrameBuffers, SUBSTEPS_THREADS, frame_substeps};
use drape_types::{ParticleSprings, SimParams, Spring, StagePush, SubstepsPush};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// The bindings every integration stage starts with (both integrator kernels, and the contact
/// passes that run the last stage, `kernels::contact::UPDATE_CONTACT_BINDINGS`), then `$extra`.
/// `read` and `write` are the caller's `BindingSpec` constructors.
macro_rules! stage_bindings {
    ($($extra:expr),*) => {
        &[
            read("params"),
            write("x"),
            write("v"),
            read("x_in"),
            read("v_in"),
            write("x_out"),
            write("v_out"),
            write("acc_x"),
            write("acc_v"),
            write("x_prev"),
            $($extra),*
        ]
    };
}
pub(crate) use stage_bindings;

/// One Runge-Kutta (or Euler) stage for every particle of a grid cloth; push constants:
/// `StagePush`.
pub static INTEGRATE_STAGE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "integrate::integrate_stage",
        bindings: stage_bindings!(),
        push_constant_size: size_of::<StagePush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: integrate_cpu,
};

/// `INTEGRATE_STAGE` for a spring-list cloth (a cloth built from a mesh).
pub static INTEGRATE_STAGE_SPRINGS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "integrate::integrate_stage_springs",
        bindings: stage_bindings!(read("particles"), read("springs")),
        push_constant_size: size_of::<StagePush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: integrate_springs_cpu,
};

/// The stage buffers (bindings 1..=9 of both integrator kernels) over host buffers.
fn stage_buffers([x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev]: [&mut HostBuffer; 9]) -> StageBuffers<'_> {
    StageBuffers {
        x: x.slice_mut(),
        v: v.slice_mut(),
        x_in: x_in.slice(),
        v_in: v_in.slice(),
        x_out: x_out.slice_mut(),
        v_out: v_out.slice_mut(),
        acc_x: acc_x.slice_mut(),
        acc_v: acc_v.slice_mut(),
        x_prev: x_prev.slice_mut(),
    }
}

fn integrate_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: StagePush = d.push_as();
    let threads = d.invocations();
    let [params, x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev] = d.bindings()?;
    let p: SimParams = params.first()?;
    let mut b = stage_buffers([x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev]);
    for i in 0..threads.min(p.particle_count) {
        integrate_stage_at(&p, push.stage, i, &mut b, &GridSprings);
    }
    Ok(())
}

fn integrate_springs_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: StagePush = d.push_as();
    let threads = d.invocations();
    let [params, x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev, particles, springs] = d.bindings()?;
    let p: SimParams = params.first()?;
    let mut b = stage_buffers([x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev]);
    let forces = SpringList { particles: particles.slice::<ParticleSprings>(), springs: springs.slice::<Spring>() };
    for i in 0..threads.min(p.particle_count) {
        integrate_stage_at(&p, push.stage, i, &mut b, &forces);
    }
    Ok(())
}

/// The bindings of both one-workgroup integrator kernels (`drape_kernels::substeps`), then
/// `$extra`: the state, both ping-pong pairs, the sums and the substep's start.
macro_rules! substeps_bindings {
    ($($extra:expr),*) => {
        &[
            read("params"),
            write("x"),
            write("v"),
            write("xa"),
            write("va"),
            write("xb"),
            write("vb"),
            write("acc_x"),
            write("acc_v"),
            write("x_prev"),
            $($extra),*
        ]
    };
}

/// A grid cloth's frame of substeps in one workgroup; push constants: `SubstepsPush`.
pub static INTEGRATE_SUBSTEPS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "substeps::integrate_substeps",
        bindings: substeps_bindings!(),
        push_constant_size: size_of::<SubstepsPush>() as u32,
        workgroup_size: SUBSTEPS_THREADS,
    },
    cpu: integrate_substeps_cpu,
};

/// `INTEGRATE_SUBSTEPS` for a spring-list cloth.
pub static INTEGRATE_SUBSTEPS_SPRINGS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "substeps::integrate_substeps_springs",
        bindings: substeps_bindings!(read("particles"), read("springs")),
        push_constant_size: size_of::<SubstepsPush>() as u32,
        workgroup_size: SUBSTEPS_THREADS,
    },
    cpu: integrate_substeps_springs_cpu,
};

/// The frame's buffers (bindings 1..=9 of both one-workgroup kernels) over host buffers.
fn frame_buffers([x, v, xa, va, xb, vb, acc_x, acc_v, x_prev]: [&mut HostBuffer; 9]) -> FrameBuffers<'_> {
    FrameBuffers {
        x: x.slice_mut(),
        v: v.slice_mut(),
        xa: xa.slice_mut(),
        va: va.slice_mut(),
        xb: xb.slice_mut(),
        vb: vb.slice_mut(),
        acc_x: acc_x.slice_mut(),
        acc_v: acc_v.slice_mut(),
        x_prev: x_prev.slice_mut(),
    }
}

/// The one workgroup's lanes one after another: each stage's particles in order, as the
/// stage-per-dispatch frame's twin runs them.
fn run_substeps(p: &SimParams, push: SubstepsPush, f: &mut FrameBuffers, forces: &impl ClothForces) {
    frame_substeps(p, push.substeps, (0, 1), f, forces, || {});
}

fn integrate_substeps_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SubstepsPush = d.push_as();
    let [params, x, v, xa, va, xb, vb, acc_x, acc_v, x_prev] = d.bindings()?;
    let p: SimParams = params.first()?;
    run_substeps(&p, push, &mut frame_buffers([x, v, xa, va, xb, vb, acc_x, acc_v, x_prev]), &GridSprings);
    Ok(())
}

fn integrate_substeps_springs_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SubstepsPush = d.push_as();
    let [params, x, v, xa, va, xb, vb, acc_x, acc_v, x_prev, particles, springs] = d.bindings()?;
    let p: SimParams = params.first()?;
    let forces = SpringList { particles: particles.slice::<ParticleSprings>(), springs: springs.slice::<Spring>() };
    run_substeps(&p, push, &mut frame_buffers([x, v, xa, va, xb, vb, acc_x, acc_v, x_prev]), &forces);
    Ok(())
}
