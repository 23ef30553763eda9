//! The energy figures of the commissioning report (issue 32, item 4): installed power, power
//! density, normalised power density, and the lighting energy numeric indicator LENI of
//! EN 15193-1 for the node's control (constant illuminance, presence detection, daylight).
//!
//! `LENI = W / A`, `W = W_L + W_P` (kWh/year), with
//!
//! * `W_L = Σ (P_n · F_C) · [(t_D · F_O · F_D) + (t_N · F_O)] / 1000`,
//! * `W_P = Σ P_pc · [t_y − (t_D + t_N)] / 1000 + W_em` (standby of the gear and the node in
//!   the hours the lighting is not operated; no emergency lighting charged, `W_em = 0`).
//!
//! The factors are in [`Assumptions`], each with where it comes from (docs/report.md).

use serde::Serialize;

use super::daylight_factor::DaylightSupply;
use super::daylight_year::DaylightYear;
use crate::control::{DEFAULT_EFFICACY_LM_PER_W, DEFAULT_STANDBY_W};

/// EN 15193-1's default annual daylight-time operating hours of an office, h.
pub const OFFICE_T_D_H: f64 = 2250.0;
/// EN 15193-1's default annual non-daylight-time operating hours of an office, h.
pub const OFFICE_T_N_H: f64 = 250.0;
/// Hours in a year (EN 15193-1's `t_y`), h.
pub const YEAR_H: f64 = 8760.0;
/// The occupancy dependency factor for automatic presence detection in an office:
/// EN 15193-1's `F_OC` for automatic on / automatic off (0.90), with the absence factor at
/// `F_A = 0.2`, where `F_O = F_OC` (the room's own absence is not known).
pub const PRESENCE_F_O: f64 = 0.90;

/// The factors and hours LENI rests on, each with its source.
#[derive(Debug, Clone, Serialize)]
pub struct Assumptions {
    /// Daylight-time operating hours, h.
    pub t_d_h: f64,
    /// Non-daylight-time operating hours, h.
    pub t_n_h: f64,
    /// Hours in a year, h.
    pub t_y_h: f64,
    /// Constant illuminance factor.
    pub f_c: f64,
    /// How `f_c` is computed.
    pub f_c_source: String,
    /// Occupancy dependency factor.
    pub f_o: f64,
    /// Where `f_o` comes from.
    pub f_o_source: String,
    /// Daylight dependency factor.
    pub f_d: f64,
    /// Where `f_d` comes from.
    pub f_d_source: String,
    /// Parasitic (standby) power per luminaire, W.
    pub standby_w_per_luminaire: f64,
    /// Hours the standby is drawn (`t_y − t_D − t_N`), h.
    pub standby_h: f64,
    /// Emergency charging energy, kWh/year.
    pub emergency_kwh: f64,
}

/// The energy figures.
#[derive(Debug, Clone, Serialize)]
pub struct Energy {
    /// Installed power at full output, W.
    pub installed_w: f64,
    /// Floor area, m².
    pub floor_area_m2: f64,
    /// Installed power per floor area, W/m² (`None`: no floor area).
    pub w_per_m2: Option<f64>,
    /// Power density per 100 lx of the maintained mean illuminance, W/m²/100 lx.
    pub w_per_m2_per_100lx: Option<f64>,
    /// The maintained mean `w_per_m2_per_100lx` is taken against, lx.
    pub em_lx: Option<f64>,
    /// Which grid `em_lx` is the mean of.
    pub em_basis: String,
    /// Lighting energy `W_L`, kWh/year.
    pub w_l_kwh: f64,
    /// Parasitic energy `W_P`, kWh/year.
    pub w_p_kwh: f64,
    /// LENI, kWh/(m²·year) (`None`: see `not_computed`).
    pub leni_kwh_per_m2_year: Option<f64>,
    /// Why a figure is missing.
    pub not_computed: Option<String>,
    /// Some luminaire's power is the assumed efficacy's guess: the figures rest on it.
    pub power_assumed: bool,
    /// The warning to show with the figures when `power_assumed`.
    pub flag: Option<String>,
    /// The factors.
    pub assumptions: Assumptions,
    /// The desks' daylight factors from the image's daylight coefficients (null without them).
    pub daylight: Option<DaylightSupply>,
    /// The year of the node's daylight control `F_D` comes from (null without daylight
    /// coefficients).
    pub daylight_year: Option<DaylightYear>,
}

/// What the energy figures are computed from.
pub struct EnergyInput<'a> {
    /// Each luminaire's rated power at full output, W.
    pub powers_w: &'a [f64],
    /// Some power is the assumed efficacy's guess.
    pub power_assumed: bool,
    /// Floor area, m².
    pub floor_area_m2: f64,
    /// Maintained mean illuminance and which grid it is of.
    pub em: Option<(f64, String)>,
    /// Maintenance factor.
    pub maintenance_factor: f64,
    /// The daylight factors at the desk sensors, when the image holds daylight coefficients.
    pub daylight: Option<DaylightSupply>,
    /// The node's daylight control over a year ([`super::daylight_year`]), when computed.
    pub daylight_year: Option<DaylightYear>,
}

