//! Dense illuminance against Radiance: the desk grids of `truth_dense.csv` (mean error, U0 per
//! desk) and the camera-view lux image against the rendered truth `E = π L / ρ` (the all-on
//! luminance frame of the capture set over `groundtruth/albedo.png`, on the desk pixels of
//! `groundtruth/labels.png`), with the time each takes (`luxnode bench dense`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::en12464::Statistics;
use crate::engine::dense::{DenseField, DenseImage, SurfacePoint};

/// Why the truth could not be read.
#[derive(Debug, thiserror::Error)]
pub enum DenseTruthError {
    /// A file could not be read.
    #[error("{}: {reason}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

fn bad(path: &Path, reason: impl Into<String>) -> DenseTruthError {
    DenseTruthError::File {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// One point of `truth_dense.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DensePoint {
    /// Desk id.
    pub desk_id: u32,
    /// Position, m.
    pub position_m: DVec3,
    /// Radiance illuminance, lx.
    pub lux: f64,
}

/// Reads `truth_dense.csv` (`desk_id,x,y,z,lux,...`).
pub fn read_truth_dense(path: &Path) -> Result<Vec<DensePoint>, DenseTruthError> {
    let text = std::fs::read_to_string(path).map_err(|e| bad(path, e.to_string()))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let num = |k: usize| -> Result<f64, DenseTruthError> {
            f.get(k)
                .and_then(|s| s.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    bad(
                        path,
                        format!("line {}: field {} is not a number", n + 1, k + 1),
                    )
                })
        };
        out.push(DensePoint {
            desk_id: num(0)? as u32,
            position_m: DVec3::new(num(1)?, num(2)?, num(3)?),
            lux: num(4)?,
        });
    }
    if out.is_empty() {
        return Err(bad(path, "no points"));
    }
    Ok(out)
}

/// Computed against true illuminance at the desk grid points.
#[derive(Debug, Clone, PartialEq)]
pub struct GridComparison {
    /// Mean |error| / mean true illuminance over all points.
    pub mean_abs_error: f64,
    /// Mean computed / mean true − 1 (the bias).
    pub mean_bias: f64,
    /// Worst single point, |error| / true.
    pub worst_point: f64,
    /// Per desk: (id, true stats, computed stats).
    pub desks: Vec<(u32, Statistics, Statistics)>,
}

/// Compares computed values at the truth's points.
pub fn compare_grid(truth: &[DensePoint], computed_lx: &[f64]) -> Option<GridComparison> {
    if truth.len() != computed_lx.len() || truth.is_empty() {
        return None;
    }
    let sum_t: f64 = truth.iter().map(|p| p.lux).sum();
    let sum_c: f64 = computed_lx.iter().sum();
    let abs: f64 = truth
        .iter()
        .zip(computed_lx)
        .map(|(t, c)| (c - t.lux).abs())
        .sum();
    let worst = truth
        .iter()
        .zip(computed_lx)
        .map(|(t, c)| (c - t.lux).abs() / t.lux.max(1e-9))
        .fold(0.0, f64::max);
    let mut per: BTreeMap<u32, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for (t, c) in truth.iter().zip(computed_lx) {
        let e = per.entry(t.desk_id).or_default();
        e.0.push(t.lux);
        e.1.push(*c);
    }
    let desks = per
        .into_iter()
        .filter_map(|(id, (t, c))| Some((id, Statistics::of(&t)?, Statistics::of(&c)?)))
        .collect();
    Some(GridComparison {
        mean_abs_error: abs / sum_t,
        mean_bias: sum_c / sum_t - 1.0,
        worst_point: worst,
        desks,
    })
}

/// The truth's desk points as surface points of the field (on the desk top below each).
pub fn truth_surface_points(field: &DenseField<'_>, truth: &[DensePoint]) -> Vec<SurfacePoint> {
    truth
        .iter()
        .map(|p| {
            field
                .surface_at(p.position_m.x, p.position_m.y, p.position_m.z)
                .unwrap_or(SurfacePoint {
                    position_m: p.position_m,
                    normal: DVec3::Z,
                    patch: u32::MAX,
                })
        })
        .collect()
}

/// The rendered truth of a capture set: illuminance per pixel `π L / ρ` and the label of the
/// surface each pixel sees.
#[derive(Debug, Clone)]
pub struct CameraTruth {
    /// Pixels across.
    pub width: u32,
    /// Pixels down.
    pub height: u32,
    /// `π L / ρ`, lx (NaN where ρ = 0 or the luminance clipped).
    pub lux: Vec<f64>,
    /// Label name per pixel.
    pub label: Vec<String>,
}

