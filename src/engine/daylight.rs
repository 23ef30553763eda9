//! Daylight through declared windows, by daylight coefficients (issue 28, item 3).
//!
//! ```text
//! windows × Tregenza sky (145 patches + ground) ─► direct sky irradiance per patch and sensor
//!   └─► one radiosity solve per column ─► D (sensors × 146), lx per cd/m²
//! sun direction ─► direct sun per patch and sensor (shadow rays) ─► solve ─► lx per lx of E_dn
//! ```
//!
//! At run time, with `L_j` the luminance of Tregenza patch j (cd/m², e.g. from
//! [`crate::sky::cie::patch_luminances_cd_m2`]), `L_g` the ground's (cd/m²; a Lambertian ground
//! of reflectance ρ_g under a horizontal illuminance E_h has `L_g = ρ_g E_h / π`) and `E_dn` the
//! sun's direct normal illuminance (lx):
//!
//! `E_s = Σ_j D_sj L_j + D_s,ground L_g + S_s(sun) E_dn`.
//!
//! **Direct sky component.** For a receiver at x with unit normal n, column j holds
//!
//! `E_j(x) = ∫ τ(θ_w) 1_j(ω) cos θ_x V(x, ω) dω` (lx per cd/m²)
//!
//! over the directions ω that leave through a window, `1_j` selecting those in sky patch j
//! (or below the horizon for the ground column), θ_w the incidence angle at the glazing, V the
//! visibility inside the room (a ray from x to the window point through the BVH). It is sampled
//! over the window's area, `dω = cos θ_w dA / r²`, at jittered stratified points (a fixed seed,
//! [`crate::rng`]) and accumulated in f64. A patch's value is its area average: each window
//! sample pairs with its own point of the patch. The shadow rays stop short of the window point
//! (the caster's margin), so the glazing patches at the window do not block; a window rectangle
//! must lie in its glazing's plane.
//!
//! **Glazing.** `τ(θ) = τ_n · T(θ)/T(0)` with T the transmittance of a single uncoated pane of
//! refractive index 1.52: Fresnel reflectance at both faces (unpolarised light, the mean of the
//! s and p terms), the internal absorption along the refracted path, and the multiple
//! reflections between the faces, `T = (1 − r)² a / (1 − r² a²)`. This is the model of
//! Radiance's `glass` material (Radiance reference manual, "Glass": n = 1.52, its
//! transmissivity from the transmittance at normal incidence), derived here from the Fresnel
//! equations rather than fitted. [`Glazing::Constant`] keeps τ_n at every angle (the closed-form
//! tests).
//!
//! **Interreflection.** A sensor reads `E_s = E_s^dir + g_s · B` with `B = ρ (E + F B)` and
//! `g_s` its gather row over the full exitance (the model's final gather is for luminaires;
//! the daylight's first bounce comes through the patches). Rather than one radiosity solve per
//! column (146 right-hand sides), each sensor's *importance* `x_s` is solved once, over the
//! transposed form factors ([`Importance`]: one right-hand side per sensor, through
//! [`super::multisolve::solve_all`]), and then `D_sj = E_sj^dir + x_s · E_j` for every column
//! and `S_s(sun) = E_s^dir(sun) + x_s · E(sun)` for any sun, without a further solve.

use glam::DVec3;
use rayon::prelude::*;

use super::formfactor::{patch_jitter, patch_point};
use super::multisolve;
use super::patches::Patches;
use super::raycast::RayCaster;
use super::{Csr, Model};
use crate::rng::{SplitMix64, hash64};
use crate::sky::{PATCH_COUNT, SkyFrame, patch_of};
use crate::solver::{SolveError, SolveOptions};

/// Columns of a daylight-coefficient row: the 145 Tregenza patches, then the ground.
pub const COLUMNS: usize = PATCH_COUNT + 1;

/// The ground's column (directions below the horizon).
pub const GROUND_COLUMN: usize = PATCH_COUNT;

/// Refractive index of float glass (Radiance's `glass`).
pub const GLASS_INDEX: f64 = 1.52;

/// How a window's transmittance depends on the angle of incidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Glazing {
    /// A single clear pane of index [`GLASS_INDEX`] (Fresnel, absorption, interreflection).
    ClearGlass,
    /// The normal transmittance at every angle (an open hole when τ_n = 1; closed-form tests).
    Constant,
}

