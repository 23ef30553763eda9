//! DALI dimming curves: arc power level → relative light output. `no_std`, no allocation.
//!
//! * Logarithmic (IEC 62386-102, the standard curve): level 1..=254 gives
//!   `X(n) = 10^((n − 1) / (253/3) − 1) %`, from 0.1 % at level 1 to 100 % at 254, each step
//!   +2.77 %. Level 0 is off.
//! * Linear (IEC 62386-207, LED gear, device type 6): `X(n) = n / 254`.
//!
//! Level 255 is MASK: "no change", which is not a light output; [`ArcLevel::fraction`] answers
//! `None` for it and the caller keeps the previous state.

/// A dimming curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DimmingCurve {
    /// IEC 62386-102 logarithmic curve (the default in DALI).
    #[default]
    Logarithmic,
    /// IEC 62386-207 linear curve.
    Linear,
}

/// The ratio of two successive levels of the logarithmic curve, 10^(3/253).
const LOG_STEP: f64 = 1.027_679_533_455_985_8;

/// The logarithmic curve as a table: level n at `0.001 · LOG_STEP^(n − 1)`, built at compile
/// time (the run-time core and the control loop read it without a `pow` per level; the
/// products drift from `10^((n−1)/(253/3) − 1) / 100` by under 1e-13 relative).
const LOGARITHMIC: [f64; 256] = {
    let mut t = [0.0; 256];
    let mut n = 1;
    let mut x = 0.001;
    while n <= 254 {
        t[n] = x;
        x *= LOG_STEP;
        n += 1;
    }
    t[254] = 1.0;
    t
};

/// A DALI arc power level, 0..=255.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct ArcLevel(pub u8);

impl ArcLevel {
    /// Off.
    pub const OFF: Self = Self(0);
    /// Full output.
    pub const MAX: Self = Self(254);
    /// MASK: no change.
    pub const MASK: Self = Self(255);

    /// Relative light output in [0, 1] on `curve`; `None` for MASK (keep the previous level).
    pub fn fraction(self, curve: DimmingCurve) -> Option<f64> {
        match self.0 {
            0 => Some(0.0),
            255 => None,
            n => Some(match curve {
                DimmingCurve::Logarithmic => LOGARITHMIC[usize::from(n)],
                DimmingCurve::Linear => f64::from(n) / 254.0,
            }),
        }
    }

    /// The arc level whose output on `curve` is nearest to `fraction` (in [0, 1]; outside or
    /// not finite: `None`). 0 is off; any light at all is at least level 1.
    pub fn nearest(fraction: f64, curve: DimmingCurve) -> Option<Self> {
        if !(fraction.is_finite() && (0.0..=1.0).contains(&fraction)) {
            return None;
        }
        if fraction == 0.0 {
            return Some(Self::OFF);
        }
        let n = match curve {
            // inverse of X(n): n = 1 + (253/3) (log10(100 x) + 1)
            DimmingCurve::Logarithmic => 1.0 + 253.0 / 3.0 * (libm::log10(100.0 * fraction) + 1.0),
            DimmingCurve::Linear => 254.0 * fraction,
        };
        Some(Self(libm::round(n).clamp(1.0, 254.0) as u8))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logarithmic_curve_values() {
        // physics.md §10 G, in percent
        for (n, pct) in [
            (1u8, 0.1000),
            (2, 0.10277),
            (85, 0.99094),
            (128, 3.20574),
            (170, 10.09143),
            (229, 50.53093),
            (250, 89.65390),
            (254, 100.0),
        ] {
            let x = ArcLevel(n).fraction(DimmingCurve::Logarithmic).unwrap() * 100.0;
            assert!((x - pct).abs() < 5e-5 * pct.max(1.0), "level {n}: {x} %");
        }
        assert_eq!(ArcLevel::OFF.fraction(DimmingCurve::Logarithmic), Some(0.0));
        assert_eq!(ArcLevel::MASK.fraction(DimmingCurve::Logarithmic), None);
    }

    #[test]
    fn nearest_inverts_both_curves() {
        for curve in [DimmingCurve::Logarithmic, DimmingCurve::Linear] {
            for n in 0..=254u8 {
                let x = ArcLevel(n).fraction(curve).unwrap();
                assert_eq!(
                    ArcLevel::nearest(x, curve),
                    Some(ArcLevel(n)),
                    "{curve:?} {n}"
                );
            }
            assert_eq!(ArcLevel::nearest(1e-9, curve), Some(ArcLevel(1)));
            assert_eq!(ArcLevel::nearest(1.5, curve), None);
            assert_eq!(ArcLevel::nearest(f64::NAN, curve), None);
        }
    }

    #[test]
    fn the_table_is_the_formula() {
        for n in 1..=254u8 {
            let formula = libm::pow(10.0, (f64::from(n) - 1.0) / (253.0 / 3.0) - 1.0) / 100.0;
            let t = ArcLevel(n).fraction(DimmingCurve::Logarithmic).unwrap();
            assert!((t / formula - 1.0).abs() < 1e-13, "{n}: {t} vs {formula}");
        }
    }

    #[test]
    fn linear_curve_values() {
        assert!((ArcLevel(127).fraction(DimmingCurve::Linear).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(ArcLevel(254).fraction(DimmingCurve::Linear), Some(1.0));
        assert_eq!(ArcLevel::MASK.fraction(DimmingCurve::Linear), None);
    }

    #[test]
    fn each_log_step_is_2_77_percent() {
        for n in 1..253u8 {
            let a = ArcLevel(n).fraction(DimmingCurve::Logarithmic).unwrap();
            let b = ArcLevel(n + 1).fraction(DimmingCurve::Logarithmic).unwrap();
            assert!((b / a - 1.027_679).abs() < 1e-5);
        }
    }
}
