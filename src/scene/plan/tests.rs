use super::*;

/// office_a's plan, as the shared scenes' README gives it.
const PLAN: &str = r#"{
  "format": "luxnode-room-plan/1",
  "outline_m": [[0.0, 0.0], [5.4, 0.0], [5.4, 9.0], [0.0, 9.0]],
  "floor_z_m": 0.0,
  "ceiling_z_m": 2.8,
  "windows": [
    {"id": "w1", "corners_m": [[0.0, 1.05, 0.9], [0.0, 2.0, 0.9], [0.0, 2.0, 2.2], [0.0, 1.05, 2.2]],
     "transmittance": 0.8}
  ],
  "site": {"latitude_deg": 48.1, "longitude_deg": 11.6, "north": [1.0, 0.0]}
}"#;

fn load_text(text: &str) -> Result<(RoomPlan, Vec<String>), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let path = dir.path().join("room.json");
    std::fs::write(&path, text).map_err(|e| e.to_string())?;
    RoomPlan::load(&path).map_err(|e| e.to_string())
}

fn refused(text: &str, needle: &str) {
    match load_text(text) {
        Ok(_) => panic!("accepted a plan that should fail with {needle:?}"),
        Err(e) => assert!(e.contains(needle), "{needle:?} not in: {e}"),
    }
}

#[test]
fn the_readme_plan_reads_with_its_window_on_the_west_wall() {
    let (p, warnings) = load_text(PLAN).expect("valid");
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(p.walls(), 4);
    assert_eq!(p.openings.len(), 1);
    let w = &p.openings[0];
    // wall 3 runs from (0, 9) to (0, 0): the window lies 7.0..7.95 m along it
    assert_eq!(w.wall, 3);
    assert!((w.along_m[0] - 7.0).abs() < 1e-9 && (w.along_m[1] - 7.95).abs() < 1e-9);
    assert_eq!(w.z_m, [0.9, 2.2]);
    assert_eq!(w.kind, OpeningKind::Window { transmittance: 0.8 });
    // the inward normal of wall 3 is +x
    assert!((p.wall_inward(3) - DVec2::X).length() < 1e-12);
    assert!(p.contains(DVec2::new(2.7, 4.5)) && !p.contains(DVec2::new(6.0, 4.5)));
    let (d, wall) = p.signed_distance_m(DVec2::new(5.9, 4.5));
    assert!((d - 0.5).abs() < 1e-12 && wall == 1);
    let site = p.site.expect("site");
    assert_eq!(site.north, DVec2::X);
}

#[test]
fn a_clockwise_outline_is_read_counter_clockwise_with_a_warning() {
    let text = PLAN.replace(
        "[[0.0, 0.0], [5.4, 0.0], [5.4, 9.0], [0.0, 9.0]]",
        "[[0.0, 9.0], [5.4, 9.0], [5.4, 0.0], [0.0, 0.0]]",
    );
    let (p, warnings) = load_text(&text).expect("valid");
    assert_eq!(warnings.len(), 1);
    assert!(signed_area2(&p.outline_m) > 0.0);
    assert_eq!(p.openings.len(), 1);
}

#[test]
fn an_l_shaped_room_contains_its_legs_but_not_its_missing_corner() {
    let text = PLAN.replace(
        "[[0.0, 0.0], [5.4, 0.0], [5.4, 9.0], [0.0, 9.0]]",
        "[[0.0, 0.0], [5.4, 0.0], [5.4, 4.0], [3.0, 4.0], [3.0, 9.0], [0.0, 9.0]]",
    );
    let (p, _) = load_text(&text).expect("valid");
    assert!(p.contains(DVec2::new(4.0, 2.0)) && p.contains(DVec2::new(1.0, 8.0)));
    assert!(!p.contains(DVec2::new(4.0, 6.0)));
    // signed area: 5.4 × 4 + 3 × 5
    assert!((signed_area2(&p.outline_m) * 0.5 - 36.6).abs() < 1e-9);
}

#[test]
fn mistakes_in_a_plan_are_refused_with_what_is_wrong() {
    const OUTLINE: &str = "[[0.0, 0.0], [5.4, 0.0], [5.4, 9.0], [0.0, 9.0]]";
    const WINDOW: &str = "[[0.0, 1.05, 0.9], [0.0, 2.0, 0.9], [0.0, 2.0, 2.2], [0.0, 1.05, 2.2]]";
    // (what is typed in place of what, and the words of the refusal)
    let mistakes = [
        ("\"site\"", "\"sight\"", "unknown field"),
        ("luxnode-room-plan/1", "luxnode-room-plan/2", "expected"),
        (
            OUTLINE,
            "[[0.0, 0.0], [5.4, 9.0], [5.4, 0.0], [0.0, 9.0]]",
            "intersects itself",
        ),
        (
            OUTLINE,
            "[[0.0, 0.0], [5400.0, 0.0], [5400.0, 9000.0], [0.0, 9000.0]]",
            "millimetres",
        ),
        (
            OUTLINE,
            "[[0.0, 0.0], [5.4, 0.0], [5.4, 0.0], [0.0, 9.0]]",
            "typed twice",
        ),
        (
            "\"ceiling_z_m\": 2.8",
            "\"ceiling_z_m\": 2800",
            "millimetres",
        ),
        (
            "\"ceiling_z_m\": 2.8",
            "\"ceiling_z_m\": 0.8",
            "above the floor",
        ),
        // the window 30 cm into the room: off every wall
        (WINDOW, &WINDOW.replace("[0.0,", "[0.3,"), "on no wall"),
        (
            "\"transmittance\": 0.8",
            "\"transmittance\": 80",
            "transmittance",
        ),
        (
            "\"ceiling_z_m\": 2.8,",
            "\"ceiling_z_m\": 2.8, \"wall_rho\": 55,",
            "percentage",
        ),
        (
            "\"north\": [1.0, 0.0]",
            "\"north\": [0.0, 0.0]",
            "unit vector",
        ),
        (
            "\"latitude_deg\": 48.1",
            "\"latitude_deg\": 148.1",
            "-90..90",
        ),
    ];
    for (from, to, needle) in mistakes {
        assert!(PLAN.contains(from), "{from}");
        refused(&PLAN.replace(from, to), needle);
    }
}

#[test]
fn contents_outside_the_outline_are_named() {
    let (p, _) = load_text(PLAN).expect("valid");
    let sensor = |id: u32, x: f64| Sensor {
        id,
        position_m: DVec3::new(x, 4.0, 0.75),
        normal: DVec3::Z,
        response: crate::lsc::AngularResponse::Cosine,
        note: String::new(),
    };
    assert!(
        p.check_contents(Path::new("room.json"), &[], &[sensor(1, 2.0)], None)
            .is_ok()
    );
    let e = p
        .check_contents(
            Path::new("room.json"),
            &[],
            &[sensor(1, 2.0), sensor(7, 6.4)],
            None,
        )
        .expect_err("sensor 7 is 1 m outside");
    let text = e.to_string();
    assert!(
        text.contains("sensor 7") && text.contains("1.00 m outside"),
        "{text}"
    );
}
