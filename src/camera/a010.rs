//! Sipeed MaixSense A010: a 100 × 100 ToF camera on a serial line (UART, or USB-CDC, which is a
//! serial port to the host). Protocol as documented by Sipeed (MaixSense-A010 wiki, "AT
//! Command" and "Image Packet Description"; restated here, not copied).
//!
//! ## Configuration: AT commands
//!
//! ASCII lines ended by `\r`: `AT+BINN=1` (1 × 1 binning: 100 × 100; 2: 50 × 50; 4: 25 × 25),
//! `AT+UNIT=u` (depth quantisation: 0 = the default square-root law, 1..=10 = `u` mm per
//! step), `AT+FPS=f` (1..=19 frames per second), `AT+DISP=d` (where frames go: bit 0 the LCD,
//! bit 1 USB, bit 2 the UART; 2 = USB only, 4 = UART only), `AT+BAUD=b` (index into 9600,
//! 57600, 115200, 230400, 460800, 921600, 1 M, 2 M, 3 M), `AT+ISP=1` (start the sensor; the
//! first frame comes 1-2 s later). The module answers `OK\r\n` (interleaved with any frames
//! already streaming; the parser below skips it like any other noise).
//!
//! ## Frames
//!
//! | bytes | field |
//! |---|---|
//! | 2 | header `00 FF` |
//! | 2 | length L, u16 little-endian: the bytes that follow up to (not including) the checksum: 16 + pixels |
//! | 1 | command |
//! | 1 | output mode |
//! | 1 | sensor temperature |
//! | 1 | driver temperature |
//! | 4 | exposure time (little-endian; µs assumed) |
//! | 1 | error code |
//! | 1 | reserved |
//! | 1 | rows |
//! | 1 | columns |
//! | 2 | frame id, u16 little-endian |
//! | 1 | ISP version |
//! | 1 | reserved |
//! | rows × cols | one byte per pixel, row-major |
//! | 1 | checksum: the low 8 bits of the sum of every byte before it (header included) |
//! | 1 | tail `DD` |
//!
//! A 100 × 100 frame is 10 022 bytes. Pixel `p` to distance: `(p / 5.1)²` mm with `UNIT=0`,
//! `p × UNIT` mm otherwise; `p = 0` (too near, no return) and `p = 255` (beyond range or
//! saturated) are reported as 0 = no return. The module reports distance along the optical
//! axis ("to the top" of the image plane), the depth convention of [`super::DepthFrame`].
//!
//! ## Parsing
//!
//! [`FrameParser`] takes bytes as they arrive and yields frames or errors. It looks for the
//! header, checks the length against the size the header block announces, waits for the whole
//! frame, then checks the checksum and the tail. A candidate that fails any check yields a
//! [`FrameError`] and the parser resumes the search one byte after the false header, so a
//! header pattern inside pixel data or a truncated frame costs at most that frame.

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant, SystemTime};

use super::{CameraError, DepthCamera, DepthFrame};
use crate::scene::Camera;

/// Frame header bytes.
pub const HEADER: [u8; 2] = [0x00, 0xFF];
/// Frame tail byte.
pub const TAIL: u8 = 0xDD;
/// Bytes of the block between the length and the pixels.
pub const INFO_LEN: usize = 16;
/// Largest frame: 100 × 100 pixels.
pub const MAX_PIXELS: usize = 100 * 100;

/// One decoded frame, pixels still quantised.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct A010Frame {
    /// Command byte.
    pub command: u8,
    /// Output mode.
    pub output_mode: u8,
    /// Sensor temperature byte, as reported.
    pub sensor_temp: u8,
    /// Driver temperature byte, as reported.
    pub driver_temp: u8,
    /// Exposure time as reported (µs assumed).
    pub exposure_raw: u32,
    /// Error code (0 = none).
    pub error_code: u8,
    /// Rows.
    pub rows: u8,
    /// Columns.
    pub cols: u8,
    /// Frame counter.
    pub frame_id: u16,
    /// ISP version.
    pub isp_version: u8,
    /// Quantised pixels, row-major.
    pub pixels: Vec<u8>,
}

