//! GPU radix sort of (key, value) u32 pairs, 8 bits per pass, and the exclusive prefix sum it
//! needs. Each pass: `radix_count` (per-tile digit histograms, digit-major table), a scan of that
//! table (`scan_blocks` / `scan_add`, as many levels as the size needs), `radix_scatter`
//! (stable: a key's rank among equal digits of its tile is counted in shared memory).
//!
//! The per-invocation math lives in plain functions; the kernels that need workgroup barriers
//! cannot run on the CPU, so the CPU twin (`cpu_radix_sort`, `cpu_exclusive_scan`) calls those
//! same functions in workgroup order.

use crate::atomics;
use drape_types::SortPush;
use drape_types::glam::UVec3;
use spirv_std::spirv;

/// Keys (and threads) per tile of the keys passes.
pub const SORT_TILE: u32 = 256;
/// Digit values per pass.
pub const RADIX: u32 = 256;
/// Elements per workgroup of the scan (4 per thread).
pub const SCAN_BLOCK: u32 = 1024;
/// Elements each scan thread adds up serially.
pub const SCAN_ITEMS: u32 = 4;
/// Words of a tile's digits packed four to a word (byte k of word w: position 4w + k).
pub const PACKED_WORDS: usize = SORT_TILE as usize / 4;

/// The 8-bit digit of `key` at bit offset `shift`.
#[inline]
pub fn digit(key: u32, shift: u32) -> u32 {
    (key >> shift) & (RADIX - 1)
}

/// Index of (digit, tile) in the digit-major count table.
#[inline]
pub fn count_index(digit: u32, tile: u32, tiles: u32) -> u32 {
    digit * tiles + tile
}

/// Number of zero bytes in `x` (exact: the high bit of each byte of `!t` is set iff that byte
/// is zero, with no borrow between bytes).
#[inline]
pub fn zero_bytes(x: u32) -> u32 {
    let t = ((x & 0x7f7f_7f7f) + 0x7f7f_7f7f) | x | 0x7f7f_7f7f;
    (!t).count_ones()
}

/// Packs the four digits of positions 4w..4w+3 into one word.
#[inline]
pub fn pack_digits(digits: &[u32; SORT_TILE as usize], word: u32) -> u32 {
    let base = (word * 4) as usize;
    digits[base] | (digits[base + 1] << 8) | (digits[base + 2] << 16) | (digits[base + 3] << 24)
}

/// Stable rank of the key at `position`, whose digit is `mine`, among the keys of its tile:
/// how many earlier positions hold the same digit. Compares four packed digits per step (a
/// plain loop over positions made the scatter 4x slower and dominated the whole LBVH build).
#[inline]
pub fn local_rank(packed: &[u32; PACKED_WORDS], position: u32, mine: u32) -> u32 {
    let pattern = mine * 0x0101_0101;
    let full = position / 4;
    let mut rank = 0;
    let mut w = 0;
    while w < full {
        rank += zero_bytes(packed[w as usize] ^ pattern);
        w += 1;
    }
    let rest = position % 4;
    if rest > 0 {
        // Only the low `rest` bytes precede `position`; make the others differ.
        let before = (1u32 << (8 * rest)) - 1;
        rank += zero_bytes((packed[full as usize] ^ pattern) | !before);
    }
    rank
}

#[cfg(target_arch = "spirv")]
fn barrier() {
    spirv_std::arch::workgroup_memory_barrier_with_group_sync();
}

/// Per-tile digit histogram into `counts[digit * tiles + tile]`.
#[spirv(compute(threads(256)))]
pub fn radix_count(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(push_constant)] push: &SortPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] counts: &mut [u32],
    #[spirv(workgroup)] histogram: &mut [u32; RADIX as usize],
) {
    histogram[lid.x as usize] = 0;
    #[cfg(target_arch = "spirv")]
    barrier();
    if gid.x < push.count {
        let d = digit(keys[gid.x as usize], push.shift);
        atomics::add_workgroup(&mut histogram[d as usize], 1);
    }
    #[cfg(target_arch = "spirv")]
    barrier();
    counts[count_index(lid.x, group.x, push.tiles) as usize] = histogram[lid.x as usize];
}

/// Moves each key (and value) to `scanned_counts[digit][tile] + local rank`.
#[allow(clippy::too_many_arguments)]
#[spirv(compute(threads(256)))]
pub fn radix_scatter(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(push_constant)] push: &SortPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys_in: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] values_in: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] keys_out: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] values_out: &mut [u32],
    #[spirv(workgroup)] digits: &mut [u32; SORT_TILE as usize],
    #[spirv(workgroup)] packed: &mut [u32; PACKED_WORDS],
) {
    let inside = gid.x < push.count;
    let key = if inside { keys_in[gid.x as usize] } else { 0 };
    // Positions past the end only occur at the end of the last tile, after every real key, so
    // their (zero) digit is never counted.
    let d = if inside { digit(key, push.shift) } else { 0 };
    digits[lid.x as usize] = d;
    #[cfg(target_arch = "spirv")]
    barrier();
    if (lid.x as usize) < PACKED_WORDS {
        packed[lid.x as usize] = pack_digits(digits, lid.x);
    }
    #[cfg(target_arch = "spirv")]
    barrier();
    if inside {
        let rank = local_rank(packed, lid.x, d);
        let dest = offsets[count_index(d, group.x, push.tiles) as usize] + rank;
        keys_out[dest as usize] = key;
        values_out[dest as usize] = values_in[gid.x as usize];
    }
}

