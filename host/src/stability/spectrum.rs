//! Matrix-free estimates of the stiffest and the most damped modes of a cloth at a state.
//!
//! The linearised cloth is x'' = J_x x + J_v x' with J_x = da/dx and J_v = da/dv, where `a` is
//! the kernels' own acceleration function (`cloth::acceleration` for a grid,
//! `cloth::acceleration_springs` for a spring list). Both Jacobians are D times a symmetric
//! matrix (D = pin weight x inverse mass per particle), so D^(1/2) (-J) D^(-1/2) is symmetric
//! with the same eigenvalues: omega_max^2 for the stiffness and gamma_max for the damping.
//! Lanczos finds the largest eigenvalue of each from products with the Jacobian alone, each a
//! central difference of two force evaluations, so the estimate sees exactly the forces the
//! kernels integrate, at the state they start from (a stretched cloth is stiffer than a flat
//! one across its springs).
//!
//! The estimate returned is the largest Ritz value plus its residual norm |beta_k s_k|: an
//! eigenvalue lies within that distance of the Ritz value, and a Ritz value approaches the
//! largest eigenvalue from below.

use crate::cloth::{Cloth, ClothTopology};
use crate::cloth_mesh::SpringTopology;
use drape_kernels::cloth::{acceleration, acceleration_springs};
use drape_types::SimParams;
use glam::{Vec3, Vec4};
use std::sync::Arc;

/// The cloth's force function at a state: springs, masses, pins and the positions and
/// velocities to linearise at.
#[derive(Clone, Debug)]
pub struct Linearisation {
    springs: Option<Arc<SpringTopology>>,
    positions: Arc<[Vec4]>,
    velocities: Arc<[Vec4]>,
}

/// Largest eigenvalues of the linearised stiffness and damping (per unit mass).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// sqrt of the largest eigenvalue of -da/dx (rad/s).
    pub omega_max: f64,
    /// Largest eigenvalue of -da/dv (1/s).
    pub gamma_max: f64,
    /// Lanczos steps taken (stiffness, damping).
    pub steps: (u32, u32),
}

/// Most Lanczos steps per estimate; the top Ritz value of a cloth's spectrum settles to 1e-6 in
/// 20-40 steps for 16^2 to 512^2 grids, and the residual term covers what is left.
const MAX_STEPS: usize = 60;

/// Lanczos stops once the residual is this fraction of the Ritz value: the estimate is then at
/// most 0.5% above an eigenvalue (0.25% in omega).
const RESIDUAL_TOLERANCE: f64 = 5e-3;

/// The largest perturbation of a particle in a position product, as a fraction of the
/// shortest rest length: small enough that the springs stay linear (central differences
/// cancel the quadratic term, the cubic one is 1e-4 relative), large enough that positions'
/// f32 rounding (6e-8 m at 1 m) is 1e-4 of it on a 64^2 metre cloth.
const POSITION_PROBE: f32 = 0.02;

impl Linearisation {
    /// `cloth` at its current state.
    pub fn of(cloth: &Cloth) -> Self {
        let springs = match &cloth.topology {
            ClothTopology::Grid => None,
            ClothTopology::Springs(s) => Some(Arc::new(s.clone())),
        };
        Linearisation {
            springs,
            positions: cloth.positions.clone().into(),
            velocities: cloth.velocities.clone().into(),
        }
    }

    fn particles(&self) -> usize {
        self.positions.len()
    }

    /// D_i = pin weight x inverse mass of each particle.
    fn mobility(&self, p: &SimParams) -> Vec<f64> {
        match &self.springs {
            None => self.positions.iter().map(|x| x.w as f64 / p.particle_mass as f64).collect(),
            Some(s) => {
                self.positions.iter().zip(&s.particles).map(|(x, q)| x.w as f64 * q.inverse_mass as f64).collect()
            }
        }
    }

