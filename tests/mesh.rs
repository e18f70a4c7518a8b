//! Mesh loading, procedural meshes, voxel-sphere colliders and accuracy metrics (CPU only, no
//! Vulkan). The Stanford models are used when `../shared/models` holds them.

use drape::collider::voxel_spheres;
use drape::metrics::{Accuracy, TriangleBvh, accuracy};
use drape::{Error, Mesh};
use glam::{DVec3, Mat4, Vec3, Vec4};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/models/stanford-bunny.obj");
const DRAGON: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/models/stanford-dragon-res2.obj");

/// The model at `path`, or `None` (with a note) where this checkout has no models.
/// A model from `../shared/models`; a missing file fails the test, naming where it looked.
fn model(path: &str) -> Option<Mesh> {
    let path = Path::new(path);
    assert!(
        path.exists(),
        "{} not found: the model checks need ../shared/models beside the repository",
        path.display()
    );
    let start = Instant::now();
    let mesh = Mesh::load_obj(path).unwrap();
    eprintln!("load {}: {:.0} ms", path.display(), start.elapsed().as_secs_f64() * 1e3);
    Some(mesh)
}

/// Every directed edge once and its reverse once: closed, and consistently oriented.
fn assert_closed_and_oriented(mesh: &Mesh) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &count) in &directed {
        assert_eq!(count, 1, "directed edge {a}->{b} used {count} times");
        assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} is not shared by exactly 2 triangles");
    }
}

/// Positive for counter-clockwise-outward closed meshes.
fn signed_volume(mesh: &Mesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// The box [-h, h]^3 as 12 outward triangles: distances to it are known exactly.
fn cube(h: f32) -> Mesh {
    let v = (0..8).map(|i| Vec3::new([-h, h][i & 1], [-h, h][(i >> 1) & 1], [-h, h][(i >> 2) & 1])).collect();
    #[rustfmt::skip]
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    Mesh::from_parts(v, triangles).unwrap()
}

#[test]
fn icosphere_is_closed_outward_and_round() {
    for (radius, s) in [(1.0f32, 0u32), (2.0, 3), (0.5, 4)] {
        let mesh = Mesh::icosphere(radius, s);
        assert_eq!(mesh.triangles.len(), 20 * 4usize.pow(s));
        assert_eq!(mesh.vertices.len(), 10 * 4usize.pow(s) + 2);
        assert_closed_and_oriented(&mesh);
        for v in &mesh.vertices {
            assert!((v.length() - radius).abs() <= 1e-5 * radius, "vertex {v} off the sphere of radius {radius}");
        }
        let volume = signed_volume(&mesh);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * (radius as f64).powi(3);
        // An inscribed polyhedron: a little smaller, 40% at s = 0, under 1% from s = 3.
        let tolerance = if s == 0 { 0.4 } else { 0.01 };
        assert!(volume > 0.0 && volume < exact && volume > exact * (1.0 - tolerance), "s={s}: {volume} vs {exact}");
    }
}

#[test]
fn torus_is_closed_outward_and_has_the_right_tube() {
    let (big, small) = (1.0f32, 0.3f32);
    let mesh = Mesh::torus(big, small, 64, 32);
    assert_eq!(mesh.triangles.len(), 2 * 64 * 32);
    assert_eq!(mesh.vertices.len(), 64 * 32);
    assert_closed_and_oriented(&mesh);
    for v in &mesh.vertices {
        let tube = Vec3::new((v.x * v.x + v.z * v.z).sqrt() - big, v.y, 0.0).length();
        assert!((tube - small).abs() < 1e-5, "vertex {v} is {tube} from the tube centre");
    }
    let (min, max) = mesh.bounds();
    assert!((max.y - small).abs() < 1e-5 && (min.y + small).abs() < 1e-5, "the hole is along Y: {min} {max}");
    let volume = signed_volume(&mesh);
    let exact = 2.0 * std::f64::consts::PI.powi(2) * big as f64 * (small as f64).powi(2);
    assert!(volume > 0.0 && (volume / exact - 1.0).abs() < 0.01, "{volume} vs {exact}");
    // Too few segments are raised to 3, so the torus is still closed.
    assert_closed_and_oriented(&Mesh::torus(1.0, 0.2, 0, 1));
}

#[test]
fn rounded_box_is_closed_outward_and_round_at_its_edges() {
    let (half, radius) = (Vec3::new(0.3, 0.1, 0.2), 0.02f32);
    let mesh = Mesh::rounded_box(half, radius, 8, 0.05);
    assert_closed_and_oriented(&mesh);
    // Every vertex lies `radius` from the inner box.
    for v in &mesh.vertices {
        let off = (v.abs() - half).max(Vec3::ZERO).length();
        assert!((off - radius).abs() < 1e-5, "vertex {v} is {off} from the inner box");
    }
    let (min, max) = mesh.bounds();
    assert!((max - (half + radius)).abs().max_element() < 1e-6 && (min + max).abs().max_element() < 1e-6);
    // Box + slabs + quarter cylinders + eighth spheres (Steiner), less the flats' chords.
    let (h, r) = (half.as_dvec3(), radius as f64);
    let exact = 8.0 * h.x * h.y * h.z
        + 2.0 * r * 4.0 * (h.x * h.y + h.y * h.z + h.z * h.x)
        + std::f64::consts::PI * r * r * 2.0 * (h.x + h.y + h.z)
        + 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let volume = signed_volume(&mesh);
    assert!(volume > 0.0 && volume < exact && volume > exact * 0.999, "{volume} vs {exact}");
    // Flat in one axis (a plate with rounded rims) and without rounding (a box) stay closed.
    assert_closed_and_oriented(&Mesh::rounded_box(Vec3::new(0.3, 0.0, 0.2), radius, 4, 0.1));
    assert_closed_and_oriented(&Mesh::rounded_box(half, 0.0, 4, 0.1));
}

#[test]
fn transform_bounds_and_scene_placement() {
    let sphere = Mesh::icosphere(1.0, 2);
    let mirrored = sphere.transformed(Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    assert!(signed_volume(&mirrored) > 0.0, "a mirror keeps the triangles facing out");
    let moved = sphere.transformed(Mat4::from_scale_rotation_translation(
        Vec3::splat(2.0),
        glam::Quat::IDENTITY,
        Vec3::new(1.0, 2.0, 3.0),
    ));
    let (min, max) = moved.bounds();
    assert!((min - Vec3::new(-1.0, 0.0, 1.0)).abs().max_element() < 0.02, "{min}");
    assert!((max - Vec3::new(3.0, 4.0, 5.0)).abs().max_element() < 0.02, "{max}");

    // An unreferenced vertex does not count in the bounds.
    let mut with_stray = cube(1.0);
    with_stray.vertices.push(Vec3::splat(100.0));
    assert_eq!(with_stray.bounds(), (Vec3::splat(-1.0), Vec3::splat(1.0)));
    assert_eq!(Mesh::default().bounds(), (Vec3::ZERO, Vec3::ZERO));

    let placed = moved.transformed(Mat4::from_scale(Vec3::new(1.0, 1.0, 0.5))).normalized_for_scene(0.93);
    let (min, max) = placed.bounds();
    assert!(((max.x - min.x).max(max.z - min.z) - 0.93).abs() < 1e-5, "{min} {max}");
    assert!(min.y.abs() < 1e-6 && (min.x + max.x).abs() < 1e-5 && (min.z + max.z).abs() < 1e-5, "{min} {max}");
}

#[test]
fn from_parts_validates() {
    let ok = Mesh::from_parts(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    assert_eq!(ok.triangles.len(), 1);
    let cases = [
        (vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 3]], "refers to vertex 3"),
        (vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, f32::NAN, 0.0)], vec![[0, 1, 2]], "vertex 2 is not finite"),
        (vec![Vec3::ZERO], vec![], "no triangles"),
    ];
    for (vertices, triangles, expected) in cases {
        match Mesh::from_parts(vertices, triangles) {
            Err(e @ Error::Mesh { .. }) => {
                let message = e.to_string();
                assert!(message.contains("<memory>") && message.contains(expected), "{message}");
            }
            other => panic!("expected a mesh error with `{expected}`, got {other:?}"),
        }
    }
}

