//! The report's appendices and energy inputs: the daylight factors from a daylight section
//! (`src/render/daylight_factor.rs`), and the UGR table appendix (CIE 117 / CIE 190,
//! `src/render/ugr_table.rs`) against an independent computation: the per-observer module (`render::ugr`: 3-D luminaires turned as the room would
//! have them, their intensity toward the eye through `Luminaire::intensity_toward_cd`, the
//! opening's luminance and solid angle by `ugr::term`) on the explicit rectangular array of the
//! standard conditions, with the table's background luminance.

mod common;
use common::office_a;

use std::sync::Arc;

use glam::DVec3;
use luxnode::engine::{Settings, compute_model};
use luxnode::image_build::{ImageOptions, build_image};
use luxnode::image_geometry::{CommissionRecord, section_of};
use luxnode::photometry::IntensityDistribution;
use luxnode::render::report::{self, ReportOptions};
use luxnode::render::ugr::{self, Observer, Opening};
use luxnode::render::ugr_table::{self, H_M, REFLECTANCES, ROOMS_H, SPACING_H, View};
use luxnode::scene::{LoadOptions, Luminaire, Scene};
use luxnode::store::Image;

/// An asymmetric distribution: `I = 1000 cos γ (0.4 + 0.6 cos² C)` cd below the horizontal
/// (brighter along C0 than along C90), none above.
fn asymmetric() -> IntensityDistribution {
    let c_deg: Vec<f64> = (0..24).map(|k| 15.0 * k as f64).collect();
    let gamma_deg: Vec<f64> = (0..=36).map(|k| 5.0 * k as f64).collect();
    let mut cd = Vec::new();
    for c in &c_deg {
        for g in &gamma_deg {
            let (c, g) = (c.to_radians(), g.to_radians());
            let v = if g <= std::f64::consts::FRAC_PI_2 {
                1000.0 * g.cos() * (0.4 + 0.6 * c.cos() * c.cos())
            } else {
                0.0
            };
            cd.push(v.max(0.0));
        }
    }
    IntensityDistribution::from_full_grid(c_deg, gamma_deg, cd, "asymmetric").unwrap()
}

/// UGR of the explicit array by the per-observer module: eye on the wall y = 0 at x = 0,
/// 1.2 m high, looking along +y; luminaires 2 m above the eye, C0 along the line of sight
/// (crosswise) or across it (endwise); the standard's filters T/R ≤ 3, γ ≤ 85°.
fn explicit_ugr(
    d: &Arc<IntensityDistribution>,
    size_m: [f64; 2],
    room_h: (f64, f64),
    view: View,
    l_b: f64,
) -> f64 {
    let eye = DVec3::new(0.0, 0.0, 1.2);
    let obs = Observer {
        eye_m: eye,
        sight: DVec3::Y,
    };
    let aim = DVec3::NEG_Z;
    let c0 = match view {
        View::Crosswise => DVec3::Y,
        View::Endwise => DVec3::X,
    };
    let (x_m, y_m) = (room_h.0 * H_M, room_h.1 * H_M);
    let s = SPACING_H * H_M;
    let (nx, ny) = ((x_m / s).round() as usize, (y_m / s).round() as usize);
    let mut terms = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let p = DVec3::new(
                -0.5 * x_m + (i as f64 + 0.5) * s,
                (j as f64 + 0.5) * s,
                1.2 + H_M,
            );
            let (t, r) = (p.x.abs(), p.y);
            let gamma_deg = p.x.hypot(p.y).atan2(H_M).to_degrees();
            if t / r > 3.0 || gamma_deg > 85.0 {
                continue;
            }
            let lum = Luminaire {
                id: (j * nx + i) as u32,
                name: String::new(),
                position_m: p,
                aim,
                c0,
                c90: c0.cross(aim),
                flux_lm: d.flux_lm(),
                opening_m: size_m,
                opening_circular: false,
                photometry: d.clone(),
                photometry_path: "asymmetric.ldt".into(),
                file_flux_lm: d.flux_lm(),
            };
            let i_cd = lum.intensity_toward_cd((eye - p).normalize());
            let o = Opening::new(lum.id, p, aim, size_m, false);
            if let Some(term) = ugr::term(&obs, &o, i_cd, 1.0).unwrap() {
                terms.push(term);
            }
        }
    }
    ugr::ugr(l_b, &terms).unwrap().unwrap()
}

