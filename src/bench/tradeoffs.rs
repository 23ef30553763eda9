//! The speed/accuracy study (`luxnode bench tradeoffs`): every knob of the engine and of the
//! store, one at a time around the balanced preset, the rays × patch-size grid, and the three
//! presets. Each point is commissioned, stored as a flash image, and measured *from the image*
//! (what the node publishes): commissioning time, image size, per-state time (superposition) and
//! re-solve time of the run-time core, error against the truth (mean and worst sensor).
//!
//! Timings are wall times on whatever machine runs it; on a shared machine they are noisy, the
//! counts (patches, form factors, bytes) and errors are not (every seed is fixed).

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use crate::engine::{EngineError, Model, PatchSettings, RaySetKind, Settings};
use crate::evaluate::{Accuracy, Computed, compare};
use crate::image_build::{ImageOptions, build_image};
use crate::preset::{Preset, StoreSettings};
use crate::render::plot::{Plot, Series};
use crate::scene::{Scenario, Scene, TruthRow};
use crate::store::Image;
use crate::store::Precision;

/// Why a point could not be measured.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// Commissioning failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The image could not be built.
    #[error(transparent)]
    Build(#[from] crate::image_build::BuildError),
    /// The image does not parse.
    #[error(transparent)]
    Image(#[from] crate::store::ImageError),
    /// The run-time core failed.
    #[error(transparent)]
    Runtime(#[from] crate::runtime::RuntimeError),
    /// Commissioning from a capture failed.
    #[error(transparent)]
    Commission(#[from] crate::commission::CommissionError),
    /// No truth value matches the scenarios.
    #[error("no truth values match the scenarios")]
    NoTruth,
}

/// One point to measure: a knob's value and the full settings it makes.
#[derive(Debug, Clone)]
pub struct Variant {
    /// The knob (or "preset", "grid").
    pub group: &'static str,
    /// Its value, for the table.
    pub label: String,
    /// Engine settings.
    pub engine: Settings,
    /// Store settings.
    pub store: StoreSettings,
    /// Room closure (capture commissioning only).
    pub closure: bool,
    /// Desk sensors read by a luxmeter with every luminaire at full, from the truth (capture
    /// commissioning only; `commission::refit`).
    pub luxmeter_at: Vec<u32>,
}

impl Variant {
    fn new(group: &'static str, label: impl Into<String>, engine: Settings) -> Self {
        Self {
            group,
            label: label.into(),
            engine,
            store: StoreSettings::default(),
            closure: true,
            luxmeter_at: Vec::new(),
        }
    }
}

/// The three presets.
pub fn preset_variants() -> Vec<Variant> {
    Preset::ALL
        .into_iter()
        .map(|p| Variant {
            store: p.store(),
            ..Variant::new("preset", p.name(), p.engine())
        })
        .collect()
}

/// Every knob, one at a time around the balanced preset (its own value included, marked `*`).
pub fn knob_variants() -> Vec<Variant> {
    let d = Preset::Balanced.engine();
    let mark = |on: bool, s: String| if on { format!("{s} *") } else { s };
    let mut v = Vec::new();
    for r in [30, 100, 300, 1000, 3000] {
        let s = Settings {
            rays: r,
            ..d.clone()
        };
        v.push(Variant::new(
            "rays per patch",
            mark(r == d.rays, r.to_string()),
            s,
        ));
    }
    v.push(Variant::new("ray set", "isocell *", d.clone()));
    v.push(Variant::new(
        "ray set",
        "monte carlo",
        Settings {
            ray_set: RaySetKind::MonteCarlo { seed: d.seed },
            ..d.clone()
        },
    ));
    for size in [0.5, 1.0, 2.0, 4.0] {
        let s = Settings {
            patches: PatchSettings {
                patch_size_m: size,
                ..d.patches
            },
            ..d.clone()
        };
        let label = mark(size == d.patches.patch_size_m, format!("{size} m"));
        v.push(Variant::new("patch size (adaptive)", label, s));
    }
    for (label, detail, light) in [
        (
            "sensor + light *",
            d.patches.detail_ratio,
            d.patches.light_ratio,
        ),
        ("sensor only", d.patches.detail_ratio, 0.0),
        ("light only", 0.0, d.patches.light_ratio),
        ("off (uniform 1 m)", 0.0, 0.0),
    ] {
        let s = Settings {
            patches: PatchSettings {
                detail_ratio: detail,
                light_ratio: light,
                ..d.patches
            },
            ..d.clone()
        };
        v.push(Variant::new("adaptive refinement", label, s));
    }
    for k in [2, 4, 8, 16, 32] {
        let s = Settings {
            opening_samples: k,
            ..d.clone()
        };
        v.push(Variant::new(
            "opening points",
            mark(k == d.opening_samples, k.to_string()),
            s,
        ));
    }
    for k in [1, 2, 4, 8] {
        let s = Settings {
            patch_direct_points: k,
            ..d.clone()
        };
        v.push(Variant::new(
            "direct points per patch",
            mark(k == d.patch_direct_points, k.to_string()),
            s,
        ));
    }
    for k in [1000, 3000, 10_000, 30_000] {
        let s = Settings {
            sensor_rays: k,
            ..d.clone()
        };
        v.push(Variant::new(
            "sensor rays",
            mark(k == d.sensor_rays, k.to_string()),
            s,
        ));
    }
    for k in [0, 300, 1000, 3000] {
        let s = Settings {
            final_gather_rays: k,
            ..d.clone()
        };
        v.push(Variant::new(
            "final gather rays",
            mark(k == d.final_gather_rays, k.to_string()),
            s,
        ));
    }
    for t in [1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12] {
        let mut s = d.clone();
        s.solve.tolerance = t;
        v.push(Variant::new(
            "solver tolerance",
            mark(t == d.solve.tolerance, format!("{t:e}")),
            s,
        ));
    }
    for on in [true, false] {
        let s = Settings {
            rectify: on,
            ..d.clone()
        };
        let label = mark(on == d.rectify, if on { "on" } else { "off" }.into());
        v.push(Variant::new("rectification (closure)", label, s));
    }
    for p in [
        Precision::F64,
        Precision::F32,
        Precision::U16,
        Precision::F16,
        Precision::U8,
    ] {
        v.push(Variant {
            store: StoreSettings {
                precision: p,
                prune_below: 0.0,
            },
            ..Variant::new(
                "storage precision",
                mark(p == StoreSettings::default().precision, p.name().into()),
                d.clone(),
            )
        });
    }
    for t in [1e-4, 1e-3, 3e-3, 1e-2] {
        v.push(Variant {
            store: StoreSettings {
                precision: Precision::U16,
                prune_below: t,
            },
            ..Variant::new("pruning (u16)", format!("{t:e}"), d.clone())
        });
    }
    v
}

/// The rays × base patch size grid (adaptive refinement on, as the defaults).
pub fn grid_variants(rays: &[usize], patch_sizes_m: &[f64]) -> Vec<Variant> {
    let d = Settings::default();
    let mut v = Vec::new();
    for &size in patch_sizes_m {
        for &r in rays {
            let s = Settings {
                rays: r,
                patches: PatchSettings {
                    patch_size_m: size,
                    min_patch_m: (size / 16.0).min(d.patches.min_patch_m),
                    ..d.patches
                },
                ..d.clone()
            };
            v.push(Variant::new("grid", format!("{size} m, {r} rays"), s));
        }
    }
    v
}

/// What one point measured.
#[derive(Debug, Clone)]
pub struct Measured {
    /// The point.
    pub variant: Variant,
    /// Patches.
    pub patches: usize,
    /// Stored form factors (after pruning).
    pub form_factors: usize,
    /// Commissioning wall time (median of the runs).
    pub commission: Duration,
    /// Flash image, bytes.
    pub image_bytes: usize,
    /// True when the image fits the `FORMFACTORS` region.
    pub fits: bool,
    /// One dimming state, all sensors, superposition in the run-time core.
    pub per_state: Duration,
    /// A full re-solve of one state over the stored form factors (median).
    pub resolve: Duration,
    /// Gauss-Seidel sweeps of that re-solve.
    pub resolve_sweeps: u32,
    /// Largest solver iteration count at commissioning.
    pub iterations: u32,
    /// Error of the image's answers against the truth.
    pub accuracy: Accuracy,
}

/// Error of an image's answers (superposition in the run-time core) against a truth table.
pub fn image_accuracy(
    image: &Image<'_>,
    scenarios: &[Scenario],
    truth: &[TruthRow],
) -> Result<Accuracy, StudyError> {
    let rt = crate::runtime::Runtime::new(image);
    let ids: Vec<u32> = (0..image.luminaires())
        .map(|j| image.luminaire_id(j))
        .collect();
    let mut out = vec![0.0; image.sensors()];
    let mut computed = Vec::with_capacity(scenarios.len() * out.len());
    for s in scenarios {
        let levels: Vec<f64> = ids
            .iter()
            .map(|id| if s.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        rt.sensor_lux(&levels, &mut out)?;
        for (k, lux) in out.iter().enumerate() {
            computed.push(Computed {
                scenario: s.id.clone(),
                sensor: image.sensor_id(k),
                lux: *lux,
            });
        }
    }
    compare(&computed, truth).ok_or(StudyError::NoTruth)
}

/// Stores a model with `store` and measures the image.
pub fn measure_model(
    model: &Model,
    variant: &Variant,
    commission: Duration,
    sensor_flags: Vec<u8>,
    scenarios: &[Scenario],
    truth: &[TruthRow],
) -> Result<Measured, StudyError> {
    let bytes = build_image(
        model,
        &ImageOptions {
            precision: variant.store.precision,
            prune_below: variant.store.prune_below,
            scene_name: "tradeoffs".into(),
            sensor_flags,
            geometry: None,
        },
    )?;
    let image = Image::parse(&bytes)?;
    let accuracy = image_accuracy(&image, scenarios, truth)?;
    let (per_state, resolve, resolve_sweeps) = super::time_runtime(&image, 200_000, 5)?;
    Ok(Measured {
        variant: variant.clone(),
        patches: model.stats.patches,
        form_factors: image.payload.ff.nnz(),
        commission,
        image_bytes: bytes.len(),
        fits: bytes.len() <= crate::layout::FORMFACTORS_LEN_BYTES as usize,
        per_state,
        resolve,
        resolve_sweeps,
        iterations: model.stats.iterations.iter().copied().max().unwrap_or(0),
        accuracy,
    })
}

/// A scene with its truth: measures variants, reusing the last model when only the store
/// changes.
pub struct SceneStudy<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its scenarios.
    pub scenarios: &'a [Scenario],
    /// Its truth.
    pub truth: &'a [TruthRow],
    /// Commissioning runs per point (the median is kept).
    pub runs: usize,
    last: Option<(Settings, Duration, Model)>,
}

impl<'a> SceneStudy<'a> {
    /// A study over a CAD scene.
    pub fn new(
        scene: &'a Scene,
        scenarios: &'a [Scenario],
        truth: &'a [TruthRow],
        runs: usize,
    ) -> Self {
        Self {
            scene,
            scenarios,
            truth,
            runs: runs.max(1),
            last: None,
        }
    }

    /// Measures one variant.
    pub fn measure(&mut self, v: &Variant) -> Result<Measured, StudyError> {
        let reuse = matches!(&self.last, Some((s, _, _)) if *s == v.engine);
        if !reuse {
            self.last = None;
            let ((time, _), model) = super::time_commissioning(self.scene, &v.engine, self.runs)?;
            self.last = Some((v.engine.clone(), time, model));
        }
        let Some((_, time, model)) = &self.last else {
            return Err(StudyError::Engine(EngineError::Empty("no model".into())));
        };
        measure_model(model, v, *time, Vec::new(), self.scenarios, self.truth)
    }
}

/// Inputs of commissioning from a capture set.
pub struct CaptureInputs {
    /// The capture.
    pub capture: crate::commission::Capture,
    /// Installed luminaires.
    pub luminaires: Vec<crate::scene::Luminaire>,
    /// Sensors.
    pub sensors: Vec<crate::scene::Sensor>,
    /// Desks.
    pub desks: Option<crate::scene::Desks>,
}

/// The capture-set variant: each point is a full `commission` run (depth, planes, mesh,
/// closure, reflectances, engine) with the variant's engine settings and closure.
pub fn measure_capture(
    inputs: &CaptureInputs,
    v: &Variant,
    scenarios: &[Scenario],
    truth: &[TruthRow],
) -> Result<Measured, StudyError> {
    let mut o = crate::commission::CommissionOptions {
        engine: v.engine.clone(),
        ..crate::commission::CommissionOptions::default()
    };
    o.closure.enabled = v.closure;
    if !v.luxmeter_at.is_empty() {
        // the readings are the truth's with every luminaire on
        let ids: Vec<u32> = inputs.luminaires.iter().map(|l| l.id).collect();
        let all_on = scenarios
            .iter()
            .find(|s| ids.iter().all(|i| s.on.contains(i)))
            .ok_or(StudyError::NoTruth)?;
        for id in &v.luxmeter_at {
            let row = truth
                .iter()
                .find(|r| r.scenario == all_on.id && r.sensor == *id)
                .ok_or(StudyError::NoTruth)?;
            o.readings.push(crate::commission::refit::Reading {
                sensor_id: *id,
                lux_lx: row.lux,
            });
        }
    }
    let t0 = Instant::now();
    let c = crate::commission::from_capture(
        &inputs.capture,
        inputs.luminaires.clone(),
        inputs.sensors.clone(),
        inputs.desks.clone(),
        &o,
    )?;
    let time = t0.elapsed();
    measure_model(&c.model, v, time, c.sensor_flags.clone(), scenarios, truth)
}

/// The capture-set points: the presets, closure off, and the knobs that matter most there.
pub fn capture_variants() -> Vec<Variant> {
    let mut v = preset_variants();
    let d = Preset::Balanced.engine();
    v.push(Variant {
        closure: false,
        ..Variant::new("room closure", "off", d.clone())
    });
    for r in [100, 1000] {
        v.push(Variant::new(
            "rays per patch",
            r.to_string(),
            Settings {
                rays: r,
                ..d.clone()
            },
        ));
    }
    for size in [0.5, 2.0] {
        v.push(Variant::new(
            "patch size (adaptive)",
            format!("{size} m"),
            Settings {
                patches: PatchSettings {
                    patch_size_m: size,
                    ..d.patches
                },
                ..d.clone()
            },
        ));
    }
    v.push(Variant::new(
        "rectification (closure)",
        "off",
        Settings {
            rectify: false,
            ..d.clone()
        },
    ));
    for p in [Precision::U8, Precision::F32] {
        v.push(Variant {
            store: StoreSettings {
                precision: p,
                prune_below: 0.0,
            },
            ..Variant::new("storage precision", p.name(), d.clone())
        });
    }
    // the engineer's time on site against the unseen walls' and ceiling's bias
    for (label, at) in [
        ("1 (sensor 7)", vec![7]),
        ("3 (sensors 1, 4, 8)", vec![1, 4, 8]),
    ] {
        v.push(Variant {
            luxmeter_at: at,
            ..Variant::new("luxmeter readings", label, d.clone())
        });
    }
    v
}

/// The table's header (markdown).
pub const TABLE_HEADER: &str = "| knob | value | patches | form factors | commissioning (s) | image (bytes) | per state (ns) | re-solve (ms) | error | worst sensor |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|";

/// One table row (markdown).
pub fn table_row(m: &Measured) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "| {} | {} | {} | {} | {:.3} | {}{} | {:.0} | {:.2} | {:.2} % | {:.2} % |",
        m.variant.group,
        m.variant.label,
        m.patches,
        m.form_factors,
        m.commission.as_secs_f64(),
        m.image_bytes,
        if m.fits { "" } else { " (does not fit)" },
        m.per_state.as_secs_f64() * 1e9,
        m.resolve.as_secs_f64() * 1e3,
        100.0 * m.accuracy.error,
        100.0 * m.accuracy.worst_sensor
    );
    s
}

/// The points no other point beats on both `cost` and error (lower is better), by cost.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|l| q.1 < l.1) {
            front.push(q);
        }
    }
    front
}

