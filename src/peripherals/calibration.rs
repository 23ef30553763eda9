//! The per-unit camera calibration record, kept in the camera module's EEPROM so that a
//! replaced module brings its own calibration. `no_std`, fixed layout, versioned, CRC-checked,
//! in two copies (A/B) so a power cut during an update leaves the previous record readable.
//!
//! ```text
//! copy A at 0, copy B at half the EEPROM (2048 on a 24C32)
//! | magic "LXCC" | version u16 | length u16 | generation u32 | body (length bytes) | CRC-32 u32 |
//! body, version 2, little-endian:
//! | serial [u8; 16] | width u32 | height u32 | fx fy cx cy k1 k2 f64 | rotation 9 × f64 (row-major)
//! | translation_m 3 × f64 | calibration_cd_m2_s f64 | lens u8 | kb 4 × f64 |
//! lens: 0 pinhole (OpenCV radial k1, k2; kb zero), 1 Kannala-Brandt fisheye (k1 = k2 = 0,
//! r = θ (1 + kb1 θ² + kb2 θ⁴ + kb3 θ⁶ + kb4 θ⁸))
//! ```
//!
//! Version 1 (written by earlier builds) is the same body without `lens` and `kb`: a pinhole.
//! It still reads; updates write version 2.
//!
//! The CRC (IEEE, as the flash image's) covers everything before it. A copy is valid when the
//! magic, the version, the length and the CRC agree and every number is in range (finite,
//! focal lengths > 0, size 1..=8192, a luminance calibration > 0); the valid copy with the
//! highest generation wins. An update writes the other copy with the next generation, then
//! reads it back.

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;

use super::at24::{self, At24};
use crate::store::Crc32;

/// Record magic.
pub const MAGIC: [u8; 4] = *b"LXCC";
/// Layout version of the body written.
pub const VERSION: u16 = 2;
/// Body length of version 1 (pinhole only).
pub const BODY_LEN_V1: usize = 16 + 4 + 4 + 8 * (6 + 9 + 3 + 1);
/// Body length of version 2.
pub const BODY_LEN: usize = BODY_LEN_V1 + 1 + 8 * 4;
/// Header length (magic, version, length, generation).
pub const HEAD_LEN: usize = 12;
/// Whole record (version 2; a version 1 record is shorter and read from the same place).
pub const RECORD_LEN: usize = HEAD_LEN + BODY_LEN + 4;
/// A fisheye coefficient beyond this is refused (a calibration's are below 1).
pub const MAX_KB: f64 = 10.0;

/// The colour camera's per-unit calibration: its intrinsics, its pose relative to the ToF
/// camera (`X_colour = rotation · X_tof + translation_m`), and its luminance calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraCalibration {
    /// Module serial number (ASCII, zero padded).
    pub serial: [u8; 16],
    /// Image width the intrinsics are for, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length x, pixels.
    pub fx: f64,
    /// Focal length y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Radial distortion k1 (OpenCV).
    pub k1: f64,
    /// Radial distortion k2.
    pub k2: f64,
    /// Rotation ToF → colour, row-major.
    pub rotation: [[f64; 3]; 3],
    /// Translation ToF → colour, m.
    pub translation_m: [f64; 3],
    /// cd/m² at full scale for a 1 s exposure.
    pub calibration_cd_m2_s: f64,
    /// A Kannala-Brandt fisheye's k1..k4 (then `k1 = k2 = 0` above); `None`: a pinhole.
    pub fisheye_k: Option<[f64; 4]>,
}

/// Why a copy is not usable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordError {
    /// All 0xFF: never written.
    Blank,
    /// Not a calibration record.
    BadMagic,
    /// Another layout version.
    Version(u16),
    /// The length field does not match the version.
    Length(u16),
    /// The checksum fails (torn write, flipped bits).
    Crc {
        /// Stored.
        stored: u32,
        /// Computed.
        actual: u32,
    },
    /// A number is out of range.
    Range(&'static str),
}

impl core::fmt::Display for RecordError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RecordError::Blank => f.write_str("blank (never written)"),
            RecordError::BadMagic => f.write_str("not a calibration record (bad magic)"),
            RecordError::Version(v) => {
                write!(f, "record version {v}, this build reads {VERSION}")
            }
            RecordError::Length(n) => write!(
                f,
                "length field {n}, version 1 has {BODY_LEN_V1}, version 2 {BODY_LEN}"
            ),
            RecordError::Crc { stored, actual } => write!(
                f,
                "CRC mismatch (stored {stored:#010x}, computed {actual:#010x})"
            ),
            RecordError::Range(what) => write!(f, "{what} is out of range"),
        }
    }
}