/// One glazed window: a rectangle `corner + u·edge_u + v·edge_v`, (u, v) ∈ [0, 1]².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// A corner, m.
    pub corner_m: DVec3,
    /// The first edge from the corner, m.
    pub edge_u_m: DVec3,
    /// The second edge from the corner (perpendicular to the first), m.
    pub edge_v_m: DVec3,
    /// Unit normal pointing into the room.
    pub inward: DVec3,
    /// Transmittance at normal incidence, in [0, 1].
    pub transmittance: f64,
    /// Its angular dependence.
    pub glazing: Glazing,
}

impl Window {
    /// The window's area, m².
    pub fn area_m2(&self) -> f64 {
        self.edge_u_m.cross(self.edge_v_m).length()
    }

    /// Transmittance at incidence angle θ given as `cos θ` (0 for `cos θ ≤ 0`).
    pub fn transmittance_at(&self, cos_theta: f64) -> f64 {
        match self.glazing {
            Glazing::Constant if cos_theta > 0.0 => self.transmittance,
            Glazing::Constant => 0.0,
            Glazing::ClearGlass => self.transmittance * clear_glass_relative(cos_theta),
        }
    }

    /// Checks the rectangle: finite, non-degenerate, its inward normal across its plane.
    pub fn check(&self) -> Result<(), DaylightError> {
        let finite = [self.corner_m, self.edge_u_m, self.edge_v_m, self.inward]
            .iter()
            .all(|v| v.is_finite());
        let n = self.edge_u_m.cross(self.edge_v_m);
        if !finite || n.length() <= 1e-12 {
            return Err(DaylightError::Window(
                "corner and edges must span a rectangle".into(),
            ));
        }
        if (self.inward.length() - 1.0).abs() > 1e-6 || n.normalize().dot(self.inward).abs() < 0.999
        {
            return Err(DaylightError::Window(
                "the inward normal must be a unit vector normal to the rectangle".into(),
            ));
        }
        if !(0.0..=1.0).contains(&self.transmittance) {
            return Err(DaylightError::Window(format!(
                "transmittance {} is outside [0, 1]",
                self.transmittance
            )));
        }
        Ok(())
    }
}

/// Transmittance of a single pane of index [`GLASS_INDEX`] for one polarisation's interface
/// reflectance `r` and one pass's internal transmittance `a`.
fn pane(r: f64, a: f64) -> f64 {
    (1.0 - r) * (1.0 - r) * a / (1.0 - r * r * a * a)
}

/// `T(θ)/T(0)` of clear float glass (Fresnel, n = 1.52), for `cos θ`; 0 at or past grazing.
///
/// The internal absorption is that of a pane of 88 % normal transmittance (6 mm clear float);
/// it changes the shape by well under 1 % between 80 % and 92 % panes.
pub fn clear_glass_relative(cos_theta: f64) -> f64 {
    if cos_theta <= 0.0 || cos_theta.is_nan() {
        return 0.0;
    }
    let n = GLASS_INDEX;
    let c = cos_theta.min(1.0);
    let transmit = |c: f64| {
        let s2 = 1.0 - c * c;
        let ct = (1.0 - s2 / (n * n)).max(0.0).sqrt();
        let rs = ((c - n * ct) / (c + n * ct)).powi(2);
        let rp = ((ct - n * c) / (ct + n * c)).powi(2);
        // internal transmittance at normal incidence so that T(0) = 0.88
        let r0 = ((n - 1.0) / (n + 1.0)).powi(2);
        let t0 = 0.88_f64;
        let q = (1.0 - r0) * (1.0 - r0);
        let a0 = (-q + (q * q + 4.0 * t0 * t0 * r0 * r0).sqrt()) / (2.0 * t0 * r0 * r0);
        let a = a0.min(1.0).powf(1.0 / ct.max(1e-12));
        0.5 * (pane(rs, a) + pane(rp, a))
    };
    (transmit(c) / transmit(1.0)).max(0.0)
}

/// The sampling knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaylightSettings {
    /// Window samples per patch and window (each paired with a point of the patch).
    pub patch_samples: usize,
    /// Window samples per sensor and window.
    pub sensor_samples: usize,
    /// Points per patch for the direct sun.
    pub sun_points: usize,
    /// Seed of the jitter.
    pub seed: u64,
}

impl Default for DaylightSettings {
    fn default() -> Self {
        Self {
            patch_samples: 64,
            sensor_samples: 4096,
            sun_points: 16,
            seed: 0xDA71,
        }
    }
}

