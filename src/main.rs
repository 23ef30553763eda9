//! `luxnode`: the command line of the node. It parses arguments, reads files through the
//! library, prints results; all logic lives in the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use luxnode::dali::ArcLevel;
use luxnode::engine::{DirectModel, RaySetKind, Settings};
use luxnode::evaluate::{Computed, compare};
use luxnode::photometry::IntensityDistribution;
use luxnode::preset::Preset;
use luxnode::scene::{LoadOptions, Scenario, Scene, read_states, read_truth};
use luxnode::store::{Image, Precision};

mod cli;

#[derive(Parser)]
#[command(
    name = "luxnode",
    version,
    about = "Desk illuminance from a ceiling ToF + RGB camera"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Summarise a photometric file (EULUMDAT .ldt or IES .ies).
    Photometry {
        /// The file.
        file: PathBuf,
        /// Print the summary as one JSON object.
        #[arg(long, conflicts_with = "csv")]
        json: bool,
        /// Print the unfolded intensity table as CSV (c_deg,gamma_deg,intensity_cd).
        #[arg(long)]
        csv: bool,
        /// Also write the distribution as EULUMDAT to this file.
        #[arg(long, value_name = "FILE")]
        to_ldt: Option<PathBuf>,
        /// Also write the distribution as IES LM-63-2002 to this file.
        #[arg(long, value_name = "FILE")]
        to_ies: Option<PathBuf>,
    },
    /// Scene directories (the format of ../shared/scenes/README.md).
    Scene {
        #[command(subcommand)]
        command: SceneCommand,
    },
    /// Compute desk illuminance for lighting scenarios.
    Simulate(Box<SimulateArgs>),
    /// The flash image: build one from a scene, inspect one.
    Image {
        #[command(subcommand)]
        command: ImageCommand,
    },
    /// Serve a commissioned image over Modbus TCP (and RTU), optionally following a DALI gateway.
    Serve(Box<cli::modbus::ServeArgs>),
    /// The Modbus register map.
    Modbus {
        #[command(subcommand)]
        command: cli::modbus::ModbusCommand,
    },
    /// Commission from a capture set (ToF depth + luminance frames, no CAD model) and write
    /// the flash image.
    Commission(Box<CommissionArgs>),
    /// Benchmarks that print tables (and plots) for docs/.
    Bench {
        #[command(subcommand)]
        command: BenchCommand,
    },
    /// Run the node on a board.
    Run(Box<cli::run::RunArgs>),
}

#[derive(clap::Args)]
struct SimulateArgs {
    /// The scene directory (CAD input).
    #[arg(long, required_unless_present = "image", conflicts_with = "image")]
    scene: Option<PathBuf>,
    /// Answer from a flash image alone (no scene needed).
    #[arg(long)]
    image: Option<PathBuf>,
    #[command(flatten)]
    load: SceneArgs,
    /// All luminaires on (the default when no state is given).
    #[arg(long, conflicts_with_all = ["on", "states"])]
    all_on: bool,
    /// These luminaire ids on (comma separated), the others off.
    #[arg(long, value_delimiter = ',', conflicts_with = "states")]
    on: Option<Vec<u32>>,
    /// A CSV of scenarios (header with scenario_id and luminaires_on, ids separated by ';').
    #[arg(long)]
    states: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Csv)]
    format: OutputFormat,
    #[command(flatten)]
    engine: EngineArgs,
    /// Compare with this truth file (default: the scene's truth.csv when present).
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Write a top view of the room in false-colour lux (PNG) for one scenario.
    #[arg(long, value_name = "FILE.png")]
    map: Option<PathBuf>,
    /// The scenario the map shows (default: the first).
    #[arg(long, requires = "map")]
    map_scenario: Option<String>,
    /// Map cell size, m.
    #[arg(long, default_value_t = 0.1, requires = "map")]
    map_cell: f64,
}

#[derive(clap::Args)]
struct CommissionArgs {
    /// The capture set directory (camera.json, depth_NNN.png, luminance_L<k>.png).
    #[arg(long)]
    capture: PathBuf,
    /// luminaires.json (installed positions and photometry).
    #[arg(long)]
    luminaires: PathBuf,
    /// sensors.json (the desk points to answer for).
    #[arg(long)]
    sensors: PathBuf,
    /// desks.json, for the report's desk outlines and desk lux.
    #[arg(long)]
    desks: Option<PathBuf>,
    /// The flash image to write.
    #[arg(long)]
    out: PathBuf,
    /// Also write the mesh as PLY (grey = reflectance).
    #[arg(long, value_name = "FILE.ply")]
    export_mesh: Option<PathBuf>,
    /// Also draw the camera view with a false-colour lux overlay, desk outlines and desk lux.
    #[arg(long, value_name = "FILE.png")]
    report: Option<PathBuf>,
    /// Close the room (inferred floor, walls, ceiling).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    closure: OnOff,
    /// Reflectance of the inferred walls.
    #[arg(long, default_value_t = luxnode::commission::ClosureOptions::default().wall_rho)]
    wall_rho: f64,
    /// Reflectance of the inferred ceiling.
    #[arg(long, default_value_t = luxnode::commission::ClosureOptions::default().ceiling_rho)]
    ceiling_rho: f64,
    /// Room box x0,y0,x1,y1 in m (default: inferred).
    #[arg(long, value_delimiter = ',', num_args = 4)]
    room: Option<Vec<f64>>,
    /// Ceiling height, m (default: just above the highest luminaire opening).
    #[arg(long)]
    ceiling_height: Option<f64>,
    /// Target patch size of the reconstructed mesh (largest rectangle side), m.
    #[arg(long, default_value_t = luxnode::commission::MeshOptions::default().patch_size_m)]
    mesh_patch_size: f64,
    /// Camera gain from one luxmeter reading instead of camera.json: SENSOR_ID:LUX with all
    /// luminaires on.
    #[arg(long, value_name = "ID:LUX")]
    luxmeter: Option<String>,
    /// Estimate reflectances (off: every seen surface gets --start-rho).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    reflectances: OnOff,
    /// Reflectance of seen surfaces before (or without) estimation.
    #[arg(long, default_value_t = 0.5)]
    start_rho: f64,
    /// How the one-luminaire-on frames combine: median of π L / E per pixel, or the paper's
    /// first-order spherical-harmonic fit per triangle (docs/commissioning.md).
    #[arg(long, value_enum, default_value_t = ReflectanceMethodArg::Median)]
    reflectance_method: ReflectanceMethodArg,
    /// Print the error against a truth.csv (with --states).
    #[arg(long, requires = "states")]
    truth: Option<PathBuf>,
    /// states.csv for --truth.
    #[arg(long)]
    states: Option<PathBuf>,
    #[command(flatten)]
    engine: EngineArgs,
    #[command(flatten)]
    store: StoreArgs,
}

