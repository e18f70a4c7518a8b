//! An independent f64 reference integrator for accuracy tests: the same cloth model written
//! directly with an explicit spring list and `DVec3`, classical RK4, any (tiny) step. A grid's
//! springs come from its offsets, a mesh cloth's from its spring list (each once), with the
//! particles' own masses.

use crate::cloth::{Cloth, ClothTopology};
use glam::DVec3;

/// One spring: particle indices, stiffness, damping along its axis, rest length.
#[derive(Copy, Clone, Debug)]
struct Spring {
    a: usize,
    b: usize,
    k: f64,
    c: f64,
    rest: f64,
}

/// f64 state and spring list of a cloth.
#[derive(Clone, Debug)]
pub struct ReferenceCloth {
    pub x: Vec<DVec3>,
    pub v: Vec<DVec3>,
    free: Vec<bool>,
    springs: Vec<Spring>,
    /// Each particle's mass, and the mean the external force and velocity damping are given
    /// per (`cloth::acceleration_springs`; a grid's particles all have the mean).
    masses: Vec<f64>,
    mean_mass: f64,
    gravity: DVec3,
    external: DVec3,
    velocity_damping: f64,
}

impl ReferenceCloth {
    pub fn new(cloth: &Cloth) -> Self {
        let p = &cloth.params;
        let x: Vec<DVec3> = cloth.positions.iter().map(|q| q.truncate().as_dvec3()).collect();
        let (springs, masses) = match &cloth.topology {
            ClothTopology::Grid => (grid_springs(cloth), vec![p.particle_mass as f64; x.len()]),
            ClothTopology::Springs(topology) => {
                let mut springs = Vec::new();
                for (a, particle) in topology.particles.iter().enumerate() {
                    for s in &topology.springs[particle.first as usize..(particle.first + particle.count) as usize] {
                        let b = s.other as usize;
                        if a < b {
                            let scale = s.stiffness_scale as f64;
                            let k = drape_kernels::cloth::stiffness(p, s.family) as f64 * scale;
                            let c = p.spring_damping as f64 * scale;
                            springs.push(Spring { a, b, k, c, rest: (x[b] - x[a]).length() });
                        }
                    }
                }
                let masses = topology
                    .particles
                    .iter()
                    .map(|q| if q.inverse_mass > 0.0 { 1.0 / q.inverse_mass as f64 } else { 0.0 })
                    .collect();
                (springs, masses)
            }
        };
        ReferenceCloth {
            v: cloth.velocities.iter().map(|q| q.truncate().as_dvec3()).collect(),
            free: cloth.positions.iter().zip(&masses).map(|(q, &m)| q.w != 0.0 && m > 0.0).collect(),
            x,
            springs,
            masses,
            mean_mass: p.particle_mass as f64,
            gravity: p.gravity.truncate().as_dvec3(),
            external: p.external_force.truncate().as_dvec3(),
            velocity_damping: p.velocity_damping as f64,
        }
    }

    fn accelerations(&self, x: &[DVec3], v: &[DVec3]) -> Vec<DVec3> {
        let mut f: Vec<DVec3> = v
            .iter()
            .zip(&self.masses)
            .map(|(vi, &m)| self.gravity * m + (self.external - *vi * self.velocity_damping) * (m / self.mean_mass))
            .collect();
        for s in &self.springs {
            let d = x[s.b] - x[s.a];
            let len = d.length();
            if len < 1e-12 {
                continue;
            }
            let u = d / len;
            let force = u * (s.k * (len - s.rest) + s.c * (v[s.b] - v[s.a]).dot(u));
            f[s.a] += force;
            f[s.b] -= force;
        }
        f.iter()
            .zip(&self.free)
            .zip(&self.masses)
            .map(|((fi, &free), &m)| if free { *fi / m } else { DVec3::ZERO })
            .collect()
    }

