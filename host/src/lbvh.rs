//! The collider's LBVH: the build (`programs::lbvh`) run on the GPU or by the CPU executor, and
//! `validate()` for the tree invariants.

use crate::cpu::CpuExecutor;
use crate::error::{Error, Result};
use crate::gpu::{Context, Engine, FrameTimings, RecordedFrame};
use crate::graph::{ReadBuffers, Resources};
use crate::programs::contact::{ColliderLeaves, ContactLeaves};
use crate::programs::spheres::SphereBvh;
use crate::programs::triangles::TriangleBvh;
use drape_kernels::lbvh::aabb_centre;
use drape_kernels::spheres::{sphere_aabb, sphere_leaf_at, swept_sphere_aabb};
use drape_types::{Aabb, BvhNode, ColliderParams, LEAF_BIT, NO_NODE, SphereLeaf, Triangle};
use glam::{Vec3, Vec4};
use std::sync::Arc;

/// Largest supported leaf count (keeps every dispatch within 65,535 workgroups of 256).
pub const MAX_LEAVES: u32 = 1 << 24;

/// Collider parameters for `spheres` (xyz centre, w radius) with a contact `thickness`.
pub fn collider_params(spheres: &[Vec4], thickness: f32, friction: f32) -> Result<ColliderParams> {
    if spheres.is_empty() || spheres.len() as u64 > MAX_LEAVES as u64 {
        return Err(Error::InvalidParameter {
            name: "collider",
            problem: format!("needs 1..={MAX_LEAVES} spheres, got {}", spheres.len()),
        });
    }
    if !spheres.iter().all(|s| s.is_finite() && s.w >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "collider",
            problem: "spheres must be finite with radius >= 0".into(),
        });
    }
    let boxes: Vec<Aabb> = spheres.iter().map(|s| sphere_aabb(*s)).collect();
    params_over_boxes(&boxes, thickness, friction)
}

/// Collider parameters for a triangle mesh with a contact `thickness`.
pub fn mesh_collider_params(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    thickness: f32,
    friction: f32,
) -> Result<ColliderParams> {
    let bad = |problem: String| Err(Error::InvalidParameter { name: "collider", problem });
    if triangles.is_empty() || triangles.len() as u64 > MAX_LEAVES as u64 {
        return bad(format!("needs 1..={MAX_LEAVES} triangles, got {}", triangles.len()));
    }
    if let Some(v) = vertices.iter().position(|v| !v.is_finite()) {
        return bad(format!("vertex {v} is not finite"));
    }
    if let Some(t) = triangles.iter().position(|t| t.iter().any(|&i| i as usize >= vertices.len())) {
        return bad(format!("triangle {t} indexes past the {} vertices", vertices.len()));
    }
    params_over_boxes(&triangle_boxes(vertices, triangles), thickness, friction)
}

/// The box of each triangle (indices checked by the caller).
pub fn triangle_boxes(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Aabb> {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            Aabb { min: a.min(b).min(c).extend(0.0), max: a.max(b).max(c).extend(0.0) }
        })
        .collect()
}

/// Checks the contact parameters; the scene box the Morton codes normalise into is over the
/// centres of the leaf boxes the build encodes.
fn params_over_boxes(boxes: &[Aabb], thickness: f32, friction: f32) -> Result<ColliderParams> {
    if !(friction.is_finite() && friction >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "friction",
            problem: format!("must be finite and >= 0, got {friction}"),
        });
    }
    if !(thickness.is_finite() && thickness >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "thickness",
            problem: format!("must be finite and >= 0, got {thickness}"),
        });
    }
    let (lo, hi) =
        boxes.iter().map(aabb_centre).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)));
    Ok(ColliderParams {
        leaf_count: boxes.len() as u32,
        thickness,
        friction,
        cover_reach: 0.0,
        scene_min: lo.extend(0.0),
        scene_max: hi.extend(0.0),
    })
}

