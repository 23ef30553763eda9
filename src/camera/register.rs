//! Registration of the colour camera to the ToF camera: every colour (luminance) frame is
//! resampled onto the ToF camera's pixel grid, so the capture set's luminance frames line up
//! with its depth frames (the capture format's convention: one [`crate::scene::Camera`]).
//!
//! ```text
//! ToF pixel (u, v), depth z ─► X_tof = z·d/d_z, d the pixel's ray         (m, ToF camera frame)
//!                             (pinhole: z·((u−cx)/fx, (v−cy)/fy, 1); fisheye: crate::scene::Lens)
//!                           ─► X_col = R·X_tof + t                         (colour camera frame)
//!                           ─► pinhole: (x, y) = X_col.xy / X_col.z,
//!                                radial: (x, y)·(1 + k1 r² + k2 r⁴), r² = x² + y²
//!                              fisheye (Kannala-Brandt): (x, y) = r(θ)·(cos φ, sin φ)
//!                           ─► (u_c, v_c) = (fx_c·x_d + cx_c, fy_c·y_d + cy_c)
//! ```
//!
//! Pixel centres are at integer coordinates (as in [`crate::scene::Camera::ray_world`]). When a
//! ToF pixel covers more than one colour pixel, the colour frame is area-averaged over its
//! footprint (n × n bilinear samples spread over the ToF pixel at its depth, n = the footprint's
//! size in colour pixels, at most [`MAX_SUBSAMPLES`]); otherwise it is sampled bilinearly at the
//! pixel centre. The footprint is taken fronto-parallel at the pixel's depth (a slanted surface's
//! footprint is slightly off; the error is a fraction of one ToF pixel).
//!
//! Output per ToF pixel (the capture format's markers):
//! - `0` (no data) where the depth frame has no return, where the pixel falls outside the colour
//!   image (more than half its samples outside) or is occluded in the colour camera's view;
//! - [`SATURATED`] where any colour pixel contributing to it is saturated;
//! - otherwise the area-weighted mean, rounded (at least 1 when any contributing colour pixel is
//!   non-zero, so a dim surface does not turn into "no data" by averaging).
//!
//! Occlusion: a z-buffer at the colour camera's resolution holds the nearest colour-camera depth
//! that lands on each colour pixel; a ToF pixel loses the colour samples where something nearer
//! (by more than [`OCCLUSION_TOLERANCE_REL`] of its depth + [`OCCLUSION_TOLERANCE_M`]) was seen,
//! and is occluded when it loses more than half of them. Surfaces the ToF camera itself does not
//! see cannot occlude (a thin object the ToF misses but the colour camera sees is not detected).

use super::{CameraError, LuminanceFrame};
use crate::camera::capture::{Frame, SATURATED};
use crate::scene::{Camera, Lens};

/// Most sub-samples per axis of one ToF pixel's footprint.
pub const MAX_SUBSAMPLES: usize = 16;
/// Relative depth margin of the occlusion test.
pub const OCCLUSION_TOLERANCE_REL: f64 = 0.03;
/// Absolute depth margin of the occlusion test, m.
pub const OCCLUSION_TOLERANCE_M: f64 = 0.02;
/// Largest accepted deviation of `R·Rᵀ` from the identity (per element).
pub const ROTATION_TOLERANCE: f64 = 1e-3;

/// The colour camera's intrinsics (pinhole + two-term radial distortion), at the resolution the
/// camera delivers.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourIntrinsics {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (pixel centres at integers).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Radial distortion, r² coefficient (OpenCV's k1).
    pub k1: f64,
    /// Radial distortion, r⁴ coefficient (OpenCV's k2).
    pub k2: f64,
    /// The lens: a pinhole (with `k1`, `k2` above) or a fisheye (then `k1 = k2 = 0`; its own
    /// coefficients are in the [`Lens`]).
    pub lens: Lens,
}

