//! Dense illuminance: lux at every surface point the camera sees (or any point of a calculation
//! grid), for any dimming state, not one flat value per patch.
//!
//! At a surface point `x` of patch `i` (unit normal `n`):
//!
//! `E(x) = Σ_l x_l [ E^dir_l(x) + H̃_l(x) ]`
//!
//! * `E^dir_l(x)`: the first bounce, exact: the luminaire's photometry over its opening, inverse
//!   square, cosine, and a shadow ray per opening point ([`super::direct`]), at the point itself.
//! * `H̃_l(x)`: the interreflected light, the incident illuminance `H_i = Σ_j F_ij B_j` of the
//!   solved radiosity (basis exitances `B` at 100 %), made continuous: each mesh vertex takes
//!   the area-weighted mean of `H` over the patches around it that lie in the same surface
//!   (same group and plane), and a point takes the barycentric interpolation of its patch's three
//!   vertex values (Gouraud interpolation of radiosity, Cohen & Wallace 1993, §8.2).
//!
//! So the picture has the sharp detail of direct light (shadow edges, the bright spot under a
//! luminaire) wherever the point is, and smooth interreflection without the triangles of the
//! patch mesh. Grid points on a desk get the same treatment ([`DenseField::points`]), with the
//! sensor's number of opening points for their direct light.
//!
//! Superposition: everything is kept per luminaire at 100 %, so a dimming state is a weighted
//! sum per point ([`Readings::lux`], [`DenseImage::lux`]).

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::direct::{self, Receiver};
use super::patches::Patches;
use super::raycast::{Hit, RayCaster};
use super::{Csr, EngineError, Model, SENSOR_OPENING_POINTS};
use crate::scene::{Camera, Luminaire};

/// How densely to evaluate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DenseSettings {
    /// Points over each luminaire's opening for a pixel's direct light.
    pub pixel_opening_points: usize,
    /// Points over each luminaire's opening for a grid point's direct light.
    pub grid_opening_points: usize,
}

impl Default for DenseSettings {
    fn default() -> Self {
        Self {
            pixel_opening_points: 16,
            grid_opening_points: SENSOR_OPENING_POINTS,
        }
    }
}

/// A corner's identity for welding: quantised position, normal, group.
type WeldKey = (i64, i64, i64, i32, i32, i32, u32);

/// Vertices of the patch mesh, welded per surface: corners at the same place (to 10⁻⁶ of the
/// scene's size) of patches of the same group and plane are one vertex.
#[derive(Debug, Clone)]
pub struct VertexMesh {
    /// The three vertex ids of each patch's corners.
    pub corner_vertex: Vec<[u32; 3]>,
    /// Vertices.
    pub vertices: usize,
    /// For each vertex, (patch, weight) with the weights summing to 1 (patch areas).
    adjacency: Vec<Vec<(u32, f64)>>,
}

impl VertexMesh {
    /// Welds the patches' corners.
    pub fn new(patches: &Patches) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &patches.corners_m {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let diag = (hi - lo).length();
        let q = if diag.is_finite() && diag > 0.0 {
            1e6 / diag
        } else {
            1e6
        };
        let key = |p: DVec3, n: DVec3, g: u32| -> WeldKey {
            (
                ((p.x - lo.x) * q).round() as i64,
                ((p.y - lo.y) * q).round() as i64,
                ((p.z - lo.z) * q).round() as i64,
                (n.x * 100.0).round() as i32,
                (n.y * 100.0).round() as i32,
                (n.z * 100.0).round() as i32,
                g,
            )
        };
        let mut ids: HashMap<WeldKey, u32> = HashMap::new();
        let mut corner_vertex = Vec::with_capacity(patches.len());
        let mut adjacency: Vec<Vec<(u32, f64)>> = Vec::new();
        for i in 0..patches.len() {
            let mut cv = [0u32; 3];
            for (k, p) in patches.corners_m[i].iter().enumerate() {
                let next = ids.len() as u32;
                let id = *ids
                    .entry(key(*p, patches.normal[i], patches.group[i]))
                    .or_insert(next);
                if id as usize == adjacency.len() {
                    adjacency.push(Vec::new());
                }
                adjacency[id as usize].push((i as u32, patches.area_m2[i]));
                cv[k] = id;
            }
            corner_vertex.push(cv);
        }
        for a in &mut adjacency {
            let total: f64 = a.iter().map(|x| x.1).sum();
            let n = a.len() as f64;
            for x in a.iter_mut() {
                x.1 = if total > 0.0 { x.1 / total } else { 1.0 / n };
            }
        }
        Self {
            corner_vertex,
            vertices: adjacency.len(),
            adjacency,
        }
    }

