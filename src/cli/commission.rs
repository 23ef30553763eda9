//! `luxnode commission`: from a capture set (ToF depth + luminance frames, no CAD model) to the
//! flash image.

use std::path::PathBuf;

use anyhow::{Context, Result};
use luxnode::commission::refit::Reading;
use luxnode::commission::refit::parse_reading;
use luxnode::commission::{self, Capture, CommissionOptions, Gain, ReflectanceMethod};
use luxnode::evaluate::{per_sensor, pooled, readings};
use luxnode::image_build::{
    ImageOptions, SECTION_RESERVE_BYTES, build_for_region, build_to_fit, formfactors_region_bytes,
};
use luxnode::scene::{
    Desks, LoadOptions, Luminaire, Sensor, load_desks_file, load_luminaires_file,
    load_sensors_file, read_states, read_truth,
};
use luxnode::store::file::write_image_file;
use luxnode::store::{Image, sensor_flags};

use super::{EngineArgs, OnOff, StoreArgs};

/// `luxnode commission`.
#[derive(clap::Args)]
pub struct Args {
    /// The capture set directory (camera.json, depth_NNN.png, luminance_L<k>.png). Repeat it
    /// for several nodes in one room (each camera.json with its pose in the room's frame and its
    /// gain), with one --out per capture set, in the same order.
    #[arg(long, required = true, value_name = "DIR")]
    capture: Vec<PathBuf>,
    /// luminaires.json (installed positions and photometry); required without --board.
    #[arg(long, required_unless_present = "board", value_name = "FILE")]
    luminaires: Option<PathBuf>,
    /// sensors.json (the desk points to answer for); required without --board.
    #[arg(long, required_unless_present = "board", value_name = "FILE")]
    sensors: Option<PathBuf>,
    /// The luminaires, sensors and desks of this board file's room instead (its `[scene]`).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["luminaires", "sensors", "desks"])]
    board: Option<PathBuf>,
    /// desks.json, for the report's desk outlines and desk lux.
    #[arg(long, value_name = "FILE")]
    desks: Option<PathBuf>,
    /// The flash image to write (one per --capture: node k's image holds the whole room and
    /// node k's camera and desks).
    #[arg(long, required = true, value_name = "FILE")]
    out: Vec<PathBuf>,
    /// Also write the mesh as PLY (grey = reflectance).
    #[arg(long, value_name = "FILE.PLY")]
    export_mesh: Option<PathBuf>,
    /// Also draw the camera view with a false-colour lux overlay, desk outlines and desk lux.
    #[cfg(feature = "report")]
    #[arg(long, value_name = "FILE.PNG")]
    report: Option<PathBuf>,
    /// Close the room (inferred floor, walls, ceiling).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    closure: OnOff,
    /// Reflectance of the inferred walls [if absent: the seen walls' when the camera saw enough
    /// wall, else 0.5]
    #[arg(long, value_name = "RHO")]
    wall_rho: Option<f64>,
    /// Reflectance of the inferred ceiling.
    #[arg(long, value_name = "RHO", default_value_t = commission::ClosureOptions::default().ceiling_rho)]
    ceiling_rho: f64,
    /// Room box in m, one comma-separated value [if absent: inferred].
    #[arg(
        long,
        value_name = "X0,Y0,X1,Y1",
        value_parser = parse_room,
        conflicts_with = "room_plan"
    )]
    room: Option<RoomBox>,
    /// Ceiling height, m [if absent: just above the highest luminaire opening].
    #[arg(long, value_name = "M", conflicts_with = "room_plan")]
    ceiling_height: Option<f64>,
    /// The room plan (room.json, luxnode-room-plan/1): outline, heights, windows, site. The
    /// walls, windows and ceiling the cameras do not see are built from it [if absent: the
    /// board's `[room] plan`, else an inferred box].
    #[arg(long, value_name = "ROOM.JSON")]
    room_plan: Option<PathBuf>,
    /// Target patch size of the reconstructed mesh (largest rectangle side), m.
    #[arg(long, value_name = "M", default_value_t = commission::MeshOptions::default().patch_size_m)]
    mesh_patch_size: f64,
    /// Camera gain from one luxmeter reading instead of camera.json: SENSOR_ID:LUX with all
    /// luminaires on.
    #[arg(long, value_name = "ID:LUX")]
    luxmeter: Option<String>,
    /// A luxmeter reading with every luminaire at full, SENSOR_ID:LUX (repeat the flag or
    /// comma-separate for more desks):
    /// the readings set the reflectance of the walls and ceiling the camera did not see
    /// (with camera.json's gain; docs/commissioning.md).
    #[arg(
        long,
        value_name = "ID:LUX",
        value_delimiter = ',',
        conflicts_with = "luxmeter"
    )]
    luxmeter_rho: Vec<String>,
    /// Commission even when a luxmeter refit hits its reflectance limits and still misses a
    /// reading: a warning in the report, the desks flagged estimated in the image.
    #[arg(long)]
    force: bool,
    /// Estimate reflectances (off: every seen surface gets --start-rho).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    reflectances: OnOff,
    /// Reflectance of seen surfaces before (or without) estimation.
    #[arg(long, value_name = "RHO", default_value_t = 0.5)]
    start_rho: f64,
    /// How the one-luminaire-on frames combine: median of π L / E per pixel, or the paper's
    /// first-order spherical-harmonic fit per triangle (docs/commissioning.md).
    #[arg(long, value_enum, default_value_t = ReflectanceMethodArg::Median)]
    reflectance_method: ReflectanceMethodArg,
    /// Print the error against a truth.csv (with --states).
    #[arg(long, value_name = "FILE", requires = "states")]
    truth: Option<PathBuf>,
    /// states.csv for --truth.
    #[arg(long, value_name = "FILE")]
    states: Option<PathBuf>,
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
}

