//! Scene input: office_a reads clean with the values its files state; every kind of bad
//! input is an error naming the file and the line or JSON path, or (zero-area) a counted warning.

mod common;
use common::office_a;

use std::path::Path;

use luxnode::scene::{LoadOptions, Scene, SceneError, SceneErrors};

/// A writable copy of office_a's scene files (not the capture sets).
fn copy_office_a() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in [
        "scene.obj",
        "scene.mtl",
        "luminaires.json",
        "sensors.json",
        "desks.json",
        "camera.json",
        "luminaire.ldt",
        "luminaire.ies",
    ] {
        std::fs::copy(office_a().join(f), dir.path().join(f)).unwrap();
    }
    dir
}

fn edit(dir: &Path, file: &str, f: impl Fn(String) -> String) {
    let p = dir.join(file);
    let text = std::fs::read_to_string(&p).unwrap();
    let new = f(text.clone());
    assert_ne!(new, text, "the edit of {file} changed nothing");
    std::fs::write(&p, new).unwrap();
}

fn load_err(dir: &Path) -> SceneErrors {
    match Scene::load(dir, &LoadOptions::default()) {
        Ok(_) => panic!("scene loaded despite bad input"),
        Err(e) => e,
    }
}

#[test]
fn office_a_loads_with_its_stated_contents() {
    let s = Scene::load(&office_a(), &LoadOptions::default()).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.mesh.triangles.len(), 290);
    let areas = s.mesh.area_per_group_m2();
    let area = |g: &str| areas[s.mesh.groups.iter().position(|x| x == g).unwrap()];
    assert!((area("floor") - 6.0 * 7.2).abs() < 1e-9);
    assert!((area("wall_w") - 7.2 * 3.0).abs() < 1e-9);
    assert!((area("luminaire_1") - 0.36).abs() < 1e-9);
    // reflectances from scene.mtl
    let rho = |name: &str| {
        s.mesh
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap()
            .rho
            .get()
    };
    assert_eq!(rho("ceiling"), 0.8);
    assert_eq!(rho("luminaire_opening"), 0.0);
    assert_eq!(s.luminaires.len(), 8);
    for (k, l) in s.luminaires.iter().enumerate() {
        assert_eq!(l.id as usize, k + 1);
        assert!((l.photometry.flux_lm() - 7913.0).abs() < 1e-6 * 7913.0);
        assert_eq!(l.opening_m, [0.6, 0.6]);
        assert!((l.c90 - glam::DVec3::Y).length() < 1e-12);
    }
    assert_eq!(s.sensors.len(), 8);
    let desks = s.desks.as_ref().unwrap();
    assert_eq!(desks.desks.len(), 5);
    assert_eq!(desks.grid_points.len(), 84);
    let cam = s.camera.as_ref().unwrap();
    assert_eq!((cam.width, cam.height), (320, 240));
    // the optical axis looks straight down
    let axis = cam.ray_world(cam.cx, cam.cy).unwrap();
    assert!((axis - glam::DVec3::NEG_Z).length() < 1e-9);
}

#[test]
fn luminaire_intensity_follows_its_frame() {
    // Peak of office_a's batwing is at C90 γ40: in the world that is toward +y, 40° off nadir.
    let s = Scene::load(&office_a(), &LoadOptions::default()).unwrap();
    let l = &s.luminaires[0];
    let (peak, _, _) = l.photometry.max_intensity();
    let g = 40f64.to_radians();
    let toward_y = glam::DVec3::new(0.0, g.sin(), -g.cos());
    assert!((l.intensity_toward_cd(toward_y) - peak).abs() < 1e-9 * peak);
}

