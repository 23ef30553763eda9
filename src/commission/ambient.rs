//! The camera's absolute gain from the node's ambient light sensor, measured directly.
//!
//! A sensor of angular response `s(θ)` (about its normal `n`) in a luminance field reads
//! `E = ∫ L(ω) s(θ) dω` (physics.md §3.5). The colour camera, a centimetre away, measures the
//! same field: pixel `i` sees luminance `L_i = g · x_i` (g the camera's gain in cd/m² per
//! unit, x_i the frame's value) over its solid angle `Δω_i`. Where the sensor sees only what
//! the camera sees (a hooded sensor, [`crate::lsc::Lsc::hooded`], inside the camera's field),
//!
//! `E = g · Σ_i x_i s(θ_i) Δω_i`, so `g = E / Σ_i x_i s(θ_i) Δω_i`,
//!
//! with no model of the room at all: no reflectance, no unseen wall enters. A bare (cosine)
//! sensor sees the whole lower hemisphere, walls and floor the camera does not see, and the
//! gain can then only come through the model (`Gain::Ambient`'s bisection), whose unseen
//! walls' default reflectance moves it: on the demo office, walls at 0.5 → 0.6 move that gain
//! by −18 % (docs/peripherals.md).
//!
//! Both sides are the luminaires' own light. The sensor's reading is one with the luminaires at
//! `levels` less one with them all off (`daemon::source`), and the frame is
//! `Σ_k level_k (L_k − O_k)` from the capture set's one-luminaire frames `L_k` less the daylight
//! in each (`O_k`: the all-off frames interpolated, [`Capture::daylight_value`]; nothing for a
//! set taken in the dark). Daylight that changes between the capture and the reading therefore
//! enters neither. `Δω_i` is the area of the pixel's footprint
//! on the unit sphere, from the lens's rays through the pixel's edges (pinhole or fisheye
//! alike). Parallax between the sensor and the camera (about 1 cm against metres) is ignored.

use glam::DVec3;

use crate::camera::capture::{Capture, SATURATED};
use crate::lsc::AngularResponse;

/// Below this share of the sensor's response inside the camera's image, the direct gain is not
/// used (the rest would be guessed).
pub const MIN_COVERED: f64 = 0.98;
/// Above this share of the response on saturated pixels, the direct gain is not used.
pub const MAX_SATURATED: f64 = 0.01;

/// The direct comparison of the sensor with the camera.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectGain {
    /// The camera's gain, cd/m² per unit.
    pub gain_cd_m2_per_unit: f64,
    /// Share of the sensor's `∫ s dω` inside the image (1: it sees only what the camera sees).
    pub covered: f64,
    /// Share of the covered response on saturated pixels.
    pub saturated: f64,
    /// The sensor's reading predicted from the frame at that gain, per unit gain
    /// (`Σ x_i s(θ_i) Δω_i`, lx per (cd/m² per unit)).
    pub response_per_gain: f64,
}

/// Why the direct gain cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DirectGainError {
    /// The sensor sees beyond the camera's image.
    #[error(
        "the ambient light sensor sees beyond the camera's image ({:.1} % of its response \
         inside, {:.0} % needed)",
        100.0 * covered,
        100.0 * MIN_COVERED
    )]
    NotCovered {
        /// Share of the response inside the image.
        covered: f64,
    },
    /// Too much of what it sees is saturated in the frames.
    #[error(
        "{:.1} % of the ambient light sensor's view is saturated in the camera's frames",
        100.0 * saturated
    )]
    Saturated {
        /// Share of the response on saturated pixels.
        saturated: f64,
    },
    /// Bad input: levels, reading or frames.
    #[error("{0}")]
    Input(String),
}

