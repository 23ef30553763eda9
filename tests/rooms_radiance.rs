//! The generalization bench's guard (issue 28, docs/generalization.md): one of its rooms, not
//! office_a, commissioned from its Radiance-rendered capture and scored against Radiance's truth,
//! through the command line as an engineer runs it.
//!
//! room_02 of seed 28 (`scenes/rooms/room_02`: a 7.3 × 5.4 m office, four luminaires, ten
//! desks, one pinhole node tilted toward half of it, the windows out of view). Its capture and
//! live frames are `tests/data/rooms/room_02` (provenance in `tests/data/rooms/README.md`).
//! Four of its in-view desks sit behind monitors the mesh loses (seen edge-on): before the
//! model was checked against the camera they read 7-16 % high.
//!
//! Tolerances: twice the values measured when this was written (in the comments), which the
//! bench's rows for room_02 repeat (`bench/radiance/results/rooms.json`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const LUXNODE: &str = env!("CARGO_BIN_EXE_luxnode");

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn room(name: &str) -> PathBuf {
    manifest().join("scenes/rooms").join(name)
}

fn data(name: &str) -> PathBuf {
    manifest().join("tests/data/rooms").join(name)
}

/// `luxnode ARGS`: (stdout, stderr), asserting success.
fn luxnode(args: &[String]) -> (String, String) {
    let out = Command::new(LUXNODE).args(args).output().expect("runs");
    let (o, e) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(out.status.success(), "luxnode {args:?}: {e}");
    (o, e)
}

fn p(path: PathBuf) -> String {
    path.display().to_string()
}

/// Commissions node a (with the room plan when `plan`); returns the image and stdout.
fn commission(name: &str, dir: &Path, plan: bool) -> (PathBuf, String) {
    commission_node(name, "node_a", dir, plan)
}

/// Commissions one node from its capture set `tests/data/rooms/NAME/NODE`.
fn commission_node(name: &str, node: &str, dir: &Path, plan: bool) -> (PathBuf, String) {
    let (mut imgs, out) = commission_nodes(name, &[node], dir, plan);
    (imgs.remove(0), out)
}

/// Commissions the nodes together (one image each, in order) from their capture sets
/// `tests/data/rooms/NAME/NODE`.
fn commission_nodes(name: &str, nodes: &[&str], dir: &Path, plan: bool) -> (Vec<PathBuf>, String) {
    let tag = if plan { "plan" } else { "plain" };
    let imgs: Vec<PathBuf> = if let [_] = nodes {
        vec![dir.join(format!("{tag}.img"))]
    } else {
        nodes
            .iter()
            .map(|n| dir.join(format!("{tag}_{n}.img")))
            .collect()
    };
    let mut args: Vec<String> = vec!["commission".into()];
    for n in nodes {
        args.push("--capture".into());
        args.push(p(data(name).join(n)));
    }
    for (flag, file) in [
        ("--luminaires", "luminaires.json"),
        ("--sensors", "sensors.json"),
        ("--desks", "desks.json"),
    ] {
        args.push(flag.into());
        args.push(p(room(name).join(file)));
    }
    for img in &imgs {
        args.push("--out".into());
        args.push(p(img.clone()));
    }
    if plan {
        args.push("--room-plan".into());
        args.push(p(room(name).join("room.json")));
    }
    let (out, _) = luxnode(&args);
    (imgs, out)
}

/// The rows of the CSV table that starts with `header` in `text`.
fn table(text: &str, header: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip_while(|l| !l.starts_with(header))
        .skip(1)
        .take_while(|l| {
            l.split(',')
                .next()
                .is_some_and(|f| f.parse::<u32>().is_ok())
        })
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// truth.csv: (scenario, sensor) → (lux, lux_sky).
fn truth(name: &str) -> HashMap<(u32, u32), (f64, f64)> {
    let text = std::fs::read_to_string(room(name).join("truth.csv")).expect("truth.csv");
    let mut t = HashMap::new();
    for l in text.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let n = |i: usize| f[i].parse::<f64>().expect("a number");
        t.insert(
            (f[0].parse().expect("id"), f[2].parse().expect("id")),
            (n(3), n(7)),
        );
    }
    t
}

