//! Cloths that are not grids: a triangle mesh as a cloth (`ClothMesh`, loaded from OBJ with its
//! texture coordinates and vertex order kept for the renderer) and the spring list the kernels
//! gather forces from (`SpringTopology`): structural springs on the mesh's edges, bend springs
//! across the shared edge of each pair of triangles, rest lengths from the mesh, masses from
//! the triangles' areas.

use crate::error::{Error, Result};
use crate::mesh::{coincident_map, welded_triangle, welded_vertices};
use drape_kernels::cloth::{BEND, SPRINGS, STRUCTURAL};
use drape_types::{ParticleSprings, SimParams, Spring};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Texture coordinates of a cloth, per triangle corner (an OBJ's `vt` indices): a vertex on a
/// UV seam has one coordinate per side, and the cloth still has one particle there.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClothUvs {
    pub coords: Vec<Vec2>,
    /// Per cloth triangle, its corners' indices into `coords`.
    pub triangles: Vec<[u32; 3]>,
}

/// A triangle mesh to build a cloth from: one particle per vertex, in the mesh's vertex order.
#[derive(Clone, Debug, Default)]
pub struct ClothMesh {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// The mesh's texture coordinates, when it has them on every face.
    pub uvs: Option<ClothUvs>,
    /// Each triangle's piece: its mesh's place in `join`'s list, which a piece's own material
    /// (`crate::PieceMaterial`) is given by. Empty: one piece, 0.
    pub triangle_pieces: Vec<u32>,
}

impl ClothMesh {
    /// A cloth mesh from vertices and triangles (checked as `Mesh::from_parts` checks).
    pub fn from_parts(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        let mesh = crate::Mesh::from_parts(vertices, triangles)?;
        Ok(ClothMesh { vertices: mesh.vertices, triangles: mesh.triangles, ..Default::default() })
    }

    /// Loads a Wavefront OBJ as a cloth: its `v` lines in order are the particles (a vertex is
    /// never split at a UV or normal seam, which would tear the cloth there), polygons are
    /// fanned into triangles, and `vt` coordinates are kept per corner when every face has
    /// them. The file is checked line by line first, as `Mesh::load_obj` does; every failure is
    /// `Error::Mesh` naming the file and the line.
    #[cfg(feature = "obj")]
    pub fn load_obj(path: &Path) -> Result<Self> {
        let error = |problem: String| Error::Mesh { path: path.to_path_buf(), problem };
        let text = crate::mesh::read_obj_text(path)?;
        let mesh = parse_obj(&text).map_err(error)?;
        crate::mesh::validate(&mesh.vertices, &mesh.triangles).map_err(error)?;
        Ok(mesh)
    }

    /// How many of the triangles' vertices lie at exactly the same position as an earlier one
    /// of them (a vertex of no triangle is not part of the surface).
    pub fn coincident_vertices(&self) -> usize {
        let mut used = vec![false; self.vertices.len()];
        for &i in self.triangles.iter().flatten() {
            if let Some(u) = used.get_mut(i as usize) {
                *u = true;
            }
        }
        let surface: Vec<Vec3> = self.vertices.iter().zip(&used).filter(|(_, u)| **u).map(|(v, _)| *v).collect();
        coincident_map(&surface).1
    }

    /// How many triangles have the same three vertices as an earlier one (in any order or
    /// winding): a repeated face adds its area's mass to its corners again.
    pub fn repeated_triangles(&self) -> usize {
        let mut seen = std::collections::HashSet::with_capacity(self.triangles.len());
        self.triangles
            .iter()
            .filter(|t| {
                let mut corners = **t;
                corners.sort_unstable();
                corners[0] != corners[1] && corners[1] != corners[2] && !seen.insert(corners)
            })
            .count()
    }

