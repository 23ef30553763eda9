//! Building the live-light section at commissioning ([`crate::store::live`]), the commissioning
//! side of live light ([`crate::live`] is the run-time side, reading only the stored image): which camera
//! pixels to sample, the patch each sees, its commissioned depth and the luminaires' light on
//! it; each desk sensor's window and camera-calibrated response; the candidate emitter groups.
//!
//! Two sources of the per-sample artificial irradiance:
//!
//! * [`from_capture`]: the one-luminaire frames of the commissioning capture with the all-off
//!   frame subtracted, `E_l = π g (L_l − L_off) / ρ` (g the camera gain, ρ the patch's estimated
//!   reflectance): what the camera measured, so that at run time, with nothing changed, the
//!   measured illuminance `π g L / ρ` and the artificial part agree pixel by pixel and the
//!   residual is the extraneous light alone.
//! * [`from_model`]: a CAD scene with a camera: the engine's exact direct light at the pixel's
//!   surface point (photometry over the opening, shadow rays) plus its patch's interreflected
//!   light, as the simulated camera renders it.

pub mod calibrate;
pub mod desk_rho;

use crate::live::DISAGREEMENT_TO_SIGMA;
use glam::DVec3;
use rayon::prelude::*;

use crate::camera::capture::Capture;
use crate::commission::{Commissioned, DepthMap};
use crate::engine::direct::{self, Receiver};
use crate::engine::raycast::{Hit, RayCaster};
use crate::engine::{Csr, Model};
use crate::image_build::LiveSectionData;
use crate::scene::{Camera, Luminaire, Scene, Sensor};
use crate::store::live::{CameraRecord, MAX_EMITTERS, NO_EMITTER, live_source};
use crate::store::sensor_flags;

use crate::live::LiveError;
use crate::live::window::{farthest_m, plane_at_origin, window_sigma_m};

/// Knobs of the section.
#[derive(Debug, Clone, PartialEq)]
pub struct SectionOptions {
    /// Grid stride of the samples, pixels (0: the smallest that keeps the section within
    /// `budget_bytes`).
    pub stride: u32,
    /// Largest section, bytes, when the stride is chosen.
    pub budget_bytes: usize,
    /// Radius of a desk sensor's window, m (5 cm: a 10 cm window took in a monitor's shade
    /// 8 cm from a reference sensor and read it 18 % low; within it the fit's width narrows
    /// further at a shade's edge, [`window_sigma_m`]; docs/live.md).
    pub window_radius_m: f64,
    /// A window with fewer than [`Self::window_min_pixels`] pixels within
    /// [`Self::window_radius_m`] (a desk far across a fisheye's view, where one pixel spans
    /// more than the window) widens to its nearest pixels, up to this radius, m; a desk whose
    /// top no pixel sees within it is not measured.
    pub window_max_radius_m: f64,
    /// Pixels a window should hold before it stops widening.
    pub window_min_pixels: usize,
    /// A window sample lies within this of the sensor's plane, m.
    pub window_plane_m: f64,
    /// Lowest reflectance of a sampled surface (darker surfaces amplify noise: π L / ρ).
    pub min_rho: f64,
    /// Side of an emitter group's cell, m.
    pub emitter_cell_m: f64,
    /// Candidate emitters on downward-facing unseen surfaces (the ceiling) too.
    pub ceiling_emitters: bool,
    /// Points over a luminaire's opening for the direct light of a model-built section.
    pub opening_points: usize,
}

impl Default for SectionOptions {
    fn default() -> Self {
        Self {
            stride: 0,
            budget_bytes: 600 * 1024,
            window_radius_m: 0.05,
            window_max_radius_m: 0.10,
            window_min_pixels: 4,
            window_plane_m: 0.03,
            min_rho: 0.02,
            emitter_cell_m: 1.5,
            ceiling_emitters: false,
            opening_points: 32,
        }
    }
}

impl SectionOptions {
    fn validate(&self) -> Result<(), LiveError> {
        let bad = |m: String| Err(LiveError::Input(m));
        if self.stride > 64 {
            return bad(format!("sample stride {} px must be 0..=64", self.stride));
        }
        if !(self.window_radius_m.is_finite() && (0.005..=1.0).contains(&self.window_radius_m)) {
            return bad(format!(
                "window radius {} m must be within 0.005..=1 m",
                self.window_radius_m
            ));
        }
        if !(self.window_max_radius_m.is_finite()
            && (self.window_radius_m..=1.0).contains(&self.window_max_radius_m))
        {
            return bad(format!(
                "largest window radius {} m must be within the window radius {} m and 1 m",
                self.window_max_radius_m, self.window_radius_m
            ));
        }
        if !(self.window_plane_m.is_finite() && (0.001..=0.5).contains(&self.window_plane_m)) {
            return bad(format!(
                "window plane tolerance {} m must be within 0.001..=0.5 m",
                self.window_plane_m
            ));
        }
        if !(self.min_rho.is_finite() && (0.0..0.9).contains(&self.min_rho)) {
            return bad(format!(
                "lowest reflectance {} outside [0, 0.9)",
                self.min_rho
            ));
        }
        if !(self.emitter_cell_m.is_finite() && (0.1..=100.0).contains(&self.emitter_cell_m)) {
            return bad(format!(
                "emitter cell {} m must be within 0.1..=100 m",
                self.emitter_cell_m
            ));
        }
        if !(1..=1024).contains(&self.opening_points) {
            return bad(format!(
                "opening points {} must be 1..=1024",
                self.opening_points
            ));
        }
        if self.budget_bytes < 4096 {
            return bad(format!(
                "section budget {} B is below 4 kB",
                self.budget_bytes
            ));
        }
        Ok(())
    }
}

