//! The lighting engine: from a [`Scene`] to a commissioned [`Model`] that answers the
//! illuminance at every sensor (and patch) for any dimming state.
//!
//! ```text
//! scene ─► patches ─► BVH ─► form factors (Isocell, CSR) ─► rectification
//!                       └──► direct light per luminaire (photometry × opening × shadow rays)
//!                       └──► sensor gather rows (Isocell from each sensor, s(θ)/cos θ)
//!   per luminaire at 100 %: solve B = ρ (E_dir + F B)  ─► basis exitances, response matrix
//! ```
//!
//! Radiosity is linear in emission, so each luminaire is solved once at 100 %; a dimming state
//! (a level `x_l` in [0, 1] per luminaire) is then a weighted sum: `E_s = Σ_l x_l R_sl`
//! (superposition). [`Model::solve_state`] re-solves the whole system for a state as a check.
//!
//! Sensor reading (physics.md §3.5): `E_s = Σ_l x_l E^dir_sl + Σ_j G_sj B_j` where the direct part
//! weighs each opening point by the sensor's response s(θ) and `G_sj = (1/N) Σ_{rays k → j}
//! s(θ_k)/cos θ_k` over a cosine-distributed Isocell set from the sensor.
//!
//! The paper's formulation ([`DirectModel::Paper`]) is kept for the ablation: the luminaire's
//! opening emits rays weighted by its LDC (`I`, not the consistent `I / cos γ`), its flux lands
//! on the patches it hits, and sensors see the opening as a Lambertian patch of exitance Φ/A.

pub mod daylight;
pub mod dense;
pub mod direct;
pub mod ffprofile;
pub mod formfactor;
pub mod multisolve;
pub mod patches;
pub mod points;
pub mod raycast;
pub mod rayset;

use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

pub use formfactor::{Csr, FormFactors, RectifyReport};
pub use patches::{PatchSettings, Patches};
pub use rayset::{RaySet, RaySetKind, isocell_count};

use crate::lsc::AngularResponse;
use crate::photometry::IntensityDistribution;
use crate::scene::{Luminaire, Scene};
use crate::solver::{self, CsrSystem, SolveOptions, SolveReport};
use direct::Receiver;
use raycast::{Hit, RayCaster};
use rayset::{frame, to_world};

/// Fewest points over a luminaire's opening for a sensor's direct light.
pub const SENSOR_OPENING_POINTS: usize = 256;

/// Points over a luminaire's opening for the direct light at final-gather hit points farther
/// than four opening diagonals from it (centred: [`direct::centred_opening_points`]).
pub const FAR_OPENING_POINTS: usize = 4;

/// How direct light reaches patches and sensors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectModel {
    /// Exact: photometry over the opening, inverse square, shadow rays.
    Exact,
    /// The paper: LDC-weighted rays from the opening patches.
    Paper,
}

/// Every knob of the engine.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Patch subdivision.
    pub patches: PatchSettings,
    /// Rays per patch (Isocell rounds up: 1000 → 1083). 300 by default: with the final gather
    /// the patches carry only the second and later bounces, and office_a's error is flat from
    /// 100 to 10 000 rays (docs/tradeoffs.md).
    pub rays: usize,
    /// Rays per sensor.
    pub sensor_rays: usize,
    /// Final gather from each sensor: rays whose hit points get exact direct light, so the first
    /// bounce seen by a sensor does not depend on the patch size (0 turns it off).
    pub final_gather_rays: usize,
    /// Isocell or Monte Carlo.
    pub ray_set: RaySetKind,
    /// Points over each luminaire's opening for direct light on patches (and at final-gather hit
    /// points near a luminaire). Sensors use 16 times as many, at least
    /// [`SENSOR_OPENING_POINTS`]: they are few, and a partial shadow right next to one (a monitor
    /// edge) decides its reading.
    pub opening_samples: usize,
    /// Points per patch at which direct light is averaged.
    pub patch_direct_points: usize,
    /// Exact or paper direct light.
    pub direct: DirectModel,
    /// Use the luminaires' LDC (off: a Lambertian luminaire of the same flux).
    pub ldc: bool,
    /// Use the sensors' LSC (off: ideal cosine sensors).
    pub lsc: bool,
    /// Reciprocity and closure rectification of the form factors.
    pub rectify: bool,
    /// Rectification stops when every row sum is this close to its closure target.
    pub rectify_tolerance: f64,
    /// Solver stop.
    pub solve: SolveOptions,
    /// Seed for every pseudo-random choice (per-patch jitter, Monte Carlo sets).
    pub seed: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            patches: PatchSettings::default(),
            rays: 300,
            sensor_rays: 10_000,
            final_gather_rays: 1000,
            ray_set: RaySetKind::Isocell,
            opening_samples: 8,
            patch_direct_points: 4,
            direct: DirectModel::Exact,
            ldc: true,
            lsc: true,
            rectify: true,
            rectify_tolerance: 1e-9,
            solve: SolveOptions::default(),
            seed: 1,
        }
    }
}

/// Why the engine could not produce a model.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// A knob is out of range.
    #[error("invalid setting: {0}")]
    Settings(String),
    /// The scene has nothing to compute on.
    #[error("nothing to compute: {0}")]
    Empty(String),
    /// A radiosity solve failed.
    #[error("radiosity solve for {what}: {source}")]
    Solve {
        /// Which solve.
        what: String,
        /// Why.
        source: solver::SolveError,
    },
    /// A dimming state does not fit the model.
    #[error("dimming state: {0}")]
    State(String),
    /// The work a setting asks for is beyond what a node can do (estimated before any of it).
    #[error("too much work: {0}")]
    TooMuchWork(String),
    /// A luminaire that has flux lights nothing (inside or behind a surface).
    #[error("luminaire {id}: {reason}")]
    Luminaire {
        /// Its id.
        id: u32,
        /// What is wrong.
        reason: String,
    },
}