/// A Pareto plot: error (%) against a cost, one series per knob (each knob's values joined in
/// cost order), and the front of all points.
pub fn pareto_plot(
    title: &str,
    x_label: &str,
    points: &[Measured],
    cost: impl Fn(&Measured) -> f64,
    groups: &[&str],
) -> Plot {
    let mut series: Vec<Series> = groups
        .iter()
        .map(|g| {
            let mut pts: Vec<(f64, f64)> = points
                .iter()
                .filter(|m| m.variant.group == *g)
                .map(|m| (cost(m), 100.0 * m.accuracy.error))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                name: g.to_string(),
                points: pts,
            }
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    let all: Vec<(f64, f64)> = points
        .iter()
        .map(|m| (cost(m), 100.0 * m.accuracy.error))
        .collect();
    series.push(Series {
        name: "Pareto front".into(),
        points: pareto_front(&all),
    });
    Plot {
        title: title.to_string(),
        x_label: x_label.to_string(),
        y_label: "error against Radiance (%, log)".into(),
        log_x: true,
        log_y: true,
        series,
    }
}

/// What `luxnode bench tradeoffs` runs.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Every knob one at a time around the balanced preset.
    pub knobs: bool,
    /// The rays × patch size grid (empty: none).
    pub grid_rays: Vec<usize>,
    /// The grid's base patch sizes, m.
    pub grid_sizes_m: Vec<f64>,
    /// Commissioning runs per knob or grid point (median).
    pub runs: usize,
    /// Commissioning runs per preset (median).
    pub preset_runs: usize,
}

