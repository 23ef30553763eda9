//! `luxnode bench ...` (feature `bench`): benchmarks that print tables (and draw plots) for
//! docs/. The measuring code is in `luxnode::bench`; this file parses and prints.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use luxnode::bench;
use luxnode::engine::{DirectModel, Settings};
use luxnode::fieldbus::tcp::TcpOptions;
use luxnode::scene::{LoadOptions, Scenario, Scene, TruthRow, read_states, read_truth};
use luxnode::store::Image;
use luxnode::store::file::read_image_file;

use super::load_scene;
use super::modbus::duration_s;

/// `luxnode bench ...`.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Commissioning time per stage, per-state time, accuracy against the scene's truth.
    Engine {
        /// The scene directory (with states.csv and truth.csv for accuracy).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
        /// Commissioning runs (the median is printed).
        #[arg(long, value_name = "N", default_value_t = 3)]
        runs: usize,
        /// Also run this Radiance harness (bench/radiance/office_a.py) and compare.
        #[arg(long, value_name = "FILE")]
        radiance: Option<PathBuf>,
        /// Arguments for the Radiance harness (its settings), one string.
        #[arg(
            long,
            value_name = "ARGS",
            default_value = "",
            allow_hyphen_values = true
        )]
        radiance_args: String,
    },
    /// Speed against accuracy: the presets, every engine and store knob one at a time, and the
    /// rays x patch size grid; commissioning time, image size, per-state time, error against
    /// the truth (mean, worst sensor). Prints a table; writes Pareto plots with --plots.
    Tradeoffs {
        /// The scene directory (states.csv, truth.csv; with --capture: luminaires.json,
        /// sensors.json, desks.json).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
        /// Commission from this capture set instead of the scene's CAD model (each point a full
        /// `commission` run).
        #[arg(long, value_name = "DIR")]
        capture: Option<PathBuf>,
        /// Grid: rays per patch (empty: no grid).
        #[arg(long, value_name = "N", value_delimiter = ',', default_values_t = [100, 300, 1000])]
        rays: Vec<usize>,
        /// Grid: base patch sizes, m.
        #[arg(long, value_name = "M", value_delimiter = ',', default_values_t = [2.0, 1.0, 0.5, 0.25])]
        patch_sizes: Vec<f64>,
        /// Skip the grid.
        #[arg(long)]
        no_grid: bool,
        /// Skip the one-at-a-time knob sweep.
        #[arg(long)]
        no_knobs: bool,
        /// Commissioning runs per point (the median is kept).
        #[arg(long, value_name = "N", default_value_t = 1)]
        runs: usize,
        /// Commissioning runs per preset.
        #[arg(long, value_name = "N", default_value_t = 3)]
        preset_runs: usize,
        /// Write the Pareto plots (PNG) into this directory.
        #[arg(long, value_name = "DIR")]
        plots: Option<PathBuf>,
        /// Also write the rays x patch-size plot (PNG) of the grid rows.
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
    },
    /// "Model only what the scene requires": patch counts per preset and surface, pictures of
    /// the patch layout, and the error of uniform meshes with the same patch counts.
    Patches {
        /// The scene directory (with states.csv and truth.csv).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
        /// Write the layout pictures (PNG) into this directory.
        #[arg(long, value_name = "DIR")]
        out_dir: Option<PathBuf>,
    },
    /// luxnode's speed-accuracy curve against Radiance's stored runs at equal error, in CPU
    /// seconds: for each Radiance rung, luxnode's cheapest setting at no more error.
    Radiance {
        /// The scene directory (states.csv, truth.csv).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
        /// Radiance's runs: a `bench/radiance/sweep.py` result.
        #[arg(
            long,
            value_name = "FILE",
            default_value = "bench/radiance/results/ad_ladder/sweep.json"
        )]
        sweep: PathBuf,
        /// Commissioning runs per luxnode setting (the median is kept).
        #[arg(long, value_name = "N", default_value_t = 5)]
        runs: usize,
    },
    /// Commissioning stage times and memory against patches x rays (Ward's grey room unless --scene).
    Scaling {
        /// A scene directory [if absent: Ward's grey room, built in code].
        #[arg(long, value_name = "DIR")]
        scene: Option<PathBuf>,
        /// Base patch sizes, m.
        #[arg(long, value_name = "M", value_delimiter = ',', default_values_t = [1.0, 0.7, 0.5])]
        patch_sizes: Vec<f64>,
        /// Rays per patch.
        #[arg(long, value_name = "N", value_delimiter = ',', default_values_t = [300, 3000])]
        rays: Vec<usize>,
        /// Uniform patches (no refinement toward sensors and luminaires).
        #[arg(long)]
        uniform: bool,
        /// Commissioning runs per point (the median is kept).
        #[arg(long, value_name = "N", default_value_t = 1)]
        runs: usize,
    },
    /// The run-time core over an image: one dimming state, and a full re-solve.
    Runtime {
        /// The image file.
        #[arg(long, value_name = "FILE")]
        image: PathBuf,
    },
    /// Draw the trade-off plot from a table printed by `bench tradeoffs`.
    PlotTradeoffs {
        /// The markdown table (the output of `bench tradeoffs`).
        #[arg(long, value_name = "FILE")]
        table: PathBuf,
        /// The PNG to write.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Plot title.
        #[arg(
            value_name = "TEXT",
            long,
            default_value = "office_a: commissioning time against error (rays 100..10000)"
        )]
        title: String,
    },
    /// Many Modbus TCP clients polling the desk lux at once: throughput, latency, memory.
    ModbusLoad {
        /// The image to serve.
        #[arg(long, value_name = "FILE")]
        image: PathBuf,
        /// Concurrent Modbus TCP clients.
        #[arg(long, value_name = "N", default_value_t = 100)]
        clients: usize,
        /// How long the clients poll, s.
        #[arg(long, value_name = "S", default_value_t = 60.0)]
        seconds: f64,
        /// Each client's poll interval, ms (0: back to back).
        #[arg(long, value_name = "MS", default_value_t = 0)]
        interval_ms: u64,
        /// The pollers come from this many BMS hosts (loopback addresses 127.0.1.1, ...), so
        /// the server's default caps apply as in a building (128 connections, 64 per host).
        #[arg(long, value_name = "N", default_value_t = 4)]
        hosts: u8,
        /// An attacker at 127.0.0.2 first opens this many sockets and never speaks (the
        /// idle-socket attack); the pollers must still all be served.
        #[arg(long, value_name = "N", default_value_t = 0)]
        idle_attack: usize,
    },
    /// Does BACnet slow Modbus? Modbus pollers' throughput without and with COV subscribers
    /// (in-process sockets), runs alternating, medians compared (docs/bacnet.md).
    BacnetCovLoad {
        /// The image to serve.
        #[arg(long, value_name = "FILE")]
        image: PathBuf,
        /// COV subscribers in the runs with them.
        #[arg(long, value_name = "N", default_value_t = 100)]
        subscribers: usize,
        /// Modbus TCP clients polling the desk floats back to back.
        #[arg(long, value_name = "N", default_value_t = 8)]
        pollers: usize,
        /// Each run's duration, s.
        #[arg(long, value_name = "S", default_value_t = 3.0)]
        seconds: f64,
        /// Runs of each kind (without, with), alternating.
        #[arg(long, value_name = "N", default_value_t = 5)]
        runs: usize,
    },
    /// Mutated Modbus frames into the register map and the RTU handler; every answer checked.
    Fuzz {
        /// Frames to send.
        #[arg(long, value_name = "N", default_value_t = 10_000_000)]
        frames: u64,
        /// Seed of the frame generator (the same seed sends the same frames).
        #[arg(long, value_name = "N", default_value_t = 0x6C75_786E)]
        seed: u64,
    },
    /// The paper's Table 1, CAD vs RGBD rows: commissioning from the capture sets (clean and
    /// noisy depth, closure on and off, true and estimated reflectances) against the truth,
    /// over all desks and the desks in view (docs/accuracy.md).
    Table1 {
        /// The scene directory (capture/, capture_clean/ with groundtruth/, states.csv,
        /// truth.csv, luminaires.json, sensors.json).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
    },
    /// The least-power optimiser (luminaires x desks up to 128 x 200): time per optimisation,
    /// the continuous optimum against the independent microlp solver, the DALI plan's excess;
    /// then the DALI plan against the exhaustive DALI optimum for 2 to 4 luminaires.
    Control {
        /// Instances per size.
        #[arg(long, value_name = "N", default_value_t = 20)]
        instances: usize,
        /// Seed of the instances.
        #[arg(long, value_name = "N", default_value_t = 1)]
        seed: u64,
    },
    /// Energy over a day of daylight: the least-power controller against all on and against one
    /// photocell dimming every luminaire together, over the occupied hours.
    ControlDay {
        /// The commissioned image (its response matrix and luminaire fluxes).
        #[arg(long, value_name = "FILE")]
        image: PathBuf,
        /// Daylight alone per desk over the day: CSV time_h,sensor_id,lux.
        #[arg(long, value_name = "FILE")]
        daylight: PathBuf,
        /// Target of every desk, lx.
        #[arg(long, value_name = "LUX", default_value_t = luxnode::control::DEFAULT_TARGET_LX)]
        target: f64,
        /// Occupied from this hour.
        #[arg(long, value_name = "H", default_value_t = 8.0)]
        from_h: f64,
        /// Occupied until this hour.
        #[arg(long, value_name = "H", default_value_t = 18.0)]
        to_h: f64,
        /// Write the power over the day as a PNG.
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
        /// Who sits where: CSV sensor_id,from_h,to_h (a fourth controller, least power
        /// following people; bench/control/office_a_occupancy.csv).
        #[arg(long, value_name = "FILE")]
        occupancy: Option<PathBuf>,
        /// Occupancy's hold, s (a desk stays occupied this long after its person left).
        #[arg(long, value_name = "S", default_value_t = 900.0)]
        hold_s: f64,
        /// What a vacant desk is lit to: surrounding (EN 12464-1's immediate surrounding
        /// level) or off.
        #[arg(long, default_value = "surrounding")]
        vacant: String,
    },
    /// Dense illuminance against Radiance: the desk grids of truth_dense.csv (mean error, U0 per
    /// desk) and the camera-view lux image against the rendered truth (π L / ρ on desk pixels),
    /// with their times.
    Dense {
        /// The scene directory (with truth_dense.csv).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
        /// The capture set with the rendered truth [if absent: the scene's capture_clean].
        #[arg(long, value_name = "DIR")]
        capture: Option<PathBuf>,
        /// Timed runs (the median is printed).
        #[arg(long, value_name = "N", default_value_t = 3)]
        runs: usize,
    },
    /// Live light's cost: one update of the estimator (frame in, desk values out) under
    /// several conditions on a board's simulated room, commissioned from its cameras in
    /// daylight; the boot cost and the memory held (docs/live.md).
    Live {
        /// A board file with simulated cameras (its scene and optics).
        #[arg(long, value_name = "FILE", default_value = "boards/sim/board.toml")]
        board: PathBuf,
        /// Timed updates in all (cycling through the conditions).
        #[arg(long, value_name = "N", default_value_t = 120)]
        frames: usize,
    },
    /// Occupancy (issue 29) against the bench's rendered rooms (bench/occupancy/generate.py):
    /// accuracy per (frame, visible desk), false presence per distractor, missed seated people,
    /// µs per update, memory. Prints a markdown table (docs/occupancy.md).
    Occupancy {
        /// The generated bench: one directory per room and pose.
        #[arg(long, value_name = "DIR")]
        dir: PathBuf,
        /// Every stride-th pixel is watched.
        #[arg(long, value_name = "N", default_value_t = 2)]
        stride: u32,
    },
    /// The paper's ablation (paper vs exact direct light, LDC, LSC) against the truth.
    Ablation {
        /// The scene directory.
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
    },
}

