//! The plan view: false-colour illuminance on every upward-facing surface (floor, desk tops,
//! cabinet tops) for one dimming state, with isolines, a grid of values, desk outlines with their
//! mean, the sensors, axes in metres and a colour bar in lux (drawn by plotters).
//!
//! Each map cell is a point on the surface seen from above with dense illuminance
//! ([`crate::engine::dense`]): exact direct light and the interreflection interpolated over
//! the patch mesh, so the picture shows shadows and gradients, not the patches.
//!
//! Windows (the surfaces labelled `window…`: a CAD scene's glazing, a room plan's windows in a
//! commissioned model) are drawn as blue bars along their wall ([`windows_of`]).

use glam::DVec3;
use plotters::prelude::*;

use super::placement::{Placer, around};
use super::{Anchor, Canvas, Colour, Label, nice_ceiling, viridis};
use crate::engine::Model;
use crate::engine::dense::{DenseField, DenseSettings, SurfacePoint};
use crate::scene::Scene;

/// What to draw.
#[derive(Debug, Clone)]
pub struct MapOptions {
    /// Map cell size, m.
    pub cell_m: f64,
    /// Pixels per metre.
    pub pixels_per_m: f64,
    /// Title line.
    pub title: String,
}

impl Default for MapOptions {
    fn default() -> Self {
        Self {
            cell_m: 0.1,
            pixels_per_m: 100.0,
            title: String::new(),
        }
    }
}

/// The computed map, before drawing.
#[derive(Debug, Clone)]
pub struct TopView {
    /// x of the first cell centre, m; y likewise (cells grow along +x and +y).
    pub origin_m: [f64; 2],
    /// Cells along x and y.
    pub cells: [usize; 2],
    /// Cell size, m.
    pub cell_m: f64,
    /// Illuminance per cell (row-major, y outer), lx; NaN where nothing faces up.
    pub lux: Vec<f64>,
    /// Each desk's mean illuminance over its grid points: (desk id, lx).
    pub desk_mean_lx: Vec<(u32, f64)>,
    /// The surface of each cell (a patch group and height bucket): isolines join cells of one
    /// surface only (empty: all one surface).
    pub surface: Vec<u64>,
}

/// The surface key of a map cell's point: its patch group and its height to the centimetre.
pub fn surface_key(group: u32, z_m: f64) -> u64 {
    (u64::from(group) << 32) | ((z_m * 100.0).round() as i64 as u32 as u64)
}

/// The surface points of a map over `bounds` (x0, x1, y0, y1) with cells of `cell_m`: the first
/// upward-facing surface below each cell centre (None where there is none).
pub fn map_points(
    field: &DenseField<'_>,
    bounds: [f64; 4],
    top_z_m: f64,
    cell_m: f64,
) -> ([f64; 2], [usize; 2], Vec<Option<SurfacePoint>>) {
    let cell = cell_m.max(1e-3);
    let nx = (((bounds[1] - bounds[0]) / cell).ceil() as usize).clamp(1, 2000);
    let ny = (((bounds[3] - bounds[2]) / cell).ceil() as usize).clamp(1, 2000);
    let mut pts = Vec::with_capacity(nx * ny);
    for iy in 0..ny {
        for ix in 0..nx {
            let x = bounds[0] + (ix as f64 + 0.5) * cell;
            let y = bounds[2] + (iy as f64 + 0.5) * cell;
            pts.push(field.surface_below(x, y, top_z_m));
        }
    }
    (
        [bounds[0] + 0.5 * cell, bounds[2] + 0.5 * cell],
        [nx, ny],
        pts,
    )
}

