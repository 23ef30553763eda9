//! Photometric quantities as newtypes whose constructors and accessors say the unit
//! (`Illuminance::from_lux(x).as_lux()`), so a value never crosses a module boundary without it.
//!
//! Inside hot loops plain `f64`/`f32` slices are used, named after the quantity with the unit as
//! suffix (`e_lx`, `b_lm_per_m2`). This module is `no_std` and allocation-free.
//!
//! | quantity | symbol | unit | type |
//! |---|---|---|---|
//! | illuminance | E | lx = lm/m² (incident) | [`Illuminance`] |
//! | luminous exitance (radiosity) | B | lm/m² (leaving) | [`Exitance`] |
//! | luminous flux | Φ | lm | [`LuminousFlux`] |
//! | luminous intensity | I | cd = lm/sr | [`LuminousIntensity`] |
//! | luminance | L | cd/m² | [`Luminance`] |
//! | diffuse reflectance | ρ | 1, in [0, 1) | [`Reflectance`] |

use core::fmt;

macro_rules! quantity {
    ($(#[$doc:meta])* $name:ident, $from:ident, $as:ident, $unit:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
        pub struct $name(f64);

        impl $name {
            /// Zero of this quantity.
            pub const ZERO: Self = Self(0.0);

            #[doc = concat!("From a value in ", $unit, ".")]
            pub const fn $from(value: f64) -> Self {
                Self(value)
            }

            #[doc = concat!("The value in ", $unit, ".")]
            pub const fn $as(self) -> f64 {
                self.0
            }

            /// True when the value is neither NaN nor infinite.
            pub fn is_finite(self) -> bool {
                self.0.is_finite()
            }
        }

        impl core::ops::Add for $name {
            type Output = Self;
            fn add(self, rhs: Self) -> Self {
                Self(self.0 + rhs.0)
            }
        }

        impl core::ops::Mul<f64> for $name {
            type Output = Self;
            fn mul(self, rhs: f64) -> Self {
                Self(self.0 * rhs)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                if let Some(p) = f.precision() {
                    write!(f, "{:.*} {}", p, self.0, $unit)
                } else {
                    write!(f, "{} {}", self.0, $unit)
                }
            }
        }
    };
}

quantity!(
    /// Illuminance: luminous flux incident per unit area.
    Illuminance, from_lux, as_lux, "lx"
);
quantity!(
    /// Luminous exitance: luminous flux leaving a surface per unit area (radiosity B).
    Exitance, from_lm_per_m2, as_lm_per_m2, "lm/m²"
);
quantity!(
    /// Luminous flux.
    LuminousFlux, from_lm, as_lm, "lm"
);
quantity!(
    /// Luminous intensity.
    LuminousIntensity, from_cd, as_cd, "cd"
);
quantity!(
    /// Luminance.
    Luminance, from_cd_per_m2, as_cd_per_m2, "cd/m²"
);

impl Luminance {
    /// Exitance of a Lambertian surface of this luminance: `B = π L`.
    pub fn lambertian_exitance(self) -> Exitance {
        Exitance(core::f64::consts::PI * self.0)
    }
}

impl Exitance {
    /// Luminance of a Lambertian surface with this exitance: `L = B / π`.
    pub fn lambertian_luminance(self) -> Luminance {
        Luminance(self.0 / core::f64::consts::PI)
    }
}

/// A diffuse (Lambertian) reflectance, validated to lie in `[0, 1)`.
///
/// A reflectance of 1 or more makes the radiosity system singular or divergent (a closed room
/// would amplify light without bound), so it is rejected at construction, never later.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct Reflectance(f64);

/// A reflectance outside `[0, 1)` or not finite.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("reflectance {0} is outside [0, 1): a diffuse reflectance must be at least 0 and below 1")]
pub struct ReflectanceError(pub f64);

impl Reflectance {
    /// Black.
    pub const ZERO: Self = Self(0.0);

    /// Validates `rho` in `[0, 1)`.
    pub fn new(rho: f64) -> Result<Self, ReflectanceError> {
        if rho.is_finite() && (0.0..1.0).contains(&rho) {
            Ok(Self(rho))
        } else {
            Err(ReflectanceError(rho))
        }
    }

    /// The value, dimensionless.
    pub const fn get(self) -> f64 {
        self.0
    }
}

impl fmt::Display for Reflectance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.3}", self.0)
    }
}

/// Degrees to radians.
pub fn deg_to_rad(deg: f64) -> f64 {
    deg * (core::f64::consts::PI / 180.0)
}

/// Radians to degrees.
pub fn rad_to_deg(rad: f64) -> f64 {
    rad * (180.0 / core::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflectance_range_is_half_open() {
        assert!(Reflectance::new(0.0).is_ok());
        assert!(Reflectance::new(0.99).is_ok());
        assert_eq!(Reflectance::new(1.0), Err(ReflectanceError(1.0)));
        assert!(Reflectance::new(-0.01).is_err());
        assert!(Reflectance::new(f64::NAN).is_err());
        assert!(Reflectance::new(f64::INFINITY).is_err());
    }

    #[test]
    fn lambertian_conversions_are_inverse() {
        let l = Luminance::from_cd_per_m2(1000.0);
        let b = l.lambertian_exitance();
        assert!((b.as_lm_per_m2() - 1000.0 * core::f64::consts::PI).abs() < 1e-9);
        assert!((b.lambertian_luminance().as_cd_per_m2() - 1000.0).abs() < 1e-9);
    }

    #[test]
    fn display_carries_unit() {
        extern crate std;
        use std::format;
        assert_eq!(format!("{:.1}", Illuminance::from_lux(412.345)), "412.3 lx");
        assert_eq!(format!("{}", LuminousFlux::from_lm(7913.0)), "7913 lm");
    }
}
