//! Several nodes and wide optics against Radiance (issue 18), on two scenes:
//!
//! - the open-plan zone of `scenes/open_plan_nodes` (12 × 7 m, 8 luminaires, 8 desks and a
//!   cabinet, two ceiling nodes), whose capture sets and truth `bench/radiance/open_plan_nodes.py`
//!   rendered with Radiance;
//! - the reference office `reference/scenes/office_a` (its own capture and truth), with the
//!   capture sets of other cameras that `bench/radiance/office_a_nodes.py` rendered with
//!   Radiance from office_a's own Radiance scene (`scenes/office_a_nodes`).
//!
//! Each configuration is commissioned from its captures alone and scored on the scenarios of
//! the scene's `truth.csv`: desks in view (some node sees the sensor), out of view, all.
//!
//! `cargo nextest run --release --test nodes_radiance --no-capture` prints the tables of
//! docs/commissioning.md.

mod common;
use common::office_a;

use std::path::{Path, PathBuf};

use luxnode::camera::capture::Capture;
use luxnode::commission::refit::Reading;
use luxnode::commission::{self, CommissionOptions, Commissioned};
use luxnode::evaluate::{SensorError, per_sensor, pooled, readings};
use luxnode::scene::{read_states, read_truth};
use luxnode::store::sensor_flags;

fn scene_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/open_plan_nodes")
}

/// Commissions the zone from the named capture sets together; one `Commissioned` per node.
fn commission(sets: &[&str]) -> Vec<Commissioned> {
    let d = scene_dir();
    let sets: Vec<PathBuf> = sets.iter().map(|s| d.join(s)).collect();
    commission_in(&d, &sets)
}

/// Commissions the room of scene directory `d` from the capture sets `sets` together.
fn commission_in(d: &Path, sets: &[PathBuf]) -> Vec<Commissioned> {
    commission_with(d, sets, &CommissionOptions::default())
}

/// [`commission_in`] with options.
fn commission_with(d: &Path, sets: &[PathBuf], o: &CommissionOptions) -> Vec<Commissioned> {
    let (lums, sensors, desks) = common::scene_inputs(d);
    assert!(desks.is_some(), "{} has desks.json", d.display());
    let caps: Vec<Capture> = sets.iter().map(|s| common::capture(s, &lums)).collect();
    commission::from_captures(&caps, lums, sensors, desks, o).expect("commissions")
}

/// One configuration's errors: (in view, out of view, all, worst desk, per sensor with its
/// in-view flag).
struct Score {
    in_view: f64,
    out_of_view: Option<f64>,
    all: f64,
    worst: (u32, f64),
    per: Vec<(SensorError, bool)>,
}

fn score(nodes: &[Commissioned]) -> Score {
    score_in(&scene_dir(), nodes)
}

fn score_in(d: &Path, nodes: &[Commissioned]) -> Score {
    let states = read_states(&d.join("states.csv")).expect("states");
    let truth = read_truth(&d.join("truth.csv")).expect("truth");
    let m = &nodes[0].model;
    // every node holds the whole room's model: the same readings
    for n in &nodes[1..] {
        let a = m
            .sensor_lux(&vec![1.0; m.luminaire_ids.len()])
            .expect("lux");
        let b = n
            .model
            .sensor_lux(&vec![1.0; m.luminaire_ids.len()])
            .expect("lux");
        assert_eq!(a, b, "every node's model is the room's");
    }
    let computed = readings(&states, &m.luminaire_ids, &m.sensor_ids, |l| {
        m.sensor_lux(l)
    })
    .expect("readings");
    let errors = per_sensor(&computed, &truth, &m.sensor_ids);
    assert_eq!(errors.len(), m.sensor_ids.len(), "truth for every sensor");
    let seen = |id: u32| {
        let k = m.sensor_ids.iter().position(|s| *s == id).expect("sensor");
        nodes
            .iter()
            .any(|n| n.sensor_flags[k] & sensor_flags::OUT_OF_VIEW == 0)
    };
    let per: Vec<(SensorError, bool)> = errors
        .into_iter()
        .map(|e| (e.clone(), seen(e.sensor)))
        .collect();
    let pick = |want: Option<bool>| -> Vec<&SensorError> {
        per.iter()
            .filter(|(_, s)| want.is_none_or(|w| *s == w))
            .map(|(e, _)| e)
            .collect()
    };
    let out = pick(Some(false));
    let worst = per
        .iter()
        .map(|(e, _)| (e.sensor, e.error()))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    Score {
        in_view: pooled(&pick(Some(true))),
        out_of_view: (!out.is_empty()).then(|| pooled(&out)),
        all: pooled(&pick(None)),
        worst,
        per,
    }
}

