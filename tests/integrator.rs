//! The integrator's first hour (issue 31), through the real client programs: every `mbpoll`
//! command of the docs' code blocks runs as written against a node serving the README's main
//! job's image (the demo office: 7 desks, 6 luminaires; the sim board's address and allowlist),
//! and a node that knows no dimming state publishes "unknown" (NaN, 0xFFFF), never 0.
//!
//! mbpoll is installed by scripts/test.sh (scripts/install-test-tools.sh); without it these tests
//! fail with that message, they never pass silently.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::procs::{LUXNODE, Proc, need, spawn_listening};

/// The README's main job serves the demo office (boards/sim/board.toml, `source = "demo-office"`)
/// on this port; the examples name it, the test's node listens elsewhere.
const MAIN_JOB_PORT: &str = "1502";

/// The demo office's image, built by the CLI as the main job's commissioning would for its
/// geometry (`image build --scene demo-office`), once for the file's tests.
fn demo_image() -> PathBuf {
    let args = ["--scene", "demo-office"].map(std::ffi::OsStr::new);
    common::procs::cli_image("integrator-demo.img", &args)
}

/// `luxnode serve` on the demo office's image, writes allowed from loopback (the sim board's
/// `write_allow`), with `extra` arguments.
fn serve_demo(extra: &[&str]) -> Proc {
    let mut args: Vec<String> = vec![
        "serve".into(),
        "--image".into(),
        demo_image().display().to_string(),
        "--bind".into(),
        "127.0.0.1:0".into(),
        "--allow-writes-from".into(),
        "127.0.0.1".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    spawn_listening(LUXNODE, &args)
}

/// Every `mbpoll` line inside the fenced code blocks of `docs/*.md`: (file, the line without
/// its trailing comment).
fn documented_mbpoll_commands() -> Vec<(String, String)> {
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&docs)
        .expect("docs/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    files.sort();
    let mut found = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read doc");
        let mut fenced = false;
        for line in text.lines() {
            if line.trim_start().starts_with("```") {
                fenced = !fenced;
                continue;
            }
            let cmd = line.split('#').next().unwrap_or("").trim();
            if fenced && cmd.starts_with("mbpoll ") {
                let name = f.file_name().map(|n| n.to_string_lossy().into_owned());
                found.push((name.unwrap_or_default(), cmd.to_string()));
            }
        }
    }
    found
}

/// What an mbpoll command must give: `Read(n)` values (`-c n`, default 1), or `Written(n)`
/// (the values after the host).
#[derive(Debug, PartialEq)]
enum Expect {
    Read(usize),
    Written(usize),
}

/// The expectation of mbpoll's arguments, from its documented syntax: options with a value
/// (`-m -p -a -r -c -t -l -o -b -d -s -P`) and flags, then the host, then values to write.
fn expectation(args: &[&str]) -> Expect {
    let with_value = [
        "-m", "-p", "-a", "-r", "-c", "-t", "-l", "-o", "-b", "-d", "-s", "-P",
    ];
    let mut count = 1;
    let mut i = 0;
    while i < args.len() && args[i].starts_with('-') {
        if with_value.contains(&args[i]) {
            if args[i] == "-c" {
                count = args.get(i + 1).and_then(|c| c.parse().ok()).unwrap_or(0);
            }
            i += 1;
        }
        i += 1;
    }
    let writes = args.len().saturating_sub(i + 1);
    if writes > 0 {
        Expect::Written(writes)
    } else {
        Expect::Read(count)
    }
}

/// mbpoll's read values: the lines `[ref]: \tvalue` (decimal, hex or nan).
fn value_lines(stdout: &str) -> usize {
    stdout
        .lines()
        .filter(|l| l.starts_with('[') && l.contains("]:"))
        .count()
}

#[test]
fn mbpoll_expectations_follow_its_syntax() {
    let e = |s: &str| expectation(&s.split_whitespace().collect::<Vec<_>>());
    assert_eq!(
        e("-m tcp -p 1502 -a 1 -r 1 -c 4 -t 3 -1 127.0.0.1"),
        Expect::Read(4)
    );
    assert_eq!(
        e("-m tcp -p 1502 -r 73 -t 3:hex -1 127.0.0.1"),
        Expect::Read(1)
    );
    assert_eq!(
        e("-m tcp -p 1502 -a 1 -r 1001 -t 4 -1 127.0.0.1 254 254 0 0"),
        Expect::Written(4)
    );
    assert_eq!(value_lines("-- Polling\n[101]: \t0\n[103]: \tnan\n\n"), 2);
}

