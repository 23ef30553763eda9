//! The bodies of the fuzz targets, shared by the cargo-fuzz targets (`fuzz/fuzz_targets/*.rs`,
//! coverage-guided, nightly) and the stable smoke test (`tests/fuzz_smoke.rs`, which runs every
//! body on its committed corpus and on deterministic mutations of it, so CI exercises every
//! target even where nightly is missing). A body may return an error for bad input; it must
//! never panic, hang or allocate without bound. Where a body reaches a parser only through
//! files (the loaders read paths), it writes the input to a per-process scratch directory.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A target's body.
pub type Body = fn(&[u8]);

/// Every target by name, for the smoke test and `scripts/fuzz.sh`.
pub const TARGETS: &[(&str, Body)] = &[
    ("modbus_pdu", modbus_pdu),
    ("modbus_rtu", modbus_rtu),
    ("bacnet_datagram", bacnet_datagram),
    ("eulumdat", eulumdat),
    ("ies", ies),
    ("obj_mtl", obj_mtl),
    ("scene_json", scene_json),
    ("capture_png", capture_png),
    ("board_toml", board_toml),
    ("flash_image", flash_image),
    ("calibration_record", calibration_record),
    ("live_section", live_section),
];

fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("luxnode-fuzz-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&d);
        d
    })
}

fn text(data: &[u8]) -> String {
    String::from_utf8_lossy(data).into_owned()
}

/// A request PDU to the register map: every answer well formed (the checks of
/// `luxnode::fieldbus::fuzz`); then the same bytes as an RTU frame with the CRC fixed up and
/// stale, for our unit, another and broadcast.
pub fn modbus_pdu(data: &[u8]) {
    let mut f = luxnode::fieldbus::fuzz::Fuzzer::default();
    let unit = data.first().copied().unwrap_or(7);
    if let Err(e) = f.feed(data, 7, true) {
        panic!("{e}");
    }
    if let Err(e) = f.feed(data, unit, false) {
        panic!("{e}");
    }
}

/// A BACnet/IP datagram to the server (`luxnode::fieldbus::bacnet::fuzz`): every answer well formed
/// (BVLC, NPDU, APDU parse; a confirmed request's answer carries its invoke id); then the same
/// bytes as an APDU behind a valid BVLC and NPDU header.
pub fn bacnet_datagram(data: &[u8]) {
    let mut f = luxnode::fieldbus::bacnet::fuzz::Fuzzer::default();
    if let Err(e) = f.feed(data) {
        panic!("{e}");
    }
    if let Err(e) = f.feed(&luxnode::fieldbus::bacnet::fuzz::frame(false, data)) {
        panic!("{e}");
    }
}

/// Raw bytes on the RTU line: the frame decoder, then a node (read-only policy, from the RTU
/// source) answering what decodes.
pub fn modbus_rtu(data: &[u8]) {
    use luxnode::fieldbus::rtu::{RtuCounters, handle_frame};
    use luxnode::modbus::access::Source;
    use luxnode::modbus::frame::{MAX_RTU_FRAME, decode_rtu};
    use luxnode::node::{Node, NodeModel, NodeOptions};
    let _ = decode_rtu(data);
    let model = NodeModel {
        response_lx: vec![100.0, 200.0, 10.0, 20.0],
        sensor_ids: vec![1, 2],
        luminaire_ids: vec![1, 2],
        sensor_flags: vec![0, 1],
        model_rel_uncertainty: vec![0.05, f64::NAN],
        uncertainty_parts_lx: Vec::new(),
        occluder_groups: Vec::new(),
        generation: 1,
        luminaire_power: vec![luxnode::control::rating::RatedPower::assumed(3000.0); 2],
        point_names: Vec::new(),
    };
    let Ok(mut node) = Node::new(model, NodeOptions::default()) else {
        panic!("the node refused a valid model");
    };
    let mut reply = [0u8; MAX_RTU_FRAME];
    let counters = RtuCounters::default();
    let source = Source::Rtu("fuzz".into());
    for chunk in data.chunks(MAX_RTU_FRAME + 1) {
        if let Some(n) = handle_frame(&mut node, &source, 7, chunk, &counters, &mut reply) {
            assert!((4..=MAX_RTU_FRAME).contains(&n), "reply length {n}");
            assert!(decode_rtu(&reply[..n]).is_ok(), "a reply with a bad CRC");
        }
    }
    for (_, lux, _) in node.desks() {
        assert!(
            lux.is_nan() || (0.0..=1e6).contains(&lux),
            "published {lux}"
        );
    }
}

/// EULUMDAT text.
pub fn eulumdat(data: &[u8]) {
    if let Ok(d) = luxnode::photometry::IntensityDistribution::from_ldt_str(&text(data)) {
        let f = d.flux_lm();
        assert!(f.is_finite() && f >= 0.0, "flux {f}");
    }
}

