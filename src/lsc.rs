//! The desk sensor (luxmeter) model: its light sensitivity curve (LSC), the relative response
//! `s(θ)` to light arriving at incidence angle θ, with `s(0) = 1`. An ideal luxmeter has
//! `s(θ) = cos θ`; real ones deviate, measured by the cosine error `f2` (CIE 69 / ISO/CIE 19476):
//!
//! `f2 = ∫_0^85° | s(ε) / (s(0) cos ε) − 1 | sin 2ε dε`
//!
//! The reading of a sensor in a luminance field L is `E = ∫ L(ω) s(θ) dω` (physics.md §3.5);
//! the engine evaluates it with cosine-distributed rays weighted by `s(θ) / cos θ`.

use std::fmt;

/// A light sensitivity curve: relative response against incidence angle, linearly
/// interpolated, zero at and beyond 90°.
#[derive(Debug, Clone, PartialEq)]
pub struct Lsc {
    angles_rad: Vec<f64>,
    response: Vec<f64>,
}

/// Why a sensitivity table was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LscError {
    /// Fewer than two points.
    #[error("an LSC table needs at least 2 points, found {0}")]
    TooShort(usize),
    /// The first angle is not 0.
    #[error("an LSC table must start at 0 degrees (normal incidence), found {0}")]
    NoNormalIncidence(f64),
    /// Angles not strictly ascending or outside [0, 90].
    #[error("LSC angles must ascend strictly within [0, 90] degrees ({0})")]
    BadAngles(String),
    /// A response that is negative or not finite.
    #[error("LSC response {value} at {angle_deg} degrees must be finite and >= 0")]
    BadResponse {
        /// Angle, degrees.
        angle_deg: f64,
        /// The offending response.
        value: f64,
    },
    /// Zero response at normal incidence: nothing to normalise by.
    #[error("LSC response at 0 degrees is 0")]
    ZeroAtNormal,
}

impl Lsc {
    /// From `(incidence_deg, relative_response)` pairs. The table is normalised to
    /// `s(0) = 1`; the returned flag tells whether it had to be.
    pub fn from_table_deg(points: &[[f64; 2]]) -> Result<(Self, bool), LscError> {
        if points.len() < 2 {
            return Err(LscError::TooShort(points.len()));
        }
        if points[0][0] != 0.0 {
            return Err(LscError::NoNormalIncidence(points[0][0]));
        }
        for w in points.windows(2) {
            let ascending = w[1][0] > w[0][0];
            if !ascending {
                return Err(LscError::BadAngles(format!("{} then {}", w[0][0], w[1][0])));
            }
        }
        let last = points[points.len() - 1][0];
        if !last.is_finite() || last > 90.0 {
            return Err(LscError::BadAngles(format!("last angle {last}")));
        }
        for p in points {
            if !p[1].is_finite() || p[1] < 0.0 {
                return Err(LscError::BadResponse {
                    angle_deg: p[0],
                    value: p[1],
                });
            }
        }
        let s0 = points[0][1];
        if s0 <= 0.0 {
            return Err(LscError::ZeroAtNormal);
        }
        let mut angles_rad: Vec<f64> = points.iter().map(|p| p[0].to_radians()).collect();
        let mut response: Vec<f64> = points.iter().map(|p| p[1] / s0).collect();
        if last < 90.0 {
            angles_rad.push(std::f64::consts::FRAC_PI_2);
            response.push(0.0);
        }
        Ok((
            Self {
                angles_rad,
                response,
            },
            (s0 - 1.0).abs() > 1e-9,
        ))
    }

    /// Relative response at incidence angle `theta_rad` (0 beyond 90°).
    pub fn response(&self, theta_rad: f64) -> f64 {
        let t = theta_rad.abs();
        let a = &self.angles_rad;
        if t >= std::f64::consts::FRAC_PI_2 || !t.is_finite() {
            return 0.0;
        }
        let i = a.partition_point(|&x| x <= t).clamp(1, a.len() - 1);
        let (x0, x1) = (a[i - 1], a[i]);
        let f = ((t - x0) / (x1 - x0)).clamp(0.0, 1.0);
        self.response[i - 1] + f * (self.response[i] - self.response[i - 1])
    }

