//! The collider's LBVH: built on the GPU by `program::lbvh_build`, with a CPU twin made of the
//! same kernel functions, and `validate()` for the tree invariants.

use crate::error::{Error, Result};
use crate::gpu::{Context, Engine, FrameTimings};
use crate::program::{BufferId, lbvh_build, scan_levels};
use drape_kernels::lbvh::{build_node_at, morton_code, refit_from_leaf, sphere_aabb};
use drape_kernels::sort::{RADIX, SORT_TILE, cpu_radix_sort};
use drape_types::{AABB_WORDS, Aabb, BvhNode, ColliderParams, LEAF_BIT, NO_NODE};
use glam::{Vec3, Vec4, Vec4Swizzles};
use gpu_allocator::MemoryLocation;
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
        spheres.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), s| (lo.min(s.xyz()), hi.max(s.xyz())));
    Ok(ColliderParams {
        leaf_count: spheres.len() as u32,
        thickness,
        friction,
        _pad: 0,
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
    /// The leaves: spheres in sorted order.
    pub spheres: Vec<Vec4>,
    /// N - 1 internal nodes (root = 0).
    pub nodes: Vec<BvhNode>,
    /// Parent of internal node i at [i], of leaf j at [N - 1 + j]; the root's is `NO_NODE`.
    pub parents: Vec<u32>,
    pub aabbs: Vec<Aabb>,
}

/// Buffers the LBVH build needs, allocated in `engine` for `spheres`.
pub fn allocate(engine: &mut Engine, params: &ColliderParams, spheres: &[Vec4]) -> Result<()> {
    let n = params.leaf_count as u64;
    let tiles = (params.leaf_count.div_ceil(SORT_TILE)).max(1);
    engine.create_with(BufferId::Collider, std::slice::from_ref(params))?;
    engine.create_with(BufferId::Spheres, spheres)?;
    engine.create(BufferId::SortedSpheres, n * 16, MemoryLocation::GpuOnly)?;
    for id in [BufferId::KeysA, BufferId::KeysB, BufferId::ValuesA, BufferId::ValuesB] {
        engine.create(id, n * 4, MemoryLocation::GpuOnly)?;
    }
    engine.create(BufferId::Counts, (RADIX * tiles) as u64 * 4, MemoryLocation::GpuOnly)?;
    for (level, blocks) in scan_levels(RADIX * tiles).into_iter().enumerate() {
        engine.create(BufferId::ScanSums(level as u8), blocks as u64 * 4, MemoryLocation::GpuOnly)?;
    }
    let internal = (n - 1).max(1);
    engine.create(BufferId::Nodes, internal * 16, MemoryLocation::GpuOnly)?;
    engine.create(BufferId::Parents, (2 * n - 1) * 4, MemoryLocation::GpuOnly)?;
    engine.create(BufferId::Flags, internal * 4, MemoryLocation::GpuOnly)?;
    engine.create(BufferId::Aabbs, internal * AABB_WORDS as u64 * 4, MemoryLocation::GpuOnly)?;
    Ok(())
}

/// Builds the LBVH on the GPU in `engine` (after `allocate`); returns per-stage GPU timings.
pub fn build_gpu(engine: &mut Engine, params: &ColliderParams) -> Result<FrameTimings> {
    let frame = engine.record(&lbvh_build(params.leaf_count), true)?;
    frame.submit()
}

/// Reads the GPU-built tree back.
pub fn download(engine: &Engine, params: &ColliderParams) -> Result<Lbvh> {
    let n = params.leaf_count as usize;
    let internal = n - 1;
    Ok(Lbvh {
        codes: engine.download(BufferId::KeysA, n)?,
        order: engine.download(BufferId::ValuesA, n)?,
        spheres: engine.download(BufferId::SortedSpheres, n)?,
        nodes: engine.download(BufferId::Nodes, internal)?,
        parents: if n > 1 { engine.download(BufferId::Parents, 2 * n - 1)? } else { vec![NO_NODE] },
        aabbs: engine.download(BufferId::Aabbs, internal)?,
    })
}

/// A standalone GPU LBVH (tests, benchmarks): builds on creation.
pub struct GpuLbvh {
    pub engine: Engine,
    pub params: ColliderParams,
    pub timings: FrameTimings,
}

impl GpuLbvh {
    pub fn build(ctx: &Arc<Context>, spheres: &[Vec4], thickness: f32) -> Result<Self> {
        let params = collider_params(spheres, thickness, 0.0)?;
        let mut engine = Engine::new(ctx)?;
        allocate(&mut engine, &params, spheres)?;
        let timings = build_gpu(&mut engine, &params)?;
        Ok(GpuLbvh { engine, params, timings })
    }

    pub fn download(&self) -> Result<Lbvh> {
        download(&self.engine, &self.params)
    }
}

/// CPU twin of the build, with the kernels' functions.
pub fn build_cpu(spheres: &[Vec4], params: &ColliderParams) -> Lbvh {
    let n = params.leaf_count;
    let mut codes: Vec<u32> =
        spheres.iter().map(|s| morton_code(s.xyz(), params.scene_min.xyz(), params.scene_max.xyz())).collect();
    let mut order: Vec<u32> = (0..n).collect();
    cpu_radix_sort(&mut codes, &mut order);
    let sorted: Vec<Vec4> = order.iter().map(|&i| spheres[i as usize]).collect();
    let internal = n.saturating_sub(1) as usize;
    let mut nodes = vec![BvhNode::default(); internal];
    let mut parents = vec![NO_NODE; (2 * n - 1) as usize];
    for i in 0..internal as u32 {
        build_node_at(&codes, n, i, &mut nodes, &mut parents);
    }
    let mut flags = vec![0u32; internal];
    let mut words = vec![0u32; internal * AABB_WORDS as usize];
    if n >= 2 {
        for leaf in 0..n {
            refit_from_leaf(leaf, n, &nodes, &parents, &sorted, &mut flags, &mut words);
        }
    }
    let aabbs = words
        .as_chunks::<{ AABB_WORDS as usize }>()
        .0
        .iter()
        .map(|w| bytemuck::pod_read_unaligned::<Aabb>(bytemuck::cast_slice(w)))
        .collect();
    Lbvh { codes, order, spheres: sorted, nodes, parents, aabbs }
}

fn contains(outer: &Aabb, inner: &Aabb) -> bool {
    outer.min.truncate().cmple(inner.min.truncate()).all() && outer.max.truncate().cmpge(inner.max.truncate()).all()
}

impl Lbvh {
    /// Checks the invariants: codes sorted, `order` a permutation matching the leaves, every
    /// node and leaf reached exactly once from the root, parent links consistent, and every
    /// box containing its children (leaf boxes = sphere boxes).
    pub fn validate(&self, input: &[Vec4]) -> std::result::Result<(), String> {
        let n = input.len();
        if self.codes.len() != n || self.order.len() != n || self.spheres.len() != n {
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
            if self.spheres[sorted] != input[o] {
                return Err(format!("leaf {sorted} is not sphere {original}"));
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
                    if !contains(&b, &sphere_aabb(self.spheres[leaf])) {
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
        Ok(())
    }
}
