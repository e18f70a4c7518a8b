//! Triangle meshes: OBJ loading with line-numbered diagnostics, procedural shapes (icosphere,
//! torus) and the benchmark placement of a model in the scene.
// The OBJ line scanner is only used by `load_obj` (feature `obj`).
#![cfg_attr(not(feature = "obj"), allow(dead_code, unused_imports))]

use crate::error::{Error, Result};
use glam::{Mat4, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A triangle mesh (world units: metres, +Y up).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    /// Counter-clockwise seen from outside, for closed meshes.
    pub triangles: Vec<[u32; 3]>,
}

/// The `path` that errors about meshes built in memory (not read from a file) carry.
const MEMORY: &str = "<memory>";

/// Subdivision levels above this are clamped: level 8 is already 1,310,720 triangles, and each
/// level multiplies the count by 4 (level 16 would not fit in memory).
const MAX_ICOSPHERE_SUBDIVISIONS: u32 = 8;

/// Segment counts above this are clamped so a torus stays below ~8.4 M triangles.
/// The most segments `Mesh::rounded_box` takes for a quarter round.
const MAX_ROUNDED_SEGMENTS: u32 = 512;
/// The most squares `Mesh::rounded_box` takes across a flat face.
const MAX_ROUNDED_FLAT: u32 = 4096;
const MAX_TORUS_SEGMENTS: u32 = 2048;

