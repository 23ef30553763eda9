//! Closing the room: the camera sees the floor, desk tops and little else; walls and ceiling
//! reflect a large part of the light that reaches a desk. The room box is inferred:
//!
//! * floor: the lowest large horizontal plane;
//! * ceiling: the highest luminaire opening plus [`ClosureOptions::ceiling_above_openings_m`]
//!   (recessed luminaires), unless a ceiling height is given;
//! * walls: the union of what was seen, the sensors (installed inside the room) and the
//!   luminaire layout extended by half its spacing on each side (luminaires in a regular grid
//!   stand half a spacing from the walls), unless a room box is given.
//!
//! Walls and ceiling get default reflectances (knobs); the luminaire openings are black quads
//! just below the ceiling.
//!
//! A seen plane inside the room (a desk top, a monitor, a partition) is a thin object: the
//! camera sees one face, and the other one (the desk's underside, the monitor's back) gets a
//! hidden face [`HIDDEN_FACE_DEPTH_M`] behind it, facing the other way, with the seen face's
//! reflectance ([`hidden_faces`]). Without it a sensor on the floor sees black desk
//! undersides: office_a's floor sensor 7 lost 12 % of its gather rays to them, and every
//! desk's interreflected light read low, as light that reaches a hidden face was absorbed.

use glam::{DVec2, DVec3};

use super::mesh::{MeshOptions, Part, RecoMesh, rect_cover};
use crate::scene::plan::{WallOpening, polygon_contains, segment_distance};
use crate::scene::{Luminaire, Sensor};

pub mod plan;

/// Closure knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosureOptions {
    /// Close the room at all.
    pub enabled: bool,
    /// Reflectance given to the walls.
    pub wall_rho: f64,
    /// The walls nobody saw take the seen walls' reflectance instead of `wall_rho` when the
    /// camera saw enough wall (`reflectance::MIN_SEEN_WALL_PIXELS`).
    pub wall_rho_from_seen: bool,
    /// Reflectance given to the ceiling.
    pub ceiling_rho: f64,
    /// Room box in the world (x0, y0, x1, y1), m; None: inferred.
    pub room_xy_m: Option<[f64; 4]>,
    /// Ceiling height, m; None: from the luminaires.
    pub ceiling_z_m: Option<f64>,
    /// Ceiling above the highest opening, m.
    pub ceiling_above_openings_m: f64,
}

impl Default for ClosureOptions {
    fn default() -> Self {
        Self {
            enabled: true,
            wall_rho: 0.5,
            wall_rho_from_seen: true,
            ceiling_rho: 0.7,
            room_xy_m: None,
            ceiling_z_m: None,
            ceiling_above_openings_m: 0.01,
        }
    }
}

/// The room: inferred as a box, or from the room plan (then its outline and openings).
#[derive(Debug, Clone, PartialEq)]
pub struct RoomBox {
    /// x0, y0, x1, y1, m (the outline's bounds, with a plan).
    pub xy_m: [f64; 4],
    /// Floor height, m.
    pub floor_z_m: f64,
    /// Ceiling height, m.
    pub ceiling_z_m: f64,
    /// The floor outline from the room plan (counter-clockwise, m); `None`: the box.
    pub outline_m: Option<Vec<DVec2>>,
    /// The plan's windows and doors on the outline's walls.
    pub openings: Vec<WallOpening>,
}

/// Half the smallest spacing of distinct coordinates (None with fewer than two).
fn half_spacing(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() < 0.05);
    v.windows(2)
        .map(|w| w[1] - w[0])
        .min_by(f64::total_cmp)
        .map(|s| 0.5 * s)
}

/// The largest room the node models: 200 m a side, 50 m floor to ceiling.
pub const MAX_ROOM_SIDE_M: f64 = 200.0;
/// The largest ceiling height above the floor, m.
pub const MAX_ROOM_HEIGHT_M: f64 = 50.0;
/// The most quads the closure may add (walls, ceiling): bounds the work of a huge box.
pub const MAX_CLOSURE_QUADS: usize = 200_000;