/// IES LM-63 text.
pub fn ies(data: &[u8]) {
    if let Ok(d) = luxnode::photometry::IntensityDistribution::from_ies_str(&text(data)) {
        let f = d.flux_lm();
        assert!(f.is_finite() && f >= 0.0, "flux {f}");
    }
}

/// An OBJ file and its MTL (the input split at its first NUL byte), through the loader.
pub fn obj_mtl(data: &[u8]) {
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(k) => (&data[..k], &data[k + 1..]),
        None => (data, &b""[..]),
    };
    let d = scratch().join("obj");
    let _ = std::fs::create_dir_all(&d);
    let mut obj = obj.to_vec();
    if !obj.starts_with(b"mtllib") {
        let mut with_lib = b"mtllib scene.mtl\n".to_vec();
        with_lib.extend_from_slice(&obj);
        obj = with_lib;
    }
    if std::fs::write(d.join("scene.obj"), &obj).is_err()
        || std::fs::write(d.join("scene.mtl"), mtl).is_err()
    {
        return;
    }
    if let Ok((mesh, _)) = luxnode::scene::load_obj(&d.join("scene.obj"), 1.0) {
        for p in &mesh.positions_m {
            assert!(p.is_finite(), "vertex {p}");
        }
    }
}

/// The scene's JSON files: the first byte picks luminaires.json, sensors.json, desks.json or
/// camera.json; the rest is the file.
pub fn scene_json(data: &[u8]) {
    use luxnode::scene::{
        LoadOptions, load_camera_file, load_desks_file, load_luminaires_file, load_sensors_file,
    };
    let Some((&which, body)) = data.split_first() else {
        return;
    };
    let d = scratch().join("scene");
    let _ = std::fs::create_dir_all(&d);
    let o = LoadOptions::default();
    let name = [
        "luminaires.json",
        "sensors.json",
        "desks.json",
        "camera.json",
    ][usize::from(which % 4)];
    let p = d.join(name);
    if std::fs::write(&p, body).is_err() {
        return;
    }
    match which % 4 {
        0 => {
            let _ = load_luminaires_file(&p, &o);
        }
        1 => {
            let _ = load_sensors_file(&p, &o);
        }
        2 => {
            let _ = load_desks_file(&p, &o);
        }
        _ => {
            if let Ok(c) = load_camera_file(&p) {
                assert!(c.fx.is_finite() && c.fx > 0.0);
            }
        }
    }
}

/// A capture's PNG frames: the input is both the depth frame and the luminance frame.
pub fn capture_png(data: &[u8]) {
    let d = scratch().join("capture");
    let _ = std::fs::create_dir_all(&d);
    let camera = r#"{"position": [1.0, 1.0, 2.5], "R_world_from_camera": [[0,1,0],[1,0,0],[0,0,-1]],
        "width": 4, "height": 4, "fx": 4.0, "fy": 4.0, "cx": 1.5, "cy": 1.5,
        "luminance_cd_m2_per_unit": 0.02}"#;
    if std::fs::write(d.join("camera.json"), camera).is_err()
        || std::fs::write(d.join("depth_000.png"), data).is_err()
        || std::fs::write(d.join("luminance_L1.png"), data).is_err()
    {
        return;
    }
    let _ = luxnode::camera::capture::Capture::load(&d, &[1]);
}

/// A board file.
pub fn board_toml(data: &[u8]) {
    let _ = luxnode::board::Board::parse(&text(data), Path::new("/etc/luxnode/board.toml"));
}

/// The input as an image payload with the header's CRCs fixed up (so the postcard decoder and
/// the validation are reached, not just the CRC check), through the whole load path: parse,
/// the A/B slots of a flash, the register map.
pub fn flash_image(data: &[u8]) {
    use luxnode::node::{Node, NodeModel, NodeOptions};
    use luxnode::store::devices::MemFlash;
    use luxnode::store::file::read_bootable;
    use luxnode::store::slots::Slots;
    use luxnode::store::{FORMAT_VERSION, Header, Image, crc32};
    let (generation, precision, payload) = match data {
        [g, p, rest @ ..] => (u64::from(*g), *p % 6, rest),
        _ => (1, 3, data),
    };
    let h = Header {
        format_version: FORMAT_VERSION,
        generation,
        payload_len: payload.len() as u32,
        payload_crc32: crc32(payload),
        precision,
    };
    let mut image = h.emit().to_vec();
    image.extend_from_slice(payload);
    if let Ok(img) = Image::parse(&image) {
        let model = NodeModel::from_image(&img, generation);
        if let Ok(mut node) = Node::new(
            model,
            NodeOptions {
                initial_arc: Some(254),
                ..NodeOptions::default()
            },
        ) {
            let _ = node.set_arc_levels(&vec![200; img.luminaires()]);
            for (_, lux, _) in node.desks() {
                assert!(
                    lux.is_nan() || (0.0..=1e6).contains(&lux),
                    "published {lux}"
                );
            }
        }
    }
    let mut slots = Slots::new(MemFlash::new(2 * (image.len() + 4096)));
    let _ = slots.write_image(&image);
    let _ = read_bootable(&mut slots, |img, g| {
        Node::new(NodeModel::from_image(img, g), NodeOptions::default())
            .map(|_| ())
            .map_err(|e| e.to_string())
    });
}

