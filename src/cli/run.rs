//! `luxnode run --board FILE`: the node.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use luxnode::board::{Board, SceneSource};
use luxnode::board_camera::{CameraBoard, FlashBoard};
use luxnode::camera::replay::ReplayWorld;
use luxnode::camera::sim::SimWorld;
use luxnode::camera::{DepthCamera, FaultInjector, LightControl, LuminanceCamera, SequenceOptions};
use luxnode::commission::CommissionOptions;
use luxnode::daemon::source::CameraSource;
use luxnode::daemon::{
    self, CadSource, CommissionSource, DaemonConfig, Exit, FlashConfig, Unavailable,
    controller::SimController,
};
use luxnode::modbus::tcp::TcpOptions;
use luxnode::scene::Scene;
use luxnode::serve::ServeOptions;
use luxnode::store::build::ImageOptions;

/// `luxnode run`.
#[derive(clap::Args)]
pub struct RunArgs {
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
    #[arg(long, hide = true)]
    pub power_cut_after_bytes: Option<usize>,
}

fn flash_config(board: &Board, args: &RunArgs) -> Result<FlashConfig> {
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
    Ok(FlashConfig {
        path,
        capacity,
        power_cut_after_bytes: args.power_cut_after_bytes,
    })
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
    report_png: PathBuf,
) -> Result<Box<dyn CommissionSource>> {
    let preset = board.preset;
    if cad {
        return Ok(Box::new(CadSource {
            scene,
            settings: preset.engine(),
            image,
        }));
    }
    let commission = CommissionOptions {
        engine: preset.engine(),
        progress: true,
        ..CommissionOptions::default()
    };
    let (what, depth, colour, lights): Rig = match &board.camera {
        CameraBoard::Sim {
            depth,
            luminance,
            faults,
        } => {
            // the simulated room is the scene; the node sees it only through the cameras
            let world = SimWorld::new(scene.clone(), &luxnode::camera::sim::world_settings())
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
            let (d, c) = luxnode::camera::hardware::open(&board.camera)?;
            let lights = luxnode::modbus::gateway::GatewayLights::connect(gateway)?;
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
        report_png: Some(report_png),
    }))
}

/// Runs the node.
pub fn run(args: &RunArgs) -> Result<ExitCode> {
    let board = Board::load(&args.board)?;
    println!(
        "luxnode {} on board {}: {}",
        env!("CARGO_PKG_VERSION"),
        board.name,
        board.description
    );
    let scene = match &board.scene {
        SceneSource::DemoOffice => luxnode::demo::demo_office(),
        SceneSource::Directory(dir) => luxnode::scene::Scene::load(dir, &Default::default())
            .map_err(|e| anyhow::anyhow!("{e}"))
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
    let flash = flash_config(&board, args)?;
    let report = flash.path.with_file_name("commissioning-report.png");
    let mut source = commission_source(&board, scene, image, args.cad, report)?;
    let seconds = args
        .seconds
        .map(|s| {
            if s.is_finite() && s > 0.0 {
                Ok(Duration::from_secs_f64(s))
            } else {
                Err(anyhow::anyhow!("--seconds {s}: must be positive"))
            }
        })
        .transpose()?;
    let m = &board.modbus;
    let config = DaemonConfig {
        board: board.name.clone(),
        flash,
        serve: ServeOptions {
            image: PathBuf::new(),
            bind: args.bind.unwrap_or(m.bind),
            tcp: TcpOptions {
                max_connections: m.max_connections,
                idle_timeout: m.idle_timeout,
            },
            rtu: m.rtu.clone(),
            gateway: m.gateway.clone(),
            model_name: board.name.clone(),
            initial_arc: None,
            run_for: seconds,
        },
        controller: (m.gateway.is_none() && !args.no_controller).then(|| SimController {
            period: Duration::from_millis(args.step_ms),
            cycles: args.cycles,
            forever: args.forever,
        }),
        recommission: args.recommission,
    };
    match daemon::run(config, source.as_mut())? {
        Exit::Stopped => Ok(ExitCode::SUCCESS),
        Exit::PowerCut => Ok(ExitCode::from(3)),
    }
}
