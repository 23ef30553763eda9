//! Stage "pose": each camera's pose in camera.json checked against what the camera sees, before
//! any meshing (issue 34: a position typed 100 m off built a 102 m room for minutes; a yaw
//! turned 180° moved the desks' values by up to 65 %, silently).
//!
//! Two checks per node, both against the declared room (luminaires.json), never against the
//! capture's ground truth:
//!
//! * **Height.** The depth puts the floor (the lowest large horizontal plane) at a height in
//!   the world frame that follows from camera.json's position. The luminaires hang from the
//!   ceiling the camera is mounted on: their median height above that floor must lie between
//!   [`MIN_LUMINAIRE_ABOVE_FLOOR_M`] (and [`MIN_LUMINAIRE_ABOVE_FLOOR_SHARE`] of the camera's
//!   own height above it) and [`MAX_LUMINAIRE_ABOVE_CAMERA_M`] above the camera. The floor
//!   must also lie within [`MAX_FLOOR_TO_LUMINAIRE_XY_M`] of some luminaire, horizontally.
//! * **Yaw.** On the horizontal surfaces the camera sees (floor, desk tops), luminaire `l`'s
//!   share of the light, `v_l / Σ_k v_k` per pixel (the reflectance cancels), is compared with
//!   the share the declared luminaires give by direct light (`I(dir) cos θ / d²`), over the same
//!   pixels: the centroids of both (weighted by the share squared, which picks the peak) must
//!   be within [`DISAGREE_M`] of each other. When most luminaires in view disagree, the pose is
//!   refused, with the rotation (90°, 180°, 270°, mirrored) about the camera's vertical under
//!   which most agree when there is one; a single luminaire that disagrees is a warning (a
//!   swapped id or DALI address).

use glam::{DMat3, DVec3};

use super::planes::Plane;
use super::{CommissionError, Inputs, Node, NodePlanes, Report};