/// Runs the study on a CAD scene; each row goes to `out` as it is measured.
pub fn run_scene(
    scene: &Scene,
    scenarios: &[Scenario],
    truth: &[TruthRow],
    o: &StudyOptions,
    out: &mut dyn FnMut(&Measured),
) -> Result<Vec<Measured>, StudyError> {
    let mut all = Vec::new();
    let mut presets = SceneStudy::new(scene, scenarios, truth, o.preset_runs);
    for v in preset_variants() {
        let m = presets.measure(&v)?;
        out(&m);
        all.push(m);
    }
    let mut study = SceneStudy::new(scene, scenarios, truth, o.runs);
    let mut list = Vec::new();
    if o.knobs {
        list.extend(knob_variants());
    }
    list.extend(grid_variants(&o.grid_rays, &o.grid_sizes_m));
    for v in list {
        let m = study.measure(&v)?;
        out(&m);
        all.push(m);
    }
    Ok(all)
}

/// Runs the capture-set variant; each row goes to `out` as it is measured.
pub fn run_capture(
    inputs: &CaptureInputs,
    scenarios: &[Scenario],
    truth: &[TruthRow],
    out: &mut dyn FnMut(&Measured),
) -> Result<Vec<Measured>, StudyError> {
    let mut all = Vec::new();
    // the luxmeter points read office_a's desks: another room's bench skips them
    let known = |id: &u32| inputs.sensors.iter().any(|s| s.id == *id);
    for v in capture_variants()
        .into_iter()
        .filter(|v| v.luxmeter_at.iter().all(known))
    {
        let m = measure_capture(inputs, &v, scenarios, truth)?;
        out(&m);
        all.push(m);
    }
    Ok(all)
}

