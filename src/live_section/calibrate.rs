//! Commissioning's last stage: the model's response at each desk a camera sees, checked against
//! the one-luminaire frames and calibrated where they show a shade the mesh lost (issue 28
//! item 5; the rule is [`crate::live::desk_scale`]).
//!
//! Each node measures the desks it sees; a desk seen by several nodes is calibrated by the one
//! whose window holds the most pixels, and the result goes into every node's model (the nodes'
//! images then agree on the desk). The desk's image flag [`sensor_flags::CALIBRATED`] says
//! which desks were calibrated, and [`DeskCalibration`] what was done, for the engineer.

use super::{PixelHit, SectionOptions, calibrated_response, cast_all, window_pixels};
use crate::camera::capture::Capture;
use crate::commission::Commissioned;
use crate::engine::raycast::RayCaster;
use crate::live::LiveError;
use crate::live::desk_scale::{self, Calibrated};
use crate::store::sensor_flags;

/// What the camera showed at one desk and what was done.
#[derive(Debug, Clone, PartialEq)]
pub struct DeskCalibration {
    /// The desk sensor's id.
    pub sensor_id: u32,
    /// The node (index of its capture) that measured it.
    pub node: usize,
    /// The camera's scale there against the model (a reflectance error under the window when
    /// far from 1; the measurement at the desk is divided by it).
    pub scale: f64,
    /// The luminaires (ids) whose light at the desk now comes from the camera.
    pub replaced_luminaire_ids: Vec<u32>,
    /// The factor every luminaire's light took toward the camera's scale (1: the model's scale
    /// stands; [`desk_scale::weigh_scale`]).
    pub scaled: f64,
    /// The model's light with every luminaire at 100 % before and after, lx.
    pub model_all_on_lx: f64,
    /// See [`Self::model_all_on_lx`].
    pub calibrated_all_on_lx: f64,
    /// The desk top's reflectance in that node's view: its own estimate, and the desks' common
    /// one when it took it ([`super::desk_rho`]); `None` when the sensor stands on no furniture.
    pub desk_rho: Option<super::desk_rho::DeskRho>,
}

/// Each sensor's camera-measured response per luminaire at 100 % in one node's view, with the
/// number of window pixels it rests on (empty out of view).
pub(crate) fn camera_rows(
    c: &Commissioned,
    capture: &Capture,
    o: &SectionOptions,
) -> Result<Vec<(usize, Vec<f64>)>, LiveError> {
    let (camera, gain) = super::camera_and_gain(c)?;
    let model = &c.model;
    if capture.luminance.len() != model.luminaires() {
        return Err(LiveError::Input(
            "the capture's frames do not match the luminaires".into(),
        ));
    }
    let caster = RayCaster::new(&model.patches);
    let hits: Vec<Option<PixelHit>> = cast_all(camera, model, &caster, o.min_rho);
    let window_px: Vec<Vec<(u32, f64, f64)>> = c
        .scene
        .sensors
        .iter()
        .zip(&c.sensor_flags)
        .map(|(s, f)| {
            if f & sensor_flags::OUT_OF_VIEW != 0 {
                Vec::new()
            } else {
                window_pixels(camera, Some(&c.depth), &hits, model, s, o)
            }
        })
        .collect();
    let rho = &model.patches.rho;
    let rows = calibrated_response(
        &window_px,
        |l, px| {
            let patch = hits.get(px as usize).copied().flatten()?.patch as usize;
            capture
                .luminaire_value(l, px as usize)
                .map(|v| std::f64::consts::PI * gain * v / rho[patch])
        },
        model.luminaires(),
        o.window_radius_m,
    );
    Ok(window_px.iter().map(Vec::len).zip(rows).collect())
}

/// Calibrates every node's model at the desks some node sees (see the module docs); returns
/// what was done per desk the cameras measured. A node whose rows cannot be measured (no gain,
/// frames that do not match) is skipped with a warning: its desks keep the model.
pub fn calibrate_desks(nodes: &mut [Commissioned], captures: &[Capture]) -> Vec<DeskCalibration> {
    let o = SectionOptions::default();
    // the camera measures each desk through its top's reflectance: the desks' common one first
    let desk_rho: Vec<super::desk_rho::DeskRho> = nodes
        .iter_mut()
        .enumerate()
        .flat_map(|(i, c)| super::desk_rho::share(c, i, &o))
        .collect();
    let rows: Vec<Vec<(usize, Vec<f64>)>> = nodes
        .iter()
        .zip(captures)
        .enumerate()
        .map(|(i, (c, cap))| {
            camera_rows(c, cap, &o).unwrap_or_else(|e| {
                tracing::warn!("node {i}: the desks' camera response: {e}; the model stays");
                Vec::new()
            })
        })
        .collect();
    for n in nodes.iter_mut() {
        n.uncalibrated_all_on_lx = n.model.response_lx.iter().map(|r| r.iter().sum()).collect();
    }
    let Some(first) = nodes.first() else {
        return Vec::new();
    };
    let sensors = first.model.sensors();
    let mut done = Vec::new();
    for s in 0..sensors {
        // the node whose window at the desk holds the most pixels
        let best = rows
            .iter()
            .enumerate()
            .filter_map(|(i, r)| {
                r.get(s)
                    .filter(|(n, _)| *n > 0)
                    .map(|(n, row)| (i, *n, row))
            })
            .max_by_key(|(_, n, _)| *n);
        let Some((i, _, camera)) = best else {
            continue;
        };
        let Some((r, cal)) = calibrate_one(&nodes[i], s, i, camera, &desk_rho) else {
            continue;
        };
        done.push(r);
        if cal.any() {
            apply(nodes, s, &cal);
        }
    }
    done
}

