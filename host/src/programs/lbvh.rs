//! The LBVH build over leaf boxes: Morton codes of the boxes' centres, radix sort, box gather,
//! Karras internal nodes, bottom-up boxes. What a leaf is belongs to its leaf kind
//! (`programs::spheres`), which writes `bounds` before the build and gathers its own data into
//! the tree's order after it.

use super::sort::RadixSort;
use crate::graph::{BufferId, Dispatch, Handle, Resources, Step};
use crate::kernels::lbvh::{BUILD_NODES, GATHER_BOUNDS, MORTON_CODES, REFIT, REFIT_TWO};
use drape_types::{Aabb, BvhNode, ColliderParams, DispatchArgs};

/// The buffers of one LBVH.
pub struct LbvhBuffers {
    pub leaves: u32,
    pub collider: Handle<ColliderParams>,
    /// Leaf boxes in input order (the leaf kind writes them), and in the tree's order.
    pub bounds: Handle<Aabb>,
    pub sorted_bounds: Handle<Aabb>,
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
            bounds: resources.device(format!("{name}: leaf boxes"), leaves),
            sorted_bounds: resources.device(format!("{name}: sorted leaf boxes"), leaves),
            codes: resources.device(format!("{name}: morton codes"), leaves),
            order: resources.device(format!("{name}: order"), leaves),
            sort: RadixSort::declare(resources, name, leaves),
            nodes: resources.device(format!("{name}: nodes"), internal),
            parents: resources.device(format!("{name}: parents"), 2 * leaves - 1),
            flags: resources.device(format!("{name}: refit flags"), internal),
            aabbs: resources.device(format!("{name}: boxes"), internal),
        }
    }

    /// The whole build, from `bounds` and `collider`.
    pub fn build_steps(&self) -> Vec<Step> {
        let mut steps = self.build_shape_steps();
        self.push_refit(&mut steps);
        steps
    }

    /// The build without its refit: Morton codes, sort, the leaf boxes gathered into the new
    /// order and the nodes (for a caller that refits them with more, `refit_with_steps`).
    pub fn build_shape_steps(&self) -> Vec<Step> {
        let n = self.leaves;
        let mut steps = vec![Step::run(
            "morton codes",
            &MORTON_CODES,
            vec![self.collider.id(), self.bounds.id(), self.codes.id(), self.order.id()],
            Dispatch::Threads(n),
        )];
        self.sort.steps(self.codes, self.order, &mut steps);
        steps.push(self.gather_step());
        steps.push(Step::run(
            "build nodes",
            &BUILD_NODES,
            vec![self.collider.id(), self.codes.id(), self.nodes.id(), self.parents.id()],
            Dispatch::Threads(n.saturating_sub(1).max(1)),
        ));
        steps
    }

    /// Refit after the leaves moved (same leaves, same tree; the leaf kind wrote new `bounds`):
    /// gather the boxes in the tree's order again and recompute every node's box bottom-up.
    /// The tree stays valid for any motion; its quality degrades only as leaves that were
    /// neighbours drift apart.
    pub fn refit_steps(&self) -> Vec<Step> {
        let mut steps = vec![self.gather_step()];
        self.push_refit(&mut steps);
        steps
    }

    /// Refits the tree over leaf boxes already written in its leaf order (`sorted_bounds`):
    /// `refit_steps` without the gather.
    pub fn refit_sorted_steps(&self) -> Vec<Step> {
        let mut steps = Vec::new();
        self.push_refit(&mut steps);
        steps
    }

    /// A second refit to the sorted leaves' boxes after `refit_sorted_steps`, over the
    /// workgroups `dispatch` holds (none leaves the first refit's boxes): its xyz words are
    /// written anew, the w words stay the zeros the first left.
    pub fn refit_sorted_again_steps(&self, dispatch: Handle<DispatchArgs>) -> Vec<Step> {
        let refit = self.refit_step("refit", (self.sorted_bounds, self.aabbs), Dispatch::Indirect(dispatch));
        vec![Step::fill(self.flags, 0), refit]
    }

    /// Another set of boxes over the same tree: the internal nodes' boxes (`aabbs`, one per
    /// internal node) of the leaves' `leaf_bounds` (tree order), e.g. what the leaves' points
    /// move by beside where they are.
    pub fn refit_other_steps(&self, label: &'static str, leaf_bounds: Handle<Aabb>, aabbs: Handle<Aabb>) -> Vec<Step> {
        self.refit_other_steps_over(label, (leaf_bounds, aabbs), Dispatch::Threads(self.leaves))
    }

    /// `refit_other_steps` dispatched as `dispatch` (an indirect one of none leaves the boxes
    /// as the fill leaves them: their readers must not run).
    pub fn refit_other_steps_over(
        &self,
        label: &'static str,
        boxes: (Handle<Aabb>, Handle<Aabb>),
        dispatch: Dispatch,
    ) -> Vec<Step> {
        let mut steps = Vec::new();
        self.push_refit_of(label, boxes, dispatch, &mut steps);
        steps
    }

    /// `refit_other_steps`' refit alone, dispatched as `dispatch` (at least one thread per
    /// leaf), for a caller that cleared the refit flags (`refit_flags`) itself and whose
    /// internal boxes' w words are already zero.
    pub fn refit_other_step(
        &self,
        label: &'static str,
        (leaf_bounds, aabbs): (Handle<Aabb>, Handle<Aabb>),
        dispatch: Dispatch,
    ) -> Step {
        self.refit_step(label, (leaf_bounds, aabbs), dispatch)
    }

    /// The refit's flags (one word per internal node, zero before a refit climbs).
    pub fn refit_flags(&self) -> BufferId {
        self.flags.id()
    }

    /// The refit of `refit_sorted_steps` and, in the same climb, of a second set of boxes over
    /// the tree (`other`: its leaves' boxes in tree order, its internal nodes' boxes), labelled
    /// `label` (`drape_kernels::lbvh::refit_two`).
    pub fn refit_with_steps(&self, label: &'static str, other: (Handle<Aabb>, Handle<Aabb>)) -> Vec<Step> {
        let (other_leaf_bounds, other_aabbs) = other;
        vec![
            Step::fill(self.flags, 0),
            // The refit writes xyz words only; zero the w words too.
            Step::fill(self.aabbs, 0),
            Step::fill(other_aabbs, 0),
            Step::run(
                label,
                &REFIT_TWO,
                vec![
                    self.collider.id(),
                    self.nodes.id(),
                    self.parents.id(),
                    self.sorted_bounds.id(),
                    other_leaf_bounds.id(),
                    self.flags.id(),
                    self.aabbs.id(),
                    other_aabbs.id(),
                ],
                Dispatch::Threads(self.leaves),
            ),
        ]
    }

    /// A leaf kind's build: its pass writing `bounds`, the build, its pass gathering its own
    /// leaves into the tree's order.
    pub fn build_around(&self, boxes: Step, gather: Step) -> Vec<Step> {
        let mut steps = vec![boxes];
        steps.extend(self.build_steps());
        steps.push(gather);
        steps
    }

    /// A leaf kind's refit after its leaves moved: the same passes around `refit_steps`.
    pub fn refit_around(&self, boxes: Step, gather: Step) -> Vec<Step> {
        let mut steps = vec![boxes];
        steps.extend(self.refit_steps());
        steps.push(gather);
        steps
    }

    /// The leaves' boxes (`bounds`) gathered into the tree's order (`sorted_bounds`).
    pub fn gather_step(&self) -> Step {
        Step::run(
            "gather leaf boxes",
            &GATHER_BOUNDS,
            vec![self.collider.id(), self.bounds.id(), self.order.id(), self.sorted_bounds.id()],
            Dispatch::Threads(self.leaves),
        )
    }

    fn push_refit(&self, steps: &mut Vec<Step>) {
        let every_leaf = Dispatch::Threads(self.leaves);
        self.push_refit_of("refit", (self.sorted_bounds, self.aabbs), every_leaf, steps);
    }

    /// The refit of `aabbs` to `leaf_bounds` over `dispatch`, its flags and boxes zeroed first.
    fn push_refit_of(
        &self,
        label: &'static str,
        (leaf_bounds, aabbs): (Handle<Aabb>, Handle<Aabb>),
        dispatch: Dispatch,
        steps: &mut Vec<Step>,
    ) {
        steps.push(Step::fill(self.flags, 0));
        // The refit writes xyz words only; zero the w words too.
        steps.push(Step::fill(aabbs, 0));
        steps.push(self.refit_step(label, (leaf_bounds, aabbs), dispatch));
    }

    /// The refit of `aabbs` to `leaf_bounds` (its flags zeroed before).
    fn refit_step(
        &self,
        label: &'static str,
        (leaf_bounds, aabbs): (Handle<Aabb>, Handle<Aabb>),
        dispatch: Dispatch,
    ) -> Step {
        Step::run(
            label,
            &REFIT,
            vec![self.collider.id(), self.nodes.id(), self.parents.id(), leaf_bounds.id(), self.flags.id(), aabbs.id()],
            dispatch,
        )
    }
}
