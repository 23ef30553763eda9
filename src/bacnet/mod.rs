//! BACnet/IP (ASHRAE 135): the building's own protocol, beside Modbus.
//!
//! * [`wire`] (`no_std`): BVLC, NPDU, APDU and the tagged encodings, parse and emit on byte
//!   slices;
//! * [`consts`] (`no_std`): the standard's numbers the node uses (object types, properties,
//!   services, error classes and codes, reject and abort reasons);
//! * `objects` (std): the node's objects (Device, the desks' Analog Inputs, the luminaires' and
//!   targets' Analog Values) read from the node's register snapshot; their table generates
//!   docs/bacnet.md;
//! * `service` (std): the services over one datagram (Who-Is, ReadProperty,
//!   ReadPropertyMultiple, WriteProperty, SubscribeCOV, DeviceCommunicationControl), and the
//!   COV subscriptions and notifications.
//!
//! The UDP server that runs them is an adapter of the node, `crate::fieldbus::bacnet`.

pub mod consts;
pub mod wire;

#[cfg(feature = "std")]
pub mod cov;
#[cfg(feature = "sim")]
pub mod fuzz;
#[cfg(feature = "std")]
pub mod objects;
#[cfg(feature = "std")]
pub mod pics;
#[cfg(feature = "std")]
pub mod property;
#[cfg(feature = "std")]
pub mod service;
