//! Direct light from the luminaires, computed exactly rather than through emitting patches.
//!
//! The luminous opening (a `w × l` rectangle along C0 and C90, centred on the luminaire's
//! position) is covered by `m` points of a low-discrepancy (R2) sequence, each carrying `1/m` of
//! the luminaire's intensity distribution. (A regular grid aliases with shadow edges parallel to
//! its rows, such as a monitor's: a sensor 2 cm in front of one read 12 % too much.) This is Radiance's `flatcorr` area source: each point
//! of the opening radiates `I(C, γ) / A` per unit area, so the far field is exactly the
//! photometry and the near field is that of an extended source. For a receiver at x with unit
//! normal n:
//!
//! `E(x) = Σ_k (1/k²) I(C_k, γ_k) · w(θ_k) / d_k² · V(x, q_k)`
//!
//! with `w(θ) = cos θ` for a surface and `w(θ) = s(θ)` for a sensor with sensitivity curve s
//! (its angular response), and V the shadow-ray visibility. Receivers behind the opening's plane
//! or facing away get nothing, without a ray.

use glam::DVec3;

use super::raycast::RayCaster;
use crate::lsc::AngularResponse;
use crate::scene::Luminaire;

/// `m` points spread evenly over a luminaire's opening (R2 sequence, centred; area-uniform on
/// a disc for a circular opening); one point for a point source.
pub fn opening_points(l: &Luminaire, m: usize) -> Vec<DVec3> {
    let [w, len] = l.opening_m;
    if w <= 0.0 && len <= 0.0 {
        return vec![l.position_m];
    }
    const A1: f64 = 0.754_877_666_246_692_7;
    const A2: f64 = 0.569_840_290_998_053_3;
    (0..m.max(1))
        .map(|k| {
            let u = (0.5 + A1 * k as f64).fract();
            let v = (0.5 + A2 * k as f64).fract();
            if l.opening_circular {
                let r = 0.5 * w * u.sqrt();
                let phi = std::f64::consts::TAU * v;
                l.position_m + l.c0 * (r * phi.cos()) + l.c90 * (r * phi.sin())
            } else {
                l.position_m + l.c0 * ((u - 0.5) * w) + l.c90 * ((v - 0.5) * len)
            }
        })
        .collect()
}

/// `m` points over a luminaire's opening whose centroid is exactly the opening's centre. The
/// engine's direct light uses these.
///
/// A rectangle gets a golden rank-1 lattice, `u_k = (k + ½)/m` along C0 and
/// `v_k = frac(½ + (k + ½ − m/2)/φ)` along C90: one point per column (no two share a row or a
/// column, so no alignment with a shadow edge parallel to either side, the reason the engine
/// left regular grids), low discrepancy, and centrally symmetric (point `m − 1 − k` is point
/// `k` mirrored through the centre). A disc gets ⌊m/2⌋ lattice points mapped to the disc and
/// their mirror images (plus the centre for odd `m`).
///
/// Why: the first `m` points of [`opening_points`]' R2 sequence are evenly spread, but their
/// centroid is not the centre: for 4 to 16 points it sits 0.09-0.12 w off along C0 (0.15 l
/// along C90 for 4), a displacement of the whole source by 3-6 cm for a 0.5 m opening. The far
/// field then comes from the wrong place, `δE/E ≈ −δ·∇ ln E` to first order: +2.6 % at a floor
/// point 6 m aside with 8 points, and +3 % at every tabulated ceiling point of Ward's grey room,
/// all of which lie on the side the points lean to (docs/accuracy.md).
pub fn centred_opening_points(l: &Luminaire, m: usize) -> Vec<DVec3> {
    let [w, len] = l.opening_m;
    if (w <= 0.0 && len <= 0.0) || m <= 1 {
        return vec![l.position_m];
    }
    const INV_GOLDEN: f64 = 0.618_033_988_749_894_9;
    let lattice = |m: usize| {
        (0..m).map(move |k| {
            let t = k as f64 + 0.5;
            let v = (0.5 + (t - 0.5 * m as f64) * INV_GOLDEN).rem_euclid(1.0);
            (t / m as f64, v)
        })
    };
    let c = l.position_m;
    if !l.opening_circular {
        return lattice(m)
            .map(|(u, v)| c + l.c0 * ((u - 0.5) * w) + l.c90 * ((v - 0.5) * len))
            .collect();
    }
    let mut out: Vec<DVec3> = lattice(m / 2)
        .map(|(u, v)| {
            let r = 0.5 * w * u.sqrt();
            let phi = std::f64::consts::TAU * v;
            c + l.c0 * (r * phi.cos()) + l.c90 * (r * phi.sin())
        })
        .flat_map(|p| [p, 2.0 * c - p])
        .collect();
    if m % 2 == 1 {
        out.push(c);
    }
    out
}

/// How a receiver weighs light arriving at incidence angle θ (given cos θ > 0).
#[derive(Debug, Clone, Copy)]
pub enum Receiver<'a> {
    /// A Lambertian surface: `cos θ`.
    Surface,
    /// A sensor with an angular response `s(θ)`.
    Sensor(&'a AngularResponse),
}

impl Receiver<'_> {
    fn weight(&self, cos_theta: f64) -> f64 {
        match self {
            Receiver::Surface => cos_theta,
            Receiver::Sensor(AngularResponse::Cosine) => cos_theta,
            Receiver::Sensor(r) => r.response(cos_theta.clamp(-1.0, 1.0).acos()),
        }
    }
}

/// Direct illuminance (lx) at `x` with unit normal `normal` from one luminaire at 100 %.
/// `origin` is `x` already offset from its surface (shadow rays start there).
pub fn illuminance_lx(
    l: &Luminaire,
    points: &[DVec3],
    x: DVec3,
    normal: DVec3,
    receiver: Receiver<'_>,
    caster: &RayCaster,
) -> f64 {
    let origin = caster.offset(x, normal);
    let share = 1.0 / points.len() as f64;
    let mut e = 0.0;
    for &q in points {
        let v = q - x;
        let d2 = v.length_squared();
        if d2.is_nan() || d2 <= 0.0 {
            continue;
        }
        let d = d2.sqrt();
        let to_lum = v / d;
        let cos_r = normal.dot(to_lum);
        if cos_r <= 0.0 {
            continue;
        }
        let i_cd = l.intensity_toward_cd(-to_lum);
        if i_cd <= 0.0 {
            continue;
        }
        let w = receiver.weight(cos_r);
        if w <= 0.0 {
            continue;
        }
        if caster.unoccluded(origin, q) {
            e += share * i_cd * w / d2;
        }
    }
    e
}
