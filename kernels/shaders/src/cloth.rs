//! Mass-spring cloth forces (design.md §1): springs are gathered per particle from its grid
//! neighbours, so no thread writes another particle's force and results are identical run to run.

use drape_types::glam::{Vec3, Vec4, Vec4Swizzles};
use drape_types::{ParticleSprings, SimParams, Spring};

/// Spring families, by grid offset.
pub const STRUCTURAL: u32 = 0;
pub const SHEAR: u32 = 1;
pub const BEND: u32 = 2;

/// One spring of a particle: the neighbour's grid offset and the spring family.
#[derive(Copy, Clone)]
pub struct SpringOffset {
    pub d_row: i32,
    pub d_col: i32,
    pub family: u32,
}

const fn spring(d_row: i32, d_col: i32, family: u32) -> SpringOffset {
    SpringOffset { d_row, d_col, family }
}

/// The 12 springs a particle can have: structural (±1,0),(0,±1), shear (±1,±1), bend (±2,0),(0,±2).
pub const SPRINGS: [SpringOffset; 12] = [
    spring(0, 1, STRUCTURAL),
    spring(0, -1, STRUCTURAL),
    spring(1, 0, STRUCTURAL),
    spring(-1, 0, STRUCTURAL),
    spring(1, 1, SHEAR),
    spring(-1, -1, SHEAR),
    spring(1, -1, SHEAR),
    spring(-1, 1, SHEAR),
    spring(0, 2, BEND),
    spring(0, -2, BEND),
    spring(2, 0, BEND),
    spring(-2, 0, BEND),
];

/// The `s`-th entry of `SPRINGS`, computed rather than looked up: rust-gpu keeps a constant
/// table indexed in a loop as a function-local array, which llvmpipe places in per-invocation
/// scratch memory and fills on every call.
#[inline]
pub fn spring_offset(s: u32) -> SpringOffset {
    let family = s >> 2;
    let k = s & 3;
    let sign = if k & 1 == 0 { 1 } else { -1 };
    let (d_row, d_col) = if family == SHEAR {
        (sign, if k < 2 { sign } else { -sign })
    } else {
        let reach = if family == STRUCTURAL { 1 } else { 2 };
        if k < 2 { (0, sign * reach) } else { (sign * reach, 0) }
    };
    SpringOffset { d_row, d_col, family }
}

/// Below this length (m) a spring has no direction; it then exerts no force (guard for eq. 1).
pub const MIN_SPRING_LENGTH: f32 = 1e-9;

/// Stiffness of a spring family.
#[inline]
pub fn stiffness(p: &SimParams, family: u32) -> f32 {
    if family == STRUCTURAL {
        p.k_struct
    } else if family == SHEAR {
        p.k_shear
    } else {
        p.k_bend
    }
}

/// Rest length of the spring with this grid offset (uniform over the grid; see `SimParams::rest`).
#[inline]
pub fn rest_length(p: &SimParams, s: SpringOffset) -> f32 {
    if s.d_row == 0 {
        p.rest.x * s.d_col.unsigned_abs() as f32
    } else if s.d_col == 0 {
        p.rest.y * s.d_row.unsigned_abs() as f32
    } else if s.d_row == s.d_col {
        p.rest.z
    } else {
        p.rest.w
    }
}

/// Index of the particle at (`row`, `col`) offset by `s`, or `None` when it falls off the grid.
/// Takes row and column rather than the index: integer division is scalarised on SIMD
/// drivers (llvmpipe), so kernels divide once per particle, not once per spring.
#[inline]
pub fn neighbour(p: &SimParams, row: u32, col: u32, s: SpringOffset) -> Option<u32> {
    let r = row as i32 + s.d_row;
    let c = col as i32 + s.d_col;
    if r < 0 || c < 0 || r >= p.rows as i32 || c >= p.cols as i32 { None } else { Some(r as u32 * p.cols + c as u32) }
}

