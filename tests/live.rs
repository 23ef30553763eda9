//! Live light on the simulated demo office: commissioning in daylight (the all-off frame),
//! measured and inferred desk lux against the world's own truth, a person over a desk, an ageing
//! luminaire, a moved desk, and bad frames. The accuracy yardstick against Radiance is the bench
//! (scenes/office_a_daylight, bench/radiance/daylight.py); here the world is the project's own engine, so
//! these tests check the method's behaviour and its consistency.

use std::sync::OnceLock;

use luxnode::camera::{DepthCamera, LightControl, LuminanceCamera};
use luxnode::image_build::with_live;
use luxnode::live::{self, Live, LiveFrame, LiveModel, LiveSettings, Source, Verdict, flags};
use luxnode::sim::camera::{SimDepthOptions, SimLuminanceOptions, SimWorld, WorldExtras};
use luxnode::sim::scenario::{Event, EventKind, Scenario};
use luxnode::store::live::{LIVE_VERSION, LIVE_VERSION_WITHOUT_GROUPS, LIVE_VERSION_WITHOUT_PARTS};
use luxnode::store::{Image, sensor_flags};

struct Rig {
    world: SimWorld,
    image: Vec<u8>,
    section: luxnode::image_build::LiveSectionData,
    flags: Vec<u8>,
}

/// The demo office commissioned from its simulated cameras with daylight in the room (window
/// exitance 1500 lm/m² during the whole capture).
fn rig() -> &'static Rig {
    static RIG: OnceLock<Rig> = OnceLock::new();
    RIG.get_or_init(|| {
        let world = SimWorld::demo_office().unwrap();
        world.set_extras(WorldExtras {
            window_exitance_lm_m2: 1500.0,
            ..WorldExtras::default()
        });
        let c = luxnode::bench::live::commission_in_daylight(&world, true).unwrap();
        let image = c.image;
        assert!(Image::parse(&image).unwrap().geometry_bytes().is_some());
        Rig {
            world,
            image,
            section: c.section,
            flags: c.sensor_flags,
        }
    })
}

fn live_state() -> Live {
    let image = Image::parse(&rig().image).unwrap();
    Live::new(LiveModel::new(&image).unwrap(), LiveSettings::default()).unwrap()
}

/// One frame of the world at these levels and extras: (luminance, gain, depth).
fn frame(levels: &[f64], extras: &WorldExtras) -> (Vec<u16>, f64, Vec<u16>) {
    let w = &rig().world;
    w.set_extras(extras.clone());
    let mut lights = w.clone();
    lights.set_levels(levels).unwrap();
    let mut lum = w.luminance_camera(SimLuminanceOptions::default()).unwrap();
    let mut depth = w.depth_camera(SimDepthOptions::default()).unwrap();
    let l = lum.capture_luminance().unwrap();
    let d = depth.capture_depth().unwrap();
    (l.data, l.cd_m2_per_unit, d.depth_mm)
}

fn update<'a>(
    live: &'a mut Live,
    f: &(Vec<u16>, f64, Vec<u16>),
    levels: &[f64],
    t: f64,
) -> &'a [live::DeskLive] {
    let (w, h) = live.model().frame_size();
    let frame = LiveFrame {
        width: w,
        height: h,
        luminance: &f.0,
        cd_m2_per_unit: f.1,
        depth_mm: Some(&f.2),
        taken_s: t,
    };
    live.update(&frame, levels, t).unwrap();
    // every frame of the simulated room is a view of this room, whatever its daylight, people
    // and dimming: the checks against foreign frames never reject one
    let verdict = live.report().map(|r| r.verdict);
    let agreement = live.edge_agreement(&frame);
    eprintln!("frame at {t} s: {verdict:?}, edges agree {agreement:?}");
    assert!(
        !matches!(verdict, Some(Verdict::NotThisRoom | Verdict::Underexposed)),
        "a frame of this room rejected: {verdict:?}, edges agree {agreement:?}"
    );
    live.desks()
}

/// `old` with `body` framed as a live section of this version (older layouts, byte for byte).
fn live_section_as(
    old: &[u8],
    version: u16,
    body: &[u8],
) -> Result<Vec<u8>, luxnode::image_build::BuildError> {
    luxnode::image_build::with_section(old, luxnode::store::LIVE_MAGIC, version, Some(body))
}

#[test]
fn the_image_keeps_its_live_section_and_old_images_still_parse() {
    let bytes = &rig().image;
    let image = Image::parse(bytes).unwrap();
    let live = image.live.as_ref().expect("a live section");
    assert!(live.samples() > 5000, "{}", live.samples());
    // docs/live.md: the run-time model of the demo office takes 6.6 MB (19577 samples, 2051
    // patches), and the section 0.44 MB of flash
    let model = LiveModel::new(&image).unwrap();
    assert!(
        model.memory_bytes() < 13_000_000,
        "{} B",
        model.memory_bytes()
    );
    let section = bytes.len() - with_live(bytes, None).unwrap().len();
    assert!(section < 900_000, "{section} B");
    // the geometry section (reports) is kept beside it, byte for byte
    let geometry = image.geometry_bytes().expect("a geometry section");
    // removing the section gives an image every reader parses, with the same payload
    let old = with_live(bytes, None).unwrap();
    let o = Image::parse(&old).unwrap();
    assert!(o.live.is_none());
    assert_eq!(o.payload, image.payload);
    assert_eq!(o.geometry_bytes(), Some(geometry));
    // and put back, it is found again after the geometry section
    let again = with_live(&old, Some(&rig().section)).unwrap();
    assert_eq!(&again, bytes);
    assert!(old.len() < bytes.len());
    assert!(matches!(
        LiveModel::new(&o),
        Err(luxnode::live::LiveError::NoSection)
    ));
    // the section states each desk's model uncertainty per luminaire (per dimming state)
    assert!(live.has_uncertainty_parts());
    let all_on = vec![1.0; image.luminaires()];
    for k in 0..image.sensors() {
        let stated = image.model_rel_uncertainty(k).unwrap();
        let at = luxnode::runtime::model_rel_uncertainty_at(&image, k, &all_on).unwrap();
        assert!(
            (at - stated).abs() <= 0.01 * stated + 2e-4,
            "{at} vs {stated}"
        );
    }
    // every desk's occluder groups travel with the parts (version 4): here every luminaire behind
    // the same back edge, group 2
    let (l_n, s_n) = (image.luminaires(), image.sensors());
    let mut grouped = rig().section.clone();
    grouped.model_occluder_groups = vec![vec![2; l_n]; s_n];
    let g_img = with_live(&old, Some(&grouped)).unwrap();
    let gi = Image::parse(&g_img).unwrap();
    let gl = gi.live.as_ref().expect("a version-4 live section");
    assert_eq!(gl.occluder_group(s_n - 1, l_n - 1, l_n), 2);
    // the rig's own groups read back as built (stop 50: its free-standing desks out of view
    // have both long sides as back edges, so a monitor there may shade a group)
    let built = &rig().section.model_occluder_groups;
    assert!(
        (0..s_n).all(|k| (0..l_n).all(|j| live.occluder_group(k, j, l_n) == built[k][j])),
        "{built:?}"
    );
    // a group beyond the format's is refused when built, and when read
    let beyond = luxnode::store::live::OCCLUDER_GROUPS + 1;
    grouped.model_occluder_groups[0][0] = beyond;
    assert!(with_live(&old, Some(&grouped)).is_err());
    let mut v3 = rig().section.clone();
    v3.model_occluder_groups.clear();
    let mut body = luxnode::image_build::encode_live(&v3).unwrap();
    assert_eq!(
        body.pop(),
        Some(0),
        "no groups: an empty byte string, one zero byte"
    );
    let mut five = body.clone();
    five.extend_from_slice(&[(s_n * l_n) as u8]);
    five.resize(five.len() + s_n * l_n, beyond);
    assert!(s_n * l_n < 128, "one postcard length byte");
    assert!(live_section_as(&old, LIVE_VERSION, &five).is_err());
    // a version-3 section (before the groups: the same body without its last byte string)
    // still parses, every luminaire alone
    assert_eq!(body[0], 4, "the body's first field is its version");
    body[0] = 3;
    let three = live_section_as(&old, LIVE_VERSION_WITHOUT_GROUPS, &body).unwrap();
    let i3 = Image::parse(&three).unwrap();
    let l3 = i3.live.as_ref().expect("a version-3 live section is read");
    assert!(l3.has_uncertainty_parts());
    assert_eq!(l3.occluder_group(0, 0, l_n), 0);
    // a desk with no group states the same; one with a group states at most the version-4
    // value (the largest luminaire alone, not the group's sum; where the groups widened the
    // all-on statement, the version-3 reading falls back to it, stored in steps of 1e-4)
    for (k, groups) in built.iter().enumerate().take(s_n) {
        let (v3, v4) = (
            luxnode::runtime::model_rel_uncertainty_at(&i3, k, &all_on).expect("v3"),
            luxnode::runtime::model_rel_uncertainty_at(&image, k, &all_on).expect("v4"),
        );
        if groups.iter().all(|g| *g == 0) {
            assert_eq!(v3, v4, "sensor {k}");
        } else {
            assert!(v3 <= v4 + 1e-4, "sensor {k}: {v3} > {v4}");
        }
    }
    // a version-2 section (before the parts: the same body without its last two byte strings,
    // here empty) still parses, and states the all-on uncertainty for every state
    let mut v2 = rig().section.clone();
    v2.model_uncertainty_parts_lx.clear();
    v2.model_occluder_groups.clear();
    let mut body = luxnode::image_build::encode_live(&v2).unwrap();
    assert_eq!(body.pop(), Some(0), "an empty byte string is one zero byte");
    assert_eq!(body.pop(), Some(0));
    // a version-4 section without its parts' and groups' byte strings is not a section
    assert!(live_section_as(&old, LIVE_VERSION, &body).is_err());
    body[0] = 2;
    let two = live_section_as(&old, LIVE_VERSION_WITHOUT_PARTS, &body).unwrap();
    let i2 = Image::parse(&two).unwrap();
    let l2 = i2.live.as_ref().expect("a version-2 live section is read");
    assert!(!l2.has_uncertainty_parts());
    let one = (0..image.luminaires())
        .map(|j| f64::from(u8::from(j == 0)))
        .collect::<Vec<_>>();
    assert_eq!(
        luxnode::runtime::model_rel_uncertainty_at(&i2, 0, &one),
        i2.model_rel_uncertainty(0)
    );
    // a flipped bit in the section fails the payload CRC like any other byte
    let mut bad = bytes.clone();
    let k = bad.len() - 100;
    bad[k] ^= 1;
    assert!(Image::parse(&bad).is_err());
}

