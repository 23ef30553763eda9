//! Command-line pieces of the `luxnode` binary, one file per command family; the library holds
//! the logic. This file has the arguments several commands share and the logging set-up.

#[cfg(feature = "bench")]
pub mod bench;
#[cfg(feature = "bench")]
pub mod bench_bacnet;
#[cfg(feature = "bench")]
pub mod bench_radiance;
#[cfg(feature = "bench")]
pub mod bench_scaling;
pub mod commission;
pub mod control;
pub mod hw;
pub mod image;
pub mod live;
pub mod logging;
pub mod modbus;
pub mod photometry;
pub mod points;
#[cfg(feature = "report")]
pub mod report;
pub mod run;
pub mod scene;
pub mod simulate;
#[cfg(feature = "bench")]
pub mod tradeoffs;

use std::io::IsTerminal;
use std::path::Path;

use anyhow::{Result, bail};
use clap::ValueEnum;
use luxnode::engine::{DirectModel, RaySetKind, Settings};
use luxnode::preset::{Preset, StoreSettings};
use luxnode::scene::{LoadOptions, PhotometryPreference, Scene};
use luxnode::store::Precision;

/// The engine knobs (`--preset` and each knob on its own).
#[derive(clap::Args)]
pub struct EngineArgs {
    /// Preset of every engine and store knob (fast, balanced, accurate; docs/tradeoffs.md); the
    /// knobs below override it one by one. Balanced is the engine's default.
    #[arg(long, default_value = "balanced", value_parser = parse_preset)]
    pub preset: Preset,
    /// Rays per patch (Isocell rounds up: 1000 becomes 1083) [from --preset; balanced: 300].
    #[arg(long, value_name = "N")]
    rays: Option<usize>,
    /// Rays per sensor [from --preset; balanced: 10000].
    #[arg(long, value_name = "N")]
    sensor_rays: Option<usize>,
    /// Final-gather rays per sensor (exact first bounce; 0: off) [from --preset; balanced: 1000].
    #[arg(long, value_name = "N")]
    final_gather_rays: Option<usize>,
    /// Largest patch edge, m [from --preset; balanced: 1].
    #[arg(long, value_name = "M")]
    patch_size: Option<f64>,
    /// Largest projected angle a patch may subtend at a sensor that sees it (0: uniform
    /// patches) [from --preset; balanced: 0.5].
    #[arg(long, value_name = "RATIO")]
    detail: Option<f64>,
    /// Smallest patch edge the refinement goes to, m [from --preset; balanced: 0.0625].
    #[arg(long, value_name = "M")]
    min_patch: Option<f64>,
    /// Largest patch edge over its distance to a luminaire lighting it (0: off) [from --preset; balanced: 1].
    #[arg(long, value_name = "RATIO")]
    light_detail: Option<f64>,
    /// Ray set [from --preset; balanced: isocell].
    #[arg(long, value_enum)]
    ray_set: Option<RaySetArg>,
    /// Points over each luminaire opening for direct light on patches (sensors: 16 times as
    /// many) [from --preset; balanced: 8].
    #[arg(long, value_name = "N")]
    opening_samples: Option<usize>,
    /// Points per patch at which direct light is averaged [from --preset; balanced: 4].
    #[arg(long, value_name = "N")]
    patch_direct_points: Option<usize>,
    /// Direct light: exact (photometry, inverse square, shadow rays) or the paper's [from --preset; balanced: exact].
    #[arg(long, value_enum)]
    direct: Option<DirectArg>,
    /// Model the luminaires' LDC (off: Lambertian luminaires of the same flux) [from --preset; balanced: on].
    #[arg(long, value_enum)]
    ldc: Option<OnOff>,
    /// Model the sensors' LSC (off: ideal cosine sensors) [from --preset; balanced: on].
    #[arg(long, value_enum)]
    lsc: Option<OnOff>,
    /// Reciprocity and closure rectification [from --preset; balanced: on].
    #[arg(long, value_enum)]
    rectify: Option<OnOff>,
    /// Rectification stops when every row sum is this close to its closure target [from --preset; balanced: 1e-9].
    #[arg(long, value_name = "TOL")]
    rectify_tolerance: Option<f64>,
    /// Solver stop: relative residual [from --preset; balanced: 1e-10].
    #[arg(long, value_name = "TOL")]
    tolerance: Option<f64>,
    /// Seed of every pseudo-random choice [from --preset; balanced: 1].
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse()
        .map_err(|e: luxnode::preset::UnknownPreset| e.to_string())
}

