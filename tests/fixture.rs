//! The repository's own fixture scene (`tests/fixtures/small_office`, written by
//! `scripts/make-fixture-scene.py`): tests that need a scene but not the Radiance truth run
//! from it, without `../shared`. Its numbers are closed forms of its construction.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::Command;

use luxnode::photometry::IntensityDistribution;
use luxnode::scene::{LoadOptions, Scene};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/small_office")
}

fn luxnode(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args(args)
        .output()
        .expect("luxnode")
}

#[test]
fn the_fixture_loads_with_the_areas_it_was_built_with() {
    let s = Scene::load(&dir(), &LoadOptions::default()).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.mesh.triangles.len(), 26);
    assert_eq!(s.luminaires.len(), 2);
    assert_eq!(s.sensors.len(), 3);
    let area = |label: &str| -> f64 {
        s.mesh
            .triangles
            .iter()
            .filter(|t| s.mesh.groups[t.group as usize] == label)
            .map(|t| s.mesh.area_m2(t))
            .sum()
    };
    // 4 x 3 x 2.8 m room; desk 1.6 x 0.8 x 0.75 m without a bottom
    assert!((area("floor") - 12.0).abs() < 1e-9);
    assert!((area("wall_s") - 4.0 * 2.8).abs() < 1e-9);
    assert!((area("desk_1") - (1.6 * 0.8 + 2.0 * (1.6 + 0.8) * 0.75)).abs() < 1e-9);
    let total: f64 = s.mesh.triangles.iter().map(|t| s.mesh.area_m2(t)).sum();
    assert!((total - 68.8).abs() < 1e-6, "{total}");
}

#[test]
fn the_cosine_photometry_integrates_to_its_closed_form() {
    // I(γ) = I0 cos γ on the lower hemisphere emits π I0; the file is per 1000 lm
    for file in ["cosine.ldt", "cosine.ies"] {
        let d = IntensityDistribution::load(&dir().join(file)).unwrap();
        let i0 = 1000.0 / PI;
        assert!((d.intensity_cd(0.0, 0.0) - i0).abs() < 1e-3 * i0, "{file}");
        let i60 = d.intensity_cd(0.3, 60f64.to_radians());
        assert!((i60 - 0.5 * i0).abs() < 1e-3 * i0, "{file}: I(60°) = {i60}");
        assert_eq!(d.intensity_cd(1.0, 120f64.to_radians()), 0.0, "{file}");
        // the 5° table integrates to the closed form within the quadrature's error
        // (trapezoids of cos γ sin γ on a 5° grid: -0.063 %)
        let flux = d.flux_lm();
        assert!((flux / 1000.0 - 1.0).abs() < 1e-3, "{file}: {flux} lm");
        assert!(d.warnings().is_empty(), "{file}: {:?}", d.warnings());
    }
}

