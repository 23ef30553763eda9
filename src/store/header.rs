//! The fixed image header: what the boot code reads first, and all it needs to decide whether a
//! slot holds a complete, current image.
//!
//! | offset | size | field |
//! |---:|---:|---|
//! | 0 | 4 | magic `LXIM` |
//! | 4 | 2 | format version (u16 LE) |
//! | 6 | 2 | header length (40) |
//! | 8 | 8 | generation counter (u64 LE): the newest valid image wins |
//! | 16 | 4 | payload length, bytes (u32 LE) |
//! | 20 | 4 | payload CRC-32 (u32 LE) |
//! | 24 | 1 | form-factor storage precision code |
//! | 25 | 11 | reserved, zero |
//! | 36 | 4 | header CRC-32 over bytes 0..36 (u32 LE) |

use super::ImageError;
use super::crc32::crc32;

/// Magic bytes.
pub const MAGIC: [u8; 4] = *b"LXIM";
/// The format version this build reads and writes.
pub const FORMAT_VERSION: u16 = 1;
/// Header length, bytes.
pub const HEADER_LEN: usize = 40;

/// A parsed header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// Format version.
    pub format_version: u16,
    /// Generation counter.
    pub generation: u64,
    /// Payload length, bytes.
    pub payload_len: u32,
    /// Payload CRC-32.
    pub payload_crc32: u32,
    /// Storage precision code of the form factors.
    pub precision: u8,
}

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

impl Header {
    /// Parses and checks a header: length, magic, header CRC, version (in that order, so an
    /// erased or torn header is reported as such, never misread).
    pub fn parse(bytes: &[u8]) -> Result<Self, ImageError> {
        if bytes.len() < HEADER_LEN {
            return Err(ImageError::Truncated {
                needed: HEADER_LEN,
                available: bytes.len(),
            });
        }
        let h = &bytes[..HEADER_LEN];
        if h.iter().all(|&b| b == 0xFF) {
            return Err(ImageError::Erased);
        }
        if h[0..4] != MAGIC {
            return Err(ImageError::BadMagic);
        }
        let stored = u32_at(h, 36);
        let actual = crc32(&h[..36]);
        if stored != actual {
            return Err(ImageError::HeaderCrc { stored, actual });
        }
        let format_version = u16_at(h, 4);
        if format_version != FORMAT_VERSION {
            return Err(ImageError::UnsupportedVersion {
                found: format_version,
                supported: FORMAT_VERSION,
            });
        }
        if usize::from(u16_at(h, 6)) != HEADER_LEN {
            return Err(ImageError::Inconsistent("header length field"));
        }
        Ok(Self {
            format_version,
            generation: u64::from_le_bytes([h[8], h[9], h[10], h[11], h[12], h[13], h[14], h[15]]),
            payload_len: u32_at(h, 16),
            payload_crc32: u32_at(h, 20),
            precision: h[24],
        })
    }

    /// The 40 header bytes, with the header CRC.
    pub fn emit(&self) -> [u8; HEADER_LEN] {
        let mut h = [0u8; HEADER_LEN];
        h[0..4].copy_from_slice(&MAGIC);
        h[4..6].copy_from_slice(&self.format_version.to_le_bytes());
        h[6..8].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
        h[8..16].copy_from_slice(&self.generation.to_le_bytes());
        h[16..20].copy_from_slice(&self.payload_len.to_le_bytes());
        h[20..24].copy_from_slice(&self.payload_crc32.to_le_bytes());
        h[24] = self.precision;
        let c = crc32(&h[..36]);
        h[36..40].copy_from_slice(&c.to_le_bytes());
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> Header {
        Header {
            format_version: FORMAT_VERSION,
            generation: 7,
            payload_len: 1234,
            payload_crc32: 0xDEAD_BEEF,
            precision: 1,
        }
    }

    #[test]
    fn round_trip_and_fixed_layout() {
        let bytes = header().emit();
        assert_eq!(&bytes[0..4], b"LXIM");
        assert_eq!(bytes[8], 7);
        assert_eq!(Header::parse(&bytes), Ok(header()));
    }

    #[test]
    fn every_single_bit_flip_is_caught() {
        let good = header().emit();
        for bit in 0..HEADER_LEN * 8 {
            let mut b = good;
            b[bit / 8] ^= 1 << (bit % 8);
            assert!(Header::parse(&b).is_err(), "bit {bit}");
        }
    }

    #[test]
    fn other_versions_erased_and_short_are_distinct_errors() {
        let mut h = header();
        h.format_version = 2;
        assert_eq!(
            Header::parse(&h.emit()),
            Err(ImageError::UnsupportedVersion {
                found: 2,
                supported: 1
            })
        );
        assert_eq!(Header::parse(&[0xFF; 40]), Err(ImageError::Erased));
        assert!(matches!(
            Header::parse(&[0; 10]),
            Err(ImageError::Truncated { .. })
        ));
        assert_eq!(Header::parse(&[0; 40]), Err(ImageError::BadMagic));
    }
}
