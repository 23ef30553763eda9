//! The sun's direct normal illuminance `E_dn` from the sun patches the camera sees, through the
//! sun's stored beam ([`super::sky_fit::SunBasis`]): a seen patch in the beam at every grid
//! position around the frame's sun gets `E_dn` times its coefficient beyond the sky's light,
//! so each such patch gives one estimate of `E_dn`, and their median is the sun's strength.
//!
//! A patch whose samples saturate gives only a lower bound (its light is at least its
//! saturation level's). With no unsaturated patch in the beam, `E_dn` is known only from
//! below: the desks in the beam are then not published (their daylight is beyond what the
//! node can tell), and the others carry the bound's share as uncertainty. With no seen patch in
//! the beam, the camera cannot tell whether the sun shines: [`fit_sun`] gives `None`.
//!
//! A sun hidden by clouds gives unsaturated patches in the beam at the sky's light alone:
//! `E_dn ≈ 0`, measured, and every desk is published with the sky alone.

use super::estimator::median;

/// A seen patch or sensor is in the sun's beam when its coefficient is at least this (lx per
/// lx of direct normal illuminance: clear glass's transmittance times the cosine at the
/// receiver; 0.2 is a floor lit through a window by a sun 20° high).
pub const SUN_LIT: f64 = 0.2;

/// Seen patches in the beam needed for an estimate.
pub const SUN_MIN_PATCHES: usize = 2;

/// The sun shines when its fitted light on the patches in its beam is at least this multiple
/// of the sky's there (a sun patch on a floor gets 10-50 × the sky's light; a fit of the sky's
/// residual under clouds, a fraction of it).
pub const SUN_MIN_CONTRAST: f64 = 1.0;

/// The least relative standard uncertainty of a fitted `E_dn`: the beam's coefficients are area
/// averages over a patch sampled at 16 points, and the patch's reflectance is the camera's
/// estimate.
pub const SUN_REL_MIN: f64 = 0.1;

/// The sun's strength in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunFit {
    /// The direct normal illuminance, lx (a lower bound when [`Self::bounded_only`]).
    pub e_dn_lx: f64,
    /// Every patch in the beam saturated: `e_dn_lx` is a lower bound.
    pub bounded_only: bool,
    /// Its relative standard uncertainty (when not bounded only).
    pub rel: f64,
    /// Patches in the beam used.
    pub patches: usize,
    /// The sun shines: its light on the patches in its beam stands out of the sky's
    /// ([`SUN_MIN_CONTRAST`]); when not, `e_dn_lx` is what the sky fit's residual there allows.
    pub present: bool,
}

/// One seen patch as the sun fit reads it.
#[derive(Debug, Clone, Copy)]
pub struct SeenSun {
    /// Its unexplained light beyond the sky's, lx.
    pub beyond_sky_lx: f64,
    /// The fitted sky's light on it, lx.
    pub sky_lx: f64,
    /// Its beam coefficient at the frame's sun, and the least of the grid's four positions.
    pub coefficient: f64,
    /// The least of the four positions' coefficients.
    pub coefficient_min: f64,
    /// Some of its samples saturated (its light is a lower bound).
    pub saturated: bool,
}

