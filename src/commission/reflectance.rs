//! Reflectances from the one-luminaire-on luminance frames.
//!
//! A Lambertian surface of reflectance ρ under irradiance E has luminance `L = ρ E / π`, so
//! `ρ = π L / E` per pixel and per frame. E comes from the engine on the reconstructed mesh:
//! the exact direct light at the pixel's surface point (photometry over the opening, shadow
//! rays) plus the interreflected light on its patch, `Σ_j F_ij B_j`, from a radiosity solve with
//! the current reflectances. The first estimate uses direct light alone (it reads high, as L
//! also holds the interreflections); [`ReflectanceOptions::iterations`] re-estimates with the
//! interreflections of the previous estimate.
//!
//! Frames combine by the median over those where the pixel is well lit (at least
//! [`ReflectanceOptions::min_rel_irradiance`] of its best frame; not saturated, not black), which
//! rejects shadows the coarse mesh misplaces. Pixels combine per mesh triangle by the median.
//! Values outside `[rho_min, rho_max]` are clamped and counted.
//!
//! Camera gain (cd/m² per unit): from `camera.json`, or from one luxmeter reading at
//! commissioning: the gain is then the one for which the model reads what the luxmeter read
//! (the reading rises with the gain through the reflectances; found by bisection on its log).

use glam::DVec3;
use rayon::prelude::*;

use super::depth::DepthMap;
use super::mesh::{Part, RecoMesh};
use crate::camera::capture::Capture;
use crate::engine::direct::{self, Receiver};
use crate::engine::raycast::{Hit, RayCaster};
use crate::engine::{Model, Settings};
use crate::scene::Luminaire;
use crate::solver::{self, CsrSystem, SolveError};

/// How the frames of a pixel combine into a reflectance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReflectanceMethod {
    /// Median over the well-lit frames of `ρ = π L / E` (E from the engine per pixel).
    #[default]
    Median,
    /// RGBD2lux §3.1 / physics.md §8.1: first-order spherical-harmonic photometric stereo with
    /// known normals, per mesh triangle, alternating least squares; the global scale it leaves
    /// open is fixed by the engine's irradiance on the triangle.
    SphericalHarmonics,
}

/// Reflectance knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReflectanceOptions {
    /// Frame combination.
    pub method: ReflectanceMethod,
    /// Alternating least-squares rounds of the spherical-harmonic fit.
    pub sh_rounds: usize,
    /// Use every n-th pixel in u and v.
    pub stride_px: u32,
    /// A frame counts for a pixel when its irradiance is at least this fraction of the pixel's
    /// best frame.
    pub min_rel_irradiance: f64,
    /// Re-estimates with interreflections.
    pub iterations: usize,
    /// Lowest accepted reflectance.
    pub rho_min: f64,
    /// Highest accepted reflectance.
    pub rho_max: f64,
    /// Points over a luminaire's opening for each pixel's direct light.
    pub opening_points: usize,
    /// The interreflections hold every seen patch at the exitance the camera measured there
    /// (inverse radiosity) rather than at the previous estimate's reflectances. The plain
    /// fixed point `ρ ← π L / (E_dir + E_ind(ρ))` oscillates where the seen walls carry most
    /// of the interreflections: on the generalization bench's fisheye rooms it ended 10-25 %
    /// high after its 2 rounds (docs/generalization.md).
    pub hold_seen: bool,
}

impl Default for ReflectanceOptions {
    fn default() -> Self {
        Self {
            method: ReflectanceMethod::Median,
            sh_rounds: 10,
            stride_px: 2,
            min_rel_irradiance: 0.25,
            iterations: 2,
            rho_min: 0.02,
            rho_max: 0.95,
            opening_points: 16,
            hold_seen: true,
        }
    }
}