/// What a pixel's ray meets.
#[derive(Debug, Clone, Copy)]
struct PixelHit {
    patch: u32,
    point: DVec3,
    z_m: f64,
}

fn record(camera: &Camera, gain: Option<f64>) -> CameraRecord {
    let m = camera.world_from_camera;
    let mut axes = [0.0; 9];
    for (k, a) in [m.x_axis, m.y_axis, m.z_axis].iter().enumerate() {
        axes[3 * k..3 * k + 3].copy_from_slice(&a.to_array());
    }
    CameraRecord {
        width: camera.width.min(u32::from(u16::MAX)) as u16,
        height: camera.height.min(u32::from(u16::MAX)) as u16,
        fx: camera.fx,
        fy: camera.fy,
        cx: camera.cx,
        cy: camera.cy,
        position_m: camera.position_m.to_array(),
        world_from_camera: axes,
        cd_m2_per_unit: gain.unwrap_or(0.0),
        lens_k: camera.lens.is_fisheye().then(|| camera.lens.k()),
    }
}

/// The scene camera of a stored camera record (its lens checked).
pub fn camera_of(c: &CameraRecord) -> Result<Camera, LiveError> {
    let a = &c.world_from_camera;
    let lens = match c.lens_k {
        None => crate::scene::Lens::Pinhole,
        Some(k) => {
            let l = crate::scene::Lens::KannalaBrandt { k };
            l.check()
                .map_err(|m| LiveError::Input(format!("the live section's camera lens: {m}")))?;
            l
        }
    };
    Ok(Camera {
        position_m: DVec3::from_array(c.position_m),
        world_from_camera: glam::DMat3::from_cols(
            DVec3::new(a[0], a[1], a[2]),
            DVec3::new(a[3], a[4], a[5]),
            DVec3::new(a[6], a[7], a[8]),
        ),
        fx: c.fx,
        fy: c.fy,
        cx: c.cx,
        cy: c.cy,
        width: u32::from(c.width),
        height: u32::from(c.height),
        luminance_cd_m2_per_unit: (c.cd_m2_per_unit > 0.0).then_some(c.cd_m2_per_unit),
        lens,
    })
}

/// Every pixel's first front-face hit on a surface of reflectance ≥ `min_rho`.
fn cast_all(
    camera: &Camera,
    model: &Model,
    caster: &RayCaster,
    min_rho: f64,
) -> Vec<Option<PixelHit>> {
    let axis = camera.world_from_camera.z_axis;
    (0..camera.width * camera.height)
        .into_par_iter()
        .map(|i| {
            let (u, v) = (i % camera.width, i / camera.width);
            // pixels outside a fisheye's image circle see nothing
            let d = camera.ray_world(f64::from(u), f64::from(v))?;
            match caster.closest(camera.position_m, d) {
                Hit::Front { patch, t_m } if model.patches.rho[patch as usize] >= min_rho => {
                    Some(PixelHit {
                        patch,
                        point: camera.position_m + d * t_m,
                        z_m: t_m * d.dot(axis),
                    })
                }
                _ => None,
            }
        })
        .collect()
}

/// Where a sensor projects in the camera, if in front of it.
/// Pixel coordinates and depth along the axis of a world point, through the camera's lens
/// (pinhole or fisheye); `None` behind the camera or outside the lens's field.
fn project(camera: &Camera, p: DVec3) -> Option<(f64, f64, f64)> {
    let c = camera.world_from_camera.transpose() * (p - camera.position_m);
    if c.z <= 1e-6 {
        return None;
    }
    let (u, v) = camera.project_camera(c)?;
    Some((u, v, c.z))
}

