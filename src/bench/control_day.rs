//! Energy over a day of daylight: the least-power controller against all luminaires at full and
//! against the conventional one-photocell controller (every luminaire dimmed together until the
//! darkest desk meets its target), over the occupied hours of a daylight series.
//!
//! The daylight series is a CSV `time_h,sensor_id,lux` (the daylight alone on each desk at
//! each time, e.g. from Radiance with the luminaires off); each time step lasts until the next
//! one (the last one as long as the one before it).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::control::{Demand, LuminairePower, Plant, photocell, plan};
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
) -> Result<(Vec<DayRow>, DayTotals), DayError> {
    let (kd, l) = (image.sensors(), image.luminaires());
    let response: Vec<f64> = (0..kd)
        .flat_map(|k| (0..l).map(move |j| (k, j)))
        .map(|(k, j)| image.response_lx(k, j))
        .collect();
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
        hours: 0.0,
    };
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
        });
    }
    Ok((rows, totals))
}
