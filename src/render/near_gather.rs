//! The task points' interreflection with the near field resolved: the gather of
//! [`DenseField::air_points`] takes each hit patch's exitance as flat over the patch, which is
//! right when the patch is small as seen from the point, and wrong when the point is close to a
//! large patch whose exitance varies over it. A desk point 10 cm from a wall sees the wall's
//! lowest part, just above the desk, fill a large share of its hemisphere; that part of the wall
//! is darker than the wall patch's mean (the desk and the point's own surroundings shade it from
//! the luminaires' light low on the wall), so the flat patch read the point high or low by the
//! patch's gradient (room_02's desk 6: its wall-side row 3.5 % low against Radiance).
//!
//! Here every gather ray that hits a surface within [`NEAR_DIAMETERS`] of the hit patch's
//! diameter takes the exitance *at the hit point* instead: `B(x) = ρ (E_direct(x) + H(x))`, with
//! the direct light exact at x (the camera pixels' opening points) and the incident
//! interreflection `H` interpolated over the patch mesh as the dense field does for surface
//! points. Farther hits keep the patch's exitance (there the patch is small as seen, and its mean
//! is what the point sees). Same rays as the gather (the isocell set about the point's normal),
//! so the correction replaces exactly the near hits' terms.

use glam::DVec3;
use rayon::prelude::*;

use crate::engine::Patches;
use crate::engine::dense::{DenseField, Readings, SurfacePoint};
use crate::engine::raycast::Hit;
use crate::engine::rayset::{RaySet, RaySetKind, frame, to_world};

/// A hit closer than this many diameters of its patch is evaluated at the hit point.
pub const NEAR_DIAMETERS: f64 = 2.0;

/// The largest edge of a patch, m.
fn diameter_m(c: &[DVec3; 3]) -> f64 {
    c[0].distance(c[1])
        .max(c[1].distance(c[2]))
        .max(c[2].distance(c[0]))
}

/// Readings at upward-facing points of a calculation plane (1 mm above each of `pts`): the
/// direct light and the gather of [`DenseField::air_points`], with the gather's near hits
/// evaluated at the hit point (see the module).
pub fn plane_readings(
    field: &DenseField<'_>,
    patches: &Patches,
    pts: &[DVec3],
    basis_b: &[Vec<f64>],
    rays: usize,
) -> Readings {
    let air: Vec<(DVec3, DVec3)> = pts
        .iter()
        .map(|p| (*p + DVec3::Z * 0.001, DVec3::Z))
        .collect();
    let mut out = field.air_points(&air, basis_b, rays);
    let l = out.luminaires;
    if l == 0 || air.is_empty() {
        return out;
    }
    let set = RaySet::new(RaySetKind::Isocell, rays.clamp(1, 100_000));
    let n = set.dirs.len() as f64;
    let caster = field.caster();
    let corrections: Vec<Vec<f64>> = air
        .par_iter()
        .map(|&(p, normal)| {
            let origin = caster.offset(p, normal);
            let fr = frame(normal, 0.0);
            let mut near: Vec<SurfacePoint> = Vec::new();
            for d in &set.dirs {
                let dir = to_world(&fr, *d);
                if let Hit::Front { patch, t_m } = caster.closest(origin, dir) {
                    let k = patch as usize;
                    if k < patches.len() && t_m < NEAR_DIAMETERS * diameter_m(&patches.corners_m[k])
                    {
                        near.push(SurfacePoint {
                            position_m: origin + dir * t_m,
                            normal: patches.normal[k],
                            patch,
                        });
                    }
                }
            }
            let mut corr = vec![0.0; l];
            if near.is_empty() {
                return corr;
            }
            let local = field.map_readings(&near);
            for (s, sp) in near.iter().enumerate() {
                let k = sp.patch as usize;
                let rho = patches.rho[k];
                for (lum, c) in corr.iter_mut().enumerate() {
                    let e = local.direct_lx[s * l + lum] + local.indirect_lx[s * l + lum];
                    let flat = basis_b
                        .get(lum)
                        .and_then(|b| b.get(k))
                        .copied()
                        .unwrap_or(0.0);
                    *c += (rho * e - flat) / n;
                }
            }
            corr
        })
        .collect();
    for (i, corr) in corrections.iter().enumerate() {
        for (lum, c) in corr.iter().enumerate() {
            out.indirect_lx[i * l + lum] += c;
        }
    }
    out
}
