//! The Unified Glare Rating of CIE 117-1995 (Discomfort glare in interior lighting), the glare
//! index EN 12464-1:2021 limits (`UGR_L`), computed at an observer from its definition:
//!
//! `UGR = 8 log10( (0.25 / L_b) Σ L² ω / p² )`
//!
//! * `L` (cd/m²): the luminance of a luminaire's luminous opening toward the eye, its luminous
//!   intensity toward the eye divided by the opening's area projected on the plane normal to
//!   that direction (`L = I / (A cos θ)`, θ between the opening's normal and the eye);
//! * `ω` (sr): the solid angle of the opening seen from the eye, `A cos θ / d²` (the small-source
//!   form CIE 117 uses; d the distance from the eye to the opening's centre);
//! * `p`: the Guth position index of the opening's centre ([`guth_position_index`]);
//! * `L_b` (cd/m²): the background luminance, `E_ind / π` with `E_ind` the indirect illuminance
//!   at the eye on the plane normal to the line of sight (CIE 117 §3).
//!
//! CIE 117 gives UGR for sources of `3·10⁻⁴ sr < ω < 0.1 sr`; a term outside is still summed,
//! and flagged ([`Term::in_range`]). Only luminaires above the horizontal line of sight and in
//! front of the eye count (the Guth index is defined there).

use glam::DVec3;
use serde::Serialize;

/// UGR_L of EN 12464-1:2021 for offices (writing, typing, reading, data processing).
pub const UGR_L_OFFICE: f64 = 19.0;

/// The smallest and largest solid angle of a source CIE 117 validates the formula for, sr.
pub const OMEGA_RANGE_SR: [f64; 2] = [3e-4, 0.1];

/// Why a UGR was not computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error, Serialize)]
pub enum UgrError {
    /// The luminaire has no luminous opening size (a point source in its photometry file).
    #[error("luminaire {0} has no luminous opening size (LDT luminous area / IES opening)")]
    NoOpening(u32),
    /// The eye lies within the opening's own extent.
    #[error("the eye lies within luminaire {0}'s opening ({1:.2} m from its centre)")]
    InsideLuminaire(u32, f64),
    /// The background luminance is zero or not a number: the ratio is undefined.
    #[error("background luminance {} (no indirect light at the eye): UGR undefined", luminance_text(*.0))]
    Background(f64),
    /// A value that is not finite (bad geometry or photometry).
    #[error("{0} is not finite")]
    NotFinite(&'static str),
}

/// A luminance as the reasons print it: `0.0 cd/m²`, or "not a number".
fn luminance_text(l_cd_per_m2: f64) -> String {
    if l_cd_per_m2.is_finite() {
        format!("{l_cd_per_m2:.1} cd/m²")
    } else {
        "not a number".into()
    }
}

/// An observer: the eye and the line of sight (unit, horizontal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observer {
    /// Eye position, m.
    pub eye_m: DVec3,
    /// Line of sight, unit, horizontal (z = 0).
    pub sight: DVec3,
}

/// A luminaire's luminous opening: a flat rectangle or disc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Opening {
    /// Luminaire id.
    pub id: u32,
    /// Centre, m.
    pub centre_m: DVec3,
    /// Unit normal on the emitting side (the luminaire's nadir, γ = 0).
    pub normal: DVec3,
    /// Area, m².
    pub area_m2: f64,
    /// Half the largest extent (half the diagonal of a rectangle, the radius of a disc), m.
    pub half_extent_m: f64,
}

impl Opening {
    /// A rectangle `a × b` m (a disc of diameter `a` when `circular`).
    pub fn new(id: u32, centre_m: DVec3, normal: DVec3, size_m: [f64; 2], circular: bool) -> Self {
        let [a, b] = size_m;
        let (area_m2, half_extent_m) = if circular {
            (std::f64::consts::PI * a * a / 4.0, a / 2.0)
        } else {
            (a * b, 0.5 * a.hypot(b))
        };
        Opening {
            id,
            centre_m,
            normal,
            area_m2,
            half_extent_m,
        }
    }
}

/// Where a source lies relative to the line of sight (CIE 117's R, T, H), m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SightFrame {
    /// Along the line of sight.
    pub r_m: f64,
    /// Across it, horizontally (either side).
    pub t_m: f64,
    /// Above it.
    pub h_m: f64,
}

impl SightFrame {
    /// The source at `point_m` seen by `obs`.
    pub fn of(obs: &Observer, point_m: DVec3) -> SightFrame {
        let v = point_m - obs.eye_m;
        let across = obs.sight.cross(DVec3::Z);
        SightFrame {
            r_m: v.dot(obs.sight),
            t_m: v.dot(across).abs(),
            h_m: v.z,
        }
    }
}

