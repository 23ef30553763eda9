//! Modbus: how the world reads luxnode.
//!
//! * [`pdu`], [`frame`] (`no_std`): the wire format, bytes in and out, never a panic on any
//!   input (fuzzed: `luxnode bench fuzz`).
//! * [`regmap`] (`no_std`): the register map, one table, and its handler.
//! * `node`, `tcp`, `rtu`, `gateway` (std): the served state, the TCP server (tokio-modbus), the
//!   RTU server on a serial port, and the DALI gateway client.

pub mod frame;
pub mod pdu;
pub mod regmap;