#[test]
fn daylight_and_dimming_measured_and_inferred() {
    let mut live = live_state();
    let flags_img = &rig().flags;
    let (mut worst_in, mut sum_in, mut n_in) = (0.0f64, 0.0f64, 0usize);
    for (w, levels) in [
        (0.0, vec![1.0; 6]),
        (1500.0, vec![1.0; 6]),
        (3000.0, vec![0.5, 0.2, 1.0, 0.0, 0.7, 0.3]),
        (800.0, vec![0.0; 6]),
    ] {
        let extras = WorldExtras {
            window_exitance_lm_m2: w,
            ..WorldExtras::default()
        };
        let f = frame(&levels, &extras);
        let truth = rig().world.sensor_truth_lx(&levels, &extras);
        let no_day = rig()
            .world
            .sensor_truth_lx(&levels, &WorldExtras::default());
        let desks = update(&mut live, &f, &levels, 0.0).to_vec();
        for (k, d) in desks.iter().enumerate() {
            assert!(d.total_lx.is_finite() && d.daylight_lx >= 0.0);
            assert!((d.total_lx - d.artificial_lx - d.daylight_lx).abs() < 1e-9);
            let in_view = flags_img[k] & sensor_flags::OUT_OF_VIEW == 0;
            let err = (d.total_lx - truth[k]).abs() / truth[k].max(50.0);
            let day_err = (d.daylight_lx - (truth[k] - no_day[k])).abs() / truth[k].max(50.0);
            eprintln!(
                "W {w:6.0} desk {} {:9} total {:7.1} truth {:7.1} ({:+.1} %) daylight {:6.1} truth {:6.1} unc {:5.1} flags {}",
                d.id,
                d.source.name(),
                d.total_lx,
                truth[k],
                100.0 * (d.total_lx - truth[k]) / truth[k].max(1.0),
                d.daylight_lx,
                truth[k] - no_day[k],
                d.uncertainty_lx,
                flags::describe(d.flags)
            );
            if in_view {
                assert_eq!(d.source, Source::Measured);
                worst_in = worst_in.max(err);
                sum_in += err;
                n_in += 1;
            } else {
                assert_eq!(d.source, Source::Inferred);
            }
            assert!(day_err < 0.15, "desk {} daylight off by {day_err}", d.id);
        }
    }
    // The simulated world renders the window's light constant over a patch (its incident
    // daylight) while its truth at a sensor is the sensor's own gather row: a desk whose patch is
    // unevenly lit by the window reads its patch's mean. Measured: mean 3.0 %, worst 13.7 % (a
    // desk at 52 lx in daylight alone). The yardstick is Radiance.
    let mean_in = sum_in / n_in.max(1) as f64;
    eprintln!(
        "in view: {n_in} readings, mean {:.2} %, worst {:.2} %",
        100.0 * mean_in,
        100.0 * worst_in
    );
    assert!(n_in >= 8, "{n_in} in-view readings");
    assert!(mean_in < 0.05, "mean in-view error {mean_in}");
    assert!(worst_in < 0.2, "worst in-view error {worst_in}");
}