/// The Guth position index `p` of a source at `(R, T, H)` from the eye (m, see [`SightFrame`]);
/// `None` behind the eye (`R ≤ 0`) or below the line of sight (`H < 0`), where it is not
/// defined.
///
/// The closed form of the Luckiesh–Guth table used by the IES and Radiance's `evalglare`:
/// `ln p = (35.2 − 0.31889 τ − 1.22 e^(−2τ/9))·10⁻³ σ + (21 + 0.26667 τ − 0.002963 τ²)·10⁻⁵ σ²`,
/// σ (degrees) the angle between the line of sight and the direction of the source, τ (degrees)
/// the angle from the vertical of the plane through the line of sight and the source. It gives
/// `p = 1` on the line of sight and every cell of CIE 117's Table 4.1 with `T/R ≤ 2` within 9 %
/// (median 4 %): at most 0.64 UGR for a single luminaire (unit test). CIE 117 prescribes the
/// table; the closed form is used for its smoothness, and that bound is its price.
pub fn guth_position_index(f: &SightFrame) -> Option<f64> {
    if !(f.r_m > 0.0 && f.h_m >= 0.0 && f.t_m.is_finite()) {
        return None;
    }
    let off_axis = f.t_m.hypot(f.h_m);
    let sigma = off_axis.atan2(f.r_m).to_degrees();
    let tau = f.t_m.atan2(f.h_m).to_degrees();
    let a = (35.2 - 0.31889 * tau - 1.22 * (-2.0 * tau / 9.0).exp()) * 1e-3;
    let b = (21.0 + 0.26667 * tau - 0.002963 * tau * tau) * 1e-5;
    Some((a * sigma + b * sigma * sigma).exp())
}

/// One luminaire's term of the sum.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Term {
    /// Luminaire id.
    pub id: u32,
    /// Luminous intensity toward the eye, cd.
    pub i_cd: f64,
    /// Luminance of the opening toward the eye, cd/m².
    pub l_cd_per_m2: f64,
    /// Solid angle of the (visible part of the) opening, sr.
    pub omega_sr: f64,
    /// Guth position index.
    pub p: f64,
    /// Where it lies, m.
    pub frame: SightFrame,
    /// `ω` within CIE 117's range ([`OMEGA_RANGE_SR`]).
    pub in_range: bool,
}

impl Term {
    /// `L² ω / p²`.
    pub fn glare(&self) -> f64 {
        self.l_cd_per_m2 * self.l_cd_per_m2 * self.omega_sr / (self.p * self.p)
    }
}

/// The term of luminaire `o` for observer `obs`: `i_cd` its intensity toward the eye (cd, at
/// its dimming level), `visible` the fraction of its opening the eye sees (0 to 1). `Ok(None)`
/// when it is behind the eye, below the line of sight, facing away, dark or hidden.
pub fn term(
    obs: &Observer,
    o: &Opening,
    i_cd: f64,
    visible: f64,
) -> Result<Option<Term>, UgrError> {
    if o.area_m2.is_nan() || o.area_m2 <= 0.0 {
        return Err(UgrError::NoOpening(o.id));
    }
    let to_eye = obs.eye_m - o.centre_m;
    let d_m = to_eye.length();
    if !(d_m.is_finite() && i_cd.is_finite() && visible.is_finite()) {
        return Err(UgrError::NotFinite("geometry, intensity or visibility"));
    }
    if d_m <= o.half_extent_m {
        return Err(UgrError::InsideLuminaire(o.id, d_m));
    }
    let frame = SightFrame::of(obs, o.centre_m);
    let cos_theta = o.normal.dot(to_eye / d_m);
    let Some(p) = guth_position_index(&frame) else {
        return Ok(None);
    };
    if cos_theta <= 0.0 || i_cd <= 0.0 || visible <= 0.0 {
        return Ok(None);
    }
    let projected_m2 = o.area_m2 * cos_theta;
    let omega_sr = projected_m2 / (d_m * d_m) * visible.min(1.0);
    Ok(Some(Term {
        id: o.id,
        i_cd,
        l_cd_per_m2: i_cd / projected_m2,
        omega_sr,
        p,
        frame,
        in_range: (OMEGA_RANGE_SR[0]..=OMEGA_RANGE_SR[1]).contains(&omega_sr),
    }))
}