/// The scene, its scenarios and its truth (states.csv, truth.csv in the scene directory).
pub(crate) fn scene_with_truth(dir: &Path) -> Result<(Scene, Vec<Scenario>, Vec<TruthRow>)> {
    let scene = load_scene(dir, &LoadOptions::default())?;
    let scenarios = read_states(&dir.join("states.csv"))?;
    let truth = read_truth(&dir.join("truth.csv"))?;
    Ok((scene, scenarios, truth))
}

/// Runs `luxnode bench ...`.
pub fn run(command: Command) -> Result<()> {
    match command {
        Command::Dense {
            scene,
            capture,
            runs,
        } => dense(&scene, capture.as_deref(), runs)?,
        Command::Live { board, frames } => live(&board, frames)?,
        Command::Occupancy { dir, stride } => occupancy(&dir, stride)?,
        Command::Engine {
            scene,
            runs,
            radiance,
            radiance_args,
        } => engine(&scene, runs, radiance, &radiance_args)?,
        Command::Tradeoffs {
            scene,
            capture,
            rays,
            patch_sizes,
            no_grid,
            no_knobs,
            runs,
            preset_runs,
            plots,
            plot,
        } => {
            super::tradeoffs::tradeoffs(&super::tradeoffs::Args {
                scene,
                capture,
                rays: if no_grid { Vec::new() } else { rays },
                patch_sizes,
                knobs: !no_knobs,
                runs,
                preset_runs,
                plots,
                plot,
            })?;
        }
        Command::Radiance { scene, sweep, runs } => {
            super::bench_radiance::run(&scene, &sweep, runs)?;
        }
        Command::Scaling {
            scene,
            patch_sizes,
            rays,
            uniform,
            runs,
        } => super::bench_scaling::run(scene.as_deref(), &patch_sizes, &rays, uniform, runs)?,
        Command::Patches { scene, out_dir } => {
            super::tradeoffs::patches(&scene, out_dir.as_deref())?;
        }
        Command::Runtime { image } => runtime(&image)?,
        Command::PlotTradeoffs { table, out, title } => plot_tradeoffs(&table, &out, &title)?,
        Command::ModbusLoad {
            image,
            clients,
            seconds,
            interval_ms,
            hosts,
            idle_attack,
        } => {
            modbus_load(&image, clients, seconds, interval_ms, hosts, idle_attack)?;
        }
        Command::BacnetCovLoad {
            image,
            subscribers,
            pollers,
            seconds,
            runs,
        } => super::bench_bacnet::cov_load(&image, subscribers, pollers, seconds, runs)?,
        Command::Fuzz { frames, seed } => {
            fuzz(frames, seed)?;
        }
        Command::Control { instances, seed } => control(instances, seed)?,
        Command::ControlDay {
            image,
            daylight,
            target,
            from_h,
            to_h,
            plot,
            occupancy,
            hold_s,
            vacant,
        } => {
            let people = match occupancy {
                Some(path) => Some(read_people_arg(&path, hold_s, &vacant)?),
                None => None,
            };
            control_day(
                &image,
                &daylight,
                target,
                (from_h, to_h),
                plot.as_deref(),
                people.as_ref(),
            )?
        }
        Command::Table1 { scene } => table1(&scene)?,
        Command::Ablation { scene } => ablation(&scene)?,
    }
    Ok(())
}