/// Counts and timings of one commissioning.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Patches.
    pub patches: usize,
    /// Rays per patch.
    pub rays_per_patch: usize,
    /// Rays per sensor.
    pub rays_per_sensor: usize,
    /// Non-zero form factors.
    pub nnz: usize,
    /// Area-weighted mean fraction of patch rays that left the scene.
    pub escaped_fraction: f64,
    /// Covered fraction of the reflecting surface area (hidden behind or under other objects).
    pub covered_fraction: f64,
    /// Rectification outcome.
    pub rectify: Option<RectifyReport>,
    /// Solver iterations per luminaire.
    pub iterations: Vec<u32>,
    /// (stage, wall time).
    pub timings: Vec<(&'static str, Duration)>,
}

impl Stats {
    /// Total wall time.
    pub fn total(&self) -> Duration {
        self.timings.iter().map(|t| t.1).sum()
    }
}

/// A commissioned model: everything needed to answer any dimming state.
#[derive(Debug, Clone)]
pub struct Model {
    /// The settings it was made with.
    pub settings: Settings,
    /// The patches.
    pub patches: Patches,
    /// Form factors (rectified when the setting says so).
    pub ff: FormFactors,
    /// Luminaire ids, in scene order (the order of every per-luminaire array).
    pub luminaire_ids: Vec<u32>,
    /// Luminaire flux at 100 %, lm.
    pub luminaire_flux_lm: Vec<f64>,
    /// Sensor ids, in scene order.
    pub sensor_ids: Vec<u32>,
    /// Direct illuminance per luminaire at 100 % on each patch, lx: `[luminaire][patch]`.
    pub direct_patch_lx: Vec<Vec<f64>>,
    /// Direct reading per luminaire at 100 % at each sensor, lx: `[sensor][luminaire]`.
    pub direct_sensor_lx: Vec<Vec<f64>>,
    /// First bounce per luminaire at 100 % seen by each sensor, from the final gather, lx:
    /// `[sensor][luminaire]` (zeros without final gather).
    pub first_bounce_sensor_lx: Vec<Vec<f64>>,
    /// True when the gather rows apply to the exitance *beyond* the first bounce
    /// (`B − ρ E^dir`), the first bounce coming from [`Model::first_bounce_sensor_lx`].
    pub final_gather: bool,
    /// Sensor gather rows over patches (weights `s/cos / N`).
    pub gather: Csr,
    /// Exitance per luminaire at 100 %, lm/m²: `[luminaire][patch]`.
    pub basis_b: Vec<Vec<f64>>,
    /// Sensor reading per luminaire at 100 %, lx: `[sensor][luminaire]`.
    pub response_lx: Vec<Vec<f64>>,
    /// Cosine error f2 of each sensor as modelled.
    pub sensor_f2: Vec<f64>,
    /// Counts and timings.
    pub stats: Stats,
}

fn timed<T>(stats: &mut Stats, stage: &'static str, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    stats.timings.push((stage, t0.elapsed()));
    out
}

/// A Lambertian distribution with the same flux (the "no LDC" ablation).
fn lambertian_like(d: &IntensityDistribution) -> IntensityDistribution {
    let flux = d.flux_lm();
    let shape = IntensityDistribution::from_gamma_fn(1.0, "lambertian", |g| {
        if g < std::f64::consts::FRAC_PI_2 {
            g.cos()
        } else {
            0.0
        }
    });
    shape.scaled_to_flux(flux).unwrap_or(shape)
}

fn check_settings(s: &Settings) -> Result<(), EngineError> {
    let p = &s.patches;
    let bad = |m: &str| Err(EngineError::Settings(m.to_owned()));
    if !(p.patch_size_m.is_finite() && p.patch_size_m > 0.0) {
        return bad("patch size must be a length > 0 m");
    }
    if !(p.min_patch_m.is_finite() && p.min_patch_m > 0.0) {
        return bad("minimum patch size must be a length > 0 m");
    }
    if !(p.detail_ratio.is_finite() && p.detail_ratio >= 0.0) {
        return bad("detail ratio must be >= 0");
    }
    if s.rays == 0 || s.rays > 1_000_000 {
        return bad("rays per patch must be 1..=1000000");
    }
    if s.sensor_rays == 0 || s.sensor_rays > 10_000_000 {
        return bad("rays per sensor must be 1..=10000000");
    }
    if s.final_gather_rays > 1_000_000 {
        return bad("final gather rays must be 0..=1000000");
    }
    if s.opening_samples == 0 || s.opening_samples > 4096 {
        return bad("opening samples must be 1..=4096");
    }
    if s.patch_direct_points == 0 || s.patch_direct_points > 4096 {
        return bad("direct points per patch must be 1..=4096");
    }
    if !(s.solve.tolerance.is_finite() && s.solve.tolerance > 0.0) {
        return bad("solver tolerance must be > 0");
    }
    Ok(())
}

/// The luminaires as the settings model them (without LDC: Lambertian at the same flux).
fn engine_luminaires(scene: &Scene, settings: &Settings) -> Vec<Luminaire> {
    scene
        .luminaires
        .iter()
        .map(|l| {
            let mut l = l.clone();
            if !settings.ldc {
                l.photometry = std::sync::Arc::new(lambertian_like(&l.photometry));
            }
            l
        })
        .collect()
}

/// The sensors' angular responses as the settings model them (without LSC: ideal cosine).
fn sensor_responses(scene: &Scene, settings: &Settings) -> Vec<AngularResponse> {
    scene
        .sensors
        .iter()
        .map(|s| {
            if settings.lsc {
                s.response.clone()
            } else {
                AngularResponse::Cosine
            }
        })
        .collect()
}

/// Most patch rays (patches × rays per patch) a model is built with: about a quarter of an hour
/// at this 2-core machine's million rays a second (docs/performance.md).
pub const MAX_PATCH_RAYS: f64 = 1e9;