impl Mesh {
    /// Loads a Wavefront OBJ (triangulated, positions only; normals, texture coordinates, groups
    /// and materials are ignored, all objects are merged into one mesh, and vertices at the same
    /// position are joined: `weld_coincident`).
    ///
    /// The file is first scanned line by line so that a bad `v` or `f` line is reported with its
    /// line number (tobj alone only says "face parse error"): unparsable, missing or non-finite
    /// coordinates, a face index that is 0 or refers to a vertex not defined above the line
    /// (negative indices count back from the last vertex), faces with fewer than 3 vertices.
    /// Only then does tobj parse the same text. Every failure is `Error::Mesh` naming the file.
    /// Needs the `obj` feature (on by default).
    #[cfg(feature = "obj")]
    pub fn load_obj(path: &Path) -> Result<Mesh> {
        let error = |problem: String| Error::Mesh { path: path.to_path_buf(), problem };
        let text = read_obj_text(path)?;
        // `load_obj_buf` on the text already read: one read, so the scan and the parse see the
        // same bytes; `mtllib` lines load nothing (materials are not used).
        let options = tobj::LoadOptions { triangulate: true, single_index: true, ..tobj::GPU_LOAD_OPTIONS };
        let (models, _materials) =
            tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| Ok((Vec::new(), Default::default())))
                .map_err(|e| error(format!("tobj could not parse it: {e}")))?;
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for model in &models {
            let m = &model.mesh;
            let (positions, rest) = m.positions.as_chunks::<3>();
            let (indices, rest_indices) = m.indices.as_chunks::<3>();
            if !rest.is_empty() || !rest_indices.is_empty() {
                return Err(error(format!("object `{}`: tobj returned incomplete triangles", model.name)));
            }
            let offset = u32::try_from(vertices.len()).map_err(|_| error("more than 4,294,967,295 vertices".into()))?;
            vertices.extend(positions.iter().map(|&p| Vec3::from_array(p)));
            for t in indices {
                let shifted = t.map(|i| i.checked_add(offset));
                match shifted {
                    [Some(a), Some(b), Some(c)] => triangles.push([a, b, c]),
                    _ => return Err(error("more than 4,294,967,295 vertices".into())),
                }
            }
        }
        validate(&vertices, &triangles).map_err(error)?;
        let (mesh, _joined) = Mesh { vertices, triangles }.weld_coincident();
        if !mesh.triangles.iter().any(|&t| spans_area(&mesh.vertices, t)) {
            return Err(error(
                "no triangles with area: every face has two corners at the same point or its corners on one line"
                    .into(),
            ));
        }
        Ok(mesh)
    }

    /// The mesh with vertices at exactly the same position joined into one (the first, in
    /// order) and the triangles that then have a corner twice (no area, no normal), or that
    /// refer to no vertex, dropped; returns it and how many vertices were joined into others.
    ///
    /// A mesh exported for rendering repeats a vertex wherever its normal or texture
    /// coordinates change (a flat-shaded cube has 24 vertices, a textured model splits along
    /// its UV seams), and tobj splits at every material change: as a collider it would have
    /// open seams, so no inside (`topology::is_closed`), holes to close where there are none,
    /// and its features twice. `load_obj` welds; `from_parts` takes the mesh as given.
    pub fn weld_coincident(&self) -> (Mesh, usize) {
        let (remap, joined) = coincident_map(&self.vertices);
        let vertices = welded_vertices(&self.vertices, &remap);
        let triangles = self.triangles.iter().filter_map(|t| welded_triangle(&remap, *t)).collect();
        (Mesh { vertices, triangles }, joined)
    }

    /// A mesh from vertices and triangles, checked: at least one triangle, every index in
    /// range, every vertex finite. Errors are `Error::Mesh` with the path `<memory>`.
    pub fn from_parts(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh> {
        validate(&vertices, &triangles).map_err(|problem| Error::Mesh { path: PathBuf::from(MEMORY), problem })?;
        Ok(Mesh { vertices, triangles })
    }

    /// A sphere of `radius` around the origin: an icosahedron whose triangles are split in 4
    /// `subdivisions` times (20 * 4^s triangles), vertices pushed out to the sphere. Closed,
    /// counter-clockwise seen from outside (for a positive radius). `subdivisions` is clamped to 8
    /// (1.3 M triangles).
    pub fn icosphere(radius: f32, subdivisions: u32) -> Mesh {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut vertices: Vec<Vec3> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|&p| Vec3::from_array(p).normalize())
        .collect();
        let mut triangles: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions.min(MAX_ICOSPHERE_SUBDIVISIONS) {
            // Each edge's midpoint is made once and shared by the two triangles on that edge, so
            // the result stays closed.
            let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(triangles.len() * 3 / 2);
            let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| -> u32 {
                *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                    vertices.push(m);
                    (vertices.len() - 1) as u32
                })
            };
            let mut next = Vec::with_capacity(triangles.len() * 4);
            for &[a, b, c] in &triangles {
                let ab = midpoint(a, b, &mut vertices);
                let bc = midpoint(b, c, &mut vertices);
                let ca = midpoint(c, a, &mut vertices);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            triangles = next;
        }
        for v in &mut vertices {
            *v *= radius;
        }
        Mesh { vertices, triangles }
    }

    /// A torus around the Y axis (it lies in the XZ plane, the hole along Y): tube centre circle
    /// of `major_radius`, tube radius `minor_radius`, `major_segments` around Y and
    /// `minor_segments` around the tube (each clamped to 3..=2048). Closed, counter-clockwise
    /// seen from outside.
    pub fn torus(major_radius: f32, minor_radius: f32, major_segments: u32, minor_segments: u32) -> Mesh {
        let (nu, nv) = (major_segments.clamp(3, MAX_TORUS_SEGMENTS), minor_segments.clamp(3, MAX_TORUS_SEGMENTS));
        let mut vertices = Vec::with_capacity((nu * nv) as usize);
        for i in 0..nu {
            let u = std::f32::consts::TAU * i as f32 / nu as f32;
            for j in 0..nv {
                let v = std::f32::consts::TAU * j as f32 / nv as f32;
                let ring = major_radius + minor_radius * v.cos();
                vertices.push(Vec3::new(ring * u.cos(), minor_radius * v.sin(), ring * u.sin()));
            }
        }
        let index = |i: u32, j: u32| (i % nu) * nv + (j % nv);
        let mut triangles = Vec::with_capacity(2 * (nu * nv) as usize);
        for i in 0..nu {
            for j in 0..nv {
                // With u around Y and v around the tube, (dP/dv x dP/du) points out of the tube:
                // a -> b steps in v, a -> d in u.
                let (a, b, c, d) = (index(i, j), index(i, j + 1), index(i + 1, j + 1), index(i + 1, j));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        Mesh { vertices, triangles }
    }

    /// A box of half extents `half` around the origin whose edges and corners are rounded with
    /// `radius` (outside `half`: the box is `half + radius` across each half), each quarter
    /// round in `segments` steps of equal angle (rounded up to even, clamped to 2..=512), the
    /// flat faces in squares of at most `flat_step` (clamped to at least a thousandth of the box;
    /// at most 4096 of them a side). Closed, counter-clockwise seen from outside: a table's or
    /// a step's rounded edges, a crease finer than a cloth's cells.
    pub fn rounded_box(half: Vec3, radius: f32, segments: u32, flat_step: f32) -> Mesh {
        let half = half.max(Vec3::ZERO);
        let radius = radius.max(0.0);
        let quarter = segments.clamp(2, MAX_ROUNDED_SEGMENTS).div_ceil(2);
        // Along an axis of half extent h: the rounds' tangents (a cube face's coordinates
        // mapped to equal angles, `outward`) and the flat part between them.
        let axis = |h: f32| {
            let step = flat_step.max(1e-3 * half.max_element().max(radius)).max(f32::MIN_POSITIVE);
            let flat = ((2.0 * h / step).ceil() as u32).clamp(1, MAX_ROUNDED_FLAT);
            let round = |j: u32| h + radius * (std::f32::consts::FRAC_PI_4 * j as f32 / quarter as f32).tan();
            let mut at: Vec<f32> = (1..=quarter).rev().map(|j| -round(j)).collect();
            at.extend((0..=flat).map(|i| -h + 2.0 * h * i as f32 / flat as f32));
            at.extend((1..=quarter).map(round));
            at.dedup();
            at
        };
        let coords = [axis(half.x), axis(half.y), axis(half.z)];
        // A point of the cube of half extent half + radius, out to the rounded surface: the
        // nearest point of the inner box, then `radius` along the way to the point.
        let outward = |g: Vec3| {
            let inner = g.clamp(-half, half);
            (g - inner).try_normalize().map_or(g, |d| inner + d * radius)
        };
        let mut index = std::collections::HashMap::new();
        let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
        for normal_axis in 0..3 {
            let (u, v) = ((normal_axis + 1) % 3, (normal_axis + 2) % 3);
            for sign in [-1.0f32, 1.0] {
                let mut vertex = |i: usize, j: usize| {
                    let mut cell = [0usize; 3];
                    (cell[u], cell[v]) = (i, j);
                    cell[normal_axis] = if sign < 0.0 { 0 } else { coords[normal_axis].len() - 1 };
                    *index.entry(cell).or_insert_with(|| {
                        let g = Vec3::new(coords[0][cell[0]], coords[1][cell[1]], coords[2][cell[2]]);
                        vertices.push(outward(g));
                        vertices.len() as u32 - 1
                    })
                };
                for i in 0..coords[u].len() - 1 {
                    for j in 0..coords[v].len() - 1 {
                        let [a, b, c, d] = [vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)];
                        // (u, v, normal) is right-handed: counter-clockwise in (u, v) faces +normal.
                        if sign > 0.0 {
                            triangles.extend([[a, b, c], [a, c, d]]);
                        } else {
                            triangles.extend([[a, c, b], [a, d, c]]);
                        }
                    }
                }
            }
        }
        Mesh { vertices, triangles }
    }

    /// The mesh with every vertex transformed by `m` (as a point). A mirroring `m` (negative
    /// determinant) would turn the triangles inside out, so their winding is reversed then.
    pub fn transformed(&self, m: Mat4) -> Mesh {
        let vertices = self.vertices.iter().map(|&v| m.transform_point3(v)).collect();
        let triangles = if m.determinant() < 0.0 {
            self.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect()
        } else {
            self.triangles.clone()
        };
        Mesh { vertices, triangles }
    }

    /// (min, max) over the vertices that triangles use: scanned models carry unreferenced
    /// vertices (the bunny has 1,113) that are not part of the surface. Indices out of range are
    /// skipped; a mesh without triangles gives (0, 0).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        used_bounds(&self.vertices, &self.triangles)
    }

    /// The standard benchmark placement (design.md §2): uniform scale so the larger horizontal (X
    /// or Z) extent is `extent` metres, then translated so the bounds' bottom centre sits at the
    /// origin (min y = 0, centred in x and z). A mesh with no horizontal extent is only moved.
    pub fn normalized_for_scene(&self, extent: f32) -> Mesh {
        let (min, max) = self.bounds();
        let horizontal = (max.x - min.x).max(max.z - min.z);
        let scale = if horizontal > 0.0 { extent / horizontal } else { 1.0 };
        let anchor = Vec3::new(0.5 * (min.x + max.x), min.y, 0.5 * (min.z + max.z));
        let vertices = self.vertices.iter().map(|&v| (v - anchor) * scale).collect();
        Mesh { vertices, triangles: self.triangles.clone() }
    }
}

