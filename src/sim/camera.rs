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
//!
//! ## The world beyond the luminaires ([`WorldExtras`], for live light)
//!
//! | what | model |
//! |---|---|
//! | daylight | the scene's `window*` groups emit a Lambertian exitance W (lm/m²); the world's engine solves `B = W S + ρ F B` once for W = 1, and a surface gets `W (F B)_p` (its patch's incident daylight; the window itself shows `W B/π`). No sun beam: a diffuse sky through the glazing |
//! | ageing | luminaire l gives `a_l` times its light |
//! | people, boxes | axis-aligned boxes: a ray that meets one first returns its depth, and luminance `ρ_box E/π` with E the light of the surface under it |
//! | a moved desk | its group is removed (its pixels show the floor plane below: depth to z = 0, the floor's reflectance) and a box stands where it went |
//! | a camera that fails | both cameras answer [`CameraError::Disconnected`] |
//!
//! [`WorldExtras`] are set directly or by a [`crate::sim::scenario::Scenario`] armed on the
//! world, evaluated at each frame from the time since it was started.

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
    /// Daylight for a window exitance of 1 lm/m²: (incident per patch, exitance per patch), lx
    /// and lm/m².
    daylight: OnceLock<(Vec<f64>, Vec<f64>)>,
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

/// An axis-aligned box in the room (a person, a box on a desk, a moved desk).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Occluder {
    /// Lower corner, m.
    pub lo_m: DVec3,
    /// Upper corner, m.
    pub hi_m: DVec3,
    /// Reflectance of its top.
    pub rho: f64,
}

impl Occluder {
    /// The ray's entry distance, if it meets the box.
    fn hit(&self, o: DVec3, d: DVec3) -> Option<f64> {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            let (oa, da, lo, hi) = (o[a], d[a], self.lo_m[a], self.hi_m[a]);
            if da.abs() < 1e-12 {
                if oa < lo || oa > hi {
                    return None;
                }
                continue;
            }
            let (mut ta, mut tb) = ((lo - oa) / da, (hi - oa) / da);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
        (t0 <= t1 && t0 > 0.0).then_some(t0)
    }
}

/// Everything the world has beyond its luminaires' levels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WorldExtras {
    /// Exitance of the window groups, lm/m² (0: night).
    pub window_exitance_lm_m2: f64,
    /// Ageing factor per luminaire (empty: all 1).
    pub ageing: Vec<f64>,
    /// Boxes in the room.
    pub occluders: Vec<Occluder>,
    /// Mesh groups taken out of the room (a moved desk's old place shows the floor).
    pub removed_groups: Vec<String>,
    /// Both cameras fail.
    pub cameras_fail: bool,
}