/// Pixels that see a reconstructed surface, with what the estimate needs.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    /// Pixel (u, v).
    pub pixel: Vec<(u32, u32)>,
    /// Engine patch hit.
    pub patch: Vec<u32>,
    /// Mesh triangle.
    pub tri: Vec<u32>,
    /// Luminance frame value per luminaire (NaN: saturated or black), units.
    pub value: Vec<Vec<f64>>,
    /// Exact direct irradiance per luminaire at 100 %, lx.
    pub e_dir_lx: Vec<Vec<f64>>,
}

impl Samples {
    /// Appends another camera's samples, their frame values times `scale` (its gain over this
    /// camera's).
    pub fn extend(&mut self, other: Samples, scale: f64) {
        self.pixel.extend(other.pixel);
        self.patch.extend(other.patch);
        self.tri.extend(other.tri);
        self.value.extend(
            other
                .value
                .into_iter()
                .map(|v| v.into_iter().map(|x| x * scale).collect::<Vec<f64>>()),
        );
        self.e_dir_lx.extend(other.e_dir_lx);
    }
}

/// Outcome of an estimate.
#[derive(Debug, Clone, Default)]
pub struct Estimate {
    /// Reflectance per mesh triangle (seen triangles; others keep their input).
    pub tri_rho: Vec<f64>,
    /// Seen triangles that got no pixel (took their part's median).
    pub tris_without_pixels: usize,
    /// Triangles clamped to the accepted range.
    pub clamped: usize,
    /// Pixels that gave a value.
    pub pixels_used: usize,
    /// Camera gain used, cd/m² per unit.
    pub gain_cd_m2_per_unit: f64,
    /// Median reflectance of the floor plane's pixels (for the inferred floor).
    pub floor_rho: Option<f64>,
    /// Median reflectance of the seen walls' pixels, when the walls nobody saw took it
    /// ([`MIN_SEEN_WALL_PIXELS`] or more of them), and how many pixels.
    pub walls_rho: Option<(f64, usize)>,
}

/// The walls nobody saw take the seen walls' reflectance from this many of their pixels on
/// (a few hundred pixels: a strip of wall at the image's edge; fewer keep the default).
pub const MIN_SEEN_WALL_PIXELS: usize = 200;

/// The median of `v` (reordered), `None` when empty.
pub(crate) fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len();
    Some(if m % 2 == 1 {
        v[m / 2]
    } else {
        0.5 * (v[m / 2 - 1] + v[m / 2])
    })
}

/// Collects the pixel samples on the pass model's patches: `(model, caster, reco)`, the pass
/// model, its ray caster and the mesh it was built from; a pixel whose cleaned depth (`depth`,
/// the capture's) disagrees with the patch its ray hits is left out.
pub fn sample(
    capture: &Capture,
    depth: &DepthMap,
    luminaires: &[Luminaire],
    (model, caster, reco): (&Model, &RayCaster, &RecoMesh),
    o: &ReflectanceOptions,
) -> Samples {
    let cam = &capture.camera;
    let s = o.stride_px.max(1);
    let openings: Vec<Vec<DVec3>> = luminaires
        .iter()
        .map(|l| direct::opening_points(l, o.opening_points.max(1)))
        .collect();
    let pixels: Vec<(u32, u32)> = (0..cam.height / s)
        .flat_map(|v| (0..cam.width / s).map(move |u| (u * s + s / 2, v * s + s / 2)))
        .collect();
    type Row = (u32, u32, u32, u32, Vec<f64>, Vec<f64>);
    let rows: Vec<Option<Row>> = pixels
        .par_iter()
        .map(|&(u, v)| {
            let dir = cam.ray_world(f64::from(u), f64::from(v))?;
            let Hit::Front { patch, t_m } = caster.closest(cam.position_m, dir) else {
                return None;
            };
            let tri = model.patches.source_triangle[patch as usize];
            if !reco.part.get(tri as usize).is_some_and(|p| p.seen()) {
                return None;
            }
            let x = cam.position_m + dir * t_m;
            // the pixel's own depth puts its surface elsewhere: it sees something the mesh
            // lacks (a monitor seen edge-on at another node's image edge), not this patch
            if depth.sees_at(cam, u, v, x) == Some(false) {
                return None;
            }
            let n = model.patches.normal[patch as usize];
            let i = (v * cam.width + u) as usize;
            // the luminaire's own light: its frame less the all-off frame (daylight), if any
            let value: Vec<f64> = (0..capture.luminance.len())
                .map(|k| capture.luminaire_value(k, i).unwrap_or(f64::NAN))
                .collect();
            let e: Vec<f64> = luminaires
                .iter()
                .zip(&openings)
                .map(|(l, pts)| direct::illuminance_lx(l, pts, x, n, Receiver::Surface, caster))
                .collect();
            Some((u, v, patch, tri, value, e))
        })
        .collect();
    let mut out = Samples::default();
    for (u, v, patch, tri, value, e) in rows.into_iter().flatten() {
        out.pixel.push((u, v));
        out.patch.push(patch);
        out.tri.push(tri);
        out.value.push(value);
        out.e_dir_lx.push(e);
    }
    out
}

