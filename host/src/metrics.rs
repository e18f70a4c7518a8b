//! Accuracy of a cloth state against the **true triangle mesh** (design.md §2), not against the
//! spheres that stand in for it during the simulation: penetration, how far the sphere proxy
//! holds the cloth off the surface, and spring stretch. CPU only.

mod bvh;
pub mod intersections;

use crate::mesh::Mesh;
use bvh::{Bvh, Node};
use glam::{Vec3, Vec4, Vec4Swizzles};

/// Ray directions for the inside test. Not axis-aligned, so rays rarely run along a scan's grid
/// of edges; all three point upward because scanned models have their holes at the bottom, where
/// they stood on the turntable (the bunny has 5), and a ray that leaves through a hole miscounts.
const RAY_DIRECTIONS: [Vec3; 3] =
    [Vec3::new(0.2620, 0.9636, 0.0530), Vec3::new(-0.3300, 0.9120, 0.2437), Vec3::new(0.1520, 0.8930, -0.4236)];

/// Below this many spheres `accuracy` tests them all; above, it builds a BVH over them.
const BRUTE_FORCE_SPHERES: usize = 64;

/// A particle within this distance (m) of the sphere surface, beyond the contact thickness,
/// still counts as resting on the collider.
const RESTING_SLACK: f32 = 1e-4;

/// A CPU BVH over a mesh's triangles for closest-point and inside/outside queries.
pub struct TriangleBvh {
    bvh: Bvh,
    /// Triangles in leaf order: a leaf holds `triangles[first..first + count]`.
    triangles: Vec<[Vec3; 3]>,
    /// Edges used by one triangle only (0: the mesh is closed and "inside" is defined).
    boundary_edges: usize,
    closed: bool,
}

impl TriangleBvh {
    /// Builds the tree (binned SAH). Triangles with an index out of range or a non-finite vertex
    /// are left out, so any `Mesh` is accepted.
    pub fn new(mesh: &Mesh) -> TriangleBvh {
        let corners = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| mesh.vertices.get(i as usize).copied());
            Some([a?, b?, c?]).filter(|tri| tri.iter().all(|v| v.is_finite()))
        };
        let valid: Vec<[Vec3; 3]> = mesh.triangles.iter().filter_map(corners).collect();
        let boxes: Vec<(Vec3, Vec3)> = valid.iter().map(|&[a, b, c]| (a.min(b).min(c), a.max(b).max(c))).collect();
        let bvh = bvh::build(&boxes);
        let triangles = bvh.order.iter().map(|&i| valid[i as usize]).collect();
        TriangleBvh {
            bvh,
            triangles,
            boundary_edges: crate::topology::boundary_edge_count(mesh),
            closed: crate::topology::is_closed(mesh),
        }
    }

    /// Whether the mesh encloses an inside (every edge shared by an even number of triangles):
    /// only then do the inside measures mean something.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Edges of the mesh used by one triangle only (its holes' or open border's length).
    pub fn boundary_edges(&self) -> usize {
        self.boundary_edges
    }

    /// Number of triangles in the tree.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// Whether the tree holds no triangle (then every point is outside, infinitely far).
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Distance from p to the closest point on the surface, and that point.
    /// For an empty tree: (infinity, p).
    pub fn closest_point(&self, p: Vec3) -> (f32, Vec3) {
        let Some(root) = self.bvh.nodes.first() else {
            return (f32::INFINITY, p);
        };
        let (mut best, mut best_point) = (f32::INFINITY, p);
        // Nodes with the squared distance to their box; the nearer child is visited first.
        let mut stack: Vec<(u32, f32)> = Vec::with_capacity(64);
        stack.push((0, root.distance_squared(p)));
        while let Some((index, d2)) = stack.pop() {
            if d2 >= best {
                continue;
            }
            let node = &self.bvh.nodes[index as usize];
            if node.count > 0 {
                for &[a, b, c] in self.leaf(node) {
                    let q = closest_on_triangle(p, a, b, c);
                    let d = q.distance_squared(p);
                    if d < best {
                        (best, best_point) = (d, q);
                    }
                }
            } else {
                let (l, r) = (node.first, node.first + 1);
                let dl = self.bvh.nodes[l as usize].distance_squared(p);
                let dr = self.bvh.nodes[r as usize].distance_squared(p);
                let (near, far) = if dl <= dr { ((l, dl), (r, dr)) } else { ((r, dr), (l, dl)) };
                if far.1 < best {
                    stack.push(far);
                }
                if near.1 < best {
                    stack.push(near);
                }
            }
        }
        (best.sqrt(), best_point)
    }

    /// Whether p is inside the mesh: ray parity along 3 fixed non-axis-aligned directions,
    /// majority vote (robust to the bunny's small bottom holes and to rays grazing edges).
    /// Back-to-back duplicate faces (the dragon's "fins") are crossed twice and cancel out.
    pub fn is_inside(&self, p: Vec3) -> bool {
        let Some(root) = self.bvh.nodes.first() else {
            return false;
        };
        if !p.is_finite() || p.cmplt(root.min).any() || p.cmpgt(root.max).any() {
            return false;
        }
        let odd = RAY_DIRECTIONS.iter().filter(|&&d| self.crossings(p, d) % 2 == 1).count();
        odd >= 2
    }

    /// How many triangles the ray `origin + t * dir`, t > 0, passes through.
    fn crossings(&self, origin: Vec3, dir: Vec3) -> u32 {
        let inv = dir.recip();
        let mut hits = 0;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(index) = stack.pop() {
            let node = &self.bvh.nodes[index as usize];
            if !ray_hits_box(origin, inv, node) {
                continue;
            }
            if node.count > 0 {
                hits +=
                    self.leaf(node).iter().filter(|&&[a, b, c]| ray_hits_triangle(origin, dir, a, b, c)).count() as u32;
            } else {
                stack.extend([node.first, node.first + 1]);
            }
        }
        hits
    }

    fn leaf(&self, node: &Node) -> &[[Vec3; 3]] {
        let first = node.first as usize;
        &self.triangles[first..first + node.count as usize]
    }
}