/// `--room`: a box in m.
#[derive(Clone, Copy)]
struct RoomBox([f64; 4]);

/// `--room X0,Y0,X1,Y1`.
fn parse_room(s: &str) -> Result<RoomBox, String> {
    let v = s
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("{v:?}: {e}")))
        .collect::<Result<Vec<f64>, String>>()?;
    match v[..] {
        [x0, y0, x1, y1] => Ok(RoomBox([x0, y0, x1, y1])),
        _ => Err(format!(
            "want X0,Y0,X1,Y1 (four numbers in m), got {}",
            v.len()
        )),
    }
}

/// `--reflectance-method`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ReflectanceMethodArg {
    /// Median over the well-lit frames of ρ = π L / E.
    Median,
    /// First-order spherical-harmonic fit (RGBD2lux §3.1).
    Sh,
}

impl Args {
    /// The commissioning options these arguments ask for, checked.
    fn options(&self, luminaires: usize) -> Result<CommissionOptions> {
        let gain = match &self.luxmeter {
            None => Gain::Camera,
            Some(s) => {
                let (id, lux) = s
                    .split_once(':')
                    .context("--luxmeter wants SENSOR_ID:LUX")?;
                Gain::Luxmeter {
                    sensor_id: id.trim().parse().context("--luxmeter sensor id")?,
                    lux_lx: lux.trim().parse().context("--luxmeter lux")?,
                    levels: vec![1.0; luminaires],
                }
            }
        };
        let luxmeter_rho = self
            .luxmeter_rho
            .iter()
            .map(|s| parse_reading(s).map_err(|e| anyhow::anyhow!("--luxmeter-rho: {e}")))
            .collect::<Result<Vec<_>>>()?;
        let mut o = CommissionOptions {
            gain,
            readings: luxmeter_rho,
            force: self.force,
            engine: self.engine.settings(),
            // spinners per stage on a terminal; in a pipe or the journal, the log lines
            progress: super::progress_on_a_terminal(),
            start_rho: self.start_rho,
            estimate_reflectances: self.reflectances == OnOff::On,
            ..CommissionOptions::default()
        };
        o.closure.enabled = self.closure == OnOff::On;
        o.reflectance.method = match self.reflectance_method {
            ReflectanceMethodArg::Median => ReflectanceMethod::Median,
            ReflectanceMethodArg::Sh => ReflectanceMethod::SphericalHarmonics,
        };
        if let Some(rho) = self.wall_rho {
            o.closure.wall_rho = rho;
            o.closure.wall_rho_from_seen = false;
        }
        o.closure.ceiling_rho = self.ceiling_rho;
        o.closure.ceiling_z_m = self.ceiling_height;
        o.closure.room_xy_m = self.room.map(|r| r.0);
        o.mesh.patch_size_m = self.mesh_patch_size;
        o.validate()?;
        Ok(o)
    }
}

