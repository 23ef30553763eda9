//! Dense lux and the commissioning report, checked as a person would: against Radiance (the
//! desk grids of truth_dense.csv, the rendered camera frames), and in a real browser (Debian's
//! chromium, headless: the screenshot is not blank and every picture loaded).

mod common;
use common::office_a;

use std::path::{Path, PathBuf};
use std::process::Command;

use luxnode::bench::dense::{
    compare_grid, compare_pixels, read_camera_truth, read_truth_dense, truth_surface_points,
};
use luxnode::engine::dense::{DenseField, DenseSettings};
use luxnode::engine::{Model, Settings, compute_model};
use luxnode::image_build::{ImageOptions, build_image};
use luxnode::image_geometry::{CommissionRecord, Room, section_of};
use luxnode::render::report::{self, NamedState, ReportOptions};
use luxnode::scene::{LoadOptions, Scene};
use luxnode::store::Image;

fn scene_and_model() -> (Scene, Model) {
    let scene = Scene::load(&office_a(), &LoadOptions::default()).expect("office_a loads");
    let model = compute_model(&scene, &Settings::default()).expect("model");
    (scene, model)
}

fn image_with_geometry(scene: &Scene, model: &Model) -> Vec<u8> {
    build_image(
        model,
        &ImageOptions {
            scene_name: scene.name.clone(),
            geometry: Some(section_of(scene, model, &CommissionRecord::default())),
            ..ImageOptions::default()
        },
    )
    .expect("image")
}

/// docs/report.md: the dense desk grids against Radiance (all on, 84 points): mean error 0.64 %
/// (target 1 %), worst ΔU0 0.012 (target 0.02); guarded at the targets.
#[test]
fn dense_desk_grids_match_radiance() {
    let (scene, model) = scene_and_model();
    let truth = read_truth_dense(&office_a().join("truth_dense.csv")).unwrap();
    let field =
        DenseField::from_model(&model, &scene.luminaires, DenseSettings::default()).unwrap();
    let pts = truth_surface_points(&field, &truth);
    assert!(
        pts.iter().all(|p| p.patch != u32::MAX),
        "every truth point lies on a desk top"
    );
    let lux = field
        .points(&pts)
        .lux(&vec![1.0; model.luminaires()])
        .unwrap();
    let g = compare_grid(&truth, &lux).unwrap();
    // the report's task points gather their interreflection (docs/report.md): the same points
    // so, 1 mm above the desk, are held to the same targets
    let air: Vec<(glam::DVec3, glam::DVec3)> = pts
        .iter()
        .map(|p| (p.position_m + glam::DVec3::Z * 0.001, glam::DVec3::Z))
        .collect();
    let gathered = field
        .air_points(&air, &model.basis_b, 1000)
        .lux(&vec![1.0; model.luminaires()])
        .unwrap();
    let gg = compare_grid(&truth, &gathered).unwrap();
    eprintln!(
        "gathered: mean error {:.2} %, bias {:.2} %",
        100.0 * gg.mean_abs_error,
        100.0 * gg.mean_bias
    );
    // measured: mean error 0.12 % (interpolated 0.57 %), bias -0.02 %, U0 within 0.002
    assert!(gg.mean_abs_error <= 0.005 && gg.mean_bias.abs() <= 0.005);
    for (id, t, c) in &gg.desks {
        eprintln!(
            "gathered desk {id}: Ē {:.1} vs {:.1}, U0 {:.3} vs {:.3}",
            c.e_mean_lx, t.e_mean_lx, c.u0, t.u0
        );
        assert!((c.u0 - t.u0).abs() <= 0.02, "desk {id}");
        assert!(
            (c.e_mean_lx / t.e_mean_lx - 1.0).abs() <= 0.015,
            "desk {id}"
        );
    }
    eprintln!(
        "interpolated: mean error {:.2} %, bias {:.2} %",
        100.0 * g.mean_abs_error,
        100.0 * g.mean_bias
    );
    assert!(
        g.mean_abs_error <= 0.01,
        "mean error {:.3} %",
        100.0 * g.mean_abs_error
    );
    assert!(
        g.mean_bias.abs() <= 0.01,
        "bias {:.3} %",
        100.0 * g.mean_bias
    );
    assert_eq!(g.desks.len(), 5);
    for (id, t, c) in &g.desks {
        assert!(
            (c.u0 - t.u0).abs() <= 0.02,
            "desk {id}: U0 {:.3} vs {:.3}",
            c.u0,
            t.u0
        );
        assert!(
            (c.e_mean_lx / t.e_mean_lx - 1.0).abs() <= 0.015,
            "desk {id}: Ē {:.0} vs {:.0}",
            c.e_mean_lx,
            t.e_mean_lx
        );
    }
}

/// docs/report.md: the camera-view lux image against π L / ρ of the rendered all-on frame, desk
/// pixels: median 1.1 % (target 3 %); guarded at 2.5 %.
#[test]
fn camera_view_matches_the_rendered_truth() {
    let (scene, model) = scene_and_model();
    let truth = read_camera_truth(&office_a().join("capture_clean")).unwrap();
    let field =
        DenseField::from_model(&model, &scene.luminaires, DenseSettings::default()).unwrap();
    let cam = scene.camera.as_ref().unwrap();
    let img = field.camera_view(cam).unwrap();
    let lux = img.lux(&vec![1.0; model.luminaires()]).unwrap();
    let p = compare_pixels(&truth, &img, &lux).unwrap();
    assert!(p.pixels > 10_000, "{} desk pixels", p.pixels);
    assert!(p.median <= 0.025, "median {:.2} %", 100.0 * p.median);
    assert!(p.bias.abs() <= 0.025, "bias {:.2} %", 100.0 * p.bias);
    // per-pixel, not per-patch: the desk pixels of one patch differ
    let distinct: std::collections::BTreeSet<u64> = lux
        .iter()
        .filter(|v| v.is_finite())
        .map(|v| (v * 10.0) as u64)
        .collect();
    assert!(
        distinct.len() > 5 * model.patches.len(),
        "{} distinct values",
        distinct.len()
    );
}

