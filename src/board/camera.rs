//! The camera, flash and I2C sections of a board file (`[camera]`, `[flash]`, `[i2c]`), read
//! into typed, validated settings. Unknown keys are errors.
//!
//! ```toml
//! [camera]
//! source = "sim"            # "sim" | "replay" | "hardware"
//! [camera.sim]              # every key optional: the defaults of camera::sim
//! seed = 1
//! range_noise_rel = 0.01
//! scenario = "day.toml"     # optional: a scripted day (crate::sim::scenario), from serving on
//! [camera.sim.faults]       # optional fault injection (camera::Faults)
//! timeout_chance = 0.05
//! [camera.sim.optics]       # optional: the installed camera's optics instead of the scene's
//! model = "kannala_brandt"  # "pinhole" | "equidistant" | "kannala_brandt"
//! width = 320
//! height = 240
//! fx = 98.0                 # pixels
//! fy = 98.0
//! cx = 159.5
//! cy = 119.5
//! k = [0.02, -0.005, 0.0, 0.0]     # Kannala-Brandt k1..k4 (fisheye only)
//! tilt_deg = 0.0            # optional tilt of the optical axis about the camera's x axis
//! position_m = [2.0, 3.0, 2.78]  # optional: the camera's place in the room (one of several nodes)
//! [camera.replay]
//! dir = "reference/scenes/office_a/capture_clean"
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
//! # model = "kannala_brandt"       # a fisheye colour camera: k = [k1, k2, k3, k4], no k1/k2
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
        /// The installed camera's optics, replacing the scene's camera's (pose kept).
        optics: Option<Optics>,
        /// A scripted day in the simulated room (daylight, people, ageing, a moved desk,
        /// camera failures: `crate::sim::scenario`), started when the node starts serving.
        scenario: Option<crate::sim::scenario::Scenario>,
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

/// A camera's optics from a board file: intrinsics, lens and a tilt, applied to a scene's
/// camera (its orientation kept, then tilted; its position kept unless given).
#[cfg(feature = "sim")]
#[derive(Debug, Clone, PartialEq)]
pub struct Optics {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal lengths and principal point, pixels: fx, fy, cx, cy.
    pub intrinsics_px: [f64; 4],
    /// The lens.
    pub lens: crate::scene::Lens,
    /// Rotation of the optical axis about the camera's x axis, rad.
    pub tilt_rad: f64,
    /// Where the camera is in the room, m (one of several nodes in a room); None: the
    /// scene's camera's position.
    pub position_m: Option<[f64; 3]>,
}

#[cfg(feature = "sim")]
impl Optics {
    /// The camera `base` with these optics (checked when the optics were read).
    pub fn apply(&self, base: &crate::scene::Camera) -> crate::scene::Camera {
        let [fx, fy, cx, cy] = self.intrinsics_px;
        let tilt = glam::DMat3::from_rotation_x(self.tilt_rad);
        crate::scene::Camera {
            fx,
            fy,
            cx,
            cy,
            width: self.width,
            height: self.height,
            lens: self.lens,
            world_from_camera: base.world_from_camera * tilt,
            position_m: self
                .position_m
                .map_or(base.position_m, glam::DVec3::from_array),
            ..base.clone()
        }
    }
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
        /// Module settings (`unit_mm` as given, or 10 until [`crate::board::hardware`] picks
        /// it for the floor distance).
        options: A010Options,
        /// `unit_mm` was given in the board file (else the node picks the finest that reaches
        /// the floor).
        unit_given: bool,
        /// `camera.json` with its intrinsics and pose.
        calibration: PathBuf,
    },
    /// A depth (ToF) camera streaming Z16 over V4L2.
    V4l2 {
        /// Device node.
        device: String,
        /// Frame width, pixels (the calibration's).
        width: u32,
        /// Frame height, pixels.
        height: u32,
        /// mm per Z16 unit.
        depth_unit_mm: f64,
        /// The farthest the camera measures, m (its datasheet's range at the mode used).
        max_range_m: f64,
        /// How long to wait for a frame.
        timeout: Duration,
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

/// The board's I2C bus for its peripherals (`[i2c]`, `[i2c.als]`, `[i2c.eeprom]`,
/// `[i2c.sim]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct I2cBoard {
    /// Bus device (`/dev/i2c-1`), or `"sim"`: the simulated bus (feature `sim`).
    pub bus: String,
    /// Bus clock, Hz.
    #[serde(default = "default_i2c_hz")]
    pub clock_hz: u32,
    /// The ambient light sensor, if fitted.
    #[serde(default)]
    pub als: Option<AlsBoard>,
    /// The camera module's calibration EEPROM, if fitted.
    #[serde(default)]
    pub eeprom: Option<EepromBoard>,
    /// Faults of the simulated bus, at times after start (HIL).
    #[serde(default)]
    pub sim: Option<I2cSimBoard>,
}

