//! Commissioning from a capture set, against independent references: the Radiance truth of
//! office_a (desk lux), its ground-truth albedo image (reflectances; read here only, never by
//! commissioning), synthetic depth with a known plane, and bad input.

mod common;

use std::path::Path;

use glam::{DMat3, DVec3};
use luxnode::camera::capture::Frame;
use luxnode::commission::refit::Reading;
use luxnode::commission::{
    self, Capture, CommissionOptions, Commissioned, Gain, ReflectanceMethod, depth, grid, planes,
};

// spherical-harmonic fit on capture_clean; measured values in docs/commissioning.md
// (measured |Δρ| median 0.0101, 90th percentile 0.0270; in view 3.77 %, worst 6.8 %)
const SH_RHO_MEDIAN_BOUND: f64 = 0.015;
const SH_RHO_P90_BOUND: f64 = 0.04;
const SH_IN_VIEW_BOUND: f64 = 0.045;
use luxnode::engine::raycast::{Hit, RayCaster};
use luxnode::scene::Camera;
use luxnode::scene::{LoadOptions, Luminaire, Sensor, load_desks_file, read_states, read_truth};
use luxnode::store::sensor_flags;

/// office_a's luminaires, sensors and the capture set `capture`.
fn inputs(capture: &str) -> (Vec<Luminaire>, Vec<Sensor>, Capture) {
    let (cap, lums, sensors) = common::office_a_capture(capture);
    (lums, sensors, cap)
}

fn run(capture: &str, o: &CommissionOptions) -> Commissioned {
    let (lums, sensors, cap) = inputs(capture);
    let desks = load_desks_file(
        &common::office_a().join("desks.json"),
        &LoadOptions::default(),
    )
    .ok();
    commission::from_capture(&cap, lums, sensors, desks, o).expect("commissions")
}

/// In-view sensors from the capture's sensor_pixels.csv (test-side ground truth).
fn in_view(capture: &str) -> Vec<u32> {
    let text = std::fs::read_to_string(
        common::office_a()
            .join(capture)
            .join("groundtruth/sensor_pixels.csv"),
    )
    .expect("sensor_pixels.csv");
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f.last() == Some(&"1"))
                .then(|| f[0].parse().ok())
                .flatten()
        })
        .collect()
}

/// (mean abs error / mean truth, worst sensor's own error, per-sensor errors) over in-view
/// sensors and all scenarios.
fn errors(c: &Commissioned, sensors: &[u32]) -> (f64, f64, Vec<(u32, f64)>) {
    let d = common::office_a();
    let states = read_states(&d.join("states.csv")).expect("states");
    let truth = read_truth(&d.join("truth.csv")).expect("truth");
    let m = &c.model;
    let mut per: Vec<(u32, f64, f64)> = sensors.iter().map(|&s| (s, 0.0, 0.0)).collect();
    for st in &states {
        let levels: Vec<f64> = m
            .luminaire_ids
            .iter()
            .map(|id| if st.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        let lux = m.sensor_lux(&levels).expect("lux");
        for (k, id) in m.sensor_ids.iter().enumerate() {
            let Some(e) = per.iter_mut().find(|e| e.0 == *id) else {
                continue;
            };
            let t = truth
                .iter()
                .find(|r| r.scenario == st.id && r.sensor == *id)
                .expect("truth row")
                .lux;
            e.1 += (lux[k] - t).abs();
            e.2 += t;
        }
    }
    let abs: f64 = per.iter().map(|e| e.1).sum();
    let tot: f64 = per.iter().map(|e| e.2).sum();
    let each: Vec<(u32, f64)> = per.iter().map(|e| (e.0, e.1 / e.2)).collect();
    let worst = each.iter().map(|e| e.1).fold(0.0, f64::max);
    (abs / tot, worst, each)
}

fn labels(capture: &str) -> (Vec<u16>, Vec<(u16, String)>) {
    let gt = common::office_a().join(capture).join("groundtruth");
    let img = image::open(gt.join("labels.png")).expect("labels.png");
    let names: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(gt.join("labels.json")).expect("json"))
            .expect("labels.json");
    let names = names
        .as_object()
        .expect("object")
        .iter()
        .map(|(k, v)| (k.parse().expect("id"), v.as_str().unwrap_or("").to_owned()))
        .collect();
    let data = match img {
        image::DynamicImage::ImageLuma16(b) => b.into_raw(),
        other => other.to_luma16().into_raw(),
    };
    (data, names)
}

/// Median |ρ estimated − ρ true| over pixels of floor, desks and walls (albedo.png: ρ × 10000).
fn reflectance_error(c: &Commissioned, capture: &str) -> (f64, usize) {
    let errs = reflectance_errors(c, capture);
    (errs[errs.len() / 2], errs.len())
}

/// |ρ of the pixel's patch − ρ true| over pixels of floor, desks and walls, sorted.
fn reflectance_errors(c: &Commissioned, capture: &str) -> Vec<f64> {
    let gt = common::office_a().join(capture).join("groundtruth");
    let albedo = image::open(gt.join("albedo.png"))
        .expect("albedo.png")
        .to_luma16();
    let (lab, names) = labels(capture);
    let wanted: Vec<u16> = names
        .iter()
        .filter(|(_, n)| n == "floor" || n.starts_with("desk_") || n.starts_with("wall_"))
        .map(|(k, _)| *k)
        .collect();
    let cam = c.scene.camera.as_ref().expect("camera");
    let caster = RayCaster::new(&c.model.patches);
    let mut errs = Vec::new();
    for v in (0..cam.height).step_by(2) {
        for u in (0..cam.width).step_by(2) {
            let i = (v * cam.width + u) as usize;
            if !wanted.contains(&lab[i]) {
                continue;
            }
            let Hit::Front { patch, .. } = caster.closest(
                cam.position_m,
                cam.ray_world(f64::from(u), f64::from(v)).unwrap(),
            ) else {
                continue;
            };
            let est = c.model.patches.rho[patch as usize];
            let truth = f64::from(albedo.get_pixel(u, v)[0]) / 10000.0;
            errs.push((est - truth).abs());
        }
    }
    errs.sort_by(f64::total_cmp);
    errs
}

#[test]
fn office_a_noisy_capture_meets_the_accuracy_bounds() {
    let c = run("capture", &CommissionOptions::default());
    let view = in_view("capture");
    assert_eq!(view, vec![2, 3, 4, 5, 6, 7]);
    let (e, worst, each) = errors(&c, &view);
    eprintln!("noisy capture, in view: {e:.4} worst {worst:.4} {each:?}");
    // measured 3.9 % and 7.5 %; the issue's bounds are 6 % and 12 %
    assert!(e <= 0.05, "in-view error {e}");
    assert!(worst <= 0.10, "worst in-view sensor {worst}");
    // flags agree with the test-side visibility
    for (id, f) in c.model.sensor_ids.iter().zip(&c.sensor_flags) {
        assert_eq!(
            view.contains(id),
            f & sensor_flags::OUT_OF_VIEW == 0,
            "sensor {id}"
        );
    }
    // reflectances against the albedo image (test side only)
    let (med, n) = reflectance_error(&c, "capture");
    eprintln!("reflectance median abs error {med:.4} over {n} pixels");
    assert!(n > 5000);
    assert!(med <= 0.03, "median |Δρ| {med}");
    // what was found: a floor and desk tops
    let r = &c.report;
    assert!(
        r.planes
            .iter()
            .any(|p| p.normal.z > 0.99 && p.origin_m.z.abs() < 0.02 && p.area_m2 > 10.0)
    );
    assert!(
        r.planes
            .iter()
            .filter(|p| p.normal.z > 0.99 && (p.origin_m.z - 0.75).abs() < 0.02)
            .count()
            >= 3
    );
    let room = r.room.as_ref().expect("closed");
    assert!((room.ceiling_z_m - 3.0).abs() < 0.02 && (room.xy_m[2] - 6.0).abs() < 0.1);
    // each sensor's stated uncertainty against its error over the 31 scenarios (all 8):
    // measured 7 of 8 within one (sensor 2, in a monitor's shadow, is not), all within two
    let all: Vec<u32> = c.model.sensor_ids.clone();
    let (_, _, each) = errors(&c, &all);
    let (mut one, mut two) = (0, 0);
    for (id, e) in &each {
        let u = r
            .uncertainty
            .iter()
            .find(|u| u.sensor_id == *id)
            .expect("stated");
        eprintln!(
            "sensor {id}: error {:.1} %, stated {:.1} % ({} {:.0} %)",
            100.0 * e,
            100.0 * u.rel,
            u.dominant().0.name(),
            100.0 * u.dominant().1
        );
        one += usize::from(*e <= u.rel);
        two += usize::from(*e <= 2.0 * u.rel);
    }
    assert!(
        one >= 6 && two == 8,
        "{one} and {two} of 8 within one and two"
    );
}