/// The geometry section (docs/report.md): old images (without it) parse as before; an image with it gives the
/// room back: the same patches, reflectances, luminaires, and a basis that reproduces the
/// model's exitance.
#[test]
fn geometry_section_round_trips_and_old_images_still_parse() {
    let (scene, model) = scene_and_model();
    let old = build_image(&model, &ImageOptions::default()).unwrap();
    let old_image = Image::parse(&old).unwrap();
    assert!(old_image.geometry_bytes().is_none());
    assert!(matches!(
        Room::from_image(&old_image),
        Err(luxnode::image_geometry::RoomError::NoGeometry)
    ));
    let new = image_with_geometry(&scene, &model);
    let image = Image::parse(&new).unwrap();
    // docs/report.md: 77 kB for office_a's 1903 patches
    let section = image.geometry_bytes().unwrap().len();
    assert!((60_000..100_000).contains(&section), "{section} bytes");
    // the run-time part is unchanged: same response matrix as the image without the section
    for s in 0..image.sensors() {
        for l in 0..image.luminaires() {
            assert_eq!(image.response_lx(s, l), old_image.response_lx(s, l));
        }
    }
    let room = Room::from_image(&image).unwrap();
    assert_eq!(room.patches.len(), model.patches.len());
    for i in (0..model.patches.len()).step_by(97) {
        for k in 0..3 {
            assert!((room.patches.corners_m[i][k] - model.patches.corners_m[i][k]).length() < 1e-5);
        }
        assert!((room.patches.rho[i] - model.patches.rho[i]).abs() < 1e-6);
    }
    assert_eq!(room.luminaires.len(), scene.luminaires.len());
    let l0 = &scene.luminaires[0];
    let r0 = &room.luminaires[0];
    for d in [
        glam::DVec3::NEG_Z,
        glam::DVec3::new(0.5, 0.2, -0.8).normalize(),
    ] {
        let (a, b) = (l0.intensity_toward_cd(d), r0.intensity_toward_cd(d));
        assert!((a - b).abs() <= 1e-5 * a.max(1.0), "{a} vs {b}");
    }
    assert_eq!(room.desks.len(), 5);
    assert!(room.camera.is_some());
    // the lamps' colour rendering (luminaire.ldt's lamp set: "1B", Ra 80-89), in the second
    // extension; a section of the build before it (no such extension: its 13 bytes, length
    // 1, "1B" with its length, Some(80.0), cut off, and the third's one byte after it) still
    // decodes, Ra not known
    let p = &room.section.photometries;
    assert_eq!(p.len(), 1);
    assert_eq!(
        (p[0].colour_rendering.as_str(), p[0].ra_min),
        ("1B", Some(80.0))
    );
    let body = image.geometry_bytes().unwrap();
    // the third extension of a CAD model: no unseen walls, an empty list (one byte); a section
    // of the build before it decodes the same
    assert!(room.section.unseen_walls.is_empty());
    let before_third =
        luxnode::store::geometry::GeometrySection::decode(&body[..body.len() - 1]).unwrap();
    assert_eq!(before_third, room.section);
    let older =
        luxnode::store::geometry::GeometrySection::decode(&body[..body.len() - 14]).unwrap();
    assert_eq!(older.photometries[0].ra_min, None);
    assert_eq!(older.photometries[0].colour_rendering, "");
    assert_eq!(older.camera, room.section.camera);
    assert!(
        luxnode::store::geometry::GeometrySection::decode(&body[..body.len() - 6]).is_err(),
        "a cut extension is an error"
    );
    // total exitance of luminaire 1's basis within the 16-bit storage of the direct terms
    let total = |b: &[f64]| -> f64 {
        b.iter()
            .zip(&model.patches.area_m2)
            .map(|(b, a)| b * a)
            .sum()
    };
    let (a, b) = (total(&model.basis_b[0]), total(&room.basis_b[0]));
    assert!((a / b - 1.0).abs() < 0.002, "{a} vs {b}");
    // a damaged frame after the payload is an error, never a misread
    let mut bad = new.clone();
    let end = bad.len();
    bad[end - image.geometry_bytes().unwrap().len() - 10] = b'X';
    let hdr = luxnode::store::Header::parse(&bad).unwrap();
    let payload = &bad[luxnode::store::HEADER_LEN..];
    let fixed = luxnode::store::Header {
        payload_crc32: luxnode::store::crc32(payload),
        ..hdr
    };
    bad[..luxnode::store::HEADER_LEN].copy_from_slice(&fixed.emit());
    assert!(Image::parse(&bad).is_err());
}

/// office_a's desks' point values in results.json (all on, new): every grid point once, and
/// covered exactly where a point lies in a monitor foot's footprint (scene.obj: monitor_1..3's
/// feet, x0, x1, y0, y1 read by hand). The 5 × 10 grids of 0.16 m put two points in each foot
/// (desks 2, 3 and 5) and two more on desk 2's foot's edge x = 2.04 m, which are left to the ray
/// (on the edge either answer is right); the page's Ēm is the free points' mean × MF.
fn task_points_of_office_a(desks: &[serde_json::Value]) {
    const FEET_M: [[f64; 4]; 3] = [
        [1.86, 2.04, 2.49, 2.71],
        [3.99, 4.17, 2.49, 2.71],
        [2.89, 3.11, 5.59, 5.77],
    ];
    let inside = |f: &[f64; 4], x: f64, y: f64, margin_m: f64| {
        x > f[0] + margin_m && x < f[1] - margin_m && y > f[2] + margin_m && y < f[3] - margin_m
    };
    let mut certain = 0;
    for desk in desks {
        let pts = desk["task"]["points"].as_array().unwrap();
        let grid = desk["grid"][0].as_array().unwrap();
        let n = grid[0].as_u64().unwrap() * grid[1].as_u64().unwrap();
        assert_eq!(pts.len() as u64, n, "{}", desk["id"]);
        let mut free = Vec::new();
        for p in pts {
            let (x, y) = (p["x_m"].as_f64().unwrap(), p["y_m"].as_f64().unwrap());
            let covered = p["covered"].as_bool().unwrap();
            if FEET_M.iter().any(|f| inside(f, x, y, 0.001)) {
                assert!(covered, "{p}");
                certain += 1;
            } else if !FEET_M.iter().any(|f| inside(f, x, y, -0.001)) {
                assert!(!covered, "{p}");
            }
            assert_eq!(p["e_lx"].is_null(), covered, "{p}");
            assert_eq!(p["z_m"].as_f64().unwrap(), 0.75);
            free.extend(p["e_lx"].as_f64());
        }
        let mean = free.iter().sum::<f64>() / free.len() as f64;
        let m = desk["task"]["maintained"]["e_mean_lx"].as_f64().unwrap();
        assert!((0.8 * mean / m - 1.0).abs() < 1e-9, "{mean} {m}");
    }
    assert_eq!(certain, 6, "two grid points inside each monitor's foot");
}

fn chromium() -> PathBuf {
    for name in ["chromium", "chromium-browser"] {
        if let Ok(o) = Command::new("sh")
            .args(["-c", &format!("command -v {name}")])
            .output()
        {
            let p = String::from_utf8_lossy(&o.stdout).trim().to_owned();
            if o.status.success() && !p.is_empty() {
                return PathBuf::from(p);
            }
        }
    }
    // the test installs what it needs (scripts/install-test-tools.sh does the same)
    let ok = Command::new("sh")
        .args([
            "-c",
            "apt-get install -y -q chromium >/dev/null 2>&1 || (apt-get update -q >/dev/null && apt-get install -y -q chromium >/dev/null)",
        ])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "chromium is missing and could not be installed (apt-get install chromium)"
    );
    PathBuf::from("chromium")
}