/// How the stated uncertainties held over every (state, desk) value.
#[derive(Debug)]
struct Coverage {
    /// Share within two of the image's statements in their dimming state (simulate's
    /// `uncertainty_lx`).
    per_state: f64,
    /// Share within two of commission's all-on relative statement at every state's value.
    all_on: f64,
    /// The median of the per-state statements, relative.
    median_rel: f64,
}

/// Per desk sensor: Σ|model − truth| / Σ truth over every state of states.csv (the bench's
/// error), and how the stated uncertainties held.
/// `luxnode simulate` of an image over the room's states.csv: `scenario_id,sensor_id,lux,...`.
fn simulate(name: &str, img: &Path) -> String {
    luxnode(&[
        "simulate".into(),
        "--image".into(),
        p(img.to_path_buf()),
        "--states".into(),
        p(room(name).join("states.csv")),
        "--format".into(),
        "csv".into(),
    ])
    .0
}

fn model_errors(name: &str, img: &Path, commission_out: &str) -> (HashMap<u32, f64>, Coverage) {
    let out = simulate(name, img);
    let u: HashMap<u32, f64> = table(commission_out, "sensor,stated_uncertainty_pct")
        .iter()
        .map(|r| {
            (
                r[0].parse().expect("id"),
                r[1].parse::<f64>().expect("u") / 100.0,
            )
        })
        .collect();
    let truth = truth(name);
    let (mut num, mut den) = (HashMap::new(), HashMap::new());
    assert_eq!(
        out.lines().next(),
        Some("scenario_id,sensor_id,lux,uncertainty_lx")
    );
    let (mut within, mut within_all_on, mut n) = (0usize, 0usize, 0usize);
    let mut rel = Vec::new();
    for l in out.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let (sc, s): (u32, u32) = (f[0].parse().expect("id"), f[1].parse().expect("id"));
        let est: f64 = f[2].parse().expect("lux");
        let u_lx: f64 = f[3].parse().expect("a stated uncertainty");
        let t = truth[&(sc, s)].0;
        *num.entry(s).or_insert(0.0) += (est - t).abs();
        *den.entry(s).or_insert(0.0) += t;
        n += 1;
        within += usize::from((est - t).abs() <= 2.0 * u_lx);
        within_all_on += usize::from((est - t).abs() <= 2.0 * u[&s] * est);
        rel.push(u_lx / est);
    }
    rel.sort_by(f64::total_cmp);
    let err = num.iter().map(|(s, x)| (*s, x / den[s])).collect();
    let c = Coverage {
        per_state: within as f64 / n as f64,
        all_on: within_all_on as f64 / n as f64,
        median_rel: rel[rel.len() / 2],
    };
    (err, c)
}

/// The desks the camera sees (not listed "out of view" by `commission`).
fn in_view(commission_out: &str) -> Vec<u32> {
    let out: Vec<u32> = commission_out
        .lines()
        .filter_map(|l| l.strip_prefix("sensor "))
        .filter(|l| l.contains("out of view"))
        .filter_map(|l| l.split(':').next()?.trim().parse().ok())
        .collect();
    (1..=10).filter(|s| !out.contains(s)).collect()
}

fn worst(errs: &HashMap<u32, f64>, desks: &[u32]) -> (u32, f64) {
    desks
        .iter()
        .map(|s| (*s, errs[s]))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// Without a plan: the in-view desks behind lost monitors are calibrated by the frames and hold
/// within 6.3 % (they were 7.5-16.4 % off), the out-of-view desks within 4.9 %.
#[test]
fn room_02_without_a_plan_holds_at_every_desk() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, out) = commission("room_02", dir.path(), false);
    let calibrated: Vec<u32> = table(&out, "sensor,node,camera_scale")
        .iter()
        .filter(|r| !r[3].is_empty())
        .map(|r| r[0].parse().expect("id"))
        .collect();
    // measured: desks 2, 5, 8 and 9 calibrated (a luminaire each behind a monitor)
    for s in [2, 5] {
        assert!(calibrated.contains(&s), "desk {s} not calibrated: {out}");
    }
    let seen = in_view(&out);
    assert_eq!(seen, [2, 3, 5, 7, 8, 9], "{out}");
    let (errs, coverage) = model_errors("room_02", &img, &out);
    let (s, w) = worst(&errs, &seen);
    eprintln!(
        "room_02, no plan: in view worst desk {s} {:.1} %; {coverage:?}",
        100.0 * w,
    );
    // measured: worst in view 6.3 % (desk 3), out of view 4.9 % (desk 1)
    assert!(w <= 0.126, "desk {s}: {:.1} %", 100.0 * w);
    let out_of_view: Vec<u32> = (1..=10).filter(|s| !seen.contains(s)).collect();
    let (s, w) = worst(&errs, &out_of_view);
    assert!(w <= 0.098, "desk {s}: {:.1} %", 100.0 * w);
    // the statement per dimming state holds (measured: every value; the all-on statement 94 %)
    // at issue 28's 90 %, and is not inflated to do so (median 7.2 %)
    assert!(coverage.per_state >= 0.90, "{coverage:?}");
    assert!(coverage.per_state >= coverage.all_on, "{coverage:?}");
    assert!(coverage.median_rel <= 0.10, "{coverage:?}");
}