    /// The cloth with vertices at exactly the same position joined into one (the first, in
    /// order), so a surface its file split at seams holds together; triangles that then have a
    /// corner twice are dropped with their texture coordinates. Texture coordinates stay per
    /// corner, so the seams keep their UVs. Returns it and how many vertices were joined. The
    /// vertex order changes (the joined ones are gone): a renderer binds the welded cloth's.
    /// Triangles that refer to no vertex are dropped; UVs that are not one per triangle are.
    pub fn weld_coincident(&self) -> (ClothMesh, usize) {
        let (remap, joined) = coincident_map(&self.vertices);
        let vertices = welded_vertices(&self.vertices, &remap);
        let welded: Vec<Option<[u32; 3]>> = self.triangles.iter().map(|&t| welded_triangle(&remap, t)).collect();
        let triangles = welded.iter().flatten().copied().collect();
        let kept = |list: &[[u32; 3]]| list.iter().zip(&welded).filter(|(_, w)| w.is_some()).map(|(t, _)| *t).collect();
        let uvs = self
            .uvs
            .as_ref()
            .filter(|uvs| uvs.triangles.len() == self.triangles.len())
            .map(|uvs| ClothUvs { coords: uvs.coords.clone(), triangles: kept(&uvs.triangles) });
        let triangle_pieces =
            (0..self.triangles.len()).filter(|&t| welded[t].is_some()).map(|t| self.piece_of(t)).collect();
        (ClothMesh { vertices, triangles, uvs, triangle_pieces }, joined)
    }

    /// Each vertex's index in `weld_coincident`'s cloth (a vertex joined into an earlier one
    /// takes that one's): where a pin given by the file's vertex index lands once welded.
    pub fn weld_map(&self) -> Vec<u32> {
        coincident_map(&self.vertices).0
    }

    /// The pieces as one cloth mesh, in order: each piece's vertices follow the pieces' before
    /// it (a particle's index is its vertex's index in its piece plus the vertices of the
    /// pieces before), its triangles with them; texture coordinates are kept when every piece
    /// has them. One cloth, so its self-collision keeps the pieces apart as it keeps one piece
    /// from itself (a skirt under a coat, a sheet over a sheet), which two cloths of one model
    /// do not; welded (`weld_coincident`), pieces whose edges meet at the same positions are
    /// sewn together there. Each triangle remembers its piece (`triangle_pieces`), so a piece
    /// can have its own material (`crate::PieceMaterial`).
    pub fn join(pieces: &[ClothMesh]) -> ClothMesh {
        let mut joined = ClothMesh::default();
        let mut uvs = Some(ClothUvs::default());
        let mut pieces_before = 0;
        for piece in pieces {
            let base = joined.vertices.len() as u32;
            joined.vertices.extend_from_slice(&piece.vertices);
            joined.triangles.extend(piece.triangles.iter().map(|t| t.map(|i| i + base)));
            // A joined mesh joined again keeps its pieces, after the ones before.
            joined.triangle_pieces.extend((0..piece.triangles.len()).map(|t| pieces_before + piece.piece_of(t)));
            pieces_before += piece.piece_count() as u32;
            uvs = match (uvs, &piece.uvs) {
                (Some(mut all), Some(own)) if own.triangles.len() == piece.triangles.len() => {
                    let coords = all.coords.len() as u32;
                    all.coords.extend_from_slice(&own.coords);
                    all.triangles.extend(own.triangles.iter().map(|t| t.map(|i| i + coords)));
                    Some(all)
                }
                _ => None,
            };
        }
        joined.uvs = uvs.filter(|_| !pieces.is_empty());
        joined
    }

    /// Triangle `t`'s piece (`triangle_pieces`; 0 when the mesh is one piece).
    pub fn piece_of(&self, t: usize) -> u32 {
        self.triangle_pieces.get(t).copied().unwrap_or(0)
    }

    /// How many pieces the mesh has (1 when it is one).
    pub fn piece_count(&self) -> usize {
        self.triangle_pieces.iter().max().map_or(1, |&p| p as usize + 1)
    }

    /// A `rows x cols` grid of `size` (m) in the XZ plane centred on the origin, as a mesh: the
    /// grid cloth's particles and triangles, with UVs across the grid.
    pub fn grid(rows: u32, cols: u32, size: f32) -> Self {
        let (rows, cols) = (rows.max(2), cols.max(2));
        let mut vertices = Vec::with_capacity((rows * cols) as usize);
        let mut coords = Vec::with_capacity(vertices.capacity());
        for r in 0..rows {
            for c in 0..cols {
                let (u, v) = (c as f32 / (cols - 1) as f32, r as f32 / (rows - 1) as f32);
                vertices.push(Vec3::new((u - 0.5) * size, 0.0, (v - 0.5) * size));
                coords.push(Vec2::new(u, v));
            }
        }
        let triangles = crate::cloth::grid_triangles(rows, cols);
        ClothMesh {
            vertices,
            uvs: Some(ClothUvs { coords, triangles: triangles.clone() }),
            triangles,
            triangle_pieces: Vec::new(),
        }
    }