/// The node's live task, one period at a time: the live registers, the daylight handed to the
/// control loop and a camera that stops answering.
#[test]
fn the_node_publishes_live_registers_and_feeds_the_control_loop() {
    use luxnode::daemon::live::{CapturedFrame, StepState, estimator, step};
    use luxnode::modbus::regmap::{NOT_AVAILABLE_U16, Space, addr, live_flags, live_status};
    use luxnode::node::{Node, NodeModel, NodeOptions};
    let image = Image::parse(&rig().image).unwrap();
    let mut node = Node::new(NodeModel::from_image(&image, 1), NodeOptions::default()).unwrap();
    let n = image.luminaires();
    let desks = image.sensors() as u16;
    let read = |node: &Node, a: u16| node.map().read(Space::Input, a);
    // live light off: the blocks are in the map and read "not available"
    assert_eq!(read(&node, addr::LIVE_TOTAL_U16), Some(NOT_AVAILABLE_U16));
    assert_eq!(read(&node, addr::LIVE_TOTAL_U16 + desks), None);
    assert_eq!(read(&node, addr::AGEING), Some(1000));
    let mut live = estimator(&image, &LiveSettings::default()).unwrap();
    let mut state = StepState::default();
    let levels = vec![0.6; n];
    node.set_levels(&levels.iter().map(|&x| Some(x)).collect::<Vec<_>>())
        .unwrap();
    let levels = node.levels().to_vec();
    let extras = WorldExtras {
        window_exitance_lm_m2: 2000.0,
        ..WorldExtras::default()
    };
    let f = frame(&levels, &extras);
    let (w, h) = live.model().frame_size();
    let captured = CapturedFrame {
        width: w,
        height: h,
        luminance: f.0.clone(),
        cd_m2_per_unit: f.1,
        depth_mm: Some(f.2.clone()),
        levels: levels.clone(),
    };
    let status = step(
        &mut live,
        &mut state,
        Ok(captured.clone()),
        0.0,
        &mut node,
        0.5,
    );
    assert_eq!(status & live_status::ON, live_status::ON);
    assert_eq!(status & live_status::FRAME_REJECTED, 0);
    let truth = rig().world.sensor_truth_lx(&levels, &extras);
    let no_day = rig()
        .world
        .sensor_truth_lx(&levels, &WorldExtras::default());
    for k in 0..desks {
        let d = live.desks()[usize::from(k)];
        // u16 block: the rounded total; split adds up
        assert_eq!(
            read(&node, addr::LIVE_TOTAL_U16 + k),
            Some(d.total_lx.round() as u16)
        );
        assert_eq!(
            read(&node, addr::LIVE_DAYLIGHT_U16 + k),
            Some(d.daylight_lx.round() as u16)
        );
        let hi = read(&node, addr::LIVE_TOTAL_FLOAT + 2 * k).unwrap();
        let lo = read(&node, addr::LIVE_TOTAL_FLOAT + 2 * k + 1).unwrap();
        let v = f32::from_bits((u32::from(hi) << 16) | u32::from(lo));
        assert!((f64::from(v) - d.total_lx).abs() < 1e-3 * d.total_lx.max(1.0));
        assert_eq!(read(&node, addr::LIVE_SOURCE + k), Some(d.source as u16));
        // the daylight against the world's own (see daylight_and_dimming_...: 15 %)
        let day = truth[usize::from(k)] - no_day[usize::from(k)];
        assert!(
            (d.daylight_lx - day).abs() < 0.15 * truth[usize::from(k)].max(50.0),
            "desk {k}: daylight {} vs {day}",
            d.daylight_lx
        );
    }
    // the control loop gets the daylight while it is fresh
    let fresh = node
        .fresh_daylight()
        .expect("daylight for the control loop");
    assert_eq!(fresh.len(), usize::from(desks));
    for (a, d) in fresh.iter().zip(live.desks()) {
        assert_eq!(*a, d.daylight_lx);
    }
    // the BMS dims while a frame is being taken: that frame is not used (it shows the old
    // state), the desks keep their daylight at the new state, flagged held
    let daylight: Vec<f64> = live.desks().iter().map(|d| d.daylight_lx).collect();
    node.set_levels(&vec![Some(0.3); n]).unwrap();
    let st = step(
        &mut live,
        &mut state,
        Ok(captured.clone()),
        5.0,
        &mut node,
        5.5,
    );
    assert_eq!(st & live_status::FRAME_REJECTED, 0);
    for (k, d) in live.desks().iter().enumerate() {
        assert_ne!(d.flags & live_flags::HELD, 0, "desk {k}");
        assert_eq!(d.daylight_lx, daylight[k], "desk {k}");
    }
    node.set_levels(&levels.iter().map(|&x| Some(x)).collect::<Vec<_>>())
        .unwrap();
    // (the same frame again at its own levels: the state of the first step)
    step(
        &mut live,
        &mut state,
        Ok(captured.clone()),
        0.0,
        &mut node,
        0.5,
    );
    // the camera stops answering: values held, then stale, and the status says so
    let before: Vec<f64> = live.desks().iter().map(|d| d.total_lx).collect();
    let st = step(
        &mut live,
        &mut state,
        Err("timeout".into()),
        10.0,
        &mut node,
        10.0,
    );
    assert_ne!(st & live_status::FRAME_REJECTED, 0);
    assert_eq!(st & live_status::CAMERA_STALE, 0);
    for (k, d) in live.desks().iter().enumerate() {
        // the held daylight with the model's artificial part: the last good total, unless the
        // luminaires read below the model there (a negative residual is not held)
        assert!(
            (d.total_lx - before[k]).abs() <= 0.05 * before[k],
            "desk {k}: held {} vs {}",
            d.total_lx,
            before[k]
        );
        assert_ne!(d.flags & live_flags::HELD, 0);
    }
    let st = step(
        &mut live,
        &mut state,
        Err("timeout".into()),
        60.0,
        &mut node,
        60.0,
    );
    assert_ne!(st & live_status::CAMERA_STALE, 0);
    assert_eq!(read(&node, addr::LIVE_STATUS), Some(st));
    assert!(
        live.desks()
            .iter()
            .all(|d| d.flags & live_flags::STALE != 0 && d.total_lx.is_finite())
    );
    assert_eq!(read(&node, addr::LIVE_LAST_FRAME_AGE), Some(60));
}

/// The first desk the camera sees (its index, its id).
fn desk_in_view() -> (usize, u32) {
    let image = Image::parse(&rig().image).unwrap();
    let k = (0..rig().flags.len())
        .find(|&k| rig().flags[k] & sensor_flags::OUT_OF_VIEW == 0)
        .expect("a desk in view");
    (k, image.sensor_id(k))
}

/// The world's extras with these scenario events in force, over this much window exitance.
fn with_events(kinds: Vec<EventKind>, window_lm_m2: f64) -> WorldExtras {
    let events = kinds
        .into_iter()
        .map(|kind| Event { at_s: 0.0, kind })
        .collect();
    let scenario = Scenario { day: None, events };
    let mut x = scenario.extras_at(1.0, rig().world.scene());
    x.window_exitance_lm_m2 = window_lm_m2;
    x
}

/// Issue 12: "a person over a desk: flagged in the first frame, value held". The person is the
/// scenario's (a 0.5 × 0.4 m box over the desk's sensor, up to 1.4 m).
#[test]
fn a_person_over_a_desk_is_flagged_in_the_first_frame_and_the_value_held() {
    let (k, id) = desk_in_view();
    let levels = vec![0.8; 6];
    let person = with_events(vec![EventKind::Person { desk: id }], 1500.0);
    let clear = with_events(Vec::new(), 1500.0);
    let mut live = live_state();
    let before = update(&mut live, &frame(&levels, &clear), &levels, 0.0).to_vec();
    assert_eq!(before[k].source, Source::Measured);
    assert!(before[k].daylight_lx > 1.0, "{:?}", before[k]);
    let covered = frame(&levels, &person);
    let after = update(&mut live, &covered, &levels, 10.0).to_vec();
    let d = after[k];
    assert_ne!(d.flags & flags::OCCLUDED, 0, "{}", flags::describe(d.flags));
    assert_ne!(d.flags & flags::HELD, 0);
    // held: the last good daylight on the model's light at the same levels, so the same total
    assert!(
        (d.total_lx - before[k].total_lx).abs() < 1e-9 * before[k].total_lx,
        "{} vs {}",
        d.total_lx,
        before[k].total_lx
    );
    assert_eq!(d.daylight_lx, before[k].daylight_lx);
    assert_eq!(d.source, Source::Measured);
    assert_eq!(d.frame_age_s, 10.0);
    // nobody else is covered, and they stay measured
    for (j, o) in after.iter().enumerate().filter(|(j, _)| *j != k) {
        assert_eq!(o.flags & (flags::OCCLUDED | flags::HELD), 0, "desk {j}");
        assert_eq!(o.source, before[j].source);
    }
    // the person leaves: measured again, within 1 % of before
    let back = update(&mut live, &frame(&levels, &clear), &levels, 20.0).to_vec();
    assert_eq!(back[k].flags & (flags::OCCLUDED | flags::HELD), 0);
    assert!((back[k].total_lx - before[k].total_lx).abs() < 0.01 * before[k].total_lx);
    // a desk covered in the node's very first frame has nothing to hold: inferred, flagged
    let mut fresh = live_state();
    let first = update(&mut fresh, &covered, &levels, 0.0).to_vec();
    assert_eq!(first[k].source, Source::Inferred);
    assert_ne!(first[k].flags & flags::OCCLUDED, 0);
    assert!(first[k].total_lx.is_finite() && first[k].total_lx > 0.0);
    // a person who stays is not a change of the room
    let report = fresh.report().unwrap();
    assert!(!report.recommission && report.samples_occluded > 0);
}