    /// A cosine sensor at the bottom of a matt black tube (a hood or light pipe) whose bore
    /// the sensor's window fills, with `tan θc = bore / length`: light at incidence θ reaches
    /// the overlap of the bore's two end discs, offset by `length · tan θ`, so
    ///
    /// `s(θ) = cos θ · V(tan θ / tan θc)`, `V(x) = (2/π)(acos x − x √(1 − x²))` for x < 1, 0
    /// beyond,
    ///
    /// the area of two unit-diameter discs' lens at centre distance x over a disc's area. It
    /// sees a cone of half-angle θc, soft-edged. Tabulated at 256 steps; `None` unless
    /// 1° ≤ θc ≤ 85°.
    pub fn hooded(cutoff_rad: f64) -> Option<Self> {
        let c = cutoff_rad.to_degrees();
        if !(1.0..=85.0).contains(&c) {
            return None;
        }
        let tan_c = cutoff_rad.tan();
        let steps = 256usize;
        let mut angles_rad = Vec::with_capacity(steps + 2);
        let mut response = Vec::with_capacity(steps + 2);
        for i in 0..=steps {
            let t = cutoff_rad * i as f64 / steps as f64;
            let x = (t.tan() / tan_c).min(1.0);
            let v = (2.0 / std::f64::consts::PI) * (x.acos() - x * (1.0 - x * x).max(0.0).sqrt());
            angles_rad.push(t);
            response.push((t.cos() * v).max(0.0));
        }
        angles_rad.push(std::f64::consts::FRAC_PI_2);
        response.push(0.0);
        Some(Self {
            angles_rad,
            response,
        })
    }

    /// The table points, degrees and relative response (after normalisation).
    pub fn points_deg(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.angles_rad
            .iter()
            .zip(&self.response)
            .map(|(a, r)| (a.to_degrees(), *r))
    }
}

/// A sensor's angular response: ideal cosine, or a measured table.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum AngularResponse {
    /// `s(θ) = cos θ`.
    #[default]
    Cosine,
    /// A measured LSC.
    Table(Lsc),
}

impl AngularResponse {
    /// Relative response `s(θ)`.
    pub fn response(&self, theta_rad: f64) -> f64 {
        match self {
            AngularResponse::Cosine => {
                if theta_rad.abs() >= std::f64::consts::FRAC_PI_2 {
                    0.0
                } else {
                    theta_rad.cos()
                }
            }
            AngularResponse::Table(l) => l.response(theta_rad),
        }
    }

    /// `∫ s(θ) dω` over the hemisphere, sr (π for a cosine sensor): a uniform luminance L gives
    /// the reading `L · ∫ s dω`. Simpson's rule on a 0.005° grid.
    pub fn projected_solid_angle_sr(&self) -> f64 {
        let n = 18_000usize; // even
        let h = std::f64::consts::FRAC_PI_2 / n as f64;
        let g = |t: f64| 2.0 * std::f64::consts::PI * self.response(t) * t.sin();
        let mut s = g(0.0) + g(n as f64 * h);
        for k in 1..n {
            let w = if k % 2 == 1 { 4.0 } else { 2.0 };
            s += w * g(k as f64 * h);
        }
        s * h / 3.0
    }

    /// The cosine error `f2` (0 for an ideal cosine receiver), integrated to 85° with
    /// Simpson's rule on a 0.01° grid.
    pub fn f2(&self) -> f64 {
        let n = 8500usize; // even
        let h = 85f64.to_radians() / n as f64;
        let g = |e: f64| {
            let c = e.cos();
            (self.response(e) / c - 1.0).abs() * (2.0 * e).sin()
        };
        let mut s = g(0.0) + g(n as f64 * h);
        for k in 1..n {
            let w = if k % 2 == 1 { 4.0 } else { 2.0 };
            s += w * g(k as f64 * h);
        }
        s * h / 3.0
    }
}