/// Accuracy of a cloth state against the true mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Accuracy {
    pub particles: usize,
    /// Every particle position is finite. Non-finite particles count as outside, not within the
    /// thickness and not resting, so the other numbers describe the finite ones.
    pub all_finite: bool,
    /// Whether the mesh is closed, so that "inside" is defined. An open mesh (a plane, a bowl,
    /// a scan with holes) has no inside: the inside measures are then 0 and every particle
    /// counts as outside.
    pub inside_defined: bool,
    /// Share of particles inside the mesh.
    pub inside_fraction: f64,
    /// Max distance to the surface over inside particles (0 if none).
    pub max_penetration: f32,
    /// 99th percentile (nearest rank) over all particles of (inside ? distance : 0).
    pub p99_penetration: f32,
    /// Share of particles whose distance to the true surface is <= thickness.
    pub within_thickness_fraction: f64,
    /// Particles resting on the collider: outside the mesh and within `thickness` (+1e-4 m) of
    /// the collider's sphere surface (distance to the nearest sphere surface = |p - c| - r, min
    /// over spheres), or of the true surface for a triangle collider (`accuracy_on_triangles`).
    pub resting: usize,
    /// Over resting particles: distance to the true surface (how far the sphere proxy holds the
    /// cloth off the mesh); 0 if none.
    pub gap_mean: f32,
    pub gap_max: f32,
    /// Structural springs (row and column neighbours): length / rest length. A non-finite length
    /// counts as infinite stretch.
    pub max_stretch: f32,
    pub p99_stretch: f32,
}