/// The colour camera's pose relative to the ToF camera: `X_colour = rotation · X_tof +
/// translation_m` (both camera frames x right, y down, z forward).
#[derive(Debug, Clone, PartialEq)]
pub struct ColourFromTof {
    /// Rotation, row-major.
    pub rotation: [[f64; 3]; 3],
    /// Translation, m (the ToF camera's centre in colour camera coordinates).
    pub translation_m: [f64; 3],
}

impl ColourFromTof {
    /// The same optical centre and axes.
    pub fn identity() -> Self {
        Self {
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation_m: [0.0; 3],
        }
    }
}

/// A validated colour-to-ToF registration.
#[derive(Debug, Clone, PartialEq)]
pub struct Registration {
    intrinsics: ColourIntrinsics,
    colour_from_tof: ColourFromTof,
}

/// Why a ToF pixel got no colour value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unmapped {
    /// The depth frame has no return.
    NoDepth,
    /// Outside the colour image (or behind the colour camera).
    OutOfView,
    /// Hidden behind a nearer surface in the colour camera's view.
    Occluded,
}

/// Counts of a [`RegistrationMap`]'s pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MapCounts {
    /// Pixels with a colour value.
    pub mapped: usize,
    /// Pixels without depth.
    pub no_depth: usize,
    /// Pixels outside the colour image.
    pub out_of_view: usize,
    /// Pixels occluded in the colour view.
    pub occluded: usize,
}

/// The resampling of one depth frame's geometry: per ToF pixel, the colour pixels and weights
/// it averages. Built once per capture ([`Registration::map`]), applied to every colour frame.
#[derive(Debug, Clone)]
pub struct RegistrationMap {
    tof_width: u32,
    tof_height: u32,
    colour_width: u32,
    colour_height: u32,
    /// Per ToF pixel: `Ok(range into taps)` or why it is unmapped.
    pixel: Vec<Result<(u32, u32), Unmapped>>,
    tap_index: Vec<u32>,
    tap_weight: Vec<f64>,
}

fn finite(name: &str, x: f64) -> Result<f64, CameraError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(CameraError::Config(format!(
            "colour registration: {name} is {x}, must be finite"
        )))
    }
}