#[test]
fn ugr_table_entries_match_the_per_observer_module_on_the_explicit_array() {
    let raw = asymmetric();
    let d = Arc::new(raw.scaled(1000.0 / raw.flux_lm()));
    let size_m = [0.6, 0.3];
    let rows = ugr_table::uncorrected_rows(&d, size_m[0] * size_m[1]).unwrap();
    assert_eq!(rows.len(), ROOMS_H.len());
    for (x_h, y_h) in [(2.0, 2.0), (4.0, 8.0), (8.0, 4.0), (12.0, 8.0)] {
        let row = rows.iter().find(|r| r.x_h == x_h && r.y_h == y_h).unwrap();
        assert_eq!(row.luminaires, (x_h * 4.0 * y_h * 4.0) as usize);
        for (v, view) in [(0, View::Crosswise), (1, View::Endwise)] {
            for k in [0, 4] {
                let l_b = row.l_b_cd_per_m2[v][k];
                let table = if v == 0 {
                    row.crosswise[k]
                } else {
                    row.endwise[k]
                }
                .unwrap();
                let explicit = explicit_ugr(&d, size_m, (x_h, y_h), view, l_b);
                assert!(
                    (table - explicit).abs() < 0.5,
                    "{x_h}H × {y_h}H {view:?} {:?}: table {table:.2}, explicit {explicit:.2}",
                    REFLECTANCES[k]
                );
            }
        }
        // the luminaire is brighter along C0: seen crosswise (C0 toward the eye) it glares more
        assert!(
            row.crosswise[0].unwrap() > row.endwise[0].unwrap() + 0.5,
            "{row:?}"
        );
        // darker walls and ceiling: less background, more glare
        assert!(
            row.crosswise[4].unwrap() > row.crosswise[0].unwrap(),
            "{row:?}"
        );
    }
    // no opening: not computed, with the reason
    assert!(ugr_table::uncorrected_rows(&d, 0.0).is_err());
}

/// office_a's report carries the table of its one luminaire type under `ugr_table`, and the
/// page prints it; the flux correction is CIE 190's `8 log10(Φ/1000)`.
#[test]
fn office_a_report_has_the_ugr_table_appendix() {
    let scene = Scene::load(&office_a(), &LoadOptions::default()).expect("office_a loads");
    let model = compute_model(&scene, &Settings::default()).expect("model");
    let bytes = build_image(
        &model,
        &ImageOptions {
            scene_name: scene.name.clone(),
            geometry: Some(section_of(&scene, &model, &CommissionRecord::default())),
            ..ImageOptions::default()
        },
    )
    .expect("image");
    let image = Image::parse(&bytes).unwrap();
    let r = report::compute(&image, &ReportOptions::default()).unwrap();
    let t = &r.results.ugr_table;
    assert_eq!(t.len(), 1, "one luminaire type");
    assert_eq!(t[0].ids.len(), scene.luminaires.len());
    assert_eq!(t[0].rows.len(), 19);
    let flux = scene.luminaires[0].flux_lm;
    assert!((t[0].flux_correction - 8.0 * (flux / 1000.0).log10()).abs() < 1e-9);
    assert!(t[0].rows.iter().all(|row| {
        row.crosswise
            .iter()
            .chain(&row.endwise)
            .all(|c| c.is_some())
    }));
    let json = serde_json::to_value(&r.results).unwrap();
    assert_eq!(json["ugr_table"][0]["rows"].as_array().unwrap().len(), 19);
    let html = report::html(&r);
    assert!(html.contains("id=\"ugr-table\""));
    assert_eq!(html.matches("class=\"ugr-table\"").count(), 1);
}

