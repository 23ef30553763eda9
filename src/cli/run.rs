//! `luxnode run --board FILE`: the node.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use luxnode::board::camera::{CameraBoard, FlashBoard};
use luxnode::board::{Board, SceneSource};
use luxnode::camera::replay::ReplayWorld;
use luxnode::camera::{DepthCamera, LightControl, LuminanceCamera, SequenceOptions};
use luxnode::commission::CommissionOptions;
use luxnode::daemon::source::{AmbientAtCommissioning, CameraSource};
use luxnode::daemon::{
    self, CadSource, CommissionSource, Companion, DaemonConfig, Exit, SensorProbe, Unavailable,
};
use luxnode::fieldbus::gateway::GatewayWriter;
use luxnode::fieldbus::tcp::TcpOptions;
use luxnode::image_build::ImageOptions;
use luxnode::scene::Scene;
use luxnode::serve::ServeOptions;
use luxnode::store::devices::{DeviceError, FileFlash};
use luxnode::store::slots::FlashDevice;

/// `luxnode run`.
#[derive(clap::Args)]
pub struct Args {
    /// The board file, e.g. boards/sim/board.toml.
    #[arg(long)]
    pub board: PathBuf,
    /// Flash device or file instead of the board's.
    #[arg(long)]
    pub flash: Option<PathBuf>,
    /// Modbus TCP address instead of the board's (port 0: any free port, printed).
    #[arg(long)]
    pub bind: Option<SocketAddr>,
    /// Commission again even if the flash holds a valid image.
    #[arg(long)]
    pub recommission: bool,
    /// Keep serving after the simulated controller's sequence (sim board).
    #[arg(long)]
    pub forever: bool,
    /// No simulated controller: the dimming state comes only from Modbus writes or the gateway
    /// (the HIL rig drives the node itself). Implies serving until a signal.
    #[arg(long)]
    pub no_controller: bool,
    /// Passes of the simulated controller through its dimming states.
    #[arg(long, default_value_t = 1)]
    pub cycles: usize,
    /// Time per dimming state of the simulated controller, ms.
    #[arg(long, default_value_t = 400)]
    pub step_ms: u64,
    /// Stop after this many seconds.
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Commission from the board's CAD scene instead of its cameras.
    #[arg(long)]
    pub cad: bool,
    /// Capture the room with the board's cameras (the commissioning sequence), save the capture
    /// set in this directory and exit, without commissioning: the node's part of commissioning
    /// several nodes of one room together (`luxnode commission --capture A --capture B ...`).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["cad", "image"])]
    pub capture_to: Option<PathBuf>,
    /// Install this flash image (commissioned elsewhere: the room's nodes together) as the next
    /// generation, then serve it.
    #[arg(long, value_name = "IMAGE", conflicts_with = "cad")]
    pub image: Option<PathBuf>,
    /// Test only (HIL): the simulated power fails after this many bytes of the image write.
    #[cfg(feature = "sim")]
    #[arg(long, hide = true)]
    pub power_cut_after_bytes: Option<usize>,
    /// Test only (HIL): the simulated status LED's edges go to this file (`ms level` lines).
    #[cfg(feature = "sim")]
    #[arg(long, hide = true)]
    pub led_trace: Option<PathBuf>,
}

/// What the simulated ALS sees, set once the simulated world exists.
type LightSlot = Arc<Mutex<Option<Box<dyn Fn() -> f64 + Send>>>>;

/// Where the image's flash is: a file of a given size, or a raw MTD partition (its size is the
/// partition's).
enum FlashTarget {
    File(PathBuf, usize),
    Mtd(PathBuf),
}

impl FlashTarget {
    fn path(&self) -> &std::path::Path {
        match self {
            FlashTarget::File(p, _) | FlashTarget::Mtd(p) => p,
        }
    }
}