/// Issue 12: "a luminaire at 80 % of its flux: ageing factor within 3 % after a night". A night
/// of 20 frames at changing dimming states (the node's default `ageing_min_frames`), then the
/// first daylight frame commits the factors.
#[test]
fn an_ageing_luminaire_is_found_within_3_percent_after_a_night() {
    let n = rig().world.luminaire_ids().len();
    let aged = 2;
    let mut ageing = vec![1.0; n];
    ageing[aged] = 0.8;
    let night = WorldExtras {
        ageing: ageing.clone(),
        ..WorldExtras::default()
    };
    let mut live = live_state();
    let min_frames = live.settings().ageing_min_frames;
    for t in 0..min_frames {
        // every luminaire somewhere between 30 % and 100 %, a different mix each frame
        let levels: Vec<f64> = (0..n)
            .map(|j| 0.3 + 0.7 * (((t as usize + 1) * (j + 3) * 7) % 11) as f64 / 10.0)
            .collect();
        update(&mut live, &frame(&levels, &night), &levels, f64::from(t));
        let r = live.report().unwrap();
        assert!(r.night, "frame {t} at night was not taken for night");
        assert!(!r.ageing_updated, "updated before the night was over");
    }
    assert!(live.ageing().iter().all(|&a| a == 1.0));
    // morning
    let levels = vec![1.0; n];
    let day = WorldExtras {
        window_exitance_lm_m2: 1500.0,
        ageing: ageing.clone(),
        ..WorldExtras::default()
    };
    let desks = update(&mut live, &frame(&levels, &day), &levels, 100.0).to_vec();
    let r = live.report().unwrap();
    assert!(!r.night && r.ageing_updated, "{r:?}");
    // measured: 0.792 for the aged luminaire (−1.0 %), the others within 0.3 % of 1
    eprintln!("ageing factors after the night: {:?}", live.ageing());
    for (j, (&a, &truth)) in live.ageing().iter().zip(&ageing).enumerate() {
        assert!(
            (a - truth).abs() < 0.03 * truth,
            "luminaire {j}: ageing {a:.4}, truth {truth}"
        );
    }
    // the factor is in the model from this frame on: the desks the aged luminaire lights most
    // are flagged, and the in-view totals still match the world
    let image = Image::parse(&rig().image).unwrap();
    let truth = rig().world.sensor_truth_lx(&levels, &day);
    let mut flagged = 0;
    for (k, d) in desks.iter().enumerate() {
        let row: Vec<f64> = (0..n).map(|j| image.response_lx(k, j)).collect();
        let share = row[aged] / row.iter().sum::<f64>();
        if share >= live.settings().ageing_flag_share {
            assert_ne!(d.flags & flags::AGEING, 0, "desk {k}: share {share}");
            flagged += 1;
        } else {
            assert_eq!(d.flags & flags::AGEING, 0, "desk {k}: share {share}");
        }
        if d.source == Source::Measured {
            let err = (d.total_lx - truth[k]).abs() / truth[k];
            assert!(err < 0.1, "desk {k}: {} vs {}", d.total_lx, truth[k]);
        }
    }
    assert!(flagged >= 1);
}

/// Issue 12: a desk moved for good advises recommissioning once the change has lasted
/// `geometry_frames` frames; the desk is flagged; a person does not do it.
#[test]
fn a_moved_desk_advises_recommissioning() {
    let (k, id) = desk_in_view();
    let levels = vec![1.0; 6];
    let moved = with_events(
        vec![EventKind::MoveDesk {
            desk: id,
            dx_m: 0.0,
            dy_m: 0.9,
        }],
        0.0,
    );
    let image = Image::parse(&rig().image).unwrap();
    let settings = LiveSettings {
        geometry_frames: 3,
        ..LiveSettings::default()
    };
    let mut live = Live::new(LiveModel::new(&image).unwrap(), settings).unwrap();
    let f = frame(&levels, &moved);
    for t in 0..3 {
        let desks = update(&mut live, &f, &levels, f64::from(t)).to_vec();
        let r = *live.report().unwrap();
        eprintln!(
            "frame {t}: changed {:.3}, occluded samples {}, desk flags {}",
            r.changed_fraction,
            r.samples_occluded,
            flags::describe(desks[k].flags)
        );
        assert_ne!(desks[k].flags & flags::OCCLUDED, 0);
        assert!(desks.iter().all(|d| d.total_lx.is_finite()));
        if t < 2 {
            assert!(!r.recommission && desks[k].flags & flags::GEOMETRY_CHANGED == 0);
        } else {
            assert!(r.recommission, "{r:?}");
            assert!(r.changed_fraction > live.settings().geometry_area_fraction);
            assert_ne!(desks[k].flags & flags::GEOMETRY_CHANGED, 0);
        }
    }
    // the desk is put back: the change is gone at the next frame (what is left are a few
    // hundred samples at depth edges, about 1 %, that the ToF noise takes past the tolerance)
    let desks = update(
        &mut live,
        &frame(&levels, &WorldExtras::default()),
        &levels,
        3.0,
    )
    .to_vec();
    let r = live.report().unwrap();
    assert!(!r.recommission && r.changed_fraction < 0.02, "{r:?}");
    assert_eq!(
        desks[k].flags & (flags::GEOMETRY_CHANGED | flags::OCCLUDED),
        0
    );
}

