//! The Vulkan executor: context, buffers, pipelines, command recording and timing. Every handle
//! is owned by exactly one RAII wrapper that holds an `Arc<Context>`. It runs the description
//! layer's step lists (`crate::graph`) and knows nothing of cloths or colliders.

pub mod buffer;
pub mod commands;
pub mod context;
pub mod engine;
pub mod image;
mod loader_lock;
pub mod pipeline;
pub mod portability;
pub mod recording;
pub mod reflect;
pub mod spirv;
mod staging;
pub(crate) mod status_ring;

pub use buffer::Buffer;
pub use context::{AllocatorStats, Context, DeviceInfo, ExternalDevice, Validation};
pub use engine::Engine;
pub use image::Image;
pub use loader_lock::vulkan_loader_lock;
pub use pipeline::{Pipeline, ShaderModule};
pub use recording::{Command, FrameBindings, FrameTimings, PassTiming, RecordedFrame};
