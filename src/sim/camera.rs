//! The simulated cameras: a [`SimWorld`] (a scene, its engine model and the luminaires' current
//! levels, shared) seen by a [`SimDepthCamera`] and a [`SimLuminanceCamera`]; the world is also
//! the [`LightControl`].
//!
//! Both cameras cast one ray per pixel centre through the scene camera's pinhole
//! ([`crate::scene::Camera::ray_world`]) with the engine's own ray caster, over the model's
//! patches. The first hits, and everything that does not depend on the levels, are computed
//! once per world (lazily, in parallel) and shared by every frame.
//!
//! ## Depth
//!
//! `z = t (d · ẑ)`: the hit distance `t` along the unit ray `d` projected on the optical axis
//! `ẑ`, in mm (the capture format's convention), 0 when the ray leaves the scene or the range
//! exceeds [`SimDepthOptions::max_range_m`]. The ToF error model, seeded per frame
//! (`seed`, frame index), applied in this order per pixel:
//!
//! | effect | model | knob |
//! |---|---|---|
//! | flying pixels | a pixel on a depth edge (a 4-neighbour differs by more than `edge_rel` of its depth) takes a depth between its own and that neighbour's, `z + s (z_n − z)`, `s` uniform in [0.2, 0.8] | `flying_pixel_chance` (per edge pixel) |
//! | range noise | `z ← z (1 + σ g)`, g standard normal: σ relative, so the absolute noise grows with distance | `range_noise_rel` |
//! | dropouts | `z ← 0` (no return) | `dropout_chance` (per pixel) |
//!
//! ## Luminance
//!
//! Every surface is Lambertian: `L = ρ E / π` at the first hit, with ρ the hit patch's
//! reflectance and
//!
//! `E = Σ_l x_l (E_dir,l(x) + (F B_l)_p)`
//!
//! where `x_l` is luminaire l's level, `E_dir,l(x)` the **exact** direct illuminance at the
//! hit point from luminaire l at 100 % (the engine's [`crate::engine::direct::illuminance_lx`]:
//! photometry over the opening's points, shadow rays), and `(F B_l)_p` the interreflected
//! illuminance on the hit patch from the engine's radiosity basis (`Σ_j F_pj B_l,j`), constant
//! over a patch. Luminaire openings (ρ = 0) and back faces render black. The value is
//! `L / cd_m2_per_unit`, rounded, clipped at 65535, with optional relative Gaussian noise.

use std::sync::{Arc, Mutex, OnceLock};
use std::time::SystemTime;

use glam::DVec3;
use rayon::prelude::*;

use crate::camera::{
    CameraError, DepthCamera, DepthFrame, LightControl, LuminanceCamera, LuminanceFrame,
};
use crate::engine::direct::{self, Receiver};
use crate::engine::raycast::{Hit, RayCaster};
use crate::engine::{self, Model, Settings};
use crate::rng::{SplitMix64, hash64};
use crate::scene::{Camera, Scene};

/// What a pixel's ray met first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelHit {
    /// Patch id.
    pub patch: u32,
    /// Distance along the ray, m.
    pub t_m: f64,
    /// Depth along the optical axis, m.
    pub z_m: f64,
    /// True when the front face was hit.
    pub front: bool,
}

struct Shared {
    scene: Scene,
    model: Model,
    camera: Camera,
    caster: RayCaster,
    opening_points: usize,
    hits: OnceLock<Vec<Option<PixelHit>>>,
    /// `[luminaire][pixel]` exact direct illuminance at 100 %, lx.
    direct_lx: OnceLock<Vec<Vec<f64>>>,
    /// `[luminaire][patch]` interreflected illuminance at 100 %, lx.
    indirect_lx: OnceLock<Vec<Vec<f64>>>,
}

