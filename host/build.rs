//! Embeds the kernels' SPIR-V: one module per entry point.
//!
//! One module per entry point, because a driver compiles a pipeline from its whole module:
//! NVIDIA's (580, H100) took 400-600 ms per kernel from the single 1.5 MB module holding every
//! entry point and 20-60 ms from a module holding only its own entry point's code.
//!
//! By default the modules committed under `kernels/spirv/` are embedded, so crates that depend
//! on drape build on stable Rust without rust-gpu (no `rustc-dev`, no SPIR-V tools). With the
//! `rebuild-kernels` feature (what drape's own CI and developers use), `kernels/shaders` is
//! compiled with spirv-builder and the fresh modules are embedded; a kernel compile error fails
//! the build (no fallback to stale SPIR-V), and `tests/engine.rs` checks that the committed
//! modules equal the fresh ones. `DRAPE_UPDATE_SPIRV=1` writes the fresh modules to
//! `kernels/spirv/` (do that after changing a kernel, and commit it).

use std::path::{Path, PathBuf};

type Error = Box<dyn std::error::Error>;

fn main() -> Result<(), Error> {
    let manifest_dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    let committed = manifest_dir.join("../kernels/spirv");
    let modules = kernels(&manifest_dir, &committed)?;
    let mut table = String::new();
    for (entry, path) in &modules {
        table += &format!("    ({entry:?}, include_bytes!({:?})),\n", path.display().to_string());
    }
    let entries: Vec<&str> = modules.iter().map(|(entry, _)| entry.as_str()).collect();
    let out = PathBuf::from(std::env::var("OUT_DIR")?).join("kernels_spv.rs");
    std::fs::write(
        &out,
        format!(
            "/// The kernels' SPIR-V: each entry point's own module, by entry point name.\n\
             pub const KERNEL_MODULES: &[(&str, &[u8])] = &[\n{table}];\n\
             /// Entry points of the modules.\npub const ENTRY_POINTS: &[&str] = &{entries:?};\n"
        ),
    )?;
    Ok(())
}

/// The committed module file of an entry point (`::` is not portable in file names).
fn module_file(committed: &Path, entry: &str) -> PathBuf {
    committed.join(format!("{}.spv", entry.replace("::", ".")))
}

#[cfg(not(feature = "rebuild-kernels"))]
fn kernels(_manifest_dir: &Path, committed: &Path) -> Result<Vec<(String, PathBuf)>, Error> {
    let list = committed.join("entry_points.txt");
    println!("cargo:rerun-if-changed={}", committed.display());
    let text = std::fs::read_to_string(&list).map_err(|e| format!("{}: {e}", list.display()))?;
    let mut modules = Vec::new();
    for entry in text.lines().filter(|l| !l.is_empty()) {
        let module = module_file(committed, entry);
        if !module.exists() {
            return Err(format!(
                "{} is missing: restore kernels/spirv/ from git, or build with `--features rebuild-kernels` \
                 (needs rust-gpu's nightly)",
                module.display()
            )
            .into());
        }
        modules.push((entry.to_string(), module));
    }
    Ok(modules)
}

#[cfg(feature = "rebuild-kernels")]
fn kernels(manifest_dir: &Path, committed: &Path) -> Result<Vec<(String, PathBuf)>, Error> {
    use spirv_builder::{Capability, ModuleResult, SpirvBuilder, SpirvMetadata};
    let kernels = manifest_dir.join("../kernels/shaders");
    let mut builder = SpirvBuilder::new(&kernels, "spirv-unknown-vulkan1.2")
        .multimodule(true)
        .spirv_metadata(SpirvMetadata::NameVariables)
        // Device-scope atomics under the Vulkan memory model (always on in rust-gpu 0.11).
        .capability(Capability::VulkanMemoryModelDeviceScope);
    builder.build_script.defaults = true;
    builder.target_dir_path = Some("spirv-builder".into());
    let result = builder.build()?;
    let modules: Vec<(String, PathBuf)> = match result.module {
        ModuleResult::MultiModule(modules) => modules.into_iter().collect(),
        ModuleResult::SingleModule(_) => return Err("expected one SPIR-V module per entry point".into()),
    };
    if std::env::var_os("DRAPE_UPDATE_SPIRV").is_some_and(|v| v == "1") {
        // Replace the directory's modules, so a removed entry point leaves no stale file.
        std::fs::create_dir_all(committed)?;
        for file in std::fs::read_dir(committed)? {
            let path = file?.path();
            if path.extension().is_some_and(|e| e == "spv") {
                std::fs::remove_file(&path)?;
            }
        }
        for (entry, path) in &modules {
            std::fs::copy(path, module_file(committed, entry))?;
        }
        let entries: Vec<&str> = modules.iter().map(|(entry, _)| entry.as_str()).collect();
        std::fs::write(committed.join("entry_points.txt"), entries.join("\n") + "\n")?;
    }
    println!("cargo:rerun-if-env-changed=DRAPE_UPDATE_SPIRV");
    // Where the test comparing committed and fresh modules finds the committed ones.
    println!("cargo:rustc-env=DRAPE_COMMITTED_SPIRV_DIR={}", committed.display());
    Ok(modules)
}