/// A pose camera.json gives that disagrees with what the camera sees.
#[derive(Debug, thiserror::Error)]
pub enum PoseError {
    /// The luminaires are not where the ceiling is, seen from the floor the depth gives.
    #[error(
        "{node}camera.json position ({:.2}, {:.2}, {:.2}) m: the camera sees the floor \
         {camera_above_floor_m:.2} m below it, at z = {floor_z_m:.2} m, which puts the \
         luminaires (median z = {luminaires_z_m:.2} m in luminaires.json) {:.2} m above the floor \
         (expected {:.2}..{:.2} m: on the ceiling the camera is mounted on): camera.json's \
         position z should be within {:.2}..{:.2} m; a position typed wrong, in another unit \
         (mm?), or another room's camera.json?",
        position_m[0], position_m[1], position_m[2], luminaires_z_m - floor_z_m,
        expected_above_m[0], expected_above_m[1], expected_z_m[0], expected_z_m[1]
    )]
    Height {
        /// The capture set.
        node: Node,
        /// camera.json's position, m.
        position_m: [f64; 3],
        /// The camera's height above the seen floor (from the depth), m.
        camera_above_floor_m: f64,
        /// The seen floor's height in the world frame, m.
        floor_z_m: f64,
        /// The luminaires' median height, m.
        luminaires_z_m: f64,
        /// The range of the luminaires' height above the floor expected, m.
        expected_above_m: [f64; 2],
        /// The range of camera.json's z that would fit, m.
        expected_z_m: [f64; 2],
    },
    /// The floor the camera sees is far from every luminaire, horizontally.
    #[error(
        "{node}camera.json position ({:.2}, {:.2}, {:.2}) m: the floor the camera sees spans \
         x {:.1}..{:.1} m, y {:.1}..{:.1} m, {nearest_m:.1} m from the nearest luminaire in \
         luminaires.json (at most {MAX_FLOOR_TO_LUMINAIRE_XY_M} m expected): a position typed \
         wrong, in another unit, or another room's camera.json?",
        position_m[0], position_m[1], position_m[2], floor_xy_m[0], floor_xy_m[2],
        floor_xy_m[1], floor_xy_m[3]
    )]
    FarFromLuminaires {
        /// The capture set.
        node: Node,
        /// camera.json's position, m.
        position_m: [f64; 3],
        /// The seen floor's extent `[x0, y0, x1, y1]`, m.
        floor_xy_m: [f64; 4],
        /// The nearest luminaire's horizontal distance from it, m.
        nearest_m: f64,
    },
    /// Where one luminaire's light dominates in the frames, the declared luminaires seen from
    /// camera.json's pose mostly put another one.
    #[error(
        "{node}camera.json position ({:.2}, {:.2}, {:.2}) m: the one-luminaire frames' light \
         does not fall where luminaires.json and camera.json put it: at {counted} seen points \
         where one luminaire clearly gives the most light, the declared luminaires agree on \
         which at only {:.0} % (at least {:.0} % expected; a genuine pose gives over 90 %): \
         camera.json's position or rotation typed wrong, or luminaires.json's positions?",
        position_m[0], position_m[1], position_m[2], 100.0 * agreement,
        100.0 * MIN_DOMINANT_AGREEMENT
    )]
    Misplaced {
        /// The capture set.
        node: Node,
        /// camera.json's position, m.
        position_m: [f64; 3],
        /// The share of points where the same luminaire dominates.
        agreement: f64,
        /// Points counted.
        counted: usize,
    },
    /// Most luminaires' light is not under them: the camera's rotation is wrong.
    #[error(
        "{node}the camera's yaw/rotation in camera.json looks wrong{}: {disagree} of the \
         {in_view} luminaires in view light the floor away from where luminaires.json puts \
         them (luminaire {}'s light is centred {:.1} m from it; at most {DISAGREE_M} m \
         expected); check R_world_from_camera (look, up, right), or the luminaires' ids",
        rotation.map_or(String::new(), |(deg, mirrored)| format!(
            " by about {deg}°{}",
            if mirrored { ", mirrored" } else { "" }
        )),
        worst.0, worst.1
    )]
    Yaw {
        /// The capture set.
        node: Node,
        /// Luminaires in view whose light is not under them.
        disagree: usize,
        /// Luminaires in view.
        in_view: usize,
        /// The worst: (id, offset m).
        worst: (u32, f64),
        /// The rotation about the camera's vertical (degrees, mirrored) under which most agree.
        rotation: Option<(u32, bool)>,
    },
}
use crate::camera::capture::{Capture, SATURATED};
use crate::scene::{Camera, Luminaire};

/// The luminaires' median height above the seen floor must be at least this, m (no room's
/// luminaires hang lower than a metre above its floor; a floor lamp is not a luminaire of the
/// model's ceiling).
pub const MIN_LUMINAIRE_ABOVE_FLOOR_M: f64 = 1.0;
/// ... and at least this share of the camera's height above the seen floor (the camera is on
/// the ceiling; luminaires in the lower 30 % of the room are pendants no office has).
pub const MIN_LUMINAIRE_ABOVE_FLOOR_SHARE: f64 = 0.3;
/// The luminaires' median height at most this above the camera's optical centre, m (recessed
/// in a coffer or a higher bay of the ceiling the camera is mounted on).
pub const MAX_LUMINAIRE_ABOVE_CAMERA_M: f64 = 1.0;
/// The nearest luminaire at most this far, horizontally, from the floor the camera sees, m
/// (ceiling luminaires are spaced at most about 1.5 mounting heights apart, a few metres; the
/// camera's frames show their light, so one is near what it sees).
pub const MAX_FLOOR_TO_LUMINAIRE_XY_M: f64 = 10.0;
/// A luminaire whose measured light centroid is farther than this from the declared one
/// disagrees, m. Measured on office_a (docs/field.md): the genuine captures (`capture`,
/// `capture_clean`) at most 0.18 m (indirect light flattens the measured share, which pulls its
/// centroid toward the view's centre); two luminaires 1.8 m apart with their frames swapped
/// 1.47 m each; a 180° yaw all 8 beyond 1.2 m, up to 3.6 m (twice each luminaire's distance
/// from the camera's nadir, flattened). Office luminaires are spaced 1.5 m and more, so 1 m is five times the
/// genuine error and below what a swap of neighbours gives.
pub const DISAGREE_M: f64 = 1.0;
/// Intensity look-ups of one node's yaw check at most (samples × luminaires × 8 rotations and
/// mirrors): the samples are thinned to keep it, whatever the number of luminaires.
const MAX_LOOKUPS: usize = 4_000_000;
/// A luminaire clearly gives the most light at a point when its share exceeds the next one's
/// by this.
const DOMINANT_MARGIN: f64 = 0.05;
/// The dominance check refuses a pose below this agreement. Measured on office_a
/// (docs/field.md): the genuine captures 0.97; camera.json's position 1.5 m off 0.41-0.71, 3 m
/// off 0.29-0.49, 5 m off 0.12-0.28, 8-12 m off (where no luminaire's nadir is in view, so the
/// yaw check has no vote) 0-0.11; its yaw 30° off 0.62, 45° off 0.16.
pub const MIN_DOMINANT_AGREEMENT: f64 = 0.5;
/// ... and warns below this.
pub const WARN_DOMINANT_AGREEMENT: f64 = 0.8;
/// Pixels on horizontal surfaces needed for the yaw check.
const MIN_SAMPLES: usize = 100;

