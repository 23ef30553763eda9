//! A V4L2 colour camera (USB UVC or CSI on Linux) read as linear luminance.
//!
//! ## From pixels to cd/m²
//!
//! The camera delivers 8-bit gamma-encoded luma: `YUYV` (Y of each pixel, chroma ignored) or
//! `GREY`. Luma is decoded with the sRGB transfer function (IEC 61966-2-1), the encoding UVC
//! cameras use: `V = Y'/255` (full range; with `limited_range`, `(Y' − 16)/219`), and
//! `lin = V/12.92` for `V ≤ 0.04045`, else `((V + 0.055)/1.055)^2.4`. Luma is formed from
//! gamma-encoded R'G'B', so this is the exact relative luminance only for achromatic (grey)
//! surfaces, the surfaces the engine models; for coloured ones it is an approximation.
//!
//! Relative to absolute: with auto exposure off and a fixed gain, `L = lin · K / t`, `K` the
//! camera's calibration (cd/m² · s at full scale, measured once against a luminance meter) and
//! `t` the exposure time. Frames carry `data = round(lin · 65535)` and
//! `cd_m2_per_unit = K / (t · 65535)`. Luma 255 is reported as 65535 (saturated).
//!
//! ## The device
//!
//! [`V4l2Camera`] opens the device, checks it can capture with `read()` I/O, sets the format
//! (`VIDIOC_S_FMT`), manual exposure (`V4L2_CID_EXPOSURE_AUTO` = manual,
//! `V4L2_CID_EXPOSURE_ABSOLUTE` in 100 µs units) and reads frames with a `poll()` timeout. A
//! short read is a garbage frame; a vanished device (`ENODEV`) a disconnect. Devices that only
//! offer streaming (mmap) I/O are refused with a clear error: streaming I/O is not implemented.

use std::time::{Duration, SystemTime};

use super::{CameraError, LuminanceCamera, LuminanceFrame};

/// Pixel formats this driver decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelFormat {
    /// YUV 4:2:2, Y0 U Y1 V per two pixels.
    Yuyv,
    /// 8-bit greyscale.
    Grey,
}

impl PixelFormat {
    /// The V4L2 fourcc.
    pub fn fourcc(self) -> u32 {
        let c = match self {
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Grey => *b"GREY",
        };
        u32::from_le_bytes(c)
    }

    /// Bytes per frame.
    pub fn frame_bytes(self, width: u32, height: u32) -> usize {
        let px = width as usize * height as usize;
        match self {
            PixelFormat::Yuyv => 2 * px,
            PixelFormat::Grey => px,
        }
    }
}