/// Computes the map values for a dimming state (`simulate --map`).
pub fn compute(
    scene: &Scene,
    model: &Model,
    levels: &[f64],
    opts: &MapOptions,
) -> Result<TopView, crate::engine::EngineError> {
    let field = DenseField::from_model(model, &scene.luminaires, DenseSettings::default())?;
    let (lo, hi) = scene.mesh.bounds_m();
    let (origin_m, cells, pts) =
        map_points(&field, [lo.x, hi.x, lo.y, hi.y], hi.z + 1.0, opts.cell_m);
    let found: Vec<SurfacePoint> = pts.iter().flatten().copied().collect();
    let values = field.map_readings(&found).lux(levels)?;
    let mut k = 0;
    let lux = pts
        .iter()
        .map(|p| match p {
            Some(_) => {
                k += 1;
                values[k - 1]
            }
            None => f64::NAN,
        })
        .collect();
    let mut desk_mean_lx = Vec::new();
    if let Some(desks) = &scene.desks {
        let sp: Vec<SurfacePoint> = desks
            .grid_points
            .iter()
            .map(|(_, p)| {
                field.surface_at(p.x, p.y, p.z).unwrap_or(SurfacePoint {
                    position_m: *p,
                    normal: DVec3::Z,
                    patch: u32::MAX,
                })
            })
            .collect();
        let v = field.points(&sp).lux(levels)?;
        for d in &desks.desks {
            let own: Vec<f64> = desks
                .grid_points
                .iter()
                .zip(&v)
                .filter(|((id, _), _)| *id == d.id)
                .map(|(_, l)| *l)
                .collect();
            if !own.is_empty() {
                desk_mean_lx.push((d.id, own.iter().sum::<f64>() / own.len() as f64));
            }
        }
    }
    let surface = pts
        .iter()
        .map(|p| {
            p.map_or(u64::MAX, |p| {
                surface_key(field.patches().group[p.patch as usize], p.position_m.z)
            })
        })
        .collect();
    Ok(TopView {
        origin_m,
        cells,
        cell_m: opts.cell_m.max(1e-3),
        lux,
        desk_mean_lx,
        surface,
    })
}

impl TopView {
    /// Bilinear value at a world point (NaN cells ignored); NaN where no cell has a value.
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let [nx, ny] = self.cells;
        let cell = self.cell_m;
        let fx = ((x - self.origin_m[0]) / cell).clamp(0.0, (nx - 1) as f64);
        let fy = ((y - self.origin_m[1]) / cell).clamp(0.0, (ny - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(nx - 1), (y0 + 1).min(ny - 1));
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let mut sum = 0.0;
        let mut w = 0.0;
        for (ix, iy, wk) in [
            (x0, y0, (1.0 - tx) * (1.0 - ty)),
            (x1, y0, tx * (1.0 - ty)),
            (x0, y1, (1.0 - tx) * ty),
            (x1, y1, tx * ty),
        ] {
            let v = self.lux[iy * nx + ix];
            if v.is_finite() {
                sum += wk * v;
                w += wk;
            }
        }
        if w > 1e-9 { sum / w } else { f64::NAN }
    }

