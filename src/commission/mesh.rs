//! The coarse mesh: planes become few large rectangles, the rest of the organised grid is
//! triangulated with cuts at depth discontinuities and Taubin-smoothed.
//!
//! A plane's nodes are projected onto it and rasterised into square cells
//! ([`MeshOptions::cell_m`]); one-cell holes (dropouts, removed flying pixels) are closed; the
//! occupied cells are covered greedily by rectangles no longer than the target patch size
//! ([`MeshOptions::patch_size_m`]), two triangles each. The floor plane, when the room is
//! closed, is rasterised over the whole room box: the cells nobody saw (under desks, outside
//! the view) become the inferred floor.

use glam::DVec3;

use super::grid::PointGrid;
use super::planes::Plane;

/// Mesh knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshOptions {
    /// Raster cell of a plane, m.
    pub cell_m: f64,
    /// Largest rectangle side (the target patch size), m.
    pub patch_size_m: f64,
    /// Grid neighbours further apart than this fraction of the depth are not joined.
    pub cut_rel: f64,
    /// Taubin smoothing passes (each a shrink and an inflate step).
    pub taubin_passes: usize,
    /// Wide-angle meshing (commissioning turns it on for a fisheye): grid nodes further apart
    /// than a cell cover half the way to their neighbours, and the floor is covered by
    /// rectangles up to the patch size over the whole room, each seen when most of it was.
    /// A wide lens sees far floor sparsely and through many desk shadows: without it the
    /// floor breaks into thousands of small rectangles and the image outgrows the flash.
    pub wide_angle: bool,
}

impl Default for MeshOptions {
    fn default() -> Self {
        Self {
            cell_m: 0.05,
            patch_size_m: 1.0,
            cut_rel: 0.05,
            taubin_passes: 5,
            wide_angle: false,
        }
    }
}

/// What a triangle models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// Detected plane k (seen).
    Plane(u32),
    /// Triangulated depth grid (seen, not planar).
    Surface,
    /// Floor nobody saw (closure; reflectance of the seen floor).
    FloorFill,
    /// Wall (closure; default reflectance).
    Wall,
    /// Ceiling (closure; default reflectance).
    Ceiling,
    /// A luminaire's opening (black).
    Opening(u32),
    /// A desk top nobody saw, at its height from desks.json or under a desk sensor (closure;
    /// the seen desk tops' reflectance).
    DeskFill,
    /// The hidden face of seen plane k, a thin object (a desk's underside, a monitor's back;
    /// closure; the reflectance of plane k's seen face).
    HiddenFace(u32),
    /// Glazing of the room plan's opening k (closure; [`GLAZING_RHO`] at night).
    Window(u32),
    /// A door, the room plan's opening k (closure; its reflectance, or the walls').
    Door(u32),
}

/// The diffuse reflectance that stands for a window's glazing when the sky is dark: two
/// uncoated panes reflect about 8 % at normal incidence (Fresnel, n = 1.52), as the benches'
/// scenes model it.
pub const GLAZING_RHO: f64 = 0.08;

impl Part {
    /// True for surfaces the camera saw.
    pub fn seen(self) -> bool {
        matches!(self, Part::Plane(_) | Part::Surface)
    }

    /// Group label.
    pub fn label(self) -> String {
        match self {
            Part::Plane(k) => format!("plane_{k}"),
            Part::Surface => "surface".into(),
            Part::FloorFill => "floor_inferred".into(),
            Part::Wall => "wall_inferred".into(),
            Part::Ceiling => "ceiling_inferred".into(),
            Part::Opening(id) => format!("luminaire_{id}"),
            Part::HiddenFace(k) => format!("plane_{k}_hidden_face"),
            Part::DeskFill => "desk_inferred".into(),
            Part::Window(k) => format!("window_{k}"),
            Part::Door(k) => format!("door_{k}"),
        }
    }
}

/// A triangle soup with a part per triangle.
#[derive(Debug, Clone, Default)]
pub struct RecoMesh {
    /// Vertices, m.
    pub positions_m: Vec<DVec3>,
    /// Triangles, counter-clockwise seen from the front.
    pub tris: Vec<[u32; 3]>,
    /// What each triangle models.
    pub part: Vec<Part>,
}