/// An LBVH as plain arrays (what the GPU holds, read back, or what the CPU twin builds).
#[derive(Clone, Debug, PartialEq)]
pub struct Lbvh {
    /// Morton codes in sorted order, and the input index of each sorted leaf.
    pub codes: Vec<u32>,
    pub order: Vec<u32>,
    /// The leaves in sorted order: spheres of a sphere collider, triangles of a mesh collider
    /// (the other is empty), and their boxes (what the tree is built from).
    pub spheres: Vec<SphereLeaf>,
    pub triangles: Vec<Triangle>,
    pub leaf_bounds: Vec<Aabb>,
    /// N - 1 internal nodes (root = 0).
    pub nodes: Vec<BvhNode>,
    /// Parent of internal node i at `[i]`, of leaf j at `[N - 1 + j]`; the root's is `NO_NODE`.
    pub parents: Vec<u32>,
    pub aabbs: Vec<Aabb>,
}

/// Reads a built tree back from either executor.
fn read_tree(executor: &impl ReadBuffers, leaves: &ColliderLeaves) -> Result<Lbvh> {
    let b = leaves.kind().tree();
    let n = b.leaves as usize;
    let (spheres, triangles) = match leaves {
        ColliderLeaves::Spheres(s) => (executor.read(s.sorted, n)?, Vec::new()),
        ColliderLeaves::Triangles(t) => (Vec::new(), executor.read(t.sorted, n)?),
    };
    Ok(Lbvh {
        codes: executor.read(b.codes, n)?,
        order: executor.read(b.order, n)?,
        spheres,
        triangles,
        leaf_bounds: executor.read(b.sorted_bounds, n)?,
        nodes: executor.read(b.nodes, n - 1)?,
        parents: if n > 1 { executor.read(b.parents, 2 * n - 1)? } else { vec![NO_NODE] },
        aabbs: executor.read(b.aabbs, n - 1)?,
    })
}

/// Reads a built tree back from the GPU.
pub fn download(engine: &Engine, leaves: &ColliderLeaves) -> Result<Lbvh> {
    read_tree(engine, leaves)
}

/// A standalone GPU LBVH (tests, benchmarks): builds on creation.
pub struct GpuLbvh {
    engine: Engine,
    buffers: ColliderLeaves,
    pub params: ColliderParams,
    /// GPU time per stage of the build.
    pub timings: FrameTimings,
}

impl GpuLbvh {
    pub fn build(ctx: &Arc<Context>, spheres: &[Vec4], thickness: f32) -> Result<Self> {
        let params = collider_params(spheres, thickness, 0.0)?;
        let mut resources = Resources::new();
        let b = SphereBvh::declare(&mut resources, "lbvh", params.leaf_count);
        let mut engine = Engine::new(ctx)?;
        engine.allocate(&resources)?;
        engine.upload(b.tree.collider, std::slice::from_ref(&params))?;
        engine.upload(b.spheres, spheres)?;
        engine.upload(b.previous, spheres)?;
        let buffers = ColliderLeaves::Spheres(b);
        let mut this = GpuLbvh { engine, buffers, params, timings: FrameTimings::default() };
        this.rebuild(true)?;
        Ok(this)
    }

    /// Builds again from the same spheres (benchmarks); returns the GPU time per stage when
    /// `timed`.
    pub fn rebuild(&mut self, timed: bool) -> Result<FrameTimings> {
        self.timings = self.build_frame(timed)?.submit()?;
        Ok(self.timings.clone())
    }

    /// The build recorded once, to submit any number of times.
    pub fn build_frame(&mut self, timed: bool) -> Result<RecordedFrame> {
        self.engine.record(&self.buffers.kind().build_steps(), timed)
    }

    pub fn download(&self) -> Result<Lbvh> {
        download(&self.engine, &self.buffers)
    }
}

/// CPU twin of the build: the same steps run by the CPU executor.
pub fn build_cpu(spheres: &[Vec4], params: &ColliderParams) -> Result<Lbvh> {
    let mut resources = Resources::new();
    let b = SphereBvh::declare(&mut resources, "lbvh", params.leaf_count);
    let mut cpu = CpuExecutor::new(&resources);
    cpu.upload(b.tree.collider, std::slice::from_ref(params))?;
    cpu.upload(b.spheres, spheres)?;
    cpu.upload(b.previous, spheres)?;
    cpu.run(&b.build_steps())?;
    read_tree(&cpu, &ColliderLeaves::Spheres(b))
}

