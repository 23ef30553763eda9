//! luxnode against Radiance at equal error (issue 33): luxnode's speed-accuracy curve (a ladder
//! of engine settings, each measured in CPU seconds and error against the truth) set beside
//! Radiance's stored runs (`bench/radiance/sweep.py --ad-ladder`, its `sweep.json`); for every
//! Radiance rung, the cheapest luxnode setting whose error is at most Radiance's, and the ratio
//! of their CPU times.
//!
//! CPU time, not wall time, is the measure: the machine is shared, and a busy machine stretches
//! the wall clock but not the work. luxnode's CPU is that of the whole process (every thread)
//! over commissioning and the scenario table; Radiance's is the harness's own count of its
//! `oconv` and `rtrace` children.

use std::fmt::Write as _;

use crate::engine::{self, EngineError, PatchSettings, Settings};
use crate::preset::Preset;
use crate::scene::{Scenario, Scene, TruthRow};

/// One Radiance rung as `sweep.py` stored it (mean over its repeats).
#[derive(Debug, Clone, PartialEq)]
pub struct RadianceRung {
    /// Its `office_a.py` options (`-ab 8 -ad 1024 -lw 1e-4`).
    pub options: String,
    /// Runs averaged.
    pub repeats: usize,
    /// CPU time of the whole table (user + sys of the Radiance processes), s, mean.
    pub cpu_s: f64,
    /// Wall time of the whole table, s, mean.
    pub wall_s: f64,
    /// Error against the truth, mean over the repeats (a fraction).
    pub error: f64,
    /// The best repeat's error.
    pub error_min: f64,
    /// The worst repeat's error.
    pub error_max: f64,
    /// The worst sensor's error, mean over the repeats.
    pub worst_sensor_error: f64,
    /// The highest load average seen around its runs.
    pub loadavg_max: f64,
}

/// Reads the rungs of a `sweep.py` result (`sweep.json`).
pub fn read_sweep(json: &str) -> Result<Vec<RadianceRung>, String> {
    let v: serde_json::Value = serde_json::from_str(json).map_err(|e| e.to_string())?;
    let rungs = v["rungs"].as_array().ok_or("no \"rungs\" array")?;
    rungs
        .iter()
        .map(|r| {
            let num = |key: &str| {
                r[key]
                    .as_f64()
                    .ok_or_else(|| format!("a rung has no number {key}"))
            };
            Ok(RadianceRung {
                options: r["options"].as_str().ok_or("a rung has no options")?.into(),
                repeats: r["repeats"].as_u64().unwrap_or(1) as usize,
                cpu_s: num("cpu_time_s")?,
                wall_s: num("wall_time_s")?,
                error: num("error")?,
                error_min: num("error_min")?,
                error_max: num("error_max")?,
                worst_sensor_error: num("worst_sensor_error")?,
                loadavg_max: r["loadavg_max"].as_f64().unwrap_or(f64::NAN),
            })
        })
        .collect()
}

/// One luxnode setting on the curve.
#[derive(Debug, Clone)]
pub struct Candidate {
    /// Its name in the tables (`fast`, `rays 30`, ...).
    pub label: &'static str,
    /// Its engine settings.
    pub settings: Settings,
}

/// luxnode's ladder, cheap to costly: the fast preset (since stop 43 the "lean" setting with 2
/// opening and 2 direct points); "lean" settings (2 m patches with
/// balanced's refinement, 10 rays per patch (Isocell: 12), 3000 sensor rays, no final gather, few
/// opening and direct points: office_a's cost is direct light and the final gather, not form
/// factors); balanced with 2 m patches and 10 rays, with and without the final gather; balanced
/// at 30, 100 and 300 (its own) rays.
pub fn candidates() -> Vec<Candidate> {
    let b = Preset::Balanced.engine();
    let with = |label, settings| Candidate { label, settings };
    let coarse = Settings {
        patches: PatchSettings {
            patch_size_m: 2.0,
            ..b.patches
        },
        rays: 10,
        ..b.clone()
    };
    let lean = |opening_samples, patch_direct_points, detail_ratio| Settings {
        patches: PatchSettings {
            detail_ratio,
            ..coarse.patches
        },
        sensor_rays: 3000,
        final_gather_rays: 0,
        opening_samples,
        patch_direct_points,
        ..coarse.clone()
    };
    let rays = |rays| Settings { rays, ..b.clone() };
    vec![
        with("fast (preset)", Preset::Fast.engine()),
        with("lean, 2 opening x 1 direct points", lean(2, 1, 0.5)),
        with("lean, 2 x 2 points, detail 1", lean(2, 2, 1.0)),
        with("lean, 4 x 4 points", lean(4, 4, 0.5)),
        with(
            "balanced, 2 m patches, 10 rays, no final gather",
            Settings {
                final_gather_rays: 0,
                ..coarse.clone()
            },
        ),
        with("balanced, 2 m patches, 10 rays", coarse.clone()),
        with("balanced, 30 rays", rays(30)),
        with("balanced, 100 rays", rays(100)),
        with("balanced (preset)", b.clone()),
    ]
}

/// One measured point of luxnode's curve.
#[derive(Debug, Clone)]
pub struct Point {
    /// The candidate's label.
    pub label: &'static str,
    /// CPU time (all threads) for commissioning and the scenario table, s: median of the runs.
    pub cpu_s: f64,
    /// Wall time of the same, s: median of the runs.
    pub wall_s: f64,
    /// Error against the truth.
    pub error: f64,
    /// The worst sensor's error.
    pub worst_sensor_error: f64,
}

