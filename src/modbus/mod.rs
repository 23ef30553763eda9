//! Modbus registers: the wire format and the register map, below the node.
//!
//! * [`pdu`], [`frame`] (`no_std`): the wire format, bytes in and out, never a panic on any
//!   input (fuzzed: `luxnode bench fuzz`).
//! * [`regmap`] (`no_std`): the register map, one table, and its handler.
//! * `access` (std): who may write (the allowlist), how each client reads floats (word
//!   order), and the settings clients wrote.
//!
//! The servers that speak this format (TCP, TLS, RTU, the DALI gateway link) are adapters over
//! the node, in `crate::fieldbus`.

pub mod frame;
pub mod pdu;
pub mod regmap;

#[cfg(feature = "std")]
pub mod access;
