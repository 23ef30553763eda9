//! Every position the sun takes at a site over a year, as a grid of declination × hour angle:
//! the sun's path on a given day is a row of the grid (its declination), the time of day a
//! column (its hour angle), so a grid over the year's declinations and the day's hour angles
//! holds every sun the site will see, whatever the date.
//!
//! Commissioning computes the sun's direct light through the room plan's windows at each
//! grid position above the horizon (`crate::daylight_section`); at run time the frame's sun
//! ([`super::sun_position`]: its declination and hour angle) falls between four positions, and
//! its light is their bilinear blend ([`SunGrid::weights`]). The blend blurs a sun patch's edge
//! over one step (half an hour, a twelfth of the year's declinations): a receiver near the
//! edge reads between lit and unlit, and the spread of the four positions says by how much.

use super::sun::{horizontal_of_equatorial, sky_direction};
use core::f64::consts::PI;
use libm::{acos, ceil, tan};
use serde::{Deserialize, Serialize};

const DEG: f64 = PI / 180.0;

/// The obliquity of the ecliptic: the sun's declination stays within ± this, rad.
pub const OBLIQUITY_RAD: f64 = 23.44 * DEG;

/// Declination rows of the grid: solstice to solstice in six steps of 7.8° (about a month near
/// the equinoxes, where the declination changes fastest).
pub const DECLINATIONS: u16 = 7;

/// The grid's hour-angle step: half an hour, 7.5°.
pub const HOUR_STEP_RAD: f64 = 7.5 * DEG;

/// Most positions a stored grid may have (a check on a section read from flash).
pub const MAX_POSITIONS: usize = 4096;

/// A grid of sun positions: `declinations` rows from `declination0_rad` by
/// `declination_step_rad`, `hours` columns from `hour0_rad` by `hour_step_rad`; position
/// `k = row · hours + column`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SunGrid {
    /// The first row's declination, rad.
    pub declination0_rad: f64,
    /// Between rows, rad (> 0).
    pub declination_step_rad: f64,
    /// Rows.
    pub declinations: u16,
    /// The first column's hour angle, rad.
    pub hour0_rad: f64,
    /// Between columns, rad (> 0).
    pub hour_step_rad: f64,
    /// Columns.
    pub hours: u16,
}

impl SunGrid {
    /// The grid of a site at `latitude_deg`: the year's declinations, and the hour angles
    /// between the longest day's sunrise and sunset (every hour angle where the sun never
    /// sets).
    pub fn for_latitude(latitude_deg: f64) -> SunGrid {
        // the longest day's half-length: cos H = −tan φ tan δ at the solstice of φ's hemisphere
        let c = -tan(latitude_deg.abs() * DEG) * tan(OBLIQUITY_RAD);
        let half_day = if c <= -1.0 { PI } else { acos(c.min(1.0)) };
        let steps = ceil(half_day / HOUR_STEP_RAD - 1e-9).max(1.0);
        let hours = (2.0 * steps) as u16 + 1;
        SunGrid {
            declination0_rad: -OBLIQUITY_RAD,
            declination_step_rad: 2.0 * OBLIQUITY_RAD / f64::from(DECLINATIONS - 1),
            declinations: DECLINATIONS,
            hour0_rad: -steps * HOUR_STEP_RAD,
            hour_step_rad: HOUR_STEP_RAD,
            hours,
        }
    }

    /// Positions in the grid.
    pub fn positions(&self) -> usize {
        usize::from(self.declinations) * usize::from(self.hours)
    }

    /// Whether the grid is usable: finite, positive steps, at least one row and column, at
    /// most [`MAX_POSITIONS`] positions, declinations within ±90°.
    pub fn is_valid(&self) -> bool {
        let finite = [
            self.declination0_rad,
            self.declination_step_rad,
            self.hour0_rad,
            self.hour_step_rad,
        ]
        .iter()
        .all(|x| x.is_finite());
        let last = self.declination0_rad
            + self.declination_step_rad * f64::from(self.declinations.saturating_sub(1));
        finite
            && self.declination_step_rad > 0.0
            && self.hour_step_rad > 0.0
            && self.declinations > 0
            && self.hours > 0
            && self.positions() <= MAX_POSITIONS
            && self.declination0_rad >= -PI / 2.0
            && last <= PI / 2.0
    }

    /// The declination and hour angle of position k, rad.
    pub fn declination_hour_rad(&self, k: usize) -> (f64, f64) {
        let hours = usize::from(self.hours.max(1));
        let (row, column) = (k / hours, k % hours);
        (
            self.declination0_rad + self.declination_step_rad * row as f64,
            self.hour0_rad + self.hour_step_rad * column as f64,
        )
    }

    /// The sky-frame direction toward the sun at position k from latitude `latitude_deg`
    /// (geometric altitude), or `None` when it is below the horizon there.
    pub fn direction_sky(&self, k: usize, latitude_deg: f64) -> Option<[f64; 3]> {
        let (declination, hour) = self.declination_hour_rad(k);
        let (altitude, azimuth) = horizontal_of_equatorial(declination, hour, latitude_deg);
        (altitude > 0.0).then(|| sky_direction(altitude, azimuth))
    }

