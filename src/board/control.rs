//! The `[control]` section of a board file: the lighting control's mode, targets, power model
//! and loop knobs. Every key is optional; unknown keys are errors.
//!
//! ```toml
//! [control]
//! mode = "constant-light"      # "off" (default) | "constant-light" | "daylight-harvesting"
//! target_lx = 500              # every desk (EN 12464-1 office work)
//! desk_targets_lx = { "3" = 750, "5" = 300 }   # by desk (sensor) id
//! rated_power_w = 60           # every luminaire at full; default: the photometry's wattage (flux / 120 lm/W without)
//! standby_power_w = 0.3
//! min_arc = 85                 # DALI physical minimum level
//! fade_steps_per_s = 20
//! dead_band = 0.05             # of the target
//! dim_hold_s = 60
//! daylight_rise_s = 30         # daylight filter time constants (rising, falling estimate)
//! daylight_fall_s = 10
//! min_saving = 0.03            # a new plan replaces levels that hold only if it saves this
//! uniformity = 0.6             # optional: every desk at least 0.6 of the mean
//! tick_s = 1
//! daylight_max_age_s = 60
//! vacant = "surrounding"       # a desk nobody is at (occupancy, after its hold): "surrounding"
//!                              # (EN 12464-1's immediate surrounding level, 500 → 300 lx) | "off"
//! ```
//!
//! What a BMS writes over Modbus (mode, targets) wins over the board and is persisted.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::camera::SectionError;
use crate::control::regulator::{Mode, Settings};
use crate::node::ControlOptions;

#[doc(hidden)]
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ControlToml {
    mode: Option<String>,
    target_lx: Option<f64>,
    #[serde(default)]
    desk_targets_lx: BTreeMap<String, f64>,
    rated_power_w: Option<f64>,
    standby_power_w: Option<f64>,
    min_arc: Option<u8>,
    fade_steps_per_s: Option<f64>,
    dead_band: Option<f64>,
    dim_hold_s: Option<f64>,
    daylight_rise_s: Option<f64>,
    daylight_fall_s: Option<f64>,
    min_saving: Option<f64>,
    uniformity: Option<f64>,
    tick_s: Option<f64>,
    daylight_max_age_s: Option<f64>,
    vacant: Option<String>,
}

fn within(name: &str, v: f64, lo: f64, hi: f64) -> Result<f64, SectionError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(SectionError(format!(
            "control.{name} {v} is outside {lo}..={hi}"
        )))
    }
}

