//! V4L2 streaming capture, device-independent: the [`VideoDevice`] interface (what the kernel's
//! streaming I/O offers: format negotiation, controls, a ring of buffers dequeued with sequence
//! numbers), the capture logic on top of it ([`StreamCamera`]: colour frames as luminance, Z16
//! frames as depth), and a recorded stream replayed behind the same interface
//! ([`RecordedStream`]), so the capture logic is tested without a camera.
//!
//! ## Capture
//!
//! * **Format**: the requested size and fourcc go to the driver, which answers with what it
//!   will deliver, including its line stride (`bytesperline`) and buffer size. Another size or
//!   fourcc is a configuration error naming both (the registration is per size); a padded
//!   stride is honoured when decoding.
//! * **Exposure**: where the driver offers `V4L2_CID_EXPOSURE_AUTO` and
//!   `V4L2_CID_EXPOSURE_ABSOLUTE` (100 µs units), auto exposure is switched off and the
//!   exposure set, clamped to the control's range and step; the value read back is the one
//!   the frames report (and their cd/m² scale uses). A driver without the controls is used as
//!   it is, with a warning: the luminance scale then assumes the board's exposure.
//! * **Freshness**: every capture first takes every buffer already filled (the ring holds
//!   frames from before a luminaire switch) and keeps the newest; it waits for one only if
//!   none is ready.
//! * **Dropped frames**: the driver numbers frames (`sequence`); a jump means frames the
//!   driver dropped (no free buffer, a USB hiccup). They are counted and logged, never
//!   silently skipped; a buffer flagged `V4L2_BUF_FLAG_ERROR` or shorter than a frame is a
//!   garbage frame (transient: the capture sequence retries it).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use super::v4l2::{PixelFormat, V4l2Options};
use super::{CameraError, DepthCamera, DepthFrame, LuminanceCamera, LuminanceFrame};

/// What the device can do (`VIDIOC_QUERYCAP`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Caps {
    /// Driver name ("uvcvideo", "vivid").
    pub driver: String,
    /// Card name.
    pub card: String,
    /// Video capture.
    pub capture: bool,
    /// Streaming I/O.
    pub streaming: bool,
}

/// A negotiated format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Format {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Fourcc.
    pub fourcc: u32,
    /// Bytes per line (stride).
    pub bytes_per_line: u32,
    /// Bytes per frame buffer.
    pub size_image: u32,
}

/// A control's range (`VIDIOC_QUERYCTRL`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ControlRange {
    /// Minimum.
    pub min: i32,
    /// Maximum.
    pub max: i32,
    /// Step.
    pub step: i32,
    /// Default.
    pub default: i32,
}

impl ControlRange {
    /// `v` clamped to the range and rounded to its step.
    pub fn clamp(&self, v: i32) -> i32 {
        let v = v.clamp(self.min, self.max);
        let step = self.step.max(1);
        let k = (f64::from(v - self.min) / f64::from(step)).round() as i32;
        (self.min + k * step).clamp(self.min, self.max)
    }
}

/// A filled buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dequeued {
    /// Buffer index.
    pub index: u32,
    /// The driver's frame number.
    pub sequence: u32,
    /// Bytes of data.
    pub bytes_used: u32,
    /// `V4L2_BUF_FLAG_ERROR`: the data may be corrupt.
    pub error: bool,
}

/// `V4L2_CID_EXPOSURE_AUTO`.
pub const CID_EXPOSURE_AUTO: u32 = 0x009a_0901;
/// `V4L2_CID_EXPOSURE_ABSOLUTE` (100 µs units).
pub const CID_EXPOSURE_ABSOLUTE: u32 = 0x009a_0902;
/// `V4L2_EXPOSURE_MANUAL`.
pub const EXPOSURE_MANUAL: i32 = 1;

