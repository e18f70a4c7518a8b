//! Self-collision's fail-safe kernels (`drape_kernels::self_failsafe`): the triangles' boxes over
//! the frame, which moving collider carries each particle, the check of every pair of triangles
//! at the frame's end (and of a triangle collider's sharp triangles against the cloth's), and
//! the roll-back of the particles of the pairs found.

use crate::graph::{BindingSpec, HostBuffer, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::lbvh::{REFIT_THREADS, refit_from_leaf};
use drape_kernels::self_failsafe::{
    CHECK_THREADS, CarrierOut, Carriers, Found, WITH_LISTS, Walkers, check_collider_triangle_at, check_frame_at,
    failsafe_box_at, note_everything, roll_back_at, sphere_carrier_at, triangle_carrier_at, widen_failsafe_tree_at,
};
use drape_types::{
    Aabb, BvhNode, CarrierPush, ColliderParams, ColliderPose, DispatchArgs, FailsafePush, Health, Triangle,
};
use glam::{UVec4, Vec4};

const fn read(name: &'static str) -> BindingSpec {
    BindingSpec::read(name)
}
const fn write(name: &'static str) -> BindingSpec {
    BindingSpec::write(name)
}

pub static FAILSAFE_BOXES: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_boxes",
        bindings: &[
            read("self_params"),
            read("sorted"),
            read("x"),
            read("anchors"),
            read("indices"),
            write("leaf_bounds"),
            write("escaped"),
            write("strays"),
            write("refit_flags"),
            read("tree_every_pass"),
            write("refit"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
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
            read("x"),
            read("anchors"),
            read("escaped"),
            read("strays"),
            read("lists"),
            read("counts"),
            read("carriers"),
            read("carrier_frames"),
            write("flags"),
            write("counters"),
            write("carried"),
            write("refit_flags"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
    cpu: check_cpu,
};

/// A later round's boxes and the tree's refit to them, in one dispatch.
pub static FAILSAFE_BOXES_AND_REFIT: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_boxes_and_refit",
        bindings: &[
            read("self_params"),
            read("sorted"),
            read("x"),
            read("anchors"),
            read("indices"),
            write("leaf_bounds"),
            write("escaped"),
            write("strays"),
            read("tree_every_pass"),
            write("refit"),
            read("nodes"),
            read("parents"),
            write("refit_flags"),
            write("aabbs"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
    cpu: boxes_and_refit_cpu,
};

fn boxes_and_refit_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: FailsafePush = d.push_as();
    let threads = d.invocations();
    let [
        self_params,
        sorted,
        x,
        anchors,
        indices,
        leaf_bounds,
        escaped,
        strays,
        tree_every_pass,
        refit,
        nodes,
        parents,
        refit_flags,
        aabbs,
    ] = d.bindings()?;
    let frame = [self_params, sorted, x, anchors, indices];
    let c = boxes_over(&push, threads, frame, [&mut *leaf_bounds, escaped, strays, tree_every_pass, refit])?;
    // Every box before any climb: the GPU's climbs read a sibling's box only after its thread
    // released the node's flag, so any order of the climbs gives the same boxes.
    if c.leaf_count >= 2 {
        let (nodes, parents, leaf_bounds) =
            (nodes.slice::<BvhNode>(), parents.slice::<u32>(), leaf_bounds.slice::<Aabb>());
        let (flags, words) = (refit_flags.slice_mut::<u32>(), aabbs.slice_mut::<u32>());
        for s in 0..threads.min(c.leaf_count) {
            refit_from_leaf(s, c.leaf_count, nodes, parents, leaf_bounds, flags, words);
        }
    }
    Ok(())
}

/// The fail-safe's boxes on the CPU (`failsafe_box_at` for each of the first `threads` sorted
/// leaves), over `FAILSAFE_BOXES`' bindings but the refit's flags, in its order: what its twin
/// and a later round's (`FAILSAFE_BOXES_AND_REFIT`) share. Returns the cloth's tree's record.
fn boxes_over(
    push: &FailsafePush,
    threads: u32,
    [self_params, sorted, x, anchors, indices]: [&mut HostBuffer; 5],
    [leaf_bounds, escaped, strays, tree_every_pass, refit]: [&mut HostBuffer; 5],
) -> Result<ColliderParams, String> {
    let c: ColliderParams = self_params.first()?;
    let (sorted, x, anchors) = (sorted.slice::<UVec4>(), x.slice::<Vec4>(), anchors.slice::<Vec4>());
    let (indices, leaf_bounds) = (indices.slice::<u32>(), leaf_bounds.slice_mut::<Aabb>());
    let (escaped, strays) = (escaped.slice_mut::<u32>(), strays.slice_mut::<f32>());
    let tree_every_pass: u32 = tree_every_pass.first()?;
    let refit = refit.first_mut::<DispatchArgs>()?;
    for s in 0..threads.min(c.leaf_count) {
        let out = (&mut *leaf_bounds, &mut *escaped, &mut *strays);
        failsafe_box_at((s, push), &c, (sorted, x, anchors, indices), out, (tree_every_pass, &mut *refit));
    }
    Ok(c)
}

pub static FAILSAFE_CARRIERS_TRIANGLES: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_carriers_triangles",
        bindings: &[
            read("params"),
            read("collider"),
            read("pose"),
            read("nodes"),
            read("aabbs"),
            read("leaves"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("order"),
            read("anchors"),
            write("carriers"),
            write("carrier_frames"),
            write("carrier_choice"),
        ],
        push_constant_size: size_of::<CarrierPush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
    cpu: triangle_carriers_cpu,
};

pub static FAILSAFE_CARRIERS_SPHERES: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_carriers_spheres",
        bindings: &[
            read("params"),
            read("collider"),
            read("pose"),
            read("nodes"),
            read("aabbs"),
            read("leaves"),
            read("anchors"),
            write("carriers"),
            write("carrier_frames"),
            write("carrier_choice"),
        ],
        push_constant_size: size_of::<CarrierPush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
    cpu: sphere_carriers_cpu,
};

pub static FAILSAFE_COLLIDER_CHECK: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_collider_check",
        bindings: &[
            read("self_params"),
            read("pose"),
            read("vertices"),
            read("previous"),
            read("indices"),
            read("sharp"),
            read("sharp_args"),
            read("nodes"),
            read("aabbs"),
            read("leaf_bounds"),
            read("sorted"),
            read("x"),
            read("anchors"),
            write("flags"),
            write("counters"),
            write("carried"),
            write("health"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: CHECK_THREADS,
    },
    cpu: collider_check_cpu,
};

pub static FAILSAFE_ROLL_BACK: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::failsafe_roll_back",
        bindings: &[
            read("params"),
            write("x"),
            write("v"),
            read("anchors"),
            write("carried"),
            write("flags"),
            write("counters"),
            write("next_check"),
            write("next_rollback"),
            write("health"),
            read("carrier_frames"),
            read("carrier_choice"),
        ],
        push_constant_size: size_of::<FailsafePush>() as u32,
        workgroup_size: WORKGROUP_SIZE,
    },
    cpu: roll_back_cpu,
};

