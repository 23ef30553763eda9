//! Numerical stability at the extremes: no panic, no NaN; a finite answer with a bound, or a
//! clear error.

mod common;

use std::path::Path;

use common::{luminaire, rel, scene, sensor};
use glam::DVec3;
use luxnode::engine::{self, Csr, Settings};
use luxnode::scene::{LoadOptions, MeshBuilder, Scene};
use luxnode::solver::{self, CsrSystem, SolveError, SolveOptions};

fn isotropic(i_cd: f64) -> impl Fn(f64) -> f64 {
    move |_| i_cd
}

fn all_finite(model: &engine::Model) -> bool {
    model
        .response_lx
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0)
}

/// A closed box with one isotropic point source inside: the area-weighted mean illuminance over
/// all surfaces is Φ / (S (1 − ρ)) exactly when form factors are reciprocal and closed
/// (Sumpner), whatever the direct distribution.
fn closed_box_mean(rho: f64) -> (f64, f64, u32) {
    let mut b = MeshBuilder::new();
    let m = b.material("grey", rho).unwrap();
    let size = DVec3::new(5.0, 4.0, 3.0);
    b.room(size, m, &[]);
    let l = luminaire(
        1,
        DVec3::new(2.5, 2.0, 2.0),
        [0.0, 0.0],
        false,
        isotropic(1000.0),
    );
    let flux = l.flux_lm;
    let s = scene(
        b.build(),
        vec![l],
        vec![sensor(1, DVec3::new(1.0, 1.0, 0.8))],
    );
    let model = engine::commission(&s, &Settings::default()).unwrap();
    assert!(all_finite(&model));
    let e = model.patch_lux(&[1.0]).unwrap();
    let p = &model.patches;
    let area: f64 = p.area_m2.iter().sum();
    let mean = e.iter().zip(&p.area_m2).map(|(e, a)| e * a).sum::<f64>() / area;
    let direct_flux: f64 = model.direct_patch_lx[0]
        .iter()
        .zip(&p.area_m2)
        .map(|(e, a)| e * a)
        .sum();
    let exact = flux / (area * (1.0 - rho));
    println!(
        "{} patches, direct flux {direct_flux:.1} of {flux:.1} lm",
        p.len()
    );
    let with_computed_direct = direct_flux / (area * (1.0 - rho));
    assert!(
        rel(mean, with_computed_direct) < 1e-6,
        "{mean} vs {with_computed_direct}"
    );
    (mean, exact, model.stats.iterations[0])
}

#[test]
fn closed_box_near_total_reflection_converges_to_sumpner() {
    for rho in [0.0, 0.5, 0.9, 0.99] {
        let (mean, exact, iterations) = closed_box_mean(rho);
        println!("rho {rho}: mean {mean:.2} lx, Sumpner {exact:.2} lx, {iterations} iterations");
        assert!(rel(mean, exact) < 0.01, "rho {rho}: {mean} vs {exact}");
    }
}

#[test]
fn reflectance_of_one_is_rejected_everywhere() {
    assert!(MeshBuilder::new().material("white", 1.0).is_err());
    let f = Csr::from_rows(vec![vec![(1, 0.2)], vec![(0, 0.2)]]);
    let rho = [1.0, 0.5];
    assert!(engine::dense_solve(&f, &rho, &[1.0, 1.0]).is_err());
    let mut b = [0.0; 2];
    let err = solver::gauss_seidel(
        &CsrSystem {
            f: f.view(),
            rho: &rho,
        },
        &[1.0, 1.0],
        &mut b,
        SolveOptions::default(),
    )
    .unwrap_err();
    assert_eq!(err, SolveError::BadReflectance { patch: 0, rho: 1.0 });
}

