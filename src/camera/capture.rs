//! A capture set on disk (format in `docs/formats.md`, extended in `docs/cameras.md`):
//! `camera.json`, `depth_NNN.png` (16-bit, mm along the optical axis, 0 = no return),
//! `luminance_L<k>.png` (16-bit linear, one luminaire on) and, optionally, `luminance_off.png`
//! (every luminaire off: the daylight and any other light during the capture, in the same
//! encoding). With an off frame, commissioning subtracts it from each one-luminaire frame, so a
//! capture taken in daylight gives the luminaires' own light; a set without one (the reference
//! captures, taken in the dark) reads as before. With `luminance_off_end.png` too (every
//! luminaire off again at the end of the sequence), the daylight subtracted from each frame is
//! interpolated linearly between the two off frames by the frame's place in the sequence
//! (`off`, `L<k>` in order, `all` when `luminance_all.png` is there, `off_end`): daylight that
//! drifts steadily during the capture is taken out of the luminaires' light. `groundtruth/` is
//! never read here.
//!
//! Loading checks what would otherwise panic or silently mislead later stages: missing frames,
//! frames of another size than `camera.json` says, 8-bit or colour frames, depth frames with no
//! returns. Problems that only lose data (saturated pixels, a dark luminaire frame) are counted
//! warnings.

use std::path::{Path, PathBuf};

use crate::scene::{Camera, load_camera_file};

/// A capture file is missing or unusable.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct CaptureError {
    /// The file or directory.
    pub path: PathBuf,
    /// What is wrong.
    pub message: String,
}

/// Saturated value of a 16-bit frame.
pub const SATURATED: u16 = u16::MAX;

/// A 16-bit single-channel frame, row-major.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Values, row-major (`v * width + u`).
    pub data: Vec<u16>,
}

/// Everything a capture set holds that commissioning may use.
#[derive(Debug, Clone)]
pub struct Capture {
    /// The directory.
    pub dir: PathBuf,
    /// The camera (intrinsics, pose, luminance scale if given).
    pub camera: Camera,
    /// Depth frames, mm.
    pub depth_mm: Vec<Frame>,
    /// Luminance frames with one luminaire on: (luminaire id, frame).
    pub luminance: Vec<(u32, Frame)>,
    /// The frame with every luminaire off (daylight, other light), same encoding; `None` for a
    /// capture taken in the dark (the reference sets).
    pub off: Option<Frame>,
    /// The frame with every luminaire off again at the end of the sequence, and its place in
    /// the sequence (the first off frame is 0, luminaire frame `k` is `k + 1`, the all-on frame
    /// when taken the one after the last): the daylight's drift during the capture. Used only
    /// with `off`.
    pub off_end: Option<OffEnd>,
    /// Non-fatal findings.
    pub warnings: Vec<String>,
}

/// The closing all-off frame of a capture ([`Capture::off_end`]).
#[derive(Debug, Clone)]
pub struct OffEnd {
    /// The frame, same encoding as the others.
    pub frame: Frame,
    /// Its place in the sequence (> the number of luminaire frames).
    pub position: usize,
}

