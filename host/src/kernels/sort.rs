//! Radix sort and scan kernels (`drape_kernels::sort`). Their CPU adapters run one workgroup at
//! a time, phase by phase between the kernel's barriers, with the kernel's own functions.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::sort::{
    PACKED_WORDS, RADIX, SCAN_BLOCK, SCAN_ITEMS, SORT_TILE, count_index, digit, local_rank, pack_digits, scan_step,
};
use drape_types::SortPush;

const PUSH: u32 = size_of::<SortPush>() as u32;
/// Threads of a scan workgroup.
const SCAN_THREADS: u32 = 256;

pub static RADIX_COUNT: Kernel = Kernel {
    spec: KernelSpec {
        entry: "sort::radix_count",
        bindings: &[BindingSpec::read("keys"), BindingSpec::write("counts")],
        push_constant_size: PUSH,
        workgroup_size: SORT_TILE,
    },
    cpu: radix_count_cpu,
};

pub static RADIX_SCATTER: Kernel = Kernel {
    spec: KernelSpec {
        entry: "sort::radix_scatter",
        bindings: &[
            BindingSpec::read("keys_in"),
            BindingSpec::read("values_in"),
            BindingSpec::read("offsets"),
            BindingSpec::write("keys_out"),
            BindingSpec::write("values_out"),
        ],
        push_constant_size: PUSH,
        workgroup_size: SORT_TILE,
    },
    cpu: radix_scatter_cpu,
};

pub static SCAN_BLOCKS: Kernel = Kernel {
    spec: KernelSpec {
        entry: "sort::scan_blocks",
        bindings: &[BindingSpec::write("data"), BindingSpec::write("sums")],
        push_constant_size: PUSH,
        workgroup_size: SCAN_THREADS,
    },
    cpu: scan_blocks_cpu,
};

pub static SCAN_ADD: Kernel = Kernel {
    spec: KernelSpec {
        entry: "sort::scan_add",
        bindings: &[BindingSpec::write("data"), BindingSpec::read("sums")],
        push_constant_size: PUSH,
        workgroup_size: SCAN_THREADS,
    },
    cpu: scan_add_cpu,
};

fn radix_count_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SortPush = d.push_as();
    let workgroups = d.workgroups;
    let [keys, counts] = d.bindings()?;
    let (keys, counts) = (keys.slice::<u32>(), counts.slice_mut::<u32>());
    for group in 0..workgroups {
        let mut histogram = [0u32; RADIX as usize];
        for lane in 0..SORT_TILE {
            let i = group * SORT_TILE + lane;
            if i < push.count {
                histogram[digit(keys[i as usize], push.shift) as usize] += 1;
            }
        }
        for lane in 0..RADIX {
            counts[count_index(lane, group, push.tiles) as usize] = histogram[lane as usize];
        }
    }
    Ok(())
}

fn radix_scatter_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SortPush = d.push_as();
    let workgroups = d.workgroups;
    let [keys_in, values_in, offsets, keys_out, values_out] = d.bindings()?;
    let (keys_in, values_in, offsets) = (keys_in.slice::<u32>(), values_in.slice::<u32>(), offsets.slice::<u32>());
    let (keys_out, values_out) = (keys_out.slice_mut::<u32>(), values_out.slice_mut::<u32>());
    for group in 0..workgroups {
        let mut digits = [0u32; SORT_TILE as usize];
        for lane in 0..SORT_TILE {
            let i = group * SORT_TILE + lane;
            if i < push.count {
                digits[lane as usize] = digit(keys_in[i as usize], push.shift);
            }
        }
        let mut packed = [0u32; PACKED_WORDS];
        for (word, slot) in packed.iter_mut().enumerate() {
            *slot = pack_digits(&digits, word as u32);
        }
        for lane in 0..SORT_TILE {
            let i = group * SORT_TILE + lane;
            if i < push.count {
                let mine = digits[lane as usize];
                let dest = offsets[count_index(mine, group, push.tiles) as usize] + local_rank(&packed, lane, mine);
                keys_out[dest as usize] = keys_in[i as usize];
                values_out[dest as usize] = values_in[i as usize];
            }
        }
    }
    Ok(())
}

fn scan_blocks_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SortPush = d.push_as();
    let workgroups = d.workgroups;
    let [data, sums] = d.bindings()?;
    let (data, sums) = (data.slice_mut::<u32>(), sums.slice_mut::<u32>());
    for group in 0..workgroups {
        let base = |lane: u32| group * SCAN_BLOCK + lane * SCAN_ITEMS;
        let mut own = [0u32; SCAN_THREADS as usize];
        for lane in 0..SCAN_THREADS {
            own[lane as usize] =
                (0..SCAN_ITEMS).filter(|k| base(lane) + k < push.count).map(|k| data[(base(lane) + k) as usize]).sum();
        }
        let mut totals = own;
        let mut stride = 1;
        while stride < SCAN_THREADS {
            let previous = totals;
            for lane in 0..SCAN_THREADS {
                totals[lane as usize] = scan_step(&previous, lane, stride);
            }
            stride *= 2;
        }
        for lane in 0..SCAN_THREADS {
            let mut running = totals[lane as usize] - own[lane as usize];
            for k in 0..SCAN_ITEMS {
                let i = base(lane) + k;
                if i < push.count {
                    let value = data[i as usize];
                    data[i as usize] = running;
                    running += value;
                }
            }
        }
        sums[group as usize] = totals[SCAN_THREADS as usize - 1];
    }
    Ok(())
}

fn scan_add_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SortPush = d.push_as();
    let threads = d.invocations();
    let [data, sums] = d.bindings()?;
    let (data, sums) = (data.slice_mut::<u32>(), sums.slice::<u32>());
    for thread in 0..threads {
        for k in 0..SCAN_ITEMS {
            let i = thread * SCAN_ITEMS + k;
            if i < push.count {
                data[i as usize] += sums[(i / SCAN_BLOCK) as usize];
            }
        }
    }
    Ok(())
}