fn headless(profile: &Path) -> Vec<String> {
    [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([format!("--user-data-dir={}", profile.display())])
    .collect()
}

/// The report opened in a real browser, offline: every picture loads (the page's own check,
/// read from the DOM after load), the screenshot shows the pictures (colour, not a blank page),
/// and results.json carries the numbers the page shows.
#[test]
fn report_opens_in_a_browser_with_every_picture() {
    let (scene, model) = scene_and_model();
    let bytes = image_with_geometry(&scene, &model);
    let image = Image::parse(&bytes).unwrap();
    let l = image.luminaires();
    let opts = ReportOptions {
        states: vec![
            NamedState {
                name: "all on".into(),
                levels: vec![1.0; l],
            },
            NamedState {
                name: "half".into(),
                levels: vec![0.5; l],
            },
        ],
        ..ReportOptions::default()
    };
    let r = report::compute(&image, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    report::write(&r, dir.path()).unwrap();
    let html_path = dir.path().join("report.html");
    let html = std::fs::read_to_string(&html_path).unwrap();
    // self-contained: no fetch of anything
    for bad in ["src=\"http", "href=\"http", "@import", "url(http"] {
        assert!(!html.contains(bad), "the report fetches something: {bad}");
    }
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 4);
    for text in [
        "EN 12464-1:2021",
        "Ēm",
        "U0",
        "luminaire.ldt",
        "lm/W",
        "office_a",
        "balanced",
    ] {
        assert!(html.contains(text), "the report lacks {text:?}");
    }
    // the numbers: results.json, with a half state at half the all-on values
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("results.json")).unwrap())
            .unwrap();
    let desks = json["desks"].as_array().unwrap();
    assert_eq!(desks.len(), 5);
    let states = json["states"].as_array().unwrap();
    let e = |s: usize, d: usize| states[s]["desks"][d][1]["e_mean_lx"].as_f64().unwrap();
    for (d, desk) in desks.iter().enumerate() {
        assert!((e(1, d) / e(0, d) - 0.5).abs() < 1e-9);
        let m = desk["task"]["maintained"]["e_mean_lx"].as_f64().unwrap();
        let n = desk["task"]["new"]["e_mean_lx"].as_f64().unwrap();
        assert!((m / n - 0.8).abs() < 1e-9, "maintained = 0.8 × new");
        assert!(html.contains(&format!("{m:.0}")));
    }
    assert!(
        json["desks_pass"].as_bool().unwrap(),
        "office_a's desks meet EN 12464-1"
    );
    // the overall verdict: every checked requirement, and the reasons on the first screen
    let rows = json["requirements"].as_array().unwrap();
    assert!(
        rows.iter()
            .any(|r| r["what"].as_str().unwrap().starts_with("UGR"))
    );
    let all_pass = rows.iter().all(|r| r["pass"].as_bool() != Some(false));
    assert_eq!(json["pass"].as_bool().unwrap(), all_pass);
    let verdict =
        &html[html.find("id=\"verdict\"").unwrap()..html.find("id=\"requirements\"").unwrap()];
    for why in json["fails_because"].as_array().unwrap() {
        let escaped = why
            .as_str()
            .unwrap()
            .replace('<', "&lt;")
            .replace('>', "&gt;");
        assert!(verdict.contains(&escaped), "{why} not on the first screen");
    }
    // the glare table: each observer's UGR as results.json has it
    for o in json["ugr"]["observers"].as_array().unwrap() {
        let cell = format!("<td>{:.1}</td></tr>", o["ugr"].as_f64().unwrap());
        assert!(html.contains(&cell), "{cell}");
    }
    task_points_of_office_a(desks);
    let lum = &json["luminaires"][0];
    assert_eq!(lum["photometry_file"], "luminaire.ldt");
    assert!(lum["flux_lm"].as_f64().unwrap() > 1000.0);

    let chrome = chromium();
    let profile = tempfile::tempdir().unwrap();
    let url = format!("file://{}", html_path.display());
    let dom = Command::new(&chrome)
        .args(headless(profile.path()))
        .args(["--virtual-time-budget=5000", "--dump-dom", &url])
        .output()
        .expect("chromium runs");
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.contains("data-images=\"loaded\""),
        "not every picture loaded: {}",
        &dom[..dom.len().min(600)]
    );
    assert!(dom.contains("all 4 pictures loaded"));
    assert!(dom.contains("<h2>Point values</h2>"));
    let shot = dir.path().join("shot.png");
    let profile2 = tempfile::tempdir().unwrap();
    let o = Command::new(&chrome)
        .args(headless(profile2.path()))
        .args([
            "--window-size=1200,1800",
            &format!("--screenshot={}", shot.display()),
            &url,
        ])
        .output()
        .expect("chromium runs");
    assert!(shot.exists(), "{}", String::from_utf8_lossy(&o.stderr));
    let png = image::open(&shot).unwrap().into_rgb8();
    assert_eq!(png.dimensions(), (1200, 1800));
    let (mut coloured, mut dark, mut white) = (0usize, 0usize, 0usize);
    for p in png.pixels() {
        let [r, g, b] = p.0;
        let (mx, mn) = (r.max(g).max(b), r.min(g).min(b));
        if mx - mn > 40 {
            coloured += 1; // the false colour of the pictures
        }
        if mx < 80 {
            dark += 1; // text
        }
        if mn > 245 {
            white += 1;
        }
    }
    let n = png.pixels().len();
    assert!(
        coloured > n / 10,
        "{coloured} coloured of {n}: no picture on screen"
    );
    assert!(dark > n / 200, "{dark} dark pixels: no text");
    assert!(white > n / 10, "{white} white pixels");
}

