//! The triangle leaf kind (a collider's true surface): each triangle's box for the LBVH build,
//! the triangles gathered into the tree's leaf order (corner positions, so a deforming collider
//! only rewrites its vertices and refits), and contact detection against them.
//!
//! Contact is with the surface grown by the thickness on both sides (open meshes, thin parts
//! and back-to-back faces work alike): a particle whose substep motion crosses a triangle, or
//! ends within the thickness of it, goes to the thickness on the side it came from. The motion
//! is tested at its end and for a crossing of the triangle's plane; a motion that passes within
//! the thickness of an edge without crossing or ending near it is not caught (continuous
//! collision against the grown surface comes with "Accurate contact").

use crate::contact::{LeafKind, detect_brute_force_particle, detect_particle};
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{
    Aabb, BvhNode, ColliderParams, ColliderPose, CollisionStatus, Contact, ContactPush, SimParams, Triangle,
};
use spirv_std::spirv;

/// Bounds of a triangle.
#[inline]
pub fn triangle_aabb(t: &Triangle) -> Aabb {
    Aabb { min: t.a.min(t.b).min(t.c), max: t.a.max(t.b).max(t.c) }
}

/// Triangle `i` of a mesh from its vertices (xyz) and flat index list (3 per triangle).
#[inline]
pub fn triangle_at(i: u32, vertices: &[Vec4], indices: &[u32]) -> Triangle {
    let base = 3 * i as usize;
    let corner = |k: usize| vertices[indices[base + k] as usize].xyz().extend(0.0);
    Triangle { a: corner(0), b: corner(1), c: corner(2) }
}

/// The point of segment `a`..`b` closest to `p`.
#[inline]
pub fn closest_on_segment(p: Vec3, a: Vec3, b: Vec3) -> Vec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    let s = ((p - a).dot(ab) * (1.0 / len2)).clamp(0.0, 1.0);
    a + ab * s
}

/// The closest of the points of `t`'s three edges to `p`.
#[inline]
fn closest_on_edges(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let e0 = closest_on_segment(p, a, b);
    let e1 = closest_on_segment(p, b, c);
    let e2 = closest_on_segment(p, c, a);
    let (d0, d1, d2) = ((p - e0).length_squared(), (p - e1).length_squared(), (p - e2).length_squared());
    if d0 <= d1 && d0 <= d2 {
        e0
    } else if d1 <= d2 {
        e1
    } else {
        e2
    }
}

/// The point of triangle `t` closest to `p`. Thin triangles (an angle below ~0.5 degrees)
/// also try their edges and keep the closer point: the region tests of the general case lose
/// precision there and may settle on an interior point where an edge is closer; triangles with
/// no measurable area (a segment or a point) are their closest edge.
pub fn closest_on_triangle(p: Vec3, t: &Triangle) -> Vec3 {
    let (a, b, c) = (t.a.xyz(), t.b.xyz(), t.c.xyz());
    let (ab2, ac2, bc2) = ((b - a).length_squared(), (c - a).length_squared(), (c - b).length_squared());
    // |ab x ac|^2 = 4 area^2 = |u|^2 |v|^2 sin^2(smallest angle), u and v the two longest edges.
    let longest = ab2.max(ac2).max(bc2);
    let second = (ab2 + ac2 + bc2) - longest - ab2.min(ac2).min(bc2);
    let area2 = (b - a).cross(c - a).length_squared();
    if area2 <= 1e-12 * longest * second {
        return closest_on_edges(p, a, b, c);
    }
    let q = closest_in_plane(p, a, b, c);
    if area2 <= 1e-4 * longest * second {
        let e = closest_on_edges(p, a, b, c);
        if (p - e).length_squared() < (p - q).length_squared() {
            return e;
        }
    }
    q
}