/// Why a frame candidate was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The length field cannot be a frame's.
    #[error("length field {0} is not 16 + 1..=10000 pixels")]
    BadLength(u16),
    /// The length field disagrees with rows × columns.
    #[error("length field {len} does not match {rows} x {cols} pixels")]
    SizeMismatch {
        /// Length field.
        len: u16,
        /// Rows announced.
        rows: u8,
        /// Columns announced.
        cols: u8,
    },
    /// The checksum does not match.
    #[error("checksum {actual:#04x}, computed {expected:#04x}")]
    Checksum {
        /// Computed.
        expected: u8,
        /// Received.
        actual: u8,
    },
    /// The tail byte is wrong (truncated or overrun frame).
    #[error("tail byte {0:#04x}, expected 0xdd")]
    Tail(u8),
}

/// Builds a frame's bytes (for tests and the simulator of the module).
pub fn encode(f: &A010Frame) -> Vec<u8> {
    let len = (INFO_LEN + f.pixels.len()) as u16;
    let mut b = Vec::with_capacity(4 + len as usize + 2);
    b.extend_from_slice(&HEADER);
    b.extend_from_slice(&len.to_le_bytes());
    b.extend_from_slice(&[f.command, f.output_mode, f.sensor_temp, f.driver_temp]);
    b.extend_from_slice(&f.exposure_raw.to_le_bytes());
    b.extend_from_slice(&[f.error_code, 0, f.rows, f.cols]);
    b.extend_from_slice(&f.frame_id.to_le_bytes());
    b.extend_from_slice(&[f.isp_version, 0]);
    b.extend_from_slice(&f.pixels);
    let sum = b.iter().fold(0u8, |s, x| s.wrapping_add(*x));
    b.push(sum);
    b.push(TAIL);
    b
}

/// A resynchronising frame parser over a byte stream.
#[derive(Debug, Default, Clone)]
pub struct FrameParser {
    buf: Vec<u8>,
    /// Bytes skipped while looking for a header (noise, `OK` replies, rejected frames).
    pub skipped_bytes: u64,
}

impl FrameParser {
    /// An empty parser.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends received bytes.
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes waiting.
    pub fn buffered(&self) -> usize {
        self.buf.len()
    }

    fn drop_front(&mut self, n: usize) {
        let n = n.min(self.buf.len());
        self.buf.drain(..n);
    }

    /// The next complete frame, or the reason the next candidate was rejected; `None` until
    /// more bytes are needed.
    pub fn next_frame(&mut self) -> Option<Result<A010Frame, FrameError>> {
        // find the header
        let start = self.buf.windows(2).position(|w| w == HEADER);
        match start {
            None => {
                // keep a trailing 0x00: it may be the first half of a header
                let keep = usize::from(self.buf.last() == Some(&HEADER[0]));
                let n = self.buf.len() - keep;
                self.skipped_bytes += n as u64;
                self.drop_front(n);
                return None;
            }
            Some(s) if s > 0 => {
                self.skipped_bytes += s as u64;
                self.drop_front(s);
            }
            Some(_) => {}
        }
        if self.buf.len() < 4 + INFO_LEN {
            return None;
        }
        let len = u16::from_le_bytes([self.buf[2], self.buf[3]]);
        let reject = |p: &mut Self, e: FrameError| {
            p.skipped_bytes += 1;
            p.drop_front(1);
            Some(Err(e))
        };
        let pixels = usize::from(len).saturating_sub(INFO_LEN);
        if usize::from(len) <= INFO_LEN || pixels > MAX_PIXELS {
            return reject(self, FrameError::BadLength(len));
        }
        let (rows, cols) = (self.buf[14], self.buf[15]);
        if usize::from(rows) * usize::from(cols) != pixels {
            return reject(self, FrameError::SizeMismatch { len, rows, cols });
        }
        let total = 4 + usize::from(len) + 2;
        if self.buf.len() < total {
            return None;
        }
        let expected = self.buf[..total - 2]
            .iter()
            .fold(0u8, |s, x| s.wrapping_add(*x));
        let actual = self.buf[total - 2];
        if expected != actual {
            return reject(self, FrameError::Checksum { expected, actual });
        }
        if self.buf[total - 1] != TAIL {
            return reject(self, FrameError::Tail(self.buf[total - 1]));
        }
        let b = &self.buf;
        let f = A010Frame {
            command: b[4],
            output_mode: b[5],
            sensor_temp: b[6],
            driver_temp: b[7],
            exposure_raw: u32::from_le_bytes([b[8], b[9], b[10], b[11]]),
            error_code: b[12],
            rows,
            cols,
            frame_id: u16::from_le_bytes([b[16], b[17]]),
            isp_version: b[18],
            pixels: b[20..20 + pixels].to_vec(),
        };
        self.drop_front(total);
        Some(Ok(f))
    }
}

