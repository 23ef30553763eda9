//! Modbus RTU server on a serial line (RS-485 on the boards, a pty in tests).
//!
//! Framing by silence, as the specification defines it: a frame ends when the line has been
//! quiet for 3.5 character times (1.75 ms above 19200 baud). The port's read timeout is set to
//! that gap, so a read that times out with bytes pending closes a frame. Then:
//!
//! * shorter than 4 bytes, or a bad CRC: discarded, no answer (the master times out, as the
//!   specification wants; a noisy line must not produce replies);
//! * another unit id: ignored;
//! * broadcast (unit 0): writes are executed, nothing is ever answered;
//! * our unit id: handled, answered (an exception if need be).
//!
//! The loop runs on its own thread over any [`std::io::Read`] + [`std::io::Write`] port whose
//! reads time out with `ErrorKind::TimedOut` (serialport's behaviour), so tests drive it with
//! a scripted port.
//!
//! The line is supervised ([`spawn_supervised`]): a read or write error (a pty hang-up, a USB
//! adapter unplugged, a write that times out on a stuck transceiver) is logged, the line state
//! in the health registers turns "down", and the port is reopened with a growing back-off (0.5 s
//! to 10 s) until it opens again, forever. The thread beats the watchdog's liveness check at
//! every frame gap, also while it is reopening.

use std::io::{ErrorKind, Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::PduHandler;
use crate::modbus::access::Source;
use crate::modbus::frame::{BROADCAST, MAX_RTU_FRAME, decode_rtu, encode_rtu, t35_us};
use crate::modbus::pdu::{MAX_PDU, function};
use crate::modbus::regmap::CommHealth;
use crate::node::health::{Beat, Health, state};
use crate::node::health::{CommCounters, low16};
use crate::node::lock;

/// Line settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtuOptions {
    /// Our unit id, 1..=247.
    pub unit_id: u8,
    /// Baud rate.
    pub baud: u32,
    /// Parity.
    pub parity: Parity,
    /// Stop bits, 1 or 2.
    pub stop_bits: u8,
}

/// Parity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parity {
    /// Even (the Modbus default).
    #[default]
    Even,
    /// Odd.
    Odd,
    /// None (then two stop bits, by the specification).
    None,
}

/// Why RTU settings were refused or the serial port did not open.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RtuError {
    /// A unit id that is not a server's.
    #[error("unit id {0} is outside 1..=247 (0 is broadcast, 248..=255 reserved)")]
    UnitId(u8),
    /// A baud rate no line runs at.
    #[error("baud {0} is outside 1200..=1000000")]
    Baud(u32),
    /// Stop bits other than 1 or 2.
    #[error("stop bits {0} is not 1 or 2")]
    StopBits(u8),
    /// The serial device did not open.
    #[error("modbus rtu: cannot open {device}: {reason}")]
    Open {
        /// The device.
        device: String,
        /// The driver's reason.
        reason: String,
    },
}

impl RtuOptions {
    /// Checks the settings.
    pub fn validate(&self) -> Result<(), RtuError> {
        if !(1..=247).contains(&self.unit_id) {
            return Err(RtuError::UnitId(self.unit_id));
        }
        if !(1200..=1_000_000).contains(&self.baud) {
            return Err(RtuError::Baud(self.baud));
        }
        if !(1..=2).contains(&self.stop_bits) {
            return Err(RtuError::StopBits(self.stop_bits));
        }
        Ok(())
    }

    /// Bits per character: start, 8 data, parity, stop.
    pub fn bits_per_char(&self) -> u32 {
        1 + 8 + u32::from(self.parity != Parity::None) + u32::from(self.stop_bits)
    }

    /// The inter-frame silence.
    pub fn t35(&self) -> Duration {
        Duration::from_micros(u64::from(t35_us(self.baud, self.bits_per_char())))
    }
}

/// Counters.
#[derive(Debug, Default)]
pub struct RtuCounters {
    /// Frames answered.
    pub answered: AtomicU64,
    /// Frames for other units.
    pub other_unit: AtomicU64,
    /// Broadcasts executed.
    pub broadcasts: AtomicU64,
    /// Frames discarded (short, CRC, overlong).
    pub discarded: AtomicU64,
    /// Times the line was reopened after an error.
    pub reopens: AtomicU64,
}