/// `bench engine`: commissioning time by stage, one state, a re-solve, accuracy; against
/// Radiance when given its harness.
fn engine(scene: &Path, runs: usize, radiance: Option<PathBuf>, radiance_args: &str) -> Result<()> {
    let (sc, scenarios, truth) = scene_with_truth(scene)?;
    let settings = Settings::default();
    let threads = rayon::current_num_threads();
    println!(
        "# luxnode engine benchmark: {} ({threads} threads)",
        sc.name
    );
    let bar = super::step_spinner("commissioning runs");
    let ((total, stages), model) = bench::time_commissioning(&sc, &settings, runs)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    println!();
    println!(
        "commissioning at default settings, median of {runs} runs: {:.3} s",
        total.as_secs_f64()
    );
    println!("| stage | time (ms) |");
    println!("|---|---:|");
    for (name, d) in &stages {
        println!("| {name} | {:.1} |", d.as_secs_f64() * 1e3);
    }
    let st = &model.stats;
    println!(
        "\n{} patches, {} rays per patch, {} rays per sensor, {} non-zero form factors",
        st.patches, st.rays_per_patch, st.rays_per_sensor, st.nnz
    );
    let per_state = bench::time_state(&model, 2_000_000)?;
    println!(
        "one dimming state ({} sensors x {} luminaires, superposition): {:.1} ns",
        model.sensors(),
        model.luminaires(),
        per_state.as_secs_f64() * 1e9
    );
    let t0 = std::time::Instant::now();
    let (_, report) = model.solve_state(&vec![1.0; model.luminaires()])?;
    println!(
        "full re-solve of one state: {:.1} ms ({} Gauss-Seidel sweeps)",
        t0.elapsed().as_secs_f64() * 1e3,
        report.iterations
    );
    let acc = bench::accuracy(&model, &scenarios, &truth)?
        .context("no truth values match the scenarios")?;
    println!(
        "accuracy against {}: error {:.2} %, worst sensor {:.2} % ({} values)",
        scene.join("truth.csv").display(),
        100.0 * acc.error,
        100.0 * acc.worst_sensor,
        acc.pairs
    );
    if let Some(script) = radiance {
        let r = bench::radiance::run(&script, scene, radiance_args)?;
        println!("\nRadiance: {}", r.command);
        let ours = total.as_secs_f64() + per_state.as_secs_f64() * scenarios.len() as f64;
        println!(
            "\n| tool | settings | time for the {} x {} table (s) | error | worst sensor |",
            scenarios.len(),
            model.sensors()
        );
        println!("|---|---|---:|---:|---:|");
        println!(
            "| luxnode | defaults | {ours:.3} | {:.2} % | {:.2} % |",
            100.0 * acc.error,
            100.0 * acc.worst_sensor
        );
        println!(
            "| Radiance | {} | {:.1} | {:.2} % | {:.2} % |",
            r.settings,
            r.wall_time_s,
            100.0 * r.error,
            100.0 * r.worst_sensor_error
        );
        println!(
            "\nluxnode is {:.0} x faster; error ratio (Radiance / luxnode) {:.2}",
            r.wall_time_s / ours,
            r.error / acc.error
        );
    }
    Ok(())
}

