//! Replay of a recorded capture directory (format: `docs/formats.md`) as the two
//! cameras and the light control.
//!
//! The depth camera serves `depth_000.png`, `depth_001.png`, ... in turn (and starts over). The
//! luminance camera serves the frame that matches the levels last set on the [`ReplayWorld`]:
//!
//! | levels | frame served |
//! |---|---|
//! | only luminaire k on, at 1 | `luminance_L<k>.png`, byte for byte |
//! | all on at 1, and `luminance_all.png` exists | `luminance_all.png`, byte for byte |
//! | anything else | `O + Σ_k x_k (L_k − O)` (luminance is linear), rounded; saturated where a contributing frame is |
//! | all off | `luminance_off.png` (`O`, the daylight), or zeros for a set without one |
//!
//! Frames carry `camera.json`'s `luminance_cd_m2_per_unit`; without it a luminance capture is a
//! configuration error. Exposure times are not recorded in the format and are reported as 0.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

use super::{CameraError, DepthCamera, DepthFrame, LightControl, LuminanceCamera, LuminanceFrame};
use crate::camera::capture::{Capture, Frame};
use crate::scene::Camera;

struct Data {
    capture: Capture,
    all_on: Option<Frame>,
}

/// A recorded capture, served as cameras; the light control selects the luminance frame.
#[derive(Clone)]
pub struct ReplayWorld {
    data: Arc<Data>,
    levels: Arc<Mutex<Vec<f64>>>,
    device: String,
}

fn read_png16(path: &Path) -> Result<Frame, CameraError> {
    let bad = |reason: String| CameraError::Garbage {
        device: path.display().to_string(),
        reason,
    };
    let img = image::ImageReader::open(path)
        .map_err(|source| CameraError::Io {
            device: path.display().to_string(),
            source,
        })?
        .with_guessed_format()
        .map_err(|source| CameraError::Io {
            device: path.display().to_string(),
            source,
        })?
        .decode()
        .map_err(|e| bad(format!("not a readable image: {e}")))?;
    match img {
        image::DynamicImage::ImageLuma16(b) => Ok(Frame {
            width: b.width(),
            height: b.height(),
            data: b.into_raw(),
        }),
        other => Err(bad(format!(
            "must be a 16-bit greyscale PNG, found {:?}",
            other.color()
        ))),
    }
}

impl ReplayWorld {
    /// Opens a capture directory for the given luminaire ids (level order).
    pub fn open(dir: &Path, luminaire_ids: &[u32]) -> Result<ReplayWorld, CameraError> {
        let capture = Capture::load(dir, luminaire_ids)
            .map_err(|e| CameraError::Config(format!("replay: {e}")))?;
        let all_path = dir.join("luminance_all.png");
        let all_on = if all_path.exists() {
            let f = read_png16(&all_path)?;
            if f.width != capture.camera.width || f.height != capture.camera.height {
                return Err(CameraError::Config(format!(
                    "{}: {}x{} pixels, camera.json says {}x{}",
                    all_path.display(),
                    f.width,
                    f.height,
                    capture.camera.width,
                    capture.camera.height
                )));
            }
            Some(f)
        } else {
            None
        };
        Ok(ReplayWorld {
            levels: Arc::new(Mutex::new(vec![0.0; luminaire_ids.len()])),
            data: Arc::new(Data { capture, all_on }),
            device: dir.display().to_string(),
        })
    }

    /// The capture as loaded.
    pub fn capture(&self) -> &Capture {
        &self.data.capture
    }

    /// The directory.
    pub fn dir(&self) -> PathBuf {
        self.data.capture.dir.clone()
    }

    /// The depth camera.
    pub fn depth_camera(&self) -> ReplayDepthCamera {
        ReplayDepthCamera {
            world: self.clone(),
            next: 0,
        }
    }

    /// The luminance camera.
    pub fn luminance_camera(&self) -> ReplayLuminanceCamera {
        ReplayLuminanceCamera {
            world: self.clone(),
        }
    }

    /// The luminance frame for levels (see the module docs).
    pub fn frame_for(&self, levels: &[f64]) -> Frame {
        let c = &self.data.capture;
        let (w, h) = (c.camera.width, c.camera.height);
        let on: Vec<usize> = (0..levels.len()).filter(|&k| levels[k] > 0.0).collect();
        if on.len() == 1 && levels[on[0]] == 1.0 {
            return c.luminance[on[0]].1.clone();
        }
        if on.len() == levels.len()
            && levels.iter().all(|&x| x == 1.0)
            && let Some(f) = &self.data.all_on
        {
            return f.clone();
        }
        if on.is_empty()
            && let Some(f) = &c.off
        {
            return f.clone();
        }
        let n = (w as usize) * (h as usize);
        let data = (0..n)
            .map(|i| {
                let off = c.off.as_ref().map_or(0, |f| f.data[i]);
                if off == u16::MAX {
                    return u16::MAX;
                }
                let mut sum = f64::from(off);
                for &k in &on {
                    let x = c.luminance[k].1.data[i];
                    if x == u16::MAX {
                        return u16::MAX;
                    }
                    sum += levels[k] * (f64::from(x) - f64::from(off));
                }
                sum.round().clamp(0.0, 65535.0) as u16
            })
            .collect();
        Frame {
            width: w,
            height: h,
            data,
        }
    }
}

impl LightControl for ReplayWorld {
    fn set_levels(&mut self, levels: &[f64]) -> Result<(), CameraError> {
        let n = self.data.capture.luminance.len();
        super::check_levels(levels, n)?;
        *self.levels.lock().unwrap_or_else(|p| p.into_inner()) = levels.to_vec();
        Ok(())
    }
}

/// The recorded depth frames, in turn.
pub struct ReplayDepthCamera {
    world: ReplayWorld,
    next: usize,
}

impl DepthCamera for ReplayDepthCamera {
    fn camera(&self) -> &Camera {
        &self.world.data.capture.camera
    }

    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
        let frames = &self.world.data.capture.depth_mm;
        let Some(f) = frames.get(self.next % frames.len().max(1)) else {
            return Err(CameraError::Disconnected {
                device: self.world.device.clone(),
                reason: "no depth frames".into(),
            });
        };
        self.next += 1;
        Ok(DepthFrame {
            width: f.width,
            height: f.height,
            depth_mm: f.data.clone(),
            timestamp: SystemTime::now(),
            exposure_s: 0.0,
        })
    }
}

/// The recorded luminance frame matching the current levels.
pub struct ReplayLuminanceCamera {
    world: ReplayWorld,
}

impl LuminanceCamera for ReplayLuminanceCamera {
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
        let cd_m2_per_unit = self
            .world
            .data
            .capture
            .camera
            .luminance_cd_m2_per_unit
            .ok_or_else(|| {
                CameraError::Config(format!(
                    "{}: camera.json has no luminance_cd_m2_per_unit",
                    self.world.device
                ))
            })?;
        let levels = self
            .world
            .levels
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone();
        let f = self.world.frame_for(&levels);
        Ok(LuminanceFrame {
            width: f.width,
            height: f.height,
            data: f.data,
            cd_m2_per_unit,
            timestamp: SystemTime::now(),
            exposure_s: 0.0,
        })
    }
}
