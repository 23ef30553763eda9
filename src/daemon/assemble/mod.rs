//! A node assembled from its board file: the board's flash, peripherals, cameras, commissioning
//! source, serving options and live light, handed to [`crate::daemon::run`]. The binary only
//! parses its arguments into [`RunOptions`] and calls [`run`] (or [`capture`]).
//!
//! A board is data: what differs between the simulated, the recorded and the hardware board is
//! in its [`CameraBoard`]; the sim board's parts (feature `sim`) are in one place, `sim`.

mod cameras;
mod flash;
#[cfg(feature = "sim")]
mod sim;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

pub use cameras::{LightSlot, Rig, live_task, rig, sensor_probe, sequence_options};
pub use flash::{Flash, FlashTarget};

use super::source::{AmbientAtCommissioning, CameraSource, ReportTarget};
use super::{
    CadSource, CommissionSource, Companion, DaemonConfig, DaemonError, Exit, ImageFile, Unavailable,
};
use crate::board::camera::CameraBoard;
use crate::board::{Board, BoardError, SceneSource};
use crate::camera::CameraError;
use crate::commission::CommissionOptions;
use crate::fieldbus::gateway::GatewayError;
use crate::fieldbus::tcp::TcpOptions;
use crate::image_build::ImageOptions;
use crate::peripherals::node::Peripherals;
use crate::scene::Scene;
use crate::serve::ServeOptions;

/// Why a node could not be assembled from its board file (or could not run).
#[derive(Debug, thiserror::Error)]
pub enum AssembleError {
    /// The board file.
    #[error(transparent)]
    Board(#[from] BoardError),
    /// What the board names cannot be used, in words naming the board and the part.
    #[error("{0}")]
    Config(String),
    /// A camera (opening, capturing, a recorded capture).
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// The DALI gateway that switches the lights at commissioning.
    #[error(transparent)]
    Gateway(#[from] GatewayError),
    /// The image file to install.
    #[error("image {}: {what}", path.display())]
    ImageFile {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        what: String,
    },
    /// The node while it ran.
    #[error(transparent)]
    Daemon(#[from] DaemonError),
}

/// The sim board's simulated controller (feature `sim`): it steps through dimming states over
/// Modbus TCP and prints the live table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimController {
    /// Time per dimming state, ms.
    pub step_ms: u64,
    /// Passes through the dimming states.
    pub cycles: usize,
    /// Keep serving after the sequence.
    pub forever: bool,
}

/// What the command line adds to a board file.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// The board file.
    pub board: PathBuf,
    /// Flash device or file instead of the board's.
    pub flash: Option<PathBuf>,
    /// Modbus TCP address instead of the board's.
    pub bind: Option<SocketAddr>,
    /// Commission again even if the flash holds a valid image.
    pub recommission: bool,
    /// Commission from the board's CAD scene instead of its cameras.
    pub cad: bool,
    /// Install this flash image (commissioned elsewhere) as the next generation, then serve it.
    pub image: Option<PathBuf>,
    /// Stop after this long.
    pub run_for: Option<Duration>,
    /// The simulated controller, on a board without a gateway (`None`: none; the dimming
    /// state comes only from Modbus writes or the gateway).
    pub controller: Option<SimController>,
    /// HIL (feature `sim`): the simulated power fails after this many bytes of the image write.
    pub power_cut_after_bytes: Option<usize>,
    /// HIL (feature `sim`): the simulated status LED's edges go to this file.
    pub led_trace: Option<PathBuf>,
}

/// What [`capture`] saved.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureSummary {
    /// The cameras it came from.
    pub what: String,
    /// Depth frames saved.
    pub depth_frames: usize,
    /// Luminance frames saved.
    pub luminance_frames: usize,
    /// How long the capture took, s.
    pub seconds: f64,
    /// Retries the capture used.
    pub retries: usize,
}

