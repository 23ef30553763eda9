//! `luxnode bench radiance`: luxnode's speed-accuracy curve against Radiance's stored runs at
//! equal error, in CPU seconds (`luxnode::bench::equal_error`).

use std::path::Path;

use anyhow::{Context, Result};
use luxnode::bench::equal_error;

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// Measures every candidate on `scene` (`runs` times each, the median kept) and prints the curve
/// and the equal-error table against the Radiance rungs of `sweep` (a `sweep.py` result).
pub fn run(scene: &Path, sweep: &Path, runs: usize) -> Result<()> {
    let text =
        std::fs::read_to_string(sweep).with_context(|| format!("reading {}", sweep.display()))?;
    let rungs =
        equal_error::read_sweep(&text).map_err(|e| anyhow::anyhow!("{}: {e}", sweep.display()))?;
    let (sc, scenarios, truth) = super::bench::scene_with_truth(scene)?;
    println!(
        "# luxnode against Radiance at equal error: {} ({} threads, load average {} at the start)\n",
        sc.name,
        rayon::current_num_threads(),
        load_average()
    );
    let mut points = Vec::new();
    for c in equal_error::candidates() {
        let p = equal_error::measure(&sc, &scenarios, &truth, &c, runs)?
            .context("no truth values match the scenarios")?;
        points.push(p);
    }
    println!("{}", equal_error::tables(&points, &rungs));
    println!(
        "luxnode: CPU of commissioning and the table, median of {runs} runs; Radiance: {} (its \
         sweep.py runs, the harness's CPU count of its children); load average at the end {}",
        sweep.display(),
        load_average()
    );
    Ok(())
}
