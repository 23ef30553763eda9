//! Benchmarks that print tables (and draw plots): commissioning time, per-state time, accuracy
//! against a truth table, the speed/accuracy trade of the engine's knobs, and the paper's
//! ablation. Used by `luxnode bench ...`; figures go to `docs/` with the command that made them.

pub mod control;
pub mod control_day;
pub mod dense;
pub mod equal_error;
pub mod live;
pub mod occupancy;
pub mod patches;
pub mod radiance;
pub mod scaling;
pub mod table1;
pub mod tradeoffs;

use std::time::{Duration, Instant};

use crate::engine::{self, DirectModel, EngineError, Model, PatchSettings, Settings};
use crate::evaluate::{Accuracy, Computed, compare};
use crate::scene::{Scenario, Scene, TruthRow};

/// Computes every scenario's sensor readings by superposition.
pub fn scenario_readings(
    model: &Model,
    scenarios: &[Scenario],
) -> Result<Vec<Computed>, EngineError> {
    crate::evaluate::readings(
        scenarios,
        &model.luminaire_ids,
        &model.sensor_ids,
        |levels| model.sensor_lux(levels),
    )
}

/// Accuracy of a model over scenarios against a truth table.
pub fn accuracy(
    model: &Model,
    scenarios: &[Scenario],
    truth: &[TruthRow],
) -> Result<Option<Accuracy>, EngineError> {
    Ok(compare(&scenario_readings(model, scenarios)?, truth))
}

/// The median of some durations.
pub fn median(mut d: Vec<Duration>) -> Duration {
    d.sort();
    d.get(d.len() / 2).copied().unwrap_or_default()
}

