//! Multi-level exclusive scan of u32s in place: scan blocks, scan their sums (recursively), add.

use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::sort::{SCAN_ADD, SCAN_BLOCKS};
use drape_kernels::sort::SCAN_BLOCK;
use drape_types::SortPush;

/// The block-sum buffers of a scan of `count` entries, one per level.
pub struct Scan {
    count: u32,
    sums: Vec<Handle<u32>>,
}

/// Sizes (in u32) of the scan's block-sum buffers for `count` entries, level by level.
pub fn scan_levels(count: u32) -> Vec<u32> {
    let mut levels = Vec::new();
    let mut n = count;
    loop {
        let blocks = n.div_ceil(SCAN_BLOCK).max(1);
        levels.push(blocks);
        if blocks == 1 {
            return levels;
        }
        n = blocks;
    }
}

impl Scan {
    pub fn declare(resources: &mut Resources, name: &str, count: u32) -> Self {
        let sums = scan_levels(count)
            .into_iter()
            .enumerate()
            .map(|(level, blocks)| resources.device(format!("{name}: scan sums {level}"), blocks))
            .collect();
        Scan { count, sums }
    }

    /// Steps that scan `data` (at least `count` entries) in place.
    pub fn steps(&self, data: Handle<u32>, out: &mut Vec<Step>) {
        self.level(data, self.count, 0, out);
    }

    fn level(&self, data: Handle<u32>, count: u32, level: usize, out: &mut Vec<Step>) {
        let blocks = count.div_ceil(SCAN_BLOCK).max(1);
        let sums = self.sums[level];
        let push = bytemuck::cast(SortPush { shift: 0, count, tiles: blocks, _pad: 0 });
        let bindings = vec![data.id(), sums.id()];
        out.push(Step::run_with("sort: scan", &SCAN_BLOCKS, bindings.clone(), push, Dispatch::Workgroups(blocks)));
        if blocks > 1 {
            self.level(sums, blocks, level + 1, out);
            // Each thread adds to SCAN_ITEMS entries: one workgroup per block again.
            out.push(Step::run_with("sort: scan", &SCAN_ADD, bindings, push, Dispatch::Workgroups(blocks)));
        }
    }
}