/// A temporary OBJ file, removed when dropped.
struct TempObj(PathBuf);

impl TempObj {
    fn new(name: &str, text: &str) -> TempObj {
        let path = std::env::temp_dir().join(format!("drape-mesh-test-{}-{name}.obj", std::process::id()));
        std::fs::write(&path, text).unwrap();
        TempObj(path)
    }
}

impl Drop for TempObj {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

#[test]
fn obj_loads_quads_negative_indices_slashes_and_objects() {
    let file = TempObj::new(
        "valid",
        "# a unit square (as a quad) and two triangles\n\
         v 0 0 0\n\
         v 1 0 0\n\
         v 1 0 1\n\
         v 0 0 1\n\
         vn 0 1 0\n\
         vt 0 0\n\
         vt 1 0\n\
         vt 1 1\n\
         f 1//1 2//1 3//1 4//1\n\
         o second\n\
         v 0 1 0   \n\
         f -4 -3 -1\n\
         g third\n\
         f 1/1/1 2/2/1 5/3/1\n",
    );
    let mesh = Mesh::load_obj(&file.0).unwrap();
    assert_eq!(mesh.triangles.len(), 4, "the quad is 2 triangles, plus 2");
    let corners = |t: usize| mesh.triangles[t].map(|i| mesh.vertices[i as usize]);
    let (v1, v2, v3, v4, v5) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z, Vec3::Y);
    let mut triangles: Vec<[Vec3; 3]> = (0..4).map(corners).collect();
    triangles.sort_by(|a, b| a.map(|v| v.to_array()).partial_cmp(&b.map(|v| v.to_array())).unwrap());
    let mut expected = vec![[v1, v2, v3], [v1, v3, v4], [v2, v3, v5], [v1, v2, v5]];
    expected.sort_by(|a, b| a.map(|v| v.to_array()).partial_cmp(&b.map(|v| v.to_array())).unwrap());
    assert_eq!(triangles, expected);
    assert_eq!(mesh.bounds(), (Vec3::ZERO, Vec3::ONE));
}