    /// The smallest value, lx (0 when none).
    pub fn min_lx(&self) -> f64 {
        let m = self
            .lux
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::INFINITY, f64::min);
        if m.is_finite() { m } else { 0.0 }
    }

    /// The largest value, lx.
    pub fn max_lx(&self) -> f64 {
        self.lux
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    }

    /// Isolines at `level`: segments ((x, y), (x, y)) in metres, by marching squares over the
    /// cell centres (squares with a cell that has no value are skipped; the saddle case is
    /// decided by the square's mean).
    pub fn isoline(&self, level: f64) -> Vec<[(f64, f64); 2]> {
        let [nx, ny] = self.cells;
        let mut out = Vec::new();
        if nx < 2 || ny < 2 {
            return out;
        }
        let at = |ix: usize, iy: usize| self.lux[iy * nx + ix];
        let pos = |ix: f64, iy: f64| {
            (
                self.origin_m[0] + ix * self.cell_m,
                self.origin_m[1] + iy * self.cell_m,
            )
        };
        for iy in 0..ny - 1 {
            for ix in 0..nx - 1 {
                // corners counter-clockwise: (0,0) (1,0) (1,1) (0,1)
                let c = [
                    at(ix, iy),
                    at(ix + 1, iy),
                    at(ix + 1, iy + 1),
                    at(ix, iy + 1),
                ];
                if c.iter().any(|v| !v.is_finite()) {
                    continue;
                }
                if !self.surface.is_empty() {
                    let k = [
                        iy * nx + ix,
                        iy * nx + ix + 1,
                        (iy + 1) * nx + ix + 1,
                        (iy + 1) * nx + ix,
                    ];
                    if k.iter().any(|&j| self.surface[j] != self.surface[k[0]]) {
                        continue;
                    }
                }
                let offs = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
                // crossing points on each edge k (corner k to k+1)
                let mut cross: Vec<(usize, (f64, f64))> = Vec::new();
                for k in 0..4 {
                    let (a, b) = (c[k], c[(k + 1) % 4]);
                    if (a < level) != (b < level) {
                        let t = (level - a) / (b - a);
                        let (ox, oy) = offs[k];
                        let (px, py) = offs[(k + 1) % 4];
                        cross.push((
                            k,
                            pos(
                                ix as f64 + ox + t * (px - ox),
                                iy as f64 + oy + t * (py - oy),
                            ),
                        ));
                    }
                }
                match cross.len() {
                    2 => out.push([cross[0].1, cross[1].1]),
                    4 => {
                        let mean = c.iter().sum::<f64>() / 4.0;
                        // corner 0 above and the centre with it: join 0-1 with 1-2? pair so the
                        // centre's side stays connected
                        if (mean >= level) == (c[0] >= level) {
                            out.push([cross[0].1, cross[3].1]);
                            out.push([cross[1].1, cross[2].1]);
                        } else {
                            out.push([cross[0].1, cross[1].1]);
                            out.push([cross[2].1, cross[3].1]);
                        }
                    }
                    _ => {}
                }
            }
        }
        out
    }
}

/// A desk on a plan: outline (x0, x1, y0, y1), and the lines of its label.
#[derive(Debug, Clone)]
pub struct PlanDesk {
    /// Outline, m: x0, x1, y0, y1.
    pub extent_m: [f64; 4],
    /// Label lines ("desk 1", "Ē 520 lx").
    pub label: Vec<String>,
}

/// Everything a plan view shows.
#[derive(Debug, Clone)]
pub struct PlanView {
    /// Title.
    pub title: String,
    /// A line under the title (state, maintenance factor).
    pub subtitle: String,
    /// Plan bounds, m: x0, x1, y0, y1.
    pub bounds_m: [f64; 4],
    /// The false-colour map.
    pub map: TopView,
    /// Desks.
    pub desks: Vec<PlanDesk>,
    /// Sensors: (id, x, y).
    pub sensors: Vec<(u32, f64, f64)>,
    /// Luminaires: (id, centre x, y, luminous opening along x, y), m.
    pub luminaires: Vec<(u32, [f64; 2], [f64; 2])>,
    /// The grid of values printed: ((x, y), lx).
    pub values: Vec<([f64; 2], f64)>,
    /// Top of the colour scale, lx (0: from the map).
    pub scale_max_lx: f64,
    /// Pixels per metre.
    pub pixels_per_m: f64,
    /// Windows, drawn as bars along their wall.
    pub windows: Vec<PlanWindow>,
}

/// A window seen from above: where its glazing meets the plan.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlanWindow {
    /// The surface's label (`window_1`).
    pub id: String,
    /// One end along the wall, m (x, y).
    pub from_m: [f64; 2],
    /// The other end, m.
    pub to_m: [f64; 2],
    /// Sill and head heights, m.
    pub z_m: [f64; 2],
}

/// The colour of a window's bar on the plan.
pub const WINDOW_RGB: [u8; 3] = [0, 150, 255];

