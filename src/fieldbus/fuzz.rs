//! A mutational fuzzer for the wire format and the register map (deterministic for a seed).
//!
//! Seeds are valid requests of every supported function (and some unsupported ones); each
//! round mutates one (bit flips, byte overwrites with boundary values, truncation, extension,
//! random bytes) and feeds it to the register map, and, framed for RTU with the CRC either
//! fixed up (so the mutation reaches the PDU decoder) or left stale, to the RTU frame handler.
//! Every answer must be well formed:
//!
//! * an exception is `fc | 0x80` followed by a code in 0x01..=0x03, for the request's function;
//! * a read answer has the request's function, a byte count of 2 × quantity and that many bytes;
//! * a write answer echoes address and value/quantity;
//! * an RTU frame with a stale CRC, another unit id or unit 0 is never answered.
//!
//! `luxnode bench fuzz` runs it for millions of frames; a test runs a few hundred thousand.

use std::sync::atomic::Ordering;

use super::PduHandler;
use super::rtu::{RtuCounters, handle_frame};
use crate::modbus::frame::{MAX_RTU_FRAME, crc16, decode_rtu, encode_rtu};
use crate::modbus::pdu::{MAX_PDU, function};
use crate::modbus::regmap::{Desk, Quality, RegisterMap};
use crate::rng::SplitMix64;

/// Outcome counts.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct FuzzReport {
    /// Frames tried.
    pub frames: u64,
    /// Normal answers.
    pub answers: u64,
    /// Exception answers by code (index 1..=3).
    pub exceptions: [u64; 4],
    /// No answer (empty PDU).
    pub silent: u64,
    /// RTU frames answered.
    pub rtu_answered: u64,
    /// RTU frames not answered (other unit, broadcast, bad CRC, too short).
    pub rtu_silent: u64,
}

/// An invariant broken by one frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("frame {frame:02x?}: {what}")]
pub struct FuzzFailure {
    /// The frame.
    pub frame: Vec<u8>,
    /// What was wrong with the answer.
    pub what: String,
}

struct MapHandler(RegisterMap);