impl CommCounters for RtuCounters {
    fn report(&self, into: &mut CommHealth) {
        let r = |a: &AtomicU64| low16(a.load(Ordering::Relaxed));
        into.rtu_reopens = r(&self.reopens);
        into.rtu_answered = r(&self.answered);
        into.rtu_discarded = r(&self.discarded);
    }
}

/// What to do with one received frame; the reply bytes are in `reply[..n]`.
pub fn handle_frame<H: PduHandler + ?Sized>(
    handler: &mut H,
    source: &Source,
    unit_id: u8,
    frame: &[u8],
    counters: &RtuCounters,
    reply: &mut [u8; MAX_RTU_FRAME],
) -> Option<usize> {
    let Ok((unit, pdu)) = decode_rtu(frame) else {
        counters.discarded.fetch_add(1, Ordering::Relaxed);
        return None;
    };
    if unit == BROADCAST {
        // only writes make sense broadcast; reads are not executed, and nothing is answered
        let is_write = matches!(
            pdu.first(),
            Some(&function::WRITE_SINGLE) | Some(&function::WRITE_MULTIPLE)
        );
        if is_write {
            let mut out = [0u8; MAX_PDU];
            let _ = handler.handle_from(source, unit, pdu, &mut out);
            counters.broadcasts.fetch_add(1, Ordering::Relaxed);
        }
        return None;
    }
    if unit != unit_id {
        counters.other_unit.fetch_add(1, Ordering::Relaxed);
        return None;
    }
    let mut out = [0u8; MAX_PDU];
    let n = handler.handle_from(source, unit, pdu, &mut out)?;
    counters.answered.fetch_add(1, Ordering::Relaxed);
    Some(encode_rtu(unit, &out[..n], reply))
}

