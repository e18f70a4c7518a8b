//! GPU structs shared by drape's kernels (SPIR-V) and its host (x86_64): each is defined once,
//! here. Rules: `#[repr(C)]`, only 4-byte scalars and `Vec4`, explicit padding, size asserted at
//! compile time, so the SPIR-V layout (std430) and the host layout cannot drift apart.
#![cfg_attr(target_arch = "spirv", no_std)]

pub use spirv_std::glam;
use spirv_std::glam::Vec4;

/// Which integrator a simulation uses (`SimParams::integrator`).
pub mod integrator {
    /// Classical 4-stage Runge-Kutta on (x, v): 4 stage dispatches per substep.
    pub const RK4: u32 = 0;
    /// Semi-implicit (symplectic) Euler, the paper's eq. 3: 2 dispatches per substep.
    pub const SEMI_IMPLICIT_EULER: u32 = 1;
}

/// Everything the cloth kernels need to know about a cloth, constant over a run.
/// Lives in a read-only storage buffer (binding 0 of the cloth kernels).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct SimParams {
    /// Particles along the row direction (grid is `rows x cols`, index = row * cols + col).
    pub rows: u32,
    pub cols: u32,
    pub particle_count: u32,
    /// `integrator::RK4` or `integrator::SEMI_IMPLICIT_EULER`.
    pub integrator: u32,
    /// Gravity acceleration (m/s^2), w unused.
    pub gravity: Vec4,
    /// Constant external force on every free particle (N), e.g. wind; w unused.
    pub external_force: Vec4,
    /// Spring stiffness (N/m) per family.
    pub k_struct: f32,
    pub k_shear: f32,
    pub k_bend: f32,
    /// Damping along each spring's axis (N s/m): damps stretching, not rigid motion.
    pub spring_damping: f32,
    /// The paper's eq. 2 damping `f = -c_d v` (N s/m).
    pub velocity_damping: f32,
    /// Mass of one particle (kg).
    pub particle_mass: f32,
    /// Substep length h (s).
    pub substep: f32,
    pub _pad0: u32,
    /// Rest lengths (m): x = one column step, y = one row step, z = diagonal (+row,+col),
    /// w = anti-diagonal (+row,-col). Bend springs are two steps: twice x and y.
    pub rest: Vec4,
}

/// Per-dispatch constants of the cloth integrator kernel.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct StagePush {
    /// 0..=3: which Runge-Kutta stage (or 0 = evaluate / 3 = commit for Euler).
    pub stage: u32,
    pub _pad: [u32; 3],
}

/// Blow-up detector, written by the `check_health` kernel once per frame (atomics).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Health {
    /// Count of particles whose position or velocity is not finite.
    pub non_finite: u32,
    /// Largest structural-spring stretch (length / rest), as `f32::to_bits` (positive floats
    /// order like their bits, so `atomic_u_max` on the bits is a float max).
    pub max_stretch_bits: u32,
    pub _pad: [u32; 2],
}

const _: () = assert!(core::mem::size_of::<SimParams>() == 96);
const _: () = assert!(core::mem::size_of::<StagePush>() == 16);
const _: () = assert!(core::mem::size_of::<Health>() == 16);
