//! Radix sort and scan kernels (`drape_kernels::sort`). Their CPU adapters run the kernels'
//! per-workgroup CPU twins one workgroup at a time.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::sort::{SCAN_BLOCK, SCAN_ITEMS, SORT_TILE, cpu_count_tile, cpu_scan_block, cpu_scatter_tile};
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
    for tile in 0..workgroups {
        cpu_count_tile(keys.slice(), counts.slice_mut(), &push, tile);
    }
    Ok(())
}

fn radix_scatter_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SortPush = d.push_as();
    let workgroups = d.workgroups;
    let [keys_in, values_in, offsets, keys_out, values_out] = d.bindings()?;
    let (keys_in, values_in, offsets) = (keys_in.slice::<u32>(), values_in.slice::<u32>(), offsets.slice::<u32>());
    let (keys_out, values_out) = (keys_out.slice_mut::<u32>(), values_out.slice_mut::<u32>());
    for tile in 0..workgroups {
        cpu_scatter_tile(keys_in, values_in, offsets, keys_out, values_out, &push, tile);
    }
    Ok(())
}

fn scan_blocks_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let push: SortPush = d.push_as();
    let workgroups = d.workgroups;
    let [data, sums] = d.bindings()?;
    for block in 0..workgroups {
        cpu_scan_block(data.slice_mut(), sums.slice_mut(), push.count, block);
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