struct Writer<'a> {
    b: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, x: &[u8]) {
        self.b[self.at..self.at + x.len()].copy_from_slice(x);
        self.at += x.len();
    }
    fn f64(&mut self, x: f64) {
        self.put(&x.to_le_bytes());
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut o = [0u8; N];
        o.copy_from_slice(&self.b[self.at..self.at + N]);
        self.at += N;
        o
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
}

impl CameraCalibration {
    /// Checks the numbers.
    pub fn validate(&self) -> Result<(), RecordError> {
        let finite = [self.fx, self.fy, self.cx, self.cy, self.k1, self.k2]
            .iter()
            .chain(self.rotation.iter().flatten())
            .chain(self.translation_m.iter())
            .all(|x| x.is_finite());
        if !finite {
            return Err(RecordError::Range("a number (not finite)"));
        }
        if !(1..=8192).contains(&self.width) || !(1..=8192).contains(&self.height) {
            return Err(RecordError::Range("the image size"));
        }
        if !(self.fx > 0.0 && self.fy > 0.0) {
            return Err(RecordError::Range("the focal length"));
        }
        if !(self.calibration_cd_m2_s.is_finite() && self.calibration_cd_m2_s > 0.0) {
            return Err(RecordError::Range("the luminance calibration"));
        }
        if let Some(k) = self.fisheye_k {
            if !k.iter().all(|x| x.is_finite() && x.abs() <= MAX_KB) {
                return Err(RecordError::Range("a fisheye coefficient"));
            }
            if self.k1 != 0.0 || self.k2 != 0.0 {
                return Err(RecordError::Range(
                    "k1, k2 (pinhole distortion on a fisheye)",
                ));
            }
        }
        Ok(())
    }

    /// The serial number as text (up to the first zero).
    pub fn serial_str(&self) -> &str {
        let n = self.serial.iter().position(|&c| c == 0).unwrap_or(16);
        core::str::from_utf8(&self.serial[..n]).unwrap_or("?")
    }

    /// The record's bytes with `generation`.
    pub fn encode(&self, generation: u32) -> [u8; RECORD_LEN] {
        let mut b = [0u8; RECORD_LEN];
        let mut w = Writer { b: &mut b, at: 0 };
        w.put(&MAGIC);
        w.put(&VERSION.to_le_bytes());
        w.put(&(BODY_LEN as u16).to_le_bytes());
        w.put(&generation.to_le_bytes());
        w.put(&self.serial);
        w.put(&self.width.to_le_bytes());
        w.put(&self.height.to_le_bytes());
        for x in [self.fx, self.fy, self.cx, self.cy, self.k1, self.k2] {
            w.f64(x);
        }
        for x in self.rotation.iter().flatten() {
            w.f64(*x);
        }
        for x in self.translation_m {
            w.f64(x);
        }
        w.f64(self.calibration_cd_m2_s);
        w.put(&[u8::from(self.fisheye_k.is_some())]);
        for x in self.fisheye_k.unwrap_or([0.0; 4]) {
            w.f64(x);
        }
        let at = w.at;
        let mut c = Crc32::new();
        c.update(&b[..at]);
        b[at..].copy_from_slice(&c.finish().to_le_bytes());
        b
    }