/// The node's first boot writes the report next to its flash (here commissioning from the sim
/// board's CAD scene, the quick path), and the report's image is the one in flash: its
/// sensors are what the node publishes.
#[test]
fn first_boot_writes_the_report_next_to_the_flash() {
    let dir = tempfile::tempdir().unwrap();
    let flash = dir.path().join("flash.img");
    let board = Path::new(env!("CARGO_MANIFEST_DIR")).join("boards/sim/board.toml");
    let o = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args([
            "run",
            "--board",
            board.to_str().unwrap(),
            "--flash",
            flash.to_str().unwrap(),
            "--bind",
            "127.0.0.1:0",
            "--cad",
            "--seconds",
            "2",
        ])
        .output()
        .expect("luxnode runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rep = dir.path().join("commissioning-report");
    let html = std::fs::read_to_string(rep.join("report.html")).expect("report.html");
    assert!(html.contains("EN 12464-1"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(rep.join("results.json")).unwrap()).unwrap();
    assert!(!json["desks"].as_array().unwrap().is_empty());
    assert_eq!(json["maintenance_factor"], 0.8);
    // the same numbers from the flash afterwards
    let out = dir.path().join("again");
    let o = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args([
            "report",
            "--image",
            flash.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(again["desks"], json["desks"]);
    assert_eq!(
        again["states"][0]["sensors_lx"],
        json["states"][0]["sensors_lx"]
    );
}

/// A room commissioned from its cameras on a laptop (`luxnode commission`) gets the report the
/// engineer signs: the image carries the geometry, and the report says where each desk
/// sensor's value comes from and its stated uncertainty (the image's, commissioning's).
#[test]
fn a_room_commissioned_from_its_cameras_gets_a_report_with_each_desks_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("office_a.img");
    let s = office_a();
    let o = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .arg("commission")
        .arg("--capture")
        .arg(s.join("capture"))
        .arg("--luminaires")
        .arg(s.join("luminaires.json"))
        .arg("--sensors")
        .arg(s.join("sensors.json"))
        .arg("--desks")
        .arg(s.join("desks.json"))
        .arg("--out")
        .arg(&img)
        .args(["--maintenance-factor", "0.75"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("report");
    let o = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .arg("report")
        .arg("--image")
        .arg(&img)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["maintenance_factor"], 0.75);
    assert_eq!(json["desks"].as_array().unwrap().len(), 5);
    let bytes = std::fs::read(&img).unwrap();
    let image = Image::parse(&bytes).unwrap();
    let live = image.live.as_ref().expect("live section");
    let rows = json["sensors"].as_array().unwrap();
    assert_eq!(rows.len(), 8);
    for (k, r) in rows.iter().enumerate() {
        let id = r["id"].as_u64().unwrap();
        assert_eq!(id, u64::from(image.sensor_id(k)));
        // sensors 1 and 8 are out of the capture's view (groundtruth/sensor_pixels.csv)
        assert_eq!(r["in_view"].as_bool().unwrap(), !matches!(id, 1 | 8), "{r}");
        let u = r["stated_rel_uncertainty"].as_f64().unwrap();
        let stated = live.model_rel_uncertainty(k).expect("stated");
        assert!((u - stated).abs() < 1e-9, "{u} {stated}");
        // docs/commissioning.md: 5.0 % to 12.5 % on office_a's capture (4.9 % to 10.9 % before
        // its wall x = 0, at the seen extent, had its position in: sensors 1 and 8 by it)
        assert!((0.04..=0.135).contains(&u), "{r}");
    }
    for (k, r) in rows.iter().enumerate() {
        let calibrated = image.sensor_flags(k) & luxnode::store::sensor_flags::CALIBRATED != 0;
        assert_eq!(r["calibrated"].as_bool(), Some(calibrated), "{r}");
    }
    // office_a's wall x = 0: no camera sees it and the luminaire grid does not place it
    // (docs/commissioning.md, "Walls nobody saw: their position"); the engineer is told where
    // it was put
    let walls = json["unseen_walls"].as_array().expect("unseen_walls");
    assert_eq!(walls.len(), 1, "{walls:?}");
    assert_eq!(walls[0]["side"], "x low");
    let at_m = walls[0]["at_m"].as_f64().expect("at_m");
    assert!((-0.3..=0.1).contains(&at_m), "{at_m}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2>Desk sensors</h2>"));
    assert!(
        html.contains("<td>floor S1</td><td>out of view</td>"),
        "sensor 1, on the floor"
    );
    assert_eq!(html.matches("± ").count(), 8);
    assert!(
        html.contains(&format!(
            "Walls no camera saw and the luminaire grid did not place: x low (x = {at_m:.2} m)"
        )),
        "the unseen wall in the report"
    );
}

/// The report of the desk with a box on it (tests/common), a point source over a black room,
/// at settings that keep the test fast.
fn box_scene_report() -> report::Report {
    let scene = common::desk_with_box_scene();
    let settings = luxnode::engine::Settings {
        patches: luxnode::engine::PatchSettings {
            patch_size_m: 0.5,
            detail_ratio: 0.0,
            min_patch_m: 0.2,
            light_ratio: 0.0,
        },
        rays: 100,
        sensor_rays: 300,
        final_gather_rays: 100,
        ..Settings::default()
    };
    let model = compute_model(&scene, &settings).unwrap();
    let bytes = image_with_geometry(&scene, &model);
    let image = Image::parse(&bytes).unwrap();
    report::compute(&image, &ReportOptions::default()).unwrap()
}

/// docs/report.md, point values: a desk with a box standing on it on 5 mm pads (built in code,
/// tests/common): the points inside the box's footprint are flagged covered, exactly those, and
/// have no value; every free point's value is the closed form of a point source of constant
/// intensity I over a black room, E = I h / d³; Ēm, Emin and U0 are the free points' alone.
#[test]
fn task_points_flag_the_points_under_a_box_and_match_the_closed_form() {
    let r = box_scene_report();
    let desk = &r.results.desks[0];
    let pts = &desk.task.points;
    // the EN 12464-1 grid of a 1.0 × 0.8 m desk: d = 1 m, p = 0.2 m, 5 × 4 points
    assert_eq!(desk.grid.0, [5, 4]);
    assert_eq!(pts.len(), 20);
    let (i_cd, lum_m) = (300.0, [1.4, 1.3, 2.7]);
    let mut free = Vec::new();
    for p in pts {
        let under_box = (1.25..=1.55).contains(&p.x_m) && (1.2..=1.4).contains(&p.y_m);
        assert_eq!(p.covered, under_box, "{p:?}");
        assert!((p.z_m - 0.75).abs() < 1e-9);
        if under_box {
            assert_eq!(p.e_lx, None);
            continue;
        }
        let h = lum_m[2] - p.z_m;
        let d = ((p.x_m - lum_m[0]).powi(2) + (p.y_m - lum_m[1]).powi(2) + h * h).sqrt();
        let closed = i_cd * h / d.powi(3);
        let e = p.e_lx.expect("a free point has a value");
        assert!(common::rel(e, closed) < 0.01, "{p:?}: {closed:.1} lx");
        free.push(closed);
    }
    assert_eq!(pts.iter().filter(|p| p.covered).count(), 2);
    // the statistics are the free points': against the closed form's
    let n = free.len() as f64;
    let mean = free.iter().sum::<f64>() / n;
    let min = free.iter().copied().fold(f64::INFINITY, f64::min);
    let s = &desk.task.new;
    assert_eq!(s.points, 18);
    assert!(common::rel(s.e_mean_lx, mean) < 0.01, "{s:?} vs {mean:.1}");
    assert!(common::rel(s.e_min_lx, min) < 0.01);
    assert!((s.u0 - min / mean).abs() < 0.01);
    // the page: a table for the desk, the two covered points greyed and marked
    let html = report::html(&r);
    assert!(html.contains("<h2>Point values</h2>"));
    assert_eq!(html.matches("<tr class=\"covered\">").count(), 2);
    assert!(html.contains("<td>1.300</td><td>1.300</td><td>covered</td>"));
    let json = serde_json::to_value(&r.results).unwrap();
    let jp = &json["desks"][0]["task"]["points"];
    assert_eq!(jp.as_array().unwrap().len(), 20);
    for k in ["x_m", "y_m", "z_m", "e_lx", "covered"] {
        assert!(jp[0].get(k).is_some(), "results.json point lacks {k}");
    }
}

/// UGR of one luminaire, worked by hand from the definitions of CIE 117: a flat 0.6 × 0.6 m
/// Lambertian opening (`I(γ) = 1000 cd · cos γ`) centred 2.0 m ahead of and 1.6 m above a seated
/// eye looking at it horizontally, background 40 cd/m².
///
/// * Lambertian: `L = I₀ / A = 1000 / 0.36 = 2777.8 cd/m²` in every direction;
/// * `d = √(2.0² + 1.6²) = 2.5612 m`, `cos θ = 1.6 / d = 0.62470`, `ω = A cos θ / d² =
///   0.36 · 0.62470 / 6.56 = 0.034282 sr`;
/// * Guth table (T/R = 0, H/R = 0.8): `p = 5.00`;
/// * `UGR = 8 log10(0.25 / 40 · 2777.8² · 0.034282 / 5.00²) = 14.56`.
///
/// The module's closed form gives p = 5.09 there, UGR 14.44: within 0.2 of the table's.
#[test]
fn ugr_of_one_luminaire_matches_the_hand_computation() {
    use glam::DVec3;
    use luxnode::render::ugr::{Observer, Opening, term, ugr};
    let obs = Observer {
        eye_m: DVec3::new(0.0, 0.0, 1.2),
        sight: DVec3::Y,
    };
    let o = Opening::new(
        1,
        DVec3::new(0.0, 2.0, 2.8),
        DVec3::NEG_Z,
        [0.6, 0.6],
        false,
    );
    let cos_theta = 1.6 / (2.0f64 * 2.0 + 1.6 * 1.6).sqrt();
    let t = term(&obs, &o, 1000.0 * cos_theta, 1.0).unwrap().unwrap();
    let l_hand_cd_per_m2 = 1000.0 / 0.36;
    let omega_hand_sr = 0.36 * 0.624_695 / 6.56;
    assert!(
        (t.l_cd_per_m2 / l_hand_cd_per_m2 - 1.0).abs() < 1e-9,
        "{t:?}"
    );
    assert!((t.omega_sr / omega_hand_sr - 1.0).abs() < 1e-5, "{t:?}");
    assert!((t.p / 5.00 - 1.0).abs() < 0.02, "Guth table 5.00: {}", t.p);
    let u = ugr(40.0, &[t]).unwrap().unwrap();
    let hand = 8.0 * (0.25 / 40.0 * 2777.78f64.powi(2) * 0.034_282 / 25.0).log10();
    assert!((hand - 14.56).abs() < 0.01, "{hand}");
    assert!(
        (u - hand).abs() < 0.2,
        "UGR {u} vs the hand computation {hand}"
    );
    // four such luminaires in the same place: UGR + 8 log10 4 = + 4.8
    let u4 = ugr(40.0, &[t, t, t, t]).unwrap().unwrap();
    assert!((u4 - u - 8.0 * 4f64.log10()).abs() < 1e-9);
}

/// office_a's UGR per desk observer against an independent computation in this test: the
/// luminaires from the scene files (their positions, openings and photometry as the scene
/// loads them, not the image's stored copy), R, T, H and the Guth index from the angles σ and
/// τ, the observers' eyes and background luminance taken from results.json. Within 1 unit (the
/// issue's target); the convention's seat checked too.
#[test]
fn office_a_ugr_matches_an_independent_computation() {
    use glam::DVec3;
    let (scene, model) = scene_and_model();
    let bytes = image_with_geometry(&scene, &model);
    let image = Image::parse(&bytes).unwrap();
    let r = report::compute(&image, &ReportOptions::default()).unwrap();
    let u = &r.results.ugr;
    let desks = &scene.desks.as_ref().unwrap().desks;
    assert_eq!(u.observers.len(), desks.len());
    let floor_z = r.results.room_extent_m.1;
    let mut max: f64 = 0.0;
    for o in &u.observers {
        let desk = desks.iter().find(|d| d.id == o.desk).unwrap();
        let eye = DVec3::from_array(o.eye_m);
        let sight = DVec3::from_array(o.sight);
        assert!((eye.z - floor_z - 1.2).abs() < 1e-9);
        let off_m = [
            eye.x - desk.x_m[0],
            desk.x_m[1] - eye.x,
            eye.y - desk.y_m[0],
            desk.y_m[1] - eye.y,
        ]
        .iter()
        .map(|v| v.abs())
        .fold(f64::INFINITY, f64::min);
        assert!((off_m - 0.5).abs() < 1e-9, "0.5 m out from an edge: {eye}");
        let mut sum = 0.0;
        for l in &scene.luminaires {
            let v = l.position_m - eye;
            let (r_m, h_m) = (v.dot(sight), v.z);
            let t_m = v.dot(sight.cross(DVec3::Z)).abs();
            if r_m <= 0.0 || h_m < 0.0 {
                continue;
            }
            let d = v.length();
            let area_m2 = l.opening_m[0] * l.opening_m[1];
            let cos_theta = l.aim.dot(-v / d);
            let i_cd = l.intensity_toward_cd(-v / d);
            let lum = i_cd / (area_m2 * cos_theta);
            let omega = area_m2 * cos_theta / (d * d);
            let sigma = (r_m / d).acos().to_degrees();
            let tau = t_m.atan2(h_m).to_degrees();
            let ln_p = (35.2 - 0.31889 * tau - 1.22 * (-2.0 * tau / 9.0).exp()) * 1e-3 * sigma
                + (21.0 + 0.26667 * tau - 0.002963 * tau * tau) * 1e-5 * sigma * sigma;
            sum += lum * lum * omega / (2.0 * ln_p).exp();
        }
        let reference = 8.0 * (0.25 / (o.e_ind_lx / std::f64::consts::PI) * sum).log10();
        let got = o.ugr.expect("computed");
        assert!(
            (got - reference).abs() < 1.0,
            "desk {}: UGR {got} vs {reference}",
            o.desk
        );
        assert!(o.l_b_cd_per_m2 > 10.0 && o.l_b_cd_per_m2 < 1000.0, "{o:?}");
        max = max.max(got);
    }
    assert_eq!(u.max.map(|m| m.0), Some(max));
    assert_eq!(u.pass, (max * 10.0).round() / 10.0 <= 19.0);
}

/// EN 12464-1:2021's room values on the black room with a point source of constant intensity
/// (tests/common `desk_with_box_scene`: I = 300 cd at (1.4, 1.3, 2.7) m, 3 × 3 × 2.8 m, no
/// interreflection), against closed forms computed here:
///
/// * walls: `Ē` is the wall's flux over its area, `∫ I cos θ / d² dA / A`, integrated on a
///   1 cm grid; the report's area-weighted patch mean within 2 %;
/// * cylindrical illuminance at 1.2 m on the room grid: the mean over 8 azimuths of the
///   vertical illuminance `I max(0, n·u) / d²` within 1 %, and within 6 % of the exact
///   `E_z = I sin α / (π d²)` (α from the vertical; 8 directions under-read by up to 5 %);
/// * UGR: the black room gives no background luminance, so each observer is "not computed"
///   with that reason, never a NaN, and the verdict says so.
#[test]
fn room_values_match_the_point_source_closed_form() {
    let r = box_scene_report();
    let x = &r.results;
    let mf = x.maintenance_factor;
    let (i_cd, lum) = (300.0, [1.4, 1.3, 2.7]);
    // walls: four 3 × 2.8 m walls, each the mean of its closed form on a 1 cm midpoint grid
    let mut sum = 0.0;
    let n = (300, 280);
    for wall in 0..4 {
        for a in 0..n.0 {
            for b in 0..n.1 {
                let (s, z) = ((a as f64 + 0.5) * 0.01, (b as f64 + 0.5) * 0.01);
                let (p, dist_normal) = match wall {
                    0 => ([0.0, s, z], lum[0]),
                    1 => ([3.0, s, z], 3.0 - lum[0]),
                    2 => ([s, 0.0, z], lum[1]),
                    _ => ([s, 3.0, z], 3.0 - lum[1]),
                };
                let d2: f64 = (0..3).map(|k| (p[k] - lum[k]).powi(2)).sum();
                sum += i_cd * dist_normal / d2.powf(1.5);
            }
        }
    }
    let walls_closed_lx = mf * sum / (4 * n.0 * n.1) as f64;
    let walls = x.room_surfaces[0].maintained.expect("walls computed");
    assert!(
        common::rel(walls.e_mean_lx, walls_closed_lx) < 0.02,
        "walls {walls:?} vs {walls_closed_lx:.2} lx"
    );
    // cylindrical: the same grid as the report's (the floor less its 0.5 m band) at 1.2 m
    let inner = luxnode::en12464::Rect {
        x_m: [0.5, 2.5],
        y_m: [0.5, 2.5],
    };
    let g = luxnode::en12464::grid(&inner).unwrap();
    let (mut eight, mut exact) = (Vec::new(), Vec::new());
    for p in &g.points_m {
        let u = [lum[0] - p[0], lum[1] - p[1], lum[2] - 1.2];
        let d2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        let d = d2.sqrt();
        let ev = |phi: f64| i_cd * ((phi.cos() * u[0] + phi.sin() * u[1]) / d).max(0.0) / d2;
        eight.push(
            mf * (0..8)
                .map(|k| ev(k as f64 * std::f64::consts::FRAC_PI_4))
                .sum::<f64>()
                / 8.0,
        );
        exact.push(mf * i_cd * (u[0].hypot(u[1]) / d) / (std::f64::consts::PI * d2));
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let cyl = x.room_surfaces[2].maintained.expect("cylindrical computed");
    assert_eq!(cyl.points, g.points_m.len());
    assert!(
        common::rel(cyl.e_mean_lx, mean(&eight)) < 0.01,
        "{cyl:?} vs {:.2}",
        mean(&eight)
    );
    assert!(
        common::rel(cyl.e_mean_lx, mean(&exact)) < 0.06,
        "{cyl:?} vs exact {:.2}",
        mean(&exact)
    );
    // UGR: no background luminance in a black room: not computed, with the reason
    for o in &x.ugr.observers {
        assert_eq!(o.ugr, None);
        let why = o.not_computed.as_deref().expect("a reason");
        assert!(why.contains("background luminance"), "{why}");
    }
    assert!(!x.ugr.pass && !x.pass);
    // the point source's photometry gives no wattage: LENI is shown, flagged as resting on the
    // assumed efficacy, its installed power the flux over 120 lm/W
    let e = &x.energy;
    let flux_lm: f64 = x.luminaires.iter().map(|l| l.flux_lm).sum();
    assert!(e.power_assumed, "{e:?}");
    assert!(common::rel(e.installed_w, flux_lm / 120.0) < 1e-9, "{e:?}");
    assert!(e.leni_kwh_per_m2_year.is_some());
    let flag = e.flag.as_deref().expect("flagged");
    assert!(flag.contains("assumed efficacy of 120 lm/W"), "{flag}");
    assert!(report::html(&r).contains(flag));
    assert!(
        x.fails_because.iter().any(|w| w.contains("not computed")),
        "{:?}",
        x.fails_because
    );
    let html = report::html(&r);
    assert!(!html.contains("NaN"), "a NaN printed as a value");
}

/// The floor's area from scene.obj's `floor` group: its triangles' areas, `|a × b| / 2`.
fn obj_floor_area_m2(obj: &str) -> f64 {
    let v: Vec<[f64; 3]> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect();
    let mut group = "";
    let mut area = 0.0;
    for l in obj.lines() {
        if let Some(g) = l.strip_prefix("g ") {
            group = g.trim();
        } else if let (Some(f), "floor") = (l.strip_prefix("f "), group) {
            let i: Vec<usize> = f
                .split_whitespace()
                .map(|t| t.split('/').next().unwrap().parse::<usize>().unwrap() - 1)
                .collect();
            for k in 1..i.len() - 1 {
                let (a, b, c) = (v[i[0]], v[i[k]], v[i[k + 1]]);
                let (u, w) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
                area += (u[0] * w[1] - u[1] * w[0]).abs() / 2.0;
            }
        }
    }
    area
}

/// office_a's energy against a hand computation from EN 15193-1's formula with the room's own
/// numbers: the luminaire count from luminaires.json, the wattage from luminaire.ldt (EULUMDAT
/// line 32, the lamp set's watts), the floor's area from scene.obj's floor triangles, MF and the
/// room's maintained Ēm from results.json; office hours t_D 2250 h, t_N 250 h, F_C = (1 + MF)/2,
/// F_O 0.9, F_D 1, 0.3 W standby per luminaire in the 8760 − 2500 h the lighting is off.
#[test]
fn office_a_energy_matches_the_hand_computation() {
    let (scene, model) = scene_and_model();
    let bytes = image_with_geometry(&scene, &model);
    let image = Image::parse(&bytes).unwrap();
    let r = report::compute(&image, &ReportOptions::default()).unwrap();
    let x = &r.results;
    let dir = office_a();
    let ldt = std::fs::read_to_string(dir.join("luminaire.ldt")).unwrap();
    let lamp_w: f64 = ldt.lines().nth(31).unwrap().trim().parse().unwrap();
    let json = std::fs::read_to_string(dir.join("luminaires.json")).unwrap();
    let n = serde_json::from_str::<Vec<serde_json::Value>>(&json)
        .unwrap()
        .len() as f64;
    let area_m2 = obj_floor_area_m2(&std::fs::read_to_string(dir.join("scene.obj")).unwrap());
    assert!((n, lamp_w) == (8.0, 60.0) && (area_m2 - 6.0 * 7.2).abs() < 1e-9);
    let mf = x.maintenance_factor;
    let installed_w = n * lamp_w;
    let w_l_kwh = installed_w * (1.0 + mf) / 2.0 * (2250.0 * 0.9 * 1.0 + 250.0 * 0.9) / 1000.0;
    let w_p_kwh = n * 0.3 * (8760.0 - 2250.0 - 250.0) / 1000.0;
    let leni = (w_l_kwh + w_p_kwh) / area_m2;
    let e = &x.energy;
    assert!((e.installed_w - installed_w).abs() < 1e-9, "{e:?}");
    assert!(common::rel(e.floor_area_m2, area_m2) < 1e-6, "{e:?}");
    assert!(common::rel(e.w_per_m2.unwrap(), installed_w / area_m2) < 1e-6);
    let em = x.room.as_ref().unwrap().maintained.e_mean_lx;
    let per_100 = installed_w / area_m2 / (em / 100.0);
    assert!(common::rel(e.w_per_m2_per_100lx.unwrap(), per_100) < 1e-6);
    assert!(
        common::rel(e.leni_kwh_per_m2_year.unwrap(), leni) < 1e-6,
        "{e:?} vs {leni}"
    );
    assert_eq!(x.leni_kwh_per_m2_year, e.leni_kwh_per_m2_year);
    assert!(!e.power_assumed && e.flag.is_none());
    let json = serde_json::to_value(x).unwrap();
    assert!(json["leni_kwh_per_m2_year"].as_f64().is_some());
    assert!(
        json["energy"]["assumptions"]["f_d_source"]
            .as_str()
            .unwrap()
            .contains("F_D = 1")
    );
    let html = report::html(&r);
    assert!(
        html.contains(&format!("{leni:.1} kWh/(m²·year)")),
        "LENI in the page"
    );
    // no NaN printed (the pictures' base64 may spell it: their data is left out)
    let text: String = html
        .split("base64,")
        .enumerate()
        .map(|(i, part)| {
            if i == 0 {
                part
            } else {
                part.split_once('"').map_or("", |p| p.1)
            }
        })
        .collect();
    assert!(!text.contains("NaN"));
}

/// No two labels on the plan overlap (geometry: pairwise box intersection), on office_a and on
/// the demo office (built by the CLI); each luminaire's id is placed (L<id> boxes counted by
/// their presence: at least one label per luminaire and desk).
#[test]
fn plan_labels_never_overlap_on_office_a_and_the_demo_office() {
    let (scene, model) = scene_and_model();
    let office_a_bytes = image_with_geometry(&scene, &model);
    let demo = common::procs::cli_image(
        "report-demo.img",
        &["--scene", "demo-office"].map(std::ffi::OsStr::new),
    );
    let demo_bytes = std::fs::read(&demo).unwrap();
    for bytes in [office_a_bytes, demo_bytes] {
        let image = Image::parse(&bytes).unwrap();
        let r = report::compute(&image, &ReportOptions::default()).unwrap();
        let b = &r.plan_label_boxes;
        let n = r.results.luminaires.len() + r.results.desks.len();
        assert!(
            b.len() >= n,
            "{} labels for {n} luminaires and desks",
            b.len()
        );
        for i in 0..b.len() {
            assert!(b[i][0] < b[i][2] && b[i][1] < b[i][3], "{:?}", b[i]);
            for j in i + 1..b.len() {
                let overlap = b[i][0] < b[j][2]
                    && b[j][0] < b[i][2]
                    && b[i][1] < b[j][3]
                    && b[j][1] < b[i][3];
                assert!(!overlap, "{}: {:?} and {:?}", r.results.scene, b[i], b[j]);
            }
        }
    }
}

/// The truth at room_02's report points (tests/data/rooms/room_02/report_points.csv, from
/// bench/radiance/report_points.py): (desk id, x, y, lux, covered) per point, grid order.
fn room_02_report_truth() -> Vec<(u32, f64, f64, f64, bool)> {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/rooms/room_02/report_points.csv");
    let text = std::fs::read_to_string(&path).expect("report_points.csv");
    text.lines()
        .skip(1)
        .map(|ln| {
            let f: Vec<&str> = ln.split(',').collect();
            let num = |k: usize| f[k].parse::<f64>().expect("a number");
            (
                f[0].parse().expect("an id"),
                num(1),
                num(2),
                num(4),
                f[6] == "1",
            )
        })
        .collect()
}

/// Issue 32's target on a room the node was not tuned on: room_02 of the generalization bench
/// (scenes/rooms/room_02: six desks, four with a monitor standing on them), its report built
/// from its CAD scene, every task point against Radiance (rtrace -I -ab 8 -ad 2048, 2 passes,
/// at exactly the report's points: bench/radiance/report_points.py). Targets: mean error ≤ 2 %,
/// each desk's Ēm within 1 %, U0 within 0.02, covered flags exactly as the geometry says (no
/// point of this room lies under an object: the monitors stand between grid rows). Measured
/// (docs/report.md): mean error 0.48 %, worst point 8.7 %, Ēm within 0.4 %, U0 within 0.013 on
/// every desk (desk 6, by the wall, 0.769 against 0.782: its wall-side row read 3.5 % low while
/// the gather took the wall's exitance flat over its patches; render::near_gather evaluates
/// near hits at the hit point).
#[test]
fn room_02_report_points_match_radiance() {
    let scene = Scene::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rooms/room_02"),
        &LoadOptions::default(),
    )
    .expect("room_02 loads");
    let model = compute_model(&scene, &Settings::default()).expect("model");
    let bytes = image_with_geometry(&scene, &model);
    let image = Image::parse(&bytes).unwrap();
    let r = report::compute(&image, &ReportOptions::default()).unwrap();
    let truth = room_02_report_truth();
    let mut k = 0;
    let mut errors = Vec::new();
    assert_eq!(r.results.desks.len(), 6);
    for desk in &r.results.desks {
        let (mut e, mut t) = (Vec::new(), Vec::new());
        for p in &desk.task.points {
            let (id, x, y, lux, covered) = truth[k];
            k += 1;
            assert_eq!(id, desk.id);
            assert!(
                (p.x_m - x).abs() < 1e-3 && (p.y_m - y).abs() < 1e-3,
                "{p:?}"
            );
            assert_eq!(p.covered, covered, "{p:?}");
            if let Some(v) = p.e_lx {
                errors.push((v / lux - 1.0).abs());
                e.push(v);
                t.push(lux);
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let (em, tm) = (mean(&e), mean(&t));
        let (u0, tu0) = (min(&e) / em, min(&t) / tm);
        eprintln!(
            "desk {}: Ēm {em:.1} vs {tm:.1} ({:+.2} %), U0 {u0:.3} vs {tu0:.3}",
            desk.id,
            100.0 * (em / tm - 1.0)
        );
        assert!((em / tm - 1.0).abs() <= 0.01, "desk {}", desk.id);
        assert!(
            (u0 - tu0).abs() <= 0.02,
            "desk {}: U0 {u0:.3} vs {tu0:.3}",
            desk.id
        );
        assert!((desk.task.new.e_mean_lx - em).abs() < 1e-6 * em);
    }
    assert_eq!(k, truth.len());
    let mean_error = errors.iter().sum::<f64>() / errors.len() as f64;
    let worst = errors.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "mean error {:.2} %, worst {:.1} %",
        100.0 * mean_error,
        100.0 * worst
    );
    assert!(mean_error <= 0.02, "mean error {:.2} %", 100.0 * mean_error);
}

/// `luxnode report --context-modifiers 1` (EN 12464-1:2021 §5.3.3) on room_02: the task
/// areas' Ēm required goes from 500 to 750 lx with the reason in the row, and the immediate
/// surroundings' from 300 to 500 lx (Table 1). Desks 1-4 (maintained Ēm about 554 lx) pass
/// their Ēm unmodified and fail it modified, each with its value; without the option the row
/// says the modified Ēm is not applied.
#[test]
fn declared_context_modifiers_raise_the_task_areas_em() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("room_02.img");
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rooms/room_02");
    let run = |args: &[&std::ffi::OsStr]| {
        let o = Command::new(env!("CARGO_BIN_EXE_luxnode"))
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&[
        "image".as_ref(),
        "build".as_ref(),
        "--scene".as_ref(),
        room.as_os_str(),
        "--out".as_ref(),
        img.as_os_str(),
    ]);
    let report = |extra: &[&str]| -> serde_json::Value {
        let out = dir.path().join(format!("report{}", extra.len()));
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "report".as_ref(),
            "--image".as_ref(),
            img.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ];
        args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
        run(&args);
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
    };
    let checks = |json: &serde_json::Value, desk: usize| -> Vec<(String, f64, bool)> {
        json["desks"][desk]["checks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                (
                    c["what"].as_str().unwrap().to_owned(),
                    c["required"].as_f64().unwrap(),
                    c["pass"].as_bool().unwrap(),
                )
            })
            .collect()
    };
    let plain = report(&[]);
    let raised = report(&["--context-modifiers", "1"]);
    assert_eq!(plain["requirement"]["context_modifiers"], 0);
    assert_eq!(raised["requirement"]["context_modifiers"], 1);
    let row = |j: &serde_json::Value| {
        j["requirements"][0]["required"]
            .as_str()
            .unwrap()
            .to_owned()
    };
    assert!(row(&plain).starts_with("≥ 500 lx") && row(&plain).contains("not applied"));
    assert!(row(&raised).starts_with("≥ 750 lx (modified: Ēm 500 lx raised one step"));
    let why = raised["fails_because"].to_string();
    for desk in 0..4 {
        let e = raised["desks"][desk]["task"]["maintained"]["e_mean_lx"]
            .as_f64()
            .unwrap();
        assert!((500.0..750.0).contains(&e), "desk {}: {e}", desk + 1);
        let (p, r) = (checks(&plain, desk), checks(&raised, desk));
        assert_eq!(("Ēm task area".to_owned(), 500.0, true), p[0]);
        assert_eq!(("Ēm task area".to_owned(), 750.0, false), r[0]);
        assert_eq!((p[2].1, r[2].1), (300.0, 500.0), "{:?}", r[2]);
        let reason = format!("desk {}: Ēm task area {e:.0} lx < 750 lx", desk + 1);
        assert!(why.contains(&reason), "{reason} not in {why}");
    }
}