/// The default office assumptions for a maintenance factor and the daylight known.
pub fn office_assumptions(
    mf: f64,
    daylight: Option<&DaylightSupply>,
    year: Option<&DaylightYear>,
) -> Assumptions {
    let (f_d, f_d_source) = match (daylight, year) {
        (Some(d), Some(y)) => {
            // the desk sensors the year holds at the target (every sensor when none is on a desk)
            let any_desk = d.sensors.iter().any(|s| s.desk.is_some());
            let (lo, hi) = d
                .sensors
                .iter()
                .filter(|s| s.desk.is_some() || !any_desk)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
                    (a.min(s.d_pct), b.max(s.d_pct))
                });
            let range = if d.sensors.is_empty() {
                "no desk sensor".to_string()
            } else {
                format!("daylight factor {lo:.2}-{hi:.2} % at the desk sensors (a lower bound)")
            };
            (
                y.f_d,
                format!(
                    "the node's daylight-responsive control ({:.2} m² of window, latitude \
                     {:.1}°, {range}), computed {}; {:.0} of the {:.0} working hours in \
                     daylight",
                    d.window_area_m2,
                    d.latitude_deg,
                    y.method,
                    y.daylight_hours_h,
                    y.working_hours_h
                ),
            )
        }
        (Some(_), None) => (
            1.0,
            "the image holds daylight coefficients but the year of its control could not be \
             computed: F_D = 1 (no daylight saving counted)"
                .into(),
        ),
        (None, _) => (
            1.0,
            "no daylight supply known (no room plan windows in the image): F_D = 1".into(),
        ),
    };
    Assumptions {
        t_d_h: OFFICE_T_D_H,
        t_n_h: OFFICE_T_N_H,
        t_y_h: YEAR_H,
        f_c: (1.0 + mf) / 2.0,
        f_c_source: format!(
            "constant illuminance control over a maintenance cycle: F_C = (1 + MF)/2 = \
             (1 + {mf:.2})/2"
        ),
        f_o: PRESENCE_F_O,
        f_o_source: "EN 15193-1 occupancy factor F_OC for automatic presence detection \
                     (automatic on / automatic off) in an office, absence factor F_A = 0.2 \
                     (so F_O = F_OC)"
            .into(),
        f_d,
        f_d_source,
        standby_w_per_luminaire: DEFAULT_STANDBY_W,
        standby_h: YEAR_H - OFFICE_T_D_H - OFFICE_T_N_H,
        emergency_kwh: 0.0,
    }
}

fn positive(v: f64) -> Option<f64> {
    (v.is_finite() && v > 0.0).then_some(v)
}

/// The energy figures of an installation.
pub fn energy(input: &EnergyInput<'_>) -> Energy {
    let a = office_assumptions(
        input.maintenance_factor,
        input.daylight.as_ref(),
        input.daylight_year.as_ref(),
    );
    let installed_w: f64 = input.powers_w.iter().filter(|p| p.is_finite()).sum();
    let hours_h = a.t_d_h * a.f_o * a.f_d + a.t_n_h * a.f_o;
    let w_l_kwh = installed_w * a.f_c * hours_h / 1000.0;
    let n = input.powers_w.len() as f64;
    let w_p_kwh = n * a.standby_w_per_luminaire * a.standby_h / 1000.0 + a.emergency_kwh;
    let area = positive(input.floor_area_m2);
    let w_per_m2 = area.map(|m2| installed_w / m2);
    let em_lx = input.em.as_ref().and_then(|(e, _)| positive(*e));
    let not_computed = if area.is_none() {
        Some("no floor area".to_string())
    } else if input.powers_w.is_empty() {
        Some("no luminaires".to_string())
    } else {
        None
    };
    Energy {
        installed_w,
        floor_area_m2: input.floor_area_m2,
        w_per_m2,
        w_per_m2_per_100lx: w_per_m2.zip(em_lx).map(|(d, e)| d / (e / 100.0)),
        em_lx,
        em_basis: input
            .em
            .as_ref()
            .map_or_else(|| "no maintained mean".into(), |(_, b)| b.clone()),
        w_l_kwh,
        w_p_kwh,
        leni_kwh_per_m2_year: area
            .filter(|_| not_computed.is_none())
            .map(|m2| (w_l_kwh + w_p_kwh) / m2),
        not_computed,
        power_assumed: input.power_assumed,
        flag: input.power_assumed.then(|| {
            format!(
                "rests on an assumed efficacy of {DEFAULT_EFFICACY_LM_PER_W} lm/W: a \
                 photometry file gives no wattage"
            )
        }),
        assumptions: a,
        daylight: input.daylight.clone(),
        daylight_year: input.daylight_year.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(powers_w: &[f64], floor_area_m2: f64) -> EnergyInput<'_> {
        EnergyInput {
            powers_w,
            power_assumed: false,
            floor_area_m2,
            em: Some((500.0, "room".into())),
            maintenance_factor: 0.8,
            daylight: None,
            daylight_year: None,
        }
    }

    #[test]
    fn render_energy_of_four_40_w_luminaires_on_20_m2_by_hand() {
        let e = energy(&input(&[40.0; 4], 20.0));
        // 160 W · 0.9 · (2250 · 0.9 + 250 · 0.9) h = 324 kWh; 4 · 0.3 W · 6260 h = 7.512 kWh
        assert!((e.w_l_kwh - 324.0).abs() < 1e-9, "{e:?}");
        assert!((e.w_p_kwh - 7.512).abs() < 1e-9, "{e:?}");
        let leni = e.leni_kwh_per_m2_year.expect("computed");
        assert!((leni - 331.512 / 20.0).abs() < 1e-9);
        assert_eq!(e.w_per_m2, Some(8.0));
        assert!((e.w_per_m2_per_100lx.unwrap() - 1.6).abs() < 1e-12);
        assert!(e.assumptions.f_d_source.contains("F_D = 1"));
    }

    #[test]
    fn render_energy_without_floor_area_is_not_computed() {
        let e = energy(&input(&[40.0], 0.0));
        assert_eq!(e.leni_kwh_per_m2_year, None);
        assert_eq!(e.w_per_m2, None);
        assert_eq!(e.not_computed.as_deref(), Some("no floor area"));
        let e = energy(&input(&[], 10.0));
        assert_eq!(e.leni_kwh_per_m2_year, None);
    }
}