/// The pixels of a sensor's window: surface points within `radius` of the sensor in its plane
/// and within `plane_m` of the plane, on a patch facing the sensor's way, as (pixel, x, y) in
/// the plane. The radius is [`SectionOptions::window_radius_m`], widened to the
/// [`SectionOptions::window_min_pixels`]-th nearest such point when fewer lie within it (up to
/// [`SectionOptions::window_max_radius_m`]: a desk far across a wide lens, where one pixel spans
/// more than the window). Empty when the camera does not see the sensor's plane there.
fn window_pixels(
    camera: &Camera,
    depth: Option<&DepthMap>,
    hits: &[Option<PixelHit>],
    model: &Model,
    sensor: &Sensor,
    o: &SectionOptions,
) -> Vec<(u32, f64, f64)> {
    let Some((u0, v0, z)) = project(camera, sensor.position_m) else {
        return Vec::new();
    };
    // pixels per metre at the sensor: f / z for a pinhole; a fisheye's is smaller than f / z
    // (for r = f θ: at most f θ / (D sin θ) < f / (D cos θ)), so this reach covers both
    let reach_px = (o.window_max_radius_m * camera.fx.max(camera.fy) / z).ceil() + 2.0;
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let umin = (u0 - reach_px).floor().max(0.0);
    let umax = (u0 + reach_px).ceil().min(w - 1.0);
    let vmin = (v0 - reach_px).floor().max(0.0);
    let vmax = (v0 + reach_px).ceil().min(h - 1.0);
    if umin > umax || vmin > vmax {
        return Vec::new();
    }
    let n = sensor.normal;
    let mut near: Vec<(f64, u32, f64, f64)> = Vec::new();
    for v in vmin as u32..=vmax as u32 {
        for u in umin as u32..=umax as u32 {
            let i = v * camera.width + u;
            let Some(hit) = hits[i as usize] else {
                continue;
            };
            // the pixel's own depth puts its surface elsewhere: it sees something the mesh
            // lacks (a monitor seen edge-on), not the desk top
            if depth.and_then(|m| m.sees_at(camera, u, v, hit.point)) == Some(false) {
                continue;
            }
            let d = hit.point - sensor.position_m;
            let along = d.dot(n);
            let inplane = d - n * along;
            let r = inplane.length();
            if along.abs() <= o.window_plane_m
                && r <= o.window_max_radius_m
                && model.patches.normal[hit.patch as usize].dot(n) > 0.95
            {
                near.push((r, i, inplane.x, inplane.y));
            }
        }
    }
    near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let kth = near
        .get(o.window_min_pixels.saturating_sub(1))
        .map_or(o.window_max_radius_m, |p| p.0);
    let radius = kth.max(o.window_radius_m);
    let mut out: Vec<(u32, f64, f64)> = near
        .into_iter()
        .filter(|p| p.0 <= radius)
        .map(|(_, i, x, y)| (i, x, y))
        .collect();
    out.sort_by_key(|p| p.0);
    out
}

/// Patches any pixel sees (seen patches' exitance is measured at run time; the others are
/// candidate emitters or modelled).
fn seen_patches(hits: &[Option<PixelHit>], patches: usize) -> Vec<bool> {
    let mut count = vec![0u32; patches];
    for h in hits.iter().flatten() {
        count[h.patch as usize] += 1;
    }
    count.iter().map(|&c| c >= 2).collect()
}

/// Groups the unseen, reflecting patches into candidate emitters: by the dominant axis of their
/// normal (walls; upward-facing floor and furniture; the ceiling only when asked), then by a
/// cell of `cell_m` over the plane's two other axes. The cell grows until there are at most
/// [`MAX_EMITTERS`] groups. With `glazing` (the room plan's windows, when the cameras see none
/// of some), only the unseen glazing emits: daylight enters there, and the unseen walls and
/// floor are lit by it through the interreflection (issue 28 item 3).
fn emitter_groups(
    model: &Model,
    seen: &[bool],
    glazing: Option<&[bool]>,
    o: &SectionOptions,
) -> (Vec<u8>, u16) {
    let p = &model.patches;
    let candidate = |i: usize| glazing.is_none_or(|g| g.get(i).copied().unwrap_or(false));
    let mut cell = o.emitter_cell_m;
    loop {
        let mut keys: std::collections::BTreeMap<(u8, i64, i64), u8> = Default::default();
        let mut out = vec![NO_EMITTER; p.len()];
        let mut overflow = false;
        for i in 0..p.len() {
            if seen[i] || p.rho[i] <= 0.0 || !candidate(i) {
                continue;
            }
            let n = p.normal[i];
            let c = p.centroid_m(i);
            let (axis, a, b) = if n.z.abs() >= n.x.abs().max(n.y.abs()) {
                if n.z < 0.0 && !o.ceiling_emitters {
                    continue;
                }
                (if n.z > 0.0 { 0 } else { 1 }, c.x, c.y)
            } else if n.x.abs() >= n.y.abs() {
                (if n.x > 0.0 { 2 } else { 3 }, c.y, c.z)
            } else {
                (if n.y > 0.0 { 4 } else { 5 }, c.x, c.z)
            };
            let key = (axis, (a / cell).floor() as i64, (b / cell).floor() as i64);
            let next = keys.len();
            let g = *keys.entry(key).or_insert(next.min(255) as u8);
            if keys.len() > MAX_EMITTERS {
                overflow = true;
                break;
            }
            out[i] = g;
        }
        if !overflow {
            return (out, keys.len() as u16);
        }
        cell *= 1.5;
    }
}