fn boxes_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: FailsafePush = d.push_as();
    let threads = d.invocations();
    let [self_params, sorted, x, anchors, indices, leaf_bounds, escaped, strays, refit_flags, tree_every_pass, refit] =
        d.bindings()?;
    let frame = [self_params, sorted, x, anchors, indices];
    let c = boxes_over(&push, threads, frame, [leaf_bounds, escaped, strays, tree_every_pass, refit])?;
    let refit_flags = refit_flags.slice_mut::<u32>();
    for node in 0..threads.min(c.leaf_count.saturating_sub(1)) {
        refit_flags[node as usize] = 0;
    }
    Ok(())
}

/// The first round's tree derived from the lists' tree, widened by the walkers' climbs (over
/// the refit's dispatch; the derivation is `self_pass_tree::DERIVE_PASS_TREE`'s).
pub static WIDEN_FAILSAFE_TREE: Kernel = Kernel {
    spec: KernelSpec {
        entry: "self_failsafe::widen_failsafe_tree",
        bindings: &[
            read("self_params"),
            read("sorted"),
            read("escaped"),
            read("parents"),
            read("leaf_bounds"),
            write("aabbs"),
        ],
        push_constant_size: 0,
        workgroup_size: REFIT_THREADS,
    },
    cpu: widen_cpu,
};