/// Issue 12, bad input: a dark, saturated, wrong-size or stale frame, a frame with a bad gain
/// or no depth at all gives a flag and the last good value: never a NaN, never a panic.
#[test]
fn bad_frames_are_flagged_and_the_last_good_values_held() {
    let levels = vec![0.7; 6];
    let day = with_events(Vec::new(), 1200.0);
    let mut live = live_state();
    let good = frame(&levels, &day);
    let before = update(&mut live, &good, &levels, 0.0).to_vec();
    let (w, h) = live.model().frame_size();
    let n = (w * h) as usize;
    let zeros = vec![0u16; n];
    let full = vec![u16::MAX; n];
    let short = vec![100u16; n - 1];
    let cases: Vec<(&str, LiveFrame<'_>, Verdict, u16)> = vec![
        (
            "lens covered (all 0)",
            lf(w, h, &zeros, good.1, Some(&good.2), 5.0),
            Verdict::Dark,
            flags::BAD_FRAME,
        ),
        (
            "overexposed (all 65535)",
            lf(w, h, &full, good.1, Some(&good.2), 5.0),
            Verdict::Saturated,
            flags::BAD_FRAME | flags::SATURATED,
        ),
        (
            "one pixel short",
            lf(w, h, &short, good.1, Some(&good.2), 5.0),
            Verdict::WrongSize,
            flags::BAD_FRAME,
        ),
        (
            "another camera's size",
            lf(w - 1, h, &good.0[..n - h as usize], good.1, None, 5.0),
            Verdict::WrongSize,
            flags::BAD_FRAME,
        ),
        (
            "depth of another size",
            lf(w, h, &good.0, good.1, Some(&short), 5.0),
            Verdict::WrongSize,
            flags::BAD_FRAME,
        ),
        (
            "taken a minute ago",
            lf(w, h, &good.0, good.1, Some(&good.2), -55.0),
            Verdict::Stale,
            flags::STALE,
        ),
        (
            "taken at NaN",
            lf(w, h, &good.0, good.1, Some(&good.2), f64::NAN),
            Verdict::Stale,
            flags::STALE,
        ),
    ];
    let mut all = cases;
    // frames that are not a view of this room (issue 34): their luminance is plausible, their
    // edges are not where the room's are, or their exposure is not what the gain says
    let rotated: Vec<u16> = good.0.iter().rev().copied().collect();
    let mirrored: Vec<u16> = good
        .0
        .chunks(w as usize)
        .flat_map(|row| row.iter().rev().copied())
        .collect();
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let noise: Vec<u16> = (0..n)
        .map(|_| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 48) as u16 % 60_000
        })
        .collect();
    let tenth: Vec<u16> = good.0.iter().map(|v| v / 10).collect();
    let foreign: [(&str, &[u16], Verdict); 6] = [
        ("rotated 180 degrees", &rotated, Verdict::NotThisRoom),
        ("mirrored", &mirrored, Verdict::NotThisRoom),
        ("noise", &noise, Verdict::NotThisRoom),
        (
            "the depth image as luminance",
            &good.2,
            Verdict::NotThisRoom,
        ),
        ("a tenth of the exposure", &tenth, Verdict::Underexposed),
        (
            "a tenth of the exposure, no depth",
            &tenth,
            Verdict::Underexposed,
        ),
    ];
    for (k, (what, lum, verdict)) in foreign.into_iter().enumerate() {
        let depth = (k < 5).then_some(&good.2[..]);
        all.push((
            what,
            lf(w, h, lum, good.1, depth, 5.0),
            verdict,
            flags::BAD_FRAME,
        ));
    }
    for gain in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        all.push((
            "a bad gain",
            lf(w, h, &good.0, gain, Some(&good.2), 5.0),
            Verdict::WrongSize,
            flags::BAD_FRAME,
        ));
    }
    for (what, f, verdict, flag) in all {
        let desks = live.update(&f, &levels, 5.0).unwrap().to_vec();
        assert_eq!(live.report().unwrap().verdict, verdict, "{what}");
        for (k, d) in desks.iter().enumerate() {
            assert_eq!(d.flags & flag, flag, "{what}: desk {k}");
            assert_ne!(d.flags & flags::HELD, 0, "{what}: desk {k}");
            assert!(
                (d.total_lx - before[k].total_lx).abs() <= 1e-9 * before[k].total_lx.max(1.0)
                    || before[k].daylight_lx == 0.0,
                "{what}: desk {k}: {} vs {}",
                d.total_lx,
                before[k].total_lx
            );
            assert!(d.total_lx.is_finite() && d.uncertainty_lx.is_finite());
            assert_eq!(d.frame_age_s, 5.0, "{what}");
        }
    }
    // a depth frame with no return anywhere (a dead ToF) is a frame without depth: the light
    // alone, flagged
    let no_return = vec![0u16; n];
    let desks = live
        .update(
            &lf(w, h, &good.0, good.1, Some(&no_return), 6.0),
            &levels,
            6.0,
        )
        .unwrap()
        .to_vec();
    assert_eq!(live.report().unwrap().verdict, Verdict::Ok);
    for (k, d) in desks.iter().enumerate() {
        assert_ne!(d.flags & flags::NO_DEPTH, 0, "desk {k}");
        assert!((d.total_lx - before[k].total_lx).abs() < 0.01 * before[k].total_lx);
    }
    // levels that are not levels are an error, not a value
    for bad in [vec![0.7; 5], vec![f64::NAN; 6], vec![1.5; 6]] {
        assert!(live.update(&good_frame(&good, w, h), &bad, 7.0).is_err());
        assert!(live.no_frame(&bad, 7.0).is_err());
    }
}

/// A frame of these parts.
fn lf<'a>(
    width: u32,
    height: u32,
    luminance: &'a [u16],
    cd_m2_per_unit: f64,
    depth_mm: Option<&'a [u16]>,
    taken_s: f64,
) -> LiveFrame<'a> {
    LiveFrame {
        width,
        height,
        luminance,
        cd_m2_per_unit,
        depth_mm,
        taken_s,
    }
}

fn good_frame(f: &(Vec<u16>, f64, Vec<u16>), w: u32, h: u32) -> LiveFrame<'_> {
    LiveFrame {
        width: w,
        height: h,
        luminance: &f.0,
        cd_m2_per_unit: f.1,
        depth_mm: Some(&f.2),
        taken_s: 7.0,
    }
}

