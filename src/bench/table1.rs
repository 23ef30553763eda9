//! The paper's Table 1, CAD vs RGBD rows: commissioning office_a from its capture sets (clean
//! and noisy depth), with and without room closure, with true or estimated reflectances, scored
//! against the Radiance truth over every desk and over the desks the camera sees.
//!
//! "True reflectances" need the capture's `groundtruth/albedo.png`, which commissioning never
//! reads: each seen triangle gets the median albedo over the pixels that see it (its part's
//! median if none), the inferred floor the seen floor's, walls and ceiling the CAD's values
//! (0.6 and 0.8) when the room is closed. "In view" are the sensors that
//! `groundtruth/sensor_pixels.csv` marks visible. `luxnode bench table1` prints the rows of
//! docs/accuracy.md.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::camera::capture::Capture;
use crate::commission::{self, CommissionOptions, Commissioned, Part, ReflectanceMethod};
use crate::engine::raycast::{Hit, RayCaster};
use crate::engine::{self, Model};
use crate::evaluate::{per_sensor, pooled, readings};
use crate::scene::{
    LoadOptions, Scenario, TruthRow, load_desks_file, load_luminaires_file, load_sensors_file,
    read_states, read_truth,
};

/// Why the table could not be made.
#[derive(Debug, thiserror::Error)]
pub enum Table1Error {
    /// A scene file is missing or wrong.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// Scene files are missing or wrong.
    #[error(transparent)]
    Scenes(#[from] crate::scene::SceneErrors),
    /// Commissioning failed.
    #[error(transparent)]
    Commission(#[from] crate::commission::CommissionError),
    /// The engine failed.
    #[error(transparent)]
    Engine(#[from] crate::engine::EngineError),
    /// A ground-truth file of the capture is missing or wrong.
    #[error("{}: {reason}", path.display())]
    GroundTruth {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// Depth of a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Depth {
    /// `capture_clean`: one exact depth frame.
    Clean,
    /// `capture`: five frames with the ToF error model.
    Noisy,
}

impl Depth {
    fn dir(self) -> &'static str {
        match self {
            Depth::Clean => "capture_clean",
            Depth::Noisy => "capture",
        }
    }

    /// Its name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Depth::Clean => "clean",
            Depth::Noisy => "noisy",
        }
    }
}

/// Reflectances of a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rho {
    /// From `groundtruth/albedo.png`.
    True,
    /// Estimated, median of π L / E.
    Median,
    /// Estimated, first-order spherical harmonics.
    Sh,
}

impl Rho {
    /// Its name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Rho::True => "true",
            Rho::Median => "estimated, median",
            Rho::Sh => "estimated, SH",
        }
    }
}

/// One row.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The model: reconstructed from depth, or the reconstruction clipped to the view.
    pub model: &'static str,
    /// Depth frames.
    pub depth: Depth,
    /// Room closure on.
    pub closure: bool,
    /// Reflectances.
    pub rho: Rho,
    /// Error over all sensors.
    pub error_all: f64,
    /// Error over the sensors in view.
    pub error_in_view: f64,
    /// The worst in-view sensor's error.
    pub worst_in_view: f64,
}

/// The rows of docs/accuracy.md, in its order: (model, depth, closure, reflectances).
pub const ROWS: [(&str, Depth, bool, Rho); 10] = [
    (
        "CAD clipped to the camera view (*)",
        Depth::Clean,
        false,
        Rho::True,
    ),
    ("RGBD", Depth::Clean, true, Rho::True),
    ("RGBD", Depth::Clean, true, Rho::Median),
    ("RGBD", Depth::Clean, true, Rho::Sh),
    ("RGBD", Depth::Clean, false, Rho::Median),
    ("RGBD", Depth::Noisy, true, Rho::True),
    ("RGBD", Depth::Noisy, true, Rho::Median),
    ("RGBD", Depth::Noisy, true, Rho::Sh),
    ("RGBD", Depth::Noisy, false, Rho::Median),
    ("RGBD", Depth::Noisy, false, Rho::Sh),
];