/// sRGB decode of a normalised code value (0..=1) to linear (0..=1).
pub fn srgb_to_linear(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The 256-entry table luma → linear × 65535 (255 → 65535 = saturated).
pub fn luma_table(limited_range: bool) -> [u16; 256] {
    let mut t = [0u16; 256];
    for (y, out) in t.iter_mut().enumerate() {
        let v = if limited_range {
            (y as f64 - 16.0) / 219.0
        } else {
            y as f64 / 255.0
        };
        *out = if y == 255 {
            u16::MAX
        } else {
            (srgb_to_linear(v) * 65535.0).round().min(65534.0) as u16
        };
    }
    t
}

/// Decodes one frame's bytes to linear values (× 65535).
pub fn decode(
    bytes: &[u8],
    format: PixelFormat,
    width: u32,
    height: u32,
    limited_range: bool,
) -> Result<Vec<u16>, String> {
    let need = format.frame_bytes(width, height);
    if bytes.len() < need {
        return Err(format!(
            "{} bytes, a {width}x{height} {format:?} frame has {need}",
            bytes.len()
        ));
    }
    let t = luma_table(limited_range);
    Ok(match format {
        PixelFormat::Grey => bytes[..need].iter().map(|&y| t[y as usize]).collect(),
        PixelFormat::Yuyv => bytes[..need]
            .iter()
            .step_by(2)
            .map(|&y| t[y as usize])
            .collect(),
    })
}

/// Settings of a V4L2 colour camera.
#[derive(Debug, Clone, PartialEq)]
pub struct V4l2Options {
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// Pixel format.
    pub format: PixelFormat,
    /// Manual exposure time, s.
    pub exposure_s: f64,
    /// Calibration K: cd/m² at full scale for a 1 s exposure.
    pub calibration_cd_m2_s: f64,
    /// Luma in 16..=235 (BT.601 limited range) rather than 0..=255.
    pub limited_range: bool,
    /// How long to wait for a frame.
    pub timeout: Duration,
}

impl V4l2Options {
    /// Checks the values.
    pub fn validate(&self) -> Result<(), CameraError> {
        if self.width == 0 || self.height == 0 || self.width > 8192 || self.height > 8192 {
            return Err(CameraError::Config(format!(
                "v4l2: frame size {}x{} is outside 1..=8192",
                self.width, self.height
            )));
        }
        if !(self.exposure_s.is_finite() && self.exposure_s > 0.0 && self.exposure_s <= 1.0) {
            return Err(CameraError::Config(format!(
                "v4l2: exposure_s {} is outside (0, 1] s",
                self.exposure_s
            )));
        }
        if !(self.calibration_cd_m2_s.is_finite() && self.calibration_cd_m2_s > 0.0) {
            return Err(CameraError::Config(
                "v4l2: calibration_cd_m2_s must be > 0".into(),
            ));
        }
        Ok(())
    }

    /// cd/m² per unit of the decoded frames.
    pub fn cd_m2_per_unit(&self) -> f64 {
        self.calibration_cd_m2_s / (self.exposure_s * 65535.0)
    }

    /// A frame from raw bytes as the device delivered them.
    pub fn frame(&self, bytes: &[u8], device: &str) -> Result<LuminanceFrame, CameraError> {
        let data = decode(
            bytes,
            self.format,
            self.width,
            self.height,
            self.limited_range,
        )
        .map_err(|reason| CameraError::Garbage {
            device: device.into(),
            reason,
        })?;
        Ok(LuminanceFrame {
            width: self.width,
            height: self.height,
            data,
            cd_m2_per_unit: self.cd_m2_per_unit(),
            timestamp: SystemTime::now(),
            exposure_s: self.exposure_s,
        })
    }
}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
mod sys {
    //! The few V4L2 ioctls used, with their structures as in `linux/videodev2.h`. nix computes
    //! the request numbers from the structure sizes, so they are right on 32- and 64-bit.

    /// `struct v4l2_capability`.
    #[repr(C)]
    #[derive(Default)]
    pub struct Capability {
        pub driver: [u8; 16],
        pub card: [u8; 32],
        pub bus_info: [u8; 32],
        pub version: u32,
        pub capabilities: u32,
        pub device_caps: u32,
        pub reserved: [u32; 3],
    }

    /// `struct v4l2_pix_format`.
    #[repr(C)]
    #[derive(Clone, Copy, Default)]
    pub struct PixFormat {
        pub width: u32,
        pub height: u32,
        pub pixelformat: u32,
        pub field: u32,
        pub bytesperline: u32,
        pub sizeimage: u32,
        pub colorspace: u32,
        pub priv_: u32,
        pub flags: u32,
        pub ycbcr_enc: u32,
        pub quantization: u32,
        pub xfer_func: u32,
    }

    /// The union in `struct v4l2_format` (200 bytes, pointer-aligned: it holds a
    /// `v4l2_window` with pointers).
    #[repr(C)]
    pub union FormatUnion {
        pub pix: PixFormat,
        pub raw: [u8; 200],
        pub _align: [*mut nix::libc::c_void; 0],
    }

    /// `struct v4l2_format`.
    #[repr(C)]
    pub struct Format {
        pub type_: u32,
        pub fmt: FormatUnion,
    }

    /// `struct v4l2_control`.
    #[repr(C)]
    pub struct Control {
        pub id: u32,
        pub value: i32,
    }

    pub const BUF_TYPE_VIDEO_CAPTURE: u32 = 1;
    pub const CAP_VIDEO_CAPTURE: u32 = 0x0000_0001;
    pub const CAP_READWRITE: u32 = 0x0100_0000;
    pub const CAP_DEVICE_CAPS: u32 = 0x8000_0000;
    pub const FIELD_NONE: u32 = 1;
    const CID_CAMERA_CLASS_BASE: u32 = 0x009a_0900;
    pub const CID_EXPOSURE_AUTO: u32 = CID_CAMERA_CLASS_BASE + 1;
    pub const CID_EXPOSURE_ABSOLUTE: u32 = CID_CAMERA_CLASS_BASE + 2;
    pub const EXPOSURE_MANUAL: i32 = 1;

    nix::ioctl_read!(querycap, b'V', 0, Capability);
    nix::ioctl_readwrite!(s_fmt, b'V', 5, Format);
    nix::ioctl_readwrite!(s_ctrl, b'V', 28, Control);

    /// Sizes as in the kernel's headers (checked at compile time on 64-bit).
    #[cfg(target_pointer_width = "64")]
    const _: () = assert!(std::mem::size_of::<Format>() == 208);
    const _: () = assert!(std::mem::size_of::<Capability>() == 104);
}

/// A V4L2 capture device (`/dev/video0`) with `read()` I/O.
#[cfg(target_os = "linux")]
pub struct V4l2Camera {
    file: std::fs::File,
    options: V4l2Options,
    device: String,
    buf: Vec<u8>,
}

#[cfg(target_os = "linux")]
impl V4l2Camera {
    /// Opens and configures the device.
    #[allow(unsafe_code)]
    pub fn open(path: &str, options: V4l2Options) -> Result<Self, CameraError> {
        use std::os::fd::AsRawFd;
        use std::os::unix::fs::OpenOptionsExt;
        options.validate()?;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::libc::O_NONBLOCK)
            .open(path)
            .map_err(|e| match e.raw_os_error() {
                Some(nix::libc::ENOENT) | Some(nix::libc::ENODEV) => CameraError::Disconnected {
                    device: path.into(),
                    reason: e.to_string(),
                },
                _ => CameraError::Io {
                    device: path.into(),
                    source: e,
                },
            })?;
        let fd = file.as_raw_fd();
        let ioerr = |what: &str, e: nix::errno::Errno| CameraError::Io {
            device: path.into(),
            source: std::io::Error::other(format!("{what}: {e}")),
        };
        let mut cap = sys::Capability::default();
        // SAFETY: `fd` is an open descriptor and `cap` a properly sized, writable
        // `v4l2_capability` that outlives the call.
        unsafe { sys::querycap(fd, &mut cap) }.map_err(|e| ioerr("VIDIOC_QUERYCAP", e))?;
        let caps = if cap.capabilities & sys::CAP_DEVICE_CAPS != 0 {
            cap.device_caps
        } else {
            cap.capabilities
        };
        if caps & sys::CAP_VIDEO_CAPTURE == 0 {
            return Err(CameraError::Config(format!(
                "{path}: not a video capture device"
            )));
        }
        if caps & sys::CAP_READWRITE == 0 {
            return Err(CameraError::Config(format!(
                "{path}: the driver offers only streaming (mmap) I/O, which luxnode does not \
                 implement yet; use a device with read() I/O"
            )));
        }
        let mut fmt = sys::Format {
            type_: sys::BUF_TYPE_VIDEO_CAPTURE,
            fmt: sys::FormatUnion { raw: [0; 200] },
        };
        fmt.fmt.pix = sys::PixFormat {
            width: options.width,
            height: options.height,
            pixelformat: options.format.fourcc(),
            field: sys::FIELD_NONE,
            ..Default::default()
        };
        // SAFETY: `fmt` is a valid `v4l2_format` for the duration of the call.
        unsafe { sys::s_fmt(fd, &mut fmt) }.map_err(|e| ioerr("VIDIOC_S_FMT", e))?;
        // SAFETY: `pix` is the member the driver fills for a capture buffer type.
        let got = unsafe { fmt.fmt.pix };
        if (got.width, got.height, got.pixelformat)
            != (options.width, options.height, options.format.fourcc())
        {
            return Err(CameraError::Config(format!(
                "{path}: the driver chose {}x{} fourcc {:#010x} instead of {}x{} {:?}",
                got.width,
                got.height,
                got.pixelformat,
                options.width,
                options.height,
                options.format
            )));
        }
        for (id, value) in [
            (sys::CID_EXPOSURE_AUTO, sys::EXPOSURE_MANUAL),
            (
                sys::CID_EXPOSURE_ABSOLUTE,
                (options.exposure_s * 1e4).round().max(1.0) as i32,
            ),
        ] {
            let mut c = sys::Control { id, value };
            // SAFETY: `c` is a valid `v4l2_control` for the duration of the call.
            unsafe { sys::s_ctrl(fd, &mut c) }.map_err(|e| ioerr("VIDIOC_S_CTRL exposure", e))?;
        }
        let n =
            (got.sizeimage as usize).max(options.format.frame_bytes(options.width, options.height));
        Ok(Self {
            file,
            options,
            device: path.into(),
            buf: vec![0; n],
        })
    }
}