/// Measures `positions` (xyz + w; particle index = row * cols + col) of a `rows x cols` cloth
/// against the mesh in `bvh` and the collider `spheres` (xyz = centre, w = radius).
///
/// Row springs join `i` and `i + cols` (rest `rest_row`), column springs `i` and `i + 1` (rest
/// `rest_col`); springs that reach past `positions` are skipped, and so is a family whose rest
/// length is not finite and positive.
// The argument list is the interface the benchmarks and tests call.
#[allow(clippy::too_many_arguments)]
pub fn accuracy(
    bvh: &TriangleBvh,
    spheres: &[Vec4],
    thickness: f32,
    rows: u32,
    cols: u32,
    rest_col: f32,
    rest_row: f32,
    positions: &[Vec4],
) -> Accuracy {
    let springs = grid_structural_springs(rows, cols, rest_col, rest_row);
    measure(bvh, Some(SphereSet::new(spheres)), thickness, &springs, positions)
}

/// `accuracy` for a collider made of the mesh's own triangles: resting particles are those
/// outside the mesh within `thickness` (+1e-4 m) of its surface.
pub fn accuracy_on_triangles(
    bvh: &TriangleBvh,
    thickness: f32,
    (rows, cols, rest_col, rest_row): (u32, u32, f32, f32),
    positions: &[Vec4],
) -> Accuracy {
    measure(bvh, None, thickness, &grid_structural_springs(rows, cols, rest_col, rest_row), positions)
}

/// `accuracy` (with the collider's `spheres`) or `accuracy_on_triangles` (without) of any
/// cloth, given its structural springs (`Cloth::structural_springs`: i, j, rest length).
pub fn accuracy_of_cloth(
    bvh: &TriangleBvh,
    spheres: Option<&[Vec4]>,
    thickness: f32,
    springs: &[(u32, u32, f32)],
    positions: &[Vec4],
) -> Accuracy {
    measure(bvh, spheres.map(SphereSet::new), thickness, springs, positions)
}

/// The structural springs of a `rows x cols` grid: row springs join `i` and `i + cols` (rest
/// `rest_row`), column springs `i` and `i + 1` (rest `rest_col`).
pub fn grid_structural_springs(rows: u32, cols: u32, rest_col: f32, rest_row: f32) -> Vec<(u32, u32, f32)> {
    let mut springs = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let i = r * cols + c;
            if r + 1 < rows {
                springs.push((i, i + cols, rest_row));
            }
            if c + 1 < cols {
                springs.push((i, i + 1, rest_col));
            }
        }
    }
    springs
}

/// The accuracy measures; resting is judged against `collider`'s spheres, or against the true
/// surface when there are none (a triangle collider).
fn measure(
    bvh: &TriangleBvh,
    collider: Option<SphereSet>,
    thickness: f32,
    springs: &[(u32, u32, f32)],
    positions: &[Vec4],
) -> Accuracy {
    let particles = positions.len();
    let mut result = Accuracy { particles, all_finite: true, inside_defined: bvh.is_closed(), ..Accuracy::default() };
    if particles == 0 {
        return result;
    }
    let mut penetrations = Vec::with_capacity(particles);
    let (mut inside, mut within) = (0usize, 0usize);
    let mut gap_sum = 0.0f64;
    for p in positions.iter().map(|p| p.xyz()) {
        if !p.is_finite() {
            result.all_finite = false;
            penetrations.push(0.0);
            continue;
        }
        let (distance, _) = bvh.closest_point(p);
        let is_inside = result.inside_defined && bvh.is_inside(p);
        if distance <= thickness {
            within += 1;
        }
        if is_inside {
            inside += 1;
            result.max_penetration = result.max_penetration.max(distance);
            penetrations.push(distance);
        } else {
            penetrations.push(0.0);
            let resting = match &collider {
                Some(spheres) => spheres.any_within(p, thickness + RESTING_SLACK),
                None => distance <= thickness + RESTING_SLACK,
            };
            if resting {
                result.resting += 1;
                gap_sum += distance as f64;
                result.gap_max = result.gap_max.max(distance);
            }
        }
    }
    result.inside_fraction = inside as f64 / particles as f64;
    result.within_thickness_fraction = within as f64 / particles as f64;
    result.p99_penetration = p99(&mut penetrations);
    if result.resting > 0 {
        result.gap_mean = (gap_sum / result.resting as f64) as f32;
    }

    let mut stretches = Vec::with_capacity(springs.len());
    for &(i, j, rest) in springs {
        let usable = rest.is_finite() && rest > 0.0;
        if let (true, Some(a), Some(b)) = (usable, positions.get(i as usize), positions.get(j as usize)) {
            let stretch = a.xyz().distance(b.xyz()) / rest;
            stretches.push(if stretch.is_finite() { stretch } else { f32::INFINITY });
        }
    }
    result.max_stretch = stretches.iter().copied().fold(0.0, f32::max);
    result.p99_stretch = p99(&mut stretches);
    result
}

