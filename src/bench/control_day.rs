//! Energy over a day of daylight: the least-power controller against all luminaires at full and
//! against the conventional one-photocell controller (every luminaire dimmed together until the
//! darkest desk meets its target), over the occupied hours of a daylight series.
//!
//! With an occupancy schedule ([`People`]), a fourth controller: least power following people
//! (each desk's demand by its presence after the hold, `control::presence_demand_lx`), on
//! quarter-hour steps within the daylight's.
//!
//! The daylight series is a CSV `time_h,sensor_id,lux` (the daylight alone on each desk at
//! each time, e.g. from Radiance with the luminaires off); each time step lasts until the next
//! one (the last one as long as the one before it).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::control::{
    Demand, LuminairePower, Plant, Presence, VacantLight, photocell, plan, presence_demand_lx,
};
use crate::dali::DimmingCurve;
use crate::store::Image;

/// Why the day could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum DayError {
    /// The series file.
    #[error("{}: {reason}", path.display())]
    Series {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The optimiser refused the input.
    #[error(transparent)]
    Control(#[from] crate::control::ControlError),
}

/// One time step of the series.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Hour of the day.
    pub time_h: f64,
    /// Daylight per desk (image sensor order), lx.
    pub daylight_lx: Vec<f64>,
}

/// Reads a series for the image's sensors; a sensor the file does not name has no daylight.
pub fn read_series(path: &Path, sensor_ids: &[u32]) -> Result<Vec<Step>, DayError> {
    let bad = |reason: String| DayError::Series {
        path: path.to_owned(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let mut lines = text.lines().enumerate();
    let header = lines.next().map(|l| l.1).unwrap_or_default();
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| {
        cols.iter()
            .position(|c| *c == name)
            .ok_or_else(|| bad(format!("header must name {name}")))
    };
    let (ct, cs, cl) = (col("time_h")?, col("sensor_id")?, col("lux")?);
    let mut by_time: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for (n, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |c: usize| f.get(c).copied().unwrap_or("");
        let t: f64 = get(ct)
            .parse()
            .map_err(|_| bad(format!("line {}: time_h", n + 1)))?;
        let s: u32 = get(cs)
            .parse()
            .map_err(|_| bad(format!("line {}: sensor_id", n + 1)))?;
        let lux: f64 = get(cl)
            .parse()
            .map_err(|_| bad(format!("line {}: lux", n + 1)))?;
        if !(t.is_finite() && (0.0..=24.0).contains(&t) && lux.is_finite() && lux >= 0.0) {
            return Err(bad(format!(
                "line {}: time within 0..=24 h, lux >= 0",
                n + 1
            )));
        }
        let Some(k) = sensor_ids.iter().position(|&id| id == s) else {
            continue;
        };
        let v = by_time
            .entry((t * 3600.0).round() as u64)
            .or_insert_with(|| vec![0.0; sensor_ids.len()]);
        v[k] = lux;
    }
    if by_time.is_empty() {
        return Err(bad("no daylight rows for the image's sensors".into()));
    }
    Ok(by_time
        .into_iter()
        .map(|(t, daylight_lx)| Step {
            time_h: t as f64 / 3600.0,
            daylight_lx,
        })
        .collect())
}

/// Who sits where over the day, and how the controller takes it.
#[derive(Debug, Clone, PartialEq)]
pub struct People {
    /// Per desk sensor id, the intervals someone is at it, `[from, to)` hours (none: empty all
    /// day). A sensor not listed is not a desk: its presence is unknown (its target holds).
    pub desks: Vec<(u32, Vec<(f64, f64)>)>,
    /// A desk stays occupied this long after its person left, h (`[occupancy] hold_s`).
    pub hold_h: f64,
    /// What a vacant desk is lit to.
    pub vacant: VacantLight,
}

/// Steps of the occupancy controller, h.
const PEOPLE_STEP_H: f64 = 0.25;

impl People {
    /// Presence at sensor `id` at hour `t_h`, the hold applied.
    pub fn presence(&self, id: u32, t_h: f64) -> Presence {
        let Some((_, spans)) = self.desks.iter().find(|(d, _)| *d == id) else {
            return Presence::Unknown;
        };
        let held = spans
            .iter()
            .any(|&(a, b)| a <= t_h && t_h < b + self.hold_h);
        if held {
            Presence::Occupied
        } else {
            Presence::Vacant
        }
    }
}

/// Reads an occupancy schedule: CSV `sensor_id,from_h,to_h`, one row per interval someone is at
/// the desk; a row with both times empty names a desk nobody uses that day.
pub fn read_people(path: &Path, hold_h: f64, vacant: VacantLight) -> Result<People, DayError> {
    let bad = |reason: String| DayError::Series {
        path: path.to_owned(),
        reason,
    };
    if !(hold_h.is_finite() && (0.0..=24.0).contains(&hold_h)) {
        return Err(bad(format!("hold {hold_h} h: within 0..=24 h")));
    }
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let mut lines = text.lines().enumerate();
    if lines.next().map(|l| l.1.trim()) != Some("sensor_id,from_h,to_h") {
        return Err(bad("header must be sensor_id,from_h,to_h".into()));
    }
    let mut desks: Vec<(u32, Vec<(f64, f64)>)> = Vec::new();
    for (n, line) in lines.filter(|(_, l)| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let line_no = n + 1;
        let [id, from, to] = f[..] else {
            return Err(bad(format!("line {line_no}: three fields")));
        };
        let id: u32 = id
            .parse()
            .map_err(|_| bad(format!("line {line_no}: sensor_id")))?;
        let i = match desks.iter().position(|(d, _)| *d == id) {
            Some(i) => i,
            None => {
                desks.push((id, Vec::new()));
                desks.len() - 1
            }
        };
        if from.is_empty() && to.is_empty() {
            continue;
        }
        let (a, b) = match (from.parse::<f64>(), to.parse::<f64>()) {
            (Ok(a), Ok(b)) if a.is_finite() && b.is_finite() && 0.0 <= a && a < b && b <= 24.0 => {
                (a, b)
            }
            _ => {
                return Err(bad(format!(
                    "line {line_no}: 0 <= from_h < to_h <= 24 (or both empty)"
                )));
            }
        };
        desks[i].1.push((a, b));
    }
    if desks.is_empty() {
        return Err(bad("no desk in the schedule".into()));
    }
    Ok(People {
        desks,
        hold_h,
        vacant,
    })
}

/// One step of the day for each controller.
#[derive(Debug, Clone, PartialEq)]
pub struct DayRow {
    /// Hour of the day.
    pub time_h: f64,
    /// Mean daylight over the desks, lx.
    pub mean_daylight_lx: f64,
    /// All luminaires at full, W.
    pub all_on_w: f64,
    /// One photocell, every luminaire together, W.
    pub photocell_w: f64,
    /// The least-power plan, W.
    pub optimised_w: f64,
    /// The continuous optimum (the linear programme's, before DALI levels), W: a lower bound.
    pub lp_w: f64,
    /// Desks short under the photocell / the optimiser.
    pub short: (usize, usize),
    /// Least power following people, mean over the step, W (`None`: no schedule).
    pub following_w: Option<f64>,
}

/// Energy totals, kWh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DayTotals {
    /// All on.
    pub all_on_kwh: f64,
    /// One photocell.
    pub photocell_kwh: f64,
    /// Least power.
    pub optimised_kwh: f64,
    /// Least power following people (`None`: no schedule).
    pub following_kwh: Option<f64>,
    /// Occupied hours covered.
    pub hours: f64,
}

/// Runs the three controllers over the occupied steps (`occupied_h` = [from, to)).
pub fn run(
    image: &Image<'_>,
    power: &[LuminairePower],
    target_lx: &[f64],
    series: &[Step],
    occupied_h: (f64, f64),
    people: Option<&People>,
) -> Result<(Vec<DayRow>, DayTotals), DayError> {
    let (kd, l) = (image.sensors(), image.luminaires());
    let response = image.response_rows_lx(0..kd);
    let plant = Plant {
        desks: kd,
        luminaires: l,
        response_lx: &response,
        power,
        curve: DimmingCurve::Logarithmic,
    };
    let steps: Vec<&Step> = series
        .iter()
        .filter(|s| s.time_h >= occupied_h.0 && s.time_h < occupied_h.1)
        .collect();
    let mut rows = Vec::new();
    let mut totals = DayTotals {
        all_on_kwh: 0.0,
        photocell_kwh: 0.0,
        optimised_kwh: 0.0,
        following_kwh: people.map(|_| 0.0),
        hours: 0.0,
    };
    let ids: Vec<u32> = (0..kd).map(|k| image.sensor_id(k)).collect();
    for (i, s) in steps.iter().enumerate() {
        let dt_h = match (
            steps.get(i + 1),
            i.checked_sub(1).and_then(|p| steps.get(p)),
        ) {
            (Some(next), _) => next.time_h - s.time_h,
            (None, Some(prev)) => s.time_h - prev.time_h,
            (None, None) => 1.0,
        }
        .min(occupied_h.1 - s.time_h);
        let demand = Demand {
            target_lx,
            daylight_lx: &s.daylight_lx,
            uniformity: None,
        };
        let pc = photocell(&plant, &demand)?.report;
        let opt = plan(&plant, &demand)?.report;
        let following_w = match people {
            Some(p) => {
                let wh = following_wh(&plant, p, &ids, target_lx, s, dt_h)?;
                if let Some(k) = totals.following_kwh.as_mut() {
                    *k += wh / 1000.0;
                }
                Some(wh / dt_h.max(1e-9))
            }
            None => None,
        };
        totals.all_on_kwh += pc.all_on_w * dt_h / 1000.0;
        totals.photocell_kwh += pc.power_w * dt_h / 1000.0;
        totals.optimised_kwh += opt.power_w * dt_h / 1000.0;
        totals.hours += dt_h;
        rows.push(DayRow {
            time_h: s.time_h,
            mean_daylight_lx: s.daylight_lx.iter().sum::<f64>() / kd.max(1) as f64,
            all_on_w: pc.all_on_w,
            photocell_w: pc.power_w,
            optimised_w: opt.power_w,
            lp_w: opt.lp_power_w,
            short: (pc.short, opt.short),
            following_w,
        });
    }
    Ok((rows, totals))
}

/// Energy of the least-power controller following people over one daylight step, Wh: the
/// step cut into quarter hours, each planned for the desks' presence at its start.
fn following_wh(
    plant: &Plant<'_>,
    people: &People,
    ids: &[u32],
    target_lx: &[f64],
    step: &Step,
    dt_h: f64,
) -> Result<f64, DayError> {
    let mut wh = 0.0;
    let mut t = 0.0;
    while t < dt_h - 1e-9 {
        let h = PEOPLE_STEP_H.min(dt_h - t);
        let demand: Vec<f64> = ids
            .iter()
            .zip(target_lx)
            .map(|(&id, &target)| {
                presence_demand_lx(target, people.presence(id, step.time_h + t), people.vacant)
            })
            .collect();
        let report = plan(
            plant,
            &Demand {
                target_lx: &demand,
                daylight_lx: &step.daylight_lx,
                uniformity: None,
            },
        )?
        .report;
        wh += report.power_w * h;
        t += h;
    }
    Ok(wh)
}
