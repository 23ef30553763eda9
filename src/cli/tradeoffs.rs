//! `luxnode bench tradeoffs` and `luxnode bench patches`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use luxnode::bench::patches as lp;
use luxnode::bench::tradeoffs::{self as st, CaptureInputs, Measured, StudyOptions};
use luxnode::engine::{self, Settings};
use luxnode::preset::Preset;
use luxnode::scene::{LoadOptions, load_desks_file, load_luminaires_file, load_sensors_file};

/// The arguments of `bench tradeoffs`.
pub struct Args {
    pub scene: PathBuf,
    pub capture: Option<PathBuf>,
    pub rays: Vec<usize>,
    pub patch_sizes: Vec<f64>,
    pub knobs: bool,
    pub runs: usize,
    pub preset_runs: usize,
    pub plots: Option<PathBuf>,
    pub plot: Option<PathBuf>,
}

fn load_average() -> String {
    luxnode::host::load_average().unwrap_or_else(|| "?".into())
}

pub fn tradeoffs(a: &Args) -> Result<()> {
    let (sc, scenarios, truth) = super::bench::scene_with_truth(&a.scene)?;
    let threads = rayon::current_num_threads();
    let started = std::time::Instant::now();
    let bar = super::step_spinner("speed vs accuracy points");
    let mut print = |m: &Measured| super::print_step(bar.as_ref(), &st::table_row(m));
    let (points, prefix, what) = match &a.capture {
        None => {
            println!(
                "# speed vs accuracy on {} ({threads} threads, load average {} at the start)\n",
                sc.name,
                load_average()
            );
            println!("{}", st::TABLE_HEADER);
            let o = StudyOptions {
                knobs: a.knobs,
                grid_rays: a.rays.clone(),
                grid_sizes_m: a.patch_sizes.clone(),
                runs: a.runs,
                preset_runs: a.preset_runs,
            };
            (
                st::run_scene(&sc, &scenarios, &truth, &o, &mut print)?,
                "tradeoffs",
                sc.name.clone(),
            )
        }
        Some(dir) => {
            let load = LoadOptions::default();
            let (luminaires, _) = load_luminaires_file(&a.scene.join("luminaires.json"), &load)?;
            let (sensors, _) = load_sensors_file(&a.scene.join("sensors.json"), &load)?;
            let desks_path = a.scene.join("desks.json");
            let desks = if desks_path.is_file() {
                Some(load_desks_file(&desks_path, &load)?)
            } else {
                None
            };
            let ids: Vec<u32> = luminaires.iter().map(|l| l.id).collect();
            let capture = luxnode::commission::Capture::load(dir, &ids)
                .with_context(|| format!("capture {}", dir.display()))?;
            let inputs = CaptureInputs {
                capture,
                luminaires,
                sensors,
                desks,
            };
            println!(
                "# speed vs accuracy, commissioning from the capture {} ({threads} threads, load average {} at the start)\n",
                dir.display(),
                load_average()
            );
            println!("{}", st::TABLE_HEADER);
            (
                st::run_capture(&inputs, &scenarios, &truth, &mut print)?,
                "tradeoffs-capture",
                format!("{} capture", sc.name),
            )
        }
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    println!(
        "\n{} points in {:.0} s; load average at the end {}\n",
        points.len(),
        started.elapsed().as_secs_f64(),
        load_average()
    );
    println!("{}", st::preset_table(&points));
    if let Some(dir) = &a.plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for p in st::write_plots(&points, dir, prefix, &what)
            .with_context(|| format!("writing plots into {}", dir.display()))?
        {
            println!("plot: {}", p.display());
        }
    }
    if let Some(path) = &a.plot {
        let rows: Vec<(f64, f64, f64)> = points
            .iter()
            .filter(|m| m.variant.group == "grid")
            .map(|m| {
                (
                    m.variant.engine.patches.patch_size_m,
                    m.commission.as_secs_f64(),
                    100.0 * m.accuracy.error,
                )
            })
            .collect();
        super::bench::tradeoff_plot(
            &rows,
            &format!(
                "{}: COMMISSIONING TIME VS ERROR (RAYS PER PATCH GRID)",
                sc.name
            ),
        )
        .save_png(path)
        .with_context(|| format!("writing {}", path.display()))?;
        println!("plot: {}", path.display());
    }
    Ok(())
}

pub fn patches(scene: &Path, out_dir: Option<&Path>) -> Result<()> {
    let (sc, scenarios, truth) = super::bench::scene_with_truth(scene)?;
    if let Some(d) = out_dir {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    println!("# patches per preset on {}\n", sc.name);
    let bar = super::step_spinner("patches per preset (adaptive and uniform twin)");
    let mut rows = Vec::new();
    for preset in Preset::ALL {
        if let Some(b) = &bar {
            b.set_message(format!(", {preset}"));
        }
        let s = preset.engine();
        let adaptive = engine::compute_model(&sc, &s)?;
        let acc = luxnode::bench::accuracy(&adaptive, &scenarios, &truth)?
            .context("no truth values match the scenarios")?;
        let n = adaptive.stats.patches;
        let (size, n_uniform) = lp::uniform_size_for(&sc, n);
        let u_settings = Settings {
            patches: lp::uniform(size),
            ..s.clone()
        };
        let uniform = engine::compute_model(&sc, &u_settings)?;
        let acc_u = luxnode::bench::accuracy(&uniform, &scenarios, &truth)?
            .context("no truth values match the scenarios")?;
        let mut out = format!("## {preset}: {n} patches\n\n");
        out.push_str("| surface | patches | area (m²) | mean patch area (m²) |\n");
        out.push_str("|---|---:|---:|---:|\n");
        for (g, count, area) in lp::per_group(&sc, &adaptive.patches) {
            let _ = writeln!(
                out,
                "| {g} | {count} | {area:.1} | {:.3} |",
                area / count as f64
            );
        }
        out.push('\n');
        if let Some(d) = out_dir {
            let range = (0.0625, 4.0);
            for (model, name, what) in [
                (&adaptive, format!("patches-{preset}.png"), "adaptive"),
                (&uniform, format!("patches-{preset}-uniform.png"), "uniform"),
            ] {
                let path = d.join(name);
                lp::layout_picture(
                    &sc,
                    model,
                    &format!(
                        "{}: {} patches, preset {} ({what})",
                        sc.name,
                        model.stats.patches,
                        preset.name()
                    ),
                    range,
                )
                .save_png(&path)
                .with_context(|| format!("writing {}", path.display()))?;
                let _ = writeln!(out, "picture: {}\n", path.display());
            }
        }
        super::print_step(bar.as_ref(), &format!("{}\n", out.trim_end()));
        rows.push((preset, n, acc, size, n_uniform, acc_u));
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    println!(
        "| preset | adaptive patches | error | worst sensor | uniform patch size (m) | uniform patches | error | worst sensor |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (p, n, a, size, nu, au) in rows {
        println!(
            "| {p} | {n} | {:.2} % | {:.2} % | {size:.3} | {nu} | {:.2} % | {:.2} % |",
            100.0 * a.error,
            100.0 * a.worst_sensor,
            100.0 * au.error,
            100.0 * au.worst_sensor
        );
    }
    Ok(())
}
