//! Modbus: how the world reads luxnode.
//!
//! * [`pdu`], [`frame`] (`no_std`): the wire format, bytes in and out, never a panic on any
//!   input (fuzzed: `luxnode bench fuzz`).
//! * [`regmap`] (`no_std`): the register map, one table, and its handler.
//! * `node`, `tcp`, `rtu`, `gateway` (std): the served state, the TCP server (tokio, plain and
//!   TLS), the RTU server on a serial port, and the DALI gateway client (tokio-modbus).
//! * `access` (std): who may write (the allowlist) and how each client reads floats (word
//!   order); `health` (std): the servers' counters and liveness, for the registers and the
//!   watchdog.

pub mod frame;
pub mod pdu;
pub mod regmap;

#[cfg(feature = "std")]
pub mod access;
#[cfg(feature = "std")]
pub mod fuzz;
#[cfg(feature = "std")]
pub mod gateway;
#[cfg(feature = "std")]
pub mod health;
#[cfg(feature = "std")]
pub mod lighting;
#[cfg(feature = "std")]
pub mod node;
#[cfg(feature = "std")]
pub mod rtu;
#[cfg(feature = "std")]
pub mod tcp;
#[cfg(feature = "std")]
pub mod tls;
