//! Modbus PDUs (function code + data) as bytes: decoding requests and encoding responses.
//! `no_std`, no allocation, and no panic on any input (fuzzed).
//!
//! Supported functions: 0x03 read holding registers, 0x04 read input registers, 0x06 write
//! single register, 0x10 write multiple registers, 0x2B/0x0E read device identification. Any
//! other function code is answered with exception 0x01. Quantities outside the limits of the
//! Modbus application protocol (1..=125 registers read, 1..=123 written) and byte counts that do
//! not match are exception 0x03, as the specification prescribes.

/// The largest PDU, bytes (256-byte RTU ADU minus address and CRC).
pub const MAX_PDU: usize = 253;
/// Registers per read request, at most.
pub const MAX_READ: usize = 125;
/// Registers per write request, at most.
pub const MAX_WRITE: usize = 123;

/// Function codes.
pub mod function {
    /// Read holding registers.
    pub const READ_HOLDING: u8 = 0x03;
    /// Read input registers.
    pub const READ_INPUT: u8 = 0x04;
    /// Write single register.
    pub const WRITE_SINGLE: u8 = 0x06;
    /// Write multiple registers.
    pub const WRITE_MULTIPLE: u8 = 0x10;
    /// Encapsulated interface transport (MEI).
    pub const MEI: u8 = 0x2B;
    /// MEI type: read device identification.
    pub const MEI_DEVICE_ID: u8 = 0x0E;
}

/// Modbus exception codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Exception {
    /// The function code is not supported.
    IllegalFunction = 0x01,
    /// An address (or range) is not in the map, or not writable.
    IllegalDataAddress = 0x02,
    /// A value or quantity is out of range.
    IllegalDataValue = 0x03,
    /// The device cannot answer now.
    ServerDeviceFailure = 0x04,
}

/// A decoded request. Written registers are copied into the caller's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request<'a> {
    /// 0x03.
    ReadHolding {
        /// Start address (PDU, 0-based).
        address: u16,
        /// Registers.
        quantity: u16,
    },
    /// 0x04.
    ReadInput {
        /// Start address.
        address: u16,
        /// Registers.
        quantity: u16,
    },
    /// 0x06.
    WriteSingle {
        /// Address.
        address: u16,
        /// Value.
        value: u16,
    },
    /// 0x10.
    WriteMultiple {
        /// Start address.
        address: u16,
        /// Values.
        values: &'a [u16],
    },
    /// 0x2B / 0x0E.
    ReadDeviceId {
        /// Read device ID code: 1 basic, 2 regular, 3 extended (streams), 4 one object.
        code: u8,
        /// First (or the single) object id.
        object: u8,
    },
}

impl Request<'_> {
    /// The function code.
    pub fn function(&self) -> u8 {
        match self {
            Request::ReadHolding { .. } => function::READ_HOLDING,
            Request::ReadInput { .. } => function::READ_INPUT,
            Request::WriteSingle { .. } => function::WRITE_SINGLE,
            Request::WriteMultiple { .. } => function::WRITE_MULTIPLE,
            Request::ReadDeviceId { .. } => function::MEI,
        }
    }
}

/// Why a request PDU was not decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// No function code: there is nothing to answer.
    Empty,
    /// Answer with this exception.
    Exception {
        /// The request's function code.
        function: u8,
        /// The exception.
        code: Exception,
    },
}

fn be16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([b[at], b[at + 1]])
}

/// Decodes a request PDU; registers of a write are decoded into `words`.
pub fn decode_request<'w>(
    pdu: &[u8],
    words: &'w mut [u16; MAX_WRITE],
) -> Result<Request<'w>, DecodeError> {
    let Some(&fc) = pdu.first() else {
        return Err(DecodeError::Empty);
    };
    let bad = |code| DecodeError::Exception { function: fc, code };
    match fc {
        function::READ_HOLDING | function::READ_INPUT => {
            if pdu.len() != 5 {
                return Err(bad(Exception::IllegalDataValue));
            }
            let (address, quantity) = (be16(pdu, 1), be16(pdu, 3));
            if quantity == 0 || usize::from(quantity) > MAX_READ {
                return Err(bad(Exception::IllegalDataValue));
            }
            Ok(if fc == function::READ_HOLDING {
                Request::ReadHolding { address, quantity }
            } else {
                Request::ReadInput { address, quantity }
            })
        }
        function::WRITE_SINGLE => {
            if pdu.len() != 5 {
                return Err(bad(Exception::IllegalDataValue));
            }
            Ok(Request::WriteSingle {
                address: be16(pdu, 1),
                value: be16(pdu, 3),
            })
        }
        function::WRITE_MULTIPLE => {
            if pdu.len() < 6 {
                return Err(bad(Exception::IllegalDataValue));
            }
            let (address, quantity) = (be16(pdu, 1), usize::from(be16(pdu, 3)));
            let count = usize::from(pdu[5]);
            if quantity == 0
                || quantity > MAX_WRITE
                || count != 2 * quantity
                || pdu.len() != 6 + count
            {
                return Err(bad(Exception::IllegalDataValue));
            }
            for (k, w) in words.iter_mut().take(quantity).enumerate() {
                *w = be16(pdu, 6 + 2 * k);
            }
            Ok(Request::WriteMultiple {
                address,
                values: &words[..quantity],
            })
        }
        function::MEI => {
            if pdu.len() < 2 || pdu[1] != function::MEI_DEVICE_ID {
                return Err(bad(Exception::IllegalFunction));
            }
            if pdu.len() != 4 || !(1..=4).contains(&pdu[2]) {
                return Err(bad(Exception::IllegalDataValue));
            }
            Ok(Request::ReadDeviceId {
                code: pdu[2],
                object: pdu[3],
            })
        }
        _ => Err(bad(Exception::IllegalFunction)),
    }
}

