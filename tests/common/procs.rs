//! Processes for the end-to-end tests: luxnode and gateway-sim started as real programs,
//! killed on drop, their Modbus address read from their `modbus tcp listening on ADDR` line.

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

pub const LUXNODE: &str = env!("CARGO_BIN_EXE_luxnode");
pub const GATEWAY_SIM: &str = env!("CARGO_BIN_EXE_gateway-sim");

/// A child process killed on drop, with everything it printed so far (stdout and stderr).
pub struct Proc {
    pub child: Child,
    pub addr: SocketAddr,
    pub stdout: Arc<Mutex<Vec<String>>>,
}

impl Proc {
    /// Everything printed so far, one string.
    pub fn output(&self) -> String {
        self.stdout.lock().map(|v| v.join("\n")).unwrap_or_default()
    }

    /// Sends SIGTERM and waits (at most 10 s) for the exit status.
    pub fn terminate(mut self) -> std::process::ExitStatus {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let t0 = std::time::Instant::now();
        loop {
            if let Ok(Some(st)) = self.child.try_wait() {
                return st;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(10),
                "no exit 10 s after SIGTERM"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `bin args` and waits (at most `limit`) for its `modbus tcp listening on ADDR` line
/// (a log line on stderr, or a line on stdout); both streams are kept, interleaved as read.
pub fn spawn_listening_within(bin: &str, args: &[String], limit: Duration) -> Proc {
    let mut child = Command::new(bin)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{bin}: {e}"));
    let lines = Arc::new(Mutex::new(Vec::new()));
    let (tx, rx) = mpsc::channel();
    let stdout = child.stdout.take().expect("stdout");
    let stderr = child.stderr.take().expect("stderr");
    let readers: [Box<dyn std::io::Read + Send>; 2] = [Box::new(stdout), Box::new(stderr)];
    for stream in readers {
        let keep = lines.clone();
        let tx = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stream).lines() {
                let Ok(line) = line else { break };
                if let Some((_, a)) = line.split_once("modbus tcp listening on ") {
                    let a = a.split_whitespace().next().unwrap_or("").to_string();
                    let _ = tx.send(a);
                }
                if let Ok(mut v) = keep.lock() {
                    v.push(line);
                }
            }
        });
    }
    let addr = match rx.recv_timeout(limit) {
        Ok(a) => a,
        Err(_) => {
            let _ = child.kill();
            let out = lines.lock().map(|v| v.join("\n")).unwrap_or_default();
            panic!("{bin} {args:?} did not start listening:\n{out}");
        }
    };
    Proc {
        child,
        addr: addr.parse().expect("address"),
        stdout: lines,
    }
}

/// [`spawn_listening_within`] 60 s.
pub fn spawn_listening(bin: &str, args: &[String]) -> Proc {
    spawn_listening_within(bin, args, Duration::from_secs(60))
}

/// A single-threaded async runtime for a test's Modbus clients.
pub fn rt() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
}

/// Desk lux as float32 ABCD register pairs.
pub fn floats_abcd(regs: &[u16]) -> Vec<f64> {
    regs.chunks(2)
        .map(|w| f64::from(f32::from_bits((u32::from(w[0]) << 16) | u32::from(w[1]))))
        .collect()
}

/// Fails with a clear message when a client program is missing.
pub fn need(tool: &str) {
    let found = Command::new("sh")
        .arg("-c")
        .arg(format!("command -v {tool}"))
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    assert!(
        found,
        "{tool} is not installed: run scripts/install-test-tools.sh (scripts/test.sh does)"
    );
}

/// mbpoll's values: lines `[ref]: \tvalue`.
pub fn mbpoll_values(stdout: &[u8]) -> Vec<f64> {
    String::from_utf8_lossy(stdout)
        .lines()
        .filter_map(|l| l.split_once("]:"))
        .filter_map(|(_, v)| v.trim().parse().ok())
        .collect()
}

/// A pty pair from socat: (server side, client side).
pub struct PtyPair {
    pub child: Child,
    pub a: std::path::PathBuf,
    pub b: std::path::PathBuf,
    pub _dir: tempfile::TempDir,
}

impl Drop for PtyPair {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A socat pty pair.
pub fn pty_pair() -> PtyPair {
    need("socat");
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let child = Command::new("socat")
        .arg(format!("pty,raw,echo=0,link={}", a.display()))
        .arg(format!("pty,raw,echo=0,link={}", b.display()))
        .stderr(Stdio::null())
        .spawn()
        .expect("socat");
    let t0 = Instant::now();
    while !(a.exists() && b.exists()) {
        assert!(t0.elapsed() < Duration::from_secs(10), "socat ptys");
        std::thread::sleep(Duration::from_millis(20));
    }
    PtyPair {
        child,
        a,
        b,
        _dir: dir,
    }
}

/// An image built once by `luxnode image build ARGS --out ...` into the test target's
/// temporary directory as `name` and shared by the tests of a file (atomic rename, so parallel
/// test processes never see half a file; a file that does not parse is built again).
pub fn cli_image(name: &str, args: &[&std::ffi::OsStr]) -> std::path::PathBuf {
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    if let Ok(bytes) = std::fs::read(&path)
        && luxnode::store::Image::parse(&bytes).is_ok()
    {
        return path;
    }
    let tmp = path.with_extension(format!("{}.tmp", std::process::id()));
    let out = Command::new(LUXNODE)
        .args(["image", "build"])
        .args(args)
        .arg("--out")
        .arg(&tmp)
        .output()
        .expect("run luxnode image build");
    assert!(
        out.status.success(),
        "image build {name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::rename(&tmp, &path).expect("rename image");
    path
}

/// office_a's image, built once as `<tag>-office_a.img` ([`cli_image`]).
pub fn cli_office_image(tag: &str) -> std::path::PathBuf {
    let scene = super::office_a();
    cli_image(
        &format!("{tag}-office_a.img"),
        &["--scene".as_ref(), scene.as_os_str()],
    )
}

/// `luxnode ARGS` run to completion, its stdout parsed as JSON (the run must succeed).
#[allow(dead_code)]
pub fn luxnode_json<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> serde_json::Value {
    let out = Command::new(LUXNODE)
        .args(args)
        .output()
        .expect("run luxnode");
    assert!(
        out.status.success(),
        "luxnode {:?}: {}",
        args.iter().map(|a| a.as_ref()).collect::<Vec<_>>(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("luxnode's JSON")
}