/// With the room plan: every desk within 2.1 % in every state, and live light by day (the
/// overcast sky through the plan's windows, fitted at the frame's time) within 2.5 %.
#[test]
fn room_02_with_its_plan_holds_at_every_desk_night_and_day() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, out) = commission("room_02", dir.path(), true);
    let (errs, _) = model_errors("room_02", &img, &out);
    let all: Vec<u32> = (1..=10).collect();
    let (s, w) = worst(&errs, &all);
    eprintln!("room_02, plan: worst desk {s} {:.1} %", 100.0 * w);
    // measured: worst 2.1 % (desk 6)
    assert!(w <= 0.042, "desk {s}: {:.1} %", 100.0 * w);
    // the bench's frame time: gensky's 12:00 at longitude 0, the site at 8.5° E
    let live = live_rows("room_02", &img, "node_a_day.png");
    let truth = truth("room_02");
    let mut worst_day = (0, 0.0);
    for (&s, (total, ..)) in &live {
        let total = total.expect("lux");
        let (lux, sky) = truth[&(1, s)];
        let e = (total / (lux + sky) - 1.0).abs();
        if e > worst_day.1 {
            worst_day = (s, e);
        }
    }
    eprintln!(
        "room_02, plan, live by day: worst desk {} {:.1} %",
        worst_day.0,
        100.0 * worst_day.1
    );
    // measured: worst 2.5 % (desk 1, out of view)
    assert!(worst_day.1 <= 0.05, "{worst_day:?}: {live:?}");
}