/// CPU twin of the build over a triangle mesh.
pub fn build_mesh_cpu(vertices: &[Vec3], triangles: &[[u32; 3]], params: &ColliderParams) -> Result<Lbvh> {
    build_swept_mesh_cpu(vertices, vertices, triangles, params)
}

/// CPU twin of the build over a deforming mesh whose vertices moved from `previous` to
/// `vertices` over the frame (its leaves sweep between them).
pub fn build_swept_mesh_cpu(
    previous: &[Vec3],
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    params: &ColliderParams,
) -> Result<Lbvh> {
    let mut resources = Resources::new();
    let b = TriangleBvh::declare(&mut resources, "lbvh", vertices.len() as u32, params.leaf_count);
    let mut cpu = CpuExecutor::new(&resources);
    cpu.upload(b.tree.collider, std::slice::from_ref(params))?;
    let corners = |v: &[Vec3]| v.iter().map(|v| v.extend(0.0)).collect::<Vec<Vec4>>();
    cpu.upload(b.vertices, &corners(vertices))?;
    cpu.upload(b.previous, &corners(previous))?;
    cpu.upload(b.indices, triangles.as_flattened())?;
    cpu.run(&b.build_steps())?;
    read_tree(&cpu, &ColliderLeaves::Triangles(b))
}

fn contains(outer: &Aabb, inner: &Aabb) -> bool {
    outer.min.truncate().cmple(inner.min.truncate()).all() && outer.max.truncate().cmpge(inner.max.truncate()).all()
}

impl Lbvh {
    /// Checks the invariants for the sphere leaf kind built from `input`: those of
    /// `validate_boxes`, and each sorted sphere is its input sphere, standing still.
    pub fn validate(&self, input: &[Vec4]) -> std::result::Result<(), String> {
        self.validate_swept(input, input)
    }

    /// `validate` for spheres that swept from `previous` to `input` over the frame: each leaf's
    /// box holds its sweep (`swept_sphere_aabb`), and each sorted leaf is its input sphere with
    /// that sweep.
    pub fn validate_swept(&self, previous: &[Vec4], input: &[Vec4]) -> std::result::Result<(), String> {
        if previous.len() != input.len() {
            return Err(format!("{} previous spheres for {} spheres", previous.len(), input.len()));
        }
        let boxes: Vec<Aabb> = input.iter().zip(previous).map(|(s, p)| swept_sphere_aabb(*p, *s)).collect();
        self.validate_boxes(&boxes)?;
        if self.spheres.len() != input.len() {
            return Err(format!("expected {} spheres", input.len()));
        }
        let leaf_of = |o: u32| sphere_leaf_at(o as usize, input, previous);
        match self.order.iter().enumerate().find(|&(sorted, &o)| self.spheres[sorted] != leaf_of(o)) {
            Some((sorted, o)) => Err(format!("leaf {sorted} is not sphere {o}")),
            None => Ok(()),
        }
    }

