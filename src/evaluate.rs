//! Accuracy against a reference (the Radiance truth): the paper's Table 1 measure.
//!
//! `error = mean |lux − true lux| / mean true lux` over all (scenario, sensor) pairs; a
//! sensor's error is the same measure over its own pairs.

use std::collections::HashMap;

use crate::scene::{Scenario, TruthRow};

/// One computed value.
#[derive(Debug, Clone, PartialEq)]
pub struct Computed {
    /// Scenario id.
    pub scenario: String,
    /// Sensor id.
    pub sensor: u32,
    /// Illuminance, lx.
    pub lux: f64,
}

/// Errors against the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    /// Pairs compared.
    pub pairs: usize,
    /// Mean absolute error over mean true lux.
    pub error: f64,
    /// Mean absolute error, lx.
    pub mean_abs_lx: f64,
    /// Mean signed error over mean true lux (bias).
    pub bias: f64,
    /// Per sensor (id, error), in id order.
    pub per_sensor: Vec<(u32, f64)>,
    /// The worst sensor's error.
    pub worst_sensor: f64,
}

/// Compares computed values with truth rows present for the same (scenario, sensor).
/// Truth rows without a computed value are skipped; returns `None` when nothing matches.
pub fn compare(computed: &[Computed], truth: &[TruthRow]) -> Option<Accuracy> {
    let mut by_key: HashMap<(&str, u32), f64> = HashMap::new();
    for c in computed {
        by_key.insert((c.scenario.as_str(), c.sensor), c.lux);
    }
    let mut sum_abs = 0.0;
    let mut sum_signed = 0.0;
    let mut sum_true = 0.0;
    let mut n = 0usize;
    let mut sensors: HashMap<u32, (f64, f64)> = HashMap::new();
    for t in truth {
        let Some(&lux) = by_key.get(&(t.scenario.as_str(), t.sensor)) else {
            continue;
        };
        let d = lux - t.lux;
        sum_abs += d.abs();
        sum_signed += d;
        sum_true += t.lux;
        n += 1;
        let e = sensors.entry(t.sensor).or_insert((0.0, 0.0));
        e.0 += d.abs();
        e.1 += t.lux;
    }
    if n == 0 || sum_true <= 0.0 {
        return None;
    }
    let mut per_sensor: Vec<(u32, f64)> = sensors
        .into_iter()
        .map(|(s, (a, t))| (s, if t > 0.0 { a / t } else { 0.0 }))
        .collect();
    per_sensor.sort_by_key(|p| p.0);
    let worst_sensor = per_sensor.iter().map(|p| p.1).fold(0.0, f64::max);
    Some(Accuracy {
        pairs: n,
        error: sum_abs / sum_true,
        mean_abs_lx: sum_abs / n as f64,
        bias: sum_signed / sum_true,
        per_sensor,
        worst_sensor,
    })
}

/// The readings of every scenario: `lux_of(levels)` answers one dimming state (one level per
/// luminaire of `luminaire_ids`, 0 or 1 here) with one reading per sensor of `sensor_ids`.
pub fn readings<E>(
    scenarios: &[Scenario],
    luminaire_ids: &[u32],
    sensor_ids: &[u32],
    mut lux_of: impl FnMut(&[f64]) -> Result<Vec<f64>, E>,
) -> Result<Vec<Computed>, E> {
    let mut out = Vec::with_capacity(scenarios.len() * sensor_ids.len());
    for sc in scenarios {
        let lux = lux_of(&sc.levels(luminaire_ids))?;
        for (sensor, lux) in sensor_ids.iter().zip(lux) {
            out.push(Computed {
                scenario: sc.id.clone(),
                sensor: *sensor,
                lux,
            });
        }
    }
    Ok(out)
}

/// One sensor's error against the truth, over the scenarios both have.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorError {
    /// Sensor id.
    pub sensor: u32,
    /// (scenario, sensor) pairs compared.
    pub pairs: usize,
    /// Mean absolute error, lx.
    pub mean_abs_lx: f64,
    /// Mean true illuminance, lx.
    pub mean_truth_lx: f64,
}