/// `luxnode bench live` on the sim board (docs/live.md, "Cost"): it runs, prints its table, and
/// the memory it states is the documented one (7.8 MB held between frames, 401 kB of flash),
/// guarded at about twice. Its times are the bench's to print, not this test's to assert.
#[test]
fn the_live_bench_prints_its_table_and_the_documented_memory() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["bench", "live", "--frames", "12"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("| all | 12 |"), "{text}");
    assert!(text.contains("frame 320 x 240 px"), "{text}");
    let number_before = |unit: &str, after: &str| -> f64 {
        let line = text.lines().find(|l| l.starts_with("memory:")).unwrap();
        let rest = &line[line.find(after).unwrap() + after.len()..];
        let end = rest.find(unit).unwrap();
        rest[..end].trim().parse().unwrap()
    };
    let flash_kb = number_before("kB", "the live section");
    let held_mb = number_before("MB", "held between frames");
    assert!(flash_kb > 100.0 && flash_kb < 800.0, "{flash_kb} kB");
    assert!(held_mb > 2.0 && held_mb < 16.0, "{held_mb} MB");
    // a board without simulated cameras is refused with a clear message
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_luxnode"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["bench", "live", "--board", "boards/rpi4/board.toml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("simulated cameras"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Issue 28: a value the node cannot estimate is never published as a number, and no value is
/// stated exact.
#[test]
fn a_value_the_node_cannot_estimate_is_nan_and_flagged_never_zero_plus_minus_zero() {
    let mut live = live_state();
    let levels = vec![1.0; live.model().luminaires()];
    let f = frame(&levels, &WorldExtras::default());
    for d in update(&mut live, &f, &levels, 1.0) {
        assert!(
            d.total_lx > 0.0 && d.uncertainty_lx >= live::MIN_UNCERTAINTY_LX,
            "{d:?}"
        );
    }
    // a level that is not a number (a gateway's garbage) is refused before any work
    let mut bad = levels.clone();
    bad[0] = f64::NAN;
    let (w, h) = live.model().frame_size();
    let frame = good_frame(&f, w, h);
    assert!(live.update(&frame, &bad, 2.0).is_err());
    // a computation that gives no number publishes none: NaN, flagged, 0xFFFF in the registers
    assert_eq!(
        live::stated_uncertainty_lx(0.0, 0.0, 0.0),
        Some(live::MIN_UNCERTAINTY_LX)
    );
    assert_eq!(live::stated_uncertainty_lx(500.0, 20.0, 12.0), Some(12.0));
    for (a, d, u) in [
        (f64::NAN, 0.0, 1.0),
        (1.0, f64::INFINITY, 1.0),
        (1.0, 1.0, f64::NAN),
    ] {
        assert_eq!(live::stated_uncertainty_lx(a, d, u), None);
    }
    let d = live::DeskLive::not_estimated(7, live::Source::Inferred, flags::HELD, 3.0);
    assert!(d.total_lx.is_nan() && d.uncertainty_lx.is_nan());
    assert_eq!(d.flags, flags::HELD | flags::NOT_ESTIMATED);
    assert_eq!(
        luxnode::modbus::regmap::lux_u16(d.total_lx),
        luxnode::modbus::regmap::NOT_AVAILABLE_U16
    );
}

/// Issue 28's generalization bench under a clear sky: a desk in the sun saturates the camera
/// over its window, and the inferred daylight (the emitters', hundreds of lx) is far below what
/// a saturated pixel says at least (tens of klx). Published as that, sunlit desks read 75-95 %
/// low with an uncertainty that did not cover them; now the desk's daylight and total are not
/// available, flagged saturated, its artificial part kept, and neither a held value nor an
/// inferred one below the saturation level is published. The sun patch here is the person
/// box's footprint over the desk (found by its depth), saturated in a day frame whose depth is
/// the empty room's.
#[test]
fn a_desk_in_the_sun_that_saturates_the_camera_is_not_published_below_it() {
    let (k, id) = desk_in_view();
    let levels = vec![0.8; 6];
    let day = with_events(Vec::new(), 1500.0);
    let good = frame(&levels, &day);
    let person = frame(
        &levels,
        &with_events(vec![EventKind::Person { desk: id }], 1500.0),
    );
    let mut sun = good.clone();
    let mut patch = 0;
    for (i, (a, b)) in good.2.iter().zip(&person.2).enumerate() {
        if *a > 0 && (i32::from(*a) - i32::from(*b)).abs() > 50 {
            sun.0[i] = u16::MAX;
            patch += 1;
        }
    }
    let (w, h) = (good.0.len(), patch);
    assert!(h > 20 && h < w / 20, "{h} of {w} pixels in the sun");
    // a node that saw the desk before: the held daylight is below the floor, not held
    let mut seen = live_state();
    let before = update(&mut seen, &good, &levels, 0.0).to_vec();
    assert_eq!(before[k].source, Source::Measured);
    assert!(before[k].daylight_lx > 1.0 && before[k].daylight_lx < 2000.0);
    let mut fresh = live_state();
    for (live, t) in [(&mut seen, 10.0), (&mut fresh, 0.0)] {
        let after = update(live, &sun, &levels, t).to_vec();
        let d = after[k];
        assert_eq!(live.report().unwrap().verdict, Verdict::Ok);
        let want = flags::SATURATED | flags::DAYLIGHT_UNKNOWN | flags::NOT_ESTIMATED;
        assert_eq!(d.flags & want, want, "{}", flags::describe(d.flags));
        assert_eq!(d.flags & (flags::HELD | flags::OCCLUDED), 0);
        assert!(d.total_lx.is_nan() && d.daylight_lx.is_nan() && d.uncertainty_lx.is_nan());
        assert!(d.artificial_lx > 100.0, "{d:?}");
        assert_eq!(
            luxnode::modbus::regmap::lux_u16(d.total_lx),
            luxnode::modbus::regmap::NOT_AVAILABLE_U16
        );
        // the other desks are untouched by the patch
        for (j, o) in after.iter().enumerate().filter(|(j, _)| *j != k) {
            assert_eq!(o.flags & flags::SATURATED, 0, "desk {j}");
        }
        // the control plans the sunlit desk with what its window is at least (the sim
        // camera's saturation level over the desk's reflectance: klx), the others with theirs;
        // a desk out of view as near the window as the sun patch (its inferred daylight at
        // least the emitters' at the patch: stop 50, no plan) is not available, and planned
        // with none
        let control = live.daylight_for_control(60.0).expect("fresh values");
        assert!(control[k] > 5.0 * before[k].daylight_lx, "{control:?}");
        for (j, o) in after.iter().enumerate().filter(|(j, _)| *j != k) {
            if o.daylight_lx.is_nan() {
                assert_eq!(o.source, Source::Inferred, "desk {j}: {o:?}");
                assert_ne!(o.flags & flags::DAYLIGHT_UNKNOWN, 0, "desk {j}: {o:?}");
                // and says why: a merger of nodes takes no other node's inference over it
                assert_ne!(o.flags & flags::SUN_MAY_REACH, 0, "desk {j}: {o:?}");
                assert_eq!(control[j], 0.0, "desk {j}");
            } else {
                assert_eq!(control[j], o.daylight_lx, "desk {j}");
            }
        }
        let unknown = after.iter().filter(|o| o.daylight_lx.is_nan()).count();
        eprintln!("{unknown} desks not available (the sunlit one among them)");
    }
}

/// Issue 34: the sim board's injected camera faults reach live light. With every read timing
/// out (`[camera.sim.faults] timeout_chance = 1`), the board's live cameras give no frame; the
/// registers stop saying "measured" from a fresh frame: status bit "frame rejected", then
/// "camera stale" past the stale time, every desk flagged held then stale with its frame age
/// growing, the last good values held (finite).
#[test]
fn the_sim_boards_injected_camera_timeouts_reach_live_light() {
    use luxnode::daemon::live::{CapturedFrame, StepState, estimator, step};
    use luxnode::modbus::regmap::{LiveSource, Space, addr, live_flags, live_status};
    use luxnode::node::{Node, NodeModel, NodeOptions};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("boards/sim/board.toml");
    let sim = std::fs::read_to_string(&path).unwrap();
    let text =
        format!("{sim}\n[live]\nperiod_s = 1.0\n[camera.sim.faults]\ntimeout_chance = 1.0\n");
    let board = luxnode::board::Board::parse(&text, &path).expect("the faulty sim board");
    let image = Image::parse(&rig().image).unwrap();
    let mut node = Node::new(NodeModel::from_image(&image, 1), NodeOptions::default()).unwrap();
    let read = |node: &Node, a: u16| node.map().read(Space::Input, a);
    let mut live = estimator(&image, &LiveSettings::default()).unwrap();
    let stale_after_s = live.settings().stale_after_s;
    let mut state = StepState::default();
    let n = image.luminaires();
    node.set_levels(&vec![Some(0.8); n]).unwrap();
    let levels = node.levels().to_vec();
    // a good frame first: the desks in view measured, frame age 0
    let f = frame(&levels, &WorldExtras::default());
    let (w, h) = live.model().frame_size();
    let good = CapturedFrame {
        width: w,
        height: h,
        luminance: f.0,
        cd_m2_per_unit: f.1,
        depth_mm: Some(f.2),
        levels: levels.clone(),
    };
    let t0 = std::time::Instant::now();
    let st = step(&mut live, &mut state, Ok(good), 0.0, &mut node, 0.0);
    assert_eq!(
        st & (live_status::FRAME_REJECTED | live_status::CAMERA_STALE),
        0
    );
    let (k, _) = desk_in_view();
    assert_eq!(
        read(&node, addr::LIVE_SOURCE + k as u16),
        Some(LiveSource::Measured as u16)
    );
    assert_eq!(read(&node, addr::LIVE_FRAME_AGE + k as u16), Some(0));
    let before: Vec<f64> = live.desks().iter().map(|d| d.total_lx).collect();
    // the board's live cameras, every read timing out
    let mut task = luxnode::daemon::assemble::live_task(&board).expect("live light on");
    for t_s in [10.0, 20.0, stale_after_s + 10.0] {
        let taken = (task.capture)(&levels);
        assert!(
            taken.as_ref().is_err_and(|e| e.contains("no frame within")),
            "an injected timeout did not reach live light: {:?}",
            taken.as_ref().map(|f| f.width)
        );
        let st = step(&mut live, &mut state, taken, t_s, &mut node, t_s);
        assert_eq!(read(&node, addr::LIVE_STATUS), Some(st));
        assert_ne!(st & live_status::FRAME_REJECTED, 0, "{t_s} s");
        let stale = t_s > stale_after_s;
        assert_eq!(st & live_status::CAMERA_STALE != 0, stale, "{t_s} s");
        assert_eq!(read(&node, addr::LIVE_LAST_FRAME_AGE), Some(t_s as u16));
        for (j, d) in live.desks().iter().enumerate() {
            let flags = read(&node, addr::LIVE_FLAGS + j as u16).unwrap();
            assert_ne!(flags & live_flags::HELD, 0, "desk {j} at {t_s} s");
            assert_eq!(flags & live_flags::STALE != 0, stale, "desk {j} at {t_s} s");
            // no desk "measured" from a fresh frame
            let age = read(&node, addr::LIVE_FRAME_AGE + j as u16).unwrap();
            let source = read(&node, addr::LIVE_SOURCE + j as u16).unwrap();
            assert!(
                source != LiveSource::Measured as u16 || age >= t_s as u16,
                "desk {j} at {t_s} s: source {source}, frame age {age} s"
            );
            // the last good value held (the same levels, no daylight)
            assert!(
                (d.total_lx - before[j]).abs() <= 0.05 * before[j].max(1.0),
                "desk {j}"
            );
        }
    }
    eprintln!(
        "the faulty board's three frames and steps: {:?}",
        t0.elapsed()
    );
}

/// Issue 34 item 5, the frame checks as a property over random frames (fixed seed). Frames of
/// the simulated room at random dimming levels (30-100 %) and daylight (window 0-3000 lm/m²),
/// their pixel values off by an exposure error of ±25 % with the gain unchanged: always
/// believed. Frames from a camera turned in its mount (luminance and depth shifted sideways
/// together by 10-30 % of the width, either way), or replaced by random values: always "not
/// this room". A night frame's pixel values scaled by 0.02-0.4 with the gain unchanged: always
/// underexposed or dark (by day a dimmed frame is less daylight until it reads below the
/// luminaires' own light). Every rejected frame holds and flags every desk: never "measured"
/// from a frame that does not fit. Found by it: the turned camera passed every luminance check
/// (the demo office's desks repeat, so its edges do; edges agreeing 0.72-0.88) and published
/// desks 47 % low and 60 % high as measured; its depth now rejects it, by occupancy's rule.
/// Not stated, because it does not hold (docs/field.md): a turn by half the width, which maps
/// the demo office nearly onto itself (61 % of its depth agrees); flipped frames of the demo
/// office, which is symmetric about the image's horizontal axis
/// (`bad_frames_are_flagged_and_the_last_good_values_held` rejects the mirrored and turned
/// frames of the asymmetric office).
#[test]
fn the_frame_checks_hold_over_random_frames_of_this_room_and_of_others() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let mut runner = TestRunner::new(Config {
        cases: 24,
        rng_seed: RngSeed::Fixed(34),
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = (
        proptest::collection::vec(0.3f64..1.0, 6),
        0.0f64..3000.0,
        0.75f64..1.25,
        prop_oneof![0.1f64..0.3, 0.7f64..0.9],
        0.02f64..0.4,
        any::<u64>(),
    );
    let live = std::cell::RefCell::new(live_state());
    let t = std::cell::Cell::new(0.0f64);
    runner
        .run(&strategy, |(levels, window, exposure, roll, dim, seed)| {
            let mut live = live.borrow_mut();
            let (w, h) = live.model().frame_size();
            let good = frame(&levels, &with_events(Vec::new(), window));
            let scaled = |f: f64| -> Vec<u16> {
                good.0
                    .iter()
                    .map(|&v| (f64::from(v) * f).round().min(65_000.0) as u16)
                    .collect()
            };
            let night = frame(&levels, &with_events(Vec::new(), 0.0));
            // a camera turned in its mount: its luminance and depth shifted sideways together
            let shift = (roll * f64::from(w)) as usize;
            let shifted = |img: &[u16]| -> Vec<u16> {
                img.chunks(w as usize)
                    .flat_map(|row| row[shift..].iter().chain(&row[..shift]).copied())
                    .collect()
            };
            let (turned, turned_depth) = (shifted(&good.0), shifted(&good.2));
            let mut s = seed | 1;
            let noise: Vec<u16> = (0..good.0.len())
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    (s >> 48) as u16 % 60_000
                })
                .collect();
            let dimmed: Vec<u16> = night
                .0
                .iter()
                .map(|&v| (f64::from(v) * dim).round() as u16)
                .collect();
            let cases: [(&str, Vec<u16>, &[Verdict]); 4] = [
                ("exposure error", scaled(exposure), &[Verdict::Ok]),
                ("turned", turned, &[Verdict::NotThisRoom]),
                ("noise", noise, &[Verdict::NotThisRoom]),
                ("dim", dimmed, &[Verdict::Underexposed, Verdict::Dark]),
            ];
            for (what, lum, expected) in cases {
                t.set(t.get() + 1.0);
                // the night frames' with the night frames' gain and depth
                let (gain, depth) = match what {
                    "dim" => (night.1, &night.2),
                    "turned" => (good.1, &turned_depth),
                    _ => (good.1, &good.2),
                };
                let f = lf(w, h, &lum, gain, Some(depth), t.get());
                let desks = live.update(&f, &levels, t.get()).unwrap().to_vec();
                let verdict = live.report().map(|r| r.verdict);
                prop_assert!(
                    verdict.is_some_and(|v| expected.contains(&v)),
                    "{what} (levels {levels:?}, window {window:.0}, exposure {exposure:.2}, roll \
                     {roll:.2}, dim {dim:.2}): {verdict:?}, edges agree {:?}, samples used {:?} \
                     occluded {:?}",
                    live.edge_agreement(&f),
                    live.report().map(|r| r.samples_used),
                    live.report().map(|r| r.samples_occluded)
                );
                if expected != [Verdict::Ok] {
                    prop_assert!(
                        desks
                            .iter()
                            .all(|d| d.flags & flags::BAD_FRAME != 0 && d.flags & flags::HELD != 0)
                    );
                }
            }
            Ok(())
        })
        .unwrap();
}

