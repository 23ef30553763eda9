//! Modbus frames around a PDU: RTU (unit id, PDU, CRC-16) and TCP (MBAP header). `no_std`.

use super::pdu::MAX_PDU;

/// RTU frames are at most 256 bytes.
pub const MAX_RTU_FRAME: usize = MAX_PDU + 3;
/// Unit id 0: a broadcast (every server executes writes, none replies).
pub const BROADCAST: u8 = 0;

/// CRC-16/MODBUS (reflected polynomial 0xA001, initial value 0xFFFF).
pub fn crc16(data: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for &b in data {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc
}

/// Why an RTU frame was dropped (a server never answers a bad frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RtuError {
    /// Fewer than 4 bytes (unit, function, CRC).
    TooShort,
    /// More than 256 bytes.
    TooLong,
    /// CRC mismatch.
    Crc,
}

/// Splits an RTU frame into (unit id, PDU) after checking its CRC (sent low byte first).
pub fn decode_rtu(frame: &[u8]) -> Result<(u8, &[u8]), RtuError> {
    if frame.len() < 4 {
        return Err(RtuError::TooShort);
    }
    if frame.len() > MAX_RTU_FRAME {
        return Err(RtuError::TooLong);
    }
    let (body, crc) = frame.split_at(frame.len() - 2);
    if crc16(body) != u16::from_le_bytes([crc[0], crc[1]]) {
        return Err(RtuError::Crc);
    }
    Ok((body[0], &body[1..]))
}

/// Builds an RTU frame from a unit id and a PDU; returns its length.
pub fn encode_rtu(unit: u8, pdu: &[u8], out: &mut [u8; MAX_RTU_FRAME]) -> usize {
    let n = pdu.len().min(MAX_PDU);
    out[0] = unit;
    out[1..1 + n].copy_from_slice(&pdu[..n]);
    let crc = crc16(&out[..1 + n]);
    out[1 + n..3 + n].copy_from_slice(&crc.to_le_bytes());
    3 + n
}

/// The silence that ends an RTU frame (t3.5), in microseconds, for a baud rate and the bits per
/// character (11 for 8E1, 8O1 and 8N2; 10 for 8N1). Above 19200 baud the specification fixes
/// it at 1750 µs.
pub fn t35_us(baud: u32, bits_per_char: u32) -> u32 {
    if baud > 19_200 || baud == 0 {
        return 1_750;
    }
    (7 * 1_000_000u64 * u64::from(bits_per_char) / (2 * u64::from(baud))) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc16_check_value() {
        assert_eq!(crc16(b"123456789"), 0x4B37);
        // a real request: unit 1, read 2 input registers at 0 -> CRC bytes 0x71 0xCB
        let frame = [0x01, 0x04, 0x00, 0x00, 0x00, 0x02, 0x71, 0xCB];
        assert_eq!(decode_rtu(&frame), Ok((1, &frame[1..6])));
    }

    #[test]
    fn round_trip_and_rejects() {
        let mut out = [0u8; MAX_RTU_FRAME];
        let n = encode_rtu(7, &[0x03, 0x03, 0xE8, 0x00, 0x01], &mut out);
        assert_eq!(
            decode_rtu(&out[..n]),
            Ok((7, &[0x03, 0x03, 0xE8, 0x00, 0x01][..]))
        );
        let mut bad = out;
        bad[2] ^= 1;
        assert_eq!(decode_rtu(&bad[..n]), Err(RtuError::Crc));
        assert_eq!(decode_rtu(&out[..3]), Err(RtuError::TooShort));
        assert_eq!(decode_rtu(&[0u8; 300]), Err(RtuError::TooLong));
    }

    #[test]
    fn frame_gap() {
        assert_eq!(t35_us(9600, 11), 4010);
        assert_eq!(t35_us(19200, 11), 2005);
        assert_eq!(t35_us(115_200, 11), 1750);
    }
}