/// Inclusive Hillis-Steele scan step `stride` over the thread totals in shared memory.
#[inline]
pub fn scan_step(totals: &[u32; 256], lane: u32, stride: u32) -> u32 {
    if lane >= stride { totals[lane as usize] + totals[(lane - stride) as usize] } else { totals[lane as usize] }
}

/// Exclusive scan of each block of `SCAN_BLOCK` entries in place; block totals into `sums`.
#[spirv(compute(threads(256)))]
pub fn scan_blocks(
    #[spirv(local_invocation_id)] lid: UVec3,
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(push_constant)] push: &SortPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] data: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sums: &mut [u32],
    #[spirv(workgroup)] totals: &mut [u32; 256],
    #[spirv(workgroup)] scratch: &mut [u32; 256],
) {
    let base = group.x * SCAN_BLOCK + lid.x * SCAN_ITEMS;
    let mut own = 0;
    let mut k = 0;
    while k < SCAN_ITEMS {
        if base + k < push.count {
            own += data[(base + k) as usize];
        }
        k += 1;
    }
    totals[lid.x as usize] = own;
    #[cfg(target_arch = "spirv")]
    barrier();
    // Inclusive scan of the 256 thread totals, ping-ponging between the two shared arrays.
    let mut stride = 1;
    let mut in_totals = true;
    while stride < 256 {
        if in_totals {
            scratch[lid.x as usize] = scan_step(totals, lid.x, stride);
        } else {
            totals[lid.x as usize] = scan_step(scratch, lid.x, stride);
        }
        #[cfg(target_arch = "spirv")]
        barrier();
        in_totals = !in_totals;
        stride *= 2;
    }
    // 8 steps: the result is back in `totals`.
    let inclusive = totals[lid.x as usize];
    let mut running = inclusive - own;
    let mut k = 0;
    while k < SCAN_ITEMS {
        if base + k < push.count {
            let value = data[(base + k) as usize];
            data[(base + k) as usize] = running;
            running += value;
        }
        k += 1;
    }
    if lid.x == 255 {
        sums[group.x as usize] = inclusive;
    }
}

/// Adds each block's scanned total to its entries (second half of a multi-level scan).
#[spirv(compute(threads(256)))]
pub fn scan_add(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(push_constant)] push: &SortPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] data: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sums: &[u32],
) {
    let mut k = 0;
    while k < SCAN_ITEMS {
        let i = gid.x * SCAN_ITEMS + k;
        if i < push.count {
            data[i as usize] += sums[(i / SCAN_BLOCK) as usize];
        }
        k += 1;
    }
}

/// CPU twin of one `radix_count` workgroup: tile `tile`'s digit histogram into `counts`.
#[cfg(not(target_arch = "spirv"))]
pub fn cpu_count_tile(keys: &[u32], counts: &mut [u32], push: &SortPush, tile: u32) {
    let mut histogram = [0u32; RADIX as usize];
    for lane in 0..SORT_TILE {
        let i = tile * SORT_TILE + lane;
        if i < push.count {
            histogram[digit(keys[i as usize], push.shift) as usize] += 1;
        }
    }
    for lane in 0..RADIX {
        counts[count_index(lane, tile, push.tiles) as usize] = histogram[lane as usize];
    }
}

/// CPU twin of one `radix_scatter` workgroup, with the kernel's packed-digit rank.
#[cfg(not(target_arch = "spirv"))]
#[allow(clippy::too_many_arguments)]
pub fn cpu_scatter_tile(
    keys_in: &[u32],
    values_in: &[u32],
    offsets: &[u32],
    keys_out: &mut [u32],
    values_out: &mut [u32],
    push: &SortPush,
    tile: u32,
) {
    let mut digits = [0u32; SORT_TILE as usize];
    for lane in 0..SORT_TILE {
        let i = tile * SORT_TILE + lane;
        if i < push.count {
            digits[lane as usize] = digit(keys_in[i as usize], push.shift);
        }
    }
    let mut packed = [0u32; PACKED_WORDS];
    for (word, slot) in packed.iter_mut().enumerate() {
        *slot = pack_digits(&digits, word as u32);
    }
    for lane in 0..SORT_TILE {
        let i = tile * SORT_TILE + lane;
        if i < push.count {
            let mine = digits[lane as usize];
            let dest = offsets[count_index(mine, tile, push.tiles) as usize] + local_rank(&packed, lane, mine);
            keys_out[dest as usize] = keys_in[i as usize];
            values_out[dest as usize] = values_in[i as usize];
        }
    }
}