/// Issue 34: a night frame shifted sideways by a desk's period (the demo office's desks
/// repeat, so its luminance edges do too: the edge check passes it) with one luminaire far
/// brighter than the rest: rejected as not this room by the light found below the luminaires'
/// own (`MAX_BELOW_ARTIFICIAL_SHARE`), every desk held and flagged.
#[test]
fn a_shifted_view_whose_edges_repeat_is_rejected_by_the_light_below_the_luminaires() {
    let levels = [0.3, 0.3, 0.3, 0.3, 0.93, 0.3];
    let night = frame(&levels, &with_events(Vec::new(), 0.0));
    let mut live = live_state();
    update(&mut live, &night, &levels, 0.0);
    let (w, h) = live.model().frame_size();
    let shift = (0.71 * f64::from(w)) as usize;
    let rolled: Vec<u16> = night
        .0
        .chunks(w as usize)
        .flat_map(|row| row[shift..].iter().chain(&row[..shift]).copied())
        .collect();
    let f = lf(w, h, &rolled, night.1, Some(&night.2), 1.0);
    let (agree, _) = live.edge_agreement(&f).expect("edges");
    assert!(agree >= 0.7, "the edge check alone would pass it: {agree}");
    let desks = live.update(&f, &levels, 1.0).unwrap().to_vec();
    assert_eq!(live.report().map(|r| r.verdict), Some(Verdict::NotThisRoom));
    assert!(
        desks
            .iter()
            .all(|d| d.flags & flags::BAD_FRAME != 0 && d.flags & flags::HELD != 0)
    );
}

