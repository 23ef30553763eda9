//! `luxnode live` (issue 12): live light from one frame, for scripts and checks, on the
//! reference office commissioned from its capture set with `luxnode commission` (which adds the
//! live-light section). The frame is the capture's Radiance-rendered all-on frame, so the
//! published totals are checked against Radiance's own truth at the sensors (`truth.csv`,
//! scenario 9, every luminaire on).

mod common;
use common::office_a;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

const LUXNODE: &str = env!("CARGO_BIN_EXE_luxnode");

/// The office commissioned once for every test here: (its image, the temp dir holding it).
fn image() -> &'static Path {
    static IMG: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &IMG.get_or_init(|| commissioned(&[])).1
}

/// office_a commissioned from its capture by `luxnode commission` with `extra` arguments.
fn commissioned(extra: &[String]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("office_a.img");
    let s = office_a();
    let path = |p: &str| s.join(p).display().to_string();
    let mut args = vec![
        "commission".to_string(),
        "--capture".into(),
        path("capture"),
        "--luminaires".into(),
        path("luminaires.json"),
        "--sensors".into(),
        path("sensors.json"),
        "--desks".into(),
        path("desks.json"),
        "--out".into(),
        img.display().to_string(),
    ];
    args.extend_from_slice(extra);
    let (ok, _, log) = luxnode(&args);
    assert!(ok, "{log}");
    assert!(log.contains("live-light section of"), "{log}");
    (dir, img)
}

/// `luxnode ARGS`: (success, stdout, stderr).
fn luxnode<S: AsRef<std::ffi::OsStr>>(args: impl IntoIterator<Item = S>) -> (bool, String, String) {
    let out = Command::new(LUXNODE).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `luxnode live --image <the commissioned office> ARGS`.
fn live(args: &[&str]) -> (bool, String, String) {
    let image = image().display().to_string();
    luxnode(["live", "--image", &image].iter().chain(args))
}

const ALL_ON: &str = "254,254,254,254,254,254,254,254";

fn frame(name: &str) -> String {
    office_a().join("capture").join(name).display().to_string()
}

/// Radiance's lux at each sensor with every luminaire on (truth.csv, scenario 9).
fn truth_all_on() -> Vec<f64> {
    let text = std::fs::read_to_string(office_a().join("truth.csv")).unwrap();
    let mut v = vec![0.0; 8];
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[1] == "1;2;3;4;5;6;7;8" {
            v[f[2].parse::<usize>().unwrap() - 1] = f[3].parse().unwrap();
        }
    }
    v
}

#[test]
fn the_all_on_frame_gives_the_desks_against_radiance() {
    let (ok, out, err) = live(&[
        "--frame",
        &frame("luminance_all.png"),
        "--arc",
        ALL_ON,
        "--depth",
        &frame("depth_000.png"),
    ]);
    assert!(ok, "{err}");
    let mut lines = out.lines();
    assert_eq!(
        lines.next(),
        Some(
            "sensor_id,lux_total,lux_artificial,lux_daylight,source,flags,uncertainty_lx,occupied"
        )
    );
    let truth = truth_all_on();
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    assert_eq!(rows.len(), 8, "{out}");
    let (mut in_view, mut errs) = (0, Vec::new());
    for r in &rows {
        let id: usize = r[0].parse().unwrap();
        let [total, art, day, unc]: [f64; 4] = [1, 2, 3, 6].map(|i| r[i].parse::<f64>().unwrap());
        assert!(
            [total, art, day, unc].iter().all(|x| x.is_finite()),
            "{r:?}"
        );
        assert!((total - art - day).abs() < 0.02, "{r:?}");
        // no daylight in the frame: the extraneous part is a fraction of a per cent
        assert!(day.abs() <= 0.01 * total, "{r:?}");
        // sensors 1 and 8 are out of the camera's view (groundtruth/sensor_pixels.csv)
        let seen = !matches!(id, 1 | 8);
        assert_eq!(r[4], if seen { "measured" } else { "inferred" }, "{r:?}");
        if seen {
            in_view += 1;
            errs.push((total / truth[id - 1] - 1.0, id));
        }
        eprintln!(
            "sensor {id}: {total:.1} lx ({}) vs Radiance {:.1} lx: {:+.1} %",
            r[4],
            truth[id - 1],
            100.0 * (total / truth[id - 1] - 1.0)
        );
    }
    assert_eq!(in_view, 6);
    let mean = errs.iter().map(|e| e.0.abs()).sum::<f64>() / errs.len() as f64;
    let worst = errs.iter().map(|e| e.0.abs()).fold(0.0, f64::max);
    eprintln!(
        "in view: mean {:.1} %, worst {:.1} %",
        100.0 * mean,
        100.0 * worst
    );
    // docs/live.md: measured 3.6 % mean and 4.8 % worst (sensor 3, 8 cm in front of a monitor,
    // read 11.5 % low before its window's fit narrowed to the shade's edge); guards 1.5 ×
    assert!(mean < 0.054, "mean {mean}");
    assert!(worst < 0.072, "worst {worst}");
}

