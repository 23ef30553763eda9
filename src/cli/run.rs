//! `luxnode run --board FILE`: the node.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use luxnode::board::{Board, SceneSource};
use luxnode::daemon::{
    self, CadSource, DaemonConfig, Exit, FlashConfig, controller::SimController,
};
use luxnode::modbus::tcp::TcpOptions;
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
    /// Test only (HIL): the simulated power fails after this many bytes of the image write.
    #[arg(long, hide = true)]
    pub power_cut_after_bytes: Option<usize>,
}

/// The default flash file of a board without one: next to the build, never in the source tree.
fn default_flash(board: &Board) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("target")
        .join(format!("node-{}", board.name))
        .join("flash.bin")
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
    let mut source = CadSource {
        scene,
        settings: board.preset.engine(),
        image: {
            let st = board.preset.store();
            ImageOptions {
                precision: st.precision,
                prune_below: st.prune_below,
                ..ImageOptions::default()
            }
        },
    };
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
        flash: FlashConfig {
            path: args.flash.clone().unwrap_or_else(|| default_flash(&board)),
            capacity: 2 * usize::try_from(luxnode::layout::FORMFACTORS_LEN_BYTES)?,
            power_cut_after_bytes: args.power_cut_after_bytes,
        },
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
    match daemon::run(config, &mut source)? {
        Exit::Stopped => Ok(ExitCode::SUCCESS),
        Exit::PowerCut => Ok(ExitCode::from(3)),
    }
}