/// The number of pixels of `rgb` in a PNG, and the number of columns holding one.
fn pixels_of_colour(png: &[u8], rgb: [u8; 3]) -> (usize, usize) {
    let img = image::load_from_memory(png).unwrap().to_rgb8();
    let mut cols = std::collections::BTreeSet::new();
    let mut n = 0;
    for (x, _, p) in img.enumerate_pixels() {
        if p.0 == rgb {
            n += 1;
            cols.insert(x);
        }
    }
    (n, cols.len())
}

/// Windows on the plan: room_02 (its room plan, room.json, has two windows on the wall y = 0,
/// x 1.12-2.53 and 4.77-6.18 m, sill 0.90 m, head 2.22 m; its scene's glazing is labelled
/// window_1 and window_2) gets both in results.json where room.json puts them, and as blue bars
/// on plan.png, one pixel column per centimetre of glazing; the desk with a box (no window) gets
/// neither.
#[test]
fn windows_are_drawn_on_the_plan_when_the_room_has_them() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rooms/room_02");
    let scene = Scene::load(&dir, &LoadOptions::default()).expect("room_02 loads");
    let model = compute_model(&scene, &Settings::default()).expect("model");
    let bytes = image_with_geometry(&scene, &model);
    let r = report::compute(&Image::parse(&bytes).unwrap(), &ReportOptions::default()).unwrap();
    let plan_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("room.json")).unwrap()).unwrap();
    let expected = plan_json["windows"].as_array().unwrap();
    let mut got = r.results.windows.clone();
    got.sort_by(|a, b| {
        a.from_m[0]
            .min(a.to_m[0])
            .total_cmp(&b.from_m[0].min(b.to_m[0]))
    });
    assert_eq!(got.len(), expected.len());
    let mut length_m = 0.0;
    for (w, e) in got.iter().zip(expected) {
        let c: Vec<[f64; 3]> = serde_json::from_value(e["corners_m"].clone()).unwrap();
        let xs = (
            c.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
            c.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
        );
        let (a, b) = (w.from_m[0].min(w.to_m[0]), w.from_m[0].max(w.to_m[0]));
        assert!(
            (a - xs.0).abs() < 0.01 && (b - xs.1).abs() < 0.01,
            "{w:?} vs {c:?}"
        );
        assert!(w.from_m[1].abs() < 0.01 && w.to_m[1].abs() < 0.01, "{w:?}");
        assert!(
            (w.z_m[0] - c[0][2]).abs() < 0.01 && (w.z_m[1] - c[1][2]).abs() < 0.01,
            "{w:?}"
        );
        length_m += b - a;
    }
    let plan = |r: &report::Report| {
        r.pictures
            .iter()
            .find(|p| p.0 == "plan")
            .map(|p| p.2.clone())
            .unwrap()
    };
    let rgb = luxnode::render::map::WINDOW_RGB;
    let (n, cols) = pixels_of_colour(&plan(&r), rgb);
    // 100 pixels per metre: 282 columns for 2.82 m, a bar 6 pixels thick
    let want = length_m * 100.0;
    assert!(
        (cols as f64 - want).abs() <= 12.0,
        "{cols} columns for {want:.0}"
    );
    assert!(
        n as f64 >= 4.0 * want && n as f64 <= 8.0 * want,
        "{n} pixels"
    );
    let plain = box_scene_report();
    assert!(plain.results.windows.is_empty());
    assert_eq!(pixels_of_colour(&plan(&plain), rgb), (0, 0));
}