/// Writes an exception PDU; returns its length.
pub fn encode_exception(function: u8, code: Exception, out: &mut [u8; MAX_PDU]) -> usize {
    out[0] = function | 0x80;
    out[1] = code as u8;
    2
}

/// Writes a register-read response PDU; returns its length.
pub fn encode_registers(function: u8, values: &[u16], out: &mut [u8; MAX_PDU]) -> usize {
    let n = values.len().min(MAX_READ);
    out[0] = function;
    out[1] = (2 * n) as u8;
    for (k, v) in values.iter().take(n).enumerate() {
        out[2 + 2 * k..4 + 2 * k].copy_from_slice(&v.to_be_bytes());
    }
    2 + 2 * n
}

/// Writes the echo of a write request (0x06: address, value; 0x10: address, quantity).
pub fn encode_write_echo(
    function: u8,
    address: u16,
    second: u16,
    out: &mut [u8; MAX_PDU],
) -> usize {
    out[0] = function;
    out[1..3].copy_from_slice(&address.to_be_bytes());
    out[3..5].copy_from_slice(&second.to_be_bytes());
    5
}

/// Writes a read-device-identification response with the given (id, value) objects, as many as
/// fit; returns its length.
pub fn encode_device_id(
    code: u8,
    conformity: u8,
    objects: &[(u8, &str)],
    out: &mut [u8; MAX_PDU],
) -> usize {
    out[0] = function::MEI;
    out[1] = function::MEI_DEVICE_ID;
    out[2] = code;
    out[3] = conformity;
    out[4] = 0; // more follows: no
    out[5] = 0; // next object id
    let mut at = 7;
    let mut n = 0u8;
    for (id, value) in objects {
        let bytes = value.as_bytes();
        let len = bytes.len().min(MAX_PDU.saturating_sub(at + 2)).min(255);
        if at + 2 + len > MAX_PDU {
            break;
        }
        out[at] = *id;
        out[at + 1] = len as u8;
        out[at + 2..at + 2 + len].copy_from_slice(&bytes[..len]);
        at += 2 + len;
        n += 1;
    }
    out[6] = n;
    at
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_what_the_specification_allows_and_nothing_else() {
        let mut w = [0u16; MAX_WRITE];
        assert_eq!(
            decode_request(&[0x04, 0x00, 0x64, 0x00, 0x02], &mut w),
            Ok(Request::ReadInput {
                address: 100,
                quantity: 2
            })
        );
        let e = |f, c| {
            Err(DecodeError::Exception {
                function: f,
                code: c,
            })
        };
        assert_eq!(
            decode_request(&[0x03, 0, 0, 0, 0], &mut w),
            e(0x03, Exception::IllegalDataValue)
        );
        assert_eq!(
            decode_request(&[0x03, 0, 0, 0, 126], &mut w),
            e(0x03, Exception::IllegalDataValue)
        );
        assert_eq!(
            decode_request(&[0x03, 0, 0, 0], &mut w),
            e(0x03, Exception::IllegalDataValue)
        );
        assert_eq!(
            decode_request(&[0x01, 0, 0, 0, 1], &mut w),
            e(0x01, Exception::IllegalFunction)
        );
        assert_eq!(decode_request(&[], &mut w), Err(DecodeError::Empty));
        let r = decode_request(
            &[0x10, 0x03, 0xE8, 0x00, 0x02, 0x04, 0x00, 0xFE, 0x00, 0x55],
            &mut w,
        );
        assert_eq!(
            r,
            Ok(Request::WriteMultiple {
                address: 1000,
                values: &[254, 85]
            })
        );
        // byte count disagreeing with the quantity
        let bad = decode_request(
            &[0x10, 0x03, 0xE8, 0x00, 0x02, 0x03, 0x00, 0xFE, 0x00],
            &mut w,
        );
        assert_eq!(bad, e(0x10, Exception::IllegalDataValue));
        assert_eq!(
            decode_request(&[0x2B, 0x0E, 0x01, 0x00], &mut w),
            Ok(Request::ReadDeviceId { code: 1, object: 0 })
        );
        assert_eq!(
            decode_request(&[0x2B, 0x0D, 0x01, 0x00], &mut w),
            e(0x2B, Exception::IllegalFunction)
        );
    }

    #[test]
    fn encodes_responses() {
        let mut out = [0u8; MAX_PDU];
        let n = encode_registers(0x04, &[0x4402, 0xD000], &mut out);
        assert_eq!(&out[..n], &[0x04, 4, 0x44, 0x02, 0xD0, 0x00]);
        let n = encode_exception(0x03, Exception::IllegalDataAddress, &mut out);
        assert_eq!(&out[..n], &[0x83, 0x02]);
        let n = encode_device_id(1, 0x82, &[(0, "luxnode"), (1, "LXN")], &mut out);
        assert_eq!(
            &out[..n],
            &[
                0x2B, 0x0E, 1, 0x82, 0, 0, 2, 0, 7, b'l', b'u', b'x', b'n', b'o', b'd', b'e', 1, 3,
                b'L', b'X', b'N'
            ]
        );
    }
}