impl RoomBox {
    /// Checks the box before any work is spent on it: finite, at most [`MAX_ROOM_SIDE_M`] a
    /// side and [`MAX_ROOM_HEIGHT_M`] high, and the camera inside it (a camera outside the room,
    /// or depth that puts the room kilometres away, is a configuration error, not a room).
    pub fn check(&self, camera_m: DVec3) -> Result<(), String> {
        let [x0, y0, x1, y1] = self.xy_m;
        let (z0, z1) = (self.floor_z_m, self.ceiling_z_m);
        if ![x0, y0, x1, y1, z0, z1].iter().all(|v| v.is_finite()) {
            return Err("the room box is not finite".into());
        }
        let (dx, dy, dz) = (x1 - x0, y1 - y0, z1 - z0);
        if dx > MAX_ROOM_SIDE_M || dy > MAX_ROOM_SIDE_M || dz > MAX_ROOM_HEIGHT_M {
            return Err(format!(
                "the inferred room is {dx:.0} x {dy:.0} x {dz:.0} m, more than {MAX_ROOM_SIDE_M} \
                 m a side or {MAX_ROOM_HEIGHT_M} m high: check the camera calibration (focal \
                 length, principal point, pose) and the luminaire positions"
            ));
        }
        let margin = 1.0;
        let inside = camera_m.x >= x0 - margin
            && camera_m.x <= x1 + margin
            && camera_m.y >= y0 - margin
            && camera_m.y <= y1 + margin
            && camera_m.z >= z0 - margin
            && camera_m.z <= z1 + margin;
        if !inside {
            return Err(format!(
                "the camera at ({:.2}, {:.2}, {:.2}) m is outside the room ({x0:.2}..{x1:.2}, \
                 {y0:.2}..{y1:.2}, {z0:.2}..{z1:.2} m): check its pose in camera.json",
                camera_m.x, camera_m.y, camera_m.z
            ));
        }
        Ok(())
    }

    /// A box room (no plan).
    pub fn boxed(xy_m: [f64; 4], floor_z_m: f64, ceiling_z_m: f64) -> RoomBox {
        RoomBox {
            xy_m,
            floor_z_m,
            ceiling_z_m,
            outline_m: None,
            openings: Vec::new(),
        }
    }

    /// Whether (x, y) is inside the room's outline (its box without a plan).
    pub fn contains_xy(&self, p: DVec2) -> bool {
        match &self.outline_m {
            Some(o) => polygon_contains(o, p),
            None => {
                let [x0, y0, x1, y1] = self.xy_m;
                (x0..=x1).contains(&p.x) && (y0..=y1).contains(&p.y)
            }
        }
    }

    /// The vertical boundary faces: (unit normal into the room, a point on it, the segment's
    /// ends in x-y).
    fn walls(&self) -> Vec<(DVec2, DVec2, DVec2)> {
        let [x0, y0, x1, y1] = self.xy_m;
        let corners = match &self.outline_m {
            Some(o) => o.clone(),
            None => vec![
                DVec2::new(x0, y0),
                DVec2::new(x1, y0),
                DVec2::new(x1, y1),
                DVec2::new(x0, y1),
            ],
        };
        let n = corners.len();
        (0..n)
            .map(|i| {
                let (a, b) = (corners[i], corners[(i + 1) % n]);
                ((b - a).perp().normalize_or_zero(), a, b)
            })
            .collect()
    }

    /// Quads the closure of this box adds with tiles of at most `patch_size_m`.
    pub fn closure_quads(&self, patch_size_m: f64) -> f64 {
        let [x0, y0, x1, y1] = self.xy_m;
        let s = patch_size_m.max(0.05);
        let n = |len: f64| (len / s).ceil().max(1.0);
        let (nx, ny, nz) = (n(x1 - x0), n(y1 - y0), n(self.ceiling_z_m - self.floor_z_m));
        2.0 * nx * nz + 2.0 * ny * nz + nx * ny
    }
}

/// Without a plan, an unseen wall stands at least this far behind a declared sensor or
/// luminaire, m.
pub const WALL_CLEARANCE_M: f64 = 0.3;

