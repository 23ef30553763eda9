//! The systemd deployment (deploy/): the unit is hardened to an exposure of at most 3.0 by
//! `systemd-analyze security` (offline, on the file), its syntax verifies, sysusers.d creates
//! the user it runs as, and it holds exactly the privileges the node needs (binding port 502,
//! its own devices) and none it must not have (the disk group). systemd-analyze and
//! systemd-sysusers come from Debian's systemd package (scripts/install-test-tools.sh).

use std::path::Path;
use std::process::Command;

fn deploy(f: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("deploy").join(f)
}

fn need(tool: &str) {
    let ok = Command::new("sh")
        .arg("-c")
        .arg(format!("command -v {tool}"))
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "{tool} is not installed: run scripts/install-test-tools.sh (scripts/test.sh does)"
    );
}

/// The measured exposure of deploy/luxnode.service, published in docs/deploy.md.
const MEASURED_EXPOSURE: f64 = 1.7;

#[test]
fn the_unit_is_hardened_to_an_exposure_of_at_most_3() {
    need("systemd-analyze");
    let out = Command::new("systemd-analyze")
        .args(["security", "--offline=true", "--no-pager"])
        .arg(deploy("luxnode.service"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let exposure: f64 = text
        .lines()
        .find_map(|l| {
            let (_, rest) = l.split_once("Overall exposure level for luxnode.service:")?;
            rest.split_whitespace().next()?.parse().ok()
        })
        .unwrap_or_else(|| {
            panic!(
                "no exposure line:\n{text}\n{}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
    assert!(exposure <= 3.0, "exposure {exposure} > 3.0:\n{text}");
    // the figure in docs/deploy.md, within its rounding
    assert!(
        (exposure - MEASURED_EXPOSURE).abs() <= 0.15,
        "exposure {exposure}: update docs/deploy.md and MEASURED_EXPOSURE"
    );
}

#[test]
fn the_unit_verifies_and_holds_only_the_privileges_it_needs() {
    need("systemd-analyze");
    let unit = std::fs::read_to_string(deploy("luxnode.service")).unwrap();
    let lines: Vec<&str> = unit
        .lines()
        .map(str::trim)
        .filter(|l| !l.starts_with('#'))
        .collect();
    let has = |l: &str| lines.contains(&l);
    assert!(has("Type=notify"));
    assert!(has("User=luxnode"));
    assert!(has("AmbientCapabilities=CAP_NET_BIND_SERVICE"), "port 502");
    assert!(has("CapabilityBoundingSet=CAP_NET_BIND_SERVICE"));
    assert!(
        has("ExecReload=/bin/kill -HUP $MAINPID"),
        "reload is SIGHUP"
    );
    assert!(
        !lines.iter().any(|l| l.starts_with("SupplementaryGroups=")),
        "devices come from the udev rule, not from groups (never disk)"
    );
    let exec = lines
        .iter()
        .find(|l| l.starts_with("ExecStart="))
        .expect("ExecStart");
    assert!(
        exec.contains("--no-controller"),
        "no simulated controller: {exec}"
    );
    // systemd itself parses it (the binary path pointed at the one just built)
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("luxnode.service");
    std::fs::write(
        &copy,
        unit.replace("/usr/local/bin/luxnode", env!("CARGO_BIN_EXE_luxnode")),
    )
    .unwrap();
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&copy)
        .output()
        .unwrap();
    let msg = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{msg}");
    assert!(!msg.contains("Unknown"), "unknown directives: {msg}");
}

#[test]
fn sysusers_creates_the_user_the_unit_runs_as() {
    need("systemd-sysusers");
    let root = tempfile::tempdir().unwrap();
    let d = root.path().join("usr/lib/sysusers.d");
    std::fs::create_dir_all(&d).unwrap();
    std::fs::create_dir_all(root.path().join("etc")).unwrap();
    std::fs::copy(deploy("sysusers.d/luxnode.conf"), d.join("luxnode.conf")).unwrap();
    let out = Command::new("systemd-sysusers")
        .arg(format!("--root={}", root.path().display()))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let passwd = std::fs::read_to_string(root.path().join("etc/passwd")).unwrap();
    let user = passwd
        .lines()
        .find(|l| l.starts_with("luxnode:"))
        .unwrap_or_else(|| panic!("{passwd}"));
    assert!(
        user.ends_with(":/var/lib/luxnode:/usr/sbin/nologin"),
        "{user}"
    );
    let group = std::fs::read_to_string(root.path().join("etc/group")).unwrap();
    assert!(group.lines().any(|l| l.starts_with("luxnode:")), "{group}");
    // the udev rule gives the devices to that group, and never a block device
    let rules = std::fs::read_to_string(deploy("udev/90-luxnode.rules")).unwrap();
    for l in rules
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
    {
        assert!(l.contains("GROUP=\"luxnode\""), "{l}");
        assert!(!l.contains("\"block\"") && !l.contains("disk"), "{l}");
    }
}