/// `bench runtime`: the run-time core over an image file.
fn runtime(image: &Path) -> Result<()> {
    let bytes = read_image_file(image)?;
    let t0 = std::time::Instant::now();
    let img = Image::parse(&bytes)?;
    let parse = t0.elapsed();
    let (per_state, resolve, sweeps) = bench::time_runtime(&img, 2_000_000, 11)?;
    println!(
        "# run-time core over {} ({}, {} bytes)",
        image.display(),
        img.payload.scene_name,
        img.len()
    );
    println!("| measure | value | target |");
    println!("|---|---:|---:|");
    println!(
        "| parse and check the image (CRCs, every array) | {:.2} ms | |",
        parse.as_secs_f64() * 1e3
    );
    println!(
        "| one dimming state, {} sensors x {} luminaires (superposition) | {:.1} ns | <= 1 us |",
        img.sensors(),
        img.luminaires(),
        per_state.as_secs_f64() * 1e9
    );
    println!(
        "| full re-solve over the stored form factors ({} patches, {} entries, {}) | {:.2} ms ({sweeps} sweeps) | <= 20 ms |",
        img.patches(),
        img.payload.ff.nnz(),
        img.payload.ff.values.precision().name(),
        resolve.as_secs_f64() * 1e3
    );
    Ok(())
}

/// `bench plot-tradeoffs`: the plot of a `bench tradeoffs` table.
fn plot_tradeoffs(table: &Path, out: &Path, title: &str) -> Result<()> {
    let text =
        std::fs::read_to_string(table).with_context(|| format!("reading {}", table.display()))?;
    // rows: | patch size | rays | patches | form factors | seconds | error % | worst % |
    let mut rows = Vec::new();
    for line in text.lines().filter(|l| l.starts_with('|')) {
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let num = |i: usize| {
            cells
                .get(i)
                .and_then(|c| c.trim_end_matches(" %").parse::<f64>().ok())
        };
        if let (Some(size), Some(secs), Some(err)) = (num(0), num(4), num(5)) {
            rows.push((size, secs, err));
        }
    }
    if rows.is_empty() {
        bail!("{} has no table rows of `bench tradeoffs`", table.display());
    }
    tradeoff_plot(&rows, title)
        .save_png(out)
        .with_context(|| format!("writing {}", out.display()))?;
    println!("plot: {} ({} points)", out.display(), rows.len());
    Ok(())
}

/// `bench control`: least-power dimming, timed, and against the exhaustive DALI optimum.
fn control(instances: usize, seed: u64) -> Result<()> {
    if !(1..=10_000).contains(&instances) {
        bail!("--instances {instances}: 1..=10000");
    }
    println!(
        "# least-power dimming: {instances} office-like instances per size (seed {seed}), each solved once untimed then {} times timed, load average {}",
        bench::control::TIMED_RUNS,
        luxnode::host::load_average().unwrap_or_else(|| "?".into())
    );
    println!(
        "| luminaires x desks | median CPU time | median wall time | worst CPU time | simplex iterations (median) | microlp, LP only (median wall) | continuous optimum vs microlp (worst rel.) | DALI plan over the continuous optimum (worst) | instances with a desk out of reach |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in bench::control::run(&bench::control::SIZES, instances, seed) {
        println!(
            "| {} x {} | {:.0} µs | {:.0} µs | {:.0} µs | {} | {:.0} µs | {:.1e} | {:.3} % | {}/{} |",
            r.luminaires,
            r.desks,
            r.median_cpu.as_secs_f64() * 1e6,
            r.median.as_secs_f64() * 1e6,
            r.worst_cpu.as_secs_f64() * 1e6,
            r.iterations,
            r.microlp_median.as_secs_f64() * 1e6,
            r.lp_rel_diff,
            100.0 * r.dali_excess,
            r.infeasible,
            r.instances
        );
    }
    println!();
    println!(
        "# the DALI plan against the exhaustive DALI optimum (every combination of levels), {instances} instances per size, daylight and targets random"
    );
    println!(
        "| luminaires x desks | combinations per instance | instances with a solution | plan = optimum | mean excess | worst excess |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for r in bench::control::exhaustive(&bench::control::EXHAUSTIVE_SIZES, instances, seed) {
        println!(
            "| {} x {} | {} | {} | {} | {:.3} % | {:.3} % |",
            r.luminaires,
            r.desks,
            r.combinations,
            r.feasible,
            r.optimal,
            100.0 * r.mean_excess,
            100.0 * r.worst_excess
        );
    }
    Ok(())
}

/// `bench table1`: the paper's Table 1.
fn table1(scene: &Path) -> Result<()> {
    println!(
        "# the paper's Table 1, CAD vs RGBD rows, on {} (error = mean |error| / mean truth)",
        scene.display()
    );
    println!("{}", bench::table1::HEADER);
    bench::table1::run(scene, |r| println!("{}", r.markdown()))?;
    Ok(())
}

/// `bench ablation`: direct light model, LDC and LSC on and off.
fn ablation(scene: &Path) -> Result<()> {
    let (sc, scenarios, truth) = scene_with_truth(scene)?;
    println!(
        "# ablation on {} (31 scenarios x 8 sensors against the Radiance truth)",
        sc.name
    );
    println!("| direct light | LDC | LSC | mean abs error (lx) | error | worst sensor |");
    println!("|---|---|---|---:|---:|---:|");
    for r in bench::ablation(&sc, &scenarios, &truth)? {
        println!(
            "| {} | {} | {} | {:.1} | {:.2} % | {:.2} % |",
            match r.direct {
                DirectModel::Paper => "paper (emitting patches, w = I)",
                DirectModel::Exact => "exact (photometry, shadow rays)",
            },
            if r.ldc { "yes" } else { "no" },
            if r.lsc { "yes" } else { "no" },
            r.accuracy.mean_abs_lx,
            100.0 * r.accuracy.error,
            100.0 * r.accuracy.worst_sensor
        );
    }
    Ok(())
}