/// `m` points over a luminaire's opening (m even): the engine's `m/2` low-discrepancy points
/// and their mirror images through the opening's centre. The set's centroid is the centre, so
/// the bias of a few points (their centroid off the centre by some cm, a % of illuminance at
/// oblique incidence) cancels to first order.
pub fn opening_points(l: &crate::scene::Luminaire, m: usize) -> Vec<DVec3> {
    let half = direct::opening_points(l, (m / 2).max(1));
    if half.len() == 1 && l.opening_m == [0.0, 0.0] {
        return half;
    }
    let c = l.position_m;
    half.iter().flat_map(|&p| [p, 2.0 * c - p]).collect()
}

/// Four points just inside the corners of a luminaire's opening (its centre for a point
/// source): when all four see a receiver, or none does, the opening is taken as wholly visible
/// or wholly hidden.
fn visibility_probes(l: &crate::scene::Luminaire) -> Vec<DVec3> {
    let [w, len] = l.opening_m;
    if w <= 0.0 && len <= 0.0 {
        return vec![l.position_m];
    }
    let (a, b) = if l.opening_circular {
        (0.35 * w, 0.35 * w)
    } else {
        (0.5 * w, 0.5 * len)
    };
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|(s, t)| l.position_m + l.c0 * (s * a) + l.c90 * (t * b))
        .collect()
}

/// Exact direct illuminance (lx) at `x` (unit normal `normal`) from one luminaire at 100 %:
/// the engine's [`direct::illuminance_lx`], with shadow rays only where needed. Shadow rays go
/// first to the four corner probes; when they agree, the opening is wholly visible (unshadowed
/// sum over its points) or wholly hidden (0); only in a penumbra is every point shadow-tested.
/// This is 4 rays instead of 16 for most pixels; an occluder that hides interior points but no
/// corner (thinner than the opening, right in front of it) is missed.
fn direct_lx(
    l: &crate::scene::Luminaire,
    points: &[DVec3],
    probes: &[DVec3],
    x: DVec3,
    normal: DVec3,
    caster: &RayCaster,
) -> f64 {
    let origin = caster.offset(x, normal);
    // behind the opening's plane or facing away from all of it: nothing, without a ray
    if probes
        .iter()
        .chain(points)
        .all(|q| normal.dot(*q - x) <= 0.0 || l.aim.dot(x - *q) <= 0.0)
    {
        return 0.0;
    }
    let seen = probes
        .iter()
        .filter(|q| caster.unoccluded(origin, **q))
        .count();
    if seen == 0 {
        return 0.0;
    }
    if seen < probes.len() {
        return direct::illuminance_lx(l, points, x, normal, Receiver::Surface, caster);
    }
    let share = 1.0 / points.len() as f64;
    let mut e = 0.0;
    for &q in points {
        let v = q - x;
        let d2 = v.length_squared();
        if d2.is_nan() || d2 <= 0.0 {
            continue;
        }
        let to_lum = v / d2.sqrt();
        let cos_r = normal.dot(to_lum);
        if cos_r <= 0.0 {
            continue;
        }
        let i_cd = l.intensity_toward_cd(-to_lum);
        if i_cd > 0.0 {
            e += share * i_cd * cos_r / d2;
        }
    }
    e
}

/// The simulated room: scene, model, current luminaire levels. Cheap to clone (shared).
#[derive(Clone)]
pub struct SimWorld {
    shared: Arc<Shared>,
    levels: Arc<Mutex<Vec<f64>>>,
}

impl std::fmt::Debug for SimWorld {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimWorld")
            .field("scene", &self.shared.scene.name)
            .field("patches", &self.shared.model.patches.len())
            .field("levels", &self.levels())
            .finish()
    }
}

/// Engine settings for a world that only needs the patches' radiosity (no sensor precision):
/// fast enough to build the demo office's world in well under a second.
pub fn world_settings() -> Settings {
    Settings {
        sensor_rays: 1000,
        final_gather_rays: 0,
        ..Settings::default()
    }
}

impl SimWorld {
    /// A world for a scene: commissions it with the engine (`settings`). The scene must have a
    /// camera. All luminaires start off.
    pub fn new(scene: Scene, settings: &Settings) -> Result<SimWorld, CameraError> {
        let model = engine::compute_model(&scene, settings)
            .map_err(|e| CameraError::Config(format!("simulated world: engine: {e}")))?;
        Self::from_model(scene, model)
    }