/// Runs `luxnode commission`.
pub fn run(a: &Args) -> Result<()> {
    let t0 = std::time::Instant::now();
    let (lums, sensors, desks, board_readings, board_plan, board_force) = inputs(a)?;
    let mut o = a.options(lums.len())?;
    // `--force`, or the board file's `[commissioning] force = true`
    o.force |= board_force;
    if o.readings.is_empty() && a.luxmeter.is_none() {
        // the board file's [commissioning] luxmeter_rho, unless the command line gives some
        o.readings = board_readings;
    }
    o.room_plan = match &a.room_plan {
        Some(p) => {
            let (plan, warnings) = luxnode::scene::RoomPlan::load(p)?;
            for w in warnings {
                tracing::warn!("{w}");
            }
            Some(plan)
        }
        None => board_plan,
    };
    if let Some(plan) = &o.room_plan {
        let at = a
            .room_plan
            .as_deref()
            .unwrap_or(std::path::Path::new("room plan"));
        plan.check_contents(at, &lums, &sensors, desks.as_ref())?;
    }
    luxnode::en12464::check_maintenance_factor(a.maintenance_factor)?;
    let ids: Vec<u32> = lums.iter().map(|l| l.id).collect();
    if a.out.len() != a.capture.len() {
        anyhow::bail!(
            "{} capture sets and {} --out images: one image per capture set (node)",
            a.capture.len(),
            a.out.len()
        );
    }
    let caps = a
        .capture
        .iter()
        .map(|d| Capture::load(d, &ids))
        .collect::<Result<Vec<_>, _>>()?;
    let mut nodes = commission::from_captures(&caps, lums, sensors, desks, &o)?;
    // the model against the cameras at the desks they see (docs/commissioning.md)
    let calibrated = luxnode::live_section::calibrate::calibrate_desks(&mut nodes, &caps);
    luxnode::live_section::calibrate::log(&calibrated);
    let Some(c) = nodes.first() else {
        anyhow::bail!("no capture set");
    };
    let r = &c.report;
    print_report(c)?;
    print_calibration(&calibrated);
    let stated = write_images(a, &nodes, &caps, o.room_plan.as_ref())?;
    print_uncertainty(r, &stated);
    // for the error table: a sensor is in view when some node sees it
    let flags: Vec<u8> = (0..c.sensor_flags.len())
        .map(|k| {
            let seen = nodes
                .iter()
                .any(|n| n.sensor_flags[k] & sensor_flags::OUT_OF_VIEW == 0);
            if seen { 0 } else { c.sensor_flags[k] }
        })
        .collect();
    warn_out_of_view_without_plan(&flags, o.room_plan.is_some());
    if let Some(p) = &a.export_mesh {
        commission::output::write_ply(c, p).with_context(|| format!("writing {}", p.display()))?;
    }
    #[cfg(feature = "report")]
    if let Some(p) = &a.report {
        luxnode::render::camera_view::report_png(c, p)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if let (Some(t), Some(s)) = (&a.truth, &a.states) {
        print_errors(c, &flags, t, s)?;
    }
    println!("stage,ms");
    for (stage, d) in &r.timings {
        println!("{stage},{:.0}", d.as_secs_f64() * 1e3);
    }
    println!(
        "total (with loading and the image),{:.0}",
        t0.elapsed().as_secs_f64() * 1e3
    );
    if let Some(m) = luxnode::host::peak_memory_mib() {
        println!("peak memory: {m:.0} MiB");
    }
    Ok(())
}

/// Luminaires, sensors, desks, and the board file's luxmeter readings, room plan and force.
type Inputs = (
    Vec<Luminaire>,
    Vec<Sensor>,
    Option<Desks>,
    Vec<Reading>,
    Option<luxnode::scene::RoomPlan>,
    bool,
);

/// The luminaires, sensors and desks (from the board file, or the files given), and the board
/// file's luxmeter readings.
fn inputs(a: &Args) -> Result<Inputs> {
    let load = LoadOptions::default();
    let mut board_readings = Vec::new();
    let mut board_plan = None;
    let mut board_force = false;
    let (lums, sensors, desks) = match (&a.board, &a.luminaires, &a.sensors) {
        (Some(b), _, _) => {
            let board = luxnode::board::Board::load(b)?;
            let scene = luxnode::daemon::assemble::board_scene(&board)?;
            board_readings = board.luxmeter_rho.clone();
            board_plan = board.room_plan.clone();
            board_force = board.force;
            (scene.luminaires, scene.sensors, scene.desks)
        }
        (None, Some(l), Some(s)) => {
            let (lums, w1) = load_luminaires_file(l, &load)?;
            let (sensors, w2) = load_sensors_file(s, &load)?;
            for w in w1.iter().chain(&w2) {
                tracing::warn!("{w}");
            }
            let desks = match &a.desks {
                Some(p) => Some(load_desks_file(p, &load)?),
                None => None,
            };
            (lums, sensors, desks)
        }
        _ => anyhow::bail!("--luminaires and --sensors, or --board"),
    };
    Ok((
        lums,
        sensors,
        desks,
        board_readings,
        board_plan,
        board_force,
    ))
}

/// One node's pose check: the seen floor, the luminaires above it, where their light falls.
fn print_pose(n: usize, p: &commission::pose::NodePose) {
    let opt = |x: Option<f64>, scale: f64| x.map_or("n/a".into(), |v| format!("{:.2}", v * scale));
    let worst_m = p
        .offsets_m
        .iter()
        .map(|o| o.1)
        .fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.max(d))));
    println!(
        "pose, node {}: seen floor at z = {} m, luminaires {} m above it; {} luminaires in view, \
         their light at most {} m from where declared; the same luminaire dominates at {} % of \
         the seen points",
        n + 1,
        opt(p.floor_z_m, 1.0),
        opt(p.luminaires_above_floor_m, 1.0),
        p.offsets_m.len(),
        opt(worst_m, 1.0),
        opt(p.dominant_agreement, 100.0)
    );
}