#[test]
fn the_cli_commissions_serves_and_evaluates_the_fixture() {
    let tmp = tempfile::tempdir().unwrap();
    let image = tmp.path().join("small.img");
    let dir = dir();
    let out = luxnode(&[
        "image",
        "build",
        "--scene",
        dir.to_str().unwrap(),
        "--out",
        image.to_str().unwrap(),
        "--preset",
        "fast",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // the image alone answers as the run-time core's full re-solve does
    let eval = luxnode(&["image", "eval", image.to_str().unwrap(), "--arc", "254,0"]);
    assert!(eval.status.success());
    let text = String::from_utf8_lossy(&eval.stdout);
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(2).map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 3, "{text}");
    for r in &rows {
        assert!(r[0] > 0.0 && (r[0] - r[1]).abs() <= 1e-6 * r[1], "{text}");
    }
    let states = dir.join("states.csv");
    let sim = luxnode(&[
        "simulate",
        "--image",
        image.to_str().unwrap(),
        "--states",
        states.to_str().unwrap(),
    ]);
    assert!(sim.status.success());
    let lux: Vec<(String, u32, f64)> = String::from_utf8_lossy(&sim.stdout)
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (
                c[0].to_owned(),
                c[1].parse().unwrap(),
                c[2].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(lux.len(), 9);
    // superposition: all on = luminaire 1 + luminaire 2, for every sensor
    for s in 1..=3 {
        let get = |sc: &str| lux.iter().find(|r| r.0 == sc && r.1 == s).unwrap().2;
        let (a, b, all) = (get("1"), get("2"), get("all"));
        assert!(
            (a + b - all).abs() <= 2e-3 * all,
            "sensor {s}: {a} + {b} vs {all}"
        );
    }
    // the image's first row (luminaire 1 at 254 = 100 %) equals simulate's scenario 1
    let s1 = lux.iter().find(|r| r.0 == "1" && r.1 == 1).unwrap().2;
    assert!(
        (rows[0][0] - s1).abs() <= 2e-3 * s1,
        "{} vs {s1}",
        rows[0][0]
    );
}

/// The engine's one solve of every luminaire at once (blocks of right-hand sides through
/// `solver::solve`) is the run-time core's one-luminaire iteration, to the last bit: the same
/// sweeps, the same sums in the same order, each right-hand side stopping on its own.
#[test]
fn the_engines_multi_solve_is_the_run_time_iteration_bit_for_bit() {
    use luxnode::engine::{self, Settings};
    use luxnode::solver::{self, CsrSystem};
    let scene = Scene::load(&dir(), &LoadOptions::default()).unwrap();
    let model = engine::compute_model(&scene, &Settings::default()).unwrap();
    let system = CsrSystem {
        f: model.ff.f.view(),
        rho: &model.patches.rho,
    };
    assert_eq!(model.basis_b.len(), 2);
    for (l, basis) in model.basis_b.iter().enumerate() {
        let mut b = vec![0.0; model.patches.rho.len()];
        let report = solver::gauss_seidel(
            &system,
            &model.direct_patch_lx[l],
            &mut b,
            model.settings.solve,
        )
        .unwrap();
        assert!(report.iterations > 3, "{report:?}");
        assert!(b.iter().any(|x| *x > 0.0));
        assert_eq!(&b, basis, "luminaire {l}");
    }
}

/// Issue 34: a one-shot command whose reader goes away ends quietly, as a Unix filter does
/// (before: "failed printing to stdout: Broken pipe", a panic and exit 101).
#[test]
fn the_cli_ends_quietly_on_a_closed_pipe() {
    use std::os::unix::process::ExitStatusExt;
    for args in [
        vec!["modbus", "map"],
        vec!["photometry", "cosine.ldt", "--csv"],
    ] {
        // the reader is gone before the command writes its first line
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_luxnode"))
            .current_dir(dir())
            .args(&args)
            .stdout(writer)
            .stderr(std::process::Stdio::piped())
            .output()
            .expect("luxnode");
        let stderr = String::from_utf8_lossy(&out.stderr);
        // ended by SIGPIPE (a shell reports 141), never a panic's 101
        assert_eq!(
            out.status.signal(),
            Some(13),
            "{args:?}: {:?} {stderr}",
            out.status
        );
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

/// Commissioning's reflectance fit solves the pass model once per luminaire; a solve that
/// fails is an error now, where it was ignored and its zeroed exitance used (issue 27).
#[test]
fn a_failed_solve_in_the_reflectance_fit_is_an_error() {
    use luxnode::commission::reflectance;
    use luxnode::engine::{self, Settings};
    use luxnode::solver::SolveError;
    let scene = Scene::load(&dir(), &LoadOptions::default()).unwrap();
    let settings = Settings::default();
    let model = engine::compute_model(&scene, &settings).unwrap();
    let ok = reflectance::indirect_lx(&model, &model.patches.rho, &[], &settings).unwrap();
    assert_eq!(ok.len(), 2);
    assert!(ok.iter().flatten().all(|e| e.is_finite() && *e >= 0.0));
    assert!(ok.iter().flatten().any(|e| *e > 0.0));
    let mut white = model.patches.rho.clone();
    white[0] = 1.0;
    let err = reflectance::indirect_lx(&model, &white, &[], &settings).unwrap_err();
    assert!(
        matches!(err, SolveError::BadReflectance { patch: 0, .. }),
        "{err}"
    );
}

/// Inverse radiosity (the reflectance fit holds the seen patches at the exitance the camera
/// measured): holding any set of patches at the forward solution's exitance leaves the solution
/// where it is, so the interreflected light equals the forward solve's, patch by patch; holding
/// them at twice theirs adds exactly the light of that extra exitance (linearity).
#[test]
fn holding_patches_at_their_exitance_reproduces_the_forward_solve() {
    use luxnode::commission::reflectance;
    use luxnode::engine::{self, Settings};
    use luxnode::solver::{self, CsrSystem};
    let scene = Scene::load(&dir(), &LoadOptions::default()).unwrap();
    let settings = Settings::default();
    let model = engine::compute_model(&scene, &settings).unwrap();
    let rho = &model.patches.rho;
    let n = rho.len();
    let forward = reflectance::indirect_lx(&model, rho, &[], &settings).unwrap();
    let sys = CsrSystem {
        f: model.ff.f.view(),
        rho,
    };
    let mut held = Vec::new();
    let mut exitance = Vec::new();
    for e in &model.direct_patch_lx {
        let mut b = vec![0.0; n];
        solver::gauss_seidel(&sys, e, &mut b, settings.solve).unwrap();
        // every third patch held
        held.push(
            (0..n)
                .map(|i| (i % 3 == 0).then_some(b[i]))
                .collect::<Vec<_>>(),
        );
        exitance.push(b);
    }
    let with_held = reflectance::indirect_lx(&model, rho, &held, &settings).unwrap();
    for (f, h) in forward.iter().flatten().zip(with_held.iter().flatten()) {
        assert!((f - h).abs() <= 1e-6 * f.abs().max(1.0), "{f} vs {h}");
    }
    // twice the exitance at the held patches: the rest solved again
    let doubled: Vec<Vec<Option<f64>>> = held
        .iter()
        .map(|h| h.iter().map(|x| x.map(|v| 2.0 * v)).collect())
        .collect();
    let more = reflectance::indirect_lx(&model, rho, &doubled, &settings).unwrap();
    let total: f64 = more.iter().flatten().sum::<f64>();
    let before: f64 = forward.iter().flatten().sum::<f64>();
    assert!(total > before, "{total} vs {before}");
}

/// Issue 34 / 31: lengths in the wrong unit are refused before any work, with the unit they look
/// like (a 4 x 3 m room read as millimetres was a valid 4 mm room; as kilometres, 4 km).
#[test]
fn a_room_in_the_wrong_unit_is_refused_with_the_unit_it_looks_like() {
    for (unit_to_m, what) in [(0.001, "4 mm"), (1000.0, "4 km")] {
        let o = LoadOptions {
            unit_to_m,
            ..LoadOptions::default()
        };
        let err = Scene::load(&dir(), &o).expect_err(what).to_string();
        assert!(
            err.contains("not a room") && err.contains("--unit m"),
            "{what}: {err}"
        );
    }
}

/// The same through the binary: `scene check --unit mm` exits non-zero and says so.
#[test]
fn the_cli_refuses_a_room_in_the_wrong_unit() {
    let out = luxnode(&["scene", "check", &dir().to_string_lossy(), "--unit", "mm"]);
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stderr) + String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("--unit m"), "{text}");
}

/// Issue 34 item 5, the unit check as a property (fixed seed): the small office read with any
/// unit length from 0.1 mm to 10 km loads exactly when its lengths then make a room (1..500 m
/// across, luminaires at most 50 m up: computed here from the scene read in metres, not by the
/// check), and a refusal always names `--unit`.
#[test]
fn the_unit_check_accepts_exactly_the_units_that_make_a_room() {
    use luxnode::scene::{MAX_LUMINAIRE_HEIGHT_M, MAX_ROOM_EXTENT_M, MIN_ROOM_EXTENT_M};
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let metres = Scene::load(&dir(), &LoadOptions::default()).expect("the fixture in metres");
    let (lo, hi) = metres.mesh.bounds_m();
    let size = hi - lo;
    let (horizontal_m, largest_m) = (size.x.max(size.y), size.max_element());
    let highest_m = metres
        .luminaires
        .iter()
        .map(|l| l.position_m.z - lo.z)
        .fold(0.0, f64::max);
    let mut runner = TestRunner::new(Config {
        cases: 64,
        rng_seed: RngSeed::Fixed(34),
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&(-4.0f64..4.0), |log_unit| {
            let unit_to_m = 10f64.powf(log_unit);
            let room = horizontal_m * unit_to_m >= MIN_ROOM_EXTENT_M
                && largest_m * unit_to_m <= MAX_ROOM_EXTENT_M
                && highest_m * unit_to_m <= MAX_LUMINAIRE_HEIGHT_M;
            let o = LoadOptions {
                unit_to_m,
                ..LoadOptions::default()
            };
            match Scene::load(&dir(), &o) {
                Ok(_) => proptest::prop_assert!(room, "unit {unit_to_m} m: loaded"),
                Err(e) => {
                    let e = e.to_string();
                    proptest::prop_assert!(!room, "unit {unit_to_m} m: {e}");
                    proptest::prop_assert!(e.contains("--unit"), "unit {unit_to_m} m: {e}");
                }
            }
            Ok(())
        })
        .expect("the unit check");
}