#[test]
fn every_documented_mbpoll_command_runs_against_the_main_jobs_node() {
    need("mbpoll");
    let commands = documented_mbpoll_commands();
    // docs/modbus.md's reading examples and its occupancy examples at least
    assert!(
        commands.len() >= 6,
        "expected the docs' mbpoll examples, found {commands:?}"
    );
    let node = serve_demo(&[]);
    let port = node.addr.port().to_string();
    for (doc, cmd) in &commands {
        let words: Vec<&str> = cmd.split_whitespace().skip(1).collect();
        let p = words.iter().position(|w| *w == "-p");
        assert!(
            p.and_then(|p| words.get(p + 1)) == Some(&MAIN_JOB_PORT),
            "{doc}: `{cmd}` is not against the main job's port {MAIN_JOB_PORT}"
        );
        let args: Vec<&str> = words
            .iter()
            .enumerate()
            .map(|(i, w)| {
                if Some(i) == p.map(|p| p + 1) {
                    &port
                } else {
                    *w
                }
            })
            .collect();
        let out = Command::new("mbpoll")
            .args(&args)
            .output()
            .expect("run mbpoll");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "{doc}: `{cmd}` failed: {stdout}{stderr}"
        );
        match expectation(&args) {
            Expect::Read(n) => assert_eq!(
                value_lines(&stdout),
                n,
                "{doc}: `{cmd}` returned another count of values: {stdout}"
            ),
            Expect::Written(n) => assert!(
                stdout.contains(&format!("Written {n} references")),
                "{doc}: `{cmd}` did not write {n} values: {stdout}"
            ),
        }
    }
}

/// One mbpoll read of input registers (1-based `reference`), its value strings.
fn mbpoll_read(node: &Proc, reference: u16, count: u16, ty: &str) -> Vec<String> {
    let port = node.addr.port().to_string();
    let (r, c) = (reference.to_string(), count.to_string());
    let out = Command::new("mbpoll")
        .args(["-m", "tcp", "-p", &port, "-a", "1", "-r", &r, "-c", &c])
        .args(["-t", ty, "-B", "-1", "127.0.0.1"])
        .output()
        .expect("run mbpoll");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "mbpoll -r {r}: {stdout}");
    stdout
        .lines()
        .filter_map(|l| l.split_once("]:"))
        .map(|(_, v)| v.trim().to_string())
        .collect()
}

#[test]
fn a_node_with_no_known_dimming_state_publishes_unknown_not_dark() {
    need("mbpoll");
    // no gateway, no --arc: no luminaire's level is known
    let node = serve_demo(&[]);
    let floats = mbpoll_read(&node, 101, 7, "3:float");
    assert_eq!(floats.len(), 7, "{floats:?}");
    assert!(
        floats
            .iter()
            .all(|v| v.to_ascii_lowercase().contains("nan")),
        "float desk lux: {floats:?}"
    );
    let ints = mbpoll_read(&node, 301, 7, "3:hex");
    assert_eq!(ints, vec!["0xFFFF"; 7], "u16 desk lux");
    // quality 1: stale, the dimming state unknown; status bit 5 says the same
    let quality = mbpoll_read(&node, 401, 7, "3");
    assert_eq!(quality, vec!["1"; 7], "quality");
    let st: u16 = mbpoll_read(&node, 4, 1, "3")[0].parse().expect("status");
    assert_ne!(st & (1 << 5), 0, "status {st:#06x}");
    // a write of every level makes it known: numbers, quality no longer stale
    let port = node.addr.port().to_string();
    let out = Command::new("mbpoll")
        .args(["-m", "tcp", "-p", &port, "-a", "1", "-r", "1001", "-t", "4"])
        .args(["-1", "127.0.0.1", "254", "254", "254", "254", "254", "254"])
        .output()
        .expect("run mbpoll");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let floats = mbpoll_read(&node, 101, 7, "3:float");
    for v in &floats {
        let x: f64 = v.parse().unwrap_or(f64::NAN);
        assert!(x > 50.0, "all on: desk lux {floats:?}");
    }
    let ints = mbpoll_read(&node, 301, 7, "3");
    assert!(ints.iter().all(|v| v != "65535"), "{ints:?}");
    let quality = mbpoll_read(&node, 401, 7, "3");
    assert!(
        quality.iter().all(|q| q != "1" && q != "65535"),
        "{quality:?}"
    );
}

