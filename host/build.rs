//! Embeds the kernels' SPIR-V.
//!
//! By default the module committed under `kernels/spirv/` is embedded, so crates that depend on
//! drape build on stable Rust without rust-gpu (no `rustc-dev`, no SPIR-V tools). With the
//! `rebuild-kernels` feature (what drape's own CI and developers use), `kernels/shaders` is
//! compiled with spirv-builder and the fresh module is embedded; a kernel compile error fails
//! the build (no fallback to stale SPIR-V), and `tests/engine.rs` checks that the committed
//! module equals the fresh one. `DRAPE_UPDATE_SPIRV=1` writes the fresh module to
//! `kernels/spirv/` (do that after changing a kernel, and commit it).

use std::path::{Path, PathBuf};

type Error = Box<dyn std::error::Error>;

fn main() -> Result<(), Error> {
    let manifest_dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    let committed = manifest_dir.join("../kernels/spirv");
    let (module, entry_points) = kernels(&manifest_dir, &committed)?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?).join("kernels_spv.rs");
    std::fs::write(
        &out,
        format!(
            "/// The kernels' SPIR-V module (every entry point).\npub const KERNELS_SPV: &[u8] = include_bytes!({:?});\n/// Entry points of the module.\npub const ENTRY_POINTS: &[&str] = &{:?};\n",
            module.display().to_string(),
            entry_points
        ),
    )?;
    Ok(())
}

#[cfg(not(feature = "rebuild-kernels"))]
fn committed_entry_points(committed: &Path) -> Result<Vec<String>, Error> {
    let text = std::fs::read_to_string(committed.join("entry_points.txt"))
        .map_err(|e| format!("{}: {e}", committed.join("entry_points.txt").display()))?;
    Ok(text.lines().filter(|l| !l.is_empty()).map(str::to_string).collect())
}

#[cfg(not(feature = "rebuild-kernels"))]
fn kernels(_manifest_dir: &Path, committed: &Path) -> Result<(PathBuf, Vec<String>), Error> {
    let module = committed.join("kernels.spv");
    println!("cargo:rerun-if-changed={}", module.display());
    println!("cargo:rerun-if-changed={}", committed.join("entry_points.txt").display());
    if !module.exists() {
        return Err(format!(
            "{} is missing: restore it from git, or build with `--features rebuild-kernels` (needs rust-gpu's nightly)",
            module.display()
        )
        .into());
    }
    Ok((module, committed_entry_points(committed)?))
}

#[cfg(feature = "rebuild-kernels")]
fn kernels(manifest_dir: &Path, committed: &Path) -> Result<(PathBuf, Vec<String>), Error> {
    use spirv_builder::{Capability, ModuleResult, SpirvBuilder, SpirvMetadata};
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
    if std::env::var_os("DRAPE_UPDATE_SPIRV").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(committed)?;
        std::fs::copy(&path, committed.join("kernels.spv"))?;
        std::fs::write(committed.join("entry_points.txt"), result.entry_points.join("\n") + "\n")?;
    }
    println!("cargo:rerun-if-env-changed=DRAPE_UPDATE_SPIRV");
    // Where the test comparing committed and fresh modules finds the committed one.
    println!("cargo:rustc-env=DRAPE_COMMITTED_SPIRV_DIR={}", committed.display());
    Ok((path, result.entry_points))
}
