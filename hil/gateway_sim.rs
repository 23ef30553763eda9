//! `gateway-sim`: a simulated DALI gateway with a Modbus TCP interface, for the tests, the HIL
//! rig and the demo.
//!
//! Real DALI-to-Modbus gateways expose each DALI short address's arc level in a register
//! (layouts differ: a base and a stride, levels as 0..=254 or as percent); a controller writes
//! them and the gateway drives the bus. This simulator is that register bank: `--registers N`
//! holding registers, all readable (0x03, and 0x04 at the same addresses) and writable (0x06,
//! 0x10), every other function exception 0x01, any address past the bank exception 0x02. Its
//! unit id is not filtered.
//!
//! `--demo L,BASE,STRIDE,PERIOD_MS` makes the gateway step its L luminaires through dimming
//! states on its own, the way a DALI controller running a scene sequence would.
//!
//! It prints `modbus tcp listening on ADDR` once its socket is open (`--bind 127.0.0.1:0` picks
//! a free port).

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Parser;
use luxnode::fieldbus::tcp::{self, TcpCounters, TcpOptions};
use luxnode::modbus::pdu::{
    Exception, MAX_PDU, MAX_WRITE, Request, decode_request, encode_exception, encode_registers,
    encode_write_echo,
};
use luxnode::{fieldbus::PduHandler, node::lock};

#[derive(Parser)]
#[command(
    name = "gateway-sim",
    about = "A simulated DALI gateway (Modbus TCP register bank)"
)]
struct Args {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:1503")]
    bind: SocketAddr,
    /// Holding registers in the bank.
    #[arg(long, default_value_t = 1024)]
    registers: u16,
    /// Initial values, ADDR=VALUE[,ADDR=VALUE...].
    #[arg(long, value_delimiter = ',')]
    set: Vec<String>,
    /// Step L luminaires at BASE + STRIDE·j through dimming states every PERIOD_MS.
    #[arg(long, value_name = "L,BASE,STRIDE,PERIOD_MS")]
    demo: Option<String>,
    /// Stop after this many seconds.
    #[arg(long)]
    seconds: Option<f64>,
}

/// The gateway's registers.
struct Bank {
    regs: Vec<u16>,
}

impl Bank {
    fn range(&self, address: u16, n: usize) -> Result<std::ops::Range<usize>, Exception> {
        let a = usize::from(address);
        if a + n <= self.regs.len() {
            Ok(a..a + n)
        } else {
            Err(Exception::IllegalDataAddress)
        }
    }

    fn answer(&mut self, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize> {
        let mut words = [0u16; MAX_WRITE];
        let request = match decode_request(pdu, &mut words) {
            Ok(r) => r,
            Err(luxnode::modbus::pdu::DecodeError::Empty) => return None,
            Err(luxnode::modbus::pdu::DecodeError::Exception { function, code }) => {
                return Some(encode_exception(function, code, out));
            }
        };
        let fc = request.function();
        let r = match request {
            Request::ReadHolding { address, quantity }
            | Request::ReadInput { address, quantity } => self
                .range(address, usize::from(quantity))
                .map(|r| encode_registers(fc, &self.regs[r], out)),
            Request::WriteSingle { address, value } => self.range(address, 1).map(|r| {
                self.regs[r.start] = value;
                // the log of writes a HIL scenario reads (a controller's arc levels)
                println!("write {address}: [{value}]");
                encode_write_echo(fc, address, value, out)
            }),
            Request::WriteMultiple { address, values } => {
                self.range(address, values.len()).map(|r| {
                    self.regs[r].copy_from_slice(values);
                    println!("write {address}: {values:?}");
                    encode_write_echo(fc, address, values.len() as u16, out)
                })
            }
            Request::ReadDeviceId { .. } => Err(Exception::IllegalFunction),
        };
        Some(r.unwrap_or_else(|code| encode_exception(fc, code, out)))
    }
}

impl PduHandler for Bank {
    fn handle_pdu(&mut self, _unit: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize> {
        self.answer(pdu, out)
    }
}

fn parse_set(items: &[String], bank: &mut Bank) -> Result<()> {
    for item in items.iter().filter(|s| !s.is_empty()) {
        let (a, v) = item
            .split_once('=')
            .with_context(|| format!("--set {item:?}: expected ADDR=VALUE"))?;
        let a: u16 = a
            .trim()
            .parse()
            .with_context(|| format!("--set {item:?}: address"))?;
        let v: u16 = v
            .trim()
            .parse()
            .with_context(|| format!("--set {item:?}: value"))?;
        let Some(slot) = bank.regs.get_mut(usize::from(a)) else {
            bail!(
                "--set {item:?}: address {a} is past the bank ({} registers)",
                bank.regs.len()
            );
        };
        *slot = v;
    }
    Ok(())
}

/// (luminaires, base, stride, period).
fn parse_demo(s: &str) -> Result<(usize, u16, u16, Duration)> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [l, base, stride, period] = parts[..] else {
        bail!("--demo {s:?}: expected L,BASE,STRIDE,PERIOD_MS");
    };
    let period: u64 = period.parse().context("--demo period")?;
    if period < 10 {
        bail!("--demo period {period} ms is below 10 ms");
    }
    Ok((
        l.parse().context("--demo L")?,
        base.parse().context("--demo BASE")?,
        stride.parse().context("--demo STRIDE")?,
        Duration::from_millis(period),
    ))
}

/// The demo sequence: all full, all at 50 % (229), a row pattern, one luminaire at 0.1 %, off.
fn demo_level(step: usize, j: usize) -> u16 {
    match step % 5 {
        0 => 254,
        1 => 229,
        2 => [254, 0][j % 2],
        3 => [1, 170, 229, 254][j % 4],
        _ => 0,
    }
}

fn main() -> Result<()> {
    let args = Args::parse();
    if args.registers == 0 {
        bail!("--registers must be at least 1");
    }
    let mut bank = Bank {
        regs: vec![0; usize::from(args.registers)],
    };
    parse_set(&args.set, &mut bank)?;
    let demo = args.demo.as_deref().map(parse_demo).transpose()?;
    if let Some((l, base, stride, _)) = demo {
        let last = usize::from(base) + usize::from(stride) * l.saturating_sub(1);
        if l == 0 || last >= bank.regs.len() {
            bail!(
                "--demo: luminaire registers up to {last} do not fit {} registers",
                bank.regs.len()
            );
        }
    }
    let bank = Arc::new(Mutex::new(bank));
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    rt.block_on(async move {
        let listener = tcp::bind(args.bind).await?;
        println!("modbus tcp listening on {}", listener.local_addr()?);
        use std::io::Write as _;
        std::io::stdout().flush()?;
        let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
        let server = tokio::spawn(tcp::serve(
            listener,
            bank.clone(),
            TcpOptions::default(),
            Arc::new(TcpCounters::default()),
            stop_rx,
            None,
        ));
        if let Some((l, base, stride, period)) = demo {
            let bank = bank.clone();
            tokio::spawn(async move {
                let mut tick = tokio::time::interval(period);
                for step in 0.. {
                    tick.tick().await;
                    let mut b = lock(&bank);
                    for j in 0..l {
                        let a = usize::from(base) + usize::from(stride) * j;
                        if let Some(r) = b.regs.get_mut(a) {
                            *r = demo_level(step, j);
                        }
                    }
                }
            });
        }
        match args.seconds {
            Some(s) if s.is_finite() && s > 0.0 => {
                tokio::time::sleep(Duration::from_secs_f64(s)).await
            }
            _ => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
        let _ = stop_tx.send(true);
        let _ = server.await;
        Ok(())
    })
}