#[test]
fn closure_of_the_unseen_room_measurably_helps() {
    let mut o = CommissionOptions::default();
    o.closure.enabled = false;
    let c = run("capture", &o);
    let view = in_view("capture");
    let (e_open, _, each) = errors(&c, &view);
    eprintln!("no closure, in view: {e_open:.4} {each:?}");
    // with closure: 3.9 % (office_a_noisy_capture_meets_the_accuracy_bounds)
    assert!(
        e_open > 0.10,
        "without closure the error should be large, is {e_open}"
    );
    // and the open model reads low (light escapes)
    let levels = vec![1.0; c.model.luminaires()];
    let lux = c.model.sensor_lux(&levels).expect("lux");
    let truth = read_truth(&common::office_a().join("truth.csv")).expect("truth");
    for (k, id) in c.model.sensor_ids.iter().enumerate() {
        if view.contains(id) {
            let t = truth
                .iter()
                .find(|r| r.scenario == "9" && r.sensor == *id)
                .expect("row")
                .lux;
            assert!(lux[k] < t, "sensor {id}: {} >= {t}", lux[k]);
        }
    }
}

#[test]
fn clean_capture_and_a_luxmeter_gain() {
    let c = run("capture_clean", &CommissionOptions::default());
    let view = in_view("capture_clean");
    let (e, worst, each) = errors(&c, &view);
    eprintln!("clean capture, in view: {e:.4} worst {worst:.4} {each:?}");
    assert!(e <= 0.05 && worst <= 0.10);
    let errs = reflectance_errors(&c, "capture_clean");
    eprintln!(
        "clean capture, median method: |Δρ| median {:.4}, 90th percentile {:.4} over {} pixels",
        errs[errs.len() / 2],
        errs[errs.len() * 9 / 10],
        errs.len()
    );
    // measured 0.0079 and 0.0181: better than the SH fit (0.0122, 0.0263)
    assert!(errs[errs.len() / 2] <= 0.01 && errs[errs.len() * 9 / 10] <= 0.025);
    // gain from one luxmeter reading (sensor 7, all on) instead of camera.json
    let truth = read_truth(&common::office_a().join("truth.csv")).expect("truth");
    let lux = truth
        .iter()
        .find(|r| r.scenario == "9" && r.sensor == 7)
        .expect("row")
        .lux;
    let o = CommissionOptions {
        gain: Gain::Luxmeter {
            sensor_id: 7,
            lux_lx: lux,
            levels: vec![1.0; 8],
        },
        ..CommissionOptions::default()
    };
    let c = run("capture_clean", &o);
    let g = c.report.reflectance.gain_cd_m2_per_unit;
    let (e, worst, _) = errors(&c, &view);
    eprintln!("luxmeter gain {g:.5} (camera.json 0.02), in view {e:.4} worst {worst:.4}");
    // the model reproduces the reading it was calibrated on
    let levels = vec![1.0; c.model.luminaires()];
    let k = c
        .model
        .sensor_ids
        .iter()
        .position(|&s| s == 7)
        .expect("sensor 7");
    let read = c.model.sensor_lux(&levels).expect("lux")[k];
    assert!(
        (read / lux - 1.0).abs() < 0.01,
        "reads {read}, luxmeter {lux}"
    );
    // a desk reading depends weakly on the reflectances (indirect light is about a quarter of
    // it), so a small model bias moves the gain a lot: measured 0.029 against camera.json's 0.02
    assert!(g > 0.01 && g < 0.04, "gain {g}");
    assert!(e <= 0.06 && worst <= 0.12);
}

/// Issue 34: commissioning that should fail does not write an image: every one-luminaire frame
/// black, one luminaire's frame the all-off frame, the sensors a metre under the floor.
#[test]
fn commissioning_refuses_dark_frames_and_dark_sensors() {
    let o = CommissionOptions::default();
    let fails = |cap: &luxnode::camera::capture::Capture, sensors: Vec<luxnode::scene::Sensor>| {
        let (lums, _, _) = inputs("capture_clean");
        match commission::from_capture(cap, lums, sensors, None, &o) {
            Ok(_) => panic!("commissioned"),
            Err(e) => e.to_string(),
        }
    };
    let (_, sensors, cap) = inputs("capture_clean");
    let mut black = cap.clone();
    for (_, f) in &mut black.luminance {
        f.data.iter_mut().for_each(|v| *v = 0);
    }
    let err = fails(&black, sensors.clone());
    assert!(err.contains("no one-luminaire frame shows light"), "{err}");
    let mut one_dark = cap.clone();
    let id = one_dark.luminance[2].0;
    one_dark.luminance[2].1.data.iter_mut().for_each(|v| *v = 0);
    let err = fails(&one_dark, sensors.clone());
    assert!(
        err.contains(&format!("luminaire {id}:")) && err.contains("dead lamp"),
        "{err}"
    );
    let mut under = sensors.clone();
    for s in &mut under {
        s.position_m.z -= 1.75;
    }
    let err = fails(&cap, under);
    assert!(
        err.contains("gets") && err.contains("under the floor"),
        "{err}"
    );
}