/// Error against commissioning time, one series per patch size: rows of (size, seconds, error %).
pub(crate) fn tradeoff_plot(rows: &[(f64, f64, f64)], title: &str) -> luxnode::render::Canvas {
    let mut sizes: Vec<f64> = Vec::new();
    for r in rows {
        if !sizes.contains(&r.0) {
            sizes.push(r.0);
        }
    }
    let series = sizes
        .iter()
        .map(|size| luxnode::render::plot::Series {
            name: format!("patch {size} m"),
            points: rows
                .iter()
                .filter(|r| r.0 == *size)
                .map(|r| (r.1, r.2))
                .collect(),
        })
        .collect();
    luxnode::render::plot::Plot {
        title: title.to_owned(),
        x_label: "commissioning time (s, log)".into(),
        y_label: "error against Radiance (%)".into(),
        log_x: true,
        log_y: false,
        series,
    }
    .draw(900, 560)
}

/// Connects from `local` to `addr`.
async fn connect_from(
    local: std::net::IpAddr,
    addr: std::net::SocketAddr,
) -> std::io::Result<tokio::net::TcpStream> {
    let sock = tokio::net::TcpSocket::new_v4()?;
    sock.bind(std::net::SocketAddr::new(local, 0))?;
    sock.connect(addr).await
}

/// `luxnode bench modbus-load`: many TCP clients polling the desk lux at once, from several
/// BMS hosts, with the server's default caps; optionally while an attacker parks idle sockets.
fn modbus_load(
    image: &Path,
    clients: usize,
    seconds: f64,
    interval_ms: u64,
    hosts: u8,
    idle_attack: usize,
) -> Result<()> {
    use luxnode::fieldbus::tcp::{self, TcpCounters};
    use luxnode::node::lock;
    use std::sync::atomic::Ordering;
    use std::sync::{Arc, Mutex};
    use tokio_modbus::client::Reader;

    if clients == 0 || clients > 10_000 {
        bail!("--clients {clients}: 1..=10000");
    }
    if hosts == 0 || hosts > 200 {
        bail!("--hosts {hosts}: 1..=200");
    }
    if idle_attack > 10_000 {
        bail!("--idle-attack {idle_attack}: at most 10000");
    }
    let run_for = duration_s("--seconds", seconds)?;
    let node = full_on_node(image)?;
    let desks = node.map().desk_count() as u16;
    let node = Arc::new(Mutex::new(node));
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let rss_before = luxnode::host::rss_kib();
    let options = TcpOptions::default();
    let caps = (options.max_connections, options.max_per_source);
    let options_evictable = options.evictable_after;
    let (lat, errors, counters, parked) = rt.block_on(async {
        let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
        let listener = tcp::bind("127.0.0.1:0".parse()?).await?;
        let addr = listener.local_addr()?;
        let counters = Arc::new(TcpCounters::default());
        let server = tokio::spawn(tcp::serve(
            listener,
            node.clone(),
            options,
            counters.clone(),
            stop_rx,
            None,
        ));
        // the attacker: sockets that connect and never speak
        let mut parked = Vec::new();
        for _ in 0..idle_attack {
            if let Ok(s) = connect_from([127, 0, 0, 2].into(), addr).await {
                parked.push(s);
            }
        }
        // the attacker parked its sockets before the BMS came (long enough to be idle)
        if idle_attack > 0 {
            tokio::time::sleep(options_evictable + Duration::from_millis(500)).await;
        }
        let deadline = tokio::time::Instant::now() + run_for;
        let mut tasks = Vec::with_capacity(clients);
        for k in 0..clients {
            let host = std::net::IpAddr::from([127, 0, 1, 1 + (k % usize::from(hosts)) as u8]);
            tasks.push(tokio::spawn(async move {
                let mut lat_us: Vec<u32> = Vec::new();
                let mut errors = 0u64;
                let Ok(stream) = connect_from(host, addr).await else {
                    return (lat_us, 1);
                };
                let mut c = tokio_modbus::client::tcp::attach(stream);
                // spread the clients' phases over the interval
                if interval_ms > 0 {
                    let phase = interval_ms * k as u64 / clients as u64;
                    tokio::time::sleep(Duration::from_millis(phase)).await;
                }
                let mut next = tokio::time::Instant::now();
                while tokio::time::Instant::now() < deadline {
                    let t0 = std::time::Instant::now();
                    match c.read_input_registers(100, 2 * desks).await {
                        Ok(Ok(_)) => {
                            lat_us.push(t0.elapsed().as_micros().min(u32::MAX as u128) as u32)
                        }
                        _ => errors += 1,
                    }
                    if interval_ms > 0 {
                        next += Duration::from_millis(interval_ms);
                        tokio::time::sleep_until(next).await;
                    }
                }
                (lat_us, errors)
            }));
        }
        let mut all = Vec::new();
        let mut errors = 0;
        for t in tasks {
            let (l, e) = t.await?;
            all.extend(l);
            errors += e;
        }
        let parked = parked.len();
        let _ = stop_tx.send(true);
        let _ = server.await;
        anyhow::Ok((all, errors, counters, parked))
    })?;
    let rss_after = luxnode::host::rss_kib();
    let mut lat = lat;
    lat.sort_unstable();
    let pct = |p: f64| -> f64 {
        if lat.is_empty() {
            return f64::NAN;
        }
        let i = ((lat.len() as f64 - 1.0) * p).round() as usize;
        f64::from(lat[i]) / 1000.0
    };
    let accepted = counters.accepted.load(Ordering::Relaxed);
    println!(
        "| clients (hosts) | idle sockets opened by the attacker | caps | poll interval | duration | requests | requests/s | p50 | p99 | p99.9 | max | errors | refused | evicted | RSS |"
    );
    println!("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "| {clients} ({hosts}) | {parked} | {} / {} per host | {} | {seconds:.0} s | {} | {:.0} | {:.2} ms | {:.2} ms | {:.2} ms | {:.2} ms | {errors} | {} | {} | {} → {} KiB |",
        caps.0,
        caps.1,
        if interval_ms == 0 {
            "back to back".to_string()
        } else {
            format!("{interval_ms} ms")
        },
        lat.len(),
        lat.len() as f64 / seconds,
        pct(0.5),
        pct(0.99),
        pct(0.999),
        pct(1.0),
        counters.refused.load(Ordering::Relaxed),
        counters.evicted.load(Ordering::Relaxed),
        rss_before.map_or("?".into(), |v| v.to_string()),
        rss_after.map_or("?".into(), |v| v.to_string()),
    );
    let _ = (accepted, lock(&node).desks());
    Ok(())
}

