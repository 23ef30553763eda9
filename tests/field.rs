//! Field readiness (issue 16): no crash on any setting, no silent failure, no write from a
//! stranger. Each test reproduces one way a hostile installer or network broke the node, with
//! real processes and real clients where the behaviour is the process's (TLS with Python's
//! OpenSSL client and openssl-made certificates, mbpoll over a pty, signals, sd_notify).

mod common;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::procs::{LUXNODE, Proc, mbpoll_values, need, rt, spawn_listening};
use luxnode::modbus::regmap::{MAP_VERSION, status};
use luxnode::store::devices::{FileFlash, MemFlash};
use luxnode::store::file::read_bootable;
use luxnode::store::slots::{FlashDevice, Slot, Slots};
use luxnode::store::{FORMAT_VERSION, HEADER_LEN, Header, Image, ImageError, crc32};
use tokio_modbus::client::{Context, Reader, Writer};
use tokio_modbus::prelude::ExceptionCode;

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The demo office's image (fast preset), built once by the CLI for this file's tests.
fn demo_image() -> Vec<u8> {
    let args = ["--scene", "demo-office", "--preset", "fast"].map(std::ffi::OsStr::new);
    std::fs::read(common::procs::cli_image("field-demo-fast.img", &args)).unwrap()
}

/// The flash size `luxnode run --flash` uses: two FORMFACTORS regions.
fn flash_bytes() -> usize {
    2 * usize::try_from(luxnode::layout::FORMFACTORS_LEN_BYTES).unwrap()
}

/// An image whose CRCs are right but whose payload is `payload` (for crafted payloads).
fn with_payload(generation: u64, payload: &[u8]) -> Vec<u8> {
    let h = Header {
        format_version: FORMAT_VERSION,
        generation,
        payload_len: payload.len() as u32,
        payload_crc32: crc32(payload),
        precision: 3,
    };
    let mut v = h.emit().to_vec();
    v.extend_from_slice(payload);
    v
}

/// Re-encodes `image` with its response matrix's entry 0 set to `x` (CRCs fixed up).
fn with_response0(image: &[u8], x: f64) -> Vec<u8> {
    let img = Image::parse(image).unwrap();
    let mut p = img.payload;
    let mut resp = p.response_lx.0.to_vec();
    resp[..8].copy_from_slice(&x.to_le_bytes());
    p.response_lx = luxnode::store::Bytes(&resp);
    with_payload(1, &postcard::to_allocvec(&p).unwrap())
}

#[test]
fn crafted_images_with_valid_crcs_never_publish_bad_lux() {
    let good = demo_image();
    for (x, what) in [
        (-8000.0, "negative"),
        (f64::INFINITY, "infinite"),
        (f64::NAN, "NaN"),
        (2.0e6, "beyond 1e6 lx"),
    ] {
        let crafted = with_response0(&good, x);
        let e = Image::parse(&crafted).expect_err(what);
        assert!(matches!(e, ImageError::Inconsistent(_)), "{what}: {e}");
    }
    // lengths that would wrap a 32-bit usize are inconsistencies, never a panic
    let img = Image::parse(&good).unwrap();
    let mut p = img.payload;
    p.n_patches = u32::MAX;
    p.n_luminaires = u16::MAX;
    let crafted = with_payload(1, &postcard::to_allocvec(&p).unwrap());
    assert!(matches!(
        Image::parse(&crafted),
        Err(ImageError::Inconsistent(_))
    ));
}

#[test]
fn boot_falls_back_past_a_newest_slot_that_does_not_load() {
    let good = demo_image();
    let mut slots = Slots::new(MemFlash::new(flash_bytes()));
    slots.write_image(&good).unwrap();
    // generation 2 in slot B: CRCs intact, payload not an image
    let bad = with_payload(2, &[0xA5; 4000]);
    let off = slots.offset(Slot::B);
    slots.device().erase(off, bad.len()).unwrap();
    slots.device().write(off, &bad).unwrap();
    assert_eq!(
        slots.boot().chosen,
        Some(Slot::B),
        "by CRC the bad one is newest"
    );
    let b = read_bootable(&mut slots, |_, _| Ok(()));
    let (_, slot, generation) = b.image.expect("falls back");
    assert_eq!((slot, generation), (Slot::A, 1));
    assert_eq!(b.refused.len(), 1);
    assert!(b.refused[0].2.contains("decode"), "{:?}", b.refused);
    // an image the register map refuses (the caller's check) is passed over too
    let b = read_bootable(&mut slots, |_, g| {
        if g == 1 {
            Err("refused".into())
        } else {
            Ok(())
        }
    });
    assert!(b.image.is_none());
    // the next write keeps the image that runs (A) and wins over the bad B
    let w = slots.write_image_keeping(&good, Some(Slot::A)).unwrap();
    assert_eq!((w.slot, w.generation), (Slot::B, 2));
    let b = read_bootable(&mut slots, |_, _| Ok(()));
    assert_eq!(b.image.map(|i| (i.1, i.2)), Some((Slot::B, 2)));
}