impl RecoMesh {
    /// Adds a quad (corners counter-clockwise seen from its front) as two triangles.
    pub fn push_quad(&mut self, c: [DVec3; 4], part: Part) {
        let b = self.positions_m.len() as u32;
        self.positions_m.extend(c);
        self.tris.push([b, b + 1, b + 2]);
        self.tris.push([b, b + 2, b + 3]);
        self.part.extend([part, part]);
    }

    /// Area of triangle t, m².
    pub fn area_m2(&self, t: usize) -> f64 {
        let [a, b, c] = self.tris[t].map(|i| self.positions_m[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Total area per class: (seen, inferred), m².
    pub fn areas_m2(&self) -> (f64, f64) {
        let mut seen = 0.0;
        let mut inferred = 0.0;
        for t in 0..self.tris.len() {
            if self.part[t].seen() {
                seen += self.area_m2(t);
            } else {
                inferred += self.area_m2(t);
            }
        }
        (seen, inferred)
    }
}

/// Covers the occupied cells of an `nx × ny` raster by rectangles `(x0, y0, w, h)` of at most
/// `max_cells` cells a side.
pub fn rect_cover(
    occ: &[bool],
    nx: usize,
    ny: usize,
    max_cells: usize,
) -> Vec<(usize, usize, usize, usize)> {
    let max_cells = max_cells.max(1);
    let mut used = vec![false; occ.len()];
    let free = |used: &[bool], x: usize, y: usize| occ[y * nx + x] && !used[y * nx + x];
    let mut out = Vec::new();
    for y in 0..ny {
        for x in 0..nx {
            if !free(&used, x, y) {
                continue;
            }
            let mut w = 1;
            while x + w < nx && w < max_cells && free(&used, x + w, y) {
                w += 1;
            }
            let mut h = 1;
            while y + h < ny && h < max_cells && (x..x + w).all(|xx| free(&used, xx, y + h)) {
                h += 1;
            }
            for yy in y..y + h {
                for xx in x..x + w {
                    used[yy * nx + xx] = true;
                }
            }
            out.push((x, y, w, h));
        }
    }
    out
}

/// An in-plane basis (e1, e2) with e1 × e2 = n: e1 along world x for a horizontal plane, else
/// horizontal.
pub fn plane_basis(n: DVec3) -> (DVec3, DVec3) {
    let e1 = if n.z.abs() > 0.7 {
        (DVec3::X - n * n.x).normalize()
    } else {
        DVec3::Z.cross(n).normalize()
    };
    (e1, n.cross(e1))
}

/// The farthest a grid node's footprint reaches around it on its plane, m (half the way to
/// its grid neighbours, a splat against holes in far, sparsely sampled surfaces).
pub const MAX_SPLAT_M: f64 = 0.15;

/// Another camera's point counts for a plane within this distance of it, m.
pub const ALSO_SEEN_DISTANCE_M: f64 = 0.05;

/// Meshes one plane. `extent`: rasterise over this world box (x0, y0, x1, y1) instead of the
/// nodes' bounds (horizontal planes only), filling unseen cells with `fill` (only those inside
/// `outline`, the room plan's floor polygon, when given). `also_seen_m`:
/// points on the plane that other cameras saw (another node's view of the floor); each marks
/// its cell (the closing below fills one-cell gaps between them).
#[allow(clippy::too_many_arguments)]
pub fn mesh_plane(
    out: &mut RecoMesh,
    grid: &PointGrid,
    plane: &Plane,
    k: u32,
    o: &MeshOptions,
    extent: Option<[f64; 4]>,
    fill: Option<Part>,
    also_seen_m: &[DVec3],
    outline: Option<&[glam::DVec2]>,
) {
    let c = o.cell_m.max(1e-3);
    let room = extent.filter(|_| plane.is_horizontal());
    let Some(r) = Raster::of(grid, plane, c, room) else {
        return;
    };
    let mut occ = r.splat_nodes(grid, plane, o.wide_angle, c);
    for p in also_seen_m {
        if plane.distance_m(*p).abs() > ALSO_SEEN_DISTANCE_M {
            continue;
        }
        if let Some(i) = r.cell_of(*p) {
            occ[i] = true;
        }
    }
    let closed = close_cells(&occ, r.nx, r.ny);
    let occ: Vec<bool> = occ.iter().zip(&closed).map(|(a, b)| *a || *b).collect();
    let max_cells = (o.patch_size_m / c).floor().max(1.0) as usize;
    let (nx, ny) = (r.nx, r.ny);
    // the cells of the room's floor: all, or those inside the plan's outline
    let in_room: Vec<bool> = (0..nx * ny)
        .map(|i| {
            outline.is_none_or(|poly| {
                let p = r.corner(i % nx, i / nx) + (r.e1 * r.ca + r.e2 * r.cb) * 0.5;
                crate::scene::plan::polygon_contains(poly, p.truncate())
            })
        })
        .collect();
    match (room, fill) {
        (Some(_), Some(fill)) if o.wide_angle => {
            // the floor over the whole room: rectangles up to the patch size regardless of what
            // was seen (the unseen floor takes the seen floor's reflectance anyway), each seen
            // when most of its cells were
            for (x, y, w, h) in rect_cover(&in_room, nx, ny, max_cells) {
                let seen = (y..y + h)
                    .flat_map(|yy| (x..x + w).map(move |xx| yy * nx + xx))
                    .filter(|&i| occ[i])
                    .count();
                let part = if 2 * seen >= w * h {
                    Part::Plane(k)
                } else {
                    fill
                };
                out.push_quad(r.quad(x, y, w, h), part);
            }
        }
        _ => {
            r.quads(out, &occ, max_cells, Part::Plane(k));
            if let (Some(_), Some(fill)) = (room, fill) {
                let unseen: Vec<bool> = occ.iter().zip(&in_room).map(|(o, i)| !o && *i).collect();
                r.quads(out, &unseen, max_cells, fill);
            }
        }
    }
}

/// A plane's raster: `nx` × `ny` cells of `ca` × `cb` m from (`a0`, `b0`) in the plane's
/// basis (`e1`, `e2`) at `org`.
struct Raster {
    org: DVec3,
    e1: DVec3,
    e2: DVec3,
    a0: f64,
    b0: f64,
    ca: f64,
    cb: f64,
    nx: usize,
    ny: usize,
}

impl Raster {
    /// Over the plane's nodes (grown half a cell of `c` m), or over the world box `room`
    /// (x0, y0, x1, y1) stretched to fit it exactly; `None` without a node.
    fn of(grid: &PointGrid, plane: &Plane, c: f64, room: Option<[f64; 4]>) -> Option<Raster> {
        let (e1, e2) = plane_basis(plane.normal);
        let org = plane.origin_m;
        let uv: Vec<(f64, f64)> = plane
            .nodes
            .iter()
            .filter_map(|&i| grid.points_m[i])
            .map(|p| ((p - org).dot(e1), (p - org).dot(e2)))
            .collect();
        if uv.is_empty() {
            return None;
        }
        let (mut a0, mut b0, mut a1, mut b1) = uv.iter().fold(
            (
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ),
            |(a0, b0, a1, b1), &(a, b)| (a0.min(a), b0.min(b), a1.max(a), b1.max(b)),
        );
        if let Some([x0, y0, x1, y1]) = room {
            // world box corners into plane coordinates (e1 ≈ x, e2 ≈ y for a horizontal plane)
            let corners = [DVec3::new(x0, y0, org.z), DVec3::new(x1, y1, org.z)];
            let ab: Vec<(f64, f64)> = corners
                .iter()
                .map(|p| ((*p - org).dot(e1), (*p - org).dot(e2)))
                .collect();
            a0 = ab[0].0.min(ab[1].0);
            a1 = ab[0].0.max(ab[1].0);
            b0 = ab[0].1.min(ab[1].1);
            b1 = ab[0].1.max(ab[1].1);
        } else {
            a0 -= 0.5 * c;
            b0 -= 0.5 * c;
            a1 += 0.5 * c;
            b1 += 0.5 * c;
        }
        let nx = (((a1 - a0) / c).ceil() as usize).clamp(1, 4000);
        let ny = (((b1 - b0) / c).ceil() as usize).clamp(1, 4000);
        // with a room extent the raster is stretched to fit it exactly
        let (ca, cb) = ((a1 - a0) / nx as f64, (b1 - b0) / ny as f64);
        Some(Raster {
            org,
            e1,
            e2,
            a0,
            b0,
            ca,
            cb,
            nx,
            ny,
        })
    }

    /// The cell a point on the plane falls in, if inside.
    fn cell_of(&self, p: DVec3) -> Option<usize> {
        let (a, b) = ((p - self.org).dot(self.e1), (p - self.org).dot(self.e2));
        let (x, y) = (
            ((a - self.a0) / self.ca).floor(),
            ((b - self.b0) / self.cb).floor(),
        );
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.nx && (y as usize) < self.ny)
            .then(|| y as usize * self.nx + x as usize)
    }

    /// The cells the plane's nodes cover: each node its cell, and where its grid neighbours on
    /// the plane are more than a cell of `c` m apart (a wide-angle lens spreads the nodes of a
    /// far floor out) half the way to them, at most [`MAX_SPLAT_M`] around it.
    fn splat_nodes(&self, grid: &PointGrid, plane: &Plane, wide_angle: bool, c: f64) -> Vec<bool> {
        let (org, e1, e2) = (self.org, self.e1, self.e2);
        let (nx, ny) = (self.nx, self.ny);
        let on_plane: std::collections::HashSet<usize> = plane.nodes.iter().copied().collect();
        let mut occ = vec![false; nx * ny];
        for &i in &plane.nodes {
            let Some(p) = grid.points_m[i] else { continue };
            let (a, b) = ((p - org).dot(e1), (p - org).dot(e2));
            let (col, row) = (i % grid.cols.max(1), i / grid.cols.max(1));
            let mut half = 0.0_f64;
            for (dc, dr) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                let (cc, rr) = (col as i64 + dc, row as i64 + dr);
                if cc < 0 || rr < 0 || cc >= grid.cols as i64 || rr >= grid.rows as i64 {
                    continue;
                }
                let j = grid.index(cc as usize, rr as usize);
                if let (true, Some(q)) = (on_plane.contains(&j), grid.points_m[j]) {
                    let d = q - p;
                    half = half.max(0.5 * d.dot(e1).abs()).max(0.5 * d.dot(e2).abs());
                }
            }
            // nodes closer than a cell apart leave no holes (the closing handles the rest)
            let half = if !wide_angle || 2.0 * half <= c {
                0.0
            } else {
                (half - 0.5 * c).min(MAX_SPLAT_M)
            };
            let x0 = ((a - half - self.a0) / self.ca).floor().max(0.0);
            let x1 = ((a + half - self.a0) / self.ca).floor();
            let y0 = ((b - half - self.b0) / self.cb).floor().max(0.0);
            let y1 = ((b + half - self.b0) / self.cb).floor();
            if x1 < 0.0 || y1 < 0.0 {
                continue;
            }
            let (x0, y0) = (x0 as usize, y0 as usize);
            let (x1, y1) = ((x1 as usize).min(nx - 1), (y1 as usize).min(ny - 1));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    occ[y * nx + x] = true;
                }
            }
        }
        occ
    }

    /// The world point at cell corner (x, y).
    fn corner(&self, x: usize, y: usize) -> DVec3 {
        self.org
            + self.e1 * (self.a0 + x as f64 * self.ca)
            + self.e2 * (self.b0 + y as f64 * self.cb)
    }

    /// The quad of `w` × `h` cells from cell (x, y).
    fn quad(&self, x: usize, y: usize, w: usize, h: usize) -> [DVec3; 4] {
        [
            self.corner(x, y),
            self.corner(x + w, y),
            self.corner(x + w, y + h),
            self.corner(x, y + h),
        ]
    }

    /// The set cells of `occ` as rectangles of at most `max_cells` a side, as `part`.
    fn quads(&self, out: &mut RecoMesh, occ: &[bool], max_cells: usize, part: Part) {
        for (x, y, w, h) in rect_cover(occ, self.nx, self.ny, max_cells) {
            out.push_quad(self.quad(x, y, w, h), part);
        }
    }
}

