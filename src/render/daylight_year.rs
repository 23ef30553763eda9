//! EN 15193-1's daylight dependency factor `F_D` of the node's own control, by the hourly
//! route: a year of working hours at the site, the daylight at each desk from its daylight
//! factor under an overcast sky, and the least-power plan (`control::plan`, the node's
//! controller) with and without that daylight.
//!
//! * **The sky.** Every daylight hour is overcast: the CIE overcast sky, whose horizontal
//!   illuminance at a solar altitude `γ_s` is Krochmann's `E_h = 300 + 21 000 sin γ_s` lx (DIN
//!   5034-2's overcast-sky daylight availability). Clear and intermediate hours give more
//!   daylight than this, so the saving counted is a lower bound (no weather file is held).
//! * **The desk.** `E_day,k = D_k · E_h`, with `D_k` the daylight factor from the image's
//!   daylight coefficients ([`super::daylight_factor`], itself a lower bound).
//! * **The hours.** Every day of a year, 08:00-18:00 local mean solar time (EN 15193-1's
//!   office: `t_D + t_N` = 2500 h, 250 days of 10 hours; the day's weather does not depend on
//!   the weekday, so the ratio below is the same over 250 days or 365). A daylight hour is one
//!   at whose middle the sun stands above the horizon.
//! * **`F_D`** = Σ over the daylight hours of the plan's power with the daylight / Σ of the
//!   plan's power without it. The constant-illuminance saving (`F_C`) is not in it: both plans
//!   hold the same target.

use serde::Serialize;

use crate::control::{ControlError, Demand, Plant, plan};
use crate::sky::sun::sun_position;
use crate::sky::time::UnixTime;

/// The working day in local mean solar time, hours: 08:00-18:00.
pub const WORKING_HOURS: (u32, u32) = (8, 18);
/// The reference year's days.
pub const DAYS: u32 = 365;
/// 2026-01-01T00:00:00Z, s since the epoch (the reference year; any non-leap year gives the
/// same sun within a few hundredths of a degree).
const YEAR_START_S: i64 = 1_767_225_600;

/// The horizontal illuminance of the CIE overcast sky at a solar altitude, lx (Krochmann:
/// `300 + 21 000 sin γ_s`); 0 with the sun below the horizon.
pub fn overcast_horizontal_lx(altitude_rad: f64) -> f64 {
    if altitude_rad > 0.0 {
        300.0 + 21_000.0 * altitude_rad.sin()
    } else {
        0.0
    }
}

/// What the year is computed from.
pub struct YearInput<'a> {
    /// The room as the controller sees it.
    pub plant: Plant<'a>,
    /// Target illuminance per desk, lx.
    pub target_lx: &'a [f64],
    /// Daylight factor per desk (a fraction).
    pub daylight_factor: &'a [f64],
    /// Site latitude, degrees north.
    pub latitude_deg: f64,
    /// Site longitude, degrees east.
    pub longitude_deg: f64,
}

/// The year's result.
#[derive(Debug, Clone, Serialize)]
pub struct DaylightYear {
    /// The daylight dependency factor.
    pub f_d: f64,
    /// Working hours with the sun up, h.
    pub daylight_hours_h: f64,
    /// Working hours in the year, h.
    pub working_hours_h: f64,
    /// The plans' energy over the daylight hours without daylight, kWh.
    pub without_daylight_kwh: f64,
    /// ... and with it, kWh.
    pub with_daylight_kwh: f64,
    /// How it was computed, as the report states it.
    pub method: &'static str,
}

/// The method, as the report states it.
pub const METHOD: &str = "hourly over a year of working hours (08:00-18:00 local mean solar time at the site), every daylight hour under the CIE overcast sky (Krochmann's E_h = 300 + 21000 sin γ_s lx, DIN 5034-2), each desk's daylight D·E_h from the image's daylight coefficients, the node's least-power plan with and without it: F_D = energy with / energy without over the daylight hours. Clear hours give more daylight, so the saving is a lower bound";

/// The instant of hour `h` (from midnight, local mean solar time) of day `day` of the
/// reference year at `longitude_deg`.
fn instant(day: u32, h: f64, longitude_deg: f64) -> UnixTime {
    let utc_h = h - longitude_deg / 15.0;
    UnixTime::from_seconds(YEAR_START_S + i64::from(day) * 86_400 + (utc_h * 3600.0).round() as i64)
}