#[test]
fn the_generation_never_wraps() {
    let good = demo_image();
    let mut slots = Slots::new(MemFlash::new(flash_bytes()));
    slots.write_image(&good).unwrap();
    // slot A at u64::MAX (a crafted or very old counter)
    let mut h = Header::parse(&good).unwrap();
    h.generation = u64::MAX;
    slots.device().data[..HEADER_LEN].copy_from_slice(&h.emit());
    assert_eq!(slots.boot().generation(), Some(u64::MAX));
    let w = slots.write_image(&good).unwrap();
    assert_eq!(
        (w.slot, w.generation),
        (Slot::B, 1),
        "renumbered, not wrapped"
    );
    let st = slots.boot();
    assert_eq!((st.chosen, st.generation()), (Some(Slot::B), Some(1)));
    assert!(
        matches!(
            st.a,
            luxnode::store::slots::SlotState::Invalid(ImageError::Erased)
        ),
        "the old slot is erased once the new one verified: {st}"
    );
    let w = slots.write_image(&good).unwrap();
    assert_eq!((w.slot, w.generation), (Slot::A, 2));
}

/// office_a's capture, loaded, with the scene's luminaires and sensors.
fn office_capture() -> (
    luxnode::camera::capture::Capture,
    Vec<luxnode::scene::Luminaire>,
    Vec<luxnode::scene::Sensor>,
) {
    common::office_a_capture("capture_clean")
}

#[test]
fn plausible_but_wrong_commissioning_inputs_fail_fast() {
    use luxnode::commission::{CommissionOptions, from_capture};
    let (cap, lums, sensors) = office_capture();
    let o = CommissionOptions::default();
    let fails_fast = |c: &luxnode::camera::capture::Capture, says: &str| {
        let t0 = Instant::now();
        let e = from_capture(c, lums.clone(), sensors.clone(), None, &o)
            .err()
            .unwrap_or_else(|| panic!("{says}: commissioned"));
        let dt = t0.elapsed();
        assert!(e.to_string().contains(says), "{says}: {e}");
        // before any engine work: a fraction of a second even on a loaded machine
        assert!(dt < Duration::from_secs(5), "{says}: {dt:?}");
    };
    // camera intrinsics (the issue's: 3.8 TB, 36 GB, a panic after 25 s)
    for (fx, cx, says) in [(1e-9, 159.5, "fx"), (1.0, 159.5, "fx"), (160.0, 1e7, "cx")] {
        let mut c = cap.clone();
        c.camera.fx = fx;
        c.camera.fy = fx;
        c.camera.cx = cx;
        fails_fast(&c, says);
    }
    // every depth pixel 65535 (no return): the cameras see nothing, no image
    let mut c = cap.clone();
    for f in &mut c.depth_mm {
        f.data.fill(65535);
    }
    fails_fast(&c, "see nothing");
    // the camera 1 km outside the room: the floor it sees is nowhere near a luminaire (issue
    // 34's pose check, before the room box is inferred)
    let mut c = cap.clone();
    c.camera.position_m.x += 1000.0;
    fails_fast(&c, "from the nearest luminaire in luminaires.json");
    // and the same values in a camera.json are refused at load, naming the key
    let dir = tempfile::tempdir().unwrap();
    let src = manifest().join("reference/scenes/office_a/capture_clean/camera.json");
    let text = std::fs::read_to_string(src).unwrap();
    for (from, to, says) in [
        ("\"fx\": 160.00000000000003", "\"fx\": 1e-9", "fx"),
        ("\"cx\": 159.5", "\"cx\": 10000000.0", "cx"),
    ] {
        let p = dir.path().join("camera.json");
        std::fs::write(&p, text.replace(from, to)).unwrap();
        let e = luxnode::scene::load_camera_file(&p).expect_err(says);
        assert!(e.to_string().contains(says), "{e}");
    }
}