#[cfg(target_os = "linux")]
impl LuminanceCamera for V4l2Camera {
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
        use std::io::Read;
        use std::os::fd::AsRawFd;
        let deadline = std::time::Instant::now() + self.options.timeout;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return Err(CameraError::Timeout {
                    device: self.device.clone(),
                    timeout_s: self.options.timeout.as_secs_f64(),
                });
            }
            let mut fds = [nix::poll::PollFd::new(
                self.file.as_raw_fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            let ms = left.as_millis().min(i32::MAX as u128) as i32;
            match nix::poll::poll(&mut fds, ms) {
                Ok(0) | Err(nix::errno::Errno::EINTR) => continue,
                Ok(_) => {}
                Err(e) => {
                    return Err(CameraError::Io {
                        device: self.device.clone(),
                        source: std::io::Error::from_raw_os_error(e as i32),
                    });
                }
            }
            match self.file.read(&mut self.buf) {
                Ok(0) => {
                    return Err(CameraError::Disconnected {
                        device: self.device.clone(),
                        reason: "end of stream".into(),
                    });
                }
                Ok(n) => return self.options.frame(&self.buf[..n], &self.device),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => continue,
                Err(e) if e.raw_os_error() == Some(nix::libc::ENODEV) => {
                    return Err(CameraError::Disconnected {
                        device: self.device.clone(),
                        reason: e.to_string(),
                    });
                }
                Err(e) => {
                    return Err(CameraError::Io {
                        device: self.device.clone(),
                        source: e,
                    });
                }
            }
        }
    }
}