/// The section, checked.
pub(crate) fn control(t: Option<ControlToml>) -> Result<ControlOptions, SectionError> {
    let t = t.unwrap_or_default();
    let d = ControlOptions::default();
    let s0 = Settings::default();
    let mode = match t.mode.as_deref() {
        None | Some("off") => Mode::Off,
        Some("constant-light") => Mode::ConstantLight,
        Some("daylight-harvesting") => Mode::DaylightHarvesting,
        Some(other) => {
            return Err(SectionError(format!(
                "control.mode {other:?}: use \"off\", \"constant-light\" or \"daylight-harvesting\""
            )));
        }
    };
    let target_lx = within(
        "target_lx",
        t.target_lx.unwrap_or(d.target_lx),
        0.0,
        10_000.0,
    )?;
    let mut desk_targets_lx = Vec::new();
    for (id, lx) in &t.desk_targets_lx {
        let id: u32 = id.parse().map_err(|_| {
            SectionError(format!("control.desk_targets_lx: {id:?} is not a desk id"))
        })?;
        desk_targets_lx.push((id, within("desk_targets_lx", *lx, 0.0, 10_000.0)?));
    }
    let standby_power_w = within(
        "standby_power_w",
        t.standby_power_w.unwrap_or(d.standby_power_w),
        0.0,
        100.0,
    )?;
    let rated_power_w = t
        .rated_power_w
        .map(|w| within("rated_power_w", w, standby_power_w.max(0.01), 10_000.0))
        .transpose()?;
    let min_arc = t.min_arc.unwrap_or(d.min_arc);
    if !(1..=254).contains(&min_arc) {
        return Err(SectionError(format!(
            "control.min_arc {min_arc} is outside 1..=254"
        )));
    }
    let loop_settings = Settings {
        fade_steps_per_s: within(
            "fade_steps_per_s",
            t.fade_steps_per_s.unwrap_or(s0.fade_steps_per_s),
            0.1,
            1000.0,
        )?,
        dead_band: within("dead_band", t.dead_band.unwrap_or(s0.dead_band), 0.0, 0.5)?,
        dim_hold_s: within(
            "dim_hold_s",
            t.dim_hold_s.unwrap_or(s0.dim_hold_s),
            0.0,
            86_400.0,
        )?,
        uniformity: t
            .uniformity
            .map(|u| within("uniformity", u, 0.0, 1.0))
            .transpose()?,
        daylight_rise_s: within(
            "daylight_rise_s",
            t.daylight_rise_s.unwrap_or(s0.daylight_rise_s),
            0.0,
            3600.0,
        )?,
        daylight_fall_s: within(
            "daylight_fall_s",
            t.daylight_fall_s.unwrap_or(s0.daylight_fall_s),
            0.0,
            3600.0,
        )?,
        min_saving: within(
            "min_saving",
            t.min_saving.unwrap_or(s0.min_saving),
            0.0,
            0.5,
        )?,
    };
    Ok(ControlOptions {
        mode,
        target_lx,
        desk_targets_lx,
        rated_power_w,
        standby_power_w,
        min_arc,
        loop_settings,
        daylight_max_age_s: within(
            "daylight_max_age_s",
            t.daylight_max_age_s.unwrap_or(d.daylight_max_age_s),
            1.0,
            86_400.0,
        )?,
        tick_s: within("tick_s", t.tick_s.unwrap_or(d.tick_s), 0.05, 3600.0)?,
        vacant: match t.vacant.as_deref() {
            None => d.vacant,
            Some(name) => crate::control::VacantLight::from_name(name).ok_or_else(|| {
                SectionError(format!(
                    "control.vacant \"{name}\": \"surrounding\" or \"off\""
                ))
            })?,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<ControlOptions, SectionError> {
        control(Some(
            toml::from_str(s).map_err(|e| SectionError(e.to_string()))?,
        ))
    }

    #[test]
    fn the_section_is_read_and_checked() {
        let c = parse(
            "mode = \"daylight-harvesting\"\ntarget_lx = 400\ndesk_targets_lx = { \"3\" = 750 }\nrated_power_w = 40\nuniformity = 0.6\n",
        )
        .unwrap();
        assert_eq!(c.mode, Mode::DaylightHarvesting);
        assert_eq!(
            (c.target_lx, c.desk_targets_lx.clone()),
            (400.0, vec![(3, 750.0)])
        );
        assert_eq!(c.rated_power_w, Some(40.0));
        assert_eq!(c.loop_settings.uniformity, Some(0.6));
        let f = parse("daylight_rise_s = 60\ndaylight_fall_s = 0\nmin_saving = 0.1\n").unwrap();
        assert_eq!(
            (
                f.loop_settings.daylight_rise_s,
                f.loop_settings.daylight_fall_s,
                f.loop_settings.min_saving
            ),
            (60.0, 0.0, 0.1)
        );
        let d = parse("").unwrap();
        assert_eq!((d.mode, d.target_lx, d.min_arc), (Mode::Off, 500.0, 85));
        assert_eq!(d.vacant, crate::control::VacantLight::Surrounding);
        assert_eq!(
            parse("vacant = \"off\"").unwrap().vacant,
            crate::control::VacantLight::Off
        );
        for (bad, says) in [
            ("mode = \"auto\"", "control.mode"),
            ("target_lx = -1", "target_lx"),
            ("target_lx = 1e9", "target_lx"),
            ("desk_targets_lx = { \"x\" = 5 }", "desk id"),
            ("min_arc = 0", "min_arc"),
            ("dead_band = 0.9", "dead_band"),
            ("uniformity = 1.5", "uniformity"),
            ("daylight_fall_s = -1", "daylight_fall_s"),
            ("min_saving = 0.9", "min_saving"),
            ("tick_s = 0", "tick_s"),
            ("rated_power_w = 0", "rated_power_w"),
            ("colour = 1", "unknown field"),
            ("vacant = \"dim\"", "control.vacant"),
        ] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }
}