/// Issue 31 item 8: a luminaire's rated power is its photometry's wattage (the demo downlight
/// declares 32 W), the same number in `control`, the report's schedule and the Modbus power
/// points (before: control and Modbus took flux / 120 lm/W, 33.3 W, beside the report's file
/// wattage).
#[test]
fn the_luminaire_wattage_is_one_number_in_control_report_and_modbus() {
    need("mbpoll");
    let image = demo_image();
    let file_w = luxnode::sim::demo::LUMINAIRE_POWER_W;
    let n = luxnode::sim::demo::demo_office().luminaires.len() as f64;
    // control
    let out = Command::new(LUXNODE)
        .args(["control", "--image"])
        .arg(&image)
        .args(["--format", "json"])
        .output()
        .expect("run luxnode control");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("assumed"),
        "no guess warning when the file has a wattage"
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("control json");
    assert_eq!(json["all_on_w"].as_f64(), Some(n * file_w), "{json}");
    // the report's schedule
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("integrator-power-report");
    let out = Command::new(LUXNODE)
        .args(["report", "--image"])
        .arg(&image)
        .arg("--out")
        .arg(&dir)
        .output()
        .expect("run luxnode report");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("results.json")).expect("results.json"))
            .expect("results json");
    let rows = results["luminaires"].as_array().expect("luminaires");
    assert_eq!(rows.len() as f64, n);
    for r in rows {
        assert_eq!(r["power_w"].as_f64(), Some(file_w), "{r}");
        assert_eq!(r["power_assumed"].as_bool(), Some(false), "{r}");
    }
    // Modbus: input 65-66, power with every luminaire at full
    let node = serve_demo(&[]);
    let all_on = mbpoll_read(&node, 66, 1, "3:float");
    let w: f64 = all_on[0].parse().expect("float");
    assert!((w - n * file_w).abs() < 1e-3, "{all_on:?}");
}

/// Issue 31 item 3: `luxnode points` lists every published value with its point's name and
/// address; mbpoll, reading each listed id register at the listed address, gets the listed
/// point's sensor id and luminaire id, and each listed float reads as one.
#[test]
fn the_points_list_addresses_are_the_ones_the_node_serves() {
    need("mbpoll");
    let image = demo_image();
    let v = common::procs::luxnode_json(&[
        "points".as_ref(),
        "--format".as_ref(),
        "json".as_ref(),
        "--image".as_ref(),
        image.as_os_str(),
    ]);
    let rows = v["values"].as_array().cloned().unwrap_or_default();
    let points = v["points"].as_array().cloned().unwrap_or_default();
    // the demo office: 6 sensors on its 6 desks and one on the floor, named for it
    let names: Vec<&str> = points.iter().filter_map(|p| p["name"].as_str()).collect();
    assert_eq!(names.len(), 7, "{names:?}");
    assert_eq!(
        names.iter().filter(|n| n.starts_with("desk ")).count(),
        6,
        "{names:?}"
    );
    assert_eq!(
        names.iter().filter(|n| n.starts_with("floor S")).count(),
        1,
        "{names:?}"
    );
    let node = serve_demo(&["--arc", "254"]);
    let mut checked = 0;
    for r in &rows {
        let q = r["quantity"].as_str().unwrap_or_default();
        let reference = (r["address"].as_u64().unwrap_or(u64::MAX) + 1) as u16;
        let expect = match q {
            "desk id" => r["sensor_id"].as_u64(),
            "luminaire id" => r["luminaire_id"].as_u64(),
            _ => None,
        };
        if let Some(id) = expect {
            let got = mbpoll_read(&node, reference, 1, "3");
            assert_eq!(got, vec![id.to_string()], "{r}");
            checked += 1;
        }
        if q == "desk lux (float)" {
            let got = mbpoll_read(&node, reference, 1, "3:float");
            let lx: f64 = got[0].parse().unwrap_or(f64::NAN);
            assert!(lx > 50.0, "{r}: {got:?}");
            checked += 1;
        }
    }
    assert_eq!(
        checked,
        7 + 6 + 7,
        "every desk id, luminaire id and desk float"
    );
}