/// Issue 34: a luxmeter gain reading the model cannot reproduce (klx typed as lx: 1.28 for
/// 1280) is refused like a `--luxmeter-rho` reading, not written into an image with a warning.
#[test]
fn a_luxmeter_gain_reading_in_the_wrong_unit_is_refused() {
    let (lums, sensors, cap) = inputs("capture_clean");
    let o = CommissionOptions {
        gain: Gain::Luxmeter {
            sensor_id: 7,
            lux_lx: 1.28,
            levels: vec![1.0; 8],
        },
        ..CommissionOptions::default()
    };
    let err = match commission::from_capture(&cap, lums, sensors, None, &o) {
        Ok(_) => panic!("a 1.28 lx reading under every luminaire at full was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("1.3 lx at sensor 7") && err.contains("klx"),
        "{err}"
    );
}

/// Luxmeter readings with every luminaire at full set the reflectance of the walls and ceiling
/// nobody saw (office_a's are 0.6 and 0.8; the defaults 0.5 and 0.7 read every desk low).
#[test]
fn luxmeter_readings_set_the_unseen_walls_and_ceiling() {
    let truth = read_truth(&common::office_a().join("truth.csv")).expect("truth");
    let all_on = |id: u32| Reading {
        sensor_id: id,
        lux_lx: truth
            .iter()
            .find(|r| r.scenario == "9" && r.sensor == id)
            .expect("row")
            .lux,
    };
    let view = in_view("capture");
    let all: Vec<u32> = (1..=8).collect();
    let plain = run("capture", &CommissionOptions::default());
    let (view_before, _, _) = errors(&plain, &view);
    let (all_before, _, _) = errors(&plain, &all);
    let stated =
        |c: &Commissioned| -> Vec<f64> { c.report.uncertainty.iter().map(|u| u.rel).collect() };
    // one reading at a desk in view; three at desks of which two are out of view
    // (docs/commissioning.md: measured in view 3.60 -> 2.47 % and 2.10 %, all 4.14 -> 2.55 %
    // and 2.10 %, walls 0.546 and 0.579)
    for (ids, view_bound, all_bound, wall_above) in [
        (vec![7], 0.028, 0.029, 0.53),
        (vec![1, 4, 8], 0.024, 0.024, 0.56),
    ] {
        let o = CommissionOptions {
            readings: ids.iter().map(|&i| all_on(i)).collect(),
            ..CommissionOptions::default()
        };
        let c = run("capture", &o);
        let f = c.report.reflectance_fit.clone().expect("fitted");
        let (e_view, _, _) = errors(&c, &view);
        let (e_all, _, each) = errors(&c, &all);
        eprintln!(
            "readings at {ids:?}: walls {:.3} ceiling {:.3} (± {:.3}, {:.3}); in view {:.4} \
             (before {view_before:.4}), all {e_all:.4} (before {all_before:.4}) {each:?}",
            f.wall_rho.1, f.ceiling_rho.1, f.sigma_after.0, f.sigma_after.1, e_view
        );
        assert!(
            e_view <= view_bound && e_all <= all_bound,
            "{e_view} {e_all}"
        );
        assert!(e_view < view_before && e_all < all_before);
        // toward the truth (0.6, 0.8), from the defaults, never past it by far
        assert!(f.wall_rho.1 > wall_above && f.wall_rho.1 < 0.65, "{f:?}");
        assert!(f.ceiling_rho.1 >= 0.7 && f.ceiling_rho.1 < 0.85, "{f:?}");
        // the readings are reproduced to their stated few per cent
        let lux = c.model.sensor_lux(&[1.0; 8]).expect("lux");
        for r in &o.readings {
            let k = c
                .model
                .sensor_ids
                .iter()
                .position(|&s| s == r.sensor_id)
                .expect("id");
            assert!(
                (lux[k] / r.lux_lx - 1.0).abs() < 0.03,
                "{} {}",
                lux[k],
                r.lux_lx
            );
        }
        // what the readings taught narrows every desk's stated uncertainty, which still covers
        // every desk's error within two (measured 7 and 6 of 8 within one)
        for (a, b) in stated(&c).iter().zip(stated(&plain)) {
            assert!(*a < b, "{a} >= {b}");
        }
        for (id, e) in &each {
            let u = c
                .report
                .uncertainty
                .iter()
                .find(|u| u.sensor_id == *id)
                .expect("stated");
            assert!(
                *e <= 2.0 * u.rel,
                "sensor {id}: error {e}, stated {}",
                u.rel
            );
        }
    }
    // bad readings are refused before any work, never fitted
    let (lums, sensors, cap) = inputs("capture");
    for o in [
        CommissionOptions {
            readings: vec![Reading {
                sensor_id: 99,
                lux_lx: 500.0,
            }],
            ..CommissionOptions::default()
        },
        CommissionOptions {
            readings: vec![Reading {
                sensor_id: 7,
                lux_lx: f64::NAN,
            }],
            ..CommissionOptions::default()
        },
        CommissionOptions {
            readings: vec![all_on(7)],
            gain: Gain::Luxmeter {
                sensor_id: 7,
                lux_lx: 1282.0,
                levels: vec![1.0; 8],
            },
            ..CommissionOptions::default()
        },
    ] {
        let t = std::time::Instant::now();
        let e = commission::from_capture(&cap, lums.clone(), sensors.clone(), None, &o);
        assert!(
            e.is_err() && t.elapsed().as_secs_f64() < 1.0,
            "{:?}",
            o.readings
        );
    }
}

fn down_camera(w: u32, h: u32) -> Camera {
    Camera {
        position_m: DVec3::new(0.0, 0.0, 3.0),
        world_from_camera: DMat3::from_cols(DVec3::Y, DVec3::X, DVec3::NEG_Z),
        fx: 100.0,
        fy: 100.0,
        cx: f64::from(w) / 2.0 - 0.5,
        cy: f64::from(h) / 2.0 - 0.5,
        width: w,
        height: h,
        luminance_cd_m2_per_unit: Some(0.01),
        lens: Default::default(),
    }
}

/// Depth (mm along the axis) of a floor at z = 0 with a box top 1 m × 0.8 m at z = 0.9 m
/// centred at (0.3, -0.2), seen from 3 m; ±`noise_mm` of deterministic noise.
fn synthetic_depth(cam: &Camera, noise_mm: f64, seed: u64) -> Frame {
    let mut rng = luxnode::rng::SplitMix64::new(seed);
    let mut data = Vec::new();
    for v in 0..cam.height {
        for u in 0..cam.width {
            let d = cam.ray_world(f64::from(u), f64::from(v)).unwrap();
            let t_floor = 3.0 / -d.z;
            let t_box = 2.1 / -d.z;
            let p = cam.position_m + d * t_box;
            let on_box = (p.x - 0.3).abs() <= 0.5 && (p.y + 0.2).abs() <= 0.4;
            let t = if on_box { t_box } else { t_floor };
            let z_cam = t * -d.z; // along the optical axis (down)
            let mm = z_cam * 1000.0 + noise_mm * (2.0 * rng.next_f64() - 1.0);
            data.push(mm.round() as u16);
        }
    }
    Frame {
        width: cam.width,
        height: cam.height,
        data,
    }
}

#[test]
fn planes_of_synthetic_depth_have_the_known_heights_and_areas() {
    let cam = down_camera(160, 120);
    let frames: Vec<Frame> = (0..3).map(|s| synthetic_depth(&cam, 20.0, s)).collect();
    let d = depth::fuse(&frames, &depth::DepthOptions::default()).expect("fuses");
    let g = grid::PointGrid::new(&d, &cam, 2, 0.03);
    let found = planes::detect(&g, &cam, &planes::PlaneOptions::default());
    let horizontal: Vec<_> = found.iter().filter(|p| p.normal.z > 0.999).collect();
    assert_eq!(horizontal.len(), 2, "{found:?}");
    let top = horizontal
        .iter()
        .find(|p| p.origin_m.z > 0.5)
        .expect("box top");
    let floor = horizontal
        .iter()
        .find(|p| p.origin_m.z < 0.5)
        .expect("floor");
    assert!((top.origin_m.z - 0.9).abs() < 0.01, "{}", top.origin_m.z);
    assert!(floor.origin_m.z.abs() < 0.01, "{}", floor.origin_m.z);
    assert!((top.origin_m.x - 0.3).abs() < 0.03 && (top.origin_m.y + 0.2).abs() < 0.03);
    // meshed area of the box top: 0.8 m² (cells quantise the outline)
    let mut m = commission::RecoMesh::default();
    commission::mesh::mesh_plane(
        &mut m,
        &g,
        top,
        0,
        &commission::MeshOptions::default(),
        None,
        None,
        &[],
        None,
    );
    let area: f64 = (0..m.tris.len()).map(|t| m.area_m2(t)).sum();
    assert!((area - 0.8).abs() < 0.08, "area {area}");
    assert!(
        m.tris.len() <= 8,
        "{} triangles for one rectangle",
        m.tris.len()
    );
}

fn write_png16(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> u16) {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |u, v| {
        image::Luma([f(u, v)])
    });
    img.save(path).expect("png");
}

