//! The triangle leaf kind (a collider's true surface): each triangle's box for the LBVH build,
//! the triangles gathered into the tree's leaf order (corner positions, so a deforming collider
//! only rewrites its vertices and refits), and contact detection against them.
//!
//! Contact is continuous: the particle's substep motion against each triangle grown by the
//! thickness on both sides (see `Triangles`).

use crate::contact::LeafKind;
use drape_types::glam::{UVec3, Vec3, Vec4, Vec4Swizzles};
use drape_types::{Aabb, ColliderParams, Triangle};
#[cfg(target_arch = "spirv")]
use spirv_std::num_traits::Float;
use spirv_std::spirv;

/// Bounds of a triangle.
#[inline]
pub fn triangle_aabb(t: &Triangle) -> Aabb {
    let (a, b, c) = (t.a.xyz(), t.b.xyz(), t.c.xyz());
    Aabb { min: a.min(b).min(c).extend(0.0), max: a.max(b).max(c).extend(0.0) }
}

/// A triangle leaf with corners `a`, `b`, `c` that does not move over the frame: its unit
/// normal (zero for a degenerate triangle) goes in the corners' w, computed once here instead of
/// in every contact test.
#[inline]
pub fn triangle_leaf(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
    let n = (b - a).cross(c - a);
    let len = n.length();
    let n = if len > 1e-30 { n * (1.0 / len) } else { Vec3::ZERO };
    Triangle { a: a.extend(n.x), b: b.extend(n.y), c: c.extend(n.z), sweep: Vec4::ZERO }
}

/// A triangle leaf whose corners moved from `previous` to `current` over the frame (a
/// deforming collider): the leaf at `current`, its sweep the centroid's displacement and how
/// far any corner moved beyond it. Between the two, every point of the linearly interpolated
/// triangle is within that residual of the current triangle moved back by the remaining share
/// of the centroid's displacement, which is what contact tests against (`Triangles::relative`).
/// Equal corners give exactly `triangle_leaf`.
#[inline]
pub fn swept_triangle_leaf(previous: [Vec3; 3], current: [Vec3; 3]) -> Triangle {
    let mut t = triangle_leaf(current[0], current[1], current[2]);
    let (d0, d1, d2) = (current[0] - previous[0], current[1] - previous[1], current[2] - previous[2]);
    let shift = (d0 + d1 + d2) * (1.0 / 3.0);
    let beyond = (d0 - shift).length().max((d1 - shift).length()).max((d2 - shift).length());
    t.sweep = shift.extend(beyond);
    t
}

/// How triangle `i`'s corners moved over the frame (from `previous` to `vertices`), as a
/// `Triangle` record (`a`, `b`, `c`; the rest zero): what the gather writes after the leaves,
/// for the contact's surface motion (`Triangles::motion_at`).
#[inline]
pub fn corner_motions_at(i: u32, vertices: &[Vec4], previous: &[Vec4], indices: &[u32]) -> Triangle {
    // Indices loaded one by one (a closure over the slices would hold them as data, which
    // rust-gpu cannot compile).
    let base = 3 * i as usize;
    let (i0, i1, i2) = (indices[base] as usize, indices[base + 1] as usize, indices[base + 2] as usize);
    Triangle {
        a: (vertices[i0].xyz() - previous[i0].xyz()).extend(0.0),
        b: (vertices[i1].xyz() - previous[i1].xyz()).extend(0.0),
        c: (vertices[i2].xyz() - previous[i2].xyz()).extend(0.0),
        sweep: Vec4::ZERO,
    }
}