/// Why daylight coefficients could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum DaylightError {
    /// A window is malformed.
    #[error("window: {0}")]
    Window(String),
    /// A knob or an input's size is out of range.
    #[error("daylight: {0}")]
    Input(String),
    /// A radiosity solve failed.
    #[error("daylight radiosity solve: {0}")]
    Solve(#[from] SolveError),
}

/// A dense receivers × [`COLUMNS`] matrix, row-major, f32 storage.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SkyMatrix {
    /// `values[r · COLUMNS + j]`.
    pub values: Vec<f32>,
}

impl SkyMatrix {
    fn from_rows(rows: Vec<[f64; COLUMNS]>) -> Self {
        Self {
            values: rows.iter().flatten().map(|v| *v as f32).collect(),
        }
    }

    /// Receivers.
    pub fn rows(&self) -> usize {
        self.values.len() / COLUMNS
    }

    /// Receiver `r`'s row (empty past the last).
    pub fn row(&self, r: usize) -> &[f32] {
        self.values
            .get(r * COLUMNS..(r + 1) * COLUMNS)
            .unwrap_or(&[])
    }

    /// Column `j` over every receiver, in f64.
    pub fn column(&self, j: usize) -> Vec<f64> {
        (0..self.rows())
            .map(|r| self.row(r).get(j).map_or(0.0, |v| f64::from(*v)))
            .collect()
    }

    /// Storage, bytes.
    pub fn bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f32>()
    }

    /// Each receiver's illuminance (lx) under a sky of patch luminances `sky_cd_m2` and
    /// ground luminance `ground_cd_m2`.
    pub fn illuminance_lx(&self, sky_cd_m2: &[f64; PATCH_COUNT], ground_cd_m2: f64) -> Vec<f64> {
        (0..self.rows())
            .map(|r| {
                let row = self.row(r);
                let sky: f64 = row
                    .iter()
                    .zip(sky_cd_m2)
                    .map(|(d, l)| f64::from(*d) * l)
                    .sum();
                sky + f64::from(row[GROUND_COLUMN]) * ground_cd_m2
            })
            .collect()
    }
}

/// The direct sky component (no interreflection), lx per cd/m².
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DirectSky {
    /// Per patch (area average).
    pub patch: SkyMatrix,
    /// Per sensor.
    pub sensor: SkyMatrix,
}

/// The direct sun (no interreflection), lx per lx of direct normal illuminance.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DirectSun {
    /// Per patch (area average over [`DaylightSettings::sun_points`] points).
    pub patch_lx: Vec<f64>,
    /// Per sensor.
    pub sensor_lx: Vec<f64>,
}

/// The room the daylight enters: the commissioned geometry, its form factors, the sensors.
pub struct DaylightRoom<'a> {
    /// The patches.
    pub patches: &'a Patches,
    /// A ray caster over them.
    pub caster: &'a RayCaster,
    /// Their form factors.
    pub form_factors: &'a Csr,
    /// Each sensor's gather row over the patches (row s for sensor s).
    pub gather: &'a Csr,
    /// Each sensor's position and unit normal, m (the gather rows' order).
    pub sensors: &'a [(DVec3, DVec3)],
    /// The glazed windows.
    pub windows: &'a [Window],
    /// The room's orientation (world ↔ sky frame).
    pub frame: SkyFrame,
    /// Solver stop.
    pub solve: SolveOptions,
}

/// One receiver point and its normal, and where its shadow rays start.
#[derive(Clone, Copy)]
struct Point {
    x: DVec3,
    n: DVec3,
}

impl<'a> DaylightRoom<'a> {
    /// The room of a commissioned model; `sensors` in the model's sensor order.
    pub fn of_model(
        model: &'a Model,
        caster: &'a RayCaster,
        sensors: &'a [(DVec3, DVec3)],
        windows: &'a [Window],
        frame: SkyFrame,
    ) -> Self {
        Self {
            patches: &model.patches,
            caster,
            form_factors: &model.ff.f,
            gather: &model.gather,
            sensors,
            windows,
            frame,
            solve: model.settings.solve,
        }
    }

    fn check(&self, settings: &DaylightSettings) -> Result<(), DaylightError> {
        for w in self.windows {
            w.check()?;
        }
        let bad = |m: &str| Err(DaylightError::Input(m.to_owned()));
        if settings.patch_samples == 0 || settings.patch_samples > 1 << 20 {
            return bad("window samples per patch must be 1..=1048576");
        }
        if settings.sensor_samples == 0 || settings.sensor_samples > 1 << 24 {
            return bad("window samples per sensor must be 1..=16777216");
        }
        if settings.sun_points == 0 || settings.sun_points > 1 << 16 {
            return bad("sun points per patch must be 1..=65536");
        }
        if self.gather.rows() != self.sensors.len() {
            return Err(DaylightError::Input(format!(
                "{} gather rows for {} sensors",
                self.gather.rows(),
                self.sensors.len()
            )));
        }
        if self.form_factors.rows() != self.patches.len() {
            return bad("form factors and patches differ in size");
        }
        Ok(())
    }