/// Serves `handler` on `port` until `stop` is set. The port's read timeout must be the frame
/// gap ([`RtuOptions::t35`]); any read error other than a timeout ends the loop with it.
pub fn serve<P: Read + Write, H: PduHandler + ?Sized>(
    port: &mut P,
    handler: &Mutex<H>,
    source: &Source,
    unit_id: u8,
    counters: &RtuCounters,
    stop: &AtomicBool,
    beat: Option<&Beat>,
) -> std::io::Result<()> {
    let mut frame = [0u8; MAX_RTU_FRAME];
    let mut len = 0usize;
    let mut overlong = false;
    let mut buf = [0u8; 64];
    let mut reply = [0u8; MAX_RTU_FRAME];
    while !stop.load(Ordering::Relaxed) {
        if let Some(b) = beat {
            b.beat();
        }
        let silence = match port.read(&mut buf) {
            Ok(0) => {
                // EOF on a pty whose other side is gone; behave as silence, but do not spin
                std::thread::sleep(Duration::from_millis(5));
                true
            }
            Ok(n) => {
                for &b in &buf[..n] {
                    if len < frame.len() {
                        frame[len] = b;
                        len += 1;
                    } else {
                        overlong = true;
                    }
                }
                false
            }
            Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => true,
            Err(e) if e.kind() == ErrorKind::Interrupted => false,
            Err(e) => return Err(e),
        };
        if silence {
            let frame = &frame[..len];
            end_of_frame(
                port, handler, source, unit_id, counters, frame, overlong, &mut reply,
            )?;
            (len, overlong) = (0, false);
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn end_of_frame<P: Write, H: PduHandler + ?Sized>(
    port: &mut P,
    handler: &Mutex<H>,
    source: &Source,
    unit_id: u8,
    counters: &RtuCounters,
    frame: &[u8],
    overlong: bool,
    reply: &mut [u8; MAX_RTU_FRAME],
) -> std::io::Result<()> {
    if frame.is_empty() {
        return Ok(());
    }
    if overlong {
        counters.discarded.fetch_add(1, Ordering::Relaxed);
        return Ok(());
    }
    let answer = {
        let mut h = lock(handler);
        handle_frame(&mut *h, source, unit_id, frame, counters, reply)
    };
    if let Some(n) = answer {
        port.write_all(&reply[..n])?;
        port.flush()?;
    }
    Ok(())
}

/// Opens a serial port for RTU with `options` (8 data bits, parity, stop bits, the t3.5 read
/// timeout).
pub fn open_port(
    device: &str,
    options: &RtuOptions,
) -> Result<Box<dyn serialport::SerialPort>, RtuError> {
    options.validate()?;
    let parity = match options.parity {
        Parity::Even => serialport::Parity::Even,
        Parity::Odd => serialport::Parity::Odd,
        Parity::None => serialport::Parity::None,
    };
    let stop = if options.stop_bits == 2 {
        serialport::StopBits::Two
    } else {
        serialport::StopBits::One
    };
    serialport::new(device, options.baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(parity)
        .stop_bits(stop)
        .flow_control(serialport::FlowControl::None)
        .timeout(options.t35())
        .open()
        .map_err(|e| RtuError::Open {
            device: device.to_owned(),
            reason: e.to_string(),
        })
}

/// Runs the RTU server on `device` on its own thread until `stop` is set, reopening the line
/// after any error (see the module doc). `port` is the already opened line, if any (the caller
/// opens it first to fail fast on a wrong device at start). The line's state and reopen count
/// go to `health`; `beat` is beaten at every frame gap and every reopening attempt.
pub fn spawn_supervised<H: PduHandler + 'static>(
    device: String,
    options: RtuOptions,
    port: Option<Box<dyn serialport::SerialPort>>,
    handler: Arc<Mutex<H>>,
    health: Arc<Health>,
    stop: Arc<AtomicBool>,
    beat: Beat,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let source = Source::Rtu(device.clone());
        let counters = health.counters::<RtuCounters>();
        let mut port = port;
        let mut backoff = Duration::from_millis(500);
        while !stop.load(Ordering::Relaxed) {
            beat.beat();
            let mut p = match port.take() {
                Some(p) => p,
                None => match open_port(&device, &options) {
                    Ok(p) => {
                        counters.reopens.fetch_add(1, Ordering::Relaxed);
                        tracing::info!("modbus rtu {device}: line reopened");
                        p
                    }
                    Err(e) => {
                        tracing::debug!("modbus rtu {device}: {e}; retrying in {backoff:?}");
                        sleep_unless(&stop, &beat, backoff);
                        backoff = (backoff * 2).min(Duration::from_secs(10));
                        continue;
                    }
                },
            };
            health.rtu_state.store(state::UP, Ordering::Relaxed);
            backoff = Duration::from_millis(500);
            let r = serve(
                &mut p,
                &*handler,
                &source,
                options.unit_id,
                &counters,
                &stop,
                Some(&beat),
            );
            drop(p);
            if let Err(e) = r {
                health.rtu_state.store(state::DOWN, Ordering::Relaxed);
                tracing::error!(
                    "modbus rtu {device}: line failed ({e}); reopening (status: communication \
                     not ok, input 43 = 2)"
                );
                sleep_unless(&stop, &beat, backoff);
            }
        }
        beat.retire();
    })
}

/// Sleeps `d` in short steps, beating, unless `stop` is set.
fn sleep_unless(stop: &AtomicBool, beat: &Beat, d: Duration) {
    let step = Duration::from_millis(100);
    let mut left = d;
    while !stop.load(Ordering::Relaxed) && !left.is_zero() {
        beat.beat();
        let s = left.min(step);
        std::thread::sleep(s);
        left -= s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    /// A handler that echoes register reads as their address and counts writes.
    #[derive(Default)]
    struct Probe {
        writes: usize,
    }

    impl PduHandler for Probe {
        fn handle_pdu(&mut self, _u: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize> {
            if pdu.first() == Some(&6) {
                self.writes += 1;
            }
            out[..pdu.len()].copy_from_slice(pdu);
            Some(pdu.len())
        }
    }

    /// A scripted port: each chunk is one read's bytes; `None` is a silence (timeout).
    struct Script {
        reads: VecDeque<Option<Vec<u8>>>,
        written: Vec<Vec<u8>>,
        stop: Arc<AtomicBool>,
    }

    impl Read for Script {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            match self.reads.pop_front() {
                Some(Some(b)) => {
                    buf[..b.len()].copy_from_slice(&b);
                    Ok(b.len())
                }
                Some(None) => Err(ErrorKind::TimedOut.into()),
                None => {
                    self.stop.store(true, Ordering::Relaxed);
                    Err(ErrorKind::TimedOut.into())
                }
            }
        }
    }

    impl Write for Script {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.written.push(buf.to_vec());
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn rtu(unit: u8, pdu: &[u8]) -> Vec<u8> {
        let mut out = [0u8; MAX_RTU_FRAME];
        let n = encode_rtu(unit, pdu, &mut out);
        out[..n].to_vec()
    }

    #[test]
    fn answers_own_unit_only_and_never_broadcasts() {
        let read = [4u8, 0, 0, 0, 1];
        let write = [6u8, 3, 0xE8, 0, 1];
        let mine = rtu(7, &read);
        let mut bad_crc = mine.clone();
        *bad_crc.last_mut().unwrap() ^= 1;
        let stop = Arc::new(AtomicBool::new(false));
        let mut port = Script {
            reads: VecDeque::from(vec![
                // our frame split across reads, then the gap
                Some(mine[..3].to_vec()),
                Some(mine[3..].to_vec()),
                None,
                Some(rtu(8, &read)),
                None,
                Some(rtu(0, &write)),
                None,
                Some(rtu(0, &read)),
                None,
                Some(bad_crc),
                None,
                Some(vec![7, 4]),
                None,
                Some(vec![0xAA; 60]),
                Some(vec![0xAA; 60]),
                Some(vec![0xAA; 60]),
                Some(vec![0xAA; 60]),
                Some(vec![0xAA; 60]),
                None,
            ]),
            written: vec![],
            stop: stop.clone(),
        };
        let probe = Mutex::new(Probe::default());
        let counters = RtuCounters::default();
        let src = Source::Rtu("test".into());
        serve(&mut port, &probe, &src, 7, &counters, &stop, None).unwrap();
        assert_eq!(port.written, vec![mine]);
        assert_eq!(lock(&probe).writes, 1, "the broadcast write is executed");
        assert_eq!(counters.answered.load(Ordering::Relaxed), 1);
        assert_eq!(counters.other_unit.load(Ordering::Relaxed), 1);
        assert_eq!(counters.broadcasts.load(Ordering::Relaxed), 1);
        assert_eq!(counters.discarded.load(Ordering::Relaxed), 3);
    }

    #[test]
    fn two_frames_without_a_gap_are_one_bad_frame() {
        let f = rtu(7, &[4, 0, 0, 0, 1]);
        let stop = Arc::new(AtomicBool::new(false));
        let mut port = Script {
            reads: VecDeque::from(vec![Some([f.clone(), f].concat()), None]),
            written: vec![],
            stop: stop.clone(),
        };
        let probe = Mutex::new(Probe::default());
        let counters = RtuCounters::default();
        let src = Source::Rtu("test".into());
        serve(&mut port, &probe, &src, 7, &counters, &stop, None).unwrap();
        assert!(port.written.is_empty());
        assert_eq!(counters.discarded.load(Ordering::Relaxed), 1);
    }

    #[test]
    fn options_are_validated() {
        let o = RtuOptions {
            unit_id: 1,
            baud: 19200,
            parity: Parity::Even,
            stop_bits: 1,
        };
        assert!(o.validate().is_ok());
        assert_eq!(o.bits_per_char(), 11);
        // 3.5 chars × 11 bits / 19200 baud = 2.005 ms
        assert!((o.t35().as_secs_f64() - 3.5 * 11.0 / 19200.0).abs() < 2e-6);
        for bad in [
            RtuOptions { unit_id: 0, ..o },
            RtuOptions { unit_id: 248, ..o },
            RtuOptions { baud: 0, ..o },
            RtuOptions { stop_bits: 3, ..o },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