#[test]
fn a_flash_of_1e14_bytes_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let board = dir.path().join("board.toml");
    std::fs::write(
        &board,
        "name = \"x\"\n[scene]\nsource = \"demo-office\"\n[flash]\nkind = \"file\"\npath = \"f.img\"\nsize_bytes = 100000000000000\n",
    )
    .unwrap();
    let t0 = Instant::now();
    let out = Command::new(LUXNODE)
        .args(["run", "--no-controller", "--seconds", "1", "--board"])
        .arg(&board)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("size_bytes"), "{err}");
    assert!(!dir.path().join("f.img").exists(), "nothing created");
    assert!(t0.elapsed() < Duration::from_secs(10));
}

#[test]
fn scene_check_and_image_build_refuse_what_the_node_would() {
    let d = common::office_a();
    let dir = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(&d).unwrap() {
        let p = f.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, dir.path().join(p.file_name().unwrap())).unwrap();
        }
    }
    // 101 desk sensors
    let sensors: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("sensors.json")).unwrap()).unwrap();
    let first = sensors[0].clone();
    let many: Vec<serde_json::Value> = (0..101)
        .map(|k| {
            let mut s = first.clone();
            s["id"] = serde_json::json!(1000 + k);
            s
        })
        .collect();
    let doc = serde_json::Value::Array(many);
    std::fs::write(dir.path().join("sensors.json"), doc.to_string()).unwrap();
    let out = Command::new(LUXNODE)
        .args(["scene", "check"])
        .arg(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "scene check accepted 101 desks");
    assert!(err.contains("101 desk sensors"), "{err}");
    let t0 = Instant::now();
    let out = Command::new(LUXNODE)
        .args(["image", "build", "--scene"])
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("x.img"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "image build accepted 101 desks");
    assert!(err.contains("at most 100"), "{err}");
    assert!(
        t0.elapsed() < Duration::from_secs(10),
        "refused before the engine ran"
    );
    assert!(!dir.path().join("x.img").exists());
}

/// A flash file with `image` in slot A (generation 1), and optionally an undecodable newer
/// image in slot B.
fn flash_with(dir: &Path, image: &[u8], bad_newest: bool) -> PathBuf {
    let path = dir.join("flash.bin");
    let mut slots = Slots::new(FileFlash::open(&path, flash_bytes()).unwrap());
    slots.write_image(image).unwrap();
    if bad_newest {
        let bad = with_payload(2, &[0x5A; 10_000]);
        let off = slots.offset(Slot::B);
        slots.device().write(off, &bad).unwrap();
        slots.device().sync().unwrap();
    }
    path
}

/// The sim board with extra TOML appended.
fn board(dir: &Path, extra: &str) -> PathBuf {
    let sim = std::fs::read_to_string(manifest().join("boards/sim/board.toml")).unwrap();
    let p = dir.join("board.toml");
    std::fs::write(&p, format!("{sim}\n{extra}")).unwrap();
    p
}

