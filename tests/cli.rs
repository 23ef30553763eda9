//! The `luxnode` binary as a user runs it: outputs, JSON keys, exit codes.

mod common;
use common::shared;

use std::process::{Command, Output};

/// Runs the binary, through `LUXNODE_TEST_RUNNER` when set (cross-compiled tests run the
/// target's binary under an emulator, e.g. `qemu-aarch64 -L /usr/aarch64-linux-gnu`).
fn luxnode(args: &[&str]) -> Output {
    let bin = env!("CARGO_BIN_EXE_luxnode");
    let runner = std::env::var("LUXNODE_TEST_RUNNER").unwrap_or_default();
    let mut words = runner.split_whitespace();
    let mut cmd = match words.next() {
        Some(emulator) => {
            let mut c = Command::new(emulator);
            c.args(words).arg(bin);
            c
        }
        None => Command::new(bin),
    };
    cmd.args(args)
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

// The main job (`luxnode run --board boards/sim/board.toml`) is tested in tests/hil.rs.

fn office_a() -> String {
    shared("scenes/office_a").to_str().unwrap().to_owned()
}

#[test]
fn simulate_states_file_prints_the_truth_shape() {
    let states = shared("scenes/office_a/truth.csv");
    let o = luxnode(&[
        "simulate",
        "--scene",
        &office_a(),
        "--states",
        states.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = stdout(&o);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("scenario_id,sensor_id,lux"));
    let rows: Vec<&str> = lines.collect();
    // truth.csv repeats each scenario for every sensor: each counts once
    assert_eq!(rows.len(), 31 * 8);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("against") && err.contains("truth.csv"),
        "{err}"
    );
}

#[test]
fn simulate_subsets_and_json() {
    let o = luxnode(&[
        "simulate",
        "--scene",
        &office_a(),
        "--on",
        "1,3,8",
        "--format",
        "json",
        "--rays",
        "300",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let sc = &v["scenarios"][0];
    assert_eq!(sc["luminaires_on"], serde_json::json!([1, 3, 8]));
    assert_eq!(sc["sensors"].as_array().unwrap().len(), 8);
    assert!(sc["sensors"][1]["lux"].as_f64().unwrap() > 100.0);
}

#[test]
fn simulate_rejects_bad_states() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("states.csv");
    std::fs::write(&bad, "scenario_id,luminaires_on\n1,1;99\n").unwrap();
    let o = luxnode(&[
        "simulate",
        "--scene",
        &office_a(),
        "--states",
        bad.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("luminaire 99"));
    std::fs::write(&bad, "scenario_id,luminaires_on\n1,1;x\n").unwrap();
    let o = luxnode(&[
        "simulate",
        "--scene",
        &office_a(),
        "--states",
        bad.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("states.csv:2"));
    let o = luxnode(&["simulate", "--scene", &office_a(), "--rays", "0"]);
    assert!(!o.status.success());
}

#[test]
fn simulate_map_writes_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("map.png");
    let o = luxnode(&[
        "simulate",
        "--scene",
        &office_a(),
        "--all-on",
        "--map",
        png.to_str().unwrap(),
        "--map-cell",
        "0.25",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let err = String::from_utf8_lossy(&o.stderr);
    // each desk's mean is printed, and desks under all luminaires are in the 1000s of lux
    let means: Vec<f64> = err
        .lines()
        .filter_map(|l| {
            l.trim()
                .strip_prefix("desk ")?
                .split("mean ")
                .nth(1)?
                .split(' ')
                .next()?
                .parse()
                .ok()
        })
        .collect();
    assert_eq!(means.len(), 5, "{err}");
    assert!(
        means.iter().all(|m| *m > 1000.0 && *m < 2000.0),
        "{means:?}"
    );
}

#[test]
fn image_build_info_and_simulate_from_the_image_alone() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("office_a.img");
    let o = luxnode(&[
        "image",
        "build",
        "--scene",
        &office_a(),
        "--out",
        img.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = luxnode(&["image", "info", img.to_str().unwrap()]);
    assert!(o.status.success());
    let info = stdout(&o);
    for key in [
        "format version:   1",
        "checksums:        header and payload OK",
        "FORMFACTORS:",
        "form factors",
    ] {
        assert!(info.contains(key), "{key} in\n{info}");
    }
    // answers from the image equal the scene's at the same settings (values to 1e-3 lx)
    let states = shared("scenes/office_a/states.csv");
    let from_image = luxnode(&[
        "simulate",
        "--image",
        img.to_str().unwrap(),
        "--states",
        states.to_str().unwrap(),
    ]);
    let from_scene = luxnode(&[
        "simulate",
        "--scene",
        &office_a(),
        "--states",
        states.to_str().unwrap(),
    ]);
    assert!(
        from_image.status.success(),
        "{}",
        String::from_utf8_lossy(&from_image.stderr)
    );
    let parse = |o: &Output| -> Vec<f64> {
        stdout(o)
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    };
    let (a, b) = (parse(&from_image), parse(&from_scene));
    assert_eq!(a.len(), 248);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 2e-5 * y.max(1.0) + 1e-3, "{x} vs {y}");
    }
}

#[test]
fn damaged_images_are_refused_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("demo.img");
    let o = luxnode(&[
        "image",
        "build",
        "--scene",
        "demo-office",
        "--out",
        img.to_str().unwrap(),
        "--patch-size",
        "2",
        "--rays",
        "100",
        "--precision",
        "u8",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut bytes = std::fs::read(&img).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(&img, &bytes).unwrap();
    for args in [
        vec!["image", "info", img.to_str().unwrap()],
        vec!["simulate", "--image", img.to_str().unwrap()],
    ] {
        let o = luxnode(&args);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("payload CRC mismatch"), "{err}");
    }
    std::fs::write(&img, &bytes[..100]).unwrap();
    let o = luxnode(&["image", "info", img.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("truncated"), "{err}");
    assert_eq!(doubled_word(&err), None, "{err}");
}

/// The first word said twice in a row (`image: image`, `error: error`), if any (issue 31).
fn doubled_word(text: &str) -> Option<String> {
    let words: Vec<String> = text
        .split(|c: char| c.is_whitespace() || c == ':' || c == ',')
        .filter(|w| !w.is_empty())
        .map(str::to_lowercase)
        .collect();
    words
        .windows(2)
        .find(|w| w[0] == w[1] && w[0].chars().all(char::is_alphabetic))
        .map(|w| w[0].clone())
}

#[test]
fn an_image_too_large_for_formfactors_names_the_knobs() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("big.img");
    let o = luxnode(&[
        "image",
        "build",
        "--scene",
        &office_a(),
        "--out",
        img.to_str().unwrap(),
        "--precision",
        "f64",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("over the") && err.contains("FORMFACTORS") && err.contains("--precision f16"),
        "{err}"
    );
    assert!(!img.exists());
}

/// `luxnode report` from an image file: report.html and results.json with the desks and the
/// states of a states file; an image without the geometry section is refused with the reason.
#[test]
fn report_from_an_image_and_a_states_file() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("office_a.img");
    let o = luxnode(&[
        "image",
        "build",
        "--scene",
        &office_a(),
        "--out",
        img.to_str().unwrap(),
        "--preset",
        "fast",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let states = dir.path().join("states.csv");
    std::fs::write(
        &states,
        "scenario_id,luminaires_on\nall,1;2;3;4;5;6;7;8\nleft,1;3;5;7\n",
    )
    .unwrap();
    let out = dir.path().join("report");
    let o = luxnode(&[
        "report",
        "--image",
        img.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--states",
        states.to_str().unwrap(),
        "--maintenance-factor",
        "0.7",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["preset"], "fast");
    assert_eq!(json["maintenance_factor"], 0.7);
    assert_eq!(json["states"].as_array().unwrap().len(), 2);
    assert_eq!(json["states"][1]["name"], "left");
    assert_eq!(json["desks"].as_array().unwrap().len(), 5);
    assert!(out.join("report.html").exists());
    // UGR per desk observer and the verdict with its reasons, as results.json has them
    let stdout = String::from_utf8_lossy(&o.stdout);
    for obs in json["ugr"]["observers"].as_array().unwrap() {
        let line = format!(
            "UGR desk {}: {:.1}",
            obs["desk"],
            obs["ugr"].as_f64().unwrap()
        );
        assert!(stdout.contains(&line), "{line} not in {stdout}");
    }
    let verdict = if json["pass"].as_bool().unwrap() {
        "EN 12464-1:2021: pass".to_string()
    } else {
        let why: Vec<&str> = json["fails_because"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap())
            .collect();
        format!("EN 12464-1:2021: fail because {}", why.join("; "))
    };
    assert!(stdout.contains(&verdict), "{verdict} not in {stdout}");
    // a state naming a luminaire the image does not have
    std::fs::write(&states, "scenario_id,luminaires_on\nbad,1;99\n").unwrap();
    let o = luxnode(&[
        "report",
        "--image",
        img.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--states",
        states.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("luminaire 99"));
    // without the geometry section
    let bare = dir.path().join("bare.img");
    let o = luxnode(&[
        "image",
        "build",
        "--scene",
        &office_a(),
        "--out",
        bare.to_str().unwrap(),
        "--preset",
        "fast",
        "--no-geometry",
    ]);
    assert!(o.status.success());
    let o = luxnode(&[
        "report",
        "--image",
        bare.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("no geometry section"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn commission_takes_one_capture_set_per_node() {
    // two nodes at the same pose see the same room: the merged model is the single node's but
    // for the merge's seams (2322 patches for 2308; a desk's camera calibration, a tie, goes to
    // the second node), and each node gets its own image
    let s = "reference/scenes/office_a";
    let dir = tempfile::tempdir().unwrap();
    let path = |f: &str| dir.path().join(f).to_string_lossy().into_owned();
    let (a, b, one) = (path("a.img"), path("b.img"), path("one.img"));
    let common = [
        "commission",
        "--luminaires",
        &format!("{s}/luminaires.json"),
        "--sensors",
        &format!("{s}/sensors.json"),
        "--truth",
        &format!("{s}/truth.csv"),
        "--states",
        &format!("{s}/states.csv"),
    ]
    .map(String::from);
    let run = |extra: &[&str]| {
        let mut args: Vec<&str> = common.iter().map(String::as_str).collect();
        args.extend(extra);
        luxnode(&args)
    };
    let cap = format!("{s}/capture");
    let single = run(&["--capture", &cap, "--out", &one]);
    let pair = run(&[
        "--capture",
        &cap,
        "--capture",
        &cap,
        "--out",
        &a,
        "--out",
        &b,
    ]);
    let text = |o: &Output| String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        single.status.success() && pair.status.success(),
        "{}",
        text(&pair)
    );
    let error = |t: &str| -> f64 {
        let line = t
            .lines()
            .find(|l| l.starts_with("error, all sensors:"))
            .unwrap_or_else(|| panic!("{t}"));
        line.split_whitespace().nth(3).unwrap().parse().unwrap()
    };
    let (e1, e2) = (error(&text(&single)), error(&text(&pair)));
    // measured: 3.40 / 3.44 % (stop 52), 3.51 / 3.60 % (stop 53's window fit, depth gate and
    // one material per desk top, which the seams' extra patches move; not bisected)
    assert!((e1 - e2).abs() < 0.2, "one node {e1} %, two {e2} %");
    for img in [&a, &b] {
        let len = std::fs::metadata(img).unwrap().len();
        assert!(len > 1_000_000, "{img}: {len} bytes");
    }
    // one image per capture set
    let o = run(&["--capture", &cap, "--capture", &cap, "--out", &a]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("one image per capture set"), "{err}");
}

/// Issue 31: an error names each cause once (a typed error that carries its source's text was
/// printed with it again: "No such file or directory (os error 2): No such file or directory
/// (os error 2)"), on one line after "error: ".
#[test]
fn an_error_names_its_cause_once() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("missing.img");
    let o = luxnode(&["image", "info", &missing.to_string_lossy()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    let line = err
        .lines()
        .find(|l| l.starts_with("error: "))
        .expect("an error line");
    assert!(line.contains("missing.img"), "{line}");
    let cause = std::io::Error::from(std::io::ErrorKind::NotFound).to_string();
    let os = "(os error 2)";
    assert_eq!(line.matches(os).count(), 1, "{line} ({cause})");
}

/// The subcommands listed under "Commands:" in a help text (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim() != "Commands:")
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_owned)
        .collect()
}

/// The argument blocks of a help text: each argument's heading line (`--room <X0,Y0,X1,Y1>`)
/// and its whole help (the heading's tail and the indented lines below it).
fn argument_blocks(help: &str) -> Vec<(String, String)> {
    let mut blocks: Vec<(String, String)> = Vec::new();
    let mut in_args = false;
    for line in help.lines() {
        if line.ends_with(':') && !line.starts_with(' ') {
            in_args = line == "Options:" || line == "Arguments:";
            continue;
        }
        if !in_args {
            continue;
        }
        let body = line.trim_start();
        let indent = line.len() - body.len();
        if indent <= 6 && (body.starts_with('-') || body.starts_with('<')) {
            let (head, tail) = body.split_once("  ").unwrap_or((body, ""));
            blocks.push((head.to_owned(), tail.trim().to_owned()));
        } else if let Some(last) = blocks.last_mut() {
            last.1.push('\n');
            last.1.push_str(body);
        }
    }
    blocks
}

/// What is wrong with one argument's help: a default written by hand (clap's own
/// `[default: …]` ends the block), a value name in lower case or repeated (`<ROOM> <ROOM>`).
fn help_problems(path: &str, head: &str, text: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let text = text.trim_end();
    let own = text
        .rfind("[default: ")
        .filter(|&at| text[at..].ends_with(']') && !text[at..].contains(", "));
    let hand = &text[..own.unwrap_or(text.len())].to_lowercase();
    if hand.contains("default:") || hand.contains("[default") || hand.contains("(default") {
        problems.push(format!("{path} {head}: a hand-written default in {text:?}"));
    }
    let names: Vec<&str> = head
        .split('<')
        .skip(1)
        .filter_map(|s| s.split_once('>').map(|(n, _)| n))
        .collect();
    for (i, n) in names.iter().enumerate() {
        if *n != n.to_uppercase() {
            problems.push(format!("{path} {head}: value name <{n}> not upper-case"));
        }
        if names[..i].contains(n) {
            problems.push(format!("{path} {head}: value name <{n}> repeated"));
        }
    }
    problems
}

/// Issue 31 item 7: every subcommand's `--help` in one style (clap's own defaults, value names
/// that say the format), and the README's command list names every top-level subcommand.
#[test]
fn every_help_is_in_one_style_and_the_readme_lists_every_command() {
    let top = stdout(&luxnode(&["--help"]));
    let mut todo: Vec<Vec<String>> = subcommands(&top).into_iter().map(|c| vec![c]).collect();
    let mut problems = Vec::new();
    let mut seen = 0;
    while let Some(path) = todo.pop() {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let o = luxnode(&args);
        assert!(o.status.success(), "{args:?}");
        let help = stdout(&o);
        seen += 1;
        for sub in subcommands(&help) {
            let mut p = path.clone();
            p.push(sub);
            todo.push(p);
        }
        for (head, text) in argument_blocks(&help) {
            problems.extend(help_problems(&path.join(" "), &head, &text));
            // the prose, not the possible values' list (`- ies: IES`)
            let prose: Vec<&str> = text.lines().filter(|l| !l.starts_with("- ")).collect();
            if let Some(w) = doubled_word(&prose.join("\n")) {
                problems.push(format!("{path:?} {head}: {w:?} twice in a row"));
            }
        }
    }
    assert!(seen > 30, "only {seen} subcommands walked");
    assert!(problems.is_empty(), "{}", problems.join("\n"));

    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let section = readme
        .split("\n## Command line")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("README section \"## Command line\"");
    let listed: std::collections::BTreeSet<&str> = section
        .split("```")
        .nth(1)
        .expect("a code block")
        .lines()
        .filter_map(|l| l.strip_prefix("luxnode "))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    let actual: std::collections::BTreeSet<String> = subcommands(&top).into_iter().collect();
    let actual: std::collections::BTreeSet<&str> = actual.iter().map(String::as_str).collect();
    assert_eq!(
        listed, actual,
        "README \"## Command line\" against `luxnode --help`"
    );
}