/// Writes the Pareto plots of a study into `dir` as `<prefix>-time.png` (engine knobs: error
/// against commissioning time), `<prefix>-time-more.png` (the other knobs and the grid) and
/// `<prefix>-size.png` (error against image size); returns the paths written.
pub fn write_plots(
    points: &[Measured],
    dir: &std::path::Path,
    prefix: &str,
    scene_name: &str,
) -> Result<Vec<std::path::PathBuf>, image::ImageError> {
    let secs = |m: &Measured| m.commission.as_secs_f64();
    let kib = |m: &Measured| m.image_bytes as f64 / 1024.0;
    let plots = [
        (
            "time",
            pareto_plot(
                &format!("{scene_name}: error vs commissioning time"),
                "commissioning time (s, log)",
                points,
                secs,
                &[
                    "rays per patch",
                    "patch size (adaptive)",
                    "adaptive refinement",
                    "opening points",
                    "direct points per patch",
                    "final gather rays",
                    "preset",
                ],
            ),
        ),
        (
            "time-more",
            pareto_plot(
                &format!("{scene_name}: error vs commissioning time (more knobs)"),
                "commissioning time (s, log)",
                points,
                secs,
                &[
                    "ray set",
                    "sensor rays",
                    "solver tolerance",
                    "rectification (closure)",
                    "room closure",
                    "luxmeter readings",
                    "grid",
                    "preset",
                ],
            ),
        ),
        (
            "size",
            pareto_plot(
                &format!("{scene_name}: error vs flash image size"),
                "image size (KiB, log)",
                points,
                kib,
                &[
                    "storage precision",
                    "pruning (u16)",
                    "rays per patch",
                    "patch size (adaptive)",
                    "adaptive refinement",
                    "preset",
                ],
            ),
        ),
    ];
    let mut written = Vec::new();
    for (name, plot) in plots {
        if plot.series.iter().all(|s| s.points.len() <= 1) {
            continue;
        }
        let path = dir.join(format!("{prefix}-{name}.png"));
        plot.draw(1000, 600).save_png(&path)?;
        written.push(path);
    }
    Ok(written)
}

