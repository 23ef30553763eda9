//! What the tests share: where the reference scenes are (`office_a` and the rest of
//! `reference/`, the repository's copy of `../shared/`) and their loaders; independent
//! references (configuration factors of the Howell catalogue in closed form, physics.md §2);
//! small scenes built in code. Every test file that
//! needs one of these takes it from here (`mod common;`), never writes its own.
#![allow(dead_code)]

#[cfg(feature = "hil")]
pub mod procs;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use luxnode::camera::capture::Capture;
use luxnode::lsc::AngularResponse;
use luxnode::photometry::IntensityDistribution;
use luxnode::scene::{
    Desks, LoadOptions, Luminaire, Mesh, ObjReport, Scene, Sensor, load_desks_file,
    load_luminaires_file, load_sensors_file,
};

/// The crate's directory.
pub fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A path under the reference data (`reference/`: the repository's copy of the shared
/// reference scenes and photometry, so a clean clone needs nothing beside it).
pub fn shared(rel: &str) -> PathBuf {
    manifest().join("reference").join(rel)
}

/// The reference office's scene directory (`reference/scenes/office_a`).
pub fn office_a() -> PathBuf {
    shared("scenes/office_a")
}

/// A scene directory's luminaires, sensors and desks (when it has `desks.json`), loaded with
/// the default options.
pub fn scene_inputs(dir: &Path) -> (Vec<Luminaire>, Vec<Sensor>, Option<Desks>) {
    let load = LoadOptions::default();
    let (lums, _) = load_luminaires_file(&dir.join("luminaires.json"), &load).expect("luminaires");
    let (sensors, _) = load_sensors_file(&dir.join("sensors.json"), &load).expect("sensors");
    let desks = load_desks_file(&dir.join("desks.json"), &load).ok();
    (lums, sensors, desks)
}

/// The capture set in `dir` for `luminaires` (one luminance frame per luminaire).
pub fn capture(dir: &Path, luminaires: &[Luminaire]) -> Capture {
    let ids: Vec<u32> = luminaires.iter().map(|l| l.id).collect();
    Capture::load(dir, &ids).expect("capture")
}

/// office_a's capture set `name` (`capture_clean`, ...), luminaires and sensors.
pub fn office_a_capture(name: &str) -> (Capture, Vec<Luminaire>, Vec<Sensor>) {
    let d = office_a();
    let (lums, sensors, _) = scene_inputs(&d);
    (capture(&d.join(name), &lums), lums, sensors)
}

/// B-3: differential element to a parallel a × b rectangle at distance c, the element on the
/// normal through one corner.
pub fn b3(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let sx = (1.0 + x * x).sqrt();
    let sy = (1.0 + y * y).sqrt();
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// C-11: identical, parallel, directly opposed a × b rectangles at distance c.
pub fn c11(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    2.0 / (PI * x * y)
        * (((1.0 + x2) * (1.0 + y2) / (1.0 + x2 + y2)).sqrt().ln()
            + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
            + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
            - x * x.atan()
            - y * y.atan())
}

/// C-14: rectangle of width w to a perpendicular rectangle of height h sharing an edge of
/// length l.
pub fn c14(w: f64, h: f64, l: f64) -> f64 {
    let (w, h) = (w / l, h / l);
    let (w2, h2) = (w * w, h * h);
    let s = (w2 + h2).sqrt();
    let log_arg = (1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2)
        * (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).powf(w2)
        * (h2 * (1.0 + w2 + h2) / ((1.0 + h2) * (w2 + h2))).powf(h2);
    (w * (1.0 / w).atan() + h * (1.0 / h).atan() - s * (1.0 / s).atan() + 0.25 * log_arg.ln())
        / (PI * w)
}

/// C-41: coaxial parallel discs of radii r1 → r2 at distance a.
pub fn c41(r1: f64, r2: f64, a: f64) -> f64 {
    let (r1, r2) = (r1 / a, r2 / a);
    let x = 1.0 + (1.0 + r2 * r2) / (r1 * r1);
    0.5 * (x - (x * x - 4.0 * (r2 / r1).powi(2)).sqrt())
}

/// A scene from a mesh, luminaires and sensors (no desks, no camera).
pub fn scene(mesh: Mesh, luminaires: Vec<Luminaire>, sensors: Vec<Sensor>) -> Scene {
    Scene {
        name: "test".into(),
        mesh,
        luminaires,
        sensors,
        desks: None,
        camera: None,
        obj_report: ObjReport::default(),
        warnings: Vec::new(),
    }
}

/// A downward-aimed luminaire with a rotationally symmetric distribution `i_cd(γ)`.
pub fn luminaire(
    id: u32,
    position: DVec3,
    opening_m: [f64; 2],
    circular: bool,
    i_cd: impl Fn(f64) -> f64,
) -> Luminaire {
    let d = IntensityDistribution::from_gamma_fn(0.25, "test", i_cd);
    let flux = d.flux_lm();
    Luminaire {
        id,
        name: format!("luminaire_{id}"),
        position_m: position,
        aim: DVec3::NEG_Z,
        c0: DVec3::X,
        c90: DVec3::Y,
        flux_lm: flux,
        opening_m,
        opening_circular: circular,
        photometry: Arc::new(d),
        photometry_path: "test".into(),
        file_flux_lm: flux,
    }
}

/// An upward-facing ideal cosine sensor.
pub fn sensor(id: u32, position: DVec3) -> Sensor {
    Sensor {
        id,
        position_m: position,
        normal: DVec3::Z,
        note: String::new(),
        response: AngularResponse::Cosine,
    }
}

/// Relative difference.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// A small room (two luminaires, two sensors) whose image is a few kB: for exhaustive tests.
pub fn small_image(flux_scale: f64) -> Vec<u8> {
    let mut b = luxnode::scene::MeshBuilder::new();
    let m = b.material("grey", 0.6).unwrap();
    b.room(DVec3::new(3.0, 2.0, 2.5), m, &[]);
    let l1 = luminaire(1, DVec3::new(1.0, 1.0, 2.4), [0.3, 0.3], false, move |_| {
        300.0 * flux_scale
    });
    let l2 = luminaire(2, DVec3::new(2.0, 1.0, 2.4), [0.3, 0.3], false, move |_| {
        200.0 * flux_scale
    });
    let s = scene(
        b.build(),
        vec![l1, l2],
        vec![
            sensor(1, DVec3::new(1.5, 1.0, 0.8)),
            sensor(2, DVec3::new(0.5, 0.5, 0.0)),
        ],
    );
    let settings = luxnode::engine::Settings {
        patches: luxnode::engine::PatchSettings {
            patch_size_m: 1.5,
            detail_ratio: 0.0,
            min_patch_m: 0.5,
            light_ratio: 0.0,
        },
        rays: 100,
        sensor_rays: 300,
        final_gather_rays: 100,
        ..luxnode::engine::Settings::default()
    };
    let model = luxnode::engine::compute_model(&s, &settings).unwrap();
    luxnode::image_build::build_image(
        &model,
        &luxnode::image_build::ImageOptions {
            precision: luxnode::store::Precision::F16,
            ..luxnode::image_build::ImageOptions::default()
        },
    )
    .unwrap()
}

/// A black room (3 × 3 × 2.8 m, every reflectance 0: only direct light) with one desk (x 1..2,
/// y 1..1.8, top at 0.75 m; desk id 1) and a box standing on it on 5 mm pads (x 1.25..1.55,
/// y 1.2..1.4, 0.755..0.80 m), lit by one small luminaire of constant 300 cd straight above the
/// box at 2.7 m; one sensor on the desk. The box covers the desk's EN 12464-1 grid points
/// (1.3, 1.3) and (1.5, 1.3) (grid 5 × 4, 0.2 m cells, centres at 1.1..1.9 × 1.1..1.7), every
/// other point sees the luminaire (the box is 5 cm tall, far below their rays).
pub fn desk_with_box_scene() -> Scene {
    let mut b = luxnode::scene::MeshBuilder::new();
    let black = b.material("black", 0.0).unwrap();
    b.room(DVec3::new(3.0, 3.0, 2.8), black, &[]);
    b.solid_box(
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(2.0, 1.8, 0.75),
        "desk_1",
        black,
    );
    b.solid_box(
        DVec3::new(1.25, 1.2, 0.755),
        DVec3::new(1.55, 1.4, 0.80),
        "box_1",
        black,
    );
    let lum = luminaire(1, DVec3::new(1.4, 1.3, 2.7), [0.02, 0.02], false, |_| 300.0);
    let mut s = scene(
        b.build(),
        vec![lum],
        vec![sensor(1, DVec3::new(1.8, 1.6, 0.75))],
    );
    s.desks = Some(Desks {
        desks: vec![luxnode::scene::Desk {
            id: 1,
            group: "desk_1".into(),
            x_m: [1.0, 2.0],
            y_m: [1.0, 1.8],
            z_m: 0.75,
        }],
        grid_step_m: 0.2,
        grid_points: Vec::new(),
    });
    s
}