fn write_capture(dir: &Path, lum_ids: &[u32]) {
    let cam = r#"{"position":[0,0,3],"R_world_from_camera":[[0,1,0],[1,0,0],[0,0,-1]],
        "width":40,"height":30,"fx":20,"fy":20,"cx":19.5,"cy":14.5,"luminance_cd_m2_per_unit":0.02}"#;
    std::fs::write(dir.join("camera.json"), cam).expect("camera");
    write_png16(&dir.join("depth_000.png"), 40, 30, |_, _| 3000);
    for id in lum_ids {
        write_png16(&dir.join(format!("luminance_L{id}.png")), 40, 30, |_, _| {
            1000
        });
    }
}

#[test]
fn bad_capture_input_is_an_error_or_a_counted_warning() {
    let tmp = tempfile::tempdir().expect("tmp");
    let d = tmp.path();
    write_capture(d, &[1, 2]);
    assert!(Capture::load(d, &[1, 2]).is_ok());
    // a missing luminaire frame
    let e = Capture::load(d, &[1, 2, 3]).expect_err("missing frame");
    assert!(e.to_string().contains("luminance_L3"), "{e}");
    // a frame of another size
    write_png16(&d.join("luminance_L2.png"), 20, 30, |_, _| 1000);
    let e = Capture::load(d, &[1, 2]).expect_err("size");
    assert!(e.to_string().contains("20x30"), "{e}");
    // an 8-bit frame
    image::GrayImage::from_pixel(40, 30, image::Luma([9]))
        .save(d.join("luminance_L2.png"))
        .expect("png");
    let e = Capture::load(d, &[1, 2]).expect_err("8 bit");
    assert!(e.to_string().contains("16-bit"), "{e}");
    // a dark frame and a saturated one: counted warnings
    write_png16(&d.join("luminance_L1.png"), 40, 30, |_, _| 0);
    write_png16(&d.join("luminance_L2.png"), 40, 30, |_, _| u16::MAX);
    let c = Capture::load(d, &[1, 2]).expect("loads with warnings");
    assert_eq!(c.warnings.len(), 3, "{:?}", c.warnings); // dark, saturated, and (saturated = not lit)
    // all-zero depth: the only frame is ignored, then no usable depth is an error
    write_png16(&d.join("depth_000.png"), 40, 30, |_, _| 0);
    let e = Capture::load(d, &[1, 2]).expect_err("no depth");
    assert!(e.to_string().contains("no usable depth"), "{e}");
    // no depth frames at all
    std::fs::remove_file(d.join("depth_000.png")).expect("rm");
    assert!(Capture::load(d, &[1, 2]).is_err());
    // not a capture directory
    assert!(Capture::load(&d.join("nope"), &[1]).is_err());
    // a corrupt PNG
    write_capture(d, &[1]);
    std::fs::write(d.join("depth_000.png"), b"not a png").expect("write");
    assert!(Capture::load(d, &[1]).is_err());
}

#[test]
fn noise_only_depth_is_rejected_not_meshed() {
    // salt noise: every pixel disagrees with its neighbours, so cleaning leaves nothing
    let cam = down_camera(64, 48);
    let mut rng = luxnode::rng::SplitMix64::new(3);
    let data = (0..64 * 48)
        .map(|_| 500 + (rng.next_u64() % 5000) as u16)
        .collect();
    let f = Frame {
        width: 64,
        height: 48,
        data,
    };
    let e = depth::fuse(&[f], &depth::DepthOptions::default()).expect_err("noise");
    assert!(e.to_string().contains("depth unusable"), "{e}");
    let _ = cam;
}

#[test]
fn spherical_harmonic_reflectance_fit_on_the_clean_capture() {
    let mut o = CommissionOptions::default();
    o.reflectance.method = ReflectanceMethod::SphericalHarmonics;
    let c = run("capture_clean", &o);
    let view = in_view("capture_clean");
    let (e, worst, each) = errors(&c, &view);
    let (e_all, _, _) = errors(&c, &(1..=8).collect::<Vec<u32>>());
    let errs = reflectance_errors(&c, "capture_clean");
    let (med, p90) = (errs[errs.len() / 2], errs[errs.len() * 9 / 10]);
    eprintln!(
        "clean capture, SH fit: in view {e:.4} worst {worst:.4} all {e_all:.4} {each:?}; \
         |Δρ| median {med:.4}, 90th percentile {p90:.4} over {} pixels; floor {:?}, {} clamped",
        errs.len(),
        c.report.reflectance.floor_rho,
        c.report.reflectance.clamped
    );
    // measured: see docs/commissioning.md (SH fit row); bounds with margin
    assert!(errs.len() > 5000);
    assert!(med <= SH_RHO_MEDIAN_BOUND, "median |Δρ| {med}");
    assert!(p90 <= SH_RHO_P90_BOUND, "90th percentile |Δρ| {p90}");
    assert!(e <= SH_IN_VIEW_BOUND && worst <= 0.10, "{e} {worst}");
    let floor = c.report.reflectance.floor_rho.expect("floor");
    assert!((floor - 0.25).abs() < 0.02, "floor {floor}");
}

#[test]
fn several_capture_sets_are_checked_before_any_work() {
    let (lums, sensors, cap) = inputs("capture");
    let go = |caps: &[Capture], o: &CommissionOptions| {
        commission::from_captures(caps, lums.clone(), sensors.clone(), None, o)
            .map(|v| v.len())
            .map_err(|e| e.to_string())
    };
    let o = CommissionOptions::default();
    assert!(go(&[], &o).unwrap_err().contains("no capture set"));
    // more nodes than one room takes: refused at once, nothing fused
    let t0 = std::time::Instant::now();
    let many = vec![cap.clone(); commission::MAX_NODES + 1];
    assert!(go(&many, &o).unwrap_err().contains("at most 16 nodes"));
    assert!(t0.elapsed().as_secs_f64() < 1.0);
    // a luxmeter gain is for one node
    let lux = CommissionOptions {
        gain: Gain::Luxmeter {
            sensor_id: 7,
            lux_lx: 1000.0,
            levels: vec![1.0; 8],
        },
        ..CommissionOptions::default()
    };
    let pair = [cap.clone(), cap.clone()];
    assert!(go(&pair, &lux).unwrap_err().contains("camera.json"));
    // every camera needs its gain
    let mut no_gain = cap.clone();
    no_gain.camera.luminance_cd_m2_per_unit = None;
    let e = go(&[cap.clone(), no_gain], &o).unwrap_err();
    assert!(
        e.contains("capture set 2") && e.contains("luminance_cd_m2_per_unit"),
        "{e}"
    );
    // a camera at a wrong pose in the second set: which set says so
    let mut far = cap.clone();
    far.camera.position_m.x = f64::NAN;
    let e = go(&[cap, far], &o).unwrap_err();
    assert!(
        e.contains("capture set 2") && e.contains("camera position"),
        "{e}"
    );
}

/// office_a's room plan: its true outline, ceiling and window (from scene.obj).
const OFFICE_A_PLAN: &str = r#"{
  "format": "luxnode-room-plan/1",
  "outline_m": [[0.0, 0.0], [6.0, 0.0], [6.0, 7.2], [0.0, 7.2]],
  "floor_z_m": 0.0,
  "ceiling_z_m": 3.0,
  "windows": [{"id": "window_1", "transmittance": 0.7,
    "corners_m": [[1.0, 7.2, 0.9], [5.0, 7.2, 0.9], [5.0, 7.2, 2.4], [1.0, 7.2, 2.4]]}]
}"#;