/// Commissioning timings: median total and per-stage medians.
pub type CommissionTimes = (Duration, Vec<(&'static str, Duration)>);

/// Commissioning timed `runs` times: median total and per-stage medians, and the last model.
pub fn time_commissioning(
    scene: &Scene,
    settings: &Settings,
    runs: usize,
) -> Result<(CommissionTimes, Model), EngineError> {
    let mut totals = Vec::new();
    let mut stages: Vec<(&'static str, Vec<Duration>)> = Vec::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        let t0 = Instant::now();
        let m = engine::compute_model(scene, settings)?;
        totals.push(t0.elapsed());
        for (name, d) in &m.stats.timings {
            match stages.iter_mut().find(|(n, _)| n == name) {
                Some((_, v)) => v.push(*d),
                None => stages.push((name, vec![*d])),
            }
        }
        last = Some(m);
    }
    let stages = stages.into_iter().map(|(n, v)| (n, median(v))).collect();
    match last {
        Some(m) => Ok(((median(totals), stages), m)),
        None => Err(EngineError::Empty("no run".into())),
    }
}

/// Time of one dimming-state evaluation (all sensors, by superposition), averaged over
/// `iterations` states with varying levels.
pub fn time_state(model: &Model, iterations: usize) -> Result<Duration, EngineError> {
    let n = model.luminaires();
    let mut out = vec![0.0; model.sensors()];
    let states: Vec<Vec<f64>> = (0..64)
        .map(|k| {
            (0..n)
                .map(|l| ((k * 7 + l * 3) % 11) as f64 / 10.0)
                .collect()
        })
        .collect();
    let mut sink = 0.0;
    let t0 = Instant::now();
    for i in 0..iterations {
        model.sensor_lux_into(std::hint::black_box(&states[i % states.len()]), &mut out)?;
        sink += out[0];
    }
    let dt = t0.elapsed();
    std::hint::black_box(sink);
    Ok(dt / iterations.max(1) as u32)
}

/// One point of the trade-off study.
#[derive(Debug, Clone)]
pub struct TradePoint {
    /// Rays per patch asked for.
    pub rays: usize,
    /// Base patch size, m.
    pub patch_size_m: f64,
    /// Patches made.
    pub patches: usize,
    /// Non-zero form factors.
    pub nnz: usize,
    /// Commissioning wall time.
    pub time: Duration,
    /// Accuracy against the truth.
    pub accuracy: Accuracy,
}

/// Commissions the scene for each (rays, patch size) and scores it.
pub fn tradeoff_sweep(
    scene: &Scene,
    scenarios: &[Scenario],
    truth: &[TruthRow],
    rays: &[usize],
    patch_sizes_m: &[f64],
    progress: &mut dyn FnMut(&TradePoint),
) -> Result<Vec<TradePoint>, EngineError> {
    let mut out = Vec::new();
    for &size in patch_sizes_m {
        for &r in rays {
            let settings = Settings {
                rays: r,
                patches: PatchSettings {
                    patch_size_m: size,
                    min_patch_m: (size / 16.0).min(0.0625),
                    ..PatchSettings::default()
                },
                ..Settings::default()
            };
            let t0 = Instant::now();
            let model = engine::compute_model(scene, &settings)?;
            let time = t0.elapsed();
            let Some(accuracy) = accuracy(&model, scenarios, truth)? else {
                return Err(EngineError::Empty(
                    "no truth values match the scenarios".into(),
                ));
            };
            let p = TradePoint {
                rays: model.stats.rays_per_patch,
                patch_size_m: size,
                patches: model.stats.patches,
                nnz: model.stats.nnz,
                time,
                accuracy,
            };
            progress(&p);
            out.push(p);
        }
    }
    Ok(out)
}

/// One row of the ablation.
#[derive(Debug, Clone)]
pub struct AblationRow {
    /// Direct light formulation.
    pub direct: DirectModel,
    /// LDC modelled.
    pub ldc: bool,
    /// LSC modelled.
    pub lsc: bool,
    /// Accuracy against the truth.
    pub accuracy: Accuracy,
}

/// The paper's ablation: {paper, exact} × LDC {off, on} × LSC {off, on}, every row with the
/// paper's 1000 rays per patch.
pub fn ablation(
    scene: &Scene,
    scenarios: &[Scenario],
    truth: &[TruthRow],
) -> Result<Vec<AblationRow>, EngineError> {
    let mut rows = Vec::new();
    for direct in [DirectModel::Paper, DirectModel::Exact] {
        for (ldc, lsc) in [(false, false), (true, false), (false, true), (true, true)] {
            let settings = Settings {
                direct,
                ldc,
                lsc,
                rays: 1000,
                ..Settings::default()
            };
            let model = engine::compute_model(scene, &settings)?;
            if let Some(accuracy) = accuracy(&model, scenarios, truth)? {
                rows.push(AblationRow {
                    direct,
                    ldc,
                    lsc,
                    accuracy,
                });
            }
        }
    }
    Ok(rows)
}

/// Run-time core timings over an image: one dimming state by superposition (averaged over
/// `iterations`), and full re-solves (median of `resolves`), with the sweeps of the last.
pub fn time_runtime(
    image: &crate::store::Image<'_>,
    iterations: usize,
    resolves: usize,
) -> Result<(Duration, Duration, u32), crate::runtime::RuntimeError> {
    let rt = crate::runtime::Runtime::new(image);
    let l = image.luminaires();
    let mut out = vec![0.0; image.sensors()];
    let states: Vec<Vec<f64>> = (0..64)
        .map(|k| {
            (0..l)
                .map(|j| ((k * 7 + j * 3) % 11) as f64 / 10.0)
                .collect()
        })
        .collect();
    let mut sink = 0.0;
    let t0 = Instant::now();
    for i in 0..iterations {
        rt.sensor_lux(std::hint::black_box(&states[i % states.len()]), &mut out)?;
        sink += out.first().copied().unwrap_or(0.0);
    }
    let per_state = t0.elapsed() / iterations.max(1) as u32;
    std::hint::black_box(sink);
    let n = image.patches();
    let (mut e, mut b) = (vec![0.0; n], vec![0.0; n]);
    let mut times = Vec::new();
    let mut sweeps = 0;
    for k in 0..resolves.max(1) {
        let t = Instant::now();
        let r = rt.resolve(&states[k % states.len()], &mut e, &mut b, &mut out)?;
        times.push(t.elapsed());
        sweeps = r.iterations;
    }
    Ok((per_state, median(times), sweeps))
}