/// Distance of a quantised pixel along the optical axis, mm (0: no return).
pub fn pixel_to_mm(p: u8, unit_mm: u8) -> u16 {
    if p == 0 || p == 255 {
        return 0;
    }
    let mm = if unit_mm == 0 {
        let x = f64::from(p) / 5.1;
        x * x
    } else {
        f64::from(p) * f64::from(unit_mm)
    };
    mm.round().clamp(1.0, 65535.0) as u16
}

/// Bytes of one 100 × 100 frame on the wire: 4 (header, length) + 16 (info) + 10 000 pixels +
/// 2 (checksum, tail).
pub const FRAME_BYTES: usize = 4 + INFO_LEN + MAX_PIXELS + 2;
/// The farthest the A010 measures, mm (its optics and the 8-bit depth: 254 steps of the
/// coarsest 10 mm quantisation, 2.54 m; the square-root law ends at (254 / 5.1)² = 2.48 m).
pub const MAX_RANGE_MM: f64 = 2500.0;
/// Headroom kept between the farthest surface expected and the quantisation's end, so a pose
/// error of a few centimetres does not push the floor into "no return".
pub const RANGE_MARGIN: f64 = 1.02;

/// Frames per second a UART at `baud` carries (8N1: 10 bits per byte) at the A010's frame
/// size: 921 600 baud → 9.2 frames/s.
pub fn uart_fps(baud: u32) -> f64 {
    f64::from(baud) / 10.0 / FRAME_BYTES as f64
}

/// The farthest depth a quantisation unit can express, mm (`p = 254`).
pub fn unit_range_mm(unit_mm: u8) -> f64 {
    if unit_mm == 0 {
        (254.0f64 / 5.1).powi(2)
    } else {
        254.0 * f64::from(unit_mm)
    }
}

/// The finest linear quantisation that reaches `distance_mm` (with [`RANGE_MARGIN`]), or why
/// the A010 cannot: a floor farther than its range. Finer steps are better: from a ceiling the
/// surfaces that matter (floor, desks) are 1.5-2.5 m away, where the square-root law
/// (`UNIT=0`) steps 15-19 mm and a linear unit of 8-10 mm steps 8-10 mm.
pub fn unit_for_distance(distance_mm: f64) -> Result<u8, CameraError> {
    let need = distance_mm * RANGE_MARGIN;
    if !(need.is_finite() && need > 0.0) || need > MAX_RANGE_MM.max(unit_range_mm(10)) {
        return Err(CameraError::Config(format!(
            "the floor is {:.2} m from the ToF camera and the A010 reaches {:.2} m: it cannot see \
             the floor; use a ToF camera with a longer range (camera.tof.driver = \"v4l2\", \
             boards/README.md)",
            distance_mm / 1000.0,
            MAX_RANGE_MM / 1000.0
        )));
    }
    Ok((1..=10u8).find(|&u| unit_range_mm(u) >= need).unwrap_or(10))
}

/// Checks a unit against the floor distance: the floor must be within its range.
pub fn check_unit(unit_mm: u8, distance_mm: f64) -> Result<(), CameraError> {
    let best = unit_for_distance(distance_mm)?;
    if unit_range_mm(unit_mm) < distance_mm * RANGE_MARGIN {
        return Err(CameraError::Config(format!(
            "a010: unit_mm {unit_mm} expresses at most {:.2} m and the floor is {:.2} m away: \
             use unit_mm = {best} (or leave it out: the node picks the finest that reaches)",
            unit_range_mm(unit_mm) / 1000.0,
            distance_mm / 1000.0
        )));
    }
    Ok(())
}