    /// An open tube (no caps) around the Y axis: `radius` (m), `height` (m) from y = 0 up,
    /// `around` vertices per ring and `rings` rings; UVs unrolled (u around, with a seam column
    /// of its own, v up).
    pub fn tube(radius: f32, height: f32, around: u32, rings: u32) -> Self {
        let (around, rings) = (around.max(3), rings.max(2));
        let mut vertices = Vec::with_capacity((around * rings) as usize);
        let mut coords = Vec::with_capacity(((around + 1) * rings) as usize);
        for r in 0..rings {
            let v = r as f32 / (rings - 1) as f32;
            for k in 0..=around {
                let u = k as f32 / around as f32;
                if k < around {
                    let angle = std::f32::consts::TAU * u;
                    vertices.push(Vec3::new(radius * angle.cos(), height * v, radius * angle.sin()));
                }
                coords.push(Vec2::new(u, v));
            }
        }
        let (mut triangles, mut uv_triangles) = (Vec::new(), Vec::new());
        for r in 0..rings - 1 {
            for k in 0..around {
                let (a, b) = (r * around + k, r * around + (k + 1) % around);
                let (c, d) = (a + around, b + around);
                let (ta, tb) = (r * (around + 1) + k, r * (around + 1) + k + 1);
                let (tc, td) = (ta + around + 1, tb + around + 1);
                // Outward normals: (b - a) x (c - a) points away from the axis.
                triangles.push([a, c, b]);
                triangles.push([b, c, d]);
                uv_triangles.push([ta, tc, tb]);
                uv_triangles.push([tb, tc, td]);
            }
        }
        ClothMesh {
            vertices,
            triangles,
            uvs: Some(ClothUvs { coords, triangles: uv_triangles }),
            triangle_pieces: Vec::new(),
        }
    }

    /// Total area (m^2).
    pub fn area(&self) -> f32 {
        self.triangles.iter().map(|&t| triangle_area(&self.vertices, t)).sum()
    }
}