    /// The direct sky component at every patch and sensor.
    pub fn direct_sky(&self, settings: &DaylightSettings) -> Result<DirectSky, DaylightError> {
        self.direct_sky_where(settings, |_| true)
    }

    /// The direct sky component at the patches `wanted` selects (the others' rows are zero)
    /// and at every sensor.
    pub fn direct_sky_where(
        &self,
        settings: &DaylightSettings,
        wanted: impl Fn(usize) -> bool + Sync,
    ) -> Result<DirectSky, DaylightError> {
        self.check(settings)?;
        let patches = self.patches;
        let patch_rows: Vec<[f64; COLUMNS]> = (0..patches.len())
            .into_par_iter()
            .map(|i| {
                if !wanted(i) {
                    return [0.0; COLUMNS];
                }
                let (shift, _) = patch_jitter(i, settings.seed ^ 0x5C7);
                let n = patches.normal[i];
                let at = |k: usize| Point {
                    x: patch_point(patches, i, k, shift),
                    n,
                };
                self.sky_row(at, settings.patch_samples, hash64(settings.seed ^ i as u64))
            })
            .collect();
        let sensor_rows: Vec<[f64; COLUMNS]> = self
            .sensors
            .par_iter()
            .enumerate()
            .map(|(s, &(x, n))| {
                let seed = hash64(settings.seed ^ 0x5E45_0000 ^ s as u64);
                self.sky_row(|_| Point { x, n }, settings.sensor_samples, seed)
            })
            .collect();
        Ok(DirectSky {
            patch: SkyMatrix::from_rows(patch_rows),
            sensor: SkyMatrix::from_rows(sensor_rows),
        })
    }

    /// One receiver's direct sky row: `samples` jittered stratified window points per window,
    /// sample k seen from receiver point `at(k)`.
    fn sky_row(&self, at: impl Fn(usize) -> Point, samples: usize, seed: u64) -> [f64; COLUMNS] {
        let mut row = [0.0; COLUMNS];
        let nu = (samples as f64).sqrt().round().max(1.0) as usize;
        let nv = samples.div_ceil(nu);
        let count = nu * nv;
        let mut rng = SplitMix64::new(seed);
        for w in self.windows {
            let share = w.area_m2() / count as f64;
            for k in 0..count {
                let u = ((k % nu) as f64 + rng.next_f64()) / nu as f64;
                let v = ((k / nu) as f64 + rng.next_f64()) / nv as f64;
                let p = at(k);
                let q = w.corner_m + w.edge_u_m * u + w.edge_v_m * v;
                let Some((col, e)) = self.through(w, p, q) else {
                    continue;
                };
                row[col] += e * share;
            }
        }
        row
    }

    /// What one window point q contributes to receiver p per unit window area: its column and
    /// `τ(θ_w) cos θ_x cos θ_w / r²`, or nothing when it faces away or is blocked.
    fn through(&self, w: &Window, p: Point, q: DVec3) -> Option<(usize, f64)> {
        let v = q - p.x;
        let r2 = v.length_squared();
        if r2.is_nan() || r2 <= 0.0 {
            return None;
        }
        let d = v / r2.sqrt();
        let cos_x = p.n.dot(d);
        let cos_w = -w.inward.dot(d);
        if cos_x <= 0.0 || cos_w <= 0.0 {
            return None;
        }
        let tau = w.transmittance_at(cos_w);
        if tau <= 0.0 || !self.caster.unoccluded(self.caster.offset(p.x, p.n), q) {
            return None;
        }
        let col = patch_of(self.frame.to_sky(d.to_array())).unwrap_or(GROUND_COLUMN);
        Some((col, tau * cos_x * cos_w / r2))
    }