/// room_04 of seed 28 without its plan (`scenes/rooms/room_04`: a 10.1 × 7.9 m office, seven
/// luminaires, one pinhole node seeing every desk; data `tests/data/rooms/room_04`). Its two
/// wall desks (sensors 1 and 2) stand by a window band the camera does not see, modelled as
/// wall: the model read them 10.7 and 12.6 % high, and live light, measuring through the desk
/// tops' reflectance estimated by that model (0.452 and 0.458 for the room's 0.50), 11.6 and
/// 10.8 %. They now take the desks' common reflectance (docs/commissioning.md, "The model against
/// the camera at an in-view desk").
#[test]
fn room_04s_desks_by_an_unseen_window_band_take_the_desks_reflectance() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, out) = commission("room_04", dir.path(), false);
    let rows = table(&out, "sensor,node,camera_scale");
    let taken = |s: u32| {
        let r = rows
            .iter()
            .find(|r| r[0] == s.to_string())
            .unwrap_or_else(|| panic!("desk {s} not measured: {out}"));
        let own: f64 = r[7].parse().expect("its own reflectance");
        let class: f64 = r[8].parse().unwrap_or(f64::NAN);
        (own, class)
    };
    // measured: own 0.452 and 0.458, the class 0.500 (the room's desks are 0.50)
    for s in [1, 2] {
        let (own, class) = taken(s);
        assert!((class - 0.50).abs() <= 0.02, "desk {s}: {own} → {class}");
        assert!(own < 0.95 * class, "desk {s}: {own} → {class}");
    }
    let (errs, coverage) = model_errors("room_04", &img, &out);
    eprintln!(
        "room_04, no plan: desks 1, 2 at {:.1}, {:.1} %; {coverage:?}",
        100.0 * errs[&1],
        100.0 * errs[&2]
    );
    // measured: 2.2 and 5.2 % in every state
    assert!(errs[&1] <= 0.045, "desk 1: {:.1} %", 100.0 * errs[&1]);
    assert!(errs[&2] <= 0.104, "desk 2: {:.1} %", 100.0 * errs[&2]);
    let seven: Vec<u32> = (1..=7).collect();
    let (s, w) = worst(&errs, &seven);
    // measured: the other five 0.9-1.4 %
    assert!(w <= 0.104, "desk {s}: {:.1} %", 100.0 * w);
    assert!(coverage.per_state >= 0.90, "{coverage:?}");
    // live light at night, every luminaire on (truth.csv scenario 1)
    let (live, _) = luxnode(&[
        "live".into(),
        "--image".into(),
        p(img.clone()),
        "--frame".into(),
        p(data("room_04").join("live/node_a_night.png")),
        "--depth".into(),
        p(data("room_04").join("live/node_a_depth.png")),
        "--arc".into(),
        "254,254,254,254,254,254,254".into(),
    ]);
    let truth = truth("room_04");
    // the model's every-luminaire state (scenario 1), what the dimming-state registers publish
    let all_on: HashMap<u32, f64> = simulate("room_04", &img)
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[0] == "1")
        .map(|f| (f[1].parse().expect("id"), f[2].parse().expect("lux")))
        .collect();
    for l in live.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let s: u32 = f[0].parse().expect("id");
        let total: f64 = f[1].parse().expect("lux");
        // live light and the per-state registers agree at night (measured within 0.5 %: the
        // frame's noise in the extraneous light)
        let m = all_on[&s];
        assert!(
            (total / m - 1.0).abs() <= 0.01,
            "desk {s}: live {total:.0} lx, model {m:.0} lx"
        );
        let e = (total / truth[&(1, s)].0 - 1.0).abs();
        // at night the frame adds nothing to a calibrated desk's commissioned response: desks 1
        // and 2 carry the model's error there (measured 2.1 and 6.5 %; the camera's own rows
        // were at 0.9 and 1.4 %, but over the bench's 200 in-view values taking the response
        // leaves 14 over 3 % where the camera's rows left 31: docs/generalization.md, eleventh
        // measurement); the others 0.4-1.2 %
        let bound = if s <= 2 { 0.085 } else { 0.03 };
        assert!(
            e <= bound,
            "desk {s}: {total:.0} lx for {:.0}",
            truth[&(1, s)].0
        );
        assert_eq!(f[4], "measured", "desk {s}: {l}");
    }
}

/// `luxnode live`'s CSV for one of room `name`'s frames (node a's depth, every luminaire at
/// 254, the bench's time for room_07's clear and hazy days).
fn live_csv(name: &str, img: &Path, frame: &str) -> String {
    live_csv_of(name, "node_a", img, frame, "2026-03-21T11:26:00Z")
}

/// `luxnode live`'s CSV for one of room `name`'s frames: `NODE_depth.png`'s depth, every
/// luminaire at 254, at `time`.
fn live_csv_of(name: &str, node: &str, img: &Path, frame: &str, time: &str) -> String {
    let n = std::fs::read_to_string(room(name).join("luminaires.json"))
        .expect("luminaires.json")
        .matches("\"id\"")
        .count();
    let (live, _) = luxnode(&[
        "live".into(),
        "--image".into(),
        p(img.to_path_buf()),
        "--frame".into(),
        p(data(name).join("live").join(frame)),
        "--depth".into(),
        p(data(name).join(format!("live/{node}_depth.png"))),
        "--arc".into(),
        vec!["254"; n].join(","),
        "--time".into(),
        time.into(),
    ]);
    live
}

/// Desk `s`'s published total in `luxnode live`'s CSV, lx (`None` when not available).
fn published_lx(live: &str, s: u32) -> Option<f64> {
    live.lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|f| f[0].parse() == Ok(s))
        .and_then(|f| f.get(1)?.parse().ok())
}

/// Room `name`'s clear-sky truth (`truth_clear.csv`): per sensor, lx.
fn truth_clear(name: &str) -> HashMap<u32, f64> {
    std::fs::read_to_string(room(name).join("truth_clear.csv"))
        .expect("truth_clear")
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().expect("id"), f[1].parse().expect("lux"))
        })
        .collect()
}