/// `luxnode bench fuzz`.
fn fuzz(frames: u64, seed: u64) -> Result<()> {
    let t0 = std::time::Instant::now();
    let r = luxnode::fieldbus::fuzz::run(frames, seed).map_err(|f| anyhow::anyhow!("{f}"))?;
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "| frames | seed | answers | exception 01 | exception 02 | exception 03 | not answered (empty) | RTU answered | RTU silent | time | invariant violations |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "| {} | {seed:#x} | {} | {} | {} | {} | {} | {} | {} | {dt:.1} s | 0 |",
        r.frames,
        r.answers,
        r.exceptions[1],
        r.exceptions[2],
        r.exceptions[3],
        r.silent,
        r.rtu_answered,
        r.rtu_silent
    );
    Ok(())
}

/// `luxnode bench control-day`.
/// `--occupancy`, `--hold-s`, `--vacant` into a schedule, each range-checked.
fn read_people_arg(
    path: &Path,
    hold_s: f64,
    vacant: &str,
) -> Result<luxnode::bench::control_day::People> {
    use luxnode::control::VacantLight;
    let Some(vacant) = VacantLight::from_name(vacant) else {
        bail!("--vacant {vacant}: surrounding or off");
    };
    if !(hold_s.is_finite() && (0.0..=86_400.0).contains(&hold_s)) {
        bail!("--hold-s {hold_s}: within 0..=86400 s");
    }
    Ok(luxnode::bench::control_day::read_people(
        path,
        hold_s / 3600.0,
        vacant,
    )?)
}

fn control_day(
    image: &Path,
    daylight: &Path,
    target: f64,
    occupied_h: (f64, f64),
    plot: Option<&Path>,
    people: Option<&luxnode::bench::control_day::People>,
) -> Result<()> {
    use luxnode::bench::control_day::{read_series, run};
    if !(target.is_finite() && (0.0..=1e5).contains(&target)) {
        bail!("--target {target}: lux within 0..=1e5");
    }
    if !((0.0..24.0).contains(&occupied_h.0) && occupied_h.0 < occupied_h.1 && occupied_h.1 <= 24.0)
    {
        bail!("occupied hours {occupied_h:?}: 0 <= from < to <= 24");
    }
    let bytes = read_image_file(image)?;
    let img = Image::parse(&bytes)?;
    let ids: Vec<u32> = (0..img.sensors()).map(|k| img.sensor_id(k)).collect();
    let series = read_series(daylight, &ids)?;
    let power: Vec<luxnode::control::LuminairePower> = luxnode::control::rating::rated_powers(&img)
        .into_iter()
        .map(luxnode::control::LuminairePower::rated)
        .collect();
    let targets = vec![target; ids.len()];
    let (rows, t) = run(&img, &power, &targets, &series, occupied_h, people)?;
    println!(
        "# energy over a day: {} ({} desks, {} luminaires), target {target} lx, occupied {:.1}-{:.1} h, daylight {}",
        img.payload.scene_name,
        ids.len(),
        img.luminaires(),
        occupied_h.0,
        occupied_h.1,
        daylight.display()
    );
    println!(
        "| time (h) | mean daylight (lx) | all on (W) | one photocell (W) | least power (W) | least power over the continuous optimum | desks short (photocell / least power) |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---|");
    for r in &rows {
        println!(
            "| {:.2} | {:.0} | {:.0} | {:.0} | {:.0} | {:.3} % | {} / {} |",
            r.time_h,
            r.mean_daylight_lx,
            r.all_on_w,
            r.photocell_w,
            r.optimised_w,
            100.0 * (r.optimised_w / r.lp_w - 1.0),
            r.short.0,
            r.short.1
        );
    }
    let saved = |kwh: f64| 100.0 * (1.0 - kwh / t.all_on_kwh.max(1e-12));
    println!();
    println!(
        "| controller | energy over {:.1} h (kWh) | saved against all on |",
        t.hours
    );
    println!("|---|---:|---:|");
    println!("| all on | {:.3} | 0 % |", t.all_on_kwh);
    println!(
        "| one photocell | {:.3} | {:.1} % |",
        t.photocell_kwh,
        saved(t.photocell_kwh)
    );
    println!(
        "| least power | {:.3} | {:.1} % |",
        t.optimised_kwh,
        saved(t.optimised_kwh)
    );
    if let Some(kwh) = t.following_kwh {
        println!(
            "| least power following people | {kwh:.3} | {:.1} % |",
            saved(kwh)
        );
        println!(
            "\nfollowing people saves {:.3} kWh ({:.1} %) against least power without occupancy",
            t.optimised_kwh - kwh,
            100.0 * (1.0 - kwh / t.optimised_kwh.max(1e-12))
        );
    }
    if let Some(path) = plot {
        use luxnode::render::plot::{Plot, Series};
        let series = [
            (
                "all on",
                rows.iter()
                    .map(|r| (r.time_h, r.all_on_w))
                    .collect::<Vec<_>>(),
            ),
            (
                "one photocell",
                rows.iter().map(|r| (r.time_h, r.photocell_w)).collect(),
            ),
            (
                "least power",
                rows.iter().map(|r| (r.time_h, r.optimised_w)).collect(),
            ),
            (
                "least power following people (mean per step)",
                rows.iter()
                    .filter_map(|r| Some((r.time_h, r.following_w?)))
                    .collect(),
            ),
        ]
        .into_iter()
        .filter(|(_, points): &(&str, Vec<(f64, f64)>)| !points.is_empty())
        .map(|(name, points)| Series {
            name: name.into(),
            points,
        })
        .collect();
        Plot {
            title: "Power over the day".into(),
            x_label: "time (h)".into(),
            y_label: "power (W)".into(),
            log_x: false,
            log_y: false,
            series,
        }
        .draw(900, 560)
        .save_png(path)
        .with_context(|| format!("writing {}", path.display()))?;
        println!("\nplot: {}", path.display());
    }
    Ok(())
}