/// Checks what every consumer of a mesh relies on; the error text is the `problem`.
/// The text of the OBJ file at `path`, checked line by line (`scan_obj`).
#[cfg(feature = "obj")]
pub(crate) fn read_obj_text(path: &Path) -> Result<String> {
    let error = |problem: String| Error::Mesh { path: path.to_path_buf(), problem };
    let bytes = std::fs::read(path).map_err(|e| error(format!("cannot read the file: {e}")))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| error(format!("is not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to())))?;
    let text = without_comments(text);
    scan_obj(&text).map_err(error)?;
    Ok(text)
}

/// `text` with the `#` comment cut from each data line (`v`, `vt`, `vn`, `f`, `l`): some
/// exporters end one with a comment, which tobj (and the cloth's parser) would read as a value.
/// Names keep theirs (`usemtl #ff0000` is a name). Line for line, so errors keep their line
/// numbers.
fn without_comments(text: String) -> String {
    if !text.contains('#') {
        return text;
    }
    text.lines().map(cut_comment).collect::<Vec<_>>().join("\n")
}

/// `line` without its `#` comment when it is a data line (see `without_comments`).
fn cut_comment(line: &str) -> &str {
    match line.split_whitespace().next() {
        Some("v" | "vt" | "vn" | "f" | "l") => line.split('#').next().unwrap_or(""),
        _ => line,
    }
}

/// (min, max) over the `vertices` that `triangles` use (`Mesh::bounds`).
pub(crate) fn used_bounds(vertices: &[Vec3], triangles: &[[u32; 3]]) -> (Vec3, Vec3) {
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for v in triangles.iter().flatten().filter_map(|&i| vertices.get(i as usize)) {
        min = min.min(*v);
        max = max.max(*v);
    }
    if min.cmple(max).all() { (min, max) } else { (Vec3::ZERO, Vec3::ZERO) }
}

/// Whether triangle `t` of `vertices` spans an area, exactly: in f64 the products of f32
/// coordinates' differences are exact, so zero only for corners on one line (an f32 area that
/// underflowed or overflowed is not zero here). An index out of range spans nothing.
pub(crate) fn spans_area(vertices: &[Vec3], t: [u32; 3]) -> bool {
    let corner = |i: u32| vertices.get(i as usize).map(|v| v.as_dvec3());
    match (corner(t[0]), corner(t[1]), corner(t[2])) {
        (Some(a), Some(b), Some(c)) => (b - a).cross(c - a) != glam::DVec3::ZERO,
        _ => false,
    }
}

pub(crate) fn validate(vertices: &[Vec3], triangles: &[[u32; 3]]) -> std::result::Result<(), String> {
    if triangles.is_empty() {
        return Err("no triangles (a mesh needs at least one face with 3 or more vertices)".into());
    }
    if let Some((i, v)) = vertices.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(format!("vertex {i} is not finite: ({}, {}, {})", v.x, v.y, v.z));
    }
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&i) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(format!("triangle {t} refers to vertex {i} but there are only {} vertices", vertices.len()));
        }
    }
    Ok(())
}

