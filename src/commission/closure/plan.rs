//! The room from its plan: walls along the outline with the plan's windows and doors cut out,
//! the ceiling over the outline, and the plan reconciled with what the cameras saw (issue 28).
//!
//! What was seen wins: where the cameras see the room reach beyond a plan's wall (floor or
//! wall points past it by more than the depth noise explains), the wall moves out to them and
//! the engineer is told which wall and by how much; a seen floor at another height than the
//! plan's is the floor.

use glam::{DVec2, DVec3};

use super::RoomBox;
use crate::commission::mesh::{Part, RecoMesh, rect_cover};
use crate::scene::RoomPlan;
use crate::scene::plan::OpeningKind;

/// Seen points this far beyond a plan's wall disagree with it, m: three standard deviations
/// of a ToF camera's range noise (1 % of depth) at 5 m.
pub const PLAN_WALL_TOLERANCE_M: f64 = 0.15;
/// A wall disagrees when at least this many seen points lie beyond it (single flying pixels
/// and reflections do not move a wall).
pub const PLAN_DISAGREE_MIN_POINTS: usize = 30;
/// The seen floor disagrees with the plan's floor beyond this height, m.
pub const PLAN_FLOOR_TOLERANCE_M: f64 = 0.05;
/// Raster cell of the plan's walls and ceiling, m (windows and doors snap to it).
pub const PLAN_CELL_M: f64 = 0.05;

/// The room of a plan, reconciled with the seen points (world, m) and the seen floor's height:
/// the room and what disagreed, one warning per wall.
pub fn room_from_plan(
    plan: &RoomPlan,
    seen_m: &[DVec3],
    seen_floor_z_m: Option<f64>,
) -> (RoomBox, Vec<String>) {
    let mut warnings = Vec::new();
    let floor_z_m = match seen_floor_z_m {
        Some(z) if (z - plan.floor_z_m).abs() > PLAN_FLOOR_TOLERANCE_M => {
            warnings.push(format!(
                "room plan: the cameras see the floor at z {z:.3} m, the plan says {:.3} m \
                 ({:+.0} mm): the plan or the camera pose is wrong; the seen floor is used",
                plan.floor_z_m,
                (z - plan.floor_z_m) * 1e3
            ));
            z
        }
        _ => plan.floor_z_m,
    };
    let mut outline = plan.outline_m.clone();
    for (wall, shift_m, count) in walls_seen_beyond(plan, seen_m, floor_z_m) {
        let (a, b) = plan.wall(wall);
        if shift_m > PLAN_WALL_TOLERANCE_M {
            warnings.push(format!(
                "room plan: the cameras see {count} points up to {shift_m:.2} m beyond wall \
                 {wall} (from ({:.2}, {:.2}) to ({:.2}, {:.2}) m): the plan or the camera pose \
                 is wrong; the wall is moved out {shift_m:.2} m to what was seen",
                a.x, a.y, b.x, b.y
            ));
        }
        let out = -plan.wall_inward(wall) * shift_m;
        let n = outline.len();
        outline[wall] += out;
        outline[(wall + 1) % n] += out;
    }
    let lo = outline.iter().fold(DVec2::INFINITY, |a, b| a.min(*b));
    let hi = outline.iter().fold(DVec2::NEG_INFINITY, |a, b| a.max(*b));
    let room = RoomBox {
        xy_m: [lo.x, lo.y, hi.x, hi.y],
        floor_z_m,
        ceiling_z_m: plan.ceiling_z_m,
        outline_m: Some(outline),
        openings: plan.openings.clone(),
    };
    (room, warnings)
}

/// The walls the seen points reach beyond: (wall, how far it moves out, how many points). A
/// wall moves out to the [`SEEN_WALL_QUANTILE`] of the seen points beyond it plus
/// [`SEEN_WALL_MARGIN_M`], so that a wall the cameras see (at the plan's position within the
/// depth noise) stays in front of the closure's wall and keeps its measured reflectance.
fn walls_seen_beyond(
    plan: &RoomPlan,
    seen_m: &[DVec3],
    floor_z_m: f64,
) -> Vec<(usize, f64, usize)> {
    let mut beyond: Vec<Vec<f64>> = vec![Vec::new(); plan.walls()];
    for p in seen_m {
        if p.z < floor_z_m - PLAN_WALL_TOLERANCE_M || p.z > plan.ceiling_z_m {
            continue;
        }
        let (d, wall) = plan.signed_distance_m(p.truncate());
        if d > 0.0 {
            beyond[wall].push(d);
        }
    }
    beyond
        .into_iter()
        .enumerate()
        .filter(|(_, d)| d.len() >= PLAN_DISAGREE_MIN_POINTS)
        .map(|(wall, mut d)| {
            d.sort_by(f64::total_cmp);
            let k = ((d.len() as f64 * SEEN_WALL_QUANTILE) as usize).min(d.len() - 1);
            (wall, d[k] + SEEN_WALL_MARGIN_M, d.len())
        })
        .collect()
}

