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
//! [`MmapDevice`] is the kernel's streaming I/O with memory-mapped buffers, the I/O every UVC
//! and CSI driver offers (UVC offers nothing else): `VIDIOC_QUERYCAP`, `VIDIOC_S_FMT`,
//! `VIDIOC_QUERYCTRL`/`S_CTRL`/`G_CTRL`, `VIDIOC_REQBUFS` (mmap), `QUERYBUF` + `mmap`,
//! `QBUF`/`DQBUF` with a `poll()` timeout, `STREAMON`/`STREAMOFF`. The capture logic above it
//! (format negotiation, exposure, freshness, dropped frames) is device-independent and lives in
//! [`super::stream`]; [`open`] puts the two together. A vanished device (`ENODEV`) is a
//! disconnect.

use std::time::{Duration, SystemTime};

use super::{CameraError, LuminanceFrame};

/// Pixel formats this driver decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelFormat {
    /// YUV 4:2:2, Y0 U Y1 V per two pixels.
    Yuyv,
    /// 8-bit greyscale.
    Grey,
    /// 16-bit depth, little-endian (`V4L2_PIX_FMT_Z16`; the unit is the device's).
    Z16,
}

impl PixelFormat {
    /// The V4L2 fourcc.
    pub fn fourcc(self) -> u32 {
        let c = match self {
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Grey => *b"GREY",
            PixelFormat::Z16 => *b"Z16 ",
        };
        u32::from_le_bytes(c)
    }