/// Interreflected irradiance per luminaire on each patch, lx: `Σ_j F_ij B_j` with
/// `B = ρ (E_dir + F B)` over the patches without a measured exitance, and `B_i` held at
/// `held[l][i]` where the camera measured it (inverse radiosity: Yu, Debevec, Malik and
/// Hawkins, "Inverse global illumination", SIGGRAPH 1999, hold the seen surfaces at their
/// measured radiance). `held` empty: every patch solved.
pub fn indirect_lx(
    model: &Model,
    patch_rho: &[f64],
    held: &[Vec<Option<f64>>],
    settings: &Settings,
) -> Result<Vec<Vec<f64>>, SolveError> {
    let sys = CsrSystem {
        f: model.ff.f.view(),
        rho: patch_rho,
    };
    let n = patch_rho.len();
    model
        .direct_patch_lx
        .par_iter()
        .enumerate()
        .map(|(l, e)| {
            let mut b = vec![0.0; n];
            match held.get(l) {
                Some(h) if h.len() == n => {
                    let mut rows = Vec::with_capacity(n);
                    for (i, hi) in h.iter().enumerate() {
                        match hi {
                            Some(x) => b[i] = *x,
                            None => rows.push(i as u32),
                        }
                    }
                    let (mut acc, mut state) = ([0.0], [solver::RhsState::default()]);
                    let work = solver::Workspace {
                        acc: &mut acc,
                        state: &mut state,
                    };
                    let rows = solver::Rows::Listed(&rows);
                    let source = solver::Source::Irradiance(e);
                    solver::solve(&sys, rows, source, &mut b, work, settings.solve)?;
                }
                _ => {
                    solver::gauss_seidel(&sys, e, &mut b, settings.solve)?;
                }
            }
            Ok((0..n)
                .map(|i| model.ff.f.row(i).map(|(j, f)| f * b[j as usize]).sum())
                .collect())
        })
        .collect()
}

/// Fewest pixels of a patch for its measured exitance to be held.
const HELD_MIN_PIXELS: usize = 3;

/// The measured exitance per luminaire on each patch the camera sees, lm/m²: the median of
/// `π gain L` over the patch's pixels (a Lambertian surface's exitance is π times its
/// luminance), where at least [`HELD_MIN_PIXELS`] pixels have a value in that frame.
pub fn measured_exitance(
    samples: &Samples,
    n_patches: usize,
    n_lum: usize,
    gain: f64,
) -> Vec<Vec<Option<f64>>> {
    let mut by_patch: Vec<Vec<usize>> = vec![Vec::new(); n_patches];
    for (k, &p) in samples.patch.iter().enumerate() {
        if let Some(v) = by_patch.get_mut(p as usize) {
            v.push(k);
        }
    }
    (0..n_lum)
        .map(|l| {
            let mut buf = Vec::new();
            by_patch
                .iter()
                .map(|ks| {
                    buf.clear();
                    buf.extend(
                        ks.iter()
                            .filter_map(|&k| samples.value[k].get(l).copied())
                            .filter(|v| v.is_finite() && *v >= 0.0)
                            .map(|v| std::f64::consts::PI * gain * v),
                    );
                    (buf.len() >= HELD_MIN_PIXELS)
                        .then(|| median(&mut buf))
                        .flatten()
                })
                .collect()
        })
        .collect()
}

