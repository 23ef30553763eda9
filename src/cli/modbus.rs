//! `luxnode serve`, `luxnode modbus ...`.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use luxnode::modbus::gateway::GatewayConfig;
use luxnode::modbus::regmap;
use luxnode::modbus::rtu::{Parity, RtuOptions};
use luxnode::modbus::tcp::TcpOptions;
use luxnode::serve::{DEFAULT_BIND, ServeOptions};

/// `luxnode serve`.
#[derive(clap::Args)]
pub struct ServeArgs {
    /// The commissioned image.
    #[arg(long)]
    pub image: PathBuf,
    /// Modbus TCP address (port 0: any free port, printed at start).
    #[arg(long, default_value = DEFAULT_BIND)]
    pub bind: SocketAddr,
    /// Most TCP connections at once.
    #[arg(long, default_value_t = 16)]
    pub max_connections: usize,
    /// Close a TCP connection silent for this long, s.
    #[arg(long, default_value_t = 60.0)]
    pub idle_timeout_s: f64,
    /// Also serve Modbus RTU on this serial device.
    #[arg(long, value_name = "DEVICE")]
    pub rtu: Option<String>,
    /// RTU unit id (1..=247).
    #[arg(long, default_value_t = 1, requires = "rtu")]
    pub unit_id: u8,
    /// RTU baud rate.
    #[arg(long, default_value_t = 19200, requires = "rtu")]
    pub baud: u32,
    /// RTU parity.
    #[arg(long, value_enum, default_value_t = ParityArg::Even, requires = "rtu")]
    pub parity: ParityArg,
    /// Follow a DALI gateway (TOML: address, layout, encoding; see docs/modbus.md).
    #[arg(long, value_name = "FILE")]
    pub gateway: Option<PathBuf>,
    /// Arc level of every luminaire at start (0 = off .. 254).
    #[arg(long)]
    pub arc: Option<u8>,
    /// Stop after this many seconds (default: until Ctrl-C or SIGTERM).
    #[arg(long)]
    pub seconds: Option<f64>,
}

/// Parity on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ParityArg {
    /// Even.
    Even,
    /// Odd.
    Odd,
    /// None (two stop bits).
    None,
}

fn duration_s(what: &str, s: f64) -> Result<Duration> {
    if !(s.is_finite() && s > 0.0 && s < 1e7) {
        bail!("{what} {s} s: must be a positive number of seconds");
    }
    Ok(Duration::from_secs_f64(s))
}

/// Runs `luxnode serve`.
pub fn serve(args: &ServeArgs) -> Result<()> {
    let rtu = match &args.rtu {
        Some(dev) => {
            let parity = match args.parity {
                ParityArg::Even => Parity::Even,
                ParityArg::Odd => Parity::Odd,
                ParityArg::None => Parity::None,
            };
            let line = RtuOptions {
                unit_id: args.unit_id,
                baud: args.baud,
                parity,
                stop_bits: if parity == Parity::None { 2 } else { 1 },
            };
            line.validate().map_err(|e| anyhow::anyhow!("--rtu: {e}"))?;
            Some((dev.clone(), line))
        }
        None => None,
    };
    let gateway = match &args.gateway {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            Some(GatewayConfig::from_toml(&text).with_context(|| path.display().to_string())?)
        }
        None => None,
    };
    if let Some(a) = args.arc
        && a > 254
    {
        bail!("--arc {a}: arc levels are 0..=254");
    }
    if args.max_connections == 0 {
        bail!("--max-connections must be at least 1");
    }
    luxnode::serve::serve(ServeOptions {
        image: args.image.clone(),
        bind: args.bind,
        tcp: TcpOptions {
            max_connections: args.max_connections,
            idle_timeout: duration_s("--idle-timeout-s", args.idle_timeout_s)?,
        },
        rtu,
        gateway,
        model_name: "luxnode serve".into(),
        initial_arc: args.arc,
        run_for: args
            .seconds
            .map(|s| duration_s("--seconds", s))
            .transpose()?,
    })
}

/// `luxnode modbus`.
#[derive(clap::Subcommand)]
pub enum ModbusCommand {
    /// Print the register map as markdown (docs/modbus.md), or check a file against it.
    Map {
        /// Compare this file with the map instead of printing; non-zero exit if they differ.
        #[arg(long, value_name = "FILE")]
        check: Option<PathBuf>,
    },
}

/// Runs `luxnode modbus ...`.
pub fn modbus(command: &ModbusCommand) -> Result<()> {
    match command {
        ModbusCommand::Map { check: None } => {
            print!("{}", regmap::markdown());
            Ok(())
        }
        ModbusCommand::Map { check: Some(path) } => check_map(path),
    }
}

fn check_map(path: &Path) -> Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let want = regmap::markdown();
    if !text.contains(want.trim()) {
        bail!(
            "{} does not contain the register map of this build: regenerate the table with `luxnode modbus map`",
            path.display()
        );
    }
    println!("{}: register map up to date", path.display());
    Ok(())
}