/// The quantile of the seen points beyond a wall that it moves out to (the rest: flying pixels).
pub const SEEN_WALL_QUANTILE: f64 = 0.98;
/// How far behind the seen points beyond it a wall moves, m.
pub const SEEN_WALL_MARGIN_M: f64 = 0.005;

/// Cells along a length: a whole number of tiles of at most `patch_size_m`, each of
/// `patch_size_m / PLAN_CELL_M` cells (equal tiles where nothing is cut out). Returns (cells,
/// cell size, cells per tile).
fn cells(len_m: f64, patch_size_m: f64) -> (usize, f64, usize) {
    let per_tile = ((patch_size_m / PLAN_CELL_M).round() as usize).max(1);
    let tiles = ((len_m / patch_size_m.max(PLAN_CELL_M)).ceil() as usize).max(1);
    let n = (tiles * per_tile).min(100_000);
    (n, len_m / n as f64, per_tile)
}

/// Adds the plan's walls (with its windows and doors) and its ceiling.
pub fn close(out: &mut RecoMesh, room: &RoomBox, outline: &[DVec2], patch_size_m: f64) {
    let n = outline.len();
    for wall in 0..n {
        close_wall(
            out,
            room,
            outline[wall],
            outline[(wall + 1) % n],
            wall,
            patch_size_m,
        );
    }
    close_ceiling(out, room, outline, patch_size_m);
}

/// One wall from a to b (the room on its left), floor to ceiling, its openings as their parts.
fn close_wall(out: &mut RecoMesh, room: &RoomBox, a: DVec2, b: DVec2, wall: usize, s: f64) {
    let (z0, z1) = (room.floor_z_m, room.ceiling_z_m);
    let len = (b - a).length();
    if len <= 0.0 || z1 <= z0 {
        return;
    }
    let dir = (b - a) / len;
    let (nu, cu, per_tile) = cells(len, s);
    let (nv, cv, _) = cells(z1 - z0, s);
    // class of each cell: 0 the wall, k + 1 opening k
    let class: Vec<usize> = (0..nu * nv)
        .map(|i| {
            let (u, z) = ((i % nu) as f64 + 0.5, (i / nu) as f64 + 0.5);
            let (u, z) = (u * cu, z0 + z * cv);
            room.openings
                .iter()
                .position(|o| {
                    o.wall == wall
                        && (o.along_m[0]..o.along_m[1]).contains(&u)
                        && (o.z_m[0]..o.z_m[1]).contains(&z)
                })
                .map_or(0, |k| k + 1)
        })
        .collect();
    let at = |x: usize, y: usize| {
        let p = a + dir * (x as f64 * cu);
        DVec3::new(p.x, p.y, z0 + y as f64 * cv)
    };
    for c in 0..=room.openings.len() {
        let occ: Vec<bool> = class.iter().map(|&k| k == c).collect();
        if !occ.iter().any(|&o| o) {
            continue;
        }
        let part = match c.checked_sub(1).map(|k| (k, room.openings[k].kind)) {
            None => Part::Wall,
            Some((k, OpeningKind::Window { .. })) => Part::Window(k as u32),
            Some((k, OpeningKind::Door { .. })) => Part::Door(k as u32),
        };
        for (x, y, w, h) in rect_cover(&occ, nu, nv, per_tile) {
            // up, then along: the front faces into the room
            out.push_quad(
                [at(x, y), at(x, y + h), at(x + w, y + h), at(x + w, y)],
                part,
            );
        }
    }
}

/// The ceiling over the outline, facing down.
fn close_ceiling(out: &mut RecoMesh, room: &RoomBox, outline: &[DVec2], s: f64) {
    let [x0, y0, x1, y1] = room.xy_m;
    let (nx, cx, per_tile) = cells(x1 - x0, s);
    let (ny, cy, _) = cells(y1 - y0, s);
    let occ: Vec<bool> = (0..nx * ny)
        .map(|i| {
            let p = DVec2::new(
                x0 + ((i % nx) as f64 + 0.5) * cx,
                y0 + ((i / nx) as f64 + 0.5) * cy,
            );
            crate::scene::plan::polygon_contains(outline, p)
        })
        .collect();
    let z = room.ceiling_z_m;
    let at = |x: usize, y: usize| DVec3::new(x0 + x as f64 * cx, y0 + y as f64 * cy, z);
    for (x, y, w, h) in rect_cover(&occ, nx, ny, per_tile) {
        out.push_quad(
            [at(x, y), at(x, y + h), at(x + w, y + h), at(x + w, y)],
            Part::Ceiling,
        );
    }
}

#[cfg(test)]
mod tests;
