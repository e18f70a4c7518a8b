//! Tile sleeping's kernels (`drape_kernels::tiles`): each tile's motion over the frame and its
//! box at the frame's end, and each tile's sleep at the next frame's start.

use crate::graph::{BindingSpec, HostDispatch, Kernel, KernelSpec};
use drape_kernels::tiles::{TILE_THREADS, decide_tile_at, measure_tile_at};
use drape_types::{Aabb, Health, TileParams};
use glam::Vec4;

pub static MEASURE_TILES: Kernel = Kernel {
    spec: KernelSpec::new(
        "tiles::measure_tiles",
        &[
            BindingSpec::read("tile_params"),
            BindingSpec::read("member_offsets"),
            BindingSpec::read("members"),
            BindingSpec::read("x"),
            BindingSpec::write("rest"),
            BindingSpec::write("motion"),
            BindingSpec::write("bounds"),
        ],
        TILE_THREADS,
    ),
    cpu: measure_cpu,
};

pub static DECIDE_TILES: Kernel = Kernel {
    spec: KernelSpec::new(
        "tiles::decide_tiles",
        &[
            BindingSpec::read("tile_params"),
            BindingSpec::read("member_offsets"),
            BindingSpec::read("members"),
            BindingSpec::read("motion"),
            BindingSpec::read("bounds"),
            BindingSpec::read("neighbour_offsets"),
            BindingSpec::read("neighbours"),
            BindingSpec::read("moving_boxes"),
            BindingSpec::write("calm_frames"),
            BindingSpec::write("v"),
            BindingSpec::write("health"),
        ],
        TILE_THREADS,
    ),
    cpu: decide_cpu,
};

fn measure_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, offsets, members, x, rest, motion, bounds] = d.bindings()?;
    let p: TileParams = params.first()?;
    let tiles = (offsets.slice::<u32>(), members.slice::<u32>());
    let (x, rest) = (x.slice::<Vec4>(), rest.slice_mut::<Vec4>());
    let (motion, bounds) = (motion.slice_mut::<f32>(), bounds.slice_mut::<Aabb>());
    // The workgroups take every tile between them (`tile_workgroups`).
    for t in 0..if threads >= TILE_THREADS { p.tile_count } else { 0 } {
        measure_tile_at(t, tiles, x, rest, motion, bounds);
    }
    Ok(())
}

fn decide_cpu(d: &mut HostDispatch<'_>) -> Result<(), String> {
    let threads = d.invocations();
    let [params, member_offsets, members, motion, bounds, offsets, neighbours, moving, frames, v, health] =
        d.bindings()?;
    let p: TileParams = params.first()?;
    let members = (member_offsets.slice::<u32>(), members.slice::<u32>());
    let tiles = (motion.slice::<f32>(), bounds.slice::<Aabb>());
    let graph = (offsets.slice::<u32>(), neighbours.slice::<u32>());
    let (moving, frames, v) = (moving.slice::<Aabb>(), frames.slice_mut::<u32>(), v.slice_mut::<Vec4>());
    let health = health.first_mut::<Health>()?;
    for t in 0..if threads >= TILE_THREADS { p.tile_count } else { 0 } {
        decide_tile_at(t, &p, members, tiles, graph, moving, frames, v, health);
    }
    Ok(())
}