/// Checks the frame rate against the link: frames to the UART (`disp` bit 2) at `baud` must
/// fit its bandwidth; USB (full speed, about 1 MB/s of bulk transfers) carries the A010's 19
/// frames/s.
pub fn check_link(options: &A010Options, baud: u32) -> Result<(), CameraError> {
    if options.disp & 4 != 0 {
        let max = uart_fps(baud);
        if f64::from(options.fps) > max {
            return Err(CameraError::Config(format!(
                "a010: fps {} over the UART: at {baud} baud (8N1) a {FRAME_BYTES}-byte frame \
                 takes {:.0} ms, so at most {max:.1} frames/s; use fps <= {} or a faster baud",
                options.fps,
                FRAME_BYTES as f64 * 10.0 / f64::from(baud) * 1000.0,
                max.floor() as u32
            )));
        }
    }
    Ok(())
}

/// The largest depth (along the optical axis, mm) at which a camera at `camera`'s pose sees the
/// floor plane z = 0 of the scene frame, over its image's corners, edge midpoints and centre;
/// `None` if it does not look at the floor.
pub fn floor_distance_mm(camera: &Camera) -> Option<f64> {
    let (w, h) = (
        f64::from(camera.width) - 1.0,
        f64::from(camera.height) - 1.0,
    );
    let axis = camera.world_from_camera.col(2);
    let mut best: Option<f64> = None;
    for (u, v) in [
        (0.0, 0.0),
        (w, 0.0),
        (0.0, h),
        (w, h),
        (w / 2.0, 0.0),
        (w / 2.0, h),
        (0.0, h / 2.0),
        (w, h / 2.0),
        (w / 2.0, h / 2.0),
    ] {
        let Some(r) = camera.ray_world(u, v) else {
            continue;
        };
        if r.z >= -1e-6 || camera.position_m.z <= 0.0 {
            continue;
        }
        let t = -camera.position_m.z / r.z;
        let z_cam = t * r.dot(axis);
        best = Some(best.map_or(z_cam, |b: f64| b.max(z_cam)));
    }
    best.map(|m| m * 1000.0)
}

/// Settings sent to the module at start.
#[derive(Debug, Clone, PartialEq)]
pub struct A010Options {
    /// `AT+UNIT`: 0 = square-root law (fine steps near, 2.48 m at most, 17 mm steps at 2 m),
    /// 1..=10 mm per step (254 steps: 2.54 m at 10 mm). A board picks the finest unit that
    /// reaches its floor ([`unit_for_distance`]); a floor beyond the A010's 2.5 m is refused.
    pub unit_mm: u8,
    /// `AT+FPS`, 1..=19.
    pub fps: u8,
    /// `AT+DISP`: 2 = USB only, 4 = UART only.
    pub disp: u8,
    /// How long to wait for a frame.
    pub timeout: Duration,
}

impl Default for A010Options {
    fn default() -> Self {
        Self {
            unit_mm: 10,
            fps: 10,
            disp: 2,
            timeout: Duration::from_secs(2),
        }
    }
}

impl A010Options {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), CameraError> {
        if self.unit_mm > 10 {
            return Err(CameraError::Config(format!(
                "a010: unit_mm {} is outside 0..=10",
                self.unit_mm
            )));
        }
        if !(1..=19).contains(&self.fps) {
            return Err(CameraError::Config(format!(
                "a010: fps {} is outside 1..=19",
                self.fps
            )));
        }
        if !(1..=7).contains(&self.disp) || self.disp & 0b110 == 0 {
            return Err(CameraError::Config(format!(
                "a010: disp {} sends frames to neither USB (2) nor the UART (4)",
                self.disp
            )));
        }
        if self.timeout.is_zero() {
            return Err(CameraError::Config("a010: timeout must be > 0".into()));
        }
        Ok(())
    }

    /// The AT commands that configure the module, in order.
    pub fn commands(&self) -> Vec<String> {
        vec![
            "AT+ISP=1\r".into(),
            "AT+BINN=1\r".into(),
            format!("AT+UNIT={}\r", self.unit_mm),
            format!("AT+FPS={}\r", self.fps),
            format!("AT+DISP={}\r", self.disp),
        ]
    }
}

/// The A010 on a byte stream (a serial port: reads return `TimedOut`/`WouldBlock` when no byte
/// came within the port's own short timeout, `Ok(0)` at end of stream).
pub struct A010<P> {
    port: P,
    parser: FrameParser,
    camera: Camera,
    options: A010Options,
    device: String,
    /// Frames rejected by the parser so far.
    pub rejected_frames: u64,
}