/// Reads a board file (a board whose ToF camera cannot reach its floor is refused before
/// anything starts) and the room it serves.
pub fn load_board(path: &Path) -> Result<(Board, Scene), AssembleError> {
    let board = Board::load(path)?;
    tracing::info!(
        "luxnode {} on board {}: {}",
        env!("CARGO_PKG_VERSION"),
        board.name,
        board.description
    );
    if let CameraBoard::Hardware { .. } = &board.camera {
        let pre = crate::board::hardware::preflight(&board.camera)
            .map_err(|e| AssembleError::Config(format!("board {}: {e}", board.name)))?;
        tracing::info!(
            "ToF camera: the floor is {:.2} m away{}",
            pre.floor_mm / 1000.0,
            pre.a010_unit_mm.map_or(String::new(), |u| format!(
                "; A010 quantisation AT+UNIT={u} ({:.2} m range)",
                crate::camera::a010::unit_range_mm(u) / 1000.0
            ))
        );
    }
    let scene = board_scene(&board)?;
    Ok((board, scene))
}

/// The room a board serves: its luminaires, sensors and desks (and, simulated, its geometry).
pub fn board_scene(board: &Board) -> Result<Scene, AssembleError> {
    match &board.scene {
        #[cfg(feature = "sim")]
        SceneSource::DemoOffice => Ok(crate::sim::demo::demo_office()),
        #[cfg(not(feature = "sim"))]
        SceneSource::DemoOffice => Err(AssembleError::Config(
            "the board names the built-in demo office, part of the `sim` feature, which this \
             binary was built without"
                .into(),
        )),
        SceneSource::Directory(dir) => Scene::load(dir, &Default::default())
            .map_err(|e| AssembleError::Config(format!("board {} scene: {e}", board.name))),
    }
}

/// The commissioning capture with the board's cameras and lights, saved in `dir` (the node's
/// part of commissioning several nodes of one room together).
pub fn capture(board: &Board, scene: &Scene, dir: &Path) -> Result<CaptureSummary, AssembleError> {
    let light: LightSlot = Arc::new(Mutex::new(None));
    let mut hook = None;
    let Some((what, mut depth, mut colour, mut lights)) =
        rig(board, scene, None, &light, &mut hook)?
    else {
        return Err(AssembleError::Config(format!(
            "board {}: capturing switches the luminaires one at a time through the DALI \
             gateway, and the board has no [gateway]",
            board.name
        )));
    };
    let ids: Vec<u32> = scene.luminaires.iter().map(|l| l.id).collect();
    let t0 = std::time::Instant::now();
    let seq = crate::camera::capture_sequence_with(
        depth.as_mut(),
        colour.as_mut(),
        lights.as_mut(),
        &ids,
        &sequence_options(board),
        &mut |_, _, _| {},
    )?;
    crate::camera::save_capture(dir, &seq.capture, seq.all_on.as_ref()).map_err(|e| {
        AssembleError::Config(format!("saving the capture set in {}: {e}", dir.display()))
    })?;
    Ok(CaptureSummary {
        what,
        depth_frames: seq.capture.depth_mm.len(),
        luminance_frames: seq.capture.luminance.len(),
        seconds: t0.elapsed().as_secs_f64(),
        retries: seq.retries_used,
    })
}

/// Runs the node of a board file until a signal, `run_for`, or the end of a stopping
/// controller.
pub fn run(options: &RunOptions) -> Result<Exit, AssembleError> {
    let (board, scene) = load_board(&options.board)?;
    let target = FlashTarget::of(&board, options.flash.as_deref())?;
    let (board, mut peripherals, light) = open_peripherals(board, &scene, options);
    let state = target.state_dir();
    let reference = state.join("ambient-reference.json");
    // the commissioning report next to the flash: <state dir>/commissioning-report/report.html
    let report = ReportTarget {
        dir: Some(state.join("commissioning-report")),
        preset: board.preset.name().into(),
        maintenance_factor: board.maintenance_factor,
        context_modifiers: board.context_modifiers,
    };
    let ambient = ambient_at_commissioning(&board, &peripherals, &reference)?;
    let mut source = commission_source(
        &board,
        scene,
        options.cad,
        report,
        ambient,
        &light,
        &mut peripherals.levels_hook,
    )?;
    if let Some(p) = &options.image {
        source = Box::new(image_file(p)?);
    }
    let flash = target.open(&board, options.power_cut_after_bytes)?;
    let companion = match (&board.modbus.gateway, &options.controller) {
        (None, Some(c)) => Some(controller(c)?),
        _ => None,
    };
    let config = DaemonConfig {
        board: board.name.clone(),
        flash_path: target.path().to_path_buf(),
        serve: serve_options(&board, options, Some(target.beside_image("settings.json"))),
        companion,
        recommission: options.recommission || options.image.is_some(),
        reload: Some(reload(options, target.beside_image("settings.json"))),
        sensor_probe: sensor_probe(&board),
        live: live_task(&board),
        peripherals,
        ambient_reference: Some(reference),
    };
    Ok(super::run(config, flash, source.as_mut())?)
}