/// What streaming capture needs from a device.
pub trait VideoDevice: Send {
    /// Capabilities.
    fn caps(&self) -> Caps;
    /// Asks for a format; returns the one the driver chose.
    fn set_format(&mut self, want: Format) -> Result<Format, CameraError>;
    /// A control's range, `None` when the driver does not offer it (or it is disabled).
    fn query_control(&mut self, id: u32) -> Option<ControlRange>;
    /// Sets a control; returns the value read back.
    fn set_control(&mut self, id: u32, value: i32) -> Result<i32, CameraError>;
    /// Requests `count` buffers, queues them and starts streaming; returns the count granted.
    fn start(&mut self, count: u32) -> Result<u32, CameraError>;
    /// The next filled buffer, waiting at most `timeout` (`None`: none within it).
    fn dequeue(&mut self, timeout: Duration) -> Result<Option<Dequeued>, CameraError>;
    /// A buffer's bytes.
    fn buffer(&self, index: u32) -> &[u8];
    /// Gives a buffer back to the driver.
    fn requeue(&mut self, index: u32) -> Result<(), CameraError>;
    /// Stops streaming.
    fn stop(&mut self);
}

/// What a [`StreamCamera`] delivers.
#[derive(Debug, Clone, PartialEq)]
pub enum StreamKind {
    /// Colour frames as luminance.
    Luminance(V4l2Options),
    /// Z16 depth frames.
    Depth {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// mm per Z16 unit (the driver's depth unit).
        unit_mm: f64,
        /// How long to wait for a frame.
        timeout: Duration,
    },
}

/// Streaming capture counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamStats {
    /// Frames delivered.
    pub frames: u64,
    /// Frames the driver dropped (sequence gaps).
    pub dropped: u64,
    /// Older ready frames passed over for a newer one.
    pub skipped_stale: u64,
    /// Buffers flagged as errors or short.
    pub bad: u64,
}

/// A camera on any [`VideoDevice`] with streaming I/O.
pub struct StreamCamera<D> {
    dev: D,
    device: String,
    kind: StreamKind,
    format: Format,
    exposure_s: Option<f64>,
    last_sequence: Option<u32>,
    /// Counters.
    pub stats: StreamStats,
}

/// Buffers in the ring.
pub const BUFFERS: u32 = 4;