/// `[i2c.als]`: the ambient light sensor.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlsBoard {
    /// `"veml7700"`.
    pub driver: String,
    /// 7-bit address (the VEML7700's is 0x10).
    #[serde(default = "default_als_address")]
    pub address: u8,
    /// Where it is, m, in the room's frame; default: 1 cm below the ToF camera.
    #[serde(default)]
    pub position_m: Option<[f64; 3]>,
    /// Which way it faces (unit vector); default straight down.
    #[serde(default = "default_down")]
    pub normal: [f64; 3],
    /// The matt black tube (hood) over the sensor, as the half-angle of the cone it lets the
    /// sensor see, degrees (`tan θc` = bore / length; response in [`crate::lsc::Lsc::hooded`]).
    /// With the cone inside the colour camera's view, the camera's gain is measured directly
    /// against the sensor at commissioning, with no model in between. Absent: a bare cosine
    /// sensor (the gain then comes through the model, docs/peripherals.md).
    #[serde(default)]
    pub hood_half_angle_deg: Option<f64>,
    /// Time between run-time readings, s.
    #[serde(default = "default_als_period_s")]
    pub period_s: f64,
    /// Run-time check: the reading may differ from the model's prediction by this fraction
    /// (plus 2 lx) before the status bit is raised.
    #[serde(default = "default_als_tolerance")]
    pub tolerance: f64,
}

/// `[i2c.eeprom]`: the calibration EEPROM on the camera module.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EepromBoard {
    /// `"24c32"`.
    pub driver: String,
    /// 7-bit address, 0x50..=0x57.
    #[serde(default = "default_eeprom_address")]
    pub address: u8,
}

/// `[i2c.sim]`: faults of the simulated bus, seconds after the node starts.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct I2cSimBoard {
    /// The ambient light sensor stops answering (unplugged).
    #[serde(default)]
    pub als_unplugged_after_s: Option<f64>,
    /// Its output registers freeze.
    #[serde(default)]
    pub als_frozen_after_s: Option<f64>,
    /// The bus jams (SDA held low).
    #[serde(default)]
    pub bus_stuck_after_s: Option<f64>,
    /// How long a transfer on the jammed bus takes to fail, s.
    #[serde(default = "default_stuck_timeout_s")]
    pub stuck_timeout_s: f64,
    /// Extra light (daylight) on the sensor, lx, from `daylight_after_s`.
    #[serde(default)]
    pub daylight_lx: f64,
    /// When the daylight comes.
    #[serde(default)]
    pub daylight_after_s: f64,
}

/// `[led]`: the status LED on a GPIO line.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LedBoard {
    /// GPIO character device (`/dev/gpiochip0`), or `"sim"` (feature `sim`).
    pub chip: String,
    /// Line offset.
    #[serde(default)]
    pub line: u32,
    /// The line high lights the LED.
    #[serde(default = "default_true")]
    pub active_high: bool,
}

fn default_i2c_hz() -> u32 {
    100_000
}
fn default_als_address() -> u8 {
    crate::peripherals::veml7700::ADDRESS
}
fn default_eeprom_address() -> u8 {
    crate::peripherals::at24::BASE_ADDRESS
}
fn default_down() -> [f64; 3] {
    [0.0, 0.0, -1.0]
}
fn default_als_period_s() -> f64 {
    5.0
}
fn default_als_tolerance() -> f64 {
    0.2
}
fn default_stuck_timeout_s() -> f64 {
    1.0
}
fn default_true() -> bool {
    true
}

fn is_sim(dev: &str) -> bool {
    dev == "sim"
}