/// `F_D` of the node's control over the reference year (see the module).
pub fn daylight_dependency(input: &YearInput<'_>) -> Result<DaylightYear, ControlError> {
    let kd = input.plant.desks;
    if input.daylight_factor.len() != kd || input.target_lx.len() != kd {
        return Err(ControlError::Shape);
    }
    if input
        .daylight_factor
        .iter()
        .any(|d| !d.is_finite() || *d < 0.0)
    {
        return Err(ControlError::Input("daylight factor"));
    }
    let none = vec![0.0; kd];
    let dark = plan(
        &input.plant,
        &Demand {
            target_lx: input.target_lx,
            daylight_lx: &none,
            uniformity: None,
        },
    )?
    .report
    .power_w;
    let mut daylight_lx = vec![0.0; kd];
    let (mut with_wh, mut day_h, mut all_h) = (0.0, 0.0, 0.0);
    for day in 0..DAYS {
        for hour in WORKING_HOURS.0..WORKING_HOURS.1 {
            all_h += 1.0;
            let t = instant(day, f64::from(hour) + 0.5, input.longitude_deg);
            let sun = sun_position(t, input.latitude_deg, input.longitude_deg);
            let e_h = overcast_horizontal_lx(sun.altitude_rad);
            if e_h <= 0.0 {
                continue;
            }
            day_h += 1.0;
            for (e, d) in daylight_lx.iter_mut().zip(input.daylight_factor) {
                *e = d * e_h;
            }
            let p = plan(
                &input.plant,
                &Demand {
                    target_lx: input.target_lx,
                    daylight_lx: &daylight_lx,
                    uniformity: None,
                },
            )?;
            with_wh += p.report.power_w;
        }
    }
    // without daylight every daylight hour draws the same plan's power
    let without_wh = dark * day_h;
    Ok(DaylightYear {
        f_d: if without_wh > 0.0 {
            with_wh / without_wh
        } else {
            1.0
        },
        daylight_hours_h: day_h,
        working_hours_h: all_h,
        without_daylight_kwh: without_wh / 1000.0,
        with_daylight_kwh: with_wh / 1000.0,
        method: METHOD,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::LuminairePower;
    use crate::dali::DimmingCurve;

    fn one_desk(d: f64, latitude_deg: f64) -> DaylightYear {
        // one luminaire giving exactly the target at full, 40 W, no standby, dimmable to 0.1 %
        let power = [LuminairePower {
            full_w: 40.0,
            standby_w: 0.0,
            min_arc: 1,
        }];
        let response = [500.0];
        daylight_dependency(&YearInput {
            plant: Plant {
                desks: 1,
                luminaires: 1,
                response_lx: &response,
                power: &power,
                curve: DimmingCurve::Logarithmic,
            },
            target_lx: &[500.0],
            daylight_factor: &[d],
            latitude_deg,
            longitude_deg: 8.5,
        })
        .expect("a valid year")
    }

    #[test]
    fn krochmanns_overcast_sky_at_30_degrees_gives_10800_lx() {
        assert!((overcast_horizontal_lx(30f64.to_radians()) - 10_800.0).abs() < 1e-9);
        assert_eq!(overcast_horizontal_lx(-0.1), 0.0);
    }

    #[test]
    fn no_daylight_saves_nothing() {
        let y = one_desk(0.0, 47.4);
        assert_eq!(y.f_d, 1.0);
        assert_eq!(y.working_hours_h, 3650.0);
    }

    #[test]
    fn one_desk_matches_the_continuous_closed_form() {
        // Independent reference: the output fraction max(0, 1 − D E_h / E_t) per hour, with
        // the sun from Cooper's declination and the hour angle of local mean solar time (no
        // equation of time: ±16 min, a few tenths of a percent of F_D over a year); the plan
        // rounds its output up to the next DALI arc level (≤ 2.8 % more). Measured: within
        // 0.004-0.009 of it at the four (D, latitude) pairs.
        for (d, lat) in [(0.02, 47.4), (0.05, 47.4), (0.01, 60.0), (0.03, 10.0)] {
            let phi = f64::to_radians(lat);
            let (mut sum, mut n) = (0.0, 0.0);
            for day in 0..365 {
                let decl = f64::to_radians(23.45)
                    * (std::f64::consts::TAU * (284.0 + f64::from(day) + 1.0) / 365.0).sin();
                for hour in 8..18 {
                    let omega = f64::to_radians(15.0 * (f64::from(hour) + 0.5 - 12.0));
                    let sin_alt = phi.sin() * decl.sin() + phi.cos() * decl.cos() * omega.cos();
                    if sin_alt <= 0.0 {
                        continue;
                    }
                    let e_h = 300.0 + 21_000.0 * sin_alt;
                    sum += (1.0 - d * e_h / 500.0).max(0.0);
                    n += 1.0;
                }
            }
            let closed = sum / n;
            let y = one_desk(d, lat);
            assert!(
                (y.f_d - closed).abs() < 0.015,
                "D {d} at {lat}°: F_D {} vs closed form {closed}",
                y.f_d
            );
        }
    }

    #[test]
    fn more_daylight_never_costs_more() {
        let mut last = 1.0;
        for d in [0.0, 0.005, 0.01, 0.02, 0.04, 0.08] {
            let f = one_desk(d, 47.4).f_d;
            assert!(f <= last + 1e-12, "D {d}: {f} > {last}");
            last = f;
        }
        assert!(last < 0.2, "D 8 % leaves {last}");
        // the far north has fewer daylight working hours
        assert!(one_desk(0.02, 65.0).daylight_hours_h < one_desk(0.02, 40.0).daylight_hours_h);
    }

    #[test]
    fn a_daylight_factor_that_is_not_a_number_is_refused() {
        let power = [LuminairePower {
            full_w: 40.0,
            standby_w: 0.0,
            min_arc: 1,
        }];
        let e = daylight_dependency(&YearInput {
            plant: Plant {
                desks: 1,
                luminaires: 1,
                response_lx: &[500.0],
                power: &power,
                curve: DimmingCurve::Logarithmic,
            },
            target_lx: &[500.0],
            daylight_factor: &[f64::NAN],
            latitude_deg: 47.4,
            longitude_deg: 8.5,
        });
        assert!(matches!(e, Err(ControlError::Input(_))));
    }
}