/// Samples on the grid of `stride` plus every window pixel; (pixel, hit) in pixel order.
fn samples(
    camera: &Camera,
    hits: &[Option<PixelHit>],
    stride: u32,
    window_px: &[Vec<(u32, f64, f64)>],
) -> Vec<(u32, PixelHit)> {
    let s = stride.max(1);
    let mut take = vec![false; hits.len()];
    for v in (s / 2..camera.height).step_by(s as usize) {
        for u in (s / 2..camera.width).step_by(s as usize) {
            take[(v * camera.width + u) as usize] = true;
        }
    }
    for w in window_px {
        for &(i, _, _) in w {
            take[i as usize] = true;
        }
    }
    take.iter()
        .enumerate()
        .filter_map(|(i, &t)| t.then_some(()).and_then(|_| hits[i].map(|h| (i as u32, h))))
        .collect()
}

fn mm(x: f64) -> i16 {
    (x * 1000.0).round().clamp(-32768.0, 32767.0) as i16
}

/// The stride for a budget: the smallest whose section fits.
fn choose_stride(
    o: &SectionOptions,
    camera: &Camera,
    hits: &[Option<PixelHit>],
    windows: &[Vec<(u32, f64, f64)>],
    luminaires: usize,
    patches: usize,
) -> u32 {
    if o.stride > 0 {
        return o.stride;
    }
    for s in 1..=16 {
        let n = samples(camera, hits, s, windows).len();
        let w: usize = windows.iter().map(Vec::len).sum();
        let bytes = 64 + n * (10 + 2 * luminaires) + 8 * w + patches;
        if bytes <= o.budget_bytes {
            return s;
        }
    }
    16
}

/// Everything both sources share: samples, windows, emitter groups.
struct Layout {
    stride: u32,
    samples: Vec<(u32, PixelHit)>,
    windows: Vec<Vec<(u32, i16, i16)>>,
    window_px: Vec<Vec<(u32, f64, f64)>>,
    patch_emitter: Vec<u8>,
    n_emitters: u16,
}

fn layout(
    camera: &Camera,
    depth: Option<&DepthMap>,
    model: &Model,
    sensors: &[Sensor],
    flags: &[u8],
    glazing: Option<&[bool]>,
    o: &SectionOptions,
) -> Layout {
    let caster = RayCaster::new(&model.patches);
    let hits = cast_all(camera, model, &caster, o.min_rho);
    let window_px: Vec<Vec<(u32, f64, f64)>> = sensors
        .iter()
        .enumerate()
        .map(|(k, s)| {
            if flags
                .get(k)
                .is_some_and(|f| f & sensor_flags::OUT_OF_VIEW != 0)
            {
                Vec::new()
            } else {
                window_pixels(camera, depth, &hits, model, s, o)
            }
        })
        .collect();
    let stride = choose_stride(
        o,
        camera,
        &hits,
        &window_px,
        model.luminaires(),
        model.patches.len(),
    );
    let samples = samples(camera, &hits, stride, &window_px);
    let index: std::collections::HashMap<u32, u32> = samples
        .iter()
        .enumerate()
        .map(|(k, (px, _))| (*px, k as u32))
        .collect();
    let windows = window_px
        .iter()
        .map(|w| {
            w.iter()
                .filter_map(|&(px, dx, dy)| index.get(&px).map(|&k| (k, mm(dx), mm(dy))))
                .collect()
        })
        .collect();
    let seen = seen_patches(&hits, model.patches.len());
    let unseen_glazing = glazing.filter(|g| g.iter().zip(&seen).any(|(g, s)| *g && !*s));
    let (patch_emitter, n_emitters) = emitter_groups(model, &seen, unseen_glazing, o);
    Layout {
        stride,
        samples,
        windows,
        window_px,
        patch_emitter,
        n_emitters,
    }
}

/// The camera-calibrated response of each sensor: the plane fit at the sensor of the window's
/// per-luminaire irradiance (zeros without a window), each sensor at the width
/// [`window_sigma_m`] chooses from its all-on irradiance.
fn calibrated_response(
    window_px: &[Vec<(u32, f64, f64)>],
    value: impl Fn(usize, u32) -> Option<f64>,
    luminaires: usize,
    radius_m: f64,
) -> Vec<Vec<f64>> {
    window_px
        .iter()
        .map(|w| {
            let all_on: Vec<(f64, f64, f64)> = w
                .iter()
                .filter_map(|&(px, dx, dy)| {
                    let mut sum = 0.0;
                    for l in 0..luminaires {
                        sum += value(l, px)?;
                    }
                    Some((dx, dy, sum))
                })
                .collect();
            // a widened window's radius is its farthest pixel (as the estimator reads it)
            let farthest = farthest_m(w.iter().map(|&(_, dx, dy)| (dx, dy)));
            let sigma_m = window_sigma_m(&all_on, w.len(), radius_m.max(farthest));
            (0..luminaires)
                .map(|l| {
                    let pts: Vec<(f64, f64, f64)> = w
                        .iter()
                        .filter_map(|&(px, dx, dy)| value(l, px).map(|e| (dx, dy, e)))
                        .collect();
                    if pts.len() * 2 < w.len().max(1) {
                        return 0.0;
                    }
                    plane_at_origin(&pts, sigma_m).unwrap_or(0.0).max(0.0)
                })
                .collect()
        })
        .collect()
}