/// What commissioning found: depth, planes, mesh, room box, reflectances, the luxmeter fit.
fn print_report(c: &commission::Commissioned) -> Result<()> {
    let r = &c.report;
    for w in &r.warnings {
        tracing::warn!("{w}");
    }
    println!(
        "depth: {} frames, {} of {} pixels kept ({} dropouts, {} flying pixels or outliers)",
        r.depth.frames, r.depth.valid, r.depth.pixels, r.depth.dropouts, r.depth.flying_or_outliers
    );
    for (n, p) in r.pose.iter().enumerate() {
        print_pose(n, p);
    }
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
        "mesh: {} triangles, seen {:.1} m², inferred {:.1} m² (desk tops nobody saw {:.2} m²); \
         {} patches in the final model",
        r.triangles, r.seen_area_m2, r.inferred_area_m2, r.inferred_desk_m2, r.patches
    );
    if let Some(room) = &r.room {
        if let Some(o) = &room.outline_m {
            println!(
                "room plan: {} walls, {} windows and doors",
                o.len(),
                room.openings.len()
            );
        }
        println!(
            "room box: x {:.2}..{:.2} m, y {:.2}..{:.2} m, floor {:.3} m, ceiling {:.3} m",
            room.xy_m[0],
            room.xy_m[2],
            room.xy_m[1],
            room.xy_m[3],
            room.floor_z_m,
            room.ceiling_z_m
        );
        let unseen = luxnode::image_geometry::unseen_walls_of(r);
        if !unseen.is_empty() {
            let sides: Vec<&str> = unseen.iter().map(|w| w.side.as_str()).collect();
            println!(
                "walls nobody saw nor the luminaire grid placed: {} (at the seen extent or \
                 behind the sensors; their position, {} m farther out, is in each desk's stated \
                 uncertainty; --room-plan gives them)",
                sides.join(", "),
                luxnode::commission::placement::UNSEEN_WALL_POSITION_SIGMA_M
            );
        }
    }
    println!(
        "reflectances: gain {:.5} cd/m² per unit, {} pixels, floor {}, {} clamped{}",
        r.reflectance.gain_cd_m2_per_unit,
        r.reflectance.pixels_used,
        r.reflectance
            .floor_rho
            .map_or("-".into(), |v| format!("{v:.3}")),
        r.reflectance.clamped,
        r.reflectance
            .walls_rho
            .map_or(String::new(), |(v, n)| format!(
                ", unseen walls {v:.3} (the seen walls' {n} pixels)"
            ))
    );
    if let Some(f) = &r.reflectance_fit {
        println!("{f}");
        println!("sensor,luxmeter_lx,model_before_lx,model_after_lx");
        let after = c.model.sensor_lux(&vec![1.0; c.model.luminaires()])?;
        for (id, read, before) in &f.readings {
            let now = c
                .model
                .sensor_ids
                .iter()
                .position(|s| s == id)
                .map_or("-".into(), |k| format!("{:.0}", after[k]));
            println!("{id},{read:.0},{before:.0},{now}");
        }
    }
    Ok(())
}