/// What the pose check measured for one node.
#[derive(Debug, Clone, Default)]
pub struct NodePose {
    /// The seen floor's height in the world frame, m (None: no floor plane found).
    pub floor_z_m: Option<f64>,
    /// The luminaires' median height above it, m.
    pub luminaires_above_floor_m: Option<f64>,
    /// Per luminaire in view: (id, distance of its measured light centroid from the declared
    /// one, m).
    pub offsets_m: Vec<(u32, f64)>,
    /// Of the seen horizontal samples where one luminaire clearly gives the most light, both
    /// measured and predicted, the share where it is the same luminaire (None: too few).
    pub dominant_agreement: Option<f64>,
}

/// A rotation (and mirror) about the camera's vertical: what camera.json may have wrong.
#[derive(Debug, Clone, Copy)]
struct Hypothesis {
    yaw_deg: u32,
    mirrored: bool,
}

/// Samples of one node: world points on seen horizontal surfaces, each luminaire's measured
/// share of the light there.
struct Samples {
    points_m: Vec<DVec3>,
    /// Per sample, per luminaire.
    shares: Vec<Vec<f64>>,
}

/// Stage "pose": every node's camera pose against the floor it sees and the light of each
/// luminaire on it. Refuses a pose that disagrees; warns of a single luminaire that does.
pub(super) fn check(
    i: &Inputs,
    planes: &NodePlanes,
    report: &mut Report,
) -> Result<(), CommissionError> {
    for (n, capture) in i.captures.iter().enumerate() {
        let node = Node((i.captures.len() > 1).then(|| (n + 1, capture.dir.clone())));
        let floor = node_floor(&planes.found[n]);
        let mut pose = NodePose::default();
        if let Some(f) = floor {
            let above = check_height(&node, &capture.camera, f, i.luminaires).map_err(Box::new)?;
            pose.floor_z_m = Some(f.origin_m.z);
            pose.luminaires_above_floor_m = Some(above);
            check_floor_xy(&node, planes, n, f, i.luminaires, &capture.camera).map_err(Box::new)?;
        }
        let samples = samples(capture, planes, n, i.luminaires.len());
        if samples.points_m.len() >= MIN_SAMPLES {
            pose.offsets_m =
                check_yaw(&node, capture, i.luminaires, &samples, report).map_err(Box::new)?;
            pose.dominant_agreement =
                check_dominant(&node, capture, i.luminaires, &samples, report).map_err(Box::new)?;
        }
        report.pose.push(pose);
    }
    Ok(())
}

/// A node's floor: its lowest large horizontal plane (as the mesh stage's).
fn node_floor(found: &[Plane]) -> Option<&Plane> {
    found
        .iter()
        .filter(|p| p.is_horizontal() && p.nodes.len() >= 100)
        .min_by(|a, b| a.origin_m.z.total_cmp(&b.origin_m.z))
}

