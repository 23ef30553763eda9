//! The point values of a desk's EN 12464-1 task grid, as a design tool prints them: every grid
//! point with its illuminance (new installation, every luminaire on), the points under an object
//! standing on the desk (a monitor's foot, a box) marked covered and left out of Ēm, Emin, Emax
//! and U0. `results.json` carries them as `desks[].task.points`; the report prints a table per
//! task area.

use std::fmt::Write as _;

use glam::DVec3;
use serde::Serialize;

use crate::en12464::Statistics;
use crate::engine::dense::DenseField;
use crate::engine::raycast::Hit;

/// An object whose underside is this close above a surface point covers it, m: a monitor's foot
/// on pads, a box, a keyboard. A screen or a shelf higher up shades the point but light still
/// arrives there from the side.
pub const COVER_CLEARANCE_M: f64 = 0.05;

/// True when a point on an upward-facing surface (a desk top, the floor) is covered: looking
/// straight up from 1 mm above it, it sees the inside of a solid (a closed box, or a foot whose
/// mesh has no bottom face) or any surface within [`COVER_CLEARANCE_M`].
pub fn covered(field: &DenseField<'_>, p_m: DVec3) -> bool {
    let c = field.caster();
    let from = c.offset(p_m + DVec3::Z * 0.001, DVec3::Z);
    match c.closest(from, DVec3::Z) {
        Hit::Back { .. } => true,
        Hit::Front { t_m, .. } => t_m + 0.001 < COVER_CLEARANCE_M,
        Hit::Miss => false,
    }
}

/// One point of a task grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TaskPoint {
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// Height of the calculation plane (the desk top), m.
    pub z_m: f64,
    /// Horizontal illuminance, new installation, every luminaire on, lx; `None` (JSON `null`)
    /// where the point is covered: no light arrives there and no luxmeter goes there.
    pub e_lx: Option<f64>,
    /// Under an object standing on the desk: left out of the statistics.
    pub covered: bool,
}

/// The grid's points from its positions, their covered flags and the values of the free points
/// (in the order of the free positions). `None` when the free values do not match the free
/// points in number.
pub fn task_points(
    positions_m: &[DVec3],
    covered: &[bool],
    free_lx: &[f64],
) -> Option<Vec<TaskPoint>> {
    let free = covered.iter().filter(|c| !**c).count();
    if positions_m.len() != covered.len() || free != free_lx.len() {
        return None;
    }
    let mut values = free_lx.iter();
    Some(
        positions_m
            .iter()
            .zip(covered)
            .map(|(p, &c)| TaskPoint {
                x_m: p.x,
                y_m: p.y,
                z_m: p.z,
                e_lx: if c { None } else { values.next().copied() },
                covered: c,
            })
            .collect(),
    )
}

/// Ē, Emin, Emax, U0 of the free points (`None` when every point is covered).
pub fn free_statistics(points: &[TaskPoint]) -> Option<Statistics> {
    let v: Vec<f64> = points.iter().filter_map(|p| p.e_lx).collect();
    Statistics::of(&v)
}

/// One desk's point table: the grid's statistics (new, all on, free points) beside the points'
/// x, y and E, covered points greyed and marked.
pub fn html_table(h: &mut String, desk_id: u32, points: &[TaskPoint]) {
    let covered = points.iter().filter(|p| p.covered).count();
    let _ = writeln!(
        h,
        "<div class=\"ptdesk\"><h3>Desk {desk_id} task area ({} points, z {:.2} m)</h3>",
        points.len(),
        points.first().map_or(0.0, |p| p.z_m)
    );
    match free_statistics(points) {
        Some(s) => {
            let _ = writeln!(
                h,
                "<table class=\"ptstats\"><tr><th>Ēm</th><td>{:.0} lx</td></tr><tr><th>Emin</th><td>{:.0} lx</td></tr>\
<tr><th>Emax</th><td>{:.0} lx</td></tr><tr><th>U0</th><td>{:.2}</td></tr>\
<tr><th>covered</th><td>{covered}</td></tr></table>",
                s.e_mean_lx, s.e_min_lx, s.e_max_lx, s.u0
            );
        }
        None => h.push_str("<p>Every point is covered.</p>\n"),
    }
    h.push_str("<table class=\"pts\"><tr><th>x (m)</th><th>y (m)</th><th>E (lx)</th></tr>\n");
    for p in points {
        match p.e_lx {
            Some(e) if !p.covered => {
                let _ = writeln!(
                    h,
                    "<tr><td>{:.3}</td><td>{:.3}</td><td>{e:.0}</td></tr>",
                    p.x_m, p.y_m
                );
            }
            _ => {
                let _ = writeln!(
                    h,
                    "<tr class=\"covered\"><td>{:.3}</td><td>{:.3}</td><td>covered</td></tr>",
                    p.x_m, p.y_m
                );
            }
        }
    }
    h.push_str("</table></div>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64) -> DVec3 {
        DVec3::new(x, 0.5, 0.75)
    }

    #[test]
    fn covered_points_get_no_value_and_stay_out_of_the_statistics() {
        let pos = [at(0.1), at(0.3), at(0.5)];
        let pts = task_points(&pos, &[false, true, false], &[400.0, 600.0]).unwrap();
        assert_eq!(pts[0].e_lx, Some(400.0));
        assert_eq!(pts[1].e_lx, None);
        assert!(pts[1].covered);
        assert_eq!(pts[2].e_lx, Some(600.0));
        // by hand: Ē = (400 + 600) / 2 = 500, U0 = 400 / 500
        let s = free_statistics(&pts).unwrap();
        assert_eq!(s.points, 2);
        assert!((s.e_mean_lx - 500.0).abs() < 1e-12);
        assert!((s.u0 - 0.8).abs() < 1e-12);
        assert!(task_points(&pos, &[false, true, false], &[400.0]).is_none());
        assert!(task_points(&pos, &[false, false], &[1.0, 2.0]).is_none());
        let all = task_points(&pos, &[true; 3], &[]).unwrap();
        assert!(free_statistics(&all).is_none());
        let mut h = String::new();
        html_table(&mut h, 7, &pts);
        assert_eq!(h.matches("class=\"covered\"").count(), 1);
        assert!(h.contains("<td>0.100</td><td>0.500</td><td>400</td>"));
        assert!(h.contains("<th>Ēm</th><td>500 lx</td>"));
    }
}