impl I2cBoard {
    /// Checks the bus, the clock and the devices.
    pub fn validate(&self) -> Result<(), SectionError> {
        if is_sim(&self.bus) {
            if !cfg!(feature = "sim") {
                return err("i2c.bus = \"sim\": this build has no simulated bus (feature `sim`)");
            }
        } else if !self.bus.starts_with("/dev/") {
            return err(format!(
                "i2c.bus {:?} must be a device under /dev (or \"sim\")",
                self.bus
            ));
        }
        if self.sim.is_some() && !is_sim(&self.bus) {
            return err("i2c.sim (fault injection) needs i2c.bus = \"sim\"");
        }
        if !(10_000..=3_400_000).contains(&self.clock_hz) {
            return err(format!(
                "i2c.clock_hz {} is outside 10 kHz..3.4 MHz",
                self.clock_hz
            ));
        }
        if let Some(a) = &self.als {
            if a.driver != "veml7700" {
                return err(format!(
                    "i2c.als.driver {:?} is not known (known: \"veml7700\")",
                    a.driver
                ));
            }
            if a.address != crate::peripherals::veml7700::ADDRESS {
                return err(format!(
                    "i2c.als.address {:#04x}: the VEML7700 answers at 0x10 only",
                    a.address
                ));
            }
            let finite = a
                .position_m
                .iter()
                .flatten()
                .chain(&a.normal)
                .all(|x| x.is_finite());
            let n = a.normal.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !finite || !(0.5..=2.0).contains(&n) {
                return err("i2c.als: position_m and normal must be finite, normal a direction");
            }
            if let Some(h) = a.hood_half_angle_deg
                && !(h.is_finite() && (1.0..=85.0).contains(&h))
            {
                return err(format!(
                    "i2c.als.hood_half_angle_deg {h} is outside 1..=85 degrees"
                ));
            }
            if !(a.period_s.is_finite() && (0.1..=3600.0).contains(&a.period_s)) {
                return err(format!(
                    "i2c.als.period_s {} is outside 0.1..=3600 s",
                    a.period_s
                ));
            }
            if !(a.tolerance.is_finite() && (0.01..=10.0).contains(&a.tolerance)) {
                return err(format!(
                    "i2c.als.tolerance {} is outside 0.01..=10",
                    a.tolerance
                ));
            }
        }
        if let Some(e) = &self.eeprom {
            if e.driver != "24c32" {
                return err(format!(
                    "i2c.eeprom.driver {:?} is not known (known: \"24c32\")",
                    e.driver
                ));
            }
            if !(0x50..=0x57).contains(&e.address) {
                return err(format!(
                    "i2c.eeprom.address {:#04x} is outside 0x50..=0x57",
                    e.address
                ));
            }
        }
        if let Some(s) = &self.sim {
            let ok = |x: Option<f64>| x.is_none_or(|v| v.is_finite() && (0.0..1e6).contains(&v));
            if !(ok(s.als_unplugged_after_s)
                && ok(s.als_frozen_after_s)
                && ok(s.bus_stuck_after_s)
                && ok(Some(s.daylight_after_s))
                && s.stuck_timeout_s.is_finite()
                && (0.0..=60.0).contains(&s.stuck_timeout_s)
                && s.daylight_lx.is_finite()
                && (0.0..=100_000.0).contains(&s.daylight_lx))
            {
                return err(
                    "i2c.sim: times must be seconds >= 0, stuck_timeout_s <= 60 s, daylight_lx 0..=100000",
                );
            }
        }
        Ok(())
    }
}

impl LedBoard {
    /// Checks the chip.
    pub fn validate(&self) -> Result<(), SectionError> {
        if is_sim(&self.chip) {
            if !cfg!(feature = "sim") {
                return err("led.chip = \"sim\": this build has no simulated GPIO (feature `sim`)");
            }
        } else if !self.chip.starts_with("/dev/gpiochip") {
            return err(format!(
                "led.chip {:?} must be a GPIO character device (/dev/gpiochipN) or \"sim\"",
                self.chip
            ));
        }
        if self.line > 1023 {
            return err(format!("led.line {} is outside 0..=1023", self.line));
        }
        Ok(())
    }
}