/// A closed cube exported for rendering: flat normals and texture coordinates per face (each
/// corner a different `v/vt/vn` triple, so a single-index loader makes 24 vertices) and two
/// materials (tobj splits objects there). As a collider it must load as the solid it is: 8
/// vertices, 12 triangles, closed; the negative zero of one corner is the same point.
#[test]
fn a_collider_exported_with_normals_and_materials_loads_closed() {
    let mut text = String::new();
    for x in ["-0.5", "0.5"] {
        for y in ["0", "1"] {
            for z in ["-0.5", "0.5"] {
                text += &format!("v {x} {y} {z}\n");
            }
        }
    }
    text += "v -0.5 -0.0 -0.5\n"; // vertex 1 again (y = -0 is +0)
    text += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
    let faces = [[1, 2, 4, 3], [5, 7, 8, 6], [1, 5, 6, 2], [3, 4, 8, 7], [1, 3, 7, 5], [2, 6, 8, 4]];
    for (f, face) in faces.iter().enumerate() {
        text += &format!("vn {f} 1 0\n");
        if f == 3 {
            text += "usemtl second\n";
        }
        let corners: Vec<String> = face.iter().enumerate().map(|(k, v)| format!("{v}/{}/{}", k + 1, f + 1)).collect();
        text += &format!("f {}\n", corners.join(" "));
    }
    // A face through the copy of vertex 1 with -0.0: welded, it has vertex 1 twice: dropped.
    text += "f 1 9 2\n";
    let file = TempObj::new("cube-with-seams", &text);
    let mesh = Mesh::load_obj(&file.0).unwrap();
    assert_eq!((mesh.vertices.len(), mesh.triangles.len()), (8, 12), "{:?}", mesh.vertices);
    assert!(drape::topology::is_closed(&mesh), "the cube must load closed");
    assert_eq!(drape::topology::boundary_edge_count(&mesh), 0);
    assert_closed_and_oriented(&mesh);
    // The weld itself: a split vertex joins its first copy, in order.
    let split =
        Mesh { vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X, Vec3::Z], triangles: vec![[0, 1, 2], [3, 4, 2]] };
    let (welded, joined) = split.weld_coincident();
    assert_eq!(joined, 1);
    assert_eq!(welded.vertices, vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z]);
    assert_eq!(welded.triangles, vec![[0, 1, 2], [1, 3, 2]]);
    // Built by hand with a bad index: that triangle is dropped, nothing panics.
    let bad = Mesh { vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y], triangles: vec![[0, 1, 2], [0, 1, 7]] };
    assert_eq!(bad.weld_coincident().0.triangles, vec![[0, 1, 2]]);
}

/// Loads `text` and checks that the error names the file, the line (if any) and `expected`.
fn assert_obj_error(name: &str, text: &str, line: Option<usize>, expected: &str) {
    let file = TempObj::new(name, text);
    let error = Mesh::load_obj(&file.0).expect_err(name);
    assert!(matches!(error, Error::Mesh { .. }), "{name}: {error:?}");
    let message = error.to_string();
    assert!(message.contains(&file.0.display().to_string()), "{name}: `{message}` does not name the file");
    if let Some(line) = line {
        assert!(message.contains(&format!("line {line}:")), "{name}: `{message}` does not name line {line}");
    }
    assert!(message.contains(expected), "{name}: `{message}` does not say `{expected}`");
    eprintln!("{name}: {message}");
}