/// Refuses, before any allocation that grows with it, a patch size or ray count whose work no
/// node can do: the mesh's area at the largest patch edge gives a lower bound of the patches.
fn check_work(scene: &Scene, settings: &Settings) -> Result<(), EngineError> {
    let size_m = settings.patches.patch_size_m;
    let fewest = patches::fewest_patches(&scene.mesh, size_m);
    let area_m2: f64 = scene
        .mesh
        .triangles
        .iter()
        .map(|t| scene.mesh.area_m2(t))
        .sum();
    // the patch edge that keeps the lower bound within the limit
    let edge_m = |n: f64| (area_m2 / (3f64.sqrt() / 4.0 * n)).sqrt();
    if fewest > patches::MAX_PATCHES as f64 {
        return Err(EngineError::TooMuchWork(format!(
            "{area_m2:.0} m² of surfaces at --patch-size {size_m} m make at least {fewest:.0} \
             patches (at most {}): a patch size of at least {:.2} m (a scene in mm read as m?)",
            patches::MAX_PATCHES,
            edge_m(patches::MAX_PATCHES as f64)
        )));
    }
    Ok(())
}

/// Refuses, once the patches are made and before a ray is cast, a ray count no node can cast.
fn check_rays(patches: usize, settings: &Settings) -> Result<(), EngineError> {
    let rays = patches as f64 * settings.rays as f64;
    if rays > MAX_PATCH_RAYS {
        return Err(EngineError::TooMuchWork(format!(
            "{patches} patches × {} rays per patch = {rays:.1e} rays (at most {MAX_PATCH_RAYS:.0e}, \
             a quarter of an hour): --rays at most {:.0}, or a larger --patch-size",
            settings.rays,
            MAX_PATCH_RAYS / patches.max(1) as f64
        )));
    }
    Ok(())
}

/// Stage "patches": the mesh subdivided, finer near the sensors and near the light.
fn make_patches(
    scene: &Scene,
    settings: &Settings,
    luminaires: &[Luminaire],
    stats: &mut Stats,
) -> Result<Patches, EngineError> {
    let interest: Vec<patches::Viewpoint> = scene
        .sensors
        .iter()
        .map(|s| patches::Viewpoint {
            position_m: s.position_m,
            normal: s.normal,
        })
        .collect();
    let light_ratio = settings.patches.light_ratio;
    let mut near_light = |t: &[DVec3; 3]| -> bool {
        if light_ratio <= 0.0 {
            return false;
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        let len = (0..3)
            .map(|k| (t[(k + 1) % 3] - t[k]).length())
            .fold(0.0, f64::max);
        let radius = t.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
        luminaires.iter().any(|l| {
            let to_lum = l.position_m - c;
            let d = (to_lum.length() - radius).max(1e-9);
            if len <= light_ratio * d {
                return false;
            }
            // lit by it: some corner in front of the surface and receiving intensity
            t.iter().chain([&c]).any(|p| {
                let v = l.position_m - *p;
                v.dot(n) > 0.0 && l.intensity_toward_cd(-v.normalize_or_zero()) > 0.0
            })
        })
    };
    check_work(scene, settings)?;
    let patches = timed(stats, "patches", || {
        patches::subdivide(&scene.mesh, &settings.patches, &interest, &mut near_light)
    });
    if patches.len() > patches::MAX_PATCHES {
        return Err(EngineError::TooMuchWork(format!(
            "the refinement toward the sensors and luminaires makes more than {} patches; raise \
             --min-patch (now {} m) or --patch-size (now {} m)",
            patches::MAX_PATCHES,
            settings.patches.min_patch_m,
            settings.patches.patch_size_m
        )));
    }
    check_rays(patches.len(), settings)?;
    if patches.is_empty() {
        return Err(EngineError::Empty("no patches".into()));
    }
    Ok(patches)
}

/// Stages "form factors" and "rectification": the patches' form factors, the share of their
/// rays that escaped or hit nothing visible (in `stats`), rectified if the settings say so.
fn form_factors(
    patches: &Patches,
    caster: &RayCaster,
    rays: &RaySet,
    settings: &Settings,
    stats: &mut Stats,
) -> FormFactors {
    let mut ff = timed(stats, "form factors", || {
        formfactor::compute(patches, caster, rays, settings.seed)
    });
    let cast_area: f64 = (0..patches.len())
        .filter(|&i| ff.cast[i])
        .map(|i| patches.area_m2[i])
        .sum();
    if cast_area > 0.0 {
        let mean = |v: &[f64]| {
            (0..patches.len())
                .filter(|&i| ff.cast[i])
                .map(|i| v[i] * patches.area_m2[i])
                .sum::<f64>()
                / cast_area
        };
        stats.escaped_fraction = mean(&ff.escaped);
        stats.covered_fraction = 1.0 - mean(&ff.visible);
    }
    if settings.rectify {
        let r = timed(stats, "rectification", || {
            formfactor::rectify(&mut ff, &patches.area_m2, settings.rectify_tolerance, 500)
        });
        stats.rectify = Some(r);
    }
    ff
}

/// What the engine's stages after the patches share: the scene and settings, the luminaires and
/// sensor responses as the settings model them, the patches and their ray caster.
struct Lit<'a> {
    scene: &'a Scene,
    settings: &'a Settings,
    luminaires: &'a [Luminaire],
    responses: &'a [AngularResponse],
    patches: &'a Patches,
    caster: &'a RayCaster,
}