/// The median of `v` (0 for none).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The luminaires' median height above the seen floor, checked: returns it.
fn check_height(
    node: &Node,
    cam: &Camera,
    floor: &Plane,
    luminaires: &[Luminaire],
) -> Result<f64, PoseError> {
    let floor_z_m = floor.origin_m.z;
    let camera_above_floor_m = cam.position_m.z - floor_z_m;
    let lum_z_m = median(luminaires.iter().map(|l| l.position_m.z).collect());
    let above_m = lum_z_m - floor_z_m;
    let lo_m =
        MIN_LUMINAIRE_ABOVE_FLOOR_M.max(MIN_LUMINAIRE_ABOVE_FLOOR_SHARE * camera_above_floor_m);
    let hi_m = camera_above_floor_m + MAX_LUMINAIRE_ABOVE_CAMERA_M;
    if (lo_m..=hi_m).contains(&above_m) {
        return Ok(above_m);
    }
    // camera z for which the luminaires would be within [lo, hi] above the floor (the depth,
    // hence the camera's height above the floor, fixed)
    let (z_lo_m, z_hi_m) = (
        lum_z_m + camera_above_floor_m - hi_m,
        lum_z_m + camera_above_floor_m - lo_m,
    );
    Err(PoseError::Height {
        node: node.clone(),
        position_m: cam.position_m.to_array(),
        camera_above_floor_m,
        floor_z_m,
        luminaires_z_m: lum_z_m,
        expected_above_m: [lo_m, hi_m],
        expected_z_m: [z_lo_m, z_hi_m],
    })
}