    /// The direct sun at one point, lx per lx of direct normal illuminance: through whichever
    /// window the ray toward the sun leaves by, if nothing inside blocks it.
    fn sun_at(&self, p: Point, sun: DVec3) -> f64 {
        let cos_x = p.n.dot(sun);
        if cos_x <= 0.0 {
            return 0.0;
        }
        let mut e = 0.0;
        for w in self.windows {
            let cos_w = -w.inward.dot(sun);
            if cos_w <= 1e-12 {
                continue;
            }
            let t = (w.corner_m - p.x).dot(w.inward) / w.inward.dot(sun);
            if t.is_nan() || t <= 0.0 {
                continue;
            }
            let h = p.x + sun * t - w.corner_m;
            let u = h.dot(w.edge_u_m) / w.edge_u_m.length_squared();
            let v = h.dot(w.edge_v_m) / w.edge_v_m.length_squared();
            if !((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)) {
                continue;
            }
            let q = w.corner_m + w.edge_u_m * u + w.edge_v_m * v;
            if self.caster.unoccluded(self.caster.offset(p.x, p.n), q) {
                e += w.transmittance_at(cos_w) * cos_x;
            }
        }
        e
    }

    /// The direct sun at every patch and sensor for a sun in world direction `sun_world`
    /// (toward the sun; normalised here), lx per lx of direct normal illuminance.
    pub fn direct_sun(
        &self,
        sun_world: DVec3,
        settings: &DaylightSettings,
    ) -> Result<DirectSun, DaylightError> {
        self.direct_sun_where(sun_world, settings, |_| true)
    }

    /// [`DaylightRoom::direct_sun`] at the patches `wanted` selects (the others' are zero)
    /// and at every sensor.
    pub fn direct_sun_where(
        &self,
        sun_world: DVec3,
        settings: &DaylightSettings,
        wanted: impl Fn(usize) -> bool + Sync,
    ) -> Result<DirectSun, DaylightError> {
        self.check(settings)?;
        let sun = sun_world.normalize_or_zero();
        if !sun.is_finite() || sun == DVec3::ZERO {
            return Err(DaylightError::Input(
                "the sun direction must be finite and non-zero".into(),
            ));
        }
        let patches = self.patches;
        let m = settings.sun_points;
        let patch_lx = (0..patches.len())
            .into_par_iter()
            .map(|i| {
                if !wanted(i) {
                    return 0.0;
                }
                let (shift, _) = patch_jitter(i, settings.seed ^ 0x5A7);
                let n = patches.normal[i];
                (0..m)
                    .map(|k| {
                        let x = patch_point(patches, i, k, shift);
                        self.sun_at(Point { x, n }, sun)
                    })
                    .sum::<f64>()
                    / m as f64
            })
            .collect();
        let sensor_lx = self
            .sensors
            .iter()
            .map(|&(x, n)| self.sun_at(Point { x, n }, sun))
            .collect();
        Ok(DirectSun {
            patch_lx,
            sensor_lx,
        })
    }

    /// Each sensor's importance over the patches (the adjoint solve; see [`Importance`]).
    pub fn importance(&self) -> Result<Importance, DaylightError> {
        let n = self.patches.len();
        if self.gather.rows() != self.sensors.len() || self.form_factors.rows() != n {
            return Err(DaylightError::Input(
                "gather rows, sensors and patches differ".into(),
            ));
        }
        let ft = transpose(self.form_factors, n);
        let g: Vec<Vec<f64>> = (0..self.sensors.len())
            .map(|s| {
                let mut g = vec![0.0; n];
                for (j, w) in self.gather.row(s) {
                    if let Some(gj) = g.get_mut(j as usize) {
                        *gj += w;
                    }
                }
                g
            })
            .collect();
        let solved = multisolve::solve_all(&ft, &self.patches.rho, &g, self.solve)?;
        Ok(Importance {
            per_sensor: solved.into_iter().map(|(x, _)| x).collect(),
        })
    }

    /// The daylight coefficients at the sensors, through the interreflections: `D` (sensors ×
    /// [`COLUMNS`]), lx per cd/m², from the direct sky component and the sensors' importance.
    pub fn coefficients(
        &self,
        direct: &DirectSky,
        importance: &Importance,
    ) -> Result<SkyMatrix, DaylightError> {
        let n = self.patches.len();
        if direct.patch.rows() != n
            || direct.sensor.rows() != self.sensors.len()
            || importance.per_sensor.len() != self.sensors.len()
            || importance.per_sensor.iter().any(|x| x.len() != n)
        {
            return Err(DaylightError::Input(
                "the direct sky component or the importance is of another room".into(),
            ));
        }
        let rows = (0..self.sensors.len())
            .into_par_iter()
            .map(|s| {
                let mut row = [0.0; COLUMNS];
                for (r, d) in row.iter_mut().zip(direct.sensor.row(s)) {
                    *r = f64::from(*d);
                }
                for (i, x) in importance.per_sensor[s].iter().enumerate() {
                    if *x == 0.0 {
                        continue;
                    }
                    for (r, e) in row.iter_mut().zip(direct.patch.row(i)) {
                        *r += x * f64::from(*e);
                    }
                }
                row
            })
            .collect();
        Ok(SkyMatrix::from_rows(rows))
    }