/// The extent the luminaire grid gives a room, `[x0, y0, x1, y1]`: half the grid's spacing
/// beyond its outer rows (at least [`WALL_CLEARANCE_M`]); `None` without luminaires.
pub fn grid_extent_m(luminaires: &[Luminaire]) -> Option<[f64; 4]> {
    if luminaires.is_empty() {
        return None;
    }
    let c = WALL_CLEARANCE_M;
    let xs: Vec<f64> = luminaires.iter().map(|l| l.position_m.x).collect();
    let ys: Vec<f64> = luminaires.iter().map(|l| l.position_m.y).collect();
    let (hx, hy) = (half_spacing(xs.clone()), half_spacing(ys.clone()));
    let dx = hx.or(hy).unwrap_or(0.0).max(c);
    let dy = hy.or(hx).unwrap_or(0.0).max(c);
    let lo = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some([lo(&xs) - dx, lo(&ys) - dy, hi(&xs) + dx, hi(&ys) + dy])
}

/// Infers the room box.
pub fn room_box(
    seen_m: &[DVec3],
    floor_z_m: f64,
    luminaires: &[Luminaire],
    sensors: &[Sensor],
    o: &ClosureOptions,
) -> RoomBox {
    let ceiling_z_m = o.ceiling_z_m.unwrap_or_else(|| {
        luminaires
            .iter()
            .map(|l| l.position_m.z)
            .fold(f64::NEG_INFINITY, f64::max)
            + o.ceiling_above_openings_m
    });
    let ceiling_z_m = if ceiling_z_m.is_finite() && ceiling_z_m > floor_z_m + 0.5 {
        ceiling_z_m
    } else {
        floor_z_m + 2.8
    };
    let xy_m = o.room_xy_m.unwrap_or_else(|| {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut add = |x: f64, y: f64| {
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        };
        for p in seen_m {
            add(p.x, p.y);
        }
        // an unseen wall stands at least WALL_CLEARANCE_M behind a declared sensor or
        // luminaire (issue 28: a wall through a sensor at the room's edge made it 0 lx)
        let c = WALL_CLEARANCE_M;
        for s in sensors {
            add(s.position_m.x - c, s.position_m.y - c);
            add(s.position_m.x + c, s.position_m.y + c);
        }
        if let Some([x0, y0, x1, y1]) = grid_extent_m(luminaires) {
            add(x0, y0);
            add(x1, y1);
        }
        b
    });
    RoomBox::boxed(xy_m, floor_z_m, ceiling_z_m)
}

/// Depth of a thin object's hidden face behind its seen face, m (a desk top's thickness).
pub const HIDDEN_FACE_DEPTH_M: f64 = 0.02;

/// A seen plane within this distance of a room-box face of its orientation is that face (a
/// wall or the floor), not a thin object, m.
pub const BOUNDARY_TOLERANCE_M: f64 = 0.15;

/// Whether a seen plane (unit normal facing the camera, a point on it) is a thin object inside
/// the room rather than part of the room's boundary (floor, a wall, the ceiling).
pub fn is_thin_object(room: &RoomBox, normal: DVec3, origin_m: DVec3) -> bool {
    let tol = BOUNDARY_TOLERANCE_M;
    let horizontal = [room.floor_z_m, room.ceiling_z_m]
        .iter()
        .any(|&z| normal.z.abs() > 0.9 && (origin_m.z - z).abs() < tol);
    let on_a_wall = room.walls().iter().any(|&(inward, a, b)| {
        let n = normal.truncate();
        n.dot(inward).abs() > 0.9 && segment_distance(a, b, origin_m.truncate()) < tol
    });
    !(horizontal || on_a_wall)
}