#[test]
fn obj_errors_name_the_file_and_line() {
    let head = "# header\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    assert_obj_error("malformed", &format!("{head}v 1 2\nf 1 2 3\n"), Some(5), "`v 1 2`");
    assert_obj_error("word", &format!("{head}v 1 two 3\nf 1 2 3\n"), Some(5), "cannot parse coordinate `two`");
    assert_obj_error("nan", &format!("{head}f 1 2 3\nv 1 nan 2\n"), Some(6), "not finite");
    assert_obj_error("huge", &format!("{head}v 1 1e39 2\nf 1 2 3\n"), Some(5), "`1e39` is beyond f32's range");
    assert_obj_error("inf", &format!("{head}v 1 inf 2\nf 1 2 3\n"), Some(5), "`inf` is not finite");
    assert_obj_error("line", "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n", None, "its corners on one line");
    assert_obj_error("range", &format!("{head}f 1 2 7\n"), Some(5), "index 7 is out of range");
    assert_obj_error("relative", &format!("{head}f -1 -2 -4\n"), Some(5), "index -4 is out of range");
    assert_obj_error("zero", &format!("{head}f 0 1 2\n"), Some(5), "index 0");
    assert_obj_error("two", &format!("{head}f 1 2\n"), Some(5), "at least 3 vertices");
    assert_obj_error("corner", &format!("{head}f 1 2/x 3\n"), Some(5), "`x`");
    assert_obj_error("normal", &format!("{head}vn 0 1 0\nf 1//1 2//1 3//2\n"), Some(6), "normal index 2");
    // A corner that refers to texture coordinates or normals the file never defines: tobj
    // would drop the index, and a cloth its UVs, without a word.
    assert_obj_error("no vt", &format!("{head}f 1/1 2/2 3/3\n"), Some(5), "texture coordinate 1, but no `vt` line");
    assert_obj_error("no vn", &format!("{head}f 1//1 2//1 3//1\n"), Some(5), "normal 1, but no `vn` line");
    assert_obj_error("noface", head, None, "no triangles");
    assert_obj_error("empty", "", None, "no triangles");

    // A comment after a line's values is cut off (some exporters write them); errors keep their
    // line numbers.
    let commented = TempObj::new("commented", "# head\nv 0 0 0 # first\nv 1 0 0\nv 0 1 0#x\nf 1 2 3 # face\n");
    assert_eq!(Mesh::load_obj(&commented.0).unwrap().triangles, vec![[0, 1, 2]]);
    assert_obj_error("comment", &format!("{head}# note\nf 1 2 9 # bad\n"), Some(6), "index 9 is out of range");
    // On a name line `#` is part of the name (a colour as a material name).
    let named = TempObj::new("named", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl #ff0000\nf 1 2 3\n");
    assert_eq!(Mesh::load_obj(&named.0).unwrap().triangles, vec![[0, 1, 2]]);

    // Windows line endings are fine; bytes that are not UTF-8 are an error, not a panic.
    let crlf = TempObj::new("crlf", "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n");
    assert_eq!(Mesh::load_obj(&crlf.0).unwrap().triangles, vec![[0, 1, 2]]);
    let binary = TempObj::new("binary", "");
    std::fs::write(&binary.0, b"v 0 0 0\n\xff\xfe\n").unwrap();
    let error = Mesh::load_obj(&binary.0).expect_err("binary");
    assert!(error.to_string().contains("not UTF-8"), "{error}");

    let missing = std::env::temp_dir().join(format!("drape-mesh-test-{}-missing.obj", std::process::id()));
    let error = Mesh::load_obj(&missing).expect_err("missing file");
    assert!(matches!(error, Error::Mesh { .. }) && error.to_string().contains(&missing.display().to_string()));
    assert!(error.to_string().contains("cannot read"), "{error}");
}

#[test]
fn real_models_load_with_their_published_sizes() {
    if let Some(bunny) = model(BUNNY) {
        assert_eq!(bunny.triangles.len(), 69_451);
        assert_eq!(bunny.vertices.len(), 35_947 - 1_113, "tobj keeps only the vertices faces use");
        let (min, max) = bunny.bounds();
        let (readme_min, readme_max) =
            (Vec3::new(-0.094690, 0.032987, -0.061874), Vec3::new(0.061009, 0.187321, 0.058800));
        assert!((min - readme_min).abs().max_element() < 1e-6, "{min}");
        assert!((max - readme_max).abs().max_element() < 1e-6, "{max}");
        assert!(signed_volume(&bunny) > 0.0);
        let placed = bunny.normalized_for_scene(0.93);
        let (min, max) = placed.bounds();
        let scale = 0.93 / (readme_max.x - readme_min.x);
        assert!((scale - 5.97).abs() < 0.01, "the bunny is scaled about x6: {scale}");
        assert!(((max.x - min.x) - 0.93).abs() < 1e-5 && min.y.abs() < 1e-6, "{min} {max}");
    }
    if let Some(dragon) = model(DRAGON) {
        assert_eq!(dragon.triangles.len(), 202_520);
        let (min, max) = dragon.bounds();
        assert!((min - Vec3::new(-0.108188, 0.052739, -0.050345)).abs().max_element() < 1e-6, "{min}");
        assert!((max - Vec3::new(0.096406, 0.197139, 0.041137)).abs().max_element() < 1e-6, "{max}");
    }
}

/// Points spread over every triangle: barycentric steps of 1/`per_edge`.
fn surface_samples(mesh: &Mesh, per_edge: u32) -> impl Iterator<Item = Vec3> + '_ {
    mesh.triangles.iter().flat_map(move |t| {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        (0..=per_edge).flat_map(move |i| {
            (0..=per_edge - i).map(move |j| {
                let (u, v) = (i as f32 / per_edge as f32, j as f32 / per_edge as f32);
                a + (b - a) * u + (c - a) * v
            })
        })
    })
}

/// Every surface sample lies in some sphere (|p - c| <= r (1 + 1e-5)). The spheres are looked up
/// through a uniform grid over the mesh's bounds, independent of the collider's own voxels.
fn assert_covered(spheres: &[Vec4], mesh: &Mesh, per_edge: u32, what: &str) {
    const M: usize = 24;
    let (lo, hi) = mesh.bounds();
    let size = (hi - lo).max(Vec3::splat(1e-6));
    let cell = |p: Vec3| ((p - lo) / size * M as f32).floor().clamp(Vec3::ZERO, Vec3::splat((M - 1) as f32));
    let mut cells = vec![Vec::new(); M * M * M];
    for (k, s) in spheres.iter().enumerate() {
        let (a, b) = (cell(s.truncate() - s.w), cell(s.truncate() + s.w));
        for z in a.z as usize..=b.z as usize {
            for y in a.y as usize..=b.y as usize {
                for x in a.x as usize..=b.x as usize {
                    cells[x + M * (y + M * z)].push(k);
                }
            }
        }
    }
    let mut count = 0usize;
    for p in surface_samples(mesh, per_edge) {
        let c = cell(p);
        let list = &cells[c.x as usize + M * (c.y as usize + M * c.z as usize)];
        let inside = |&k: &usize| spheres[k].truncate().distance(p) <= spheres[k].w * (1.0 + 1e-5);
        assert!(list.iter().any(inside), "{what}: surface point {p} is in no sphere");
        count += 1;
    }
    assert!(count > 0);
}

#[test]
fn one_voxel_is_one_sphere_around_everything() {
    let mesh = Mesh::torus(1.0, 0.25, 24, 12).transformed(Mat4::from_translation(Vec3::new(5.0, -1.0, 2.0)));
    let spheres = voxel_spheres(&mesh, 1).unwrap();
    assert_eq!(spheres.len(), 1);
    let s = spheres[0];
    for v in &mesh.vertices {
        assert!(v.distance(s.truncate()) <= s.w, "{v} outside {s}");
    }
    // Centre of the bounds, radius to the farthest vertex (a corner region of the torus).
    assert!((s.truncate() - Vec3::new(5.0, -1.0, 2.0)).length() < 1e-5, "{s}");
    assert!((s.w - 1.25).abs() < 1e-3, "{s}");
}