fn widen_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [self_params, sorted, escaped, parents, leaf_bounds, aabbs] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let (sorted, escaped) = (sorted.slice::<UVec4>(), escaped.slice::<u32>());
    let (parents, leaf_bounds) = (parents.slice::<u32>(), leaf_bounds.slice::<Aabb>());
    let words = aabbs.slice_mut::<u32>();
    for s in 0..threads.min(c.leaf_count) {
        widen_failsafe_tree_at(s, c.leaf_count, (sorted, escaped), (parents, leaf_bounds), words);
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
        x,
        anchors,
        escaped,
        strays,
        lists,
        counts,
        carriers,
        carrier_frames,
        flags,
        counters,
        carried,
        refit_flags,
    ] = d.bindings()?;
    let c: ColliderParams = self_params.first()?;
    let refit_flags = refit_flags.slice_mut::<u32>();
    for node in 0..threads.min(c.leaf_count.saturating_sub(1)) {
        refit_flags[node as usize] = 0;
    }
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let (x, anchors) = (x.slice::<Vec4>(), anchors.slice::<Vec4>());
    let carriers = Carriers { carriers: carriers.slice::<u32>(), frames: carrier_frames.slice::<Vec4>() };
    let (flags, counters, carried) =
        (flags.slice_mut::<u32>(), counters.slice_mut::<u32>(), carried.slice_mut::<u32>());
    let pairs = counters.get_mut(2 * push.round as usize).ok_or("fail-safe round out of range")?;
    let walkers = Walkers { escaped: escaped.slice::<u32>(), counts: counts.slice::<u32>() };
    let with_lists = (push.flags & WITH_LISTS != 0, walkers, lists.slice::<u32>(), strays.slice::<f32>());
    for leaf in 0..threads.min(c.leaf_count) {
        let found = Found { flags: &mut *flags, pairs: &mut *pairs, carried: &mut *carried };
        check_frame_at(leaf, &c, tree, (x, anchors, carriers), with_lists, found);
    }
    Ok(())
}

fn triangle_carriers_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: CarrierPush = d.push_as();
    let threads = d.invocations();
    let [
        params,
        collider,
        pose,
        nodes,
        aabbs,
        leaves,
        vertices,
        previous,
        indices,
        order,
        anchors,
        carriers,
        frames,
        choice,
    ] = d.bindings()?;
    let p: drape_types::SimParams = params.first()?;
    let (c, pose): (ColliderParams, ColliderPose) = (collider.first()?, pose.first()?);
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaves.slice::<Triangle>());
    let mesh = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>(), order.slice::<u32>());
    let (anchors, carriers, frames) =
        (anchors.slice::<Vec4>(), carriers.slice_mut::<u32>(), frames.slice_mut::<Vec4>());
    let choice = choice.first_mut::<u32>()?;
    for i in 0..threads.min(p.particle_count) {
        let out = CarrierOut { carriers: &mut *carriers, frames: &mut *frames, choice: &mut *choice };
        triangle_carrier_at((i, p.particle_count, push.slot), (&c, &pose), tree, mesh, anchors, out);
    }
    Ok(())
}

fn sphere_carriers_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: CarrierPush = d.push_as();
    let threads = d.invocations();
    let [params, collider, pose, nodes, aabbs, leaves, anchors, carriers, frames, choice] = d.bindings()?;
    let p: drape_types::SimParams = params.first()?;
    let (c, pose): (ColliderParams, ColliderPose) = (collider.first()?, pose.first()?);
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaves.slice::<drape_types::SphereLeaf>());
    let (anchors, carriers, frames) =
        (anchors.slice::<Vec4>(), carriers.slice_mut::<u32>(), frames.slice_mut::<Vec4>());
    let choice = choice.first_mut::<u32>()?;
    for i in 0..threads.min(p.particle_count) {
        let out = CarrierOut { carriers: &mut *carriers, frames: &mut *frames, choice: &mut *choice };
        sphere_carrier_at((i, p.particle_count, push.slot), (&c, &pose), tree, anchors, out);
    }
    Ok(())
}

fn collider_check_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: FailsafePush = d.push_as();
    let threads = d.invocations();
    let [
        self_params,
        pose,
        vertices,
        previous,
        indices,
        sharp,
        sharp_args,
        nodes,
        aabbs,
        leaf_bounds,
        sorted,
        x,
        anchors,
        flags,
        counters,
        carried,
        health,
    ] = d.bindings()?;
    if threads == 0 {
        return Ok(()); // a round the one before left nothing to check
    }
    let c: ColliderParams = self_params.first()?;
    let pose: ColliderPose = pose.first()?;
    let mesh = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>(), &pose);
    let tree = (nodes.slice::<BvhNode>(), aabbs.slice::<Aabb>(), leaf_bounds.slice::<Aabb>(), sorted.slice::<UVec4>());
    let (x, anchors) = (x.slice::<Vec4>(), anchors.slice::<Vec4>());
    let (flags, counters) = (flags.slice_mut::<u32>(), counters.slice_mut::<u32>());
    let pairs = counters.get_mut(2 * push.round as usize).ok_or("fail-safe round out of range")?;
    let (sharp, listed) = (sharp.slice::<u32>(), sharp_args.first::<DispatchArgs>()?._pad);
    let (carried, health) = (carried.slice_mut::<u32>(), health.first_mut::<Health>()?);
    // The kernel's threads stride over the whole list: every listed triangle, whatever the count.
    for i in 0..listed {
        let t = *sharp.get(i as usize).ok_or("the sharp triangles' count runs past their list")?;
        if 3 * t as usize + 2 >= mesh.2.len() {
            return Err("a listed sharp triangle is past the collider's triangles".into());
        }
        let found = Found { flags: &mut *flags, pairs: &mut *pairs, carried: &mut *carried };
        let marks = (found, &mut *health);
        check_collider_triangle_at(t, mesh, &c, tree, (x, anchors), marks);
    }
    Ok(())
}

