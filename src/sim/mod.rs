//! The simulated world (feature `sim`): what the sim board, the HIL rig and the tests run the
//! node against instead of a real room. None of it is in the product build.
//!
//! | module | what it is |
//! |---|---|
//! | [`camera`] | simulated ToF and colour cameras over a scene: the project's own ray caster and engine render depth and luminance; seeded ToF noise |
//! | [`demo`] | the built-in demo office the sim board uses |
//! | [`controller`] | the simulated luminaire controller: steps through dimming states over Modbus TCP and prints the live table |
//! | [`people`] | people of boxes the simulated cameras see: seated at a desk, standing |
//! | [`scenario`] | a scripted day for live light and occupancy: daylight from sunrise to sunset, clouds, people at desks and in the aisles, an ageing luminaire, a moved desk, a failing camera |
//!
//! The fault injectors stay beside the device traits they wrap, behind the same feature:
//! `camera::FaultInjector` (timeouts, garbage frames, disconnects) and `store::devices::FaultyFlash`
//! (the power-cut hook).

pub mod camera;
pub mod controller;
pub mod demo;
pub mod people;
pub mod scenario;
