//! "Model only what the scene requires", shown: where the adaptive subdivision puts its
//! patches (a picture coloured by patch size), how many per surface, and what a uniform mesh of
//! the same patch count gets wrong (`luxnode bench patches`).

use glam::DVec3;

use crate::engine::{Model, PatchSettings, Patches, patches};
use crate::render::{BLACK, Canvas, Colour, WHITE, text_width, viridis};
use crate::scene::Scene;

/// Patches per mesh group (label), in group order, with their area.
pub fn per_group(scene: &Scene, p: &Patches) -> Vec<(String, usize, f64)> {
    let mut out: Vec<(String, usize, f64)> = scene
        .mesh
        .groups
        .iter()
        .map(|g| (g.clone(), 0, 0.0))
        .collect();
    for i in 0..p.len() {
        if let Some(row) = out.get_mut(p.group[i] as usize) {
            row.1 += 1;
            row.2 += p.area_m2[i];
        }
    }
    out.retain(|r| r.1 > 0);
    out
}

/// Patches of a uniform subdivision (no refinement) with base size `size_m`.
pub fn uniform_count(scene: &Scene, size_m: f64) -> usize {
    let s = uniform(size_m);
    patches::subdivide(&scene.mesh, &s, &[], &mut |_| false).len()
}

/// Uniform patch settings of base size `size_m`.
pub fn uniform(size_m: f64) -> PatchSettings {
    PatchSettings {
        patch_size_m: size_m,
        detail_ratio: 0.0,
        min_patch_m: size_m.min(PatchSettings::default().min_patch_m),
        light_ratio: 0.0,
    }
}

/// The uniform patch size whose patch count is closest to `target` (bisection on the size;
/// counts are steps, so the match is the nearest step), and that count.
pub fn uniform_size_for(scene: &Scene, target: usize) -> (f64, usize) {
    let (mut lo, mut hi) = (0.02f64, 20.0f64);
    let mut best = (hi, uniform_count(scene, hi));
    for _ in 0..30 {
        let mid = (lo * hi).sqrt();
        let n = uniform_count(scene, mid);
        if n.abs_diff(target) < best.1.abs_diff(target) {
            best = (mid, n);
        }
        if n > target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi / lo < 1.0005 {
            break;
        }
    }
    best
}

/// Colour of a luminaire opening on the layout pictures.
const OPENING: Colour = [255, 196, 0];

fn longest_edge_m(t: &[DVec3; 3]) -> f64 {
    (0..3)
        .map(|k| (t[(k + 1) % 3] - t[k]).length())
        .fold(0.0, f64::max)
}

fn fill_triangle(c: &mut Canvas, p: [(f64, f64); 3], col: Colour) {
    let xs = p.map(|q| q.0);
    let ys = p.map(|q| q.1);
    let (x0, x1) = (
        xs.iter().cloned().fold(f64::INFINITY, f64::min),
        xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    );
    let (y0, y1) = (
        ys.iter().cloned().fold(f64::INFINITY, f64::min),
        ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    );
    let edge = |a: (f64, f64), b: (f64, f64), x: f64, y: f64| {
        (b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0)
    };
    let area = edge(p[0], p[1], p[2].0, p[2].1);
    if area.abs() < 1e-9 {
        return;
    }
    for y in (y0.floor() as i64)..=(y1.ceil() as i64) {
        for x in (x0.floor() as i64)..=(x1.ceil() as i64) {
            let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
            let w0 = edge(p[1], p[2], fx, fy) / area;
            let w1 = edge(p[2], p[0], fx, fy) / area;
            let w2 = edge(p[0], p[1], fx, fy) / area;
            if w0 >= -1e-9 && w1 >= -1e-9 && w2 >= -1e-9 {
                c.put(x, y, col);
            }
        }
    }
}

fn line(c: &mut Canvas, a: (f64, f64), b: (f64, f64), col: Colour) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as i64).max(1);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        c.put(
            (a.0 + t * (b.0 - a.0)).floor() as i64,
            (a.1 + t * (b.1 - a.1)).floor() as i64,
            col,
        );
    }
}