#[doc(hidden)]
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct CameraToml {
    source: String,
    #[cfg(feature = "sim")]
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
#[cfg(feature = "sim")]
struct SimToml {
    seed: Option<u64>,
    range_noise_rel: Option<f64>,
    flying_pixel_chance: Option<f64>,
    dropout_chance: Option<f64>,
    max_range_m: Option<f64>,
    cd_m2_per_unit: Option<f64>,
    luminance_noise_rel: Option<f64>,
    faults: Option<FaultsToml>,
    optics: Option<OpticsToml>,
    scenario: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[cfg(feature = "sim")]
struct OpticsToml {
    #[serde(default = "default_model")]
    model: String,
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    #[serde(default)]
    k: Option<[f64; 4]>,
    #[serde(default)]
    tilt_deg: f64,
    #[serde(default)]
    position_m: Option<[f64; 3]>,
}

fn default_model() -> String {
    "pinhole".into()
}

/// A board's camera position coordinate, at most, m (a building's floor, not a city).
pub const MAX_CAMERA_COORDINATE_M: f64 = 1000.0;

#[cfg(feature = "sim")]
fn optics(o: OpticsToml, what: &str) -> Result<Optics, SectionError> {
    if o.width == 0 || o.height == 0 || o.width > 16384 || o.height > 16384 {
        return err(format!(
            "{what}: image size {}x{} must be 1..16384 pixels",
            o.width, o.height
        ));
    }
    crate::scene::check_intrinsics(o.fx, o.fy, o.cx, o.cy, o.width, o.height)
        .map_err(|m| format!("{what}: {m}"))?;
    let lens = crate::scene::Lens::from_model(&o.model, o.k).map_err(|m| format!("{what}: {m}"))?;
    if !(o.tilt_deg.is_finite() && o.tilt_deg.abs() <= 60.0) {
        return err(format!(
            "{what}.tilt_deg {} must be within ±60° (a ceiling camera looks down)",
            o.tilt_deg
        ));
    }
    if let Some(p) = o.position_m
        && !p
            .iter()
            .all(|x| x.is_finite() && x.abs() <= MAX_CAMERA_COORDINATE_M)
    {
        return err(format!(
            "{what}.position_m {p:?} must be finite and within ±{MAX_CAMERA_COORDINATE_M} m \
             (the camera's place in the room's frame)"
        ));
    }
    Ok(Optics {
        width: o.width,
        height: o.height,
        intrinsics_px: [o.fx, o.fy, o.cx, o.cy],
        lens,
        tilt_rad: o.tilt_deg.to_radians(),
        position_m: o.position_m,
    })
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
#[cfg(feature = "sim")]
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
    #[serde(default)]
    unit_mm: Option<u8>,
    #[serde(default = "default_fps")]
    fps: u8,
    #[serde(default = "default_disp")]
    disp: u8,
    #[serde(default = "default_timeout_s")]
    timeout_s: f64,
    calibration: String,
    // driver = "v4l2"
    #[serde(default)]
    width: Option<u32>,
    #[serde(default)]
    height: Option<u32>,
    #[serde(default)]
    format: Option<String>,
    #[serde(default)]
    depth_unit_mm: Option<f64>,
    #[serde(default)]
    max_range_m: Option<f64>,
}

fn default_tof_baud() -> u32 {
    115_200
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
    #[serde(default = "default_model")]
    model: String,
    #[serde(default)]
    k: Option<[f64; 4]>,
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
    #[cfg(feature = "sim")]
    let sim_given = t.sim.is_some();
    #[cfg(not(feature = "sim"))]
    let sim_given = false;
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
            sim_camera(t.sim.unwrap_or_default(), base)
        }
        "replay" => {
            unused("sim", sim_given)?;
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
            unused("sim", sim_given)?;
            unused("replay", t.replay.is_some())?;
            let tof = t
                .tof
                .ok_or("camera.source = \"hardware\" needs [camera.tof]")?;
            let colour = t
                .colour
                .ok_or("camera.source = \"hardware\" needs [camera.colour]")?;
            Ok(CameraBoard::Hardware {
                tof: tof_board(tof, base)?,
                colour: colour_board(colour)?,
            })
        }
        other => err(format!(
            "camera.source {other:?}: use \"sim\", \"replay\" or \"hardware\""
        )),
    }
}