/// The flash device, from the board or `--flash`.
fn flash_config(board: &Board, args: &Args) -> Result<FlashTarget> {
    let region = usize::try_from(luxnode::layout::FORMFACTORS_LEN_BYTES)?;
    let (path, capacity) = match (&args.flash, &board.flash) {
        (Some(p), _) => (p.clone(), 2 * region),
        (None, FlashBoard::File { path, size_bytes }) => (path.clone(), *size_bytes),
        (None, FlashBoard::Mtd { device }) => return Ok(FlashTarget::Mtd(PathBuf::from(device))),
    };
    if capacity < 2 * region {
        bail!(
            "board {}: flash of {capacity} bytes is smaller than two {region}-byte image slots",
            board.name
        );
    }
    Ok(FlashTarget::File(path, capacity))
}

/// The flash device, with the simulated power cut of `--power-cut-after-bytes` (HIL) if asked.
fn open_flash(target: &FlashTarget, board: &Board, args: &Args) -> Result<Flash> {
    let (path, capacity) = match target {
        FlashTarget::File(p, c) => (p, *c),
        FlashTarget::Mtd(p) => return open_mtd(p, board),
    };
    let dev = daemon::open_flash_file(path, capacity)?;
    #[cfg(feature = "sim")]
    if let Some(n) = args.power_cut_after_bytes {
        use luxnode::store::devices::{Faults, FaultyFlash};
        let faults = Faults {
            cut_after_bytes: Some(n),
            ..Faults::default()
        };
        return Ok(Flash::Faulty(FaultyFlash::new(dev, faults)));
    }
    let _ = args;
    Ok(Flash::File(dev))
}

/// A raw MTD partition (`/dev/mtdN`, SPI NOR) for the A/B slots.
#[cfg(target_os = "linux")]
fn open_mtd(path: &std::path::Path, board: &Board) -> Result<Flash> {
    let region = usize::try_from(luxnode::layout::FORMFACTORS_LEN_BYTES)?;
    let dev = luxnode::store::mtd::open(path)
        .with_context(|| format!("board {}: flash kind \"mtd\"", board.name))?;
    let info = dev.info();
    if dev.capacity() < 2 * region {
        bail!(
            "board {}: MTD partition {} holds {} bytes ({} KiB erase blocks): smaller than two \
             {region}-byte image slots",
            board.name,
            path.display(),
            info.size,
            info.erase_size / 1024
        );
    }
    tracing::info!(
        "flash: MTD partition {}: {} bytes, {} KiB erase blocks",
        path.display(),
        info.size,
        info.erase_size / 1024
    );
    Ok(Flash::Mtd(dev))
}

#[cfg(not(target_os = "linux"))]
fn open_mtd(path: &std::path::Path, board: &Board) -> Result<Flash> {
    bail!(
        "board {}: flash kind \"mtd\" ({}) needs Linux",
        board.name,
        path.display()
    )
}

/// The node's flash: the file, an MTD partition, or (HIL) the file behind a fault injector.
enum Flash {
    File(FileFlash),
    #[cfg(target_os = "linux")]
    Mtd(luxnode::store::mtd::MtdFlash<luxnode::store::mtd::MtdDevice>),
    #[cfg(feature = "sim")]
    Faulty(luxnode::store::devices::FaultyFlash<FileFlash>),
}

macro_rules! each_flash {
    ($self:expr, $d:ident => $e:expr) => {
        match $self {
            Flash::File($d) => $e,
            #[cfg(target_os = "linux")]
            Flash::Mtd($d) => $e,
            #[cfg(feature = "sim")]
            Flash::Faulty($d) => $e,
        }
    };
}

impl FlashDevice for Flash {
    type Error = DeviceError;
    fn capacity(&self) -> usize {
        each_flash!(self, d => d.capacity())
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        each_flash!(self, d => d.read(offset, buf))
    }
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        each_flash!(self, d => d.erase(offset, len))
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        each_flash!(self, d => d.write(offset, data))
    }
    fn sync(&mut self) -> Result<(), DeviceError> {
        each_flash!(self, d => d.sync())
    }
}

/// What a commissioning capture needs: a name, the two cameras, the lights.
pub(crate) type Rig = (
    String,
    Box<dyn DepthCamera>,
    Box<dyn LuminanceCamera>,
    Box<dyn LightControl>,
);

