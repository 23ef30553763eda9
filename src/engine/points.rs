//! Illuminance at arbitrary points (virtual sensors): the desk grids and the top-view map. Each
//! point gets what a sensor gets: exact direct light per luminaire and a gather row over the
//! patch exitances, so any dimming state follows by superposition.

use glam::DVec3;
use rayon::prelude::*;

use super::direct::{self, Receiver};
use super::raycast::{Hit, RayCaster};
use super::rayset::RaySet;
use super::{GatherWeighting, Model, gather_row};
use crate::lsc::AngularResponse;
use crate::scene::Scene;

/// Per-luminaire readings at a set of points (ideal cosine receivers).
#[derive(Debug, Clone)]
pub struct PointReadings {
    /// `[point][luminaire]` illuminance at 100 %, lx.
    pub per_luminaire_lx: Vec<Vec<f64>>,
}

impl PointReadings {
    /// Illuminance at each point for a dimming state (levels in luminaire order).
    pub fn lux(&self, levels: &[f64]) -> Vec<f64> {
        self.per_luminaire_lx
            .iter()
            .map(|r| r.iter().zip(levels).map(|(a, x)| a * x).sum())
            .collect()
    }
}

/// Evaluates points `(position, unit normal)` against a commissioned model of `scene`, with
/// `rays` gather rays and the model's opening samples.
pub fn evaluate(
    scene: &Scene,
    model: &Model,
    points: &[(DVec3, DVec3)],
    rays: usize,
) -> PointReadings {
    evaluate_with(scene, model, points, rays, &AngularResponse::Cosine)
}

/// [`evaluate`] for sensors of angular response `response` (a hooded ambient light sensor,
/// a luxmeter's LSC): `E = ∫ L s(θ) dω`, direct light weighted by `s(θ)`.
pub fn evaluate_with(
    scene: &Scene,
    model: &Model,
    points: &[(DVec3, DVec3)],
    rays: usize,
    response: &AngularResponse,
) -> PointReadings {
    let caster = RayCaster::new(&model.patches);
    let set = RaySet::new(model.settings.ray_set, rays);
    let openings: Vec<Vec<DVec3>> = scene
        .luminaires
        .iter()
        .map(|l| direct::centred_opening_points(l, model.settings.opening_samples))
        .collect();
    let receiver = match response {
        AngularResponse::Cosine => Receiver::Surface,
        r => Receiver::Sensor(r),
    };
    let per_luminaire_lx = points
        .par_iter()
        .map(|&(p, n)| {
            let row = gather_row(p, n, response, &caster, &set, GatherWeighting::Consistent);
            scene
                .luminaires
                .iter()
                .zip(&openings)
                .zip(&model.basis_b)
                .map(|((l, pts), b)| {
                    let d = direct::illuminance_lx(l, pts, p, n, receiver, &caster);
                    d + row.iter().map(|(j, w)| w * b[*j as usize]).sum::<f64>()
                })
                .collect()
        })
        .collect();
    PointReadings { per_luminaire_lx }
}

/// The first upward-facing surface below `(x, y)`, seen from above the scene: its point and
/// patch. Surfaces met from behind (a ceiling seen from above) are passed through.
pub fn surface_below(caster: &RayCaster, x: f64, y: f64, top_z: f64) -> Option<(DVec3, u32)> {
    let mut origin = DVec3::new(x, y, top_z);
    for _ in 0..16 {
        match caster.closest(origin, DVec3::NEG_Z) {
            Hit::Miss => return None,
            Hit::Front { patch, t_m } => return Some((origin + DVec3::NEG_Z * t_m, patch)),
            Hit::Back { t_m, .. } => origin += DVec3::NEG_Z * (t_m + caster.eps_m),
        }
    }
    None
}
