//! The top-view map: false-colour illuminance on every upward-facing surface (floor, desk tops,
//! cabinet tops) for one dimming state, a colour bar in lux, desk outlines with each desk's mean
//! illuminance written on it, and the sensors marked.
//!
//! Each map cell is a virtual sensor on the surface seen from above (exact direct light plus a
//! gather over the patch exitances), so the picture is as accurate as a sensor reading, not a
//! picture of the patches.

use glam::DVec3;

use super::{BLACK, Canvas, WHITE, nice_ceiling, text_width, viridis};
use crate::engine::Model;
use crate::engine::points::{self, surface_below};
use crate::engine::raycast::RayCaster;
use crate::scene::Scene;

/// What to draw.
#[derive(Debug, Clone)]
pub struct MapOptions {
    /// Map cell size, m.
    pub cell_m: f64,
    /// Pixels per metre.
    pub pixels_per_m: f64,
    /// Gather rays per cell.
    pub rays: usize,
    /// Title line.
    pub title: String,
}

impl Default for MapOptions {
    fn default() -> Self {
        Self {
            cell_m: 0.1,
            pixels_per_m: 100.0,
            rays: 300,
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
    /// Illuminance per cell (row-major, y outer), lx; NaN where nothing faces up.
    pub lux: Vec<f64>,
    /// Each desk's mean illuminance over its grid points: (desk id, lx).
    pub desk_mean_lx: Vec<(u32, f64)>,
}

/// Computes the map values for a dimming state.
pub fn compute(scene: &Scene, model: &Model, levels: &[f64], opts: &MapOptions) -> TopView {
    let (lo, hi) = scene.mesh.bounds_m();
    let cell = opts.cell_m.max(1e-3);
    let nx = (((hi.x - lo.x) / cell).ceil() as usize).clamp(1, 4000);
    let ny = (((hi.y - lo.y) / cell).ceil() as usize).clamp(1, 4000);
    let caster = RayCaster::new(&model.patches);
    let top = hi.z + 1.0;
    let mut where_: Vec<Option<(DVec3, DVec3)>> = Vec::with_capacity(nx * ny);
    for iy in 0..ny {
        for ix in 0..nx {
            let x = lo.x + (ix as f64 + 0.5) * cell;
            let y = lo.y + (iy as f64 + 0.5) * cell;
            where_.push(
                surface_below(&caster, x, y, top)
                    .map(|(p, patch)| (p, model.patches.normal[patch as usize])),
            );
        }
    }
    let found: Vec<(DVec3, DVec3)> = where_.iter().flatten().copied().collect();
    let readings = points::evaluate(scene, model, &found, opts.rays);
    let values = readings.lux(levels);
    let mut k = 0;
    let lux = where_
        .iter()
        .map(|w| match w {
            Some(_) => {
                k += 1;
                values[k - 1]
            }
            None => f64::NAN,
        })
        .collect();
    let mut desk_mean_lx = Vec::new();
    if let Some(desks) = &scene.desks {
        let pts: Vec<(DVec3, DVec3)> = desks
            .grid_points
            .iter()
            .map(|(_, p)| (*p, DVec3::Z))
            .collect();
        let r = points::evaluate(scene, model, &pts, model.settings.sensor_rays);
        let v = r.lux(levels);
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
    TopView {
        origin_m: [lo.x + 0.5 * cell, lo.y + 0.5 * cell],
        cells: [nx, ny],
        lux,
        desk_mean_lx,
    }
}

impl TopView {
    /// Bilinear value at a world point (NaN cells ignored); NaN where no cell has a value.
    fn sample(&self, x: f64, y: f64, cell: f64) -> f64 {
        let [nx, ny] = self.cells;
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

    /// The largest value, lx.
    pub fn max_lx(&self) -> f64 {
        self.lux
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    }
}

/// Draws the map.
pub fn draw(scene: &Scene, view: &TopView, opts: &MapOptions) -> Canvas {
    let (lo, hi) = scene.mesh.bounds_m();
    let ppm = opts.pixels_per_m;
    let map_w = ((hi.x - lo.x) * ppm).ceil() as i64;
    let map_h = ((hi.y - lo.y) * ppm).ceil() as i64;
    let (left, top, right, bottom) = (30i64, 50i64, 140i64, 40i64);
    let mut c = Canvas::new(
        (left + map_w + right) as u32,
        (top + map_h + bottom) as u32,
        WHITE,
    );
    let scale_max = nice_ceiling(view.max_lx());
    let to_px = |x: f64, y: f64| -> (i64, i64) {
        (
            left + ((x - lo.x) * ppm) as i64,
            top + ((hi.y - y) * ppm) as i64,
        )
    };
    for py in 0..map_h {
        for px in 0..map_w {
            let x = lo.x + (px as f64 + 0.5) / ppm;
            let y = hi.y - (py as f64 + 0.5) / ppm;
            let v = view.sample(x, y, opts.cell_m);
            let col = if v.is_finite() {
                viridis(v / scale_max)
            } else {
                [200, 200, 200]
            };
            c.put(left + px, top + py, col);
        }
    }
    c.frame(left - 1, top - 1, map_w + 2, map_h + 2, 1, BLACK);
    c.text(&opts.title, left, 14, 2, BLACK);
    c.text("NORTH UP, 1 M GRID TICKS", left, top + map_h + 14, 1, BLACK);
    let mut x = lo.x.ceil();
    while x <= hi.x {
        let (px, py) = to_px(x, lo.y);
        c.fill(px, py, 1, 6, BLACK);
        x += 1.0;
    }
    let mut y = lo.y.ceil();
    while y <= hi.y {
        let (px, py) = to_px(lo.x, y);
        c.fill(px - 6, py, 6, 1, BLACK);
        y += 1.0;
    }
    if let Some(desks) = &scene.desks {
        for d in &desks.desks {
            let (x0, y0) = to_px(d.x_m[0], d.y_m[1]);
            let (x1, y1) = to_px(d.x_m[1], d.y_m[0]);
            c.frame(x0, y0, x1 - x0, y1 - y0, 2, WHITE);
            if let Some((_, m)) = view.desk_mean_lx.iter().find(|(id, _)| *id == d.id) {
                let (cx, cy) = to_px(0.5 * (d.x_m[0] + d.x_m[1]), 0.5 * (d.y_m[0] + d.y_m[1]));
                let (name, value) = (format!("DESK {}", d.id), format!("{m:.0} LX"));
                let room = x1 - x0 - 8;
                let scale = if i64::from(text_width(&name, 2).max(text_width(&value, 2))) <= room {
                    2
                } else {
                    1
                };
                let line = 9 * i64::from(scale);
                c.label(&name, cx, cy - line / 2 - 1, scale, WHITE, BLACK);
                c.label(&value, cx, cy + line / 2 + 1, scale, WHITE, BLACK);
            }
        }
    }
    for s in &scene.sensors {
        let (px, py) = to_px(s.position_m.x, s.position_m.y);
        c.fill(px - 4, py - 1, 9, 3, WHITE);
        c.fill(px - 1, py - 4, 3, 9, WHITE);
        c.fill(px - 3, py, 7, 1, BLACK);
        c.fill(px, py - 3, 1, 7, BLACK);
        c.text(&format!("S{}", s.id), px + 6, py - 3, 1, BLACK);
    }
    // colour bar
    let bx = left + map_w + 30;
    let bh = map_h.max(100);
    for k in 0..bh {
        let t = 1.0 - k as f64 / (bh - 1).max(1) as f64;
        c.fill(bx, top + k, 24, 1, viridis(t));
    }
    c.frame(bx - 1, top - 1, 26, bh + 2, 1, BLACK);
    for k in 0..=4 {
        let v = scale_max * f64::from(k) / 4.0;
        let py = top + ((1.0 - f64::from(k) / 4.0) * (bh - 1) as f64) as i64;
        c.fill(bx + 24, py, 5, 1, BLACK);
        c.text(&format!("{v:.0}"), bx + 32, py - 3, 1, BLACK);
    }
    let unit = "LX";
    c.text(
        unit,
        bx + 12 - i64::from(text_width(unit, 1)) / 2,
        top - 14,
        1,
        BLACK,
    );
    c
}