#[test]
fn spheres_cover_the_whole_surface() {
    let sphere = Mesh::icosphere(1.0, 3);
    for n in [1, 3, 5, 16] {
        let spheres = voxel_spheres(&sphere, n).unwrap();
        assert!(spheres.len() <= (n * n * n) as usize);
        assert_covered(&spheres, &sphere, 10, &format!("icosphere n={n}"));
        assert_eq!(spheres, voxel_spheres(&sphere, n).unwrap(), "deterministic");
    }
    if let Some(bunny) = model(BUNNY) {
        for n in [1, 3, 5, 16] {
            let start = Instant::now();
            let spheres = voxel_spheres(&bunny, n).unwrap();
            let elapsed = start.elapsed();
            eprintln!("bunny n={n}: {} spheres in {:.1} ms", spheres.len(), elapsed.as_secs_f64() * 1e3);
            assert_covered(&spheres, &bunny, 10, &format!("bunny n={n}"));
        }
    }
}

/// Separating-axis test of a triangle against a closed box (Akenine-Möller 2001).
fn triangle_meets_box(tri: [DVec3; 3], lo: DVec3, hi: DVec3) -> bool {
    let (centre, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let v = tri.map(|p| p - centre);
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let mut axes = vec![DVec3::X, DVec3::Y, DVec3::Z, edges[0].cross(edges[1])];
    for e in edges {
        axes.extend([DVec3::X.cross(e), DVec3::Y.cross(e), DVec3::Z.cross(e)]);
    }
    axes.into_iter().filter(|a| a.length_squared() > 0.0).all(|axis| {
        let p = v.map(|x| x.dot(axis));
        let r = half.dot(axis.abs());
        p.iter().copied().fold(f64::INFINITY, f64::min) <= r
            && p.iter().copied().fold(f64::NEG_INFINITY, f64::max) >= -r
    })
}

#[test]
fn long_triangles_get_spheres_in_voxels_without_vertices() {
    // One big triangle spanning its own bounding box: n = 8 cuts it into many pieces, most of
    // them in voxels that hold none of its 3 vertices (the paper's vertex-only spheres miss them).
    let tri = [Vec3::new(0.0, 0.13, 0.0), Vec3::new(1.0, 0.0, 0.71), Vec3::new(0.37, 1.0, 1.0)];
    let mesh = Mesh::from_parts(tri.to_vec(), vec![[0, 1, 2]]).unwrap();
    let n = 8;
    let spheres = voxel_spheres(&mesh, n).unwrap();
    assert_eq!(mesh.bounds(), (Vec3::ZERO, Vec3::ONE), "the voxels are cubes of 1/8");
    let t = tri.map(|p| p.as_dvec3());
    let mut crossed = 0;
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let lo = DVec3::new(x as f64, y as f64, z as f64) / n as f64;
                crossed += triangle_meets_box(t, lo, lo + 1.0 / n as f64) as usize;
            }
        }
    }
    let vertex_voxels = 3;
    assert!(crossed > 4 * vertex_voxels, "the triangle crosses {crossed} voxels");
    assert_eq!(spheres.len(), crossed, "one sphere per voxel the triangle crosses");
    assert_covered(&spheres, &mesh, 200, "long triangle");
    // Each sphere holds only its voxel's piece: no radius beyond the voxel's half diagonal.
    let half_diagonal = 3f32.sqrt() / (2.0 * n as f32);
    assert!(spheres.iter().all(|s| s.w <= half_diagonal * 1.001), "{spheres:?}");

    // Two long thin triangles (a strip) across the whole box.
    let strip = Mesh::from_parts(
        vec![Vec3::ZERO, Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.02, 0.0, 0.0), Vec3::new(1.0, 0.98, 1.0)],
        vec![[0, 2, 1], [2, 3, 1]],
    )
    .unwrap();
    let spheres = voxel_spheres(&strip, 16).unwrap();
    assert!(spheres.len() >= 16, "{} spheres along the diagonal", spheres.len());
    assert_covered(&spheres, &strip, 400, "strip");
}

#[test]
fn flat_meshes_and_bad_input() {
    // A 1 m square in the XZ plane: one layer of voxels, all n x n of them.
    let square = Mesh::from_parts(
        vec![Vec3::new(0.0, 0.5, 0.0), Vec3::new(1.0, 0.5, 0.0), Vec3::new(1.0, 0.5, 1.0), Vec3::new(0.0, 0.5, 1.0)],
        vec![[0, 2, 1], [0, 3, 2]],
    )
    .unwrap();
    for n in [1, 4, 7] {
        let spheres = voxel_spheres(&square, n).unwrap();
        assert_eq!(spheres.len(), (n * n) as usize, "n={n}");
        assert_covered(&spheres, &square, 50, &format!("square n={n}"));
        let half_diagonal = 2f32.sqrt() / (2.0 * n as f32);
        assert!(spheres.iter().all(|s| (s.y - 0.5).abs() < 1e-4 && s.w <= half_diagonal * 1.001), "{spheres:?}");
    }
    // A single point (every triangle degenerate) still gets a sphere.
    let point = Mesh::from_parts(vec![Vec3::ONE; 3], vec![[0, 1, 2]]).unwrap();
    let spheres = voxel_spheres(&point, 4).unwrap();
    assert_eq!(spheres.len(), 1);
    assert!(spheres[0].truncate() == Vec3::ONE && spheres[0].w >= 0.0);

    for n in [0, 257] {
        assert!(matches!(voxel_spheres(&square, n), Err(Error::InvalidParameter { name: "n", .. })), "n={n}");
    }
    let broken = Mesh { vertices: vec![Vec3::ZERO], triangles: vec![[0, 0, 5]] };
    assert!(matches!(voxel_spheres(&broken, 2), Err(Error::Mesh { .. })));
    assert!(matches!(voxel_spheres(&Mesh::default(), 2), Err(Error::Mesh { .. })));
}