fn io_error(device: &str, e: std::io::Error) -> CameraError {
    match e.kind() {
        ErrorKind::BrokenPipe
        | ErrorKind::NotConnected
        | ErrorKind::ConnectionAborted
        | ErrorKind::ConnectionReset
        | ErrorKind::UnexpectedEof
        | ErrorKind::NotFound => CameraError::Disconnected {
            device: device.into(),
            reason: e.to_string(),
        },
        _ => CameraError::Io {
            device: device.into(),
            source: e,
        },
    }
}

impl<P: Read + Write + Send> A010<P> {
    /// Configures the module on `port` (AT commands) and returns the camera. `camera` is its
    /// calibration (intrinsics and pose; 100 × 100).
    pub fn new(
        mut port: P,
        camera: Camera,
        options: A010Options,
        device: &str,
    ) -> Result<Self, CameraError> {
        options.validate()?;
        if (camera.width, camera.height) != (100, 100) {
            return Err(CameraError::Config(format!(
                "a010: the camera calibration is {}x{}, the module sends 100x100",
                camera.width, camera.height
            )));
        }
        for c in options.commands() {
            port.write_all(c.as_bytes())
                .map_err(|e| io_error(device, e))?;
        }
        port.flush().map_err(|e| io_error(device, e))?;
        Ok(Self {
            port,
            parser: FrameParser::new(),
            camera,
            options,
            device: device.into(),
            rejected_frames: 0,
        })
    }

    /// The port.
    pub fn port(&self) -> &P {
        &self.port
    }

    /// Reads until one frame (or one rejected candidate, or the timeout).
    pub fn read_frame(&mut self) -> Result<A010Frame, CameraError> {
        let deadline = Instant::now() + self.options.timeout;
        let mut chunk = [0u8; 4096];
        loop {
            match self.parser.next_frame() {
                Some(Ok(f)) => return Ok(f),
                Some(Err(e)) => {
                    self.rejected_frames += 1;
                    return Err(CameraError::Garbage {
                        device: self.device.clone(),
                        reason: e.to_string(),
                    });
                }
                None => {}
            }
            if Instant::now() >= deadline {
                return Err(CameraError::Timeout {
                    device: self.device.clone(),
                    timeout_s: self.options.timeout.as_secs_f64(),
                });
            }
            match self.port.read(&mut chunk) {
                Ok(0) => {
                    return Err(CameraError::Disconnected {
                        device: self.device.clone(),
                        reason: "end of stream".into(),
                    });
                }
                Ok(n) => self.parser.push(&chunk[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(io_error(&self.device, e)),
            }
        }
    }
}

impl A010<Box<dyn serialport::SerialPort>> {
    /// Opens the module on a serial device (`/dev/ttyUSB0`, `/dev/ttyAMA1`) at `baud`.
    pub fn open_serial(
        path: &str,
        baud: u32,
        camera: Camera,
        options: A010Options,
    ) -> Result<Self, CameraError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(50))
            .open()
            .map_err(|e| match e.kind {
                serialport::ErrorKind::NoDevice => CameraError::Disconnected {
                    device: path.into(),
                    reason: e.to_string(),
                },
                _ => CameraError::Io {
                    device: path.into(),
                    source: std::io::Error::other(e.to_string()),
                },
            })?;
        Self::new(port, camera, options, path)
    }
}

impl<P: Read + Write + Send> DepthCamera for A010<P> {
    fn camera(&self) -> &Camera {
        &self.camera
    }

    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
        let f = self.read_frame()?;
        if (u32::from(f.cols), u32::from(f.rows)) != (self.camera.width, self.camera.height) {
            return Err(CameraError::Config(format!(
                "{}: frame is {}x{}, expected {}x{} (AT+BINN=1)",
                self.device, f.cols, f.rows, self.camera.width, self.camera.height
            )));
        }
        if f.error_code != 0 {
            return Err(CameraError::Garbage {
                device: self.device.clone(),
                reason: format!("module error code {}", f.error_code),
            });
        }
        let unit = self.options.unit_mm;
        Ok(DepthFrame {
            width: u32::from(f.cols),
            height: u32::from(f.rows),
            depth_mm: f.pixels.iter().map(|&p| pixel_to_mm(p, unit)).collect(),
            timestamp: SystemTime::now(),
            exposure_s: f64::from(f.exposure_raw) * 1e-6,
        })
    }
}