/// A room commissioned from office_a's capture with a room plan whose window the camera does not
/// see, and a site: the image holds daylight coefficients, and the report gives each desk
/// sensor's daylight factor under the CIE overcast sky. Checked against the test's own sum over
/// the image's coefficients with the overcast sky written out here (`L = L_z (1 + 2 sin h)/3`,
/// `E_out = 7π L_z / 9` in closed form, the ground `ρ_g E_out / π`): within 1.5 % (the report
/// takes E_out as the Tregenza sum, 0.4 % from the closed form). F_D is the node's control over
/// a year from those factors, and LENI counts it.
#[test]
fn a_daylight_section_gives_each_desk_sensor_its_daylight_factor() {
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("room.json");
    std::fs::write(
        &plan,
        r#"{
  "format": "luxnode-room-plan/1",
  "outline_m": [[0.0, 0.0], [6.0, 0.0], [6.0, 7.2], [0.0, 7.2]],
  "floor_z_m": 0.0,
  "ceiling_z_m": 3.0,
  "site": {"latitude_deg": 47.4, "longitude_deg": 8.5, "north": [0.0, 1.0]},
  "windows": [{"id": "window_1", "transmittance": 0.7,
    "corners_m": [[1.0, 7.2, 0.9], [5.0, 7.2, 0.9], [5.0, 7.2, 2.4], [1.0, 7.2, 2.4]]}]
}"#,
    )
    .unwrap();
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
        .arg("--room-plan")
        .arg(&plan)
        .arg("--out")
        .arg(&img)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("report");
    let o = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args(["report", "--image"])
        .arg(&img)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let bytes = std::fs::read(&img).unwrap();
    let image = Image::parse(&bytes).unwrap();
    let d = image.daylight.expect("a daylight section");
    let day = &json["energy"]["daylight"];
    assert!((day["latitude_deg"].as_f64().unwrap() - 47.4).abs() < 1e-9);
    let sensors = day["sensors"].as_array().unwrap();
    assert_eq!(sensors.len(), image.sensors());
    // the overcast sky written out, patch by patch (Tregenza centres)
    let e_out = 7.0 * std::f64::consts::PI / 9.0;
    let lum: Vec<f64> = luxnode::sky::patches()
        .map(|p| (1.0 + 2.0 * p.altitude_rad.sin()) / 3.0)
        .collect();
    let mut on_desks = 0;
    for (k, row) in sensors.iter().enumerate() {
        let e_in: f64 = (0..145).map(|j| d.sensor_lx(k, j) * lum[j]).sum::<f64>()
            + d.sensor_lx(k, 145) * d.ground_rho * e_out / std::f64::consts::PI;
        let want_pct = 100.0 * e_in / e_out;
        let got = row["d_pct"].as_f64().unwrap();
        assert!(want_pct > 0.0, "sensor {k}: no daylight");
        assert!(
            (got / want_pct - 1.0).abs() < 0.015,
            "sensor {k}: {got} vs {want_pct}"
        );
        if !row["desk"].is_null() {
            on_desks += 1;
        }
    }
    assert!(on_desks > 0, "{day}");
    let a = &json["energy"]["assumptions"];
    // F_D from the node's control over a year (render::daylight_year's closed-form tests):
    // office_a's 6 m² window at 47.4° N saves about a quarter over the daylight hours
    let f_d = a["f_d"].as_f64().unwrap();
    let year = &json["energy"]["daylight_year"];
    let ratio = year["with_daylight_kwh"].as_f64().unwrap()
        / year["without_daylight_kwh"].as_f64().unwrap();
    assert!((f_d - ratio).abs() < 1e-12, "{f_d} vs {year}");
    assert!((0.6..0.95).contains(&f_d), "{f_d}");
    let why = a["f_d_source"].as_str().unwrap();
    assert!(
        why.contains("daylight factor") && why.contains("overcast"),
        "{why}"
    );
    // and LENI's W_L counts it: Σ P_n F_C (t_D F_O F_D + t_N F_O) / 1000
    let e = &json["energy"];
    let f = |k: &str| a[k].as_f64().unwrap();
    let w_l = e["installed_w"].as_f64().unwrap()
        * f("f_c")
        * (f("t_d_h") * f("f_o") * f_d + f("t_n_h") * f("f_o"))
        / 1000.0;
    assert!((e["w_l_kwh"].as_f64().unwrap() / w_l - 1.0).abs() < 1e-9);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("id=\"daylight-factors\""));
}
