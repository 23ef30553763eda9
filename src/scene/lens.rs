//! The projection of a camera's lens: the pinhole, or a wide-angle (fisheye) lens in the
//! Kannala-Brandt model (Kannala & Brandt, IEEE TPAMI 28(8), 2006; OpenCV's `cv::fisheye`).
//!
//! In normalised image coordinates `m = ((u − cx)/fx, (v − cy)/fy)` and for a ray at angle θ
//! from the optical axis with azimuth φ:
//!
//! | lens | radius `r = |m|` of the ray's image | field |
//! |---|---|---|
//! | pinhole | `r = tan θ` | θ < 90° |
//! | Kannala-Brandt | `r = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)` | θ ≤ [`MAX_FISHEYE_THETA_RAD`] |
//! | equidistant | Kannala-Brandt with `k = 0`: `r = θ` | the same |
//!
//! and `m = r (cos φ, sin φ)`. Depth frames stay in the capture format's convention, depth
//! along the optical axis (`z_cam`), for every lens: a point at depth z on the ray of unit
//! direction d is `z d / d_z`; the fisheye's field therefore stops short of 90° off the axis.
//!
//! A lens is checked before any use ([`Lens::check`]): finite coefficients of moderate size
//! and an image radius that grows with θ over the whole field (a lens that folds its image
//! over cannot be inverted). Inversion ([`Lens::theta_rad`]) is a Newton iteration safeguarded
//! by bisection, at most [`MAX_ITERATIONS`] steps: bounded work for any input.

use glam::{DVec2, DVec3};

/// The widest angle off the optical axis a fisheye lens is used to, rad (89°: depth along the
/// axis, the capture format's convention, degenerates at 90°).
pub const MAX_FISHEYE_THETA_RAD: f64 = 89.0 * std::f64::consts::PI / 180.0;
/// The widest angle off the optical axis of a pinhole ray, rad (the image bounds it well
/// before: [`super::check_intrinsics`] allows at most 178° across).
pub const MAX_PINHOLE_THETA_RAD: f64 = 89.5 * std::f64::consts::PI / 180.0;
/// The largest magnitude of a Kannala-Brandt coefficient (calibrated lenses have |k| < 1).
pub const MAX_K: f64 = 10.0;
/// The most steps of the inversion of `r(θ)`.
pub const MAX_ITERATIONS: usize = 60;

/// A camera's lens model (the intrinsics fx, fy, cx, cy live beside it in [`super::Camera`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Lens {
    /// Rectilinear projection, `r = tan θ`.
    #[default]
    Pinhole,
    /// Fisheye, `r = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`; `k = [0; 4]` is the equidistant
    /// lens.
    KannalaBrandt {
        /// k1..k4.
        k: [f64; 4],
    },
}

impl Lens {
    /// The equidistant fisheye (`r = θ`).
    pub const EQUIDISTANT: Lens = Lens::KannalaBrandt { k: [0.0; 4] };