/// The point of triangle (`a`, `b`, `c`) closest to `p` and its barycentric weights (Ericson,
/// Real-Time Collision Detection 5.1.5). Only for triangles with area (the caller skips the
/// degenerate ones).
pub fn closest_with_weights(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, Vec3) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Vec3::X);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Vec3::Y);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 * (1.0 / (d1 - d3));
        return (a + ab * v, Vec3::new(1.0 - v, v, 0.0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Vec3::Z);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 * (1.0 / (d2 - d6));
        return (a + ac * w, Vec3::new(1.0 - w, 0.0, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) * (1.0 / ((d4 - d3) + (d5 - d6)));
        return (b + (c - b) * w, Vec3::new(0.0, 1.0 - w, w));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    // The first weight as va / (va + vb + vc), not Ericson's 1 - v - w: Mesa's NIR treats
    // float math as reassociable and rewrites that as 1 - (vb + vc) x denom, which rounds
    // differently from the CPU (the self-collision twin parted by one fixed-point unit).
    (a + ab * v + ac * w, Vec3::new(va * denom, v, w))
}

/// Triangle `i` of a mesh from its vertices (xyz) at the frame's end and start, and its flat
/// index list (3 per triangle).
#[inline]
pub fn triangle_at(i: u32, vertices: &[Vec4], previous: &[Vec4], indices: &[u32]) -> Triangle {
    let base = 3 * i as usize;
    let (i0, i1, i2) = (indices[base] as usize, indices[base + 1] as usize, indices[base + 2] as usize);
    swept_triangle_leaf(
        [previous[i0].xyz(), previous[i1].xyz(), previous[i2].xyz()],
        [vertices[i0].xyz(), vertices[i1].xyz(), vertices[i2].xyz()],
    )
}

/// The box a leaf occupies over the frame: its triangle at the end and moved back by its sweep's
/// translation, grown by the sweep's residual (what the LBVH is built and refit over).
#[inline]
pub fn swept_aabb(t: &Triangle) -> Aabb {
    let end = triangle_aabb(t);
    let back = t.sweep.xyz();
    let grow = Vec3::splat(t.sweep.w);
    Aabb {
        min: (end.min.xyz().min(end.min.xyz() - back) - grow).extend(0.0),
        max: (end.max.xyz().max(end.max.xyz() - back) + grow).extend(0.0),
    }
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

/// Unit normal of `t` (`Vec3::ZERO` for a degenerate triangle), as `triangle_leaf` stored it.
#[inline]
pub fn face_normal(t: &Triangle) -> Vec3 {
    Vec3::new(t.a.w, t.b.w, t.c.w)
}

/// Relative growth of the thickness in the continuous test: rounding never turns a motion that
/// touches the grown surface into a miss; a contact is found at most this share of the
/// thickness early (the stated gap of the conservative test: 0.1%).
pub const CCD_SLACK: f32 = 1e-3;

/// Whether `x` (on or near the plane of `t`, unit normal `n`) is inside `t` grown by `margin`
/// within its plane: on the inner side of every edge line, or less than `margin` beyond it.
#[inline]
pub fn inside_in_plane(x: Vec3, t: &Triangle, n: Vec3, margin: f32) -> bool {
    let (a, b, c) = (t.a.xyz(), t.b.xyz(), t.c.xyz());
    let edge = |from: Vec3, to: Vec3| {
        let e = to - from;
        // = |e| x the signed distance of x from the edge line (positive inside).
        e.cross(x - from).dot(n) >= -margin * e.length()
    };
    edge(a, b) && edge(b, c) && edge(c, a)
}

/// The first parameter in [0, 1] at which `p0 + d s` comes within `radius` of the point `c`,
/// or 2.0 for none.
#[inline]
fn ball_entry(p0: Vec3, d: Vec3, c: Vec3, radius: f32) -> f32 {
    entry_of(p0 - c, d, radius)
}

/// The first parameter in [0, 1] at which `m + d s` comes within `radius` of the origin, or
/// 2.0: the smaller root of `|d|^2 s^2 + 2 (m.d) s + |m|^2 - r^2`. Written so that nothing
/// cancels when the motion passes far from the origin compared with the radius (a grazing
/// contact): the discriminant as `|d|^2 r^2 - |m x d|^2` (Lagrange's identity) instead of
/// `(m.d)^2 - |d|^2 (|m|^2 - r^2)`, and the root as `(|m|^2 - r^2) / (-m.d + sqrt(disc))`.
#[inline]
fn entry_of(m: Vec3, d: Vec3, radius: f32) -> f32 {
    let far = m.length_squared() - radius * radius;
    if far <= 0.0 {
        return 0.0;
    }
    let (b, a) = (m.dot(d), d.length_squared());
    if b >= 0.0 || a <= 0.0 {
        return 2.0; // moving away or not moving
    }
    let disc = a * (radius * radius) - m.cross(d).length_squared();
    if disc < 0.0 {
        return 2.0;
    }
    let s = far * (1.0 / (-b + disc.sqrt()));
    if s <= 1.0 { s } else { 2.0 }
}

/// The first parameter in [0, 1] at which `p0 + d s` comes within `radius` of the segment
/// `e0`..`e1` through its side (the infinite cylinder, entered where the segment is), or 2.0.
/// The end caps are the corner balls, tested once per corner by the caller.
#[inline]
fn cylinder_entry(p0: Vec3, d: Vec3, e0: Vec3, e1: Vec3, radius: f32) -> f32 {
    let axis = e1 - e0;
    let len2 = axis.length_squared();
    if len2 <= 0.0 {
        return 2.0;
    }
    let u = axis * (1.0 / len2.sqrt());
    let m = p0 - e0;
    let s = entry_of(m - u * m.dot(u), d - u * d.dot(u), radius);
    if s > 1.0 {
        return 2.0;
    }
    let along = (m + d * s).dot(u);
    if along >= 0.0 && along * along <= len2 { s } else { 2.0 }
}

/// Earliest contact of the motion `p0 -> p1` with triangle `t` grown by `radius` on both sides
/// (the Minkowski sum of the triangle and a ball: a slab over the face, a cylinder around each
/// edge, a ball at each corner), `p0` given farther than `radius` from `t`. The first entry
/// into a union is the first entry into any of its parts; a side wall of the slab lies inside
/// the edge cylinders, so only the slab's two faces are tested. Returns the parameter in
/// [0, 1], or 2.0 for none.
pub fn grown_triangle_entry(t: &Triangle, n: Vec3, p0: Vec3, p1: Vec3, radius: f32) -> f32 {
    let (a, b, c) = (t.a.xyz(), t.b.xyz(), t.c.xyz());
    let d = p1 - p0;
    let mut first = ball_entry(p0, d, a, radius).min(ball_entry(p0, d, b, radius)).min(ball_entry(p0, d, c, radius));
    first = first.min(cylinder_entry(p0, d, a, b, radius));
    first = first.min(cylinder_entry(p0, d, b, c, radius));
    first = first.min(cylinder_entry(p0, d, c, a, radius));
    if n != Vec3::ZERO {
        let (h0, h1) = ((p0 - a).dot(n), (p1 - a).dot(n));
        let side = if h0 >= 0.0 { 1.0 } else { -1.0 };
        let (above0, above1) = (h0 * side, h1 * side);
        if above0 > radius && above1 < radius {
            let s = (above0 - radius) * (1.0 / (above0 - above1));
            if s < first && inside_in_plane(p0 + d * s, t, n, 0.0) {
                first = s;
            }
        }
    }
    first
}

/// Where `a -> b` crosses the triangle itself: whether it goes from one side of its plane to
/// the other (or onto it) at a point inside the triangle grown by `margin`. A degenerate
/// triangle has no sides to cross.
#[inline]
pub fn crosses(t: &Triangle, n: Vec3, a: Vec3, b: Vec3, margin: f32) -> bool {
    let o = t.a.xyz();
    let (ha, hb) = ((a - o).dot(n), (b - o).dot(n));
    if n == Vec3::ZERO || !((ha > 0.0 && hb <= 0.0) || (ha < 0.0 && hb >= 0.0)) {
        return false;
    }
    let s = (ha * (1.0 / (ha - hb))).clamp(0.0, 1.0);
    inside_in_plane(a + (b - a) * s, t, n, margin)
}

/// Whether the box of the motion `p0 -> p1` grown by `radius` (and 1 µm for rounding) meets
/// `b`: the box test of a subtree and of a single triangle.
#[inline]
fn motion_box_meets(b: &Aabb, p0: Vec3, p1: Vec3, radius: f32) -> bool {
    let m = Vec3::splat(radius + 1e-6);
    (p0.min(p1) - m).cmple(b.max.xyz()).all() && (p0.max(p1) + m).cmpge(b.min.xyz()).all()
}

/// Triangles as contact leaves: continuous collision of the particle's substep motion (in the
/// collider's frame) with each triangle grown by the thickness on both sides, so open meshes,
/// thin parts and back-to-back faces work alike.
///
/// The response keeps a particle on the side it came from: it goes to the point of its motion's
/// end lifted to the thickness along the contact normal (sliding keeps its tangential motion),
/// and when the straight path there would cross any triangle (a crease, a thin part) it stops
/// at the first contact instead, which its motion reached without crossing anything. Contact
/// is found before any crossing (the grown surface is met first), so no path ever crosses a
/// static collider's surface.
pub struct Triangles;

impl Triangles {
    /// The thickness as the continuous test uses it (grown by `CCD_SLACK`).
    #[inline]
    fn grown(thickness: f32) -> f32 {
        thickness * (1.0 + CCD_SLACK)
    }
}

impl LeafKind for Triangles {
    type Leaf = Triangle;

    /// The point's own motion: its triangle's corners' motions (the leaves' second half,
    /// `corner_motions_at`) mixed by the barycentric weights of its closest point on the
    /// triangle where the frame ends. The centroid's for a triangle with no area (no normal),
    /// or with only the leaves (a tree built for a test).
    #[inline]
    fn motion_at(leaves: &[Triangle], count: u32, leaf: u32, p: Vec3) -> Vec3 {
        let t = leaves[leaf as usize];
        if (leaves.len() as u32) < 2 * count || face_normal(&t) == Vec3::ZERO {
            return Self::still_to_move(t, 1.0);
        }
        let moves = leaves[(count + leaf) as usize];
        let (_, w) = closest_with_weights(p, t.a.xyz(), t.b.xyz(), t.c.xyz());
        moves.a.xyz() * w.x + moves.b.xyz() * w.y + moves.c.xyz() * w.z
    }

    /// The whole motion matters, so a subtree matters when its box grown by the (conservative)
    /// thickness meets the motion's box.
    #[inline]
    fn may_touch(b: &Aabb, p0: Vec3, p1: Vec3, thickness: f32) -> bool {
        motion_box_meets(b, p0, p1, Self::grown(thickness))
    }

    /// Hit parameter (for the motion relative to the leaf, see `relative`; a deforming leaf's
    /// radius grows by its sweep's residual): 0 when the motion starts within the thickness (key: the distance, so the
    /// nearest surface wins), else the first entry into the grown triangle. As a safety net
    /// against rounding, a motion that crosses the triangle itself is a hit at the crossing.
    ///
    /// Cheap rejections first (most leaves a traversal reaches are near the motion's box, not
    /// the motion): a motion that stays on one side of the slab around the triangle's plane
    /// grown by the radius, or outside the triangle's grown box, cannot touch it; and `p0` can
    /// only be within the radius when it is within the slab.
    #[inline]
    fn hit(t: Triangle, p0: Vec3, p1: Vec3, thickness: f32) -> (f32, f32) {
        let radius = Self::grown(thickness) + t.sweep.w;
        let n = face_normal(&t);
        let o = t.a.xyz();
        let (h0, h1) = ((p0 - o).dot(n), (p1 - o).dot(n));
        // The triangle's extent along n: 0 for a proper triangle, but a nearly degenerate one's
        // normal is rounding noise, and its corners need not lie in that "plane".
        let (hb, hc) = ((t.b.xyz() - o).dot(n), (t.c.xyz() - o).dot(n));
        let (low, high) = (hb.min(hc).min(0.0) - radius, hb.max(hc).max(0.0) + radius);
        if (h0 > high && h1 > high) || (h0 < low && h1 < low) {
            return (2.0, 0.0);
        }
        if !motion_box_meets(&triangle_aabb(&t), p0, p1, radius) {
            return (2.0, 0.0);
        }
        if h0 >= low && h0 <= high {
            let d0 = (p0 - closest_on_triangle(p0, &t)).length();
            if d0 <= radius {
                return (0.0, d0);
            }
            // Every point of the motion is within its length of p0, so a motion shorter than
            // p0's distance beyond the radius cannot come within it (most leaves near a slowly
            // moving particle end here, before the costly entry test; the extra share of the
            // radius absorbs rounding) nor cross the triangle.
            let length = (p1 - p0).length();
            if d0 > radius * (1.0 + CCD_SLACK) + length {
                return (2.0, 0.0);
            }
        }
        let entry = grown_triangle_entry(&t, n, p0, p1, radius);
        if entry <= 1.0 {
            return (entry, 0.0);
        }
        if crosses(&t, n, p0, p1, radius * CCD_SLACK) {
            return ((h0 * (1.0 / (h0 - h1))).clamp(0.0, 1.0), 0.0);
        }
        (2.0, 0.0)
    }

    /// The contact point `c` (the motion at the hit) and the closest point `q` of the triangle
    /// to it give the normal: along the face normal over the face's interior, away from the
    /// edge or corner otherwise; a particle exactly on the triangle takes the face's side
    /// opposite to its motion. The particle goes to its motion's end lifted along that normal
    /// to the thickness above `q`'s tangent plane.
    #[inline]
    fn surface(t: Triangle, p0: Vec3, p1: Vec3, hit: f32, thickness: f32) -> (Vec3, Vec3) {
        let n = face_normal(&t);
        let c = p0 + (p1 - p0) * hit;
        let q = closest_on_triangle(c, &t);
        let away = c - q;
        let h = away.dot(n);
        let off_face = away - n * h;
        let len = away.length();
        let normal = if n != Vec3::ZERO && off_face.length_squared() <= 1e-12 * away.length_squared().max(1e-30) {
            // Over the interior; exactly on the face: the side the motion comes from.
            let side = if h != 0.0 { h } else { -(p1 - p0).dot(n) };
            if side >= 0.0 { n } else { -n }
        } else if len > 1e-12 {
            away * (1.0 / len)
        } else {
            let back = p0 - p1;
            let back_len = back.length();
            if back_len > 1e-12 { back * (1.0 / back_len) } else { Vec3::Y }
        };
        let lift = (thickness - (p1 - q).dot(normal)).max(0.0);
        (p1 + normal * lift, normal)
    }

    /// The motion's box is inside the region, so its grown box meets `b` only if the region's
    /// does (the same sums, on bounds at least as far out).
    #[inline]
    fn may_touch_region(b: &Aabb, region: &Aabb, thickness: f32) -> bool {
        Self::may_touch(b, region.min.xyz(), region.max.xyz(), thickness)
    }

    /// Every point of the region is within its half diagonal of its centre, and a hit needs a
    /// point of the motion within the grown radius of the triangle: a triangle farther from the
    /// centre than both together (plus a margin for rounding, relative to the coordinates)
    /// cannot be hit. Far tighter than the box test for a particle beside a dense surface.
    #[inline]
    fn may_touch_leaf_region(t: Triangle, region: &Aabb, thickness: f32) -> bool {
        if t.sweep != Vec4::ZERO {
            return true; // the box test over its sweep is all there is
        }
        let (lo, hi) = (region.min.xyz(), region.max.xyz());
        let centre = (lo + hi) * 0.5;
        let half_diagonal = (hi - lo).length() * 0.5;
        let reach = half_diagonal + Self::grown(thickness) * (1.0 + CCD_SLACK);
        let margin = 1e-5 * (centre.abs().max_element() + half_diagonal);
        (centre - closest_on_triangle(centre, &t)).length() <= reach + margin
    }

    /// The centroid's motion over the frame: its corners move within the sweep's residual of
    /// it (`swept_triangle_leaf`), which `hit` grows the radius by.
    #[inline]
    fn translation(t: Triangle) -> Vec3 {
        t.sweep.xyz()
    }

    #[inline]
    fn checks_path() -> bool {
        true
    }

    #[inline]
    fn blocks(t: Triangle, a: Vec3, b: Vec3, thickness: f32) -> bool {
        crosses(&t, face_normal(&t), a, b, thickness * CCD_SLACK)
    }

    /// The larger of the distance to the triangle's box and the distance beyond its extent
    /// along its normal: both are at most the true distance.
    #[inline]
    fn clearance(t: Triangle, p: Vec3) -> f32 {
        if t.sweep.w != 0.0 {
            return 0.0; // deforming: no bound, every path is checked
        }
        let b = triangle_aabb(&t);
        let to_box = (b.min.xyz() - p).max(p - b.max.xyz()).max(Vec3::ZERO).length();
        let n = face_normal(&t);
        let o = t.a.xyz();
        let (hb, hc) = ((t.b.xyz() - o).dot(n), (t.c.xyz() - o).dot(n));
        let h = (p - o).dot(n);
        let off_plane = (h - hb.max(hc).max(0.0)).max(hb.min(hc).min(0.0) - h).max(0.0);
        to_box.max(off_plane)
    }
}

/// `bounds[i]` = the box triangle `i` (input order) occupies over the frame.
#[spirv(compute(threads(256)))]
pub fn triangle_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] bounds: &mut [Aabb],
) {
    let i = id.x;
    if i < collider.leaf_count {
        bounds[i as usize] = swept_aabb(&triangle_at(i, vertices, previous, indices));
    }
}

/// Puts the triangles' corners in the tree's leaf order: `sorted[i] = triangle order[i]`, and
/// after the leaves how its corners moved (`sorted[leaf_count + i]`, `corner_motions_at`).
#[spirv(compute(threads(256)))]
pub fn gather_triangles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] collider: &ColliderParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] vertices: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] previous: &[Vec4],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] indices: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] order: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] sorted: &mut [Triangle],
) {
    let i = id.x;
    if i < collider.leaf_count {
        let t = order[i as usize];
        sorted[i as usize] = triangle_at(t, vertices, previous, indices);
        sorted[(collider.leaf_count + i) as usize] = corner_motions_at(t, vertices, previous, indices);
    }
}

crate::contact::contact_entry_points!(Triangles, Triangle);