/// Colour of a patch edge length on the picture's log scale.
fn size_colour(edge_m: f64, range_m: (f64, f64)) -> Colour {
    let t = (edge_m / range_m.0).ln() / (range_m.1 / range_m.0).ln();
    viridis(t.clamp(0.0, 1.0))
}

/// The patch layout of a model: up-facing surfaces from above (floor, desk tops), down-facing
/// surfaces (ceiling) from above as through a glass roof, and the walls unfolded around the
/// room (south, east, north, west, as seen from inside), each patch coloured by its longest
/// edge on a log scale over `range_m`; sensors marked on the first panel.
pub fn layout_picture(scene: &Scene, model: &Model, title: &str, range_m: (f64, f64)) -> Canvas {
    let p = &model.patches;
    let (lo, hi) = scene.mesh.bounds_m();
    let (w, d, h) = (hi.x - lo.x, hi.y - lo.y, hi.z - lo.z);
    let ppm = (520.0 / w.max(d)).min(60.0);
    let pad = 30.0;
    let top = 60.0;
    let panel_w = w * ppm;
    let panel_h = d * ppm;
    let strip_w = 2.0 * (w + d) * ppm;
    let strip_h = h * ppm;
    let width = (pad * 3.0 + 2.0 * panel_w).max(pad * 2.0 + strip_w) + 150.0;
    let height = top + panel_h + 40.0 + strip_h + 70.0;
    let mut c = Canvas::new(width as u32, height as u32, WHITE);
    c.bold(title, pad as i64, 12, 20.0, BLACK);
    let edge_col: Colour = [60, 60, 60];
    let up_org = (pad, top);
    let down_org = (2.0 * pad + panel_w, top);
    let strip_org = (pad, top + panel_h + 40.0);
    let plan = |org: (f64, f64), v: DVec3| (org.0 + (v.x - lo.x) * ppm, org.1 + (hi.y - v.y) * ppm);
    // wall coordinate: distance along the unfolded perimeter and height
    let unfold = |n: DVec3, v: DVec3| -> (f64, f64) {
        let s = if n.y.abs() >= n.x.abs() {
            if n.y > 0.0 {
                v.x - lo.x // south wall, facing north
            } else {
                w + d + (hi.x - v.x) // north wall
            }
        } else if n.x < 0.0 {
            w + (v.y - lo.y) // east wall, facing west
        } else {
            2.0 * w + d + (hi.y - v.y) // west wall
        };
        (strip_org.0 + s * ppm, strip_org.1 + (hi.z - v.z) * ppm)
    };
    let dist_to_wall = |n: DVec3, v: DVec3| -> f64 {
        if n.y.abs() >= n.x.abs() {
            if n.y > 0.0 { v.y - lo.y } else { hi.y - v.y }
        } else if n.x < 0.0 {
            hi.x - v.x
        } else {
            v.x - lo.x
        }
    };
    let mut up: Vec<usize> = (0..p.len()).filter(|&i| p.normal[i].z > 0.7).collect();
    let mut down: Vec<usize> = (0..p.len()).filter(|&i| p.normal[i].z < -0.7).collect();
    let mut side: Vec<usize> = (0..p.len())
        .filter(|&i| p.normal[i].z.abs() <= 0.7)
        .collect();
    let z = |i: &usize| p.centroid_m(*i).z;
    up.sort_by(|a, b| z(a).total_cmp(&z(b)));
    // seen through the roof: the ceiling first, the luminaire openings on top of everything
    down.sort_by(|a, b| {
        let opening = |i: &usize| p.rho[*i] <= 0.0;
        opening(a).cmp(&opening(b)).then(z(a).total_cmp(&z(b)))
    });
    side.sort_by(|a, b| {
        let (da, db) = (
            dist_to_wall(p.normal[*a], p.centroid_m(*a)),
            dist_to_wall(p.normal[*b], p.centroid_m(*b)),
        );
        db.total_cmp(&da)
    });
    let draw = |c: &mut Canvas, ids: &[usize], map: &dyn Fn(usize, DVec3) -> (f64, f64)| {
        for &i in ids {
            let t = p.corners_m[i];
            let q = [map(i, t[0]), map(i, t[1]), map(i, t[2])];
            let col = if p.rho[i] <= 0.0 {
                OPENING
            } else {
                size_colour(longest_edge_m(&t), range_m)
            };
            fill_triangle(c, q, col);
            let e = if p.rho[i] <= 0.0 { BLACK } else { edge_col };
            for k in 0..3 {
                line(c, q[k], q[(k + 1) % 3], e);
            }
        }
    };
    draw(&mut c, &up, &|_, v| plan(up_org, v));
    draw(&mut c, &down, &|_, v| plan(down_org, v));
    draw(&mut c, &side, &|i, v| unfold(p.normal[i], v));
    c.text(
        "Up-facing surfaces, seen from above",
        up_org.0 as i64,
        (top - 20.0) as i64,
        14.0,
        BLACK,
    );
    c.text(
        "Ceiling and luminaire openings, seen from above through the roof",
        down_org.0 as i64,
        (top - 20.0) as i64,
        14.0,
        BLACK,
    );
    c.text(
        "Walls unfolded: south, east, north, west (seen from inside)",
        strip_org.0 as i64,
        (strip_org.1 - 20.0) as i64,
        14.0,
        BLACK,
    );
    for s in &scene.sensors {
        let (x, y) = plan(up_org, s.position_m);
        let (x, y) = (x as i64, y as i64);
        c.fill(x - 4, y - 1, 9, 3, WHITE);
        c.fill(x - 1, y - 4, 3, 9, WHITE);
        c.fill(x - 3, y, 7, 1, [214, 39, 40]);
        c.fill(x, y - 3, 1, 7, [214, 39, 40]);
    }
    let legend_y = (height - 26.0) as i64;
    c.text(
        &format!(
            "{} patches. Colour: longest patch edge (log scale). Red crosses: desk sensors.",
            p.len()
        ),
        pad as i64,
        legend_y,
        14.0,
        BLACK,
    );
    let lx = pad as i64
        + i64::from(text_width(
            "0000 patches. Colour: longest patch edge (log scale). Red crosses: desk sensors.",
            14.0,
        ))
        + 20;
    c.fill(lx, legend_y + 2, 18, 12, OPENING);
    c.frame(lx, legend_y + 2, 18, 12, 1, BLACK);
    c.text("luminaire openings (ρ = 0)", lx + 24, legend_y, 14.0, BLACK);
    // colour bar
    size_bar(&mut c, (width - 110.0) as i64, top as i64, range_m);
    c
}

/// The colour bar of patch sizes (`range_m`, log scale) with its top left at (`bx`, `by`).
fn size_bar(c: &mut Canvas, bx: i64, by: i64, range_m: (f64, f64)) {
    let bh = 200i64;
    for k in 0..bh {
        let t = 1.0 - k as f64 / (bh - 1) as f64;
        c.fill(bx, by + k, 20, 1, viridis(t));
    }
    c.frame(bx - 1, by - 1, 22, bh + 2, 1, BLACK);
    let mut v = range_m.0;
    while v <= range_m.1 * 1.0001 {
        let t = (v / range_m.0).ln() / (range_m.1 / range_m.0).ln();
        let py = by + ((1.0 - t) * (bh - 1) as f64) as i64;
        c.fill(bx + 20, py, 5, 1, BLACK);
        c.text(
            &format!("{} m", crate::render::plot::label(v)),
            bx + 28,
            py - 8,
            13.0,
            BLACK,
        );
        v *= 2.0;
    }
    let unit = "edge";
    c.text(
        unit,
        bx + 10 - i64::from(text_width(unit, 13.0)) / 2,
        by - 20,
        13.0,
        BLACK,
    );
}