/// A pixel's irradiance per luminaire (exact direct + the patch's interreflected), lx, and
/// which frames count for it: lit at least `min_rel_irradiance` of its best frame, not
/// saturated or black. `None`: the pixel is dark in every frame.
fn pixel_frames(
    samples: &Samples,
    k: usize,
    e_ind: &[Vec<f64>],
    o: &ReflectanceOptions,
) -> Option<(Vec<f64>, Vec<bool>)> {
    let p = samples.patch[k] as usize;
    let e: Vec<f64> = (0..e_ind.len())
        .map(|l| samples.e_dir_lx[k][l] + e_ind[l][p])
        .collect();
    let best = e.iter().copied().fold(0.0, f64::max);
    if best <= 1e-6 {
        return None;
    }
    let ok = e
        .iter()
        .enumerate()
        .map(|(l, &el)| {
            let val = samples.value[k].get(l).copied().unwrap_or(f64::NAN);
            val.is_finite() && el >= o.min_rel_irradiance * best && el > 0.0
        })
        .collect();
    Some((e, ok))
}

/// Median method: per pixel, the median over its counted frames of `π gain L / E`.
fn median_pixels(
    samples: &Samples,
    e_ind: &[Vec<f64>],
    gain: f64,
    o: &ReflectanceOptions,
) -> Vec<Option<f64>> {
    let mut buf = Vec::with_capacity(e_ind.len());
    (0..samples.pixel.len())
        .map(|k| {
            let (e, ok) = pixel_frames(samples, k, e_ind, o)?;
            buf.clear();
            for l in 0..e.len() {
                if ok[l] {
                    buf.push(std::f64::consts::PI * gain * samples.value[k][l] / e[l]);
                }
            }
            median(&mut buf)
        })
        .collect()
}