/// A PDF's objects as (number, dictionary text, stream bytes if any) — enough of the format
/// for what Chromium (Skia) writes: no object streams, one dictionary per object.
fn pdf_objects(pdf: &[u8]) -> std::collections::BTreeMap<u32, (String, Vec<u8>)> {
    let find = |from: usize, pat: &[u8]| -> Option<usize> {
        pdf.get(from..)?
            .windows(pat.len())
            .position(|w| w == pat)
            .map(|k| from + k)
    };
    let mut out = std::collections::BTreeMap::new();
    let mut at = 0;
    while let Some(start) = find(at, b" 0 obj") {
        let num_start = pdf[..start]
            .iter()
            .rposition(|c| !c.is_ascii_digit())
            .map_or(0, |i| i + 1);
        let end = find(start, b"endobj").unwrap_or(pdf.len());
        at = start + 6;
        let Ok(num) = String::from_utf8_lossy(&pdf[num_start..start]).parse::<u32>() else {
            continue;
        };
        let (dict, stream) = match find(start, b"stream").filter(|s| *s < end) {
            Some(s) => {
                let from = s + b"stream".len();
                let from = from + usize::from(pdf[from] == b'\r') + 1;
                let to = find(from, b"endstream").unwrap_or(end);
                (&pdf[start + 6..s], pdf[from..to].to_vec())
            }
            None => (&pdf[start + 6..end], Vec::new()),
        };
        out.insert(num, (String::from_utf8_lossy(dict).into_owned(), stream));
        at = end;
    }
    out
}

