//! `luxnode serve`, `luxnode modbus ...`.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use luxnode::bacnet::objects::DeviceInfo;
use luxnode::fieldbus::bacnet::BacnetOptions;
use luxnode::fieldbus::bacnet::service::ServerConfig;
use luxnode::fieldbus::gateway::GatewayConfig;
use luxnode::fieldbus::rtu::{Parity, RtuOptions};
use luxnode::fieldbus::tcp::TcpOptions;
use luxnode::modbus::regmap;
use luxnode::serve::{DEFAULT_BIND, ServeOptions};

/// `luxnode serve`.
#[derive(clap::Args)]
pub struct ServeArgs {
    /// The commissioned image.
    #[arg(long, value_name = "FILE")]
    pub image: PathBuf,
    /// Take the Modbus settings (TCP, RTU, gateway) from this board file; flags override it.
    #[arg(long, value_name = "FILE")]
    pub board: Option<PathBuf>,
    /// Modbus TCP address (port 0: any free port, printed at start) [if absent: the board's, or
    /// 127.0.0.1:1502].
    #[arg(long, value_name = "ADDR:PORT")]
    pub bind: Option<SocketAddr>,
    /// Most TCP connections at once [if absent: the board's, or 128].
    #[arg(long, value_name = "N")]
    pub max_connections: Option<usize>,
    /// Most TCP connections from one address [if absent: the board's, or 64].
    #[arg(long, value_name = "N")]
    pub max_per_source: Option<usize>,
    /// Allow writes from these sources (IP, ADDR/PREFIX, "rtu", "tls", "role:NAME"; repeat or
    /// comma-separate) [if absent: the board's write_allow, or nobody: read-only].
    #[arg(long, value_name = "SOURCE", value_delimiter = ',')]
    pub allow_writes_from: Vec<String>,
    /// Persist the settings clients write (word orders, dimming curve) in this JSON file.
    #[arg(long, value_name = "FILE")]
    pub settings: Option<PathBuf>,
    /// Close a TCP connection silent for this long, s [if absent: the board's, or 60].
    #[arg(long, value_name = "S")]
    pub idle_timeout_s: Option<f64>,
    /// Also serve Modbus RTU on this serial device.
    #[arg(long, value_name = "DEVICE")]
    pub rtu: Option<String>,
    /// RTU unit id (1..=247).
    #[arg(long, value_name = "N", default_value_t = 1, requires = "rtu")]
    pub unit_id: u8,
    /// RTU baud rate.
    #[arg(long, value_name = "BAUD", default_value_t = 19200, requires = "rtu")]
    pub baud: u32,
    /// RTU parity.
    #[arg(long, value_enum, default_value_t = ParityArg::Even, requires = "rtu")]
    pub parity: ParityArg,
    /// Follow a DALI gateway (TOML: address, layout, encoding; see docs/modbus.md).
    #[arg(long, value_name = "FILE")]
    pub gateway: Option<PathBuf>,
    /// Arc level of every luminaire at start (0 = off .. 254).
    #[arg(long, value_name = "LEVEL")]
    pub arc: Option<u8>,
    /// Stop after this many seconds [if absent: until Ctrl-C or SIGTERM].
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Also serve BACnet/IP on this UDP address (port 0: any free port, printed at start)
    /// [if absent: the board's `[bacnet]`, or none]. Writes follow the Modbus write allowlist.
    #[arg(long, value_name = "ADDR:PORT")]
    pub bacnet: Option<SocketAddr>,
    /// BACnet Device object instance (0..=4194302) [if absent: the board's, or 1].
    #[arg(long, value_name = "N")]
    pub bacnet_device_id: Option<u32>,
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

pub(crate) fn duration_s(what: &str, s: f64) -> Result<Duration> {
    if !(s.is_finite() && s > 0.0 && s < 1e7) {
        bail!("{what} {s} s: must be a positive number of seconds");
    }
    Ok(Duration::from_secs_f64(s))
}

/// Runs `luxnode serve`.
pub fn serve(args: &ServeArgs) -> Result<()> {
    let board = args
        .board
        .as_deref()
        .map(luxnode::board::Board::load)
        .transpose()?;
    let bm = board.as_ref().map(|b| &b.modbus);
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
            line.validate().context("--rtu")?;
            Some((dev.clone(), line))
        }
        None => bm.and_then(|m| m.rtu.clone()),
    };
    let gateway = match &args.gateway {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            Some(GatewayConfig::from_toml(&text).with_context(|| path.display().to_string())?)
        }
        None => bm.and_then(|m| m.gateway.clone()),
    };
    let bind = match (args.bind, bm) {
        (Some(b), _) => b,
        (None, Some(m)) => m.bind,
        (None, None) => DEFAULT_BIND.parse()?,
    };
    let max_connections = args
        .max_connections
        .or(bm.map(|m| m.max_connections))
        .unwrap_or(TcpOptions::default().max_connections);
    let max_per_source = args
        .max_per_source
        .or(bm.map(|m| m.max_per_source))
        .unwrap_or(TcpOptions::default().max_per_source)
        .min(max_connections);
    let mut access = bm.map(|m| m.access.clone()).unwrap_or_default();
    if !args.allow_writes_from.is_empty() {
        access = access
            .with_writers(&args.allow_writes_from)
            .context("--allow-writes-from")?;
        if let Some(entry) = access.admits_everyone() {
            tracing::warn!(
                "--allow-writes-from {entry} lets every network address write; name the BMS \
                 and gateway addresses instead"
            );
        }
    }
    let idle_timeout = match (args.idle_timeout_s, bm) {
        (Some(s), _) => duration_s("--idle-timeout-s", s)?,
        (None, Some(m)) => m.idle_timeout,
        (None, None) => Duration::from_secs(60),
    };
    if let Some(a) = args.arc
        && a > 254
    {
        bail!("--arc {a}: arc levels are 0..=254");
    }
    if max_connections == 0 || max_per_source == 0 {
        bail!("--max-connections and --max-per-source must be at least 1");
    }
    let bacnet = bacnet_options(args, board.as_ref())?;
    luxnode::serve::serve(
        &args.image,
        ServeOptions {
            bind,
            tcp: TcpOptions {
                max_connections,
                max_per_source,
                idle_timeout,
                ..TcpOptions::default()
            },
            tls: bm.and_then(|m| m.tls.clone()),
            rtu,
            gateway,
            access,
            settings_path: args.settings.clone(),
            control: board
                .as_ref()
                .map(|b| b.control.clone())
                .unwrap_or_default(),
            model_name: board.map_or("luxnode serve".into(), |b| b.name),
            bacnet,
            initial_arc: args.arc,
            run_for: args
                .seconds
                .map(|s| duration_s("--seconds", s))
                .transpose()?,
        },
    )?;
    Ok(())
}

