//! A frame described as data: which kernel runs, on which buffers, with which push constants and
//! timing label. The Vulkan engine records it; the CPU executor runs the same list with the same
//! kernel functions, so both follow one schedule.

use crate::kernels::KernelId;
use drape_types::{StagePush, integrator};

/// Every buffer a frame can bind.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum BufferId {
    Params,
    X,
    V,
    /// Ping-pong intermediate states of the Runge-Kutta stages.
    XA,
    VA,
    XB,
    VB,
    AccX,
    AccV,
    XPrev,
    Normals,
    Health,
}

/// One dispatch of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    pub label: &'static str,
    pub kernel: KernelId,
    pub bindings: Vec<BufferId>,
    pub push: Option<StagePush>,
    /// Threads to run (one per particle).
    pub threads: u32,
}

/// One entry of a frame: a pass to run, or one the scene does not need.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameStep {
    /// Zero the health counters.
    ResetHealth,
    Run(Pass),
    Skip { label: &'static str },
}

/// What a frame must do.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FramePlan {
    pub particles: u32,
    pub substeps: u32,
    pub integrator: u32,
    pub normals: bool,
}

fn integrate_pass(label: &'static str, stage: u32, input: (BufferId, BufferId), output: (BufferId, BufferId), threads: u32) -> Pass {
    use BufferId::*;
    Pass {
        label,
        kernel: KernelId::IntegrateStage,
        bindings: vec![Params, X, V, input.0, input.1, output.0, output.1, AccX, AccV, XPrev],
        push: Some(StagePush { stage, _pad: [0; 3] }),
        threads,
    }
}

/// The passes of one frame: `substeps` integration substeps, then normals (when asked) and the
/// blow-up check.
pub fn cloth_frame(plan: FramePlan) -> Vec<FrameStep> {
    use BufferId::*;
    let n = plan.particles;
    let a = (XA, VA);
    let b = (XB, VB);
    let mut steps = vec![FrameStep::ResetHealth];
    for _ in 0..plan.substeps {
        if plan.integrator == integrator::SEMI_IMPLICIT_EULER {
            steps.push(FrameStep::Run(integrate_pass("euler: evaluate", 0, b, a, n)));
            steps.push(FrameStep::Run(integrate_pass("euler: commit", 3, b, a, n)));
        } else {
            // Stage s reads the previous stage's output: A and B swap roles each stage.
            steps.push(FrameStep::Run(integrate_pass("rk4: k1", 0, b, a, n)));
            steps.push(FrameStep::Run(integrate_pass("rk4: k2", 1, a, b, n)));
            steps.push(FrameStep::Run(integrate_pass("rk4: k3", 2, b, a, n)));
            steps.push(FrameStep::Run(integrate_pass("rk4: k4 + update", 3, a, b, n)));
        }
    }
    if plan.normals {
        steps.push(FrameStep::Run(Pass {
            label: "normals",
            kernel: KernelId::VertexNormals,
            bindings: vec![Params, X, Normals],
            push: None,
            threads: n,
        }));
    } else {
        steps.push(FrameStep::Skip { label: "normals" });
    }
    steps.push(FrameStep::Run(Pass {
        label: "health check",
        kernel: KernelId::CheckHealth,
        bindings: vec![Params, X, V, Health],
        push: None,
        threads: n,
    }));
    steps
}
