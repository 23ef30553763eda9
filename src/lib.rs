//! # luxnode
//!
//! The software of a ceiling-mounted smart-lighting node that tells a building how much light
//! falls on every desk, in lux, without a luxmeter on any desk. It follows RGBD2lux (Tsesmelis
//! et al., WACV 2019) and corrects it where the paper is radiometrically loose (see
//! `reference/physics.md`).
//!
//! ## Layers, and the one direction data flows
//!
//! ```text
//! sensors -> mesh -> form factors -> store -> solver -> registers
//! ```
//!
//! The run-time core (store, solver over stored data, registers) sits at the bottom and knows
//! nothing of commissioning: it builds without std and runs from flash on a microcontroller.
//! The commissioning side sits above it: the cameras (sensors) give frames, `commission` turns
//! them into a mesh with reflectances, the `engine` computes its form factors, and
//! `image_build` writes them in the store's format. The node's application state (`node`:
//! model, levels, targets, control mode, daylight, live values, health) sits just above the
//! run-time core and knows no protocol; the protocols (`fieldbus`: Modbus TCP/TLS/RTU, the DALI
//! gateway link) are adapters over it. `serve`, `board` and `daemon` assemble a node and wire
//! it all together. Off-product code (the simulated world, pictures, benchmarks) is on top, behind
//! cargo features.
//!
//! A module uses only modules of lower layers (never its own layer, never a higher one). The
//! test `tests/architecture.rs` reads the `crate::` paths of every file in `src/` and fails on
//! an edge against this table, so the table is the rule, not a description.
//!
//! | layer | modules | std? | owns |
//! |---:|---|---|---|
//! | 0 | `units`, `layout`, `rng`, `host`, `en12464`, `sky` | no_std (`rng`, `host`, `en12464`: std) | the reflectance, validated once (other quantities are `f64` named with their unit); the `memory.x` regions; a seedable generator; facts of the host process; the rules of EN 12464-1 (grids, statistics, requirements); the sky for daylight coefficients: time, the sun's position, the Tregenza patches, the CIE standard skies |
//! | 1 | `dali`, `solver` | no_std | DALI dimming curves (IEC 62386-102 logarithmic, -207 linear); the radiosity solve over any sparse system (Gauss-Seidel, f64) |
//! | 2 | `store` | no_std core | the flash image (header + postcard payload), A/B slots on a flash device; image and flash files (std) |
//! | 3 | `runtime`, `control`, `peripherals`, `points` | no_std core (`points`: std) | the solver over stored data: desk lux for any dimming state from an image borrowed in place; the measuring points' names (`desk 1 (S2)`, `floor S8`), one per sensor everywhere; lighting control: the least-power dimming state that meets every desk's target, and its loop; the sensor layer: ambient light sensor, calibration EEPROM, status LED on `embedded-hal` (Linux, simulated buses: std) |
//! | 4 | `modbus` | no_std core | registers: Modbus wire format and register map (no_std); who may write and how each client reads (access), the settings clients wrote (std) |
//! | 5 | `node`, `bacnet` | std (`bacnet`: no_std core) | the node's application state, whatever protocol reads it: model, levels, targets and control mode, ageing, daylight, live values, faults, health (its servers' counters through a trait, liveness); BACnet: BVLC/NPDU/APDU wire format and tagged encodings (no_std), the node's objects over the register snapshot, COV subscriptions, the PICS |
//! | 6 | `fieldbus` | std | protocol adapters over the node: Modbus requests onto it, the TCP/TLS/RTU servers (each with its counters), the BACnet/IP services and UDP server, the DALI gateway link and the lighting loop; the frame and datagram fuzzers (feature `sim`); the integrator's points list (Modbus and BACnet) |
//! | 7 | `photometry`, `lsc`, `live`, `occupancy` | std | EULUMDAT / IES LM-63 into one intensity distribution; the desk sensor (luxmeter) model: LSC, cosine error f2; live light at run time: the cameras' frames into measured desk lux, daylight, occlusion, ageing, from the stored image alone; occupancy at run time: who is at which desk, from a depth frame against the commissioned depth |
//! | 8 | `scene` | std | scene input: OBJ/MTL geometry, luminaires, sensors, desks, camera; validation; scenarios and truth |
//! | 9 | `evaluate`, `camera` | std | accuracy against a reference; sensors: the ToF and luminance cameras (replay, A010, V4L2), registration, capture sets, the capture sequence |
//! | 10 | `engine` | std | form factors: patches, Isocell rays, BVH, direct light, sensors, superposition |
//! | 11 | `commission` | std | mesh: capture set to a scene (points, planes, mesh, closure, reflectances), then its model |
//! | 12 | `image_build`, `image_geometry`, `preset` | std | a model into the store's format, checked against the `FORMFACTORS` region; the image's geometry section to and from the engine's types (the room a report works on); the speed/accuracy presets |
//! | 13 | `render`, `live_section`, `daylight_section` | feature `report`; std | pictures: the top-view illuminance map, the camera-view report, plots; the live-light section of the image, built at commissioning from the capture or a CAD model, and the model checked against the one-luminaire frames at the desks the cameras see (a lost shade calibrated); the daylight coefficients through the room plan's windows the camera does not see |
//! | 14 | `sim` | feature `sim` | the simulated world: simulated cameras, the demo office, the simulated controller |
//! | 15 | `serve` | std | serving an image over Modbus TCP and RTU and BACnet/IP, following a DALI gateway |
//! | 16 | `board` | std | board files (`boards/<name>/board.toml`): hardware as data; opening a board's cameras |
//! | 17 | `daemon` | std | running a node: assembled from its board file (flash, peripherals, cameras, serving, live light), boot from flash or commission, serve, systemd |
//! | 18 | `bench` | feature `bench` | benchmarks that print tables: timing, accuracy, trade-offs, Modbus load and fuzzing |
//!
//! The binary (`src/main.rs`, `src/cli/`) parses arguments and prints; it may use any layer.
//! Errors are `thiserror` enums in the library and `anyhow` only in the binary; the library
//! speaks through `tracing`, never `println!`.
//!
//! ## Conventions
//!
//! * Lengths in metres, angles in radians inside the code; degrees only at file and UI edges,
//!   converted at once. Names carry units: `_m`, `_m2`, `_rad`, `_deg`, `_lx`, `_lm`, `_cd`.
//! * World frame: right-handed, z up (as the scene files).
//! * Photometry is photometric end to end: flux in lm, intensity in cd, illuminance in lx,
//!   exitance in lm/m² (never called lux, even though the dimensions match).
//! * f64 for every accumulation.
//!
//! ## Features
//!
//! * `std`: everything that needs an operating system. Without it only the run-time core
//!   builds, for `thumbv7em-none-eabihf` (`cargo build --lib --no-default-features --target
//!   thumbv7em-none-eabihf`). `--no-default-features --features std` is the product build.
//! * `sim`: the simulated world (simulated cameras, the demo office, fault injectors, the
//!   power-cut hook, the simulated controller, the sim board's files) and the Modbus frame
//!   fuzzer (tests, benchmarks, the fuzz crate).
//! * `report`: pictures and reports.
//! * `bench`: the benchmarks.
//! * `hil`: the hardware-in-the-loop rig's programs (`gateway-sim`).
//!
//! The default (development) build enables all of them.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod units;