#[test]
fn a_room_plan_builds_the_unseen_walls_and_window_and_every_desk_improves() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("room.json");
    // the plan with office_a's measured reflectances (scene.mtl: walls 0.6, ceiling 0.8), and
    // the box given the same: what the plan's geometry does, apart from the reflectances
    let with_rho = OFFICE_A_PLAN.replace(
        "\"ceiling_z_m\": 3.0,",
        "\"ceiling_z_m\": 3.0, \"wall_rho\": 0.6, \"ceiling_rho\": 0.8,",
    );
    std::fs::write(&path, with_rho).expect("write");
    let (plan, warnings) = luxnode::scene::RoomPlan::load(&path).expect("plan");
    assert!(warnings.is_empty(), "{warnings:?}");
    let mut o = CommissionOptions::default();
    o.closure.wall_rho = 0.6;
    o.closure.ceiling_rho = 0.8;
    let boxed = run("capture", &o);
    let o = CommissionOptions {
        room_plan: Some(plan),
        ..CommissionOptions::default()
    };
    let planned = run("capture", &o);
    let r = &planned.report;
    // the camera sees the room where the plan says it is: no warning about the plan
    assert!(
        !r.warnings.iter().any(|w| w.contains("room plan")),
        "{:?}",
        r.warnings
    );
    let room = r.room.as_ref().expect("closed");
    // the seen walls stand within the depth noise of the plan's: at most 15 cm out
    for (got, want) in room.xy_m.iter().zip([0.0, 0.0, 6.0, 7.2]) {
        assert!((got - want).abs() <= 0.15, "{:?}", room.xy_m);
    }
    // the window is modelled as glazing, 4 × 1.5 m (to the wall raster's cells)
    let glazing: f64 = (0..planned.reco.tris.len())
        .filter(|&t| planned.reco.part[t] == commission::Part::Window(0))
        .map(|t| planned.reco.area_m2(t))
        .sum();
    assert!((glazing - 6.0).abs() < 0.05 * 5.5, "glazing {glazing} m²");
    let all: Vec<u32> = planned.model.sensor_ids.clone();
    let (e_box, worst_box, _) = errors(&boxed, &all);
    let (e_plan, worst_plan, each) = errors(&planned, &all);
    eprintln!(
        "every desk: box {e_box:.4} (worst {worst_box:.4}), plan {e_plan:.4} (worst \
         {worst_plan:.4}) {each:?}"
    );
    // measured (release build, `luxnode commission --room-plan`): box 2.9 % (worst 5.9 %),
    // plan 1.0 % (worst 2.9 %)
    // live light's daylight enters through the plan's window (out of view): its glazing is
    // the only emitter
    let (_, _, cap) = inputs("capture");
    let section = luxnode::live_section::from_capture(&planned, &cap, &Default::default())
        .expect("live section");
    let p = &planned.model.patches;
    let groups = &planned.scene.mesh.groups;
    let mut emitting = 0;
    for (i, &e) in section.patch_emitter.iter().enumerate() {
        if e != luxnode::store::live::NO_EMITTER {
            emitting += 1;
            assert!(
                groups[p.group[i] as usize].starts_with("window_"),
                "patch {i}"
            );
        }
    }
    assert!(emitting > 0 && section.n_emitters >= 1);
    assert!(e_plan < e_box, "plan {e_plan} vs box {e_box}");
    assert!(
        e_plan <= 0.02 && worst_plan <= 0.045,
        "{e_plan} {worst_plan}"
    );
}

/// Issue 34: a camera whose pose in camera.json disagrees with what it sees is refused before
/// any meshing: its position 100 m off (the floor it sees then lies 97 m above the luminaires),
/// 100 m off horizontally only, its yaw turned 180° (every luminaire's light then lies under
/// another one). The genuine captures pass, every luminaire in view within a few decimetres;
/// a pair of swapped luminaire frames (DALI addresses) is a warning naming both.
#[test]
fn a_camera_pose_that_disagrees_with_what_it_sees_is_refused() {
    use luxnode::commission::pose::{self, DISAGREE_M, PoseError};
    let o = CommissionOptions::default();
    let (lums, sensors, cap) = inputs("capture_clean");
    for name in ["capture", "capture_clean"] {
        let (_, _, c) = inputs(name);
        let r = pose::check_captures(std::slice::from_ref(&c), &lums, &o).expect("genuine");
        let p = &r.pose[0];
        eprintln!("{name}: {p:?}, warnings {:?}", r.warnings);
        // office_a: luminaires at 2.997 m over a floor at 0 (independent: luminaires.json)
        let above = p.luminaires_above_floor_m.expect("floor seen");
        assert!((above - 2.997).abs() < 0.05, "{above}");
        assert!(p.offsets_m.len() >= 4, "{:?}", p.offsets_m);
        assert!(
            p.offsets_m.iter().all(|&(_, d)| d < 0.5 * DISAGREE_M),
            "{p:?}"
        );
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        // docs/field.md: 0.97 on both
        assert!(p.dominant_agreement.is_some_and(|a| a > 0.9), "{p:?}");
    }
    let refuse = |c: &Capture| -> (PoseError, String) {
        let t0 = std::time::Instant::now();
        let e = match commission::from_capture(c, lums.clone(), sensors.clone(), None, &o) {
            Ok(_) => panic!("commissioned with a wrong pose"),
            Err(e) => e,
        };
        let dt = t0.elapsed().as_secs_f64();
        eprintln!("refused in {dt:.2} s: {e}");
        assert!(dt < 10.0, "{dt} s");
        let msg = e.to_string();
        match e {
            commission::CommissionError::Pose(p) => (*p, msg),
            other => panic!("not a pose error: {other}"),
        }
    };
    let mut far = cap.clone();
    far.camera.position_m = DVec3::new(100.0, 100.0, 100.0);
    let (e, msg) = refuse(&far);
    assert!(
        matches!(
            e,
            PoseError::Height { floor_z_m, expected_z_m, .. }
                if (floor_z_m - 97.02).abs() < 0.1
                    && expected_z_m[0] < 2.98 && expected_z_m[1] > 2.98
                    && expected_z_m[1] - expected_z_m[0] < 5.0
        ),
        "{msg}"
    );
    assert!(
        msg.contains("camera.json position (100.00, 100.00, 100.00)"),
        "{msg}"
    );
    let mut aside = cap.clone();
    aside.camera.position_m.x += 100.0;
    let (e, msg) = refuse(&aside);
    assert!(
        matches!(e, PoseError::FarFromLuminaires { nearest_m, .. } if nearest_m > 90.0),
        "{msg}"
    );
    // the yaw turned 180° about the vertical: R_world_from_camera's x and y columns negated
    // (as camera.json's right and up negated with look kept)
    let mut turned = cap.clone();
    turned.camera.world_from_camera =
        DMat3::from_rotation_z(std::f64::consts::PI) * turned.camera.world_from_camera;
    let (e, msg) = refuse(&turned);
    assert!(
        matches!(
            e,
            PoseError::Yaw { disagree, in_view, rotation: Some((180, false)), .. }
                if 2 * disagree > in_view
        ),
        "{msg}"
    );
    assert!(
        msg.contains("yaw/rotation in camera.json looks wrong by about 180°"),
        "{msg}"
    );
    // two luminaires' frames swapped (a DALI address mix-up): a warning names each
    let mut swapped = cap.clone();
    let (a, b) = (
        swapped.luminance[0].1.clone(),
        swapped.luminance[1].1.clone(),
    );
    swapped.luminance[0].1 = b;
    swapped.luminance[1].1 = a;
    let r = pose::check_captures(std::slice::from_ref(&swapped), &lums, &o).expect("a warning");
    eprintln!("swapped: {:?} {:?}", r.pose[0].offsets_m, r.warnings);
    for id in [lums[0].id, lums[1].id] {
        assert!(
            r.warnings
                .iter()
                .any(|w| w.contains(&format!("luminaire {id}:")) && w.contains("DALI address")),
            "{id}: {:?}",
            r.warnings
        );
    }
}