/// Where each image XObject is drawn on a page, in points: the unit square through the
/// content stream's matrices (`q`, `Q`, `cm`, `Do`), as (x0, y0, x1, y1).
fn image_boxes_pt(content: &str, images: &[String]) -> Vec<(String, [f64; 4])> {
    type M = [f64; 6];
    let mul = |m: &M, c: &M| -> M {
        [
            m[0] * c[0] + m[1] * c[2],
            m[0] * c[1] + m[1] * c[3],
            m[2] * c[0] + m[3] * c[2],
            m[2] * c[1] + m[3] * c[3],
            m[4] * c[0] + m[5] * c[2] + c[4],
            m[4] * c[1] + m[5] * c[3] + c[5],
        ]
    };
    let (mut ctm, mut stack, mut nums, mut name): (M, Vec<M>, Vec<f64>, String) = (
        [1.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        Vec::new(),
        Vec::new(),
        String::new(),
    );
    let mut out = Vec::new();
    for tok in content.split_ascii_whitespace() {
        if let Ok(v) = tok.parse::<f64>() {
            nums.push(v);
            continue;
        }
        match tok {
            "q" => stack.push(ctm),
            "Q" => ctm = stack.pop().unwrap_or(ctm),
            "cm" if nums.len() >= 6 => {
                let m: M = nums[nums.len() - 6..].try_into().unwrap();
                ctm = mul(&m, &ctm);
            }
            "Do" if images.contains(&name) => {
                let pts = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)].map(|(x, y)| {
                    (
                        ctm[0] * x + ctm[2] * y + ctm[4],
                        ctm[1] * x + ctm[3] * y + ctm[5],
                    )
                });
                let xs = pts.map(|p| p.0);
                let ys = pts.map(|p| p.1);
                let lo = |v: [f64; 4]| v.into_iter().fold(f64::INFINITY, f64::min);
                let hi = |v: [f64; 4]| v.into_iter().fold(f64::NEG_INFINITY, f64::max);
                out.push((name.clone(), [lo(xs), lo(ys), hi(xs), hi(ys)]));
            }
            t if t.starts_with('/') => name = t[1..].to_owned(),
            _ => {}
        }
        if !tok.starts_with('/') {
            nums.clear();
        }
    }
    out
}