/// A published figure's guard: at most 1.5 times the measured value.
fn guard(what: &str, got: f64, measured: f64) {
    assert!(
        got <= 1.5 * measured,
        "{what}: {:.2} % against {:.2} % measured",
        100.0 * got,
        100.0 * measured
    );
}

fn print(name: &str, s: &Score) {
    let per: Vec<String> = s
        .per
        .iter()
        .map(|(e, v)| {
            format!(
                "{}{}:{:.1}",
                e.sensor,
                if *v { "" } else { "*" },
                100.0 * e.error()
            )
        })
        .collect();
    println!(
        "| {name} | {} | {:.2} % | {} | {:.2} % | {:.1} % (sensor {}) | {} |",
        s.per.iter().filter(|p| p.1).count(),
        100.0 * s.in_view,
        s.out_of_view
            .map_or("-".into(), |e| format!("{:.2} %", 100.0 * e)),
        100.0 * s.all,
        100.0 * s.worst.1,
        s.worst.0,
        per.join(" ")
    );
}

#[test]
fn the_open_plan_zone_by_one_and_two_nodes_pinhole_and_fisheye() {
    println!(
        "| nodes | sensors in view | in view | out of view | all | worst | per sensor (* out of view), % |"
    );
    let mut scores = Vec::new();
    for (name, sets) in [
        ("node A, pinhole", &["pinhole_a"][..]),
        ("nodes A + B, pinhole", &["pinhole_a", "pinhole_b"][..]),
        ("node A, fisheye", &["fisheye_a"][..]),
        ("nodes A + B, fisheye", &["fisheye_a", "fisheye_b"][..]),
    ] {
        let nodes = commission(sets);
        let s = score(&nodes);
        print(name, &s);
        scores.push(s);
    }
    // each desk's stated uncertainty (commissioning's, from what it inferred) covers its error
    for (name, nodes) in [("node A, pinhole", commission(&["pinhole_a"]))] {
        let s = score(&nodes);
        let u = &nodes[0].report.uncertainty;
        assert_eq!(u.len(), 9, "{name}: one per sensor");
        for (e, _) in &s.per {
            let st = u.iter().find(|x| x.sensor_id == e.sensor).expect("stated");
            println!(
                "{name}, sensor {}: error {:.1} %, stated {:.1} % ({} {:.0} %)",
                e.sensor,
                100.0 * e.error(),
                100.0 * st.rel,
                st.dominant().0.name(),
                100.0 * st.dominant().1
            );
            // measured 4.1-18.1 % (the out-of-view sensors: unseen occluders, the unseen
            // walls' reflectance and position; sensors 5-7 stand by back edges where one unseen
            // monitor could shade two luminaires together: 12.7-14.6 % before the occluder
            // groups, docs/generalization.md, tenth measurement)
            assert!(
                (0.01..=0.20).contains(&st.rel) && e.error() <= st.rel,
                "{name}, sensor {}: {:.2} % against a stated {:.2} %",
                e.sensor,
                100.0 * e.error(),
                100.0 * st.rel
            );
        }
    }
    // a luxmeter reading (sensor 2, every luminaire on) where the walls' default is right (0.5)
    // and the ceiling's is not (0.8 in truth): docs/commissioning.md, measured all 1.56 ->
    // 0.92 %, walls 0.524, ceiling 0.716
    let d = scene_dir();
    let truth = read_truth(&d.join("truth.csv")).expect("truth");
    let lux_lx = truth
        .iter()
        .find(|r| r.scenario == "1" && r.sensor == 2)
        .expect("all on")
        .lux;
    let o = CommissionOptions {
        readings: vec![Reading {
            sensor_id: 2,
            lux_lx,
        }],
        ..CommissionOptions::default()
    };
    let read = commission_with(&d, &[d.join("pinhole_a")], &o);
    let s = score(&read);
    print("node A, pinhole, one luxmeter reading", &s);
    let f = read[0].report.reflectance_fit.clone().expect("fitted");
    assert!(s.all < 0.0105 && s.all < scores[0].all, "{}", s.all);
    assert!((f.wall_rho.1 - 0.5).abs() < 0.04, "{f:?}");
    assert!(f.ceiling_rho.1 >= 0.7 && f.ceiling_rho.1 < 0.8, "{f:?}");
    let seen = |s: &Score| s.per.iter().filter(|p| p.1).count();
    // what each configuration sees: a pinhole node its own island, two pinholes every desk
    // (not the cabinet by the south wall), a fisheye the whole zone
    assert_eq!(
        [
            seen(&scores[0]),
            seen(&scores[1]),
            seen(&scores[2]),
            seen(&scores[3])
        ],
        [4, 8, 9, 9]
    );
    // issue 18's target: two nodes covering an open-plan room, every desk <= 5 %
    for s in [&scores[1], &scores[3]] {
        for (e, _) in &s.per {
            assert!(
                e.error() <= 0.05,
                "sensor {}: {:.2} %",
                e.sensor,
                100.0 * e.error()
            );
        }
    }
    // the published figures (docs/commissioning.md)
    guard("one pinhole node, all", scores[0].all, 0.0173);
    guard(
        "one pinhole node, out of view",
        scores[0].out_of_view.unwrap_or(1.0),
        0.0189,
    );
    guard("two pinhole nodes, all", scores[1].all, 0.0171);
    // the cabinet top 0.25 m from the unseen south wall: the wall stands 0.3 m behind it
    // (closure::WALL_CLEARANCE_M), 5 cm too far
    guard("two pinhole nodes, worst", scores[1].worst.1, 0.0278);
    guard("one fisheye node, all", scores[2].all, 0.0221);
    guard("two fisheye nodes, all", scores[3].all, 0.0221);
    guard("two fisheye nodes, worst", scores[3].worst.1, 0.041);
}

