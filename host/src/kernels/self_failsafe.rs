//! Self-collision's fail-safe kernels (`drape_kernels::self_failsafe`): the triangles' boxes over
//! the frame, the check of every pair swept over it, and the roll-back of the particles of the
//! pairs found.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::self_failsafe::{
    CHECK_THREADS, Found, WITH_LISTS, Walkers, check_frame_at, whole_triangles_in, frame_box_at, note_everything, roll_back_at,
};
use drape_types::{Aabb, BvhNode, ColliderParams, DispatchArgs, FailsafePush, Health};
use glam::{UVec4, Vec4};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

pub static FAILSAFE_BOXES: Kernel = Kernel {
    spec: KernelSpec::new(
        "self_failsafe::failsafe_boxes",
        &[
            read("self_params"),
            read("sorted"),
            read("x"),
            read("anchors"),
            read("indices"),
            write("leaf_bounds"),
            write("escaped"),
            write("strays"),
        ],
        CHECK_THREADS,
    ),
    cpu: boxes_cpu,
};

pub static FAILSAFE_CHECK: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_check",
        bindings: &[
            read("self_params"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("owned"),
            read("x"),
            read("anchors"),
            read("escaped"),
            read("strays"),
            read("lists"),
            read("counts"),
            write("flags"),
            write("counters"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
    cpu: check_cpu,
};

pub static FAILSAFE_ROLL_BACK: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_roll_back",
        bindings: &[
            read("params"),
            write("x"),
            write("v"),
            read("anchors"),
            write("flags"),
            write("counters"),
            write("next_check"),
            write("next_rollback"),
            write("health"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: roll_back_cpu,
};

fn boxes_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, sorted, x, anchors, indices, leaf_bounds, escaped, strays] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let (sorted, x, anchors) = (sorted.slice::<UVec4>(), x.slice::<Vec4>(), anchors.slice::<Vec4>());
    let (indices, leaf_bounds) = (indices.slice::<u32>(), leaf_bounds.slice_mut::<Aabb>());
    let (escaped, strays) = (escaped.slice_mut::<u32>(), strays.slice_mut::<f32>());
    for s in 0..threads.min(c.leaf_count) {
        leaf_bounds[s as usize] = frame_box_at(s, sorted, (x, anchors), indices, (&mut *escaped, &mut *strays));
    }
    Ok(())
}

fn check_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: FailsafePush = d.push_as();
    let threads = d.invocations();
    let [
        self_params,
        nodes,
        aabbs,
        leaf_bounds,
        sorted,
        owned,
        x,
        anchors,
        escaped,
        strays,
        lists,
        counts,
        flags,
        counters,
    ] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let (owned, x, anchors) = (owned.slice::<u32>(), x.slice::<Vec4>(), anchors.slice::<Vec4>());
    let (flags, counters) = (flags.slice_mut::<u32>(), counters.slice_mut::<u32>());
    let pairs = counters.get_mut(2 * push.round as usize).ok_or("fail-safe round out of range")?;
    let walkers = Walkers { escaped: escaped.slice::<u32>(), counts: counts.slice::<u32>() };
    let with_lists = (push.flags & WITH_LISTS != 0, walkers, lists.slice::<u32>(), strays.slice::<f32>());
    for leaf in 0..threads.min(c.leaf_count) {
        let found = Found { flags: &mut *flags, pairs: &mut *pairs, whole_triangles: whole_triangles_in(push.round) };
        check_frame_at(leaf, &c, tree, owned, (x, anchors), with_lists, found);
    }
    Ok(())
}