/// Spherical-harmonic method (physics.md §8.1, known normals), one fit per mesh triangle.
///
/// Observations `M_jp = π gain L_jp` (lx: ρ times irradiance). Model `M_jp = ρ_p l_jᵀ b(n_p)`,
/// `b(n) = (1, n_x, n_y, n_z)`, one lighting vector `l_j` per frame. From `ρ ≡ 1`, alternate
/// the lighting step `(Bᵀ diag(ρ²) B) l_j = Bᵀ diag(ρ) M_j` (a tiny ridge: a flat triangle's
/// normals span one direction only, and the minimum-norm `l_j` gives the same shading) and the
/// albedo step `ρ_p = Σ_j M_jp s_jp / Σ_j s_jp²` over frames with `s_jp > 0`; ρ is normalised to
/// mean 1 each round. The fit leaves a global scale open per triangle (the paper fixes it with a
/// reference surface); here the shading `s_jp / k` is matched to the engine's irradiance
/// `E_jp` by least squares, which gives the scale `k`. Frames that do not count for a pixel
/// (shadowed by the engine's light, saturated, black) are left out of both steps.
fn sh_pixels(
    samples: &Samples,
    model: &Model,
    e_ind: &[Vec<f64>],
    gain: f64,
    o: &ReflectanceOptions,
) -> Vec<Option<f64>> {
    use nalgebra::{Matrix4, Vector4};
    let n_px = samples.pixel.len();
    let n_lum = e_ind.len();
    let frames: Vec<Option<(Vec<f64>, Vec<bool>)>> = (0..n_px)
        .map(|k| pixel_frames(samples, k, e_ind, o))
        .collect();
    // pixels grouped by triangle, in pixel order (deterministic)
    let mut by_tri: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
    for (k, f) in frames.iter().enumerate() {
        if f.is_some() {
            by_tri.entry(samples.tri[k]).or_default().push(k);
        }
    }
    let groups: Vec<Vec<usize>> = by_tri.into_values().collect();
    let fitted: Vec<Vec<(usize, f64)>> = groups
        .par_iter()
        .map(|px| {
            let b: Vec<Vector4<f64>> = px
                .iter()
                .map(|&k| {
                    let n = model.patches.normal[samples.patch[k] as usize];
                    Vector4::new(1.0, n.x, n.y, n.z)
                })
                .collect();
            let obs = |i: usize, l: usize| -> Option<(f64, f64)> {
                let (e, ok) = frames[px[i]].as_ref()?;
                ok[l].then(|| (std::f64::consts::PI * gain * samples.value[px[i]][l], e[l]))
            };
            let mut rho = vec![1.0_f64; px.len()];
            let mut light = vec![Vector4::<f64>::zeros(); n_lum];
            for _ in 0..o.sh_rounds.max(1) {
                for (l, lj) in light.iter_mut().enumerate() {
                    let mut a = Matrix4::<f64>::zeros();
                    let mut r = Vector4::<f64>::zeros();
                    for i in 0..px.len() {
                        if let (Some((m, _)), true) = (obs(i, l), rho[i].is_finite()) {
                            a += b[i] * b[i].transpose() * (rho[i] * rho[i]);
                            r += b[i] * (rho[i] * m);
                        }
                    }
                    let ridge = 1e-9 * a.trace() + 1e-300;
                    a += Matrix4::identity() * ridge;
                    *lj = a.cholesky().map_or(Vector4::zeros(), |c| c.solve(&r));
                }
                let mut sum = 0.0;
                let mut cnt = 0usize;
                for i in 0..px.len() {
                    let (mut num, mut den) = (0.0, 0.0);
                    for (l, lj) in light.iter().enumerate() {
                        let s = lj.dot(&b[i]);
                        if let (Some((m, _)), true) = (obs(i, l), s > 0.0) {
                            num += m * s;
                            den += s * s;
                        }
                    }
                    rho[i] = if den > 0.0 { num / den } else { f64::NAN };
                    if rho[i].is_finite() {
                        sum += rho[i];
                        cnt += 1;
                    }
                }
                if cnt == 0 || sum <= 0.0 {
                    return Vec::new();
                }
                let mean = sum / cnt as f64;
                for r in &mut rho {
                    *r /= mean;
                }
                for lj in &mut light {
                    *lj *= mean;
                }
            }
            // global scale: shading / k ≈ engine irradiance → 1/k = Σ s E / Σ s²
            let (mut se, mut ss) = (0.0, 0.0);
            for (i, bi) in b.iter().enumerate() {
                for (l, lj) in light.iter().enumerate() {
                    let s = lj.dot(bi);
                    if let (Some((_, e)), true) = (obs(i, l), s > 0.0) {
                        se += s * e;
                        ss += s * s;
                    }
                }
            }
            if se <= 0.0 || ss <= 0.0 {
                return Vec::new();
            }
            let k = ss / se;
            px.iter()
                .zip(&rho)
                .filter(|(_, r)| r.is_finite())
                .map(|(&p, &r)| (p, k * r))
                .collect()
        })
        .collect();
    let mut out = vec![None; n_px];
    for (k, r) in fitted.into_iter().flatten() {
        out[k] = Some(r);
    }
    out
}