/// Issue 34: a luxmeter reading 1.9 times the model (office_a's truth at sensor 7 times 1.9)
/// pins the walls and ceiling at the 0.9 limit and leaves the model about a third below it:
/// refused, naming the reading, the model's value and the limits, unless forced; forced, the
/// report warns and every desk is flagged estimated in the image.
#[test]
fn a_luxmeter_refit_at_its_limits_is_refused_unless_forced() {
    let truth = read_truth(&common::office_a().join("truth.csv")).expect("truth");
    let true_lx = truth
        .iter()
        .find(|r| r.scenario == "9" && r.sensor == 7)
        .expect("row")
        .lux;
    let (lums, sensors, cap) = inputs("capture");
    let mut o = CommissionOptions {
        readings: vec![Reading {
            sensor_id: 7,
            lux_lx: 1.9 * true_lx,
        }],
        ..CommissionOptions::default()
    };
    let t0 = std::time::Instant::now();
    let e = match commission::from_capture(&cap, lums.clone(), sensors.clone(), None, &o) {
        Ok(_) => panic!("a reading 1.9 times the truth was fitted"),
        Err(e) => e,
    };
    eprintln!("refused in {:.1} s: {e}", t0.elapsed().as_secs_f64());
    let commission::CommissionError::RefitAtLimit(at) = &e else {
        panic!("{e}");
    };
    assert_eq!(at.sensor_id, 7);
    // the model at the limits stays 20 to 50 % below the reading (issue 34: 35 %)
    let short = 1.0 - at.model_lx / at.reading_lx;
    assert!((0.2..0.5).contains(&short), "{short}: {e}");
    let msg = e.to_string();
    assert!(
        msg.contains("at its limit 0.90") && msg.contains("--force"),
        "{msg}"
    );
    o.force = true;
    let c = commission::from_capture(&cap, lums, sensors, None, &o).expect("forced");
    assert!(
        c.report
            .warnings
            .iter()
            .any(|w| w.starts_with("--force: luxmeter reading") && w.contains("sensor 7")),
        "{:?}",
        c.report.warnings
    );
    assert!(
        c.sensor_flags
            .iter()
            .all(|f| f & sensor_flags::ESTIMATED != 0),
        "{:?}",
        c.sensor_flags
    );
}

/// Issue 28 item 3: with a site, the plan's window the camera does not see gets daylight
/// coefficients in the image (what they cost in bytes is printed), and at run time the sky fit
/// with the frame's time finds no daylight in a night frame (a window behind closed blinds is
/// the fit's business, not an assumption).
#[test]
fn the_plans_unseen_window_gets_daylight_coefficients() {
    use luxnode::live::{Live, LiveFrame, LiveModel, LiveSettings, Source};
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("room.json");
    let with_site = OFFICE_A_PLAN.replace(
        "\"ceiling_z_m\": 3.0,",
        "\"ceiling_z_m\": 3.0, \"site\": {\"latitude_deg\": 47.4, \"longitude_deg\": 8.5, \
         \"north\": [0.0, 1.0]},",
    );
    std::fs::write(&path, with_site).expect("write");
    let (plan, warnings) = luxnode::scene::RoomPlan::load(&path).expect("plan");
    assert!(warnings.is_empty(), "{warnings:?}");
    let o = CommissionOptions {
        room_plan: Some(plan.clone()),
        ..CommissionOptions::default()
    };
    let planned = run("capture", &o);
    let (_, _, cap) = inputs("capture");
    let img =
        luxnode::image_build::build_image(&planned.model, &Default::default()).expect("image");
    let reserve =
        luxnode::daylight_section::reserve_bytes(Some(&plan), planned.scene.sensors.len());
    let img = luxnode::live_section::with_capture_section(img, &planned, &cap, reserve);
    let before = img.len();
    let img = luxnode::daylight_section::with_daylight_section(img, &planned, Some(&plan));
    // the room commissioning keeps for the section holds it (sky, sun and lists)
    assert!(
        img.len() - before <= reserve,
        "{} > {reserve}",
        img.len() - before
    );
    let parsed = luxnode::store::Image::parse(&img).expect("parse");
    let d = parsed.daylight.expect("a daylight section");
    eprintln!(
        "daylight coefficients: {} bytes for {} seen patches and {} sensors",
        img.len() - before,
        d.seen(),
        parsed.sensors()
    );
    assert_eq!(d.windows, 1);
    // the window's 4 × 1.5 m
    assert!(
        (d.window_area_m2 - 6.0).abs() < 1e-9,
        "{}",
        d.window_area_m2
    );
    // under a uniform sky of 1 cd/m² (ground dark) a receiver gets at most π τ_n lx through
    // the glazing plus what the room reflects of it; every desk gets some
    let uniform: Vec<f64> = (0..parsed.sensors())
        .map(|s| (0..145).map(|j| d.sensor_lx(s, j)).sum())
        .collect();
    assert!(
        uniform
            .iter()
            .all(|&e| e > 0.0 && e < std::f64::consts::PI * 0.7),
        "{uniform:?}"
    );
    // a night frame at noon: the sky fit finds no daylight
    let model = LiveModel::new(&parsed).expect("live model");
    let mut live = Live::new(model, LiveSettings::default()).expect("live");
    assert!(live.has_sky());
    live.set_time(luxnode::sky::parse_rfc3339("2026-03-21T11:26:00Z").ok());
    let gain = live.model().gain();
    let dir_cap = Path::new(env!("CARGO_MANIFEST_DIR")).join("reference/scenes/office_a/capture");
    let lum: Vec<luxnode::camera::capture::Frame> = (1..=8)
        .map(|k| {
            luxnode::camera::capture::read_frame16(&dir_cap.join(format!("luminance_L{k}.png")))
                .expect("frame")
        })
        .collect();
    // every luminaire on: the sum of the one-luminaire frames
    let sum: Vec<u16> = (0..lum[0].data.len())
        .map(|i| {
            lum.iter()
                .map(|f| u32::from(f.data[i]))
                .sum::<u32>()
                .min(65534) as u16
        })
        .collect();
    let frame = LiveFrame {
        width: lum[0].width,
        height: lum[0].height,
        luminance: &sum,
        cd_m2_per_unit: gain,
        depth_mm: None,
        taken_s: 0.0,
    };
    let desks = live
        .update(&frame, &[1.0; 8], 0.0)
        .expect("update")
        .to_vec();
    assert!(live.sky_type() > 0, "the sky was fitted");
    for desk in desks.iter().filter(|x| x.source == Source::Inferred) {
        assert!(
            desk.daylight_lx <= 0.02 * desk.total_lx,
            "desk {}: {} lx of daylight at night",
            desk.id,
            desk.daylight_lx
        );
    }
    assert!(desks.iter().any(|x| x.source == Source::Inferred));
}

