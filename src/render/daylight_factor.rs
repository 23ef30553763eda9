//! The daylight factor at the desk sensors from the image's daylight-coefficient section
//! ([`crate::store::daylight`]), under the CIE overcast sky: `D = E_in / E_out`, `E_in = Σ_j
//! c_j L_j` over the 145 Tregenza patches and the ground column, `E_out` the unobstructed
//! horizontal illuminance of the same sky (the Tregenza sum `Σ_j L_j Ω_j,projected`, so that a
//! receiver seeing the whole sky unobstructed reads exactly 100 %).
//!
//! **What D covers.** The section's coefficients are *boundary* coefficients: the sky through the
//! room plan's windows plus its reflections off the surfaces the camera does not see, with the
//! seen surfaces held dark (their light is measured at run time). The internally reflected
//! component off the seen surfaces is therefore not in D: it is a lower bound of the daylight
//! factor, and any daylight saving computed from it errs toward less saving.
//!
//! **F_D.** EN 15193-1's daylight supply method turns D into the daylight dependency factor
//! through its tables (daylight availability classes, a supply factor per class and latitude, a
//! control factor per control type). Those tables are not among this build's sources, so F_D is
//! computed by the hourly route instead, from these daylight factors and the node's own
//! controller over a year ([`super::daylight_year`]).

use serde::Serialize;

use crate::image_geometry::Room;
use crate::sky::{PATCH_COUNT, SkyModel, patches};
use crate::store::DaylightCoefficients;
use crate::store::daylight::COLUMNS;

/// The CIE overcast sky (Moon and Spencer, the daylight factor's sky) as the section's columns:
/// each Tregenza patch's luminance for a zenith luminance of 1 cd/m², and the ground's
/// `ρ_g E_out / π`; with `E_out`, lx.
pub fn overcast_columns(ground_rho: f64) -> ([f64; COLUMNS], f64) {
    let sky = SkyModel::Overcast1942;
    let mut cols = [0.0; COLUMNS];
    let mut e_out_lx = 0.0;
    for (c, p) in cols.iter_mut().zip(patches()) {
        *c = sky.relative_luminance(p.centre(), [0.0, 0.0, 1.0]);
        e_out_lx += *c * p.projected_solid_angle_sr;
    }
    cols[PATCH_COUNT] = ground_rho * e_out_lx / std::f64::consts::PI;
    (cols, e_out_lx)
}

/// The daylight factor (a fraction, not percent) of a receiver with coefficients `c` (lx per
/// cd/m², the section's columns), under the overcast sky with ground reflectance `ground_rho`.
pub fn daylight_factor(c: impl Fn(usize) -> f64, ground_rho: f64) -> f64 {
    let (cols, e_out_lx) = overcast_columns(ground_rho);
    let e_in_lx: f64 = cols.iter().enumerate().map(|(j, l)| c(j) * l).sum();
    e_in_lx / e_out_lx
}

/// One desk sensor's daylight factor.
#[derive(Debug, Clone, Serialize)]
pub struct SensorDaylight {
    /// Sensor id.
    pub sensor: u32,
    /// The desk it lies on, if any.
    pub desk: Option<u32>,
    /// Daylight factor, percent (a lower bound: see the module).
    pub d_pct: f64,
}

/// The daylight the image's section says, for the energy figures.
#[derive(Debug, Clone, Serialize)]
pub struct DaylightSupply {
    /// Site latitude, degrees north.
    pub latitude_deg: f64,
    /// Glazed area the coefficients go through, m².
    pub window_area_m2: f64,
    /// Per desk sensor.
    pub sensors: Vec<SensorDaylight>,
    /// What the daylight factors cover.
    pub scope: &'static str,
}

/// What the daylight factors cover, as the report states it.
pub const SCOPE: &str = "CIE overcast sky (Moon and Spencer), D = E_in/E_out at each desk sensor from the image's daylight coefficients: the sky through the room plan's windows and its reflections off the surfaces the camera does not see; the reflections off the seen surfaces are measured at run time and not in the image, so D is a lower bound";

/// The desk sensors' daylight factors, `None` when the image has no daylight section.
pub fn of_image(section: Option<&DaylightCoefficients<'_>>, room: &Room) -> Option<DaylightSupply> {
    let d = section?;
    let sensors = room
        .sensors
        .iter()
        .enumerate()
        .map(|(s, rs)| {
            let (x, y) = (rs.position_m.x, rs.position_m.y);
            let desk = room
                .desks
                .iter()
                .find(|k| (k.x_m[0]..=k.x_m[1]).contains(&x) && (k.y_m[0]..=k.y_m[1]).contains(&y))
                .map(|k| k.id);
            SensorDaylight {
                sensor: rs.id,
                desk,
                d_pct: 100.0 * daylight_factor(|j| d.sensor_lx(s, j), d.ground_rho),
            }
        })
        .collect();
    Some(DaylightSupply {
        latitude_deg: d.latitude_deg,
        window_area_m2: d.window_area_m2,
        sensors,
        scope: SCOPE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unobstructed_horizontal_receiver_reads_100_percent() {
        // coefficients of a horizontal receiver under the open sky: each patch's projected
        // solid angle, no ground
        let proj: Vec<f64> = patches().map(|p| p.projected_solid_angle_sr).collect();
        let d = daylight_factor(|j| proj.get(j).copied().unwrap_or(0.0), 0.2);
        assert!((d - 1.0).abs() < 1e-12, "{d}");
        // E_out of the Tregenza sum against the closed form 7π/9 L_z of the overcast sky
        let (_, e_out) = overcast_columns(0.2);
        let closed = 7.0 * std::f64::consts::PI / 9.0;
        assert!((e_out / closed - 1.0).abs() < 0.01, "{e_out} vs {closed}");
    }

    #[test]
    fn a_receiver_seeing_the_sky_above_36_degrees_matches_the_closed_form() {
        // a horizontal receiver at the bottom of a light well that shows it the sky above
        // altitude α = 36° (three Tregenza bands cut off): under L = L_z (1 + 2 sin h)/3,
        // E = (2π L_z/3) [(1 − sin² α)/2 + 2 (1 − sin³ α)/3], D = E / (7π L_z/9)
        let alpha = 36f64.to_radians();
        let s = alpha.sin();
        let closed =
            (2.0 / 3.0) * ((1.0 - s * s) / 2.0 + 2.0 * (1.0 - s * s * s) / 3.0) / (7.0 / 9.0);
        let c: Vec<f64> = patches()
            .map(|p| {
                if p.altitude_min_rad >= alpha - 1e-9 {
                    p.projected_solid_angle_sr
                } else {
                    0.0
                }
            })
            .collect();
        let d = daylight_factor(|j| c.get(j).copied().unwrap_or(0.0), 0.2);
        assert!((d / closed - 1.0).abs() < 0.01, "{d} vs {closed}");
        // the ground column: a receiver facing down on open ground sees ρ_g E_out / π over
        // π sr of projected solid angle: D = ρ_g
        let ground = daylight_factor(
            |j| {
                if j == PATCH_COUNT {
                    std::f64::consts::PI
                } else {
                    0.0
                }
            },
            0.2,
        );
        assert!((ground - 0.2).abs() < 1e-12, "{ground}");
    }
}