/// The windows among the patches (`group` indexes `labels`): per surface labelled `window…`
/// that stands upright (normal within 30° of horizontal), the two extremes of its corners
/// along the horizontal direction in its plane, and its height range.
pub fn windows_of(
    corners_m: &[[DVec3; 3]],
    normal: &[DVec3],
    group: &[u32],
    labels: &[String],
) -> Vec<PlanWindow> {
    let mut out: Vec<(u32, Vec<DVec3>, DVec3)> = Vec::new();
    for ((c, n), g) in corners_m.iter().zip(normal).zip(group) {
        let label = labels.get(*g as usize).map_or("", String::as_str);
        if !label.starts_with("window") || n.z.abs() > 0.5 {
            continue;
        }
        match out.iter_mut().find(|(k, _, _)| k == g) {
            Some((_, pts, _)) => pts.extend_from_slice(c),
            None => out.push((*g, c.to_vec(), *n)),
        }
    }
    out.into_iter()
        .map(|(g, pts, n)| {
            let along = DVec3::new(-n.y, n.x, 0.0).normalize_or_zero();
            let key = |p: &DVec3| p.dot(along);
            let lo = pts.iter().min_by(|a, b| key(a).total_cmp(&key(b)));
            let hi = pts.iter().max_by(|a, b| key(a).total_cmp(&key(b)));
            let z = pts.iter().map(|p| p.z);
            let (zl, zh) = z.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), z| {
                (a.min(z), b.max(z))
            });
            let (a, b) = (
                lo.copied().unwrap_or_default(),
                hi.copied().unwrap_or_default(),
            );
            PlanWindow {
                id: labels[g as usize].clone(),
                from_m: [a.x, a.y],
                to_m: [b.x, b.y],
                z_m: [zl, zh],
            }
        })
        .collect()
}

/// EN 12464-1's scale of illuminances, lx: the isolines of the report's plan.
pub const EN12464_LEVELS_LX: [f64; 13] = [
    20.0, 30.0, 50.0, 75.0, 100.0, 150.0, 200.0, 300.0, 500.0, 750.0, 1000.0, 1500.0, 2000.0,
];

/// The EN 12464-1 levels strictly between `min` and `max`.
pub fn en12464_levels(min: f64, max: f64) -> Vec<f64> {
    EN12464_LEVELS_LX
        .into_iter()
        .filter(|&v| v > min && v < max)
        .collect()
}

/// Isoline levels for a scale: about six round steps.
pub fn isoline_levels(min: f64, max: f64) -> Vec<f64> {
    if !(max.is_finite() && max > 0.0) {
        return Vec::new();
    }
    let step = nice_ceiling(max / 7.0);
    let mut v = step;
    let mut out = Vec::new();
    while v < max {
        if v > min {
            out.push(v);
        }
        v += step;
    }
    out
}

fn rgb(c: Colour) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

const LEFT: f64 = 72.0;
const TOP: f64 = 58.0;
const RIGHT: f64 = 150.0;
const BOTTOM: f64 = 78.0;

/// Size of the picture of a plan view, pixels, and its pixels per metre.
fn plan_size(v: &PlanView) -> (u32, u32, f64) {
    let [x0, x1, y0, y1] = v.bounds_m;
    let mut ppm = v.pixels_per_m.clamp(10.0, 400.0);
    let big = (x1 - x0).max(y1 - y0) * ppm;
    if big > 2400.0 {
        ppm *= 2400.0 / big;
    }
    let w = ((x1 - x0) * ppm).max(50.0);
    let h = ((y1 - y0) * ppm).max(50.0);
    ((w + LEFT + RIGHT) as u32, (h + TOP + BOTTOM) as u32, ppm)
}

/// Metres to the plan picture's pixels.
#[derive(Debug, Clone, Copy)]
struct Px {
    x0: f64,
    y1: f64,
    ppm: f64,
    /// The map's area in pixels: x0, y0, x1, y1.
    area: [f64; 4],
}

impl Px {
    fn of(v: &PlanView) -> Px {
        let (_, _, ppm) = plan_size(v);
        let [x0, x1, y0, y1] = v.bounds_m;
        Px {
            x0,
            y1,
            ppm,
            area: [LEFT, TOP, LEFT + (x1 - x0) * ppm, TOP + (y1 - y0) * ppm],
        }
    }