/// Per-triangle reflectances for a gain, iterating with interreflections. `tri_rho` holds the
/// starting values (unseen triangles keep theirs, except the inferred floor, which takes the
/// seen floor's, thin objects' hidden faces, which take their seen face's, and inferred desk
/// tops, which take the seen furniture tops' `tops_seen`, and, when `walls_seen` names the
/// seen planes on the room's walls and they hold [`MIN_SEEN_WALL_PIXELS`] pixels, the walls
/// nobody saw, which take theirs: a room's walls are most often one paint). `floor_plane`: the
/// part of the floor plane.
#[allow(clippy::too_many_arguments)]
pub fn estimate(
    samples: &Samples,
    model: &Model,
    reco: &RecoMesh,
    tri_rho_start: &[f64],
    floor_plane: Option<Part>,
    (tops_seen, walls_seen): (&[Part], &[Part]),
    gain: f64,
    settings: &Settings,
    o: &ReflectanceOptions,
) -> Result<Estimate, SolveError> {
    let n_tri = reco.tris.len();
    let mut tri_rho = tri_rho_start.to_vec();
    let mut out = Estimate {
        gain_cd_m2_per_unit: gain,
        ..Estimate::default()
    };
    let n_lum = model.direct_patch_lx.len();
    let held = if o.hold_seen {
        measured_exitance(samples, model.patches.len(), n_lum, gain)
    } else {
        Vec::new()
    };
    for it in 0..=o.iterations {
        let e_ind: Vec<Vec<f64>> = if it == 0 {
            vec![vec![0.0; model.patches.len()]; n_lum]
        } else {
            let patch_rho: Vec<f64> = model
                .patches
                .source_triangle
                .iter()
                .map(|&t| tri_rho[t as usize])
                .collect();
            indirect_lx(model, &patch_rho, &held, settings)?
        };
        let mut per_tri: Vec<Vec<f64>> = vec![Vec::new(); n_tri];
        let mut floor_px = Vec::new();
        let pixel_rho = match o.method {
            ReflectanceMethod::Median => median_pixels(samples, &e_ind, gain, o),
            ReflectanceMethod::SphericalHarmonics => sh_pixels(samples, model, &e_ind, gain, o),
        };
        let mut used = 0;
        for (k, r) in pixel_rho.iter().enumerate() {
            if let Some(r) = *r {
                used += 1;
                let t = samples.tri[k] as usize;
                per_tri[t].push(r);
                if floor_plane == Some(reco.part[t]) {
                    floor_px.push(r);
                }
            }
        }
        out.pixels_used = used;
        // per part medians for seen triangles without pixels
        let mut by_part: std::collections::HashMap<Part, Vec<f64>> = Default::default();
        #[allow(clippy::needless_range_loop)]
        for t in 0..n_tri {
            if !per_tri[t].is_empty() {
                by_part.entry(reco.part[t]).or_default().extend(&per_tri[t]);
            }
        }
        let mut all: Vec<f64> = by_part.values().flatten().copied().collect();
        let global = median(&mut all).unwrap_or(0.5);
        let mut top_px: Vec<f64> = tops_seen
            .iter()
            .filter_map(|p| by_part.get(p))
            .flatten()
            .copied()
            .collect();
        let desk_rho = median(&mut top_px);
        let mut wall_px: Vec<f64> = walls_seen
            .iter()
            .filter_map(|p| by_part.get(p))
            .flatten()
            .copied()
            .collect();
        let walls_seen_px = wall_px.len();
        out.walls_rho = median(&mut wall_px)
            .filter(|_| walls_seen_px >= MIN_SEEN_WALL_PIXELS)
            .map(|r| (r.clamp(o.rho_min, o.rho_max), walls_seen_px));
        let part_median: std::collections::HashMap<Part, f64> = by_part
            .into_iter()
            .map(|(k, mut v)| (k, median(&mut v).unwrap_or(global)))
            .collect();
        out.floor_rho = median(&mut floor_px);
        out.clamped = 0;
        out.tris_without_pixels = 0;
        for t in 0..n_tri {
            let part = reco.part[t];
            let raw = if part.seen() {
                match median(&mut per_tri[t]) {
                    Some(r) => r,
                    None => {
                        out.tris_without_pixels += 1;
                        part_median.get(&part).copied().unwrap_or(global)
                    }
                }
            } else if part == Part::FloorFill {
                out.floor_rho.unwrap_or(global)
            } else if part == Part::DeskFill {
                desk_rho.unwrap_or(tri_rho_start[t])
            } else if part == Part::Wall {
                out.walls_rho.map_or(tri_rho_start[t], |(r, _)| r)
            } else if let Part::HiddenFace(k) = part {
                // the seen face's material
                part_median.get(&Part::Plane(k)).copied().unwrap_or(global)
            } else {
                tri_rho_start[t]
            };
            let r = if part.seen()
                || matches!(part, Part::FloorFill | Part::HiddenFace(_) | Part::DeskFill)
            {
                let c = raw.clamp(o.rho_min, o.rho_max);
                if c != raw || !raw.is_finite() {
                    out.clamped += 1;
                }
                if c.is_finite() { c } else { o.rho_min }
            } else {
                raw
            };
            tri_rho[t] = r;
        }
    }
    out.tri_rho = tri_rho;
    Ok(out)
}