    /// The built-in demo office with [`world_settings`].
    pub fn demo_office() -> Result<SimWorld, CameraError> {
        Self::new(crate::sim::demo::demo_office(), &world_settings())
    }

    /// A world from a scene and a model already computed for it.
    pub fn from_model(scene: Scene, model: Model) -> Result<SimWorld, CameraError> {
        let camera = scene
            .camera
            .clone()
            .ok_or_else(|| CameraError::Config(format!("scene {} has no camera", scene.name)))?;
        if model.luminaire_ids.len() != scene.luminaires.len() {
            return Err(CameraError::Config(
                "the model does not belong to the scene (luminaire count)".into(),
            ));
        }
        let caster = RayCaster::new(&model.patches);
        let n = scene.luminaires.len();
        Ok(SimWorld {
            shared: Arc::new(Shared {
                scene,
                model,
                camera,
                caster,
                opening_points: 16,
                hits: OnceLock::new(),
                direct_lx: OnceLock::new(),
                indirect_lx: OnceLock::new(),
            }),
            levels: Arc::new(Mutex::new(vec![0.0; n])),
        })
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.shared.scene
    }

    /// The engine model of the scene.
    pub fn model(&self) -> &Model {
        &self.shared.model
    }

    /// The camera both simulated cameras see through.
    pub fn camera(&self) -> &Camera {
        &self.shared.camera
    }

    /// Luminaire ids in level order.
    pub fn luminaire_ids(&self) -> Vec<u32> {
        self.shared.scene.luminaires.iter().map(|l| l.id).collect()
    }

    /// What an ideal cosine receiver at `position` facing `normal` reads from each luminaire
    /// at 100 %, lx (the node's ambient light sensor in this world): exact direct light and a
    /// gather of the world's exitances with `rays` rays.
    pub fn receiver_lx(&self, position: DVec3, normal: DVec3, rays: usize) -> Vec<f64> {
        crate::engine::points::evaluate(self.scene(), self.model(), &[(position, normal)], rays)
            .per_luminaire_lx
            .into_iter()
            .next()
            .unwrap_or_default()
    }

    /// Sets the levels (luminaire order; clamped to [0, 1], extra or missing entries ignored),
    /// as the room's controller would: the simulated board's light model follows the node.
    pub fn follow_levels(&self, levels: &[f64]) {
        let mut g = self.levels.lock().unwrap_or_else(|p| p.into_inner());
        for (l, x) in g.iter_mut().zip(levels) {
            if x.is_finite() {
                *l = x.clamp(0.0, 1.0);
            }
        }
    }