/// `luxnode bench dense`.
fn dense(dir: &Path, capture: Option<&Path>, runs: usize) -> Result<()> {
    use luxnode::bench::dense as bd;
    use luxnode::engine::dense::{DenseField, DenseSettings};
    use luxnode::host::load_average;
    let scene = load_scene(dir, &LoadOptions::default())?;
    let truth = bd::read_truth_dense(&dir.join("truth_dense.csv"))?;
    let capture = capture.map_or_else(|| dir.join("capture_clean"), Path::to_path_buf);
    let cam_truth = bd::read_camera_truth(&capture)?;
    let model = luxnode::engine::compute_model(&scene, &Settings::default())?;
    let cam = scene.camera.as_ref().context("the scene has no camera")?;
    let all_on = vec![1.0; model.luminaires()];
    println!(
        "# dense illuminance: {} ({} patches), load average {}",
        scene.name,
        model.patches.len(),
        load_average().unwrap_or_default()
    );
    let timed = timed_stage;
    let mut times: Vec<[(Duration, f64); 3]> = Vec::new();
    let mut last = None;
    let bar = super::step_spinner("dense field, desk grid and camera view");
    for run in 0..runs.max(1) {
        if let Some(b) = &bar {
            b.set_message(format!(", run {} of {}", run + 1, runs.max(1)));
        }
        let mut field = None;
        let t_field = timed(&mut || {
            field = Some(DenseField::from_model(
                &model,
                &scene.luminaires,
                DenseSettings::default(),
            )?);
            Ok(())
        })?;
        let field = field.context("no field")?;
        let mut grid = Vec::new();
        let t_grid = timed(&mut || {
            let pts = bd::truth_surface_points(&field, &truth);
            grid = field.points(&pts).lux(&all_on)?;
            Ok(())
        })?;
        let mut view = None;
        let t_image = timed(&mut || {
            let img = field.camera_view(cam)?;
            let lux = img.lux(&all_on)?;
            view = Some((img, lux));
            Ok(())
        })?;
        times.push([t_field, t_grid, t_image]);
        last = Some((grid, view.context("no view")?));
    }
    let (t_report, n_states) = time_report(&scene, &model, runs)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let (grid_lux, (img, img_lux)) = last.context("no run")?;
    let g = bd::compare_grid(&truth, &grid_lux).context("grid comparison")?;
    println!();
    println!("| desk grid (truth_dense.csv, all on) | value | target |");
    println!("|---|---:|---:|");
    println!("| points | {} | |", truth.len());
    println!(
        "| mean abs error / mean lux | {:.2} % | ≤ 1 % |",
        100.0 * g.mean_abs_error
    );
    println!(
        "| bias (mean computed / mean true − 1) | {:+.2} % | |",
        100.0 * g.mean_bias
    );
    println!("| worst point | {:.2} % | |", 100.0 * g.worst_point);
    let worst_u0 = g
        .desks
        .iter()
        .map(|(_, t, c)| (c.u0 - t.u0).abs())
        .fold(0.0, f64::max);
    println!("| worst ΔU0 over the desks | {worst_u0:.3} | ≤ 0.02 |");
    println!();
    println!("| desk | Ē truth (lx) | Ē (lx) | U0 truth | U0 | ΔU0 |");
    println!("|---:|---:|---:|---:|---:|---:|");
    for (id, t, c) in &g.desks {
        println!(
            "| {id} | {:.0} | {:.0} | {:.3} | {:.3} | {:+.3} |",
            t.e_mean_lx,
            c.e_mean_lx,
            t.u0,
            c.u0,
            c.u0 - t.u0
        );
    }
    let p = bd::compare_pixels(&cam_truth, &img, &img_lux).context("pixel comparison")?;
    println!();
    println!("| camera view (π L / ρ, inner desk pixels, all on) | value | target |");
    println!("|---|---:|---:|");
    println!("| pixels | {} | |", p.pixels);
    println!("| median abs error | {:.2} % | ≤ 3 % |", 100.0 * p.median);
    println!("| 90th percentile | {:.2} % | |", 100.0 * p.p90);
    println!("| bias | {:+.2} % | |", 100.0 * p.bias);
    println!();
    println!(
        "| stage, median of {} runs | wall (ms) | CPU (ms, both cores) |",
        runs.max(1)
    );
    println!("|---|---:|---:|");
    let names = [
        "field (BVH, vertex interreflection)".to_string(),
        format!("desk grid, {} points", truth.len()),
        format!("camera view, {} pixels", img.pixels.len()),
    ];
    for (k, name) in names.iter().enumerate() {
        let (wall, cpu) = median_wall_cpu(&times.iter().map(|t| t[k]).collect::<Vec<_>>());
        println!(
            "| {name} | {:.0} | {:.0} |",
            wall.as_secs_f64() * 1e3,
            cpu * 1e3
        );
    }
    let (wall, cpu) = median_wall_cpu(&t_report);
    println!(
        "| report of the image ({n_states} states: rebuild, grids, plan, camera views, HTML) | {:.0} | {:.0} |",
        wall.as_secs_f64() * 1e3,
        cpu * 1e3
    );
    Ok(())
}

/// (wall, CPU seconds) of a stage.
fn timed_stage(f: &mut dyn FnMut() -> Result<()>) -> Result<(Duration, f64)> {
    use luxnode::host::cpu_seconds;
    let (t0, c0) = (std::time::Instant::now(), cpu_seconds().unwrap_or(0.0));
    f()?;
    Ok((t0.elapsed(), cpu_seconds().unwrap_or(0.0) - c0))
}

/// The medians of (wall, CPU seconds) timings.
fn median_wall_cpu(t: &[(Duration, f64)]) -> (Duration, f64) {
    let wall = bench::median(t.iter().map(|t| t.0).collect());
    let mut cpu: Vec<f64> = t.iter().map(|t| t.1).collect();
    cpu.sort_by(f64::total_cmp);
    (wall, cpu[cpu.len() / 2])
}