fn node(board: &Path, flash: &Path, extra: &[&str]) -> Proc {
    let mut args: Vec<String> = vec![
        "run".into(),
        "--board".into(),
        board.display().to_string(),
        "--flash".into(),
        flash.display().to_string(),
        "--bind".into(),
        "127.0.0.1:0".into(),
        "--no-controller".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    spawn_listening(LUXNODE, &args)
}

async fn client(addr: SocketAddr) -> Context {
    tokio_modbus::client::tcp::connect(addr).await.unwrap()
}

async fn status_of(c: &mut Context) -> u16 {
    c.read_input_registers(3, 1).await.unwrap().unwrap()[0]
}

/// Polls the status until `ok`, at most `limit`.
async fn wait_status(c: &mut Context, limit: Duration, ok: impl Fn(u16) -> bool) -> u16 {
    let t0 = Instant::now();
    loop {
        let st = status_of(c).await;
        if ok(st) {
            return st;
        }
        assert!(t0.elapsed() < limit, "status stayed {st:#06x}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[test]
fn an_undecodable_newest_slot_boots_the_last_good_image() {
    let dir = tempfile::tempdir().unwrap();
    let flash = flash_with(dir.path(), &demo_image(), true);
    let n = node(&board(dir.path(), ""), &flash, &[]);
    let out = n.output();
    assert!(out.contains("does not load"), "{out}");
    assert!(out.contains("loaded image generation 1"), "{out}");
    rt().block_on(async {
        let mut c = client(n.addr).await;
        let st = status_of(&mut c).await;
        assert_ne!(st & status::COMMISSIONED, 0);
        assert_eq!(st & status::STORE_OK, 0, "the store reports the bad slot");
        assert_eq!(c.read_input_registers(4, 2).await.unwrap().unwrap(), [0, 1]);
    });
}

#[test]
fn the_sensors_bit_clears_when_the_camera_fails() {
    let dir = tempfile::tempdir().unwrap();
    let flash = flash_with(dir.path(), &demo_image(), false);
    // the simulated ToF camera disconnects after 2 frames; checked every 0.3 s
    let b = board(
        dir.path(),
        "[health]\nsensor_check_s = 0.3\n[camera.sim.faults]\ndisconnect_after_frames = 2\n",
    );
    let n = node(&b, &flash, &[]);
    rt().block_on(async {
        let mut c = client(n.addr).await;
        wait_status(&mut c, Duration::from_secs(60), |s| {
            s & status::SENSORS_OK == 0
        })
        .await;
    });
    assert!(n.output().contains("sensor probe"), "{}", n.output());
}

#[test]
fn writes_only_from_the_allowlist_reload_on_sighup_and_sigusr1_does_not_kill() {
    let dir = tempfile::tempdir().unwrap();
    let flash = flash_with(dir.path(), &demo_image(), false);
    let b = board(dir.path(), "");
    let n = node(&b, &flash, &[]);
    let pid = n.child.id().to_string();
    let signal = |sig: &str| {
        assert!(
            Command::new("kill")
                .args([sig, &pid])
                .status()
                .unwrap()
                .success()
        );
    };
    rt().block_on(async {
        let mut c = client(n.addr).await;
        // the sim board allows loopback: the write is executed, persisted settings too
        c.write_single_register(1000, 254).await.unwrap().unwrap();
        c.write_single_register(2000, 3).await.unwrap().unwrap();
        assert_eq!(c.read_input_registers(12, 1).await.unwrap().unwrap(), [3]);
        // SIGUSR1: a status report, the node lives on
        signal("-USR1");
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert_eq!(
            c.read_input_registers(0, 1).await.unwrap().unwrap(),
            [MAP_VERSION]
        );
    });
    assert!(
        n.output().contains("status: image generation 1"),
        "{}",
        n.output()
    );
    // the board file now allows nobody: SIGHUP applies it without a restart
    let sim = std::fs::read_to_string(&b).unwrap();
    std::fs::write(
        &b,
        sim.replace("write_allow = [\"127.0.0.1\", \"::1\"]", "write_allow = []"),
    )
    .unwrap();
    signal("-HUP");
    std::thread::sleep(Duration::from_millis(500));
    rt().block_on(async {
        let mut c = client(n.addr).await;
        let e = c.write_single_register(1000, 0).await.unwrap();
        assert_eq!(
            e,
            Err(ExceptionCode::IllegalFunction),
            "read-only after reload"
        );
        assert_eq!(
            c.read_holding_registers(1000, 1).await.unwrap().unwrap(),
            [254]
        );
        let refused = c.read_input_registers(49, 1).await.unwrap().unwrap()[0];
        assert!(refused >= 1, "writes refused counter {refused}");
    });
    // a broken board file: logged, the running configuration stays
    std::fs::write(&b, "name = \"x\"\n[scene]\nsourse = 1\n").unwrap();
    signal("-HUP");
    std::thread::sleep(Duration::from_millis(500));
    rt().block_on(async {
        let mut c = client(n.addr).await;
        assert_eq!(
            c.read_input_registers(0, 1).await.unwrap().unwrap(),
            [MAP_VERSION]
        );
    });
    let out = n.output();
    assert!(out.contains("the running configuration stays"), "{out}");
    assert!(
        out.contains("modbus write by tcp 127.0.0.1"),
        "every write logged: {out}"
    );
    // the settings persisted next to the flash
    let saved = std::fs::read_to_string(flash.with_extension("settings.json")).unwrap();
    assert!(saved.contains("\"127.0.0.1\": 3"), "{saved}");
    assert_eq!(n.terminate().code(), Some(0));
}

#[test]
fn the_watchdog_is_petted_and_ready_is_sent() {
    use std::os::unix::net::UnixDatagram;
    let dir = tempfile::tempdir().unwrap();
    let flash = flash_with(dir.path(), &demo_image(), false);
    let sock_path = dir.path().join("notify");
    let sock = UnixDatagram::bind(&sock_path).unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let mut child = Command::new(LUXNODE)
        .args([
            "run",
            "--no-controller",
            "--seconds",
            "4",
            "--bind",
            "127.0.0.1:0",
        ])
        .arg("--board")
        .arg(board(dir.path(), ""))
        .arg("--flash")
        .arg(&flash)
        .env("NOTIFY_SOCKET", &sock_path)
        .env("WATCHDOG_USEC", "400000")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while let Ok(n) = sock.recv(&mut buf) {
        let m = String::from_utf8_lossy(&buf[..n]).into_owned();
        let stop = m.starts_with("STOPPING");
        got.push(m);
        if stop {
            break;
        }
    }
    let _ = child.wait();
    assert_eq!(got.first().map(String::as_str), Some("READY=1"), "{got:?}");
    let pets = got.iter().filter(|m| *m == "WATCHDOG=1").count();
    // 4 s at one pet per 0.2 s while every part beats
    assert!(pets >= 10, "{pets} pets: {got:?}");
}

/// A socat pty pair at fixed paths (restartable at the same paths).
fn socat(a: &Path, b: &Path) -> std::process::Child {
    need("socat");
    let child = Command::new("socat")
        .arg(format!("pty,raw,echo=0,link={}", a.display()))
        .arg(format!("pty,raw,echo=0,link={}", b.display()))
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !(a.exists() && b.exists()) {
        assert!(t0.elapsed() < Duration::from_secs(10), "socat ptys");
        std::thread::sleep(Duration::from_millis(20));
    }
    child
}

fn mbpoll_rtu(dev: &Path) -> Vec<f64> {
    let out = Command::new("mbpoll")
        .args([
            "-m", "rtu", "-b", "19200", "-P", "none", "-s", "2", "-a", "5",
        ])
        .args(["-r", "1", "-c", "1", "-t", "3", "-1", "-o", "1"])
        .arg(dev)
        .output()
        .unwrap();
    mbpoll_values(&out.stdout)
}

#[test]
fn a_dead_serial_line_is_reported_and_reopened() {
    need("mbpoll");
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let mut line = socat(&a, &b);
    let flash = flash_with(dir.path(), &demo_image(), false);
    let board = board(
        dir.path(),
        &format!(
            "[modbus.rtu]\ndevice = \"{}\"\nbaud = 19200\nparity = \"none\"\nunit_id = 5\n",
            a.display()
        ),
    );
    let n = node(&board, &flash, &[]);
    assert_eq!(
        mbpoll_rtu(&b),
        [f64::from(MAP_VERSION)],
        "map version over RTU"
    );
    // the line hangs up (the adapter is pulled): reported, not silent
    let _ = line.kill();
    let _ = line.wait();
    rt().block_on(async {
        let mut c = client(n.addr).await;
        wait_status(&mut c, Duration::from_secs(10), |s| {
            s & status::COMM_OK == 0
        })
        .await;
        assert_eq!(c.read_input_registers(43, 1).await.unwrap().unwrap(), [2]);
    });
    // back: reopened, answering again
    let mut line = socat(&a, &b);
    rt().block_on(async {
        let mut c = client(n.addr).await;
        wait_status(&mut c, Duration::from_secs(20), |s| {
            s & status::COMM_OK != 0
        })
        .await;
        let h = c.read_input_registers(43, 2).await.unwrap().unwrap();
        assert_eq!(h[0], 1, "line up");
        assert!(h[1] >= 1, "reopened {} times", h[1]);
    });
    assert_eq!(
        mbpoll_rtu(&b),
        [f64::from(MAP_VERSION)],
        "answers after the reopen"
    );
    assert!(n.output().contains("line failed"), "{}", n.output());
    let _ = line.kill();
    let _ = line.wait();
}

/// `luxnode serve` on the demo image with `args`.
fn serve(dir: &Path, args: &[&str]) -> Proc {
    let img = dir.join("demo.img");
    std::fs::write(&img, demo_image()).unwrap();
    let mut a: Vec<String> = vec![
        "serve".into(),
        "--image".into(),
        img.display().to_string(),
        "--bind".into(),
        "127.0.0.1:0".into(),
        "--arc".into(),
        "254".into(),
    ];
    a.extend(args.iter().map(|s| s.to_string()));
    spawn_listening(LUXNODE, &a)
}

/// A raw read of input 0 on `s`; true when answered.
fn answered(s: &mut TcpStream) -> bool {
    s.set_read_timeout(Some(Duration::from_secs(3))).ok();
    if s.write_all(&[0, 1, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1]).is_err() {
        return false;
    }
    let mut b = [0u8; 11];
    s.read_exact(&mut b).is_ok() && b[7] == 4
}

/// `n` connections from `local` (127.0.0.x) to `addr` (those that connect).
fn connect_from(local: &str, addr: SocketAddr, n: usize) -> Vec<TcpStream> {
    rt().block_on(async {
        let mut v = Vec::new();
        for _ in 0..n {
            let Ok(sock) = tokio::net::TcpSocket::new_v4() else {
                continue;
            };
            if sock.bind(format!("{local}:0").parse().unwrap()).is_err() {
                continue;
            }
            if let Ok(s) = sock.connect(addr).await
                && let Ok(s) = s.into_std()
                && s.set_nonblocking(false).is_ok()
            {
                v.push(s);
            }
        }
        v
    })
}

#[test]
fn idle_sockets_never_lock_out_a_bms_with_50_pollers() {
    let dir = tempfile::tempdir().unwrap();
    let server = serve(dir.path(), &[]);
    // an attacker at 127.0.0.2 opens 200 sockets and never speaks
    let parked = connect_from("127.0.0.2", server.addr, 200);
    assert_eq!(parked.len(), 200);
    std::thread::sleep(Duration::from_millis(300));
    // a BMS with 50 pollers at 127.0.0.1: every one is served, at once
    let mut bms: Vec<TcpStream> = (0..50)
        .map(|_| TcpStream::connect(server.addr).unwrap())
        .collect();
    for round in 0..3 {
        for (k, s) in bms.iter_mut().enumerate() {
            assert!(answered(s), "poller {k} round {round} not served");
        }
    }
    // the default per-source cap kept the attacker to 64 connections
    rt().block_on(async {
        let mut c = client(server.addr).await;
        let h = c.read_input_registers(40, 3).await.unwrap().unwrap();
        assert_eq!(
            h[0],
            64 + 50 + 1,
            "open: 64 parked, 50 pollers, this client"
        );
    });
    // one address holding the whole cap: newcomers evict its longest-idle sockets
    drop(parked);
    drop(bms);
    let server = serve(
        dir.path(),
        &["--max-connections", "32", "--max-per-source", "32"],
    );
    let parked: Vec<TcpStream> = (0..32)
        .map(|_| TcpStream::connect(server.addr).unwrap())
        .collect();
    std::thread::sleep(Duration::from_millis(2500));
    for k in 0..20 {
        let mut s = TcpStream::connect(server.addr).unwrap();
        assert!(answered(&mut s), "newcomer {k} not served");
        std::mem::forget(s);
    }
    rt().block_on(async {
        let mut c = client(server.addr).await;
        let h = c.read_input_registers(40, 3).await.unwrap().unwrap();
        assert!(h[2] >= 20, "evictions {h:?}");
    });
    drop(parked);
}

/// openssl, in `dir`: a CA, the node's certificate (localhost, 127.0.0.1), and client
/// certificates with a ModbusRole (None: no role extension).
fn make_certs(dir: &Path, clients: &[(&str, Option<&str>)]) {
    need("openssl");
    let run = |args: &[&str]| {
        let out = Command::new("openssl")
            .args(args)
            .current_dir(dir)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "openssl {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let ec = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:P-256",
        "-nodes",
    ];
    let mut a = vec!["req", "-x509"];
    a.extend(ec);
    a.extend([
        "-keyout",
        "ca.key",
        "-out",
        "ca.pem",
        "-days",
        "2",
        "-subj",
        "/CN=luxnode test CA",
        "-addext",
        "basicConstraints=critical,CA:TRUE",
        "-addext",
        "keyUsage=critical,keyCertSign,cRLSign",
    ]);
    run(&a);
    let sign = |name: &str, subject: &str, ext: &str| {
        std::fs::write(dir.join(format!("{name}.ext")), ext).unwrap();
        let mut a = vec!["req"];
        a.extend(ec);
        let (key, csr, pem, extf) = (
            format!("{name}.key"),
            format!("{name}.csr"),
            format!("{name}.pem"),
            format!("{name}.ext"),
        );
        a.extend(["-keyout", &key, "-out", &csr, "-subj", subject]);
        run(&a);
        run(&[
            "x509",
            "-req",
            "-in",
            &csr,
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-out",
            &pem,
            "-days",
            "2",
            "-extfile",
            &extf,
        ]);
    };
    sign(
        "node",
        "/CN=localhost",
        "basicConstraints=CA:FALSE\nsubjectAltName=DNS:localhost,IP:127.0.0.1\nextendedKeyUsage=serverAuth\n",
    );
    for (name, role) in clients {
        let role_ext = role
            .map(|r| format!("1.3.6.1.4.1.50316.802.1=ASN1:UTF8String:{r}\n"))
            .unwrap_or_default();
        sign(
            name,
            &format!("/CN={name}"),
            &format!("basicConstraints=CA:FALSE\nextendedKeyUsage=clientAuth\n{role_ext}"),
        );
    }
}

fn tls_client(dir: &Path, port: u16, who: Option<&str>, write: Option<&str>) -> serde_json::Value {
    let py = std::env::var("LUXNODE_PYTHON").unwrap_or_else(|_| "python3".into());
    let mut c = Command::new(py);
    c.arg(manifest().join("tests/clients/tls_client.py"))
        .args(["--port", &port.to_string(), "--ca"])
        .arg(dir.join("ca.pem"));
    if let Some(w) = who {
        c.arg("--cert")
            .arg(dir.join(format!("{w}.pem")))
            .arg("--key")
            .arg(dir.join(format!("{w}.key")));
    }
    if let Some(w) = write {
        c.args(["--write", w]);
    }
    let out = c.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stdout)))
}

#[test]
fn modbus_tcp_security_with_mutual_tls_and_roles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    make_certs(
        d,
        &[
            ("operator", Some("operator")),
            ("viewer", Some("viewer")),
            ("norole", None),
        ],
    );
    let board = d.join("board.toml");
    std::fs::write(
        &board,
        "name = \"tls\"\n[scene]\nsource = \"demo-office\"\n[modbus]\nwrite_allow = [\"role:operator\"]\n[modbus.tls]\nbind = \"127.0.0.1:0\"\ncert = \"node.pem\"\nkey = \"node.key\"\nclient_ca = \"ca.pem\"\n",
    )
    .unwrap();
    let server = serve(d, &["--board", &board.display().to_string()]);
    let t0 = Instant::now();
    let port: u16 = loop {
        let out = server.output();
        if let Some(p) = out.lines().find_map(|l| {
            l.split_once("modbus tls listening on ")
                .map(|x| x.1.to_string())
        }) {
            break p.trim().rsplit(':').next().unwrap().parse().unwrap();
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "no TLS listener:\n{out}"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    // an operator reads and writes
    let v = tls_client(d, port, Some("operator"), Some("1000=0"));
    assert!(v["version"].as_str().unwrap().starts_with("TLSv1."), "{v}");
    assert_eq!(v["core"][0], MAP_VERSION, "{v}");
    assert!(v["desk0_lux"].as_f64().unwrap() > 100.0, "{v}");
    assert_eq!(v["write"], serde_json::json!([6, 3, 232, 0, 0]), "{v}");
    // a viewer and a certificate without a role read, but may not write
    for who in ["viewer", "norole"] {
        let v = tls_client(d, port, Some(who), Some("1000=254"));
        assert_eq!(v["write"], serde_json::json!([0x86, 1]), "{who}: {v}");
    }
    // no client certificate: no session at all
    let v = tls_client(d, port, None, None);
    assert_eq!(v["handshake"], "failed", "{v}");
    // plain Modbus TCP on the TLS port: closed, counted
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    assert!(!answered(&mut s));
    rt().block_on(async {
        let mut c = client(server.addr).await;
        let h = c.read_input_registers(50, 2).await.unwrap().unwrap();
        assert_eq!(h[0], 1, "tls listening");
        assert!(h[1] >= 2, "failed handshakes {h:?}");
        // and plain TCP is read-only for everyone (the allowlist names only a role)
        let e = c.write_single_register(1000, 254).await.unwrap();
        assert_eq!(e, Err(ExceptionCode::IllegalFunction));
        assert_eq!(
            c.read_holding_registers(1000, 1).await.unwrap().unwrap(),
            [0]
        );
    });
}

/// Runs `luxnode run` on `board` and `flash` and SIGKILLs it as soon as a log line contains
/// `marker`; true if it was killed there (false: it ended before).
fn kill_at(board: &Path, flash: &Path, extra: &[&str], marker: &str) -> bool {
    use std::io::BufRead;
    let mut child = Command::new(LUXNODE)
        .args([
            "run",
            "--no-controller",
            "--seconds",
            "30",
            "--bind",
            "127.0.0.1:0",
        ])
        .arg("--board")
        .arg(board)
        .arg("--flash")
        .arg(flash)
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let mut killed = false;
    for line in std::io::BufReader::new(stderr).lines() {
        let Ok(line) = line else { break };
        if line.contains(marker) {
            let _ = child.kill();
            killed = true;
            break;
        }
    }
    let _ = child.wait();
    killed
}

/// What a boot would find on `flash`: the generation of the image that passes the whole load
/// path, if any.
fn bootable_generation(flash: &Path) -> Option<u64> {
    use luxnode::node::{Node, NodeModel, NodeOptions};
    let dev = FileFlash::open(flash, flash_bytes()).unwrap();
    read_bootable(&mut Slots::new(dev), |img, g| {
        Node::new(NodeModel::from_image(img, g), NodeOptions::default())
            .map(|_| ())
            .map_err(|e| e.to_string())
    })
    .image
    .map(|(_, _, g)| g)
}

#[test]
fn a_kill_at_every_stage_of_commissioning_and_write_loses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let flash = dir.path().join("flash.bin");
    let b = board(dir.path(), "").display().to_string();
    let b = Path::new(&b);
    // the fast preset keeps each run short; the stages are the same
    let sim = std::fs::read_to_string(b).unwrap();
    std::fs::write(b, sim.replace("preset = \"balanced\"", "preset = \"fast\"")).unwrap();
    let stages = [
        "commissioning from",
        "capture: depth frame",
        "capture: luminance frame",
        "commission: planes",
        "commissioned in",
        "flash: image written",
    ];
    let mut table = Vec::new();
    // first boot, empty flash: killed at each stage, the flash holds nothing or a whole image
    for s in stages {
        let killed = kill_at(b, &flash, &[], s);
        let found = bootable_generation(&flash);
        table.push(format!("first boot | {s} | {killed} | {found:?}"));
        if s == "flash: image written" {
            assert_eq!(found, Some(1), "{s}");
        } else {
            assert!(found.is_none() || found == Some(1), "{s}: {found:?}");
        }
    }
    // re-commissioning over generation 1: killed at each stage, generation 1 or 2 boots
    for s in stages {
        let killed = kill_at(b, &flash, &["--recommission"], s);
        let found = bootable_generation(&flash);
        table.push(format!("re-commissioning | {s} | {killed} | {found:?}"));
        assert!(killed, "never reached {s}");
        assert!(found.is_some(), "{s}: the last good image was lost");
    }
    eprintln!(
        "run | killed at | killed | bootable generation after\n{}",
        table.join("\n")
    );
}

/// A board's luxmeter readings (`[commissioning] luxmeter_rho`) reach the first boot's
/// commissioning from the cameras: the walls and ceiling are fitted to them with the hooded
/// ambient light sensor's directly measured gain, whose run-time reference is still written. A
/// reading at a sensor the room does not have is refused before any capture.
#[test]
fn a_boards_luxmeter_readings_reach_first_boot_commissioning() {
    let dir = tempfile::tempdir().unwrap();
    let flash = dir.path().join("flash.img");
    let run = |board: &Path, seconds: &str| {
        Command::new(LUXNODE)
            .args(["run", "--no-controller", "--bind", "127.0.0.1:0"])
            .args(["--seconds", seconds, "--board"])
            .arg(board)
            .arg("--flash")
            .arg(&flash)
            .output()
            .unwrap()
    };
    let t0 = Instant::now();
    let out = run(
        &board(dir.path(), "[commissioning]\nluxmeter_rho = [\"99:600\"]\n"),
        "1",
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("sensor 99: no such sensor"), "{err}");
    assert!(
        !err.contains("capture:"),
        "refused before any capture: {err}"
    );
    assert!(t0.elapsed() < Duration::from_secs(10));
    for bad in ["\"2\"", "\"2:-5\"", "\"2:600\", \"2:610\""] {
        let out = run(
            &board(
                dir.path(),
                &format!("[commissioning]\nluxmeter_rho = [{bad}]\n"),
            ),
            "1",
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{bad}: {err}");
        assert!(err.contains("commissioning.luxmeter_rho"), "{bad}: {err}");
    }
    // the demo office's CAD model reads 684 lx at sensor 2 with every luminaire on
    // (`luxnode image eval`): the luxmeter here
    let out = run(
        &board(dir.path(), "[commissioning]\nluxmeter_rho = [\"2:684\"]\n"),
        "2",
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("1 luxmeter readings set the walls"), "{err}");
    assert!(err.contains("the camera's gain measured directly"), "{err}");
    assert!(
        dir.path().join("ambient-reference.json").exists(),
        "the ALS check's reference: {err}"
    );
}

/// Issue 34: `luxnode commission --force` has its board-file form for the node's own first-boot
/// commissioning, `[commissioning] force = true` (default false); anything but a boolean is
/// refused with the key's name.
#[test]
fn a_boards_commissioning_force_is_read_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let plain = luxnode::board::Board::load(&board(dir.path(), "")).expect("sim board");
    assert!(!plain.force);
    let forced = luxnode::board::Board::load(&board(dir.path(), "[commissioning]\nforce = true\n"))
        .expect("board with force");
    assert!(forced.force);
    let err = luxnode::board::Board::load(&board(dir.path(), "[commissioning]\nforce = \"yes\"\n"))
        .map(|_| ())
        .expect_err("a string is not a boolean")
        .to_string();
    assert!(err.contains("force"), "{err}");
}