impl Lit<'_> {
    /// Stage "direct light": each luminaire's direct illuminance on every patch, lx.
    fn direct_on_patches(&self, rays: &RaySet) -> Vec<Vec<f64>> {
        let (settings, patches, caster) = (self.settings, self.patches, self.caster);
        let k = settings.opening_samples;
        match settings.direct {
            DirectModel::Exact => self
                .luminaires
                .iter()
                .map(|l| {
                    let near = opening_points_for(l, k);
                    let far = opening_points_for(l, FAR_OPENING_POINTS.min(k));
                    direct_on_patches(l, &near, &far, patches, caster, settings)
                })
                .collect(),
            DirectModel::Paper => self
                .luminaires
                .iter()
                .map(|l| paper_direct_on_patches(l, patches, caster, rays, settings))
                .collect(),
        }
    }

    /// Stage "sensors": each sensor's gather row and its direct illuminance per luminaire, lx.
    fn sensor_rows(&self, sensor_rays: &RaySet) -> (Csr, Vec<Vec<f64>>) {
        let settings = self.settings;
        let rows: Vec<SensorRows> = self
            .scene
            .sensors
            .par_iter()
            .zip(self.responses.par_iter())
            .map(|(s, resp)| {
                // The paper weighs sensor rays by s (normalised); without an LSC its sensor is a
                // plain hit count, which is consistent for a cosine receiver.
                let weighting = match (settings.direct, settings.lsc) {
                    (DirectModel::Paper, true) => GatherWeighting::Paper,
                    _ => GatherWeighting::Consistent,
                };
                let row = gather_row(
                    s.position_m,
                    s.normal,
                    resp,
                    self.caster,
                    sensor_rays,
                    weighting,
                );
                let direct = self.direct_on_sensor(s, resp, &row);
                (row, direct)
            })
            .collect();
        let (g, d): (Vec<_>, Vec<_>) = rows.into_iter().unzip();
        (Csr::from_rows(g), d)
    }

    /// One sensor's direct illuminance per luminaire, lx (the paper's: through its gather row).
    fn direct_on_sensor(
        &self,
        s: &crate::scene::Sensor,
        resp: &AngularResponse,
        row: &[(u32, f64)],
    ) -> Vec<f64> {
        let k = self.settings.opening_samples;
        match self.settings.direct {
            DirectModel::Exact => self
                .luminaires
                .iter()
                .map(|l| {
                    direct::illuminance_lx(
                        l,
                        &opening_points_for(l, (16 * k).max(SENSOR_OPENING_POINTS)),
                        s.position_m,
                        s.normal,
                        Receiver::Sensor(resp),
                        self.caster,
                    )
                })
                .collect(),
            DirectModel::Paper => self
                .luminaires
                .iter()
                .map(|l| {
                    let (ids, area) = opening_patches(l, self.patches);
                    if area <= 0.0 {
                        return 0.0;
                    }
                    let exitance = l.flux_lm / area;
                    row.iter()
                        .filter(|(j, _)| ids.contains(j))
                        .map(|(_, w)| w * exitance)
                        .sum()
                })
                .collect(),
        }
    }

    /// A luminaire with flux that reaches no patch and no sensor is mounted inside or behind a
    /// surface: an error, not a silent zero (exact direct light only).
    fn check_lit(
        &self,
        direct_patch_lx: &[Vec<f64>],
        direct_sensor_lx: &[Vec<f64>],
    ) -> Result<(), EngineError> {
        if self.settings.direct != DirectModel::Exact {
            return Ok(());
        }
        for (l, lum) in self.luminaires.iter().enumerate() {
            let lights_patch = direct_patch_lx[l].iter().any(|e| *e > 0.0);
            let lights_sensor = direct_sensor_lx.iter().any(|row| row[l] > 0.0);
            if lum.flux_lm > 0.0 && !lights_patch && !lights_sensor {
                let p = lum.position_m;
                return Err(EngineError::Luminaire {
                    id: lum.id,
                    reason: format!(
                        "it has {:.0} lm but lights no surface and no sensor: its opening at ({:.3}, {:.3}, {:.3}) m is inside or behind a surface, or aimed into one; check its position and aim",
                        lum.flux_lm, p.x, p.y, p.z
                    ),
                });
            }
        }
        Ok(())
    }

    /// Stage "final gather": each sensor's first-bounce illuminance per luminaire, lx.
    fn final_gather(&self) -> Vec<Vec<f64>> {
        let settings = self.settings;
        let k = settings.opening_samples;
        let set = RaySet::new(settings.ray_set, settings.final_gather_rays);
        let near: Vec<Vec<DVec3>> = self
            .luminaires
            .iter()
            .map(|l| opening_points_for(l, k))
            .collect();
        let far: Vec<Vec<DVec3>> = self
            .luminaires
            .iter()
            .map(|l| opening_points_for(l, FAR_OPENING_POINTS))
            .collect();
        self.scene
            .sensors
            .par_iter()
            .zip(self.responses.par_iter())
            .map(|(s, resp)| {
                first_bounce(
                    s.position_m,
                    s.normal,
                    resp,
                    self.caster,
                    &set,
                    self.patches,
                    self.luminaires,
                    &near,
                    &far,
                )
            })
            .collect()
    }
}

/// Stage "solve": one solve per luminaire at 100 %, all luminaires in the same sweeps
/// (multisolve): each luminaire's patch exitance, lm/m² (iterations in `stats`).
fn solve_basis(
    ff: &FormFactors,
    patches: &Patches,
    direct_patch_lx: &[Vec<f64>],
    settings: &Settings,
    stats: &mut Stats,
) -> Result<Vec<Vec<f64>>, EngineError> {
    let solved = timed(stats, "solve", || {
        multisolve::solve_all(&ff.f, &patches.rho, direct_patch_lx, settings.solve)
    });
    let solved = solved.map_err(|source| EngineError::Solve {
        what: format!("{} luminaires at 100 %", direct_patch_lx.len()),
        source,
    })?;
    let mut basis_b = Vec::with_capacity(direct_patch_lx.len());
    for (b, report) in solved {
        stats.iterations.push(report.iterations);
        basis_b.push(b);
    }
    Ok(basis_b)
}