    /// Checks the invariants of a tree built from leaf boxes `input`: codes sorted, `order` a
    /// permutation, each sorted leaf box its input box, every node and leaf reached exactly
    /// once from the root, parent links consistent, every box containing its children.
    pub fn validate_boxes(&self, input: &[Aabb]) -> std::result::Result<(), String> {
        let n = input.len();
        if self.codes.len() != n || self.order.len() != n || self.leaf_bounds.len() != n {
            return Err(format!("expected {n} leaves"));
        }
        if let Some(i) = (1..n).find(|&i| self.codes[i - 1] > self.codes[i]) {
            return Err(format!("codes not sorted at {i}"));
        }
        let mut seen = vec![false; n];
        for (sorted, &original) in self.order.iter().enumerate() {
            let o = original as usize;
            if o >= n || std::mem::replace(&mut seen[o], true) {
                return Err(format!("order is not a permutation (index {original})"));
            }
            if self.leaf_bounds[sorted] != input[o] {
                return Err(format!("leaf {sorted}'s box is not leaf {original}'s"));
            }
        }
        if n == 1 {
            return Ok(());
        }
        if self.nodes.len() != n - 1 || self.aabbs.len() != n - 1 || self.parents.len() != 2 * n - 1 {
            return Err("wrong node / box / parent counts".into());
        }
        if self.parents[0] != NO_NODE {
            return Err(format!("root has parent {}", self.parents[0]));
        }
        let mut leaf_hits = vec![0u32; n];
        let mut node_hits = vec![0u32; n - 1];
        let mut stack = vec![0u32];
        while let Some(node) = stack.pop() {
            let i = node as usize;
            if i >= n - 1 {
                return Err(format!("node index {node} out of range"));
            }
            node_hits[i] += 1;
            if node_hits[i] > 1 {
                return Err(format!("node {node} reached twice"));
            }
            let b = self.aabbs[i];
            for child in [self.nodes[i].left, self.nodes[i].right] {
                let slot = if child & LEAF_BIT != 0 { n - 1 + (child & !LEAF_BIT) as usize } else { child as usize };
                if slot >= 2 * n - 1 {
                    return Err(format!("child {child:#x} of node {node} out of range"));
                }
                if self.parents[slot] != node {
                    return Err(format!("child {child:#x} of node {node} has parent {}", self.parents[slot]));
                }
                if child & LEAF_BIT != 0 {
                    let leaf = (child & !LEAF_BIT) as usize;
                    leaf_hits[leaf] += 1;
                    if !contains(&b, &self.leaf_bounds[leaf]) {
                        return Err(format!("node {node} does not contain leaf {leaf}"));
                    }
                } else {
                    if !contains(&b, &self.aabbs[child as usize]) {
                        return Err(format!("node {node} does not contain node {child}"));
                    }
                    stack.push(child);
                }
            }
        }
        if let Some(i) = node_hits.iter().position(|&h| h != 1) {
            return Err(format!("internal node {i} reached {} times", node_hits[i]));
        }
        if let Some(i) = leaf_hits.iter().position(|&h| h != 1) {
            return Err(format!("leaf {i} reached {} times", leaf_hits[i]));
        }
        self.validate_escapes()
    }

    /// Checks the stackless walks' links (`BvhNode::escape`, `BvhNode::leaf_escape`) against a
    /// depth-first walk with a stack, left child first: each node's escape is the entry after
    /// its subtree, each leaf's the entry after the leaf, and the leaves come in order (the
    /// last leaf ends the walk). Call on a tree whose children were checked (`validate_boxes`).
    fn validate_escapes(&self) -> std::result::Result<(), String> {
        let n = self.leaf_bounds.len() as u32;
        // Entries depth first, and where each internal node's subtree ends among them.
        let mut preorder = Vec::with_capacity(2 * n as usize - 1);
        let mut subtree_end = vec![0usize; n as usize - 1];
        let mut stack = vec![(0u32, false)];
        while let Some((entry, done)) = stack.pop() {
            if done {
                subtree_end[entry as usize] = preorder.len();
                continue;
            }
            preorder.push(entry);
            if entry & LEAF_BIT == 0 {
                let node = self.nodes[entry as usize];
                stack.push((entry, true));
                stack.push((node.right, false));
                stack.push((node.left, false));
            }
        }
        let after = |end: usize| preorder.get(end).copied().unwrap_or(NO_NODE);
        let leaves: Vec<u32> = preorder.iter().filter(|&&e| e & LEAF_BIT != 0).map(|&e| e & !LEAF_BIT).collect();
        if leaves.iter().enumerate().any(|(k, &leaf)| leaf != k as u32) {
            return Err("leaves are not in tree order depth first".into());
        }
        for (position, &entry) in preorder.iter().enumerate() {
            let index = entry & !LEAF_BIT;
            let (stored, expected, what) = if entry & LEAF_BIT != 0 {
                if index + 1 == n {
                    continue; // the last leaf ends the walk without a link
                }
                (self.nodes[index as usize].leaf_escape, after(position + 1), "leaf")
            } else {
                (self.nodes[index as usize].escape, after(subtree_end[index as usize]), "node")
            };
            if stored != expected {
                return Err(format!("{what} {index} escapes to {stored:#x}, not {expected:#x}"));
            }
        }
        Ok(())
    }
}