    /// Bytes per frame.
    pub fn frame_bytes(self, width: u32, height: u32) -> usize {
        let px = width as usize * height as usize;
        match self {
            PixelFormat::Yuyv | PixelFormat::Z16 => 2 * px,
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
        PixelFormat::Z16 => return Err("Z16 is depth, not a colour format".into()),
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
        if self.format == PixelFormat::Z16 {
            return Err(CameraError::Config(
                "v4l2: format z16 is depth: a colour camera takes yuyv or grey".into(),
            ));
        }
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
    //! The V4L2 ioctls used, with their structures as in `linux/videodev2.h`. nix computes the
    //! request numbers from the structure sizes, so they are right on 32- and 64-bit.

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

    /// `struct v4l2_queryctrl`.
    #[repr(C)]
    pub struct QueryCtrl {
        pub id: u32,
        pub type_: u32,
        pub name: [u8; 32],
        pub minimum: i32,
        pub maximum: i32,
        pub step: i32,
        pub default_value: i32,
        pub flags: u32,
        pub reserved: [u32; 2],
    }

    /// `struct v4l2_requestbuffers`.
    #[repr(C)]
    #[derive(Default)]
    pub struct RequestBuffers {
        pub count: u32,
        pub type_: u32,
        pub memory: u32,
        pub capabilities: u32,
        pub flags: u8,
        pub reserved: [u8; 3],
    }

    /// `struct v4l2_timecode`.
    #[repr(C)]
    #[derive(Default, Clone, Copy)]
    pub struct Timecode {
        pub type_: u32,
        pub flags: u32,
        pub frames: u8,
        pub seconds: u8,
        pub minutes: u8,
        pub hours: u8,
        pub userbits: [u8; 4],
    }

    /// `struct v4l2_buffer` (single-planar; `m` holds the mmap offset).
    #[repr(C)]
    pub struct Buffer {
        pub index: u32,
        pub type_: u32,
        pub bytesused: u32,
        pub flags: u32,
        pub field: u32,
        pub timestamp: nix::libc::timeval,
        pub timecode: Timecode,
        pub sequence: u32,
        pub memory: u32,
        pub m: BufferM,
        pub length: u32,
        pub reserved2: u32,
        pub request_fd: i32,
    }

    /// The union `m` of `struct v4l2_buffer`.
    #[repr(C)]
    #[derive(Clone, Copy)]
    pub union BufferM {
        pub offset: u32,
        pub userptr: nix::libc::c_ulong,
        pub fd: i32,
    }

    impl Buffer {
        pub fn new(index: u32) -> Self {
            Self {
                index,
                type_: BUF_TYPE_VIDEO_CAPTURE,
                bytesused: 0,
                flags: 0,
                field: 0,
                timestamp: nix::libc::timeval {
                    tv_sec: 0,
                    tv_usec: 0,
                },
                timecode: Timecode::default(),
                sequence: 0,
                memory: MEMORY_MMAP,
                m: BufferM { userptr: 0 },
                length: 0,
                reserved2: 0,
                request_fd: 0,
            }
        }
    }

    pub const BUF_TYPE_VIDEO_CAPTURE: u32 = 1;
    pub const MEMORY_MMAP: u32 = 1;
    pub const CAP_VIDEO_CAPTURE: u32 = 0x0000_0001;
    pub const CAP_STREAMING: u32 = 0x0400_0000;
    pub const CAP_DEVICE_CAPS: u32 = 0x8000_0000;
    pub const FIELD_NONE: u32 = 1;
    pub const BUF_FLAG_ERROR: u32 = 0x0000_0040;
    pub const CTRL_FLAG_DISABLED: u32 = 0x0001;
    pub const CTRL_FLAG_READ_ONLY: u32 = 0x0004;

    nix::ioctl_read!(querycap, b'V', 0, Capability);
    nix::ioctl_readwrite!(s_fmt, b'V', 5, Format);
    nix::ioctl_readwrite!(reqbufs, b'V', 8, RequestBuffers);
    nix::ioctl_readwrite!(querybuf, b'V', 9, Buffer);
    nix::ioctl_readwrite!(qbuf, b'V', 15, Buffer);
    nix::ioctl_readwrite!(dqbuf, b'V', 17, Buffer);
    nix::ioctl_write_ptr!(streamon, b'V', 18, i32);
    nix::ioctl_write_ptr!(streamoff, b'V', 19, i32);
    nix::ioctl_readwrite!(g_ctrl, b'V', 27, Control);
    nix::ioctl_readwrite!(s_ctrl, b'V', 28, Control);
    nix::ioctl_readwrite!(queryctrl, b'V', 36, QueryCtrl);

    /// Sizes as in the kernel's headers (checked at compile time on 64-bit).
    #[cfg(target_pointer_width = "64")]
    const _: () = assert!(std::mem::size_of::<Format>() == 208);
    #[cfg(target_pointer_width = "64")]
    const _: () = assert!(std::mem::size_of::<Buffer>() == 88);
    const _: () = assert!(std::mem::size_of::<Capability>() == 104);
    const _: () = assert!(std::mem::size_of::<QueryCtrl>() == 68);
    const _: () = assert!(std::mem::size_of::<RequestBuffers>() == 20);
}

/// A V4L2 capture device (`/dev/video0`) with streaming I/O through mmap'ed buffers.
#[cfg(target_os = "linux")]
pub struct MmapDevice {
    file: std::fs::File,
    path: String,
    caps: super::stream::Caps,
    buffers: Vec<(std::ptr::NonNull<u8>, usize)>,
    streaming: bool,
}

// The mapped buffers belong to this device alone; moving it to another thread is sound.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
unsafe impl Send for MmapDevice {}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
impl MmapDevice {
    /// Opens the device and reads its capabilities.
    pub fn open(path: &str) -> Result<Self, CameraError> {
        use std::os::fd::AsRawFd;
        use std::os::unix::fs::OpenOptionsExt;
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
        let mut cap = sys::Capability::default();
        // SAFETY: `file` is open and `cap` a properly sized, writable `v4l2_capability`.
        unsafe { sys::querycap(file.as_raw_fd(), &mut cap) }
            .map_err(|e| ioerr(path, "VIDIOC_QUERYCAP", e))?;
        let c = if cap.capabilities & sys::CAP_DEVICE_CAPS != 0 {
            cap.device_caps
        } else {
            cap.capabilities
        };
        let text = |b: &[u8]| {
            let n = b.iter().position(|&x| x == 0).unwrap_or(b.len());
            String::from_utf8_lossy(&b[..n]).into_owned()
        };
        Ok(Self {
            caps: super::stream::Caps {
                driver: text(&cap.driver),
                card: text(&cap.card),
                capture: c & sys::CAP_VIDEO_CAPTURE != 0,
                streaming: c & sys::CAP_STREAMING != 0,
            },
            file,
            path: path.into(),
            buffers: Vec::new(),
            streaming: false,
        })
    }

    fn fd(&self) -> std::os::fd::RawFd {
        std::os::fd::AsRawFd::as_raw_fd(&self.file)
    }

    fn unmap(&mut self) {
        for (p, len) in self.buffers.drain(..) {
            // SAFETY: `p` and `len` are a mapping made by `start` and not yet unmapped.
            let _ = unsafe { nix::sys::mman::munmap(p.as_ptr().cast(), len) };
        }
    }
}

#[cfg(target_os = "linux")]
fn ioerr(path: &str, what: &str, e: nix::errno::Errno) -> CameraError {
    if e == nix::errno::Errno::ENODEV {
        return CameraError::Disconnected {
            device: path.into(),
            reason: format!("{what}: {e}"),
        };
    }
    CameraError::Io {
        device: path.into(),
        source: std::io::Error::other(format!("{what}: {e}")),
    }
}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
impl super::stream::VideoDevice for MmapDevice {
    fn caps(&self) -> super::stream::Caps {
        self.caps.clone()
    }

    fn set_format(
        &mut self,
        want: super::stream::Format,
    ) -> Result<super::stream::Format, CameraError> {
        let mut fmt = sys::Format {
            type_: sys::BUF_TYPE_VIDEO_CAPTURE,
            fmt: sys::FormatUnion { raw: [0; 200] },
        };
        fmt.fmt.pix = sys::PixFormat {
            width: want.width,
            height: want.height,
            pixelformat: want.fourcc,
            field: sys::FIELD_NONE,
            ..Default::default()
        };
        // SAFETY: `fmt` is a valid `v4l2_format` for the duration of the call.
        unsafe { sys::s_fmt(self.fd(), &mut fmt) }
            .map_err(|e| ioerr(&self.path, "VIDIOC_S_FMT", e))?;
        // SAFETY: `pix` is the member the driver fills for a capture buffer type.
        let got = unsafe { fmt.fmt.pix };
        Ok(super::stream::Format {
            width: got.width,
            height: got.height,
            fourcc: got.pixelformat,
            bytes_per_line: got.bytesperline,
            size_image: got.sizeimage,
        })
    }

    fn query_control(&mut self, id: u32) -> Option<super::stream::ControlRange> {
        let mut q = sys::QueryCtrl {
            id,
            type_: 0,
            name: [0; 32],
            minimum: 0,
            maximum: 0,
            step: 0,
            default_value: 0,
            flags: 0,
            reserved: [0; 2],
        };
        // SAFETY: `q` is a valid `v4l2_queryctrl` for the duration of the call.
        unsafe { sys::queryctrl(self.fd(), &mut q) }.ok()?;
        if q.flags & (sys::CTRL_FLAG_DISABLED | sys::CTRL_FLAG_READ_ONLY) != 0 {
            return None;
        }
        Some(super::stream::ControlRange {
            min: q.minimum,
            max: q.maximum,
            step: q.step,
            default: q.default_value,
        })
    }

    fn set_control(&mut self, id: u32, value: i32) -> Result<i32, CameraError> {
        let mut c = sys::Control { id, value };
        // SAFETY: `c` is a valid `v4l2_control` for the duration of the call.
        unsafe { sys::s_ctrl(self.fd(), &mut c) }
            .map_err(|e| ioerr(&self.path, "VIDIOC_S_CTRL", e))?;
        let mut g = sys::Control { id, value: 0 };
        // SAFETY: as above.
        unsafe { sys::g_ctrl(self.fd(), &mut g) }
            .map_err(|e| ioerr(&self.path, "VIDIOC_G_CTRL", e))?;
        Ok(g.value)
    }

    fn start(&mut self, count: u32) -> Result<u32, CameraError> {
        use nix::sys::mman::{MapFlags, ProtFlags, mmap};
        let mut req = sys::RequestBuffers {
            count,
            type_: sys::BUF_TYPE_VIDEO_CAPTURE,
            memory: sys::MEMORY_MMAP,
            ..Default::default()
        };
        // SAFETY: `req` is a valid `v4l2_requestbuffers` for the duration of the call.
        unsafe { sys::reqbufs(self.fd(), &mut req) }.map_err(|e| {
            if e == nix::errno::Errno::EINVAL {
                CameraError::Config(format!(
                    "{}: the driver does not support mmap streaming",
                    self.path
                ))
            } else {
                ioerr(&self.path, "VIDIOC_REQBUFS", e)
            }
        })?;
        for i in 0..req.count {
            let mut b = sys::Buffer::new(i);
            // SAFETY: `b` is a valid `v4l2_buffer` for the duration of the call.
            unsafe { sys::querybuf(self.fd(), &mut b) }
                .map_err(|e| ioerr(&self.path, "VIDIOC_QUERYBUF", e))?;
            let len = std::num::NonZeroUsize::new(b.length as usize).ok_or_else(|| {
                CameraError::Config(format!("{}: buffer {i} has length 0", self.path))
            })?;
            // SAFETY: mapping the driver's buffer `i` at the offset it gave, shared, for
            // reading; unmapped in `unmap` before the file closes.
            let p = unsafe {
                mmap(
                    None,
                    len,
                    ProtFlags::PROT_READ,
                    MapFlags::MAP_SHARED,
                    self.fd(),
                    b.m.offset as nix::libc::off_t,
                )
            }
            .map_err(|e| ioerr(&self.path, "mmap", e))?;
            let p = std::ptr::NonNull::new(p.cast::<u8>())
                .ok_or_else(|| CameraError::Config(format!("{}: mmap gave null", self.path)))?;
            self.buffers.push((p, len.get()));
            // SAFETY: as for `querybuf`.
            unsafe { sys::qbuf(self.fd(), &mut b) }
                .map_err(|e| ioerr(&self.path, "VIDIOC_QBUF", e))?;
        }
        let t = sys::BUF_TYPE_VIDEO_CAPTURE as i32;
        // SAFETY: `t` outlives the call.
        unsafe { sys::streamon(self.fd(), &t) }
            .map_err(|e| ioerr(&self.path, "VIDIOC_STREAMON", e))?;
        self.streaming = true;
        Ok(req.count)
    }

    fn dequeue(
        &mut self,
        timeout: Duration,
    ) -> Result<Option<super::stream::Dequeued>, CameraError> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let mut b = sys::Buffer::new(0);
            // SAFETY: `b` is a valid `v4l2_buffer` for the duration of the call.
            match unsafe { sys::dqbuf(self.fd(), &mut b) } {
                Ok(_) => {
                    return Ok(Some(super::stream::Dequeued {
                        index: b.index,
                        sequence: b.sequence,
                        bytes_used: b.bytesused,
                        error: b.flags & sys::BUF_FLAG_ERROR != 0,
                    }));
                }
                Err(nix::errno::Errno::EAGAIN) => {}
                Err(nix::errno::Errno::EINTR) => continue,
                Err(e) => return Err(ioerr(&self.path, "VIDIOC_DQBUF", e)),
            }
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            let mut fds = [nix::poll::PollFd::new(
                self.fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            let ms = left.as_millis().clamp(1, i32::MAX as u128) as i32;
            match nix::poll::poll(&mut fds, ms) {
                Ok(_) | Err(nix::errno::Errno::EINTR) => {}
                Err(e) => return Err(ioerr(&self.path, "poll", e)),
            }
        }
    }

    fn buffer(&self, index: u32) -> &[u8] {
        match self.buffers.get(index as usize) {
            // SAFETY: the mapping is `len` readable bytes, alive until `unmap`, and the driver
            // does not write a buffer while userspace holds it (dequeued, not requeued).
            Some((p, len)) => unsafe { std::slice::from_raw_parts(p.as_ptr(), *len) },
            None => &[],
        }
    }

    fn requeue(&mut self, index: u32) -> Result<(), CameraError> {
        let mut b = sys::Buffer::new(index);
        // SAFETY: `b` is a valid `v4l2_buffer` for the duration of the call.
        unsafe { sys::qbuf(self.fd(), &mut b) }
            .map(|_| ())
            .map_err(|e| ioerr(&self.path, "VIDIOC_QBUF", e))
    }

    fn stop(&mut self) {
        if self.streaming {
            let t = sys::BUF_TYPE_VIDEO_CAPTURE as i32;
            // SAFETY: `t` outlives the call.
            let _ = unsafe { sys::streamoff(self.fd(), &t) };
            self.streaming = false;
        }
        self.unmap();
        let mut req = sys::RequestBuffers {
            count: 0,
            type_: sys::BUF_TYPE_VIDEO_CAPTURE,
            memory: sys::MEMORY_MMAP,
            ..Default::default()
        };
        // SAFETY: releases the buffers; `req` is valid for the call.
        let _ = unsafe { sys::reqbufs(self.fd(), &mut req) };
    }
}

#[cfg(target_os = "linux")]
impl Drop for MmapDevice {
    fn drop(&mut self) {
        use super::stream::VideoDevice;
        self.stop();
    }
}

/// Opens a colour camera: the device, streaming, format and exposure ([`super::stream`]).
#[cfg(target_os = "linux")]
pub fn open(
    path: &str,
    options: V4l2Options,
) -> Result<super::stream::StreamCamera<MmapDevice>, CameraError> {
    super::stream::StreamCamera::new(
        MmapDevice::open(path)?,
        path,
        super::stream::StreamKind::Luminance(options),
    )
}
