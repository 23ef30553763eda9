//! `luxnode run --board FILE`: the node. The arguments are parsed here; the node is assembled
//! from its board file by the library ([`luxnode::daemon::assemble`]).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;
use luxnode::daemon::Exit;
use luxnode::daemon::assemble::{self, RunOptions, SimController};

/// `luxnode run`.
#[derive(clap::Args)]
pub struct Args {
    /// The board file, e.g. boards/sim/board.toml.
    #[arg(long, value_name = "FILE")]
    pub board: PathBuf,
    /// Flash device or file instead of the board's.
    #[arg(long, value_name = "FILE")]
    pub flash: Option<PathBuf>,
    /// Modbus TCP address instead of the board's (port 0: any free port, printed).
    #[arg(long, value_name = "ADDR:PORT")]
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
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub cycles: usize,
    /// Time per dimming state of the simulated controller, ms.
    #[arg(long, value_name = "MS", default_value_t = 400)]
    pub step_ms: u64,
    /// Stop after this many seconds.
    #[arg(long, value_name = "S")]
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
    #[arg(long, value_name = "FILE", conflicts_with = "cad")]
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

impl Args {
    /// The library's run options.
    fn options(&self) -> Result<RunOptions> {
        let run_for = self
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
        #[cfg(feature = "sim")]
        let (power_cut_after_bytes, led_trace) =
            (self.power_cut_after_bytes, self.led_trace.clone());
        #[cfg(not(feature = "sim"))]
        let (power_cut_after_bytes, led_trace) = (None, None);
        Ok(RunOptions {
            board: self.board.clone(),
            flash: self.flash.clone(),
            bind: self.bind,
            recommission: self.recommission,
            cad: self.cad,
            image: self.image.clone(),
            run_for,
            controller: (!self.no_controller).then_some(SimController {
                step_ms: self.step_ms,
                cycles: self.cycles,
                forever: self.forever,
            }),
            power_cut_after_bytes,
            led_trace,
        })
    }
}

/// Runs the node (or, with `--capture-to`, captures the room and exits).
pub fn run(args: &Args) -> Result<ExitCode> {
    if let Some(dir) = &args.capture_to {
        let (board, scene) = assemble::load_board(&args.board)?;
        let c = assemble::capture(&board, &scene, dir)?;
        println!(
            "{}: {} depth frames and {} luminance frames from {} in {:.2} s, {} retries",
            dir.display(),
            c.depth_frames,
            c.luminance_frames,
            c.what,
            c.seconds,
            c.retries
        );
        return Ok(ExitCode::SUCCESS);
    }
    let options = args.options()?;
    match assemble::run(&options)? {
        Exit::Stopped => Ok(ExitCode::SUCCESS),
        Exit::PowerCut => Ok(ExitCode::from(3)),
    }
}
