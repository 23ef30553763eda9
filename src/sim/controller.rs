//! The simulated luminaire controller of the sim board: it steps through dimming states by
//! writing the arc-level holding registers over Modbus TCP, exactly as the installed controller
//! or a BMS would, reads the desk lux back the same way, and prints the live table.

use std::io::Write;
use std::net::SocketAddr;
use std::time::Duration;

use tokio_modbus::client::{Reader, Writer};

use crate::modbus::regmap::addr;

/// Why the controller stopped.
#[derive(Debug, thiserror::Error)]
pub enum ControllerError {
    /// The connection to the node failed.
    #[error("controller: {0}")]
    Link(#[from] tokio_modbus::Error),
    /// The node answered with an exception.
    #[error("controller: the node answered exception {0:?}")]
    Exception(#[from] tokio_modbus::ExceptionCode),
    /// The node's answer is not what the register map says.
    #[error("controller: {0}")]
    Answer(String),
    /// Connecting or writing the table failed.
    #[error("controller: {0}")]
    Io(#[from] std::io::Error),
}

/// The controller's settings.
#[derive(Debug, Clone)]
pub struct SimController {
    /// Time per dimming state.
    pub period: Duration,
    /// Passes through the sequence.
    pub cycles: usize,
    /// Keep serving after the last pass (otherwise the daemon stops).
    pub forever: bool,
}

/// Arc level of luminaire j of L in a state.
pub type StateFn = fn(usize, usize) -> u8;

/// The states of one pass: (name, arc level of luminaire j of L).
pub fn demo_states() -> Vec<(&'static str, StateFn)> {
    vec![
        ("all 100 %", |_, _| 254),
        ("all 50 %", |_, _| 229),
        ("all 10 %", |_, _| 170),
        ("first half", |j, l| if j < l.div_ceil(2) { 254 } else { 0 }),
        (
            "second half",
            |j, l| if j >= l.div_ceil(2) { 254 } else { 0 },
        ),
        ("every other", |j, _| if j % 2 == 0 { 254 } else { 0 }),
        ("ramp", |j, l| {
            (1 + 253 * j / l.max(2).saturating_sub(1).max(1)).min(254) as u8
        }),
        ("all 0.1 %", |_, _| 1),
        ("off", |_, _| 0),
    ]
}

fn f32_at(regs: &[u16], k: usize) -> f64 {
    let bits = (u32::from(regs[2 * k]) << 16) | u32::from(regs[2 * k + 1]);
    f64::from(f32::from_bits(bits))
}

impl SimController {
    /// Runs the passes against the node's Modbus TCP server at `addr`, writing the live table
    /// to `out`.
    pub async fn run(
        &self,
        addr: SocketAddr,
        out: &mut (dyn Write + Send),
    ) -> Result<(), ControllerError> {
        let mut c = tokio_modbus::client::tcp::connect(addr).await?;
        let core = c.read_input_registers(0, 4).await??;
        if core.len() < 3 {
            return Err(ControllerError::Answer(format!(
                "{} core registers for 4",
                core.len()
            )));
        }
        let (desks, lums) = (usize::from(core[1]), usize::from(core[2]));
        let ids = if desks > 0 {
            c.read_input_registers(addr::DESK_ID, desks as u16)
                .await??
        } else {
            Vec::new()
        };
        let states = demo_states();
        let mut header = format!("{:<12} {:>6}", "state", "step");
        for id in &ids {
            header.push_str(&format!(" {:>9}", format!("desk {id}")));
        }
        writeln!(
            out,
            "\nlive desk lux (read over Modbus TCP from {addr}; lx)\n{header}"
        )?;
        writeln!(out, "{}", "-".repeat(header.len()))?;
        let mut step = 0usize;
        for _ in 0..self.cycles.max(1) {
            for (name, level) in &states {
                step += 1;
                let arcs: Vec<u16> = (0..lums).map(|j| u16::from(level(j, lums))).collect();
                for (chunk_no, chunk) in arcs.chunks(123).enumerate() {
                    let a = addr::ARC_LEVEL + (chunk_no * 123) as u16;
                    c.write_multiple_registers(a, chunk).await??;
                }
                let lux = c
                    .read_input_registers(addr::DESK_FLOAT, (2 * desks) as u16)
                    .await??;
                let quality = c
                    .read_input_registers(addr::DESK_QUALITY, desks as u16)
                    .await??;
                if lux.len() < 2 * quality.len() {
                    return Err(ControllerError::Answer(format!(
                        "{} lux registers for {} desks",
                        lux.len(),
                        quality.len()
                    )));
                }
                let mut row = format!("{name:<12} {step:>6}");
                for (k, q) in quality.iter().enumerate() {
                    let mark = match q {
                        0 => ' ',
                        1 => 's',
                        2 => 'v',
                        _ => 'e',
                    };
                    row.push_str(&format!(" {:>8.0}{mark}", f32_at(&lux, k)));
                }
                writeln!(out, "{row}")?;
                out.flush()?;
                tokio::time::sleep(self.period).await;
            }
        }
        writeln!(
            out,
            "(marks: v = desk outside the camera's view, e = estimated surroundings, s = stale)"
        )?;
        Ok(())
    }
}
