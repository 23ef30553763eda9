//! `luxnode image build|info|eval`: the flash image.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use luxnode::dali::ArcLevel;
use luxnode::image_build::{
    ImageOptions, build_for_region, formfactors_region_bytes, sections, too_large_message,
};
use luxnode::store::file::{read_image_file, write_image_file};
use luxnode::store::{Header, Image};

use super::{EngineArgs, SceneArgs, StoreArgs, load_scene};

/// `luxnode image ...`.
// parsed once per process: the size of a variant does not matter
#[allow(clippy::large_enum_variant)]
#[derive(clap::Subcommand)]
pub enum Command {
    /// Commission a scene (CAD input) and write its flash image.
    Build {
        /// The scene directory; `demo-office` for the built-in demo office (feature `sim`).
        #[arg(long, value_name = "DIR")]
        scene: PathBuf,
        #[command(flatten)]
        load: SceneArgs,
        /// The image file to write.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        #[command(flatten)]
        engine: EngineArgs,
        #[command(flatten)]
        store: StoreArgs,
        /// Leave out the geometry section (patch corners, camera, desks, luminaires with their
        /// photometry) that `luxnode report` needs: a smaller image for the run time only.
        #[arg(long)]
        no_geometry: bool,
        /// The installation's maintenance factor, recorded for reports (EN 12464-1 maintained
        /// values).
        #[arg(long, value_name = "MF", default_value_t = luxnode::en12464::DEFAULT_MAINTENANCE_FACTOR)]
        maintenance_factor: f64,
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
        #[arg(long = "arc", value_name = "LEVEL,...", value_delimiter = ',', num_args = 1.., action = clap::ArgAction::Append, required_unless_present = "demo_states")]
        arc: Vec<String>,
        /// The firmware's demo states instead.
        #[arg(long, conflicts_with = "arc")]
        demo_states: bool,
    },
}

/// Runs `luxnode image ...`.
pub fn run(command: &Command) -> Result<()> {
    match command {
        Command::Build {
            scene,
            load,
            out,
            engine,
            store,
            no_geometry,
            maintenance_factor,
        } => build(
            scene,
            load,
            out,
            engine,
            store,
            (!*no_geometry).then_some(*maintenance_factor),
        ),
        Command::Eval {
            file,
            arc,
            demo_states,
        } => eval(file, arc, *demo_states),
        Command::Info { file } => info(file),
    }
}

fn build(
    scene: &std::path::Path,
    load: &SceneArgs,
    out: &std::path::Path,
    engine: &EngineArgs,
    store: &StoreArgs,
    geometry_mf: Option<f64>,
) -> Result<()> {
    if let Some(mf) = geometry_mf {
        luxnode::en12464::check_maintenance_factor(mf)?;
    }
    let sc = if scene.as_os_str() == "demo-office" {
        demo_office()?
    } else {
        load_scene(scene, &load.options())?
    };
    // refused before any work: what the node could not serve
    let limits = luxnode::image_build::served_limits(sc.sensors.len(), sc.luminaires.len());
    if !limits.is_empty() {
        anyhow::bail!(
            "scene {}: the node cannot serve it: {}",
            sc.name,
            limits.join("; ")
        );
    }
    let t0 = std::time::Instant::now();
    let model = luxnode::engine::compute_model(&sc, &engine.settings())?;
    let st = store.store(engine.preset);
    let options = ImageOptions {
        precision: st.precision,
        prune_below: st.prune_below,
        scene_name: sc.name.clone(),
        sensor_flags: Vec::new(),
        geometry: geometry_mf.map(|mf| {
            luxnode::image_geometry::section_of(
                &sc,
                &model,
                &luxnode::image_geometry::CommissionRecord {
                    preset: engine.preset.name().into(),
                    maintenance_factor: mf,
                    ..Default::default()
                },
            )
        }),
    };
    let region = formfactors_region_bytes();
    let bytes = build_for_region(&model, &options, region)?;
    let image = Image::parse(&bytes)?;
    write_image_file(out, &bytes)?;
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
    Ok(())
}