impl fmt::Display for AngularResponse {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AngularResponse::Cosine => write!(f, "ideal cosine"),
            AngularResponse::Table(l) => {
                write!(
                    f,
                    "LSC table ({} points), f2 = {:.1} %",
                    l.angles_rad.len(),
                    100.0 * self.f2()
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hooded_sensor_sees_a_soft_cone() {
        // a cosine sensor's projected solid angle is π
        let pi = std::f64::consts::PI;
        assert!((AngularResponse::Cosine.projected_solid_angle_sr() - pi).abs() < 1e-9);
        // small cut-off: s ≈ V(θ/θc), ∫ s dω → 2π tan²θc ∫_0^1 V(x) x dx = π tan²θc / 4 (the
        // disc's autocorrelation integrates to its area); relative correction O(tan²θc)
        let c = 2f64.to_radians();
        let h = AngularResponse::Table(Lsc::hooded(c).unwrap());
        let want = pi * c.tan().powi(2) / 4.0;
        let got = h.projected_solid_angle_sr();
        assert!((got / want - 1.0).abs() < 3e-3, "{got} vs {want}");
        // 35°: zero beyond the cut-off, below the cosine inside, 1 at normal incidence
        let c = 35f64.to_radians();
        let h = AngularResponse::Table(Lsc::hooded(c).unwrap());
        assert!((h.response(0.0) - 1.0).abs() < 1e-12);
        assert_eq!(h.response(36f64.to_radians()), 0.0);
        for d in 1..35 {
            let t = f64::from(d).to_radians();
            assert!(h.response(t) < t.cos() && h.response(t) > 0.0, "{d}°");
        }
        // out of range: no hood
        assert!(Lsc::hooded(0.5f64.to_radians()).is_none());
        assert!(Lsc::hooded(86f64.to_radians()).is_none());
        assert!(Lsc::hooded(f64::NAN).is_none());
    }

    #[test]
    fn ideal_cosine_has_zero_f2() {
        assert!(AngularResponse::Cosine.f2().abs() < 1e-12);
    }

    #[test]
    fn reference_code_sample_lsc_f2() {
        // physics.md §10 H2: the ttsesm/radiosity sample LSC, linear, 0 at 90°: f2 = 0.2209 ± 0.002
        let pts: Vec<[f64; 2]> = [1.0, 0.984, 0.936, 0.854, 0.736, 0.572, 0.313, 0.077, 0.0164]
            .iter()
            .enumerate()
            .map(|(i, &s)| [10.0 * i as f64, s])
            .collect();
        let (lsc, renormalised) = Lsc::from_table_deg(&pts).unwrap();
        assert!(!renormalised);
        let f2 = AngularResponse::Table(lsc).f2();
        assert!((f2 - 0.2209).abs() < 0.002, "f2 = {f2}");
    }

    #[test]
    fn uniform_under_response_f2() {
        // physics.md §10 H3: 3 % under-response away from normal: f2 = 0.0298
        let pts: Vec<[f64; 2]> = (0..=180)
            .map(|i| {
                let a = 0.5 * i as f64;
                [
                    a,
                    if i == 0 {
                        1.0
                    } else {
                        0.97 * a.to_radians().cos()
                    },
                ]
            })
            .collect();
        let (lsc, _) = Lsc::from_table_deg(&pts).unwrap();
        let f2 = AngularResponse::Table(lsc).f2();
        assert!((f2 - 0.0298).abs() < 0.0005, "f2 = {f2}");
    }

    #[test]
    fn tables_are_validated_and_normalised() {
        assert_eq!(
            Lsc::from_table_deg(&[[0.0, 1.0]]),
            Err(LscError::TooShort(1))
        );
        assert!(matches!(
            Lsc::from_table_deg(&[[5.0, 1.0], [10.0, 0.9]]),
            Err(LscError::NoNormalIncidence(_))
        ));
        assert!(Lsc::from_table_deg(&[[0.0, 1.0], [0.0, 0.9]]).is_err());
        assert!(Lsc::from_table_deg(&[[0.0, 1.0], [95.0, 0.0]]).is_err());
        assert!(Lsc::from_table_deg(&[[0.0, 1.0], [45.0, -0.1]]).is_err());
        assert!(Lsc::from_table_deg(&[[0.0, 0.0], [45.0, 0.1]]).is_err());
        let (l, renorm) = Lsc::from_table_deg(&[[0.0, 2.0], [60.0, 1.0]]).unwrap();
        assert!(renorm);
        assert!((l.response(0.0) - 1.0).abs() < 1e-12);
        assert!((l.response(60f64.to_radians()) - 0.5).abs() < 1e-12);
        assert!((l.response(75f64.to_radians()) - 0.25).abs() < 1e-12);
        assert_eq!(l.response(1.6), 0.0);
    }
}