impl Registration {
    /// Checks and takes a calibration: positive finite focal lengths, principal point inside the
    /// image, finite distortion that keeps the projection monotonic over the image, an
    /// orthonormal right-handed rotation (within [`ROTATION_TOLERANCE`]), a finite translation
    /// under 1 m.
    pub fn new(
        intrinsics: ColourIntrinsics,
        colour_from_tof: ColourFromTof,
    ) -> Result<Self, CameraError> {
        let bad = |m: String| Err(CameraError::Config(format!("colour registration: {m}")));
        let i = &intrinsics;
        if i.width == 0 || i.height == 0 || i.width > 16384 || i.height > 16384 {
            return bad(format!("image size {}x{} pixels", i.width, i.height));
        }
        for (n, x) in [("fx", i.fx), ("fy", i.fy)] {
            if finite(n, x)? <= 0.0 {
                return bad(format!("{n} = {x} pixels must be positive"));
            }
        }
        for (n, x, size) in [("cx", i.cx, i.width), ("cy", i.cy, i.height)] {
            if !(-0.5..=f64::from(size) - 0.5).contains(&finite(n, x)?) {
                return bad(format!(
                    "{n} = {x} pixels is outside the {size}-pixel image"
                ));
            }
        }
        if let Err(m) = crate::scene::check_intrinsics(i.fx, i.fy, i.cx, i.cy, i.width, i.height) {
            return bad(m);
        }
        finite("k1", i.k1)?;
        finite("k2", i.k2)?;
        if let Err(m) = i.lens.check() {
            return bad(m);
        }
        if i.lens.is_fisheye() && (i.k1 != 0.0 || i.k2 != 0.0) {
            return bad(format!(
                "k1 = {}, k2 = {} are pinhole distortion: a fisheye lens takes its own k",
                i.k1, i.k2
            ));
        }
        // the distortion factor r_d = r (1 + k1 r² + k2 r⁴) must grow with r up to the image
        // corner, or the projection folds over
        let corner_r2 = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(a, b)| {
                let x = (a * f64::from(i.width) - 0.5 - i.cx) / i.fx;
                let y = (b * f64::from(i.height) - 0.5 - i.cy) / i.fy;
                x * x + y * y
            })
            .fold(0.0_f64, f64::max);
        for k in 0..=32 {
            let r2 = corner_r2 * 1.5 * f64::from(k) / 32.0;
            // d/dr [r (1 + k1 r² + k2 r⁴)] = 1 + 3 k1 r² + 5 k2 r⁴
            if 1.0 + 3.0 * i.k1 * r2 + 5.0 * i.k2 * r2 * r2 <= 0.0 {
                return bad(format!(
                    "distortion k1 = {}, k2 = {} folds the image over inside its corners",
                    i.k1, i.k2
                ));
            }
        }
        let r = &colour_from_tof.rotation;
        for (a, row) in r.iter().enumerate() {
            for (b, &x) in row.iter().enumerate() {
                finite(&format!("rotation[{a}][{b}]"), x)?;
            }
        }
        for a in 0..3 {
            for b in 0..3 {
                let dot: f64 = (0..3).map(|k| r[a][k] * r[b][k]).sum();
                let want = if a == b { 1.0 } else { 0.0 };
                if (dot - want).abs() > ROTATION_TOLERANCE {
                    return bad(format!(
                        "rotation is not orthonormal (rows {a}·{b} = {dot:.6}, want {want}); \
                         give a rotation matrix, row-major"
                    ));
                }
            }
        }
        let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
            - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
        if det < 0.0 {
            return bad("rotation is a reflection (determinant −1)".into());
        }
        let t = colour_from_tof.translation_m;
        for (k, &x) in t.iter().enumerate() {
            finite(&format!("translation_m[{k}]"), x)?;
        }
        let baseline_m = t.iter().map(|x| x * x).sum::<f64>().sqrt();
        if baseline_m > 1.0 {
            return bad(format!(
                "translation of {baseline_m:.3} m: the cameras of one node are centimetres apart \
                 (metres expected, not millimetres?)"
            ));
        }
        Ok(Self {
            intrinsics,
            colour_from_tof,
        })
    }

    /// The identity registration for frames already on the ToF camera's grid (same intrinsics,
    /// no distortion, same optical centre).
    pub fn identity(tof: &Camera) -> Result<Self, CameraError> {
        Self::new(
            ColourIntrinsics {
                width: tof.width,
                height: tof.height,
                fx: tof.fx,
                fy: tof.fy,
                cx: tof.cx,
                cy: tof.cy,
                k1: 0.0,
                k2: 0.0,
                lens: tof.lens,
            },
            ColourFromTof::identity(),
        )
    }

    /// The colour camera's intrinsics.
    pub fn intrinsics(&self) -> &ColourIntrinsics {
        &self.intrinsics
    }

    /// The colour camera's pose relative to the ToF camera.
    pub fn colour_from_tof(&self) -> &ColourFromTof {
        &self.colour_from_tof
    }

    /// Projects a point in ToF camera coordinates (m) to the colour image: (u, v, depth along
    /// the colour camera's axis in m), `None` behind the colour camera.
    pub fn project(&self, p_tof_m: [f64; 3]) -> Option<(f64, f64, f64)> {
        let r = &self.colour_from_tof.rotation;
        let t = &self.colour_from_tof.translation_m;
        let c: [f64; 3] =
            std::array::from_fn(|a| (0..3).map(|k| r[a][k] * p_tof_m[k]).sum::<f64>() + t[a]);
        let i = &self.intrinsics;
        if i.lens.is_fisheye() {
            let m = i.lens.project(glam::DVec3::from_array(c))?;
            return Some((i.fx * m.x + i.cx, i.fy * m.y + i.cy, c[2]));
        }
        if c[2] <= 1e-6 {
            return None;
        }
        let (x, y) = (c[0] / c[2], c[1] / c[2]);
        let r2 = x * x + y * y;
        let d = 1.0 + i.k1 * r2 + i.k2 * r2 * r2;
        Some((i.fx * x * d + i.cx, i.fy * y * d + i.cy, c[2]))
    }

    /// The resampling for one depth frame (mm along the ToF axis, 0 = no return) of the ToF
    /// camera `tof`.
    pub fn map(&self, tof: &Camera, depth_mm: &Frame) -> Result<RegistrationMap, CameraError> {
        let (tw, th) = (tof.width, tof.height);
        if depth_mm.width != tw || depth_mm.height != th {
            return Err(CameraError::Config(format!(
                "registration: the depth frame is {}x{}, the ToF camera {tw}x{th}",
                depth_mm.width, depth_mm.height
            )));
        }
        if depth_mm.data.len() != (tw as usize) * (th as usize) {
            return Err(CameraError::Config(format!(
                "registration: {} depth values for {tw}x{th} pixels",
                depth_mm.data.len()
            )));
        }
        if !(tof.fx.is_finite() && tof.fy.is_finite() && tof.fx > 0.0 && tof.fy > 0.0) {
            return Err(CameraError::Config(format!(
                "registration: ToF focal lengths {} / {} pixels",
                tof.fx, tof.fy
            )));
        }
        let (cw, ch) = (self.intrinsics.width, self.intrinsics.height);
        let back = |u: f64, v: f64, z_m: f64| tof.point_at_depth_camera(u, v, z_m);
        let proj = |p: Option<glam::DVec3>| p.and_then(|p| self.project(p.to_array()));
        // pass 1: per pixel, the in-view bilinear taps of its footprint and its colour depth
        struct Px {
            taps: Vec<(u32, f64)>,
            in_view: f64,
            z_colour_m: f64,
        }
        let mut pass1: Vec<Result<Px, Unmapped>> = Vec::with_capacity(depth_mm.data.len());
        for v in 0..th {
            for u in 0..tw {
                let d = depth_mm.data[(v * tw + u) as usize];
                if d == 0 {
                    pass1.push(Err(Unmapped::NoDepth));
                    continue;
                }
                let z_m = f64::from(d) * 1e-3;
                let (uf, vf) = (f64::from(u), f64::from(v));
                let Some((uc, vc, zc)) = proj(back(uf, vf, z_m)) else {
                    pass1.push(Err(Unmapped::OutOfView));
                    continue;
                };
                // footprint size in colour pixels: the images of the pixel's edge midpoints
                let extent = |a, b| match (proj(a), proj(b)) {
                    (Some(p), Some(q)) => (p.0 - q.0).hypot(p.1 - q.1),
                    _ => 1.0,
                };
                let su = extent(back(uf + 0.5, vf, z_m), back(uf - 0.5, vf, z_m));
                let sv = extent(back(uf, vf + 0.5, z_m), back(uf, vf - 0.5, z_m));
                let n = ((su.max(sv) - 1e-6).ceil() as usize).clamp(1, MAX_SUBSAMPLES);
                let mut taps: Vec<(u32, f64)> = Vec::with_capacity(4 * n * n);
                let w_sample = 1.0 / (n * n) as f64;
                let mut in_view = 0.0;
                for j in 0..n {
                    for i in 0..n {
                        let (p_u, p_v) = if n == 1 {
                            (uc, vc)
                        } else {
                            let du = (i as f64 + 0.5) / n as f64 - 0.5;
                            let dv = (j as f64 + 0.5) / n as f64 - 0.5;
                            match proj(back(uf + du, vf + dv, z_m)) {
                                Some((a, b, _)) => (a, b),
                                None => continue,
                            }
                        };
                        if let Some(b) = bilinear(p_u, p_v, cw, ch) {
                            in_view += w_sample;
                            for (idx, w) in b {
                                if w > 1e-12 {
                                    taps.push((idx, w * w_sample));
                                }
                            }
                        }
                    }
                }
                if in_view < 0.5 {
                    pass1.push(Err(Unmapped::OutOfView));
                    continue;
                }
                taps.sort_unstable_by_key(|t| t.0);
                taps.dedup_by(|a, b| {
                    if a.0 == b.0 {
                        b.1 += a.1;
                        true
                    } else {
                        false
                    }
                });
                pass1.push(Ok(Px {
                    taps,
                    in_view,
                    z_colour_m: zc,
                }));
            }
        }
        // pass 2: z-buffer at colour resolution, then drop the occluded taps
        let mut zbuf = vec![f64::INFINITY; (cw as usize) * (ch as usize)];
        for p in pass1.iter().flatten() {
            for &(idx, _) in &p.taps {
                let z = &mut zbuf[idx as usize];
                *z = z.min(p.z_colour_m);
            }
        }
        let mut map = RegistrationMap {
            tof_width: tw,
            tof_height: th,
            colour_width: cw,
            colour_height: ch,
            pixel: Vec::with_capacity(pass1.len()),
            tap_index: Vec::new(),
            tap_weight: Vec::new(),
        };
        for p in pass1 {
            let p = match p {
                Ok(p) => p,
                Err(e) => {
                    map.pixel.push(Err(e));
                    continue;
                }
            };
            let limit = p.z_colour_m * (1.0 - OCCLUSION_TOLERANCE_REL) - OCCLUSION_TOLERANCE_M;
            let start = map.tap_index.len();
            let mut kept = 0.0;
            for &(idx, w) in &p.taps {
                if zbuf[idx as usize] >= limit {
                    map.tap_index.push(idx);
                    map.tap_weight.push(w);
                    kept += w;
                }
            }
            if kept < 0.5 * p.in_view {
                map.tap_index.truncate(start);
                map.tap_weight.truncate(start);
                map.pixel.push(Err(Unmapped::Occluded));
                continue;
            }
            for w in &mut map.tap_weight[start..] {
                *w /= kept;
            }
            map.pixel
                .push(Ok((start as u32, (map.tap_index.len() - start) as u32)));
        }
        Ok(map)
    }

    /// Maps one colour frame onto the ToF grid for one depth frame (for a sequence, build the
    /// [`RegistrationMap`] once and [`RegistrationMap::apply`] it to every frame).
    pub fn register(
        &self,
        tof: &Camera,
        depth_mm: &Frame,
        colour: &LuminanceFrame,
    ) -> Result<LuminanceFrame, CameraError> {
        self.map(tof, depth_mm)?.apply(colour)
    }
}