/// Each vertex's index once vertices at exactly the same position are joined (new indices in
/// order of first occurrence), and how many were joined. -0.0 and +0.0 are the same point.
pub(crate) fn coincident_map(vertices: &[Vec3]) -> (Vec<u32>, usize) {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(vertices.len());
    let remap: Vec<u32> = vertices
        .iter()
        .map(|&v| {
            let next = first.len() as u32;
            *first.entry((v + Vec3::ZERO).to_array().map(f32::to_bits)).or_insert(next)
        })
        .collect();
    let joined = vertices.len() - first.len();
    (remap, joined)
}

/// The vertices that stay once `remap` (from `coincident_map`) joins coincident ones: each
/// first occurrence, in order.
pub(crate) fn welded_vertices(vertices: &[Vec3], remap: &[u32]) -> Vec<Vec3> {
    let mut kept = Vec::with_capacity(vertices.len());
    for (&v, &to) in vertices.iter().zip(remap) {
        if to as usize == kept.len() {
            kept.push(v);
        }
    }
    kept
}

/// Triangle `t` through `remap`, or `None` when two of its corners became one vertex (no area)
/// or it refers to a vertex that does not exist.
pub(crate) fn welded_triangle(remap: &[u32], t: [u32; 3]) -> Option<[u32; 3]> {
    let [a, b, c] = t.map(|i| remap.get(i as usize).copied());
    let (a, b, c) = (a?, b?, c?);
    (a != b && b != c && a != c).then_some([a, b, c])
}

