//! The camera, flash and I2C sections of a board file (`[camera]`, `[flash]`, `[i2c]`), read
//! into typed, validated settings. Unknown keys are errors.
//!
//! ```toml
//! [camera]
//! source = "sim"            # "sim" | "replay" | "hardware"
//! [camera.sim]              # every key optional: the defaults of camera::sim
//! seed = 1
//! range_noise_rel = 0.01
//! [camera.sim.faults]       # optional fault injection (camera::Faults)
//! timeout_chance = 0.05
//! [camera.replay]
//! dir = "../../../shared/scenes/office_a/capture_clean"
//! [camera.tof]              # source = "hardware"
//! driver = "a010"
//! device = "/dev/ttyUSB0"
//! calibration = "tof_camera.json"   # intrinsics + pose, the capture format's camera.json
//! [camera.colour]
//! driver = "v4l2"
//! device = "/dev/video0"
//! [camera.colour.registration]      # per-unit calibration of the colour camera against the ToF
//! fx = 554.3                        # pixels, at camera.colour width x height
//! fy = 554.3
//! cx = 319.5
//! cy = 239.5
//! k1 = -0.05                        # optional radial distortion (OpenCV k1, k2), default 0
//! k2 = 0.01
//! rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]   # X_colour = rotation · X_tof + translation_m
//! translation_m = [-0.03, 0.0, 0.0]
//! ```
//!
//! Without `[camera.colour.registration]` the colour frames must already be on the ToF grid
//! (same size as the ToF camera): otherwise the capture sequence refuses them with a
//! configuration error naming the section.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;

#[cfg(feature = "sim")]
use crate::camera::Faults;
use crate::camera::a010::A010Options;
use crate::camera::register::{ColourFromTof, ColourIntrinsics, Registration};
use crate::camera::v4l2::{PixelFormat, V4l2Options};
#[cfg(feature = "sim")]
use crate::sim::camera::{SimDepthOptions, SimLuminanceOptions};

/// A board file section that is not acceptable, in words naming the key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SectionError(pub String);

impl From<String> for SectionError {
    fn from(s: String) -> Self {
        Self(s)
    }
}

impl From<&str> for SectionError {
    fn from(s: &str) -> Self {
        Self(s.to_owned())
    }
}

fn err<T>(message: impl Into<String>) -> Result<T, SectionError> {
    Err(SectionError(message.into()))
}

/// Where the node's frames come from.
// read once from the board file: the size of a variant does not matter
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum CameraBoard {
    /// Simulated cameras on the board's scene (feature `sim`).
    #[cfg(feature = "sim")]
    Sim {
        /// Depth camera error model.
        depth: SimDepthOptions,
        /// Luminance camera.
        luminance: SimLuminanceOptions,
        /// Injected faults (both cameras), if any.
        faults: Option<Faults>,
    },
    /// A recorded capture directory.
    Replay {
        /// The directory.
        dir: PathBuf,
    },
    /// Real cameras.
    Hardware {
        /// The ToF camera.
        tof: TofBoard,
        /// The colour camera.
        colour: ColourBoard,
    },
}

/// A real ToF camera.
#[derive(Debug, Clone, PartialEq)]
pub enum TofBoard {
    /// Sipeed MaixSense A010 on a serial device.
    A010 {
        /// Serial device.
        device: String,
        /// Line speed, baud.
        baud: u32,
        /// Module settings.
        options: A010Options,
        /// `camera.json` with its intrinsics and pose.
        calibration: PathBuf,
    },
}

/// A real colour camera.
#[derive(Debug, Clone, PartialEq)]
pub enum ColourBoard {
    /// A V4L2 device.
    V4l2 {
        /// Device node.
        device: String,
        /// Format, exposure, calibration.
        options: V4l2Options,
        /// The colour camera's intrinsics and pose relative to the ToF camera (frames are
        /// resampled onto the ToF grid); `None` when its frames are already registered.
        registration: Option<Registration>,
    },
}

impl CameraBoard {
    /// The colour-to-ToF registration the capture sequence needs
    /// ([`crate::camera::SequenceOptions::registration`]), if the board has one.
    pub fn registration(&self) -> Option<&Registration> {
        match self {
            CameraBoard::Hardware {
                colour: ColourBoard::V4l2 { registration, .. },
                ..
            } => registration.as_ref(),
            _ => None,
        }
    }
}

