//! The `luxnode` binary as a user runs it: outputs, JSON keys, exit codes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared")
        .join(rel)
}

fn luxnode(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run luxnode")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn photometry_json_summary() {
    let f = shared("photometry/ies-lab/3.ies");
    let o = luxnode(&["photometry", f.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["format"], "IES LM-63-2002");
    assert_eq!(v["symmetry"], "none");
    let flux = v["flux_lm"].as_f64().unwrap();
    assert!((flux - 13359.57).abs() / 13359.57 < 0.005, "{flux}");
    assert!(v["max_cd"].as_f64().unwrap() > 0.0);
}

#[test]
fn photometry_text_summary_and_csv() {
    let f = shared("scenes/office_a/luminaire.ldt");
    let o = luxnode(&["photometry", f.to_str().unwrap()]);
    assert!(o.status.success());
    let text = stdout(&o);
    for key in [
        "format:",
        "symmetry:",
        "C planes:",
        "gamma angles:",
        "total flux:",
        "max intensity:",
    ] {
        assert!(text.contains(key), "missing {key} in\n{text}");
    }
    assert!(text.contains("7913.0"), "{text}");

    let o = luxnode(&["photometry", f.to_str().unwrap(), "--csv"]);
    assert!(o.status.success());
    let csv = stdout(&o);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("c_deg,gamma_deg,intensity_cd"));
    // 24 C planes x 37 gamma angles (0..180 every 5°)
    assert_eq!(lines.count(), 24 * 37);
}

#[test]
fn photometry_conversion_writes_files_that_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let ies_out = dir.path().join("out.ies");
    let ldt_out = dir.path().join("out.ldt");
    let f = shared("photometry/ies-lab/2.ies");
    let o = luxnode(&[
        "photometry",
        f.to_str().unwrap(),
        "--to-ldt",
        ldt_out.to_str().unwrap(),
        "--to-ies",
        ies_out.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success());
    for out in [&ies_out, &ldt_out] {
        let o = luxnode(&["photometry", out.to_str().unwrap(), "--json"]);
        assert!(o.status.success());
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        assert!((v["flux_lm"].as_f64().unwrap() - 5834.2).abs() / 5834.2 < 0.005);
        assert_eq!(v["symmetry"], "C0-C180");
    }
}

#[test]
fn photometry_errors_exit_non_zero_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ies");
    std::fs::write(&bad, "IESNA:LM-63-2002\nTILT=elsewhere.tlt\n").unwrap();
    let o = luxnode(&["photometry", bad.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("bad.ies") && err.contains("elsewhere.tlt"),
        "{err}"
    );
}

#[test]
fn scene_check_office_a_is_clean() {
    let o = luxnode(&[
        "scene",
        "check",
        shared("scenes/office_a").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = stdout(&o);
    assert!(text.contains("290 triangles"), "{text}");
    assert!(
        text.contains("luminaires: 8") && text.contains("sensors: 8"),
        "{text}"
    );
    assert!(text.contains("warnings: none"), "{text}");
}

#[test]
fn scene_check_fails_on_a_broken_scene() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), "v 0 0 0\nf 1 1\n").unwrap();
    let o = luxnode(&["scene", "check", dir.path().to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("scene.obj:2"), "{err}");
    assert!(
        err.contains("luminaires.json") && err.contains("sensors.json"),
        "{err}"
    );
}

#[test]
fn main_job_on_the_sim_board_summarises_the_demo_office() {
    let o = luxnode(&["run", "--board", "boards/sim/board.toml"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = stdout(&o);
    assert!(text.contains("board sim"), "{text}");
    assert!(text.contains("luminaires: 6"), "{text}");
}