/// The markdown header of [`Row::markdown`].
pub const HEADER: &str = "| model | depth | closure | reflectances | error (all 8) | in view | worst in view |\n|---|---|---|---|---:|---:|---:|";

impl Row {
    /// The row as a markdown table line.
    pub fn markdown(&self) -> String {
        format!(
            "| {} | {} | {} | {} | {:.2} % | {:.2} % | {:.2} % |",
            self.model,
            self.depth.name(),
            if self.closure { "on" } else { "off" },
            self.rho.name(),
            100.0 * self.error_all,
            100.0 * self.error_in_view,
            100.0 * self.worst_in_view
        )
    }
}

struct Inputs {
    dir: PathBuf,
    states: Vec<Scenario>,
    truth: Vec<TruthRow>,
}

fn ground_truth_error(path: &Path, reason: impl ToString) -> Table1Error {
    Table1Error::GroundTruth {
        path: path.to_owned(),
        reason: reason.to_string(),
    }
}

/// The sensors `groundtruth/sensor_pixels.csv` marks visible.
fn in_view(capture: &Path) -> Result<Vec<u32>, Table1Error> {
    let path = capture.join("groundtruth/sensor_pixels.csv");
    let text = std::fs::read_to_string(&path).map_err(|e| ground_truth_error(&path, e))?;
    Ok(text
        .lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f.last() == Some(&"1"))
                .then(|| f.first().and_then(|s| s.parse().ok()))
                .flatten()
        })
        .collect())
}

fn commission(
    inputs: &Inputs,
    capture: &Path,
    o: &CommissionOptions,
) -> Result<Commissioned, Table1Error> {
    let load = LoadOptions::default();
    let (lums, _) = load_luminaires_file(&inputs.dir.join("luminaires.json"), &load)?;
    let (sensors, _) = load_sensors_file(&inputs.dir.join("sensors.json"), &load)?;
    let desks = load_desks_file(&inputs.dir.join("desks.json"), &load).ok();
    let ids: Vec<u32> = lums.iter().map(|l| l.id).collect();
    let cap = Capture::load(capture, &ids).map_err(commission::CommissionError::from)?;
    Ok(commission::from_capture(&cap, lums, sensors, desks, o)?)
}