    /// Vertex values from per-patch values: the weighted mean over the adjacent patches.
    pub fn vertex_values(&self, per_patch: &[f64]) -> Vec<f64> {
        self.adjacency
            .iter()
            .map(|a| a.iter().map(|(p, w)| w * per_patch[*p as usize]).sum())
            .collect()
    }
}

/// Barycentric coordinates of `x` (on or near the triangle's plane) in triangle `t`, clamped
/// to the triangle.
pub fn barycentric(t: &[DVec3; 3], x: DVec3) -> [f64; 3] {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], x - t[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if den.is_nan() || den.abs() <= 0.0 {
        return [1.0 / 3.0; 3];
    }
    let v = ((d22 * d1 - d12 * d2) / den).clamp(0.0, 1.0);
    let w = ((d11 * d2 - d12 * d1) / den).clamp(0.0, 1.0);
    let s = v + w;
    let (v, w) = if s > 1.0 { (v / s, w / s) } else { (v, w) };
    [1.0 - v - w, v, w]
}

/// A surface point to evaluate: position, unit normal of its surface, and its patch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position, m.
    pub position_m: DVec3,
    /// Unit normal.
    pub normal: DVec3,
    /// The patch it lies on.
    pub patch: u32,
}

/// Illuminance per luminaire at 100 % at a set of points, split into direct and interreflected.
#[derive(Debug, Clone, Default)]
pub struct Readings {
    /// Luminaires.
    pub luminaires: usize,
    /// Direct, lx, `[point * luminaires + l]`.
    pub direct_lx: Vec<f64>,
    /// Interreflected, lx, `[point * luminaires + l]`.
    pub indirect_lx: Vec<f64>,
}

impl Readings {
    /// The readings of points computed one row (direct, interreflected per luminaire) each.
    fn from_rows(luminaires: usize, rows: Vec<(Vec<f64>, Vec<f64>)>) -> Self {
        let mut out = Readings {
            luminaires,
            direct_lx: Vec::with_capacity(rows.len() * luminaires),
            indirect_lx: Vec::with_capacity(rows.len() * luminaires),
        };
        for (d, i) in rows {
            out.direct_lx.extend(d);
            out.indirect_lx.extend(i);
        }
        out
    }
}

impl Readings {
    /// Points.
    pub fn len(&self) -> usize {
        self.direct_lx.len() / self.luminaires.max(1)
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.direct_lx.is_empty()
    }

    /// Illuminance at every point for a dimming state (levels in luminaire order, in [0, 1]).
    pub fn lux(&self, levels: &[f64]) -> Result<Vec<f64>, EngineError> {
        check_levels(levels, self.luminaires)?;
        let l = self.luminaires;
        Ok(self
            .direct_lx
            .chunks(l.max(1))
            .zip(self.indirect_lx.chunks(l.max(1)))
            .map(|(d, i)| {
                d.iter()
                    .zip(i)
                    .zip(levels)
                    .map(|((d, i), x)| (d + i) * x)
                    .sum()
            })
            .collect())
    }
}

