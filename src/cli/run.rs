//! `luxnode run --board FILE`: the node.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use luxnode::board::camera::{CameraBoard, FlashBoard};
use luxnode::board::{Board, SceneSource};
use luxnode::camera::replay::ReplayWorld;
use luxnode::camera::{DepthCamera, LightControl, LuminanceCamera, SequenceOptions};
use luxnode::commission::CommissionOptions;
use luxnode::daemon::source::CameraSource;
use luxnode::daemon::{
    self, CadSource, CommissionSource, Companion, DaemonConfig, Exit, SensorProbe, Unavailable,
};
use luxnode::image_build::ImageOptions;
use luxnode::modbus::gateway::GatewayWriter;
use luxnode::modbus::tcp::TcpOptions;
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
    /// Test only (HIL): the simulated power fails after this many bytes of the image write.
    #[cfg(feature = "sim")]
    #[arg(long, hide = true)]
    pub power_cut_after_bytes: Option<usize>,
}

/// The flash device's path and size, from the board or `--flash`.
fn flash_config(board: &Board, args: &Args) -> Result<(PathBuf, usize)> {
    let region = usize::try_from(luxnode::layout::FORMFACTORS_LEN_BYTES)?;
    let (path, capacity) = match (&args.flash, &board.flash) {
        (Some(p), _) => (p.clone(), 2 * region),
        (None, FlashBoard::File { path, size_bytes }) => (path.clone(), *size_bytes),
        (None, FlashBoard::Mtd { device }) => bail!(
            "board {}: flash kind \"mtd\" ({device}): the store has no raw MTD backend yet; use \
             the partition through mtdblock as kind = \"file\", or --flash FILE",
            board.name
        ),
    };
    if capacity < 2 * region {
        bail!(
            "board {}: flash of {capacity} bytes is smaller than two {region}-byte image slots",
            board.name
        );
    }
    Ok((path, capacity))
}

/// The flash device, with the simulated power cut of `--power-cut-after-bytes` (HIL) if asked.
fn open_flash(path: &std::path::Path, capacity: usize, args: &Args) -> Result<Flash> {
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

/// The node's flash: the file, or (HIL) the file behind a fault injector.
enum Flash {
    File(FileFlash),
    #[cfg(feature = "sim")]
    Faulty(luxnode::store::devices::FaultyFlash<FileFlash>),
}

impl FlashDevice for Flash {
    type Error = DeviceError;
    fn capacity(&self) -> usize {
        match self {
            Flash::File(d) => d.capacity(),
            #[cfg(feature = "sim")]
            Flash::Faulty(d) => d.capacity(),
        }
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        match self {
            Flash::File(d) => d.read(offset, buf),
            #[cfg(feature = "sim")]
            Flash::Faulty(d) => d.read(offset, buf),
        }
    }
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        match self {
            Flash::File(d) => d.erase(offset, len),
            #[cfg(feature = "sim")]
            Flash::Faulty(d) => d.erase(offset, len),
        }
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        match self {
            Flash::File(d) => d.write(offset, data),
            #[cfg(feature = "sim")]
            Flash::Faulty(d) => d.write(offset, data),
        }
    }
    fn sync(&mut self) -> Result<(), DeviceError> {
        match self {
            Flash::File(d) => d.sync(),
            #[cfg(feature = "sim")]
            Flash::Faulty(d) => d.sync(),
        }
    }
}

/// What a commissioning capture needs: a name, the two cameras, the lights.
type Rig = (
    String,
    Box<dyn DepthCamera>,
    Box<dyn LuminanceCamera>,
    Box<dyn LightControl>,
);