/// The area of triangle `[a, b, c]` of `vertices`.
pub(crate) fn triangle_area(vertices: &[Vec3], [a, b, c]: [u32; 3]) -> f32 {
    let (a, b, c) = (vertices[a as usize], vertices[b as usize], vertices[c as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// What the spring-list kernels read: each particle's springs (every spring stored at both
/// ends) and inverse mass, and for the normals each vertex's triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpringTopology {
    pub particles: Vec<ParticleSprings>,
    pub springs: Vec<Spring>,
    /// Vertex `i`'s triangles are `vertex_triangles[offsets[i]..offsets[i + 1]]`.
    pub vertex_triangle_offsets: Vec<u32>,
    pub vertex_triangles: Vec<u32>,
    /// Structural springs whose stiffness scale's geometric share was capped at
    /// `MAX_STIFFNESS_SCALE` (each once).
    pub capped_edges: usize,
}

/// An undirected spring: its ends, rest length, family and stiffness scale.
type Link = (u32, u32, f32, u32, f32);

/// The most a structural spring's stiffness scale (`structural_scale`) may be: a needle or cap
/// triangle's short edge would otherwise take a stiffness that needs many times the substeps
/// (its scale grows as the triangle's width over the edge). Capped, the cloth is softer there
/// than its material, and the cloth's build warns (`SpringTopology::capped_edges`).
pub const MAX_STIFFNESS_SCALE: f32 = 16.0;

/// A structural spring's share of its family's stiffness and damping (`Spring::stiffness_scale`):
/// the area of the triangles on its edge (`area`) over its squared rest length (Van Gelder 1998,
/// "Approximate simulation of elastic membranes by triangulated spring meshes"), at most
/// `MAX_STIFFNESS_SCALE`. With one stiffness for every spring, a sheet's stiffness across a row
/// of cells goes as the cells' width over their length: a strip of triangles 5 mm along it and
/// 50 cm across hung 1.6-2.2x stretched over the standard scene's sphere, where a regular mesh
/// of the same sheet stretched a few percent. With the scale each spring stands for the
/// material around it, so the cloth is one material whatever its triangles' shapes. Inside a
/// square grid a side gets 1
/// (two half cells over a side squared), so `k_struct` means on a mesh what it means on the grid;
/// a cell's diagonal gets 1/2, a side on the boundary 1/2. An edge of no length or no area
/// (only flat triangles on it) keeps its family's stiffness: 1.
pub fn structural_scale(area: f32, rest: f32) -> f32 {
    let scale = area / (rest * rest);
    if area > 0.0 && rest > 0.0 && scale.is_finite() { scale.min(MAX_STIFFNESS_SCALE) } else { 1.0 }
}

/// A triangle's stiffness as a multiple of its cloth's, per spring family (its piece's material:
/// `crate::PieceMaterial`): the structural springs on its edges, and the bend springs across
/// them. 1 and 1 for a cloth of one material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StiffnessFactors {
    pub structural: f32,
    pub bend: f32,
}

impl Default for StiffnessFactors {
    fn default() -> Self {
        StiffnessFactors { structural: 1.0, bend: 1.0 }
    }
}

/// Each undirected edge of `triangles` (keyed lower vertex first) with the summed area of its
/// triangles (`areas`, per triangle), and that area with each triangle's weighted by its
/// structural factor.
fn edge_areas(triangles: &[[u32; 3]], areas: &[f32], factors: &[StiffnessFactors]) -> HashMap<(u32, u32), (f32, f32)> {
    let mut sums: HashMap<(u32, u32), (f32, f32)> = HashMap::new();
    for (i, (&[a, b, c], &area)) in triangles.iter().zip(areas).enumerate() {
        let factor = factors.get(i).map_or(1.0, |f| f.structural);
        for (p, q) in [(a, b), (b, c), (c, a)] {
            let edge = sums.entry((p.min(q), p.max(q))).or_default();
            edge.0 += area;
            edge.1 += area * factor;
        }
    }
    sums
}

impl SpringTopology {
    /// The springs of `mesh` (placed in the world: rest lengths are its edge lengths, stiffness
    /// scales from its triangles' areas: `structural_scale`) with per-vertex `masses` (kg; a
    /// vertex of mass 0 gets inverse mass 0, i.e. it must be pinned), each triangle's springs
    /// at its `factors` (one per triangle; empty: all 1). A structural spring takes its
    /// triangles' factors weighted by their areas (an edge between two materials is as stiff as
    /// the material around it); a bend spring the same of the two triangles it crosses.
    pub fn of_mesh(vertices: &[Vec3], triangles: &[[u32; 3]], masses: &[f32], factors: &[StiffnessFactors]) -> Self {
        let length = |a: u32, b: u32| (vertices[a as usize] - vertices[b as usize]).length();
        let triangle_areas: Vec<f32> = triangles.iter().map(|&t| triangle_area(vertices, t)).collect();
        let edges = edge_areas(triangles, &triangle_areas, factors);
        let bend_factor = |t: usize| factors.get(t).map_or(1.0, |f| f.bend);
        let mut families: HashMap<(u32, u32), u32> = HashMap::new();
        let mut links: Vec<Link> = Vec::new();
        let mut capped = 0;
        // A structural spring (`bend` None) on a mesh edge, or a bend spring at its factor.
        let mut add = |a: u32, b: u32, bend: Option<f32>, links: &mut Vec<Link>| {
            let key = (a.min(b), a.max(b));
            let family = if bend.is_some() { BEND } else { STRUCTURAL };
            if a != b && !families.contains_key(&key) {
                families.insert(key, family);
                let rest = length(a, b);
                let scale = bend.unwrap_or_else(|| {
                    let (area, weighted) = edges[&key];
                    let geometric = structural_scale(area, rest);
                    capped += usize::from(geometric >= MAX_STIFFNESS_SCALE);
                    // The material's share: the triangles' factors by area (1 without area).
                    geometric * if area > 0.0 { weighted / area } else { 1.0 }
                });
                links.push((a, b, rest, family, scale));
            }
        };
        for &[a, b, c] in triangles {
            for (p, q) in [(a, b), (b, c), (c, a)] {
                add(p, q, None, &mut links);
            }
        }
        // Bend springs join the corners opposite each shared edge, for every pair of triangles
        // on it (a non-manifold edge has more than one pair).
        let mut opposite: HashMap<(u32, u32), Vec<(u32, usize)>> = HashMap::new();
        for (t, &[a, b, c]) in triangles.iter().enumerate() {
            for (p, q, o) in [(a, b, c), (b, c, a), (c, a, b)] {
                opposite.entry((p.min(q), p.max(q))).or_default().push((o, t));
            }
        }
        let mut shared: Vec<_> = opposite.into_iter().collect();
        shared.sort_unstable_by_key(|(edge, _)| *edge); // a deterministic spring order
        for (_, corners) in &shared {
            for (i, &(o, t)) in corners.iter().enumerate() {
                for &(o2, t2) in &corners[i + 1..] {
                    let (area, area2) = (triangle_areas[t], triangle_areas[t2]);
                    let (bend, bend2) = (bend_factor(t), bend_factor(t2));
                    let across = if area + area2 > 0.0 {
                        (area * bend + area2 * bend2) / (area + area2)
                    } else {
                        0.5 * (bend + bend2)
                    };
                    add(o, o2, Some(across), &mut links);
                }
            }
        }
        let mut per_particle: Vec<Vec<Spring>> = vec![Vec::new(); vertices.len()];
        for &(a, b, rest, family, stiffness_scale) in &links {
            per_particle[a as usize].push(Spring { other: b, rest, family, stiffness_scale });
            per_particle[b as usize].push(Spring { other: a, rest, family, stiffness_scale });
        }
        let mut topology = Self::of_lists(per_particle, masses);
        (topology.vertex_triangle_offsets, topology.vertex_triangles) = vertex_triangles(vertices.len(), triangles);
        topology.capped_edges = capped;
        topology
    }

    /// The springs of a grid cloth (`params`), in the order the grid kernel visits them, so
    /// the spring-list path can be measured and checked against the grid's fast path.
    pub fn of_grid(params: &SimParams, triangles: &[[u32; 3]]) -> Self {
        let (rows, cols) = (params.rows, params.cols);
        let mut per_particle = Vec::with_capacity((rows * cols) as usize);
        for row in 0..rows {
            for col in 0..cols {
                let mut springs = Vec::with_capacity(SPRINGS.len());
                for s in SPRINGS {
                    if let Some(other) = drape_kernels::cloth::neighbour(params, row, col, s) {
                        let rest = drape_kernels::cloth::rest_length(params, s);
                        springs.push(Spring { other, rest, family: s.family, stiffness_scale: 1.0 });
                    }
                }
                per_particle.push(springs);
            }
        }
        let masses = vec![params.particle_mass; per_particle.len()];
        let mut topology = Self::of_lists(per_particle, &masses);
        let n = (rows * cols) as usize;
        (topology.vertex_triangle_offsets, topology.vertex_triangles) = vertex_triangles(n, triangles);
        topology
    }

    fn of_lists(per_particle: Vec<Vec<Spring>>, masses: &[f32]) -> Self {
        let mut particles = Vec::with_capacity(per_particle.len());
        let mut springs = Vec::with_capacity(per_particle.iter().map(Vec::len).sum());
        for (list, &mass) in per_particle.into_iter().zip(masses) {
            let inverse_mass = if mass > 0.0 { 1.0 / mass } else { 0.0 };
            particles.push(ParticleSprings {
                first: springs.len() as u32,
                count: list.len() as u32,
                inverse_mass,
                _pad: 0,
            });
            springs.extend(list);
        }
        SpringTopology { particles, springs, ..Default::default() }
    }

    /// Each structural spring once (i < j): (i, j, rest).
    pub fn structural_springs(&self) -> Vec<(u32, u32, f32)> {
        let mut out = Vec::new();
        for (i, p) in self.particles.iter().enumerate() {
            for s in &self.springs[p.first as usize..(p.first + p.count) as usize] {
                if s.family == STRUCTURAL && (i as u32) < s.other {
                    out.push((i as u32, s.other, s.rest));
                }
            }
        }
        out
    }
}

/// Each vertex's triangles, as offsets and a flat list (in triangle order).
fn vertex_triangles(vertex_count: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    let mut counts = vec![0u32; vertex_count + 1];
    for t in triangles {
        for &v in t {
            counts[v as usize + 1] += 1;
        }
    }
    for i in 0..vertex_count {
        counts[i + 1] += counts[i];
    }
    let offsets = counts.clone();
    let mut next = counts;
    let mut list = vec![0u32; offsets[vertex_count] as usize];
    for (t, tri) in triangles.iter().enumerate() {
        for &v in tri {
            list[next[v as usize] as usize] = t as u32;
            next[v as usize] += 1;
        }
    }
    (offsets, list)
}

/// Lumped masses: each triangle's mass (its area times its areal density, `densities[t]` in
/// kg/m^2) spread evenly over its corners. A vertex of only collapsed triangles gets the
/// smallest mass of the others (it still moves); a vertex of no triangle gets 0 (the builder
/// pins it).
pub fn lumped_masses(vertices: &[Vec3], triangles: &[[u32; 3]], densities: &[f32]) -> Vec<f32> {
    let mut masses = vec![0.0f32; vertices.len()];
    let mut used = vec![false; vertices.len()];
    for (&t, &density) in triangles.iter().zip(densities) {
        let share = triangle_area(vertices, t) * density / 3.0;
        for v in t {
            masses[v as usize] += share;
            used[v as usize] = true;
        }
    }
    let lightest = masses.iter().copied().filter(|&m| m > 0.0).fold(f32::INFINITY, f32::min);
    let fallback = if lightest.is_finite() { lightest } else { 0.0 };
    for (m, used) in masses.iter_mut().zip(used) {
        if used && *m <= 0.0 {
            *m = fallback;
        }
    }
    masses
}

/// The cloth in an OBJ text that `mesh::read_obj_text` has checked (numbers parse, indices are
/// in range): positions in file order, faces fanned, texture coordinates per corner.
fn parse_obj(text: &str) -> std::result::Result<ClothMesh, String> {
    let (mut vertices, mut coords) = (Vec::new(), Vec::new());
    let (mut triangles, mut uv_triangles) = (Vec::new(), Vec::new());
    let mut every_face_has_uvs = true;
    for (n, line) in text.lines().enumerate() {
        let at = |problem: &str| format!("line {}: {problem}: `{}`", n + 1, line.trim());
        let mut words = line.split_whitespace();
        let numbers = |words: std::str::SplitWhitespace| -> Vec<f32> { words.filter_map(|w| w.parse().ok()).collect() };
        match words.next() {
            Some("v") => {
                let v = numbers(words);
                let w = if v.len() == 4 { v[3] } else { 1.0 };
                let p = Vec3::new(v[0], v[1], v[2]) / w;
                vertices.push(p);
            }
            Some("vt") => {
                let t = numbers(words);
                coords.push(Vec2::new(t.first().copied().unwrap_or(0.0), t.get(1).copied().unwrap_or(0.0)));
            }
            Some("f") => {
                let mut corners = Vec::new();
                for word in words {
                    let mut parts = word.split('/');
                    let v = resolve(parts.next(), vertices.len()).ok_or_else(|| at("bad vertex index"))?;
                    let t = resolve(parts.next(), coords.len());
                    corners.push((v, t));
                }
                let face_has_uvs = corners.iter().all(|c| c.1.is_some());
                every_face_has_uvs &= face_has_uvs;
                for k in 1..corners.len().saturating_sub(1) {
                    let (a, b, c) = (corners[0], corners[k], corners[k + 1]);
                    triangles.push([a.0, b.0, c.0]);
                    if let (Some(ta), Some(tb), Some(tc)) = (a.1, b.1, c.1) {
                        uv_triangles.push([ta, tb, tc]);
                    }
                }
            }
            _ => {}
        }
    }
    let uvs = (every_face_has_uvs && !uv_triangles.is_empty()).then_some(ClothUvs { coords, triangles: uv_triangles });
    Ok(ClothMesh { vertices, triangles, uvs, triangle_pieces: Vec::new() })
}

/// A 1-based (or negative, relative) OBJ index among `count` elements defined so far, as a
/// 0-based index; `None` when absent or out of range.
fn resolve(word: Option<&str>, count: usize) -> Option<u32> {
    let i: i64 = word.filter(|w| !w.is_empty())?.parse().ok()?;
    let index = if i < 0 { count as i64 + i } else { i - 1 };
    (0..count as i64).contains(&index).then_some(index as u32)
}