/// The BACnet/IP options: the board's `[bacnet]`, `--bacnet` and `--bacnet-device-id` over it.
fn bacnet_options(
    args: &ServeArgs,
    board: Option<&luxnode::board::Board>,
) -> Result<Option<BacnetOptions>> {
    let from_board = board.and_then(|b| b.bacnet.clone());
    let mut options = match (args.bacnet, from_board) {
        (None, None) => {
            if args.bacnet_device_id.is_some() {
                bail!("--bacnet-device-id needs --bacnet ADDR:PORT (or a board with [bacnet])");
            }
            return Ok(None);
        }
        (Some(bind), None) => {
            let model = board.map_or("luxnode serve", |b| b.name.as_str());
            BacnetOptions {
                bind,
                server: ServerConfig {
                    device: DeviceInfo::new(1, model),
                    dcc_password: None,
                },
                bbmd: None,
            }
        }
        (bind, Some(mut o)) => {
            if let Some(b) = bind {
                o.bind = b;
            }
            o
        }
    };
    if let Some(id) = args.bacnet_device_id {
        let id = luxnode::board::bacnet::check_device_id(id)
            .map_err(anyhow::Error::msg)
            .context("--bacnet-device-id")?;
        let d = &mut options.server.device;
        d.name = d.name.replace(&d.instance.to_string(), &id.to_string());
        d.instance = id;
    }
    Ok(Some(options))
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

/// `luxnode bacnet`.
#[derive(clap::Subcommand)]
pub enum BacnetCommand {
    /// Print the PICS as markdown (docs/bacnet.md), or check a file against it.
    Pics {
        /// Compare this file with the PICS instead of printing; non-zero exit if they differ.
        #[arg(long, value_name = "FILE")]
        check: Option<PathBuf>,
    },
}

/// Runs `luxnode bacnet ...`.
pub fn bacnet(command: &BacnetCommand) -> Result<()> {
    let BacnetCommand::Pics { check } = command;
    let want = luxnode::bacnet::pics::markdown();
    match check {
        None => {
            print!("{want}");
            Ok(())
        }
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            if !text.contains(want.trim()) {
                bail!(
                    "{} does not contain the PICS of this build: regenerate it with `luxnode bacnet pics`",
                    path.display()
                );
            }
            println!("{}: PICS up to date", path.display());
            Ok(())
        }
    }
}
