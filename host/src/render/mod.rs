//! Pictures of a simulation: an offscreen Vulkan renderer that draws cloths straight from a
//! solver's vertex buffers and colliders from meshes it uploads, with a fixed camera, into an
//! image it reads back (the CLI's `--png-dir`, the embedding example, tests that check what a
//! renderer sees). It needs a queue family with graphics; drape's own context picks one where
//! the device has it.
//!
//! Two ways to use it: [`Renderer::render`] records, submits and waits on its own command
//! buffer (safe; the draws borrow what they bind), and [`Renderer::record`] records into the
//! caller's command buffer after drape's frame (an engine's single submission).

mod camera;
mod pipeline;
mod renderer;
mod surface_mesh;
mod target;

pub use camera::{Camera, scene_box};
pub use renderer::{Draw, Picture, RawDraw, Renderer};
pub use surface_mesh::SurfaceMesh;

/// Linear RGB of a cloth, a = ambient share: red dominant (tests tell it from the collider).
pub const CLOTH_COLOR: glam::Vec4 = glam::Vec4::new(0.85, 0.22, 0.18, 0.35);
/// Linear RGB of a collider, a = ambient share: blue dominant.
pub const COLLIDER_COLOR: glam::Vec4 = glam::Vec4::new(0.30, 0.45, 0.80, 0.35);
/// Colours of further colliders (linear RGB, a = ambient share), so several are told apart:
/// teal, sand, grey, then round again.
const MORE_COLLIDER_COLORS: [glam::Vec4; 3] = [
    glam::Vec4::new(0.22, 0.55, 0.50, 0.35),
    glam::Vec4::new(0.62, 0.55, 0.40, 0.35),
    glam::Vec4::new(0.45, 0.45, 0.50, 0.35),
];

/// The colour of collider `index`: the first [`COLLIDER_COLOR`], the others from a palette.
pub fn collider_color(index: usize) -> glam::Vec4 {
    match index {
        0 => COLLIDER_COLOR,
        i => MORE_COLLIDER_COLORS[(i - 1) % MORE_COLLIDER_COLORS.len()],
    }
}

/// The cleared background (linear RGBA).
pub const BACKGROUND: [f32; 4] = [0.02, 0.025, 0.035, 1.0];
