use super::*;
use crate::scene::plan::{OpeningKind, WallOpening};

/// An L-shaped room: 6 × 4 m with the corner x > 4, y > 2 cut, 2.8 m high, a window on the
/// south wall (wall 0) 1..3 m along it, 1..2 m high.
fn plan() -> RoomPlan {
    let outline = [
        (0.0, 0.0),
        (6.0, 0.0),
        (6.0, 2.0),
        (4.0, 2.0),
        (4.0, 4.0),
        (0.0, 4.0),
    ];
    RoomPlan {
        outline_m: outline.iter().map(|&(x, y)| DVec2::new(x, y)).collect(),
        floor_z_m: 0.0,
        ceiling_z_m: 2.8,
        openings: vec![WallOpening {
            id: "w1".into(),
            wall: 0,
            along_m: [1.0, 3.0],
            z_m: [1.0, 2.0],
            kind: OpeningKind::Window { transmittance: 0.7 },
        }],
        site: None,
        wall_rho: None,
        ceiling_rho: None,
        floor_rho: None,
    }
}

fn area_of(m: &RecoMesh, pred: impl Fn(Part) -> bool) -> f64 {
    (0..m.tris.len())
        .filter(|&t| pred(m.part[t]))
        .map(|t| m.area_m2(t))
        .sum()
}

#[test]
fn the_plan_closes_an_l_shaped_room_with_its_window_cut_out_of_its_wall() {
    let (room, warnings) = room_from_plan(&plan(), &[], None);
    assert!(warnings.is_empty());
    assert_eq!(room.xy_m, [0.0, 0.0, 6.0, 4.0]);
    let outline = room.outline_m.clone().expect("outline");
    let mut m = RecoMesh::default();
    close(&mut m, &room, &outline, 1.0);
    // perimeter 20 m × 2.8 m, less the 2 m² window; the ceiling is the L's 20 m²
    let walls = area_of(&m, |p| p == Part::Wall);
    let window = area_of(&m, |p| p == Part::Window(0));
    let ceiling = area_of(&m, |p| p == Part::Ceiling);
    // the window snaps to the wall's cells (at most half a cell of PLAN_CELL_M on each edge)
    let snap_m2 = PLAN_CELL_M * (2.0 + 1.0);
    assert!((window - 2.0).abs() < snap_m2, "window {window}");
    assert!((walls + window - 56.0).abs() < 1e-9);
    assert!((ceiling - 20.0).abs() < 1e-9, "ceiling {ceiling}");
    // every face points into the room: its centre plus 1 cm along its normal is inside
    for t in 0..m.tris.len() {
        let [a, b, c] = m.tris[t].map(|i| m.positions_m[i as usize]);
        let n = (b - a).cross(c - a).normalize();
        let p = (a + b + c) / 3.0 + n * 0.01;
        let inside =
            crate::scene::plan::polygon_contains(&outline, p.truncate()) && p.z > 0.0 && p.z < 2.8;
        assert!(
            inside,
            "triangle {t} ({:?}) faces out of the room",
            m.part[t]
        );
    }
    // no patch is larger than the patch size
    for t in 0..m.tris.len() {
        assert!(m.area_m2(t) <= 0.5 + 1e-9);
    }
}

#[test]
fn what_the_cameras_see_beyond_a_wall_moves_it_and_says_so() {
    // floor points 0.5 m beyond the east wall (x = 6) of the south leg, and noise within 0.1 m
    // beyond the north wall: one warning, about wall 1
    let mut seen: Vec<DVec3> = (0..100)
        .map(|i| DVec3::new(6.5, 0.1 + 0.018 * i as f64, 0.0))
        .collect();
    seen.extend((0..100).map(|i| DVec3::new(0.5 + 0.03 * i as f64, 4.1, 0.0)));
    let (room, warnings) = room_from_plan(&plan(), &seen, Some(0.0));
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("wall 1") && warnings[0].contains("0.51 m"),
        "{warnings:?}"
    );
    let outline = room.outline_m.expect("outline");
    let x = 6.5 + SEEN_WALL_MARGIN_M;
    assert!((outline[1].x - x).abs() < 1e-9 && (outline[2].x - x).abs() < 1e-9);
    assert_eq!(room.xy_m[2], x);
    // the north wall, seen within the depth noise, moves silently behind what was seen
    assert!(outline[4].y > 4.1 && outline[4].y < 4.11, "{outline:?}");
    // a floor seen 8 cm above the plan's: the seen floor wins, with a warning
    let (room, warnings) = room_from_plan(&plan(), &[], Some(0.08));
    assert_eq!(room.floor_z_m, 0.08);
    assert!(warnings[0].contains("+80 mm"), "{warnings:?}");
}
