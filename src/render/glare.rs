//! UGR at the room's observers ([`super::ugr`] for the formula): one seated observer per desk,
//! with the luminaires' luminance from their stored photometry and the background luminance
//! from the model's interreflection.
//!
//! **Observer convention.** The eye is [`EYE_HEIGHT_SEATED_M`] above the floor (EN 12464-1 /
//! CIE 117 seated), [`EYE_SETBACK_M`] out from the middle of one of the desk's long edges,
//! looking horizontally across the desk (perpendicular to that edge). The edge is the one no
//! other desk adjoins (a chair fits there) whose eye lies inside the room, the one whose eye is
//! nearer the room's centre when both qualify.
//!
//! **Background luminance.** `L_b = E_ind / π`, `E_ind` the indirect illuminance at the eye on
//! the vertical plane facing the line of sight: the light the room's surfaces reflect, gathered
//! from the solved patch exitances with the report's air rays (the luminaires' direct light left
//! out), in the design state, new installation (CIE 117 rates initial values; since `L² / L_b`
//! scales with the maintenance factor, maintained values would lower every UGR by
//! `8 log10(1/MF)`, 0.78 for MF 0.8).
//!
//! **Luminaires.** Each luminaire's intensity toward the eye from its stored photometry at its
//! design level; its opening (flat, the size from the luminaires file or the photometry file)
//! with the fraction of [`VISIBILITY_POINTS`] opening points the eye sees unobstructed scaling ω.

use glam::DVec3;
use serde::Serialize;

use super::ugr::{self, Observer, Opening, Term, UgrError};
use crate::en12464::Rect;
use crate::engine::dense::DenseField;
use crate::engine::direct::centred_opening_points;
use crate::image_geometry::Room;
use crate::scene::Luminaire;

/// Height of a seated observer's eye above the floor, m.
pub const EYE_HEIGHT_SEATED_M: f64 = 1.2;

/// Distance of the eye from the desk's edge, m.
pub const EYE_SETBACK_M: f64 = 0.5;

/// Points over each opening tested for visibility from the eye.
pub const VISIBILITY_POINTS: usize = 16;

/// The convention, as the report states it.
pub const CONVENTION: &str = "one seated observer per desk: eye 1.2 m above the floor, 0.5 m out from the middle of the desk's free long edge (no other desk adjoins it; the one nearer the room's centre when both are free), looking horizontally across the desk; L_b = E_ind/π with E_ind the indirect vertical illuminance at the eye facing the line of sight (model interreflection, design state, new installation); luminance from each luminaire's photometry toward the eye over its flat luminous opening; Guth index by the Luckiesh-Guth closed form";

/// One observer's UGR.
#[derive(Debug, Clone, Serialize)]
pub struct ObserverUgr {
    /// The desk it sits at.
    pub desk: u32,
    /// Eye, m.
    pub eye_m: [f64; 3],
    /// Line of sight (unit).
    pub sight: [f64; 3],
    /// Indirect vertical illuminance at the eye, lx.
    pub e_ind_lx: f64,
    /// Background luminance `E_ind / π`, cd/m².
    pub l_b_cd_per_m2: f64,
    /// UGR; null when not computed or when no luminaire is in view.
    pub ugr: Option<f64>,
    /// Why it was not computed (null when it was, or when no luminaire is in view).
    pub not_computed: Option<String>,
    /// The luminaires in view.
    pub terms: Vec<Term>,
}

/// UGR of the room.
#[derive(Debug, Clone, Serialize)]
pub struct UgrResult {
    /// How the observers were placed and what was computed.
    pub convention: &'static str,
    /// `UGR_L`.
    pub limit: f64,
    /// Per observer.
    pub observers: Vec<ObserverUgr>,
    /// The room's maximum over the observers computed, and its desk.
    pub max: Option<(f64, u32)>,
    /// Every observer computed and the maximum (to one decimal) at most the limit.
    pub pass: bool,
}

/// The seated observer at a desk (see the module's convention).
pub fn seat(desk: &Rect, others: &[Rect], room: &Rect, floor_z_m: f64) -> Observer {
    let (cx, cy) = (
        0.5 * (desk.x_m[0] + desk.x_m[1]),
        0.5 * (desk.y_m[0] + desk.y_m[1]),
    );
    // the long edges' midpoints and outward normals
    let edges = if desk.width_m() >= desk.depth_m() {
        [
            (DVec3::new(cx, desk.y_m[0], 0.0), DVec3::NEG_Y),
            (DVec3::new(cx, desk.y_m[1], 0.0), DVec3::Y),
        ]
    } else {
        [
            (DVec3::new(desk.x_m[0], cy, 0.0), DVec3::NEG_X),
            (DVec3::new(desk.x_m[1], cy, 0.0), DVec3::X),
        ]
    };
    let centre = DVec3::new(
        0.5 * (room.x_m[0] + room.x_m[1]),
        0.5 * (room.y_m[0] + room.y_m[1]),
        0.0,
    );
    let score = |(m, n): &(DVec3, DVec3)| {
        let probe = *m + *n * 0.1;
        let eye = *m + *n * EYE_SETBACK_M;
        let free =
            !others.iter().any(|r| r.contains(probe.x, probe.y)) && room.contains(eye.x, eye.y);
        (if free { 0.0 } else { 1e6 }) + eye.distance(centre)
    };
    let (m, n) = if score(&edges[0]) <= score(&edges[1]) {
        edges[0]
    } else {
        edges[1]
    };
    let eye = m + n * EYE_SETBACK_M;
    Observer {
        eye_m: DVec3::new(eye.x, eye.y, floor_z_m + EYE_HEIGHT_SEATED_M),
        sight: -n,
    }
}