/// One image per node, each shrunk to fit its flash region unless the storage was chosen.
/// Returns each sensor's stated relative uncertainty as the images hold it (the largest over the
/// nodes: the model's disagreement with each node's camera widens it, issue 28 item 5).
fn write_images(
    a: &Args,
    nodes: &[commission::Commissioned],
    caps: &[Capture],
    plan: Option<&luxnode::scene::RoomPlan>,
) -> Result<Vec<f64>> {
    let st = a.store.store(a.engine.preset);
    let mut stated = vec![f64::NAN; nodes.first().map_or(0, |n| n.model.sensors())];
    for ((node, cap), out) in nodes.iter().zip(caps).zip(&a.out) {
        let flags = node.sensor_flags.clone();
        let options = ImageOptions {
            precision: st.precision,
            prune_below: st.prune_below,
            scene_name: node.scene.name.clone(),
            sensor_flags: flags.clone(),
            // what `luxnode report` draws and checks: the commissioned room as modelled
            geometry: (!a.no_geometry).then(|| {
                luxnode::image_geometry::section_of(
                    &node.scene,
                    &node.model,
                    &luxnode::image_geometry::CommissionRecord {
                        preset: a.engine.preset.name().into(),
                        maintenance_factor: a.maintenance_factor,
                        unseen_walls: luxnode::image_geometry::unseen_walls_of(&node.report),
                        ..Default::default()
                    },
                )
            }),
        };
        let region = formfactors_region_bytes();
        // room kept for the plan's daylight coefficients, after the live section
        let daylight = luxnode::daylight_section::reserve_bytes(plan, node.scene.sensors.len());
        let bytes = if a.store.explicit() {
            build_for_region(&node.model, &options, region)?
        } else {
            // the engineer chose no storage: shrink it to fit, keeping room for live light
            let reserve = SECTION_RESERVE_BYTES + daylight;
            let f = build_to_fit(&node.model, &options, region, reserve)?;
            if f.step > 0 {
                println!(
                    "{}: stored at {} with form factors below {:.0e} dropped to fit the {:.2} MiB \
                     flash region{} (--precision/--prune choose)",
                    out.display(),
                    f.options.precision.name(),
                    f.options.prune_below,
                    region as f64 / 1048576.0,
                    f.first_bytes.map_or(String::new(), |b| format!(
                        " with room for live light ({} would be {:.2} MiB)",
                        options.precision.name(),
                        b as f64 / 1048576.0
                    ))
                );
            }
            f.bytes
        };
        // live light: the section that turns run-time frames into desk lux (docs/live.md)
        let bytes = luxnode::live_section::with_capture_section(bytes, node, cap, daylight);
        // daylight through the plan's windows the camera does not see (docs/live.md)
        let bytes = luxnode::daylight_section::with_daylight_section(bytes, node, plan);
        let image = Image::parse(&bytes)?;
        for (k, u) in stated.iter_mut().enumerate() {
            if let Some(v) = image.model_rel_uncertainty(k).filter(|v| v.is_finite()) {
                *u = if u.is_finite() { u.max(v) } else { v };
            }
        }
        write_image_file(out, &bytes)?;
        println!(
            "{}: {} bytes, {} patches",
            out.display(),
            bytes.len(),
            image.patches()
        );
        for (s, f) in node.model.sensor_ids.iter().zip(&flags) {
            if *f != 0 {
                println!(
                    "sensor {s}:{}{}{}",
                    if f & sensor_flags::OUT_OF_VIEW != 0 {
                        " out of view"
                    } else {
                        ""
                    },
                    if f & sensor_flags::ESTIMATED != 0 {
                        " estimated"
                    } else {
                        ""
                    },
                    if f & sensor_flags::CALIBRATED != 0 {
                        " calibrated by the camera"
                    } else {
                        ""
                    }
                );
            }
        }
    }
    Ok(stated)
}

