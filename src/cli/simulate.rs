//! `luxnode simulate`: desk illuminance for lighting scenarios, from a scene (CAD) or from a
//! flash image alone.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use luxnode::evaluate::{Computed, compare, readings};
use luxnode::scene::{Scenario, check_scenarios, read_states, read_truth};
use luxnode::store::Image;
use luxnode::store::file::read_image_file;

use super::{EngineArgs, OutputFormat, SceneArgs, load_scene};

/// `luxnode simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// The scene directory (CAD input).
    #[arg(
        long,
        value_name = "DIR",
        required_unless_present = "image",
        conflicts_with = "image"
    )]
    scene: Option<PathBuf>,
    /// Answer from a flash image alone (no scene needed).
    #[arg(long, value_name = "FILE")]
    image: Option<PathBuf>,
    #[command(flatten)]
    load: SceneArgs,
    /// All luminaires on (also when no state is given).
    #[arg(long, conflicts_with_all = ["on", "states"])]
    all_on: bool,
    /// These luminaire ids on (repeat the flag or comma-separate), the others off.
    #[arg(
        long,
        value_name = "ID",
        value_delimiter = ',',
        conflicts_with = "states"
    )]
    on: Option<Vec<u32>>,
    /// A CSV of scenarios (header with scenario_id and luminaires_on, ids separated by ';').
    #[arg(long, value_name = "FILE")]
    states: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Csv)]
    format: OutputFormat,
    #[command(flatten)]
    engine: EngineArgs,
    /// Compare with this truth file [if absent: the scene's truth.csv when
    /// present].
    #[arg(long, value_name = "FILE")]
    truth: Option<PathBuf>,
    /// Write a top view of the room in false-colour lux (PNG) for one scenario.
    #[cfg(feature = "report")]
    #[arg(long, value_name = "FILE.PNG")]
    map: Option<PathBuf>,
    /// The scenario the map shows [if absent: the first].
    #[cfg(feature = "report")]
    #[arg(long, value_name = "ID", requires = "map")]
    map_scenario: Option<String>,
    /// Map cell size, m.
    #[cfg(feature = "report")]
    #[arg(long, value_name = "M", default_value_t = 0.1, requires = "map")]
    map_cell: f64,
}

/// Scenarios from the arguments, checked against the luminaire ids `ids`.
fn scenarios(a: &Args, ids: &[u32]) -> Result<Vec<Scenario>> {
    let scenarios = match (&a.states, &a.on) {
        (Some(path), _) => read_states(path)?,
        (None, Some(on)) => vec![Scenario::only(on)],
        (None, None) => vec![Scenario::all_on(ids)],
    };
    check_scenarios(&scenarios, ids)?;
    Ok(scenarios)
}

/// Runs `luxnode simulate`.
pub fn run(a: &Args) -> Result<()> {
    if let Some(path) = &a.image {
        return from_image(a, path);
    }
    let Some(scene_dir) = &a.scene else {
        bail!("give --scene DIR or --image FILE");
    };
    let scene = load_scene(scene_dir, &a.load.options())?;
    for w in &scene.warnings {
        tracing::warn!("{w}");
    }
    let ids: Vec<u32> = scene.luminaires.iter().map(|l| l.id).collect();
    let scenarios = scenarios(a, &ids)?;
    let model = luxnode::engine::compute_model(&scene, &a.engine.settings())?;
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
    let computed = readings(&scenarios, &model.luminaire_ids, &model.sensor_ids, |l| {
        model.sensor_lux(l)
    })?;
    let extra = serde_json::json!({
        "patches": st.patches,
        "rays_per_patch": st.rays_per_patch,
        "sensor_f2": model.sensor_ids.iter().zip(&model.sensor_f2)
            .map(|(id, f2)| serde_json::json!({"sensor_id": id, "f2": f2}))
            .collect::<Vec<_>>(),
    });
    print_computed(a.format, &scene.name, &scenarios, &computed, None, extra)?;
    #[cfg(feature = "report")]
    if let Some(path) = &a.map {
        draw_map(a, path, &scene, &model, &scenarios)?;
    }
    report_truth(
        a.truth
            .clone()
            .or_else(|| Some(scene_dir.join("truth.csv")).filter(|p| p.exists())),
        &computed,
    )
}