#[test]
fn millimetre_scene_reads_as_metres() {
    let dir = copy_office_a();
    edit(dir.path(), "scene.obj", |t| {
        t.lines()
            .map(|l| {
                if let Some(rest) = l.strip_prefix("v ") {
                    let v: Vec<String> = rest
                        .split_whitespace()
                        .map(|x| format!("{}", x.parse::<f64>().unwrap() * 1000.0))
                        .collect();
                    format!("v {}", v.join(" "))
                } else {
                    l.to_owned()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    for f in ["luminaires.json", "sensors.json", "camera.json"] {
        edit(dir.path(), f, |t| {
            let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
            let scale = |p: &mut serde_json::Value| {
                for x in p.as_array_mut().unwrap() {
                    *x = (x.as_f64().unwrap() * 1000.0).into();
                }
            };
            match v.as_array_mut() {
                Some(items) => items.iter_mut().for_each(|i| scale(&mut i["position"])),
                None => scale(&mut v["position"]),
            }
            serde_json::to_string(&v).unwrap()
        });
    }
    std::fs::remove_file(dir.path().join("desks.json")).unwrap();
    let mm = Scene::load(
        dir.path(),
        &LoadOptions {
            unit_to_m: 0.001,
            ..LoadOptions::default()
        },
    )
    .unwrap();
    let m = Scene::load(&office_a(), &LoadOptions::default()).unwrap();
    for (a, b) in mm.mesh.positions_m.iter().zip(&m.mesh.positions_m) {
        assert!((*a - *b).length() < 1e-9);
    }
    assert!((mm.luminaires[3].position_m - m.luminaires[3].position_m).length() < 1e-9);
    assert!((mm.sensors[2].position_m - m.sensors[2].position_m).length() < 1e-9);
}

#[test]
fn reflectance_of_one_is_an_error_naming_file_and_line() {
    let dir = copy_office_a();
    edit(dir.path(), "scene.mtl", |t| {
        t.replacen("Kd 0.8000 0.8000 0.8000", "Kd 1.0 1.0 1.0", 1)
    });
    let e = load_err(dir.path());
    let msg = e.to_string();
    assert!(msg.contains("scene.mtl:12"), "{msg}");
    assert!(msg.contains("[0, 1)"), "{msg}");
}

#[test]
fn non_finite_coordinates_are_errors() {
    let dir = copy_office_a();
    edit(dir.path(), "scene.obj", |t| {
        t.replacen("v 6.000000 0.000000 0.000000", "v 6.0 nan 0.0", 1)
    });
    let msg = load_err(dir.path()).to_string();
    assert!(msg.contains("scene.obj:5"), "{msg}");
}

#[test]
fn zero_area_triangles_are_dropped_and_counted() {
    let dir = copy_office_a();
    edit(dir.path(), "scene.obj", |t| {
        format!("{t}\nusemtl wall\nf 1 2 2\nf 1 1 1\n")
    });
    let s = Scene::load(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(s.obj_report.zero_area_dropped, 2);
    assert_eq!(s.mesh.triangles.len(), 290);
    assert!(
        s.warnings.iter().any(|w| w.contains("2 zero-area")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn unknown_photometry_file_is_an_error() {
    let dir = copy_office_a();
    std::fs::remove_file(dir.path().join("luminaire.ldt")).unwrap();
    std::fs::remove_file(dir.path().join("luminaire.ies")).unwrap();
    let e = load_err(dir.path());
    assert!(
        e.errors
            .iter()
            .all(|x| matches!(x, SceneError::Photometry { .. }))
    );
    assert!(e.to_string().contains("luminaire.ldt"), "{e}");
}

#[test]
fn duplicate_luminaire_ids_are_an_error() {
    let dir = copy_office_a();
    edit(dir.path(), "luminaires.json", |t| {
        t.replacen("\"id\": 2,", "\"id\": 1,", 1)
    });
    let msg = load_err(dir.path()).to_string();
    assert!(
        msg.contains("luminaires[1].id") && msg.contains("more than once"),
        "{msg}"
    );
}

#[test]
fn malformed_json_names_the_json_path() {
    let dir = copy_office_a();
    edit(dir.path(), "sensors.json", |t| {
        let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
        v[2]["position"][1] = "two".into();
        serde_json::to_string_pretty(&v).unwrap()
    });
    let msg = load_err(dir.path()).to_string();
    assert!(
        msg.contains("sensors.json") && msg.contains("[2].position[1]"),
        "{msg}"
    );

    let dir = copy_office_a();
    edit(dir.path(), "luminaires.json", |t| {
        t[..t.len() / 2].to_owned()
    });
    let msg = load_err(dir.path()).to_string();
    assert!(
        msg.contains("luminaires.json") && msg.contains("line"),
        "{msg}"
    );

    let dir = copy_office_a();
    edit(dir.path(), "sensors.json", |t| {
        t.replacen("\"normal\"", "\"nromal\"", 1)
    });
    let msg = load_err(dir.path()).to_string();
    assert!(msg.contains("nromal"), "{msg}");
}

#[test]
fn mirrored_c90_and_zero_aim_are_errors() {
    let dir = copy_office_a();
    edit(dir.path(), "luminaires.json", |t| {
        let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
        v[4]["c90_direction"] = serde_json::json!([0.0, -1.0, 0.0]);
        v[6]["aim"] = serde_json::json!([0.0, 0.0, 0.0]);
        serde_json::to_string_pretty(&v).unwrap()
    });
    let e = load_err(dir.path());
    let msg = e.to_string();
    assert!(msg.contains("luminaires[4].c90_direction"), "{msg}");
    assert!(msg.contains("luminaires[6].aim"), "{msg}");
    assert_eq!(e.errors.len(), 2, "every error is reported: {msg}");
}

#[test]
fn bad_lsc_and_desks_are_errors() {
    let dir = copy_office_a();
    edit(dir.path(), "sensors.json", |t| {
        let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
        v[0]["lsc"] = serde_json::json!([[0.0, 1.0], [50.0, 0.7], [40.0, 0.8]]);
        serde_json::to_string_pretty(&v).unwrap()
    });
    edit(dir.path(), "desks.json", |t| {
        let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
        v["desks"][1]["x1"] = 0.5.into();
        v["grid_points"][0]["desk_id"] = 42.into();
        serde_json::to_string_pretty(&v).unwrap()
    });
    let msg = load_err(dir.path()).to_string();
    assert!(msg.contains("sensors[0].lsc"), "{msg}");
    assert!(msg.contains("desks[1]"), "{msg}");
    assert!(msg.contains("grid_points[0].desk_id"), "{msg}");
}

#[test]
fn lsc_table_is_read() {
    let dir = copy_office_a();
    edit(dir.path(), "sensors.json", |t| {
        let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
        v[1]["lsc"] = serde_json::json!([
            [0, 1],
            [10, 0.984],
            [20, 0.936],
            [30, 0.854],
            [40, 0.736],
            [50, 0.572],
            [60, 0.313],
            [70, 0.077],
            [80, 0.0164]
        ]);
        serde_json::to_string_pretty(&v).unwrap()
    });
    let s = Scene::load(dir.path(), &LoadOptions::default()).unwrap();
    let f2 = s.sensors[1].response.f2();
    assert!((f2 - 0.2209).abs() < 0.002, "{f2}");
}

#[test]
fn missing_required_file_is_an_error() {
    let dir = copy_office_a();
    std::fs::remove_file(dir.path().join("sensors.json")).unwrap();
    let msg = load_err(dir.path()).to_string();
    assert!(
        msg.contains("sensors.json") && msg.contains("cannot read"),
        "{msg}"
    );
}