/// The commissioned geometry with true reflectances (see the module docs), full settings.
fn true_rho_model(c: &Commissioned, capture: &Path) -> Result<Model, Table1Error> {
    let path = capture.join("groundtruth/albedo.png");
    let albedo = image::open(&path)
        .map_err(|e| ground_truth_error(&path, e))?
        .to_luma16();
    let Some(cam) = c.scene.camera.as_ref() else {
        return Err(ground_truth_error(
            capture,
            "the commissioned scene has no camera",
        ));
    };
    if (albedo.width(), albedo.height()) != (cam.width, cam.height) {
        return Err(ground_truth_error(&path, "not the camera's size"));
    }
    let caster = RayCaster::new(&c.model.patches);
    let n_tri = c.reco.tris.len();
    let mut per_tri: Vec<Vec<f64>> = vec![Vec::new(); n_tri];
    for v in 0..cam.height {
        for u in 0..cam.width {
            let Some(d) = cam.ray_world(f64::from(u), f64::from(v)) else {
                continue;
            };
            let Hit::Front { patch, .. } = caster.closest(cam.position_m, d) else {
                continue;
            };
            let t = c.model.patches.source_triangle[patch as usize] as usize;
            if t < n_tri && c.reco.part[t].seen() {
                per_tri[t].push(f64::from(albedo.get_pixel(u, v)[0]) / 10000.0);
            }
        }
    }
    let med = |v: &mut Vec<f64>| -> Option<f64> {
        v.sort_by(f64::total_cmp);
        (!v.is_empty()).then(|| v[v.len() / 2])
    };
    let mut by_part: HashMap<Part, Vec<f64>> = HashMap::new();
    for (t, v) in per_tri.iter().enumerate() {
        by_part.entry(c.reco.part[t]).or_default().extend(v);
    }
    let part_med: HashMap<Part, f64> = by_part
        .into_iter()
        .filter_map(|(k, mut v)| med(&mut v).map(|m| (k, m)))
        .collect();
    // the floor: the seen plane with the largest area at z ≈ 0
    let floor = c
        .report
        .planes
        .iter()
        .enumerate()
        .filter(|(_, p)| p.normal.z > 0.99 && p.origin_m.z.abs() < 0.05)
        .max_by(|a, b| a.1.area_m2.total_cmp(&b.1.area_m2))
        .and_then(|(k, _)| part_med.get(&Part::Plane(k as u32)).copied())
        .unwrap_or(0.25);
    let rho: Vec<f64> = (0..n_tri)
        .map(|t| {
            let part = c.reco.part[t];
            if part.seen() {
                med(&mut per_tri[t])
                    .or_else(|| part_med.get(&part).copied())
                    .unwrap_or(0.5)
            } else if part == Part::FloorFill {
                floor
            } else if let Part::HiddenFace(k) = part {
                // a thin object's hidden face: the material of its seen face
                part_med
                    .get(&Part::Plane(k))
                    .copied()
                    .unwrap_or(c.scene.mesh.materials[t].rho.get())
            } else {
                c.scene.mesh.materials[t].rho.get()
            }
        })
        .collect();
    let mut scene = c.scene.clone();
    scene.mesh = commission::to_mesh(&c.reco, &rho);
    Ok(engine::compute_model(&scene, &c.model.settings)?)
}

/// One row of the table.
pub fn row(
    scene_dir: &Path,
    model: &'static str,
    depth: Depth,
    closure: bool,
    rho: Rho,
) -> Result<Row, Table1Error> {
    let inputs = Inputs {
        dir: scene_dir.to_owned(),
        states: read_states(&scene_dir.join("states.csv"))?,
        truth: read_truth(&scene_dir.join("truth.csv"))?,
    };
    let capture = scene_dir.join(depth.dir());
    let mut o = CommissionOptions::default();
    o.closure.enabled = closure;
    match rho {
        Rho::Median => {}
        Rho::Sh => o.reflectance.method = ReflectanceMethod::SphericalHarmonics,
        Rho::True => {
            o.estimate_reflectances = false;
            o.closure.wall_rho = 0.6;
            o.closure.ceiling_rho = 0.8;
        }
    }
    let mut c = commission(&inputs, &capture, &o)?;
    if rho == Rho::True {
        c.model = true_rho_model(&c, &capture)?;
    }
    let m = &c.model;
    let computed = readings(&inputs.states, &m.luminaire_ids, &m.sensor_ids, |l| {
        m.sensor_lux(l)
    })?;
    let errors = per_sensor(&computed, &inputs.truth, &m.sensor_ids);
    let view = in_view(&capture)?;
    let all: Vec<_> = errors.iter().collect();
    let seen: Vec<_> = errors.iter().filter(|e| view.contains(&e.sensor)).collect();
    Ok(Row {
        model,
        depth,
        closure,
        rho,
        error_all: pooled(&all),
        error_in_view: pooled(&seen),
        worst_in_view: seen.iter().map(|e| e.error()).fold(0.0, f64::max),
    })
}

/// Every row of [`ROWS`], each handed to `each` as it is done.
pub fn run(scene_dir: &Path, mut each: impl FnMut(&Row)) -> Result<Vec<Row>, Table1Error> {
    let mut out = Vec::new();
    for (model, depth, closure, rho) in ROWS {
        let r = row(scene_dir, model, depth, closure, rho)?;
        each(&r);
        out.push(r);
    }
    Ok(out)
}