/// Where the flash image is stored.
#[derive(Debug, Clone, PartialEq)]
pub enum FlashBoard {
    /// A file (on ext4 / UBIFS / eMMC): `crate::store::devices::FileFlash`.
    File {
        /// The file.
        path: PathBuf,
        /// Capacity, bytes (both A/B slots).
        size_bytes: usize,
    },
    /// A raw MTD partition (SPI NOR). The store has no MTD backend yet: the daemon refuses it.
    Mtd {
        /// Character device (`/dev/mtd2`).
        device: String,
    },
}

/// The board's I2C bus for its peripherals (ambient light sensor, ID EEPROM).
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct I2cBoard {
    /// Bus device (`/dev/i2c-1`).
    pub bus: String,
    /// Bus clock, Hz.
    #[serde(default = "default_i2c_hz")]
    pub clock_hz: u32,
}

fn default_i2c_hz() -> u32 {
    100_000
}

impl I2cBoard {
    /// Checks the bus path and clock.
    pub fn validate(&self) -> Result<(), SectionError> {
        if !self.bus.starts_with("/dev/") {
            return err(format!(
                "i2c.bus {:?} must be a device under /dev",
                self.bus
            ));
        }
        if !(10_000..=3_400_000).contains(&self.clock_hz) {
            return err(format!(
                "i2c.clock_hz {} is outside 10 kHz..3.4 MHz",
                self.clock_hz
            ));
        }
        Ok(())
    }
}