/// Force (N) on a particle at `xi` from one spring to `xj`: Hooke (eq. 1) plus damping along
/// the axis. Branch-free: a zero-length spring (including a particle paired with itself, which
/// `acceleration` uses for springs that fall off the grid) has no axis and exerts no force.
#[inline]
pub fn spring_force(k: f32, rest: f32, c_s: f32, xi: Vec3, vi: Vec3, xj: Vec3, vj: Vec3) -> Vec3 {
    let d = xj - xi;
    let len = d.length();
    let inv_len = if len > MIN_SPRING_LENGTH { 1.0 / len } else { 0.0 };
    let axis = d * inv_len;
    let magnitude = k * (len - rest) + c_s * (vj - vi).dot(axis);
    axis * magnitude
}

/// `slice[index]`. (Kept checked: spirv-std's `index_unchecked` made this kernel ~1.5x slower on
/// llvmpipe, since its pointer round-trip defeats the driver's optimiser.)
#[inline]
pub fn load(slice: &[Vec4], index: u32) -> Vec4 {
    slice[index as usize]
}

/// Acceleration (m/s^2) of particle `index` in state (`pos`, `vel`): springs, gravity, external
/// force and velocity damping. `pos.w` is the inverse mass weight (0 = pinned, 1 = free).
pub fn acceleration(p: &SimParams, index: u32, pos: &[Vec4], vel: &[Vec4]) -> Vec3 {
    let here = load(pos, index);
    let pin_weight = here.w;
    let xi = here.xyz();
    let vi = load(vel, index).xyz();
    let mut force = p.gravity.xyz() * p.particle_mass + p.external_force.xyz() - vi * p.velocity_damping;
    // Integer division is scalarised on SIMD drivers (llvmpipe): once per particle.
    let (row, col) = (index / p.cols, index % p.cols);
    let mut s = 0;
    while s < SPRINGS.len() as u32 {
        let spring = spring_offset(s);
        // Off-grid springs pair the particle with itself: zero length, zero force, no branch.
        let j = match neighbour(p, row, col, spring) {
            Some(j) => j,
            None => index,
        };
        force += spring_force(
            stiffness(p, spring.family),
            rest_length(p, spring),
            p.spring_damping,
            xi,
            vi,
            load(pos, j).xyz(),
            load(vel, j).xyz(),
        );
        s += 1;
    }
    force * (pin_weight * (1.0 / p.particle_mass))
}

/// Acceleration (m/s^2) of particle `index` of a spring-list cloth (one built from a mesh):
/// its own springs (`particles[index]`, each at its `Spring::stiffness_scale` of its family's
/// stiffness and damping), gravity, and the external force and velocity damping
/// per unit of the mean particle mass, so a light particle and a heavy one drift alike in wind
/// and a uniform cloth behaves as the grid does. `pos.w` is the pin weight.
pub fn acceleration_springs(
    p: &SimParams,
    index: u32,
    pos: &[Vec4],
    vel: &[Vec4],
    particles: &[ParticleSprings],
    springs: &[Spring],
) -> Vec3 {
    let here = load(pos, index);
    let xi = here.xyz();
    let vi = load(vel, index).xyz();
    let me = particles[index as usize];
    let mut force = Vec3::ZERO;
    let mut s = me.first;
    let end = me.first + me.count;
    while s < end {
        let spring = springs[s as usize];
        force += spring_force(
            stiffness(p, spring.family) * spring.stiffness_scale,
            spring.rest,
            p.spring_damping * spring.stiffness_scale,
            xi,
            vi,
            load(pos, spring.other).xyz(),
            load(vel, spring.other).xyz(),
        );
        s += 1;
    }
    // Written as `(wind - v c) / m`, lavapipe's frames left the CPU twin's in the last bits
    // whenever velocity damping was on (the driver rounds that form its own way); in this form
    // they agree (`mesh_cloth_with_velocity_damping_and_wind_equals_the_cpu_twin`).
    let inverse_mean_mass = 1.0 / p.particle_mass;
    let per_mass = p.external_force.xyz() * inverse_mean_mass - vi * (p.velocity_damping * inverse_mean_mass);
    (force * me.inverse_mass + per_mass + p.gravity.xyz()) * here.w
}