#[test]
fn json_output_and_bad_input() {
    let (ok, out, err) = live(&[
        "--frame",
        &frame("luminance_all.png"),
        "--arc",
        ALL_ON,
        "--format",
        "json",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let desks = v.as_array().unwrap();
    assert_eq!(desks.len(), 8);
    assert!(
        desks
            .iter()
            .all(|d| d["lux_total"].as_f64().unwrap().is_finite())
    );
    // without depth nothing is known of occupancy
    assert!(desks.iter().all(|d| d["occupied"].is_null()), "{out}");
    // without depth the desks say so
    assert!(
        desks
            .iter()
            .any(|d| d["flags"].as_str().unwrap().contains("no_depth")),
        "{out}"
    );
    // --repeat times further updates of the same frame and gives the same values
    let (ok, again, err) = live(&[
        "--frame",
        &frame("luminance_all.png"),
        "--arc",
        ALL_ON,
        "--format",
        "json",
        "--repeat",
        "3",
    ]);
    assert!(ok, "{err}");
    assert_eq!(again, out);
    assert!(err.contains("live update: 3 updates, median"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let small = dir.path().join("small.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(4, 3, vec![100; 12])
        .unwrap()
        .save(&small)
        .unwrap();
    let not_png = dir.path().join("frame.png");
    std::fs::write(&not_png, b"not a png").unwrap();
    let f = frame("luminance_all.png");
    let s = small.display().to_string();
    let n = not_png.display().to_string();
    for (args, says) in [
        (vec!["--frame", &f, "--arc", "254,254"], "8 luminaires"),
        (
            vec!["--frame", &f, "--arc", "254,254,254,254,254,254,254,255"],
            "0..=254",
        ),
        (
            vec!["--frame", &f, "--arc", "254,254,254,254,254,254,254,x"],
            "0..=254",
        ),
        (vec!["--frame", &s, "--arc", ALL_ON], "4x3 pixels"),
        (
            vec!["--frame", &f, "--arc", ALL_ON, "--depth", &s],
            "4x3 pixels",
        ),
        (vec!["--frame", &n, "--arc", ALL_ON], "frame.png"),
        (
            vec!["--frame", "/nonexistent.png", "--arc", ALL_ON],
            "nonexistent",
        ),
        // the frame's time (issue 28): unparsable, or in the future
        (
            vec!["--frame", &f, "--arc", ALL_ON, "--time", "21.3.2026 12:00"],
            "RFC 3339",
        ),
        (
            vec![
                "--frame",
                &f,
                "--arc",
                ALL_ON,
                "--time",
                "2999-01-01T00:00:00Z",
            ],
            "in the future",
        ),
    ] {
        let (ok, _, err) = live(&args);
        assert!(!ok, "{args:?}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // an image without a live-light section: a clear error
    let plain = dir.path().join("plain.img");
    let plain = plain.display().to_string();
    let scene = office_a().display().to_string();
    let (ok, _, err) = luxnode([
        "image", "build", "--scene", &scene, "--out", &plain, "--preset", "fast",
    ]);
    assert!(ok, "{err}");
    let (ok, _, err) = luxnode(["live", "--image", &plain, "--frame", &f, "--arc", ALL_ON]);
    assert!(!ok);
    assert!(err.contains("no live light"), "{err}");
}

/// (mean, worst) relative error of the measured desks' totals in `luxnode live`'s CSV against
/// Radiance with every luminaire on.
fn measured_error(out: &str) -> (f64, f64) {
    let truth = truth_all_on();
    let errs: Vec<f64> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|r| r[4] == "measured")
        .map(|r| {
            let id: usize = r[0].parse().unwrap();
            (r[1].parse::<f64>().unwrap() / truth[id - 1] - 1.0).abs()
        })
        .collect();
    assert_eq!(errs.len(), 6, "{out}");
    (
        errs.iter().sum::<f64>() / errs.len() as f64,
        errs.iter().copied().fold(0.0, f64::max),
    )
}

/// A luxmeter reading at commissioning (docs/commissioning.md) sets the unseen walls and
/// ceiling; the seen surfaces' reflectances, estimated against that less biased model, take
/// the bias out of the live measurement too (docs/live.md).
#[test]
fn a_luxmeter_reading_at_commissioning_takes_bias_out_of_live_light() {
    let frame_args = [
        "--frame".to_string(),
        frame("luminance_all.png"),
        "--arc".into(),
        ALL_ON.into(),
        "--depth".into(),
        frame("depth_000.png"),
    ];
    let (ok, out, err) = live(&frame_args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok, "{err}");
    let (plain, _) = measured_error(&out);
    let reading = format!("7:{}", truth_all_on()[6]);
    let (_dir, img) = commissioned(&["--luxmeter-rho".into(), reading]);
    let img = img.display().to_string();
    let (ok, out, err) = luxnode(
        ["live", "--image", img.as_str()]
            .into_iter()
            .chain(frame_args.iter().map(String::as_str)),
    );
    assert!(ok, "{err}");
    let (mean, worst) = measured_error(&out);
    eprintln!(
        "in view: {:.2} % without the reading, {:.2} % with it (worst {:.1} %)",
        100.0 * plain,
        100.0 * mean,
        100.0 * worst
    );
    // docs/live.md: measured 3.57 % -> 2.40 %, worst 3.7 % (sensor 2)
    assert!(
        mean < 0.027 && mean < plain - 0.008,
        "{mean} against {plain}"
    );
    assert!(worst < 0.045, "{worst}");
}

/// office_a's desks: (id, x0, x1, y0, y1, top z), m.
fn desks() -> Vec<(u32, [f64; 5])> {
    let text = std::fs::read_to_string(office_a().join("desks.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["desks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            let f = |k: &str| d[k].as_f64().unwrap();
            (
                d["id"].as_u64().unwrap() as u32,
                [f("x0"), f("x1"), f("y0"), f("y1"), f("z")],
            )
        })
        .collect()
}

/// Plan distance from (x, y) to a desk's top, m.
fn desk_distance_m(d: &[f64; 5], x: f64, y: f64) -> f64 {
    let dx = (d[0] - x).max(x - d[1]).max(0.0);
    let dy = (d[2] - y).max(y - d[3]).max(0.0);
    dx.hypot(dy)
}

/// office_a's sensors: (id, position), m.
fn sensors() -> Vec<(u32, [f64; 3])> {
    let text = std::fs::read_to_string(office_a().join("sensors.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v.as_array()
        .unwrap()
        .iter()
        .map(|s| {
            let p = &s["position"];
            (
                s["id"].as_u64().unwrap() as u32,
                [0, 1, 2].map(|i| p[i].as_f64().unwrap()),
            )
        })
        .collect()
}

/// The capture's empty-room depth with a seated person cast into it: a head (disc of 0.1 m
/// radius, top 1.3 m) over shoulders (0.44 m × 0.24 m, top 1.05 m) centred at `at`, each a
/// flat top seen along the pixel's ray where it is nearer than the room.
fn with_person(empty: &luxnode::camera::capture::Frame, at: [f64; 2]) -> Vec<u16> {
    let cam =
        luxnode::scene::load_camera_file(&office_a().join("capture").join("camera.json")).unwrap();
    let axis = cam.world_from_camera.z_axis;
    let mut out = empty.data.clone();
    for v in 0..empty.height {
        for u in 0..empty.width {
            let Some(d) = cam.ray_world(f64::from(u), f64::from(v)) else {
                continue;
            };
            let depth_at = |h: f64| (h - cam.position_m.z) / d.z * d.dot(axis);
            let plan = |h: f64| {
                let t = (h - cam.position_m.z) / d.z;
                (
                    cam.position_m.x + t * d.x - at[0],
                    cam.position_m.y + t * d.y - at[1],
                )
            };
            let (hx, hy) = plan(1.3);
            let (sx, sy) = plan(1.05);
            let z = if hx.hypot(hy) <= 0.1 {
                depth_at(1.3)
            } else if sx.abs() <= 0.22 && sy.abs() <= 0.12 {
                depth_at(1.05)
            } else {
                continue;
            };
            let k = (v * empty.width + u) as usize;
            let mm = (z * 1e3).round() as u16;
            if out[k] == 0 || mm < out[k] {
                out[k] = mm;
            }
        }
    }
    out
}

fn write_depth(path: &Path, w: u32, h: u32, data: Vec<u16>) {
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w, h, data)
        .unwrap()
        .save(path)
        .unwrap();
}

/// The `occupied` column per sensor id of `luxnode live` on a depth frame.
fn occupied_column(depth: Option<&Path>) -> Vec<(u32, String)> {
    let f = frame("luminance_all.png");
    let d = depth.map(|p| p.display().to_string());
    let mut args = vec!["--frame", &f, "--arc", ALL_ON];
    if let Some(d) = &d {
        args.extend(["--depth", d.as_str()]);
    }
    let (ok, out, err) = live(&args);
    assert!(ok, "{err}");
    out.lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            assert_eq!(c.len(), 8, "{l}");
            (c[0].parse().unwrap(), c[7].to_string())
        })
        .collect()
}

#[test]
fn the_occupied_column_follows_a_person_at_a_desk() {
    let (desks, sensors) = (desks(), sensors());
    // the desk a sensor lies on (its top), by the files
    let on_desk = |p: [f64; 3]| {
        desks
            .iter()
            .find(|(_, d)| desk_distance_m(d, p[0], p[1]) < 0.02 && (p[2] - d[4]).abs() < 0.1)
            .map(|(id, _)| *id)
    };
    // without a depth frame: nothing known
    assert!(occupied_column(None).iter().all(|(_, o)| o.is_empty()));
    let dir = tempfile::tempdir().unwrap();
    let empty = luxnode::camera::capture::read_frame16(Path::new(&frame("depth_000.png"))).unwrap();
    let (w, h) = (empty.width, empty.height);
    // the empty room: nobody anywhere; a desk sensor of a desk whose zone the camera sees
    // answers 0 (desks 2 and 3 lie wholly inside the field; 1 and 4 half outside, and over
    // the far half of desk 5's zone a head would leave the frame)
    let vacant = occupied_column(Some(Path::new(&frame("depth_000.png"))));
    for (id, o) in &vacant {
        let desk = on_desk(sensors[(*id - 1) as usize].1);
        assert_ne!(o, "1", "sensor {id}: {vacant:?}");
        if matches!(desk, Some(2 | 3)) {
            assert_eq!(o, "0", "sensor {id} on desk {desk:?}: {vacant:?}");
        }
        if desk.is_none() {
            assert_eq!(o, "", "sensor {id} is on no desk: {vacant:?}");
        }
    }
    // a person 0.4 m beyond a desk's edge, away from the others: that desk is occupied
    for at in [[2.2, 3.8], [3.8, 3.8], [3.0, 4.6]] {
        let nearest = desks
            .iter()
            .min_by(|a, b| {
                desk_distance_m(&a.1, at[0], at[1]).total_cmp(&desk_distance_m(&b.1, at[0], at[1]))
            })
            .unwrap()
            .0;
        let path = dir.path().join("person.png");
        write_depth(&path, w, h, with_person(&empty, at));
        let got = occupied_column(Some(&path));
        for (id, o) in &got {
            let desk = on_desk(sensors[(*id - 1) as usize].1);
            if desk == Some(nearest) {
                assert_eq!(o, "1", "person at {at:?}, sensor {id}: {got:?}");
            } else {
                assert_ne!(o, "1", "person at {at:?}, sensor {id}: {got:?}");
            }
        }
    }
    // garbage depth: unknown everywhere, never vacant
    let path = dir.path().join("zeros.png");
    write_depth(&path, w, h, vec![0; (w * h) as usize]);
    let got = occupied_column(Some(&path));
    assert!(got.iter().all(|(_, o)| o.is_empty()), "{got:?}");
    write_depth(&path, w, h, vec![u16::MAX; (w * h) as usize]);
    let got = occupied_column(Some(&path));
    assert!(got.iter().all(|(_, o)| o.is_empty()), "{got:?}");
}