/// The pass model's reading at sensor `s` for a dimming state, with these patch exitances
/// (no final gather in the pass model: the gather row applies to all of B).
pub fn sensor_reading_lx(
    model: &Model,
    s: usize,
    levels: &[f64],
    patch_rho: &[f64],
    settings: &Settings,
) -> Result<f64, SolveError> {
    reading_over_row(
        model,
        levels,
        patch_rho,
        settings,
        |l| model.direct_sensor_lx[s][l],
        || model.gather.row(s),
    )
}

/// A receiver's reading for a dimming state: `Σ_l x_l (direct_l + row · B_l)`, with `B_l` the
/// pass model's exitance from luminaire `l` alone at these patch reflectances.
fn reading_over_row<R: IntoIterator<Item = (u32, f64)>>(
    model: &Model,
    levels: &[f64],
    patch_rho: &[f64],
    settings: &Settings,
    direct_lx: impl Fn(usize) -> f64,
    row: impl Fn() -> R,
) -> Result<f64, SolveError> {
    let sys = CsrSystem {
        f: model.ff.f.view(),
        rho: patch_rho,
    };
    let mut total = 0.0;
    for (l, &x) in levels.iter().enumerate() {
        if x == 0.0 {
            continue;
        }
        let mut b = vec![0.0; patch_rho.len()];
        solver::gauss_seidel(&sys, &model.direct_patch_lx[l], &mut b, settings.solve)?;
        let g: f64 = row().into_iter().map(|(j, w)| w * b[j as usize]).sum();
        total += x * (direct_lx(l) + g);
    }
    Ok(total)
}

/// A point receiver's gather row and direct light on a model: what an ideal cosine receiver at
/// `position` facing `normal` reads (the ambient light sensor at the node).
#[derive(Debug, Clone)]
pub struct PointReceiver {
    /// Direct illuminance per luminaire at 100 %, lx.
    pub direct_lx: Vec<f64>,
    /// Gather row over the model's patches.
    pub row: Vec<(u32, f64)>,
}

impl PointReceiver {
    /// The receiver on `model` (the scene's luminaires, `rays` gather rays).
    pub fn new(
        model: &Model,
        luminaires: &[Luminaire],
        caster: &RayCaster,
        position: DVec3,
        normal: DVec3,
        response: &crate::lsc::AngularResponse,
        rays: usize,
    ) -> Self {
        let set = crate::engine::rayset::RaySet::new(model.settings.ray_set, rays);
        let row = crate::engine::gather_row(
            position,
            normal,
            response,
            caster,
            &set,
            crate::engine::GatherWeighting::Consistent,
        );
        let direct_lx = luminaires
            .iter()
            .map(|l| {
                let pts = direct::opening_points(l, model.settings.opening_samples);
                let receiver = match response {
                    crate::lsc::AngularResponse::Cosine => Receiver::Surface,
                    r => Receiver::Sensor(r),
                };
                direct::illuminance_lx(l, &pts, position, normal, receiver, caster)
            })
            .collect();
        Self { direct_lx, row }
    }

    /// The reading for a dimming state with these patch reflectances (the model's solve; no
    /// final gather).
    pub fn reading_lx(
        &self,
        model: &Model,
        levels: &[f64],
        patch_rho: &[f64],
        settings: &Settings,
    ) -> Result<f64, SolveError> {
        reading_over_row(
            model,
            levels,
            patch_rho,
            settings,
            |l| self.direct_lx.get(l).copied().unwrap_or(0.0),
            || self.row.iter().copied(),
        )
    }
}