fn check_levels(levels: &[f64], luminaires: usize) -> Result<(), EngineError> {
    if levels.len() != luminaires {
        return Err(EngineError::State(format!(
            "{} levels for {} luminaires",
            levels.len(),
            luminaires
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

/// The solved radiosity of a room made dense: the ray caster, the luminaires, and the
/// interreflected illuminance per luminaire at every vertex of the patch mesh.
pub struct DenseField<'a> {
    patches: &'a Patches,
    luminaires: &'a [Luminaire],
    caster: RayCaster,
    mesh: VertexMesh,
    /// `[luminaire][vertex]` interreflected illuminance at 100 %, lx.
    vertex_indirect_lx: Vec<Vec<f64>>,
    settings: DenseSettings,
}

impl<'a> DenseField<'a> {
    /// From patches, luminaires (in the order of `basis_b`), the form factors and the basis
    /// exitances `[luminaire][patch]` (lm/m²).
    pub fn new(
        patches: &'a Patches,
        luminaires: &'a [Luminaire],
        ff: &Csr,
        basis_b: &[Vec<f64>],
        settings: DenseSettings,
    ) -> Result<Self, EngineError> {
        if basis_b.len() != luminaires.len() {
            return Err(EngineError::State(format!(
                "{} basis solutions for {} luminaires",
                basis_b.len(),
                luminaires.len()
            )));
        }
        let n = patches.len();
        if ff.rows() != n || basis_b.iter().any(|b| b.len() != n) {
            return Err(EngineError::State(
                "form factors or exitances do not match the patches".into(),
            ));
        }
        if settings.pixel_opening_points == 0
            || settings.pixel_opening_points > 4096
            || settings.grid_opening_points == 0
            || settings.grid_opening_points > 4096
        {
            return Err(EngineError::Settings(
                "opening points must be 1..=4096".into(),
            ));
        }
        let caster = RayCaster::new(patches);
        let mesh = VertexMesh::new(patches);
        let vertex_indirect_lx = basis_b
            .par_iter()
            .map(|b| {
                let h: Vec<f64> = (0..n)
                    .map(|i| ff.row(i).map(|(j, f)| f * b[j as usize]).sum())
                    .collect();
                mesh.vertex_values(&h)
            })
            .collect();
        Ok(Self {
            patches,
            luminaires,
            caster,
            mesh,
            vertex_indirect_lx,
            settings,
        })
    }

    /// From a commissioned model and its scene's luminaires.
    pub fn from_model(
        model: &'a Model,
        luminaires: &'a [Luminaire],
        settings: DenseSettings,
    ) -> Result<Self, EngineError> {
        Self::new(
            &model.patches,
            luminaires,
            &model.ff.f,
            &model.basis_b,
            settings,
        )
    }

    /// The ray caster over the patches.
    pub fn caster(&self) -> &RayCaster {
        &self.caster
    }

    /// The patches.
    pub fn patches(&self) -> &Patches {
        self.patches
    }

    /// The welded vertex mesh.
    pub fn mesh(&self) -> &VertexMesh {
        &self.mesh
    }

    /// Interreflected illuminance per luminaire at 100 % at a point of patch `patch`, lx.
    fn indirect_at(&self, patch: usize, x: DVec3, out: &mut [f64]) {
        let w = barycentric(&self.patches.corners_m[patch], x);
        let v = self.mesh.corner_vertex[patch];
        for (o, vals) in out.iter_mut().zip(&self.vertex_indirect_lx) {
            *o = w[0] * vals[v[0] as usize]
                + w[1] * vals[v[1] as usize]
                + w[2] * vals[v[2] as usize];
        }
    }

    fn evaluate(&self, points: &[SurfacePoint], opening_points: usize) -> Readings {
        let l = self.luminaires.len();
        let openings: Vec<Vec<DVec3>> = self
            .luminaires
            .iter()
            .map(|lum| direct::opening_points(lum, opening_points))
            .collect();
        let rows: Vec<(Vec<f64>, Vec<f64>)> = points
            .par_iter()
            .map(|p| {
                let mut d = vec![0.0; l];
                let mut i = vec![0.0; l];
                if (p.patch as usize) < self.patches.len() {
                    for ((o, lum), pts) in d.iter_mut().zip(self.luminaires).zip(&openings) {
                        *o = direct::illuminance_lx(
                            lum,
                            pts,
                            p.position_m,
                            p.normal,
                            Receiver::Surface,
                            &self.caster,
                        );
                    }
                    self.indirect_at(p.patch as usize, p.position_m, &mut i);
                }
                (d, i)
            })
            .collect();
        Readings::from_rows(l, rows)
    }

    /// Readings at calculation-grid points (the sensor's number of opening points).
    pub fn points(&self, points: &[SurfacePoint]) -> Readings {
        self.evaluate(points, self.settings.grid_opening_points)
    }

    /// Readings at many points for a picture (a plan view's cells): a pixel's number of opening
    /// points.
    pub fn map_readings(&self, points: &[SurfacePoint]) -> Readings {
        let openings = self.openings();
        let l = self.luminaires.len();
        let rows: Vec<(Vec<f64>, Vec<f64>)> = points
            .par_iter()
            .map(|p| {
                let mut i = vec![0.0; l];
                if (p.patch as usize) < self.patches.len() {
                    self.indirect_at(p.patch as usize, p.position_m, &mut i);
                    (self.pixel_direct(&Pixel::Surface(*p), &openings), i)
                } else {
                    (vec![0.0; l], i)
                }
            })
            .collect();
        Readings::from_rows(l, rows)
    }

    /// Readings at points in the air (a calculation plane above the floor, the immediate
    /// surroundings of a desk): exact direct light as at grid points, and the interreflection
    /// gathered from the patches' exitance with `rays` cosine-distributed rays (there is no
    /// patch to interpolate on).
    pub fn air_points(
        &self,
        points: &[(DVec3, DVec3)],
        basis_b: &[Vec<f64>],
        rays: usize,
    ) -> Readings {
        let l = self.luminaires.len();
        let openings: Vec<Vec<DVec3>> = self
            .luminaires
            .iter()
            .map(|lum| direct::opening_points(lum, self.settings.grid_opening_points))
            .collect();
        let set = super::RaySet::new(super::RaySetKind::Isocell, rays.clamp(1, 100_000));
        let cosine = crate::lsc::AngularResponse::Cosine;
        let rows: Vec<(Vec<f64>, Vec<f64>)> = points
            .par_iter()
            .map(|&(p, n)| {
                let row = super::gather_row(
                    p,
                    n,
                    &cosine,
                    &self.caster,
                    &set,
                    super::GatherWeighting::Consistent,
                );
                let d = self
                    .luminaires
                    .iter()
                    .zip(&openings)
                    .map(|(lum, pts)| {
                        direct::illuminance_lx(lum, pts, p, n, Receiver::Surface, &self.caster)
                    })
                    .collect();
                let i = basis_b
                    .iter()
                    .map(|b| {
                        row.iter()
                            .map(|(j, w)| w * b.get(*j as usize).copied().unwrap_or(0.0))
                            .sum()
                    })
                    .collect();
                (d, i)
            })
            .collect();
        Readings::from_rows(l, rows)
    }

    fn openings(&self) -> Openings {
        Openings {
            near: self
                .luminaires
                .iter()
                .map(|lum| direct::opening_points(lum, self.settings.pixel_opening_points))
                .collect(),
            far: self
                .luminaires
                .iter()
                .map(|lum| {
                    direct::opening_points(lum, (self.settings.pixel_opening_points / 4).max(1))
                })
                .collect(),
        }
    }

    /// The surface point on the first upward-facing surface below (x, y): a desk top, the floor
    /// (ceilings seen from above are passed through).
    pub fn surface_below(&self, x: f64, y: f64, top_z_m: f64) -> Option<SurfacePoint> {
        let (p, patch) = super::points::surface_below(&self.caster, x, y, top_z_m)?;
        Some(SurfacePoint {
            position_m: p,
            normal: self.patches.normal[patch as usize],
            patch,
        })
    }

    /// The surface point at height `z_m` on the patch right below (x, y, z + 1 mm): a point of
    /// a horizontal calculation plane that lies on a surface (a desk top at its height), or
    /// `None` when no horizontal surface is within 5 mm.
    pub fn surface_at(&self, x: f64, y: f64, z_m: f64) -> Option<SurfacePoint> {
        let origin = DVec3::new(x, y, z_m + 0.001);
        match self.caster.closest(origin, DVec3::NEG_Z) {
            Hit::Front { patch, t_m } if t_m < 0.006 => Some(SurfacePoint {
                position_m: origin + DVec3::NEG_Z * t_m,
                normal: self.patches.normal[patch as usize],
                patch,
            }),
            _ => None,
        }
    }

    /// Direct light per luminaire at one pixel (zeros where no reflecting surface is seen).
    /// Luminaires farther than [`FAR_OPENINGS`] opening diagonals use the `far` opening points.
    fn pixel_direct(&self, p: &Pixel, openings: &Openings) -> Vec<f64> {
        let mut out = vec![0.0; self.luminaires.len()];
        if let Pixel::Surface(sp) = p {
            for (k, (o, lum)) in out.iter_mut().zip(self.luminaires).enumerate() {
                let size = lum.opening_m[0].hypot(lum.opening_m[1]);
                let pts = if (lum.position_m - sp.position_m).length() < FAR_OPENINGS * size {
                    &openings.near[k]
                } else {
                    &openings.far[k]
                };
                *o = direct::illuminance_lx(
                    lum,
                    pts,
                    sp.position_m,
                    sp.normal,
                    Receiver::Surface,
                    &self.caster,
                );
            }
        }
        out
    }

    /// The plane a pixel sees (group, normal, offset), for the smoothness test.
    fn plane_of(&self, p: &Pixel) -> Option<(u32, [i32; 3], i64)> {
        match p {
            Pixel::Surface(sp) => {
                let n = sp.normal;
                Some((
                    self.patches.group[sp.patch as usize],
                    [
                        (n.x * 100.0).round() as i32,
                        (n.y * 100.0).round() as i32,
                        (n.z * 100.0).round() as i32,
                    ],
                    (n.dot(sp.position_m) * 1000.0).round() as i64,
                ))
            }
            _ => None,
        }
    }

    /// Fills a block's direct light: interpolated where its corners see one plane and predict
    /// its centre, else split in four (computed pixel by pixel at 3 × 3 pixels and below).
    fn refine(
        &self,
        block: &mut Block,
        (a0, a1, b0, b1): (usize, usize, usize, usize),
        w: usize,
        pixels: &[Pixel],
        openings: &Openings,
    ) {
        let compute = |block: &mut Block, u: usize, v: usize| {
            if block.get(u, v).is_none() {
                block.set(u, v, self.pixel_direct(&pixels[v * w + u], openings));
            }
        };
        for (u, v) in [(a0, b0), (a1, b0), (a0, b1), (a1, b1)] {
            compute(block, u, v);
        }
        if a1 - a0 <= 2 && b1 - b0 <= 2 {
            for v in b0..=b1 {
                for u in a0..=a1 {
                    compute(block, u, v);
                }
            }
            return;
        }
        let (ac, bc) = ((a0 + a1) / 2, (b0 + b1) / 2);
        let plane = self.plane_of(&pixels[b0 * w + a0]);
        let smooth = plane.is_some()
            && [(a1, b0), (a0, b1), (a1, b1), (ac, bc)]
                .iter()
                .all(|&(u, v)| self.plane_of(&pixels[v * w + u]) == plane);
        compute(block, ac, bc);
        if smooth {
            let exact = block.get(ac, bc).cloned().unwrap_or_default();
            let pred = block.lerp((a0, a1, b0, b1), ac, bc);
            let total: f64 = exact.iter().sum();
            let good = exact.iter().zip(&pred).all(|(e, p)| {
                (e - p).abs() <= BLOCK_TOLERANCE * e + BLOCK_TOLERANCE_OF_TOTAL * total + 0.5
            });
            if good {
                for v in b0..=b1 {
                    for u in a0..=a1 {
                        if block.get(u, v).is_none() {
                            let vals = block.lerp((a0, a1, b0, b1), u, v);
                            block.set(u, v, vals);
                        }
                    }
                }
                return;
            }
        }
        for (x0, x1) in [(a0, ac), (ac, a1)] {
            for (y0, y1) in [(b0, bc), (bc, b1)] {
                if x1 > x0 && y1 > y0 {
                    self.refine(block, (x0, x1, y0, y1), w, pixels, openings);
                }
            }
        }
        // a degenerate split (a side of one pixel): compute what is left
        for v in b0..=b1 {
            for u in a0..=a1 {
                compute(block, u, v);
            }
        }
    }

    /// The per-pixel view of a camera: what each pixel sees and its illuminance per luminaire.
    ///
    /// Interreflection is interpolated at every pixel. Direct light is computed exactly at every
    /// pixel where it changes in a way a bilinear interpolation could miss: the image is cut in
    /// blocks of [`BLOCK_PIXELS`]²; a block whose corners see one plane of one surface, and
    /// whose centre's exact value the corners' bilinear interpolation predicts to within
    /// [`BLOCK_TOLERANCE`] for every luminaire (no shadow edge, no highlight inside), is
    /// interpolated; every other block is computed pixel by pixel.
    pub fn camera_view(&self, cam: &Camera) -> Result<DenseImage, EngineError> {
        let (w, h) = (cam.width as usize, cam.height as usize);
        if w == 0 || h == 0 || w * h > 16_000_000 {
            return Err(EngineError::Settings(format!(
                "camera of {w} × {h} pixels: 1 to 16 million pixels"
            )));
        }
        let pixels: Vec<Pixel> = (0..w * h)
            .into_par_iter()
            .map(|k| {
                let (u, v) = ((k % w) as f64, (k / w) as f64);
                let Some(dir) = cam.ray_world(u, v) else {
                    return Pixel::Nothing;
                };
                match self.caster.closest(cam.position_m, dir) {
                    Hit::Front { patch, t_m } => {
                        if self.patches.rho[patch as usize] <= 0.0 {
                            Pixel::Emitter(patch)
                        } else {
                            Pixel::Surface(SurfacePoint {
                                position_m: cam.position_m + dir * t_m,
                                normal: self.patches.normal[patch as usize],
                                patch,
                            })
                        }
                    }
                    Hit::Back { patch, .. } => Pixel::Back(patch),
                    Hit::Miss => Pixel::Nothing,
                }
            })
            .collect();
        let l = self.luminaires.len();
        let openings = self.openings();
        // indirect: every pixel
        let mut indirect_lx = vec![0.0; w * h * l];
        indirect_lx
            .par_chunks_mut(l.max(1))
            .zip(&pixels)
            .for_each(|(out, p)| {
                if let Pixel::Surface(s) = p {
                    self.indirect_at(s.patch as usize, s.position_m, out);
                }
            });
        // direct: the block corners first, then each block refined where it must be
        let s = BLOCK_PIXELS;
        let lattice = |n: usize| -> Vec<usize> {
            let mut c: Vec<usize> = (0..n).step_by(s).collect();
            if *c.last().unwrap_or(&0) != n - 1 {
                c.push(n - 1);
            }
            c
        };
        let (us, vs) = (lattice(w), lattice(h));
        let mut direct_lx = vec![0.0; w * h * l];
        let corner_ids: Vec<usize> = vs
            .iter()
            .flat_map(|&v| us.iter().map(move |&u| v * w + u))
            .collect();
        let corner_values: Vec<(usize, Vec<f64>)> = corner_ids
            .par_iter()
            .map(|&k| (k, self.pixel_direct(&pixels[k], &openings)))
            .collect();
        for (k, vals) in &corner_values {
            direct_lx[k * l..(k + 1) * l].copy_from_slice(vals);
        }
        let blocks: Vec<(usize, usize)> = (0..vs.len().saturating_sub(1))
            .flat_map(|bv| (0..us.len().saturating_sub(1)).map(move |bu| (bu, bv)))
            .collect();
        let filled: Vec<Vec<(usize, Vec<f64>)>> = blocks
            .par_iter()
            .map(|&(bu, bv)| {
                let (u0, u1, v0, v1) = (us[bu], us[bu + 1], vs[bv], vs[bv + 1]);
                let mut block = Block {
                    u0,
                    v0,
                    bw: u1 - u0 + 1,
                    values: vec![None; (u1 - u0 + 1) * (v1 - v0 + 1)],
                };
                for (u, v) in [(u0, v0), (u1, v0), (u0, v1), (u1, v1)] {
                    let k = v * w + u;
                    block.set(u, v, direct_lx[k * l..(k + 1) * l].to_vec());
                }
                self.refine(&mut block, (u0, u1, v0, v1), w, &pixels, &openings);
                // the pixels this block owns: not its corners (computed already); its right and
                // bottom edges only at the image border
                let mut out = Vec::new();
                for v in v0..=v1 {
                    for u in u0..=u1 {
                        let corner = (u == u0 || u == u1) && (v == v0 || v == v1);
                        let own = (u < u1 || u1 == w - 1) && (v < v1 || v1 == h - 1);
                        if own
                            && !corner
                            && let Some(vals) = block.take(u, v)
                        {
                            out.push((v * w + u, vals));
                        }
                    }
                }
                out
            })
            .collect();
        for block in filled {
            for (k, vals) in block {
                direct_lx[k * l..(k + 1) * l].copy_from_slice(&vals);
            }
        }
        Ok(DenseImage {
            width: cam.width,
            height: cam.height,
            luminaires: l,
            pixels,
            direct_lx,
            indirect_lx,
        })
    }
}

/// Side of the largest blocks of a camera view whose direct light may be interpolated, pixels.
pub const BLOCK_PIXELS: usize = 8;

/// Beyond this many opening diagonals a pixel takes a quarter of the opening points.
pub const FAR_OPENINGS: f64 = 4.0;

/// Opening points per luminaire, near and far.
struct Openings {
    near: Vec<Vec<DVec3>>,
    far: Vec<Vec<DVec3>>,
}

/// A block of pixels being filled: values per pixel (per luminaire), None until known.
struct Block {
    u0: usize,
    v0: usize,
    bw: usize,
    values: Vec<Option<Vec<f64>>>,
}

impl Block {
    fn get(&self, u: usize, v: usize) -> Option<&Vec<f64>> {
        self.values[(v - self.v0) * self.bw + (u - self.u0)].as_ref()
    }
    fn set(&mut self, u: usize, v: usize, x: Vec<f64>) {
        self.values[(v - self.v0) * self.bw + (u - self.u0)] = Some(x);
    }
    fn take(&mut self, u: usize, v: usize) -> Option<Vec<f64>> {
        self.values[(v - self.v0) * self.bw + (u - self.u0)].take()
    }
    /// Bilinear interpolation of the corners of (a0, a1, b0, b1) at (u, v).
    fn lerp(&self, (a0, a1, b0, b1): (usize, usize, usize, usize), u: usize, v: usize) -> Vec<f64> {
        let tu = (u - a0) as f64 / (a1 - a0).max(1) as f64;
        let tv = (v - b0) as f64 / (b1 - b0).max(1) as f64;
        let empty = Vec::new();
        let c = |x, y| self.get(x, y).unwrap_or(&empty);
        let (c00, c10, c01, c11) = (c(a0, b0), c(a1, b0), c(a0, b1), c(a1, b1));
        (0..c00.len().min(c10.len()).min(c01.len()).min(c11.len()))
            .map(|j| {
                (1.0 - tu) * (1.0 - tv) * c00[j]
                    + tu * (1.0 - tv) * c10[j]
                    + (1.0 - tu) * tv * c01[j]
                    + tu * tv * c11[j]
            })
            .collect()
    }
}

/// Largest relative error of the bilinear prediction at a block's centre for the block to be
/// interpolated (plus 0.5 lx).
pub const BLOCK_TOLERANCE: f64 = 0.01;

/// The same, as a fraction of the pixel's direct light from all luminaires at 100 %.
pub const BLOCK_TOLERANCE_OF_TOTAL: f64 = 0.0025;

/// What a pixel sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pixel {
    /// A reflecting surface point.
    Surface(SurfacePoint),
    /// A black emitting surface (a luminaire opening).
    Emitter(u32),
    /// The back of a surface (the camera is behind it).
    Back(u32),
    /// Nothing.
    Nothing,
}

/// The dense illuminance of a camera's view.
#[derive(Debug, Clone)]
pub struct DenseImage {
    /// Pixels across.
    pub width: u32,
    /// Pixels down.
    pub height: u32,
    /// Luminaires.
    pub luminaires: usize,
    /// What each pixel sees, row by row.
    pub pixels: Vec<Pixel>,
    /// Direct illuminance per luminaire at 100 %, lx, `[pixel * luminaires + l]` (0 where no
    /// reflecting surface is seen).
    pub direct_lx: Vec<f64>,
    /// Interreflected illuminance per luminaire at 100 %, lx, likewise.
    pub indirect_lx: Vec<f64>,
}

impl DenseImage {
    /// Illuminance per pixel (row by row) for a dimming state; NaN where no reflecting surface
    /// is seen.
    pub fn lux(&self, levels: &[f64]) -> Result<Vec<f64>, EngineError> {
        check_levels(levels, self.luminaires)?;
        let l = self.luminaires.max(1);
        Ok(self
            .pixels
            .par_iter()
            .zip(self.direct_lx.par_chunks(l))
            .zip(self.indirect_lx.par_chunks(l))
            .map(|((p, d), i)| match p {
                Pixel::Surface(_) => d
                    .iter()
                    .zip(i)
                    .zip(levels)
                    .map(|((d, i), x)| (d + i) * x)
                    .sum(),
                _ => f64::NAN,
            })
            .collect())
    }

    /// The patch each pixel sees (None for nothing).
    pub fn patch(&self, k: usize) -> Option<u32> {
        match self.pixels[k] {
            Pixel::Surface(s) => Some(s.patch),
            Pixel::Emitter(p) | Pixel::Back(p) => Some(p),
            Pixel::Nothing => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentric_reproduces_corners_and_clamps() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert_eq!(barycentric(&t, DVec3::ZERO), [1.0, 0.0, 0.0]);
        let w = barycentric(&t, DVec3::new(0.25, 0.25, 0.0));
        assert!((w[0] - 0.5).abs() < 1e-12 && (w[1] - 0.25).abs() < 1e-12);
        let w = barycentric(&t, DVec3::new(2.0, 2.0, 0.0));
        assert!(w.iter().all(|x| *x >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}