    /// The model's name as `camera.json` and board files spell it.
    pub fn model_name(&self) -> &'static str {
        match self {
            Lens::Pinhole => "pinhole",
            Lens::KannalaBrandt { k } if *k == [0.0; 4] => "equidistant",
            Lens::KannalaBrandt { .. } => "kannala_brandt",
        }
    }

    /// The lens from a file's `model` name and coefficients (`k`, optional, Kannala-Brandt
    /// only), checked.
    pub fn from_model(model: &str, k: Option<[f64; 4]>) -> Result<Lens, String> {
        let lens = match model {
            "pinhole" => {
                if k.is_some_and(|k| k != [0.0; 4]) {
                    return Err(
                        "k (Kannala-Brandt coefficients) given for a pinhole lens: use model \
                         \"kannala_brandt\""
                            .into(),
                    );
                }
                Lens::Pinhole
            }
            "equidistant" => {
                if k.is_some_and(|k| k != [0.0; 4]) {
                    return Err(
                        "an equidistant lens has k = 0: use model \"kannala_brandt\"".into(),
                    );
                }
                Lens::EQUIDISTANT
            }
            "kannala_brandt" => Lens::KannalaBrandt {
                k: k.unwrap_or([0.0; 4]),
            },
            other => {
                return Err(format!(
                    "lens model {other:?} is not known (known: \"pinhole\", \"equidistant\", \
                     \"kannala_brandt\")"
                ));
            }
        };
        lens.check()?;
        Ok(lens)
    }

    /// The coefficients (zero for the pinhole).
    pub fn k(&self) -> [f64; 4] {
        match self {
            Lens::Pinhole => [0.0; 4],
            Lens::KannalaBrandt { k } => *k,
        }
    }

    /// True for a fisheye.
    pub fn is_fisheye(&self) -> bool {
        matches!(self, Lens::KannalaBrandt { .. })
    }

    /// Checks the coefficients: finite, |k| ≤ [`MAX_K`], and `r(θ)` strictly increasing over
    /// the whole field (sampled every 0.1°, then the derivative's polynomial is positive
    /// between samples within the check's margin). The error names the coefficient.
    pub fn check(&self) -> Result<(), String> {
        let Lens::KannalaBrandt { k } = self else {
            return Ok(());
        };
        for (i, x) in k.iter().enumerate() {
            if !(x.is_finite() && x.abs() <= MAX_K) {
                return Err(format!(
                    "k{} = {x} is not a Kannala-Brandt coefficient (|k| ≤ {MAX_K})",
                    i + 1
                ));
            }
        }
        let n = 890;
        for i in 0..=n {
            let t = MAX_FISHEYE_THETA_RAD * f64::from(i) / f64::from(n);
            if self.dradius_dtheta(t) <= 1e-3 {
                return Err(format!(
                    "k = {k:?} folds the image over at {:.1}° off the axis (the image radius \
                     must grow with the angle up to {:.0}°)",
                    t.to_degrees(),
                    MAX_FISHEYE_THETA_RAD.to_degrees()
                ));
            }
        }
        Ok(())
    }

    /// The widest angle off the axis this lens images, rad.
    pub fn max_theta_rad(&self) -> f64 {
        match self {
            Lens::Pinhole => MAX_PINHOLE_THETA_RAD,
            Lens::KannalaBrandt { .. } => MAX_FISHEYE_THETA_RAD,
        }
    }

    /// Image radius (normalised) of a ray at `theta_rad` off the axis.
    pub fn radius(&self, theta_rad: f64) -> f64 {
        match self {
            Lens::Pinhole => theta_rad.tan(),
            Lens::KannalaBrandt { k } => {
                let t2 = theta_rad * theta_rad;
                theta_rad * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
            }
        }
    }

    /// d r / d θ.
    pub fn dradius_dtheta(&self, theta_rad: f64) -> f64 {
        match self {
            Lens::Pinhole => 1.0 / theta_rad.cos().powi(2),
            Lens::KannalaBrandt { k } => {
                let t2 = theta_rad * theta_rad;
                1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])))
            }
        }
    }

    /// The angle off the axis of the ray imaged at normalised radius `r` (`None` beyond the
    /// field or for a radius that is not a number).
    pub fn theta_rad(&self, r: f64) -> Option<f64> {
        if !(r.is_finite() && r >= 0.0) {
            return None;
        }
        match self {
            Lens::Pinhole => {
                let t = r.atan();
                (t <= MAX_PINHOLE_THETA_RAD).then_some(t)
            }
            Lens::KannalaBrandt { .. } => {
                let (mut lo, mut hi) = (0.0, MAX_FISHEYE_THETA_RAD);
                if r > self.radius(hi) {
                    return None;
                }
                // r(θ) increases on [lo, hi] (checked): Newton, falling back to bisection
                // whenever a step leaves the bracket
                let mut t = r.min(hi);
                for _ in 0..MAX_ITERATIONS {
                    let f = self.radius(t) - r;
                    if f.abs() <= 1e-14 * r.max(1e-3) {
                        break;
                    }
                    if f > 0.0 {
                        hi = t;
                    } else {
                        lo = t;
                    }
                    let step = t - f / self.dradius_dtheta(t);
                    t = if step > lo && step < hi {
                        step
                    } else {
                        0.5 * (lo + hi)
                    };
                }
                Some(t)
            }
        }
    }

    /// Normalised image coordinates of a point in camera coordinates (x right, y down, z
    /// forward), `None` outside the field (behind the camera, or beyond the fisheye's angle).
    pub fn project(&self, p_cam: DVec3) -> Option<DVec2> {
        if !p_cam.is_finite() {
            return None;
        }
        let rho = p_cam.x.hypot(p_cam.y);
        let theta = rho.atan2(p_cam.z);
        if theta > self.max_theta_rad() || (rho == 0.0 && p_cam.z <= 0.0) {
            return None;
        }
        match self {
            Lens::Pinhole => Some(DVec2::new(p_cam.x / p_cam.z, p_cam.y / p_cam.z)),
            Lens::KannalaBrandt { .. } => {
                if rho < 1e-300 {
                    return Some(DVec2::ZERO);
                }
                let r = self.radius(theta);
                Some(DVec2::new(p_cam.x, p_cam.y) * (r / rho))
            }
        }
    }

    /// The unit ray direction (camera coordinates) imaged at normalised coordinates `m`,
    /// `None` beyond the field.
    pub fn unproject(&self, m: DVec2) -> Option<DVec3> {
        if !m.is_finite() {
            return None;
        }
        let r = m.length();
        let theta = self.theta_rad(r)?;
        if r < 1e-300 {
            return Some(DVec3::Z);
        }
        let s = theta.sin() / r;
        Some(DVec3::new(m.x * s, m.y * s, theta.cos()))
    }

    /// Solid angle per unit of normalised image area at `theta_rad` off the axis,
    /// `sin θ / (r r')` (the pinhole's `cos³ θ`); a pixel subtends this divided by fx·fy.
    pub fn solid_angle_per_area(&self, theta_rad: f64) -> f64 {
        match self {
            Lens::Pinhole => theta_rad.cos().powi(3),
            Lens::KannalaBrandt { .. } => {
                if theta_rad < 1e-6 {
                    return 1.0;
                }
                theta_rad.sin() / (self.radius(theta_rad) * self.dradius_dtheta(theta_rad))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equidistant_images_the_angle() {
        let l = Lens::EQUIDISTANT;
        for deg in [0.0, 10.0, 45.0, 60.0, 80.0, 88.0] {
            let t = f64::to_radians(deg);
            let p = DVec3::new(t.sin() * 0.6, t.sin() * 0.8, t.cos()) * 3.0;
            let m = l.project(p).unwrap();
            assert!((m.length() - t).abs() < 1e-12, "{deg}°");
            let d = l.unproject(m).unwrap();
            assert!((d - p.normalize()).length() < 1e-12, "{deg}°");
        }
        assert!(l.project(DVec3::new(1.0, 0.0, 0.0)).is_none());
        assert!(l.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
        assert!(l.unproject(DVec2::new(2.0, 0.0)).is_none());
    }

    #[test]
    fn bad_coefficients_are_refused() {
        for k in [
            [f64::NAN, 0.0, 0.0, 0.0],
            [0.0, 1e9, 0.0, 0.0],
            [-0.5, 0.0, 0.0, 0.0],
        ] {
            assert!(Lens::KannalaBrandt { k }.check().is_err(), "{k:?}");
        }
        assert!(Lens::from_model("fish", None).is_err());
        assert!(Lens::from_model("pinhole", Some([0.1, 0.0, 0.0, 0.0])).is_err());
        assert!(Lens::from_model("kannala_brandt", Some([-0.02, 0.003, 0.0, 0.0])).is_ok());
    }
}
