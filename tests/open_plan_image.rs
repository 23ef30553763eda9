//! The open-plan floor's flash image with the fast preset (docs/accuracy.md, docs/performance.md):
//! it fits the FORMFACTORS region, and the node's answers from the image alone stay within
//! 0.34 % of Radiance (worst sensor 0.79 %; 20 % of the region), through the real binary.
use std::process::Command;

fn luxnode(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run luxnode");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The number after `key` in `text` (e.g. "error 0.28 %").
fn number_after(text: &str, key: &str) -> f64 {
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("no `{key}` in {text}"))
        + key.len();
    text[at..]
        .split_whitespace()
        .next()
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("no number after `{key}` in {text}"))
}

#[test]
fn open_plan_fast_image_fits_and_matches_radiance() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("op.img");
    let img = img.to_str().unwrap();
    let (ok, out, err) = luxnode(&[
        "image",
        "build",
        "--scene",
        "scenes/open_plan",
        "--out",
        img,
        "--preset",
        "fast",
    ]);
    assert!(ok, "{out}{err}");
    // "... N bytes (P % of the 4096 KiB FORMFACTORS region) ..."
    let usage = number_after(&out, "bytes (");
    println!("{out}");
    assert!(usage < 30.0, "{usage} % of the region");
    let (ok, out, err) = luxnode(&[
        "simulate",
        "--image",
        img,
        "--states",
        "scenes/open_plan/states.csv",
        "--truth",
        "scenes/open_plan/truth.csv",
    ]);
    assert!(ok, "{err}");
    let error = number_after(&err, "error ");
    let worst = number_after(&err, "worst sensor ");
    println!(
        "{}",
        err.lines().find(|l| l.contains("against")).unwrap_or("")
    );
    assert!(!out.is_empty());
    assert!(error < 0.5, "error {error} %");
    assert!(worst < 1.2, "worst sensor {worst} %");
}