/// Each sensor's illuminance per luminaire at 100 %, lx: direct, first bounce (with the final
/// gather) and the exitance it gathers from the patches (beyond the first bounce with it).
fn sensor_response_lx(
    patches: &Patches,
    basis_b: &[Vec<f64>],
    direct_patch_lx: &[Vec<f64>],
    final_gather: bool,
    sensors: (&Csr, &[Vec<f64>], &[Vec<f64>]),
) -> Result<Vec<Vec<f64>>, EngineError> {
    let (gather, direct_sensor_lx, first_bounce_sensor_lx) = sensors;
    // Exitance a sensor gathers from the patches: all of it, or beyond the first bounce.
    let beyond_first: Vec<Vec<f64>> = basis_b
        .iter()
        .zip(direct_patch_lx)
        .map(|(b, e)| {
            if final_gather {
                b.iter()
                    .zip(e)
                    .zip(&patches.rho)
                    .map(|((b, e), r)| b - r * e)
                    .collect()
            } else {
                b.clone()
            }
        })
        .collect();
    let response_lx: Vec<Vec<f64>> = (0..direct_sensor_lx.len())
        .map(|s| {
            (0..basis_b.len())
                .map(|l| {
                    direct_sensor_lx[s][l]
                        + first_bounce_sensor_lx[s][l]
                        + gather_dot(gather, s, &beyond_first[l])
                })
                .collect()
        })
        .collect();
    if response_lx.iter().flatten().any(|x| !x.is_finite()) {
        return Err(EngineError::State("a sensor response is not finite".into()));
    }
    Ok(response_lx)
}

/// Commissions a scene: patches, form factors, direct light, sensor rows, one solve per
/// luminaire.
pub fn compute_model(scene: &Scene, settings: &Settings) -> Result<Model, EngineError> {
    check_settings(settings)?;
    if scene.mesh.triangles.is_empty() {
        return Err(EngineError::Empty("the scene has no geometry".into()));
    }
    let mut stats = Stats::default();
    let luminaires = engine_luminaires(scene, settings);
    let responses = sensor_responses(scene, settings);
    let patches = make_patches(scene, settings, &luminaires, &mut stats)?;
    let caster = timed(&mut stats, "bvh", || RayCaster::new(&patches));
    let rays = RaySet::new(settings.ray_set, settings.rays);
    let ff = form_factors(&patches, &caster, &rays, settings, &mut stats);
    let lit = Lit {
        scene,
        settings,
        luminaires: &luminaires,
        responses: &responses,
        patches: &patches,
        caster: &caster,
    };
    let direct_patch_lx = timed(&mut stats, "direct light", || lit.direct_on_patches(&rays));
    let sensor_rays = RaySet::new(settings.ray_set, settings.sensor_rays);
    let (gather, direct_sensor_lx) = timed(&mut stats, "sensors", || lit.sensor_rows(&sensor_rays));
    lit.check_lit(&direct_patch_lx, &direct_sensor_lx)?;
    let basis_b = solve_basis(&ff, &patches, &direct_patch_lx, settings, &mut stats)?;
    let final_gather = settings.final_gather_rays > 0 && settings.direct == DirectModel::Exact;
    let first_bounce_sensor_lx: Vec<Vec<f64>> = if final_gather {
        timed(&mut stats, "final gather", || lit.final_gather())
    } else {
        vec![vec![0.0; luminaires.len()]; scene.sensors.len()]
    };
    let response_lx = sensor_response_lx(
        &patches,
        &basis_b,
        &direct_patch_lx,
        final_gather,
        (&gather, &direct_sensor_lx, &first_bounce_sensor_lx),
    )?;
    stats.patches = patches.len();
    stats.rays_per_patch = rays.len();
    stats.rays_per_sensor = sensor_rays.len();
    stats.nnz = ff.f.nnz();
    Ok(Model {
        settings: settings.clone(),
        patches,
        ff,
        luminaire_ids: luminaires.iter().map(|l| l.id).collect(),
        luminaire_flux_lm: luminaires.iter().map(|l| l.flux_lm).collect(),
        sensor_ids: scene.sensors.iter().map(|s| s.id).collect(),
        direct_patch_lx,
        direct_sensor_lx,
        first_bounce_sensor_lx,
        final_gather,
        gather,
        basis_b,
        response_lx,
        sensor_f2: responses.iter().map(AngularResponse::f2).collect(),
        stats,
    })
}

/// Where the time per ray goes in the form-factor stage of `scene` at `settings`:
/// [`ffprofile::profile`] on `sample` of its patches (one thread).
pub fn form_factor_profile(
    scene: &Scene,
    settings: &Settings,
    sample: usize,
) -> Result<ffprofile::RayProfile, EngineError> {
    check_settings(settings)?;
    let luminaires = engine_luminaires(scene, settings);
    let patches = make_patches(scene, settings, &luminaires, &mut Stats::default())?;
    let caster = RayCaster::new(&patches);
    let rays = RaySet::new(settings.ray_set, settings.rays);
    Ok(ffprofile::profile(
        &patches,
        &caster,
        &rays,
        settings.seed,
        sample,
    ))
}

/// Largest system [`dense_solve`] accepts (an n × n f64 matrix: 128 MiB at 4096).
pub const DENSE_SOLVE_MAX_PATCHES: usize = 4096;

/// Solves `B = ρ (E^dir + F B)` directly, `(I − diag(ρ) F) B = ρ E^dir`, by LU decomposition
/// (nalgebra): the cross-check for the iterative solver on small systems.
pub fn dense_solve(f: &Csr, rho: &[f64], e_direct_lx: &[f64]) -> Result<Vec<f64>, EngineError> {
    let n = rho.len();
    if n > DENSE_SOLVE_MAX_PATCHES {
        return Err(EngineError::Settings(format!(
            "dense solve is for at most {DENSE_SOLVE_MAX_PATCHES} patches, not {n}"
        )));
    }
    let system = CsrSystem { f: f.view(), rho };
    f.view().validate(n).map_err(|source| EngineError::Solve {
        what: "dense solve".into(),
        source,
    })?;
    solver::check_inputs(&system, e_direct_lx).map_err(|source| EngineError::Solve {
        what: "dense solve".into(),
        source,
    })?;
    let mut a = nalgebra::DMatrix::<f64>::identity(n, n);
    for (i, r) in rho.iter().enumerate() {
        for (j, v) in f.row(i) {
            a[(i, j as usize)] -= r * v;
        }
    }
    let rhs = nalgebra::DVector::from_iterator(n, rho.iter().zip(e_direct_lx).map(|(r, e)| r * e));
    let b = a.lu().solve(&rhs).ok_or(EngineError::Solve {
        what: "dense solve".into(),
        source: solver::SolveError::Diverged,
    })?;
    let out: Vec<f64> = b.iter().copied().collect();
    finite(out)
}