    /// The four positions around a sun at `declination_rad`, `hour_angle_rad` and their
    /// bilinear weights (summing to 1; a sun beyond the grid takes its edge).
    pub fn weights(&self, declination_rad: f64, hour_angle_rad: f64) -> [(usize, f64); 4] {
        let axis = |x: f64, x0: f64, step: f64, n: u16| -> (usize, usize, f64) {
            let last = f64::from(n.max(1) - 1);
            let f = ((x - x0) / step).clamp(0.0, last);
            let f = if f.is_finite() { f } else { 0.0 };
            let i = (f as usize).min(usize::from(n.max(1)) - 1);
            let j = (i + 1).min(usize::from(n.max(1)) - 1);
            (i, j, f - i as f64)
        };
        let (r0, r1, fr) = axis(
            declination_rad,
            self.declination0_rad,
            self.declination_step_rad,
            self.declinations,
        );
        let (c0, c1, fc) = axis(
            hour_angle_rad,
            self.hour0_rad,
            self.hour_step_rad,
            self.hours,
        );
        let h = usize::from(self.hours.max(1));
        [
            (r0 * h + c0, (1.0 - fr) * (1.0 - fc)),
            (r0 * h + c1, (1.0 - fr) * fc),
            (r1 * h + c0, fr * (1.0 - fc)),
            (r1 * h + c1, fr * fc),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::{parse_rfc3339, sun_position};

    #[test]
    fn the_grid_spans_the_year_and_the_longest_day() {
        // Zurich, 47.4° N: the June solstice's day is 15 h 56 min by the geometric horizon,
        // half of it 119.6°: 16 steps of 7.5°, 33 columns
        let g = SunGrid::for_latitude(47.4);
        assert!(g.is_valid());
        assert_eq!((g.declinations, g.hours), (7, 33));
        assert!((g.hour0_rad / DEG + 120.0).abs() < 1e-9);
        // the equator: 12 h days every day, 12 steps each side, 25 columns
        assert_eq!(SunGrid::for_latitude(0.0).hours, 25);
        // beyond the polar circle the sun does not set in June: every hour angle
        let polar = SunGrid::for_latitude(70.0);
        assert!((polar.hour0_rad / DEG + 180.0).abs() < 1e-9 && polar.hours == 49);
        // a corrupt grid
        let bad = SunGrid {
            hour_step_rad: f64::NAN,
            ..g
        };
        assert!(!bad.is_valid());
        assert!(
            !SunGrid {
                declinations: 4096,
                ..g
            }
            .is_valid()
        );
    }

    #[test]
    fn a_grid_position_is_the_sun_of_its_declination_and_hour() {
        // the sun on 2025-06-21 at 12:00 UTC over Zurich, rebuilt from its own declination and
        // hour angle through the grid's position arithmetic
        let t = parse_rfc3339("2025-06-21T12:00:00Z").expect("time");
        let sun = sun_position(t, 47.4, 8.5);
        let g = SunGrid {
            declination0_rad: sun.declination_rad,
            declination_step_rad: 0.1,
            declinations: 2,
            hour0_rad: sun.hour_angle_rad,
            hour_step_rad: 0.1,
            hours: 3,
        };
        let d = g.direction_sky(0, 47.4).expect("day");
        let want = sky_direction(sun.altitude_rad, sun.azimuth_rad);
        for (a, b) in d.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{d:?} {want:?}");
        }
        // at midnight the grid's sun is below the horizon
        let night = SunGrid { hour0_rad: PI, ..g };
        assert!(night.direction_sky(0, 47.4).is_none());
    }

    #[test]
    fn weights_are_bilinear_and_sum_to_one() {
        let g = SunGrid::for_latitude(47.4);
        // exactly on a position: its weight is 1
        let (d, h) = g.declination_hour_rad(3 * 33 + 10);
        let w = g.weights(d, h);
        let on: f64 = w
            .iter()
            .filter(|(k, _)| *k == 3 * 33 + 10)
            .map(|x| x.1)
            .sum();
        assert!((on - 1.0).abs() < 1e-9, "{w:?}");
        // a quarter of the way in hour, half in declination
        let w = g.weights(d + 0.5 * g.declination_step_rad, h + 0.25 * g.hour_step_rad);
        let want = [
            (3 * 33 + 10, 0.375),
            (3 * 33 + 11, 0.125),
            (4 * 33 + 10, 0.375),
            (4 * 33 + 11, 0.125),
        ];
        for ((k, x), (wk, wx)) in w.iter().zip(want) {
            assert_eq!(*k, wk);
            assert!((x - wx).abs() < 1e-9, "{w:?}");
        }
        // beyond the grid, or NaN: the edge, never an index out of range
        for (d, h) in [(1.0, 4.0), (-1.0, -4.0), (f64::NAN, f64::NAN)] {
            let w = g.weights(d, h);
            assert!(w.iter().all(|(k, _)| *k < g.positions()));
            assert!((w.iter().map(|x| x.1).sum::<f64>() - 1.0).abs() < 1e-9);
        }
    }
}
