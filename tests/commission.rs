//! Commissioning from a capture set, against independent references: the Radiance truth of
//! office_a (desk lux), its ground-truth albedo image (reflectances; read here only, never by
//! commissioning), synthetic depth with a known plane, and bad input.

use std::path::{Path, PathBuf};

use luxnode::commission::{self, Capture, CommissionOptions, Commissioned, Gain};
use luxnode::scene::{
    LoadOptions, load_desks_file, load_luminaires_file, load_sensors_file, read_states, read_truth,
};

fn scene_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/office_a")
}

fn run(capture: &str, o: &CommissionOptions) -> Commissioned {
    let d = scene_dir();
    let (lums, _) = load_luminaires_file(&d.join("luminaires.json"), &LoadOptions::default())
        .expect("luminaires");
    let (sensors, _) =
        load_sensors_file(&d.join("sensors.json"), &LoadOptions::default()).expect("sensors");
    let desks = load_desks_file(&d.join("desks.json"), &LoadOptions::default()).ok();
    let ids: Vec<u32> = lums.iter().map(|l| l.id).collect();
    let cap = Capture::load(&d.join(capture), &ids).expect("capture");
    commission::commission(&cap, lums, sensors, desks, o).expect("commissions")
}

/// In-view sensors from the capture's sensor_pixels.csv (test-side ground truth).
fn in_view(capture: &str) -> Vec<u32> {
    let text = std::fs::read_to_string(
        scene_dir()
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
    let d = scene_dir();
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

#[test]
fn explore() {
    let o = CommissionOptions::default();
    let c = run("capture", &o);
    let r = &c.report;
    eprintln!("timings {:?}", r.timings);
    eprintln!("depth {:?}", r.depth);
    for p in &r.planes {
        eprintln!("plane {:?}", p);
    }
    eprintln!(
        "tris {} seen {:.1} inferred {:.1} room {:?} patches {}",
        r.triangles, r.seen_area_m2, r.inferred_area_m2, r.room, r.patches
    );
    eprintln!(
        "rho: floor {:?} pixels {} clamped {} without {}",
        r.reflectance.floor_rho,
        r.reflectance.pixels_used,
        r.reflectance.clamped,
        r.reflectance.tris_without_pixels
    );
    eprintln!("warnings {:?}", r.warnings);
    eprintln!("flags {:?}", c.sensor_flags);
    let (e, w, each) = errors(&c, &in_view("capture"));
    eprintln!("error {e:.4} worst {w:.4} {each:?}");
    let (e, w, each) = errors(&c, &[1, 2, 3, 4, 5, 6, 7, 8]);
    eprintln!("all sensors: error {e:.4} worst {w:.4} {each:?}");
    let _ = Gain::Camera;
}
