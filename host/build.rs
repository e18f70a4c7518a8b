//! Compiles `kernels/shaders` to one SPIR-V module with spirv-builder and embeds it. A kernel
//! compile error fails this build: there is no fallback to stale SPIR-V.

use spirv_builder::{Capability, ModuleResult, SpirvBuilder, SpirvMetadata};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let manifest_dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    let kernels = manifest_dir.join("../kernels/shaders");
    let mut builder = SpirvBuilder::new(&kernels, "spirv-unknown-vulkan1.2")
        .multimodule(false)
        .spirv_metadata(SpirvMetadata::NameVariables)
        // Device-scope atomics under the Vulkan memory model (always on in rust-gpu 0.11).
        .capability(Capability::VulkanMemoryModelDeviceScope);
    builder.build_script.defaults = true;
    builder.target_dir_path = Some("spirv-builder".into());
    let result = builder.build()?;
    let path = match &result.module {
        ModuleResult::SingleModule(path) => path.clone(),
        ModuleResult::MultiModule(_) => return Err("expected a single SPIR-V module".into()),
    };
    let out = PathBuf::from(std::env::var("OUT_DIR")?).join("kernels_spv.rs");
    std::fs::write(
        &out,
        format!(
            "/// The kernels' SPIR-V module (every entry point).\npub const KERNELS_SPV: &[u8] = include_bytes!({:?});\n/// Entry points found by spirv-builder.\npub const ENTRY_POINTS: &[&str] = &{:?};\n",
            path.display().to_string(),
            result.entry_points
        ),
    )?;
    Ok(())
}