/// Adds the hidden face of each thin seen plane: its triangles of [`Part::Plane`] `k` for
/// every k in `thin`, [`HIDDEN_FACE_DEPTH_M`] behind along `-normal`, wound the other way
/// ([`Part::HiddenFace`] `k`).
pub fn hidden_faces(out: &mut RecoMesh, thin: &[(u32, DVec3)]) {
    for &(k, normal) in thin {
        let tris: Vec<usize> = (0..out.tris.len())
            .filter(|&t| out.part[t] == Part::Plane(k))
            .collect();
        let shift = -normal * HIDDEN_FACE_DEPTH_M;
        for t in tris {
            let [a, b, c] = out.tris[t].map(|i| out.positions_m[i as usize] + shift);
            let base = out.positions_m.len() as u32;
            out.positions_m.extend([a, c, b]);
            out.tris.push([base, base + 1, base + 2]);
            out.part.push(Part::HiddenFace(k));
        }
    }
}

/// Whether a point lies on one of these desk tops (within its outline, within
/// [`DESK_HEIGHT_TOLERANCE_M`] of its height).
pub fn on_a_desk(desks: &[crate::scene::Desk], p: DVec3) -> bool {
    desks.iter().any(|d| {
        (d.x_m[0]..=d.x_m[1]).contains(&p.x)
            && (d.y_m[0]..=d.y_m[1]).contains(&p.y)
            && (p.z - d.z_m).abs() < DESK_HEIGHT_TOLERANCE_M
    })
}

/// A desk sensor this far above the floor or more stands on furniture, m.
pub const DESK_SENSOR_MIN_HEIGHT_M: f64 = 0.3;

/// Side of the desk top inferred under a desk sensor that is on no desk of desks.json, m.
pub const DEFAULT_DESK_SIDE_M: f64 = 0.6;

/// Raster cell for finding the unseen part of a desk top, m.
const DESK_CELL_M: f64 = 0.05;

/// A seen surface within this height of a desk top is that desk top, m.
const DESK_HEIGHT_TOLERANCE_M: f64 = 0.05;

/// The desk tops to model, x0, x1, y0, y1 and height, m: every desk of desks.json, and a
/// [`DEFAULT_DESK_SIDE_M`] square under each desk sensor that stands on none of them (on
/// furniture: at least [`DESK_SENSOR_MIN_HEIGHT_M`] above the floor), inside the room box.
pub fn desk_tops(
    room: &RoomBox,
    desks: &[crate::scene::Desk],
    sensors: &[Sensor],
) -> Vec<([f64; 2], [f64; 2], f64)> {
    let [x0, y0, x1, y1] = room.xy_m;
    let mut out: Vec<([f64; 2], [f64; 2], f64)> =
        desks.iter().map(|d| (d.x_m, d.y_m, d.z_m)).collect();
    for s in sensors {
        let p = s.position_m;
        let on_a_desk = out.iter().any(|(x, y, z)| {
            (x[0]..=x[1]).contains(&p.x)
                && (y[0]..=y[1]).contains(&p.y)
                && (p.z - z).abs() < DESK_HEIGHT_TOLERANCE_M
        });
        if on_a_desk || p.z - room.floor_z_m < DESK_SENSOR_MIN_HEIGHT_M || s.normal.z < 0.9 {
            continue;
        }
        let h = 0.5 * DEFAULT_DESK_SIDE_M;
        let x = [(p.x - h).max(x0), (p.x + h).min(x1)];
        let y = [(p.y - h).max(y0), (p.y + h).min(y1)];
        if x[1] > x[0] && y[1] > y[0] {
            out.push((x, y, p.z - 0.001));
        }
    }
    out
}