/// The simulated room: scene, model, current luminaire levels. Cheap to clone (shared).
#[derive(Clone)]
pub struct SimWorld {
    shared: Arc<Shared>,
    levels: Arc<Mutex<Vec<f64>>>,
    extras: Arc<Mutex<WorldExtras>>,
    scenario: Arc<Mutex<Option<(crate::sim::scenario::Scenario, std::time::Instant)>>>,
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
                daylight: OnceLock::new(),
            }),
            levels: Arc::new(Mutex::new(vec![0.0; n])),
            extras: Arc::new(Mutex::new(WorldExtras::default())),
            scenario: Arc::new(Mutex::new(None)),
        })
    }

    /// The extras as they are now (a running scenario's, evaluated at this instant).
    pub fn extras(&self) -> WorldExtras {
        let sc = self.scenario.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((scenario, t0)) = sc.as_ref() {
            return scenario.extras_at(t0.elapsed().as_secs_f64(), self.scene());
        }
        self.extras
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Sets the extras (a scenario, if running, overrides them).
    pub fn set_extras(&self, extras: WorldExtras) {
        *self.extras.lock().unwrap_or_else(|p| p.into_inner()) = extras;
    }

    /// Starts a scenario now: from here on every frame shows the scenario's state at the time
    /// since this call. Before, the world shows the scenario's state at time 0.
    pub fn start_scenario(&self, scenario: crate::sim::scenario::Scenario) {
        self.set_extras(scenario.extras_at(0.0, self.scene()));
        *self.scenario.lock().unwrap_or_else(|p| p.into_inner()) =
            Some((scenario, std::time::Instant::now()));
    }

    /// Seconds since the scenario started (`None`: none running).
    pub fn scenario_time_s(&self) -> Option<f64> {
        self.scenario
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
            .map(|(_, t0)| t0.elapsed().as_secs_f64())
    }

    /// Daylight for a window exitance of 1 lm/m²: (incident illuminance per patch, lx; exitance
    /// per patch, lm/m²). Zeros without `window*` groups.
    pub fn daylight_basis(&self) -> &(Vec<f64>, Vec<f64>) {
        let s = &self.shared;
        s.daylight.get_or_init(|| {
            let m = &s.model;
            let n = m.patches.len();
            let mesh = &s.scene.mesh;
            let emits: Vec<bool> = (0..n)
                .map(|i| {
                    let t = m.patches.source_triangle[i] as usize;
                    mesh.triangles
                        .get(t)
                        .and_then(|t| mesh.groups.get(t.group as usize))
                        .is_some_and(|g| g.starts_with("window"))
                })
                .collect();
            // B = S + ρ F B by Jacobi-style sweeps (Gauss-Seidel in place)
            let mut b: Vec<f64> = emits.iter().map(|&e| f64::from(u8::from(e))).collect();
            for _ in 0..500 {
                let mut change = 0.0f64;
                for i in 0..n {
                    let inc: f64 = m.ff.f.row(i).map(|(j, f)| f * b[j as usize]).sum();
                    let new = f64::from(u8::from(emits[i])) + m.patches.rho[i] * inc;
                    change = change.max((new - b[i]).abs());
                    b[i] = new;
                }
                if change < 1e-10 {
                    break;
                }
            }
            let incident = (0..n)
                .map(|i| m.ff.f.row(i).map(|(j, f)| f * b[j as usize]).sum())
                .collect();
            (incident, b)
        })
    }

    /// The world's own reading at each sensor for these levels and extras, lx: the engine's
    /// response (times the ageing) plus the window's daylight through the sensors' gather rows.
    /// Boxes and moved desks are not in it (a covered desk's value is held by the node anyway).
    pub fn sensor_truth_lx(&self, levels: &[f64], extras: &WorldExtras) -> Vec<f64> {
        let m = &self.shared.model;
        let (_, b) = self.daylight_basis();
        (0..m.sensors())
            .map(|s| {
                let art: f64 = m.response_lx[s]
                    .iter()
                    .zip(levels)
                    .enumerate()
                    .map(|(l, (r, x))| r * x * extras.ageing.get(l).copied().unwrap_or(1.0))
                    .sum();
                let day: f64 = m.gather.row(s).map(|(j, w)| w * b[j as usize]).sum();
                art + extras.window_exitance_lm_m2 * day
            })
            .collect()
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

    /// What a receiver of angular response `response` at `position` facing `normal` reads from
    /// each luminaire at 100 %, lx (the node's ambient light sensor in this world):
    /// `E = ∫ L s(θ) dω`, with exact direct light on the receiver and, over `rays`
    /// cosine-distributed directions (weight `(π/N) s/cos`), the luminance of the first surface
    /// hit as the cameras see it (`ρ (E_direct at the point + E_indirect of its patch) / π`).
    pub fn receiver_lx(
        &self,
        position: DVec3,
        normal: DVec3,
        response: &crate::lsc::AngularResponse,
        rays: usize,
    ) -> Vec<f64> {
        let s = &self.shared;
        let m = &s.model;
        let receiver = match response {
            crate::lsc::AngularResponse::Cosine => Receiver::Surface,
            r => Receiver::Sensor(r),
        };
        let lums = &s.scene.luminaires;
        let points: Vec<Vec<DVec3>> = lums
            .iter()
            .map(|l| opening_points(l, s.opening_points))
            .collect();
        let probes: Vec<Vec<DVec3>> = lums.iter().map(visibility_probes).collect();
        let indirect = self.indirect_lx();
        let seen: Vec<Vec<f64>> = self
            .receiver_rays(position, normal, response, rays)
            .par_iter()
            .map(|&(p, x, w)| {
                let n = m.patches.normal[p];
                let k = w * m.patches.rho[p] / std::f64::consts::PI;
                lums.iter()
                    .enumerate()
                    .map(|(j, l)| {
                        k * (direct_lx(l, &points[j], &probes[j], x, n, &s.caster) + indirect[j][p])
                    })
                    .collect()
            })
            .collect();
        // summed in ray order: the same result for any thread count
        let seen = seen.into_iter().fold(vec![0.0; lums.len()], |mut a, b| {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
            a
        });
        lums.iter()
            .zip(&points)
            .zip(seen)
            .map(|((l, pts), e)| {
                e + direct::illuminance_lx(l, pts, position, normal, receiver, &s.caster)
            })
            .collect()
    }

    /// The receiver's gather rays that hit a surface's front, in ray order: (patch, hit point,
    /// weight `(π/N) s(θ)/cos θ` of `rays` cosine-distributed directions).
    fn receiver_rays(
        &self,
        position: DVec3,
        normal: DVec3,
        response: &crate::lsc::AngularResponse,
        rays: usize,
    ) -> Vec<(usize, DVec3, f64)> {
        use crate::engine::rayset::{RaySet, frame, to_world};
        let s = &self.shared;
        let set = RaySet::new(s.model.settings.ray_set, rays.max(1));
        let fr = frame(normal, 0.0);
        let origin = s.caster.offset(position, normal);
        let scale = std::f64::consts::PI / set.len() as f64;
        set.dirs
            .par_iter()
            .filter_map(|d| {
                let cos = d.z.max(1e-12);
                let w = scale * response.response(cos.acos()) / cos;
                if w <= 0.0 {
                    return None;
                }
                let dw = to_world(&fr, *d);
                match s.caster.closest(origin, dw) {
                    Hit::Front { patch, t_m } => Some((patch as usize, origin + dw * t_m, w)),
                    _ => None,
                }
            })
            .collect()
    }

    /// What the same receiver reads of the window's daylight per lm/m² of window exitance, lx:
    /// over the same cosine-distributed rays, the luminance of the first surface hit by the
    /// daylight as the cameras see it (`ρ E_day / π`, the glazing its own exitance `B / π`).
    pub fn receiver_daylight_lx(
        &self,
        position: DVec3,
        normal: DVec3,
        response: &crate::lsc::AngularResponse,
        rays: usize,
    ) -> f64 {
        let m = &self.shared.model;
        let (incident, b) = self.daylight_basis();
        self.receiver_rays(position, normal, response, rays)
            .iter()
            .map(|&(p, _, w)| {
                let exitance = if self.group_of(p).is_some_and(|g| g.starts_with("window")) {
                    b[p]
                } else {
                    m.patches.rho[p] * incident[p]
                };
                w * exitance / std::f64::consts::PI
            })
            // summed in ray order: the same result for any thread count
            .sum()
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
        self.luminance_with(levels, &WorldExtras::default())
    }

    /// The patch's group name.
    fn group_of(&self, patch: usize) -> Option<&str> {
        let s = &self.shared;
        let t = s.model.patches.source_triangle[patch] as usize;
        let mesh = &s.scene.mesh;
        mesh.triangles
            .get(t)
            .and_then(|t| mesh.groups.get(t.group as usize))
            .map(String::as_str)
    }

    /// What pixel `i` sees with the extras: (depth along the axis, m, or NaN; luminance factor
    /// source). `None` keeps the plain hit.
    fn overlay(&self, i: usize, extras: &WorldExtras) -> Option<(f64, f64)> {
        let cam = &self.shared.camera;
        let (u, v) = (i as u32 % cam.width, i as u32 / cam.width);
        let d = cam.ray_world(f64::from(u), f64::from(v))?;
        let axis = cam.world_from_camera.z_axis;
        let hit = self.hits()[i];
        let mut t_hit = hit.map_or(f64::INFINITY, |h| h.t_m);
        let mut rho = None;
        if let Some(h) = hit
            && self
                .group_of(h.patch as usize)
                .is_some_and(|g| extras.removed_groups.iter().any(|r| r == g))
            && d.z < -1e-9
        {
            // the floor plane below the removed object
            t_hit = -cam.position_m.z / d.z;
            rho = Some(self.floor_rho());
        }
        for o in &extras.occluders {
            if let Some(t) = o.hit(cam.position_m, d)
                && t < t_hit
            {
                t_hit = t;
                rho = Some(o.rho);
            }
        }
        rho.map(|r| (t_hit * d.dot(axis), r))
    }

    fn floor_rho(&self) -> f64 {
        let m = &self.shared.model;
        (0..m.patches.len())
            .find(|&p| self.group_of(p) == Some("floor"))
            .map_or(0.25, |p| m.patches.rho[p])
    }

    /// Luminance at each pixel for these levels and extras, cd/m² (noise-free).
    pub fn luminance_with(&self, levels: &[f64], extras: &WorldExtras) -> Vec<f64> {
        let hits = self.hits();
        let dir = self.direct_lx();
        let ind = self.indirect_lx();
        let rho = &self.shared.model.patches.rho;
        let w = extras.window_exitance_lm_m2;
        let day = (w > 0.0).then(|| self.daylight_basis());
        let any_overlay = !extras.occluders.is_empty() || !extras.removed_groups.is_empty();
        hits.iter()
            .enumerate()
            .map(|(i, h)| match h {
                Some(h) if h.front => {
                    let p = h.patch as usize;
                    let mut e = 0.0;
                    for (l, x) in levels.iter().enumerate() {
                        if *x > 0.0 {
                            let a = extras.ageing.get(l).copied().unwrap_or(1.0);
                            e += x * a * (dir[l][i] + ind[l][p]);
                        }
                    }
                    let mut own = 0.0;
                    if let Some((incident, b)) = day {
                        e += w * incident[p];
                        if self.group_of(p).is_some_and(|g| g.starts_with("window")) {
                            // the glazing: its own exitance (emission and reflection)
                            own = w * (b[p] - rho[p] * incident[p]);
                        }
                    }
                    let r = if any_overlay {
                        self.overlay(i, extras).map_or(rho[p], |(_, r)| r)
                    } else {
                        rho[p]
                    };
                    (r * e + own) / std::f64::consts::PI
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
        let extras = self.world.extras();
        if extras.cameras_fail {
            return Err(CameraError::Disconnected {
                device: "simulated ToF camera".into(),
                reason: "the scenario failed the camera".into(),
            });
        }
        let mut z = self.exact_depth_m();
        if !extras.occluders.is_empty() || !extras.removed_groups.is_empty() {
            for (i, zi) in z.iter_mut().enumerate() {
                if let Some((zo, _)) = self.world.overlay(i, &extras) {
                    *zi = zo;
                }
            }
        }
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
        let extras = self.world.extras();
        if extras.cameras_fail {
            return Err(CameraError::Disconnected {
                device: "simulated colour camera".into(),
                reason: "the scenario failed the camera".into(),
            });
        }
        let l = self.world.luminance_with(&levels, &extras);
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
