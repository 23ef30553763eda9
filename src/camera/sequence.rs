//! The commissioning capture sequence and writing a capture set to disk.
//!
//! ```text
//! all off ─► N depth frames ─► one luminance frame, all off (the daylight)
//!         ─► for each luminaire k: only k on ─► one luminance frame
//!         ─► all on ─► one luminance frame ─► all off ─► one more all-off frame (drift check)
//! ```
//!
//! The all-off frames make commissioning work with daylight in the room: commissioning
//! subtracts the daylight from every one-luminaire frame (`capture::Capture::luminaire_value`),
//! interpolated linearly between the first and the last off frame by the frame's place in the
//! sequence, so a steady drift of the daylight during the capture cancels. The last one is also
//! compared with the first: daylight that changed during the capture by more than
//! [`DAYLIGHT_DRIFT_WARNING`] is a warning (a change that is not steady, a cloud passing, is
//! not taken out).
//!
//! A frame that fails with a transient error (timeout, garbage) is retried up to `retries`
//! times; each retry is counted in the capture's warnings. Any other error, or a frame still
//! failing after its retries, ends the sequence with that error. The luminaires are switched
//! all off at the end, also when the sequence fails (best effort: a failure to do so on the
//! error path is logged, the original error is returned).

use std::path::{Path, PathBuf};
use std::time::Duration;

use super::register::{Registration, RegistrationMap, median_depth};
use super::{CameraError, DepthCamera, LightControl, LuminanceCamera, LuminanceFrame};
use crate::camera::capture::{Capture, Frame, OffEnd};
use crate::scene::Camera;

/// Knobs of the sequence beyond the interface's arguments.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceOptions {
    /// Depth frames to take.
    pub depth_frames: usize,
    /// Retries per frame for transient errors.
    pub retries: usize,
    /// Wait after switching the luminaires before the next frame (lamp run-up, DALI fade).
    pub settle: Duration,
    /// Frames thrown away after each switch (auto exposure catching up; 0 for the simulation).
    pub discard_after_switch: usize,
    /// Take the all-on frame (a consistency check: it should equal the sum of the singles).
    pub all_on_frame: bool,
    /// Take the all-off frames (the daylight during the capture, subtracted at commissioning;
    /// and the drift check at the end).
    pub off_frame: bool,
    /// The colour camera's calibration relative to the ToF camera: when given, every colour
    /// frame is resampled onto the ToF grid with the per-pixel median of the depth frames
    /// ([`super::register`]); when `None`, colour frames must already be registered (the
    /// simulation, replay) and of the ToF camera's size.
    pub registration: Option<Registration>,
}

impl Default for SequenceOptions {
    fn default() -> Self {
        Self {
            depth_frames: 5,
            retries: 3,
            settle: Duration::ZERO,
            discard_after_switch: 0,
            all_on_frame: true,
            off_frame: true,
            registration: None,
        }
    }
}

/// Everything the sequence took.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// The capture set commissioning reads (`dir` is empty: it is not on disk).
    pub capture: Capture,
    /// The all-on luminance frame (same scale as the single ones), if taken.
    pub all_on: Option<Frame>,
    /// Retries spent.
    pub retries_used: usize,
    /// Largest relative difference between the all-on frame and the sum of the single frames
    /// over well-exposed pixels (a luminaire that did not switch shows here).
    pub superposition_error: Option<f64>,
    /// How much the daylight changed during the capture: the median relative difference of the
    /// last all-off frame from the first over the pixels lit in both (`None` without off frames
    /// or in the dark).
    pub daylight_drift: Option<f64>,
}

/// Daylight drift during a capture above which the sequence warns.
pub const DAYLIGHT_DRIFT_WARNING: f64 = 0.05;