#[test]
fn degenerate_and_sliver_triangles() {
    let mut b = MeshBuilder::new();
    let m = b.material("grey", 0.5).unwrap();
    b.room(DVec3::new(4.0, 4.0, 3.0), m, &[]);
    let p = DVec3::new;
    // a 2 m sliver 0.1 mm wide standing on the floor, and two zero-area quads
    b.quad(
        [
            p(1., 1., 0.),
            p(3., 1., 0.),
            p(3., 1.0001, 0.5),
            p(1., 1.0001, 0.5),
        ],
        "sliver",
        m,
    );
    b.quad(
        [p(2., 2., 1.), p(2., 2., 1.), p(2., 2., 1.), p(2., 2., 1.)],
        "point",
        m,
    );
    b.quad(
        [p(0., 0., 1.), p(1., 1., 1.), p(2., 2., 1.), p(3., 3., 1.)],
        "line",
        m,
    );
    let l = luminaire(1, p(2.0, 2.0, 2.9), [0.3, 0.3], false, isotropic(500.0));
    let s = scene(b.build(), vec![l], vec![sensor(1, p(2.0, 2.0, 0.75))]);
    let model = engine::commission(&s, &Settings::default()).unwrap();
    assert!(all_finite(&model));
    assert!(model.patches.area_m2.iter().all(|a| *a > 0.0));
    assert!(
        model
            .patches
            .normal
            .iter()
            .all(|n| (n.length() - 1.0).abs() < 1e-9)
    );
}

#[test]
fn sensor_lying_on_a_surface_reads_like_one_just_above() {
    let mut b = MeshBuilder::new();
    let m = b.material("grey", 0.5).unwrap();
    b.room(DVec3::new(4.0, 4.0, 3.0), m, &[]);
    let l = luminaire(
        1,
        DVec3::new(2.0, 2.0, 2.9),
        [0.6, 0.6],
        false,
        isotropic(800.0),
    );
    let on = sensor(1, DVec3::new(1.5, 1.5, 0.0));
    let above = sensor(2, DVec3::new(1.5, 1.5, 0.001));
    let model = engine::commission(
        &scene(b.build(), vec![l], vec![on, above]),
        &Settings::default(),
    )
    .unwrap();
    let lux = model.sensor_lux(&[1.0]).unwrap();
    assert!(lux.iter().all(|v| v.is_finite() && *v > 0.0));
    assert!(rel(lux[0], lux[1]) < 0.005, "{lux:?}");
}

#[test]
fn luminaire_one_centimetre_from_a_wall() {
    let mut b = MeshBuilder::new();
    let m = b.material("grey", 0.7).unwrap();
    b.room(DVec3::new(4.0, 4.0, 3.0), m, &[]);
    let l = luminaire(
        1,
        DVec3::new(0.01, 2.0, 2.5),
        [0.0, 0.0],
        false,
        isotropic(1000.0),
    );
    let s = scene(
        b.build(),
        vec![l],
        vec![sensor(1, DVec3::new(2.0, 2.0, 0.0))],
    );
    let model = engine::commission(&s, &Settings::default()).unwrap();
    assert!(all_finite(&model));
    // the wall patch nearest the source is very bright but finite
    let e = model.patch_lux(&[1.0]).unwrap();
    let max = e.iter().cloned().fold(0.0, f64::max);
    assert!(max.is_finite() && max > 1000.0, "{max}");
}

#[test]
fn open_scene_without_ceiling() {
    let mut b = MeshBuilder::new();
    let m = b.material("grey", 0.5).unwrap();
    b.room(DVec3::new(4.0, 4.0, 3.0), m, &["ceiling"]);
    let l = luminaire(
        1,
        DVec3::new(2.0, 2.0, 2.5),
        [0.0, 0.0],
        false,
        isotropic(1000.0),
    );
    let s = scene(
        b.build(),
        vec![l],
        vec![sensor(1, DVec3::new(2.0, 2.0, 0.0))],
    );
    let model = engine::commission(&s, &Settings::default()).unwrap();
    assert!(all_finite(&model));
    assert!(
        model.stats.escaped_fraction > 0.1,
        "{}",
        model.stats.escaped_fraction
    );
    let lux = model.sensor_lux(&[1.0]).unwrap()[0];
    let direct = 1000.0 / 2.5f64.powi(2);
    // interreflections add light, but less than in a closed room
    assert!(lux > direct && lux < 2.0 * direct, "{lux}");
}

