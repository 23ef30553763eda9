//! The ceiling cameras: a ToF depth camera and a (colour) camera read as linear luminance, behind
//! two small traits, and the commissioning capture sequence that drives them together with the
//! luminaires.
//!
//! | driver | module | what it is |
//! |---|---|---|
//! | simulated | `crate::sim::camera` (feature `sim`) | renders depth and luminance of a scene with the project's own ray caster and engine; seeded ToF noise |
//! | replay | [`replay`] | serves a recorded capture directory (`docs/formats.md`) |
//! | Sipeed MaixSense A010 | [`a010`] | ToF over serial / USB-CDC: AT commands, framed packets with checksum, resynchronising parser |
//! | V4L2 | [`v4l2`], [`stream`] | a UVC/CSI colour camera on Linux (YUYV or GREY, sRGB decoded to linear luminance) or a depth camera (Z16), streaming I/O with mmap buffers; a recorded stream replayed behind the same device interface |
//! | registration | [`register`] | resamples colour frames of another camera (size, intrinsics, baseline) onto the ToF grid |
//! | fault injection (feature `sim`) | `FaultInjector` | wraps any camera: timeouts, garbage frames, disconnects (seeded or at given frames) |
//!
//! Every driver reports trouble as a [`CameraError`], never a panic. [`CameraError::is_transient`]
//! says which errors a retry may cure (timeouts, garbage frames); [`capture_sequence`] retries
//! those and fails on the others.
//!
//! ## Frames
//!
//! Depth is millimetres along the optical axis (`z_cam`, not the ray length), `0` = no return;
//! luminance is linear, cd/m² = value × `cd_m2_per_unit`, `65535` = saturated. Both are
//! row-major, pixel (u, v) at `v * width + u`, registered to the depth camera's
//! [`crate::scene::Camera`] (the capture format's convention).

pub mod a010;
pub mod capture;
#[cfg(feature = "sim")]
mod faults;
pub mod register;
pub mod replay;
mod sequence;
pub mod stream;
pub mod v4l2;

use std::time::SystemTime;

#[cfg(feature = "sim")]
pub use faults::{FaultInjector, Faults};
pub use register::{ColourFromTof, ColourIntrinsics, Registration};
pub use sequence::{
    Sequence, SequenceOptions, capture_sequence, capture_sequence_with, save_capture,
};

use crate::camera::capture::Frame;

/// One depth frame.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthFrame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Depth along the optical axis, mm, row-major; 0 = no return.
    pub depth_mm: Vec<u16>,
    /// When the frame was taken.
    pub timestamp: SystemTime,
    /// Integration (exposure) time, s.
    pub exposure_s: f64,
}

/// One linear luminance frame.
#[derive(Debug, Clone, PartialEq)]
pub struct LuminanceFrame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear luminance values, row-major; 65535 = saturated.
    pub data: Vec<u16>,
    /// cd/m² per unit of `data`.
    pub cd_m2_per_unit: f64,
    /// When the frame was taken.
    pub timestamp: SystemTime,
    /// Exposure time, s.
    pub exposure_s: f64,
}

impl DepthFrame {
    /// The frame in the capture format's shape.
    pub fn to_frame(&self) -> Frame {
        Frame {
            width: self.width,
            height: self.height,
            data: self.depth_mm.clone(),
        }
    }
}

impl LuminanceFrame {
    /// The frame in the capture format's shape (values as they are; the scale is separate).
    pub fn to_frame(&self) -> Frame {
        Frame {
            width: self.width,
            height: self.height,
            data: self.data.clone(),
        }
    }

    /// Luminance of pixel (u, v), cd/m² (`None` outside the frame or saturated).
    pub fn luminance_cd_m2(&self, u: u32, v: u32) -> Option<f64> {
        if u >= self.width || v >= self.height {
            return None;
        }
        let x = *self.data.get((v * self.width + u) as usize)?;
        (x != u16::MAX).then(|| f64::from(x) * self.cd_m2_per_unit)
    }
}

/// Why a camera (or the light control during a capture) failed.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// No frame arrived in time.
    #[error("{device}: no frame within {timeout_s} s")]
    Timeout {
        /// The device (path or name).
        device: String,
        /// How long was waited, s.
        timeout_s: f64,
    },
    /// A frame arrived but is unusable (checksum, size, format, torn).
    #[error("{device}: bad frame: {reason}")]
    Garbage {
        /// The device.
        device: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The device is gone (unplugged, closed, end of stream).
    #[error("{device}: disconnected: {reason}")]
    Disconnected {
        /// The device.
        device: String,
        /// What was seen.
        reason: String,
    },
    /// An operating-system error on the device.
    #[error("{device}: {source}")]
    Io {
        /// The device.
        device: String,
        /// The error.
        #[source]
        source: std::io::Error,
    },
    /// The camera or the request is misconfigured (size mismatch, missing calibration, bad
    /// option).
    #[error("camera configuration: {0}")]
    Config(String),
    /// Switching the luminaires failed.
    #[error("light control: {0}")]
    Lights(String),
}

impl CameraError {
    /// True for errors a retry may cure: a timeout or a garbage frame. A disconnect, an I/O
    /// error or a configuration error needs the device reopened or the setup fixed.
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            CameraError::Timeout { .. } | CameraError::Garbage { .. }
        )
    }
}

/// A ToF depth camera.
pub trait DepthCamera: Send {
    /// Intrinsics and pose (the frame every capture is registered to).
    fn camera(&self) -> &crate::scene::Camera;
    /// Takes one depth frame.
    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError>;
}

/// A camera delivering linear luminance, registered to the depth camera, or resampled onto its
/// grid by the capture sequence ([`SequenceOptions::registration`]).
pub trait LuminanceCamera: Send {
    /// Takes one luminance frame.
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError>;
}

/// Switches luminaires for commissioning (the daemon implements it over the DALI gateway /
/// holding registers; the simulated world implements it directly).
pub trait LightControl {
    /// Sets every luminaire's level (fraction 0..=1, in the order of the luminaire ids the
    /// capture sequence was given).
    fn set_levels(&mut self, levels: &[f64]) -> Result<(), CameraError>;
}

impl<T: DepthCamera + ?Sized> DepthCamera for Box<T> {
    fn camera(&self) -> &crate::scene::Camera {
        (**self).camera()
    }
    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
        (**self).capture_depth()
    }
}

impl<T: LuminanceCamera + ?Sized> LuminanceCamera for Box<T> {
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
        (**self).capture_luminance()
    }
}

impl<T: LightControl + ?Sized> LightControl for Box<T> {
    fn set_levels(&mut self, levels: &[f64]) -> Result<(), CameraError> {
        (**self).set_levels(levels)
    }
}

/// Checks levels for `n` luminaires: the right count, each in [0, 1].
pub fn check_levels(levels: &[f64], n: usize) -> Result<(), CameraError> {
    if levels.len() != n {
        return Err(CameraError::Lights(format!(
            "{} levels for {n} luminaires",
            levels.len()
        )));
    }
    if let Some(x) = levels
        .iter()
        .find(|x| !(x.is_finite() && (0.0..=1.0).contains(*x)))
    {
        return Err(CameraError::Lights(format!("level {x} is outside [0, 1]")));
    }
    Ok(())
}
