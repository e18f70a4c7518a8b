//! The LBVH build over sphere leaves: Morton codes, radix sort, leaf gather, Karras internal
//! nodes, bottom-up boxes.

use super::sort::RadixSort;
use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::lbvh::{BUILD_NODES, GATHER_LEAVES, MORTON_CODES, REFIT};
use drape_types::{Aabb, BvhNode, ColliderParams};
use glam::Vec4;

/// The buffers of one LBVH.
pub struct LbvhBuffers {
    pub leaves: u32,
    pub collider: Handle<ColliderParams>,
    /// Leaves in input order, and in Morton order.
    pub spheres: Handle<Vec4>,
    pub sorted: Handle<Vec4>,
    /// Sorted Morton codes, and the input index of each sorted leaf.
    pub codes: Handle<u32>,
    pub order: Handle<u32>,
    sort: RadixSort,
    pub nodes: Handle<BvhNode>,
    pub parents: Handle<u32>,
    flags: Handle<u32>,
    pub aabbs: Handle<Aabb>,
}

impl LbvhBuffers {
    /// Buffers for `leaves` >= 1 leaves.
    pub fn declare(resources: &mut Resources, name: &str, leaves: u32) -> Self {
        let internal = leaves.saturating_sub(1).max(1);
        LbvhBuffers {
            leaves,
            collider: resources.device(format!("{name}: params"), 1),
            spheres: resources.device(format!("{name}: spheres"), leaves),
            sorted: resources.device(format!("{name}: sorted spheres"), leaves),
            codes: resources.device(format!("{name}: morton codes"), leaves),
            order: resources.device(format!("{name}: order"), leaves),
            sort: RadixSort::declare(resources, name, leaves),
            nodes: resources.device(format!("{name}: nodes"), internal),
            parents: resources.device(format!("{name}: parents"), 2 * leaves - 1),
            flags: resources.device(format!("{name}: refit flags"), internal),
            aabbs: resources.device(format!("{name}: boxes"), internal),
        }
    }

    /// The whole build, from `spheres` and `collider`.
    pub fn build_steps(&self) -> Vec<Step> {
        let n = self.leaves;
        let mut steps = vec![Step::run(
            "morton codes",
            &MORTON_CODES,
            vec![self.collider.id(), self.spheres.id(), self.codes.id(), self.order.id()],
            Dispatch::Threads(n),
        )];
        self.sort.steps(self.codes, self.order, &mut steps);
        steps.push(Step::run(
            "gather leaves",
            &GATHER_LEAVES,
            vec![self.collider.id(), self.spheres.id(), self.order.id(), self.sorted.id()],
            Dispatch::Threads(n),
        ));
        steps.push(Step::run(
            "build nodes",
            &BUILD_NODES,
            vec![self.collider.id(), self.codes.id(), self.nodes.id(), self.parents.id()],
            Dispatch::Threads(n.saturating_sub(1).max(1)),
        ));
        self.push_refit(&mut steps);
        steps
    }

    /// Refit after the leaves moved (same leaves, same tree): gather the leaves in the tree's
    /// order again and recompute every box bottom-up. The tree stays valid for any motion;
    /// its quality degrades only as leaves that were neighbours drift apart.
    pub fn refit_steps(&self) -> Vec<Step> {
        let mut steps = vec![Step::run(
            "gather leaves",
            &GATHER_LEAVES,
            vec![self.collider.id(), self.spheres.id(), self.order.id(), self.sorted.id()],
            Dispatch::Threads(self.leaves),
        )];
        self.push_refit(&mut steps);
        steps
    }

    fn push_refit(&self, steps: &mut Vec<Step>) {
        let n = self.leaves;
        steps.push(Step::fill(self.flags, 0));
        // The refit writes xyz words only; zero the w words too.
        steps.push(Step::fill(self.aabbs, 0));
        steps.push(Step::run(
            "refit",
            &REFIT,
            vec![
                self.collider.id(),
                self.nodes.id(),
                self.parents.id(),
                self.sorted.id(),
                self.flags.id(),
                self.aabbs.id(),
            ],
            Dispatch::Threads(n),
        ));
    }
}