    /// The sun's contribution at the sensors through the interreflections, for each sun
    /// direction (world, toward the sun): `[sun][sensor]`, lx per lx of direct normal
    /// illuminance. No solve: the direct sun on the patches weighed by the importance.
    pub fn sun_coefficients(
        &self,
        suns_world: &[DVec3],
        settings: &DaylightSettings,
        importance: &Importance,
    ) -> Result<Vec<Vec<f64>>, DaylightError> {
        suns_world
            .iter()
            .map(|s| {
                let d = self.direct_sun(*s, settings)?;
                importance.sensor_lx(&d)
            })
            .collect()
    }
}

/// Each sensor's importance: how much a unit irradiance on each patch adds to the sensor's
/// reading through the interreflections, lx per lx.
///
/// A sensor reads `g · B` (its gather row over the exitances) with `B = (I − ρF)⁻¹ ρ E` for a
/// direct patch irradiance E, so `g · B = x · E` with `x = ρ ⊙ z`, `(I − ρF)ᵀ z = g`, i.e.
/// `x = ρ ⊙ (g + Fᵀ x)`: the radiosity system over the transposed form factors with the gather
/// row as its source, which the same solver solves. One solve per sensor instead of one per
/// sky column (the adjoint, or importance, of radiosity: Smits, Arvo and Salesin, "An
/// importance-driven radiosity algorithm", SIGGRAPH 1992). Its iteration matrix `ρFᵀ` is
/// similar to `ρF` by reciprocity (`Fᵀ = A F A⁻¹`), so it converges as the forward solve does.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Importance {
    /// `[sensor][patch]`, lx per lx.
    pub per_sensor: Vec<Vec<f64>>,
}

impl Importance {
    /// The readings of every sensor (lx) for a direct sun (its direct sensor values plus the
    /// interreflected part of its patch irradiances).
    pub fn sensor_lx(&self, sun: &DirectSun) -> Result<Vec<f64>, DaylightError> {
        if sun.sensor_lx.len() != self.per_sensor.len()
            || self
                .per_sensor
                .iter()
                .any(|x| x.len() != sun.patch_lx.len())
        {
            return Err(DaylightError::Input(
                "the direct sun is of another room".into(),
            ));
        }
        Ok(self
            .per_sensor
            .iter()
            .zip(&sun.sensor_lx)
            .map(|(x, d)| d + x.iter().zip(&sun.patch_lx).map(|(x, e)| x * e).sum::<f64>())
            .collect())
    }

    /// Storage as f32, bytes.
    pub fn bytes(&self) -> usize {
        self.per_sensor.iter().map(Vec::len).sum::<usize>() * std::mem::size_of::<f32>()
    }
}

/// The transpose of an n × n sparse matrix.
fn transpose(f: &Csr, n: usize) -> Csr {
    let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for i in 0..f.rows() {
        for (j, v) in f.row(i) {
            if let Some(r) = rows.get_mut(j as usize) {
                r.push((i as u32, v));
            }
        }
    }
    Csr::from_rows(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clear_glass_follows_fresnel() {
        assert!((clear_glass_relative(1.0) - 1.0).abs() < 1e-12);
        assert_eq!(clear_glass_relative(0.0), 0.0);
        assert_eq!(clear_glass_relative(-0.3), 0.0);
        // monotone in the angle
        let mut last = 1.0;
        for k in 1..90 {
            let t = clear_glass_relative((f64::from(k) * std::f64::consts::PI / 180.0).cos());
            assert!(t <= last + 1e-12, "{k}°: {t} > {last}");
            last = t;
        }
        // flat to ~40°, then falling: the clear-glass curve (e.g. ~0.99 at 40°, ~0.9 at 60°)
        let at = |deg: f64| clear_glass_relative(deg.to_radians().cos());
        assert!(at(40.0) > 0.98, "{}", at(40.0));
        assert!((0.85..0.95).contains(&at(60.0)), "{}", at(60.0));
        assert!(at(80.0) < 0.6, "{}", at(80.0));
    }
}
