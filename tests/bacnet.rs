//! BACnet/IP end to end: `luxnode serve --bacnet` as a real process on a real UDP socket, read,
//! written and subscribed by an independent stack (bacpypes3, PyPI, through
//! tests/clients/bacnet_client.py), its numbers checked against the Modbus registers of the
//! same process and the run-time core over the same image; raw datagrams for the refusals; the
//! fuzzer for 10^5 malformed datagrams; the PICS against the object table.
//!
//! bacpypes3 and pymodbus are installed by scripts/install-test-tools.sh (scripts/test.sh
//! runs it); a test that needs them and cannot import them fails saying so.

use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use luxnode::bacnet::consts::{confirmed, property};
use luxnode::bacnet::wire::{ObjectId, Writer};
use luxnode::runtime::Runtime;
use luxnode::store::Image;
use serde_json::Value;
use tokio_modbus::client::Reader;
use tokio_modbus::prelude::Slave;

mod common;
use common::procs::{LUXNODE, Proc, floats_abcd, rt, spawn_listening};

const DEVICE: u32 = 4321;

fn office_image() -> PathBuf {
    common::procs::cli_office_image("bacnet")
}

/// A node serving Modbus and BACnet (device 4321, any free UDP port on 127.0.0.1), writes
/// allowed from 127.0.0.1 only; `extra` are more `serve` flags.
struct Node {
    proc: Proc,
    bacnet: SocketAddr,
}