    /// One classical RK4 step of length `h`.
    pub fn rk4_step(&mut self, h: f64) {
        let n = self.x.len();
        let axpy = |y: &[DVec3], k: &[DVec3], s: f64| -> Vec<DVec3> { (0..n).map(|i| y[i] + k[i] * s).collect() };
        let k1x = self.v.clone();
        let k1v = self.accelerations(&self.x, &self.v);
        let (x2, v2) = (axpy(&self.x, &k1x, h / 2.0), axpy(&self.v, &k1v, h / 2.0));
        let k2x = v2.clone();
        let k2v = self.accelerations(&x2, &v2);
        let (x3, v3) = (axpy(&self.x, &k2x, h / 2.0), axpy(&self.v, &k2v, h / 2.0));
        let k3x = v3.clone();
        let k3v = self.accelerations(&x3, &v3);
        let (x4, v4) = (axpy(&self.x, &k3x, h), axpy(&self.v, &k3v, h));
        let k4v = self.accelerations(&x4, &v4);
        let k4x = v4;
        for i in 0..n {
            if !self.free[i] {
                self.v[i] = DVec3::ZERO;
                continue;
            }
            self.x[i] += (k1x[i] + 2.0 * k2x[i] + 2.0 * k3x[i] + k4x[i]) * (h / 6.0);
            self.v[i] += (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]) * (h / 6.0);
        }
    }

    /// Advances `duration` seconds in `steps` equal RK4 steps.
    pub fn run(&mut self, duration: f64, steps: u32) {
        let h = duration / steps as f64;
        for _ in 0..steps {
            self.rk4_step(h);
        }
    }

    /// The stiffest mode's angular frequency (rad/s) and the largest damping rate (1/s) of the
    /// cloth linearised at its current state: the largest eigenvalues of M^-1/2 K M^-1/2 and
    /// M^-1/2 C M^-1/2 over the free particles, from the exact f64 spring Hessians by a dense
    /// Jacobi eigen-solve. O(n^3): for checking the solver's estimate on small cloths.
    pub fn stiffest_modes(&self) -> (f64, f64) {
        let free: Vec<usize> = (0..self.x.len()).filter(|&i| self.free[i]).collect();
        let mut slot = vec![usize::MAX; self.x.len()];
        for (k, &i) in free.iter().enumerate() {
            slot[i] = k;
        }
        let n = 3 * free.len();
        let (mut stiffness, mut damping) = (vec![0.0; n * n], vec![0.0; n * n]);
        for i in &free {
            let diagonal = self.velocity_damping / self.mean_mass;
            for r in 0..3 {
                damping[(3 * slot[*i] + r) * n + 3 * slot[*i] + r] += diagonal;
            }
        }
        for s in &self.springs {
            let d = self.x[s.b] - self.x[s.a];
            let len = d.length();
            if len < 1e-12 {
                continue;
            }
            let u = d / len;
            let along = glam::DMat3::from_cols(u * u.x, u * u.y, u * u.z);
            let block_k = along * s.k + (glam::DMat3::IDENTITY - along) * (s.k * (1.0 - s.rest / len));
            let block_c = along * s.c;
            for (a, b, sign) in [(s.a, s.a, 1.0), (s.b, s.b, 1.0), (s.a, s.b, -1.0), (s.b, s.a, -1.0)] {
                if slot[a] == usize::MAX || slot[b] == usize::MAX {
                    continue;
                }
                let scale = sign / (self.masses[a] * self.masses[b]).sqrt();
                for r in 0..3 {
                    for c in 0..3 {
                        let at = (3 * slot[a] + r) * n + 3 * slot[b] + c;
                        stiffness[at] += block_k.col(c)[r] * scale;
                        damping[at] += block_c.col(c)[r] * scale;
                    }
                }
            }
        }
        let top = |m: Vec<f64>| symmetric_eigenvalues(m, n).into_iter().fold(0.0, f64::max);
        (top(stiffness).sqrt(), top(damping))
    }

    /// Total energy (J): kinetic + gravitational + spring potential (no external force).
    pub fn energy(&self) -> f64 {
        energy_of(self, &self.x, &self.v)
    }
}