/// The first boot's commissioning source: the board's cameras, or the CAD scene with `--cad`.
// the node's whole setup passes through here once
#[allow(clippy::too_many_arguments)]
fn commission_source(
    board: &Board,
    scene: Scene,
    image: ImageOptions,
    cad: bool,
    report: luxnode::daemon::source::ReportTarget,
    ambient: Option<AmbientAtCommissioning>,
    light: &LightSlot,
    levels_hook: &mut Option<luxnode::peripherals::node::LevelsHook>,
) -> Result<Box<dyn CommissionSource>> {
    let preset = board.preset;
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
    luxnode::commission::refit::check(&board.luxmeter_rho, &sensor_ids)
        .map_err(|e| anyhow::anyhow!("board {}: commissioning.luxmeter_rho: {e}", board.name))?;
    let commission = CommissionOptions {
        engine: preset.engine(),
        progress: true,
        readings: board.luxmeter_rho.clone(),
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

/// The room a board serves: its luminaires, sensors and desks (and, simulated, its geometry).
pub(crate) fn board_scene(board: &Board) -> Result<Scene> {
    Ok(match &board.scene {
        SceneSource::DemoOffice => demo_office()?,
        SceneSource::Directory(dir) => luxnode::scene::Scene::load(dir, &Default::default())
            .with_context(|| format!("board {} scene", board.name))?,
    })
}

/// The capture sequence's settings for a board's cameras.
fn sequence_options(board: &Board) -> SequenceOptions {
    match &board.camera {
        // lamp run-up / DALI fade, and auto exposure catching up, on real hardware
        CameraBoard::Hardware { .. } => SequenceOptions {
            registration: board.camera.registration().cloned(),
            settle: Duration::from_millis(500),
            discard_after_switch: 2,
            ..SequenceOptions::default()
        },
        _ => SequenceOptions::default(),
    }
}

/// `--capture-to`: the commissioning capture with the board's cameras and lights, saved.
fn capture_to(board: &Board, scene: &Scene, dir: &std::path::Path) -> Result<ExitCode> {
    let light: LightSlot = Arc::new(Mutex::new(None));
    let mut hook = None;
    let Some((what, mut depth, mut colour, mut lights)) =
        rig(board, scene, None, &light, &mut hook)?
    else {
        bail!(
            "board {}: capturing switches the luminaires one at a time through the DALI \
             gateway, and the board has no [gateway]",
            board.name
        );
    };
    let ids: Vec<u32> = scene.luminaires.iter().map(|l| l.id).collect();
    let t0 = std::time::Instant::now();
    let seq = luxnode::camera::capture_sequence_with(
        depth.as_mut(),
        colour.as_mut(),
        lights.as_mut(),
        &ids,
        &sequence_options(board),
        &mut |_, _, _| {},
    )?;
    luxnode::camera::save_capture(dir, &seq.capture, seq.all_on.as_ref())
        .with_context(|| format!("saving the capture set in {}", dir.display()))?;
    println!(
        "{}: {} depth frames and {} luminance frames from {what} in {:.2} s, {} retries",
        dir.display(),
        seq.capture.depth_mm.len(),
        seq.capture.luminance.len(),
        t0.elapsed().as_secs_f64(),
        seq.retries_used
    );
    Ok(ExitCode::SUCCESS)
}

/// The largest image file `--image` reads, bytes (a flash image region is a few MiB).
const MAX_IMAGE_FILE_BYTES: u64 = 64 << 20;

/// `--image`: the image file, read within bounds and checked.
fn image_file(path: &std::path::Path) -> Result<luxnode::daemon::ImageFile> {
    let len = std::fs::metadata(path)
        .with_context(|| format!("--image {}", path.display()))?
        .len();
    if len > MAX_IMAGE_FILE_BYTES {
        bail!(
            "--image {}: {len} bytes, more than any flash image ({MAX_IMAGE_FILE_BYTES})",
            path.display()
        );
    }
    let bytes = std::fs::read(path).with_context(|| format!("--image {}", path.display()))?;
    luxnode::store::Image::parse(&bytes)
        .map_err(|e| anyhow::anyhow!("--image {}: not a valid flash image: {e}", path.display()))?;
    Ok(luxnode::daemon::ImageFile {
        path: path.to_path_buf(),
        bytes,
    })
}

/// The board's cameras and lights over `scene` (the simulated world with the board's optics, a
/// recorded capture, or the hardware), `None` for hardware cameras without a DALI gateway to
/// switch the luminaires.
/// With an ambient light sensor on a simulated board, `light` and `levels_hook` are set so the
/// simulated sensor reads what the world sends up to it.
#[cfg_attr(not(feature = "sim"), allow(unused_variables))]
pub(crate) fn rig(
    board: &Board,
    scene: &Scene,
    ambient: Option<&AmbientAtCommissioning>,
    light: &LightSlot,
    levels_hook: &mut Option<luxnode::peripherals::node::LevelsHook>,
) -> Result<Option<Rig>> {
    let rig: Rig = match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim {
            depth,
            luminance,
            faults,
            optics,
            ..
        } => {
            use luxnode::camera::FaultInjector;
            use luxnode::sim::camera::{SimWorld, world_settings};
            // the simulated room is the scene; the node sees it only through the cameras
            // (with the board's optics, when it gives them)
            let world = SimWorld::new(
                with_optics(scene.clone(), optics.as_ref()),
                &world_settings(),
            )
            .with_context(|| format!("board {}: simulated cameras", board.name))?;
            if let Some(a) = &ambient {
                // the simulated ALS reads what the world sends up to it at the current levels,
                // with the running scenario's ageing and daylight
                let (p, n) = a.pose;
                let (p, n) = (glam::DVec3::from_array(p), glam::DVec3::from_array(n));
                let per = world.receiver_lx(p, n, &a.response, 20_000);
                let day = world.receiver_daylight_lx(p, n, &a.response, 20_000);
                let w = world.clone();
                *light.lock().unwrap_or_else(|p| p.into_inner()) = Some(Box::new(move || {
                    let x = w.extras();
                    let art: f64 = w
                        .levels()
                        .iter()
                        .zip(&per)
                        .enumerate()
                        .map(|(l, (level, e))| level * x.ageing.get(l).copied().unwrap_or(1.0) * e)
                        .sum();
                    art + x.window_exitance_lm_m2 * day
                }));
                let w = world.clone();
                *levels_hook = Some(Box::new(move |l: &[f64]| w.follow_levels(l)));
            }
            let d = world.depth_camera(depth.clone())?;
            let c = world.luminance_camera(luminance.clone())?;
            let (d, c): (Box<dyn DepthCamera>, Box<dyn LuminanceCamera>) = match faults {
                Some(f) => (
                    Box::new(FaultInjector::new(d, f.clone(), "simulated ToF camera")?),
                    Box::new(FaultInjector::new(c, f.clone(), "simulated colour camera")?),
                ),
                None => (Box::new(d), Box::new(c)),
            };
            (
                format!("simulated ToF + colour cameras over {}", scene.name),
                d,
                c,
                Box::new(world),
            )
        }
        CameraBoard::Replay { dir } => {
            let ids: Vec<u32> = scene.luminaires.iter().map(|l| l.id).collect();
            let world = ReplayWorld::open(dir, &ids)?;
            (
                format!("recorded capture {}", dir.display()),
                Box::new(world.depth_camera()),
                Box::new(world.luminance_camera()),
                Box::new(world),
            )
        }
        CameraBoard::Hardware { .. } => {
            let Some(gateway) = &board.modbus.gateway else {
                return Ok(None);
            };
            let (d, c) = luxnode::board::hardware::open(&board.camera)?;
            let lights = GatewayWriter::connect(gateway)?;
            (
                format!("A010 ToF + V4L2 colour cameras of board {}", board.name),
                d,
                c,
                Box::new(lights),
            )
        }
    };
    Ok(Some(rig))
}

/// Runs the node.
pub fn run(args: &Args) -> Result<ExitCode> {
    let board = Board::load(&args.board)?;
    tracing::info!(
        "luxnode {} on board {}: {}",
        env!("CARGO_PKG_VERSION"),
        board.name,
        board.description
    );
    // a board whose ToF camera cannot reach its floor is refused before anything starts
    if let CameraBoard::Hardware { .. } = &board.camera {
        let pre = luxnode::board::hardware::preflight(&board.camera)
            .with_context(|| format!("board {}", board.name))?;
        tracing::info!(
            "ToF camera: the floor is {:.2} m away{}",
            pre.floor_mm / 1000.0,
            pre.a010_unit_mm.map_or(String::new(), |u| format!(
                "; A010 quantisation AT+UNIT={u} ({:.2} m range)",
                luxnode::camera::a010::unit_range_mm(u) / 1000.0
            ))
        );
    }
    let scene = board_scene(&board)?;
    if let Some(dir) = &args.capture_to {
        return capture_to(&board, &scene, dir);
    }
    let image = {
        let st = board.preset.store();
        ImageOptions {
            precision: st.precision,
            prune_below: st.prune_below,
            ..ImageOptions::default()
        }
    };
    let flash_target = flash_config(&board, args)?;
    let flash_path = flash_target.path().to_path_buf();
    let default_als_at = match &board.camera {
        CameraBoard::Hardware { .. } => luxnode::board::hardware::preflight(&board.camera)
            .ok()
            .map(|p| p.tof_camera.position_m.to_array()),
        _ => scene.camera.as_ref().map(|c| c.position_m.to_array()),
    };
    let light: LightSlot = Arc::new(Mutex::new(None));
    let hooks = luxnode::board::peripherals::SimHooks {
        light: Some(Box::new({
            let l = light.clone();
            move || {
                l.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .as_ref()
                    .map_or(0.0, |f| f())
            }
        })),
        led_trace: led_trace(args),
        eeprom_record: None,
    };
    let mut peripherals = luxnode::board::peripherals::open(
        board.i2c.as_ref(),
        board.led.as_ref(),
        default_als_at,
        hooks,
    );
    // a camera module's EEPROM record replaces the board file's colour calibration
    let board = if let CameraBoard::Hardware { .. } = &board.camera {
        let camera = luxnode::board::peripherals::calibrated_cameras(
            &board.camera,
            peripherals.eeprom.as_mut(),
        );
        Board { camera, ..board }
    } else {
        board
    };
    let state = state_dir(&board, &flash_target);
    let reference = state.join("ambient-reference.json");
    // the commissioning report next to the flash: <state dir>/commissioning-report/report.html
    let report = luxnode::daemon::source::ReportTarget {
        dir: Some(state.join("commissioning-report")),
        preset: board.preset.name().into(),
        maintenance_factor: board.maintenance_factor,
    };
    let ambient = match (&peripherals.als, peripherals.als_pose) {
        (Some(sensor), Some(pose)) => Some(AmbientAtCommissioning {
            sensor: sensor.clone(),
            pose,
            response: als_response(&board)?,
            reference: reference.clone(),
        }),
        (Some(_), None) => {
            tracing::warn!(
                "ambient light sensor: no position (i2c.als.position_m, or a ToF calibration): \
                 not used at commissioning"
            );
            None
        }
        _ => None,
    };
    let mut source = commission_source(
        &board,
        scene,
        image,
        args.cad,
        report,
        ambient,
        &light,
        &mut peripherals.levels_hook,
    )?;
    if let Some(p) = &args.image {
        source = Box::new(image_file(p)?);
    }
    let seconds = args
        .seconds
        .map(|s| {
            if s.is_finite() && s > 0.0 && s < 1e9 {
                Ok(Duration::from_secs_f64(s))
            } else {
                Err(anyhow::anyhow!(
                    "--seconds {s}: must be a positive number of seconds"
                ))
            }
        })
        .transpose()?;
    let m = &board.modbus;
    let flash = open_flash(&flash_target, &board, args)?;
    let companion = if m.gateway.is_none() && !args.no_controller {
        Some(controller(args)?)
    } else {
        None
    };
    let settings_path = beside_image(&flash_target, "settings.json");
    let serve = serve_options(&board, args.bind, seconds, Some(settings_path.clone()));
    // SIGHUP: the board file again; its Modbus, gateway and access settings take effect
    let board_path = args.board.clone();
    let bind_arg = args.bind;
    let reload: luxnode::serve::Reload = Box::new(move || {
        let b = Board::load(&board_path).map_err(|e| e.to_string())?;
        tracing::info!("reload: {} read", board_path.display());
        Ok(serve_options(
            &b,
            bind_arg,
            seconds,
            Some(settings_path.clone()),
        ))
    });
    let config = DaemonConfig {
        board: board.name.clone(),
        flash_path,
        serve,
        companion,
        recommission: args.recommission || args.image.is_some(),
        reload: Some(reload),
        sensor_probe: sensor_probe(&board),
        live: live_task(&board),
        peripherals,
        ambient_reference: Some(reference),
    };
    match daemon::run(config, flash, source.as_mut())? {
        Exit::Stopped => Ok(ExitCode::SUCCESS),
        Exit::PowerCut => Ok(ExitCode::from(3)),
    }
}

#[cfg(feature = "sim")]
fn led_trace(args: &Args) -> Option<PathBuf> {
    args.led_trace.clone()
}

#[cfg(not(feature = "sim"))]
fn led_trace(_args: &Args) -> Option<PathBuf> {
    None
}

/// Where the node keeps files beside its image (the commissioning report, the ambient light
/// check's reference, the persisted settings): the flash file's directory, or for a raw MTD
/// partition `/var/lib/luxnode`.
fn state_dir(board: &Board, target: &FlashTarget) -> PathBuf {
    let _ = board;
    match target {
        FlashTarget::File(p, _) => p
            .parent()
            .map(|d| d.to_path_buf())
            .unwrap_or_else(|| PathBuf::from(".")),
        FlashTarget::Mtd(_) => PathBuf::from("/var/lib/luxnode"),
    }
}

/// A file beside the image: `<flash file>.<ext>` (`flash.settings.json`), or for a raw MTD
/// partition `/var/lib/luxnode/mtdN.<ext>`.
fn beside_image(target: &FlashTarget, ext: &str) -> PathBuf {
    match target {
        FlashTarget::File(p, _) => p.with_extension(ext),
        FlashTarget::Mtd(p) => {
            let name = p.file_name().map_or_else(
                || std::ffi::OsString::from("flash"),
                std::ffi::OsStr::to_os_string,
            );
            PathBuf::from("/var/lib/luxnode")
                .join(name)
                .with_extension(ext)
        }
    }
}

fn bind(arg: Option<SocketAddr>, board: SocketAddr) -> SocketAddr {
    arg.unwrap_or(board)
}

/// The serving options of a board (`--bind` overrides its address).
fn serve_options(
    board: &Board,
    bind_arg: Option<SocketAddr>,
    seconds: Option<Duration>,
    settings_path: Option<PathBuf>,
) -> ServeOptions {
    let m = &board.modbus;
    ServeOptions {
        bind: bind(bind_arg, m.bind),
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
        run_for: seconds,
        access: m.access.clone(),
        settings_path,
        control: board.control.clone(),
    }
}

/// Live light's cameras at run time (`[live]`): the simulated cameras over the board's scene
/// (their room follows the node's dimming state), a recorded capture replayed at the node's
/// levels, or the hardware cameras (opened again at each failure).
fn live_task(board: &Board) -> Option<luxnode::daemon::live::LiveTask> {
    use luxnode::daemon::live::{LiveTask, OpenedCameras, camera_source};
    if !board.live.enabled {
        tracing::info!("live: off (board [live] enabled = false)");
        return None;
    }
    let capture = match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim {
            depth,
            luminance,
            optics,
            scenario,
            ..
        } => {
            use luxnode::sim::camera::{SimWorld, world_settings};
            let (scene_source, depth, luminance, optics, scenario) = (
                board.scene.clone(),
                depth.clone(),
                luminance.clone(),
                optics.clone(),
                scenario.clone(),
            );
            // one world for the node's life: cameras opened again after a failure see the same
            // room, and a scenario runs on from where it was
            let mut world: Option<SimWorld> = None;
            camera_source(
                move || -> Result<OpenedCameras, String> {
                    if world.is_none() {
                        // the same camera as at commissioning: the board's optics
                        let scene = match &scene_source {
                            SceneSource::DemoOffice => luxnode::sim::demo::demo_office(),
                            SceneSource::Directory(dir) => {
                                luxnode::scene::Scene::load(dir, &Default::default())
                                    .map_err(|e| e.to_string())?
                            }
                        };
                        let scene = with_optics(scene, optics.as_ref());
                        let w =
                            SimWorld::new(scene, &world_settings()).map_err(|e| e.to_string())?;
                        if let Some(s) = &scenario {
                            tracing::info!(
                                "live: the simulated room runs the board's scenario from now on"
                            );
                            w.start_scenario(s.clone());
                        }
                        world = Some(w);
                    }
                    let Some(world) = world.clone() else {
                        return Err("no simulated world".into());
                    };
                    let d = world
                        .depth_camera(depth.clone())
                        .map_err(|e| e.to_string())?;
                    let c = world
                        .luminance_camera(luminance.clone())
                        .map_err(|e| e.to_string())?;
                    Ok((Box::new(d), Box::new(c), Some(Box::new(world))))
                },
                None,
            )
        }
        CameraBoard::Replay { dir } => {
            let (dir, scene_source) = (dir.clone(), board.scene.clone());
            camera_source(
                move || -> Result<OpenedCameras, String> {
                    let ids: Vec<u32> = match &scene_source {
                        SceneSource::Directory(d) => {
                            luxnode::scene::Scene::load(d, &Default::default())
                                .map_err(|e| e.to_string())?
                                .luminaires
                                .iter()
                                .map(|l| l.id)
                                .collect()
                        }
                        SceneSource::DemoOffice => {
                            return Err("a recorded capture needs the scene's directory".into());
                        }
                    };
                    let world = ReplayWorld::open(&dir, &ids).map_err(|e| e.to_string())?;
                    Ok((
                        Box::new(world.depth_camera()),
                        Box::new(world.luminance_camera()),
                        Some(Box::new(world)),
                    ))
                },
                None,
            )
        }
        CameraBoard::Hardware { .. } => {
            // the colour frames resampled onto the ToF grid through each frame's depth, with the
            // calibration commissioning used (the board's, or the camera module's EEPROM record)
            let camera = board.camera.clone();
            let registration = board.camera.registration().cloned();
            camera_source(
                move || -> Result<OpenedCameras, String> {
                    let (d, c) =
                        luxnode::board::hardware::open(&camera).map_err(|e| e.to_string())?;
                    Ok((d, c, None))
                },
                registration,
            )
        }
    };
    Some(LiveTask {
        period: board.live.period,
        settings: luxnode::live::LiveSettings::default(),
        capture,
    })
}