/// The last gate: a non-finite reading is an error, never a published value.
fn finite(v: Vec<f64>) -> Result<Vec<f64>, EngineError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(EngineError::State(
            "a computed illuminance is not finite".into(),
        ))
    }
}

fn gather_dot(g: &Csr, s: usize, b: &[f64]) -> f64 {
    g.row(s).map(|(j, w)| w * b[j as usize]).sum()
}

fn opening_points_for(l: &Luminaire, k: usize) -> Vec<DVec3> {
    direct::centred_opening_points(l, k)
}

/// Direct illuminance averaged over each patch (`patch_direct_points` area samples). Patches
/// farther from the luminaire than four opening diagonals use the `far` opening points (fewer:
/// centred, they give the far field to second order), as the final gather does.
fn direct_on_patches(
    l: &Luminaire,
    near: &[DVec3],
    far: &[DVec3],
    patches: &Patches,
    caster: &RayCaster,
    settings: &Settings,
) -> Vec<f64> {
    let m = settings.patch_direct_points;
    (0..patches.len())
        .into_par_iter()
        .map(|i| {
            let n = patches.normal[i];
            // Nothing to do for a patch entirely behind the luminaire or facing away from it.
            let corners = patches.corners_m[i];
            let sees = corners.iter().any(|c| (l.position_m - *c).dot(n) > 0.0);
            if !sees {
                return 0.0;
            }
            let size = l.opening_m[0].hypot(l.opening_m[1]);
            let points = if (l.position_m - patches.centroid_m(i)).length() < 4.0 * size {
                near
            } else {
                far
            };
            let (shift, _) = formfactor::patch_jitter(i, settings.seed ^ 0xD1EC7);
            let mut sum = 0.0;
            let mut uncovered = 0usize;
            for k in 0..m {
                let x = formfactor::patch_point(patches, i, k, shift);
                // a point under a cover sees the cover's back face straight up its normal
                if matches!(caster.closest(caster.offset(x, n), n), Hit::Back { .. }) {
                    continue;
                }
                uncovered += 1;
                sum += direct::illuminance_lx(l, points, x, n, Receiver::Surface, caster);
            }
            if uncovered == 0 {
                0.0
            } else {
                sum / uncovered as f64
            }
        })
        .collect()
}

/// The luminaire's opening patches (black patches within its opening, facing along its aim),
/// and their total area.
fn opening_patches(l: &Luminaire, patches: &Patches) -> (Vec<u32>, f64) {
    let reach = 0.5 * (l.opening_m[0].hypot(l.opening_m[1])) + 0.01;
    let mut ids = Vec::new();
    let mut area = 0.0;
    for i in 0..patches.len() {
        if patches.rho[i] > 0.0 {
            continue;
        }
        let c = patches.centroid_m(i);
        if (c - l.position_m).length() <= reach && patches.normal[i].dot(l.aim) > 0.9 {
            ids.push(i as u32);
            area += patches.area_m2[i];
        }
    }
    (ids, area)
}

/// The paper's direct light: rays from the opening, weighted by the LDC as the paper does
/// (`w = I(γ, C)`, normalised over the set; `w = 1`, a Lambertian patch, without LDC); each hit
/// patch receives its share of the flux.
fn paper_direct_on_patches(
    l: &Luminaire,
    patches: &Patches,
    caster: &RayCaster,
    rays: &RaySet,
    settings: &Settings,
) -> Vec<f64> {
    let mut flux_to = vec![0.0; patches.len()];
    let (ids, _) = opening_patches(l, patches);
    let emitters = ids.len().max(1);
    let mut weights = Vec::with_capacity(rays.len() * emitters);
    let mut targets = Vec::with_capacity(rays.len() * emitters);
    for e in 0..emitters {
        let (shift, azimuth) = formfactor::patch_jitter(e, settings.seed ^ u64::from(l.id));
        let fr_e = frame(l.aim, azimuth);
        for (k, d) in rays.dirs.iter().enumerate() {
            let origin = match ids.get(e) {
                Some(&p) => formfactor::patch_point(patches, p as usize, k, shift),
                None => {
                    let (u, v) = (
                        (k as f64 * 0.618_034).fract() - 0.5,
                        (k as f64 * 0.754_878).fract() - 0.5,
                    );
                    l.position_m + l.c0 * (u * l.opening_m[0]) + l.c90 * (v * l.opening_m[1])
                }
            };
            let dir = to_world(&fr_e, *d);
            let w = if settings.ldc {
                l.intensity_toward_cd(dir)
            } else {
                1.0
            };
            weights.push(w);
            targets.push(caster.closest(caster.offset(origin, l.aim), dir));
        }
    }
    let total: f64 = weights.iter().sum();
    if total <= 0.0 {
        return flux_to;
    }
    for (w, hit) in weights.iter().zip(&targets) {
        if let Hit::Front { patch, .. } = hit {
            flux_to[*patch as usize] += l.flux_lm * w / total;
        }
    }
    flux_to
        .iter()
        .zip(&patches.area_m2)
        .zip(&patches.rho)
        .map(|((f, a), rho)| if *rho > 0.0 && *a > 0.0 { f / a } else { 0.0 })
        .collect()
}

/// A sensor's gather row and its direct reading per luminaire.
type SensorRows = (Vec<(u32, f64)>, Vec<f64>);