/// `luxnode live` of an image on one of the room's frames at the bench's frame time: per desk,
/// (total lx or `None` when not available, its source, its flags).
fn live_rows(name: &str, img: &Path, frame: &str) -> HashMap<u32, (Option<f64>, String, String)> {
    let live = live_csv(name, img, frame);
    live.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let id = f[0].parse().expect("id");
            (id, (f[1].parse().ok(), f[4].into(), f[5].into()))
        })
        .collect()
}

/// room_07 under a hazy sun: the bench's clear sky and sun at a quarter of their strength
/// (`bench/radiance/rooms.py`, `HAZY`; Radiance is linear in its sources, so the frame is the
/// all-on frame plus a quarter of the clear-sky frame, and the truth the all-on truth plus a
/// quarter of `truth_clear.csv`). The sun patches the camera sees stay below its saturation, so
/// the node fits the sun's strength to them through the sun's stored beam (gensky's sun:
/// 81.4 klx direct normal, a quarter 20.4 klx; fitted 21.4 klx) and gives desk 1, out of view
/// in a sun patch, its beam: published 28.7 % high, within its two stated uncertainties (stop
/// 48, without the sun's beam in the image, published it as not available).
#[test]
fn room_07s_desk_in_a_sun_patch_nobody_sees_is_published_when_the_camera_measures_the_sun() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, _) = commission("room_07", dir.path(), true);
    let truth = truth("room_07");
    let clear = truth_clear("room_07");
    let live = live_csv("room_07", &img, "node_a_hazy.png");
    for l in live.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let s: u32 = f[0].parse().expect("id");
        let t = truth[&(1, s)].0 + 0.25 * clear[&s];
        let (v, u): (f64, f64) = (
            f[1].parse().unwrap_or(f64::NAN),
            f[6].parse().unwrap_or(f64::NAN),
        );
        eprintln!(
            "room_07, hazy: desk {s} {v:.0} ± {u:.0} lx, truth {t:.0} ({})",
            f[4]
        );
        // every desk published, the truth within two stated uncertainties, none 40 % off
        assert!(v.is_finite() && u.is_finite(), "desk {s}: {live}");
        assert!((v - t).abs() <= 2.0 * u, "desk {s}: {v} ± {u}, truth {t}");
        assert!((v / t - 1.0).abs() < 0.4, "desk {s}: {v}, truth {t}");
    }
    // desk 1 has the sun's beam: over 5 klx (the sky alone gives it under 2 klx)
    let d1 = published_lx(&live, 1).expect("desk 1");
    assert!(d1 > 5000.0, "{live}");
}

/// room_07 of seed 28 with its plan (`scenes/rooms/room_07`: 8.6 × 5.7 m, its window wall
/// facing south; node a a pinhole tilted toward the other half; data `tests/data/rooms/room_07`),
/// under the bench's clear sky at noon (stop 48; `truth_clear.csv`). Desk 1, out of view by the
/// window, lies in a sun patch: 27 klx of daylight. The plan's daylight coefficients hold the
/// sky's diffuse light, not the sun's beam, and gave it 82.9 % low, outside its statement. The
/// camera sees sun patches, and desk 1 sees the sun's sky patch through the window: its daylight
/// is not available. Under the overcast sky (no sun patch) it is published, within 3.6 %.
#[test]
fn room_07s_desk_in_a_sun_patch_nobody_sees_is_not_available_under_the_sun_only() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, out) = commission("room_07", dir.path(), true);
    let seen = in_view(&out);
    assert!(!seen.contains(&1), "{out}");
    let truth = truth("room_07");
    let clear = truth_clear("room_07");
    assert!(clear[&1] > 20_000.0, "desk 1 in the sun: {}", clear[&1]);
    let sunny = live_rows("room_07", &img, "node_a_clear.png");
    let (total, _, flags) = &sunny[&1];
    assert!(
        total.is_none() && flags.contains("daylight_unknown") && flags.contains("sun_may_reach"),
        "{sunny:?}"
    );
    // the other desks keep their values; those in view are measured
    for (s, (total, source, _)) in &sunny {
        if *s == 1 {
            continue;
        }
        let t = truth[&(1, *s)].0 + clear[s];
        let e = total.map(|v| (v / t - 1.0).abs());
        eprintln!("room_07, clear: desk {s} {source} {e:?}");
        assert!(e.is_some_and(|e| e < 0.35), "desk {s}: {sunny:?}");
        assert_eq!(source == "measured", seen.contains(s), "desk {s}");
    }
    let overcast = live_rows("room_07", &img, "node_a_day.png");
    let (lux, sky) = truth[&(1, 1)];
    let e = overcast[&1].0.map(|v| (v / (lux + sky) - 1.0).abs());
    // measured: 3.6 %
    assert!(e.is_some_and(|e| e < 0.08), "{overcast:?}");
}

