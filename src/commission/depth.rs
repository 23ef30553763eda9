//! Depth frames to one clean depth map, and pixels to world points.
//!
//! 1. **Temporal median** per pixel over the frames' returns (0 = no return). With three or
//!    more frames a pixel needs returns in at least half of them, else it is a dropout.
//! 2. **Flying pixels and outliers**: a ToF pixel straddling a depth edge mixes the two depths
//!    and lands in between; an outlier lands anywhere. Both have few neighbours at their own
//!    depth: a pixel keeps its depth only when at least [`DepthOptions::min_agreeing`] of its 8
//!    neighbours lie within [`DepthOptions::edge_rel`] (relative) of it.
//!
//! Back-projection (`docs/formats.md`): the pixel (u, v) at depth z (along the
//! optical axis) is `p_camera = z d / d_z` for the unit ray d of the pixel (the pinhole's
//! `z ((u − cx)/fx, (v − cy)/fy, 1)`; a fisheye's per [`crate::scene::Lens`]), `p_world =
//! position + world_from_camera · p_camera`.

use glam::DVec3;

use super::CommissionError;
use crate::camera::capture::Frame;
use crate::scene::Camera;

/// Depth cleaning knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthOptions {
    /// Two neighbouring depths agree when they differ by at most this fraction of the depth.
    pub edge_rel: f64,
    /// Fewest agreeing neighbours (of 8) a pixel needs to be kept.
    pub min_agreeing: usize,
    /// Depths beyond this are no return (a ToF camera's saturated or overflowing pixels, such
    /// as 65535 mm): treated as dropouts, never as a far wall.
    pub max_depth_m: f64,
}

impl Default for DepthOptions {
    fn default() -> Self {
        Self {
            edge_rel: 0.03,
            min_agreeing: 3,
            max_depth_m: 20.0,
        }
    }
}

/// What cleaning removed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DepthStats {
    /// Frames fused.
    pub frames: usize,
    /// Pixels in a frame.
    pub pixels: usize,
    /// No (or too few) returns.
    pub dropouts: usize,
    /// Removed as flying pixels or outliers.
    pub flying_or_outliers: usize,
    /// Pixels kept.
    pub valid: usize,
}

/// A clean depth map: z along the optical axis per pixel, m (NaN: none).
#[derive(Debug, Clone)]
pub struct DepthMap {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Depth per pixel, m, row-major; NaN where there is none.
    pub z_m: Vec<f64>,
    /// What cleaning did.
    pub stats: DepthStats,
}

impl DepthMap {
    /// Depth at (u, v), m, if any.
    pub fn at(&self, u: u32, v: u32) -> Option<f64> {
        let z = *self.z_m.get((v * self.width + u) as usize)?;
        z.is_finite().then_some(z)
    }

    /// The world point of pixel (u, v), m, if it has a depth.
    pub fn point_m(&self, camera: &Camera, u: u32, v: u32) -> Option<DVec3> {
        self.at(u, v)
            .and_then(|z| back_project(camera, f64::from(u), f64::from(v), z))
    }

    /// Whether the depth seen at pixel (u, v) puts the surface at the world point `p`: within
    /// [`SEEN_AT_ABS_M`] + [`SEEN_AT_REL`] of its distance from the camera. `None` when the
    /// pixel has no depth.
    pub fn sees_at(&self, camera: &Camera, u: u32, v: u32, p: DVec3) -> Option<bool> {
        let q = self.point_m(camera, u, v)?;
        let (dq, dp) = (
            (q - camera.position_m).length(),
            (p - camera.position_m).length(),
        );
        Some((dq - dp).abs() <= SEEN_AT_ABS_M + SEEN_AT_REL * dp)
    }
}

/// A depth within this of a point's distance (plus [`SEEN_AT_REL`] of it) sees the point: a
/// ToF camera's noise after the temporal median and the coarse mesh's flatness, well under a
/// monitor's height above its desk.
pub const SEEN_AT_ABS_M: f64 = 0.05;
/// The part of [`DepthMap::sees_at`]'s tolerance that grows with the distance.
pub const SEEN_AT_REL: f64 = 0.03;

/// The world point at depth `z_m` (along the optical axis) through pixel (u, v), `None` outside
/// the lens's field.
pub fn back_project(camera: &Camera, u: f64, v: f64, z_m: f64) -> Option<DVec3> {
    camera.point_at_depth(u, v, z_m)
}