/// Issue 28 item 5: a shade the mesh does not have (a luminaire's light halved on a desk, in its
/// one-luminaire frame only, the depth unchanged) is found by the model-against-camera check and
/// the desk's response to that luminaire calibrated by the frames, to the imposed factor; its
/// other luminaires keep the model's light and the desk is flagged.
#[test]
fn a_shade_the_mesh_lost_is_calibrated_from_the_one_luminaire_frames() {
    use luxnode::live_section::calibrate::calibrate_desks;
    let o = CommissionOptions::default();
    let (lums, sensors, cap) = inputs("capture_clean");
    let c = commission::from_capture(&cap, lums.clone(), sensors.clone(), None, &o)
        .expect("commissions");
    // the in-view desk with the most light, and its brightest luminaire
    let s = (0..c.model.sensors())
        .filter(|&k| c.sensor_flags[k] & sensor_flags::OUT_OF_VIEW == 0)
        .max_by(|&a, &b| {
            let t = |k: usize| c.model.response_lx[k].iter().sum::<f64>();
            t(a).total_cmp(&t(b))
        })
        .expect("an in-view desk");
    let row = c.model.response_lx[s].clone();
    let j = (0..row.len())
        .max_by(|&a, &b| row[a].total_cmp(&row[b]))
        .expect("a luminaire");
    let mut clean = vec![c];
    let before = calibrate_desks(&mut clean, std::slice::from_ref(&cap));
    let id = clean[0].model.sensor_ids[s];
    let lum_id = clean[0].model.luminaire_ids[j];
    let at = before.iter().find(|d| d.sensor_id == id).expect("measured");
    assert!(
        !at.replaced_luminaire_ids.contains(&lum_id),
        "the clean frames already disagree: {at:?}"
    );
    // halve luminaire j's light within 0.25 m of the desk sensor, in its frame only
    let camera = &cap.camera;
    let p = sensors[s].position_m;
    let (u0, v0) = camera.project_world(p).expect("in view");
    let (u1, _) = camera
        .project_world(p + DVec3::new(0.25, 0.0, 0.0))
        .expect("in view");
    let r_px = (u1 - u0).abs().max(3.0);
    let mut shaded = cap.clone();
    let f = &mut shaded.luminance[j].1;
    for v in 0..f.height {
        for u in 0..f.width {
            if (f64::from(u) - u0).hypot(f64::from(v) - v0) <= r_px {
                let x = &mut f.data[(v * f.width + u) as usize];
                *x /= 2;
            }
        }
    }
    let c = commission::from_capture(&shaded, lums, sensors, None, &o).expect("commissions");
    let model_row = c.model.response_lx[s].clone();
    let mut nodes = vec![c];
    let done = calibrate_desks(&mut nodes, std::slice::from_ref(&shaded));
    let at = done.iter().find(|d| d.sensor_id == id).expect("measured");
    assert!(at.replaced_luminaire_ids.contains(&lum_id), "{at:?}");
    assert!(nodes[0].sensor_flags[s] & sensor_flags::CALIBRATED != 0);
    let cal = &nodes[0].model.response_lx[s];
    let got = cal[j] / model_row[j];
    assert!(
        (got - 0.5).abs() <= 0.1,
        "luminaire {lum_id}: {got:.3} of the model's light, want 0.5"
    );
    for (k, (a, b)) in cal.iter().zip(&model_row).enumerate() {
        if k != j
            && !at
                .replaced_luminaire_ids
                .contains(&clean[0].model.luminaire_ids[k])
        {
            // the others keep the model's light, at most weighed toward the camera's scale
            // alike (a desk that took the desks' common reflectance)
            assert!(
                (a / b - at.scaled).abs() < 1e-9,
                "luminaire {k} changed: {a} for {b}, scaled {}",
                at.scaled
            );
        }
    }
    assert!((at.scaled - 1.0).abs() < 0.05, "{at:?}");
    // the image the node serves holds it (its response is re-derived from the stored direct,
    // first-bounce and gathered parts)
    let bytes =
        luxnode::image_build::build_image(&nodes[0].model, &Default::default()).expect("image");
    let image = luxnode::store::Image::parse(&bytes).expect("parses");
    let stored = image.response_lx(s, j);
    assert!(
        (stored / cal[j] - 1.0).abs() < 0.01,
        "the image serves {stored:.1} lx for {:.1}",
        cal[j]
    );
    println!(
        "sensor {id}: luminaire {lum_id} at {got:.3} of the model's light (imposed 0.5), camera \
         scale {:.3}; the image serves {stored:.1} lx",
        at.scale
    );
}

/// The pose check's outcome for capture_clean with camera.json moved by `shift_m` and turned
/// by `yaw_rad` about the vertical through the camera.
fn pose_outcome(
    cap: &Capture,
    lums: &[Luminaire],
    shift_m: DVec3,
    yaw_rad: f64,
) -> Result<luxnode::commission::pose::NodePose, luxnode::commission::pose::PoseError> {
    let mut c = cap.clone();
    c.camera.position_m += shift_m;
    c.camera.world_from_camera = DMat3::from_rotation_z(yaw_rad) * c.camera.world_from_camera;
    let o = CommissionOptions::default();
    match luxnode::commission::pose::check_captures(std::slice::from_ref(&c), lums, &o) {
        Ok(mut r) => Ok(r.pose.remove(0)),
        Err(commission::CommissionError::Pose(p)) => Err(*p),
        Err(e) => panic!("not a pose outcome: {e}"),
    }
}