/// The opening of a luminaire for UGR.
pub fn opening(l: &Luminaire) -> Opening {
    Opening::new(l.id, l.position_m, l.aim, l.opening_m, l.opening_circular)
}

/// Each luminaire's term at an observer, at its level (`Err` on the first bad luminaire).
pub fn terms(
    field: &DenseField<'_>,
    luminaires: &[Luminaire],
    levels: &[f64],
    obs: &Observer,
) -> Result<Vec<Term>, UgrError> {
    let mut out = Vec::new();
    for (l, level) in luminaires.iter().zip(levels) {
        let o = opening(l);
        let to_eye = (obs.eye_m - l.position_m).normalize_or_zero();
        let i_cd = l.intensity_toward_cd(to_eye) * level;
        let pts = centred_opening_points(l, VISIBILITY_POINTS);
        let seen = pts
            .iter()
            .filter(|q| field.caster().unoccluded(obs.eye_m, **q))
            .count();
        let visible = seen as f64 / pts.len().max(1) as f64;
        if let Some(t) = ugr::term(obs, &o, i_cd, visible)? {
            out.push(t);
        }
    }
    Ok(out)
}

/// The UGR of one observer, `e_ind_lx` the indirect vertical illuminance at its eye.
pub fn observer_ugr(
    desk: u32,
    obs: &Observer,
    e_ind_lx: f64,
    terms: Result<Vec<Term>, UgrError>,
) -> ObserverUgr {
    let l_b = e_ind_lx / std::f64::consts::PI;
    let (value, why, terms) = match terms.and_then(|t| ugr::ugr(l_b, &t).map(|u| (u, t))) {
        Ok((u, t)) => (u, None, t),
        Err(e) => (None, Some(e.to_string()), Vec::new()),
    };
    ObserverUgr {
        desk,
        eye_m: obs.eye_m.to_array(),
        sight: obs.sight.to_array(),
        e_ind_lx,
        l_b_cd_per_m2: l_b,
        ugr: value,
        not_computed: why,
        terms,
    }
}

/// The room's UGR: an observer per desk of `room`, in the state `levels`; `room_rect` the
/// floor's rectangle at height `floor_z_m`; `rays` gather rays for the background.
pub fn room_ugr(
    field: &DenseField<'_>,
    room: &Room,
    room_rect: &Rect,
    floor_z_m: f64,
    levels: &[f64],
    rays: usize,
) -> UgrResult {
    let rects: Vec<Rect> = room
        .desks
        .iter()
        .map(|d| Rect {
            x_m: d.x_m,
            y_m: d.y_m,
        })
        .collect();
    let observers: Vec<(u32, Observer)> = room
        .desks
        .iter()
        .zip(&rects)
        .enumerate()
        .map(|(k, (d, r))| {
            let others: Vec<Rect> = (0..rects.len())
                .filter(|j| *j != k)
                .map(|j| rects[j])
                .collect();
            (d.id, seat(r, &others, room_rect, floor_z_m))
        })
        .collect();
    let eyes: Vec<(DVec3, DVec3)> = observers.iter().map(|(_, o)| (o.eye_m, o.sight)).collect();
    let readings = field.air_points(&eyes, &room.basis_b, rays);
    let l = readings.luminaires.max(1);
    let observers: Vec<ObserverUgr> = observers
        .iter()
        .zip(readings.indirect_lx.chunks(l))
        .map(|((id, obs), ind)| {
            let e_ind: f64 = ind.iter().zip(levels).map(|(e, x)| e * x).sum();
            observer_ugr(*id, obs, e_ind, terms(field, &room.luminaires, levels, obs))
        })
        .collect();
    summarise(observers)
}

/// The maximum and the verdict over the observers.
pub fn summarise(observers: Vec<ObserverUgr>) -> UgrResult {
    let max = observers
        .iter()
        .filter_map(|o| o.ugr.map(|u| (u, o.desk)))
        .fold(None, |m: Option<(f64, u32)>, (u, d)| match m {
            Some((v, _)) if v >= u => m,
            _ => Some((u, d)),
        });
    let limit = ugr::UGR_L_OFFICE;
    let pass = !observers.is_empty()
        && observers.iter().all(|o| o.not_computed.is_none())
        && max.is_none_or(|(u, _)| (u * 10.0).round() / 10.0 <= limit);
    UgrResult {
        convention: CONVENTION,
        limit,
        observers,
        max,
        pass,
    }
}
