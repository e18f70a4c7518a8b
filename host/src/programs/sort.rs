//! Stable LSD radix sort of (u32 key, u32 value) pairs: 4 passes of 8 bits, each a per-tile
//! digit count, a scan of the counts and a stable scatter. Keys and values ping-pong through
//! scratch buffers and end where they started.

use super::scan::Scan;
use crate::graph::{Dispatch, Handle, Resources, Step};
use crate::kernels::sort::{RADIX_COUNT, RADIX_SCATTER};
use drape_kernels::sort::{RADIX, SORT_TILE};
use drape_types::SortPush;

/// Scratch buffers of a sort of `count` pairs.
pub struct RadixSort {
    count: u32,
    keys_scratch: Handle<u32>,
    values_scratch: Handle<u32>,
    counts: Handle<u32>,
    scan: Scan,
}

impl RadixSort {
    pub fn declare(resources: &mut Resources, name: &str, count: u32) -> Self {
        let tiles = count.div_ceil(SORT_TILE).max(1);
        RadixSort {
            count,
            keys_scratch: resources.device(format!("{name}: keys scratch"), count),
            values_scratch: resources.device(format!("{name}: values scratch"), count),
            counts: resources.device(format!("{name}: digit counts"), RADIX * tiles),
            scan: Scan::declare(resources, name, RADIX * tiles),
        }
    }

    /// Steps that sort `keys` (and `values` along) in place.
    pub fn steps(&self, keys: Handle<u32>, values: Handle<u32>, out: &mut Vec<Step>) {
        let tiles = self.count.div_ceil(SORT_TILE).max(1);
        let (a, b) = ((keys, values), (self.keys_scratch, self.values_scratch));
        for pass in 0..4u32 {
            let push = bytemuck::cast(SortPush { shift: 8 * pass, count: self.count, tiles, _pad: 0 });
            let (from, to) = if pass % 2 == 0 { (a, b) } else { (b, a) };
            let groups = Dispatch::Workgroups(tiles);
            out.push(Step::run_with("sort: count", &RADIX_COUNT, vec![from.0.id(), self.counts.id()], push, groups));
            self.scan.steps(self.counts, out);
            let bindings = vec![from.0.id(), from.1.id(), self.counts.id(), to.0.id(), to.1.id()];
            out.push(Step::run_with("sort: scatter", &RADIX_SCATTER, bindings, push, groups));
        }
    }
}