/// The camera's gain from a reading `lux_lx` of a sensor with `response` facing `normal`,
/// taken with the luminaires at `levels` (capture order), in the light of the capture's frames.
pub fn direct_gain(
    capture: &Capture,
    response: &AngularResponse,
    normal: DVec3,
    lux_lx: f64,
    levels: &[f64],
) -> Result<DirectGain, DirectGainError> {
    let n = normal.normalize_or_zero();
    if n == DVec3::ZERO || !n.is_finite() {
        return Err(DirectGainError::Input(
            "the ambient light sensor's facing is not a direction".into(),
        ));
    }
    if !(lux_lx.is_finite() && lux_lx > 0.0) {
        return Err(DirectGainError::Input(format!(
            "ambient light sensor reading {lux_lx} lx: need a reading > 0 lx"
        )));
    }
    if levels.len() != capture.luminance.len() || levels.iter().any(|x| !(0.0..=1.0).contains(x)) {
        return Err(DirectGainError::Input(format!(
            "ambient light sensor reading: {} levels in [0, 1] needed, one per luminaire frame",
            capture.luminance.len()
        )));
    }
    let cam = &capture.camera;
    let (w, h) = (cam.width, cam.height);
    let pixels = (w as usize) * (h as usize);
    let frames_ok = capture
        .luminance
        .iter()
        .all(|(_, f)| f.data.len() == pixels)
        && capture.off.as_ref().is_none_or(|f| f.data.len() == pixels);
    if !frames_ok {
        return Err(DirectGainError::Input(
            "the luminance frames do not match the camera's size".into(),
        ));
    }
    let total_sr = response.projected_solid_angle_sr();
    if !(total_sr.is_finite() && total_sr > 0.0) {
        return Err(DirectGainError::Input(
            "the ambient light sensor's response is zero everywhere".into(),
        ));
    }
    let (mut sum, mut seen_sr, mut saturated_sr) = (0.0f64, 0.0f64, 0.0f64);
    for v in 0..h {
        for u in 0..w {
            let (uf, vf) = (f64::from(u), f64::from(v));
            let Some(d) = cam.ray_world(uf, vf) else {
                continue;
            };
            let cos_t = d.dot(n);
            if cos_t <= 0.0 {
                continue;
            }
            let s = response.response(cos_t.clamp(-1.0, 1.0).acos());
            if s <= 0.0 {
                continue;
            }
            let Some(d_omega) = pixel_solid_angle_sr(cam, uf, vf) else {
                continue;
            };
            let weight = s * d_omega;
            seen_sr += weight;
            let i = (v as usize) * (w as usize) + u as usize;
            match pixel_value(capture, levels, i) {
                Some(x) => sum += x * weight,
                None => saturated_sr += weight,
            }
        }
    }
    let covered = (seen_sr / total_sr).min(1.0);
    if covered < MIN_COVERED {
        return Err(DirectGainError::NotCovered { covered });
    }
    let saturated = saturated_sr / seen_sr;
    if saturated > MAX_SATURATED {
        return Err(DirectGainError::Saturated { saturated });
    }
    // the uncovered sliver and the saturated pixels read as the rest, on average
    let response_per_gain = sum * total_sr / (seen_sr - saturated_sr);
    if !(response_per_gain.is_finite() && response_per_gain > 0.0) {
        return Err(DirectGainError::Input(
            "the camera's frames are dark where the ambient light sensor looks".into(),
        ));
    }
    Ok(DirectGain {
        gain_cd_m2_per_unit: lux_lx / response_per_gain,
        covered,
        saturated,
        response_per_gain,
    })
}

/// The luminaires' own light at pixel `i` for the dimming state, frame units: each
/// luminaire's frame less the daylight at its time. `None` where a frame is saturated.
fn pixel_value(capture: &Capture, levels: &[f64], i: usize) -> Option<f64> {
    let mut x = 0.0;
    for (k, ((_, f), &level)) in capture.luminance.iter().zip(levels).enumerate() {
        if level == 0.0 {
            continue;
        }
        match f.data[i] {
            SATURATED => return None,
            v => x += level * (f64::from(v) - capture.daylight_value(k, i)?),
        }
    }
    Some(x.max(0.0))
}