/// Each sensor's stated uncertainty of the model's light: what commissioning inferred (by
/// sensor id), widened at an in-view desk to what the model's disagreement with the camera's
/// measurement there implies (issue 28 item 5; [`crate::live::model_camera_disagreement`]). A
/// disagreement beyond two stated uncertainties is logged: a shade the mesh lost, or a wrong
/// reflectance, at that desk.
/// The smallest stated uncertainty of a desk whose response the camera calibrated: the live
/// measurement's ([`crate::live::LiveSettings`]' `measured_rel_uncertainty`).
pub const CALIBRATED_MIN_REL: f64 = 0.04;

fn widened_uncertainty(c: &Commissioned, camera_lx: &[Vec<f64>]) -> Vec<f64> {
    let model = &c.model;
    (0..model.sensors())
        .map(|s| {
            let id = model.sensor_ids[s];
            let u = c.report.stated_rel(id);
            let row = camera_lx.get(s).map_or(&[][..], |r| &r[..]);
            let cam: f64 = row.iter().sum();
            // the model as it was before the cameras calibrated it: how far it was off says how
            // hard the desk is for both
            let mdl: f64 = c
                .uncalibrated_all_on_lx
                .get(s)
                .copied()
                .unwrap_or_else(|| model.response_lx[s].iter().sum());
            // a calibrated desk's light is partly the camera's measurement
            let u = if c
                .sensor_flags
                .get(s)
                .is_some_and(|f| f & sensor_flags::CALIBRATED != 0)
            {
                u.max(CALIBRATED_MIN_REL)
            } else {
                u
            };
            let Some(d) = crate::live::model_camera_disagreement(mdl, cam) else {
                return u;
            };
            let widened = DISAGREEMENT_TO_SIGMA * d;
            if d > 2.0 * u.max(0.0) && d > 0.05 {
                tracing::warn!(
                    "sensor {id}: the model gives {mdl:.0} lx with every luminaire on, the \
                     camera measures {cam:.0} lx ({:+.0} %): beyond the stated {:.1} %; a shade \
                     the mesh lost or a wrong reflectance there; its stated uncertainty is \
                     widened to {:.1} %",
                    100.0 * (mdl / cam - 1.0),
                    100.0 * u,
                    100.0 * widened
                );
            }
            if u.is_finite() {
                u.max(widened)
            } else {
                widened
            }
        })
        .collect()
}

/// A commissioned node's camera and its luminance gain (cd/m² per unit).
fn camera_and_gain(c: &Commissioned) -> Result<(&Camera, f64), LiveError> {
    let camera = c
        .scene
        .camera
        .as_ref()
        .ok_or_else(|| LiveError::Input("the commissioned scene has no camera".into()))?;
    let gain = c.report.reflectance.gain_cd_m2_per_unit;
    if !(gain.is_finite() && gain > 0.0) {
        return Err(LiveError::Input(format!(
            "camera gain {gain} cd/m² per unit: reflectances were not estimated"
        )));
    }
    Ok((camera, gain))
}

/// The section from a commissioning: the capture's one-luminaire frames less its all-off frame.
pub fn from_capture(
    c: &Commissioned,
    capture: &Capture,
    o: &SectionOptions,
) -> Result<LiveSectionData, LiveError> {
    o.validate()?;
    let (camera, gain) = camera_and_gain(c)?;
    if capture.luminance.len() != c.model.luminaires() {
        return Err(LiveError::Input(
            "the capture's frames do not match the luminaires".into(),
        ));
    }
    let model = &c.model;
    let l_count = model.luminaires();
    let glazing = crate::commission::glazing_patches(c);
    let mut lay = layout(
        camera,
        Some(&c.depth),
        model,
        &c.scene.sensors,
        &c.sensor_flags,
        glazing.as_deref(),
        o,
    );
    let rho = &model.patches.rho;
    // E_l = π g (L_l − L_off) / ρ of the pixel's patch
    let e_at = |l: usize, px: u32, patch: usize| -> f64 {
        let r = rho[patch];
        if r <= 0.0 {
            return 0.0;
        }
        capture
            .luminaire_value(l, px as usize)
            .map_or(0.0, |v| std::f64::consts::PI * gain * v / r)
    };
    let artificial: Vec<Vec<f64>> = (0..l_count)
        .map(|l| {
            lay.samples
                .iter()
                .map(|(px, h)| e_at(l, *px, h.patch as usize))
                .collect()
        })
        .collect();
    let hit_of: std::collections::HashMap<u32, usize> = lay
        .samples
        .iter()
        .map(|(px, h)| (*px, h.patch as usize))
        .collect();
    let mut response = calibrated_response(
        &lay.window_px,
        |l, px| {
            let patch = *hit_of.get(&px)?;
            capture
                .luminaire_value(l, px as usize)
                .map(|v| std::f64::consts::PI * gain * v / rho[patch])
        },
        l_count,
        o.window_radius_m,
    );
    drop_windows_that_miss_the_desk(c, &mut lay.windows, &mut response);
    let depth_mm = lay
        .samples
        .iter()
        .map(|(px, h)| {
            let (u, v) = (px % camera.width, px / camera.width);
            let z = c.depth.at(u, v).unwrap_or(h.z_m);
            (z * 1000.0).round().clamp(0.0, 65535.0) as u16
        })
        .collect();
    let model_rel_uncertainty = widened_uncertainty(c, &response);
    Ok(LiveSectionData {
        camera: record(camera, Some(gain)),
        source: live_source::CAPTURE,
        stride: lay.stride.min(u32::from(u16::MAX)) as u16,
        pixel: lay.samples.iter().map(|s| s.0).collect(),
        patch: lay.samples.iter().map(|s| s.1.patch).collect(),
        depth_mm,
        artificial_lx: artificial,
        windows: lay.windows,
        sensor_response_lx: response,
        model_rel_uncertainty,
        model_uncertainty_parts_lx: uncertainty_parts(c),
        model_occluder_groups: occluder_groups(c),
        patch_emitter: lay.patch_emitter,
        n_emitters: lay.n_emitters,
    })
}