/// Counts of the elements defined so far, which relative (negative) indices count back from.
#[derive(Default)]
struct ObjCounts {
    positions: usize,
    texcoords: usize,
    normals: usize,
}

/// Checks every line tobj would read, with the rules tobj applies, so each problem is reported
/// with its line number and text. Returns the `problem` of the first bad line.
fn scan_obj(text: &str) -> std::result::Result<(), String> {
    let mut counts = ObjCounts::default();
    let mut faces = 0usize;
    for (n, line) in text.lines().enumerate() {
        let at = |problem: String| format!("line {}: {problem}: `{}`", n + 1, line.trim());
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                scan_position(&mut words).map_err(at)?;
                counts.positions += 1;
            }
            Some("vt") => {
                scan_floats(&mut words, 2, "texture coordinate").map_err(at)?;
                counts.texcoords += 1;
            }
            Some("vn") => {
                scan_floats(&mut words, 3, "normal").map_err(at)?;
                counts.normals += 1;
            }
            Some(kind @ ("f" | "l")) => {
                let mut corners = 0usize;
                for word in words {
                    scan_corner(word, &counts).map_err(at)?;
                    corners += 1;
                }
                if kind == "f" {
                    if corners < 3 {
                        return Err(at(format!("a face needs at least 3 vertices, this one has {corners}")));
                    }
                    faces += 1;
                }
            }
            Some("usemtl") if words.next().is_none() => return Err(at("`usemtl` without a material name".into())),
            _ => {}
        }
    }
    if faces == 0 {
        return Err("no triangles: the file has no `f` lines".into());
    }
    Ok(())
}

