//! Photometry against independent references: Photometric Toolbox flux for the lab files,
//! declared light output ratios, the edge-case files' documented values, and round trips.

mod common;
use common::shared;

use luxnode::photometry::{ErrorKind, IntensityDistribution, Symmetry};

fn load(rel: &str) -> IntensityDistribution {
    let p = shared(rel);
    IntensityDistribution::load(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn ies_lab_files_match_photometric_toolbox_flux() {
    // reference/photometry/README.md: reference flux by Photometric Toolbox; tolerance 0.5 %.
    let reference = [
        ("1.ies", 9217.18, Symmetry::Quadrant),
        ("2.ies", 5834.2, Symmetry::AboutC0C180),
        ("3.ies", 13359.57, Symmetry::None),
        ("4.ies", 5821.76, Symmetry::AboutC0C180),
        ("5.ies", 753.8, Symmetry::Quadrant),
        ("6.ies", 9230.16, Symmetry::None),
        ("7.ies", 531.98, Symmetry::Rotational),
        ("8.ies", 828.32, Symmetry::AboutC0C180),
    ];
    for (file, flux_lm, symmetry) in reference {
        let d = load(&format!("photometry/ies-lab/{file}"));
        let rel = (d.flux_lm() - flux_lm) / flux_lm;
        println!(
            "{file}: {:.2} lm vs {flux_lm} lm ({:+.3} %)",
            d.flux_lm(),
            100.0 * rel
        );
        assert!(
            rel.abs() < 0.005,
            "{file}: {} lm vs {flux_lm} lm",
            d.flux_lm()
        );
        assert_eq!(d.symmetry(), symmetry, "{file}");
        assert!(
            d.meta.absolute,
            "{file} is absolute photometry (lumens = -1)"
        );
    }
}

#[test]
fn ledvance_eulumdat_reproduces_declared_light_output_ratio() {
    // Integrating the cd/klm table must give LORL/100 x lamp flux within 0.5 %.
    for (file, lamp_lm, lorl_pct) in [
        (
            "4058075580596_FL_MAX_LUM_600W_757_SYM_30_WAL.ldt",
            81000.0,
            99.9,
        ),
        (
            "4058075580657_FL_MAX_LUM_900W_757_ASYM_50X110_WAL.ldt",
            123000.0,
            99.8,
        ),
        (
            "4058075580688_FL_MAX_LUM_1200W_757_SYM_60_WAL.ldt",
            161000.0,
            99.9,
        ),
    ] {
        let d = load(&format!("photometry/ldt-manufacturer/{file}"));
        let expected = lorl_pct / 100.0 * lamp_lm;
        let rel = (d.flux_lm() - expected) / expected;
        println!(
            "{file}: {:.0} lm vs {expected:.0} lm ({:+.3} %)",
            d.flux_lm(),
            100.0 * rel
        );
        assert!(rel.abs() < 0.005, "{file}");
        assert_eq!(d.meta.lamp_flux_lm, Some(lamp_lm));
        assert_eq!(d.meta.declared_lor_pct, Some(lorl_pct));
        assert_eq!(d.symmetry(), Symmetry::None);
        // measured to 90° only: nothing above the horizon
        assert_eq!(d.intensity_cd(0.0, 100f64.to_radians()), 0.0);
    }
}

#[test]
fn interlight_ovni_multiplier_applied_once() {
    // physics.md §10 F4: multiplier 0.4597, lumens -1: nadir 1917.09 cd, flux 5300.7 ± 1 lm
    let d = load("photometry/ies-edge/Indoor_60W_120G_5300LM_5000K_OVNI.ies");
    assert!(
        (d.intensity_cd(0.0, 0.0) - 1917.09).abs() < 0.01,
        "{}",
        d.intensity_cd(0.0, 0.0)
    );
    assert!((d.flux_lm() - 5300.7).abs() < 1.0, "{}", d.flux_lm());
    assert!(d.meta.absolute);
    // ISO-8859-1 keyword bytes survive as text
    assert!(d.meta.keywords.iter().any(|(k, _)| k == "LUMINAIRE"));
}

#[test]
fn edge_files_parse() {
    let abs = load("photometry/ies-edge/ABSOLUTE_LED.ies");
    assert!(abs.meta.absolute);
    assert!((abs.intensity_cd(0.0, 0.0) - 3500.0).abs() < 1e-9);
    let maxwell = load("photometry/ies-edge/MAXWELL-8-T4_MEASURED_IESNA.ies");
    assert_eq!(maxwell.c_grid_deg().len(), 72);
    assert_eq!(maxwell.gamma_grid_deg().len(), 91);
    // relative photometry: 1 lamp of 1000 lm, LOR of a measured luminaire near 100 %
    let lor = maxwell.lor_pct().unwrap();
    assert!((lor - 100.0).abs() < 0.5, "{lor}");
}

#[test]
fn tilt_include_factors_are_applied() {
    // physics.md §10 F6: factors 1.00/0.90/0.80/1.00 at 0/45/90/180 degrees
    let d = load("photometry/ies-edge/TILT_TEST_SYNTHETIC.ies");
    let t = d.meta.tilt.as_ref().expect("TILT=INCLUDE table");
    assert_eq!(t.angles_deg, vec![0.0, 45.0, 90.0, 180.0]);
    assert_eq!(t.factors, vec![1.0, 0.9, 0.8, 1.0]);
    let nadir = d.intensity_cd(0.0, 0.0);
    for (tilt_deg, factor) in [
        (0.0, 1.0),
        (45.0, 0.9),
        (90.0, 0.8),
        (180.0, 1.0),
        (22.5, 0.95),
    ] {
        let tilted = d.with_installed_tilt(f64::to_radians(tilt_deg));
        assert!(
            (tilted.intensity_cd(0.0, 0.0) - factor * nadir).abs() < 1e-9,
            "{tilt_deg}"
        );
        assert!((tilted.flux_lm() - factor * d.flux_lm()).abs() < 1e-9 * d.flux_lm());
    }
}

#[test]
fn tilt_file_reference_is_an_error_not_ignored() {
    let text = std::fs::read_to_string(shared("photometry/ies-edge/TILT_TEST_SYNTHETIC.ies"))
        .unwrap()
        .replace("TILT=INCLUDE", "TILT=HPS_BASE_UP.TLT");
    let err = IntensityDistribution::from_ies_str(&text).unwrap_err();
    assert!(matches!(err.kind, ErrorKind::Unsupported(_)), "{err}");
    assert!(err.to_string().contains("HPS_BASE_UP.TLT"));
}

/// Every sample of `a` and `b` on a 1° grid agrees within `rel` of the local value (with a
/// floor of 1e-6 of the peak, for zeros).
fn assert_same_distribution(
    a: &IntensityDistribution,
    b: &IntensityDistribution,
    rel: f64,
    what: &str,
) {
    let peak = a.max_intensity().0.max(b.max_intensity().0);
    let mut worst: f64 = 0.0;
    for ic in 0..360 {
        for ig in 0..=180 {
            let (c, g) = (f64::from(ic).to_radians(), f64::from(ig).to_radians());
            let (x, y) = (a.intensity_cd(c, g), b.intensity_cd(c, g));
            let err = (x - y).abs() / (x.abs().max(y.abs()) + 1e-6 * peak);
            worst = worst.max(err);
            assert!(err <= rel, "{what}: C{ic} γ{ig}: {x} vs {y}");
        }
    }
    println!("{what}: worst relative difference {worst:.2e}");
}

#[test]
fn office_a_ldt_and_ies_are_the_same_distribution() {
    // Two independent files of one luminaire (EULUMDAT 0..180° and IES 0..90°): every sample
    // within 0.1 %.
    let ldt = load("scenes/office_a/luminaire.ldt");
    let ies = load("scenes/office_a/luminaire.ies");
    assert!((ldt.flux_lm() - 7913.0).abs() < 0.01 * 7913.0);
    assert_same_distribution(&ldt, &ies, 1e-3, "office_a ldt vs ies");
}

#[test]
fn round_trips_between_formats_keep_every_sample() {
    let files = [
        "photometry/ies-lab/1.ies",
        "photometry/ies-lab/2.ies",
        "photometry/ies-lab/3.ies",
        "photometry/ies-lab/7.ies",
        "photometry/ies-lab/8.ies",
        "photometry/ies-edge/Indoor_60W_120G_5300LM_5000K_OVNI.ies",
        "photometry/ies-edge/TILT_TEST_SYNTHETIC.ies",
        "photometry/ldt-manufacturer/4058075580657_FL_MAX_LUM_900W_757_ASYM_50X110_WAL.ldt",
        "scenes/office_a/luminaire.ldt",
        "scenes/office_a/luminaire.ies",
    ];
    for f in files {
        let d = load(f);
        let via_ies = IntensityDistribution::from_ies_str(&d.to_ies()).unwrap();
        assert_same_distribution(&d, &via_ies, 1e-3, &format!("{f} -> IES"));
        let via_ldt = IntensityDistribution::from_ldt_str(&d.to_ldt().unwrap()).unwrap();
        assert_same_distribution(&d, &via_ldt, 1e-3, &format!("{f} -> LDT"));
        let back = IntensityDistribution::from_ies_str(&via_ldt.to_ies()).unwrap();
        assert_same_distribution(&d, &back, 1e-3, &format!("{f} -> LDT -> IES"));
        assert_eq!(via_ldt.symmetry(), d.symmetry(), "{f}: symmetry kept");
        assert!((via_ldt.flux_lm() - d.flux_lm()).abs() < 1e-6 * d.flux_lm());
    }
}

#[test]
fn isym3_file_written_in_spec_layout_unfolds_per_spec() {
    // physics.md §10 F2 through a real file: rows C270..C90, each 1000 + its angle.
    let mut s = String::new();
    let mut line = |x: &str| {
        s.push_str(x);
        s.push_str("\r\n");
    };
    for x in ["isym3 test", "3", "3", "24", "15", "3", "45"] {
        line(x);
    }
    for _ in 0..5 {
        line("-");
    }
    for x in [
        "0", "0", "0", "0", "0", "0", "0", "0", "0", "100", "100", "1", "0", "1",
    ] {
        line(x);
    }
    for x in ["1", "LED", "1000", "", "", "10"] {
        line(x);
    }
    for _ in 0..10 {
        line("0");
    }
    for i in 0..24 {
        line(&(15 * i).to_string());
    }
    for g in ["0", "45", "90"] {
        line(g);
    }
    for r in 0..13 {
        let c = (270 + 15 * r) % 360;
        for _ in 0..3 {
            line(&(1000 + c).to_string());
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("isym3.ldt");
    std::fs::write(&path, s).unwrap();
    let d = IntensityDistribution::load(&path).unwrap();
    let expected = [
        (0.0, 1000.0),
        (30.0, 1030.0),
        (90.0, 1090.0),
        (120.0, 1060.0),
        (180.0, 1000.0),
        (210.0, 1330.0),
        (270.0, 1270.0),
        (300.0, 1300.0),
    ];
    for (c, want) in expected {
        let got = d.intensity_cd(f64::to_radians(c), f64::to_radians(45.0));
        assert!((got - want).abs() < 1e-9, "C{c}: {got} vs {want}");
    }
}

#[test]
fn malformed_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(shared("scenes/office_a/luminaire.ldt")).unwrap();
    // truncated: drop the last 20 lines
    let lines: Vec<&str> = good.lines().collect();
    let truncated = lines[..lines.len() - 20].join("\r\n");
    let p = dir.path().join("truncated.ldt");
    std::fs::write(&p, truncated).unwrap();
    let e = IntensityDistribution::load(&p).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Truncated { .. }), "{e}");
    assert!(e.to_string().contains("truncated.ldt"), "{e}");
    // garbage
    let p = dir.path().join("garbage.ies");
    std::fs::write(&p, [0u8, 159, 146, 150, 255, 10, 13]).unwrap();
    assert!(IntensityDistribution::load(&p).is_err());
    // missing
    let e = IntensityDistribution::load(&dir.path().join("nope.ldt")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io(_)), "{e}");
}