impl PduHandler for MapHandler {
    fn handle_pdu(&mut self, _u: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize> {
        self.0.process(pdu, out).map(|(n, _)| n)
    }
}

/// A register map like a commissioned node's: 8 desks, 8 luminaires, a NaN and a huge value.
pub fn sample_map() -> RegisterMap {
    let mut m = RegisterMap::default();
    for k in 0..8u32 {
        let lux = match k {
            3 => f64::NAN,
            5 => 1e9,
            _ => 100.0 * f64::from(k) + 0.25,
        };
        let _ = m.desks.push(Desk {
            id: k + 1,
            lux,
            quality: Quality::Ok,
            model_rel_uncertainty: if k == 2 { f64::NAN } else { 0.05 },
        });
        let _ = m.luminaire_ids.push(k + 1);
        let _ = m.arc.push(254);
    }
    m
}

fn seeds() -> Vec<Vec<u8>> {
    vec![
        vec![0x03, 0x00, 0x00, 0x00, 0x0E],
        vec![0x04, 0x00, 0x64, 0x00, 0x10],
        vec![0x04, 0x01, 0x2C, 0x00, 0x08],
        vec![0x03, 0x03, 0xE8, 0x00, 0x08],
        vec![0x06, 0x03, 0xE8, 0x00, 0xFE],
        vec![0x06, 0x07, 0xD0, 0x00, 0x01],
        vec![0x10, 0x03, 0xE8, 0x00, 0x02, 0x04, 0x00, 0xFE, 0x00, 0x00],
        vec![0x2B, 0x0E, 0x01, 0x00],
        vec![0x2B, 0x0E, 0x04, 0x05],
        vec![0x01, 0x00, 0x00, 0x00, 0x01],
        vec![
            0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x02, 0x00, 0x00,
        ],
    ]
}

fn mutate(rng: &mut SplitMix64, seed: &[u8]) -> Vec<u8> {
    let mut f = seed.to_vec();
    let rounds = 1 + u64::from(rng.next_u64().is_multiple_of(3));
    for _ in 0..rounds {
        let r = rng.next_u64();
        let pos = if f.is_empty() {
            0
        } else {
            (r >> 8) as usize % f.len()
        };
        match r % 16 {
            0..=3 if !f.is_empty() => f[pos] ^= 1 << ((r >> 40) % 8),
            4..=6 if !f.is_empty() => {
                const EDGE: [u8; 8] = [0x00, 0x01, 0x7D, 0x7E, 0x7F, 0x80, 0xFE, 0xFF];
                f[pos] = EDGE[((r >> 40) % 8) as usize];
            }
            7 => f.truncate(pos),
            8 | 9 => {
                let n = (r >> 40) % 8;
                for k in 0..n {
                    f.push((r >> (k * 3)) as u8);
                }
            }
            10 => {
                let n = ((r >> 40) % 260) as usize;
                f = (0..n).map(|_| rng.next_u64() as u8).collect();
            }
            11..=13 if f.len() >= 5 => {
                // quantity / byte count to boundary values
                let q: [u16; 6] = [0, 1, 123, 124, 125, 126];
                let v = q[((r >> 40) % 6) as usize].to_be_bytes();
                f[3] = v[0];
                f[4] = v[1];
            }
            _ => {
                if !f.is_empty() {
                    f[pos] = (r >> 48) as u8;
                }
            }
        }
    }
    f.truncate(MAX_PDU + 8);
    f
}

fn fail(frame: &[u8], what: impl Into<String>) -> FuzzFailure {
    FuzzFailure {
        frame: frame.to_vec(),
        what: what.into(),
    }
}

/// Checks a response PDU against its request.
fn check_answer(req: &[u8], resp: &[u8], report: &mut FuzzReport) -> Result<(), FuzzFailure> {
    let Some(&fc) = req.first() else {
        return Err(fail(req, "answered an empty PDU"));
    };
    let Some(&rfc) = resp.first() else {
        return Err(fail(req, "empty answer"));
    };
    if rfc == fc | 0x80 {
        let code = resp.get(1).copied().unwrap_or(0);
        if resp.len() != 2 || !(1..=3).contains(&code) {
            return Err(fail(req, format!("malformed exception {resp:02x?}")));
        }
        report.exceptions[usize::from(code)] += 1;
        return Ok(());
    }
    if rfc != fc {
        return Err(fail(req, format!("function {rfc:#04x} answers {fc:#04x}")));
    }
    report.answers += 1;
    match fc {
        function::READ_HOLDING | function::READ_INPUT => {
            let q = usize::from(u16::from_be_bytes([req[3], req[4]]));
            if resp.len() != 2 + 2 * q || usize::from(resp[1]) != 2 * q {
                return Err(fail(req, format!("read answer of {} bytes", resp.len())));
            }
        }
        function::WRITE_SINGLE | function::WRITE_MULTIPLE => {
            if resp.len() != 5 || resp[1..5] != req[1..5] {
                return Err(fail(req, format!("write answer {resp:02x?}")));
            }
        }
        function::MEI => {
            if resp.len() < 7 || resp[1] != 0x0E {
                return Err(fail(req, format!("device id answer {resp:02x?}")));
            }
        }
        _ => return Err(fail(req, "answered an unsupported function")),
    }
    Ok(())
}

/// The system under test: a register map, reached directly and through the RTU handler.
pub struct Fuzzer {
    handler: MapHandler,
    counters: RtuCounters,
    /// Outcomes so far.
    pub report: FuzzReport,
}

impl Default for Fuzzer {
    fn default() -> Self {
        Self {
            handler: MapHandler(sample_map()),
            counters: RtuCounters::default(),
            report: FuzzReport::default(),
        }
    }
}

impl Fuzzer {
    /// Feeds one PDU (any bytes) to the register map, then as an RTU frame for `unit` (our unit
    /// is 7) with a correct CRC or a stale one; checks every answer.
    pub fn feed(&mut self, pdu: &[u8], unit: u8, fix_crc: bool) -> Result<(), FuzzFailure> {
        let mut out = [0u8; MAX_PDU];
        let report = &mut self.report;
        report.frames += 1;
        let pdu_in = &pdu[..pdu.len().min(MAX_PDU)];
        match self.handler.handle_pdu(1, pdu_in, &mut out) {
            None if pdu_in.is_empty() => report.silent += 1,
            None => return Err(fail(pdu_in, "no answer to a non-empty PDU")),
            Some(n) => {
                if n == 0 || n > MAX_PDU {
                    return Err(fail(pdu_in, format!("answer length {n}")));
                }
                check_answer(pdu_in, &out[..n], report)?;
            }
        }
        let mut rtu = [0u8; MAX_RTU_FRAME + 8];
        let n = if fix_crc {
            let mut buf = [0u8; MAX_RTU_FRAME];
            let n = encode_rtu(unit, pdu_in, &mut buf);
            rtu[..n].copy_from_slice(&buf[..n]);
            n
        } else {
            let body = &pdu[..pdu.len().min(rtu.len() - 3)];
            let n = body.len() + 3;
            rtu[0] = unit;
            rtu[1..n - 2].copy_from_slice(body);
            let c = crc16(&rtu[..n - 2]) ^ 0x5A5A; // stale
            rtu[n - 2..n].copy_from_slice(&c.to_le_bytes());
            n
        };
        let frame = &rtu[..n];
        let mut reply = [0u8; MAX_RTU_FRAME];
        let source = crate::modbus::access::Source::Internal;
        match handle_frame(
            &mut self.handler,
            &source,
            7,
            frame,
            &self.counters,
            &mut reply,
        ) {
            None => report.rtu_silent += 1,
            Some(m) => {
                report.rtu_answered += 1;
                if unit != 7 || !fix_crc {
                    return Err(fail(frame, "RTU answered a frame not for it"));
                }
                let (u, resp) = decode_rtu(&reply[..m])
                    .map_err(|e| fail(frame, format!("RTU reply does not decode: {e:?}")))?;
                if u != 7 {
                    return Err(fail(frame, "RTU reply from another unit id"));
                }
                check_answer(pdu_in, resp, &mut FuzzReport::default())?;
            }
        }
        Ok(())
    }
}

/// Runs `frames` mutated frames from `seed`.
pub fn run(frames: u64, seed: u64) -> Result<FuzzReport, FuzzFailure> {
    let mut rng = SplitMix64::new(seed);
    let seeds = seeds();
    let mut fuzzer = Fuzzer::default();
    for _ in 0..frames {
        let seed_pdu = &seeds[(rng.next_u64() % seeds.len() as u64) as usize];
        let pdu = mutate(&mut rng, seed_pdu);
        let r = rng.next_u64();
        let unit = [7u8, 7, 7, 0, 8][(r % 5) as usize];
        fuzzer.feed(&pdu, unit, r & 0x100 != 0)?;
    }
    let _ = fuzzer.counters.answered.load(Ordering::Relaxed);
    Ok(fuzzer.report)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_short_run_is_clean_and_deterministic() {
        let a = super::run(20_000, 1).unwrap();
        let b = super::run(20_000, 1).unwrap();
        assert_eq!(a, b);
        // every outcome class is reached
        assert!(
            a.answers > 1000 && a.exceptions[1] > 100 && a.exceptions[2] > 100,
            "{a:?}"
        );
        assert!(
            a.exceptions[3] > 100 && a.rtu_answered > 1000 && a.rtu_silent > 1000,
            "{a:?}"
        );
    }
}
