//! Built-in scenes shared by the CLI, the benchmarks and the tests.

use crate::cloth::ClothBuilder;
use glam::{Mat4, Vec3};

/// The default wind: a constant force on the whole cloth (N).
pub const DEFAULT_WIND: Vec3 = Vec3::new(0.3, 0.0, 0.5);

/// A `grid x grid`, 1 m, 0.2 kg cloth, 1 m above the origin, pinned at two corners, swinging
/// down under gravity with a light wind.
pub fn swinging_cloth(grid: u32) -> ClothBuilder {
    ClothBuilder::new(grid, grid)
        .external_force(DEFAULT_WIND)
        .transform(Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)))
        .pin_top_corners()
}
