//! Modbus: how the world reads luxnode.
//!
//! * [`pdu`], [`frame`] (`no_std`): the wire format, bytes in and out, never a panic on any
//!   input (fuzzed: `luxnode bench fuzz`).
//! * [`regmap`] (`no_std`): the register map, one table, and its handler.
//! * `node`, `tcp`, `rtu`, `gateway` (std): the served state, the TCP server (tokio), the
//!   RTU server on a serial port, and the DALI gateway client (tokio-modbus).

pub mod frame;
pub mod pdu;
pub mod regmap;

#[cfg(feature = "std")]
pub mod fuzz;
#[cfg(feature = "std")]
pub mod gateway;
#[cfg(feature = "std")]
pub mod node;
#[cfg(feature = "std")]
pub mod rtu;
#[cfg(feature = "std")]
pub mod tcp;