    /// The current levels (luminaire order).
    pub fn levels(&self) -> Vec<f64> {
        self.levels
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Computes the per-pixel hits and direct light now (otherwise the first frame does).
    pub fn prepare(&self) {
        let _ = self.direct_lx();
        let _ = self.indirect_lx();
    }

    /// First hit of every pixel (row-major).
    pub fn hits(&self) -> &[Option<PixelHit>] {
        let s = &self.shared;
        s.hits.get_or_init(|| {
            let cam = &s.camera;
            let axis = cam.world_from_camera.z_axis;
            (0..cam.width * cam.height)
                .into_par_iter()
                .map(|i| {
                    let (u, v) = (i % cam.width, i / cam.width);
                    let d = cam.ray_world(f64::from(u), f64::from(v))?;
                    let (patch, t_m, front) = match s.caster.closest(cam.position_m, d) {
                        Hit::Front { patch, t_m } => (patch, t_m, true),
                        Hit::Back { patch, t_m } => (patch, t_m, false),
                        Hit::Miss => return None,
                    };
                    Some(PixelHit {
                        patch,
                        t_m,
                        z_m: t_m * d.dot(axis),
                        front,
                    })
                })
                .collect()
        })
    }

    /// Exact direct illuminance per luminaire at 100 % at each pixel's hit point, lx
    /// (`[luminaire][pixel]`; 0 for misses and back faces).
    pub fn direct_lx(&self) -> &[Vec<f64>] {
        let hits = self.hits();
        let s = &self.shared;
        s.direct_lx.get_or_init(|| {
            let cam = &s.camera;
            s.scene
                .luminaires
                .iter()
                .map(|l| {
                    let pts = opening_points(l, s.opening_points);
                    let probes = visibility_probes(l);
                    hits.par_iter()
                        .enumerate()
                        .map(|(i, h)| match h {
                            Some(h) if h.front => {
                                let (u, v) = (i as u32 % cam.width, i as u32 / cam.width);
                                let Some(d) = cam.ray_world(f64::from(u), f64::from(v)) else {
                                    return 0.0;
                                };
                                let x: DVec3 = cam.position_m + d * h.t_m;
                                let n = s.model.patches.normal[h.patch as usize];
                                direct_lx(l, &pts, &probes, x, n, &s.caster)
                            }
                            _ => 0.0,
                        })
                        .collect()
                })
                .collect()
        })
    }

    /// Interreflected illuminance per luminaire at 100 % on each patch, lx (`[luminaire][patch]`).
    pub fn indirect_lx(&self) -> &[Vec<f64>] {
        let s = &self.shared;
        s.indirect_lx.get_or_init(|| {
            let m = &s.model;
            m.basis_b
                .par_iter()
                .map(|b| {
                    (0..m.patches.len())
                        .map(|i| m.ff.f.row(i).map(|(j, f)| f * b[j as usize]).sum())
                        .collect()
                })
                .collect()
        })
    }

    /// Luminance at each pixel for the given levels, cd/m² (row-major, noise-free).
    pub fn luminance_cd_m2(&self, levels: &[f64]) -> Vec<f64> {
        let hits = self.hits();
        let dir = self.direct_lx();
        let ind = self.indirect_lx();
        let rho = &self.shared.model.patches.rho;
        hits.iter()
            .enumerate()
            .map(|(i, h)| match h {
                Some(h) if h.front => {
                    let p = h.patch as usize;
                    let mut e = 0.0;
                    for (l, x) in levels.iter().enumerate() {
                        if *x > 0.0 {
                            e += x * (dir[l][i] + ind[l][p]);
                        }
                    }
                    rho[p] * e / std::f64::consts::PI
                }
                _ => 0.0,
            })
            .collect()
    }

    /// A depth camera on this world.
    pub fn depth_camera(&self, options: SimDepthOptions) -> Result<SimDepthCamera, CameraError> {
        options.validate()?;
        Ok(SimDepthCamera {
            world: self.clone(),
            options,
            frame_index: 0,
            edges: OnceLock::new(),
        })
    }

    /// A luminance camera on this world.
    pub fn luminance_camera(
        &self,
        options: SimLuminanceOptions,
    ) -> Result<SimLuminanceCamera, CameraError> {
        options.validate()?;
        Ok(SimLuminanceCamera {
            world: self.clone(),
            options,
            frame_index: 0,
        })
    }
}

impl LightControl for SimWorld {
    fn set_levels(&mut self, levels: &[f64]) -> Result<(), CameraError> {
        let n = self.shared.scene.luminaires.len();
        crate::camera::check_levels(levels, n)?;
        *self.levels.lock().unwrap_or_else(|p| p.into_inner()) = levels.to_vec();
        Ok(())
    }
}

/// Checks simulated camera options (for board files).
pub fn validate_options(
    depth: &SimDepthOptions,
    luminance: &SimLuminanceOptions,
) -> Result<(), CameraError> {
    depth.validate()?;
    luminance.validate()
}

/// The ToF error model and range of a [`SimDepthCamera`].
#[derive(Debug, Clone, PartialEq)]
pub struct SimDepthOptions {
    /// Seed; frame k uses (seed, k).
    pub seed: u64,
    /// Range noise σ as a fraction of the depth.
    pub range_noise_rel: f64,
    /// Chance that a pixel on a depth edge is a flying pixel.
    pub flying_pixel_chance: f64,
    /// A depth edge: a 4-neighbour's depth differs by more than this fraction.
    pub edge_rel: f64,
    /// Chance that a pixel returns nothing.
    pub dropout_chance: f64,
    /// Farthest return, m.
    pub max_range_m: f64,
    /// Reported integration time, s.
    pub exposure_s: f64,
}

impl Default for SimDepthOptions {
    /// The error model of the reference captures (`office_a/capture/`): 1 % range noise, flying
    /// pixels at depth edges, 0.5 % dropouts.
    fn default() -> Self {
        Self {
            seed: 1,
            range_noise_rel: 0.01,
            flying_pixel_chance: 0.3,
            edge_rel: 0.05,
            dropout_chance: 0.005,
            max_range_m: 12.0,
            exposure_s: 1e-3,
        }
    }
}

impl SimDepthOptions {
    /// No noise, no flying pixels, no dropouts: the exact depth.
    pub fn exact() -> Self {
        Self {
            range_noise_rel: 0.0,
            flying_pixel_chance: 0.0,
            dropout_chance: 0.0,
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<(), CameraError> {
        let frac = |name: &str, x: f64, hi: f64| {
            if x.is_finite() && (0.0..=hi).contains(&x) {
                Ok(())
            } else {
                Err(CameraError::Config(format!(
                    "simulated depth: {name} {x} is outside [0, {hi}]"
                )))
            }
        };
        frac("range_noise_rel", self.range_noise_rel, 0.5)?;
        frac("flying_pixel_chance", self.flying_pixel_chance, 1.0)?;
        frac("edge_rel", self.edge_rel, 10.0)?;
        frac("dropout_chance", self.dropout_chance, 1.0)?;
        frac("max_range_m", self.max_range_m, 65.0)?;
        frac("exposure_s", self.exposure_s, 10.0)
    }
}

/// The simulated ToF camera.
pub struct SimDepthCamera {
    world: SimWorld,
    options: SimDepthOptions,
    frame_index: u64,
    /// Edge pixels: (pixel, the most different neighbour's depth, m).
    edges: OnceLock<Vec<(usize, f64)>>,
}

impl SimDepthCamera {
    /// The exact depth of every pixel along the optical axis, m (NaN: no return).
    pub fn exact_depth_m(&self) -> Vec<f64> {
        let max = self.options.max_range_m;
        self.world
            .hits()
            .iter()
            .map(|h| match h {
                Some(h) if h.z_m > 0.0 && h.t_m <= max => h.z_m,
                _ => f64::NAN,
            })
            .collect()
    }

    /// Pixels on a depth edge, with the depth (m) of their most different 4-neighbour.
    pub fn edge_pixels(&self) -> &[(usize, f64)] {
        self.edges.get_or_init(|| {
            let z = self.exact_depth_m();
            let cam = self.world.camera();
            let (w, h) = (cam.width as usize, cam.height as usize);
            let mut out = Vec::new();
            for v in 0..h {
                for u in 0..w {
                    let i = v * w + u;
                    let zi = z[i];
                    if zi.is_nan() {
                        continue;
                    }
                    let mut best: Option<f64> = None;
                    let neighbours = [
                        (u > 0).then(|| i - 1),
                        (u + 1 < w).then(|| i + 1),
                        (v > 0).then(|| i - w),
                        (v + 1 < h).then(|| i + w),
                    ];
                    for j in neighbours.into_iter().flatten() {
                        let zj = z[j];
                        if zj.is_nan() {
                            continue;
                        }
                        let d = (zj - zi).abs();
                        if d > self.options.edge_rel * zi && best.is_none_or(|b| d > (b - zi).abs())
                        {
                            best = Some(zj);
                        }
                    }
                    if let Some(zn) = best {
                        out.push((i, zn));
                    }
                }
            }
            out
        })
    }

    /// The options.
    pub fn options(&self) -> &SimDepthOptions {
        &self.options
    }
}

fn to_mm(z_m: f64) -> u16 {
    if z_m.is_nan() || z_m <= 0.0 {
        0
    } else {
        (z_m * 1000.0).round().clamp(1.0, 65535.0) as u16
    }
}

impl DepthCamera for SimDepthCamera {
    fn camera(&self) -> &Camera {
        self.world.camera()
    }

    fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
        let o = self.options.clone();
        let mut z = self.exact_depth_m();
        let mut rng = SplitMix64::new(o.seed ^ hash64(self.frame_index.wrapping_add(0x5EED)));
        self.frame_index += 1;
        if o.flying_pixel_chance > 0.0 {
            for &(i, zn) in self.edge_pixels() {
                if rng.next_f64() < o.flying_pixel_chance {
                    let s = 0.2 + 0.6 * rng.next_f64();
                    z[i] += s * (zn - z[i]);
                }
            }
        }
        let depth_mm = z
            .iter()
            .map(|&zi| {
                let g = if o.range_noise_rel > 0.0 {
                    crate::rng::gaussian(&mut rng)
                } else {
                    0.0
                };
                let dropped = o.dropout_chance > 0.0 && rng.next_f64() < o.dropout_chance;
                if dropped {
                    0
                } else {
                    to_mm(zi * (1.0 + o.range_noise_rel * g))
                }
            })
            .collect();
        let cam = self.world.camera();
        Ok(DepthFrame {
            width: cam.width,
            height: cam.height,
            depth_mm,
            timestamp: SystemTime::now(),
            exposure_s: o.exposure_s,
        })
    }
}

/// Scale and noise of a [`SimLuminanceCamera`].
#[derive(Debug, Clone, PartialEq)]
pub struct SimLuminanceOptions {
    /// Seed; frame k uses (seed, k).
    pub seed: u64,
    /// cd/m² per unit (office_a's captures: 0.02, so 65535 units = 1311 cd/m²).
    pub cd_m2_per_unit: f64,
    /// Relative Gaussian noise σ per pixel (0: exact).
    pub noise_rel: f64,
    /// Reported exposure time, s.
    pub exposure_s: f64,
}

impl Default for SimLuminanceOptions {
    fn default() -> Self {
        Self {
            seed: 2,
            cd_m2_per_unit: 0.02,
            noise_rel: 0.0,
            exposure_s: 0.01,
        }
    }
}

impl SimLuminanceOptions {
    fn validate(&self) -> Result<(), CameraError> {
        if !(self.cd_m2_per_unit.is_finite() && self.cd_m2_per_unit > 0.0) {
            return Err(CameraError::Config(format!(
                "simulated luminance: cd_m2_per_unit {} must be > 0",
                self.cd_m2_per_unit
            )));
        }
        if !(self.noise_rel.is_finite() && (0.0..=0.5).contains(&self.noise_rel)) {
            return Err(CameraError::Config(format!(
                "simulated luminance: noise_rel {} is outside [0, 0.5]",
                self.noise_rel
            )));
        }
        if !(self.exposure_s.is_finite() && self.exposure_s > 0.0) {
            return Err(CameraError::Config(
                "simulated luminance: exposure_s must be > 0".into(),
            ));
        }
        Ok(())
    }
}

/// The simulated luminance camera: renders the world at its current levels.
pub struct SimLuminanceCamera {
    world: SimWorld,
    options: SimLuminanceOptions,
    frame_index: u64,
}

impl LuminanceCamera for SimLuminanceCamera {
    fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
        let o = &self.options;
        let levels = self.world.levels();
        let l = self.world.luminance_cd_m2(&levels);
        let mut rng = SplitMix64::new(o.seed ^ hash64(self.frame_index.wrapping_add(0x1A11)));
        self.frame_index += 1;
        let data = l
            .iter()
            .map(|&x| {
                let n = if o.noise_rel > 0.0 {
                    1.0 + o.noise_rel * crate::rng::gaussian(&mut rng)
                } else {
                    1.0
                };
                (x * n / o.cd_m2_per_unit).round().clamp(0.0, 65535.0) as u16
            })
            .collect();
        let cam = self.world.camera();
        Ok(LuminanceFrame {
            width: cam.width,
            height: cam.height,
            data,
            cd_m2_per_unit: o.cd_m2_per_unit,
            timestamp: SystemTime::now(),
            exposure_s: o.exposure_s,
        })
    }
}