/// The sun's strength from the seen patches in its beam, `None` when fewer than
/// [`SUN_MIN_PATCHES`] are in it.
pub fn fit_sun(seen: impl Iterator<Item = SeenSun>) -> Option<SunFit> {
    let (mut free, mut bound, mut sky, mut coef) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for p in seen {
        // in the beam at the sun's blend, and at least half lit at every position around it
        let lit = p.coefficient >= SUN_LIT && p.coefficient_min >= 0.5 * SUN_LIT;
        if !(lit && p.beyond_sky_lx.is_finite()) {
            continue;
        }
        let q = (p.beyond_sky_lx / p.coefficient).max(0.0);
        sky.push(p.sky_lx);
        coef.push(p.coefficient);
        if p.saturated {
            bound.push(q)
        } else {
            free.push(q)
        }
    }
    let patches = free.len() + bound.len();
    if patches < SUN_MIN_PATCHES {
        return None;
    }
    let lower = median(&mut bound).unwrap_or(0.0);
    if free.len() >= SUN_MIN_PATCHES {
        // the median reorders `free`, which the spread below does not mind
        let e = median(&mut free).unwrap_or(0.0);
        let mut dev: Vec<f64> = free.iter().map(|q| (q - e).abs()).collect();
        let spread = 1.4826 * median(&mut dev).unwrap_or(0.0) / (free.len() as f64).sqrt();
        let rel = if e > 0.0 {
            (spread / e).max(SUN_REL_MIN)
        } else {
            SUN_REL_MIN
        };
        let e = e.max(lower);
        let (c, sky) = (
            median(&mut coef).unwrap_or(0.0),
            median(&mut sky).unwrap_or(0.0),
        );
        return Some(SunFit {
            e_dn_lx: e,
            bounded_only: false,
            rel,
            patches,
            present: !bound.is_empty() || c * e >= SUN_MIN_CONTRAST * sky.max(0.0),
        });
    }
    Some(SunFit {
        e_dn_lx: lower,
        bounded_only: true,
        rel: SUN_REL_MIN,
        patches,
        present: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn patch(beyond_sky_lx: f64, coefficient: f64, saturated: bool) -> SeenSun {
        SeenSun {
            beyond_sky_lx,
            sky_lx: 1000.0,
            coefficient,
            coefficient_min: coefficient,
            saturated,
        }
    }

    #[test]
    fn the_median_of_the_patches_in_the_beam_is_the_suns_strength() {
        // 60 klx through glass of 0.7 at cosines 0.5, 0.6, 0.7, and one patch off the beam
        let e = 60_000.0;
        let ps = [0.35, 0.42, 0.49]
            .map(|c| patch(e * c, c, false))
            .into_iter()
            .chain([patch(500.0, 0.05, false)]);
        let f = fit_sun(ps).expect("fit");
        assert!((f.e_dn_lx - e).abs() < 1e-6 && !f.bounded_only && f.patches == 3 && f.present);
        assert!((f.rel - SUN_REL_MIN).abs() < 1e-12);
        // a cloud over the sun: the beam's patches at the sky's light alone
        let f =
            fit_sun([patch(3.0, 0.4, false), patch(-2.0, 0.5, false)].into_iter()).expect("fit");
        assert!(f.e_dn_lx < 10.0 && !f.bounded_only && !f.present);
        // the sky fit's residual on the beam's patches: 300 lx beyond a sky of 1000 lx is not
        // the sun
        let f =
            fit_sun([patch(300.0, 0.4, false), patch(320.0, 0.5, false)].into_iter()).expect("fit");
        assert!(!f.present && f.e_dn_lx > 600.0);
    }

    #[test]
    fn saturated_patches_only_bound_it_and_too_few_patches_give_nothing() {
        let f = fit_sun([patch(8_000.0, 0.4, true), patch(10_000.0, 0.4, true)].into_iter())
            .expect("bound");
        // the median (of two: the upper) of 20 and 25 klx
        assert!(f.bounded_only && (f.e_dn_lx - 25_000.0).abs() < 1e-6);
        // an unsaturated estimate below the saturated patches' bound takes the bound
        let f = fit_sun(
            [
                patch(4_000.0, 0.4, false),
                patch(4_400.0, 0.4, false),
                patch(9_000.0, 0.4, true),
            ]
            .into_iter(),
        )
        .expect("fit");
        assert!(!f.bounded_only && (f.e_dn_lx - 22_500.0).abs() < 1e-6);
        // one patch in the beam, a patch half lit at one of the grid's positions, NaN light
        assert!(fit_sun([patch(9_000.0, 0.4, false)].into_iter()).is_none());
        let half = SeenSun {
            coefficient_min: 0.09,
            ..patch(9_000.0, 0.4, false)
        };
        assert!(fit_sun([half, half].into_iter()).is_none());
        assert!(fit_sun([patch(f64::NAN, 0.4, false); 3].into_iter()).is_none());
    }
}