/// The first boot's commissioning source: the board's cameras, or the CAD scene with `--cad`.
fn commission_source(
    board: &Board,
    scene: Scene,
    image: ImageOptions,
    cad: bool,
    report: luxnode::daemon::source::ReportTarget,
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
    let commission = CommissionOptions {
        engine: preset.engine(),
        progress: true,
        ..CommissionOptions::default()
    };
    let (what, depth, colour, lights): Rig = match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim {
            depth,
            luminance,
            faults,
        } => {
            use luxnode::camera::FaultInjector;
            use luxnode::sim::camera::{SimWorld, world_settings};
            // the simulated room is the scene; the node sees it only through the cameras
            let world = SimWorld::new(scene.clone(), &world_settings())
                .with_context(|| format!("board {}: simulated cameras", board.name))?;
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
                return Ok(Box::new(Unavailable(format!(
                    "board {}: commissioning with the hardware cameras switches the luminaires \
                     one at a time through the DALI gateway, and the board has no [gateway]",
                    board.name
                ))));
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
    Ok(Box::new(CameraSource {
        what,
        depth,
        colour,
        lights,
        luminaires: scene.luminaires.clone(),
        sensors: scene.sensors.clone(),
        desks: scene.desks.clone(),
        sequence: match &board.camera {
            // lamp run-up / DALI fade, and auto exposure catching up, on real hardware
            CameraBoard::Hardware { .. } => SequenceOptions {
                registration: board.camera.registration().cloned(),
                settle: Duration::from_millis(500),
                discard_after_switch: 2,
                ..SequenceOptions::default()
            },
            _ => SequenceOptions::default(),
        },
        commission,
        image,
        report,
    }))
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
    let scene = match &board.scene {
        SceneSource::DemoOffice => demo_office()?,
        SceneSource::Directory(dir) => luxnode::scene::Scene::load(dir, &Default::default())
            .with_context(|| format!("board {} scene", board.name))?,
    };
    let image = {
        let st = board.preset.store();
        ImageOptions {
            precision: st.precision,
            prune_below: st.prune_below,
            ..ImageOptions::default()
        }
    };
    let (flash_path, capacity) = flash_config(&board, args)?;
    // the commissioning report next to the flash: <flash dir>/commissioning-report/report.html
    let report = luxnode::daemon::source::ReportTarget {
        dir: Some(flash_path.with_file_name("commissioning-report")),
        preset: board.preset.name().into(),
        maintenance_factor: board.maintenance_factor,
    };
    let mut source = commission_source(&board, scene, image, args.cad, report)?;
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
    let flash = open_flash(&flash_path, capacity, args)?;
    let companion = if m.gateway.is_none() && !args.no_controller {
        Some(controller(args)?)
    } else {
        None
    };
    let settings_path = flash_path.with_extension("settings.json");
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
        recommission: args.recommission,
        reload: Some(reload),
        sensor_probe: sensor_probe(&board),
        live: live_task(&board),
    };
    match daemon::run(config, flash, source.as_mut())? {
        Exit::Stopped => Ok(ExitCode::SUCCESS),
        Exit::PowerCut => Ok(ExitCode::from(3)),
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
            depth, luminance, ..
        } => {
            use luxnode::sim::camera::{SimWorld, world_settings};
            let (scene_source, depth, luminance) =
                (board.scene.clone(), depth.clone(), luminance.clone());
            camera_source(move || -> Result<OpenedCameras, String> {
                let scene = match &scene_source {
                    SceneSource::DemoOffice => luxnode::sim::demo::demo_office(),
                    SceneSource::Directory(dir) => {
                        luxnode::scene::Scene::load(dir, &Default::default())
                            .map_err(|e| e.to_string())?
                    }
                };
                let world = SimWorld::new(scene, &world_settings()).map_err(|e| e.to_string())?;
                let d = world
                    .depth_camera(depth.clone())
                    .map_err(|e| e.to_string())?;
                let c = world
                    .luminance_camera(luminance.clone())
                    .map_err(|e| e.to_string())?;
                Ok((Box::new(d), Box::new(c), Some(Box::new(world))))
            })
        }
        CameraBoard::Replay { dir } => {
            let (dir, scene_source) = (dir.clone(), board.scene.clone());
            camera_source(move || -> Result<OpenedCameras, String> {
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
            })
        }
        CameraBoard::Hardware { .. } => {
            // the colour frames must be registered to the ToF grid like at commissioning; the
            // run-time registration is not wired yet
            tracing::warn!(
                "live: run-time frames from hardware cameras are not supported yet; serving the \
                 model only"
            );
            return None;
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
        CameraBoard::Sim { depth, faults, .. } => {
            use luxnode::camera::FaultInjector;
            use luxnode::sim::camera::{SimWorld, world_settings};
            let (scene_source, depth, faults) =
                (board.scene.clone(), depth.clone(), faults.clone());
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
                            SimWorld::new(scene, &world_settings()).map_err(|e| e.to_string())?;
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
            let luxnode::board::camera::TofBoard::A010 { device: tof, .. } = tof;
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
