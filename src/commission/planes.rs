//! Dominant planes in the point grid: RANSAC (seeded, deterministic) over the nodes not yet
//! explained, inliers by distance *and* normal agreement, then connected components on the grid
//! (so two desk tops at the same height are two planes), each refitted by least squares
//! (principal axes of its points).

use glam::DVec3;

use super::grid::PointGrid;
use crate::rng::SplitMix64;
use crate::scene::Camera;

/// Plane detection knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneOptions {
    /// Inlier distance: this plus [`PlaneOptions::dist_rel`] × depth, m.
    pub dist_m: f64,
    /// Depth-proportional part of the inlier distance (ToF range noise grows with depth).
    pub dist_rel: f64,
    /// Largest angle between a node's normal and the plane's, rad.
    pub max_normal_angle_rad: f64,
    /// Smallest plane, m².
    pub min_area_m2: f64,
    /// Most planes.
    pub max_planes: usize,
    /// RANSAC hypotheses per plane.
    pub iterations: usize,
    /// Seed.
    pub seed: u64,
}

impl Default for PlaneOptions {
    fn default() -> Self {
        Self {
            dist_m: 0.015,
            dist_rel: 0.01,
            max_normal_angle_rad: 20f64.to_radians(),
            min_area_m2: 0.04,
            max_planes: 40,
            iterations: 400,
            seed: 1,
        }
    }
}

/// One planar region.
#[derive(Debug, Clone)]
pub struct Plane {
    /// Unit normal, facing the camera.
    pub normal: DVec3,
    /// A point on the plane (the centroid of its nodes), m.
    pub origin_m: DVec3,
    /// Grid nodes on it.
    pub nodes: Vec<usize>,
    /// RMS distance of its nodes from it, m.
    pub rms_m: f64,
}

impl Plane {
    /// Signed distance of a point, m.
    pub fn distance_m(&self, p: DVec3) -> f64 {
        (p - self.origin_m).dot(self.normal)
    }

    /// True when its normal is within 10° of world up.
    pub fn is_horizontal(&self) -> bool {
        self.normal.z > 10f64.to_radians().cos()
    }
}