#[cfg(test)]
mod tests {
    use super::*;
    use drape_types::glam::Vec4;

    fn grid(rows: u32, cols: u32) -> SimParams {
        SimParams {
            rows,
            cols,
            particle_count: rows * cols,
            k_struct: 10.0,
            k_shear: 2.0,
            k_bend: 1.0,
            particle_mass: 0.5,
            rest: Vec4::new(0.1, 0.2, 0.3, 0.4),
            ..Default::default()
        }
    }

    #[test]
    fn stretched_spring_pulls_towards_its_neighbour() {
        let f = spring_force(10.0, 1.0, 0.0, Vec3::ZERO, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::ZERO);
        assert_eq!(f, Vec3::new(10.0, 0.0, 0.0));
        let f = spring_force(10.0, 1.0, 0.0, Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO);
        assert_eq!(f, Vec3::new(0.0, -5.0, 0.0));
    }

    #[test]
    fn axis_damping_ignores_rigid_motion_and_resists_separation() {
        let (xi, xj) = (Vec3::ZERO, Vec3::X);
        let rigid = spring_force(0.0, 1.0, 3.0, xi, Vec3::ONE, xj, Vec3::ONE);
        assert_eq!(rigid, Vec3::ZERO);
        let separating = spring_force(0.0, 1.0, 3.0, xi, Vec3::ZERO, xj, Vec3::X);
        assert_eq!(separating, Vec3::new(3.0, 0.0, 0.0));
    }

    #[test]
    fn coincident_particles_exert_no_force() {
        let f = spring_force(10.0, 1.0, 1.0, Vec3::ONE, Vec3::ZERO, Vec3::ONE, Vec3::X);
        assert_eq!(f, Vec3::ZERO);
    }

    #[test]
    fn computed_offsets_equal_the_table() {
        for (s, expected) in SPRINGS.iter().enumerate() {
            let got = spring_offset(s as u32);
            assert_eq!((got.d_row, got.d_col, got.family), (expected.d_row, expected.d_col, expected.family));
        }
    }

    #[test]
    fn neighbours_stay_on_the_grid() {
        let p = grid(3, 4);
        assert_eq!(neighbour(&p, 0, 0, spring(0, 1, STRUCTURAL)), Some(1));
        assert_eq!(neighbour(&p, 0, 0, spring(1, 1, SHEAR)), Some(5));
        assert_eq!(neighbour(&p, 0, 0, spring(-1, 0, STRUCTURAL)), None);
        assert_eq!(neighbour(&p, 2, 3, spring(0, 2, BEND)), None);
        assert_eq!(neighbour(&p, 2, 3, spring(-2, 0, BEND)), Some(3));
    }

    #[test]
    fn rest_lengths_follow_the_offset() {
        let p = grid(3, 3);
        assert_eq!(rest_length(&p, spring(0, -2, BEND)), 0.2);
        assert_eq!(rest_length(&p, spring(2, 0, BEND)), 0.4);
        assert_eq!(rest_length(&p, spring(-1, -1, SHEAR)), 0.3);
        assert_eq!(rest_length(&p, spring(1, -1, SHEAR)), 0.4);
    }

    #[test]
    fn cloth_at_rest_without_gravity_feels_nothing() {
        let mut p = grid(3, 3);
        p.rest = Vec4::new(1.0, 1.0, 2f32.sqrt(), 2f32.sqrt());
        let pos: Vec<Vec4> = (0..9).map(|i| Vec4::new((i % 3) as f32, 0.0, (i / 3) as f32, 1.0)).collect();
        let vel = vec![Vec4::ZERO; 9];
        for i in 0..9 {
            assert!(acceleration(&p, i, &pos, &vel).length() < 1e-6);
        }
    }
}