/// The board's peripherals (ambient light sensor, EEPROM, LED), the simulated sensor seeing
/// the simulated room through `light` (set once the world exists); a camera module's EEPROM
/// record replaces the board file's colour calibration.
fn open_peripherals(
    board: Board,
    scene: &Scene,
    options: &RunOptions,
) -> (Board, Peripherals, LightSlot) {
    let default_als_at = match &board.camera {
        CameraBoard::Hardware { .. } => crate::board::hardware::preflight(&board.camera)
            .ok()
            .map(|p| p.tof_camera.position_m.to_array()),
        _ => scene.camera.as_ref().map(|c| c.position_m.to_array()),
    };
    let light: LightSlot = Arc::new(Mutex::new(None));
    let hooks = crate::board::peripherals::SimHooks {
        light: Some(Box::new({
            let l = light.clone();
            move || {
                l.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .as_ref()
                    .map_or(0.0, |f| f())
            }
        })),
        led_trace: options.led_trace.clone(),
        eeprom_record: None,
    };
    let mut peripherals = crate::board::peripherals::open(
        board.i2c.as_ref(),
        board.led.as_ref(),
        default_als_at,
        hooks,
    );
    let board = if let CameraBoard::Hardware { .. } = &board.camera {
        let camera = crate::board::peripherals::calibrated_cameras(
            &board.camera,
            peripherals.eeprom.as_mut(),
        );
        Board { camera, ..board }
    } else {
        board
    };
    (board, peripherals, light)
}

/// The ambient light sensor at commissioning, when the board has one with a position.
fn ambient_at_commissioning(
    board: &Board,
    peripherals: &Peripherals,
    reference: &Path,
) -> Result<Option<AmbientAtCommissioning>, AssembleError> {
    Ok(match (&peripherals.als, peripherals.als_pose) {
        (Some(sensor), Some(pose)) => Some(AmbientAtCommissioning {
            sensor: sensor.clone(),
            pose,
            response: als_response(board)?,
            reference: reference.to_path_buf(),
        }),
        (Some(_), None) => {
            tracing::warn!(
                "ambient light sensor: no position (i2c.als.position_m, or a ToF calibration): \
                 not used at commissioning"
            );
            None
        }
        _ => None,
    })
}

/// The first boot's commissioning source: the board's cameras, or the CAD scene with `cad`.
fn commission_source(
    board: &Board,
    scene: Scene,
    cad: bool,
    report: ReportTarget,
    ambient: Option<AmbientAtCommissioning>,
    light: &LightSlot,
    levels_hook: &mut Option<crate::peripherals::node::LevelsHook>,
) -> Result<Box<dyn CommissionSource>, AssembleError> {
    let preset = board.preset;
    let image = {
        let st = preset.store();
        ImageOptions {
            precision: st.precision,
            prune_below: st.prune_below,
            ..ImageOptions::default()
        }
    };
    if cad {
        return Ok(Box::new(CadSource {
            scene,
            settings: preset.engine(),
            image,
            report,
        }));
    }
    // the board's luxmeter readings, checked against the room's sensors before any capture
    let sensor_ids: Vec<u32> = scene.sensors.iter().map(|s| s.id).collect();
    crate::commission::refit::check(&board.luxmeter_rho, &sensor_ids).map_err(|e| {
        AssembleError::Config(format!(
            "board {}: commissioning.luxmeter_rho: {e}",
            board.name
        ))
    })?;
    if let Some(plan) = &board.room_plan {
        plan.check_contents(
            Path::new("room plan"),
            &scene.luminaires,
            &scene.sensors,
            scene.desks.as_ref(),
        )
        .map_err(|e| AssembleError::Config(format!("board {}: room.plan: {e}", board.name)))?;
    }
    let commission = CommissionOptions {
        engine: preset.engine(),
        progress: true,
        readings: board.luxmeter_rho.clone(),
        room_plan: board.room_plan.clone(),
        force: board.force,
        ..CommissionOptions::default()
    };
    let Some((what, depth, colour, lights)) =
        rig(board, &scene, ambient.as_ref(), light, levels_hook)?
    else {
        return Ok(Box::new(Unavailable(format!(
            "board {}: commissioning with the hardware cameras switches the luminaires \
             one at a time through the DALI gateway, and the board has no [gateway]",
            board.name
        ))));
    };
    Ok(Box::new(CameraSource {
        what,
        depth,
        colour,
        lights,
        luminaires: scene.luminaires.clone(),
        sensors: scene.sensors.clone(),
        desks: scene.desks.clone(),
        sequence: sequence_options(board),
        commission,
        image,
        report,
        ambient,
    }))
}

