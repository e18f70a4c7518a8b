//! drape's error type: every failure the library can report, with a message that says what to do.

use std::path::PathBuf;

/// Errors returned by drape. The library never panics on bad input or Vulkan failures.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// No Vulkan loader could be opened.
    #[error(
        "no Vulkan loader found ({0}); install a Vulkan driver: on machines without a GPU, Mesa's \
         lavapipe >= 25 (Debian: `apt-get install -t bookworm-backports mesa-vulkan-drivers libvulkan1`)"
    )]
    NoVulkanLoader(String),
    /// A loader exists but no device offers a compute queue.
    #[error(
        "no Vulkan device with a compute queue; install a Vulkan driver (lavapipe >= 25 on machines \
         without a GPU: `apt-get install -t bookworm-backports mesa-vulkan-drivers`)"
    )]
    NoComputeDevice,
    /// The device lacks a feature the kernels need.
    #[error("Vulkan device `{device}` lacks {feature}; use Mesa >= 25 lavapipe or a recent GPU driver")]
    MissingFeature { device: String, feature: &'static str },
    /// A Vulkan call failed.
    #[error("Vulkan call `{call}` failed: {result}")]
    Vulkan { call: &'static str, result: ash::vk::Result },
    /// GPU memory allocation failed.
    #[error("GPU memory allocation failed: {0}")]
    Allocation(#[from] gpu_allocator::AllocationError),
    /// The embedded SPIR-V does not match what the host expects.
    #[error("kernel `{kernel}`: {problem}")]
    Kernel { kernel: String, problem: String },
    /// Validation layers reported an error (only when validation is on).
    #[error("Vulkan validation error: {0}")]
    Validation(String),
    /// A parameter is out of its valid range.
    #[error("invalid parameter `{name}`: {problem}")]
    InvalidParameter { name: &'static str, problem: String },
    /// The simulation blew up; the message names the quantity that drove it, a value of it that
    /// would be stable, and the substeps that would be.
    #[error(
        "cloth {cloth} became unstable at frame {frame} ({detail}): {cause}; {}",
        substeps_remedy(*automatic_substeps, *suggested_substeps)
    )]
    Unstable {
        cloth: usize,
        frame: u64,
        detail: String,
        /// What drove it and a stable value (`stability::diagnosis`).
        cause: String,
        substep: f32,
        bound: f32,
        suggested_substeps: u32,
        /// Whether the substeps were automatic (the stability bound's), not the caller's.
        automatic_substeps: bool,
    },
    /// A mesh file or mesh parameter is unusable; names the file and line where there is one.
    #[error("mesh {path}: {problem}")]
    Mesh { path: PathBuf, problem: String },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// Result with drape's error.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Adds the name of the failing Vulkan call to an `ash` result.
pub(crate) trait VkContext<T> {
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, ash::vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}

/// What the blow-up message offers on substeps: a fixed count above the automatic one (which
/// ran), or that count or automatic substeps (the caller fixed fewer).
fn substeps_remedy(automatic: bool, suggested: u32) -> String {
    if automatic {
        format!("or fix at least {suggested} substeps per frame (`SimSettings::with_substeps`, CLI --substeps)")
    } else {
        format!("or use at least {suggested} substeps per frame (or automatic substeps)")
    }
}