/// What the one-luminaire frames showed at each desk a camera sees, and what was done.
fn print_calibration(done: &[luxnode::live_section::calibrate::DeskCalibration]) {
    if done.is_empty() {
        return;
    }
    println!(
        "sensor,node,camera_scale,calibrated_luminaires,scaled,model_all_on_lx,\
         calibrated_all_on_lx,desk_rho,desk_rho_taken"
    );
    for d in done {
        let ids: Vec<String> = d
            .replaced_luminaire_ids
            .iter()
            .map(u32::to_string)
            .collect();
        // the desk top's own reflectance, and the desks' common one when it took it
        let (own, taken) = d
            .desk_rho
            .as_ref()
            .map_or((String::new(), String::new()), |r| {
                (
                    format!("{:.3}", r.local),
                    r.taken.map_or(String::new(), |t| format!("{t:.3}")),
                )
            });
        println!(
            "{},{},{:.3},{},{:.3},{:.0},{:.0},{own},{taken}",
            d.sensor_id,
            d.node,
            d.scale,
            ids.join(";"),
            d.scaled,
            d.model_all_on_lx,
            d.calibrated_all_on_lx
        );
    }
}

/// Each desk sensor's stated uncertainty and its largest source.
/// Each sensor's stated uncertainty: as the image holds it (`stated`, by sensor index; widened by
/// the camera's disagreement), else as commissioning inferred it, with its largest source.
fn print_uncertainty(r: &commission::Report, stated: &[f64]) {
    if !r.uncertainty.is_empty() {
        println!("sensor,stated_uncertainty_pct,all_on_lx,largest_source,its_share_pct");
        for (k, u) in r.uncertainty.iter().enumerate() {
            let (c, share) = u.largest_source();
            let rel = stated
                .get(k)
                .copied()
                .filter(|v| v.is_finite())
                .unwrap_or(u.rel);
            // the image stores it to 1e-4: only a widening beyond that is the camera's
            let (c, share) = if rel > u.rel + 2e-4 {
                ("model vs camera", 1.0)
            } else {
                (c, share)
            };
            println!(
                "{},{:.1},{:.0},{},{:.0}",
                u.sensor_id,
                100.0 * rel,
                u.all_on_lx,
                c,
                100.0 * share
            );
        }
    }
}

/// Each sensor's error against the truth (truth.csv `t`, states.csv `s`), all and in view.
fn print_errors(
    c: &commission::Commissioned,
    flags: &[u8],
    t: &std::path::Path,
    s: &std::path::Path,
) -> Result<()> {
    let states = read_states(s)?;
    let truth = read_truth(t)?;
    let computed = readings(&states, &c.model.luminaire_ids, &c.model.sensor_ids, |l| {
        c.model.sensor_lux(l)
    })?;
    let errors = per_sensor(&computed, &truth, &c.model.sensor_ids);
    println!("sensor,flags,mean_abs_error_lx,mean_truth_lx,error_pct");
    let flag_of = |id: u32| {
        c.model
            .sensor_ids
            .iter()
            .position(|s| *s == id)
            .and_then(|k| flags.get(k).copied())
            .unwrap_or(0)
    };
    for e in &errors {
        println!(
            "{},{},{:.1},{:.1},{:.2}",
            e.sensor,
            flag_of(e.sensor),
            e.mean_abs_lx,
            e.mean_truth_lx,
            100.0 * e.error()
        );
    }
    let all: Vec<_> = errors.iter().collect();
    let in_view: Vec<_> = errors
        .iter()
        .filter(|e| flag_of(e.sensor) & sensor_flags::OUT_OF_VIEW == 0)
        .collect();
    println!(
        "error, all sensors: {:.2} %; in view: {:.2} %",
        100.0 * pooled(&all),
        100.0 * pooled(&in_view)
    );
    Ok(())
}

/// Without a room plan, a desk no camera sees gets its daylight from the emitters' fit, which
/// places windows out of view only as well as the seen surfaces tell them apart: by day its
/// value may be published as its artificial part alone (docs/live.md). The plan removes it.
fn warn_out_of_view_without_plan(flags: &[u8], has_plan: bool) {
    let out = flags
        .iter()
        .filter(|f| *f & sensor_flags::OUT_OF_VIEW != 0)
        .count();
    if out > 0 && !has_plan {
        tracing::warn!(
            "{out} desk sensor(s) out of every camera's view and no room plan: their daylight is \
             inferred from what the cameras see and may be published as not available by day; \
             give the room's outline and windows with --room-plan (docs/formats.md)"
        );
    }
}
