//! The commissioning report picture: the camera's view with a false-colour overlay of the
//! all-on illuminance on the modelled surfaces, desk outlines and each desk's mean lux.

use std::path::Path;

use glam::DVec3;

use super::{BLACK, Canvas, WHITE, nice_ceiling, viridis};
use crate::commission::Commissioned;
use crate::engine::raycast::{Hit, RayCaster};
use crate::scene::Camera;

/// Why a picture was not drawn.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene has no camera to look through.
    #[error("the scene has no camera")]
    NoCamera,
    /// The model could not be solved for the state shown.
    #[error("solving the model: {0}")]
    Engine(#[from] crate::engine::EngineError),
    /// The PNG could not be written.
    #[error("writing the picture: {0}")]
    Png(#[from] image::ImageError),
}

fn project(cam: &Camera, p: DVec3) -> Option<(f64, f64)> {
    let q = cam.world_from_camera.transpose() * (p - cam.position_m);
    (q.z > 1e-6).then(|| (cam.fx * q.x / q.z + cam.cx, cam.fy * q.y / q.z + cam.cy))
}

/// Mean all-on illuminance per desk (its grid points, or its centre), lx: (desk id, centre, lux).
pub fn desk_lux(c: &Commissioned) -> Vec<(u32, DVec3, f64)> {
    let Some(desks) = &c.scene.desks else {
        return Vec::new();
    };
    let levels = vec![1.0; c.model.luminaires()];
    desks
        .desks
        .iter()
        .map(|d| {
            let mut pts: Vec<(DVec3, DVec3)> = desks
                .grid_points
                .iter()
                .filter(|(id, _)| *id == d.id)
                .map(|(_, p)| (*p + DVec3::Z * 0.001, DVec3::Z))
                .collect();
            let centre = DVec3::new(
                0.5 * (d.x_m[0] + d.x_m[1]),
                0.5 * (d.y_m[0] + d.y_m[1]),
                d.z_m + 0.001,
            );
            if pts.is_empty() {
                pts.push((centre, DVec3::Z));
            }
            let r = crate::engine::points::evaluate(&c.scene, &c.model, &pts, 1000);
            let lux = r.lux(&levels);
            (
                d.id,
                centre,
                lux.iter().sum::<f64>() / lux.len().max(1) as f64,
            )
        })
        .collect()
}

/// Draws the report picture.
pub fn report_png(c: &Commissioned, path: &Path) -> Result<(), RenderError> {
    let Some(cam) = &c.scene.camera else {
        return Err(RenderError::NoCamera);
    };
    let levels = vec![1.0; c.model.luminaires()];
    let patch_lx = c.model.patch_lux(&levels)?;
    let caster = RayCaster::new(&c.model.patches);
    let k = 2u32; // upscale
    let (w, h) = (cam.width, cam.height);
    let bar_h = 40;
    let mut canvas = Canvas::new(w * k, h * k + bar_h, WHITE);
    let mut per_px = vec![f64::NAN; (w * h) as usize];
    for v in 0..h {
        for u in 0..w {
            let dir = cam.ray_world(f64::from(u), f64::from(v));
            if let Hit::Front { patch, .. } = caster.closest(cam.position_m, dir) {
                per_px[(v * w + u) as usize] = patch_lx[patch as usize];
            }
        }
    }
    let max = nice_ceiling(
        per_px
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .fold(1.0, f64::max),
    );
    for v in 0..h {
        for u in 0..w {
            let x = per_px[(v * w + u) as usize];
            let col = if x.is_finite() {
                viridis(x / max)
            } else {
                [40, 40, 40]
            };
            canvas.fill(
                i64::from(u * k),
                i64::from(v * k),
                i64::from(k),
                i64::from(k),
                col,
            );
        }
    }
    if let Some(desks) = &c.scene.desks {
        for d in &desks.desks {
            let cs = [
                DVec3::new(d.x_m[0], d.y_m[0], d.z_m),
                DVec3::new(d.x_m[1], d.y_m[0], d.z_m),
                DVec3::new(d.x_m[1], d.y_m[1], d.z_m),
                DVec3::new(d.x_m[0], d.y_m[1], d.z_m),
            ];
            for e in 0..4 {
                let (a, b) = (cs[e], cs[(e + 1) % 4]);
                for s in 0..=200 {
                    let p = a + (b - a) * (f64::from(s) / 200.0);
                    if let Some((u, v)) = project(cam, p) {
                        canvas.fill(
                            (u * f64::from(k)) as i64 - 1,
                            (v * f64::from(k)) as i64 - 1,
                            2,
                            2,
                            WHITE,
                        );
                    }
                }
            }
        }
    }
    for (id, centre, lux) in desk_lux(c) {
        if let Some((u, v)) = project(cam, centre) {
            canvas.label(
                &format!("desk {id}: {lux:.0} lx"),
                (u * f64::from(k)) as i64,
                (v * f64::from(k)) as i64,
                1,
                BLACK,
                WHITE,
            );
        }
    }
    // colour bar
    let y0 = i64::from(h * k) + 8;
    let bw = i64::from(w * k) - 100;
    for x in 0..bw {
        canvas.fill(10 + x, y0, 1, 12, viridis(x as f64 / bw as f64));
    }
    canvas.text("0 lx", 10, y0 + 16, 1, BLACK);
    canvas.text(&format!("{max:.0} lx (all on)"), bw - 40, y0 + 16, 1, BLACK);
    Ok(canvas.save_png(path)?)
}
