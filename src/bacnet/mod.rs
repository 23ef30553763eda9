//! BACnet/IP (ASHRAE 135): the building's own protocol, beside Modbus.
//!
//! * [`wire`] (`no_std`): BVLC, NPDU, APDU and the tagged encodings, parse and emit on byte
//!   slices;
//! * [`who_has`] (`no_std`): Who-Has and I-Have (DM-DOB-B), parse and emit;
//! * [`consts`] (`no_std`): the standard's numbers the node uses (object types, properties,
//!   services, error classes and codes, reject and abort reasons);
//! * `objects` (std): the node's objects (Device, the desks' Analog Inputs, the luminaires' and
//!   targets' Analog Values) read from the node's register snapshot; their table generates
//!   docs/bacnet.md;
//! * `property` (std): one property of one object, encoded;
//! * `cov` (std): the COV subscriptions and what each is owed;
//! * `pics` (std): the PICS (docs/bacnet.md) from the object table.
//!
//! The services over datagrams and the UDP server are an adapter of the node,
//! `crate::fieldbus::bacnet`.

pub mod consts;
pub mod who_has;
pub mod wire;

#[cfg(feature = "std")]
pub mod cov;
#[cfg(feature = "std")]
pub mod objects;
#[cfg(feature = "std")]
pub mod pics;
#[cfg(feature = "std")]
pub mod property;
