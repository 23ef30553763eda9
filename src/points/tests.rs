use super::*;
use crate::store::geometry::{DeskRecord, SensorRecord};

fn section(sensors: &[(u32, [f64; 3])]) -> GeometrySection {
    GeometrySection {
        scene_name: "t".into(),
        preset: "custom".into(),
        commissioned_unix_s: 0,
        software: "t".into(),
        maintenance_factor: 0.8,
        groups: vec!["floor".into()],
        // a floor at z = 0.02 m
        patch_corners_m: vec![[0.0, 0.0, 0.02, 4.0, 0.0, 0.02, 4.0, 3.0, 0.02]],
        patch_group: vec![0],
        camera: None,
        desks: vec![
            DeskRecord {
                id: 1,
                group: "desk_1".into(),
                extent_m: [1.0, 1.8, 1.8, 3.4],
                z_m: 0.75,
            },
            DeskRecord {
                id: 2,
                group: "desk_2".into(),
                extent_m: [2.6, 1.8, 1.8, 3.4], // x0 > x1: the outline still holds
                z_m: 0.75,
            },
        ],
        sensors: sensors
            .iter()
            .map(|&(id, p)| SensorRecord {
                id,
                position_m: p,
                normal: [0.0, 0.0, 1.0],
            })
            .collect(),
        luminaires: vec![],
        photometries: vec![],
        unseen_walls: vec![],
    }
}

#[test]
fn points_are_named_for_the_desk_floor_or_place_they_stand_on() {
    let s = section(&[
        (2, [1.45, 2.25, 0.751]), // on desk 1
        (3, [2.2, 2.0, 0.76]),    // on desk 2 (outline given x1 < x0)
        (8, [0.8, 0.6, 0.021]),   // floor
        (9, [0.3, 2.0, 0.92]),    // a sideboard, 0.90 m above the floor
        (5, [1.45, 2.25, 1.2]),   // above desk 1, not on it
        (6, [0.95, 2.0, 0.75]),   // 5 cm short of desk 1's edge
    ]);
    let p = points_in(&[2, 3, 8, 9, 5, 6, 77], Some(&s));
    let names: Vec<&str> = p.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "desk 1 (S2)",
            "desk 2 (S3)",
            "floor S8",
            "S9",
            "S5",
            "S6",
            "S77"
        ]
    );
    match p[3].place {
        Place::Other(h) => assert!((h - 0.90).abs() < 1e-6, "{h}"),
        other => panic!("{other:?}"),
    }
    assert_eq!(p[0].desk_id(), Some(1));
    assert_eq!(p[2].desk_id(), None);
    // a sensor the section does not list, and an image without geometry: its id alone
    assert!(matches!(p[6].place, Place::Other(h) if h.is_nan()));
    assert_eq!(points_in(&[4], None)[0].name, "S4");
}