impl SensorError {
    /// Mean absolute error over mean true lux (the paper's Table 1 measure for one sensor).
    pub fn error(&self) -> f64 {
        if self.mean_truth_lx > 0.0 {
            self.mean_abs_lx / self.mean_truth_lx
        } else {
            0.0
        }
    }
}

/// The error of each sensor of `sensor_ids` (in that order) that has truth rows.
pub fn per_sensor(
    computed: &[Computed],
    truth: &[TruthRow],
    sensor_ids: &[u32],
) -> Vec<SensorError> {
    let mut by_key: HashMap<(&str, u32), f64> = HashMap::new();
    for c in computed {
        by_key.insert((c.scenario.as_str(), c.sensor), c.lux);
    }
    sensor_ids
        .iter()
        .filter_map(|&id| {
            let (mut abs, mut tru, mut n) = (0.0, 0.0, 0usize);
            for t in truth.iter().filter(|t| t.sensor == id) {
                if let Some(&lux) = by_key.get(&(t.scenario.as_str(), id)) {
                    abs += (lux - t.lux).abs();
                    tru += t.lux;
                    n += 1;
                }
            }
            (n > 0).then(|| SensorError {
                sensor: id,
                pairs: n,
                mean_abs_lx: abs / n as f64,
                mean_truth_lx: tru / n as f64,
            })
        })
        .collect()
}

/// The pooled error (sum of absolute errors over sum of true lux) of some sensors' errors.
pub fn pooled(errors: &[&SensorError]) -> f64 {
    let abs: f64 = errors.iter().map(|e| e.mean_abs_lx * e.pairs as f64).sum();
    let tru: f64 = errors
        .iter()
        .map(|e| e.mean_truth_lx * e.pairs as f64)
        .sum();
    if tru > 0.0 { abs / tru } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_percent_low_scores_five_percent() {
        let truth: Vec<TruthRow> = (0..4)
            .map(|i| TruthRow {
                scenario: "1".into(),
                sensor: i,
                lux: 100.0 * (i + 1) as f64,
                lux_direct: None,
            })
            .collect();
        let computed: Vec<Computed> = truth
            .iter()
            .map(|t| Computed {
                scenario: t.scenario.clone(),
                sensor: t.sensor,
                lux: 0.95 * t.lux,
            })
            .collect();
        let a = compare(&computed, &truth).unwrap();
        assert!((a.error - 0.05).abs() < 1e-12);
        assert!((a.bias + 0.05).abs() < 1e-12);
        assert!((a.worst_sensor - 0.05).abs() < 1e-12);
        assert_eq!(a.pairs, 4);
    }

    #[test]
    fn per_sensor_and_pooled_errors_weigh_by_pairs() {
        let truth: Vec<TruthRow> = [("a", 1, 100.0), ("b", 1, 300.0), ("a", 2, 50.0)]
            .iter()
            .map(|&(sc, s, lux)| TruthRow {
                scenario: sc.into(),
                sensor: s,
                lux,
                lux_direct: None,
            })
            .collect();
        let scenarios = vec![
            Scenario {
                id: "a".into(),
                on: vec![7],
            },
            Scenario {
                id: "b".into(),
                on: vec![],
            },
        ];
        // sensor 1 reads 110 in a and 300 in b; sensor 2 reads 40 in a
        let computed = readings(&scenarios, &[7], &[1, 2], |levels| {
            Ok::<_, ()>(if levels[0] > 0.5 {
                vec![110.0, 40.0]
            } else {
                vec![300.0, 0.0]
            })
        })
        .unwrap();
        assert_eq!(computed.len(), 4);
        let e = per_sensor(&computed, &truth, &[1, 2, 3]);
        assert_eq!(e.len(), 2, "sensor 3 has no truth");
        assert_eq!((e[0].sensor, e[0].pairs), (1, 2));
        assert!((e[0].error() - 10.0 / 400.0).abs() < 1e-12);
        assert!((e[1].error() - 10.0 / 50.0).abs() < 1e-12);
        // pooled = (10 + 10) / (400 + 50), the same as compare()
        let all = compare(&computed, &truth).unwrap();
        assert!((pooled(&[&e[0], &e[1]]) - all.error).abs() < 1e-12);
        assert!((pooled(&[&e[0]]) - 10.0 / 400.0).abs() < 1e-12);
    }
}
