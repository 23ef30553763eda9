//! People of the simulated world made of boxes the simulated cameras render (issue 29's HIL day
//! of people): a person seated at a desk and a person standing. Their shapes are those of
//! docs/occupancy.md's person seen from above: shoulders as wide as a person, and a head about
//! 0.2 m across on top of them (a box as wide as the shoulders up to head height is not a
//! person's shape: its top is 0.5 m across, and the occupancy test's cap refuses it).
//!
//! | who | solids (x across the shoulders, y front to back, z up from the floor) |
//! |---|---|
//! | seated | seat 0.44 × 0.44 m at 0.45 m; torso 0.44 × 0.24 m from the seat to the shoulders at 1.05 m; head 0.18 × 0.20 m up to 1.30 m |
//! | standing | legs 0.34 × 0.22 m to 0.90 m; torso 0.46 × 0.26 m to 1.45 m; head 0.18 × 0.20 m up to 1.72 m |
//!
//! A seated person sits at the middle of the desk's long side that faces the camera (the side
//! nearer to the camera's plan position), the torso's centre 0.30 m out from the desk's edge.
//! Nobody is perfectly still: the head (and a standing person's upper body) sways in plan by
//! up to [`SWAY_M`] across and half that front to back, with a period of [`SWAY_PERIOD_S`],
//! phase by desk or place, so a person moves by a few centimetres between frames as a real one
//! does (what occupancy's motion over frames, `crate::occupancy::motion`, tells people by).

use glam::DVec3;

use super::camera::Occluder;
use crate::scene::Desk;

/// Sway of a head in plan, amplitude, m.
pub const SWAY_M: f64 = 0.04;
/// Sway period, s.
pub const SWAY_PERIOD_S: f64 = 7.0;
/// A seated person's head top above the floor, m.
pub const SEATED_HEAD_TOP_M: f64 = 1.30;
/// A standing person's head top above the floor, m.
pub const STANDING_HEAD_TOP_M: f64 = 1.72;
/// From a desk's edge to a seated torso's centre, m.
pub const SEAT_OUT_M: f64 = 0.30;
/// A person's reflectance (clothes, hair).
const RHO: f64 = 0.3;

/// A box centred at (x, y) in plan, `w` × `d` m, from `z0` to `z1` m.
fn block(x: f64, y: f64, w: f64, d: f64, z: [f64; 2]) -> Occluder {
    Occluder {
        lo_m: DVec3::new(x - w / 2.0, y - d / 2.0, z[0]),
        hi_m: DVec3::new(x + w / 2.0, y + d / 2.0, z[1]),
        rho: RHO,
    }
}

/// The sway in plan at `t_s` for a phase seed, m.
fn sway(t_s: f64, phase: f64) -> (f64, f64) {
    let a = std::f64::consts::TAU * t_s / SWAY_PERIOD_S + phase;
    (SWAY_M * a.sin(), 0.5 * SWAY_M * (1.3 * a).cos())
}

/// Where a person at `desk` sits (plan centre of the torso, m), the camera at `camera_xy`.
pub fn seat_of(desk: &Desk, camera_xy: [f64; 2]) -> [f64; 2] {
    let (cx, cy) = (
        0.5 * (desk.x_m[0] + desk.x_m[1]),
        0.5 * (desk.y_m[0] + desk.y_m[1]),
    );
    let long_along_x = desk.x_m[1] - desk.x_m[0] >= desk.y_m[1] - desk.y_m[0];
    if long_along_x {
        let (edge, out) = if camera_xy[1] >= cy {
            (desk.y_m[1], SEAT_OUT_M)
        } else {
            (desk.y_m[0], -SEAT_OUT_M)
        };
        [cx, edge + out]
    } else {
        let (edge, out) = if camera_xy[0] >= cx {
            (desk.x_m[1], SEAT_OUT_M)
        } else {
            (desk.x_m[0], -SEAT_OUT_M)
        };
        [edge + out, cy]
    }
}

/// A person seated at `desk` at time `t_s` (the camera at `camera_xy`).
pub fn seated(desk: &Desk, camera_xy: [f64; 2], t_s: f64) -> [Occluder; 3] {
    let [x, y] = seat_of(desk, camera_xy);
    let (dx, dy) = sway(t_s, f64::from(desk.id));
    [
        block(x, y, 0.44, 0.44, [0.0, 0.45]),
        block(x, y, 0.44, 0.24, [0.45, 1.05]),
        block(x + dx, y + dy, 0.18, 0.20, [1.05, SEATED_HEAD_TOP_M]),
    ]
}

/// A person standing at (x, y) at time `t_s`.
pub fn standing(x: f64, y: f64, t_s: f64) -> [Occluder; 3] {
    let (dx, dy) = sway(t_s, 10.0 * x + y);
    [
        block(x, y, 0.34, 0.22, [0.0, 0.90]),
        block(x + 0.4 * dx, y + 0.4 * dy, 0.46, 0.26, [0.90, 1.45]),
        block(x + dx, y + dy, 0.18, 0.20, [1.45, STANDING_HEAD_TOP_M]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desk() -> Desk {
        Desk {
            id: 1,
            group: "desk_1".into(),
            x_m: [1.0, 2.6],
            y_m: [1.2, 2.0],
            z_m: 0.75,
        }
    }

    #[test]
    fn a_seated_person_sits_on_the_camera_side_with_a_head_on_the_shoulders() {
        let near = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-12;
        assert!(near(seat_of(&desk(), [4.0, 3.0]), [1.8, 2.3]));
        assert!(near(seat_of(&desk(), [4.0, 0.5]), [1.8, 0.9]));
        let p = seated(&desk(), [4.0, 3.0], 0.0);
        let head = p[2];
        assert!((head.hi_m.z - 1.30).abs() < 1e-12);
        // the head 0.18 × 0.20 m, within the shoulders (0.44 × 0.24) wherever it sways
        for t in [0.0, 1.0, 2.5, 3.3, 6.9] {
            let h = seated(&desk(), [4.0, 3.0], t)[2];
            let torso = p[1];
            assert!((h.hi_m.x - h.lo_m.x - 0.18).abs() < 1e-12);
            assert!((h.hi_m.y - h.lo_m.y - 0.20).abs() < 1e-12);
            assert!(h.lo_m.x >= torso.lo_m.x && h.hi_m.x <= torso.hi_m.x, "{t}");
            assert!(h.lo_m.y >= torso.lo_m.y && h.hi_m.y <= torso.hi_m.y, "{t}");
        }
    }

    #[test]
    fn a_person_sways_by_centimetres_not_decimetres() {
        let a = standing(4.0, 2.9, 0.0)[2];
        let b = standing(4.0, 2.9, SWAY_PERIOD_S / 4.0)[2];
        let moved_m = (a.lo_m - b.lo_m).length();
        // at most the sway's extent: 2 × (4 cm, 2 cm)
        assert!(moved_m > 0.01 && moved_m <= 0.09, "{moved_m}");
        assert!((a.hi_m.z - STANDING_HEAD_TOP_M).abs() < 1e-12);
    }
}