    /// Decodes and checks one copy: (record, generation).
    pub fn decode(b: &[u8; RECORD_LEN]) -> Result<(Self, u32), RecordError> {
        if b.iter().all(|&x| x == 0xFF) {
            return Err(RecordError::Blank);
        }
        if b[..4] != MAGIC {
            return Err(RecordError::BadMagic);
        }
        let version = u16::from_le_bytes([b[4], b[5]]);
        let body_len = match version {
            1 => BODY_LEN_V1,
            2 => BODY_LEN,
            v => return Err(RecordError::Version(v)),
        };
        let len = u16::from_le_bytes([b[6], b[7]]);
        if usize::from(len) != body_len {
            return Err(RecordError::Length(len));
        }
        let end = HEAD_LEN + body_len;
        let stored = u32::from_le_bytes([b[end], b[end + 1], b[end + 2], b[end + 3]]);
        let mut c = Crc32::new();
        c.update(&b[..end]);
        let actual = c.finish();
        if stored != actual {
            return Err(RecordError::Crc { stored, actual });
        }
        let mut r = Reader { b, at: 8 };
        let generation = r.u32();
        let serial = r.take::<16>();
        let width = r.u32();
        let height = r.u32();
        let [fx, fy, cx, cy, k1, k2] = [r.f64(), r.f64(), r.f64(), r.f64(), r.f64(), r.f64()];
        let mut rotation = [[0.0; 3]; 3];
        for row in &mut rotation {
            for x in row.iter_mut() {
                *x = r.f64();
            }
        }
        let translation_m = [r.f64(), r.f64(), r.f64()];
        let calibration_cd_m2_s = r.f64();
        let fisheye_k = if version >= 2 {
            let lens = r.take::<1>()[0];
            let k = [r.f64(), r.f64(), r.f64(), r.f64()];
            match lens {
                0 if k == [0.0; 4] => None,
                1 => Some(k),
                _ => return Err(RecordError::Range("the lens model")),
            }
        } else {
            None
        };
        let cal = CameraCalibration {
            serial,
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            k1,
            k2,
            rotation,
            translation_m,
            calibration_cd_m2_s,
            fisheye_k,
        };
        cal.validate()?;
        Ok((cal, generation))
    }
}

/// Both copies and the choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stored {
    /// Copy A.
    pub a: Result<(CameraCalibration, u32), RecordError>,
    /// Copy B.
    pub b: Result<(CameraCalibration, u32), RecordError>,
}

impl Stored {
    /// The newest valid copy: (record, generation, which copy: 0 = A, 1 = B).
    pub fn newest(&self) -> Option<(CameraCalibration, u32, usize)> {
        match (&self.a, &self.b) {
            (Ok((ca, ga)), Ok((cb, gb))) => Some(if gb > ga {
                (*cb, *gb, 1)
            } else {
                (*ca, *ga, 0)
            }),
            (Ok((c, g)), _) => Some((*c, *g, 0)),
            (_, Ok((c, g))) => Some((*c, *g, 1)),
            _ => None,
        }
    }
}

/// Offset of copy `k` (0 or 1).
pub fn copy_offset(eeprom_size: usize, k: usize) -> usize {
    k * (eeprom_size / 2)
}

/// Reads both copies.
pub fn read<I: I2c>(eeprom: &mut At24<I>) -> Result<Stored, at24::Error<I::Error>> {
    let mut a = [0u8; RECORD_LEN];
    let mut b = [0u8; RECORD_LEN];
    eeprom.read(copy_offset(eeprom.size(), 0), &mut a)?;
    eeprom.read(copy_offset(eeprom.size(), 1), &mut b)?;
    Ok(Stored {
        a: CameraCalibration::decode(&a),
        b: CameraCalibration::decode(&b),
    })
}

/// Why an update failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UpdateError<E> {
    /// The record is not valid.
    Record(RecordError),
    /// The EEPROM failed.
    Eeprom(at24::Error<E>),
    /// The copy just written does not read back valid.
    ReadBack(RecordError),
}

