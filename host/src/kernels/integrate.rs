//! The cloth integrator kernel (`drape_kernels::integrate`).

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::integrate::{StageBuffers, integrate_stage_at};
use drape_types::{SimParams, StagePush};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

/// One Runge-Kutta (or Euler) stage for every particle; push constants: `StagePush`.
pub static INTEGRATE_STAGE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "integrate::integrate_stage",
        bindings: &[
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
        ],
        push_constant_size: size_of::<StagePush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: integrate_cpu,
};

fn integrate_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: StagePush = d.push_as();
    let threads = d.invocations();
    let [params, x, v, x_in, v_in, x_out, v_out, acc_x, acc_v, x_prev] = d.bindings()?;
    let p: SimParams = params.first()?;
    let mut b = StageBuffers {
        x: x.slice_mut(),
        v: v.slice_mut(),
        x_in: x_in.slice(),
        v_in: v_in.slice(),
        x_out: x_out.slice_mut(),
        v_out: v_out.slice_mut(),
        acc_x: acc_x.slice_mut(),
        acc_v: acc_v.slice_mut(),
        x_prev: x_prev.slice_mut(),
    };
    for i in 0..threads.min(p.particle_count) {
        integrate_stage_at(&p, push.stage, i, &mut b);
    }
    Ok(())
}