#[cfg(feature = "report")]
fn draw_map(
    a: &Args,
    path: &Path,
    scene: &luxnode::scene::Scene,
    model: &luxnode::engine::Model,
    scenarios: &[Scenario],
) -> Result<()> {
    let sc = match &a.map_scenario {
        Some(id) => scenarios
            .iter()
            .find(|s| &s.id == id)
            .with_context(|| format!("--map-scenario {id} is not among the scenarios"))?,
        None => scenarios.first().context("no scenario to map")?,
    };
    if !(a.map_cell.is_finite() && (0.01..=10.0).contains(&a.map_cell)) {
        bail!("--map-cell must be within 0.01..=10 m");
    }
    let levels = sc.levels(&model.luminaire_ids);
    let opts = luxnode::render::map::MapOptions {
        cell_m: a.map_cell,
        title: format!("{}: scenario {}, illuminance", scene.name, sc.id),
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let view = luxnode::render::map::compute(scene, model, &levels, &opts)?;
    luxnode::render::map::draw(scene, &view, &opts)
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
    Ok(())
}

/// Prints the error against a truth file to stderr.
fn report_truth(truth_path: Option<PathBuf>, computed: &[Computed]) -> Result<()> {
    let Some(path) = truth_path else {
        return Ok(());
    };
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
    Ok(())
}

fn print_computed(
    format: OutputFormat,
    name: &str,
    scenarios: &[Scenario],
    computed: &[Computed],
    uncertainty_lx: Option<&[f64]>,
    extra: serde_json::Value,
) -> Result<()> {
    // per value, its stated standard uncertainty (an image's; NaN: not stated)
    let u = |i: usize| uncertainty_lx.and_then(|u| u.get(i)).copied();
    match format {
        OutputFormat::Csv => {
            let column = if uncertainty_lx.is_some() {
                ",uncertainty_lx"
            } else {
                ""
            };
            println!("scenario_id,sensor_id,lux{column}");
            for (i, c) in computed.iter().enumerate() {
                let u = match u(i) {
                    Some(v) if v.is_finite() => format!(",{v:.3}"),
                    Some(_) => ",".into(),
                    None => String::new(),
                };
                println!("{},{},{:.3}{u}", c.scenario, c.sensor, c.lux);
            }
        }
        OutputFormat::Json => {
            let sensor = |(i, c): (usize, &Computed)| {
                let mut v = serde_json::json!({"sensor_id": c.sensor, "lux": c.lux});
                if let Some(u) = u(i) {
                    v["uncertainty_lx"] = serde_json::json!(u.is_finite().then_some(u));
                }
                v
            };
            let mut v = serde_json::json!({
                "scene": name,
                "scenarios": scenarios.iter().map(|sc| serde_json::json!({
                    "scenario_id": sc.id,
                    "luminaires_on": sc.on,
                    "sensors": computed.iter().enumerate().filter(|(_, c)| c.scenario == sc.id)
                        .map(sensor)
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

fn from_image(a: &Args, path: &Path) -> Result<()> {
    #[cfg(feature = "report")]
    if a.map.is_some() {
        bail!("--map needs the scene's geometry: use --scene");
    }
    let bytes = read_image_file(path)?;
    let image = Image::parse(&bytes).with_context(|| format!("image {}", path.display()))?;
    let runtime = luxnode::runtime::Runtime::new(&image);
    let ids: Vec<u32> = (0..image.luminaires())
        .map(|j| image.luminaire_id(j))
        .collect();
    let sensor_ids: Vec<u32> = (0..image.sensors()).map(|k| image.sensor_id(k)).collect();
    let scenarios = scenarios(a, &ids)?;
    let computed = readings(&scenarios, &ids, &sensor_ids, |levels| {
        let mut out = vec![0.0; image.sensors()];
        runtime.sensor_lux(levels, &mut out).map(|()| out)
    })?;
    // each value's stated uncertainty in its dimming state (the image's live section states it)
    let uncertainty: Option<Vec<f64>> = image.live.is_some().then(|| {
        scenarios
            .iter()
            .flat_map(|sc| {
                let levels = sc.levels(&ids);
                (0..image.sensors())
                    .map(|k| {
                        luxnode::runtime::model_rel_uncertainty_at(&image, k, &levels)
                            .unwrap_or(f64::NAN)
                    })
                    .collect::<Vec<_>>()
            })
            .zip(&computed)
            .map(|(rel, c)| rel * c.lux)
            .collect()
    });
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
        a.format,
        image.payload.scene_name,
        &scenarios,
        &computed,
        uncertainty.as_deref(),
        extra,
    )?;
    report_truth(a.truth.clone(), &computed)
}