/// Clears the window of a desk whose camera response is no reflectance error away from the
/// model's ([`crate::live::desk_scale::camera_scale`] outside its range: the pixels are not the
/// desk's light, say a widened window's far pixels on another object's top): the desk is then
/// inferred, not measured from pixels that do not measure it.
fn drop_windows_that_miss_the_desk(
    c: &Commissioned,
    windows: &mut [Vec<(u32, i16, i16)>],
    response: &mut [Vec<f64>],
) {
    let model = &c.model;
    for (s, (w, r)) in windows.iter_mut().zip(response.iter_mut()).enumerate() {
        let Some(m) = model.response_lx.get(s) else {
            continue;
        };
        let model_lx: f64 = m.iter().sum();
        if w.is_empty() || model_lx <= 0.0 {
            continue;
        }
        if crate::live::desk_scale::camera_scale(m, r).is_none() {
            tracing::warn!(
                "sensor {}: the camera's {} window pixels give {:.0} lx all on where the model \
                 gives {model_lx:.0} lx: they do not measure the desk; it is inferred",
                model.sensor_ids[s],
                w.len(),
                r.iter().sum::<f64>()
            );
            w.clear();
            r.iter_mut().for_each(|v| *v = 0.0);
        }
    }
}

/// Each sensor's uncertainty parts per luminaire at 100 % (what commissioning inferred,
/// `crate::commission::uncertainty`), in the model's sensor order; empty when a sensor has none
/// (then no dimming state is stated per luminaire).
fn uncertainty_parts(c: &Commissioned) -> Vec<Vec<[f64; crate::runtime::UNCERTAINTY_PARTS]>> {
    per_luminaire_rows(c, |u| &u.by_luminaire)
}

/// Each sensor's occluder group per luminaire ([`crate::commission::uncertainty::Occluders`]), in
/// the model's sensor order, when every sensor has its parts ([`uncertainty_parts`]); empty
/// otherwise (every luminaire alone).
fn occluder_groups(c: &Commissioned) -> Vec<Vec<u8>> {
    if uncertainty_parts(c).is_empty() {
        return Vec::new();
    }
    per_luminaire_rows(c, |u| &u.occluder_group)
}

/// One row per luminaire of every sensor's stated uncertainty (`row` picks it), in the model's
/// sensor order; empty when a sensor has none or a row of another length.
fn per_luminaire_rows<T: Clone>(
    c: &Commissioned,
    row: impl Fn(&crate::commission::uncertainty::SensorUncertainty) -> &Vec<T>,
) -> Vec<Vec<T>> {
    let model = &c.model;
    let rows: Option<Vec<Vec<T>>> = model
        .sensor_ids
        .iter()
        .map(|id| {
            c.report
                .uncertainty_of(*id)
                .map(&row)
                .filter(|r| r.len() == model.luminaires())
                .cloned()
        })
        .collect();
    rows.unwrap_or_default()
}

/// Interreflected illuminance per luminaire at 100 % on each patch, lx (`[luminaire][patch]`).
fn indirect_lx(ff: &Csr, basis_b: &[Vec<f64>]) -> Vec<Vec<f64>> {
    basis_b
        .par_iter()
        .map(|b| {
            (0..ff.rows())
                .map(|i| ff.row(i).map(|(j, f)| f * b[j as usize]).sum())
                .collect()
        })
        .collect()
}

fn direct_at(l: &Luminaire, points: &[DVec3], x: DVec3, n: DVec3, caster: &RayCaster) -> f64 {
    direct::illuminance_lx(l, points, x, n, Receiver::Surface, caster)
}