/// The whole report of the image of `model` (all on, then each luminaire alone), timed `runs`
/// times: the timings and the number of states.
fn time_report(
    scene: &Scene,
    model: &luxnode::engine::Model,
    runs: usize,
) -> Result<(Vec<(Duration, f64)>, usize)> {
    let bytes = luxnode::image_build::build_image(
        model,
        &luxnode::image_build::ImageOptions {
            scene_name: scene.name.clone(),
            geometry: Some(luxnode::image_geometry::section_of(
                scene,
                model,
                &luxnode::image_geometry::CommissionRecord::default(),
            )),
            ..Default::default()
        },
    )?;
    let image = Image::parse(&bytes)?;
    let ids: Vec<u32> = model.luminaire_ids.clone();
    let states: Vec<luxnode::render::report::NamedState> =
        std::iter::once(luxnode::render::report::NamedState {
            name: "all on".into(),
            levels: vec![1.0; ids.len()],
        })
        .chain((0..ids.len()).map(|j| {
            luxnode::render::report::NamedState {
                name: format!("luminaire {} alone", ids[j]),
                levels: (0..ids.len())
                    .map(|k| if k == j { 1.0 } else { 0.0 })
                    .collect(),
            }
        }))
        .collect();
    let mut t_report = Vec::new();
    for _ in 0..runs.max(1) {
        t_report.push(timed_stage(&mut || {
            let r = luxnode::render::report::compute(
                &image,
                &luxnode::render::report::ReportOptions {
                    states: states.clone(),
                    ..Default::default()
                },
            )?;
            let _ = luxnode::render::report::html(&r);
            Ok(())
        })?);
    }
    Ok((t_report, states.len()))
}

/// `luxnode bench live`.
fn live(board: &Path, frames: usize) -> Result<()> {
    use luxnode::bench::live as bl;
    use luxnode::board::{Board, SceneSource, camera::CameraBoard};
    let b = Board::load(board)?;
    let CameraBoard::Sim { optics, .. } = &b.camera else {
        bail!(
            "board {}: bench live needs simulated cameras (camera.source = \"sim\")",
            b.name
        );
    };
    let mut scene = match &b.scene {
        SceneSource::DemoOffice => luxnode::sim::demo::demo_office(),
        SceneSource::Directory(dir) => load_scene(dir, &LoadOptions::default())?,
    };
    if let (Some(o), Some(c)) = (optics.as_ref(), scene.camera.as_ref()) {
        scene.camera = Some(o.apply(c));
    }
    let threads = rayon::current_num_threads();
    println!(
        "# luxnode bench live: board {} ({}), {frames} updates, {threads} threads",
        b.name,
        board.display()
    );
    let r = bl::run(scene, frames).map_err(anyhow::Error::msg)?;
    println!(
        "\nframe {} x {} px, {} samples, {} of {} patches seen, {} unknown-emitter groups, \
         {} desks, {} luminaires",
        r.width,
        r.height,
        r.samples,
        r.seen_patches,
        r.patches,
        r.emitters,
        r.sensors,
        r.luminaires
    );
    println!("\n| condition | updates | median (ms) | p95 (ms) | max (ms) |");
    println!("|---|---:|---:|---:|---:|");
    for c in &r.conditions {
        let (m, p, x) = bl::stats(&c.update_ms);
        println!(
            "| {} | {} | {m:.1} | {p:.1} | {x:.1} |",
            c.name,
            c.update_ms.len()
        );
    }
    let (m, p, x) = bl::stats(&r.all_ms());
    println!("| all | {} | {m:.1} | {p:.1} | {x:.1} |", r.all_ms().len());
    println!(
        "\nboot (the live section decoded into the run-time model): {:.0} ms",
        r.boot_ms
    );
    println!(
        "memory: the live section {:.0} kB of flash; held between frames {:.1} MB (the model \
         {:.1} MB)",
        r.section_bytes as f64 / 1e3,
        r.live_bytes as f64 / 1e6,
        r.model_bytes as f64 / 1e6
    );
    if let Some(p) = luxnode::host::peak_memory_mib() {
        println!("process peak resident memory (commissioning included): {p:.0} MiB");
    }
    Ok(())
}

/// `luxnode bench occupancy`: the table of docs/occupancy.md.
fn occupancy(dir: &Path, stride: u32) -> Result<()> {
    let sets = bench::occupancy::run(dir, stride)?;
    println!(
        "| set | frames | visible desk-frames | accuracy | wrong answers | 0 where < 30 % seen | \
         seated missed | false presence (distractors) | µs per update | memory, bytes | cells |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|");
    for r in &sets {
        let fp: Vec<String> = r
            .false_presence
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        println!(
            "| {} | {} | {} | {:.1} % | {} | {} | {} | {} | {:.0} | {} | {} |",
            r.name,
            r.frames,
            r.visible,
            100.0 * r.accuracy(),
            r.wrong,
            r.vacant_unseen,
            r.missed_seated,
            fp.join(", "),
            r.update_us,
            r.memory_bytes,
            r.cells
        );
    }
    let sum = |f: fn(&bench::occupancy::SetResult) -> usize| sets.iter().map(f).sum::<usize>();
    let (visible, correct) = (sum(|r| r.visible), sum(|r| r.correct));
    println!(
        "| all | {} | {visible} | {:.1} % | {} | {} | {} | {} | {:.0} | | |",
        sum(|r| r.frames),
        100.0 * correct as f64 / visible.max(1) as f64,
        sum(|r| r.wrong),
        sum(|r| r.vacant_unseen),
        sum(|r| r.missed_seated),
        sum(|r| r.false_presence.iter().map(|e| e.1).sum()),
        sets.iter().map(|r| r.update_us).fold(0.0, f64::max),
    );
    Ok(())
}

/// A node serving `image` with every luminaire at full (arc 254): what the load benches poll.
pub(crate) fn full_on_node(image: &std::path::Path) -> Result<luxnode::node::Node> {
    Ok(luxnode::serve::load_node(
        image,
        luxnode::node::NodeOptions {
            initial_arc: Some(254),
            ..luxnode::node::NodeOptions::default()
        },
    )?)
}