fn roll_back_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: FailsafePush = d.push_as();
    let threads = d.invocations();
    let [params, x, v, anchors, carried, flags, counters, next_check, next_rollback, health, frames, choice] =
        d.bindings()?;
    let p: drape_types::SimParams = params.first()?;
    let (x, v) = (x.slice_mut::<Vec4>(), v.slice_mut::<Vec4>());
    let (anchors, carried) = (anchors.slice::<Vec4>(), carried.slice_mut::<u32>());
    let carriers = (frames.slice::<Vec4>(), choice.first()?);
    let (flags, counters) = (flags.slice_mut::<u32>(), counters.slice_mut::<u32>());
    let (next_check, next_rollback) =
        (next_check.first_mut::<DispatchArgs>()?, next_rollback.first_mut::<DispatchArgs>()?);
    let health = health.first_mut::<Health>()?;
    if threads > 0 {
        note_everything(&push, counters, health);
    }
    for i in 0..threads.min(p.particle_count) {
        let next = (&mut *next_check, &mut *next_rollback);
        let push = (&push, p.substep);
        let starts = (anchors, &mut *carried, carriers);
        roll_back_at(i, push, (&mut *x, &mut *v), starts, flags, counters, next, health);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::metrics::intersections::triangles_intersect;
    use drape_kernels::self_failsafe::triangles_cross;
    use glam::Vec3;

    /// The kernels' f32 test agrees with the exact one (`metrics::intersections`, robust
    /// predicates) on random pairs of triangles, crossing and apart.
    #[test]
    fn triangles_cross_agrees_with_the_exact_test() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let (mut crossing, mut differ) = (0, 0);
        for _ in 0..20000 {
            let mut point = || Vec3::new(random(), random(), random()) * 0.04;
            let (t, u) = ([point(), point(), point()], [point(), point(), point()]);
            let exact = triangles_intersect(t, u);
            crossing += usize::from(exact);
            differ += usize::from(exact != triangles_cross(t, u));
        }
        assert_eq!(differ, 0, "{differ} of 20000 pairs judged otherwise than the exact test");
        assert!(crossing > 1000, "the cases must include crossing pairs ({crossing})");
    }

    /// Two triangles of a sheet lying flat (1e-7 m off its plane, as the pile's upright strip
    /// is in its first frames), two cells apart, do not cross; a triangle through the sheet
    /// does, and one whose corner only touches it gets the exact test's answer.
    #[test]
    fn a_flat_sheet_s_triangles_do_not_cross_but_one_through_it_does() {
        let cell = 0.04;
        let flat = |x: f32, y: f32, dz: [f32; 3]| {
            [Vec3::new(x, y, dz[0]), Vec3::new(x + cell, y, dz[1]), Vec3::new(x, y + cell, dz[2])]
        };
        let a = flat(0.0, 0.0, [7e-7, -1.6e-7, 2.9e-7]);
        let b = flat(2.0 * cell, 0.0, [8.5e-8, -2.7e-8, 4.8e-8]);
        assert!(!triangles_cross(a, b) && !triangles_cross(b, a));
        let through = [Vec3::new(0.01, 0.01, -0.01), Vec3::new(0.01, 0.01, 0.01), Vec3::new(0.02, -0.02, 0.0)];
        assert!(triangles_cross(a, through) && triangles_cross(through, a));
        let touching = [Vec3::new(0.01, 0.01, 2e-7), Vec3::new(0.01, 0.01, 0.02), Vec3::new(0.02, 0.0, 0.02)];
        assert!(triangles_intersect(a, touching) == triangles_cross(a, touching));
    }

    /// A cloth lying flat (on a box's top: its heights 0-2 f32 steps apart, as contact leaves
    /// them): no two of its triangles that share no particle cross, though their boxes touch at
    /// corners and edges and f32 cannot tell the sign of their orientations. The first pair is
    /// one the fail-safe took for crossed at a 64^2 cloth's landing on a cube, and put the
    /// whole cloth back.
    #[test]
    fn a_cloth_lying_flat_does_not_cross_itself_whatever_f32_rounds() {
        let landed = (
            [
                Vec3::new(0.03321431, 0.93095, -0.54249465),
                Vec3::new(0.033214305, 0.9309501, -0.52033186),
                Vec3::new(0.055357154, 0.93095, -0.5424947),
            ],
            [
                Vec3::new(0.07749999, 0.93095, -0.54249465),
                Vec3::new(0.055357166, 0.9309501, -0.52033186),
                Vec3::new(0.07750002, 0.9309501, -0.52033186),
            ],
        );
        assert!(!triangles_cross(landed.0, landed.1) && !triangles_intersect(landed.0, landed.1));
        let n = 12u32;
        let spacing = 0.022142857;
        let mut rng = 0x2545_f491_u32;
        let heights: Vec<f32> = (0..n * n)
            .map(|_| {
                rng ^= rng << 13;
                rng ^= rng >> 17;
                rng ^= rng << 5;
                let steps = (rng % 3) as f32;
                0.93095 + steps * 6e-8
            })
            .collect();
        let point = |i: u32, j: u32| {
            Vec3::new(-0.1 + i as f32 * spacing, heights[(i * n + j) as usize], -0.5 + j as f32 * spacing)
        };
        let mut triangles = Vec::new();
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                let (a, b, c, d) = ((i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1));
                triangles.push([a, c, b]);
                triangles.push([b, c, d]);
            }
        }
        let mut touching = 0;
        for (k, t) in triangles.iter().enumerate() {
            for u in &triangles[k + 1..] {
                if t.iter().any(|p| u.contains(p)) {
                    continue;
                }
                let (tp, up) = (t.map(|(i, j)| point(i, j)), u.map(|(i, j)| point(i, j)));
                let (tl, th) = (tp[0].min(tp[1]).min(tp[2]), tp[0].max(tp[1]).max(tp[2]));
                let (ul, uh) = (up[0].min(up[1]).min(up[2]), up[0].max(up[1]).max(up[2]));
                if (tl - 1e-6).cmple(uh).all() && (ul - 1e-6).cmple(th).all() {
                    touching += 1;
                    assert!(!triangles_cross(tp, up), "{t:?} and {u:?} cross: {tp:?} {up:?}");
                }
            }
        }
        assert!(touching > 100, "{touching} pairs with touching boxes");
    }

    /// A sphere of a deforming collider carries a particle that started the frame beside it by
    /// its own motion: the carrier's frames stand at its centre where the frame started (its
    /// centre less its sweep) and where it ends, not both at the end.
    #[test]
    fn a_deforming_sphere_carries_a_particle_from_where_its_centre_started() {
        use drape_kernels::self_failsafe::{CARRIER_FRAME_WORDS, CarrierOut, sphere_carrier_at};
        use drape_kernels::self_pairs::{ANCHOR_WORDS, FRAME_START_WORD};
        use drape_types::{ColliderParams, ColliderPose, RigidPose, SphereLeaf};
        use glam::Vec4;
        let (start, end) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.1, 0.0));
        let leaf = SphereLeaf { sphere: end.extend(0.05), sweep: (end - start).extend(0.0) };
        let collider = ColliderParams { leaf_count: 1, thickness: 0.005, ..Default::default() };
        let pose = ColliderPose {
            previous: RigidPose::IDENTITY,
            current: RigidPose::IDENTITY,
            sweep: Vec4::new(0.1, 0.0, 0.0, 0.0),
        };
        let mut anchors = vec![Vec4::ZERO; ANCHOR_WORDS as usize];
        anchors[FRAME_START_WORD as usize] = Vec4::new(0.0, 0.06, 0.0, 0.0);
        let (mut carriers, mut frames, mut choice) = (vec![0u32], vec![Vec4::ZERO; CARRIER_FRAME_WORDS as usize], 0);
        let out = CarrierOut { carriers: &mut carriers, frames: &mut frames, choice: &mut choice };
        sphere_carrier_at((0, 1, 2), (&collider, &pose), (&[], &[], &[leaf]), &anchors, out);
        assert_eq!(carriers, [3], "collider 2 carries the particle");
        let frames: Vec<Vec3> = frames.iter().map(|f| f.truncate()).collect();
        assert_eq!(frames, [start, start + Vec3::X, start + Vec3::Y, end, end + Vec3::X, end + Vec3::Y]);
    }
}