/// The section from a CAD scene with a camera and its engine model: per sample the engine's exact
/// direct light at the pixel's surface point plus its patch's interreflected light. Sensor
/// visibility: a sensor is in view when the camera's ray toward it first meets a surface within
/// 3 cm of it. `gain`: the camera's luminance scale, if known.
pub fn from_model(
    scene: &Scene,
    model: &Model,
    o: &SectionOptions,
) -> Result<(LiveSectionData, Vec<u8>), LiveError> {
    o.validate()?;
    let camera = scene
        .camera
        .as_ref()
        .ok_or_else(|| LiveError::Input(format!("scene {} has no camera.json", scene.name)))?;
    if camera.width == 0 || camera.height == 0 || camera.width > 4096 || camera.height > 4096 {
        return Err(LiveError::Input(format!(
            "camera of {}x{} pixels: 1..=4096 a side",
            camera.width, camera.height
        )));
    }
    let caster = RayCaster::new(&model.patches);
    let flags: Vec<u8> = scene
        .sensors
        .iter()
        .map(|s| {
            let visible = project(camera, s.position_m).is_some_and(|(u, v, _)| {
                u >= -0.5
                    && v >= -0.5
                    && u < f64::from(camera.width) - 0.5
                    && v < f64::from(camera.height) - 0.5
                    && {
                        let d = (s.position_m - camera.position_m).normalize();
                        match caster.closest(camera.position_m, d) {
                            Hit::Front { t_m, .. } => {
                                (camera.position_m + d * t_m - s.position_m).length() < 0.03
                            }
                            _ => false,
                        }
                    }
            });
            if visible {
                0
            } else {
                sensor_flags::OUT_OF_VIEW
            }
        })
        .collect();
    let lay = layout(camera, None, model, &scene.sensors, &flags, None, o);
    let indirect = indirect_lx(&model.ff.f, &model.basis_b);
    let points: Vec<Vec<DVec3>> = scene
        .luminaires
        .iter()
        .map(|l| direct::centred_opening_points(l, o.opening_points))
        .collect();
    let artificial: Vec<Vec<f64>> = scene
        .luminaires
        .iter()
        .enumerate()
        .map(|(l, lum)| {
            lay.samples
                .par_iter()
                .map(|(_, h)| {
                    let p = h.patch as usize;
                    let n = model.patches.normal[p];
                    direct_at(lum, &points[l], h.point, n, &caster) + indirect[l][p]
                })
                .collect()
        })
        .collect();
    // the model's own sensor reading is its calibrated response (zero out of view)
    let response = (0..model.sensors())
        .map(|s| {
            if lay.windows[s].is_empty() {
                vec![0.0; model.luminaires()]
            } else {
                model.response_lx[s].clone()
            }
        })
        .collect();
    let depth_mm = lay
        .samples
        .iter()
        .map(|(_, h)| (h.z_m * 1000.0).round().clamp(0.0, 65535.0) as u16)
        .collect();
    Ok((
        LiveSectionData {
            camera: record(camera, camera.luminance_cd_m2_per_unit),
            source: live_source::MODEL,
            stride: lay.stride.min(u32::from(u16::MAX)) as u16,
            pixel: lay.samples.iter().map(|s| s.0).collect(),
            patch: lay.samples.iter().map(|s| s.1.patch).collect(),
            depth_mm,
            artificial_lx: artificial,
            model_rel_uncertainty: vec![f64::NAN; model.sensors()],
            model_uncertainty_parts_lx: Vec::new(),
            model_occluder_groups: Vec::new(),
            windows: lay.windows,
            sensor_response_lx: response,
            patch_emitter: lay.patch_emitter,
            n_emitters: lay.n_emitters,
        },
        flags,
    ))
}

/// Adds a live section to an image, within a flash region of `region_bytes`: the section's
/// budget is what the region has left (at most `o.budget_bytes`), so the sample stride grows
/// until it fits. `Ok(None)` when not even a coarse section fits (the image is served without
/// live light, and the caller says so).
pub fn attach(
    image: &[u8],
    section: impl Fn(&SectionOptions) -> Result<crate::image_build::LiveSectionData, LiveError>,
    o: &SectionOptions,
    region_bytes: usize,
) -> Result<Option<Vec<u8>>, LiveError> {
    let room = region_bytes.saturating_sub(image.len());
    if room < 8 * 1024 {
        return Ok(None);
    }
    let mut opts = o.clone();
    opts.budget_bytes = opts.budget_bytes.min(room - 1024);
    // the budget is met by the section's estimated size: when the encoded image still overflows
    // the region, the budget shrinks by the overflow (and a margin) and the section is laid out
    // again, a few times at most
    for _ in 0..ATTACH_TRIES {
        let data = section(&opts)?;
        let bytes = crate::image_build::with_live(image, Some(&data))
            .map_err(|e| LiveError::Input(format!("live section: {e}")))?;
        if bytes.len() <= region_bytes {
            return Ok(Some(bytes));
        }
        let over = bytes.len() - region_bytes;
        match opts.budget_bytes.checked_sub(over + 2048) {
            Some(b) if b >= 8 * 1024 => opts.budget_bytes = b,
            _ => return Ok(None),
        }
    }
    Ok(None)
}

/// Layouts of the live section [`attach`] tries against the flash region.
const ATTACH_TRIES: usize = 3;