/// `[camera.sim]`: the simulated cameras' error models, faults, optics and scenario.
#[cfg(feature = "sim")]
fn sim_camera(s: SimToml, base: &Path) -> Result<CameraBoard, SectionError> {
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
    let optics = s
        .optics
        .map(|o| optics(o, "camera.sim.optics"))
        .transpose()?;
    let scenario = s
        .scenario
        .map(|f| {
            crate::sim::scenario::Scenario::load(&base.join(f))
                .map_err(|e| format!("camera.sim.scenario: {e}"))
        })
        .transpose()?;
    Ok(CameraBoard::Sim {
        depth,
        luminance,
        faults,
        optics,
        scenario,
    })
}

/// `[camera.tof]` of a hardware board: the A010 or a V4L2 ToF camera.
fn tof_board(tof: TofToml, base: &Path) -> Result<TofBoard, SectionError> {
    Ok(match tof.driver.as_str() {
        "a010" => {
            if tof.width.is_some()
                || tof.height.is_some()
                || tof.format.is_some()
                || tof.depth_unit_mm.is_some()
                || tof.max_range_m.is_some()
            {
                return err(
                    "camera.tof: width, height, format, depth_unit_mm and max_range_m \
                     are for driver = \"v4l2\" (the A010 is 100 x 100, range 2.5 m)",
                );
            }
            let options = A010Options {
                unit_mm: tof.unit_mm.unwrap_or(10),
                fps: tof.fps,
                disp: tof.disp,
                timeout: timeout("camera.tof.timeout_s", tof.timeout_s)?,
            };
            options.validate().map_err(|e| format!("camera.tof: {e}"))?;
            if ![
                9600, 57600, 115_200, 230_400, 460_800, 921_600, 1_000_000, 2_000_000, 3_000_000,
            ]
            .contains(&tof.baud)
            {
                return err(format!(
                    "camera.tof.baud {} is not one the A010 supports",
                    tof.baud
                ));
            }
            crate::camera::a010::check_link(&options, tof.baud)
                .map_err(|e| format!("camera.tof: {e}"))?;
            TofBoard::A010 {
                device: device("camera.tof.device", &tof.device)?,
                baud: tof.baud,
                options,
                unit_given: tof.unit_mm.is_some(),
                calibration: base.join(tof.calibration),
            }
        }
        "v4l2" => {
            let (Some(width), Some(height), Some(max_range_m)) =
                (tof.width, tof.height, tof.max_range_m)
            else {
                return err(
                    "camera.tof driver = \"v4l2\" needs width, height and max_range_m \
                     (the camera's range from its datasheet)",
                );
            };
            if tof.format.as_deref().unwrap_or("z16") != "z16" {
                return err(format!(
                    "camera.tof.format {:?}: a V4L2 ToF camera streams \"z16\"",
                    tof.format.unwrap_or_default()
                ));
            }
            if !(1..=4096).contains(&width) || !(1..=4096).contains(&height) {
                return err(format!(
                    "camera.tof: size {width}x{height} is outside 1..=4096"
                ));
            }
            let unit = tof.depth_unit_mm.unwrap_or(1.0);
            if !(unit.is_finite() && unit > 0.0 && unit <= 100.0) {
                return err(format!(
                    "camera.tof.depth_unit_mm {unit} is outside (0, 100] mm"
                ));
            }
            if !(max_range_m.is_finite() && max_range_m > 0.0 && max_range_m <= 50.0) {
                return err(format!(
                    "camera.tof.max_range_m {max_range_m} is outside (0, 50] m"
                ));
            }
            TofBoard::V4l2 {
                device: device("camera.tof.device", &tof.device)?,
                width,
                height,
                depth_unit_mm: unit,
                max_range_m,
                timeout: timeout("camera.tof.timeout_s", tof.timeout_s)?,
                calibration: base.join(tof.calibration),
            }
        }
        other => {
            return err(format!(
                "camera.tof.driver {other:?} is not known (known: \"a010\", \"v4l2\")"
            ));
        }
    })
}

/// `[camera.colour]` of a hardware board: a V4L2 colour camera and its registration.
fn colour_board(colour: ColourToml) -> Result<ColourBoard, SectionError> {
    Ok(match colour.driver.as_str() {
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
                            lens: crate::scene::Lens::from_model(&r.model, r.k)
                                .map_err(|m| format!("camera.colour.registration: {m}"))?,
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
    })
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