/// Ericson, Real-Time Collision Detection 5.1.5: the closest point by Voronoi regions of a
/// triangle with area.
#[inline]
fn closest_in_plane(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 * (1.0 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 * (1.0 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) * (1.0 / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Unit normal of `t` (`Vec3::ZERO` for a degenerate triangle).
#[inline]
pub fn face_normal(t: &Triangle) -> Vec3 {
    let n = (t.b.xyz() - t.a.xyz()).cross(t.c.xyz() - t.a.xyz());
    let len = n.length();
    if len > 1e-30 { n * (1.0 / len) } else { Vec3::ZERO }
}

/// Where `p0 -> p1` crosses the plane of `t` (unit normal `n`): the parameter along the motion,
/// the side `p0` is on (+1 / -1 along `n`), and whether the crossing is inside the triangle
/// (false too when the motion does not cross the plane).
#[inline]
pub fn plane_crossing(t: &Triangle, n: Vec3, p0: Vec3, p1: Vec3) -> (f32, f32, bool) {
    let a = t.a.xyz();
    let (h0, h1) = ((p0 - a).dot(n), (p1 - a).dot(n));
    if n == Vec3::ZERO || !((h0 > 0.0 && h1 < 0.0) || (h0 < 0.0 && h1 > 0.0)) {
        return (2.0, 0.0, false);
    }
    let s = (h0 * (1.0 / (h0 - h1))).clamp(0.0, 1.0);
    let x = p0 + (p1 - p0) * s;
    // Inside: the plane point's closest triangle point is itself (up to rounding).
    let q = closest_on_triangle(x, t);
    let scale = (t.b.xyz() - t.a.xyz()).length() + (t.c.xyz() - t.a.xyz()).length();
    let inside = (x - q).length_squared() <= (1e-5 * scale) * (1e-5 * scale);
    (s, if h0 > 0.0 { 1.0 } else { -1.0 }, inside)
}

/// Triangles as contact leaves.
pub struct Triangles;

impl LeafKind for Triangles {
    type Leaf = Triangle;

    /// Both ends of the motion matter (a crossing), so a subtree matters when its grown box
    /// meets the motion's box.
    #[inline]
    fn may_touch(b: &Aabb, p0: Vec3, p1: Vec3, thickness: f32) -> bool {
        let m = Vec3::splat(thickness);
        (p0.min(p1) - m).cmple(b.max.xyz()).all() && (p0.max(p1) + m).cmpge(b.min.xyz()).all()
    }

    /// A crossing of the face counts from where the motion came within the thickness of it
    /// (t < 1, key 0); a motion ending within the thickness without crossing the face counts at
    /// t = 1, so a crossing always wins over proximity (a particle that entered a closed mesh
    /// through one face goes back out through it, whatever other faces it ended near). Key of
    /// proximity: the distance, so the nearest surface wins.
    #[inline]
    fn hit(t: Triangle, p0: Vec3, p1: Vec3, thickness: f32) -> (f32, f32) {
        let n = face_normal(&t);
        let (s, _, inside) = plane_crossing(&t, n, p0, p1);
        if inside {
            let (h0, h1) = ((p0 - t.a.xyz()).dot(n), (p1 - t.a.xyz()).dot(n));
            let early = (s - thickness * (1.0 / (h0 - h1).abs().max(1e-30))).max(0.0);
            return (early.min(1.0), 0.0);
        }
        let d1 = (p1 - closest_on_triangle(p1, &t)).length();
        if d1 >= thickness {
            return (2.0, 0.0);
        }
        (1.0, d1)
    }

    /// A crossing: back to the thickness on the side the motion came from, along the normal.
    /// Proximity (the motion stayed on its side of this triangle): to the thickness on the
    /// particle's side, along the normal over the face's interior and away from the closest
    /// point near an edge or a corner.
    #[inline]
    fn surface(t: Triangle, p0: Vec3, p1: Vec3, _hit: f32, thickness: f32) -> (Vec3, Vec3) {
        let n = face_normal(&t);
        let (s, side, inside) = plane_crossing(&t, n, p0, p1);
        if inside {
            let normal = n * side;
            return (p0 + (p1 - p0) * s + normal * thickness, normal);
        }
        let q = closest_on_triangle(p1, &t);
        let away = p1 - q;
        let h1 = away.dot(n);
        let off_face = away - n * h1;
        let normal = if n != Vec3::ZERO && off_face.length_squared() <= 1e-12 * away.length_squared().max(1e-30) {
            // Over the interior (exactly on the face: the side p0 is on).
            let h = if h1 != 0.0 { h1 } else { (p0 - t.a.xyz()).dot(n) };
            if h >= 0.0 { n } else { -n }
        } else {
            let len = away.length();
            if len > 1e-12 {
                away * (1.0 / len)
            } else if n != Vec3::ZERO {
                n
            } else {
                Vec3::Y
            }
        };
        (q + normal * thickness, normal)
    }
}

/// `bounds[i]` = the box of triangle `i` (input order).
#[spirv(compute(threads(256)))]
pub fn triangle_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bounds: &mut [Aabb],
) {
    let i = id.x;
    if i < collider.leaf_count {
        bounds[i as usize] = triangle_aabb(&triangle_at(i, vertices, indices));
    }
}

/// Puts the triangles' corners in the tree's leaf order: `sorted[i] = triangle order[i]`.
#[spirv(compute(threads(256)))]
pub fn gather_triangles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] sorted: &mut [Triangle],
) {
    let i = id.x;
    if i < collider.leaf_count {
        sorted[i as usize] = triangle_at(order[i as usize], vertices, indices);
    }
}

/// Detect through the LBVH over triangles (tree order): one contact per particle.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn detect(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] aabbs: &[Aabb],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] leaves: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] contacts: &mut [Contact],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] status: &mut CollisionStatus,
) {
    detect_particle::<Triangles>(
        id.x,
        push,
        params,
        collider,
        pose,
        (nodes, aabbs, leaves),
        (x, x_prev),
        contacts,
        status,
    );
}

/// Detect by testing every triangle (the baseline).
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(64)))]
pub fn detect_brute_force(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &ContactPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &SimParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] pose: &ColliderPose,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] leaves: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] x: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] x_prev: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] contacts: &mut [Contact],
) {
    detect_brute_force_particle::<Triangles>(id.x, push, params, collider, pose, leaves, (x, x_prev), contacts);
}
