//! `luxnode bench scaling`: stage times and memory against patches × rays.

use std::path::Path;

use anyhow::{Result, anyhow};
use luxnode::bench::scaling;
use luxnode::scene::{LoadOptions, Scene};

/// Runs the scaling benchmark on `scene` (a directory) or on Ward's grey room, and prints the
/// table.
pub fn run(
    scene: Option<&Path>,
    patch_sizes_m: &[f64],
    rays: &[usize],
    uniform: bool,
    runs: usize,
) -> Result<()> {
    let sc = match scene {
        Some(dir) => Scene::load(dir, &LoadOptions::default()).map_err(|e| anyhow!("{e}"))?,
        None => scaling::ward_room(),
    };
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "# luxnode scaling benchmark: {} ({} threads, load average {})\n",
        sc.name,
        rayon::current_num_threads(),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    let bar = super::step_spinner("patches x rays");
    let rows = scaling::scaling(&sc, patch_sizes_m, rays, uniform, runs)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    println!("{}", scaling::table(&rows));
    println!(
        "Form-factor stage per ray, µs (one thread, {} patches sampled):\n",
        scaling::PROFILE_PATCHES
    );
    println!("{}", scaling::profile_table(&rows));
    Ok(())
}