/// `--format`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    /// scenario_id,sensor_id,lux
    Csv,
    /// One JSON object.
    Json,
}

/// `--ray-set`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RaySetArg {
    /// Isocell: stratified, equal-weight cells of the cosine-weighted hemisphere.
    Isocell,
    /// Monte Carlo: independent cosine-weighted directions.
    Mc,
}

/// `--direct`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DirectArg {
    /// Photometry, inverse square and shadow rays from points over each opening.
    Exact,
    /// The paper's formulation: emitting patches weighted by intensity (for comparison).
    Paper,
}

/// A switch.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

impl EngineArgs {
    /// The preset's settings with every knob given on the command line applied.
    pub fn settings(&self) -> Settings {
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

/// The store knobs.
#[derive(clap::Args)]
pub struct StoreArgs {
    /// Storage precision of the form factors and direct terms [from --preset; balanced: u16].
    #[arg(long, value_enum)]
    precision: Option<PrecisionArg>,
    /// Drop form factors below this (each row keeps its sum); 0 keeps all [from --preset; balanced: 0].
    #[arg(long, value_name = "FRACTION")]
    prune: Option<f64>,
}

impl StoreArgs {
    /// The preset's store settings with the command line's applied.
    pub fn store(&self, preset: Preset) -> StoreSettings {
        let mut s = preset.store();
        set(
            &mut s.precision,
            self.precision.map(PrecisionArg::precision),
        );
        set(&mut s.prune_below, self.prune);
        s
    }

    /// True when the command line chose the storage (then an image that does not fit is an
    /// error, not shrunk).
    pub fn explicit(&self) -> bool {
        self.precision.is_some() || self.prune.is_some()
    }
}

/// `--precision`.
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

/// How a scene directory is read.
#[derive(clap::Args)]
pub struct SceneArgs {
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
    /// The load options.
    pub fn options(&self) -> LoadOptions {
        LoadOptions {
            unit_to_m: match self.unit {
                Unit::M => 1.0,
                Unit::Mm => 0.001,
            },
            photometry: match self.prefer {
                Prefer::Ldt => PhotometryPreference::Ldt,
                Prefer::Ies => PhotometryPreference::Ies,
            },
        }
    }
}

/// Loads a scene directory; every error found, in one message.
pub fn load_scene(dir: &Path, options: &LoadOptions) -> Result<Scene> {
    if !dir.is_dir() {
        bail!("{} is not a scene directory", dir.display());
    }
    Ok(Scene::load(dir, options)?)
}

/// True when progress may be drawn: stderr is a terminal, not a pipe, a file or the journal
/// (there the plain log lines stay as they are).
pub fn progress_on_a_terminal() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("JOURNAL_STREAM").is_none()
}

/// A spinner on stderr with the time `what` has taken (and the steps done, with
/// [`print_step`]), on a terminal only; `finish_and_clear` it before the summary.
#[cfg(feature = "bench")]
pub fn step_spinner(what: &'static str) -> Option<indicatif::ProgressBar> {
    if !progress_on_a_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new_spinner();
    let style = indicatif::ProgressStyle::with_template("{spinner} {prefix}: {elapsed}{msg}")
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner());
    bar.set_style(style);
    bar.set_prefix(what);
    bar.enable_steady_tick(std::time::Duration::from_millis(100));
    Some(bar)
}

/// Prints a result line on stdout; with a spinner on the same terminal, around it (the
/// spinner hidden while the line is written, then counting one more step).
#[cfg(feature = "bench")]
pub fn print_step(bar: Option<&indicatif::ProgressBar>, line: &str) {
    match bar {
        Some(b) => {
            b.suspend(|| println!("{line}"));
            b.inc(1);
            b.set_message(format!(", {} done", b.position()));
        }
        None => println!("{line}"),
    }
}