/// Adds the parts of these desk tops that no seen surface covers ([`Part::DeskFill`], with a
/// hidden face [`HIDDEN_FACE_DEPTH_M`] below): a desk the camera does not see still shades the
/// floor and reflects light. A raster cell of a top is seen when a seen, upward-facing triangle
/// within 5 cm of its height covers the cell's centre. Returns the area added, m².
pub fn inferred_desk_tops(
    out: &mut RecoMesh,
    tops: &[([f64; 2], [f64; 2], f64)],
    patch_size_m: f64,
) -> f64 {
    let seen: Vec<[DVec3; 3]> = (0..out.tris.len())
        .filter(|&t| out.part[t].seen())
        .map(|t| out.tris[t].map(|i| out.positions_m[i as usize]))
        .filter(|[a, b, c]| (*b - *a).cross(*c - *a).normalize_or_zero().z > 0.9)
        .collect();
    let inside = |p: DVec3, [a, b, c]: &[DVec3; 3]| {
        let s = |u: DVec3, v: DVec3| (v.x - u.x) * (p.y - u.y) - (v.y - u.y) * (p.x - u.x);
        let (d1, d2, d3) = (s(*a, *b), s(*b, *c), s(*c, *a));
        (d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0) || (d1 <= 0.0 && d2 <= 0.0 && d3 <= 0.0)
    };
    let max_cells = (patch_size_m / DESK_CELL_M).floor().max(1.0) as usize;
    let mut area = 0.0;
    for &([x0, x1], [y0, y1], z) in tops {
        if !(x1 > x0 && y1 > y0) {
            continue;
        }
        let nx = (((x1 - x0) / DESK_CELL_M).ceil() as usize).clamp(1, 400);
        let ny = (((y1 - y0) / DESK_CELL_M).ceil() as usize).clamp(1, 400);
        let (cx, cy) = ((x1 - x0) / nx as f64, (y1 - y0) / ny as f64);
        let near: Vec<&[DVec3; 3]> = seen
            .iter()
            .filter(|t| {
                t.iter().all(|p| (p.z - z).abs() < DESK_HEIGHT_TOLERANCE_M)
                    && t.iter().any(|p| p.x >= x0 - 1.0 && p.x <= x1 + 1.0)
            })
            .collect();
        let unseen: Vec<bool> = (0..nx * ny)
            .map(|i| {
                let p = DVec3::new(
                    x0 + ((i % nx) as f64 + 0.5) * cx,
                    y0 + ((i / nx) as f64 + 0.5) * cy,
                    z,
                );
                !near.iter().any(|t| inside(p, t))
            })
            .collect();
        for (x, y, w, h) in rect_cover(&unseen, nx, ny, max_cells) {
            let c = |i: usize, j: usize, zz: f64| {
                DVec3::new(x0 + i as f64 * cx, y0 + j as f64 * cy, zz)
            };
            let (zt, zb) = (z, z - HIDDEN_FACE_DEPTH_M);
            out.push_quad(
                [
                    c(x, y, zt),
                    c(x + w, y, zt),
                    c(x + w, y + h, zt),
                    c(x, y + h, zt),
                ],
                Part::DeskFill,
            );
            out.push_quad(
                [
                    c(x, y, zb),
                    c(x, y + h, zb),
                    c(x + w, y + h, zb),
                    c(x + w, y, zb),
                ],
                Part::DeskFill,
            );
            area += (w as f64 * cx) * (h as f64 * cy);
        }
    }
    area
}

/// Adds walls, ceiling and black luminaire openings: the plan's (walls along its outline with
/// its windows and doors, the ceiling over its outline) or the box's.
pub fn close(out: &mut RecoMesh, room: &RoomBox, luminaires: &[Luminaire], o: &MeshOptions) {
    match &room.outline_m {
        Some(outline) => plan::close(out, room, outline, o.patch_size_m),
        None => close_box(out, room, o.patch_size_m),
    }
    luminaire_openings(out, room, luminaires);
}