#[test]
fn hundred_metre_hall() {
    let mut b = MeshBuilder::new();
    let m = b.material("grey", 0.3).unwrap();
    b.room(DVec3::new(100.0, 100.0, 10.0), m, &[]);
    let l = luminaire(
        1,
        DVec3::new(50.0, 50.0, 9.9),
        [0.6, 0.6],
        false,
        isotropic(20_000.0),
    );
    let s = scene(
        b.build(),
        vec![l],
        vec![sensor(1, DVec3::new(50.0, 50.0, 0.0))],
    );
    let settings = Settings {
        patches: engine::PatchSettings {
            patch_size_m: 10.0,
            detail_ratio: 0.5,
            min_patch_m: 0.5,
            light_ratio: 0.5,
        },
        ..Settings::default()
    };
    let model = engine::commission(&s, &settings).unwrap();
    assert!(all_finite(&model));
    // direct part at the centre: an isotropic source 9.9 m up (the opening is tiny at that range)
    let direct = model.direct_sensor_lx[0][0];
    assert!(rel(direct, 20_000.0 / 9.9f64.powi(2)) < 1e-3, "{direct}");
}

#[test]
fn zero_and_fifty_thousand_lumens() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/office_a");
    let base = Scene::load(&dir, &LoadOptions::default()).unwrap();
    let scaled = |flux: f64| {
        let mut s = base.clone();
        for l in &mut s.luminaires {
            l.photometry = std::sync::Arc::new(l.photometry.scaled_to_flux(flux).unwrap());
            l.flux_lm = flux;
        }
        engine::commission(&s, &Settings::default()).unwrap()
    };
    let dark = scaled(0.0);
    assert!(dark.response_lx.iter().flatten().all(|v| *v == 0.0));
    let bright = scaled(50_000.0);
    let normal = scaled(7913.0);
    for (a, b) in bright
        .response_lx
        .iter()
        .flatten()
        .zip(normal.response_lx.iter().flatten())
    {
        assert!(rel(*a, b * 50_000.0 / 7913.0) < 1e-9, "{a} vs {b}");
    }
}

#[test]
fn millimetre_scene_gives_the_same_lux() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/office_a");
    let tmp = tempfile::tempdir().unwrap();
    let obj = std::fs::read_to_string(src.join("scene.obj")).unwrap();
    let obj_mm: Vec<String> = obj
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<String> = rest
                    .split_whitespace()
                    .map(|x| format!("{}", x.parse::<f64>().unwrap() * 1000.0))
                    .collect();
                format!("v {}", v.join(" "))
            }
            None => l.to_owned(),
        })
        .collect();
    std::fs::write(tmp.path().join("scene.obj"), obj_mm.join("\n")).unwrap();
    for f in ["scene.mtl", "luminaire.ldt", "luminaire.ies"] {
        std::fs::copy(src.join(f), tmp.path().join(f)).unwrap();
    }
    for f in ["luminaires.json", "sensors.json"] {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(src.join(f)).unwrap()).unwrap();
        for item in v.as_array_mut().unwrap() {
            for x in item["position"].as_array_mut().unwrap() {
                *x = (x.as_f64().unwrap() * 1000.0).into();
            }
        }
        std::fs::write(tmp.path().join(f), serde_json::to_string(&v).unwrap()).unwrap();
    }
    let m = Scene::load(&src, &LoadOptions::default()).unwrap();
    let mm = Scene::load(
        tmp.path(),
        &LoadOptions {
            unit_to_m: 0.001,
            ..LoadOptions::default()
        },
    )
    .unwrap();
    let a = engine::commission(&m, &Settings::default()).unwrap();
    let b = engine::commission(&mm, &Settings::default()).unwrap();
    for (x, y) in a
        .response_lx
        .iter()
        .flatten()
        .zip(b.response_lx.iter().flatten())
    {
        assert!(rel(*y, *x) < 1e-3, "{y} vs {x}");
    }
}