/// The first bounce a sensor sees, per luminaire at 100 %: a gather whose every hit point gets
/// exact direct light (`Σ_k w_k ρ(y_k) E^dir_l(y_k)`, `w_k = s/cos / N`). Hit points near a
/// luminaire use its `near` opening points, others the `far` ones.
#[allow(clippy::too_many_arguments)]
fn first_bounce(
    position: DVec3,
    normal: DVec3,
    response: &AngularResponse,
    caster: &RayCaster,
    rays: &RaySet,
    patches: &Patches,
    luminaires: &[Luminaire],
    near: &[Vec<DVec3>],
    far: &[Vec<DVec3>],
) -> Vec<f64> {
    let origin = caster.offset(position, normal);
    // a different azimuth from the gather set's, so the two estimates do not share a pattern
    let fr = frame(normal, 1.0);
    let n = rays.len() as f64;
    let mut out = vec![0.0; luminaires.len()];
    for d in &rays.dirs {
        let cos = d.z.max(1e-12);
        let w = response.response(cos.acos()) / cos / n;
        if w <= 0.0 {
            continue;
        }
        let dir = to_world(&fr, *d);
        let Hit::Front { patch, t_m } = caster.closest(origin, dir) else {
            continue;
        };
        let j = patch as usize;
        let rho = patches.rho[j];
        if rho <= 0.0 {
            continue;
        }
        let y = origin + dir * t_m;
        for (k, l) in luminaires.iter().enumerate() {
            let size = l.opening_m[0].hypot(l.opening_m[1]);
            let pts = if (l.position_m - y).length() < 4.0 * size {
                &near[k]
            } else {
                &far[k]
            };
            out[k] += w
                * rho
                * direct::illuminance_lx(l, pts, y, patches.normal[j], Receiver::Surface, caster);
        }
    }
    out
}

/// How a sensor weighs the rays it gathers with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GatherWeighting {
    /// `s(θ) / cos θ / N` over cosine-distributed rays: the reading `∫ L s dω` (physics.md §3.5).
    Consistent,
    /// The paper's: `s(θ) / Σ_k s(θ_k)` (an effective response ∝ s cos θ, normalised).
    Paper,
}

/// A sensor's gather row over patches: `E = Σ_j w_j B_j` for patch exitances B.
pub fn gather_row(
    position: DVec3,
    normal: DVec3,
    response: &AngularResponse,
    caster: &RayCaster,
    rays: &RaySet,
    weighting: GatherWeighting,
) -> Vec<(u32, f64)> {
    let origin = caster.offset(position, normal);
    let fr = frame(normal, 0.0);
    let n = rays.len() as f64;
    let mut weights: Vec<(u32, f64)> = Vec::with_capacity(rays.len());
    let mut norm = 0.0;
    for d in &rays.dirs {
        let cos = d.z.max(1e-12);
        let s = response.response(cos.acos());
        let w = match weighting {
            GatherWeighting::Consistent => s / cos / n,
            GatherWeighting::Paper => s,
        };
        norm += w;
        if let Hit::Front { patch, .. } = caster.closest(origin, to_world(&fr, *d)) {
            weights.push((patch, w));
        }
    }
    if weighting == GatherWeighting::Paper && norm > 0.0 {
        for w in &mut weights {
            w.1 /= norm;
        }
    }
    weights.sort_unstable_by_key(|w| w.0);
    let mut row: Vec<(u32, f64)> = Vec::new();
    for (j, w) in weights {
        match row.last_mut() {
            Some((c, v)) if *c == j => *v += w,
            _ => row.push((j, w)),
        }
    }
    row
}

impl Model {
    /// Number of luminaires.
    pub fn luminaires(&self) -> usize {
        self.luminaire_ids.len()
    }

    /// Number of sensors.
    pub fn sensors(&self) -> usize {
        self.sensor_ids.len()
    }

    fn check_levels(&self, levels: &[f64]) -> Result<(), EngineError> {
        if levels.len() != self.luminaires() {
            return Err(EngineError::State(format!(
                "{} levels for {} luminaires",
                levels.len(),
                self.luminaires()
            )));
        }
        if let Some(x) = levels
            .iter()
            .find(|x| !(x.is_finite() && (0.0..=1.0).contains(*x)))
        {
            return Err(EngineError::State(format!("level {x} is outside [0, 1]")));
        }
        Ok(())
    }

    /// Sensor readings (lx) for a dimming state by superposition; `levels[l]` in [0, 1] in
    /// luminaire order.
    pub fn sensor_lux(&self, levels: &[f64]) -> Result<Vec<f64>, EngineError> {
        self.check_levels(levels)?;
        let lux: Vec<f64> = self
            .response_lx
            .iter()
            .map(|row| row.iter().zip(levels).map(|(r, x)| r * x).sum())
            .collect();
        finite(lux)
    }

    /// [`Model::sensor_lux`] into a caller's buffer, without allocating (the run-time path).
    pub fn sensor_lux_into(&self, levels: &[f64], out: &mut [f64]) -> Result<(), EngineError> {
        self.check_levels(levels)?;
        if out.len() != self.sensors() {
            return Err(EngineError::State("output buffer length".into()));
        }
        for (o, row) in out.iter_mut().zip(&self.response_lx) {
            let mut acc = 0.0;
            for (r, x) in row.iter().zip(levels) {
                acc += r * x;
            }
            if !acc.is_finite() {
                return Err(EngineError::State(
                    "a computed illuminance is not finite".into(),
                ));
            }
            *o = acc;
        }
        Ok(())
    }

    /// The same readings from a full re-solve of the radiosity system for the state.
    pub fn solve_state(&self, levels: &[f64]) -> Result<(Vec<f64>, SolveReport), EngineError> {
        self.check_levels(levels)?;
        let n = self.patches.len();
        let mut e = vec![0.0; n];
        for (l, x) in levels.iter().enumerate() {
            for (ei, d) in e.iter_mut().zip(&self.direct_patch_lx[l]) {
                *ei += x * d;
            }
        }
        let system = CsrSystem {
            f: self.ff.f.view(),
            rho: &self.patches.rho,
        };
        let mut b = vec![0.0; n];
        let report =
            solver::gauss_seidel(&system, &e, &mut b, self.settings.solve).map_err(|source| {
                EngineError::Solve {
                    what: "dimming state".into(),
                    source,
                }
            })?;
        if self.final_gather {
            for ((bi, ei), r) in b.iter_mut().zip(&e).zip(&self.patches.rho) {
                *bi -= r * ei;
            }
        }
        let lux = (0..self.sensors())
            .map(|s| {
                let own: f64 = self.direct_sensor_lx[s]
                    .iter()
                    .zip(&self.first_bounce_sensor_lx[s])
                    .zip(levels)
                    .map(|((d, f), x)| (d + f) * x)
                    .sum();
                own + gather_dot(&self.gather, s, &b)
            })
            .collect();
        Ok((finite(lux)?, report))
    }