/// The presets' rows as the README shows them.
pub fn preset_table(points: &[Measured]) -> String {
    let mut s = String::from(
        "| preset | patches | commissioning (s) | image (bytes) | per state (ns) | re-solve (ms) | error | worst sensor |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for m in points.iter().filter(|m| m.variant.group == "preset") {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | {:.0} | {:.1} | {:.2} % | {:.2} % |",
            m.variant.label,
            m.patches,
            m.commission.as_secs_f64(),
            m.image_bytes,
            m.per_state.as_secs_f64() * 1e9,
            m.resolve.as_secs_f64() * 1e3,
            100.0 * m.accuracy.error,
            100.0 * m.accuracy.worst_sensor
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let f = pareto_front(&[(1.0, 5.0), (2.0, 6.0), (3.0, 1.0), (0.5, 9.0), (4.0, 1.0)]);
        assert_eq!(f, vec![(0.5, 9.0), (1.0, 5.0), (3.0, 1.0)]);
    }

    #[test]
    fn every_knob_is_swept_and_the_balanced_point_is_marked() {
        let v = knob_variants();
        for g in [
            "rays per patch",
            "ray set",
            "patch size (adaptive)",
            "adaptive refinement",
            "opening points",
            "solver tolerance",
            "rectification (closure)",
            "storage precision",
            "pruning (u16)",
        ] {
            let n = v.iter().filter(|x| x.group == g).count();
            assert!(n >= 2, "{g}: {n}");
        }
        let marked = v.iter().filter(|x| x.label.ends_with('*')).count();
        assert!(marked >= 10, "{marked}");
    }
}