    /// Shortest spring rest length (m): the scale of a position probe.
    fn shortest_rest(&self, p: &SimParams) -> f32 {
        match &self.springs {
            None => {
                [p.rest.x, p.rest.y, p.rest.z, p.rest.w].into_iter().filter(|r| *r > 0.0).fold(f32::INFINITY, f32::min)
            }
            Some(s) => s.springs.iter().map(|s| s.rest).filter(|r| *r > 0.0).fold(f32::INFINITY, f32::min),
        }
    }

    /// Every particle's acceleration in state (`x`, `v`), split over the machine's cores.
    fn accelerations(&self, p: &SimParams, x: &[Vec4], v: &[Vec4], out: &mut [Vec3]) {
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(16);
        let chunk = out.len().div_ceil(threads).max(1024);
        std::thread::scope(|scope| {
            for (c, part) in out.chunks_mut(chunk).enumerate() {
                scope.spawn(move || {
                    let first = c * chunk;
                    for (k, a) in part.iter_mut().enumerate() {
                        let i = (first + k) as u32;
                        *a = match &self.springs {
                            None => acceleration(p, i, x, v),
                            Some(s) => acceleration_springs(p, i, x, v, &s.particles, &s.springs),
                        };
                    }
                });
            }
        });
    }

    /// `out = S y` (see `Operator`).
    fn apply(&self, op: &Operator, y: &[f64], out: &mut [f64], work: &mut Work) {
        let Operator { params: p, root_d, velocity, probe } = *op;
        let u = |i: usize| Vec3::new(y[3 * i] as f32, y[3 * i + 1] as f32, y[3 * i + 2] as f32) * root_d[i] as f32;
        let largest = (0..self.particles()).map(|i| u(i).abs().max_element()).fold(0.0f32, f32::max);
        if largest == 0.0 {
            out.fill(0.0);
            return;
        }
        let scale = probe / largest;
        // a is affine in v: a one-sided difference is exact, one force evaluation fewer.
        let signs: &[f32] = if velocity { &[1.0, 0.0] } else { &[1.0, -1.0] };
        for &sign in signs {
            if sign == 0.0 && work.unperturbed {
                continue; // `minus` still holds a(x, v)
            }
            if sign <= 0.0 {
                work.unperturbed = sign == 0.0;
            }
            let (x, v) = (&mut work.x, &mut work.v);
            x.copy_from_slice(&self.positions);
            v.copy_from_slice(&self.velocities);
            let moved = if velocity { &mut *v } else { &mut *x };
            for (i, m) in moved.iter_mut().enumerate() {
                *m += (u(i) * (sign * scale)).extend(0.0);
            }
            let target = if sign > 0.0 { &mut work.plus } else { &mut work.minus };
            self.accelerations(p, x, v, target);
        }
        let span = (signs[0] - signs[1]) as f64 * scale as f64;
        for i in 0..self.particles() {
            let d = (work.plus[i] - work.minus[i]).as_dvec3() / span;
            let s = if root_d[i] > 0.0 { -1.0 / root_d[i] } else { 0.0 };
            out[3 * i..3 * i + 3].copy_from_slice(&(d * s).to_array());
        }
    }

    /// The stiffest and most damped modes under `p`.
    pub fn spectrum(&self, p: &SimParams) -> Spectrum {
        let n = self.particles();
        let root_d: Vec<f64> = self.mobility(p).into_iter().map(|d| d.max(0.0).sqrt()).collect();
        let mut work = Work::new(n);
        let probe = POSITION_PROBE * self.shortest_rest(p);
        let probe = if probe.is_finite() && probe > 0.0 { probe } else { 1e-4 };
        let stiffness = Operator { params: p, root_d: &root_d, velocity: false, probe };
        let (stiff, stiff_steps) = lanczos_max(3 * n, |y, out| self.apply(&stiffness, y, out, &mut work));
        let damping = Operator { params: p, root_d: &root_d, velocity: true, probe: 1.0 };
        let (damp, damp_steps) = lanczos_max(3 * n, |y, out| self.apply(&damping, y, out, &mut work));
        Spectrum { omega_max: stiff.max(0.0).sqrt(), gamma_max: damp.max(0.0), steps: (stiff_steps, damp_steps) }
    }
}