#[cfg(feature = "sim")]
fn demo_office() -> Result<luxnode::scene::Scene> {
    Ok(luxnode::sim::demo::demo_office())
}

#[cfg(not(feature = "sim"))]
fn demo_office() -> Result<luxnode::scene::Scene> {
    bail!("the demo office is part of the `sim` feature, which this binary was built without")
}

fn eval(file: &std::path::Path, arc: &[String], demo_states: bool) -> Result<()> {
    let bytes = read_image_file(file)?;
    let image = Image::parse(&bytes).with_context(|| format!("image {}", file.display()))?;
    let l = image.luminaires();
    let states: Vec<Vec<ArcLevel>> = if demo_states {
        (0..luxnode::runtime::DEMO_STATES)
            .map(|k| {
                (0..l)
                    .map(|j| luxnode::runtime::demo_arc_level(k, j))
                    .collect()
            })
            .collect()
    } else {
        let levels_all: Vec<u8> = arc
            .iter()
            .map(|a| {
                a.trim()
                    .parse::<u8>()
                    .with_context(|| format!("arc level {a:?} is not 0..255"))
            })
            .collect::<Result<_>>()?;
        if l == 0 || levels_all.is_empty() || !levels_all.len().is_multiple_of(l) {
            bail!(
                "give {l} arc levels per state (one per luminaire); got {}",
                levels_all.len()
            );
        }
        levels_all
            .chunks(l)
            .map(|c| c.iter().map(|&a| ArcLevel(a)).collect())
            .collect()
    };
    print!("{}", luxnode::runtime::eval_report(&image, &states)?);
    Ok(())
}

fn info(file: &std::path::Path) -> Result<()> {
    let bytes = read_image_file(file)?;
    let header = Header::parse(&bytes).with_context(|| format!("{}: header", file.display()))?;
    println!("file:             {}", file.display());
    println!("format version:   {}", header.format_version);
    println!("generation:       {}", header.generation);
    println!(
        "payload:          {} bytes, CRC-32 {:#010x}",
        header.payload_len, header.payload_crc32
    );
    let image = Image::parse(&bytes).with_context(|| format!("image {}", file.display()))?;
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
    let region = formfactors_region_bytes();
    let fits = image.len() <= region;
    println!(
        "FORMFACTORS:      {} of {} bytes ({:.1} %){}",
        image.len(),
        region,
        100.0 * image.len() as f64 / region as f64,
        if fits { "" } else { " - DOES NOT FIT" }
    );
    if !fits {
        println!("{}", too_large_message(&image, region));
    }
    print_sensors(&image);
    Ok(())
}

/// Each desk sensor with every luminaire at 100 %: the model's light and, where the camera sees
/// the desk, the camera's measured (calibrated) light, with the stated uncertainty.
fn print_sensors(image: &Image<'_>) {
    let l = image.luminaires();
    println!("sensor,out_of_view,model_all_on_lx,camera_all_on_lx,stated_uncertainty_pct");
    for k in 0..image.sensors() {
        let model: f64 = (0..l).map(|j| image.response_lx(k, j)).sum();
        let camera = image
            .live
            .as_ref()
            .filter(|v| !v.window(k).is_empty())
            .map(|v| (0..l).map(|j| v.sensor_response_lx(k, j, l)).sum::<f64>());
        let out = image.sensor_flags(k) & luxnode::store::sensor_flags::OUT_OF_VIEW != 0;
        println!(
            "{},{},{model:.1},{},{}",
            image.sensor_id(k),
            u8::from(out),
            camera.map_or(String::new(), |c| format!("{c:.1}")),
            image
                .model_rel_uncertainty(k)
                .map_or(String::new(), |u| format!("{:.1}", 100.0 * u))
        );
    }
}