/// Closing of an `nx` × `ny` occupancy: dilate then erode (one cell); fills one-cell holes and
/// cracks.
fn close_cells(occ: &[bool], nx: usize, ny: usize) -> Vec<bool> {
    let dil: Vec<bool> = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0
                        && yy >= 0
                        && xx < nx as i64
                        && yy < ny as i64
                        && occ[(yy as usize) * nx + xx as usize]
                })
            })
        })
        .collect();
    (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    // outside the raster counts as set, so borders do not erode away
                    xx < 0
                        || yy < 0
                        || xx >= nx as i64
                        || yy >= ny as i64
                        || dil[(yy as usize) * nx + xx as usize]
                })
            })
        })
        .collect()
}

/// Triangulates the grid nodes not on a plane, cutting at depth discontinuities, smooths
/// them (Taubin λ|μ) and orients them toward the camera.
pub fn mesh_rest(
    out: &mut RecoMesh,
    grid: &PointGrid,
    on_plane: &[bool],
    camera_m: DVec3,
    o: &MeshOptions,
) {
    let usable = |i: usize| !on_plane[i] && grid.points_m[i].is_some();
    let mut vid = vec![u32::MAX; grid.points_m.len()];
    let mut local: Vec<DVec3> = Vec::new();
    let mut tris: Vec<[usize; 3]> = Vec::new();
    let joined = |a: usize, b: usize| {
        let (za, zb) = (grid.z_m[a], grid.z_m[b]);
        (za - zb).abs() <= o.cut_rel * za.min(zb)
    };
    for r in 0..grid.rows.saturating_sub(1) {
        for c in 0..grid.cols.saturating_sub(1) {
            let i00 = grid.index(c, r);
            let i10 = grid.index(c + 1, r);
            let i01 = grid.index(c, r + 1);
            let i11 = grid.index(c + 1, r + 1);
            for t in [[i00, i10, i11], [i00, i11, i01]] {
                if t.iter().all(|&i| usable(i))
                    && joined(t[0], t[1])
                    && joined(t[1], t[2])
                    && joined(t[0], t[2])
                {
                    tris.push(t);
                }
            }
        }
    }
    for t in &tris {
        for &i in t {
            if vid[i] == u32::MAX {
                vid[i] = local.len() as u32;
                local.push(grid.points_m[i].unwrap_or_default());
            }
        }
    }
    // Taubin smoothing over the triangle adjacency
    let mut nbr: Vec<Vec<u32>> = vec![Vec::new(); local.len()];
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (vid[t[k]], vid[t[(k + 1) % 3]]);
            if !nbr[a as usize].contains(&b) {
                nbr[a as usize].push(b);
                nbr[b as usize].push(a);
            }
        }
    }
    let step = |p: &mut Vec<DVec3>, f: f64| {
        let q: Vec<DVec3> = (0..p.len())
            .map(|i| {
                if nbr[i].is_empty() {
                    return p[i];
                }
                let m = nbr[i].iter().map(|&j| p[j as usize]).sum::<DVec3>() / nbr[i].len() as f64;
                p[i] + (m - p[i]) * f
            })
            .collect();
        *p = q;
    };
    for _ in 0..o.taubin_passes {
        step(&mut local, 0.5);
        step(&mut local, -0.53);
    }
    let base = out.positions_m.len() as u32;
    out.positions_m.extend(&local);
    for t in &tris {
        let mut v = t.map(|i| base + vid[i]);
        let [a, b, c] = v.map(|i| out.positions_m[i as usize]);
        let n = (b - a).cross(c - a);
        if n.length_squared() < 1e-16 {
            continue;
        }
        if n.dot(camera_m - (a + b + c) / 3.0) < 0.0 {
            v.swap(1, 2);
        }
        out.tris.push(v);
        out.part.push(Part::Surface);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangles_cover_exactly_the_occupied_cells() {
        let (nx, ny) = (9, 7);
        let occ: Vec<bool> = (0..nx * ny).map(|i| (i % nx) < 6 || (i / nx) > 4).collect();
        let rects = rect_cover(&occ, nx, ny, 4);
        let mut cov = vec![0; nx * ny];
        for (x, y, w, h) in &rects {
            assert!(*w <= 4 && *h <= 4);
            for yy in *y..y + h {
                for xx in *x..x + w {
                    cov[yy * nx + xx] += 1;
                }
            }
        }
        for i in 0..nx * ny {
            assert_eq!(cov[i], usize::from(occ[i]), "cell {i}");
        }
        assert!(rects.len() <= 8, "{} rectangles", rects.len());
    }
}