/// UGR from the terms and the background luminance (cd/m²). `Ok(None)` when no luminaire is in
/// view (no glare from the luminaires: the rating has no value).
pub fn ugr(l_b_cd_per_m2: f64, terms: &[Term]) -> Result<Option<f64>, UgrError> {
    if !(l_b_cd_per_m2.is_finite() && l_b_cd_per_m2 > 0.0) {
        return Err(UgrError::Background(l_b_cd_per_m2));
    }
    let sum: f64 = terms.iter().map(Term::glare).sum();
    if !sum.is_finite() {
        return Err(UgrError::NotFinite("Σ L² ω / p²"));
    }
    Ok((sum > 0.0).then(|| 8.0 * (0.25 / l_b_cd_per_m2 * sum).log10()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(r: f64, t: f64, h: f64) -> SightFrame {
        SightFrame {
            r_m: r,
            t_m: t,
            h_m: h,
        }
    }

    #[test]
    fn guth_index_follows_the_table() {
        // on the line of sight p = 1 exactly
        assert_eq!(guth_position_index(&at(2.0, 0.0, 0.0)), Some(1.0));
        // CIE 117:1995 Table 4.1 (Guth), cells (T/R, H/R, p) across the table, the worst of
        // its T/R ≤ 2 cells among them (2.0, 0.7): every such cell is within 9 % (0.64 UGR for
        // one luminaire, 16 log10 1.09); the table as transcribed in eulumdat-ugr's guth.py
        let cells = [
            (0.0, 0.5, 2.86),
            (0.0, 1.0, 7.00),
            (0.0, 1.5, 13.15),
            (0.5, 0.0, 1.43),
            (0.5, 0.5, 2.91),
            (0.5, 1.0, 6.40),
            (1.0, 0.0, 2.11),
            (1.0, 0.5, 3.91),
            (1.0, 1.0, 7.00),
            (1.0, 1.5, 11.90),
            (1.3, 0.4, 4.20),
            (1.5, 0.5, 5.00),
            (1.5, 1.0, 8.20),
            (2.0, 0.0, 3.50),
            (2.0, 0.7, 7.10),
            (2.0, 1.0, 8.90),
            (0.2, 0.8, 4.60),
        ];
        for (t_over_r, h_over_r, table) in cells {
            let p = guth_position_index(&at(1.0, t_over_r, h_over_r)).unwrap();
            assert!(
                (p / table - 1.0).abs() < 0.09,
                "T/R {t_over_r}, H/R {h_over_r}: {p} vs {table}"
            );
        }
        // the T/R = 0 column is closer: H/R 0.5 → 2.86 within 0.5 %
        let p = guth_position_index(&at(2.0, 0.0, 1.0)).unwrap();
        assert!((p / 2.86 - 1.0).abs() < 0.005, "{p}");
        // the index grows with the angle off the line of sight
        let p1 = guth_position_index(&at(1.0, 0.5, 0.5)).unwrap();
        let p2 = guth_position_index(&at(1.0, 1.0, 0.5)).unwrap();
        assert!(p2 > p1 && p1 > 1.0);
        // undefined behind the eye and below the line of sight
        assert_eq!(guth_position_index(&at(-1.0, 0.0, 1.0)), None);
        assert_eq!(guth_position_index(&at(1.0, 0.0, -0.1)), None);
    }

    #[test]
    fn bad_input_is_an_error_not_a_nan() {
        let obs = Observer {
            eye_m: DVec3::new(0.0, 0.0, 1.2),
            sight: DVec3::Y,
        };
        let point = Opening::new(
            7,
            DVec3::new(0.0, 2.0, 2.8),
            DVec3::NEG_Z,
            [0.0, 0.0],
            false,
        );
        assert_eq!(term(&obs, &point, 100.0, 1.0), Err(UgrError::NoOpening(7)));
        let around = Opening::new(
            8,
            DVec3::new(0.0, 0.1, 1.3),
            DVec3::NEG_Z,
            [0.6, 0.6],
            false,
        );
        assert!(matches!(
            term(&obs, &around, 100.0, 1.0),
            Err(UgrError::InsideLuminaire(8, _))
        ));
        assert!(matches!(ugr(0.0, &[]), Err(UgrError::Background(_))));
        let nan = ugr(f64::NAN, &[]).unwrap_err();
        assert!(!nan.to_string().contains("NaN"), "{nan}");
        assert_eq!(ugr(10.0, &[]), Ok(None));
        let behind = Opening::new(
            9,
            DVec3::new(0.0, -2.0, 2.8),
            DVec3::NEG_Z,
            [0.6, 0.6],
            false,
        );
        assert_eq!(term(&obs, &behind, 100.0, 1.0), Ok(None));
    }
}
