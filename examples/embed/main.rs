//! drape embedded in an engine: the engine's own Vulkan device, drape's step and the engine's
//! graphics pass in one command buffer, the cloth drawn straight from drape's vertex buffers.
//!
//! ```text
//! cargo run --release --example embed -- --frames 60 --out DIR [--every 10] [--size 640x480]
//! ```
//! writes `DIR/frame_0010.png`, ..., `DIR/frame_0060.png`.

mod app;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: embed [--frames N] [--out DIR] [--every N] [--size WxH] [--grid N] [--voxels N]";

fn parse(args: impl Iterator<Item = String>) -> Result<app::Options, String> {
    let mut options = app::Options::default();
    let mut args = args.peekable();
    while let Some(flag) = args.next() {
        if flag == "--help" || flag == "-h" {
            return Err(USAGE.into());
        }
        let value = args.next().ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))?;
        let number = |v: &str| v.parse::<u32>().map_err(|e| format!("{flag} {v}: {e} (expected a whole number)"));
        match flag.as_str() {
            "--frames" => options.frames = number(&value)?,
            "--every" => options.every = number(&value)?,
            "--grid" => options.grid = number(&value)?,
            "--voxels" => options.voxels = number(&value)?,
            "--out" => options.out = Some(PathBuf::from(value)),
            "--size" => {
                let (w, h) =
                    value.split_once('x').ok_or_else(|| format!("--size {value}: expected WxH, e.g. 640x480"))?;
                options.width = number(w)?;
                options.height = number(h)?;
            }
            _ => return Err(format!("unknown flag {flag}\n{USAGE}")),
        }
    }
    Ok(options)
}

fn main() -> ExitCode {
    let options = match parse(std::env::args().skip(1)) {
        Ok(options) => options,
        Err(message) => {
            eprintln!("{message}");
            return ExitCode::from(2);
        }
    };
    match app::run(&options) {
        Ok(outcome) => {
            for path in &outcome.written {
                println!("wrote {}", path.display());
            }
            println!(
                "{} frames, {} particles{}",
                options.frames,
                outcome.cloth_positions.len(),
                if outcome.validated { ", validation clean" } else { " (validation layer not installed)" }
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("embed: {e}");
            ExitCode::FAILURE
        }
    }
}