impl<D: VideoDevice> StreamCamera<D> {
    /// Negotiates the format, sets the exposure where the driver offers it, starts streaming.
    pub fn new(mut dev: D, device: &str, kind: StreamKind) -> Result<Self, CameraError> {
        let caps = dev.caps();
        if !caps.capture {
            return Err(CameraError::Config(format!(
                "{device} ({}): not a video capture device",
                caps.driver
            )));
        }
        if !caps.streaming {
            return Err(CameraError::Config(format!(
                "{device} ({}): the driver offers no streaming I/O",
                caps.driver
            )));
        }
        let (width, height, fmt) = match &kind {
            StreamKind::Luminance(o) => {
                o.validate()?;
                (o.width, o.height, o.format)
            }
            StreamKind::Depth { width, height, .. } => (*width, *height, PixelFormat::Z16),
        };
        let want = Format {
            width,
            height,
            fourcc: fmt.fourcc(),
            bytes_per_line: 0,
            size_image: 0,
        };
        let got = dev.set_format(want)?;
        if (got.width, got.height, got.fourcc) != (width, height, fmt.fourcc()) {
            return Err(CameraError::Config(format!(
                "{device}: the driver chose {}x{} {} instead of {width}x{height} {}",
                got.width,
                got.height,
                fourcc_str(got.fourcc),
                fourcc_str(fmt.fourcc())
            )));
        }
        let min_line = fmt.frame_bytes(width, 1) as u32;
        if got.bytes_per_line < min_line
            || (got.size_image as usize) < got.bytes_per_line as usize * height as usize
        {
            return Err(CameraError::Config(format!(
                "{device}: the driver's stride {} / buffer {} bytes cannot hold {width}x{height} {}",
                got.bytes_per_line,
                got.size_image,
                fourcc_str(fmt.fourcc())
            )));
        }
        let mut exposure_s = None;
        if let StreamKind::Luminance(o) = &kind {
            match (
                dev.query_control(CID_EXPOSURE_AUTO),
                dev.query_control(CID_EXPOSURE_ABSOLUTE),
            ) {
                (Some(_), Some(range)) => {
                    dev.set_control(CID_EXPOSURE_AUTO, EXPOSURE_MANUAL)?;
                    let want = range.clamp((o.exposure_s * 1e4).round() as i32);
                    let set = dev.set_control(CID_EXPOSURE_ABSOLUTE, want)?;
                    let s = f64::from(set) / 1e4;
                    if (s / o.exposure_s - 1.0).abs() > 0.01 {
                        tracing::warn!(
                            "{device}: exposure {:.4} s asked, the driver set {s:.4} s (range \
                             {}..{} × 100 µs); the luminance scale uses {s:.4} s",
                            o.exposure_s,
                            range.min,
                            range.max
                        );
                    }
                    exposure_s = Some(s);
                }
                _ => tracing::warn!(
                    "{device} ({}): the driver offers no manual exposure control; the luminance \
                     scale assumes the board's exposure {} s",
                    caps.driver,
                    o.exposure_s
                ),
            }
        }
        let n = dev.start(BUFFERS)?;
        if n == 0 {
            return Err(CameraError::Config(format!(
                "{device}: the driver granted no buffers"
            )));
        }
        tracing::info!(
            "{device} ({}, {}): streaming {}x{} {} (stride {} bytes) in {n} mmap buffers",
            caps.driver,
            caps.card,
            width,
            height,
            fourcc_str(fmt.fourcc()),
            got.bytes_per_line
        );
        Ok(Self {
            dev,
            device: device.into(),
            kind,
            format: got,
            exposure_s,
            last_sequence: None,
            stats: StreamStats::default(),
        })
    }

    /// The negotiated format.
    pub fn format(&self) -> Format {
        self.format
    }

    /// The exposure set on the driver, s (`None`: no exposure control).
    pub fn exposure_s(&self) -> Option<f64> {
        self.exposure_s
    }

    /// The device back (streaming stopped).
    pub fn into_inner(mut self) -> D {
        self.dev.stop();
        self.dev
    }

    fn timeout(&self) -> Duration {
        match &self.kind {
            StreamKind::Luminance(o) => o.timeout,
            StreamKind::Depth { timeout, .. } => *timeout,
        }
    }

    /// The newest filled buffer's bytes (tightly packed rows) and its sequence number.
    pub fn next_frame(&mut self) -> Result<(Vec<u8>, u32), CameraError> {
        let deadline = Instant::now() + self.timeout();
        // the newest of what is ready now
        let mut newest: Option<Dequeued> = None;
        while let Some(b) = self.dev.dequeue(Duration::ZERO)? {
            if let Some(old) = newest.replace(b) {
                self.stats.skipped_stale += 1;
                self.note_sequence(old.sequence);
                self.dev.requeue(old.index)?;
            }
        }
        let b = match newest {
            Some(b) => b,
            None => {
                let left = deadline.saturating_duration_since(Instant::now());
                match self.dev.dequeue(left)? {
                    Some(b) => b,
                    None => {
                        return Err(CameraError::Timeout {
                            device: self.device.clone(),
                            timeout_s: self.timeout().as_secs_f64(),
                        });
                    }
                }
            }
        };
        self.note_sequence(b.sequence);
        let (fmt, width, height) = match &self.kind {
            StreamKind::Luminance(o) => (o.format, o.width, o.height),
            StreamKind::Depth { width, height, .. } => (PixelFormat::Z16, *width, *height),
        };
        let line = fmt.frame_bytes(width, 1);
        let stride = self.format.bytes_per_line as usize;
        let need = stride * (height as usize - 1) + line;
        let result = if b.error || (b.bytes_used as usize) < need {
            self.stats.bad += 1;
            Err(CameraError::Garbage {
                device: self.device.clone(),
                reason: if b.error {
                    format!(
                        "buffer {} (frame {}) flagged as an error by the driver",
                        b.index, b.sequence
                    )
                } else {
                    format!(
                        "frame {}: {} bytes, a {width}x{height} frame needs {need}",
                        b.sequence, b.bytes_used
                    )
                },
            })
        } else {
            let data = self.dev.buffer(b.index);
            let mut packed = Vec::with_capacity(line * height as usize);
            for row in 0..height as usize {
                packed.extend_from_slice(&data[row * stride..row * stride + line]);
            }
            self.stats.frames += 1;
            Ok((packed, b.sequence))
        };
        self.dev.requeue(b.index)?;
        result
    }