/// room_07 without its plan (`scenes/rooms/room_07`; node a tilted away from the south window
/// wall), under the bench's clear sky and its hazy quarter. Desk 1, out of view by the window,
/// lies in a sun patch (27 klx clear); the unknown emitters give it the diffuse daylight alone
/// and stop 49 published it 92 % low (hazy 84.5 %), far outside its statement. The camera sees
/// the sun's patches on the floor and desk tops; the emitters' fit gives them a diffuse
/// daylight of 0.9 klx at least (hazy 0.23 klx), and desk 1's own is higher: it is as near the
/// windows as a patch the sun lights, and its daylight is not available. Desks farther in keep
/// their values, within their statements. Under the overcast sky no sun patch is seen and desk
/// 1 is published (with the emitters' error by a window nobody declared, 43 % low: the
/// generalization bench's worst overcast value without a plan, docs/generalization.md).
#[test]
fn without_a_plan_a_desk_as_near_the_windows_as_a_seen_sun_patch_is_not_available() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, out) = commission("room_07", dir.path(), false);
    assert!(!in_view(&out).contains(&1), "{out}");
    let truth = truth("room_07");
    let clear = truth_clear("room_07");
    for (frame, k) in [("node_a_clear.png", 1.0), ("node_a_hazy.png", 0.25)] {
        let live = live_csv("room_07", &img, frame);
        let rows = live_rows("room_07", &img, frame);
        let (total, _, flags) = &rows[&1];
        assert!(
            total.is_none()
                && flags.contains("daylight_unknown")
                && flags.contains("sun_may_reach"),
            "{frame}: {live}"
        );
        for l in live.lines().skip(1).filter(|l| !l.starts_with("1,")) {
            let f: Vec<&str> = l.split(',').collect();
            let s: u32 = f[0].parse().expect("id");
            let t = truth[&(1, s)].0 + k * clear[&s];
            let (v, u): (f64, f64) = (
                f[1].parse().unwrap_or(f64::NAN),
                f[6].parse().unwrap_or(f64::NAN),
            );
            eprintln!("room_07, {frame}, no plan: desk {s} {v:.0} ± {u:.0} lx, truth {t:.0}");
            assert!((v - t).abs() <= 2.0 * u, "{frame}: desk {s}: {live}");
        }
    }
    let overcast = live_rows("room_07", &img, "node_a_day.png");
    assert!(overcast[&1].0.is_some_and(f64::is_finite), "{overcast:?}");
}