/// Fuses depth frames (mm) into one clean map.
pub fn fuse(frames: &[Frame], options: &DepthOptions) -> Result<DepthMap, CommissionError> {
    let Some(first) = frames.first() else {
        return Err(CommissionError::NoDepthFrames);
    };
    let (w, h) = (first.width, first.height);
    if let Some(f) = frames.iter().find(|f| f.width != w || f.height != h) {
        return Err(CommissionError::DepthSizes {
            first: [w, h],
            other: [f.width, f.height],
        });
    }
    let n = (w as usize) * (h as usize);
    if let Some(f) = frames.iter().find(|f| f.data.len() != n) {
        return Err(CommissionError::DepthData {
            values: f.data.len(),
            pixels: n,
        });
    }
    let need = if frames.len() >= 3 {
        frames.len().div_ceil(2)
    } else {
        1
    };
    let mut stats = DepthStats {
        frames: frames.len(),
        pixels: n,
        ..DepthStats::default()
    };
    let mut z = vec![f64::NAN; n];
    let mut buf = Vec::with_capacity(frames.len());
    for (i, zi) in z.iter_mut().enumerate() {
        buf.clear();
        buf.extend(
            frames
                .iter()
                .map(|f| f.data[i])
                .filter(|&d| d > 0 && f64::from(d) * 1e-3 <= options.max_depth_m),
        );
        if buf.len() < need {
            stats.dropouts += 1;
            continue;
        }
        buf.sort_unstable();
        let m = buf.len();
        let mm = if m % 2 == 1 {
            f64::from(buf[m / 2])
        } else {
            0.5 * (f64::from(buf[m / 2 - 1]) + f64::from(buf[m / 2]))
        };
        *zi = mm * 1e-3;
    }
    // flying pixels and outliers
    let mut keep = vec![false; n];
    let (wi, hi) = (w as i64, h as i64);
    for v in 0..hi {
        for u in 0..wi {
            let i = (v * wi + u) as usize;
            let zc = z[i];
            if !zc.is_finite() {
                continue;
            }
            let mut agree = 0;
            let mut neighbours: usize = 0;
            for dv in -1..=1 {
                for du in -1..=1 {
                    if du == 0 && dv == 0 {
                        continue;
                    }
                    let (uu, vv) = (u + du, v + dv);
                    if uu < 0 || vv < 0 || uu >= wi || vv >= hi {
                        continue;
                    }
                    let zn = z[(vv * wi + uu) as usize];
                    if zn.is_finite() {
                        neighbours += 1;
                        if (zn - zc).abs() <= options.edge_rel * zc {
                            agree += 1;
                        }
                    }
                }
            }
            // at the image border or beside dropouts fewer neighbours exist: ask for a
            // majority of those present
            let needed = options.min_agreeing.min(neighbours.div_ceil(2)).max(1);
            keep[i] = agree >= needed;
        }
    }
    for (zi, k) in z.iter_mut().zip(&keep) {
        if zi.is_finite() && !k {
            *zi = f64::NAN;
            stats.flying_or_outliers += 1;
        }
    }
    stats.valid = z.iter().filter(|v| v.is_finite()).count();
    if (stats.valid as f64) < 0.01 * n as f64 {
        return Err(CommissionError::DepthUnusable {
            valid: stats.valid,
            pixels: n,
            max_depth_m: options.max_depth_m,
        });
    }
    Ok(DepthMap {
        width: w,
        height: h,
        z_m: z,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: u32, h: u32, f: impl Fn(u32, u32) -> u16) -> Frame {
        let mut data = Vec::new();
        for v in 0..h {
            for u in 0..w {
                data.push(f(u, v));
            }
        }
        Frame {
            width: w,
            height: h,
            data,
        }
    }

    #[test]
    fn median_removes_dropouts_and_a_flying_pixel() {
        let a = frame(20, 20, |_, _| 2000);
        let mut b = a.clone();
        b.data[5] = 0; // one dropout: the others still give the median
        let mut c = a.clone();
        c.data[7] = 9000; // an outlier in one frame: the median ignores it
        let mut d = frame(20, 20, |u, _| if u < 10 { 2000 } else { 3000 });
        d.data[10 * 20 + 10] = 2500;
        let m = fuse(&[a, b, c], &DepthOptions::default()).expect("fuses");
        assert_eq!(m.stats.dropouts, 0);
        assert!((m.at(5, 0).expect("depth") - 2.0).abs() < 1e-9);
        assert!((m.at(7, 0).expect("depth") - 2.0).abs() < 1e-9);
        let m = fuse(&[d], &DepthOptions::default()).expect("fuses");
        assert!(m.at(10, 10).is_none(), "flying pixel between 2 m and 3 m");
        assert!(m.at(3, 10).is_some() && m.at(15, 10).is_some());
    }

    #[test]
    fn all_zero_depth_is_an_error() {
        let z = frame(8, 8, |_, _| 0);
        assert!(fuse(&[z], &DepthOptions::default()).is_err());
        assert!(fuse(&[], &DepthOptions::default()).is_err());
    }

    #[test]
    fn a_pixels_depth_sees_the_surface_at_its_distance_and_not_a_monitor_above_it() {
        // a straight-down pinhole 2 m over a desk top: every pixel's depth 2 m, but a monitor
        // 0.4 m tall over the pixels u ≥ 10
        let camera = Camera {
            position_m: DVec3::new(0.0, 0.0, 2.0),
            world_from_camera: glam::DMat3::from_cols(DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z),
            fx: 20.0,
            fy: 20.0,
            cx: 9.5,
            cy: 9.5,
            width: 20,
            height: 20,
            luminance_cd_m2_per_unit: None,
            lens: crate::scene::Lens::Pinhole,
        };
        let depth = |u: u32| if u >= 10 { 1600 } else { 2000 };
        let m = fuse(&[frame(20, 20, |u, _| depth(u))], &DepthOptions::default()).expect("fuses");
        // the desk-top point each pixel's ray meets
        let on_desk = |u: u32, v: u32| {
            let d = camera.ray_world(f64::from(u), f64::from(v)).expect("a ray");
            camera.position_m + d * (2.0 / -d.z)
        };
        assert_eq!(m.sees_at(&camera, 3, 4, on_desk(3, 4)), Some(true));
        assert_eq!(m.sees_at(&camera, 15, 4, on_desk(15, 4)), Some(false));
        // within the tolerance: 5 cm + 3 % of the distance (11 cm at 2 m)
        let p = on_desk(3, 4) + DVec3::new(0.0, 0.0, 0.1);
        assert_eq!(m.sees_at(&camera, 3, 4, p), Some(true));
        let p = on_desk(3, 4) + DVec3::new(0.0, 0.0, 0.13);
        assert_eq!(m.sees_at(&camera, 3, 4, p), Some(false));
        // no depth at the pixel: no answer
        let mut hole = m.clone();
        hole.z_m[(4 * 20 + 3) as usize] = f64::NAN;
        assert_eq!(hole.sees_at(&camera, 3, 4, on_desk(3, 4)), None);
    }
}
