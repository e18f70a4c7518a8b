//! Shared test helpers: a validated Vulkan context and small comparisons.
#![allow(dead_code)]

use drape::{Context, Validation};
use glam::Vec4;
use std::sync::Arc;

/// A context with the validation layer on; tests fail if it is missing or reports an error.
pub fn context() -> Arc<Context> {
    let ctx = Context::new(Validation::Required).expect("Vulkan with VK_LAYER_KHRONOS_validation");
    assert!(ctx.validation_enabled());
    ctx
}

/// Fails the test if the validation layer reported any error.
pub fn assert_validation_clean(ctx: &Context) {
    let errors = ctx.take_validation_errors();
    assert!(errors.is_empty(), "validation errors:\n{}", errors.join("\n"));
}

/// Largest distance between corresponding xyz.
pub fn max_distance(a: &[Vec4], b: &[Vec4]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(p, q)| (p.truncate() - q.truncate()).length()).fold(0.0, f32::max)
}