    fn note_sequence(&mut self, seq: u32) {
        if let Some(last) = self.last_sequence {
            let gap = seq.wrapping_sub(last).wrapping_sub(1);
            if gap > 0 && gap < u32::MAX / 2 {
                self.stats.dropped += u64::from(gap);
                tracing::debug!(
                    "{}: the driver dropped {gap} frame(s) before frame {seq}",
                    self.device
                );
            }
        }
        self.last_sequence = Some(seq);
    }
}

impl<D: VideoDevice> LuminanceCamera for StreamCamera<D> {
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
        let StreamKind::Luminance(o) = &self.kind else {
            return Err(CameraError::Config(format!(
                "{}: a depth stream, not a colour camera",
                self.device
            )));
        };
        let o = V4l2Options {
            exposure_s: self.exposure_s.unwrap_or(o.exposure_s),
            ..o.clone()
        };
        let (bytes, _) = self.next_frame()?;
        o.frame(&bytes, &self.device)
    }
}

/// A depth camera streaming Z16 over V4L2, with its calibration.
pub struct DepthStream<D> {
    /// The stream (kind [`StreamKind::Depth`]).
    pub stream: StreamCamera<D>,
    /// Intrinsics and pose.
    pub camera: crate::scene::Camera,
}

impl<D: VideoDevice> DepthCamera for DepthStream<D> {
    fn camera(&self) -> &crate::scene::Camera {
        &self.camera
    }

    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
        let s = &mut self.stream;
        let (width, height, unit_mm) = match &s.kind {
            StreamKind::Depth {
                width,
                height,
                unit_mm,
                ..
            } => (*width, *height, *unit_mm),
            StreamKind::Luminance(_) => {
                return Err(CameraError::Config(format!(
                    "{}: a colour stream, not a depth camera",
                    s.device
                )));
            }
        };
        if (width, height) != (self.camera.width, self.camera.height) {
            return Err(CameraError::Config(format!(
                "{}: frames are {width}x{height}, the calibration is {}x{}",
                s.device, self.camera.width, self.camera.height
            )));
        }
        let (bytes, _) = s.next_frame()?;
        let depth_mm = bytes
            .chunks_exact(2)
            .map(|c| {
                let z = f64::from(u16::from_le_bytes([c[0], c[1]])) * unit_mm;
                z.round().clamp(0.0, 65535.0) as u16
            })
            .collect();
        Ok(DepthFrame {
            width,
            height,
            depth_mm,
            timestamp: SystemTime::now(),
            exposure_s: 0.0,
        })
    }
}

/// A fourcc as text ("YUYV").
pub fn fourcc_str(f: u32) -> String {
    f.to_le_bytes()
        .iter()
        .map(|&c| if c.is_ascii_graphic() { c as char } else { '?' })
        .collect::<String>()
        .trim_end()
        .to_string()
}