#[doc(hidden)]
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct CameraToml {
    source: String,
    #[serde(default)]
    sim: Option<SimToml>,
    #[serde(default)]
    replay: Option<ReplayToml>,
    #[serde(default)]
    tof: Option<TofToml>,
    #[serde(default)]
    colour: Option<ColourToml>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
#[cfg_attr(not(feature = "sim"), allow(dead_code))]
struct SimToml {
    seed: Option<u64>,
    range_noise_rel: Option<f64>,
    flying_pixel_chance: Option<f64>,
    dropout_chance: Option<f64>,
    max_range_m: Option<f64>,
    cd_m2_per_unit: Option<f64>,
    luminance_noise_rel: Option<f64>,
    faults: Option<FaultsToml>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
#[cfg_attr(not(feature = "sim"), allow(dead_code))]
struct FaultsToml {
    #[serde(default)]
    seed: u64,
    #[serde(default)]
    timeout_chance: f64,
    #[serde(default)]
    garbage_chance: f64,
    #[serde(default)]
    disconnect_after_frames: Option<u64>,
    #[serde(default)]
    timeout_delay_s: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReplayToml {
    dir: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TofToml {
    driver: String,
    device: String,
    #[serde(default = "default_tof_baud")]
    baud: u32,
    #[serde(default = "default_unit_mm")]
    unit_mm: u8,
    #[serde(default = "default_fps")]
    fps: u8,
    #[serde(default = "default_disp")]
    disp: u8,
    #[serde(default = "default_timeout_s")]
    timeout_s: f64,
    calibration: String,
}

fn default_tof_baud() -> u32 {
    115_200
}
fn default_unit_mm() -> u8 {
    10
}
fn default_fps() -> u8 {
    10
}
fn default_disp() -> u8 {
    2
}
fn default_timeout_s() -> f64 {
    2.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ColourToml {
    driver: String,
    device: String,
    width: u32,
    height: u32,
    format: PixelFormat,
    exposure_s: f64,
    calibration_cd_m2_s: f64,
    #[serde(default)]
    limited_range: bool,
    #[serde(default = "default_timeout_s")]
    timeout_s: f64,
    #[serde(default)]
    registration: Option<RegistrationToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RegistrationToml {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    #[serde(default)]
    k1: f64,
    #[serde(default)]
    k2: f64,
    rotation: [[f64; 3]; 3],
    translation_m: [f64; 3],
}

#[doc(hidden)]
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlashToml {
    kind: String,
    #[serde(default)]
    path: Option<String>,
    #[serde(default)]
    size_bytes: Option<usize>,
    #[serde(default)]
    device: Option<String>,
}

/// Default flash file size: two slots of the 4 MiB `FORMFACTORS` budget plus a sector.
pub const DEFAULT_FLASH_BYTES: usize = 2 * 4 * 1024 * 1024 + 4096;
/// The largest flash file a board may name: two slots of 128 MiB (a plausible typo such as
/// `1e14` is refused before any work, never padded).
pub const MAX_FLASH_BYTES: usize = 256 * 1024 * 1024;

fn timeout(name: &str, s: f64) -> Result<Duration, SectionError> {
    if s.is_finite() && s > 0.0 && s <= 60.0 {
        Ok(Duration::from_secs_f64(s))
    } else {
        err(format!("{name} {s} must be in (0, 60] s"))
    }
}

fn device(name: &str, d: &str) -> Result<String, SectionError> {
    if d.starts_with("/dev/") {
        Ok(d.to_owned())
    } else {
        err(format!("{name} {d:?} must be a device under /dev"))
    }
}

pub(crate) fn camera(t: Option<CameraToml>, base: &Path) -> Result<CameraBoard, SectionError> {
    let t = t.unwrap_or_else(|| CameraToml {
        source: "sim".into(),
        ..CameraToml::default()
    });
    let unused = |what: &str, present: bool| {
        if present {
            err(format!(
                "camera.{what} is given but camera.source is {:?}",
                t.source
            ))
        } else {
            Ok(())
        }
    };
    match t.source.as_str() {
        #[cfg(not(feature = "sim"))]
        "sim" => {
            err("camera.source = \"sim\": this build has no simulated cameras (feature `sim`)")
        }
        #[cfg(feature = "sim")]
        "sim" => {
            unused("replay", t.replay.is_some())?;
            unused("tof", t.tof.is_some())?;
            unused("colour", t.colour.is_some())?;
            let s = t.sim.unwrap_or_default();
            let d0 = SimDepthOptions::default();
            let depth = SimDepthOptions {
                seed: s.seed.unwrap_or(d0.seed),
                range_noise_rel: s.range_noise_rel.unwrap_or(d0.range_noise_rel),
                flying_pixel_chance: s.flying_pixel_chance.unwrap_or(d0.flying_pixel_chance),
                dropout_chance: s.dropout_chance.unwrap_or(d0.dropout_chance),
                max_range_m: s.max_range_m.unwrap_or(d0.max_range_m),
                ..d0
            };
            let l0 = SimLuminanceOptions::default();
            let luminance = SimLuminanceOptions {
                seed: s.seed.map_or(l0.seed, |x| x.wrapping_add(1)),
                cd_m2_per_unit: s.cd_m2_per_unit.unwrap_or(l0.cd_m2_per_unit),
                noise_rel: s.luminance_noise_rel.unwrap_or(l0.noise_rel),
                ..l0
            };
            // the option checks live with the cameras: build throwaway checks here
            crate::sim::camera::validate_options(&depth, &luminance)
                .map_err(|e| format!("camera.sim: {e}"))?;
            let faults = s.faults.map(|f| Faults {
                seed: f.seed,
                timeout_chance: f.timeout_chance,
                garbage_chance: f.garbage_chance,
                disconnect_after_frames: f.disconnect_after_frames,
                timeout_delay_s: f.timeout_delay_s,
                ..Faults::none()
            });
            if let Some(f) = &faults {
                f.validate()
                    .map_err(|e| format!("camera.sim.faults: {e}"))?;
            }
            Ok(CameraBoard::Sim {
                depth,
                luminance,
                faults,
            })
        }
        "replay" => {
            unused("sim", t.sim.is_some())?;
            unused("tof", t.tof.is_some())?;
            unused("colour", t.colour.is_some())?;
            let r = t
                .replay
                .ok_or("camera.source = \"replay\" needs [camera.replay] dir")?;
            Ok(CameraBoard::Replay {
                dir: base.join(r.dir),
            })
        }
        "hardware" => {
            unused("sim", t.sim.is_some())?;
            unused("replay", t.replay.is_some())?;
            let tof = t
                .tof
                .ok_or("camera.source = \"hardware\" needs [camera.tof]")?;
            let colour = t
                .colour
                .ok_or("camera.source = \"hardware\" needs [camera.colour]")?;
            let tof = match tof.driver.as_str() {
                "a010" => {
                    let options = A010Options {
                        unit_mm: tof.unit_mm,
                        fps: tof.fps,
                        disp: tof.disp,
                        timeout: timeout("camera.tof.timeout_s", tof.timeout_s)?,
                    };
                    options.validate().map_err(|e| format!("camera.tof: {e}"))?;
                    if ![
                        9600, 57600, 115_200, 230_400, 460_800, 921_600, 1_000_000, 2_000_000,
                        3_000_000,
                    ]
                    .contains(&tof.baud)
                    {
                        return err(format!(
                            "camera.tof.baud {} is not one the A010 supports",
                            tof.baud
                        ));
                    }
                    TofBoard::A010 {
                        device: device("camera.tof.device", &tof.device)?,
                        baud: tof.baud,
                        options,
                        calibration: base.join(tof.calibration),
                    }
                }
                other => {
                    return err(format!(
                        "camera.tof.driver {other:?} is not known (known: \"a010\")"
                    ));
                }
            };
            let colour = match colour.driver.as_str() {
                "v4l2" => {
                    let options = V4l2Options {
                        width: colour.width,
                        height: colour.height,
                        format: colour.format,
                        exposure_s: colour.exposure_s,
                        calibration_cd_m2_s: colour.calibration_cd_m2_s,
                        limited_range: colour.limited_range,
                        timeout: timeout("camera.colour.timeout_s", colour.timeout_s)?,
                    };
                    options
                        .validate()
                        .map_err(|e| format!("camera.colour: {e}"))?;
                    let registration = match colour.registration {
                        Some(r) => Some(
                            Registration::new(
                                ColourIntrinsics {
                                    width: colour.width,
                                    height: colour.height,
                                    fx: r.fx,
                                    fy: r.fy,
                                    cx: r.cx,
                                    cy: r.cy,
                                    k1: r.k1,
                                    k2: r.k2,
                                },
                                ColourFromTof {
                                    rotation: r.rotation,
                                    translation_m: r.translation_m,
                                },
                            )
                            .map_err(|e| format!("camera.colour.registration: {e}"))?,
                        ),
                        // frames already on the ToF grid (same size), or the capture
                        // sequence refuses them with a configuration error naming this section
                        None => None,
                    };
                    ColourBoard::V4l2 {
                        device: device("camera.colour.device", &colour.device)?,
                        options,
                        registration,
                    }
                }
                other => {
                    return err(format!(
                        "camera.colour.driver {other:?} is not known (known: \"v4l2\")"
                    ));
                }
            };
            Ok(CameraBoard::Hardware { tof, colour })
        }
        other => err(format!(
            "camera.source {other:?}: use \"sim\", \"replay\" or \"hardware\""
        )),
    }
}

pub(crate) fn flash(t: Option<FlashToml>, base: &Path) -> Result<FlashBoard, SectionError> {
    let Some(t) = t else {
        return Ok(FlashBoard::File {
            path: base.join("flash.img"),
            size_bytes: DEFAULT_FLASH_BYTES,
        });
    };
    match t.kind.as_str() {
        "file" => {
            if t.device.is_some() {
                return err("flash.device is for kind = \"mtd\"; a file takes flash.path");
            }
            let path = t.path.ok_or("flash kind = \"file\" needs flash.path")?;
            let size_bytes = t.size_bytes.unwrap_or(DEFAULT_FLASH_BYTES);
            if !(64 * 1024..=MAX_FLASH_BYTES).contains(&size_bytes) || size_bytes % 4096 != 0 {
                return err(format!(
                    "flash.size_bytes {size_bytes} must be whole 4 KiB sectors, at least 64 KiB \
                     and at most {} MiB (two image slots)",
                    MAX_FLASH_BYTES >> 20
                ));
            }
            Ok(FlashBoard::File {
                path: base.join(path),
                size_bytes,
            })
        }
        "mtd" => {
            if t.path.is_some() || t.size_bytes.is_some() {
                return err(
                    "flash kind = \"mtd\" takes only flash.device (the size is the partition's)",
                );
            }
            let d = t.device.ok_or("flash kind = \"mtd\" needs flash.device")?;
            let d = device("flash.device", &d)?;
            if !d.starts_with("/dev/mtd") {
                return err(format!(
                    "flash.device {d:?} is not an MTD device (/dev/mtdN)"
                ));
            }
            Ok(FlashBoard::Mtd { device: d })
        }
        other => err(format!("flash.kind {other:?}: use \"file\" or \"mtd\"")),
    }
}