/// room_06 seen by node b alone (a straight-down pinhole over half the room; 9 luminaires, the
/// windows out of view; data `tests/data/rooms/room_06`) on the bench's hazy day, no plan: the
/// clear sky and its sun at a quarter of their strength at 08:26 UTC, when the window wall faces
/// the sun. The sun patches the camera sees on the floor get about 4.5 klx of light the
/// emitters do not explain: below the 5 klx that stop 51 took for direct sun, so no desk was
/// held back, and desk 1, out of view in a sun patch (6.1 klx), was published at 1.5 klx ±
/// 0.29 klx, 75 % low. With sun patches from 2.5 klx (`SUN_PATCH_MIN_LX`: a hazy day's sun
/// through glass at a low sun) desk 1 is not available, flagged `sun_may_reach`, as are the
/// out-of-view desks as near the windows as a seen sun patch (6 and 7); the desks the camera
/// sees keep their measured values, within their statements.
#[test]
fn room_06s_weak_sun_patches_hold_back_the_desks_as_near_the_windows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (img, out) = commission_node("room_06", "node_b", dir.path(), false);
    let seen = in_view(&out);
    assert!(!seen.contains(&1), "{out}");
    let truth = truth("room_06");
    let clear = truth_clear("room_06");
    let live = live_csv_of(
        "room_06",
        "node_b",
        &img,
        "node_b_hazy.png",
        "2026-03-21T08:26:00Z",
    );
    let mut held_back = Vec::new();
    for l in live.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let s: u32 = f[0].parse().expect("id");
        let t = truth[&(1, s)].0 + 0.25 * clear[&s];
        if f[1].is_empty() {
            assert!(
                f[5].contains("daylight_unknown") && f[5].contains("sun_may_reach"),
                "desk {s}: {live}"
            );
            held_back.push(s);
            continue;
        }
        let (v, u): (f64, f64) = (f[1].parse().expect("lx"), f[6].parse().expect("u"));
        eprintln!("room_06, node b, hazy, no plan: desk {s} {v:.0} ± {u:.0} lx, truth {t:.0}");
        assert!((v - t).abs() <= 2.0 * u, "desk {s}: {live}");
    }
    assert!(held_back.contains(&1), "{live}");
    // only desks out of view are held back: the camera measures the others
    assert!(held_back.iter().all(|s| !seen.contains(s)), "{live}\n{out}");
    assert!(held_back.len() < 5, "{live}");
}

/// The desk material's reflectance in room `name`'s scene.mtl (its `Kd`).
fn desk_kd(name: &str) -> f64 {
    let mtl = std::fs::read_to_string(room(name).join("scene.mtl")).expect("scene.mtl");
    mtl.split("newmtl ")
        .find(|m| m.starts_with("desk"))
        .and_then(|m| m.lines().find(|l| l.starts_with("Kd ")))
        .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        .expect("the desk's Kd")
}

/// room_03 of seed 28 (`scenes/rooms/room_03`: 11.2 × 4.2 m, node a a fisheye at x = 3.0 m,
/// node b a pinhole at x = 8.2 m; data `tests/data/rooms/room_03`) commissioned with both nodes,
/// no plan. Node b sees desk 2's top at its image's top edge behind desk 2's monitor, which
/// neither node's mesh holds: its rays there meet the desk top in the mesh while its depth says
/// 0.4 m nearer. Those pixels' reflectance (0.03-0.22, the monitor's side) made three of the
/// four patches under desk 2's window 0.229 for 0.40, and node a's camera measured desk 2 1.7
/// times the truth (live light 71 % high once the window fit no longer extrapolated its way out
/// of the measurement, stop 53). Now a pixel whose depth disagrees with the surface its ray
/// meets is no sample (reflectances, windows), and a desk top is one material at the highest of
/// its window's patches: every desk top's reflectance holds within 8 % of the scene's (measured
/// 0.396-0.420, desk 2 0.412; stop 52: 0.229) and desk 2's live light at night within 5 % of
/// Radiance's (measured 758 lx for 763).
#[test]
fn room_03s_two_nodes_sample_a_desk_only_where_their_depth_sees_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (imgs, out) = commission_nodes("room_03", &["node_a", "node_b"], dir.path(), false);
    let kd = desk_kd("room_03");
    let rows = table(&out, "sensor,node,camera_scale");
    assert!(rows.len() >= 8, "{out}");
    for r in &rows {
        let rho: f64 = r[7].parse().expect("desk_rho");
        eprintln!(
            "room_03, two nodes: desk {} top ρ {rho:.3} (scene {kd})",
            r[0]
        );
        // measured: 0.396-0.420 (desk 2 0.412; stop 52: 0.229)
        assert!(
            (rho / kd - 1.0).abs() <= 0.08,
            "desk {}: {rho}: {out}",
            r[0]
        );
    }
    let truth = truth("room_03");
    let live = live_csv_of(
        "room_03",
        "node_a",
        &imgs[0],
        "node_a_night.png",
        "2026-03-21T11:26:00Z",
    );
    let d2 = published_lx(&live, 2).expect("desk 2 measured");
    let t = truth[&(1, 2)].0;
    eprintln!("room_03, two nodes, night: desk 2 {d2:.0} lx, truth {t:.0}");
    assert!((d2 / t - 1.0).abs() <= 0.05, "{d2} for {t}: {live}");
}