/// The box's four walls and ceiling in equal tiles of at most `patch_size_m`.
fn close_box(out: &mut RecoMesh, room: &RoomBox, patch_size_m: f64) {
    let [x0, y0, x1, y1] = room.xy_m;
    let (z0, z1) = (room.floor_z_m, room.ceiling_z_m);
    let s = patch_size_m.max(0.05);
    // a rectangle (origin, edge a, edge b) in tiles of at most s, front = a × b
    let mut tile = |org: DVec3, a: DVec3, b: DVec3, part: Part| {
        let (na, nb) = (
            ((a.length() / s).ceil() as usize).max(1),
            ((b.length() / s).ceil() as usize).max(1),
        );
        let occ = vec![true; na * nb];
        let (da, db) = (a / na as f64, b / nb as f64);
        for (x, y, w, h) in rect_cover(&occ, na, nb, 1) {
            let c = |i: usize, j: usize| org + da * i as f64 + db * j as f64;
            out.push_quad([c(x, y), c(x + w, y), c(x + w, y + h), c(x, y + h)], part);
        }
    };
    let (dx, dy, dz) = (
        DVec3::X * (x1 - x0),
        DVec3::Y * (y1 - y0),
        DVec3::Z * (z1 - z0),
    );
    // fronts face into the room
    tile(DVec3::new(x0, y0, z0), dy, dz, Part::Wall); // x = x0, normal +x
    tile(DVec3::new(x1, y0, z0), dz, dy, Part::Wall); // x = x1, normal -x
    tile(DVec3::new(x0, y0, z0), dz, dx, Part::Wall); // y = y0, normal +y
    tile(DVec3::new(x0, y1, z0), dx, dz, Part::Wall); // y = y1, normal -y
    tile(DVec3::new(x0, y0, z1), dy, dx, Part::Ceiling); // normal -z
}