/// The sensors' health check while serving: simulated cameras take a frame (through their
/// fault injector, so an injected disconnect shows); hardware cameras must still be there
/// (their device nodes open); a recorded capture has nothing to check.
fn sensor_probe(board: &Board) -> Option<SensorProbe> {
    let every = board.sensor_check;
    match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim {
            depth,
            faults,
            optics,
            ..
        } => {
            use luxnode::camera::FaultInjector;
            use luxnode::sim::camera::{SimWorld, world_settings};
            let (scene_source, depth, faults, optics) = (
                board.scene.clone(),
                depth.clone(),
                faults.clone(),
                optics.clone(),
            );
            // the simulated camera is built at the first check (on the probe's thread), not
            // before the node serves
            let mut cam: Option<Box<dyn DepthCamera>> = None;
            Some(SensorProbe {
                every,
                probe: Box::new(move || {
                    if cam.is_none() {
                        let scene = match &scene_source {
                            SceneSource::DemoOffice => luxnode::sim::demo::demo_office(),
                            SceneSource::Directory(dir) => {
                                luxnode::scene::Scene::load(dir, &Default::default())
                                    .map_err(|e| e.to_string())?
                            }
                        };
                        let world =
                            SimWorld::new(with_optics(scene, optics.as_ref()), &world_settings())
                                .map_err(|e| e.to_string())?;
                        let c = world
                            .depth_camera(depth.clone())
                            .map_err(|e| e.to_string())?;
                        cam = Some(match &faults {
                            Some(f) => Box::new(
                                FaultInjector::new(c, f.clone(), "simulated ToF camera")
                                    .map_err(|e| e.to_string())?,
                            ),
                            None => Box::new(c),
                        });
                    }
                    let Some(c) = cam.as_mut() else {
                        return Err("no camera".into());
                    };
                    c.capture_depth()
                        .map(|_| ())
                        .map_err(|e| format!("ToF camera: {e}"))
                }),
            })
        }
        CameraBoard::Replay { .. } => None,
        CameraBoard::Hardware { tof, colour } => {
            let tof = match tof {
                luxnode::board::camera::TofBoard::A010 { device, .. }
                | luxnode::board::camera::TofBoard::V4l2 { device, .. } => device,
            };
            let luxnode::board::camera::ColourBoard::V4l2 { device: video, .. } = colour;
            let devices = [tof.clone(), video.clone()];
            Some(SensorProbe {
                every,
                probe: Box::new(move || {
                    for d in &devices {
                        std::fs::OpenOptions::new()
                            .read(true)
                            .open(d)
                            .map_err(|e| format!("{d}: {e}"))?;
                    }
                    Ok(())
                }),
            })
        }
    }
}