/// Issue 34 item 5, the pose check as a property over the mistake's size (office_a's
/// capture_clean, fixed seed). camera.json's z off by `dz`: the seen floor moves with it, so
/// the luminaires' height above it is the genuine one less `dz` (luminaires.json, not the
/// check), and the pose is refused by the height check exactly when that leaves
/// [max(1, 0.3 h), h + 1] m, h the camera's height above the floor it sees. Its position within
/// 0.25 m and its yaw within 10°: accepted, with no warning. Its position 3.5 m or more off
/// horizontally, or its yaw 50..310° off: refused.
#[test]
fn the_pose_check_refuses_exactly_the_poses_that_do_not_fit() {
    use luxnode::commission::pose::{
        MAX_LUMINAIRE_ABOVE_CAMERA_M, MIN_LUMINAIRE_ABOVE_FLOOR_M, MIN_LUMINAIRE_ABOVE_FLOOR_SHARE,
        PoseError,
    };
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let (lums, _, cap) = inputs("capture_clean");
    let genuine = pose_outcome(&cap, &lums, DVec3::ZERO, 0.0).expect("genuine");
    let above0_m = genuine.luminaires_above_floor_m.expect("a floor");
    let h_m = cap.camera.position_m.z - genuine.floor_z_m.expect("a floor");
    let lo_m = MIN_LUMINAIRE_ABOVE_FLOOR_M.max(MIN_LUMINAIRE_ABOVE_FLOOR_SHARE * h_m);
    let hi_m = h_m + MAX_LUMINAIRE_ABOVE_CAMERA_M;
    let config = Config {
        cases: 40,
        rng_seed: RngSeed::Fixed(34),
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner = TestRunner::new(config.clone());
    runner
        .run(&(-3.0f64..6.0), |dz| {
            let above_m = above0_m - dz;
            if (above_m - lo_m).abs() < 0.02 || (above_m - hi_m).abs() < 0.02 {
                return Ok(());
            }
            let r = pose_outcome(&cap, &lums, DVec3::new(0.0, 0.0, dz), 0.0);
            let fits = (lo_m..=hi_m).contains(&above_m);
            proptest::prop_assert!(
                fits == r.is_ok() && (fits || matches!(r, Err(PoseError::Height { .. }))),
                "dz {dz}: luminaires {above_m:.3} m above the floor, {r:?}"
            );
            Ok(())
        })
        .expect("the height check");
    let mut runner = TestRunner::new(config.clone());
    runner
        .run(
            &(0.0f64..0.25, 0.0f64..6.3, -10.0f64..10.0),
            |(d, a, yaw_deg)| {
                let shift = DVec3::new(d * a.cos(), d * a.sin(), 0.0);
                let mut c = cap.clone();
                c.camera.position_m += shift;
                c.camera.world_from_camera =
                    DMat3::from_rotation_z(yaw_deg.to_radians()) * c.camera.world_from_camera;
                let o = CommissionOptions::default();
                let r =
                    luxnode::commission::pose::check_captures(std::slice::from_ref(&c), &lums, &o);
                let r = r.map_err(|e| e.to_string());
                proptest::prop_assert!(
                    matches!(&r, Ok(r) if r.warnings.is_empty()),
                    "{d:.2} m off, yaw {yaw_deg:.1}°: {:?}",
                    r.map(|r| r.warnings)
                );
                Ok(())
            },
        )
        .expect("small errors pass");
    let mut runner = TestRunner::new(config.clone());
    runner
        .run(&(3.5f64..60.0, 0.0f64..6.3), |(d, a)| {
            let r = pose_outcome(&cap, &lums, DVec3::new(d * a.cos(), d * a.sin(), 0.0), 0.0);
            proptest::prop_assert!(r.is_err(), "{d:.2} m off horizontally: {r:?}");
            Ok(())
        })
        .expect("a position metres off");
    let mut runner = TestRunner::new(config);
    runner
        .run(&(50.0f64..310.0), |yaw_deg| {
            let r = pose_outcome(&cap, &lums, DVec3::ZERO, yaw_deg.to_radians());
            proptest::prop_assert!(r.is_err(), "yaw {yaw_deg:.1}° off: {r:?}");
            Ok(())
        })
        .expect("a yaw far off");
}

/// The walls nobody saw take the reflectance of the walls the camera saw (their pixels' median):
/// the demo office (walls 0.60, its door 0.35 and window band 0.10 on them) seen from its
/// ceiling camera with the sim-fisheye board's optics (a Kannala-Brandt fisheye, about 170°
/// across), commissioned from the simulated capture at night. The seen walls give
/// 0.60 within 0.03, and the sensors' modelled light with every luminaire on is closer to the
/// world's own (the sim engine on the true scene) than with the walls at the 0.5 default: mean
/// |error| at most 0.7 of it (measured: walls 0.610 from 5478 pixels, 1.14 % against 2.25 %).
#[cfg(feature = "sim")]
#[test]
fn the_unseen_walls_take_the_seen_walls_reflectance() {
    use luxnode::camera::{SequenceOptions, capture_sequence_with};
    use luxnode::sim::camera::{SimDepthOptions, SimLuminanceOptions, SimWorld, WorldExtras};
    let mut scene = luxnode::sim::demo::demo_office();
    let cam = scene.camera.as_mut().unwrap();
    (cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy) =
        (320, 240, 105.0, 105.0, 159.5, 119.5);
    cam.lens = luxnode::scene::Lens::KannalaBrandt {
        k: [0.03, -0.008, 0.0005, 0.0],
    };
    let world = SimWorld::new(scene, &luxnode::sim::camera::world_settings()).unwrap();
    let ids = world.luminaire_ids();
    let mut depth = world.depth_camera(SimDepthOptions::default()).unwrap();
    let mut lum = world
        .luminance_camera(SimLuminanceOptions::default())
        .unwrap();
    let mut lights = world.clone();
    let seq = capture_sequence_with(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        &SequenceOptions::default(),
        &mut |_, _, _| {},
    )
    .unwrap();
    let sc = world.scene();
    let run = |from_seen: bool| {
        let mut o = CommissionOptions::default();
        o.closure.wall_rho_from_seen = from_seen;
        commission::from_capture(
            &seq.capture,
            sc.luminaires.clone(),
            sc.sensors.clone(),
            sc.desks.clone(),
            &o,
        )
        .unwrap()
    };
    let (seen, default) = (run(true), run(false));
    let (rho, pixels) = seen.report.reflectance.walls_rho.expect("walls seen");
    assert!((rho - 0.60).abs() < 0.03, "{rho} from {pixels} pixels");
    assert_eq!(default.report.reflectance.walls_rho, None);
    let all_on = vec![1.0; ids.len()];
    let truth = world.sensor_truth_lx(&all_on, &WorldExtras::default());
    let (a, b) = (
        seen.model.sensor_lux(&all_on).unwrap(),
        default.model.sensor_lux(&all_on).unwrap(),
    );
    let (mut sum_a, mut sum_b) = (0.0, 0.0);
    for (k, s) in sc.sensors.iter().enumerate() {
        let (ea, eb) = (a[k] / truth[k] - 1.0, b[k] / truth[k] - 1.0);
        eprintln!(
            "sensor {}: seen walls {:+.2} %, default {:+.2} %",
            s.id,
            100.0 * ea,
            100.0 * eb
        );
        sum_a += ea.abs();
        sum_b += eb.abs();
    }
    let n = sc.sensors.len() as f64;
    eprintln!(
        "walls {rho:.3} from {pixels} pixels; mean |error| {:.2} % against {:.2} %",
        100.0 * sum_a / n,
        100.0 * sum_b / n
    );
    assert!(sum_a < 0.7 * sum_b, "{sum_a} vs {sum_b}");
}

/// Issue 28 item 2: without a plan, where the walls nobody saw stand enters each desk's stated
/// uncertainty. Office_a's camera sees none of its walls above the desks: they are placed from
/// the seen extent, the luminaire grid and the sensors. The placement term (the model rebuilt with those
/// walls 0.5 m farther out, every surface at the first model's reflectance) is checked against
/// commissioning again from the frames with that box given: each desk's change with every
/// luminaire on agrees within 1 % of its light, the term is in the stated uncertainty, and a plan
/// removes it.
#[test]
fn the_unseen_walls_position_is_in_each_desks_stated_uncertainty() {
    let plain = run("capture", &CommissionOptions::default());
    let r = &plain.report;
    let unseen = r.unseen_wall_sides.expect("no plan: the box is inferred");
    eprintln!(
        "unseen: {unseen:?} box {:?}",
        r.room.as_ref().map(|b| b.xy_m)
    );
    let room = r.room.as_ref().expect("closed");
    let sigma = unseen.map(|u| {
        if u {
            commission::placement::UNSEEN_WALL_POSITION_SIGMA_M
        } else {
            0.0
        }
    });
    let grown = commission::placement::grown_box(room.xy_m, sigma).expect("grown");
    let mut o = CommissionOptions::default();
    o.closure.room_xy_m = Some(grown);
    o.closure.ceiling_z_m = Some(room.ceiling_z_m);
    let moved = run("capture", &o);
    assert_eq!(
        moved.report.unseen_wall_sides, None,
        "a given box is not inferred"
    );
    let on = vec![1.0; plain.model.luminaires()];
    let (a, b) = (
        plain.model.sensor_lux(&on).expect("lux"),
        moved.model.sensor_lux(&on).expect("lux"),
    );
    let mut largest = 0.0f64;
    for (k, u) in r.uncertainty.iter().enumerate() {
        let full = b[k] - a[k];
        eprintln!(
            "sensor {}: {:.1} lx, walls out: {full:+.2} lx (recommissioned) {:+.2} lx (stated \
             term), stated {:.2} %",
            u.sensor_id,
            a[k],
            u.wall_placement_lx,
            100.0 * u.rel
        );
        assert!(
            (u.wall_placement_lx - full).abs() <= 0.01 * a[k],
            "sensor {}: {} vs {full}",
            u.sensor_id,
            u.wall_placement_lx
        );
        assert!(u.rel * a[k] >= u.wall_placement_lx.abs() - 1e-9);
        largest = largest.max(u.wall_placement_lx.abs() / a[k]);
    }
    // walls farther out reflect less onto the desks: a term that is there
    assert!(largest > 0.003, "largest placement term {largest}");
    // with the plan the walls stand where it says
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("room.json");
    std::fs::write(&path, OFFICE_A_PLAN).expect("write");
    let (plan, _) = luxnode::scene::RoomPlan::load(&path).expect("plan");
    let planned = run(
        "capture",
        &CommissionOptions {
            room_plan: Some(plan),
            ..CommissionOptions::default()
        },
    );
    assert_eq!(planned.report.unseen_wall_sides, None);
    assert!(
        planned
            .report
            .uncertainty
            .iter()
            .all(|u| u.wall_placement_lx == 0.0)
    );
}
