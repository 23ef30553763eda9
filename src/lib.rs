//! # luxnode
//!
//! The software of a ceiling-mounted smart-lighting node that tells a building how much light
//! falls on every desk, in lux, without a luxmeter on any desk. It follows RGBD2lux (Tsesmelis
//! et al., WACV 2019) and corrects it where the paper is radiometrically loose (see
//! `../shared/reference/physics.md`).
//!
//! ## Layers, and the one direction data flows
//!
//! ```text
//! sensors -> mesh -> form factors -> store -> solver -> registers
//! ```
//!
//! | module | std? | owns |
//! |---|---|---|
//! | [`units`] | no_std | physical quantities with their unit in the name |
//! | [`layout`] | no_std | the `memory.x` regions (the `FORMFACTORS` flash region's size) |
//! | [`dali`] | no_std | DALI dimming curves (IEC 62386-102 logarithmic, -207 linear) |
//! | [`store`] | no_std | the flash image (header + postcard payload), A/B slots on a flash device |
//! | [`runtime`] | no_std | desk lux for any dimming state from an image borrowed in place |
//! | [`modbus`] | no_std core | Modbus wire format and register map (no_std); TCP/RTU servers, gateway link (std) |
//! | [`solver`] | no_std | the radiosity solve over sparse form factors (Gauss-Seidel, f64) |
//! | `camera` | std | the ToF and luminance cameras (simulated, replay, A010, V4L2), fault injection, the capture sequence |
//! | `commission` | std | capture sets (ToF depth + luminance) to a scene: points, planes, mesh, closure, reflectances |
//! | `engine` | std | patches, Isocell rays, BVH, form factors, direct light, sensors, superposition |
//! | `render` | std | pictures: the top-view illuminance map |
//! | `photometry` | std | EULUMDAT / IES LM-63 parsing into one [`photometry::IntensityDistribution`] |
//! | `scene` | std | scene input: OBJ/MTL geometry, luminaires, sensors, desks, camera; validation |
//! | `sensor` | std | the desk sensor model: light sensitivity curve (LSC), cosine error f2 |
//! | `demo` | std | the built-in demo office the simulated board uses |
//! | `board` | std | board files (`boards/<name>/board.toml`): hardware as data |
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
//! * `std` (default): everything that needs an operating system. Without it the run-time core
//!   builds for `thumbv7em-none-eabihf` (`cargo build --lib --no-default-features --target
//!   thumbv7em-none-eabihf`).
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod units;

pub mod layout {
    //! The microcontroller memory layout, read from `memory.x` at build time (`build.rs`).
    include!(concat!(env!("OUT_DIR"), "/memory_layout.rs"));

    // Checked when memory.x is read: whole 4 KiB flash sectors, not overlapping RAM.
    const _: () = assert!(FORMFACTORS_LEN_BYTES > 0 && FORMFACTORS_LEN_BYTES % 4096 == 0);
    const _: () = assert!(
        FORMFACTORS_ORIGIN >= 0x2000_0000 + RAM_LEN_BYTES
            || FORMFACTORS_ORIGIN + FORMFACTORS_LEN_BYTES <= 0x2000_0000
    );
}

pub mod dali;
pub mod modbus;
pub mod runtime;
pub mod solver;
pub mod store;

#[cfg(feature = "std")]
pub mod camera;
#[cfg(feature = "std")]
pub mod commission;
#[cfg(feature = "std")]
pub mod engine;
#[cfg(feature = "std")]
pub mod evaluate;
#[cfg(feature = "std")]
pub mod render;
#[cfg(feature = "std")]
pub mod rng;
#[cfg(feature = "std")]
pub mod sensor;

#[cfg(feature = "std")]
pub mod bench;
#[cfg(feature = "std")]
pub mod board;
#[cfg(feature = "std")]
pub mod board_camera;
#[cfg(feature = "std")]
pub mod daemon;
#[cfg(feature = "std")]
pub mod demo;
#[cfg(feature = "std")]
pub mod photometry;
#[cfg(feature = "std")]
pub mod preset;
#[cfg(feature = "std")]
pub mod scene;
#[cfg(feature = "std")]
pub mod serve;