/// The nearest luminaire within [`MAX_FLOOR_TO_LUMINAIRE_XY_M`] of the seen floor's extent.
fn check_floor_xy(
    node: &Node,
    planes: &NodePlanes,
    n: usize,
    floor: &Plane,
    luminaires: &[Luminaire],
    cam: &Camera,
) -> Result<(), PoseError> {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in floor
        .nodes
        .iter()
        .filter_map(|&g| planes.grids[n].points_m[g])
    {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let nearest_m = luminaires
        .iter()
        .map(|l| {
            let p = l.position_m;
            let dx = (lo.x - p.x).max(p.x - hi.x).max(0.0);
            let dy = (lo.y - p.y).max(p.y - hi.y).max(0.0);
            dx.hypot(dy)
        })
        .fold(f64::INFINITY, f64::min);
    if nearest_m <= MAX_FLOOR_TO_LUMINAIRE_XY_M {
        return Ok(());
    }
    Err(PoseError::FarFromLuminaires {
        node: node.clone(),
        position_m: cam.position_m.to_array(),
        floor_xy_m: [lo.x, lo.y, hi.x, hi.y],
        nearest_m,
    })
}

/// The node's samples on seen horizontal surfaces facing up (at most a bounded number, evenly
/// picked), with each luminaire's measured share of the light.
fn samples(capture: &Capture, planes: &NodePlanes, n: usize, luminaires: usize) -> Samples {
    let grid = &planes.grids[n];
    let nodes: Vec<usize> = planes.found[n]
        .iter()
        .filter(|p| p.is_horizontal() && p.origin_m.z < capture.camera.position_m.z - 0.3)
        .flat_map(|p| p.nodes.iter().copied())
        .collect();
    let most = (MAX_LOOKUPS / (8 * luminaires.max(1))).max(MIN_SAMPLES);
    let step = nodes.len().div_ceil(most).max(1);
    let width = capture.camera.width as usize;
    let mut out = Samples {
        points_m: Vec::new(),
        shares: Vec::new(),
    };
    for &g in nodes.iter().step_by(step) {
        let Some(p) = grid.points_m[g] else {
            continue;
        };
        let (u, v) = grid.pixel(g % grid.cols.max(1), g / grid.cols.max(1));
        let pixel = v.round() as usize * width + u.round() as usize;
        let mut light = Vec::with_capacity(luminaires);
        for (k, (_, frame)) in capture.luminance.iter().enumerate() {
            match frame.data.get(pixel) {
                Some(&x) if x != SATURATED => {
                    let day = capture.daylight_value(k, pixel).unwrap_or(0.0);
                    light.push((f64::from(x) - day).max(0.0));
                }
                _ => break,
            }
        }
        let total: f64 = light.iter().sum();
        if light.len() == luminaires && total > 0.0 {
            out.points_m.push(p);
            out.shares.push(light.iter().map(|x| x / total).collect());
        }
    }
    out
}

/// The direct-light share of each luminaire at `p` (up-facing surface).
fn predicted_shares(luminaires: &[Luminaire], p: DVec3) -> Vec<f64> {
    let e: Vec<f64> = luminaires
        .iter()
        .map(|l| {
            let d = p - l.position_m;
            let r2 = d.length_squared();
            if r2 < 1e-6 {
                return 0.0;
            }
            let dir = d / r2.sqrt();
            (l.intensity_toward_cd(dir) * (-dir.z).max(0.0) / r2).max(0.0)
        })
        .collect();
    let total: f64 = e.iter().sum();
    if total > 0.0 {
        e.iter().map(|x| x / total).collect()
    } else {
        e
    }
}

/// Per luminaire, the distance between the measured and the predicted light centroids (xy)
/// with the samples moved by `m` about the camera (the pose hypothesis), m.
fn offsets_m(luminaires: &[Luminaire], samples: &Samples, camera_m: DVec3, m: DMat3) -> Vec<f64> {
    let l = luminaires.len();
    let (mut meas, mut pred) = (vec![(DVec3::ZERO, 0.0); l], vec![(DVec3::ZERO, 0.0); l]);
    for (p, s) in samples.points_m.iter().zip(&samples.shares) {
        let q = camera_m + m * (*p - camera_m);
        let e = predicted_shares(luminaires, q);
        for k in 0..l {
            let (wm, wp) = (s[k] * s[k], e[k] * e[k]);
            meas[k].0 += wm * q;
            meas[k].1 += wm;
            pred[k].0 += wp * q;
            pred[k].1 += wp;
        }
    }
    meas.iter()
        .zip(&pred)
        .map(|(a, b)| {
            if a.1 > 0.0 && b.1 > 0.0 {
                (a.0 / a.1 - b.0 / b.1).truncate().length()
            } else {
                0.0
            }
        })
        .collect()
}

/// The dominance check: where one luminaire clearly gives the most light in the frames, the
/// declared luminaires' direct light must say the same one at most seen points. Returns the
/// agreement (None: too few points to tell).
fn check_dominant(
    node: &Node,
    capture: &Capture,
    luminaires: &[Luminaire],
    samples: &Samples,
    report: &mut Report,
) -> Result<Option<f64>, PoseError> {
    let (agree, counted) = dominant_agreement(luminaires, samples);
    if counted < MIN_SAMPLES {
        return Ok(None);
    }
    if agree < MIN_DOMINANT_AGREEMENT {
        return Err(PoseError::Misplaced {
            node: node.clone(),
            position_m: capture.camera.position_m.to_array(),
            agreement: agree,
            counted,
        });
    }
    if agree < WARN_DOMINANT_AGREEMENT {
        report.warnings.push(format!(
            "{node}the declared luminaires give the most light where the frames show it at only              {:.0} % of {counted} seen points (a genuine pose: above {:.0} %): check camera.json's              position and rotation and luminaires.json's positions",
            100.0 * agree,
            100.0 * WARN_DOMINANT_AGREEMENT
        ));
    }
    Ok(Some(agree))
}

/// Of the samples where one luminaire clearly gives the most light (by a share margin of
/// [`DOMINANT_MARGIN`] over the next), both in the frames and by the declared luminaires'
/// direct light, the fraction where it is the same one, and how many were counted.
fn dominant_agreement(luminaires: &[Luminaire], samples: &Samples) -> (f64, usize) {
    let winner = |s: &[f64]| -> Option<usize> {
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by(|&a, &b| s[b].total_cmp(&s[a]));
        match order.as_slice() {
            [a] => Some(*a),
            [a, b, ..] if s[*a] - s[*b] >= DOMINANT_MARGIN => Some(*a),
            _ => None,
        }
    };
    let (mut same, mut counted) = (0usize, 0usize);
    for (p, s) in samples.points_m.iter().zip(&samples.shares) {
        let e = predicted_shares(luminaires, *p);
        if let (Some(a), Some(b)) = (winner(s), winner(&e)) {
            counted += 1;
            same += usize::from(a == b);
        }
    }
    (same as f64 / counted.max(1) as f64, counted)
}

/// The hypothesis' move of world points about the camera: a mirror of the image's x axis (in
/// the world), then a rotation about the vertical.
fn hypothesis_matrix(cam: &Camera, h: Hypothesis) -> DMat3 {
    let rot = DMat3::from_rotation_z(f64::from(h.yaw_deg).to_radians());
    let r = cam.world_from_camera;
    let mirror = if h.mirrored {
        r * DMat3::from_diagonal(DVec3::new(-1.0, 1.0, 1.0)) * r.transpose()
    } else {
        DMat3::IDENTITY
    };
    rot * mirror
}

/// Luminaires in view: their nadir on the floor projects into the image.
fn in_view(cam: &Camera, luminaires: &[Luminaire], samples: &Samples) -> Vec<bool> {
    let floor_z_m = samples
        .points_m
        .iter()
        .map(|p| p.z)
        .fold(f64::INFINITY, f64::min);
    luminaires
        .iter()
        .map(|l| {
            cam.pixel_of(DVec3::new(l.position_m.x, l.position_m.y, floor_z_m))
                .is_some()
        })
        .collect()
}

/// The yaw check: per luminaire in view, its measured light against the declared luminaire's.
/// Returns (id, offset) per luminaire in view.
fn check_yaw(
    node: &Node,
    capture: &Capture,
    luminaires: &[Luminaire],
    samples: &Samples,
    report: &mut Report,
) -> Result<Vec<(u32, f64)>, PoseError> {
    let cam = &capture.camera;
    let view = in_view(cam, luminaires, samples);
    let voters = view.iter().filter(|&&v| v).count();
    let disagree = |off: &[f64]| {
        off.iter()
            .zip(&view)
            .filter(|&(d, &v)| v && *d > DISAGREE_M)
            .count()
    };
    let as_declared = offsets_m(luminaires, samples, cam.position_m, DMat3::IDENTITY);
    let seen: Vec<(u32, f64)> = luminaires
        .iter()
        .zip(&as_declared)
        .zip(&view)
        .filter(|&(_, &v)| v)
        .map(|((l, &d), _)| (l.id, d))
        .collect();
    let wrong = disagree(&as_declared);
    if voters >= 2 && 2 * wrong > voters {
        let best = [false, true]
            .into_iter()
            .flat_map(|mirrored| [0, 90, 180, 270].map(|yaw_deg| Hypothesis { yaw_deg, mirrored }))
            .skip(1)
            .map(|h| {
                let off = offsets_m(
                    luminaires,
                    samples,
                    cam.position_m,
                    hypothesis_matrix(cam, h),
                );
                (h, disagree(&off))
            })
            .min_by_key(|&(_, w)| w)
            .filter(|&(_, w)| 2 * w < voters && w < wrong);
        return Err(PoseError::Yaw {
            node: node.clone(),
            disagree: wrong,
            in_view: voters,
            worst: seen
                .iter()
                .copied()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, 0.0)),
            rotation: best.map(|(h, _)| (h.yaw_deg, h.mirrored)),
        });
    }
    for &(id, d) in seen.iter().filter(|&&(_, d)| d > DISAGREE_M) {
        report.warnings.push(format!(
            "{node}luminaire {id}: its light on the floor the camera sees is centred {d:.1} m \
             from where luminaires.json puts it (at most {DISAGREE_M} m expected): a swapped \
             luminaire id or DALI address?"
        ));
    }
    Ok(seen)
}

/// The stages up to "pose" alone (depth, planes, pose) on capture sets: what the pose check
/// measured per node, with its warnings, or why it refused. For tests and diagnostics; the
/// commissioning runs the same stage ([`super::from_captures`]).
pub fn check_captures(
    captures: &[Capture],
    luminaires: &[Luminaire],
    o: &super::CommissionOptions,
) -> Result<Report, CommissionError> {
    let i = Inputs {
        captures,
        luminaires,
        sensors: &[],
        desks: None,
        o,
        progress: super::Progress::new(false, 0),
    };
    super::check_captures(&i)?;
    let depths = super::fuse_depths(&i)?;
    let planes = super::find_planes(&i, &depths);
    let mut report = Report::default();
    check(&i, &planes, &mut report)?;
    Ok(report)
}