/// A recorded stream: `stream.json` and one raw file per buffer, as a device recorded them
/// ([`record`]). Replayed behind [`VideoDevice`]: the format the driver negotiated, its exposure
/// control, and every buffer with its sequence number, error flag and length.
///
/// ```json
/// { "driver": "uvcvideo", "card": "HD USB Camera",
///   "format": { "width": 640, "height": 480, "fourcc": "YUYV", "bytes_per_line": 1280, "size_image": 614400 },
///   "exposure": { "min": 1, "max": 5000, "step": 1, "default": 156 },
///   "buffers": [ { "file": "000000.raw", "sequence": 0, "error": false }, ... ] }
/// ```
#[derive(Debug)]
pub struct RecordedStream {
    header: StreamHeader,
    dir: PathBuf,
    next: usize,
    loaded: Vec<u8>,
    queued: bool,
    exposure: Option<i32>,
    started: bool,
}

/// `stream.json`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StreamHeader {
    /// Driver name.
    pub driver: String,
    /// Card name.
    pub card: String,
    /// The negotiated format.
    pub format: FormatJson,
    /// The exposure control's range (`null`: the driver had none).
    pub exposure: Option<ControlJson>,
    /// The buffers in dequeue order.
    pub buffers: Vec<BufferJson>,
}

/// A format in `stream.json`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormatJson {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Fourcc as text.
    pub fourcc: String,
    /// Stride.
    pub bytes_per_line: u32,
    /// Buffer size.
    pub size_image: u32,
}

/// A control range in `stream.json`.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlJson {
    /// Minimum.
    pub min: i32,
    /// Maximum.
    pub max: i32,
    /// Step.
    pub step: i32,
    /// Default.
    pub default: i32,
}

/// One buffer in `stream.json`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BufferJson {
    /// Raw bytes file (relative).
    pub file: String,
    /// Sequence number.
    pub sequence: u32,
    /// Error flag.
    #[serde(default)]
    pub error: bool,
}

fn fourcc_of(s: &str) -> Result<u32, String> {
    let b = s.as_bytes();
    if b.is_empty() || b.len() > 4 || !b.iter().all(|c| c.is_ascii_graphic()) {
        return Err(format!("fourcc {s:?} is not 1-4 printable characters"));
    }
    let mut f = [b' '; 4];
    f[..b.len()].copy_from_slice(b);
    Ok(u32::from_le_bytes(f))
}

impl RecordedStream {
    /// Opens a recorded stream directory.
    pub fn open(dir: &Path) -> Result<Self, CameraError> {
        let p = dir.join("stream.json");
        let bad = |m: String| CameraError::Config(format!("{}: {m}", p.display()));
        let text = std::fs::read_to_string(&p).map_err(|e| bad(e.to_string()))?;
        let header: StreamHeader = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        fourcc_of(&header.format.fourcc).map_err(bad)?;
        let f = &header.format;
        if f.width == 0 || f.height == 0 || f.width > 8192 || f.height > 8192 {
            return Err(bad(format!("size {}x{}", f.width, f.height)));
        }
        if u64::from(f.size_image) > 64 << 20 {
            return Err(bad(format!("buffer size {} bytes", f.size_image)));
        }
        if header.buffers.is_empty() {
            return Err(bad("no buffers".into()));
        }
        Ok(Self {
            header,
            dir: dir.to_path_buf(),
            next: 0,
            loaded: Vec::new(),
            queued: false,
            exposure: None,
            started: false,
        })
    }

    /// The exposure the capture set (100 µs units), if any.
    pub fn exposure(&self) -> Option<i32> {
        self.exposure
    }
}

impl VideoDevice for RecordedStream {
    fn caps(&self) -> Caps {
        Caps {
            driver: self.header.driver.clone(),
            card: self.header.card.clone(),
            capture: true,
            streaming: true,
        }
    }

    fn set_format(&mut self, _want: Format) -> Result<Format, CameraError> {
        let f = &self.header.format;
        Ok(Format {
            width: f.width,
            height: f.height,
            fourcc: fourcc_of(&f.fourcc).map_err(CameraError::Config)?,
            bytes_per_line: f.bytes_per_line,
            size_image: f.size_image,
        })
    }