/// A printed report (Chromium's print to PDF): its page count, and each picture's page
/// boxes in points (a picture split over pages is drawn on each; one clipped by the page
/// reaches past the page's printable area).
fn printed(html: &Path, pdf: &Path) -> (usize, Vec<Vec<[f64; 4]>>, [f64; 4]) {
    let profile = tempfile::tempdir().unwrap();
    let o = Command::new(chromium())
        .args(headless(profile.path()))
        .args([
            "--no-pdf-header-footer".to_owned(),
            format!("--print-to-pdf={}", pdf.display()),
            format!("file://{}", html.display()),
        ])
        .output()
        .expect("chromium runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(pdf).expect("the PDF is written");
    assert!(bytes.starts_with(b"%PDF-"), "not a PDF");
    let objs = pdf_objects(&bytes);
    let images: Vec<u32> = objs
        .iter()
        .filter(|(_, (d, _))| d.contains("/Subtype /Image"))
        .map(|(k, _)| *k)
        .collect();
    let pages: Vec<&String> = objs
        .values()
        .map(|(d, _)| d)
        .filter(|d| {
            d.contains("/Type /Page\n") || d.contains("/Type /Page/") || d.contains("/Type /Page ")
        })
        .collect();
    let mut media = [0.0; 4];
    let mut drawn: Vec<Vec<[f64; 4]>> = vec![Vec::new(); images.len()];
    for page in &pages {
        let mb = &page[page.find("/MediaBox [").unwrap() + 11..];
        let v: Vec<f64> = mb[..mb.find(']').unwrap()]
            .split_ascii_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        media = [v[0], v[1], v[2], v[3]];
        // the page's names for the images: /Xk n 0 R
        let names: Vec<(String, usize)> = images
            .iter()
            .enumerate()
            .filter_map(|(i, n)| {
                let pat = format!(" {n} 0 R");
                let at = page.find(&pat)?;
                let slash = page[..at].rfind('/')?;
                Some((page[slash + 1..at].to_owned(), i))
            })
            .collect();
        let c = &page[page.find("/Contents ").unwrap() + 10..];
        let content_obj: u32 = c[..c.find(' ').unwrap()].parse().unwrap();
        let raw = &objs[&content_obj].1;
        let mut text = String::new();
        use std::io::Read;
        flate2::read::ZlibDecoder::new(&raw[..])
            .read_to_string(&mut text)
            .expect("a Flate content stream");
        let list: Vec<String> = names.iter().map(|n| n.0.clone()).collect();
        for (name, b) in image_boxes_pt(&text, &list) {
            let i = names.iter().find(|n| n.0 == name).unwrap().1;
            drawn[i].push(b);
        }
    }
    (pages.len(), drawn, media)
}

/// The report printed (docs/report.md, print stylesheet: A4, 12 mm margins, no picture split):
/// Chromium's print to PDF gives A4 pages, a sane count (office_a: 13), each of the 4
/// pictures drawn once, on one page, inside the printable area (12 mm = 34 pt in from every
/// edge). The check can fail: the same page with its pictures forced to 1400 px tall prints a
/// picture past its page.
#[test]
fn the_report_prints_to_pdf_with_no_picture_cut() {
    let (scene, model) = scene_and_model();
    let bytes = image_with_geometry(&scene, &model);
    let r = report::compute(&Image::parse(&bytes).unwrap(), &ReportOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    report::write(&r, dir.path()).unwrap();
    let html = dir.path().join("report.html");
    let (pages, drawn, media) = printed(&html, &dir.path().join("report.pdf"));
    // A4: 595.3 × 841.9 pt
    assert!(
        (media[2] - 595.3).abs() < 1.0 && (media[3] - 841.9).abs() < 1.0,
        "{media:?}"
    );
    eprintln!("{pages} pages; pictures at (pt) {drawn:?}");
    assert!((5..=30).contains(&pages), "{pages} pages");
    assert_eq!(drawn.len(), 4, "the 4 pictures");
    let margin_pt = 12.0 / 25.4 * 72.0;
    let inside = |b: &[f64; 4]| {
        b[0] >= media[0] + margin_pt - 1.0
            && b[1] >= media[1] + margin_pt - 1.0
            && b[2] <= media[2] - margin_pt + 1.0
            && b[3] <= media[3] - margin_pt + 1.0
    };
    for (k, boxes) in drawn.iter().enumerate() {
        assert_eq!(boxes.len(), 1, "picture {k} drawn {} times", boxes.len());
        assert!(inside(&boxes[0]), "picture {k} at {:?}", boxes[0]);
        assert!(
            boxes[0][2] - boxes[0][0] > 200.0,
            "picture {k} too small: {:?}",
            boxes[0]
        );
    }
    // the control: pictures taller than a page are cut, and the check sees it
    let tall = dir.path().join("tall.html");
    let page = std::fs::read_to_string(&html).unwrap().replacen(
        "</style>",
        "img{width:auto!important;max-width:none!important;height:1400px}</style>",
        1,
    );
    std::fs::write(&tall, page).unwrap();
    let (_, drawn, _) = printed(&tall, &dir.path().join("tall.pdf"));
    eprintln!("forced 1400 px tall: pictures at (pt) {drawn:?}");
    assert!(
        drawn.iter().flatten().any(|b| !inside(b)),
        "a 1400 px picture fits a page?"
    );
}