/// Issue 28 item 4: by day, an inferred desk whose stated uncertainty is beyond
/// `unknown_above_rel_uncertainty` publishes its artificial part alone, the total and the
/// daylight not available (NaN, flagged), and the control plans without its daylight. With
/// the threshold at its floor (5 %), the out-of-view desks of the demo office by day are such
/// desks; at the default (100 %) none is, and their values stand.
#[test]
fn an_inferred_desk_beyond_the_uncertainty_limit_publishes_its_artificial_part_alone() {
    let image = Image::parse(&rig().image).unwrap();
    let strict = LiveSettings {
        unknown_above_rel_uncertainty: 0.05,
        ..LiveSettings::default()
    };
    let mut live = Live::new(LiveModel::new(&image).unwrap(), strict).unwrap();
    let mut default = live_state();
    let levels = vec![1.0; 6];
    let extras = WorldExtras {
        window_exitance_lm_m2: 3000.0,
        ..WorldExtras::default()
    };
    let f = frame(&levels, &extras);
    let loose = update(&mut default, &f, &levels, 0.0).to_vec();
    let desks = update(&mut live, &f, &levels, 0.0).to_vec();
    let model_art: Vec<f64> = loose.iter().map(|d| d.artificial_lx).collect();
    let mut unknown = 0;
    for (k, d) in desks.iter().enumerate() {
        if d.source != Source::Inferred {
            assert!(
                d.total_lx.is_finite(),
                "desk {k}: a measured desk is never unknown"
            );
            continue;
        }
        assert!(loose[k].total_lx.is_finite() && loose[k].uncertainty_lx > 0.0);
        let rel = loose[k].uncertainty_lx / loose[k].total_lx;
        if rel > 0.05 {
            unknown += 1;
            assert!(d.total_lx.is_nan() && d.daylight_lx.is_nan() && d.uncertainty_lx.is_nan());
            assert_eq!(d.flags & flags::DAYLIGHT_UNKNOWN, flags::DAYLIGHT_UNKNOWN);
            assert_eq!(d.flags & flags::NOT_ESTIMATED, flags::NOT_ESTIMATED);
            assert!((d.artificial_lx - model_art[k]).abs() < 1e-9, "desk {k}");
        } else {
            assert!(d.total_lx.is_finite(), "desk {k}");
        }
    }
    assert!(unknown >= 2, "{unknown} desks beyond 5 %");
    let control = live.daylight_for_control(60.0).unwrap();
    for (k, d) in desks.iter().enumerate() {
        assert!(control[k].is_finite(), "desk {k}");
        if d.flags & flags::DAYLIGHT_UNKNOWN != 0 {
            assert_eq!(control[k], 0.0, "desk {k}: planned without daylight");
        }
    }
}

/// A window's glass the camera sees, dark at commissioning (night) and bright by day, is a
/// light source in the frame, not the room's texture: the edges it turns do not reject a genuine
/// frame (issue 28's bench: room_08's tilted node saw its glazing, 80 klx by day, and every day
/// frame was refused as "not this room", the desks held at the model without daylight). The
/// demo office's camera tilted 45° toward its window band, commissioned at night, then the band
/// at 2000 lm/m² (below saturation): 31 % of the commissioned edges turn (measured: 0.689 of 978
/// agree, under the 0.7 that rejects another view), and the frame is taken.
#[test]
fn a_window_bright_by_day_in_view_is_not_another_room() {
    let mut scene = luxnode::sim::demo::demo_office();
    let cam = scene.camera.as_mut().unwrap();
    cam.world_from_camera =
        glam::DMat3::from_rotation_y(-45f64.to_radians()) * cam.world_from_camera;
    let world = SimWorld::new(scene, &luxnode::sim::camera::world_settings()).unwrap();
    let c = luxnode::bench::live::commission_in_daylight(&world, false).unwrap();
    let image = Image::parse(&c.image).unwrap();
    let mut live = Live::new(LiveModel::new(&image).unwrap(), LiveSettings::default()).unwrap();
    let levels = vec![1.0; world.luminaire_ids().len()];
    for (t, exitance) in [(1.0, 0.0), (2.0, 2000.0)] {
        world.set_extras(WorldExtras {
            window_exitance_lm_m2: exitance,
            ..WorldExtras::default()
        });
        let mut lights = world.clone();
        lights.set_levels(&levels).unwrap();
        let l = world
            .luminance_camera(SimLuminanceOptions::default())
            .unwrap()
            .capture_luminance()
            .unwrap();
        let d = world
            .depth_camera(SimDepthOptions::default())
            .unwrap()
            .capture_depth()
            .unwrap();
        let (w, h) = live.model().frame_size();
        let frame = LiveFrame {
            width: w,
            height: h,
            luminance: &l.data,
            cd_m2_per_unit: l.cd_m2_per_unit,
            depth_mm: Some(&d.depth_mm),
            taken_s: t,
        };
        live.update(&frame, &levels, t).unwrap();
        let (agree, edges) = live.edge_agreement(&frame).unwrap();
        eprintln!("window {exitance} lm/m²: {agree:.3} of {edges} edges agree");
        assert_eq!(
            live.report().unwrap().verdict,
            Verdict::Ok,
            "window {exitance}"
        );
        if exitance > 0.0 {
            // the check this test is about: every edge counted, the frame would be refused
            assert!(agree < 0.7, "{agree}");
        }
    }
}

/// Before the camera's first frame is taken (boot; a camera that never answered; every frame
/// refused) the daylight is not known, day or night: every desk publishes its artificial light
/// and the total and daylight as not available (NaN, flags not estimated and daylight unknown),
/// never the model's light as the total with the daylight at 0 lx (issue 28 item 4).
#[test]
fn before_the_first_frame_the_daylight_is_not_known() {
    let mut live = live_state();
    for d in live.desks() {
        assert!(d.total_lx.is_nan() && d.uncertainty_lx.is_nan(), "{d:?}");
        assert_ne!(d.flags & flags::DAYLIGHT_UNKNOWN, 0, "{d:?}");
    }
    let n = rig().world.luminaire_ids().len();
    let levels = vec![1.0; n];
    let (w, h) = live.model().frame_size();
    let dark = vec![0u16; (w * h) as usize];
    // a dark frame (the lens covered) and no frame at all
    live.update(&lf(w, h, &dark, 0.02, None, 1.0), &levels, 1.0)
        .unwrap();
    assert_eq!(live.report().unwrap().verdict, Verdict::Dark);
    for step in 0..2 {
        let desks = if step == 0 {
            live.desks().to_vec()
        } else {
            live.no_frame(&levels, 2.0).unwrap().to_vec()
        };
        for d in &desks {
            assert!(d.total_lx.is_nan() && d.daylight_lx.is_nan(), "{d:?}");
            assert!(
                d.artificial_lx.is_finite() && d.artificial_lx > 0.0,
                "{d:?}"
            );
            let f = flags::DAYLIGHT_UNKNOWN | flags::NOT_ESTIMATED | flags::HELD;
            assert_eq!(d.flags & f, f, "{d:?}");
            assert_eq!(d.source, Source::Model);
        }
    }
    // the first frame taken sets them
    let f = frame(&levels, &WorldExtras::default());
    update(&mut live, &f, &levels, 3.0);
    for d in live.desks() {
        assert!(
            d.total_lx.is_finite() && d.uncertainty_lx.is_finite(),
            "{d:?}"
        );
        assert_eq!(d.flags & flags::DAYLIGHT_UNKNOWN, 0, "{d:?}");
    }
}