/// The commissioning capture sequence: `depth_frames` depth frames, then for each luminaire in
/// turn only that one on, one luminance frame, then all on; restores all off at the end. Retries
/// a failed frame up to `retries` times (counted in the returned Capture's warnings), an error
/// after that. `progress` is called with (step, total, what).
#[allow(clippy::too_many_arguments)]
pub fn capture_sequence(
    depth: &mut dyn DepthCamera,
    colour: &mut dyn LuminanceCamera,
    lights: &mut dyn LightControl,
    luminaire_ids: &[u32],
    depth_frames: usize,
    retries: usize,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Capture, CameraError> {
    let o = SequenceOptions {
        depth_frames,
        retries,
        ..SequenceOptions::default()
    };
    capture_sequence_with(depth, colour, lights, luminaire_ids, &o, progress).map(|s| s.capture)
}

fn with_retries<T>(
    what: &str,
    retries: usize,
    used: &mut usize,
    warnings: &mut Vec<String>,
    mut f: impl FnMut() -> Result<T, CameraError>,
) -> Result<T, CameraError> {
    let mut attempt = 0;
    loop {
        match f() {
            Ok(x) => return Ok(x),
            Err(e) if e.is_transient() && attempt < retries => {
                attempt += 1;
                *used += 1;
                warnings.push(format!("{what}: {e}; retry {attempt} of {retries}"));
            }
            Err(e) => return Err(e),
        }
    }
}

fn check_size(what: &str, w: u32, h: u32, cam: &Camera, len: usize) -> Result<(), CameraError> {
    if w != cam.width || h != cam.height {
        return Err(CameraError::Config(format!(
            "{what} is {w}x{h} pixels, the depth camera's frame is {}x{} (frames must be \
             registered: give the colour camera's calibration, [camera.colour.registration] in \
             the board file)",
            cam.width, cam.height
        )));
    }
    if len != (w as usize) * (h as usize) {
        return Err(CameraError::Garbage {
            device: what.into(),
            reason: format!("{len} values for {w}x{h} pixels"),
        });
    }
    Ok(())
}

/// Brings a luminance frame to the reference scale (values × own/reference, saturation kept).
fn rescale(f: &LuminanceFrame, reference_cd_m2_per_unit: f64) -> Frame {
    let k = f.cd_m2_per_unit / reference_cd_m2_per_unit;
    let data = if (k - 1.0).abs() < 1e-12 {
        f.data.clone()
    } else {
        f.data
            .iter()
            .map(|&x| {
                if x == u16::MAX {
                    u16::MAX
                } else {
                    (f64::from(x) * k).round().min(65535.0) as u16
                }
            })
            .collect()
    };
    Frame {
        width: f.width,
        height: f.height,
        data,
    }
}

/// [`capture_sequence`] with every knob, returning the all-on frame too.
pub fn capture_sequence_with(
    depth: &mut dyn DepthCamera,
    colour: &mut dyn LuminanceCamera,
    lights: &mut dyn LightControl,
    luminaire_ids: &[u32],
    o: &SequenceOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Sequence, CameraError> {
    if luminaire_ids.is_empty() {
        return Err(CameraError::Config("no luminaires to capture".into()));
    }
    if o.depth_frames == 0 {
        return Err(CameraError::Config(
            "at least one depth frame is needed".into(),
        ));
    }
    let result = run(depth, colour, lights, luminaire_ids, o, progress);
    let off = vec![0.0; luminaire_ids.len()];
    match result {
        Ok(s) => {
            lights.set_levels(&off)?;
            Ok(s)
        }
        Err(e) => {
            if let Err(e2) = lights.set_levels(&off) {
                tracing::warn!("could not switch the luminaires off after a failed capture: {e2}");
            }
            Err(e)
        }
    }
}

fn run(
    depth: &mut dyn DepthCamera,
    colour: &mut dyn LuminanceCamera,
    lights: &mut dyn LightControl,
    ids: &[u32],
    o: &SequenceOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Sequence, CameraError> {
    let n = ids.len();
    let total = o.depth_frames + n + usize::from(o.all_on_frame) + 2 * usize::from(o.off_frame);
    let mut step = 0;
    let mut warnings = Vec::new();
    let mut used = 0;
    let mut camera = depth.camera().clone();

    // depth with everything off (a ToF camera does not care, but the luminaires start known)
    lights.set_levels(&vec![0.0; n])?;
    let mut switch = |levels: &[f64], colour: &mut dyn LuminanceCamera| {
        lights.set_levels(levels)?;
        if !o.settle.is_zero() {
            std::thread::sleep(o.settle);
        }
        for _ in 0..o.discard_after_switch {
            // a thrown-away frame may fail: only the kept one counts
            let _ = colour.capture_luminance();
        }
        Ok::<(), CameraError>(())
    };

    let mut depth_mm = Vec::with_capacity(o.depth_frames);
    for k in 0..o.depth_frames {
        let what = format!("depth frame {}/{}", k + 1, o.depth_frames);
        progress(step, total, &what);
        let f = with_retries(&what, o.retries, &mut used, &mut warnings, || {
            depth.capture_depth()
        })?;
        check_size(&what, f.width, f.height, &camera, f.depth_mm.len())?;
        depth_mm.push(f.to_frame());
        step += 1;
    }

    let map = registration_map(o.registration.as_ref(), &camera, &depth_mm, &mut warnings)?;
    let mut scale: Option<f64> = None;
    let mut luminance = Vec::with_capacity(n);
    let take = |what: &str,
                colour: &mut dyn LuminanceCamera,
                scale: &mut Option<f64>,
                warnings: &mut Vec<String>,
                used: &mut usize|
     -> Result<Frame, CameraError> {
        let f = with_retries(what, o.retries, used, warnings, || {
            colour.capture_luminance()
        })?;
        let f = match &map {
            Some(m) => m.apply(&f)?,
            None => f,
        };
        check_size(what, f.width, f.height, &camera, f.data.len())?;
        if !(f.cd_m2_per_unit.is_finite() && f.cd_m2_per_unit > 0.0) {
            return Err(CameraError::Garbage {
                device: what.into(),
                reason: format!("scale {} cd/m² per unit", f.cd_m2_per_unit),
            });
        }
        let reference = *scale.get_or_insert(f.cd_m2_per_unit);
        Ok(rescale(&f, reference))
    };
    let mut off = None;
    if o.off_frame {
        let what = "luminance frame, all off (daylight)";
        progress(step, total, what);
        // the luminaires are off since the depth frames: no switch, no settling
        off = Some(take(what, colour, &mut scale, &mut warnings, &mut used)?);
        step += 1;
    }
    for (k, &id) in ids.iter().enumerate() {
        let what = format!("luminance frame, luminaire {id} on");
        progress(step, total, &what);
        let mut levels = vec![0.0; n];
        levels[k] = 1.0;
        switch(&levels, colour)?;
        let f = take(&what, colour, &mut scale, &mut warnings, &mut used)?;
        luminance.push((id, f));
        step += 1;
    }
    let mut all_on = None;
    let mut superposition_error = None;
    if o.all_on_frame {
        let what = "luminance frame, all on";
        progress(step, total, what);
        switch(&vec![1.0; n], colour)?;
        let f = take(what, colour, &mut scale, &mut warnings, &mut used)?;
        superposition_error = superposition(&f, &luminance, off.as_ref());
        if let Some(e) = superposition_error.filter(|e| *e > 0.1) {
            warnings.push(format!(
                "the all-on frame differs from the sum of the single-luminaire frames by up to \
                 {:.0} % (a luminaire that did not switch, or the daylight changed?)",
                100.0 * e
            ));
        }
        all_on = Some(f);
        step += 1;
    }
    let mut daylight_drift = None;
    let mut off_end = None;
    if let Some(first) = &off {
        let what = "luminance frame, all off again (daylight drift)";
        progress(step, total, what);
        switch(&vec![0.0; n], colour)?;
        let last = take(what, colour, &mut scale, &mut warnings, &mut used)?;
        daylight_drift = drift(first, &last);
        if let Some(d) = daylight_drift.filter(|d| *d > DAYLIGHT_DRIFT_WARNING) {
            warnings.push(format!(
                "the daylight changed by {:.0} % during the capture: a steady change is taken \
                 out of the one-luminaire frames, any other is not (commission again when the \
                 light is steady, or at night)",
                100.0 * d
            ));
        }
        off_end = Some(OffEnd {
            frame: last,
            position: n + 1 + usize::from(all_on.is_some()),
        });
        step += 1;
    }
    progress(step, total, "done");
    camera.luminance_cd_m2_per_unit = scale;
    Ok(Sequence {
        capture: Capture {
            dir: PathBuf::new(),
            camera,
            depth_mm,
            luminance,
            off,
            off_end,
            warnings,
        },
        all_on,
        retries_used: used,
        superposition_error,
        daylight_drift,
    })
}

/// The median relative difference between two all-off frames over the pixels well exposed in
/// both (`None` when fewer than 1 % of the pixels are: a dark room).
fn drift(a: &Frame, b: &Frame) -> Option<f64> {
    let mut rel: Vec<f64> = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| **x >= 50 && **y >= 50 && **x != u16::MAX && **y != u16::MAX)
        .map(|(x, y)| (f64::from(*y) - f64::from(*x)).abs() / f64::from(*x))
        .collect();
    if rel.len() * 100 < a.data.len() {
        return None;
    }
    rel.sort_by(f64::total_cmp);
    Some(rel[rel.len() / 2])
}

/// The resampling of the colour frames for this capture's geometry (the median depth), with a
/// warning when fewer than half the pixels with depth get a colour value.
fn registration_map(
    registration: Option<&Registration>,
    camera: &Camera,
    depth_mm: &[Frame],
    warnings: &mut Vec<String>,
) -> Result<Option<RegistrationMap>, CameraError> {
    let Some(r) = registration else {
        return Ok(None);
    };
    let depth = median_depth(depth_mm).ok_or_else(|| {
        CameraError::Config("registration: the depth frames differ in size".into())
    })?;
    let map = r.map(camera, &depth)?;
    let c = map.counts();
    let with_depth = c.mapped + c.out_of_view + c.occluded;
    if c.mapped * 2 < with_depth {
        warnings.push(format!(
            "registration: only {} of {} pixels with depth have a colour value ({} outside the \
             colour image, {} occluded): check the colour camera's calibration",
            c.mapped, with_depth, c.out_of_view, c.occluded
        ));
    }
    Ok(Some(map))
}

/// Relative difference between the all-on frame and the sum of the singles (each less the
/// all-off frame, when there is one), over pixels that are well exposed in the all-on frame and
/// saturated nowhere: the 99th percentile (a few pixels on a shadow edge may differ by
/// rounding).
fn superposition(all: &Frame, singles: &[(u32, Frame)], off: Option<&Frame>) -> Option<f64> {
    let mut rel = Vec::new();
    'px: for (i, &a) in all.data.iter().enumerate() {
        if a < 1000 || a == u16::MAX {
            continue;
        }
        let o = match off.map(|f| f.data[i]) {
            Some(u16::MAX) => continue,
            Some(o) => f64::from(o),
            None => 0.0,
        };
        // all on = off + Σ (single − off)
        let mut sum = o;
        for (_, f) in singles {
            let x = f.data[i];
            if x == u16::MAX {
                continue 'px;
            }
            sum += f64::from(x) - o;
        }
        rel.push((sum - f64::from(a)).abs() / f64::from(a));
    }
    if rel.is_empty() {
        return None;
    }
    rel.sort_by(f64::total_cmp);
    Some(rel[(rel.len() - 1) * 99 / 100])
}

fn write_png16(path: &Path, f: &Frame) -> Result<(), CameraError> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
        f.width,
        f.height,
        f.data.clone(),
    )
    .ok_or_else(|| CameraError::Config(format!("{}: frame size mismatch", path.display())))?;
    img.save(path).map_err(|e| CameraError::Io {
        device: path.display().to_string(),
        source: std::io::Error::other(e.to_string()),
    })
}