/// Sensor `s`'s calibration by node `i`'s camera rows (see the module docs): the shades the mesh
/// lost, then, where the desk took the desks' common reflectance, the model's scale weighed
/// against the camera's; `None` when the rows give no camera scale.
fn calibrate_one(
    c: &Commissioned,
    s: usize,
    i: usize,
    camera: &[f64],
    desk_rho: &[super::desk_rho::DeskRho],
) -> Option<(DeskCalibration, Calibrated)> {
    let mut cal = desk_scale::calibrate(&c.model.response_lx[s], camera)?;
    let id = c.model.sensor_ids[s];
    let rho = desk_rho
        .iter()
        .find(|d| d.node == i && d.sensor_id == id)
        .cloned();
    // with the desks' common reflectance the camera's scale is a measurement of its own
    if rho.as_ref().is_some_and(|d| d.taken.is_some()) {
        let u = c.report.stated_rel(id);
        desk_scale::weigh_scale(&mut cal, u, super::CALIBRATED_MIN_REL);
    }
    let mut r = record(c, s, i, &cal);
    r.desk_rho = rho;
    Some((r, cal))
}

/// The camera's light in every node's model for the luminaires it replaced at sensor `s`: the
/// difference goes into the sensor's direct light (a lost shade takes direct light; the image
/// stores the direct, first-bounce and gathered parts and derives the response from them).
fn apply(nodes: &mut [Commissioned], s: usize, cal: &Calibrated) {
    for n in nodes.iter_mut() {
        let m = &mut n.model;
        let (Some(resp), Some(direct), Some(first)) = (
            m.response_lx.get_mut(s),
            m.direct_sensor_lx.get_mut(s),
            m.first_bounce_sensor_lx.get_mut(s),
        ) else {
            continue;
        };
        for (l, (c, replaced)) in cal.response_lx.iter().zip(&cal.replaced).enumerate() {
            let (Some(r), Some(d), Some(f)) =
                (resp.get_mut(l), direct.get_mut(l), first.get_mut(l))
            else {
                continue;
            };
            if *replaced || cal.scaled != 1.0 {
                *d += c - *r;
                if *d < 0.0 {
                    // less than the model's interreflections alone: the shade takes some too
                    *f = (*f + *d).max(0.0);
                    *d = 0.0;
                }
                *r = *c;
            }
        }
        if let Some(f) = n.sensor_flags.get_mut(s) {
            *f |= sensor_flags::CALIBRATED;
        }
    }
}

fn record(c: &Commissioned, s: usize, node: usize, cal: &Calibrated) -> DeskCalibration {
    let model = &c.model;
    DeskCalibration {
        sensor_id: model.sensor_ids[s],
        node,
        scale: cal.scale,
        replaced_luminaire_ids: model
            .luminaire_ids
            .iter()
            .zip(&cal.replaced)
            .filter(|(_, r)| **r)
            .map(|(id, _)| *id)
            .collect(),
        scaled: cal.scaled,
        model_all_on_lx: model.response_lx[s].iter().sum(),
        calibrated_all_on_lx: cal.response_lx.iter().sum(),
        desk_rho: None,
    }
}

/// A camera scale this far from 1 at a desk is worth a warning.
pub const SCALE_NOTICE: f64 = 0.1;

/// Logs the desks whose response was calibrated (info) and those where model and camera
/// disagree alike at every luminaire (warning).
pub fn log(done: &[DeskCalibration]) {
    for d in done {
        if !d.replaced_luminaire_ids.is_empty() {
            tracing::info!(
                "sensor {}: calibrated by node {}'s frames: luminaires {:?} give it {:.0} lx all \
                 on where the model gave {:.0} lx (a shade the mesh lost)",
                d.sensor_id,
                d.node,
                d.replaced_luminaire_ids,
                d.calibrated_all_on_lx,
                d.model_all_on_lx
            );
        }
        if d.scale.ln().abs() > SCALE_NOTICE.ln_1p() {
            tracing::warn!(
                "sensor {}: node {}'s camera measures {:+.0} % at every luminaire against the \
                 model: a wrong reflectance under its window, or light the model misses at \
                 every luminaire alike; the stated uncertainty holds the disagreement",
                d.sensor_id,
                d.node,
                100.0 * (d.scale - 1.0)
            );
        }
    }
}