/// The 99th percentile by nearest rank (the value at position ceil(0.99 n) in ascending order);
/// 0 for no values.
fn p99(values: &mut [f32]) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let rank = (values.len() * 99).div_ceil(100).max(1);
    *values.select_nth_unstable_by(rank - 1, f32::total_cmp).1
}

/// The collider's spheres, for "is p within `slack` of some sphere" queries.
struct SphereSet {
    spheres: Vec<Vec4>,
    /// Over the spheres when there are many; spheres are then in leaf order.
    bvh: Option<Bvh>,
}

impl SphereSet {
    fn new(spheres: &[Vec4]) -> SphereSet {
        let finite: Vec<Vec4> = spheres.iter().copied().filter(|s| s.is_finite()).collect();
        if finite.len() <= BRUTE_FORCE_SPHERES {
            return SphereSet { spheres: finite, bvh: None };
        }
        let boxes: Vec<(Vec3, Vec3)> = finite.iter().map(|s| (s.xyz() - s.w.abs(), s.xyz() + s.w.abs())).collect();
        let bvh = bvh::build(&boxes);
        let spheres = bvh.order.iter().map(|&i| finite[i as usize]).collect();
        SphereSet { spheres, bvh: Some(bvh) }
    }

    /// Whether `|p - c| - r <= slack` for some sphere: the minimum over spheres is at most
    /// `slack` exactly when one of them is, so the search stops at the first.
    fn any_within(&self, p: Vec3, slack: f32) -> bool {
        let near = |s: &Vec4| p.distance(s.xyz()) - s.w <= slack;
        let Some(bvh) = &self.bvh else {
            return self.spheres.iter().any(near);
        };
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(index) = stack.pop() {
            let node = &bvh.nodes[index as usize];
            if node.distance_squared(p) > slack.max(0.0).powi(2) {
                continue;
            }
            if node.count > 0 {
                let first = node.first as usize;
                if self.spheres[first..first + node.count as usize].iter().any(near) {
                    return true;
                }
            } else {
                stack.extend([node.first, node.first + 1]);
            }
        }
        false
    }
}

/// Slab test; `inv` = 1 / direction (finite: the directions are not axis-aligned).
fn ray_hits_box(origin: Vec3, inv: Vec3, node: &Node) -> bool {
    let t0 = (node.min - origin) * inv;
    let t1 = (node.max - origin) * inv;
    let near = t0.min(t1).max_element();
    let far = t0.max(t1).min_element();
    far >= near.max(0.0)
}

/// Möller–Trumbore, edges included (a ray through a shared edge may count twice: the majority
/// vote over three directions absorbs that). Degenerate and parallel triangles are missed.
fn ray_hits_triangle(origin: Vec3, dir: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (e1, e2) = (b - a, c - a);
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 || !det.is_finite() {
        return false;
    }
    let inv = 1.0 / det;
    let s = origin - a;
    let u = s.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    e2.dot(q) * inv > 0.0
}

/// Closest point to `p` on triangle `abc`: the triangle leaf kind's own function (tested
/// against an f64 reference on random, thin and degenerate triangles in `tests/triangles.rs`).
fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    drape_kernels::triangles::closest_on_triangle(p, &drape_kernels::triangles::triangle_leaf(a, b, c))
}
