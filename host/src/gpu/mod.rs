//! The Vulkan engine: context, buffers, pipelines, command recording and timing. Every handle is
//! owned by exactly one RAII wrapper that holds an `Arc<Context>`.

pub mod buffer;
pub mod commands;
pub mod context;
pub mod engine;
pub mod pipeline;
pub mod recording;
pub mod reflect;

pub use buffer::Buffer;
pub use context::{Context, DeviceInfo, Validation};
pub use engine::Engine;
pub use pipeline::{BindingSpec, KernelSpec, Pipeline, ShaderModule};
pub use recording::{Command, FrameTimings, PassTiming, RecordedFrame};
