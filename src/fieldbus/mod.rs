//! The protocol adapters over the node ([`crate::node`]): how the world reads and drives it.
//!
//! * [`registers`]: Modbus requests onto the node (access policy, word orders, writes kept),
//!   and [`PduHandler`], what every Modbus server calls.
//! * [`tcp`], [`tls`], [`rtu`]: the Modbus TCP server (tokio, plain and TLS) and the RTU
//!   server on a serial port; each owns its counters, which the node's health reads
//!   ([`crate::node::health::CommCounters`]).
//! * [`gateway`], [`lighting`]: the DALI gateway link (tokio-modbus client) and the lighting
//!   control loop that drives it.
//! * `fuzz` (feature `sim`: tests, benchmarks, the fuzz crate): the wire format and the
//!   register map under random frames.
//!
//! * [`bacnet`]: the BACnet/IP server (UDP), one more adapter beside Modbus
//!   ([`crate::bacnet`]: codec, objects, services).

pub mod bacnet;
pub mod gateway;
pub mod lighting;
pub mod points;
pub mod registers;
pub mod rtu;
pub mod tcp;
pub mod tls;

#[cfg(feature = "sim")]
pub mod fuzz;

pub use registers::PduHandler;