/// Each luminaire's opening: a black quad just below the ceiling, facing along its aim.
fn luminaire_openings(out: &mut RecoMesh, room: &RoomBox, luminaires: &[Luminaire]) {
    let z1 = room.ceiling_z_m;
    for l in luminaires {
        let [w, len] = l.opening_m;
        if w <= 0.0 || len <= 0.0 {
            continue;
        }
        let c = l
            .position_m
            .min(DVec3::new(f64::INFINITY, f64::INFINITY, z1 - 1e-3));
        let (a, b) = (l.c0 * (0.5 * w), l.c90 * (0.5 * len));
        let mut q = [c - a - b, c + a - b, c + a + b, c - a + b];
        // face along the aim (down)
        let n = (q[1] - q[0]).cross(q[2] - q[0]);
        if n.dot(l.aim) < 0.0 {
            q.reverse();
        }
        out.push_quad(q, Part::Opening(l.id));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room() -> RoomBox {
        RoomBox::boxed([0.0, 0.0, 6.0, 4.0], 0.0, 2.8)
    }

    #[test]
    fn thin_objects_are_the_planes_inside_the_room() {
        let r = room();
        // a desk top, a monitor facing -x, a partition facing +y
        assert!(is_thin_object(&r, DVec3::Z, DVec3::new(2.0, 2.0, 0.75)));
        assert!(is_thin_object(&r, -DVec3::X, DVec3::new(3.0, 2.0, 1.0)));
        assert!(is_thin_object(&r, DVec3::Y, DVec3::new(3.0, 1.0, 1.0)));
        // the floor, a wall seen at each side (within the tolerance), the ceiling
        assert!(!is_thin_object(&r, DVec3::Z, DVec3::new(2.0, 2.0, 0.03)));
        assert!(!is_thin_object(&r, DVec3::X, DVec3::new(0.1, 2.0, 1.0)));
        assert!(!is_thin_object(&r, -DVec3::X, DVec3::new(5.9, 2.0, 1.0)));
        assert!(!is_thin_object(&r, DVec3::Y, DVec3::new(3.0, -0.05, 1.0)));
        assert!(!is_thin_object(&r, -DVec3::Y, DVec3::new(3.0, 3.88, 1.0)));
        assert!(!is_thin_object(&r, -DVec3::Z, DVec3::new(3.0, 2.0, 2.75)));
        // a vertical plane near the floor's height is not the floor
        assert!(is_thin_object(&r, DVec3::X, DVec3::new(3.0, 2.0, 0.05)));
    }

    #[test]
    fn a_hidden_face_lies_behind_its_seen_face_and_faces_the_other_way() {
        let mut m = RecoMesh::default();
        let z = 0.75;
        m.push_quad(
            [
                DVec3::new(1.0, 1.0, z),
                DVec3::new(2.0, 1.0, z),
                DVec3::new(2.0, 1.5, z),
                DVec3::new(1.0, 1.5, z),
            ],
            Part::Plane(3),
        );
        m.push_quad(
            [
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
            ],
            Part::Plane(0),
        );
        hidden_faces(&mut m, &[(3, DVec3::Z)]);
        assert_eq!(m.tris.len(), 6);
        let hidden: Vec<usize> = (0..6)
            .filter(|&t| m.part[t] == Part::HiddenFace(3))
            .collect();
        assert_eq!(hidden, vec![4, 5]);
        let seen_area: f64 = (0..2).map(|t| m.area_m2(t)).sum();
        let hidden_area: f64 = hidden.iter().map(|&t| m.area_m2(t)).sum();
        assert!((seen_area - 0.5).abs() < 1e-12 && (hidden_area - seen_area).abs() < 1e-12);
        for t in hidden {
            let [a, b, c] = m.tris[t].map(|i| m.positions_m[i as usize]);
            let n = (b - a).cross(c - a).normalize();
            assert!((n - (-DVec3::Z)).length() < 1e-12, "{n}");
            for p in [a, b, c] {
                assert!((p.z - (z - HIDDEN_FACE_DEPTH_M)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_desk_top_is_inferred_where_nobody_saw_it() {
        let r = room();
        let desk = crate::scene::Desk {
            id: 1,
            group: "desk_1".into(),
            x_m: [1.0, 2.6],
            y_m: [1.0, 1.8],
            z_m: 0.75,
        };
        // a sensor on a sideboard against the wall (on no desk), one on the floor, one on the desk
        let sensor = |x: f64, y: f64, z: f64| Sensor {
            id: 0,
            position_m: DVec3::new(x, y, z),
            normal: DVec3::Z,
            note: String::new(),
            response: Default::default(),
        };
        let sensors = [
            sensor(0.1, 3.0, 0.801),
            sensor(3.0, 3.0, 0.001),
            sensor(1.5, 1.4, 0.751),
        ];
        let tops = desk_tops(&r, std::slice::from_ref(&desk), &sensors);
        assert_eq!(tops.len(), 2, "{tops:?}");
        // the sideboard's square is clipped by the wall at x = 0
        let (x, y, z) = tops[1];
        assert!(
            (x[0] - 0.0).abs() < 1e-12 && (x[1] - 0.4).abs() < 1e-12,
            "{x:?}"
        );
        assert!((y[1] - y[0] - DEFAULT_DESK_SIDE_M).abs() < 1e-12 && (z - 0.8).abs() < 1e-9);
        // the camera saw the desk's left half: only the right half is inferred, top and
        // underside
        let mut m = RecoMesh::default();
        let z = 0.75;
        m.push_quad(
            [
                DVec3::new(1.0, 1.0, z),
                DVec3::new(1.8, 1.0, z),
                DVec3::new(1.8, 1.8, z),
                DVec3::new(1.0, 1.8, z),
            ],
            Part::Plane(2),
        );
        let area = inferred_desk_tops(&mut m, &tops[..1], 1.0);
        assert!((area - 0.64).abs() < 0.02, "{area}");
        let (mut up, mut down) = (0.0, 0.0);
        for t in 0..m.tris.len() {
            if m.part[t] != Part::DeskFill {
                continue;
            }
            let [a, b, c] = m.tris[t].map(|i| m.positions_m[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(a.x >= 1.75 && b.x >= 1.75 && c.x >= 1.75, "{a} {b} {c}");
            if n.z > 0.0 {
                up += m.area_m2(t);
            } else {
                down += m.area_m2(t);
            }
        }
        assert!(
            (up - area).abs() < 1e-9 && (down - area).abs() < 1e-9,
            "{up} {down}"
        );
        // a desk fully seen adds nothing
        let mut seen = m.clone();
        seen.push_quad(
            [
                DVec3::new(1.8, 1.0, z),
                DVec3::new(2.6, 1.0, z),
                DVec3::new(2.6, 1.8, z),
                DVec3::new(1.8, 1.8, z),
            ],
            Part::Plane(2),
        );
        let n = seen.tris.len();
        assert_eq!(inferred_desk_tops(&mut seen, &tops[..1], 1.0), 0.0);
        assert_eq!(seen.tris.len(), n);
    }
}
