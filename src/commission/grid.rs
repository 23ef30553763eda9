//! The organised point grid: the clean depth map sampled every `stride` pixels (each sample the
//! median of its `stride × stride` block, which also averages range noise), back-projected to
//! world points, with normals from the grid neighbours.

use glam::DVec3;

use super::depth::{DepthMap, back_project};
use crate::scene::Camera;

/// World points on a regular grid of pixels.
#[derive(Debug, Clone)]
pub struct PointGrid {
    /// Grid columns.
    pub cols: usize,
    /// Grid rows.
    pub rows: usize,
    /// Pixels per grid step.
    pub stride: u32,
    /// World point per grid node, m (None: no depth).
    pub points_m: Vec<Option<DVec3>>,
    /// Unit normal per grid node, facing the camera (None: not estimable).
    pub normals: Vec<Option<DVec3>>,
    /// Depth along the optical axis per node, m (NaN: none).
    pub z_m: Vec<f64>,
}

impl PointGrid {
    /// Index of node (c, r).
    pub fn index(&self, c: usize, r: usize) -> usize {
        r * self.cols + c
    }

    /// The pixel centre of node (c, r).
    pub fn pixel(&self, c: usize, r: usize) -> (f64, f64) {
        let s = f64::from(self.stride);
        (
            c as f64 * s + 0.5 * (s - 1.0),
            r as f64 * s + 0.5 * (s - 1.0),
        )
    }

    /// Samples a depth map. `edge_rel`: neighbours further apart than this fraction of the
    /// depth do not enter a normal (a depth discontinuity).
    pub fn new(depth: &DepthMap, camera: &Camera, stride: u32, edge_rel: f64) -> PointGrid {
        let s = stride.max(1);
        let cols = (depth.width / s) as usize;
        let rows = (depth.height / s) as usize;
        let mut z_m = vec![f64::NAN; cols * rows];
        let mut block = Vec::with_capacity((s * s) as usize);
        for r in 0..rows {
            for c in 0..cols {
                block.clear();
                for dv in 0..s {
                    for du in 0..s {
                        if let Some(z) = depth.at(c as u32 * s + du, r as u32 * s + dv) {
                            block.push(z);
                        }
                    }
                }
                // a block straddling an edge or mostly empty gives no node
                if block.len() * 2 <= (s * s) as usize && s > 1 {
                    continue;
                }
                if block.is_empty() {
                    continue;
                }
                block.sort_by(f64::total_cmp);
                z_m[r * cols + c] = block[block.len() / 2];
            }
        }
        let mut g = PointGrid {
            cols,
            rows,
            stride: s,
            points_m: vec![None; cols * rows],
            normals: vec![None; cols * rows],
            z_m,
        };
        for r in 0..rows {
            for c in 0..cols {
                let i = g.index(c, r);
                let z = g.z_m[i];
                if z.is_finite() {
                    let (u, v) = g.pixel(c, r);
                    g.points_m[i] = back_project(camera, u, v, z);
                }
            }
        }
        // normals: cross product of the central differences (falling back to one side)
        let near = |g: &PointGrid, a: usize, b: usize| -> Option<DVec3> {
            let (pa, pb) = (g.points_m[a]?, g.points_m[b]?);
            ((g.z_m[a] - g.z_m[b]).abs() <= 2.0 * edge_rel * g.z_m[a]).then_some(pb - pa)
        };
        for r in 0..rows {
            for c in 0..cols {
                let i = g.index(c, r);
                let Some(p) = g.points_m[i] else { continue };
                let pick = |g: &PointGrid, cands: &[(i64, i64)]| -> Option<DVec3> {
                    let mut acc = DVec3::ZERO;
                    let mut n = 0;
                    for &(dc, dr) in cands {
                        let (cc, rr) = (c as i64 + dc, r as i64 + dr);
                        if cc < 0 || rr < 0 || cc >= cols as i64 || rr >= rows as i64 {
                            continue;
                        }
                        let j = g.index(cc as usize, rr as usize);
                        if let Some(d) = near(g, i, j) {
                            // orient every difference along +dc / +dr
                            acc += d * (dc + dr).signum() as f64;
                            n += 1;
                        }
                    }
                    (n > 0).then_some(acc)
                };
                let (Some(du), Some(dv)) =
                    (pick(&g, &[(1, 0), (-1, 0)]), pick(&g, &[(0, 1), (0, -1)]))
                else {
                    continue;
                };
                let n = du.cross(dv).normalize_or_zero();
                if n == DVec3::ZERO {
                    continue;
                }
                let to_cam = camera.position_m - p;
                g.normals[i] = Some(if n.dot(to_cam) < 0.0 { -n } else { n });
            }
        }
        g
    }
}