/// Distance from `p` to the mesh by testing every triangle, in f64 and by another method than
/// the library's (projection onto the plane, else the nearest edge): what the BVH must reproduce.
fn brute_force_distance(mesh: &Mesh, p: Vec3) -> f32 {
    let p = p.as_dvec3();
    let segment = |a: DVec3, b: DVec3| {
        let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
        (a + (b - a) * t).distance(p)
    };
    let triangle = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize].as_dvec3());
        let n = (b - a).cross(c - a);
        let q = p - n * ((p - a).dot(n) / n.length_squared());
        if [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| (v - u).cross(q - u).dot(n) >= 0.0) {
            q.distance(p)
        } else {
            segment(a, b).min(segment(b, c)).min(segment(c, a))
        }
    };
    mesh.triangles.iter().map(triangle).fold(f64::INFINITY, f64::min) as f32
}

/// Deterministic pseudo-random points in a box (no rand dependency).
fn points_in(lo: Vec3, hi: Vec3, count: usize, seed: u64) -> Vec<Vec3> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..count).map(|_| lo + (hi - lo) * Vec3::new(next(), next(), next())).collect()
}

#[test]
fn closest_point_and_inside_on_a_sphere() {
    let mesh = Mesh::icosphere(1.0, 4);
    let bvh = TriangleBvh::new(&mesh);
    assert_eq!(bvh.len(), mesh.triangles.len());
    let (d, q) = bvh.closest_point(Vec3::new(0.0, 2.0, 0.0));
    assert!((d - 1.0).abs() < 2e-3 && (q - Vec3::Y).length() < 0.05, "{d} {q}");
    assert!((d - q.distance(Vec3::new(0.0, 2.0, 0.0))).abs() < 1e-6);
    let (d, _) = bvh.closest_point(Vec3::new(0.0, 0.5, 0.0));
    assert!((d - 0.5).abs() < 2e-3, "{d}");
    assert!(bvh.is_inside(Vec3::new(0.0, 0.5, 0.0)));
    assert!(bvh.is_inside(Vec3::ZERO));
    assert!(!bvh.is_inside(Vec3::new(3.0, 0.0, 0.0)));
    assert!((bvh.closest_point(Vec3::new(3.0, 0.0, 0.0)).0 - 2.0).abs() < 2e-3);

    for p in points_in(Vec3::splat(-1.5), Vec3::splat(1.5), 300, 7) {
        let (d, q) = bvh.closest_point(p);
        assert!((d - brute_force_distance(&mesh, p)).abs() < 2e-6, "{p}");
        assert!((q.distance(p) - d).abs() < 1e-5);
        // The icosphere is within 1.2e-3 of the unit sphere.
        let r = p.length();
        assert!((d - (r - 1.0).abs()).abs() < 2e-3, "{p}: {d}");
        if (r - 1.0).abs() > 0.01 {
            assert_eq!(bvh.is_inside(p), r < 1.0, "{p}");
        }
    }
    let empty = TriangleBvh::new(&Mesh::default());
    assert!(empty.is_empty() && !empty.is_inside(Vec3::ZERO) && empty.closest_point(Vec3::ONE).0.is_infinite());
}

#[test]
fn closest_point_on_a_cube_and_a_torus_is_exact() {
    let box_mesh = cube(1.0);
    assert_closed_and_oriented(&box_mesh);
    assert!((signed_volume(&box_mesh) - 8.0).abs() < 1e-9);
    let bvh = TriangleBvh::new(&box_mesh);
    let cases = [
        (Vec3::new(0.2, 0.9, -0.3), 0.1, true),
        (Vec3::new(3.0, 0.5, 0.5), 2.0, false),
        (Vec3::new(2.0, 2.0, 1.0), 2f32.sqrt(), false), // an edge
        (Vec3::new(2.0, 2.0, 2.0), 3f32.sqrt(), false), // a corner
        (Vec3::new(-0.5, -0.5, -0.95), 0.05, true),
    ];
    for (p, distance, inside) in cases {
        assert!((bvh.closest_point(p).0 - distance).abs() < 1e-6, "{p}");
        assert_eq!(bvh.is_inside(p), inside, "{p}");
    }
    // A torus: inside the tube but not in the hole.
    let torus = TriangleBvh::new(&Mesh::torus(1.0, 0.3, 48, 24));
    assert!(torus.is_inside(Vec3::new(1.0, 0.0, 0.0)) && torus.is_inside(Vec3::new(0.0, 0.1, -1.1)));
    assert!(!torus.is_inside(Vec3::ZERO) && !torus.is_inside(Vec3::new(0.0, 0.5, 1.0)));
    // A degenerate triangle (a segment) has a closest point too.
    let segment = Mesh::from_parts(vec![Vec3::ZERO, Vec3::X, Vec3::X], vec![[0, 1, 2]]).unwrap();
    let (d, q) = TriangleBvh::new(&segment).closest_point(Vec3::new(0.5, 1.0, 0.0));
    assert!((d - 1.0).abs() < 1e-6 && (q - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6, "{d} {q}");
}

/// A 10 x 20 grid over the top of the cube [-1, 1]^3 (cols along x, rows along z, 0.05 apart):
/// row 0 well above (y = 1.5), rows 1-4 just above (y = 1.005), rows 5-9 inside (y = 0.98,
/// two particles deeper at y = 0.9 and 0.8).
fn cube_top_grid() -> (u32, u32, Vec<Vec4>) {
    let (rows, cols) = (10u32, 20u32);
    let mut positions = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let y = match r {
                0 => 1.5,
                1..=4 => 1.005,
                _ => 0.98,
            };
            positions.push(Vec4::new(-0.5 + 0.05 * c as f32, y, -0.5 + 0.05 * r as f32, 1.0));
        }
    }
    positions[7 * 20 + 3].y = 0.9;
    positions[9 * 20 + 11].y = 0.8;
    (rows, cols, positions)
}