pub mod layout {
    //! The microcontroller memory layout, read from `memory.x` at build time (`build.rs`).
    include!(concat!(env!("OUT_DIR"), "/memory_layout.rs"));

    // Checked when memory.x is read: whole 4 KiB flash sectors, not overlapping RAM.
    const _: () = assert!(FORMFACTORS_LEN_BYTES > 0 && FORMFACTORS_LEN_BYTES.is_multiple_of(4096));
    const _: () = assert!(
        FORMFACTORS_ORIGIN >= 0x2000_0000 + RAM_LEN_BYTES
            || FORMFACTORS_ORIGIN + FORMFACTORS_LEN_BYTES <= 0x2000_0000
    );
}

pub mod bacnet;
pub mod control;
pub mod dali;
pub mod modbus;
pub mod peripherals;
pub mod runtime;
pub mod sky;
pub mod solver;
pub mod store;

#[cfg(feature = "std")]
pub mod camera;
#[cfg(feature = "std")]
pub mod commission;
#[cfg(feature = "std")]
pub mod daylight_section;
#[cfg(feature = "std")]
pub mod en12464;
#[cfg(feature = "std")]
pub mod engine;
#[cfg(feature = "std")]
pub mod evaluate;
#[cfg(feature = "std")]
pub mod fieldbus;
#[cfg(feature = "std")]
pub mod host;
#[cfg(feature = "std")]
pub mod image_build;
#[cfg(feature = "std")]
pub mod image_geometry;
#[cfg(feature = "std")]
pub mod live;
#[cfg(feature = "std")]
pub mod live_section;
#[cfg(feature = "std")]
pub mod lsc;
#[cfg(feature = "std")]
pub mod node;
#[cfg(feature = "std")]
pub mod occupancy;
#[cfg(feature = "std")]
pub mod photometry;
#[cfg(feature = "std")]
pub mod rng;
#[cfg(feature = "std")]
pub mod scene;

#[cfg(feature = "std")]
pub mod board;
#[cfg(feature = "std")]
pub mod daemon;
#[cfg(feature = "std")]
pub mod points;
#[cfg(feature = "std")]
pub mod preset;
#[cfg(feature = "std")]
pub mod serve;

#[cfg(feature = "bench")]
pub mod bench;
#[cfg(feature = "report")]
pub mod render;
#[cfg(feature = "sim")]
pub mod sim;