    fn at(&self, x: f64, y: f64) -> (f64, f64) {
        (
            LEFT + (x - self.x0) * self.ppm,
            TOP + (self.y1 - y) * self.ppm,
        )
    }

    /// A luminaire symbol's box: its opening, at least 10 pixels a side.
    fn luminaire_box(&self, c: [f64; 2], o: [f64; 2]) -> [f64; 4] {
        let (cx, cy) = self.at(c[0], c[1]);
        let (hw, hh) = (
            (o[0] * self.ppm).max(10.0) / 2.0,
            (o[1] * self.ppm).max(10.0) / 2.0,
        );
        [cx - hw, cy - hh, cx + hw, cy + hh]
    }

    /// A point symbol's box, `r` pixels round it.
    fn point_box(&self, x: f64, y: f64, r: f64) -> [f64; 4] {
        let (px, py) = self.at(x, y);
        [px - r, py - r, px + r, py + r]
    }
}

/// The labels inside a plan's map, placed ([`placement`]): the desks' blocks, then the
/// luminaires' ids, the sensors' ids, the isolines' levels and the grid's values; a label
/// with no free place is left out, so no two overlap.
pub fn plan_labels(v: &PlanView) -> Vec<Label> {
    let px = Px::of(v);
    let mut p = Placer::new(px.area);
    for (_, c, o) in &v.luminaires {
        p.symbol(px.luminaire_box(*c, *o));
    }
    for (_, x, y) in &v.sensors {
        p.symbol(px.point_box(*x, *y, 7.0));
    }
    for (q, _) in &v.values {
        p.symbol(px.point_box(q[0], q[1], 2.0));
    }
    for d in &v.desks {
        let [a, b, c, e] = d.extent_m;
        let (mx, my) = px.at(0.5 * (a + b), 0.5 * (c + e));
        let n = d.label.len() as f64;
        let lines: Vec<Label> = (d.label.iter().enumerate())
            .map(|(k, text)| {
                let l = Label::new(
                    text.clone(),
                    (mx, my + (k as f64 - 0.5 * (n - 1.0)) * 17.0),
                    14.0,
                )
                .anchored(Anchor::Middle, Anchor::Middle)
                .colour(super::WHITE)
                .halo([20, 20, 20]);
                if k == 0 { l.bold() } else { l }
            })
            .collect();
        // the desk's middle, else just beside the luminaire there, then further, each at the
        // desk's height first, then a line block up or down
        let half_w = lines
            .iter()
            .map(|l| 0.5 * (l.bbox()[2] - l.bbox()[0]))
            .fold(0.0, f64::max);
        let lum_half_w = (v.luminaires.iter())
            .filter(|(_, q, _)| q[0] >= a && q[0] <= b && q[1] >= c && q[1] <= e)
            .map(|(_, c, o)| 0.5 * (px.luminaire_box(*c, *o)[2] - px.luminaire_box(*c, *o)[0]))
            .fold(0.0, f64::max);
        let near = lum_half_w + half_w + 3.0;
        let offsets: Vec<(f64, f64)> = [0.0, near, -near, near + 60.0, -near - 60.0]
            .iter()
            .flat_map(|&dx| [0.0, 1.0, -1.0, 2.0, -2.0].map(|k| (dx, k * 17.0 * n)))
            .collect();
        p.place_block(&lines, &offsets);
    }
    for (id, c, o) in &v.luminaires {
        let l = Label::new(format!("L{id}"), (0.0, 0.0), 12.0).halo([255, 255, 255]);
        p.place(around(&l, px.luminaire_box(*c, *o), 3.0));
    }
    for (id, x, y) in &v.sensors {
        let l = Label::new(format!("S{id}"), (0.0, 0.0), 13.0)
            .colour(super::WHITE)
            .halo([20, 20, 20]);
        p.place(around(&l, px.point_box(*x, *y, 7.0), 1.0));
    }
    isoline_labels(v, &px, &mut p);
    for (q, val) in &v.values {
        let l = Label::new(format!("{val:.0}"), (0.0, 0.0), 11.0).halo([255, 255, 255]);
        let mut c = around(&l, px.point_box(q[0], q[1], 2.0), 1.0);
        c.rotate_left(2); // below the dot first
        p.place(c);
    }
    p.labels()
}

