//! `murk render`.

use anyhow::{Result, anyhow};
use murk::render::{RenderOptions, RenderPlan, run as render};
use std::path::Path;

pub const EXAMPLES: &str = "Examples:
  murk render fixtures/cloud.vdb -o cloud.exr --preview cloud.png
  murk render fixtures/cloud.vdb -o cloud.exr --res 320x180 --light sun:1,1,0:1,0.9,0.8:8 --light sun:-1,0.2,0:0.3,0.4,1:2
  murk render fixtures/pyro.vdb -o pyro.exr --no-lights --stats pyro.json
  murk render fixtures/scene.toml -o cloud.exr --spp 4

With no --light the scene is lit by the default sun, sun:0.6,1,0.5:1,1,1:6 (from the upper right front, white, irradiance 6).
With no camera flags the camera frames the density's world bounds.";

pub fn run(input: &Path, options: RenderOptions) -> Result<()> {
    let is_scene = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let (options, vdb) = if is_scene {
        let scene = RenderOptions::from_scene_file(input).map_err(|e| anyhow!(e))?;
        let merged = options.over(scene);
        let vdb = merged
            .input
            .clone()
            .ok_or_else(|| anyhow!("{}: the scene names no `input` .vdb file", input.display()))?;
        (merged, vdb)
    } else {
        (options, input.to_path_buf())
    };
    let plan = RenderPlan::new(&options, vdb).map_err(|e| anyhow!(e))?;
    let stats = render(&plan)?;
    if !options.quiet {
        eprintln!(
            "murk: wrote {} ({}x{}, {} channels) in {:.2} s",
            plan.output.display(),
            stats.width,
            stats.height,
            stats.channels.len(),
            stats.total_seconds
        );
        for n in &stats.notes {
            eprintln!("murk: note: {n}");
        }
    }
    Ok(())
}