/// `--reflectance-method`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ReflectanceMethodArg {
    /// Median over the well-lit frames of ρ = π L / E.
    Median,
    /// First-order spherical-harmonic fit (RGBD2lux §3.1).
    Sh,
}

#[derive(clap::Args)]
struct EngineArgs {
    /// Preset of every engine and store knob (fast, balanced, accurate; docs/tradeoffs.md); the
    /// knobs below override it one by one. Balanced is the engine's default.
    #[arg(long, default_value = "balanced", value_parser = parse_preset)]
    preset: Preset,
    /// Rays per patch (Isocell rounds up: 1000 becomes 1083) [balanced: 300].
    #[arg(long)]
    rays: Option<usize>,
    /// Rays per sensor [balanced: 10000].
    #[arg(long)]
    sensor_rays: Option<usize>,
    /// Final-gather rays per sensor (exact first bounce; 0: off) [balanced: 1000].
    #[arg(long)]
    final_gather_rays: Option<usize>,
    /// Largest patch edge, m [balanced: 1].
    #[arg(long)]
    patch_size: Option<f64>,
    /// Largest projected angle a patch may subtend at a sensor that sees it (0: uniform
    /// patches) [balanced: 0.5].
    #[arg(long)]
    detail: Option<f64>,
    /// Smallest patch edge the refinement goes to, m [balanced: 0.0625].
    #[arg(long)]
    min_patch: Option<f64>,
    /// Largest patch edge over its distance to a luminaire lighting it (0: off) [balanced: 1].
    #[arg(long)]
    light_detail: Option<f64>,
    /// Ray set [balanced: isocell].
    #[arg(long, value_enum)]
    ray_set: Option<RaySetArg>,
    /// Points over each luminaire opening for direct light on patches (sensors: 16 times as
    /// many) [balanced: 8].
    #[arg(long)]
    opening_samples: Option<usize>,
    /// Points per patch at which direct light is averaged [balanced: 4].
    #[arg(long)]
    patch_direct_points: Option<usize>,
    /// Direct light: exact (photometry, inverse square, shadow rays) or the paper's [exact].
    #[arg(long, value_enum)]
    direct: Option<DirectArg>,
    /// Model the luminaires' LDC (off: Lambertian luminaires of the same flux) [on].
    #[arg(long, value_enum)]
    ldc: Option<OnOff>,
    /// Model the sensors' LSC (off: ideal cosine sensors) [on].
    #[arg(long, value_enum)]
    lsc: Option<OnOff>,
    /// Reciprocity and closure rectification [balanced: on].
    #[arg(long, value_enum)]
    rectify: Option<OnOff>,
    /// Rectification stops when every row sum is this close to its closure target [1e-9].
    #[arg(long)]
    rectify_tolerance: Option<f64>,
    /// Solver stop: relative residual [balanced: 1e-10].
    #[arg(long)]
    tolerance: Option<f64>,
    /// Seed of every pseudo-random choice [1].
    #[arg(long)]
    seed: Option<u64>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse()
        .map_err(|e: luxnode::preset::UnknownPreset| e.to_string())
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum OutputFormat {
    /// scenario_id,sensor_id,lux
    Csv,
    /// One JSON object.
    Json,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum RaySetArg {
    /// Isocell (stratified).
    Isocell,
    /// Monte Carlo (cosine weighted).
    Mc,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DirectArg {
    /// Exact.
    Exact,
    /// The paper's formulation.
    Paper,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

impl EngineArgs {
    /// The preset's settings with every knob given on the command line applied.
    fn settings(&self) -> Settings {
        let mut s = self.preset.engine();
        let p = &mut s.patches;
        set(&mut p.patch_size_m, self.patch_size);
        set(&mut p.detail_ratio, self.detail);
        set(&mut p.min_patch_m, self.min_patch);
        set(&mut p.light_ratio, self.light_detail);
        set(&mut s.rays, self.rays);
        set(&mut s.sensor_rays, self.sensor_rays);
        set(&mut s.final_gather_rays, self.final_gather_rays);
        set(&mut s.seed, self.seed);
        if let Some(r) = self.ray_set {
            s.ray_set = match r {
                RaySetArg::Isocell => RaySetKind::Isocell,
                RaySetArg::Mc => RaySetKind::MonteCarlo { seed: s.seed },
            };
        }
        set(&mut s.opening_samples, self.opening_samples);
        set(&mut s.patch_direct_points, self.patch_direct_points);
        if let Some(d) = self.direct {
            s.direct = match d {
                DirectArg::Exact => DirectModel::Exact,
                DirectArg::Paper => DirectModel::Paper,
            };
        }
        set(&mut s.ldc, self.ldc.map(|x| x == OnOff::On));
        set(&mut s.lsc, self.lsc.map(|x| x == OnOff::On));
        set(&mut s.rectify, self.rectify.map(|x| x == OnOff::On));
        set(&mut s.rectify_tolerance, self.rectify_tolerance);
        set(&mut s.solve.tolerance, self.tolerance);
        s
    }
}

fn set<T>(slot: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *slot = v;
    }
}

// parsed once per process: the size of a variant does not matter
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum ImageCommand {
    /// Commission a scene (CAD input) and write its flash image.
    Build {
        /// The scene directory; `demo-office` for the built-in demo office.
        #[arg(long)]
        scene: PathBuf,
        #[command(flatten)]
        load: SceneArgs,
        /// The image file to write.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        engine: EngineArgs,
        #[command(flatten)]
        store: StoreArgs,
    },
    /// Print an image's header, sections and FORMFACTORS usage; verify its checksums.
    Info {
        /// The image file.
        file: PathBuf,
    },
    /// Evaluate DALI states with the run-time core (what the firmware prints):
    /// `state,sensor_id,lux_superposition,lux_resolve`.
    Eval {
        /// The image file.
        file: PathBuf,
        /// A state: one DALI arc level per luminaire (0 off, 1..254, 255 no change), comma
        /// separated; repeat for several states (MASK keeps the previous state's level).
        #[arg(long = "arc", value_delimiter = ',', num_args = 1.., action = clap::ArgAction::Append, required_unless_present = "demo_states")]
        arc: Vec<String>,
        /// The firmware's demo states instead.
        #[arg(long, conflicts_with = "arc")]
        demo_states: bool,
    },
}

#[derive(clap::Args)]
struct StoreArgs {
    /// Storage precision of the form factors and direct terms [from --preset; balanced: u16].
    #[arg(long, value_enum)]
    precision: Option<PrecisionArg>,
    /// Drop form factors below this (each row keeps its sum); 0 keeps all [0].
    #[arg(long)]
    prune: Option<f64>,
}

impl StoreArgs {
    /// The preset's store settings with the command line's applied.
    fn store(&self, preset: Preset) -> luxnode::preset::StoreSettings {
        let mut s = preset.store();
        set(
            &mut s.precision,
            self.precision.map(PrecisionArg::precision),
        );
        set(&mut s.prune_below, self.prune);
        s
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum PrecisionArg {
    /// 8-byte floats.
    F64,
    /// 4-byte floats.
    F32,
    /// 2-byte floats.
    F16,
    /// 16-bit fractions of a per-row scale.
    U16,
    /// 8-bit fractions of a per-row scale.
    U8,
}

impl PrecisionArg {
    fn precision(self) -> Precision {
        match self {
            PrecisionArg::F64 => Precision::F64,
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F16 => Precision::F16,
            PrecisionArg::U16 => Precision::U16,
            PrecisionArg::U8 => Precision::U8,
        }
    }
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Commissioning time per stage, per-state time, accuracy against the scene's truth.
    Engine {
        /// The scene directory (with states.csv and truth.csv for accuracy).
        #[arg(long)]
        scene: PathBuf,
        /// Commissioning runs (the median is printed).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Also run this Radiance harness (bench/radiance/office_a.py) and compare.
        #[arg(long)]
        radiance: Option<PathBuf>,
        /// Arguments for the Radiance harness (its settings), one string.
        #[arg(long, default_value = "", allow_hyphen_values = true)]
        radiance_args: String,
    },
    /// Speed against accuracy: the presets, every engine and store knob one at a time, and the
    /// rays x patch size grid; commissioning time, image size, per-state time, error against
    /// the truth (mean, worst sensor). Prints a table; writes Pareto plots with --plots.
    Tradeoffs {
        /// The scene directory (states.csv, truth.csv; with --capture: luminaires.json,
        /// sensors.json, desks.json).
        #[arg(long)]
        scene: PathBuf,
        /// Commission from this capture set instead of the scene's CAD model (each point a full
        /// `commission` run).
        #[arg(long)]
        capture: Option<PathBuf>,
        /// Grid: rays per patch (empty: no grid).
        #[arg(long, value_delimiter = ',', default_values_t = [100, 300, 1000])]
        rays: Vec<usize>,
        /// Grid: base patch sizes, m.
        #[arg(long, value_delimiter = ',', default_values_t = [2.0, 1.0, 0.5, 0.25])]
        patch_sizes: Vec<f64>,
        /// Skip the grid.
        #[arg(long)]
        no_grid: bool,
        /// Skip the one-at-a-time knob sweep.
        #[arg(long)]
        no_knobs: bool,
        /// Commissioning runs per point (the median is kept).
        #[arg(long, default_value_t = 1)]
        runs: usize,
        /// Commissioning runs per preset.
        #[arg(long, default_value_t = 3)]
        preset_runs: usize,
        /// Write the Pareto plots (PNG) into this directory.
        #[arg(long)]
        plots: Option<PathBuf>,
        /// Also write the rays x patch-size plot (PNG) of the grid rows.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// "Model only what the scene requires": patch counts per preset and surface, pictures of
    /// the patch layout, and the error of uniform meshes with the same patch counts.
    Patches {
        /// The scene directory (with states.csv and truth.csv).
        #[arg(long)]
        scene: PathBuf,
        /// Write the layout pictures (PNG) into this directory.
        #[arg(long)]
        out_dir: Option<PathBuf>,
    },
    /// Stage times and memory against patches x rays (Ward's grey room, or --scene).
    Scaling {
        /// A scene directory (default: Ward's grey room, built in code).
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Base patch sizes, m.
        #[arg(long, value_delimiter = ',', default_values_t = [1.0, 0.7, 0.5])]
        patch_sizes: Vec<f64>,
        /// Rays per patch.
        #[arg(long, value_delimiter = ',', default_values_t = [300, 3000])]
        rays: Vec<usize>,
        /// Uniform patches (no refinement toward sensors and luminaires).
        #[arg(long)]
        uniform: bool,
        /// Commissioning runs per point (the median is kept).
        #[arg(long, default_value_t = 1)]
        runs: usize,
    },
    /// The run-time core over an image: one dimming state, and a full re-solve.
    Runtime {
        /// The image file.
        #[arg(long)]
        image: PathBuf,
    },
    /// Draw the trade-off plot from a table printed by `bench tradeoffs`.
    PlotTradeoffs {
        /// The markdown table (the output of `bench tradeoffs`).
        #[arg(long)]
        table: PathBuf,
        /// The PNG to write.
        #[arg(long)]
        out: PathBuf,
        /// Plot title.
        #[arg(
            long,
            default_value = "OFFICE_A: COMMISSIONING TIME VS ERROR (RAYS 100..10000)"
        )]
        title: String,
    },
    /// Many Modbus TCP clients polling the desk lux at once: throughput, latency, memory.
    ModbusLoad {
        /// The image to serve.
        #[arg(long)]
        image: PathBuf,
        /// Clients.
        #[arg(long, default_value_t = 100)]
        clients: usize,
        /// Duration, s.
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// Each client's poll interval, ms (0: back to back).
        #[arg(long, default_value_t = 0)]
        interval_ms: u64,
    },
    /// Mutated Modbus frames into the register map and the RTU handler; every answer checked.
    Fuzz {
        /// Frames.
        #[arg(long, default_value_t = 10_000_000)]
        frames: u64,
        /// Seed.
        #[arg(long, default_value_t = 0x6C75_786E)]
        seed: u64,
    },
    /// The paper's ablation (paper vs exact direct light, LDC, LSC) against the truth.
    Ablation {
        /// The scene directory.
        #[arg(long)]
        scene: PathBuf,
    },
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Validate a scene directory and print what it contains; non-zero exit on errors.
    Check {
        /// The scene directory.
        dir: PathBuf,
        #[command(flatten)]
        load: SceneArgs,
    },
}

#[derive(clap::Args)]
struct SceneArgs {
    /// Length unit of the scene's coordinates.
    #[arg(long, value_enum, default_value_t = Unit::M)]
    unit: Unit,
    /// Which photometric file wins when a luminaire names both.
    #[arg(long, value_enum, default_value_t = Prefer::Ldt)]
    prefer: Prefer,
}

#[derive(Clone, Copy, ValueEnum)]
enum Unit {
    /// Metres.
    M,
    /// Millimetres.
    Mm,
}

#[derive(Clone, Copy, ValueEnum)]
enum Prefer {
    /// EULUMDAT.
    Ldt,
    /// IES.
    Ies,
}

impl SceneArgs {
    fn options(&self) -> LoadOptions {
        LoadOptions {
            unit_to_m: match self.unit {
                Unit::M => 1.0,
                Unit::Mm => 0.001,
            },
            photometry: match self.prefer {
                Prefer::Ldt => luxnode::scene::PhotometryPreference::Ldt,
                Prefer::Ies => luxnode::scene::PhotometryPreference::Ies,
            },
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .init();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Photometry {
            file,
            json,
            csv,
            to_ldt,
            to_ies,
        } => photometry(&file, json, csv, to_ldt.as_deref(), to_ies.as_deref()),
        Command::Scene {
            command: SceneCommand::Check { dir, load },
        } => scene_check(&dir, &load.options()),
        Command::Simulate(args) => simulate(&args),
        Command::Bench { command } => bench(command),
        Command::Image { command } => image(command),
        Command::Run(args) => cli::run::run(&args),
        Command::Serve(args) => cli::modbus::serve(&args).map(|()| ExitCode::SUCCESS),
        Command::Modbus { command } => cli::modbus::modbus(&command).map(|()| ExitCode::SUCCESS),
        Command::Commission(args) => commission_cmd::run(&args),
    }
}

/// "N (a .. b°, step s°)" for an angle grid.
fn describe_grid(v: &[f64]) -> String {
    let n = v.len();
    match n {
        0 => "none".into(),
        1 => format!("1 ({}°)", v[0]),
        _ => {
            let step = v[1] - v[0];
            let uniform = v.windows(2).all(|w| ((w[1] - w[0]) - step).abs() < 1e-6);
            let spacing = if uniform {
                format!("step {step}°")
            } else {
                "non-uniform".into()
            };
            format!("{n} ({} .. {}°, {spacing})", v[0], v[n - 1])
        }
    }
}

fn photometry(
    file: &Path,
    json: bool,
    csv: bool,
    to_ldt: Option<&Path>,
    to_ies: Option<&Path>,
) -> Result<ExitCode> {
    let d = IntensityDistribution::load(file)?;
    if let Some(out) = to_ldt {
        std::fs::write(out, d.to_ldt()?).with_context(|| format!("writing {}", out.display()))?;
    }
    if let Some(out) = to_ies {
        std::fs::write(out, d.to_ies()).with_context(|| format!("writing {}", out.display()))?;
    }
    if csv {
        print!("{}", d.to_csv());
        return Ok(ExitCode::SUCCESS);
    }
    let flux = d.flux_lm();
    let down = d.zonal_flux_lm(0.0, 90.0);
    let (max_cd, max_c, max_g) = d.max_intensity();
    let mut warnings = d.meta.warnings.clone();
    if let Some(lor) = d.lor_pct() {
        if lor > 100.5 {
            warnings.push(format!(
                "integrated flux exceeds the rated lamp flux (light output ratio {lor:.1} %)"
            ));
        }
        if let Some(declared) = d.meta.declared_lor_pct
            && (lor - declared).abs() > 0.02 * declared.max(1.0)
        {
            warnings.push(format!(
                "declared light output ratio {declared} % but the table integrates to {lor:.1} %"
            ));
        }
    }
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "format": d.format().to_string(),
            "symmetry": d.symmetry().name(),
            "isym": d.symmetry().isym(),
            "luminaire": d.meta.luminaire,
            "manufacturer": d.meta.manufacturer,
            "c_planes_stored": d.stored_c_deg().len(),
            "c_planes_unfolded": d.c_grid_deg().len(),
            "gamma_angles": d.gamma_grid_deg().len(),
            "gamma_min_deg": d.gamma_grid_deg().first(),
            "gamma_max_deg": d.gamma_grid_deg().last(),
            "flux_lm": flux,
            "downward_flux_lm": down,
            "max_cd": max_cd,
            "max_c_deg": max_c,
            "max_gamma_deg": max_g,
            "absolute_photometry": d.meta.absolute,
            "lamp_flux_lm": d.meta.lamp_flux_lm,
            "lor_pct": d.lor_pct(),
            "declared_lor_pct": d.meta.declared_lor_pct,
            "tilt_include": d.meta.tilt.is_some(),
            "warnings": warnings,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("file:           {}", file.display());
    println!("format:         {}", d.format());
    if !d.meta.luminaire.is_empty() {
        println!("luminaire:      {}", d.meta.luminaire);
    }
    if !d.meta.manufacturer.is_empty() {
        println!("manufacturer:   {}", d.meta.manufacturer);
    }
    println!("symmetry:       {}", d.symmetry());
    println!(
        "C planes:       {} stored, {} after unfolding to 0..360°",
        describe_grid(d.stored_c_deg()),
        d.c_grid_deg().len()
    );
    println!("gamma angles:   {}", describe_grid(d.gamma_grid_deg()));
    if d.meta.absolute {
        println!("photometry:     absolute");
    } else if let (Some(lamp), Some(lor)) = (d.meta.lamp_flux_lm, d.lor_pct()) {
        println!("photometry:     relative, lamp flux {lamp:.1} lm, light output ratio {lor:.1} %");
    }
    println!(
        "total flux:     {flux:.2} lm (downward {down:.2} lm, {:.1} %)",
        if flux > 0.0 { 100.0 * down / flux } else { 0.0 }
    );
    println!("max intensity:  {max_cd:.2} cd at C {max_c}° gamma {max_g}°");
    if let Some(t) = &d.meta.tilt {
        println!(
            "tilt:           TILT=INCLUDE, {} angles, factor {:.3} at 0° .. {:.3} at {}°",
            t.angles_deg.len(),
            t.factors[0],
            t.factors[t.factors.len() - 1],
            t.angles_deg[t.angles_deg.len() - 1]
        );
    }
    for w in &warnings {
        println!("warning:        {w}");
    }
    Ok(ExitCode::SUCCESS)
}

fn scene_check(dir: &Path, options: &LoadOptions) -> Result<ExitCode> {
    if !dir.is_dir() {
        bail!("{} is not a directory", dir.display());
    }
    match Scene::load(dir, options) {
        Ok(scene) => {
            print!("{}", scene.summary());
            println!("OK: scene {} is valid", scene.name);
            Ok(ExitCode::SUCCESS)
        }
        Err(errors) => {
            eprintln!("{errors}");
            Ok(ExitCode::FAILURE)
        }
    }
}

fn load_scene(dir: &Path, options: &LoadOptions) -> Result<Scene> {
    if !dir.is_dir() {
        bail!("{} is not a scene directory", dir.display());
    }
    Scene::load(dir, options).map_err(|e| anyhow::anyhow!("{e}"))
}

fn simulate(args: &SimulateArgs) -> Result<ExitCode> {
    if let Some(path) = &args.image {
        return simulate_image(args, path);
    }
    let Some(scene_dir) = &args.scene else {
        bail!("give --scene DIR or --image FILE");
    };
    let scene = load_scene(scene_dir, &args.load.options())?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let ids: Vec<u32> = scene.luminaires.iter().map(|l| l.id).collect();
    let scenarios = scenarios_from(args, &ids)?;
    let settings = args.engine.settings();
    let model = luxnode::engine::commission(&scene, &settings)?;
    let st = &model.stats;
    eprintln!(
        "model: {} patches, {} rays/patch, {} rays/sensor, {} form factors; {} ms ({})",
        st.patches,
        st.rays_per_patch,
        st.rays_per_sensor,
        st.nnz,
        st.total().as_millis(),
        st.timings
            .iter()
            .map(|(n, t)| format!("{n} {} ms", t.as_millis()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    eprintln!(
        "rays: {:.3} % left the scene; {:.2} % of the surface is covered{}; solver iterations {:?}",
        100.0 * st.escaped_fraction,
        100.0 * st.covered_fraction,
        st.rectify.map_or(String::new(), |r| format!(
            "; rectified in {} sweeps (reciprocity {:.1e}, closure {:.1e})",
            r.iterations, r.reciprocity_error, r.closure_error
        )),
        st.iterations
    );
    eprintln!(
        "sensor cosine error f2: {}",
        model
            .sensor_ids
            .iter()
            .zip(&model.sensor_f2)
            .map(|(id, f2)| format!("{id}: {:.1} %", 100.0 * f2))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut computed = Vec::new();
    for sc in &scenarios {
        let levels: Vec<f64> = model
            .luminaire_ids
            .iter()
            .map(|id| if sc.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        let lux = model.sensor_lux(&levels)?;
        for (sensor, lux) in model.sensor_ids.iter().zip(lux) {
            computed.push(Computed {
                scenario: sc.id.clone(),
                sensor: *sensor,
                lux,
            });
        }
    }
    let extra = serde_json::json!({
        "patches": st.patches,
        "rays_per_patch": st.rays_per_patch,
        "sensor_f2": model.sensor_ids.iter().zip(&model.sensor_f2)
            .map(|(id, f2)| serde_json::json!({"sensor_id": id, "f2": f2}))
            .collect::<Vec<_>>(),
    });
    print_computed(args.format, &scene.name, &scenarios, &computed, extra)?;
    if let Some(path) = &args.map {
        let sc = match &args.map_scenario {
            Some(id) => scenarios
                .iter()
                .find(|s| &s.id == id)
                .with_context(|| format!("--map-scenario {id} is not among the scenarios"))?,
            None => &scenarios[0],
        };
        if !(args.map_cell.is_finite() && args.map_cell >= 0.01) {
            bail!("--map-cell must be at least 0.01 m");
        }
        let levels: Vec<f64> = model
            .luminaire_ids
            .iter()
            .map(|id| if sc.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        let opts = luxnode::render::map::MapOptions {
            cell_m: args.map_cell,
            title: format!("{} - SCENARIO {} - ILLUMINANCE", scene.name, sc.id),
            ..Default::default()
        };
        let t0 = std::time::Instant::now();
        let view = luxnode::render::map::compute(&scene, &model, &levels, &opts);
        luxnode::render::map::draw(&scene, &view, &opts)
            .save_png(path)
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!(
            "map: {} ({} x {} cells of {} m, scenario {}, {} ms)",
            path.display(),
            view.cells[0],
            view.cells[1],
            opts.cell_m,
            sc.id,
            t0.elapsed().as_millis()
        );
        for (id, lux) in &view.desk_mean_lx {
            eprintln!("  desk {id}: mean {lux:.0} lx");
        }
    }
    report_truth(
        args.truth
            .clone()
            .or_else(|| Some(scene_dir.join("truth.csv")).filter(|p| p.exists())),
        &computed,
    )?;
    Ok(ExitCode::SUCCESS)
}

/// Prints the error against a truth file to stderr.
fn report_truth(truth_path: Option<PathBuf>, computed: &[Computed]) -> Result<()> {
    if let Some(path) = truth_path {
        let truth = read_truth(&path)?;
        if let Some(a) = compare(computed, &truth) {
            eprintln!(
                "against {}: error {:.2} % (mean |error| {:.1} lx over {} values, bias {:+.2} %), worst sensor {:.2} %",
                path.display(),
                100.0 * a.error,
                a.mean_abs_lx,
                a.pairs,
                100.0 * a.bias,
                100.0 * a.worst_sensor
            );
            for (s, e) in &a.per_sensor {
                eprintln!("  sensor {s}: {:.2} %", 100.0 * e);
            }
        }
    }
    Ok(())
}

/// Scenarios from the arguments, for luminaire ids `ids`.
fn scenarios_from(args: &SimulateArgs, ids: &[u32]) -> Result<Vec<Scenario>> {
    let scenarios = if let Some(path) = &args.states {
        read_states(path)?
    } else if let Some(on) = &args.on {
        vec![Scenario {
            id: format!(
                "on:{}",
                on.iter().map(u32::to_string).collect::<Vec<_>>().join(";")
            ),
            on: on.clone(),
        }]
    } else {
        vec![Scenario {
            id: "all_on".into(),
            on: ids.to_vec(),
        }]
    };
    for s in &scenarios {
        for id in &s.on {
            if !ids.contains(id) {
                bail!("scenario {}: luminaire {id} is not in the scene", s.id);
            }
        }
    }
    Ok(scenarios)
}

fn print_computed(
    format: OutputFormat,
    name: &str,
    scenarios: &[Scenario],
    computed: &[Computed],
    extra: serde_json::Value,
) -> Result<()> {
    match format {
        OutputFormat::Csv => {
            println!("scenario_id,sensor_id,lux");
            for c in computed {
                println!("{},{},{:.3}", c.scenario, c.sensor, c.lux);
            }
        }
        OutputFormat::Json => {
            let mut v = serde_json::json!({
                "scene": name,
                "scenarios": scenarios.iter().map(|sc| serde_json::json!({
                    "scenario_id": sc.id,
                    "luminaires_on": sc.on,
                    "sensors": computed.iter().filter(|c| c.scenario == sc.id)
                        .map(|c| serde_json::json!({"sensor_id": c.sensor, "lux": c.lux}))
                        .collect::<Vec<_>>(),
                })).collect::<Vec<_>>(),
            });
            if let (Some(v), serde_json::Value::Object(extra)) = (v.as_object_mut(), extra) {
                v.extend(extra);
            }
            println!("{}", serde_json::to_string_pretty(&v)?);
        }
    }
    Ok(())
}

fn read_image_file(path: &Path) -> Result<Vec<u8>> {
    luxnode::daemon::read_image_file(path)
}

fn simulate_image(args: &SimulateArgs, path: &Path) -> Result<ExitCode> {
    if args.map.is_some() {
        bail!("--map needs the scene's geometry: use --scene");
    }
    let bytes = read_image_file(path)?;
    let image = Image::parse(&bytes).with_context(|| format!("image {}", path.display()))?;
    let runtime = luxnode::runtime::Runtime::new(&image);
    let ids: Vec<u32> = (0..image.luminaires())
        .map(|j| image.luminaire_id(j))
        .collect();
    let scenarios = scenarios_from(args, &ids)?;
    let mut computed = Vec::new();
    let mut out = vec![0.0; image.sensors()];
    for sc in &scenarios {
        let levels: Vec<f64> = ids
            .iter()
            .map(|id| if sc.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        runtime.sensor_lux(&levels, &mut out)?;
        for (k, lux) in out.iter().enumerate() {
            computed.push(Computed {
                scenario: sc.id.clone(),
                sensor: image.sensor_id(k),
                lux: *lux,
            });
        }
    }
    eprintln!(
        "image {}: {}, generation {}, {} patches, {} luminaires, {} sensors",
        path.display(),
        image.payload.scene_name,
        image.header.generation,
        image.patches(),
        image.luminaires(),
        image.sensors()
    );
    let extra = serde_json::json!({
        "image_generation": image.header.generation,
        "patches": image.patches(),
    });
    print_computed(
        args.format,
        image.payload.scene_name,
        &scenarios,
        &computed,
        extra,
    )?;
    report_truth(args.truth.clone(), &computed)?;
    Ok(ExitCode::SUCCESS)
}

fn image(command: ImageCommand) -> Result<ExitCode> {
    use luxnode::store::build::{ImageOptions, build_image, sections, too_large_message};
    match command {
        ImageCommand::Build {
            scene,
            load,
            out,
            engine,
            store,
        } => {
            let sc = if scene.as_os_str() == "demo-office" {
                luxnode::demo::demo_office()
            } else {
                load_scene(&scene, &load.options())?
            };
            let t0 = std::time::Instant::now();
            let model = luxnode::engine::commission(&sc, &engine.settings())?;
            let st = store.store(engine.preset);
            let options = ImageOptions {
                precision: st.precision,
                prune_below: st.prune_below,
                scene_name: sc.name.clone(),
                sensor_flags: Vec::new(),
            };
            let bytes = build_image(&model, &options)?;
            let image = Image::parse(&bytes)?;
            let region = luxnode::layout::FORMFACTORS_LEN_BYTES as usize;
            if bytes.len() > region {
                bail!("{}", too_large_message(&image, region));
            }
            std::fs::write(&out, &bytes).with_context(|| format!("writing {}", out.display()))?;
            println!(
                "{}: {} bytes ({:.1} % of the {} KiB FORMFACTORS region), {} patches, {} form factors ({}), built in {} ms",
                out.display(),
                bytes.len(),
                100.0 * bytes.len() as f64 / region as f64,
                region / 1024,
                image.patches(),
                image.payload.ff.nnz(),
                image.payload.ff.values.precision().name(),
                t0.elapsed().as_millis()
            );
        }
        ImageCommand::Eval {
            file,
            arc,
            demo_states,
        } => {
            let bytes = read_image_file(&file)?;
            let image =
                Image::parse(&bytes).with_context(|| format!("image {}", file.display()))?;
            let l = image.luminaires();
            if demo_states {
                let states: Vec<Vec<ArcLevel>> = (0..luxnode::runtime::DEMO_STATES)
                    .map(|k| {
                        (0..l)
                            .map(|j| luxnode::runtime::demo_arc_level(k, j))
                            .collect()
                    })
                    .collect();
                print!("{}", luxnode::runtime::eval_report(&image, &states)?);
                return Ok(ExitCode::SUCCESS);
            }
            let levels_all: Vec<u8> = arc
                .iter()
                .map(|a| {
                    a.trim()
                        .parse::<u8>()
                        .with_context(|| format!("arc level {a:?} is not 0..255"))
                })
                .collect::<Result<_>>()?;
            if levels_all.len() % l != 0 || levels_all.is_empty() {
                bail!(
                    "give {l} arc levels per state (one per luminaire); got {}",
                    levels_all.len()
                );
            }
            let states: Vec<Vec<ArcLevel>> = levels_all
                .chunks(l)
                .map(|c| c.iter().map(|&a| ArcLevel(a)).collect())
                .collect();
            print!("{}", luxnode::runtime::eval_report(&image, &states)?);
        }
        ImageCommand::Info { file } => {
            let bytes = read_image_file(&file)?;
            let header = luxnode::store::Header::parse(&bytes)
                .with_context(|| format!("{}: header", file.display()))?;
            println!("file:             {}", file.display());
            println!("format version:   {}", header.format_version);
            println!("generation:       {}", header.generation);
            println!(
                "payload:          {} bytes, CRC-32 {:#010x}",
                header.payload_len, header.payload_crc32
            );
            let image =
                Image::parse(&bytes).with_context(|| format!("{}: image", file.display()))?;
            let p = &image.payload;
            println!("checksums:        header and payload OK");
            println!("scene:            {}", p.scene_name);
            println!(
                "model:            {} patches, {} luminaires, {} sensors, {} form factors ({}, {}-byte columns), final gather {}",
                image.patches(),
                image.luminaires(),
                image.sensors(),
                p.ff.nnz(),
                p.ff.values.precision().name(),
                p.ff.col_width,
                if p.final_gather { "on" } else { "off" }
            );
            let st = &p.settings;
            println!(
                "settings:         {} rays/patch, {} rays/sensor, {} final-gather rays, patch {} mm, {} opening points, rectified {}, pruned below {}",
                st.rays,
                st.sensor_rays,
                st.final_gather_rays,
                st.patch_size_mm,
                st.opening_samples,
                st.rectified,
                st.prune_below
            );
            println!("sections:");
            println!("{}", sections(&image));
            let region = luxnode::layout::FORMFACTORS_LEN_BYTES as usize;
            println!(
                "FORMFACTORS:      {} of {} bytes ({:.1} %){}",
                image.len(),
                region,
                100.0 * image.len() as f64 / region as f64,
                if image.len() > region {
                    " - DOES NOT FIT"
                } else {
                    ""
                }
            );
            if image.len() > region {
                println!("{}", too_large_message(&image, region));
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The scene, its scenarios and its truth (states.csv, truth.csv in the scene directory).
fn scene_with_truth(dir: &Path) -> Result<(Scene, Vec<Scenario>, Vec<luxnode::scene::TruthRow>)> {
    let scene = load_scene(dir, &LoadOptions::default())?;
    let scenarios = read_states(&dir.join("states.csv"))?;
    let truth = read_truth(&dir.join("truth.csv"))?;
    Ok((scene, scenarios, truth))
}

fn bench(command: BenchCommand) -> Result<ExitCode> {
    use luxnode::bench;
    match command {
        BenchCommand::Engine {
            scene,
            runs,
            radiance,
            radiance_args,
        } => {
            let (sc, scenarios, truth) = scene_with_truth(&scene)?;
            let settings = Settings::default();
            let threads = rayon::current_num_threads();
            println!(
                "# luxnode engine benchmark: {} ({threads} threads)",
                sc.name
            );
            let ((total, stages), model) = bench::time_commissioning(&sc, &settings, runs)?;
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
                let mut cmd = std::process::Command::new("python3");
                cmd.arg(&script).arg("--scene").arg(&scene);
                let json = std::env::temp_dir()
                    .join(format!("luxnode-radiance-{}.json", std::process::id()));
                cmd.arg("--json").arg(&json);
                cmd.args(radiance_args.split_whitespace());
                println!("\nRadiance: {cmd:?}");
                let status = cmd
                    .status()
                    .with_context(|| format!("running {}", script.display()))?;
                if !status.success() {
                    bail!("the Radiance harness failed ({status})");
                }
                let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json)?)?;
                let _ = std::fs::remove_file(&json);
                let r_time = v["wall_time_s"]
                    .as_f64()
                    .context("wall_time_s in the Radiance result")?;
                let r_err = v["error"]
                    .as_f64()
                    .context("error in the Radiance result")?;
                let r_worst = v["worst_sensor_error"].as_f64().unwrap_or(f64::NAN);
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
                    "| Radiance | {} | {r_time:.1} | {:.2} % | {:.2} % |",
                    v["settings"].as_str().unwrap_or(radiance_args.as_str()),
                    100.0 * r_err,
                    100.0 * r_worst
                );
                println!(
                    "\nluxnode is {:.0} x faster; error ratio (Radiance / luxnode) {:.2}",
                    r_time / ours,
                    r_err / acc.error
                );
            }
        }
        BenchCommand::Tradeoffs {
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
            cli::tradeoffs::tradeoffs(&cli::tradeoffs::Args {
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
        BenchCommand::Scaling {
            scene,
            patch_sizes,
            rays,
            uniform,
            runs,
        } => cli::bench_scaling::run(scene.as_deref(), &patch_sizes, &rays, uniform, runs)?,
        BenchCommand::Patches { scene, out_dir } => {
            cli::tradeoffs::patches(&scene, out_dir.as_deref())?;
        }
        BenchCommand::Runtime { image } => {
            let bytes = read_image_file(&image)?;
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
        }
        BenchCommand::PlotTradeoffs { table, out, title } => {
            let text = std::fs::read_to_string(&table)
                .with_context(|| format!("reading {}", table.display()))?;
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
            tradeoff_plot(&rows, &title)
                .save_png(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            println!("plot: {} ({} points)", out.display(), rows.len());
        }
        BenchCommand::ModbusLoad {
            image,
            clients,
            seconds,
            interval_ms,
        } => {
            cli::modbus::bench_load(&image, clients, seconds, interval_ms)?;
        }
        BenchCommand::Fuzz { frames, seed } => {
            cli::modbus::bench_fuzz(frames, seed)?;
        }
        BenchCommand::Ablation { scene } => {
            let (sc, scenarios, truth) = scene_with_truth(&scene)?;
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
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Error against commissioning time, one series per patch size: rows of (size, seconds, error %).
fn tradeoff_plot(rows: &[(f64, f64, f64)], title: &str) -> luxnode::render::Canvas {
    let mut sizes: Vec<f64> = Vec::new();
    for r in rows {
        if !sizes.contains(&r.0) {
            sizes.push(r.0);
        }
    }
    let series = sizes
        .iter()
        .map(|size| luxnode::render::plot::Series {
            name: format!("PATCH {size} M"),
            points: rows
                .iter()
                .filter(|r| r.0 == *size)
                .map(|r| (r.1, r.2))
                .collect(),
        })
        .collect();
    luxnode::render::plot::Plot {
        title: title.to_owned(),
        x_label: "COMMISSIONING TIME (S, LOG)".into(),
        y_label: "ERROR VS RADIANCE (%)".into(),
        log_x: true,
        log_y: false,
        series,
    }
    .draw(900, 560)
}

mod commission_cmd {
    //! `luxnode commission`.
    use super::*;
    use luxnode::commission::{self, Capture, CommissionOptions, Gain};
    use luxnode::scene::{load_desks_file, load_luminaires_file, load_sensors_file};
    use luxnode::store::build::{ImageOptions, build_image, too_large_message};

    fn peak_memory_mib() -> Option<f64> {
        let s = std::fs::read_to_string("/proc/self/status").ok()?;
        let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
        let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kb / 1024.0)
    }

    pub(super) fn run(a: &CommissionArgs) -> Result<ExitCode> {
        let t0 = std::time::Instant::now();
        let load = LoadOptions::default();
        let (lums, w1) = load_luminaires_file(&a.luminaires, &load)?;
        let (sensors, w2) = load_sensors_file(&a.sensors, &load)?;
        let desks = match &a.desks {
            Some(p) => Some(load_desks_file(p, &load)?),
            None => None,
        };
        for w in w1.iter().chain(&w2) {
            eprintln!("warning: {w}");
        }
        let ids: Vec<u32> = lums.iter().map(|l| l.id).collect();
        let cap = Capture::load(&a.capture, &ids)?;
        let gain = match &a.luxmeter {
            None => Gain::Camera,
            Some(s) => {
                let (id, lux) = s
                    .split_once(':')
                    .context("--luxmeter wants SENSOR_ID:LUX")?;
                Gain::Luxmeter {
                    sensor_id: id.trim().parse().context("--luxmeter sensor id")?,
                    lux_lx: lux.trim().parse().context("--luxmeter lux")?,
                    levels: vec![1.0; lums.len()],
                }
            }
        };
        let mut o = CommissionOptions {
            gain,
            engine: a.engine.settings(),
            progress: true,
            start_rho: a.start_rho,
            estimate_reflectances: a.reflectances == OnOff::On,
            ..CommissionOptions::default()
        };
        o.closure.enabled = a.closure == OnOff::On;
        o.reflectance.method = match a.reflectance_method {
            ReflectanceMethodArg::Median => commission::ReflectanceMethod::Median,
            ReflectanceMethodArg::Sh => commission::ReflectanceMethod::SphericalHarmonics,
        };
        o.closure.wall_rho = a.wall_rho;
        o.closure.ceiling_rho = a.ceiling_rho;
        o.closure.ceiling_z_m = a.ceiling_height;
        o.closure.room_xy_m = a.room.as_ref().map(|r| [r[0], r[1], r[2], r[3]]);
        o.mesh.patch_size_m = a.mesh_patch_size;
        for (name, v) in [
            ("--wall-rho", a.wall_rho),
            ("--ceiling-rho", a.ceiling_rho),
            ("--start-rho", a.start_rho),
        ] {
            if !(0.0..1.0).contains(&v) {
                bail!("{name} {v} must be a reflectance in [0, 1)");
            }
        }
        if !(a.mesh_patch_size.is_finite() && a.mesh_patch_size >= 0.05) {
            bail!("--mesh-patch-size must be at least 0.05 m");
        }
        let c = commission::commission(&cap, lums, sensors, desks, &o)?;
        let r = &c.report;
        for w in &r.warnings {
            eprintln!("warning: {w}");
        }
        println!(
            "depth: {} frames, {} of {} pixels kept ({} dropouts, {} flying pixels or outliers)",
            r.depth.frames,
            r.depth.valid,
            r.depth.pixels,
            r.depth.dropouts,
            r.depth.flying_or_outliers
        );
        println!("planes: {}", r.planes.len());
        for (k, p) in r.planes.iter().enumerate() {
            println!(
                "  plane_{k}: normal ({:.2}, {:.2}, {:.2}), centre ({:.2}, {:.2}, {:.2}) m, {:.2} m², {} triangles, rms {:.1} mm",
                p.normal.x,
                p.normal.y,
                p.normal.z,
                p.origin_m.x,
                p.origin_m.y,
                p.origin_m.z,
                p.area_m2,
                p.triangles,
                p.rms_m * 1e3
            );
        }
        println!(
            "mesh: {} triangles, seen {:.1} m², inferred {:.1} m²; {} patches in the final model",
            r.triangles, r.seen_area_m2, r.inferred_area_m2, r.patches
        );
        if let Some(room) = &r.room {
            println!(
                "room box: x {:.2}..{:.2} m, y {:.2}..{:.2} m, floor {:.3} m, ceiling {:.3} m",
                room.xy_m[0],
                room.xy_m[2],
                room.xy_m[1],
                room.xy_m[3],
                room.floor_z_m,
                room.ceiling_z_m
            );
        }
        println!(
            "reflectances: gain {:.5} cd/m² per unit, {} pixels, floor {}, {} clamped",
            r.reflectance.gain_cd_m2_per_unit,
            r.reflectance.pixels_used,
            r.reflectance
                .floor_rho
                .map_or("-".into(), |v| format!("{v:.3}")),
            r.reflectance.clamped
        );
        let flags = c.sensor_flags.clone();
        let st = a.store.store(a.engine.preset);
        let options = ImageOptions {
            precision: st.precision,
            prune_below: st.prune_below,
            scene_name: c.scene.name.clone(),
            sensor_flags: flags.clone(),
        };
        let bytes = build_image(&c.model, &options)?;
        let image = Image::parse(&bytes)?;
        let region = luxnode::layout::FORMFACTORS_LEN_BYTES as usize;
        if bytes.len() > region {
            bail!("{}", too_large_message(&image, region));
        }
        std::fs::write(&a.out, &bytes).with_context(|| format!("writing {}", a.out.display()))?;
        println!(
            "{}: {} bytes, {} patches",
            a.out.display(),
            bytes.len(),
            image.patches()
        );
        for (s, f) in c.model.sensor_ids.iter().zip(&flags) {
            if *f != 0 {
                println!(
                    "sensor {s}:{}{}",
                    if f & luxnode::store::sensor_flags::OUT_OF_VIEW != 0 {
                        " out of view"
                    } else {
                        ""
                    },
                    if f & luxnode::store::sensor_flags::ESTIMATED != 0 {
                        " estimated"
                    } else {
                        ""
                    }
                );
            }
        }
        if let Some(p) = &a.export_mesh {
            commission::output::write_ply(&c, p)
                .with_context(|| format!("writing {}", p.display()))?;
        }
        if let Some(p) = &a.report {
            commission::output::report_png(&c, p)
                .map_err(anyhow::Error::msg)
                .with_context(|| format!("writing {}", p.display()))?;
        }
        if let (Some(t), Some(s)) = (&a.truth, &a.states) {
            let states = read_states(s)?;
            let truth = read_truth(t)?;
            let mut computed = Vec::new();
            for st in &states {
                let levels: Vec<f64> = c
                    .model
                    .luminaire_ids
                    .iter()
                    .map(|id| if st.on.contains(id) { 1.0 } else { 0.0 })
                    .collect();
                let lux = c.model.sensor_lux(&levels)?;
                for (sensor, lux) in c.model.sensor_ids.iter().zip(lux) {
                    computed.push(Computed {
                        scenario: st.id.clone(),
                        sensor: *sensor,
                        lux,
                    });
                }
            }
            println!("sensor,flags,mean_abs_error_lx,mean_truth_lx,error_pct");
            let (mut ea, mut ta, mut ei, mut ti) = (0.0, 0.0, 0.0, 0.0);
            for (k, id) in c.model.sensor_ids.iter().enumerate() {
                let (mut e, mut tt, mut n) = (0.0, 0.0, 0.0);
                for cmp in computed.iter().filter(|x| x.sensor == *id) {
                    if let Some(row) = truth
                        .iter()
                        .find(|r| r.scenario == cmp.scenario && r.sensor == *id)
                    {
                        e += (cmp.lux - row.lux).abs();
                        tt += row.lux;
                        n += 1.0;
                    }
                }
                if n > 0.0 {
                    println!(
                        "{id},{},{:.1},{:.1},{:.2}",
                        flags[k],
                        e / n,
                        tt / n,
                        100.0 * e / tt
                    );
                    ea += e;
                    ta += tt;
                    if flags[k] & luxnode::store::sensor_flags::OUT_OF_VIEW == 0 {
                        ei += e;
                        ti += tt;
                    }
                }
            }
            println!(
                "error, all sensors: {:.2} %; in view: {:.2} %",
                100.0 * ea / ta.max(1e-9),
                100.0 * ei / ti.max(1e-9)
            );
        }
        println!("stage,ms");
        for (stage, d) in &r.timings {
            println!("{stage},{:.0}", d.as_secs_f64() * 1e3);
        }
        println!(
            "total (with loading and the image),{:.0}",
            t0.elapsed().as_secs_f64() * 1e3
        );
        if let Some(m) = peak_memory_mib() {
            println!("peak memory: {m:.0} MiB");
        }
        Ok(ExitCode::SUCCESS)
    }
}