/// Each isoline's level, once, at the first of its segments (nearest the room's middle first)
/// where it fits.
fn isoline_labels(v: &PlanView, px: &Px, p: &mut Placer) {
    let [x0, x1, y0, y1] = v.bounds_m;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    for level in en12464_levels(v.map.min_lx(), v.map.max_lx()) {
        let mut segs = v.map.isoline(level);
        let d = |s: &[(f64, f64); 2]| (s[0].0 - cx).powi(2) + (s[0].1 - cy).powi(2);
        segs.sort_by(|a, b| d(a).total_cmp(&d(b)));
        p.place(segs.iter().step_by(3).map(|s| {
            Label::new(format!("{level:.0}"), px.at(s[0].0, s[0].1), 12.0)
                .anchored(Anchor::Middle, Anchor::Middle)
                .colour(super::WHITE)
                .halo([40, 40, 40])
        }));
    }
}

/// Draws a plan view.
pub fn draw_plan(v: &PlanView) -> Canvas {
    let (w, h, ppm) = plan_size(v);
    let [x0, x1, y0, y1] = v.bounds_m;
    let scale_max = if v.scale_max_lx > 0.0 {
        v.scale_max_lx
    } else {
        nice_ceiling(v.map.max_lx())
    };
    let map = move |x: f64, y: f64| -> (i32, i32) {
        (
            (LEFT + (x - x0) * ppm).round() as i32,
            (TOP + (y1 - y) * ppm).round() as i32,
        )
    };
    super::with_plotters(w, h, &mut |root, labels| {
        root.fill(&WHITE)?;
        labels.push(Label::new(v.title.clone(), (LEFT, 12.0), 19.0).bold());
        // the raster, pixel by pixel
        let (pw, ph) = (((x1 - x0) * ppm) as i32, ((y1 - y0) * ppm) as i32);
        for j in 0..ph {
            for i in 0..pw {
                let x = x0 + (f64::from(i) + 0.5) / ppm;
                let y = y1 - (f64::from(j) + 0.5) / ppm;
                let val = v.map.sample(x, y);
                let col = if val.is_finite() {
                    viridis(val / scale_max)
                } else {
                    [210, 210, 210]
                };
                root.draw_pixel((LEFT as i32 + i, TOP as i32 + j), &rgb(col))?;
            }
        }
        super::draw_axes(
            root,
            &map,
            &super::Axis {
                lo: x0,
                hi: x1,
                log: false,
                desc: "x (m)".into(),
            },
            &super::Axis {
                lo: y0,
                hi: y1,
                log: false,
                desc: "y (m)".into(),
            },
            false,
            labels,
        )?;
        let px = Px::of(v);
        for level in en12464_levels(v.map.min_lx(), v.map.max_lx()) {
            for s in &v.map.isoline(level) {
                root.draw(&PathElement::new(
                    vec![map(s[0].0, s[0].1), map(s[1].0, s[1].1)],
                    WHITE.stroke_width(1),
                ))?;
            }
        }
        for (p, _) in &v.values {
            root.draw(&Circle::new(map(p[0], p[1]), 2, BLACK.filled()))?;
        }
        let window = RGBColor(WINDOW_RGB[0], WINDOW_RGB[1], WINDOW_RGB[2]);
        for w in &v.windows {
            root.draw(&PathElement::new(
                vec![map(w.from_m[0], w.from_m[1]), map(w.to_m[0], w.to_m[1])],
                window.stroke_width(6),
            ))?;
        }
        for d in &v.desks {
            let [a, b, c, e] = d.extent_m;
            root.draw(&Rectangle::new(
                [map(a, e), map(b, c)],
                WHITE.stroke_width(2),
            ))?;
        }
        for (_, c, o) in &v.luminaires {
            let [x0, y0, x1, y1] = px.luminaire_box(*c, *o);
            let (a, b) = ((x0 as i32, y0 as i32), (x1 as i32, y1 as i32));
            root.draw(&Rectangle::new([a, b], WHITE.filled()))?;
            root.draw(&Rectangle::new([a, b], BLACK.stroke_width(2)))?;
            root.draw(&PathElement::new(vec![a, b], BLACK.stroke_width(1)))?;
            root.draw(&PathElement::new(
                vec![(a.0, b.1), (b.0, a.1)],
                BLACK.stroke_width(1),
            ))?;
        }
        for (_, x, y) in &v.sensors {
            root.draw(&Cross::new(
                map(*x, *y),
                6,
                RGBColor(230, 30, 30).stroke_width(3),
            ))?;
        }
        labels.extend(plan_labels(v));
        if !v.subtitle.is_empty() {
            labels.push(Label::new(
                v.subtitle.clone(),
                (LEFT, f64::from(h) - 22.0),
                13.0,
            ));
        }
        let bx = (LEFT + (x1 - x0) * ppm + 40.0) as i32;
        super::draw_colour_bar(
            root,
            (bx, TOP as i32, 24, TOP as i32 + ph),
            scale_max,
            "lx",
            &viridis,
            labels,
        )?;
        Ok(())
    })
}