fn serve(extra: &[&str]) -> Node {
    let mut args: Vec<String> = [
        "serve",
        "--bind",
        "127.0.0.1:0",
        "--bacnet",
        "127.0.0.1:0",
        "--bacnet-device-id",
        "4321",
        "--allow-writes-from",
        "127.0.0.1",
        "--image",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.push(office_image().display().to_string());
    args.extend(extra.iter().map(|s| s.to_string()));
    let proc = spawn_listening(LUXNODE, &args);
    let t0 = Instant::now();
    loop {
        let out = proc.output();
        if let Some((_, a)) = out.split_once("bacnet listening on ") {
            let a = a.split_whitespace().next().unwrap_or("");
            let bacnet = a.parse().expect("bacnet address");
            return Node { proc, bacnet };
        }
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "no bacnet line:\n{out}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The Object_Name `luxnode points` lists for BACnet object `table`,`instance` of the office.
fn points_list_object_name(table: &str, instance: u64) -> String {
    let image = office_image();
    let v = common::procs::luxnode_json(&[
        "points".as_ref(),
        "--format".as_ref(),
        "json".as_ref(),
        "--bacnet-device-id".as_ref(),
        "4321".as_ref(),
        "--image".as_ref(),
        image.as_os_str(),
    ]);
    let row = v["values"]
        .as_array()
        .and_then(|rows| {
            rows.iter().find(|r| {
                r["protocol"] == "bacnet" && r["table"] == table && r["address"] == instance
            })
        })
        .cloned()
        .unwrap_or_default();
    row["object_name"].as_str().unwrap_or_default().to_owned()
}

fn python() -> String {
    std::env::var("LUXNODE_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Runs the bacpypes3 client from `local` (IP) against the node; its JSON answer.
fn client(node: &Node, local: &str, args: &[&str]) -> Value {
    let import = Command::new(python())
        .args(["-c", "import bacpypes3, pymodbus"])
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    assert!(
        import,
        "bacpypes3 or pymodbus missing: run scripts/install-test-tools.sh (scripts/test.sh does)"
    );
    // a free UDP port on that address for the client
    let port = UdpSocket::bind((local, 0))
        .and_then(|s| s.local_addr())
        .expect("free port")
        .port();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/clients/bacnet_client.py");
    let out = Command::new(python())
        .arg(script)
        .args(["--local", &format!("{local}:{port}")])
        .args(["--target", &node.bacnet.to_string()])
        .args(["--device", &DEVICE.to_string()])
        .args(args)
        .output()
        .expect("run bacnet_client.py");
    assert!(
        out.status.success(),
        "bacnet_client.py {args:?}: {}\nnode:\n{}",
        String::from_utf8_lossy(&out.stderr),
        node.proc.output()
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("{e}: {}", String::from_utf8_lossy(&out.stdout));
    })
}

/// Desk lux from the run-time core over the same image, every luminaire at arc 254.
fn runtime_all_on() -> Vec<f64> {
    let bytes = std::fs::read(office_image()).unwrap();
    let image = Image::parse(&bytes).unwrap();
    let rt = Runtime::new(&image);
    let levels = vec![1.0; image.luminaires()];
    let mut out = vec![0.0; image.sensors()];
    rt.sensor_lux(&levels, &mut out).unwrap();
    out
}

fn modbus_floats(node: &Node, address: u16, n: u16) -> Vec<f64> {
    rt().block_on(async {
        let mut c = tokio_modbus::client::tcp::connect_slave(node.proc.addr, Slave(1))
            .await
            .expect("connect");
        floats_abcd(&c.read_input_registers(address, n).await.unwrap().unwrap())
    })
}

fn object<'a>(read: &'a Value, id: &str) -> &'a Value {
    &read["objects"][id]
}

#[test]
fn who_is_finds_the_device_in_and_only_in_its_range() {
    let node = serve(&["--arc", "254"]);
    let all = client(&node, "127.0.0.1", &["whois"]);
    let i_am = &all["i_am"][0];
    assert_eq!(i_am["device"], serde_json::json!(["device", DEVICE]));
    assert_eq!(i_am["max_apdu"], 1476);
    assert_eq!(i_am["segmentation"], "no-segmentation");
    let inside = client(
        &node,
        "127.0.0.1",
        &["whois", "--low", "4000", "--high", "4400"],
    );
    assert_eq!(inside["i_am"].as_array().map(Vec::len), Some(1));
    let outside = client(
        &node,
        "127.0.0.1",
        &["whois", "--low", "1", "--high", "4320"],
    );
    assert_eq!(outside["i_am"].as_array().map(Vec::len), Some(0));
}

#[test]
fn who_has_by_identifier_and_by_name_is_answered_with_the_right_i_have() {
    let node = serve(&["--arc", "254"]);
    // the second point's total Analog Input is named after the point (`luxnode points`)
    let name = points_list_object_name("analog-input", 1);
    // office_a's sensor 2 stands on desk 1 (its sensors.json note says so)
    assert_eq!(name, "desk 1 (S2) illuminance");
    let only = |q: &[&str]| {
        let mut args = vec!["whohas", "--low", "4321", "--high", "4321"];
        args.extend_from_slice(q);
        let r = client(&node, "127.0.0.1", &args);
        let list = r["i_have"].as_array().cloned().unwrap_or_default();
        assert_eq!(list.len(), 1, "{q:?}: {r}");
        list[0].clone()
    };
    let by_id = only(&["--id", "analog-input,1"]);
    assert_eq!(by_id["device"], serde_json::json!(["device", DEVICE]));
    assert_eq!(by_id["object"], serde_json::json!(["analog-input", 1]));
    assert_eq!(by_id["name"], name.as_str());
    let by_name = only(&["--name", &name]);
    assert_eq!(by_name, by_id, "by name: the same object");
    // the Device itself, by identifier then by the name it gave
    let dev = only(&["--id", &format!("device,{DEVICE}")]);
    assert_eq!(dev["object"], serde_json::json!(["device", DEVICE]));
    let dev_name = dev["name"].as_str().unwrap_or_default().to_owned();
    assert_eq!(only(&["--name", &dev_name])["object"], dev["object"]);
    // no answer: outside the device range, a name or an object the node does not have
    for q in [
        vec!["--id", "analog-input,1", "--low", "1", "--high", "4320"],
        vec!["--name", "desk 424242 illuminance"],
        vec!["--id", "analog-input,9999"],
    ] {
        let mut args = vec!["whohas"];
        args.extend_from_slice(&q);
        let r = client(&node, "127.0.0.1", &args);
        assert_eq!(r["i_have"].as_array().map(Vec::len), Some(0), "{q:?}: {r}");
    }
}

#[test]
fn every_desk_reads_what_modbus_and_the_runtime_give() {
    let node = serve(&["--arc", "254"]);
    let read = client(&node, "127.0.0.1", &["read"]);
    let want = runtime_all_on();
    let d = want.len();
    let modbus = modbus_floats(&node, 100, 2 * d as u16);
    let luminaires = 8;
    assert_eq!(read["object_count"], 1 + 5 * d + luminaires);
    let dev = &read["device"];
    assert_eq!(
        dev["object-identifier"],
        serde_json::json!(["device", DEVICE])
    );
    assert_eq!(dev["vendor-name"], "luxnode");
    assert_eq!(dev["max-apdu-length-accepted"], 1476);
    assert_eq!(dev["segmentation-supported"], 3);
    let map_version = luxnode::modbus::regmap::MAP_VERSION;
    assert!(
        dev["description"]
            .as_str()
            .is_some_and(|s| s.contains(&format!("register map version {map_version}"))),
        "{dev}"
    );
    for k in 0..d {
        let ai = object(&read, &format!("analog-input,{k}"));
        let pv = ai["present-value"].as_f64().expect("present value");
        // the same f32 as the Modbus float, the run-time core's value in f32
        assert_eq!(pv, modbus[k], "desk {k}: BACnet {pv}, Modbus {}", modbus[k]);
        assert_eq!(
            pv,
            f64::from(want[k] as f32),
            "desk {k} vs the run-time core"
        );
        assert_eq!(
            ai["rp-present-value"], ai["present-value"],
            "RP and RPM agree"
        );
        assert_eq!(ai["units"], 37, "luxes");
        assert_eq!(ai["status-flags"], serde_json::json!([0, 0, 0, 0]));
        assert_eq!(ai["reliability"], 0);
        assert_eq!(ai["out-of-service"], 0);
        assert!(
            ai["object-name"]
                .as_str()
                .is_some_and(|n| n.ends_with(" illuminance"))
        );
        // artificial = total without live light; the daylight is not known: NaN, flagged
        let art = object(&read, &format!("analog-input,{}", 200 + k));
        assert_eq!(art["present-value"], ai["present-value"]);
        let day = object(&read, &format!("analog-input,{}", 100 + k));
        assert_eq!(day["present-value"], Value::Null, "NaN, not a guess");
        assert_eq!(day["reliability"], 7, "unreliable-other");
        assert_eq!(
            day["status-flags"],
            serde_json::json!([0, 1, 0, 0]),
            "fault"
        );
        let target = object(&read, &format!("analog-value,{}", 1000 + k));
        assert_eq!(target["units"], 37);
        assert!(
            (ai["cov-increment"].as_f64().unwrap()
                - 0.01 * target["present-value"].as_f64().unwrap())
            .abs()
                < 1e-3
        );
    }
    for j in 0..luminaires {
        let av = object(&read, &format!("analog-value,{j}"));
        assert_eq!(av["present-value"], 100.0);
        assert_eq!(av["units"], 98, "percent");
    }
}

#[test]
fn stale_values_are_flagged_communication_failure() {
    // no --arc: the dimming state is unknown until written, the values are stale
    let node = serve(&[]);
    let read = client(&node, "127.0.0.1", &["read"]);
    let ai = object(&read, "analog-input,0");
    // no dimming state known yet: no value (NaN, as on Modbus), never 0 lx
    assert_eq!(ai["present-value"], Value::Null, "NaN, not dark");
    assert_eq!(ai["reliability"], 12, "communication-failure");
    assert_eq!(ai["status-flags"], serde_json::json!([0, 1, 0, 0]));
}

#[test]
fn cov_notifications_follow_bacnet_and_modbus_writes_within_a_second() {
    let node = serve(&["--arc", "254"]);
    // 100 subscribers (unconfirmed) to desk 1's total; a BACnet write dims luminaire 1
    let r = client(
        &node,
        "127.0.0.1",
        &[
            "cov",
            "analog-input,1",
            "--write",
            "analog-value,1",
            "20",
            "--subscribers",
            "100",
        ],
    );
    assert_eq!(r["ok"], true, "{r}");
    let elapsed = r["elapsed_s"].as_array().expect("elapsed");
    assert_eq!(elapsed.len(), 100);
    for (k, e) in elapsed.iter().enumerate() {
        let e = e
            .as_f64()
            .unwrap_or_else(|| panic!("subscriber {k}: no notification in 3 s"));
        assert!(e < 1.0, "subscriber {k}: notified after {e} s");
    }
    let (before, after) = (
        r["initial"][0].as_f64().unwrap(),
        r["after"][0].as_f64().unwrap(),
    );
    assert!(after < before, "dimmer: {before} -> {after}");
    // confirmed notifications, the change made over Modbus (luminaire 0 off)
    let modbus = node.proc.addr.to_string();
    let r = client(
        &node,
        "127.0.0.1",
        &[
            "cov",
            "analog-input,0",
            "--write-modbus",
            &modbus,
            "1000",
            "0",
            "--confirmed",
        ],
    );
    assert_eq!(r["ok"], true, "{r}");
    let e = r["elapsed_s"][0].as_f64().expect("a notification");
    assert!(e < 1.0, "notified after {e} s");
    let now = modbus_floats(&node, 100, 2)[0];
    assert_eq!(
        r["after"][0].as_f64(),
        Some(now),
        "the notified value is the new one"
    );
}

#[test]
fn writes_only_from_the_allowlist() {
    let node = serve(&["--arc", "254"]);
    // 127.0.0.2 is not in the allowlist (127.0.0.1 is)
    for (obj, value) in [("analog-value,1000", "420"), ("analog-value,0", "10")] {
        let r = client(&node, "127.0.0.2", &["write", obj, "present-value", value]);
        assert_eq!(r["ok"], false, "{r}");
        assert!(
            r["error"]
                .as_str()
                .is_some_and(|e| e.contains("write-access-denied")),
            "{r}"
        );
    }
    let read = client(&node, "127.0.0.1", &["read"]);
    assert_eq!(
        object(&read, "analog-value,1000")["present-value"],
        500.0,
        "unchanged"
    );
    assert_eq!(
        object(&read, "analog-value,0")["present-value"],
        100.0,
        "unchanged"
    );
    // from the allowlist: the target is set (and reads back over Modbus), the level too
    let r = client(
        &node,
        "127.0.0.1",
        &["write", "analog-value,1000", "present-value", "420"],
    );
    assert_eq!(r["ok"], true, "{r}");
    let r = client(
        &node,
        "127.0.0.1",
        &[
            "write",
            "analog-value,0",
            "present-value",
            "10",
            "--priority",
            "8",
        ],
    );
    assert_eq!(r["ok"], true, "{r}");
    let target = rt().block_on(async {
        let mut c = tokio_modbus::client::tcp::connect_slave(node.proc.addr, Slave(1))
            .await
            .expect("connect");
        c.read_holding_registers(2100, 1).await.unwrap().unwrap()[0]
    });
    assert_eq!(target, 420);
    // out of range, read-only property, unknown object: errors, not crashes
    for (obj, prop, value, want) in [
        (
            "analog-value,0",
            "present-value",
            "101",
            "value-out-of-range",
        ),
        (
            "analog-input,0",
            "present-value",
            "1",
            "write-access-denied",
        ),
        ("analog-value,999", "present-value", "1", "unknown-object"),
    ] {
        let r = client(&node, "127.0.0.1", &["write", obj, prop, value]);
        assert!(
            r["error"].as_str().is_some_and(|e| e.contains(want)),
            "{obj}: {r}"
        );
    }
}

/// A confirmed request datagram (invoke id 9, `max_apdu_code`), `body` its service data.
fn request(service: u8, max_apdu_code: u8, body: impl FnOnce(&mut Writer<'_>)) -> Vec<u8> {
    let mut d = luxnode::fieldbus::bacnet::fuzz::request(service, body);
    d[6 + 1] = max_apdu_code;
    d[6 + 2] = 9;
    d
}

fn exchange(sock: &UdpSocket, to: SocketAddr, d: &[u8]) -> Option<Vec<u8>> {
    sock.send_to(d, to).expect("send");
    let mut buf = [0u8; 2048];
    match sock.recv_from(&mut buf) {
        Ok((n, _)) => Some(buf[..n].to_vec()),
        Err(_) => None,
    }
}

#[test]
fn refusals_are_bacnet_rejects_and_aborts_and_service_survives_garbage() {
    let node = serve(&["--arc", "254"]);
    let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
    sock.set_read_timeout(Some(Duration::from_millis(500)))
        .unwrap();
    let to = node.bacnet;
    let apdu = |a: Option<Vec<u8>>| a.map(|d| d[6..].to_vec());
    let dev = ObjectId::new(8, DEVICE);
    // the whole object list does not fit in 50 octets: abort, segmentation-not-supported
    let rp_list = request(confirmed::READ_PROPERTY, 0, |w| {
        let _ = w.context_object_id(0, dev);
        let _ = w.context_enumerated(1, property::OBJECT_LIST);
    });
    assert_eq!(apdu(exchange(&sock, to, &rp_list)), Some(vec![0x71, 9, 4]));
    // a segmented request: abort, segmentation-not-supported
    let mut seg = rp_list.clone();
    seg[6] = 0x08;
    seg.splice(9..9, [0u8, 1]);
    let n = seg.len() as u16;
    seg[2..4].copy_from_slice(&n.to_be_bytes());
    assert_eq!(apdu(exchange(&sock, to, &seg)), Some(vec![0x71, 9, 4]));
    // ReinitializeDevice (not executed): reject, unrecognized-service
    let reinit = request(confirmed::REINITIALIZE_DEVICE, 5, |w| {
        let _ = w.context_enumerated(0, 0);
    });
    assert_eq!(apdu(exchange(&sock, to, &reinit)), Some(vec![0x60, 9, 9]));
    // DeviceCommunicationControl without a board setting: error services/service-request-denied
    let dcc = request(confirmed::DEVICE_COMMUNICATION_CONTROL, 5, |w| {
        let _ = w.context_enumerated(1, 1);
    });
    assert_eq!(
        apdu(exchange(&sock, to, &dcc)),
        Some(vec![0x50, 9, 17, 0x91, 5, 0x91, 29])
    );
    // a truncated ReadProperty: reject, missing-required-parameter
    let short = request(confirmed::READ_PROPERTY, 5, |w| {
        let _ = w.context_object_id(0, dev);
    });
    assert_eq!(apdu(exchange(&sock, to, &short)), Some(vec![0x60, 9, 5]));
    // 20 000 datagrams of garbage and mutations: answered or dropped, the node still serves
    let seeds = luxnode::fieldbus::bacnet::fuzz::seeds();
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    for i in 0..20_000usize {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let mut d = seeds[i % seeds.len()].clone();
        let at = (x as usize) % d.len();
        d[at] ^= (x >> 32) as u8 | 1;
        if i % 3 == 0 {
            d.truncate(at.max(1));
        }
        let _ = sock.send_to(&d, to);
    }
    std::thread::sleep(Duration::from_millis(300));
    sock.set_read_timeout(Some(Duration::from_millis(1)))
        .unwrap();
    let mut buf = [0u8; 2048];
    while sock.recv_from(&mut buf).is_ok() {}
    sock.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let r = client(&node, "127.0.0.1", &["whois"]);
    assert_eq!(r["i_am"].as_array().map(Vec::len), Some(1), "still served");
}

#[test]
fn a_hundred_thousand_malformed_datagrams_neither_panic_nor_hang() {
    let t0 = Instant::now();
    let r = luxnode::fieldbus::bacnet::fuzz::run(100_000, 0xBAC0_0001)
        .unwrap_or_else(|f| panic!("{f}"));
    eprintln!("{r:?} in {:?}", t0.elapsed());
    assert_eq!(r.datagrams, 100_000);
    assert!(r.acks > 1_000 && r.refusals > 1_000, "{r:?}");
    assert!(r.slowest < Duration::from_millis(50), "{r:?}");
    assert!(t0.elapsed() < Duration::from_secs(30), "{:?}", t0.elapsed());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(5_000))]
    /// Arbitrary bytes behind a valid BVLC and NPDU header: handled, never a panic.
    #[test]
    fn arbitrary_apdus_never_panic(body in proptest::collection::vec(proptest::num::u8::ANY, 0..200)) {
        let mut node = luxnode::fieldbus::bacnet::fuzz::sample_node();
        let mut server = luxnode::fieldbus::bacnet::fuzz::sample_server();
        let d = luxnode::fieldbus::bacnet::fuzz::frame(false, &body);
        let out = server.handle(&mut node, luxnode::fieldbus::bacnet::fuzz::peer(), &d, Instant::now());
        proptest::prop_assert!(out.len() <= 2);
    }
}

#[test]
fn the_pics_is_generated_from_the_object_table() {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/bacnet.md"))
        .unwrap();
    let pics = luxnode::bacnet::pics::markdown();
    assert!(
        doc.contains(pics.trim()),
        "docs/bacnet.md differs from the object table: regenerate it with `luxnode bacnet pics`"
    );
}

#[test]
fn foreign_device_registration_is_retried_with_backoff_and_local_service_goes_on() {
    use luxnode::bacnet::objects::DeviceInfo;
    use luxnode::fieldbus::bacnet::service::ServerConfig;
    use luxnode::fieldbus::bacnet::{BacnetCounters, BacnetOptions, BbmdConfig, bind, serve};
    use std::sync::atomic::Ordering;
    use std::sync::{Arc, Mutex};
    use tokio::time::timeout;
    rt().block_on(async {
        let bbmd = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let options = BacnetOptions {
            bind: "127.0.0.1:0".parse().unwrap(),
            server: ServerConfig {
                device: DeviceInfo::new(1234, "test"),
                dcc_password: None,
            },
            bbmd: Some(BbmdConfig {
                address: bbmd.local_addr().unwrap(),
                ttl_s: 60,
            }),
        };
        let socket = bind(options.bind).await.unwrap();
        let node_addr = socket.local_addr().unwrap();
        let node = Arc::new(Mutex::new(luxnode::fieldbus::bacnet::fuzz::sample_node()));
        let counters = Arc::new(BacnetCounters::default());
        let (stop, stop_rx) = tokio::sync::watch::channel(false);
        let task = tokio::spawn(serve(
            socket,
            node,
            options,
            counters.clone(),
            stop_rx,
            None,
        ));
        let mut buf = [0u8; 64];
        // the first registration at once (TTL 60 s); the BBMD stays silent
        let (n, _) = timeout(Duration::from_secs(1), bbmd.recv_from(&mut buf))
            .await
            .expect("a registration")
            .unwrap();
        assert_eq!(&buf[..n], &[0x81, 0x05, 0, 6, 0, 60]);
        let t1 = Instant::now();
        // local service does not wait for the BBMD
        let client = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let who_is = luxnode::fieldbus::bacnet::fuzz::frame(true, &[0x10, 0x08]);
        client.send_to(&who_is, node_addr).await.unwrap();
        let (n, _) = timeout(Duration::from_secs(1), client.recv_from(&mut buf))
            .await
            .expect("an I-Am while the BBMD is silent")
            .unwrap();
        assert_eq!(&buf[6..8], &[0x10, 0x00], "I-Am: {:02x?}", &buf[..n]);
        // no answer in 2 s: a failure, retried after the first backoff (1 s)
        let (_, from) = timeout(Duration::from_secs(5), bbmd.recv_from(&mut buf))
            .await
            .expect("a retry")
            .unwrap();
        let gap = t1.elapsed();
        assert!(
            gap >= Duration::from_millis(2900) && gap < Duration::from_millis(3600),
            "retry after {gap:?}"
        );
        assert!(!counters.fd_registered.load(Ordering::Relaxed));
        assert_eq!(counters.fd_failures.load(Ordering::Relaxed), 1);
        // the BBMD accepts: registered
        bbmd.send_to(&[0x81, 0x00, 0, 6, 0, 0], from).await.unwrap();
        // registered: the device announces itself through the BBMD (Distribute-Broadcast-To-
        // Network, an I-Am of device 1234)
        let (n, _) = timeout(Duration::from_secs(1), bbmd.recv_from(&mut buf))
            .await
            .expect("an I-Am through the BBMD")
            .unwrap();
        assert_eq!(&buf[..2], &[0x81, 0x09], "{:02x?}", &buf[..n]);
        assert_eq!(&buf[6..13], &[0x10, 0x00, 0xC4, 0x02, 0x00, 0x04, 0xD2]);
        assert!(counters.fd_registered.load(Ordering::Relaxed));
        let _ = stop.send(true);
        let _ = task.await;
    });
}

/// Input register 3 (status bits) of the node.
fn modbus_status(node: &Node) -> u16 {
    rt().block_on(async {
        let mut c = tokio_modbus::client::tcp::connect_slave(node.proc.addr, Slave(1))
            .await
            .expect("connect");
        c.read_input_registers(3, 1).await.unwrap().unwrap()[0]
    })
}

/// Waits up to `limit` for the status bit `bit` to be `on`; the status last read.
fn await_status_bit(node: &Node, bit: u16, on: bool, limit: Duration) -> u16 {
    let t0 = Instant::now();
    loop {
        let s = modbus_status(node);
        if (s & bit != 0) == on || t0.elapsed() > limit {
            return s;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_bbmd_that_does_not_answer_raises_status_bit_9_and_the_device_reliability() {
    use luxnode::modbus::regmap::status::BBMD_FAILING;
    assert_eq!(BBMD_FAILING, 1 << 9, "docs/modbus.md: status bit 9");
    let bbmd = UdpSocket::bind("127.0.0.1:0").unwrap();
    bbmd.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let board = dir.path().join("board.toml");
    std::fs::write(
        &board,
        format!(
            "name = \"bbmd-test\"\n[scene]\nsource = \"demo-office\"\n[bacnet]\n\
             bind = \"127.0.0.1:0\"\ndevice_id = 4321\nbbmd = \"{}\"\nbbmd_ttl_s = 60\n",
            bbmd.local_addr().unwrap()
        ),
    )
    .unwrap();
    let node = serve(&["--arc", "254", "--board", &board.display().to_string()]);
    let mut buf = [0u8; 64];
    let (n, _) = bbmd.recv_from(&mut buf).expect("a registration");
    assert_eq!(&buf[..n], &[0x81, 0x05, 0, 6, 0, 60]);
    // the BBMD stays silent: no answer in 2 s, the bit is set
    let s = await_status_bit(&node, BBMD_FAILING, true, Duration::from_secs(6));
    assert_ne!(s & BBMD_FAILING, 0, "status {s:#06x}");
    let reliability = |node: &Node| {
        let r = client(
            node,
            "127.0.0.1",
            &["rp", &format!("device,{DEVICE}"), "reliability"],
        );
        assert_eq!(r["ok"], true, "{r}");
        r["value"].clone()
    };
    assert_eq!(reliability(&node), 12, "communication-failure");
    // local service goes on: the local client finds the device and reads a desk
    let r = client(&node, "127.0.0.1", &["whois"]);
    assert_eq!(r["i_am"].as_array().map(Vec::len), Some(1), "{r}");
    let r = client(
        &node,
        "127.0.0.1",
        &["rp", "analog-input,0", "present-value"],
    );
    assert_eq!(
        r["value"].as_f64(),
        Some(modbus_floats(&node, 100, 2)[0]),
        "{r}"
    );
    // the BBMD answers the next registration: the bit clears, the Device is reliable again
    let from = loop {
        let (n, from) = bbmd.recv_from(&mut buf).expect("a retry");
        if buf[..n] == [0x81, 0x05, 0, 6, 0, 60] {
            break from;
        }
    };
    bbmd.send_to(&[0x81, 0x00, 0, 6, 0, 0], from).unwrap();
    let s = await_status_bit(&node, BBMD_FAILING, false, Duration::from_secs(3));
    assert_eq!(s & BBMD_FAILING, 0, "status {s:#06x}");
    assert_eq!(reliability(&node), 0, "no-fault-detected");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2_000))]
    /// Who-Has and I-Have: what the codec emits parses back to the same request; arbitrary
    /// service data is an error or a request, never a panic.
    #[test]
    fn who_has_and_i_have_round_trip_and_never_panic(
        limits in proptest::option::of((0u32..=0x3F_FFFF, 0u32..=0x3F_FFFF)),
        raw_id in proptest::num::u32::ANY,
        name in "[ -~äöü€]{0,60}",
        by_name in proptest::bool::ANY,
        junk in proptest::collection::vec(proptest::num::u8::ANY, 0..80),
    ) {
        use luxnode::bacnet::who_has::{IHave, Wanted, WhoHas};
        let id = ObjectId::from_u32(raw_id);
        let object = if by_name { Wanted::Name(&name) } else { Wanted::Id(id) };
        let q = WhoHas { limits, object };
        let mut buf = [0u8; 256];
        let mut w = Writer::new(&mut buf);
        q.emit(&mut w).expect("fits");
        proptest::prop_assert_eq!(WhoHas::parse(w.written()), Ok(q));
        let a = IHave { device: ObjectId::new(8, DEVICE), object: id, name: &name };
        let mut buf = [0u8; 256];
        let mut w = Writer::new(&mut buf);
        a.emit(&mut w).expect("fits");
        proptest::prop_assert_eq!(IHave::parse(w.written()), Ok(a));
        let _ = (WhoHas::parse(&junk), IHave::parse(&junk));
    }
}