/// Writes `cal` into the copy that is not the newest, with the next generation, and reads it
/// back; returns (generation, copy).
pub fn write<I: I2c, D: DelayNs + ?Sized>(
    eeprom: &mut At24<I>,
    delay: &mut D,
    cal: &CameraCalibration,
) -> Result<(u32, usize), UpdateError<I::Error>> {
    cal.validate().map_err(UpdateError::Record)?;
    let stored = read(eeprom).map_err(UpdateError::Eeprom)?;
    let (generation, target) = match stored.newest() {
        Some((_, g, k)) => (g.wrapping_add(1).max(1), 1 - k),
        None => (1, 0),
    };
    let bytes = cal.encode(generation);
    let off = copy_offset(eeprom.size(), target);
    eeprom
        .write(delay, off, &bytes)
        .map_err(UpdateError::Eeprom)?;
    let mut back = [0u8; RECORD_LEN];
    eeprom.read(off, &mut back).map_err(UpdateError::Eeprom)?;
    match CameraCalibration::decode(&back) {
        Ok((c, g)) if g == generation && c == *cal => Ok((generation, target)),
        Ok(_) => Err(UpdateError::ReadBack(RecordError::BadMagic)),
        Err(e) => Err(UpdateError::ReadBack(e)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn example() -> CameraCalibration {
        let mut serial = [0u8; 16];
        serial[..8].copy_from_slice(b"CAM-0042");
        CameraCalibration {
            serial,
            width: 640,
            height: 480,
            fx: 554.3,
            fy: 554.1,
            cx: 319.5,
            cy: 239.5,
            k1: -0.05,
            k2: 0.01,
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation_m: [-0.03, 0.0, 0.0],
            calibration_cd_m2_s: 12.0,
            fisheye_k: None,
        }
    }

    /// A version 1 record (earlier builds): the version 2 layout without lens and kb.
    fn encode_v1(c: &CameraCalibration, generation: u32) -> [u8; RECORD_LEN] {
        let v2 = c.encode(generation);
        let mut b = [0u8; RECORD_LEN];
        let end = HEAD_LEN + BODY_LEN_V1;
        b[..end].copy_from_slice(&v2[..end]);
        b[4..6].copy_from_slice(&1u16.to_le_bytes());
        b[6..8].copy_from_slice(&(BODY_LEN_V1 as u16).to_le_bytes());
        let mut crc = Crc32::new();
        crc.update(&b[..end]);
        b[end..end + 4].copy_from_slice(&crc.finish().to_le_bytes());
        b
    }

    #[test]
    fn fisheye_records_round_trip_and_version_1_still_reads() {
        let mut f = example();
        f.k1 = 0.0;
        f.k2 = 0.0;
        f.fisheye_k = Some([0.03, -0.008, 0.0005, 0.0]);
        let b = f.encode(3);
        assert_eq!(CameraCalibration::decode(&b), Ok((f, 3)));
        // a pinhole written by an earlier build (version 1) reads as a pinhole
        let c = example();
        let v1 = encode_v1(&c, 9);
        assert_eq!(CameraCalibration::decode(&v1), Ok((c, 9)));
        // an unknown lens byte, a fisheye with pinhole distortion, absurd coefficients
        let mut x = b;
        x[HEAD_LEN + BODY_LEN_V1] = 7;
        let end = HEAD_LEN + BODY_LEN;
        let mut crc = Crc32::new();
        crc.update(&x[..end]);
        x[end..].copy_from_slice(&crc.finish().to_le_bytes());
        assert_eq!(
            CameraCalibration::decode(&x),
            Err(RecordError::Range("the lens model"))
        );
        let mut g = f;
        g.k1 = 0.1;
        assert!(g.validate().is_err());
        g.k1 = 0.0;
        g.fisheye_k = Some([f64::NAN, 0.0, 0.0, 0.0]);
        assert!(g.validate().is_err());
        g.fisheye_k = Some([1e3, 0.0, 0.0, 0.0]);
        assert!(matches!(
            CameraCalibration::decode(&g.encode(1)),
            Err(RecordError::Range(_))
        ));
    }

    #[test]
    fn record_round_trips_and_every_byte_is_covered() {
        let c = example();
        let b = c.encode(7);
        assert_eq!(b.len(), RECORD_LEN);
        assert_eq!(CameraCalibration::decode(&b), Ok((c, 7)));
        assert_eq!(c.serial_str(), "CAM-0042");
        // any single flipped bit anywhere is caught
        for i in 0..RECORD_LEN {
            let mut x = b;
            x[i] ^= 0x10;
            assert!(CameraCalibration::decode(&x).is_err(), "byte {i}");
        }
        assert_eq!(
            CameraCalibration::decode(&[0xFF; RECORD_LEN]),
            Err(RecordError::Blank)
        );
        let mut v3 = b;
        v3[4] = 3;
        assert_eq!(CameraCalibration::decode(&v3), Err(RecordError::Version(3)));
    }

    #[test]
    fn out_of_range_values_are_refused() {
        for (what, f) in [
            (
                "nan",
                (|c: &mut CameraCalibration| c.fx = f64::NAN) as fn(&mut _),
            ),
            ("zero focal", |c| c.fy = 0.0),
            ("size", |c| c.width = 0),
            ("gain", |c| c.calibration_cd_m2_s = -1.0),
        ] {
            let mut c = example();
            f(&mut c);
            assert!(c.validate().is_err(), "{what}");
            // a record with a valid CRC but bad numbers is refused on decode too
            assert!(
                matches!(
                    CameraCalibration::decode(&c.encode(1)),
                    Err(RecordError::Range(_))
                ),
                "{what}"
            );
        }
    }
}