/// The image with the live-light section of a commissioning from `capture` added, within the
/// formfactors flash region less `reserve_bytes` for the sections after it (the room plan's
/// daylight coefficients: [`crate::daylight_section::reserve_bytes`]), or within the whole
/// region when it fits only there (logged: the daylight section may then find no room); the
/// image as it is when the section cannot be built or does not fit (logged: the node then serves
/// the model only).
pub fn with_capture_section(
    image: Vec<u8>,
    c: &crate::commission::Commissioned,
    capture: &crate::camera::capture::Capture,
    reserve_bytes: usize,
) -> Vec<u8> {
    let o = SectionOptions::default();
    let region = crate::image_build::formfactors_region_bytes();
    let build = |o: &SectionOptions| from_capture(c, capture, o);
    let attached = match attach(&image, build, &o, region.saturating_sub(reserve_bytes)) {
        Ok(None) if reserve_bytes > 0 => {
            tracing::warn!(
                "commission: the live-light section fits only in the room kept for the daylight \
                 coefficients ({reserve_bytes} bytes)"
            );
            attach(&image, build, &o, region)
        }
        other => other,
    };
    match attached {
        Ok(Some(bytes)) => {
            tracing::info!(
                "commission: live-light section of {} bytes added",
                bytes.len() - image.len()
            );
            bytes
        }
        Ok(None) => {
            tracing::warn!(
                "commission: no room for the live-light section in the flash region; live light \
                 is off"
            );
            image
        }
        Err(e) => {
            tracing::warn!("commission: live-light section: {e}; live light is off");
            image
        }
    }
}

/// The occupancy cells of `pixels` (`v · width + u`, commissioned depth mm) of `camera`: each
/// pixel's ray in the world per metre of depth along the optical axis (pixels outside a
/// fisheye's field are left out).
pub fn occupancy_cells(camera: &Camera, pixels: &[(u32, u16)]) -> Vec<crate::occupancy::CellInput> {
    let w = camera.width.max(1);
    let axis = camera.world_from_camera.z_axis;
    pixels
        .iter()
        .filter_map(|&(pixel, background_mm)| {
            let d = camera.ray_world(f64::from(pixel % w), f64::from(pixel / w))?;
            let along = d.dot(axis);
            (along > 1e-6).then(|| crate::occupancy::CellInput {
                pixel,
                background_mm,
                ray_per_m: (d / along).to_array(),
            })
        })
        .collect()
}

/// Occupancy over an image: the live section's samples as the cells (their commissioned depth,
/// their rays from the stored camera), the desks and the floor (the lowest patch corner) from
/// the geometry section. With it, per sensor (the image's order) the desk whose top holds it
/// (none for a sensor on the floor or another surface).
pub fn occupancy_map(
    image: &crate::store::Image<'_>,
    settings: crate::occupancy::OccupancySettings,
) -> Result<(crate::occupancy::OccupancyMap, Vec<Option<usize>>), LiveError> {
    use crate::occupancy::{DeskTop, OccupancyMap};
    let live = image.live.as_ref().ok_or(LiveError::NoSection)?;
    let geometry = image
        .geometry_bytes()
        .ok_or_else(|| LiveError::Input("the image has no geometry section (no desks)".into()))
        .and_then(|b| {
            crate::store::geometry::GeometrySection::decode(b)
                .map_err(|e| LiveError::Input(format!("the image's geometry section: {e}")))
        })?;
    let camera = camera_of(&live.camera)?;
    let pixels: Vec<(u32, u16)> = (0..live.samples())
        .map(|i| (live.pixel(i) as u32, live.depth_mm(i)))
        .collect();
    let cells = occupancy_cells(&camera, &pixels);
    // the room: the patches' plan extent, the floor their lowest corner
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for c in &geometry.patch_corners_m {
        for p in c.chunks_exact(3) {
            for a in 0..3 {
                lo[a] = lo[a].min(f64::from(p[a]));
                hi[a] = hi[a].max(f64::from(p[a]));
            }
        }
    }
    let room_m = lo[0].is_finite().then_some([lo[0], hi[0], lo[1], hi[1]]);
    let floor_z_m = lo[2];
    let desks: Vec<DeskTop> = geometry
        .desks
        .iter()
        .map(|d| DeskTop {
            id: d.id,
            x_m: [d.extent_m[0], d.extent_m[1]],
            y_m: [d.extent_m[2], d.extent_m[3]],
            z_m: d.z_m,
        })
        .collect();
    let map = OccupancyMap::new(
        camera.width,
        camera.height,
        camera.position_m.to_array(),
        if floor_z_m.is_finite() {
            floor_z_m
        } else {
            0.0
        },
        room_m,
        &desks,
        &cells,
        settings,
    )
    .map_err(|e| LiveError::Input(e.to_string()))?;
    let sensor_desk = (0..image.sensors())
        .map(|s| map.desk_under(geometry.sensors.get(s)?.position_m))
        .collect();
    Ok((map, sensor_desk))
}