/// `v x y z`, `v x y z w` (homogeneous, divided by w) or `v x y z r g b` (vertex colour).
fn scan_position(words: &mut std::str::SplitWhitespace) -> std::result::Result<(), String> {
    let xyz = scan_floats(words, 3, "vertex")?;
    let extra: [Option<&str>; 4] = [words.next(), words.next(), words.next(), words.next()];
    match extra {
        [None, ..] => Ok(()),
        [Some(w), None, ..] => {
            let w = parse_float(w, "w")?;
            if w == 0.0 {
                return Err("homogeneous coordinate w is 0".into());
            }
            if xyz.iter().all(|c| (c / w).is_finite()) {
                Ok(())
            } else {
                Err("coordinates divided by w are not finite".into())
            }
        }
        [Some(r), Some(g), Some(b), None] => {
            for c in [r, g, b] {
                parse_float(c, "colour component")?;
            }
            Ok(())
        }
        _ => Err("expected `v x y z`, `v x y z w` or `v x y z r g b`".into()),
    }
}

/// The first `count` words as finite floats (more words are ignored, as tobj does).
fn scan_floats(
    words: &mut std::str::SplitWhitespace,
    count: usize,
    what: &str,
) -> std::result::Result<[f32; 3], String> {
    let mut values = [0.0; 3];
    for (k, value) in values.iter_mut().enumerate().take(count) {
        let word = words.next().ok_or_else(|| format!("{what} has {k} coordinates, needs {count}"))?;
        *value = parse_float(word, "coordinate")?;
    }
    Ok(values)
}

fn parse_float(word: &str, what: &str) -> std::result::Result<f32, String> {
    // f32, the type tobj parses into, so "1e39" is caught here as the infinity it would become.
    let value: f32 = word.parse().map_err(|_| format!("cannot parse {what} `{word}` as a number"))?;
    if value.is_finite() {
        Ok(value)
    } else if word.parse::<f64>().is_ok_and(f64::is_finite) {
        Err(format!("{what} `{word}` is beyond f32's range (at most about 3.4e38 in size)"))
    } else {
        Err(format!("{what} `{word}` is not finite"))
    }
}

/// One face corner: `v`, `v/vt`, `v//vn` or `v/vt/vn`.
fn scan_corner(word: &str, counts: &ObjCounts) -> std::result::Result<(), String> {
    let mut parts = word.split('/');
    let kinds = [("vertex", counts.positions), ("texture coordinate", counts.texcoords), ("normal", counts.normals)];
    for (k, (what, defined)) in kinds.into_iter().enumerate() {
        match parts.next() {
            None => break,
            Some("") if k == 0 => return Err(format!("face corner `{word}` has no vertex index")),
            Some("") => continue,
            Some(index) => {
                let index: i64 = index
                    .parse()
                    .map_err(|_| format!("cannot parse {what} index `{index}` in face corner `{word}`"))?;
                // tobj skips a texture or normal index when the file has none of them; so would
                // the cloth's UVs, silently: a file that refers to what it never defines is broken.
                if k > 0 && defined == 0 {
                    let lines = if k == 1 { "vt" } else { "vn" };
                    return Err(format!(
                        "face corner `{word}` refers to {what} {index}, but no `{lines}` line comes before it: \
                         add the {what}s, or write the corner without that index"
                    ));
                }
                check_index(index, defined, what)?;
            }
        }
    }
    if parts.next().is_some() {
        return Err(format!("face corner `{word}` has more than 3 indices"));
    }
    Ok(())
}

/// A 1-based index, or a negative one counting back from the last element defined above.
fn check_index(index: i64, defined: usize, what: &str) -> std::result::Result<(), String> {
    let defined_i = defined as i64;
    if index == 0 {
        Err(format!("{what} index 0 is out of range (OBJ indices start at 1)"))
    } else if index > defined_i {
        Err(format!("{what} index {index} is out of range: only {defined} defined above this line"))
    } else if index < 0 && -index > defined_i {
        Err(format!("relative {what} index {index} is out of range: only {defined} defined above this line"))
    } else {
        Ok(())
    }
}

/// The height of triangle `a`, `b`, `c` from its longest side (a corner to the opposite side:
/// its shortest height); `None` when its corners all coincide.
pub(crate) fn triangle_height(a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let longest = (b - a).length().max((c - a).length()).max((c - b).length());
    (longest > 0.0).then(|| (b - a).cross(c - a).length() / longest)
}