#[test]
fn accuracy_counts_what_was_constructed() {
    let bvh = TriangleBvh::new(&cube(1.0));
    let (rows, cols, positions) = cube_top_grid();
    // One big sphere whose top is at y = 1.003 near the axis: the particles at y = 1.005 are
    // 0.002-0.0045 m from it (within thickness), those at 1.5 are ~0.5 m away.
    let mut spheres = vec![Vec4::new(0.0, -100.0, 0.0, 101.003)];
    let thickness = 0.01;
    let measure = |spheres: &[Vec4]| accuracy(&bvh, spheres, thickness, rows, cols, 0.05, 0.05, &positions);
    let a = measure(&spheres);
    let close = |x: f32, y: f32| (x - y).abs() < 1e-5;
    assert_eq!(a.particles, 200);
    assert!(a.all_finite);
    assert_eq!(a.inside_fraction, 0.5);
    assert!(close(a.max_penetration, 0.2), "{a:?}");
    // Nearest rank 198 of 200: 100 zeros, 98 x 0.02, then 0.1 and 0.2.
    assert!(close(a.p99_penetration, 0.02), "{a:?}");
    assert_eq!(a.within_thickness_fraction, 0.4, "the 80 particles 5 mm above the top");
    assert_eq!(a.resting, 80);
    assert!(close(a.gap_mean, 0.005) && close(a.gap_max, 0.005), "{a:?}");
    // Column springs are at rest; row springs between y levels are stretched: row 0 -> 1 spans
    // 0.495 in y and 0.05 in z, the deepest particle's row spring to row 8 spans 0.18 in y.
    let top = (0.495f32 * 0.495 + 0.05 * 0.05).sqrt() / 0.05;
    assert!(close(a.max_stretch, top), "{a:?} vs {top}");
    // 370 springs, nearest rank 367 (the 4th largest): the 20 row-0 springs are the largest.
    assert!(close(a.p99_stretch, top), "{a:?}");

    // Many spheres (a BVH over them instead of a loop): the same numbers.
    spheres.extend((0..100).map(|i| Vec4::new(10.0 + i as f32, -50.0, 0.0, 0.1)));
    assert_eq!(measure(&spheres), a);
    // No collider: nothing rests on it.
    let bare = measure(&[]);
    assert_eq!((bare.resting, bare.gap_mean, bare.gap_max), (0, 0.0, 0.0));
    // The mesh's own triangles as the collider: the 80 particles within the thickness of the
    // true surface rest on it, 5 mm off; everything else is as before.
    let on_surface = drape::metrics::accuracy_on_triangles(&bvh, thickness, (rows, cols, 0.05, 0.05), &positions);
    assert_eq!(on_surface.resting, 80);
    assert!(close(on_surface.gap_mean, 0.005) && close(on_surface.gap_max, 0.005), "{on_surface:?}");
    assert_eq!((on_surface.inside_fraction, on_surface.max_stretch), (a.inside_fraction, a.max_stretch));
}

#[test]
fn stretch_percentile_and_non_finite_particles() {
    let bvh = TriangleBvh::new(&cube(1.0));
    let (rows, cols) = (11u32, 11u32);
    let mut positions: Vec<Vec4> =
        (0..rows * cols).map(|i| Vec4::new(0.1 * (i % cols) as f32, 5.0, 0.1 * (i / cols) as f32, 1.0)).collect();
    positions[10].x += 0.05; // row 0, col 10: its column spring 0.15, its row spring 0.1118
    let a = accuracy(&bvh, &[], 0.01, rows, cols, 0.1, 0.1, &positions);
    // 220 springs, nearest rank 218: the two stretched ones are above it.
    assert!((a.max_stretch - 1.5).abs() < 1e-5 && (a.p99_stretch - 1.0).abs() < 1e-5, "{a:?}");
    assert_eq!((a.inside_fraction, a.within_thickness_fraction, a.max_penetration), (0.0, 0.0, 0.0));

    positions[60].y = f32::NAN;
    let a = accuracy(&bvh, &[], 0.01, rows, cols, 0.1, 0.1, &positions);
    assert!(!a.all_finite && a.max_stretch.is_infinite(), "{a:?}");
    let empty = Accuracy { all_finite: true, inside_defined: true, ..Default::default() };
    assert_eq!(accuracy(&bvh, &[], 0.01, 0, 0, 0.1, 0.1, &[]), empty);
}