#[cfg(feature = "sim")]
fn demo_office() -> Result<Scene> {
    Ok(luxnode::sim::demo::demo_office())
}

#[cfg(not(feature = "sim"))]
fn demo_office() -> Result<Scene> {
    bail!(
        "the board names the built-in demo office, part of the `sim` feature, which this binary \
         was built without"
    )
}

/// The sim board's simulated controller: steps through dimming states over Modbus TCP and
/// prints the live table on stdout; the node stops after it unless `--forever`.
#[cfg(feature = "sim")]
fn controller(args: &Args) -> Result<(Companion, bool)> {
    let c = luxnode::sim::controller::SimController {
        period: Duration::from_millis(args.step_ms),
        cycles: args.cycles,
        forever: args.forever,
    };
    let stops = !c.forever;
    let task: Companion = Box::new(move |addr| {
        Box::pin(async move {
            let mut out = std::io::stdout();
            if let Err(e) = c.run(addr, &mut out).await {
                tracing::error!("simulated controller: {e}");
            }
        })
    });
    Ok((task, stops))
}

#[cfg(not(feature = "sim"))]
fn controller(_args: &Args) -> Result<(Companion, bool)> {
    bail!("the simulated controller is part of the `sim` feature; run with --no-controller")
}

/// The scene with the board's camera optics (`[camera.sim.optics]`) on its camera.
#[cfg(feature = "sim")]
fn with_optics(
    mut scene: luxnode::scene::Scene,
    optics: Option<&luxnode::board::camera::Optics>,
) -> luxnode::scene::Scene {
    if let (Some(o), Some(c)) = (optics, scene.camera.as_ref()) {
        scene.camera = Some(o.apply(c));
    }
    scene
}

/// The board's ambient light sensor's angular response: hooded (`[i2c.als]
/// hood_half_angle_deg`) or a bare cosine sensor.
fn als_response(board: &Board) -> Result<luxnode::lsc::AngularResponse> {
    use luxnode::lsc::{AngularResponse, Lsc};
    let hood = board
        .i2c
        .as_ref()
        .and_then(|i| i.als.as_ref())
        .and_then(|a| a.hood_half_angle_deg);
    Ok(match hood {
        None => AngularResponse::Cosine,
        Some(deg) => AngularResponse::Table(Lsc::hooded(deg.to_radians()).with_context(|| {
            format!(
                "board {}: i2c.als.hood_half_angle_deg {deg} is outside 1..=85",
                board.name
            )
        })?),
    })
}
