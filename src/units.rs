//! Quantities whose validity is checked once, at construction, rather than at every use.
//!
//! Everywhere else plain `f64`/`f32` carry physical quantities, named after the quantity with
//! the unit as suffix (`e_lx`, `b_lm_per_m2`, `flux_lm`, `intensity_cd`): the name says the
//! unit (see the crate's conventions). This module is `no_std` and allocation-free.
//!
//! | quantity | symbol | unit | type |
//! |---|---|---|---|
//! | diffuse reflectance | ρ | 1, in [0, 1) | [`Reflectance`] |

use core::fmt;

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
    fn reflectance_displays_three_decimals() {
        extern crate std;
        use std::format;
        assert_eq!(
            format!("{}", Reflectance::new(0.5).unwrap_or(Reflectance::ZERO)),
            "0.500"
        );
    }
}