/// Commissions `scene` with a candidate `runs` times and scores it (the error is the same every
/// run: fixed seed).
pub fn measure(
    scene: &Scene,
    scenarios: &[Scenario],
    truth: &[TruthRow],
    candidate: &Candidate,
    runs: usize,
) -> Result<Option<Point>, EngineError> {
    let mut cpu = Vec::new();
    let mut wall = Vec::new();
    let mut acc = None;
    for _ in 0..runs.max(1) {
        let cpu0 = crate::host::process_cpu_time().unwrap_or_default();
        let t0 = std::time::Instant::now();
        let model = engine::compute_model(scene, &candidate.settings)?;
        let readings = super::scenario_readings(&model, scenarios)?;
        wall.push(t0.elapsed().as_secs_f64());
        cpu.push((crate::host::process_cpu_time().unwrap_or_default() - cpu0).as_secs_f64());
        acc = crate::evaluate::compare(&readings, truth);
    }
    Ok(acc.map(|a| Point {
        label: candidate.label,
        cpu_s: median_f64(cpu),
        wall_s: median_f64(wall),
        error: a.error,
        worst_sensor_error: a.worst_sensor,
    }))
}

fn median_f64(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The cheapest point (CPU) whose error is at most `error`.
pub fn cheapest_at(points: &[Point], error: f64) -> Option<&Point> {
    points
        .iter()
        .filter(|p| p.error <= error)
        .min_by(|a, b| a.cpu_s.total_cmp(&b.cpu_s))
}

/// The two tables: luxnode's curve, then Radiance's rungs each with the cheapest luxnode point at
/// its mean error and at its best repeat's error, and the CPU ratios.
pub fn tables(points: &[Point], rungs: &[RadianceRung]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| luxnode setting | CPU (s) | wall (s) | error | worst sensor |\n|---|---:|---:|---:|---:|"
    );
    for p in points {
        let _ = writeln!(
            s,
            "| {} | {:.3} | {:.3} | {:.2} % | {:.2} % |",
            p.label,
            p.cpu_s,
            p.wall_s,
            100.0 * p.error,
            100.0 * p.worst_sensor_error
        );
    }
    let _ = writeln!(
        s,
        "\n| Radiance (superpose) | runs | CPU (s) | error, mean (min-max) | worst sensor | \
         luxnode's cheapest at ≤ the mean error | its CPU (s) | its error | CPU ratio | \
         luxnode's cheapest at ≤ the best run's error | its CPU (s) | CPU ratio |\n\
         |---|---:|---:|---|---:|---|---:|---:|---:|---|---:|---:|"
    );
    for r in rungs {
        let at = |e: f64| match cheapest_at(points, e) {
            Some(p) => (
                p.label.to_owned(),
                format!("{:.3}", p.cpu_s),
                format!("{:.2} %", 100.0 * p.error),
                format!("{:.1}", r.cpu_s / p.cpu_s),
            ),
            None => ("none".into(), "".into(), "".into(), "".into()),
        };
        let (mean_label, mean_cpu, mean_err, mean_ratio) = at(r.error);
        let (best_label, best_cpu, _, best_ratio) = at(r.error_min);
        let _ = writeln!(
            s,
            "| `{}` | {} | {:.2} | {:.2} % ({:.2}-{:.2}) | {:.2} % | {mean_label} | {mean_cpu} | \
             {mean_err} | {mean_ratio} | {best_label} | {best_cpu} | {best_ratio} |",
            r.options,
            r.repeats,
            r.cpu_s,
            100.0 * r.error,
            100.0 * r.error_min,
            100.0 * r.error_max,
            100.0 * r.worst_sensor_error
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(label: &'static str, cpu_s: f64, error: f64) -> Point {
        Point {
            label,
            cpu_s,
            wall_s: cpu_s,
            error,
            worst_sensor_error: error,
        }
    }

    #[test]
    fn the_sweep_is_read_and_the_cheapest_point_at_an_error_found() {
        let json = r#"{"rungs": [{"options": "-ab 8 -ad 512 -lw 1e-4", "repeats": 3,
            "cpu_time_s": 1.7, "wall_time_s": 0.9, "error": 0.005, "error_min": 0.004,
            "error_max": 0.006, "worst_sensor_error": 0.015, "loadavg_max": 1.2}]}"#;
        let rungs = read_sweep(json).unwrap();
        assert_eq!(rungs.len(), 1);
        assert_eq!((rungs[0].cpu_s, rungs[0].error_min), (1.7, 0.004));
        assert!(read_sweep(r#"{"rungs": [{"options": "x"}]}"#).is_err());
        assert!(read_sweep("[]").is_err());
        let pts = [
            point("a", 0.05, 0.013),
            point("b", 0.2, 0.0045),
            point("c", 0.4, 0.002),
        ];
        assert_eq!(cheapest_at(&pts, 0.005).map(|p| p.label), Some("b"));
        assert_eq!(cheapest_at(&pts, 0.004).map(|p| p.label), Some("c"));
        assert!(cheapest_at(&pts, 0.001).is_none());
        let t = tables(&pts, &rungs);
        assert!(t.contains("| b | 0.200 |"), "{t}");
        assert!(t.contains("| 8.5 |"), "{t}");
    }
}