/// CPU twin of one `scan_blocks` workgroup: block `block` of the first `count` entries of
/// `data` scanned in place (exclusive), its total into `sums[block]`.
#[cfg(not(target_arch = "spirv"))]
pub fn cpu_scan_block(data: &mut [u32], sums: &mut [u32], count: u32, block: u32) {
    let base = |lane: u32| block * SCAN_BLOCK + lane * SCAN_ITEMS;
    let mut own = [0u32; 256];
    for lane in 0..256u32 {
        own[lane as usize] =
            (0..SCAN_ITEMS).filter(|k| base(lane) + k < count).map(|k| data[(base(lane) + k) as usize]).sum();
    }
    let mut totals = own;
    let mut stride = 1;
    while stride < 256 {
        let previous = totals;
        for lane in 0..256u32 {
            totals[lane as usize] = scan_step(&previous, lane, stride);
        }
        stride *= 2;
    }
    for lane in 0..256u32 {
        let mut running = totals[lane as usize] - own[lane as usize];
        for k in 0..SCAN_ITEMS {
            let i = base(lane) + k;
            if i < count {
                let value = data[i as usize];
                data[i as usize] = running;
                running += value;
            }
        }
    }
    sums[block as usize] = totals[255];
}

/// CPU twin of the multi-level scan (`scan_blocks`, then recursively the sums, then
/// `scan_add`), workgroup by workgroup.
#[cfg(not(target_arch = "spirv"))]
pub fn cpu_exclusive_scan(data: &mut [u32]) {
    let count = data.len() as u32;
    let blocks = count.div_ceil(SCAN_BLOCK).max(1);
    let mut sums = vec![0u32; blocks as usize];
    for block in 0..blocks {
        cpu_scan_block(data, &mut sums, count, block);
    }
    if blocks > 1 {
        cpu_exclusive_scan(&mut sums);
        for (i, value) in data.iter_mut().enumerate() {
            *value += sums[i / SCAN_BLOCK as usize];
        }
    }
}

/// CPU twin of the whole sort (4 passes of count, scan, scatter). Sorts by key, stably.
#[cfg(not(target_arch = "spirv"))]
pub fn cpu_radix_sort(keys: &mut Vec<u32>, values: &mut Vec<u32>) {
    let count = keys.len() as u32;
    let tiles = count.div_ceil(SORT_TILE).max(1);
    for pass in 0..4 {
        let push = SortPush { shift: pass * 8, count, tiles, _pad: 0 };
        let mut counts = vec![0u32; (RADIX * tiles) as usize];
        for tile in 0..tiles {
            cpu_count_tile(keys, &mut counts, &push, tile);
        }
        cpu_exclusive_scan(&mut counts);
        let mut keys_out = vec![0u32; keys.len()];
        let mut values_out = vec![0u32; keys.len()];
        for tile in 0..tiles {
            cpu_scatter_tile(keys, values, &counts, &mut keys_out, &mut values_out, &push, tile);
        }
        *keys = keys_out;
        *values = values_out;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_bytes_counts_exactly() {
        assert_eq!(zero_bytes(0), 4);
        assert_eq!(zero_bytes(0xffff_ffff), 0);
        assert_eq!(zero_bytes(0x0100_0001), 2);
        assert_eq!(zero_bytes(0x8000_0080), 2);
        assert_eq!(zero_bytes(0x0001_0000), 3);
    }

    #[test]
    fn packed_rank_equals_counting_one_by_one() {
        let mut digits = [0u32; SORT_TILE as usize];
        for (i, d) in digits.iter_mut().enumerate() {
            *d = ((i * 37 + i / 7) % 5) as u32 * 51;
        }
        let mut packed = [0u32; PACKED_WORDS];
        for (w, slot) in packed.iter_mut().enumerate() {
            *slot = pack_digits(&digits, w as u32);
        }
        for position in 0..SORT_TILE {
            let mine = digits[position as usize];
            let expected = digits[..position as usize].iter().filter(|&&d| d == mine).count() as u32;
            assert_eq!(local_rank(&packed, position, mine), expected, "position {position}");
        }
    }

    #[test]
    fn cpu_sort_is_stable_and_sorted() {
        let mut keys: Vec<u32> = (0..3000u32).map(|i| (i.wrapping_mul(2654435761) >> 7) % 97).collect();
        let mut values: Vec<u32> = (0..3000).collect();
        let mut expected: Vec<(u32, u32)> = keys.iter().copied().zip(values.iter().copied()).collect();
        expected.sort_by_key(|&(k, _)| k);
        cpu_radix_sort(&mut keys, &mut values);
        let got: Vec<(u32, u32)> = keys.into_iter().zip(values).collect();
        assert_eq!(got, expected);
    }
}