/// S = D^(1/2) (-J) D^(-1/2), J = da/dx (or da/dv when `velocity`), applied by a difference of
/// the force function along u = D^(1/2) y (central for positions), the largest component of
/// the perturbation being `probe` (m, or m/s).
#[derive(Copy, Clone)]
struct Operator<'a> {
    params: &'a SimParams,
    /// sqrt(D_i) per particle.
    root_d: &'a [f64],
    velocity: bool,
    probe: f32,
}

/// Scratch state of the products.
struct Work {
    x: Vec<Vec4>,
    v: Vec<Vec4>,
    plus: Vec<Vec3>,
    minus: Vec<Vec3>,
    /// `minus` holds the unperturbed accelerations.
    unperturbed: bool,
}

impl Work {
    fn new(n: usize) -> Self {
        Work {
            x: vec![Vec4::ZERO; n],
            v: vec![Vec4::ZERO; n],
            plus: vec![Vec3::ZERO; n],
            minus: vec![Vec3::ZERO; n],
            unperturbed: false,
        }
    }
}

/// A fixed pseudo-random start vector (xorshift), so the estimate is the same every run.
fn start_vector(n: usize) -> Vec<f64> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut v: Vec<f64> = (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    normalise(&mut v);
    v
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn normalise(v: &mut [f64]) -> f64 {
    let norm = dot(v, v).sqrt();
    if norm > 0.0 {
        v.iter_mut().for_each(|x| *x /= norm);
    }
    norm
}

/// Largest eigenvalue estimate of the symmetric operator `apply` on R^n (Lanczos without
/// reorthogonalisation: lost orthogonality only repeats converged Ritz values): the top Ritz
/// value plus its residual, and the steps taken.
pub(crate) fn lanczos_max(n: usize, mut apply: impl FnMut(&[f64], &mut [f64])) -> (f64, u32) {
    let mut q = start_vector(n);
    let mut q_prev = vec![0.0; n];
    let mut w = vec![0.0; n];
    let (mut alpha, mut beta) = (Vec::new(), Vec::new());
    let mut estimate = 0.0;
    let mut last_top = f64::NAN;
    for step in 1..=MAX_STEPS.min(n) {
        apply(&q, &mut w);
        let a = dot(&w, &q);
        let b_prev = beta.last().copied().unwrap_or(0.0);
        for i in 0..n {
            w[i] -= a * q[i] + b_prev * q_prev[i];
        }
        alpha.push(a);
        let b = normalise(&mut w);
        let (top, residual) = top_ritz(&alpha, &beta, b);
        estimate = top + residual;
        // Settled when the estimate is within RESIDUAL_TOLERANCE of an eigenvalue and the top
        // Ritz value has stopped climbing (a cluster below the top can have a small residual
        // while the top is still being found).
        let settled = residual <= RESIDUAL_TOLERANCE * top.abs() && (top - last_top).abs() <= 1e-4 * top.abs();
        if b <= 1e-12 * top.abs().max(f64::MIN_POSITIVE) || settled {
            return (estimate, step as u32);
        }
        last_top = top;
        beta.push(b);
        std::mem::swap(&mut q_prev, &mut q);
        std::mem::swap(&mut q, &mut w);
    }
    (estimate, MAX_STEPS.min(n) as u32)
}

/// Largest eigenvalue of the symmetric tridiagonal matrix (diagonal `alpha`, off-diagonal
/// `beta`) by Sturm-sequence bisection, and the residual |b s_k| of its Ritz pair, s being its
/// unit eigenvector (by inverse iteration) and b the next off-diagonal.
fn top_ritz(alpha: &[f64], beta: &[f64], b: f64) -> (f64, f64) {
    let k = alpha.len();
    // Gershgorin interval of the tridiagonal matrix.
    let radius =
        |i: usize| (if i > 0 { beta[i - 1].abs() } else { 0.0 }) + (if i + 1 < k { beta[i].abs() } else { 0.0 });
    let lo0 = (0..k).map(|i| alpha[i] - radius(i)).fold(f64::INFINITY, f64::min);
    let hi0 = (0..k).map(|i| alpha[i] + radius(i)).fold(f64::NEG_INFINITY, f64::max);
    // Eigenvalues greater than x: sign changes of the LDL^T pivots of (T - x).
    let above = |x: f64| {
        let mut count = 0;
        let mut d = 1.0;
        for i in 0..k {
            let off = if i > 0 { beta[i - 1] * beta[i - 1] } else { 0.0 };
            d = alpha[i] - x - if i > 0 { off / d } else { 0.0 };
            if d == 0.0 {
                d = -1e-300;
            }
            if d > 0.0 {
                count += 1;
            }
        }
        count
    };
    let (mut lo, mut hi) = (lo0, hi0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if above(mid) >= 1 { lo = mid } else { hi = mid }
    }
    let top = hi;
    // Inverse iteration for the eigenvector's last component.
    let shift = top + (hi0 - lo0).abs().max(top.abs()) * 1e-10;
    let mut s = vec![1.0; k];
    for _ in 0..3 {
        s = solve_tridiagonal(alpha, beta, shift, &s);
        normalise(&mut s);
    }
    (top, (b * s[k - 1]).abs())
}

/// Solves (T - shift) x = rhs (Thomas algorithm; T symmetric tridiagonal).
fn solve_tridiagonal(alpha: &[f64], beta: &[f64], shift: f64, rhs: &[f64]) -> Vec<f64> {
    let k = alpha.len();
    let mut c = vec![0.0; k];
    let mut d = vec![0.0; k];
    let nonzero = |x: f64| if x.abs() < 1e-300 { 1e-300 } else { x };
    let mut pivot = nonzero(alpha[0] - shift);
    c[0] = if k > 1 { beta[0] / pivot } else { 0.0 };
    d[0] = rhs[0] / pivot;
    for i in 1..k {
        pivot = nonzero(alpha[i] - shift - beta[i - 1] * c[i - 1]);
        c[i] = if i + 1 < k { beta[i] / pivot } else { 0.0 };
        d[i] = (rhs[i] - beta[i - 1] * d[i - 1]) / pivot;
    }
    let mut x = vec![0.0; k];
    x[k - 1] = d[k - 1];
    for i in (0..k - 1).rev() {
        x[i] = d[i] - c[i] * x[i + 1];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 1D Laplacian's largest eigenvalue is 2 - 2 cos(pi n / (n + 1)), close to 4.
    #[test]
    fn lanczos_finds_the_top_of_a_laplacian_from_above() {
        for n in [10usize, 300, 20_000] {
            let (estimate, steps) = lanczos_max(n, |y, out| {
                for i in 0..n {
                    let left = if i > 0 { y[i - 1] } else { 0.0 };
                    let right = if i + 1 < n { y[i + 1] } else { 0.0 };
                    out[i] = 2.0 * y[i] - left - right;
                }
            });
            let truth = 2.0 - 2.0 * (std::f64::consts::PI * n as f64 / (n as f64 + 1.0)).cos();
            assert!(estimate >= truth * (1.0 - 1e-9), "n {n}: {estimate} < {truth}");
            assert!(estimate <= truth * 1.01, "n {n}: {estimate} vs {truth} after {steps} steps");
        }
    }

    #[test]
    fn lanczos_of_a_diagonal_matrix() {
        let d: Vec<f64> = (0..50).map(|i| (i as f64 * 0.37).sin() * 10.0).collect();
        let truth = d.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (estimate, _) = lanczos_max(50, |y, out| {
            for i in 0..50 {
                out[i] = d[i] * y[i];
            }
        });
        // Within the stopping tolerance, from above.
        assert!(estimate >= truth && estimate <= truth * (1.0 + 2.0 * RESIDUAL_TOLERANCE), "{estimate} vs {truth}");
    }
}