/// The closing all-off frame's place in the sequence: camera.json's
/// `luminance_off_end_position`, or, without it, the one after the all-on frame when
/// `luminance_all.png` is there and after the last luminaire frame when not.
fn off_end_position(dir: &Path, luminaires: usize) -> Result<usize, CaptureError> {
    let path = dir.join("camera.json");
    let bad = |message: String| CaptureError {
        path: path.clone(),
        message,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let j: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    match j.get("luminance_off_end_position") {
        None => Ok(luminaires + 1 + usize::from(dir.join("luminance_all.png").exists())),
        Some(v) => match v.as_u64() {
            Some(p) if (luminaires as u64 + 1..=luminaires as u64 + 2).contains(&p) => {
                Ok(p as usize)
            }
            _ => Err(bad(format!(
                "luminance_off_end_position {v}: the closing all-off frame comes right after \
                 the {luminaires} luminaire frames or the all-on frame ({} or {})",
                luminaires + 1,
                luminaires + 2
            ))),
        },
    }
}

/// Reads a 16-bit greyscale PNG frame (the capture format's encoding).
pub fn read_frame16(path: &Path) -> Result<Frame, CaptureError> {
    let bad = |message: String| CaptureError {
        path: path.to_path_buf(),
        message,
    };
    let reader = image::ImageReader::open(path).map_err(|e| bad(format!("cannot open: {e}")))?;
    let img = reader
        .with_guessed_format()
        .map_err(|e| bad(format!("cannot read: {e}")))?
        .decode()
        .map_err(|e| bad(format!("not a readable image: {e}")))?;
    match img {
        image::DynamicImage::ImageLuma16(buf) => Ok(Frame {
            width: buf.width(),
            height: buf.height(),
            data: buf.into_raw(),
        }),
        other => Err(bad(format!(
            "must be a 16-bit greyscale PNG, found {:?}",
            other.color()
        ))),
    }
}

fn check_size(path: &Path, f: &Frame, camera: &Camera) -> Result<(), CaptureError> {
    if f.width != camera.width || f.height != camera.height {
        return Err(CaptureError {
            path: path.to_path_buf(),
            message: format!(
                "frame is {}x{} pixels, camera.json says {}x{}",
                f.width, f.height, camera.width, camera.height
            ),
        });
    }
    Ok(())
}

impl Capture {
    /// Loads a capture set for the given luminaire ids (one `luminance_L<id>.png` each).
    pub fn load(dir: &Path, luminaire_ids: &[u32]) -> Result<Capture, CaptureError> {
        let camera = load_camera_file(&dir.join("camera.json")).map_err(|e| CaptureError {
            path: dir.join("camera.json"),
            message: e.to_string(),
        })?;
        let mut warnings = Vec::new();
        let mut depth_mm = Vec::new();
        for k in 0..1000 {
            let path = dir.join(format!("depth_{k:03}.png"));
            if !path.exists() {
                break;
            }
            let f = read_frame16(&path)?;
            check_size(&path, &f, &camera)?;
            let returns = f.data.iter().filter(|&&d| d > 0).count();
            if returns == 0 {
                warnings.push(format!(
                    "{}: no depth returns, frame ignored",
                    path.display()
                ));
                continue;
            }
            depth_mm.push(f);
        }
        if depth_mm.is_empty() {
            return Err(CaptureError {
                path: dir.to_path_buf(),
                message: "no usable depth frame (depth_000.png, depth_001.png, ...)".into(),
            });
        }
        let mut luminance = Vec::new();
        for &id in luminaire_ids {
            let path = dir.join(format!("luminance_L{id}.png"));
            if !path.exists() {
                return Err(CaptureError {
                    path,
                    message: format!("missing: the frame with only luminaire {id} on"),
                });
            }
            let f = read_frame16(&path)?;
            check_size(&path, &f, &camera)?;
            let n = f.data.len().max(1) as f64;
            let saturated = f.data.iter().filter(|&&v| v == SATURATED).count();
            if saturated as f64 > 0.2 * n {
                warnings.push(format!(
                    "{}: {:.1} % of the pixels saturated (ignored)",
                    path.display(),
                    100.0 * saturated as f64 / n
                ));
            }
            let lit = f.data.iter().filter(|&&v| v > 0 && v < SATURATED).count();
            if (lit as f64) < 0.01 * n {
                warnings.push(format!(
                    "{}: dark frame (luminaire {id} off or broken?): not used for reflectances",
                    path.display()
                ));
            }
            luminance.push((id, f));
        }
        let off_path = dir.join("luminance_off.png");
        let off = if off_path.exists() {
            let f = read_frame16(&off_path)?;
            check_size(&off_path, &f, &camera)?;
            let n = f.data.len().max(1) as f64;
            let saturated = f.data.iter().filter(|&&v| v == SATURATED).count();
            if saturated as f64 > 0.05 * n {
                warnings.push(format!(
                    "{}: {:.1} % of the pixels saturated: the daylight there cannot be \
                     subtracted (those pixels are ignored)",
                    off_path.display(),
                    100.0 * saturated as f64 / n
                ));
            }
            Some(f)
        } else {
            None
        };
        let end_path = dir.join("luminance_off_end.png");
        let off_end = if off.is_some() && end_path.exists() {
            let f = read_frame16(&end_path)?;
            check_size(&end_path, &f, &camera)?;
            let position = off_end_position(dir, luminance.len())?;
            Some(OffEnd { frame: f, position })
        } else {
            None
        };
        Ok(Capture {
            dir: dir.to_path_buf(),
            camera,
            depth_mm,
            luminance,
            off,
            off_end,
            warnings,
        })
    }

    /// The value of luminaire frame `k` at pixel `i` with the daylight subtracted
    /// ([`Self::daylight_value`]), in frame units: `None` where a frame is saturated, or the
    /// difference is not positive (no light from the luminaire there, or daylight noise larger
    /// than it).
    pub fn luminaire_value(&self, k: usize, i: usize) -> Option<f64> {
        let x = *self.luminance.get(k)?.1.data.get(i)?;
        if x == SATURATED || x == 0 {
            return None;
        }
        let v = f64::from(x) - self.daylight_value(k, i)?;
        (v > 0.0).then_some(v)
    }

    /// The daylight in luminaire frame `k` at pixel `i`, frame units: 0 without an off frame;
    /// the off frame's value; with a closing off frame, the two interpolated linearly by the
    /// frame's place in the sequence (clamped at 0). `None` where an off frame is saturated or
    /// the pixel is outside the frame.
    pub fn daylight_value(&self, k: usize, i: usize) -> Option<f64> {
        // a frame's value at the pixel, `None` where saturated or outside
        let at = |f: &Frame| match f.data.get(i) {
            Some(&SATURATED) | None => None,
            Some(&x) => Some(f64::from(x)),
        };
        let Some(first) = &self.off else {
            return Some(0.0);
        };
        let o = at(first)?;
        let Some(end) = &self.off_end else {
            return Some(o);
        };
        let e = at(&end.frame)?;
        let t = (k + 1) as f64 / end.position.max(k + 2) as f64;
        Some((o + t * (e - o)).max(0.0))
    }
}