/// The camera module's EEPROM record (both layout versions): a record that decodes is valid,
/// and encodes back to the same record (version 2).
pub fn calibration_record(data: &[u8]) {
    use luxnode::peripherals::calibration::{CameraCalibration, RECORD_LEN};
    let mut b = [0xFFu8; RECORD_LEN];
    let n = data.len().min(RECORD_LEN);
    b[..n].copy_from_slice(&data[..n]);
    if let Ok((c, g)) = CameraCalibration::decode(&b) {
        assert!(c.validate().is_ok(), "{c:?}");
        assert_eq!(CameraCalibration::decode(&c.encode(g)), Ok((c, g)));
    }
}

/// The demo office's image without its live section, and that section's body (the seed).
fn live_base() -> &'static (Vec<u8>, Vec<u8>) {
    static BASE: OnceLock<(Vec<u8>, Vec<u8>)> = OnceLock::new();
    BASE.get_or_init(|| {
        use luxnode::image_build::{ImageOptions, build_image, encode_live};
        use luxnode::live_section::{SectionOptions, from_model};
        let world = luxnode::sim::camera::SimWorld::demo_office().expect("demo office");
        let scene = luxnode::sim::demo::demo_office();
        let image = build_image(world.model(), &ImageOptions::default()).expect("image");
        // a coarse sample grid keeps the seed small (a few kB) for the fuzzer
        let o = SectionOptions {
            budget_bytes: 12 * 1024,
            ..SectionOptions::default()
        };
        let (section, _) = from_model(&scene, world.model(), &o).expect("section");
        (image, encode_live(&section).expect("live body"))
    })
}

/// Builds `live_section`'s base image (the demo office's world: seconds in a sanitised build)
/// before fuzzing starts, so libFuzzer's per-input timeout does not count it (the fuzz target's
/// `init`; a loaded machine took the first input past the 10 s limit).
pub fn live_section_init() {
    live_base();
}

/// A live-light section body after a valid image (framed, so it reaches the decoder): a section
/// that parses gives an estimator, which answers a frame of its camera's size (when that is
/// at most 2^18 pixels) with finite values only, never a panic.
pub fn live_section(data: &[u8]) {
    use luxnode::live::{Live, LiveFrame, LiveModel, LiveSettings};
    use luxnode::store::{Image, LIVE_MAGIC, frame_section};
    let (base, _) = live_base();
    let Some(framed) = frame_section(LIVE_MAGIC, luxnode::store::live::LIVE_VERSION, data) else {
        return;
    };
    let mut bytes = base.clone();
    bytes.extend_from_slice(&framed);
    let Ok(image) = Image::parse(&bytes) else {
        return;
    };
    let Ok(model) = LiveModel::new(&image) else {
        return;
    };
    let (w, h) = model.frame_size();
    let Ok(mut live) = Live::new(model, LiveSettings::default()) else {
        return;
    };
    let pixels = (w as usize) * (h as usize);
    if pixels > 1 << 18 {
        return;
    }
    let luminance: Vec<u16> = (0..pixels)
        .map(|i| u16::from(data.get(i % data.len().max(1)).copied().unwrap_or(0)) * 97)
        .collect();
    let depth: Vec<u16> = (0..pixels).map(|i| 1500 + (i % 1000) as u16).collect();
    let levels = vec![1.0; image.luminaires()];
    for (k, depth) in [None, Some(&depth[..])].into_iter().enumerate() {
        let frame = LiveFrame {
            width: w,
            height: h,
            luminance: &luminance,
            cd_m2_per_unit: 0.02,
            depth_mm: depth,
            taken_s: k as f64,
        };
        if let Ok(desks) = live.update(&frame, &levels, k as f64) {
            for d in desks {
                let v = [d.total_lx, d.artificial_lx, d.daylight_lx, d.uncertainty_lx];
                assert!(v.iter().all(|x| x.is_finite()), "{d:?}");
            }
        }
    }
}

/// The seed of `live_section`: the demo office's own live section body.
pub fn live_section_seed() -> Vec<u8> {
    live_base().1.clone()
}
