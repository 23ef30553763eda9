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
    /// Take the Modbus settings (TCP, RTU, gateway) from this board file; flags override it.
    #[arg(long)]
    pub board: Option<PathBuf>,
    /// Modbus TCP address (port 0: any free port, printed at start) [default: the board's, or
    /// 127.0.0.1:1502].
    #[arg(long)]
    pub bind: Option<SocketAddr>,
    /// Most TCP connections at once [default: the board's, or 16].
    #[arg(long)]
    pub max_connections: Option<usize>,
    /// Close a TCP connection silent for this long, s [default: the board's, or 60].
    #[arg(long)]
    pub idle_timeout_s: Option<f64>,
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
            line.validate().map_err(|e| anyhow::anyhow!("--rtu: {e}"))?;
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
        .unwrap_or(16);
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
    if max_connections == 0 {
        bail!("--max-connections must be at least 1");
    }
    luxnode::serve::serve(ServeOptions {
        image: args.image.clone(),
        bind,
        tcp: TcpOptions {
            max_connections,
            idle_timeout,
        },
        rtu,
        gateway,
        model_name: board.map_or("luxnode serve".into(), |b| b.name),
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

/// `luxnode bench modbus-load`: many TCP clients polling the desk lux at once.
pub fn bench_load(image: &Path, clients: usize, seconds: f64, interval_ms: u64) -> Result<()> {
    use luxnode::modbus::node::{NodeOptions, lock};
    use luxnode::modbus::tcp::{self, TcpCounters};
    use std::sync::{Arc, Mutex};
    use tokio_modbus::client::Reader;

    if clients == 0 || clients > 10_000 {
        bail!("--clients {clients}: 1..=10000");
    }
    let run_for = duration_s("--seconds", seconds)?;
    let node = luxnode::serve::load_node(
        image,
        NodeOptions {
            initial_arc: Some(254),
            ..NodeOptions::default()
        },
    )?;
    let desks = node.map().desk_count() as u16;
    let node = Arc::new(Mutex::new(node));
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let rss_before = rss_kib();
    let (lat, errors, counters) = rt.block_on(async {
        let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
        let listener = tcp::bind("127.0.0.1:0".parse()?).await?;
        let addr = listener.local_addr()?;
        let counters = Arc::new(TcpCounters::default());
        let server = tokio::spawn(tcp::serve(
            listener,
            node.clone(),
            TcpOptions {
                max_connections: clients + 8,
                idle_timeout: Duration::from_secs(60),
            },
            counters.clone(),
            stop_rx,
        ));
        let deadline = tokio::time::Instant::now() + run_for;
        let mut tasks = Vec::with_capacity(clients);
        for k in 0..clients {
            tasks.push(tokio::spawn(async move {
                let mut lat_us: Vec<u32> = Vec::new();
                let mut errors = 0u64;
                let Ok(mut c) = tokio_modbus::client::tcp::connect(addr).await else {
                    return (lat_us, 1);
                };
                // spread the clients' phases over the interval
                if interval_ms > 0 {
                    let phase = interval_ms * k as u64 / clients as u64;
                    tokio::time::sleep(Duration::from_millis(phase)).await;
                }
                let mut next = tokio::time::Instant::now();
                while tokio::time::Instant::now() < deadline {
                    let t0 = std::time::Instant::now();
                    match c.read_input_registers(100, 2 * desks).await {
                        Ok(Ok(_)) => {
                            lat_us.push(t0.elapsed().as_micros().min(u32::MAX as u128) as u32)
                        }
                        _ => errors += 1,
                    }
                    if interval_ms > 0 {
                        next += Duration::from_millis(interval_ms);
                        tokio::time::sleep_until(next).await;
                    }
                }
                (lat_us, errors)
            }));
        }
        let mut all = Vec::new();
        let mut errors = 0;
        for t in tasks {
            let (l, e) = t.await?;
            all.extend(l);
            errors += e;
        }
        let _ = stop_tx.send(true);
        let _ = server.await;
        anyhow::Ok((all, errors, counters))
    })?;
    let rss_after = rss_kib();
    let mut lat = lat;
    lat.sort_unstable();
    let pct = |p: f64| -> f64 {
        if lat.is_empty() {
            return f64::NAN;
        }
        let i = ((lat.len() as f64 - 1.0) * p).round() as usize;
        f64::from(lat[i]) / 1000.0
    };
    let accepted = counters.accepted.load(std::sync::atomic::Ordering::Relaxed);
    println!(
        "| clients | poll interval | duration | requests | requests/s | p50 | p99 | p99.9 | max | errors | connections | RSS |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "| {clients} | {} | {seconds:.0} s | {} | {:.0} | {:.2} ms | {:.2} ms | {:.2} ms | {:.2} ms | {errors} | {accepted} | {} → {} KiB |",
        if interval_ms == 0 {
            "back to back".to_string()
        } else {
            format!("{interval_ms} ms")
        },
        lat.len(),
        lat.len() as f64 / seconds,
        pct(0.5),
        pct(0.99),
        pct(0.999),
        pct(1.0),
        rss_before.map_or("?".into(), |v| v.to_string()),
        rss_after.map_or("?".into(), |v| v.to_string()),
    );
    let _ = lock(&node).desks();
    Ok(())
}

fn rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmRSS:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// `luxnode bench fuzz`.
pub fn bench_fuzz(frames: u64, seed: u64) -> Result<()> {
    let t0 = std::time::Instant::now();
    let r = luxnode::modbus::fuzz::run(frames, seed).map_err(|f| anyhow::anyhow!("{f}"))?;
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "| frames | seed | answers | exception 01 | exception 02 | exception 03 | not answered (empty) | RTU answered | RTU silent | time | invariant violations |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "| {} | {seed:#x} | {} | {} | {} | {} | {} | {} | {} | {dt:.1} s | 0 |",
        r.frames,
        r.answers,
        r.exceptions[1],
        r.exceptions[2],
        r.exceptions[3],
        r.silent,
        r.rtu_answered,
        r.rtu_silent
    );
    Ok(())
}