/// Writes a capture set in the shared format (`camera.json`, `depth_NNN.png`,
/// `luminance_L<id>.png`, `luminance_off.png` when the capture has an all-off frame,
/// `luminance_all.png`), so it can be commissioned from or replayed.
pub fn save_capture(
    dir: &Path,
    capture: &Capture,
    all_on: Option<&Frame>,
) -> Result<(), CameraError> {
    let io = |source: std::io::Error| CameraError::Io {
        device: dir.display().to_string(),
        source,
    };
    std::fs::create_dir_all(dir).map_err(io)?;
    let c = &capture.camera;
    let m = c.world_from_camera;
    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
    let mut j = serde_json::json!({
        "position": c.position_m.to_array(),
        "look": z.to_array(),
        "up": (-y).to_array(),
        "right": x.to_array(),
        "width": c.width,
        "height": c.height,
        "fx": c.fx,
        "fy": c.fy,
        "cx": c.cx,
        "cy": c.cy,
        // rows of the matrix whose columns are the camera axes
        "R_world_from_camera": [[x.x, y.x, z.x], [x.y, y.y, z.y], [x.z, y.z, z.z]],
        "encodings": {
            "depth_png": "uint16 millimetres along the camera optical axis (z_cam), 0 = no return",
            "luminance_png": "uint16 linear, luminance_cd_per_m2 = value * luminance_cd_m2_per_unit, clipped at 65535",
            "luminance_off_png": "as luminance_png, every luminaire off (the daylight during the capture); commissioning subtracts it from each luminance_L<k>.png",
            "luminance_off_end_png": "as luminance_png, every luminaire off again at the end of the sequence, frame luminance_off_end_position of it (luminance_off.png is 0, luminance_L<k> the k-th after it, then the all-on frame if taken; without the key: after luminance_all.png when there is one); the daylight subtracted from each frame is interpolated linearly between the two off frames by its place",
        },
    });
    if let Some(s) = c.luminance_cd_m2_per_unit {
        j["luminance_cd_m2_per_unit"] = serde_json::json!(s);
    }
    if let Some(e) = &capture.off_end {
        j["luminance_off_end_position"] = serde_json::json!(e.position);
    }
    if c.lens.is_fisheye() {
        j["model"] = serde_json::json!(c.lens.model_name());
        j["k"] = serde_json::json!(c.lens.k());
    }
    let text = serde_json::to_string_pretty(&j)
        .map_err(|e| CameraError::Config(format!("camera.json: {e}")))?;
    std::fs::write(dir.join("camera.json"), text).map_err(io)?;
    for (k, f) in capture.depth_mm.iter().enumerate() {
        write_png16(&dir.join(format!("depth_{k:03}.png")), f)?;
    }
    for (id, f) in &capture.luminance {
        write_png16(&dir.join(format!("luminance_L{id}.png")), f)?;
    }
    if let Some(f) = &capture.off {
        write_png16(&dir.join("luminance_off.png"), f)?;
    }
    if let Some(e) = &capture.off_end {
        write_png16(&dir.join("luminance_off_end.png"), &e.frame)?;
    }
    if let Some(f) = all_on {
        write_png16(&dir.join("luminance_all.png"), f)?;
    }
    Ok(())
}