/// The largest image file [`image_file`] reads, bytes (a flash image region is a few MiB).
pub const MAX_IMAGE_FILE_BYTES: u64 = 64 << 20;

/// An image file to install, read within bounds and checked.
pub fn image_file(path: &Path) -> Result<ImageFile, AssembleError> {
    let bad = |what: String| AssembleError::ImageFile {
        path: path.to_path_buf(),
        what,
    };
    let len = std::fs::metadata(path)
        .map_err(|e| bad(e.to_string()))?
        .len();
    if len > MAX_IMAGE_FILE_BYTES {
        return Err(bad(format!(
            "{len} bytes, more than any flash image ({MAX_IMAGE_FILE_BYTES})"
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| bad(e.to_string()))?;
    crate::store::Image::parse(&bytes).map_err(|e| bad(format!("not a valid flash image: {e}")))?;
    Ok(ImageFile {
        path: path.to_path_buf(),
        bytes,
    })
}

/// The serving options of a board (`options.bind` overrides its address).
pub fn serve_options(
    board: &Board,
    options: &RunOptions,
    settings_path: Option<PathBuf>,
) -> ServeOptions {
    let m = &board.modbus;
    ServeOptions {
        bind: options.bind.unwrap_or(m.bind),
        tcp: TcpOptions {
            max_connections: m.max_connections,
            max_per_source: m.max_per_source,
            idle_timeout: m.idle_timeout,
            ..TcpOptions::default()
        },
        tls: m.tls.clone(),
        rtu: m.rtu.clone(),
        gateway: m.gateway.clone(),
        model_name: board.name.clone(),
        initial_arc: None,
        run_for: options.run_for,
        access: m.access.clone(),
        settings_path,
        control: board.control.clone(),
        bacnet: board.bacnet.clone(),
    }
}

/// SIGHUP: the board file again; its Modbus, gateway and access settings take effect.
fn reload(options: &RunOptions, settings_path: PathBuf) -> crate::serve::Reload {
    let options = options.clone();
    Box::new(move || {
        let b = Board::load(&options.board).map_err(|e| e.to_string())?;
        tracing::info!("reload: {} read", options.board.display());
        Ok(serve_options(&b, &options, Some(settings_path.clone())))
    })
}

/// The simulated controller (feature `sim`), and whether the node stops after it.
fn controller(c: &SimController) -> Result<(Companion, bool), AssembleError> {
    #[cfg(feature = "sim")]
    return Ok(sim::controller(c));
    #[cfg(not(feature = "sim"))]
    {
        let _ = c;
        Err(AssembleError::Config(
            "the simulated controller is part of the `sim` feature; run with --no-controller"
                .into(),
        ))
    }
}

/// The board's ambient light sensor's angular response: hooded (`[i2c.als]
/// hood_half_angle_deg`) or a bare cosine sensor.
fn als_response(board: &Board) -> Result<crate::lsc::AngularResponse, AssembleError> {
    use crate::lsc::{AngularResponse, Lsc};
    let hood = board
        .i2c
        .as_ref()
        .and_then(|i| i.als.as_ref())
        .and_then(|a| a.hood_half_angle_deg);
    Ok(match hood {
        None => AngularResponse::Cosine,
        Some(deg) => AngularResponse::Table(Lsc::hooded(deg.to_radians()).ok_or_else(|| {
            AssembleError::Config(format!(
                "board {}: i2c.als.hood_half_angle_deg {deg} is outside 1..=85",
                board.name
            ))
        })?),
    })
}
