//! The frame's list of a triangle collider's possibly sharp triangles
//! (`drape_kernels::sharp_features`), which each self-collision pass's collider features
//! dispatch over.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::WORKGROUP_SIZE;
use drape_kernels::self_contact::tested_features;
use drape_kernels::sharp_features::{frame_threshold, list_sharp, may_be_sharp_cached, reshaped};
use drape_types::{ColliderParams, ColliderPose, DispatchArgs};
use glam::{UVec4, Vec4};

pub static LIST_SHARP_FEATURES: Kernel = Kernel {
    spec: KernelSpec::new(
        "sharp_features::list_sharp_features",
        &[
            BindingSpec::read("self_params"),
            BindingSpec::read("collider"),
            BindingSpec::read("vertices"),
            BindingSpec::read("previous"),
            BindingSpec::read("indices"),
            BindingSpec::read("features"),
            BindingSpec::write("sharp"),
            BindingSpec::write("sharp_args"),
            BindingSpec::write("tree_every_pass"),
            BindingSpec::write("listed"),
            BindingSpec::read("pose"),
            BindingSpec::write("folds"),
        ],
        WORKGROUP_SIZE,
    ),
    cpu: list_cpu,
};

fn list_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [
        self_params,
        collider,
        vertices,
        previous,
        indices,
        features,
        sharp,
        sharp_args,
        tree_every_pass,
        listed,
        pose,
        folds,
    ] = d.bindings()?;
    let self_params = self_params.first::<ColliderParams>()?;
    let collider = collider.first::<ColliderParams>()?;
    let (longest2, thickness) = frame_threshold(&self_params, &collider);
    let mesh = (vertices.slice::<Vec4>(), previous.slice::<Vec4>(), indices.slice::<u32>());
    let features = features.slice::<UVec4>();
    let (list, args) = (sharp.slice_mut::<u32>(), sharp_args.first_mut::<DispatchArgs>()?);
    let tree_every_pass = tree_every_pass.first_mut::<u32>()?;
    let flags = listed.slice_mut::<u32>();
    let cache = (folds.slice_mut::<Vec4>(), reshaped(&pose.first::<ColliderPose>()?));
    for t in 0..threads.min(features.len() as u32) {
        let feature = tested_features(features[t as usize], &collider);
        let sharp = may_be_sharp_cached(t, feature, mesh, (longest2, thickness), (&mut *cache.0, cache.1));
        if sharp {
            list_sharp(t, list, args, tree_every_pass);
        }
        *flags.get_mut(t as usize).ok_or("the sharp flags are shorter than the collider's triangles")? = sharp as u32;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::programs::self_contact::collider_features;
    use drape_kernels::pose::to_world;
    use drape_kernels::self_contact::{NO_NEIGHBOUR, fold, sharp_features};
    use drape_kernels::sharp_features::may_be_sharp;
    use drape_types::RigidPose;
    use glam::{Quat, Vec3};

    /// The features a pass tests of collider triangle `t` at `pose`: its folds measured in the
    /// world, as `collider_feature_contact_at` does, against the exact threshold.
    fn pass_sharp(mesh: &Mesh, feature: UVec4, t: usize, pose: &RigidPose, cloth: (f32, f32)) -> u32 {
        let world = |i: u32| to_world(pose, mesh.vertices[i as usize]);
        let corners = mesh.triangles[t].map(world);
        let across = [feature.x, feature.y, feature.z];
        let folds: Vec<f32> = (0..3)
            .map(|k| match across[k] {
                NO_NEIGHBOUR => 2.0,
                apex => fold(corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3], world(apex)),
            })
            .collect();
        sharp_features(feature.w, Vec3::from_slice(&folds), cloth, 1.0)
    }

    /// Every triangle a pass finds a sharp feature on, at any pose, is on the frame's list;
    /// the list leaves out most of a smooth sphere for a short cloth edge and takes a triangle
    /// whose vertex deforms in the frame whatever its folds.
    #[test]
    fn the_frame_s_list_holds_every_triangle_a_pass_finds_sharp() {
        let thickness = 0.005;
        let meshes = [Mesh::icosphere(0.3, 3), Mesh::torus(0.4, 0.1, 48, 16), Mesh::icosphere(0.2, 1)];
        let poses = [
            RigidPose::IDENTITY,
            RigidPose {
                rotation: Vec4::from(Quat::from_euler(glam::EulerRot::XYZ, 0.7, -1.9, 2.4)),
                translation: Vec3::new(3.1, -0.4, 12.5).extend(0.0),
            },
        ];
        let (mut listed_total, mut sharp_total, mut triangles_total) = (0, 0, 0);
        for mesh in &meshes {
            let features = collider_features(&mesh.triangles);
            let local: Vec<Vec4> = mesh.vertices.iter().map(|v| v.extend(0.0)).collect();
            let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
            for edge in [0.005f32, 0.02, 0.05, 0.2] {
                let longest2 = edge * edge;
                for (t, &feature) in features.iter().enumerate() {
                    let listed = may_be_sharp(t as u32, feature, (&local, &local, &indices), longest2, thickness);
                    let mut sharp_somewhere = false;
                    for pose in &poses {
                        let sharp = pass_sharp(mesh, feature, t, pose, (longest2, thickness));
                        sharp_somewhere |= sharp != 0;
                        assert!(listed || sharp == 0, "triangle {t}: sharp {sharp:#b} at {pose:?} but not listed");
                    }
                    listed_total += listed as u32;
                    sharp_total += sharp_somewhere as u32;
                    triangles_total += 1;
                }
            }
            // A vertex that deforms lists the triangles around it (and those whose neighbour
            // apex it is), however flat.
            let mut moved = local.clone();
            moved[0].y += 1e-3;
            let around: Vec<usize> = (0..features.len()).filter(|&t| mesh.triangles[t].contains(&0)).collect();
            for t in around {
                let feature = features[t];
                if feature.w != 0 {
                    assert!(may_be_sharp(t as u32, feature, (&moved, &local, &indices), 1e-6, thickness));
                }
            }
        }
        // Neither everything nor nothing: the test tells a list from a full dispatch.
        assert!(sharp_total > 0 && listed_total < triangles_total / 2, "{listed_total} of {triangles_total} listed");
        println!("listed {listed_total}, sharp in a pass {sharp_total}, of {triangles_total} triangle-thresholds");
    }

    /// The list through the cached folds (`may_be_sharp_cached`) answers as `may_be_sharp`
    /// measuring every frame: on the first frame (nothing cached), on still frames (the cache
    /// read), on a frame whose start wrote new vertices (the torus pressed nearly flat: measured
    /// and cached anew, and every triangle whose vertices moved listed) and on the still frames
    /// after it; without the write's flag it would have kept the round torus's folds.
    #[test]
    fn cached_folds_list_what_measured_folds_list_until_the_vertices_are_written() {
        let mesh = Mesh::torus(0.4, 0.1, 48, 16);
        let features = collider_features(&mesh.triangles);
        let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        let round: Vec<Vec4> = mesh.vertices.iter().map(|v| v.extend(0.0)).collect();
        let flat: Vec<Vec4> = round.iter().map(|v| Vec4::new(v.x, v.y * 0.05, v.z, 0.0)).collect();
        let threshold = (0.03f32 * 0.03, 0.005);
        let mut folds = vec![Vec4::ZERO; features.len()];
        let list = |folds: &mut [Vec4], (now, before): (&[Vec4], &[Vec4]), reshaped: bool| -> Vec<bool> {
            (0..features.len())
                .map(|t| {
                    let mesh = (now, before, &indices[..]);
                    may_be_sharp_cached(t as u32, features[t], mesh, threshold, (&mut *folds, reshaped))
                })
                .collect()
        };
        let measured = |(now, before): (&[Vec4], &[Vec4])| -> Vec<bool> {
            (0..features.len())
                .map(|t| may_be_sharp(t as u32, features[t], (now, before, &indices), threshold.0, threshold.1))
                .collect()
        };
        let (round_list, flat_list) = (measured((&round, &round)), measured((&flat, &flat)));
        assert_ne!(round_list, flat_list, "pressing the torus flat changes which triangles may be sharp");
        assert_eq!(list(&mut folds, (&round, &round), false), round_list, "first frame: nothing cached");
        assert!(folds.iter().all(|f| f.w == 1.0), "every triangle's folds cached");
        assert_eq!(list(&mut folds, (&round, &round), false), round_list, "a still frame: the cache");
        let pressed = list(&mut folds, (&flat, &round), true);
        assert_eq!(pressed, measured((&flat, &round)), "the frame that deforms it");
        assert!(pressed.iter().filter(|&&l| l).count() > round_list.iter().filter(|&&l| l).count());
        assert_eq!(list(&mut folds, (&flat, &flat), false), flat_list, "still again: the new shape's folds");
        let mut stale = vec![Vec4::ZERO; features.len()];
        list(&mut stale, (&round, &round), false);
        assert_eq!(list(&mut stale, (&flat, &flat), false), round_list, "unflagged, the cache keeps the old folds");
    }

    /// A smooth sphere (radius 0.5 m, 5120 triangles): its features, vertices (w = 0) and
    /// indices, and a triangle that owns a feature.
    fn sphere_with_an_owning_triangle() -> (Vec<UVec4>, Vec<Vec4>, Vec<u32>, usize) {
        let mesh = Mesh::icosphere(0.5, 4);
        let features = collider_features(&mesh.triangles);
        let local = mesh.vertices.iter().map(|v| v.extend(0.0)).collect();
        let indices = mesh.triangles.iter().flatten().copied().collect();
        let owning = features.iter().position(|f| f.w != 0).expect("a triangle owning a feature");
        (features, local, indices, owning)
    }

    /// A triangle marked curled (`CURLED_BIT`) is listed however flat its folds, unless it owns
    /// no vertex or edge to test; unmarked, the same triangle of a large sphere is not.
    #[test]
    fn a_curled_triangle_is_listed_whatever_its_folds() {
        use drape_kernels::self_contact::CURLED_BIT;
        let (features, local, indices, owning) = sphere_with_an_owning_triangle();
        let mesh = (&local[..], &local[..], &indices[..]);
        let (longest2, thickness) = (0.02f32 * 0.02, 0.005);
        let plain = features[owning];
        assert!(!may_be_sharp(owning as u32, plain, mesh, longest2, thickness), "a smooth sphere's triangle");
        let curled = UVec4 { w: plain.w | CURLED_BIT, ..plain };
        assert!(may_be_sharp(owning as u32, curled, mesh, longest2, thickness), "curled");
        let owning_nothing = UVec4 { w: CURLED_BIT, ..plain };
        assert!(!may_be_sharp(owning as u32, owning_nothing, mesh, longest2, thickness), "curled, owning nothing");
    }

    /// A curled triangle's covered features (`COVERED_SHIFT`) leave its tested ones while the
    /// collider's covers hold (a reach within `COVER_LIMIT` of the thickness); with no reach (a
    /// deformed collider), a thickness under twice the reach, or no `CURLED_BIT`, all stay.
    #[test]
    fn covered_features_are_skipped_only_while_the_covers_hold() {
        use drape_kernels::self_contact::{COVERED_SHIFT, CURLED_BIT, OWNED_FEATURE_BITS, VERTEX_OWNED_BIT};
        let owned = 0b011 | (VERTEX_OWNED_BIT << 1); // edges 0 and 1, corner 1
        let covered = 0b010 | (VERTEX_OWNED_BIT << 1); // edge 1 and corner 1
        let curled = UVec4::new(1, 2, 3, owned | CURLED_BIT | (covered << COVERED_SHIFT));
        let collider =
            |cover_reach: f32, thickness: f32| ColliderParams { thickness, cover_reach, ..Default::default() };
        let tested = |feature: UVec4, c: ColliderParams| tested_features(feature, &c).w & OWNED_FEATURE_BITS;
        let holding = tested_features(curled, &collider(0.00125, 0.005));
        assert_eq!(holding.w & OWNED_FEATURE_BITS, 0b001, "covers hold: only edge 0 is tested");
        assert_eq!((holding.truncate(), holding.w & CURLED_BIT), (curled.truncate(), CURLED_BIT), "apexes, curl kept");
        assert_eq!(tested(curled, collider(0.00125, 0.0025)), 0b001, "thickness twice the reach: covers hold");
        assert_eq!(tested(curled, collider(0.0, 0.005)), owned, "no reach (deformed): all tested");
        assert_eq!(tested(curled, collider(0.00125, 0.002)), owned, "thickness under twice the reach: all tested");
        let unmarked = UVec4 { w: curled.w & !CURLED_BIT, ..curled };
        assert_eq!(tested(unmarked, collider(0.00125, 0.005)), owned, "not curled: all tested");
    }

    /// The frame's list (`list_cpu`'s test: `may_be_sharp` of `tested_features`) leaves out a
    /// curled triangle all of whose features are covered while the covers hold, and lists it
    /// again once they do not.
    #[test]
    fn a_curled_triangle_whose_features_are_all_covered_is_not_listed() {
        use drape_kernels::self_contact::{COVERED_SHIFT, CURLED_BIT, OWNED_FEATURE_BITS};
        let (features, local, indices, owning) = sphere_with_an_owning_triangle();
        let mesh = (&local[..], &local[..], &indices[..]);
        let (longest2, thickness) = (0.02f32 * 0.02, 0.005);
        let owned = features[owning].w & OWNED_FEATURE_BITS;
        let covered = UVec4 { w: owned | CURLED_BIT | (owned << COVERED_SHIFT), ..features[owning] };
        let listed = |reach: f32| {
            let collider = ColliderParams { thickness, cover_reach: reach, ..Default::default() };
            may_be_sharp(owning as u32, tested_features(covered, &collider), mesh, longest2, thickness)
        };
        assert!(!listed(0.25 * thickness), "all covered, covers holding: not listed");
        assert!(listed(0.0), "covers dropped (deformed): listed");
    }
}