    fn query_control(&mut self, id: u32) -> Option<ControlRange> {
        let e = self.header.exposure?;
        match id {
            CID_EXPOSURE_AUTO => Some(ControlRange {
                min: 0,
                max: 3,
                step: 1,
                default: 3,
            }),
            CID_EXPOSURE_ABSOLUTE => Some(ControlRange {
                min: e.min,
                max: e.max,
                step: e.step,
                default: e.default,
            }),
            _ => None,
        }
    }

    fn set_control(&mut self, id: u32, value: i32) -> Result<i32, CameraError> {
        if id == CID_EXPOSURE_ABSOLUTE {
            self.exposure = Some(value);
        }
        Ok(value)
    }

    fn start(&mut self, count: u32) -> Result<u32, CameraError> {
        self.started = true;
        Ok(count.min(1))
    }

    fn dequeue(&mut self, timeout: Duration) -> Result<Option<Dequeued>, CameraError> {
        // one buffer in flight; a recording plays out one buffer per call that waits
        if !self.started || self.queued || timeout.is_zero() {
            return Ok(None);
        }
        let Some(b) = self.header.buffers.get(self.next).cloned() else {
            return Err(CameraError::Disconnected {
                device: self.dir.display().to_string(),
                reason: "end of the recorded stream".into(),
            });
        };
        self.next += 1;
        let path = self.dir.join(&b.file);
        self.loaded = std::fs::read(&path).map_err(|e| CameraError::Io {
            device: path.display().to_string(),
            source: e,
        })?;
        self.loaded.truncate(self.header.format.size_image as usize);
        self.queued = true;
        Ok(Some(Dequeued {
            index: 0,
            sequence: b.sequence,
            bytes_used: self.loaded.len() as u32,
            error: b.error,
        }))
    }

    fn buffer(&self, _index: u32) -> &[u8] {
        &self.loaded
    }

    fn requeue(&mut self, _index: u32) -> Result<(), CameraError> {
        self.queued = false;
        Ok(())
    }

    fn stop(&mut self) {
        self.started = false;
    }
}

/// Records `frames` buffers of a started device into `dir` in the [`RecordedStream`] format
/// (the format and exposure range as the driver reported them).
pub fn record<D: VideoDevice>(
    dev: &mut D,
    format: Format,
    exposure: Option<ControlRange>,
    frames: usize,
    timeout: Duration,
    dir: &Path,
) -> Result<StreamHeader, CameraError> {
    let io = |e: std::io::Error| CameraError::Io {
        device: dir.display().to_string(),
        source: e,
    };
    std::fs::create_dir_all(dir).map_err(io)?;
    let caps = dev.caps();
    let mut buffers = Vec::new();
    for k in 0..frames {
        let Some(b) = dev.dequeue(timeout)? else {
            return Err(CameraError::Timeout {
                device: caps.driver.clone(),
                timeout_s: timeout.as_secs_f64(),
            });
        };
        let file = format!("{k:06}.raw");
        let used = (b.bytes_used as usize).min(dev.buffer(b.index).len());
        std::fs::write(dir.join(&file), &dev.buffer(b.index)[..used]).map_err(io)?;
        dev.requeue(b.index)?;
        buffers.push(BufferJson {
            file,
            sequence: b.sequence,
            error: b.error,
        });
    }
    let header = StreamHeader {
        driver: caps.driver,
        card: caps.card,
        format: FormatJson {
            width: format.width,
            height: format.height,
            fourcc: fourcc_str(format.fourcc),
            bytes_per_line: format.bytes_per_line,
            size_image: format.size_image,
        },
        exposure: exposure.map(|r| ControlJson {
            min: r.min,
            max: r.max,
            step: r.step,
            default: r.default,
        }),
        buffers,
    };
    let text =
        serde_json::to_string_pretty(&header).map_err(|e| CameraError::Config(e.to_string()))?;
    std::fs::write(dir.join("stream.json"), text).map_err(io)?;
    Ok(header)
}
