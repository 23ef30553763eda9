//! Accuracy against a reference (the Radiance truth): the paper's Table 1 measure.
//!
//! `error = mean |lux − true lux| / mean true lux` over all (scenario, sensor) pairs; a
//! sensor's error is the same measure over its own pairs.

use std::collections::HashMap;

use crate::scene::TruthRow;

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
}