#[test]
fn model_timings() {
    for (name, path) in [("bunny", BUNNY), ("dragon", DRAGON)] {
        let Some(mesh) = model(path) else { continue };
        // Closed, so that inside is defined (the bunny has five holes in its base).
        let mesh = mesh.normalized_for_scene(0.93).close_small_holes().0;
        let start = Instant::now();
        let spheres = voxel_spheres(&mesh, 64).unwrap();
        eprintln!("{name}: voxel_spheres n=64: {} spheres in {:.0} ms", spheres.len(), ms(start));
        assert_covered(&spheres, &mesh, 3, &format!("{name} n=64"));
        let start = Instant::now();
        let finest = voxel_spheres(&mesh, 256).unwrap();
        eprintln!("{name}: voxel_spheres n=256: {} spheres in {:.0} ms", finest.len(), ms(start));
        let start = Instant::now();
        let bvh = TriangleBvh::new(&mesh);
        eprintln!("{name}: TriangleBvh::new ({} triangles): {:.0} ms", bvh.len(), ms(start));
        // A 64 x 64 cloth over the model at pseudo-random heights through it.
        let (lo, hi) = mesh.bounds();
        let heights = points_in(Vec3::ZERO, Vec3::ONE, 4096, 11);
        let positions: Vec<Vec4> = (0..4096)
            .map(|i| {
                let (r, c) = ((i / 64) as f32 / 63.0, (i % 64) as f32 / 63.0);
                Vec3::new(lo.x + (hi.x - lo.x) * c, lo.y + (hi.y - lo.y) * heights[i].y, lo.z + (hi.z - lo.z) * r)
                    .extend(1.0)
            })
            .collect();
        let start = Instant::now();
        let a = accuracy(&bvh, &spheres, 0.005, 64, 64, (hi.x - lo.x) / 63.0, (hi.z - lo.z) / 63.0, &positions);
        eprintln!("{name}: accuracy (4096 particles, {} spheres): {:.0} ms: {a:?}", spheres.len(), ms(start));
        assert!(a.all_finite && a.inside_fraction > 0.05 && a.inside_fraction < 0.95, "{a:?}");
    }
}

fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Points just off the surface of the real models, along each face normal: outside in front of
/// the face, inside behind it. The dragon's back-to-back duplicate faces ("fins") have no inside
/// and are skipped; its other decimation defects make a few more ambiguous, so a high share, not
/// all, must agree.
#[test]
fn inside_test_agrees_with_face_normals_on_the_models() {
    for (name, path) in [("bunny", BUNNY), ("dragon", DRAGON)] {
        let Some(mesh) = model(path) else { continue };
        let bvh = TriangleBvh::new(&mesh);
        let (mut right, mut total) = (0usize, 0usize);
        let mut copies: HashMap<[u32; 3], usize> = HashMap::new();
        for t in &mesh.triangles {
            let mut key = *t;
            key.sort_unstable();
            *copies.entry(key).or_default() += 1;
        }
        for t in mesh.triangles.iter().step_by(37) {
            let mut key = *t;
            key.sort_unstable();
            if copies[&key] > 1 {
                continue;
            }
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            let normal = (b - a).cross(c - a).normalize();
            let centre = (a + b + c) / 3.0;
            let offset = 1e-4; // 0.1 mm, well under the 1 mm edges
            right += (!bvh.is_inside(centre + normal * offset)) as usize;
            right += bvh.is_inside(centre - normal * offset) as usize;
            total += 2;
        }
        let share = right as f64 / total as f64;
        eprintln!("{name}: inside/outside agrees with the face normal for {right} of {total} points ({share:.4})");
        // Measured: bunny 100%, dragon 99.8% (the misses sit on faces the res2 decimation turned
        // inside out or folded against a neighbour: both probe points land on the same side).
        let least = if name == "bunny" { 0.999 } else { 0.995 };
        assert!(share >= least, "{name}: {share}");
    }
}

/// Both OBJ loaders (the collider's `Mesh::load_obj`, the cloth's `ClothMesh::load_obj`) on
/// 1500 random mutations of a valid file (bytes flipped, dropped, inserted from OBJ's own
/// alphabet, cut short): each answer is a mesh or an error, never a panic.
#[test]
fn mangled_obj_files_are_errors_not_panics() {
    let valid = "# quad\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\n\
                 f 1/1/1 2/2/1 3/3/1 4/4/1\nf -4/-4 -2/-2 -1/-1\no part\nusemtl none\n";
    let path = std::env::temp_dir().join(format!("drape-obj-fuzz-{}.obj", std::process::id()));
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let alphabet = b"vtnfo/ -0123456789.e#\n\t+";
    let (mut loaded, mut rejected) = (0, 0);
    for _ in 0..1500 {
        let mut bytes = valid.as_bytes().to_vec();
        for _ in 0..1 + next() % 5 {
            if bytes.is_empty() {
                break;
            }
            let at = (next() % bytes.len() as u64) as usize;
            match next() % 4 {
                0 => bytes[at] = alphabet[(next() % alphabet.len() as u64) as usize],
                1 => {
                    bytes.remove(at);
                }
                2 => bytes.insert(at, alphabet[(next() % alphabet.len() as u64) as usize]),
                _ => bytes.truncate(at),
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        for ok in [drape::Mesh::load_obj(&path).is_ok(), drape::ClothMesh::load_obj(&path).is_ok()] {
            if ok { loaded += 1 } else { rejected += 1 }
        }
    }
    std::fs::remove_file(&path).ok();
    assert!(
        loaded > 0 && rejected > 0,
        "the mutations must reach both outcomes ({loaded} loaded, {rejected} rejected)"
    );
}