/// The same two-node commissioning through the binary, as on a laptop with the nodes' capture
/// sets: both images fit the flash region, parse and hold the same room.
#[test]
fn two_fisheye_nodes_commission_through_the_binary_into_images_that_fit() {
    let d = scene_dir();
    let out = std::env::temp_dir().join(format!("luxnode-opn-{}", std::process::id()));
    std::fs::create_dir_all(&out).expect("temp dir");
    let (a, b) = (out.join("a.img"), out.join("b.img"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args(["commission", "--capture"])
        .arg(d.join("fisheye_a"))
        .arg("--capture")
        .arg(d.join("fisheye_b"))
        .arg("--luminaires")
        .arg(d.join("luminaires.json"))
        .arg("--sensors")
        .arg(d.join("sensors.json"))
        .arg("--desks")
        .arg(d.join("desks.json"))
        .arg("--truth")
        .arg(d.join("truth.csv"))
        .arg("--states")
        .arg(d.join("states.csv"))
        .arg("--out")
        .arg(&a)
        .arg("--out")
        .arg(&b)
        .output()
        .expect("runs");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{}: {text}{}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    let region = luxnode::image_build::formfactors_region_bytes();
    let mut patches = Vec::new();
    for p in [&a, &b] {
        let bytes = std::fs::read(p).expect("image");
        println!("{}: {} bytes of {region}", p.display(), bytes.len());
        assert!(bytes.len() <= region, "{} bytes", bytes.len());
        let image = luxnode::store::Image::parse(&bytes).expect("parses");
        patches.push(image.patches());
    }
    assert_eq!(patches[0], patches[1], "one room model in both");
    // each desk's stated uncertainty is in the image and in the registers (800 + k, 0.1 %)
    let bytes = std::fs::read(&a).expect("image");
    let image = luxnode::store::Image::parse(&bytes).expect("parses");
    let node = luxnode::node::NodeModel::from_image(&image, 1);
    for (k, u) in node.model_rel_uncertainty.iter().enumerate() {
        let stated = image
            .live
            .as_ref()
            .and_then(|l| l.model_rel_uncertainty(k))
            .expect("stated in the live section");
        assert!(
            (u - stated).abs() < 1e-12 && (0.01..=0.15).contains(u),
            "{k}: {u}"
        );
    }
    let uncertainty_line = text
        .lines()
        .skip_while(|l| !l.starts_with("sensor,stated_uncertainty_pct"))
        .nth(1)
        .expect("the stated uncertainties are printed");
    println!("{uncertainty_line}");
    let line = text
        .lines()
        .find(|l| l.starts_with("error, all sensors"))
        .expect("error line");
    println!("{line}");
    let all: f64 = line
        .split(':')
        .nth(1)
        .and_then(|v| v.trim().split(' ').next())
        .and_then(|v| v.parse().ok())
        .expect("a percentage");
    assert!(all <= 1.5 * 2.21, "{line}");
    let _ = std::fs::remove_dir_all(&out);
}

/// office_a with and without a fisheye, with one and two nodes: its own capture (one pinhole
/// node), and the capture sets `bench/radiance/office_a_nodes.py` rendered from its Radiance
/// scene, against its own 31-scenario truth.
#[test]
fn office_a_by_one_and_two_nodes_pinhole_and_fisheye() {
    let d = office_a();
    let ours = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office_a_nodes");
    println!(
        "| nodes | sensors in view | in view | out of view | all | worst | per sensor (* out of view), % |"
    );
    let mut scores = Vec::new();
    for (name, sets) in [
        (
            "one pinhole node (office_a's capture)",
            vec![d.join("capture")],
        ),
        ("one fisheye node, same pose", vec![ours.join("fisheye_c")]),
        (
            "two pinhole nodes",
            vec![ours.join("pinhole_s"), ours.join("pinhole_n")],
        ),
        (
            "two fisheye nodes",
            vec![ours.join("fisheye_s"), ours.join("fisheye_n")],
        ),
    ] {
        let nodes = commission_in(&d, &sets);
        let s = score_in(&d, &nodes);
        print(name, &s);
        scores.push(s);
    }
    let seen = |s: &Score| s.per.iter().filter(|p| p.1).count();
    // a fisheye sees all 8 sensors from one node; the two pinholes miss sensors 5 and 8
    assert_eq!(scores.iter().map(seen).collect::<Vec<_>>(), [6, 8, 6, 8]);
    // the published figures (docs/commissioning.md)
    guard("one pinhole node, all", scores[0].all, 0.0414);
    guard("one pinhole node, in view", scores[0].in_view, 0.0360);
    // every desk but sensor 3 (2 cm in front of a dark monitor whose front face these cameras
    // see at a grazing angle: its reconstruction falls apart and the desk loses the monitor's
    // shadow; docs/commissioning.md): measured worst 4.2 %, 7.7 % (sensor 1), 4.2 %
    for (k, all, worst) in [(1, 0.0738, 0.042), (2, 0.0726, 0.077), (3, 0.0796, 0.042)] {
        guard("office_a, all", scores[k].all, all);
        for (e, _) in scores[k].per.iter().filter(|(e, _)| e.sensor != 3) {
            guard("office_a, a desk but sensor 3", e.error(), worst);
        }
    }
}

/// Issue 28: a desk a fisheye sees far across its view, where one pixel spans more than the
/// 5 cm window, is measured from its nearest desk-top pixels (the window widens up to 10 cm)
/// instead of being inferred. On the open-plan zone's fisheye nodes (Radiance capture sets),
/// every in-view desk has a window with widening; the camera's all-on light there agrees with
/// Radiance's truth as closely as the 5 cm windows' does.
#[test]
fn a_far_desk_in_a_fisheyes_view_is_measured_from_its_nearest_pixels() {
    use luxnode::live_section::{SectionOptions, from_capture};
    let d = scene_dir();
    let truth = read_truth(&d.join("truth.csv")).expect("truth");
    let (lums, _, _) = common::scene_inputs(&d);
    let narrow = SectionOptions {
        window_max_radius_m: SectionOptions::default().window_radius_m,
        ..SectionOptions::default()
    };
    let (mut widened, mut in_view, mut errors) = (0, 0, Vec::new());
    for set in ["fisheye_a", "fisheye_b"] {
        let nodes = commission(&[set]);
        let c = &nodes[0];
        let cap = common::capture(&d.join(set), &lums);
        let wide = from_capture(c, &cap, &SectionOptions::default()).expect("section");
        let near = from_capture(c, &cap, &narrow).expect("section");
        for (k, id) in c.model.sensor_ids.iter().enumerate() {
            if c.sensor_flags[k] & sensor_flags::OUT_OF_VIEW != 0 {
                continue;
            }
            in_view += 1;
            let all_on: f64 = wide.sensor_response_lx[k].iter().sum();
            let t = truth
                .iter()
                .find(|r| r.scenario == "1" && r.sensor == *id)
                .expect("all-on truth")
                .lux;
            let rel = (all_on - t).abs() / t;
            println!(
                "{set} sensor {id}: window {} px (5 cm: {} px), camera {all_on:.0} lx, truth \
                 {t:.0} lx, {:+.1} %",
                wide.windows[k].len(),
                near.windows[k].len(),
                100.0 * (all_on / t - 1.0)
            );
            if near.windows[k].is_empty() {
                assert!(!wide.windows[k].is_empty(), "{set} sensor {id}: no window");
                widened += 1;
            }
            if !wide.windows[k].is_empty() {
                errors.push(rel);
            }
        }
    }
    assert!(widened >= 1, "no far desk needed a wider window");
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    println!(
        "{in_view} in-view desks, {widened} widened; camera vs truth median {:.1} %",
        100.0 * median
    );
    assert!(median <= 0.05, "median {:.1} %", 100.0 * median);
}