/// Draws the map of `simulate --map`: desks with their mean, the sensors.
pub fn draw(scene: &Scene, view: &TopView, opts: &MapOptions) -> Canvas {
    let (lo, hi) = scene.mesh.bounds_m();
    let desks = scene
        .desks
        .as_ref()
        .map(|d| {
            d.desks
                .iter()
                .map(|d| {
                    let mut label = vec![format!("desk {}", d.id)];
                    if let Some((_, m)) = view.desk_mean_lx.iter().find(|(id, _)| *id == d.id) {
                        label.push(format!("Ē {m:.0} lx"));
                    }
                    PlanDesk {
                        extent_m: [d.x_m[0], d.x_m[1], d.y_m[0], d.y_m[1]],
                        label,
                    }
                })
                .collect()
        })
        .unwrap_or_default();
    draw_plan(&PlanView {
        title: opts.title.clone(),
        subtitle:
            "illuminance on the upward-facing surfaces (floor, desk tops), lx; isolines white"
                .into(),
        bounds_m: [lo.x, hi.x, lo.y, hi.y],
        map: view.clone(),
        desks,
        sensors: scene
            .sensors
            .iter()
            .map(|s| (s.id, s.position_m.x, s.position_m.y))
            .collect(),
        luminaires: scene
            .luminaires
            .iter()
            .map(|l| (l.id, [l.position_m.x, l.position_m.y], l.opening_m))
            .collect(),
        values: Vec::new(),
        scale_max_lx: 0.0,
        pixels_per_m: opts.pixels_per_m,
        windows: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isolines_of_a_ramp_are_straight() {
        // lux = 100 x (x in cells): the 250 lx line is at x = 2.5 cells
        let (nx, ny) = (6, 4);
        let view = TopView {
            origin_m: [0.0, 0.0],
            cells: [nx, ny],
            cell_m: 1.0,
            lux: (0..nx * ny).map(|k| 100.0 * (k % nx) as f64).collect(),
            desk_mean_lx: Vec::new(),
            surface: Vec::new(),
        };
        let segs = view.isoline(250.0);
        assert_eq!(segs.len(), ny - 1);
        for s in segs {
            assert!((s[0].0 - 2.5).abs() < 1e-12 && (s[1].0 - 2.5).abs() < 1e-12);
        }
        assert!(view.isoline(1000.0).is_empty());
        assert_eq!(
            isoline_levels(0.0, 1400.0),
            vec![200.0, 400.0, 600.0, 800.0, 1000.0, 1200.0]
        );
    }
}