/// The bilinear taps of the point (u, v) of a `w`×`h` image: `None` outside the image (pixel
/// centres at integers, the image spans −0.5..w−0.5); within half a pixel of the border the
/// nearest row/column is repeated.
fn bilinear(u: f64, v: f64, w: u32, h: u32) -> Option<[(u32, f64); 4]> {
    let (wf, hf) = (f64::from(w), f64::from(h));
    if !(u >= -0.5 && u < wf - 0.5 && v >= -0.5 && v < hf - 0.5) {
        return None;
    }
    // snap positions within rounding of a pixel centre (exact identity mapping)
    let snap = |x: f64| {
        let r = x.round();
        if (x - r).abs() < 1e-9 { r } else { x }
    };
    let u = snap(u).clamp(0.0, wf - 1.0);
    let v = snap(v).clamp(0.0, hf - 1.0);
    let (x0, y0) = (u.floor(), v.floor());
    let (ax, ay) = (u - x0, v - y0);
    let (x0, y0) = (x0 as u32, y0 as u32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    Some([
        (y0 * w + x0, (1.0 - ax) * (1.0 - ay)),
        (y0 * w + x1, ax * (1.0 - ay)),
        (y1 * w + x0, (1.0 - ax) * ay),
        (y1 * w + x1, ax * ay),
    ])
}

impl RegistrationMap {
    /// Why ToF pixel (u, v) has no colour value, `None` when it has one (or is outside the
    /// frame).
    pub fn unmapped(&self, u: u32, v: u32) -> Option<Unmapped> {
        if u >= self.tof_width || v >= self.tof_height {
            return None;
        }
        self.pixel[(v * self.tof_width + u) as usize].err()
    }

    /// How many pixels are mapped, and why the others are not.
    pub fn counts(&self) -> MapCounts {
        let mut c = MapCounts::default();
        for p in &self.pixel {
            match p {
                Ok(_) => c.mapped += 1,
                Err(Unmapped::NoDepth) => c.no_depth += 1,
                Err(Unmapped::OutOfView) => c.out_of_view += 1,
                Err(Unmapped::Occluded) => c.occluded += 1,
            }
        }
        c
    }

    /// Resamples a colour frame onto the ToF grid (same scale, timestamp and exposure).
    pub fn apply(&self, colour: &LuminanceFrame) -> Result<LuminanceFrame, CameraError> {
        if colour.width != self.colour_width || colour.height != self.colour_height {
            return Err(CameraError::Config(format!(
                "registration: the colour frame is {}x{}, the colour calibration is for {}x{}",
                colour.width, colour.height, self.colour_width, self.colour_height
            )));
        }
        if colour.data.len() != (colour.width as usize) * (colour.height as usize) {
            return Err(CameraError::Garbage {
                device: "colour camera".into(),
                reason: format!(
                    "{} values for {}x{} pixels",
                    colour.data.len(),
                    colour.width,
                    colour.height
                ),
            });
        }
        let data = self
            .pixel
            .iter()
            .map(|p| {
                let Ok((start, n)) = *p else { return 0 };
                let r = start as usize..(start + n) as usize;
                let mut sum = 0.0_f64;
                for (&idx, &w) in self.tap_index[r.clone()].iter().zip(&self.tap_weight[r]) {
                    let x = colour.data[idx as usize];
                    if x == SATURATED {
                        return SATURATED;
                    }
                    sum += w * f64::from(x);
                }
                // 0 is "no data" in the capture format: a lit-but-dark pixel reads 1
                let x = sum.round().min(f64::from(SATURATED - 1));
                if sum > 0.0 { x.max(1.0) as u16 } else { 0 }
            })
            .collect();
        Ok(LuminanceFrame {
            width: self.tof_width,
            height: self.tof_height,
            data,
            cd_m2_per_unit: colour.cd_m2_per_unit,
            timestamp: colour.timestamp,
            exposure_s: colour.exposure_s,
        })
    }
}

/// The per-pixel median of the non-zero values of several depth frames (0 where none has a
/// return): the geometry a capture's colour frames are registered with.
pub fn median_depth(frames: &[Frame]) -> Option<Frame> {
    let first = frames.first()?;
    let n = first.data.len();
    if frames
        .iter()
        .any(|f| f.width != first.width || f.height != first.height || f.data.len() != n)
    {
        return None;
    }
    let mut vals = Vec::with_capacity(frames.len());
    let data = (0..n)
        .map(|i| {
            vals.clear();
            vals.extend(frames.iter().map(|f| f.data[i]).filter(|&d| d != 0));
            if vals.is_empty() {
                return 0;
            }
            vals.sort_unstable();
            let m = vals.len();
            if m % 2 == 1 {
                vals[m / 2]
            } else {
                ((u32::from(vals[m / 2 - 1]) + u32::from(vals[m / 2])) / 2) as u16
            }
        })
        .collect();
    Some(Frame {
        width: first.width,
        height: first.height,
        data,
    })
}