fn read_gray16(path: &Path) -> Result<(u32, u32, Vec<u16>), DenseTruthError> {
    let img = image::ImageReader::open(path)
        .map_err(|e| bad(path, e.to_string()))?
        .with_guessed_format()
        .map_err(|e| bad(path, e.to_string()))?
        .decode()
        .map_err(|e| bad(path, e.to_string()))?;
    let w = img.width();
    let h = img.height();
    Ok((w, h, img.into_luma16().into_raw()))
}

/// Reads a capture set's all-on luminance frame, albedo and labels.
pub fn read_camera_truth(capture: &Path) -> Result<CameraTruth, DenseTruthError> {
    let cam_path = capture.join("camera.json");
    let cam: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&cam_path).map_err(|e| bad(&cam_path, e.to_string()))?,
    )
    .map_err(|e| bad(&cam_path, e.to_string()))?;
    let per_unit = cam
        .get("luminance_cd_m2_per_unit")
        .and_then(|v| v.as_f64())
        .ok_or_else(|| bad(&cam_path, "no luminance_cd_m2_per_unit"))?;
    let (w, h, lum) = read_gray16(&capture.join("luminance_all.png"))?;
    let (wa, ha, albedo) = read_gray16(&capture.join("groundtruth/albedo.png"))?;
    let labels_path = capture.join("groundtruth/labels.png");
    let (wl, hl, labels) = read_gray16(&labels_path)?;
    if (wa, ha) != (w, h) || (wl, hl) != (w, h) {
        return Err(bad(capture, "frames of different sizes"));
    }
    let names_path = capture.join("groundtruth/labels.json");
    let names: BTreeMap<String, String> = serde_json::from_str(
        &std::fs::read_to_string(&names_path).map_err(|e| bad(&names_path, e.to_string()))?,
    )
    .map_err(|e| bad(&names_path, e.to_string()))?;
    // a 16-bit decode of an 8-bit label image scales by 257
    let scale = if labels.iter().all(|v| v % 257 == 0) {
        257
    } else {
        1
    };
    let label = labels
        .iter()
        .map(|v| {
            names
                .get(&(v / scale).to_string())
                .cloned()
                .unwrap_or_default()
        })
        .collect();
    let lux = lum
        .iter()
        .zip(&albedo)
        .map(|(l, a)| {
            let rho = f64::from(*a) / 10_000.0;
            if rho <= 0.0 || *l == u16::MAX {
                f64::NAN
            } else {
                std::f64::consts::PI * f64::from(*l) * per_unit / rho
            }
        })
        .collect();
    Ok(CameraTruth {
        width: w,
        height: h,
        lux,
        label,
    })
}

/// Computed against true per-pixel illuminance on the desk pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelComparison {
    /// Desk pixels compared (all of whose 4 neighbours are desk pixels too).
    pub pixels: usize,
    /// Median |error| / true.
    pub median: f64,
    /// 90th percentile of |error| / true.
    pub p90: f64,
    /// Mean (computed / true − 1).
    pub bias: f64,
}

/// Compares a dense image (all on) with the truth on the inner desk pixels.
pub fn compare_pixels(
    truth: &CameraTruth,
    image: &DenseImage,
    lux: &[f64],
) -> Option<PixelComparison> {
    if (truth.width, truth.height) != (image.width, image.height) {
        return None;
    }
    let (w, h) = (truth.width as usize, truth.height as usize);
    let desk = |k: usize| truth.label[k].starts_with("desk_");
    let mut rel = Vec::new();
    let mut bias = 0.0;
    for v in 1..h.saturating_sub(1) {
        for u in 1..w.saturating_sub(1) {
            let k = v * w + u;
            if !(desk(k) && desk(k - 1) && desk(k + 1) && desk(k - w) && desk(k + w)) {
                continue;
            }
            let (t, c) = (truth.lux[k], lux[k]);
            if !(t.is_finite() && c.is_finite() && t > 0.0) {
                continue;
            }
            rel.push((c - t).abs() / t);
            bias += c / t - 1.0;
        }
    }
    if rel.is_empty() {
        return None;
    }
    let n = rel.len();
    bias /= n as f64;
    rel.sort_by(f64::total_cmp);
    Some(PixelComparison {
        pixels: n,
        median: rel[n / 2],
        p90: rel[(n * 9) / 10],
        bias,
    })
}