/// The solid angle pixel (u, v) subtends, sr: the footprint of its edges' rays on the unit
/// sphere (the cross product of the differences across the pixel).
pub fn pixel_solid_angle_sr(cam: &crate::scene::Camera, u: f64, v: f64) -> Option<f64> {
    let l = cam.ray_world(u - 0.5, v)?;
    let r = cam.ray_world(u + 0.5, v)?;
    let t = cam.ray_world(u, v - 0.5)?;
    let b = cam.ray_world(u, v + 0.5)?;
    let a = (r - l).cross(b - t).length();
    a.is_finite().then_some(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::capture::Frame;
    use crate::lsc::Lsc;
    use crate::scene::{Camera, Lens};
    use glam::DMat3;
    use std::path::PathBuf;

    fn camera(lens: Lens, f: f64) -> Camera {
        Camera {
            position_m: DVec3::new(0.0, 0.0, 3.0),
            world_from_camera: DMat3::from_cols(DVec3::Y, DVec3::X, DVec3::NEG_Z),
            fx: f,
            fy: f,
            cx: 159.5,
            cy: 119.5,
            width: 320,
            height: 240,
            luminance_cd_m2_per_unit: None,
            lens,
        }
    }

    fn capture(cam: Camera, value: u16, off: Option<u16>) -> Capture {
        let frame = |x: u16| Frame {
            width: cam.width,
            height: cam.height,
            data: vec![x; (cam.width * cam.height) as usize],
        };
        Capture {
            dir: PathBuf::new(),
            depth_mm: vec![],
            luminance: vec![(1, frame(value)), (2, frame(value))],
            off: off.map(frame),
            off_end: None,
            camera: cam,
            warnings: vec![],
        }
    }

    #[test]
    fn pixel_solid_angles_sum_to_the_field_of_view() {
        // a pinhole of half-fields atan(160/f), atan(120/f): the rectangle's solid angle is
        // 4 asin(sin α sin β) (α, β the half-fields)
        let cam = camera(Lens::Pinhole, 160.0);
        let mut sum = 0.0;
        for v in 0..cam.height {
            for u in 0..cam.width {
                sum += pixel_solid_angle_sr(&cam, f64::from(u), f64::from(v)).unwrap();
            }
        }
        let (a, b) = ((160.0f64 / 160.0).atan(), (120.0f64 / 160.0).atan());
        let want = 4.0 * (a.sin() * b.sin()).asin();
        assert!((sum / want - 1.0).abs() < 1e-3, "{sum} vs {want}");
    }

    #[test]
    fn a_uniform_field_gives_the_gain_back() {
        // uniform luminance x·g everywhere: the sensor reads g·x·∫s dω
        let hood = AngularResponse::Table(Lsc::hooded(30f64.to_radians()).unwrap());
        let g = 0.02;
        let x = 1000.0;
        for (lens, f) in [
            (Lens::Pinhole, 160.0),
            (Lens::KannalaBrandt { k: [0.0; 4] }, 100.0),
        ] {
            let c = capture(camera(lens, f), 1000, None);
            // both luminaires at half: 0.5 x + 0.5 x = x
            let lux = g * x * hood.projected_solid_angle_sr();
            let r = direct_gain(&c, &hood, DVec3::NEG_Z, lux, &[0.5, 0.5]).unwrap();
            assert!((r.gain_cd_m2_per_unit / g - 1.0).abs() < 2e-3, "{r:?}");
            assert!(r.covered > 0.999 && r.saturated == 0.0, "{r:?}");
        }
        // daylight: off frame 400, one-luminaire frames 1000 (600 of luminaire light each); the
        // sensor's lights-on less lights-off reading is the luminaire's 600 alone
        let c = capture(camera(Lens::Pinhole, 160.0), 1000, Some(400));
        let lux = g * 600.0 * hood.projected_solid_angle_sr();
        let r = direct_gain(&c, &hood, DVec3::NEG_Z, lux, &[1.0, 0.0]).unwrap();
        assert!((r.gain_cd_m2_per_unit / g - 1.0).abs() < 2e-3, "{r:?}");
    }

    #[test]
    fn a_bare_sensor_or_a_saturated_view_is_refused() {
        let c = capture(camera(Lens::Pinhole, 160.0), 1000, None);
        let e = direct_gain(
            &c,
            &AngularResponse::Cosine,
            DVec3::NEG_Z,
            100.0,
            &[1.0, 1.0],
        );
        assert!(
            matches!(e, Err(DirectGainError::NotCovered { covered }) if covered < 0.6),
            "{e:?}"
        );
        let hood = AngularResponse::Table(Lsc::hooded(30f64.to_radians()).unwrap());
        // a sensor looking sideways sees out of the image
        let e = direct_gain(&c, &hood, DVec3::X, 100.0, &[1.0, 1.0]);
        assert!(
            matches!(e, Err(DirectGainError::NotCovered { .. })),
            "{e:?}"
        );
        let s = capture(camera(Lens::Pinhole, 160.0), SATURATED, None);
        let e = direct_gain(&s, &hood, DVec3::NEG_Z, 100.0, &[1.0, 1.0]);
        assert!(matches!(e, Err(DirectGainError::Saturated { .. })), "{e:?}");
        for (lux, levels, normal) in [
            (f64::NAN, vec![1.0, 1.0], DVec3::NEG_Z),
            (0.0, vec![1.0, 1.0], DVec3::NEG_Z),
            (100.0, vec![1.0], DVec3::NEG_Z),
            (100.0, vec![1.0, 2.0], DVec3::NEG_Z),
            (100.0, vec![1.0, 1.0], DVec3::ZERO),
            (100.0, vec![1.0, 1.0], DVec3::NAN),
        ] {
            let e = direct_gain(&c, &hood, normal, lux, &levels);
            assert!(
                matches!(e, Err(DirectGainError::Input(_))),
                "{lux} {levels:?}"
            );
        }
        // dark frames: no gain, not infinity
        let d = capture(camera(Lens::Pinhole, 160.0), 0, None);
        let e = direct_gain(&d, &hood, DVec3::NEG_Z, 100.0, &[1.0, 1.0]);
        assert!(matches!(e, Err(DirectGainError::Input(_))), "{e:?}");
    }
}