fn roll_back_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: FailsafePush = d.push_as();
    let threads = d.invocations();
    let [params, x, v, anchors, flags, counters, next_check, next_rollback, health] = d.bindings()?;
    let p: drape_types::SimParams = params.first()?;
    let (x, v, anchors) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>(), anchors.slice::<Vec4>());
    let (flags, counters) = (flags.slice_mut::<u32>(), counters.slice_mut::<u32>());
    let (next_check, next_rollback) = (next_check.first_mut::<DispatchArgs>()?, next_rollback.first_mut::<DispatchArgs>()?);
    let health = health.first_mut::<Health>()?;
    if threads > 0 {
        note_everything(&push, counters, health);
    }
    for i in 0..threads.min(p.particle_count) {
        let next = (&mut *next_check, &mut *next_rollback);
        roll_back_at(i, &push, (&mut *x, &mut *v), anchors, flags, counters, next, health);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use drape_kernels::self_failsafe::{pair_meets, point_triangle_distance2, segment_distance2};
    use glam::Vec3;

    /// The smallest distance of a pair over the straight path from `then` to `now`, sampled
    /// finely in f64 (vertex 0 against triangle 1-2-3, or edge 0-1 against edge 2-3).
    fn sampled_minimum(then: [Vec3; 4], now: [Vec3; 4], edges: bool) -> f64 {
        let steps = 4000;
        (0..=steps)
            .map(|i| {
                let t = i as f64 / steps as f64;
                let at = |k: usize| {
                    let (a, b) = (then[k].as_dvec3(), now[k].as_dvec3());
                    (a + (b - a) * t).as_vec3()
                };
                let d2 = if edges {
                    segment_distance2(at(0), at(1), at(2), at(3))
                } else {
                    point_triangle_distance2(at(0), at(1), at(2), at(3))
                };
                f64::from(d2).sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Random pairs, each start at least a millimetre apart, moved by up to 2 cm: every pair
    /// whose sampled path comes within the separation is found (the check never misses), and a
    /// pair that stays more than 0.5 mm apart is almost never taken for one.
    #[test]
    fn pair_meets_finds_every_pair_that_comes_within_the_separation() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let separation = 5e-6;
        let (mut met, mut missed, mut false_alarms, mut apart) = (0, 0, 0, 0);
        for case in 0..4000 {
            let edges = case % 2 == 0;
            let mut point = || Vec3::new(random(), random(), random()) * 0.04;
            let then = [point(), point(), point(), point()];
            let mut motion = || Vec3::new(random(), random(), random()) * 0.04;
            let now = [then[0] + motion(), then[1] + motion(), then[2] + motion(), then[3] + motion()];
            if sampled_minimum(then, then, edges) < 1e-3 {
                continue;
            }
            let found = pair_meets(then, now, edges, separation);
            let minimum = sampled_minimum(then, now, edges);
            if minimum < f64::from(separation) * 0.5 {
                met += 1;
                missed += usize::from(!found);
            } else if minimum > 5e-4 {
                apart += 1;
                false_alarms += usize::from(found);
            }
        }
        assert_eq!(missed, 0, "{missed} of {met} meeting pairs missed");
        assert!(met > 50, "the cases must include meeting pairs ({met})");
        assert!(false_alarms * 200 < apart, "{false_alarms} of {apart} pairs apart by 0.5 mm taken as meeting");
    }

    /// Pairs that move together, however fast, or slide past each other a millimetre apart, do
    /// not meet; one passing through the other does, and so does one that ends touching.
    #[test]
    fn pair_meets_tells_passing_through_from_sliding_by() {
        let face = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.02, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.02)];
        let vertex = Vec3::new(0.005, 0.001, 0.005);
        let then = [vertex, face[0], face[1], face[2]];
        let shifted = |d: Vec3| then.map(|p| p + d);
        assert!(!pair_meets(then, shifted(Vec3::new(3.0, -2.0, 1.0)), false, 1e-6), "moving together");
        let mut slide = then;
        slide[0] += Vec3::new(0.01, 0.0, 0.01);
        assert!(!pair_meets(then, slide, false, 1e-6), "sliding 1 mm over the face");
        let mut through = then;
        through[0] -= Vec3::Y * 0.002;
        assert!(pair_meets(then, through, false, 1e-6), "through the face");
        let mut touching = then;
        touching[0] -= Vec3::Y * 0.001;
        assert!(pair_meets(then, touching, false, 1e-6), "ending on the face");
        // Two edges crossing: one sweeps down through the other.
        let edges = [Vec3::new(-0.01, 0.001, 0.0), Vec3::new(0.01, 0.001, 0.0), Vec3::new(0.0, 0.0, -0.01), Vec3::new(0.0, 0.0, 0.01)];
        let mut crossed = edges;
        crossed[0].y = -0.001;
        crossed[1].y = -0.001;
        assert!(pair_meets(edges, crossed, true, 1e-6), "edge through edge");
        let mut beside = crossed;
        beside[0].z = 0.02;
        beside[1].z = 0.02;
        let mut beside_then = edges;
        beside_then[0].z = 0.02;
        beside_then[1].z = 0.02;
        assert!(!pair_meets(beside_then, beside, true, 1e-6), "edge beyond the other's end");
    }
}