/// Principal-axes fit: centroid, unit normal (smallest axis), RMS distance.
pub fn fit(points: &[DVec3]) -> Option<(DVec3, DVec3, f64)> {
    if points.len() < 3 {
        return None;
    }
    let c = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for p in points {
        let d = *p - c;
        let v = nalgebra::Vector3::new(d.x, d.y, d.z);
        m += v * v.transpose();
    }
    let eig = m.symmetric_eigen();
    let (k, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let e = eig.eigenvectors.column(k);
    let n = DVec3::new(e[0], e[1], e[2]).normalize_or_zero();
    if n == DVec3::ZERO || !n.is_finite() {
        return None;
    }
    let rms =
        (points.iter().map(|p| (*p - c).dot(n).powi(2)).sum::<f64>() / points.len() as f64).sqrt();
    Some((c, n, rms))
}

/// Area a grid node stands for on a surface with normal `n` (its pixel footprint), m²: the
/// solid angle of its `stride × stride` pixel block (the lens's, [`Camera::pixel_solid_angle_sr`])
/// times the squared distance, tilted onto the surface.
pub fn node_area_m2(grid: &PointGrid, cam: &Camera, i: usize, p: DVec3, n: DVec3) -> f64 {
    let s = f64::from(grid.stride);
    let (u, v) = grid.pixel(i % grid.cols.max(1), i / grid.cols.max(1));
    let to_cam = cam.position_m - p;
    let dist2 = to_cam.length_squared();
    let cos = (to_cam.dot(n) / dist2.sqrt()).abs().max(0.2);
    s * s * cam.pixel_solid_angle_sr(u, v) * dist2 / cos
}

/// Finds the dominant planes seen by camera `cam`.
pub fn detect(grid: &PointGrid, cam: &Camera, o: &PlaneOptions) -> Vec<Plane> {
    let camera_m = cam.position_m;
    let n_nodes = grid.points_m.len();
    let mut free: Vec<bool> = (0..n_nodes)
        .map(|i| grid.points_m[i].is_some() && grid.normals[i].is_some())
        .collect();
    let cos_max = o.max_normal_angle_rad.cos();
    let mut rng = SplitMix64::new(o.seed);
    let mut planes = Vec::new();
    let tol = |i: usize| o.dist_m + o.dist_rel * grid.z_m[i];
    let is_inlier = |i: usize, c: DVec3, n: DVec3| -> bool {
        let (Some(p), Some(pn)) = (grid.points_m[i], grid.normals[i]) else {
            return false;
        };
        (p - c).dot(n).abs() <= tol(i) && pn.dot(n).abs() >= cos_max
    };
    let mut rejected_rounds = 0;
    while planes.len() < o.max_planes && rejected_rounds < 3 {
        let candidates: Vec<usize> = (0..n_nodes).filter(|&i| free[i]).collect();
        if candidates.len() < 10 {
            break;
        }
        let step = (candidates.len() / 4000).max(1);
        let mut best: Option<(usize, DVec3, DVec3)> = None;
        for _ in 0..o.iterations {
            // a node and its normal make a hypothesis (one sample, as the normals are good)
            let i = candidates[(rng.next_u64() % candidates.len() as u64) as usize];
            let (Some(p), Some(n)) = (grid.points_m[i], grid.normals[i]) else {
                continue;
            };
            let score = candidates
                .iter()
                .step_by(step)
                .filter(|&&j| is_inlier(j, p, n))
                .count();
            if best.is_none_or(|b| score > b.0) {
                best = Some((score, p, n));
            }
        }
        let Some((_, p, n)) = best else { break };
        // refine once on all inliers
        let inl: Vec<usize> = candidates
            .iter()
            .copied()
            .filter(|&j| is_inlier(j, p, n))
            .collect();
        let pts: Vec<DVec3> = inl.iter().filter_map(|&j| grid.points_m[j]).collect();
        let Some((c, mut nn, _)) = fit(&pts) else {
            break;
        };
        if nn.dot(camera_m - c) < 0.0 {
            nn = -nn;
        }
        let inl: Vec<usize> = candidates
            .iter()
            .copied()
            .filter(|&j| is_inlier(j, c, nn))
            .collect();
        // connected components (8-connected) of the inliers
        let mut mark = vec![false; n_nodes];
        for &j in &inl {
            mark[j] = true;
        }
        let mut found = false;
        for &seed in &inl {
            if !mark[seed] {
                continue;
            }
            let mut comp = vec![seed];
            mark[seed] = false;
            let mut k = 0;
            while k < comp.len() {
                let j = comp[k];
                k += 1;
                let (cc, rr) = ((j % grid.cols) as i64, (j / grid.cols) as i64);
                for dr in -1..=1 {
                    for dc in -1..=1 {
                        let (c2, r2) = (cc + dc, rr + dr);
                        if c2 < 0 || r2 < 0 || c2 >= grid.cols as i64 || r2 >= grid.rows as i64 {
                            continue;
                        }
                        let q = grid.index(c2 as usize, r2 as usize);
                        if mark[q] {
                            mark[q] = false;
                            comp.push(q);
                        }
                    }
                }
            }
            let area: f64 = comp
                .iter()
                .filter_map(|&j| Some(node_area_m2(grid, cam, j, grid.points_m[j]?, nn)))
                .sum();
            if area < o.min_area_m2 || comp.len() < 8 {
                continue;
            }
            let pts: Vec<DVec3> = comp.iter().filter_map(|&j| grid.points_m[j]).collect();
            let Some((c, mut n2, rms)) = fit(&pts) else {
                continue;
            };
            if n2.dot(camera_m - c) < 0.0 {
                n2 = -n2;
            }
            for &j in &comp {
                free[j] = false;
            }
            planes.push(Plane {
                normal: n2,
                origin_m: c,
                nodes: comp,
                rms_m: rms,
            });
            found = true;
        }
        if !found {
            rejected_rounds += 1;
        }
    }
    absorb(grid, &mut planes, &free, o, ABSORB_ROUNDS);
    planes
}

/// Rounds of `absorb`: how far (in grid nodes) a plane grows into the nodes around it.
pub const ABSORB_ROUNDS: usize = 3;
/// `absorb` fills holes: a node is taken when at least this many of its 8 neighbours are
/// on the plane (a plane's edge, with at most 3 or 4, does not grow onto what lies beside it).
pub const ABSORB_MIN_NEIGHBOURS: u32 = 5;
/// The loose normal test of `absorb`: a node's normal within this angle of the plane's, rad.
pub const ABSORB_NORMAL_ANGLE_RAD: f64 = 45.0 * core::f64::consts::PI / 180.0;

/// Grows each plane into the free nodes next to it that lie on it within the inlier distance,
/// whatever their normal, `rounds` times. A normal from neighbouring nodes a few centimetres
/// apart is noisy (ToF range noise of 1 % is 3 cm at a 3 m ceiling), so RANSAC's normal test
/// leaves scattered holes in a floor; each hole would become grid triangles and split the
/// plane's rectangles around it (on a 12 × 7 m open-plan zone, 1 200 of 2 700 triangles).
/// Distance alone keeps depth edges apart: a desk top 0.75 m above the floor is not on it.
fn absorb(grid: &PointGrid, planes: &mut [Plane], free: &[bool], o: &PlaneOptions, rounds: usize) {
    let n_nodes = grid.points_m.len();
    let mut owner: Vec<u32> = vec![u32::MAX; n_nodes];
    for (k, p) in planes.iter().enumerate() {
        for &j in &p.nodes {
            owner[j] = k as u32;
        }
    }
    let mut open: Vec<bool> = (0..n_nodes)
        .map(|i| free[i] && owner[i] == u32::MAX && grid.points_m[i].is_some())
        .collect();
    let cos_loose = ABSORB_NORMAL_ANGLE_RAD.cos();
    for _ in 0..rounds {
        let mut taken: Vec<(usize, u32)> = Vec::new();
        for i in (0..n_nodes).filter(|&i| open[i]) {
            let Some(p) = grid.points_m[i] else { continue };
            let tol = o.dist_m + o.dist_rel * grid.z_m[i];
            let (c, r) = ((i % grid.cols) as i64, (i / grid.cols) as i64);
            // the plane most of the 8 neighbours are on: a hole in it, not its edge
            let mut count: [(u32, u32); 8] = [(u32::MAX, 0); 8];
            for dr in -1..=1 {
                for dc in -1..=1 {
                    let (c2, r2) = (c + dc, r + dr);
                    if c2 < 0 || r2 < 0 || c2 >= grid.cols as i64 || r2 >= grid.rows as i64 {
                        continue;
                    }
                    let k = owner[grid.index(c2 as usize, r2 as usize)];
                    if k == u32::MAX {
                        continue;
                    }
                    if let Some(e) = count.iter_mut().find(|e| e.0 == k || e.0 == u32::MAX) {
                        e.0 = k;
                        e.1 += 1;
                    }
                }
            }
            let best = count
                .iter()
                .filter(|e| e.0 != u32::MAX && e.1 >= ABSORB_MIN_NEIGHBOURS)
                .find(|e| {
                    let pl = &planes[e.0 as usize];
                    pl.distance_m(p).abs() <= tol
                        && grid.normals[i].is_none_or(|n| n.dot(pl.normal).abs() >= cos_loose)
                })
                .map(|e| e.0);
            if let Some(k) = best {
                taken.push((i, k));
            }
        }
        if taken.is_empty() {
            break;
        }
        for (i, k) in taken {
            owner[i] = k;
            open[i] = false;
            planes[k as usize].nodes.push(i);
        }
    }
}