/// Each spring of a grid cloth once (offsets with a positive first non-zero component), rest
/// lengths from the cloth's parameters (as the kernels take them; a grid placed stretched
/// starts under tension).
fn grid_springs(cloth: &Cloth) -> Vec<Spring> {
    let p = &cloth.params;
    let (rows, cols) = (p.rows as i64, p.cols as i64);
    let mut springs = Vec::new();
    let families = [
        ((0, 1), p.k_struct),
        ((1, 0), p.k_struct),
        ((1, 1), p.k_shear),
        ((1, -1), p.k_shear),
        ((0, 2), p.k_bend),
        ((2, 0), p.k_bend),
    ];
    for r in 0..rows {
        for c in 0..cols {
            for ((dr, dc), k) in families {
                let (r2, c2) = (r + dr, c + dc);
                if r2 < 0 || c2 < 0 || r2 >= rows || c2 >= cols {
                    continue;
                }
                let (a, b) = ((r * cols + c) as usize, (r2 * cols + c2) as usize);
                let offset = drape_kernels::cloth::SpringOffset { d_row: dr as i32, d_col: dc as i32, family: 0 };
                let rest = drape_kernels::cloth::rest_length(p, offset) as f64;
                springs.push(Spring { a, b, k: k as f64, c: p.spring_damping as f64, rest });
            }
        }
    }
    springs
}

fn energy_of(c: &ReferenceCloth, x: &[DVec3], v: &[DVec3]) -> f64 {
    let mut e = 0.0;
    for i in 0..x.len() {
        if c.free[i] {
            e += 0.5 * c.masses[i] * v[i].length_squared() - c.masses[i] * c.gravity.dot(x[i]);
        }
    }
    for s in &c.springs {
        let stretch = (x[s.b] - x[s.a]).length() - s.rest;
        e += 0.5 * s.k * stretch * stretch;
    }
    e
}

/// Total energy (J) of a cloth state given in f32 (positions w = pin weight).
pub fn energy(cloth: &Cloth, x: &[glam::Vec4], v: &[glam::Vec4]) -> f64 {
    let reference = ReferenceCloth::new(cloth);
    let xs: Vec<DVec3> = x.iter().map(|q| q.truncate().as_dvec3()).collect();
    let vs: Vec<DVec3> = v.iter().map(|q| q.truncate().as_dvec3()).collect();
    energy_of(&reference, &xs, &vs)
}

/// Eigenvalues of the symmetric `n x n` matrix `a` (row-major) by cyclic Jacobi rotations.
fn symmetric_eigenvalues(mut a: Vec<f64>, n: usize) -> Vec<f64> {
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|r| (0..n).filter(move |&c| c != r).map(move |c| (r, c)))
            .map(|(r, c)| a[r * n + c].powi(2))
            .sum();
        let scale: f64 = (0..n).map(|i| a[i * n + i].powi(2)).sum::<f64>().max(f64::MIN_POSITIVE);
        if off <= 1e-24 * scale {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq.abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
            }
        }
    }
    (0..n).map(|i| a[i * n + i]).collect()
}

#[cfg(test)]
mod tests {
    use super::symmetric_eigenvalues;

    #[test]
    fn jacobi_finds_a_laplacians_eigenvalues() {
        let n = 12;
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            a[i * n + i] = 2.0;
            if i + 1 < n {
                a[i * n + i + 1] = -1.0;
                a[(i + 1) * n + i] = -1.0;
            }
        }
        let mut found = symmetric_eigenvalues(a, n);
        found.sort_by(f64::total_cmp);
        for (j, value) in found.iter().enumerate() {
            let truth = 2.0 - 2.0 * (std::f64::consts::PI * (j + 1) as f64 / (n + 1) as f64).cos();
            assert!((value - truth).abs() < 1e-10, "{j}: {value} vs {truth}");
        }
    }
}