    /// How the sensor readings of a dimming state change when the patches' reflectances
    /// change from the model's to `rho` (the same length, each in [0, 1)), lx per sensor, by
    /// re-solving the radiosity system with each: `Δ_s = g_s · (B' − B)`, `g_s` sensor s's
    /// gather row. With a final gather the first bounce moves with the reflectance too, and it
    /// is `g_s · (Δρ E_dir)` to the gather's accuracy, which this difference includes. Direct
    /// light does not depend on reflectance. For sensitivity studies (what an inferred
    /// reflectance's uncertainty does to a desk): two solves, no allocation beyond vectors of
    /// the patch count.
    pub fn reflectance_sensitivity_lx(
        &self,
        levels: &[f64],
        rho: &[f64],
    ) -> Result<Vec<f64>, EngineError> {
        let mut d = self.reflectance_sensitivities_lx(levels, std::slice::from_ref(&rho))?;
        Ok(d.pop().unwrap_or_default())
    }

    /// [`Model::reflectance_sensitivity_lx`] for several sets of reflectances, the model's own
    /// solve done once: one vector of sensor changes per set, in order.
    pub fn reflectance_sensitivities_lx<R: AsRef<[f64]>>(
        &self,
        levels: &[f64],
        rhos: &[R],
    ) -> Result<Vec<Vec<f64>>, EngineError> {
        self.check_levels(levels)?;
        self.check_rhos(rhos)?;
        let n = self.patches.len();
        let mut e = vec![0.0; n];
        for (l, x) in levels.iter().enumerate() {
            for (ei, d) in e.iter_mut().zip(&self.direct_patch_lx[l]) {
                *ei += x * d;
            }
        }
        let solve = |rho: &[f64]| -> Result<Vec<f64>, EngineError> {
            let system = CsrSystem {
                f: self.ff.f.view(),
                rho,
            };
            let mut b = vec![0.0; n];
            solver::gauss_seidel(&system, &e, &mut b, self.settings.solve).map_err(|source| {
                EngineError::Solve {
                    what: "reflectance sensitivity".into(),
                    source,
                }
            })?;
            Ok(b)
        };
        let b0 = solve(&self.patches.rho)?;
        rhos.iter()
            .map(|rho| {
                let b1 = solve(rho.as_ref())?;
                let db: Vec<f64> = b1.iter().zip(&b0).map(|(a, b)| a - b).collect();
                finite(
                    (0..self.sensors())
                        .map(|s| gather_dot(&self.gather, s, &db))
                        .collect(),
                )
            })
            .collect()
    }

    /// [`Model::reflectance_sensitivities_lx`] per luminaire at 100 %: for each set of
    /// reflectances, `[luminaire][sensor]` changes, lx. By linearity in the emission a dimming
    /// state's change is `Σ_l x_l Δ_l` (what a stated uncertainty per state needs,
    /// [`crate::commission::uncertainty`]). One multisolve per set (every luminaire in the same
    /// sweeps); the model's own solutions are its basis.
    pub fn reflectance_sensitivities_per_luminaire_lx<R: AsRef<[f64]>>(
        &self,
        rhos: &[R],
    ) -> Result<Vec<Vec<Vec<f64>>>, EngineError> {
        self.check_rhos(rhos)?;
        rhos.iter()
            .map(|rho| {
                let solved = multisolve::solve_all(
                    &self.ff.f,
                    rho.as_ref(),
                    &self.direct_patch_lx,
                    self.settings.solve,
                )
                .map_err(|source| EngineError::Solve {
                    what: "reflectance sensitivity per luminaire".into(),
                    source,
                })?;
                solved
                    .into_iter()
                    .zip(&self.basis_b)
                    .map(|((b1, _), b0)| {
                        let db: Vec<f64> = b1.iter().zip(b0).map(|(a, b)| a - b).collect();
                        finite(
                            (0..self.sensors())
                                .map(|s| gather_dot(&self.gather, s, &db))
                                .collect(),
                        )
                    })
                    .collect()
            })
            .collect()
    }

    /// Each set of reflectances has the patch count and lies in [0, 1).
    fn check_rhos<R: AsRef<[f64]>>(&self, rhos: &[R]) -> Result<(), EngineError> {
        let n = self.patches.len();
        for rho in rhos {
            let rho = rho.as_ref();
            if rho.len() != n {
                return Err(EngineError::State(format!(
                    "{} reflectances for {n} patches",
                    rho.len()
                )));
            }
            if let Some(r) = rho
                .iter()
                .find(|r| !(r.is_finite() && (0.0..1.0).contains(*r)))
            {
                return Err(EngineError::State(format!(
                    "reflectance {r} is outside [0, 1)"
                )));
            }
        }
        Ok(())
    }

    /// Incident illuminance on each patch (lx) for a dimming state: `E_dir + F B`.
    pub fn patch_lux(&self, levels: &[f64]) -> Result<Vec<f64>, EngineError> {
        self.check_levels(levels)?;
        let n = self.patches.len();
        let mut e = vec![0.0; n];
        let mut b = vec![0.0; n];
        for (l, x) in levels.iter().enumerate() {
            for i in 0..n {
                e[i] += x * self.direct_patch_lx[l][i];
                b[i] += x * self.basis_b[l][i];
            }
        }
        Ok((0..n)
            .map(|i| {
                e[i] + self
                    .ff
                    .f
                    .row(i)
                    .map(|(j, f)| f * b[j as usize])
                    .sum::<f64>()
            })
            .collect())
    }
}
