//! The cameras: simulated (closed forms, the engine, noise statistics, determinism), replay
//! (byte-identical to the files), the capture sequence with injected faults, the A010 parser on
//! byte streams, V4L2 pixel decoding.

mod common;
use common::office_a;

use std::sync::OnceLock;
use std::time::Instant;

use luxnode::camera::{
    CameraError, DepthCamera, FaultInjector, Faults, LightControl, LuminanceCamera,
    SequenceOptions, capture_sequence, capture_sequence_with,
};
use luxnode::engine::direct::{self, Receiver};
use luxnode::sim::camera::{SimDepthOptions, SimLuminanceOptions, SimWorld};

fn demo() -> &'static SimWorld {
    static W: OnceLock<SimWorld> = OnceLock::new();
    W.get_or_init(|| {
        let t0 = Instant::now();
        let w = SimWorld::demo_office().expect("demo world");
        let t1 = Instant::now();
        w.prepare();
        eprintln!(
            "demo world: engine {:.0} ms, per-pixel hits + direct light {:.0} ms",
            (t1 - t0).as_secs_f64() * 1e3,
            t1.elapsed().as_secs_f64() * 1e3
        );
        w
    })
}

fn group_of(w: &SimWorld, patch: u32) -> &str {
    let g = w.model().patches.group[patch as usize] as usize;
    &w.scene().mesh.groups[g]
}

#[test]
fn sim_depth_of_the_floor_is_the_camera_height() {
    let w = demo();
    let mut cam = w.depth_camera(SimDepthOptions::exact()).unwrap();
    let f = cam.capture_depth().unwrap();
    let c = w.camera();
    assert_eq!((f.width, f.height), (c.width, c.height));
    // the camera looks straight down: every floor pixel's depth along the axis is its height
    let height_mm = (c.position_m.z * 1000.0).round() as u16;
    let mut floor = 0;
    for (i, h) in w.hits().iter().enumerate() {
        let Some(h) = h else { continue };
        if group_of(w, h.patch) == "floor" {
            floor += 1;
            assert!(
                f.depth_mm[i].abs_diff(height_mm) <= 1,
                "pixel {i}: {} mm, expected {height_mm} mm",
                f.depth_mm[i]
            );
        }
        // desk tops: camera height minus the desk height
        if group_of(w, h.patch).starts_with("desk")
            && h.front
            && w.model().patches.normal[h.patch as usize].z > 0.99
        {
            let desk_mm = ((c.position_m.z - 0.75) * 1000.0).round() as u16;
            assert!(
                f.depth_mm[i].abs_diff(desk_mm) <= 1,
                "desk pixel {i}: {}",
                f.depth_mm[i]
            );
        }
    }
    assert!(floor > 20_000, "{floor} floor pixels");
    // the room is closed: every pixel inside the lens's field has a return, none outside
    let mut outside = 0;
    for v in 0..c.height {
        for u in 0..c.width {
            let d = f.depth_mm[(v * c.width + u) as usize];
            match c.ray_world(f64::from(u), f64::from(v)) {
                Some(_) => assert!(d > 0, "({u}, {v})"),
                None => {
                    outside += 1;
                    assert_eq!(d, 0, "({u}, {v}) is outside the field");
                }
            }
        }
    }
    // the demo camera is a pinhole: every pixel is inside its field (the sim-fisheye board's
    // lens leaves the corners out: tests in `fisheye` below)
    assert_eq!(outside, 0, "{outside} pixels outside the field");
}

#[test]
fn sim_luminance_is_rho_e_over_pi_with_the_engines_e() {
    let w = demo();
    let mut world = w.clone();
    let n = w.scene().luminaires.len();
    let mut levels = vec![0.0; n];
    levels[1] = 1.0;
    levels[4] = 0.5;
    world.set_levels(&levels).unwrap();
    let opts = SimLuminanceOptions::default();
    let mut cam = w.luminance_camera(opts.clone()).unwrap();
    let f = cam.capture_luminance().unwrap();
    // independent reference: direct light with 16x the opening points, indirect from
    // Model::patch_lux minus the patch's own direct light
    let m = w.model();
    let patch_lux = m.patch_lux(&levels).unwrap();
    let caster = luxnode::engine::raycast::RayCaster::new(&m.patches);
    let c = w.camera();
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    let mut rels = Vec::new();
    for v in (10..c.height).step_by(23) {
        for u in (10..c.width).step_by(29) {
            let i = (v * c.width + u) as usize;
            let Some(h) = w.hits()[i] else { continue };
            if !h.front
                || !["floor", "desk_2", "desk_5", "wall_s"]
                    .iter()
                    .any(|g| group_of(w, h.patch) == *g)
            {
                continue;
            }
            let p = h.patch as usize;
            let x = c.position_m + c.ray_world(f64::from(u), f64::from(v)).unwrap() * h.t_m;
            let nrm = m.patches.normal[p];
            let mut e_dir = 0.0;
            let mut e_dir16 = 0.0;
            let mut e_dir_patch = 0.0;
            for (l, lum) in w.scene().luminaires.iter().enumerate() {
                if levels[l] > 0.0 {
                    let e = |m| {
                        let pts = if m == 16 {
                            luxnode::sim::camera::opening_points(lum, m)
                        } else {
                            direct::opening_points(lum, m)
                        };
                        direct::illuminance_lx(lum, &pts, x, nrm, Receiver::Surface, &caster)
                    };
                    e_dir += levels[l] * e(256);
                    e_dir16 += levels[l] * e(16);
                    e_dir_patch += levels[l] * m.direct_patch_lx[l][p];
                }
            }
            let indirect = patch_lux[p] - e_dir_patch;
            let l_ref = m.patches.rho[p] * (e_dir + indirect) / std::f64::consts::PI;
            let l_ref16 = m.patches.rho[p] * (e_dir16 + indirect) / std::f64::consts::PI;
            let l_sim = f64::from(f.data[i]) * f.cd_m2_per_unit;
            // the engine's own direct light with the same 16 points: equal up to rounding
            assert!(
                (l_sim - l_ref16).abs() < 0.002 * l_ref16 + opts.cd_m2_per_unit,
                "pixel ({u}, {v}) on {}: {l_sim:.3} cd/m², reference {l_ref16:.3}",
                group_of(w, h.patch)
            );
            // 256 points: a few % apart in a penumbra only
            let rel = (l_sim - l_ref).abs() / l_ref;
            worst = worst.max(rel);
            rels.push(rel);
            checked += 1;
        }
    }
    rels.sort_by(f64::total_cmp);
    let median = rels[rels.len() / 2];
    eprintln!(
        "luminance vs rho E / pi: {checked} pixels, median {:.2} %, worst {:.2} %",
        100.0 * median,
        100.0 * worst
    );
    assert!(median < 0.005, "{median}");
    assert!(worst < 0.1, "{worst}");
    assert!(checked > 30, "{checked}");
    // all off is black
    world.set_levels(&vec![0.0; n]).unwrap();
    assert!(
        cam.capture_luminance()
            .unwrap()
            .data
            .iter()
            .all(|&x| x == 0)
    );
}

#[test]
fn sim_depth_noise_matches_the_model() {
    let w = demo();
    // range noise and dropouts alone
    let o = SimDepthOptions {
        flying_pixel_chance: 0.0,
        seed: 42,
        ..SimDepthOptions::default()
    };
    let mut cam = w.depth_camera(o.clone()).unwrap();
    let exact = cam.exact_depth_m();
    let (mut n, mut sum, mut sum2, mut dropped, mut total) = (0.0, 0.0, 0.0, 0usize, 0usize);
    for _ in 0..4 {
        let f = cam.capture_depth().unwrap();
        for (d, z) in f.depth_mm.iter().zip(&exact) {
            // the fisheye's corners: no ray, no return
            if z.is_nan() {
                assert_eq!(*d, 0);
                continue;
            }
            total += 1;
            if *d == 0 {
                dropped += 1;
                continue;
            }
            let r = (f64::from(*d) / 1000.0 - z) / z;
            n += 1.0;
            sum += r;
            sum2 += r * r;
        }
    }
    let mean = sum / n;
    let sd = (sum2 / n - mean * mean).sqrt();
    let drop_rate = dropped as f64 / total as f64;
    eprintln!(
        "range noise: mean {mean:.5}, sd {sd:.5} (model 0.01); dropouts {:.3} % (model 0.5 %)",
        100.0 * drop_rate
    );
    assert!(mean.abs() < 3e-4, "{mean}");
    // mm rounding adds (1/sqrt(12)) mm over ~2.5 m: negligible
    assert!(
        (sd - o.range_noise_rel).abs() < 0.03 * o.range_noise_rel,
        "{sd}"
    );
    // binomial sd over 307200 pixels: 1.3e-4
    assert!((drop_rate - o.dropout_chance).abs() < 6e-4, "{drop_rate}");

    // flying pixels alone: only on edges, at the configured rate, between the two depths
    let o = SimDepthOptions {
        range_noise_rel: 0.0,
        dropout_chance: 0.0,
        seed: 7,
        ..SimDepthOptions::default()
    };
    let mut cam = w.depth_camera(o.clone()).unwrap();
    let edges: Vec<(usize, f64)> = cam.edge_pixels().to_vec();
    let f = cam.capture_depth().unwrap();
    let mut is_edge = vec![false; exact.len()];
    let mut flying = 0;
    for &(i, zn) in &edges {
        is_edge[i] = true;
        let d = f64::from(f.depth_mm[i]) / 1000.0;
        if (d - exact[i]).abs() > 0.0015 {
            flying += 1;
            let (lo, hi) = (exact[i].min(zn), exact[i].max(zn));
            assert!(
                d > lo && d < hi,
                "flying pixel {i} at {d} m outside [{lo}, {hi}]"
            );
        }
    }
    for (i, d) in f.depth_mm.iter().enumerate() {
        if exact[i].is_nan() {
            assert_eq!(*d, 0, "pixel {i} is outside the field");
        } else if !is_edge[i] {
            assert!(
                (f64::from(*d) / 1000.0 - exact[i]).abs() <= 0.0005 + 1e-9,
                "pixel {i}"
            );
        }
    }
    let rate = flying as f64 / edges.len() as f64;
    eprintln!(
        "flying pixels: {} edge pixels ({:.2} % of the frame), {:.1} % flying (model {:.0} %)",
        edges.len(),
        100.0 * edges.len() as f64 / exact.len() as f64,
        100.0 * rate,
        100.0 * o.flying_pixel_chance
    );
    let sd = (o.flying_pixel_chance * (1.0 - o.flying_pixel_chance) / edges.len() as f64).sqrt();
    assert!(
        (rate - o.flying_pixel_chance).abs() < 4.0 * sd + 0.01,
        "{rate}"
    );
}

#[test]
fn sim_is_deterministic_for_a_seed() {
    let w = demo();
    let o = SimDepthOptions::default();
    let mut a = w.depth_camera(o.clone()).unwrap();
    let mut b = w.depth_camera(o.clone()).unwrap();
    let (a1, b1) = (a.capture_depth().unwrap(), b.capture_depth().unwrap());
    assert_eq!(a1.depth_mm, b1.depth_mm);
    // frames differ from each other, and another seed differs
    assert_ne!(a.capture_depth().unwrap().depth_mm, a1.depth_mm);
    let mut c = w.depth_camera(SimDepthOptions { seed: 99, ..o }).unwrap();
    assert_ne!(c.capture_depth().unwrap().depth_mm, a1.depth_mm);
}

/// A colour camera in a room whose daylight brightens while the capture runs: frame j (0 the
/// first) gets a uniform `base · (1 + step · j)` cd/m² on top of the room's own light.
struct DriftingDaylight<C> {
    inner: C,
    base_cd_m2: f64,
    step: f64,
    calls: usize,
}

impl<C: LuminanceCamera> LuminanceCamera for DriftingDaylight<C> {
    fn capture_luminance(&mut self) -> Result<luxnode::camera::LuminanceFrame, CameraError> {
        let mut f = self.inner.capture_luminance()?;
        let add = self.base_cd_m2 * (1.0 + self.step * self.calls as f64) / f.cd_m2_per_unit;
        for v in &mut f.data {
            *v = (f64::from(*v) + add).round().min(65535.0) as u16;
        }
        self.calls += 1;
        Ok(f)
    }
}

#[test]
fn daylight_drifting_during_the_capture_is_taken_out_of_each_luminaires_frame() {
    let w = demo();
    let ids = w.luminaire_ids();
    let take = |base_cd_m2: f64, step: f64| {
        let mut depth = w.depth_camera(SimDepthOptions::default()).unwrap();
        let mut lum = DriftingDaylight {
            inner: w.luminance_camera(SimLuminanceOptions::default()).unwrap(),
            base_cd_m2,
            step,
            calls: 0,
        };
        let mut lights = w.clone();
        capture_sequence_with(
            &mut depth,
            &mut lum,
            &mut lights,
            &ids,
            &SequenceOptions {
                depth_frames: 1,
                ..SequenceOptions::default()
            },
            &mut |_, _, _| {},
        )
        .unwrap()
    };
    let dark = take(0.0, 0.0);
    // 20 cd/m² of daylight, +2 % a frame: + 2 (n + 2) % by the closing all-off frame
    let (base, step) = (20.0, 0.02);
    let day = take(base, step);
    let end = day
        .capture
        .off_end
        .as_ref()
        .expect("the closing all-off frame");
    assert_eq!(end.position, ids.len() + 2, "after the all-on frame");
    let drift = day.daylight_drift.unwrap();
    let by_end = step * (ids.len() + 2) as f64;
    assert!((drift - by_end).abs() < 0.01, "{drift} vs {by_end}");
    assert!(
        day.capture
            .warnings
            .iter()
            .any(|x| x.contains("daylight changed"))
    );
    let gain = day.capture.camera.luminance_cd_m2_per_unit.unwrap();
    let mut without = day.capture.clone();
    without.off_end = None;
    let (mut worst, mut worst_without, mut n) = (0.0f64, 0.0f64, 0usize);
    for k in 0..ids.len() {
        for (i, &x) in dark.capture.luminance[k].1.data.iter().enumerate() {
            if x < 200 || x == u16::MAX {
                continue;
            }
            let truth = f64::from(x);
            let (Some(a), Some(b)) = (
                day.capture.luminaire_value(k, i),
                without.luminaire_value(k, i),
            ) else {
                continue;
            };
            worst = worst.max((a - truth).abs());
            worst_without = worst_without.max((b - truth).abs());
            n += 1;
        }
    }
    assert!(n > 10_000, "{n}");
    // interpolated: rounding only (three frames, half a unit each)
    assert!(worst <= 1.5, "{worst}");
    // the first off frame alone leaves the drift in: up to (n + 1) · step · base
    let expect = ids.len() as f64 * step * base / gain;
    assert!(worst_without > 0.9 * expect, "{worst_without} vs {expect}");
    // the capture set on disk keeps the closing frame and its place
    let tmp = tempfile::tempdir().unwrap();
    luxnode::camera::save_capture(tmp.path(), &day.capture, day.all_on.as_ref()).unwrap();
    let back = luxnode::camera::capture::Capture::load(tmp.path(), &ids).unwrap();
    assert_eq!(
        back.off_end.as_ref().map(|e| e.position),
        Some(ids.len() + 2)
    );
    assert_eq!(
        back.luminaire_value(0, 1000),
        day.capture.luminaire_value(0, 1000)
    );
    // saved without the all-on frame, camera.json still says where the closing frame was
    let tmp = tempfile::tempdir().unwrap();
    luxnode::camera::save_capture(tmp.path(), &day.capture, None).unwrap();
    let back = luxnode::camera::capture::Capture::load(tmp.path(), &ids).unwrap();
    assert_eq!(
        back.off_end.as_ref().map(|e| e.position),
        Some(ids.len() + 2)
    );
    // a place the sequence cannot have had is a clear error
    let path = tmp.path().join("camera.json");
    let text = std::fs::read_to_string(&path).unwrap();
    let key = format!("\"luminance_off_end_position\": {}", ids.len() + 2);
    assert!(text.contains(&key), "{text}");
    std::fs::write(
        &path,
        text.replace(&key, "\"luminance_off_end_position\": 99"),
    )
    .unwrap();
    let e = luxnode::camera::capture::Capture::load(tmp.path(), &ids).unwrap_err();
    assert!(e.to_string().contains("luminance_off_end_position"), "{e}");
}

#[test]
fn capture_sequence_survives_transient_faults_and_reports_the_rest() {
    let w = demo();
    let ids = w.luminaire_ids();
    let depth = w.depth_camera(SimDepthOptions::default()).unwrap();
    let lum = w.luminance_camera(SimLuminanceOptions::default()).unwrap();
    // call 1 of the depth camera is garbage, call 0 and 2 of the colour camera time out
    let mut depth = FaultInjector::new(
        depth,
        Faults {
            garbage_at: vec![1],
            ..Faults::none()
        },
        "tof",
    )
    .unwrap();
    let mut lum = FaultInjector::new(
        lum,
        Faults {
            timeout_at: vec![0, 2],
            ..Faults::none()
        },
        "rgb",
    )
    .unwrap();
    let mut lights = w.clone();
    let mut steps = Vec::new();
    let s = capture_sequence_with(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        &SequenceOptions {
            depth_frames: 3,
            retries: 2,
            ..SequenceOptions::default()
        },
        &mut |step, total, what| steps.push((step, total, what.to_owned())),
    )
    .unwrap();
    assert_eq!(s.retries_used, 3);
    assert_eq!(s.capture.warnings.len(), 3, "{:?}", s.capture.warnings);
    assert!(s.capture.warnings[0].contains("bad frame"));
    assert_eq!(s.capture.depth_mm.len(), 3);
    assert_eq!(
        s.capture.luminance.iter().map(|l| l.0).collect::<Vec<_>>(),
        ids
    );
    assert_eq!(s.capture.camera.luminance_cd_m2_per_unit, Some(0.02));
    assert!(s.all_on.is_some());
    // superposition holds in the simulation (rounding only)
    let e = s.superposition_error.unwrap();
    assert!(e < 0.01, "{e}");
    // the all-off frames (the daylight, subtracted at commissioning; and the drift check): in the
    // dark room every pixel is 0, so there is no drift to measure
    assert!(s.capture.off.is_some());
    assert_eq!(s.daylight_drift, None);
    let total = 3 + 1 + ids.len() + 1 + 1;
    assert_eq!(steps.first().map(|s| s.1), Some(total));
    assert_eq!(steps.last().map(|s| s.0), Some(total));
    assert!(w.levels().iter().all(|&x| x == 0.0), "lights left on");

    // a frame that keeps failing: the error after `retries` retries
    let mut depth = FaultInjector::new(
        w.depth_camera(SimDepthOptions::default()).unwrap(),
        Faults {
            timeout_chance: 1.0,
            ..Faults::none()
        },
        "tof",
    )
    .unwrap();
    let mut lum = w.luminance_camera(SimLuminanceOptions::default()).unwrap();
    let e = capture_sequence(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        2,
        3,
        &mut |_, _, _| {},
    )
    .unwrap_err();
    assert!(matches!(e, CameraError::Timeout { .. }), "{e}");
    assert_eq!(depth.calls(), 4);

    // a disconnect is not retried; the lights are switched off anyway
    let mut lum = FaultInjector::new(
        w.luminance_camera(SimLuminanceOptions::default()).unwrap(),
        Faults {
            disconnect_after_frames: Some(2),
            ..Faults::none()
        },
        "rgb",
    )
    .unwrap();
    let mut depth = w.depth_camera(SimDepthOptions::default()).unwrap();
    let e = capture_sequence(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        1,
        5,
        &mut |_, _, _| {},
    )
    .unwrap_err();
    assert!(matches!(e, CameraError::Disconnected { .. }), "{e}");
    assert_eq!(lum.calls(), 3);
    assert!(w.levels().iter().all(|&x| x == 0.0), "lights left on");
    lum.reconnect();
    assert!(lum.capture_luminance().is_ok());

    // random faults: deterministic for a seed, never a panic
    let run = |seed| {
        let mut d = FaultInjector::new(
            w.depth_camera(SimDepthOptions::default()).unwrap(),
            Faults {
                seed,
                timeout_chance: 0.2,
                garbage_chance: 0.2,
                ..Faults::none()
            },
            "tof",
        )
        .unwrap();
        (0..50)
            .map(|_| match d.capture_depth() {
                Ok(_) => 'o',
                Err(CameraError::Timeout { .. }) => 't',
                Err(CameraError::Garbage { .. }) => 'g',
                Err(_) => '?',
            })
            .collect::<String>()
    };
    let a = run(5);
    assert_eq!(a, run(5));
    assert_ne!(a, run(6));
    assert!(a.contains('t') && a.contains('g') && a.contains('o') && !a.contains('?'));
}

/// A simulated world's capture set through its cameras (5 depth frames, 2 per luminance frame).
fn capture_of(w: &SimWorld) -> luxnode::camera::capture::Capture {
    let ids = w.luminaire_ids();
    let mut depth = w.depth_camera(SimDepthOptions::default()).unwrap();
    let mut lum = w.luminance_camera(SimLuminanceOptions::default()).unwrap();
    let mut lights = w.clone();
    capture_sequence(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        5,
        2,
        &mut |_, _, _| {},
    )
    .unwrap()
}

/// Captures a simulated world through its cameras and commissions it at defaults; also the
/// capture's time.
fn commission_from_cameras(
    w: &SimWorld,
) -> (luxnode::commission::Commissioned, std::time::Duration) {
    let t0 = Instant::now();
    let capture = capture_of(w);
    let t_capture = t0.elapsed();
    let scene = w.scene();
    let c = luxnode::commission::from_capture(
        &capture,
        scene.luminaires.clone(),
        scene.sensors.clone(),
        scene.desks.clone(),
        &luxnode::commission::CommissionOptions::default(),
    )
    .unwrap();
    (c, t_capture)
}

/// The commissioned model's all-on sensor error against the world's (mean abs / mean), with
/// both readings.
fn all_on_error(c: &luxnode::commission::Commissioned, w: &SimWorld) -> (f64, Vec<f64>, Vec<f64>) {
    let all_on = vec![1.0; w.luminaire_ids().len()];
    let got = c.model.sensor_lux(&all_on).unwrap();
    let want = w.model().sensor_lux(&all_on).unwrap();
    let err = got
        .iter()
        .zip(&want)
        .map(|(g, t)| (g - t).abs())
        .sum::<f64>()
        / want.iter().sum::<f64>();
    (err, got, want)
}

#[test]
fn two_nodes_commission_the_demo_office_together() {
    // two pinhole nodes over the two halves of the demo office (8 x 6 m): one room model from
    // both capture sets, one image per node; each node serves the desks it sees
    let base = demo();
    let pinhole = base.scene().camera.clone().unwrap();
    let world_at = |x: f64| {
        let mut scene = base.scene().clone();
        let mut cam = pinhole.clone();
        cam.position_m.x = x;
        scene.camera = Some(cam);
        SimWorld::from_model(scene, base.model().clone()).unwrap()
    };
    let (wa, wb) = (world_at(2.0), world_at(6.0));
    let (ca, cb) = (capture_of(&wa), capture_of(&wb));
    let scene = base.scene();
    let o = luxnode::commission::CommissionOptions::default();
    let commission = |caps: &[luxnode::camera::capture::Capture]| {
        luxnode::commission::from_captures(
            caps,
            scene.luminaires.clone(),
            scene.sensors.clone(),
            scene.desks.clone(),
            &o,
        )
        .unwrap()
    };
    let nodes = commission(&[ca.clone(), cb.clone()]);
    assert_eq!(nodes.len(), 2);
    let (alone_a, alone_b) = (commission(&[ca]).remove(0), commission(&[cb]).remove(0));
    // every node holds the same room model, with its own camera
    assert_eq!(nodes[0].model.patches.len(), nodes[1].model.patches.len());
    assert_eq!(
        nodes[0].scene.camera.as_ref().unwrap().position_m.x,
        2.0,
        "node 1's camera"
    );
    assert_eq!(nodes[1].scene.camera.as_ref().unwrap().position_m.x, 6.0);
    // the floor is modelled once: floor triangles cover the room box's floor, no more
    let floor_area = |c: &luxnode::commission::Commissioned| -> f64 {
        let r = &c.reco;
        (0..r.tris.len())
            .filter(|&t| {
                let [a, b, cc] = r.tris[t].map(|i| r.positions_m[i as usize]);
                let n = (b - a).cross(cc - a);
                n.z > 0.0 && a.z.max(b.z).max(cc.z) < 0.05
            })
            .map(|t| r.area_m2(t))
            .sum()
    };
    let room = nodes[0].report.room.clone().expect("closed");
    let box_area = (room.xy_m[2] - room.xy_m[0]) * (room.xy_m[3] - room.xy_m[1]);
    let merged_floor = floor_area(&nodes[0]);
    assert!(
        (merged_floor / box_area - 1.0).abs() < 0.02,
        "floor {merged_floor:.2} m² in a {box_area:.2} m² box"
    );
    // between them the nodes see more desk sensors than either alone; a sensor one node sees is
    // out of the other's view in that node's flags
    let seen = |c: &luxnode::commission::Commissioned| -> Vec<bool> {
        c.sensor_flags.iter().map(|&f| f == 0).collect()
    };
    let (sa, sb) = (seen(&nodes[0]), seen(&nodes[1]));
    assert_eq!(sa, seen(&alone_a));
    assert_eq!(sb, seen(&alone_b));
    let either = sa.iter().zip(&sb).filter(|(a, b)| **a || **b).count();
    let (na, nb) = (
        sa.iter().filter(|&&x| x).count(),
        sb.iter().filter(|&&x| x).count(),
    );
    assert!(either > na.max(nb), "{sa:?} {sb:?}");
    // the room model against the world, all on
    let (err, got, want) = all_on_error(&nodes[0], &wa);
    let (err_a, _, _) = all_on_error(&alone_a, &wa);
    let (err_b, _, _) = all_on_error(&alone_b, &wb);
    eprintln!(
        "two nodes on the demo office: sensors in view {na} + {nb} ({either} in all), all-on \
         error {:.2} % (node 1 alone {:.2} %, node 2 alone {:.2} %); got {got:.0?}, world \
         {want:.0?}; floor {merged_floor:.2} of {box_area:.2} m², {} patches",
        100.0 * err,
        100.0 * err_a,
        100.0 * err_b,
        nodes[0].model.patches.len()
    );
    assert!(err < 0.03, "{err}");
}

#[test]
fn demo_office_commissions_from_simulated_cameras() {
    let w = demo();
    let t0 = Instant::now();
    let (c, t_capture) = commission_from_cameras(w);
    let t_total = t0.elapsed();
    let (err, got, want) = all_on_error(&c, w);
    eprintln!(
        "demo office from simulated cameras: capture {:.0} ms, capture + commission {:.0} ms, \
         all-on sensor error {:.1} % (mean abs / mean), got {got:.0?}, world {want:.0?}",
        t_capture.as_secs_f64() * 1e3,
        t_total.as_secs_f64() * 1e3,
        100.0 * err
    );
    // the pinhole demo camera sees 2 of the 7 desk sensors; the others are estimated from the
    // room closure and the inferred desk tops (docs/cameras.md: 2.2 %)
    assert!(err < 0.045, "{err}");
}

#[test]
fn sim_luminance_agrees_with_the_radiance_capture_of_office_a() {
    let dir = office_a();
    let scene = luxnode::scene::Scene::load(&dir, &Default::default()).unwrap();
    let t0 = Instant::now();
    let w = SimWorld::new(scene, &luxnode::sim::camera::world_settings()).unwrap();
    let mut lights = w.clone();
    let mut cam = w.luminance_camera(SimLuminanceOptions::default()).unwrap();
    let n = w.scene().luminaires.len();
    let mut medians = Vec::new();
    for k in [0usize, 4] {
        let mut levels = vec![0.0; n];
        levels[k] = 1.0;
        lights.set_levels(&levels).unwrap();
        let f = cam.capture_luminance().unwrap();
        let id = w.scene().luminaires[k].id;
        let img = image::open(dir.join(format!("capture_clean/luminance_L{id}.png")))
            .unwrap()
            .into_luma16();
        assert_eq!((img.width(), img.height()), (f.width, f.height));
        let mut rel: Vec<f64> = img
            .as_raw()
            .iter()
            .zip(&f.data)
            .filter(|(r, _)| **r > 500 && **r < u16::MAX)
            .map(|(r, s)| (f64::from(*s) - f64::from(*r)) / f64::from(*r))
            .collect();
        rel.sort_by(f64::total_cmp);
        let med = rel[rel.len() / 2];
        let mut abs: Vec<f64> = rel.iter().map(|x| x.abs()).collect();
        abs.sort_by(f64::total_cmp);
        eprintln!(
            "office_a L{id}: simulated vs Radiance luminance over {} pixels: median {:+.2} %, \
             median |.| {:.2} %, 90th pct |.| {:.2} %",
            rel.len(),
            100.0 * med,
            100.0 * abs[abs.len() / 2],
            100.0 * abs[abs.len() * 9 / 10]
        );
        medians.push(med);
    }
    eprintln!(
        "office_a world + 2 frames: {:.0} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
    assert!(medians.iter().all(|m| m.abs() < 0.01), "{medians:?}");
}

#[test]
fn replay_serves_the_files_byte_for_byte() {
    let dir = office_a().join("capture_clean");
    let ids: Vec<u32> = (1..=8).collect();
    let world = luxnode::camera::replay::ReplayWorld::open(&dir, &ids).unwrap();
    let mut lights = world.clone();
    let mut depth = world.depth_camera();
    let mut lum = world.luminance_camera();
    let png = |name: &str| {
        image::open(dir.join(name))
            .unwrap()
            .into_luma16()
            .into_raw()
    };
    let d = depth.capture_depth().unwrap();
    assert_eq!(d.depth_mm, png("depth_000.png"));
    assert_eq!(depth.camera().width, 320);
    for (k, id) in ids.iter().enumerate() {
        let mut levels = vec![0.0; ids.len()];
        levels[k] = 1.0;
        lights.set_levels(&levels).unwrap();
        let f = lum.capture_luminance().unwrap();
        assert_eq!(f.data, png(&format!("luminance_L{id}.png")), "L{id}");
        assert_eq!(f.cd_m2_per_unit, 0.02);
    }
    lights.set_levels(&[1.0; 8]).unwrap();
    assert_eq!(
        lum.capture_luminance().unwrap().data,
        png("luminance_all.png")
    );
    // a dimmed state is the weighted sum
    let mut levels = vec![0.0; 8];
    levels[2] = 0.5;
    lights.set_levels(&levels).unwrap();
    let half = lum.capture_luminance().unwrap().data;
    let l3 = png("luminance_L3.png");
    assert!(half.iter().zip(&l3).all(|(h, f)| if *f == u16::MAX {
        *h == u16::MAX
    } else {
        h.abs_diff(((f64::from(*f)) * 0.5).round() as u16) == 0
    }));
    assert!(lights.set_levels(&[1.0; 3]).is_err());

    // the sequence over the replay reproduces the capture set, and saving it gives the files back
    let mut depth = world.depth_camera();
    let cap = capture_sequence(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        1,
        0,
        &mut |_, _, _| {},
    )
    .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    luxnode::camera::save_capture(tmp.path(), &cap, None).unwrap();
    let again = luxnode::camera::capture::Capture::load(tmp.path(), &ids).unwrap();
    assert_eq!(again.camera, cap.camera);
    assert_eq!(again.depth_mm[0].data, png("depth_000.png"));
    assert_eq!(again.luminance[7].1.data, png("luminance_L8.png"));
}

mod a010 {
    use std::collections::VecDeque;
    use std::io::{ErrorKind, Read, Write};
    use std::time::Duration;

    use luxnode::camera::a010::{
        A010, A010Frame, A010Options, FrameError, FrameParser, encode, pixel_to_mm,
    };
    use luxnode::camera::{CameraError, DepthCamera};

    fn frame(id: u16, fill: impl Fn(usize) -> u8) -> A010Frame {
        A010Frame {
            command: 0,
            output_mode: 0,
            sensor_temp: 40,
            driver_temp: 38,
            exposure_raw: 500,
            error_code: 0,
            rows: 100,
            cols: 100,
            frame_id: id,
            isp_version: 3,
            pixels: (0..10_000).map(fill).collect(),
        }
    }

    #[test]
    fn layout_checksum_and_units() {
        let f = frame(0x1234, |i| (i % 251) as u8);
        let b = encode(&f);
        assert_eq!(b.len(), 10_022);
        assert_eq!(&b[..4], &[0x00, 0xFF, 0x20, 0x27]); // 16 + 10000 = 0x2720
        assert_eq!((b[14], b[15]), (100, 100));
        assert_eq!((b[16], b[17]), (0x34, 0x12));
        assert_eq!(b[10_021], 0xDD);
        let sum = b[..10_020].iter().map(|&x| u32::from(x)).sum::<u32>();
        assert_eq!(u32::from(b[10_020]), sum & 0xFF);
        // UNIT=0: (p/5.1)^2 mm; UNIT=k: p*k mm; 0 and 255: no return
        assert_eq!(pixel_to_mm(51, 0), 100);
        assert_eq!(pixel_to_mm(200, 10), 2000);
        assert_eq!((pixel_to_mm(0, 10), pixel_to_mm(255, 10)), (0, 0));
    }

    #[test]
    fn parser_resynchronises_over_garbage_truncation_and_bad_checksums() {
        let good: Vec<Vec<u8>> = (0..4u16)
            .map(|k| encode(&frame(k, |i| ((i + k as usize) % 250) as u8 + 1)))
            .collect();
        let mut stream = Vec::new();
        stream.extend_from_slice(b"OK\r\nOK\r\n\x00\x00\xff"); // AT replies, a false header
        stream.extend_from_slice(&good[0]);
        stream.extend_from_slice(&good[1][..5000]); // truncated: the next frame follows
        stream.extend_from_slice(&good[2]);
        let mut bad = good[3].clone();
        bad[500] ^= 0x40; // flipped bit: checksum
        stream.extend_from_slice(&bad);
        stream.extend_from_slice(&[0x00, 0xFF, 0xFF, 0xFF]); // impossible length
        stream.extend_from_slice(&good[3]);
        let mut p = FrameParser::new();
        let mut ids = Vec::new();
        let mut errors = Vec::new();
        // bytes arrive in odd-sized chunks
        for chunk in stream.chunks(777) {
            p.push(chunk);
            while let Some(r) = p.next_frame() {
                match r {
                    Ok(f) => ids.push(f.frame_id),
                    Err(e) => errors.push(e),
                }
            }
        }
        assert_eq!(ids, vec![0, 2, 3], "{errors:?}");
        assert!(
            errors
                .iter()
                .any(|e| matches!(e, FrameError::Checksum { .. }))
        );
        assert!(errors.iter().any(|e| matches!(e, FrameError::BadLength(_))));
        // the truncated frame swallowed the start of frame 2, whose checksum/tail then failed
        // at the truncated frame's position, and frame 2 was found again after it
        assert!(errors.len() >= 3, "{errors:?}");
        assert_eq!(p.buffered(), 0);
    }

    #[test]
    fn random_bytes_never_panic() {
        let mut rng = luxnode::rng::SplitMix64::new(3);
        let mut p = FrameParser::new();
        for _ in 0..200 {
            let chunk: Vec<u8> = (0..997)
                .map(|_| {
                    let r = rng.next_u64();
                    // plenty of header bytes
                    if r.is_multiple_of(7) {
                        0
                    } else if r.is_multiple_of(11) {
                        0xFF
                    } else {
                        r as u8
                    }
                })
                .collect();
            p.push(&chunk);
            while let Some(r) = p.next_frame() {
                assert!(r.is_err());
            }
            assert!(p.buffered() <= 10_022 + 997);
        }
    }

    /// A serial port that plays a script: data, silence (read timeouts), end of stream.
    enum Event {
        Data(Vec<u8>),
        Silence,
        Gone,
    }

    struct MockPort {
        script: VecDeque<Event>,
        written: Vec<u8>,
    }

    impl Read for MockPort {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            match self.script.pop_front() {
                Some(Event::Data(mut d)) => {
                    let n = d.len().min(buf.len());
                    buf[..n].copy_from_slice(&d[..n]);
                    if n < d.len() {
                        self.script.push_front(Event::Data(d.split_off(n)));
                    }
                    Ok(n)
                }
                Some(Event::Silence) | None => {
                    std::thread::sleep(Duration::from_millis(30));
                    Err(ErrorKind::TimedOut.into())
                }
                Some(Event::Gone) => Err(ErrorKind::BrokenPipe.into()),
            }
        }
    }

    impl Write for MockPort {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.written.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn camera() -> luxnode::scene::Camera {
        let mut c = luxnode::sim::demo::demo_office().camera.unwrap();
        c.width = 100;
        c.height = 100;
        c.cx = 49.5;
        c.cy = 49.5;
        c.fx = 71.4;
        c.fy = 86.6;
        c.lens = Default::default();
        c
    }

    #[test]
    fn driver_configures_reads_and_reports_faults() {
        let good = encode(&frame(7, |_| 200));
        let mut bad = encode(&frame(8, |_| 200));
        bad[100] ^= 1;
        let script = VecDeque::from(vec![
            Event::Data(b"OK\r\n".to_vec()),
            Event::Data(good[..3000].to_vec()),
            Event::Silence,
            Event::Data(good[3000..].to_vec()),
            Event::Data(bad),
            Event::Silence,
            Event::Silence,
            Event::Silence,
            Event::Silence,
            Event::Silence,
            Event::Silence,
            Event::Gone,
        ]);
        let port = MockPort {
            script,
            written: Vec::new(),
        };
        let o = A010Options {
            timeout: Duration::from_millis(100),
            ..A010Options::default()
        };
        let mut cam = A010::new(port, camera(), o, "mock-tof").unwrap();
        let w = String::from_utf8(cam.port().written.clone()).unwrap();
        assert_eq!(w, "AT+ISP=1\rAT+BINN=1\rAT+UNIT=10\rAT+FPS=10\rAT+DISP=2\r");
        let f = cam.capture_depth().unwrap();
        assert_eq!((f.width, f.height), (100, 100));
        assert!(f.depth_mm.iter().all(|&d| d == 2000));
        assert!((f.exposure_s - 500e-6).abs() < 1e-12);
        let e = cam.capture_depth().unwrap_err();
        assert!(matches!(e, CameraError::Garbage { .. }), "{e}");
        // the rest of the bad frame is skipped, then silence: a timeout
        let e = loop {
            match cam.capture_depth() {
                Err(CameraError::Garbage { .. }) => continue,
                other => break other.unwrap_err(),
            }
        };
        assert!(matches!(e, CameraError::Timeout { .. }), "{e}");
        let e = loop {
            match cam.capture_depth() {
                Err(CameraError::Timeout { .. }) => continue,
                other => break other.unwrap_err(),
            }
        };
        assert!(matches!(e, CameraError::Disconnected { .. }), "{e}");
        // a bad option is a configuration error
        let port = MockPort {
            script: VecDeque::new(),
            written: Vec::new(),
        };
        let o = A010Options {
            fps: 30,
            ..A010Options::default()
        };
        assert!(matches!(
            A010::new(port, camera(), o, "x").err(),
            Some(CameraError::Config(_))
        ));
    }
}

mod v4l2 {
    use luxnode::camera::v4l2::{PixelFormat, V4l2Options, decode, luma_table, srgb_to_linear};
    use std::time::Duration;

    #[test]
    fn srgb_decode_is_the_iec_curve() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-12);
        // continuous at the knee, and mid grey (code 0.5) is 21.4 % linear
        let k = 0.04045;
        assert!((srgb_to_linear(k) - ((k + 0.055) / 1.055f64).powf(2.4)).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.21404).abs() < 1e-4);
        let t = luma_table(false);
        assert_eq!((t[0], t[255]), (0, u16::MAX));
        assert!(t.windows(2).all(|w| w[0] < w[1]));
        let lim = luma_table(true);
        assert_eq!(lim[16], 0);
        assert!((f64::from(lim[235]) / 65535.0 - 1.0).abs() < 1e-4);
    }

    #[test]
    fn yuyv_and_grey_frames_decode_to_luminance() {
        // 4x2 YUYV: Y0 U Y1 V
        let bytes = [
            0, 128, 128, 128, 255, 128, 10, 128, //
            64, 1, 200, 2, 128, 3, 30, 4,
        ];
        let y = decode(&bytes, PixelFormat::Yuyv, 4, 2, false).unwrap();
        let t = luma_table(false);
        assert_eq!(
            y,
            vec![t[0], t[128], t[255], t[10], t[64], t[200], t[128], t[30]]
        );
        let g = decode(&[0, 128, 255, 10], PixelFormat::Grey, 2, 2, false).unwrap();
        assert_eq!(g, vec![t[0], t[128], t[255], t[10]]);
        assert!(decode(&bytes[..10], PixelFormat::Yuyv, 4, 2, false).is_err());
        let o = V4l2Options {
            width: 2,
            height: 2,
            format: PixelFormat::Grey,
            exposure_s: 0.01,
            calibration_cd_m2_s: 10.0,
            limited_range: false,
            timeout: Duration::from_secs(1),
        };
        let f = o.frame(&[0, 128, 255, 10], "mock").unwrap();
        // full scale at 10 ms: 1000 cd/m²; code 128 is 21.6 % of it
        let l = f.luminance_cd_m2(1, 0).unwrap();
        assert!(
            (l - 1000.0 * srgb_to_linear(128.0 / 255.0)).abs() < 0.02,
            "{l}"
        );
        assert_eq!(f.luminance_cd_m2(0, 1), None); // saturated
        assert!(matches!(
            o.frame(&[1, 2], "mock"),
            Err(luxnode::camera::CameraError::Garbage { .. })
        ));
    }
}

/// Registration of a colour camera of another size / intrinsics / pose onto the ToF grid,
/// against closed forms.
mod registration {
    use std::path::Path;
    use std::time::SystemTime;

    use glam::{DMat3, DVec3};
    use luxnode::board::Board;
    use luxnode::camera::capture::{Frame, SATURATED};
    use luxnode::camera::register::{RegistrationMap, Unmapped};
    use luxnode::camera::{
        CameraError, ColourFromTof, ColourIntrinsics, DepthCamera, LightControl, LuminanceCamera,
        Registration, SequenceOptions, capture_sequence_with,
    };
    use luxnode::camera::{DepthFrame, LuminanceFrame};
    use luxnode::scene::Camera;

    fn tof() -> Camera {
        Camera {
            position_m: DVec3::new(0.0, 0.0, 2.8),
            world_from_camera: DMat3::IDENTITY,
            fx: 70.0,
            fy: 70.0,
            cx: 49.5,
            cy: 49.5,
            width: 100,
            height: 100,
            luminance_cd_m2_per_unit: None,
            lens: Default::default(),
        }
    }

    fn depth(f: impl Fn(u32, u32) -> u16) -> Frame {
        Frame {
            width: 100,
            height: 100,
            data: (0..100 * 100).map(|i| f(i % 100, i / 100)).collect(),
        }
    }

    fn colour(w: u32, h: u32, f: impl Fn(u32, u32) -> u16) -> LuminanceFrame {
        LuminanceFrame {
            width: w,
            height: h,
            data: (0..w * h).map(|i| f(i % w, i / w)).collect(),
            cd_m2_per_unit: 0.01,
            timestamp: SystemTime::UNIX_EPOCH,
            exposure_s: 0.01,
        }
    }

    fn intrinsics(w: u32, h: u32, f: f64, k1: f64, k2: f64) -> ColourIntrinsics {
        ColourIntrinsics {
            width: w,
            height: h,
            fx: f,
            fy: f,
            cx: (f64::from(w) - 1.0) / 2.0,
            cy: (f64::from(h) - 1.0) / 2.0,
            k1,
            k2,
            lens: Default::default(),
        }
    }

    fn rot_z(deg: f64) -> [[f64; 3]; 3] {
        let (s, c) = deg.to_radians().sin_cos();
        [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    }

    /// The colour pixel a ToF pixel centre at depth z lands on, written out independently.
    fn closed_form(
        i: &ColourIntrinsics,
        e: &ColourFromTof,
        u: f64,
        v: f64,
        z_m: f64,
    ) -> (f64, f64) {
        let t = tof();
        let p = [(u - t.cx) / t.fx * z_m, (v - t.cy) / t.fy * z_m, z_m];
        let r = e.rotation;
        let q: Vec<f64> = (0..3)
            .map(|a| r[a][0] * p[0] + r[a][1] * p[1] + r[a][2] * p[2] + e.translation_m[a])
            .collect();
        let (x, y) = (q[0] / q[2], q[1] / q[2]);
        let r2 = x * x + y * y;
        let d = 1.0 + i.k1 * r2 + i.k2 * r2 * r2;
        (i.fx * x * d + i.cx, i.fy * y * d + i.cy)
    }

    #[test]
    fn identity_calibration_with_equal_intrinsics_is_the_identity() {
        let t = tof();
        let r = Registration::identity(&t).unwrap();
        let d = depth(|u, v| 1500 + ((u * 7 + v * 13) % 900) as u16);
        let c = colour(100, 100, |u, v| match (u, v) {
            (3, 4) => SATURATED,
            (5, 5) => 0,
            _ => ((u * 131 + v * 37) % 60000) as u16,
        });
        let out = r.register(&t, &d, &c).unwrap();
        assert_eq!((out.width, out.height), (100, 100));
        assert_eq!(out.data, c.data);
        assert_eq!(out.cd_m2_per_unit, c.cd_m2_per_unit);
    }

    #[test]
    fn a_plane_seen_from_a_colour_camera_with_a_baseline_matches_the_closed_form() {
        // 640 x 480, f = 550 px (ToF pixel ≈ 7.8 colour pixels: area-averaged), turned 2°
        // about the axis, 3 cm / 1 cm / 2 cm away; a plane at 2.5 m; colour = 1000 + 20 u + 10 v
        // (linear, so the footprint average is the value at the centre's image: the plane is
        // fronto-parallel and the mapping affine)
        let i = intrinsics(640, 480, 550.0, 0.0, 0.0);
        let e = ColourFromTof {
            rotation: rot_z(2.0),
            translation_m: [0.03, -0.01, 0.02],
        };
        let r = Registration::new(i.clone(), e.clone()).unwrap();
        let t = tof();
        let d = depth(|_, _| 2500);
        let c = colour(640, 480, |u, v| (1000 + 20 * u + 10 * v) as u16);
        let map = r.map(&t, &d).unwrap();
        let out = map.apply(&c).unwrap();
        let half_footprint = 550.0 / 70.0 * 2.5 / 2.52 / 2.0 * 1.5; // with the 2° turn, generous
        let (mut inside, mut outside) = (0, 0);
        for v in 0..100 {
            for u in 0..100 {
                let (uc, vc) = closed_form(&i, &e, f64::from(u), f64::from(v), 2.5);
                let got = out.data[(v * 100 + u) as usize];
                let m = half_footprint + 1.0;
                if uc > m && uc < 639.0 - m && vc > m && vc < 479.0 - m {
                    let want = 1000.0 + 20.0 * uc + 10.0 * vc;
                    assert!(
                        (f64::from(got) - want).abs() <= 0.5 + 1e-6,
                        "({u}, {v}): {got} vs {want}"
                    );
                    inside += 1;
                } else if uc < -0.5 - m || uc > 639.5 + m || vc < -0.5 - m || vc > 479.5 + m {
                    assert_eq!(got, 0, "({u}, {v}) is out of view");
                    assert_eq!(map.unmapped(u, v), Some(Unmapped::OutOfView));
                    outside += 1;
                }
            }
        }
        // the ToF sees ±35.5°, the colour camera ±30.2° × ±23.6°: both cases are common
        assert!(
            inside > 4000 && outside > 1500,
            "{inside} inside, {outside} outside"
        );
        let n = map.counts();
        assert_eq!(n.occluded + n.no_depth, 0, "{n:?}");
    }

    #[test]
    fn distortion_and_a_coarser_colour_camera_match_the_closed_form() {
        // 160 x 120 at f = 40 px: coarser than the ToF (bilinear at the pixel centre's image)
        let i = intrinsics(160, 120, 40.0, -0.1, 0.02);
        let e = ColourFromTof {
            rotation: rot_z(-3.0),
            translation_m: [-0.05, 0.02, 0.0],
        };
        let r = Registration::new(i.clone(), e.clone()).unwrap();
        let t = tof();
        let d = depth(|u, _| 2000 + 10 * u as u16); // a slanted plane
        let c = colour(160, 120, |u, v| (500 + 100 * u + 37 * v) as u16);
        let out = r.register(&t, &d, &c).unwrap();
        let mut n = 0;
        for v in 0..100 {
            for u in 0..100 {
                let z = f64::from(2000 + 10 * u) * 1e-3;
                let (uc, vc) = closed_form(&i, &e, f64::from(u), f64::from(v), z);
                if uc > 0.0 && uc < 159.0 && vc > 0.0 && vc < 119.0 {
                    let want = 500.0 + 100.0 * uc + 37.0 * vc;
                    let got = f64::from(out.data[(v * 100 + u) as usize]);
                    assert!(
                        (got - want).abs() <= 0.5 + 1e-6,
                        "({u}, {v}): {got} vs {want}"
                    );
                    n += 1;
                }
            }
        }
        assert!(n > 5000, "{n}");
    }

    #[test]
    fn a_nearer_box_occludes_the_floor_beside_it_in_the_colour_view() {
        // floor at 2.5 m, a box top at 1.5 m over ToF pixels 40..60 × 40..60; the colour camera
        // has the ToF's intrinsics, 20 cm to the side (+x). Closed form: the box top moves by
        // 70·0.2/1.5 = 9.33 px, the floor by 5.6 px: floor columns u − 5.6 ∈ [30.2, 50.2]
        // with u < 39.5 (u = 36..39), rows 40..59, are hidden behind the box.
        let t = tof();
        let i = intrinsics(100, 100, 70.0, 0.0, 0.0);
        let e = ColourFromTof {
            rotation: ColourFromTof::identity().rotation,
            translation_m: [-0.2, 0.0, 0.0],
        };
        let r = Registration::new(i, e).unwrap();
        let boxed = |u: u32, v: u32| (40..60).contains(&u) && (40..60).contains(&v);
        let d = depth(|u, v| if boxed(u, v) { 1500 } else { 2500 });
        let map: RegistrationMap = r.map(&t, &d).unwrap();
        let c = colour(100, 100, |_, _| 1234);
        let out = map.apply(&c).unwrap();
        let mut occluded = 0;
        for v in 0..100 {
            for u in 0..100 {
                let o = map.unmapped(u, v) == Some(Unmapped::Occluded);
                if o {
                    occluded += 1;
                    assert!(
                        (35..=40).contains(&u) && (39..=60).contains(&v),
                        "({u}, {v})"
                    );
                    assert_eq!(out.data[(v * 100 + u) as usize], 0);
                }
                if (37..=38).contains(&u) && (41..=58).contains(&v) {
                    assert!(o, "({u}, {v}) should be occluded");
                }
                if boxed(u, v) && u >= 46 {
                    assert_eq!(out.data[(v * 100 + u) as usize], 1234, "box top ({u}, {v})");
                }
            }
        }
        assert!((60..=100).contains(&occluded), "{occluded} occluded");
    }

    #[test]
    fn no_depth_and_saturated_colour_are_marked() {
        let t = tof();
        let i = intrinsics(640, 480, 550.0, 0.0, 0.0);
        let r = Registration::new(i, ColourFromTof::identity()).unwrap();
        let d = depth(|u, v| if (u, v) == (50, 50) { 0 } else { 2500 });
        // one saturated colour pixel near the image of ToF pixel (60, 50)
        let (su, sv): (f64, f64) = (319.5 + 10.5 * 550.0 / 70.0, 239.5 + 0.5 * 550.0 / 70.0);
        let c = colour(640, 480, |u, v| {
            if (u, v) == (su.round() as u32, sv.round() as u32) {
                SATURATED
            } else {
                2000
            }
        });
        let map = r.map(&t, &d).unwrap();
        let out = map.apply(&c).unwrap();
        assert_eq!(map.unmapped(50, 50), Some(Unmapped::NoDepth));
        assert_eq!(out.data[50 * 100 + 50], 0);
        let sat: Vec<usize> = (0..out.data.len())
            .filter(|&k| out.data[k] == SATURATED)
            .collect();
        assert!(!sat.is_empty() && sat.len() <= 4, "{sat:?}");
        assert!(
            sat.contains(&(50 * 100 + 60)) || sat.contains(&(51 * 100 + 61)),
            "{sat:?}"
        );
        assert_eq!(out.data[20 * 100 + 30], 2000);
    }

    #[test]
    fn bad_calibrations_are_clear_errors() {
        let ok = intrinsics(640, 480, 550.0, 0.0, 0.0);
        let id = ColourFromTof::identity();
        let err = |i: ColourIntrinsics, e: ColourFromTof| match Registration::new(i, e) {
            Err(CameraError::Config(m)) => m,
            other => panic!("{other:?}"),
        };
        assert!(
            err(
                ColourIntrinsics {
                    fx: 0.0,
                    ..ok.clone()
                },
                id.clone()
            )
            .contains("fx")
        );
        assert!(
            err(
                ColourIntrinsics {
                    fy: -5.0,
                    ..ok.clone()
                },
                id.clone()
            )
            .contains("fy")
        );
        assert!(
            err(
                ColourIntrinsics {
                    fx: f64::NAN,
                    ..ok.clone()
                },
                id.clone()
            )
            .contains("finite")
        );
        assert!(
            err(
                ColourIntrinsics {
                    cx: 900.0,
                    ..ok.clone()
                },
                id.clone()
            )
            .contains("cx")
        );
        assert!(
            err(
                ColourIntrinsics {
                    k1: -2.0,
                    ..ok.clone()
                },
                id.clone()
            )
            .contains("folds")
        );
        let mut scaled = id.clone();
        scaled.rotation[0][0] = 1.1;
        assert!(err(ok.clone(), scaled).contains("orthonormal"));
        let mut mirror = id.clone();
        mirror.rotation[2][2] = -1.0;
        assert!(err(ok.clone(), mirror).contains("reflection"));
        let mut inf = id.clone();
        inf.rotation[1][0] = f64::INFINITY;
        assert!(err(ok.clone(), inf).contains("finite"));
        let mm = ColourFromTof {
            translation_m: [30.0, 0.0, 0.0],
            ..id.clone()
        };
        assert!(err(ok.clone(), mm).contains("millimetres"));
        // a colour frame of another size than calibrated
        let r = Registration::new(ok, id).unwrap();
        let map = r.map(&tof(), &depth(|_, _| 2500)).unwrap();
        match map.apply(&colour(320, 240, |_, _| 1)) {
            Err(CameraError::Config(m)) => assert!(m.contains("640x480"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    struct PlaneDepth(Camera, u32);
    impl DepthCamera for PlaneDepth {
        fn camera(&self) -> &Camera {
            &self.0
        }
        fn capture_depth(&mut self) -> Result<DepthFrame, CameraError> {
            self.1 += 1;
            let k = self.1;
            Ok(DepthFrame {
                width: 100,
                height: 100,
                // a dropout per frame at a different place: the median hides it
                depth_mm: (0..10_000u32)
                    .map(|i| if i == k * 97 { 0 } else { 2500 })
                    .collect(),
                timestamp: SystemTime::UNIX_EPOCH,
                exposure_s: 0.001,
            })
        }
    }
    struct Pattern;
    impl LuminanceCamera for Pattern {
        fn capture_luminance(&mut self) -> Result<LuminanceFrame, CameraError> {
            Ok(colour(640, 480, |u, v| (1000 + 20 * u + 10 * v) as u16))
        }
    }
    struct NoLights;
    impl LightControl for NoLights {
        fn set_levels(&mut self, _: &[f64]) -> Result<(), CameraError> {
            Ok(())
        }
    }

    #[test]
    fn capture_sequence_registers_a_colour_camera_of_another_size() {
        let i = intrinsics(640, 480, 550.0, -0.05, 0.01);
        let e = ColourFromTof {
            rotation: rot_z(1.0),
            translation_m: [-0.03, 0.0, 0.0],
        };
        let r = Registration::new(i, e).unwrap();
        let o = SequenceOptions {
            depth_frames: 3,
            all_on_frame: false,
            registration: Some(r.clone()),
            ..SequenceOptions::default()
        };
        let mut d = PlaneDepth(tof(), 0);
        let s = capture_sequence_with(
            &mut d,
            &mut Pattern,
            &mut NoLights,
            &[1, 2],
            &o,
            &mut |_, _, _| {},
        )
        .unwrap();
        assert_eq!(s.capture.luminance.len(), 2);
        let want = r
            .register(
                &tof(),
                &depth(|_, _| 2500),
                &Pattern.capture_luminance().unwrap(),
            )
            .unwrap();
        for (_, f) in &s.capture.luminance {
            assert_eq!((f.width, f.height), (100, 100));
            assert_eq!(f.data, want.data);
        }
        assert!(s.capture.warnings.is_empty(), "{:?}", s.capture.warnings);
        // without the calibration the frames are refused as unregistered
        let o = SequenceOptions {
            registration: None,
            ..o
        };
        let mut d = PlaneDepth(tof(), 0);
        match capture_sequence_with(
            &mut d,
            &mut Pattern,
            &mut NoLights,
            &[1, 2],
            &o,
            &mut |_, _, _| {},
        ) {
            Err(CameraError::Config(m)) => {
                assert!(m.contains("[camera.colour.registration]"), "{m}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn boards_carry_a_validated_colour_registration() {
        for b in ["rpi4", "rock5b"] {
            let board = Board::load(Path::new(&format!("boards/{b}/board.toml"))).unwrap();
            let r = board.camera.registration().expect("a registration");
            assert!(r.intrinsics().width > 100, "{b}");
        }
        let text = std::fs::read_to_string("boards/rpi4/board.toml").unwrap();
        let path = Path::new("boards/rpi4/board.toml");
        let parse = |t: &str| Board::parse(t, path).map(|_| ()).map_err(|e| e.to_string());
        let unknown = text.replace("k2 = 0.01", "k2 = 0.01\nk3 = 0.001");
        let e = parse(&unknown).unwrap_err();
        assert!(e.contains("k3"), "{e}");
        let bent = text.replace("[[1.0, 0.0, 0.0],", "[[1.0, 0.2, 0.0],");
        let e = parse(&bent).unwrap_err();
        assert!(e.contains("orthonormal"), "{e}");
        let start = text.find("[camera.colour.registration]").unwrap();
        let end = text[start..].find("\n\n").unwrap() + start;
        let missing = format!("{}{}", &text[..start], &text[end + 2..]);
        // accepted (frames of the ToF's size need none); the capture sequence refuses 640 x 480
        let b = Board::parse(&missing, path).unwrap();
        assert!(b.camera.registration().is_none());
    }

    #[test]
    fn hardware_open_refuses_other_boards_and_reports_a_missing_calibration() {
        let sim = Board::load(Path::new("boards/sim/board.toml")).unwrap();
        match luxnode::board::hardware::open(&sim.camera) {
            Err(CameraError::Config(m)) => assert!(m.contains("hardware"), "{m}"),
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("opened a sim board"),
        }
        // a board whose ToF calibration (written at installation) is missing
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string("boards/rpi4/board.toml").unwrap();
        std::fs::write(dir.path().join("board.toml"), &text).unwrap();
        let rpi = Board::load(&dir.path().join("board.toml")).unwrap();
        match luxnode::board::hardware::open(&rpi.camera) {
            Err(CameraError::Config(m)) => assert!(m.contains("ToF calibration"), "{m}"),
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("opened without a calibration"),
        }
        // with the example calibration it gets as far as the device, which is not here
        let rpi = Board::load(Path::new("boards/rpi4/board.toml")).unwrap();
        match luxnode::board::hardware::open(&rpi.camera) {
            Err(e) => assert!(e.to_string().contains("/dev/ttyUSB0"), "{e}"),
            Ok(_) => panic!("opened a serial device that does not exist"),
        }
    }
}

/// The fisheye lens (Kannala-Brandt, equidistant) against closed forms.
mod fisheye {
    use glam::{DMat3, DVec3};
    use luxnode::camera::{ColourFromTof, ColourIntrinsics, Registration};
    use luxnode::scene::{Camera, Lens};

    fn cam(lens: Lens) -> Camera {
        Camera {
            position_m: DVec3::new(1.0, 2.0, 3.0),
            world_from_camera: DMat3::from_cols(DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z),
            fx: 100.0,
            fy: 100.0,
            cx: 159.5,
            cy: 119.5,
            width: 320,
            height: 240,
            luminance_cd_m2_per_unit: None,
            lens,
        }
    }

    /// r(θ) written out independently of the library.
    fn kb(theta: f64, k: [f64; 4]) -> f64 {
        theta
            + k[0] * theta.powi(3)
            + k[1] * theta.powi(5)
            + k[2] * theta.powi(7)
            + k[3] * theta.powi(9)
    }

    #[test]
    fn kannala_brandt_projects_known_angles_and_round_trips() {
        let k = [0.08, -0.02, 0.004, -0.0005];
        let c = cam(Lens::KannalaBrandt { k });
        c.check().unwrap();
        for (deg, az_deg) in [
            (0.0, 0.0),
            (5.0, 30.0),
            (30.0, 100.0),
            (60.0, 200.0),
            (85.0, 300.0),
        ] {
            let (t, a) = (f64::to_radians(deg), f64::to_radians(az_deg));
            // a world point 2 m from the camera at angle t off the axis, azimuth a
            let dir_cam = DVec3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos());
            let p = c.position_m + c.world_from_camera * dir_cam * 2.0;
            let (u, v) = c.project_world(p).unwrap();
            let r_px = kb(t, k) * 100.0;
            assert!((u - (159.5 + r_px * a.cos())).abs() < 1e-9, "{deg}°: u {u}");
            assert!((v - (119.5 + r_px * a.sin())).abs() < 1e-9, "{deg}°: v {v}");
            // back through the pixel: the same ray, and the point at its axial depth
            let d = c.ray_world(u, v).unwrap();
            assert!(
                (d - (p - c.position_m).normalize()).length() < 1e-10,
                "{deg}°"
            );
            let z = 2.0 * t.cos();
            let q = c.point_at_depth(u, v, z).unwrap();
            assert!((q - p).length() < 1e-9, "{deg}°: {q} vs {p}");
        }
        // beyond 89° and behind: no pixel; beyond the image circle of 89°: no ray
        let side = c.position_m + c.world_from_camera * DVec3::new(1.0, 0.0, 0.001);
        assert!(c.project_world(side).is_none());
        let r89 = kb(89f64.to_radians(), k) * 100.0;
        assert!(c.ray_world(159.5 + r89 + 1.0, 119.5).is_none());
        assert!(c.ray_world(159.5 + r89 - 1.0, 119.5).is_some());
    }

    #[test]
    fn pixel_solid_angles_add_up_to_the_cone() {
        // equidistant, f = 100 px: the pixels within r = 100 θ0 cover the cone of half-angle
        // θ0, 2π (1 − cos θ0) sr
        let c = cam(Lens::EQUIDISTANT);
        let theta0: f64 = 1.0;
        let mut sum = 0.0;
        for v in 0..240 {
            for u in 0..320 {
                let (du, dv) = (f64::from(u) - 159.5, f64::from(v) - 119.5);
                if du.hypot(dv) < 100.0 * theta0 {
                    sum += c.pixel_solid_angle_sr(f64::from(u), f64::from(v));
                }
            }
        }
        let want = 2.0 * std::f64::consts::PI * (1.0 - theta0.cos());
        assert!((sum - want).abs() < 0.01 * want, "{sum} sr vs {want} sr");
        // the pinhole's pixel at 45° off the axis: cos³ 45° / f²
        let p = cam(Lens::Pinhole);
        let got = p.pixel_solid_angle_sr(159.5 + 100.0, 119.5);
        assert!((got - 0.5f64.sqrt().powi(3) / 1e4).abs() < 1e-12);
    }

    #[test]
    fn camera_json_carries_the_lens_and_refuses_bad_ones() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("camera.json");
        let base = r#"{"position": [1, 2, 3], "R_world_from_camera": [[1, 0, 0], [0, -1, 0], [0, 0, -1]],
            "width": 320, "height": 240, "fx": 100, "fy": 100, "cx": 159.5, "cy": 119.5"#;
        let load = |extra: &str| {
            std::fs::write(&path, format!("{base}{extra}}}")).unwrap();
            luxnode::scene::load_camera_file(&path)
        };
        assert_eq!(load("").unwrap().lens, Lens::Pinhole);
        assert_eq!(
            load(r#", "model": "equidistant""#).unwrap().lens,
            Lens::EQUIDISTANT
        );
        let k = [0.01, -0.002, 0.0, 0.0];
        assert_eq!(
            load(r#", "model": "kannala_brandt", "k": [0.01, -0.002, 0, 0]"#)
                .unwrap()
                .lens,
            Lens::KannalaBrandt { k }
        );
        for (extra, says) in [
            (r#", "model": "kannala_brandt", "k": [1e9, 0, 0, 0]"#, "k1"),
            (
                r#", "model": "kannala_brandt", "k": [-0.5, 0, 0, 0]"#,
                "folds",
            ),
            (r#", "model": "fish""#, "not known"),
            (r#", "model": "pinhole", "k": [0.1, 0, 0, 0]"#, "pinhole"),
            (
                r#", "model": "equidistant", "k": [0.1, 0, 0, 0]"#,
                "equidistant",
            ),
        ] {
            let e = load(extra).unwrap_err().to_string();
            assert!(e.contains(says), "{extra}: {e}");
        }
        // a capture saved with a fisheye camera reads back with the same lens
        let c = cam(Lens::KannalaBrandt { k });
        let cap = luxnode::camera::capture::Capture {
            dir: dir.path().to_path_buf(),
            camera: c.clone(),
            depth_mm: vec![luxnode::camera::capture::Frame {
                width: 320,
                height: 240,
                data: vec![1000; 320 * 240],
            }],
            luminance: Vec::new(),
            off: None,
            off_end: None,
            warnings: Vec::new(),
        };
        let out = dir.path().join("cap");
        luxnode::camera::save_capture(&out, &cap, None).unwrap();
        let again = luxnode::scene::load_camera_file(&out.join("camera.json")).unwrap();
        assert_eq!(again.lens, c.lens);
    }

    #[test]
    fn a_fisheye_colour_camera_registers_by_the_closed_form() {
        // ToF: equidistant; colour: Kannala-Brandt, twice the resolution, 2 cm to the side.
        // A floor 2.5 m below: every ToF pixel's colour position is the closed form of its point.
        let tof = cam(Lens::EQUIDISTANT);
        let k = [0.05, -0.01, 0.0, 0.0];
        let colour = ColourIntrinsics {
            width: 640,
            height: 480,
            fx: 190.0,
            fy: 190.0,
            cx: 319.5,
            cy: 239.5,
            k1: 0.0,
            k2: 0.0,
            lens: Lens::KannalaBrandt { k },
        };
        let t = [0.02, 0.0, 0.0];
        let reg = Registration::new(
            colour.clone(),
            ColourFromTof {
                rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                translation_m: t,
            },
        )
        .unwrap();
        let mut checked = 0;
        for (u, v) in [(159.5, 119.5), (60.0, 50.0), (280.0, 180.0), (10.0, 119.5)] {
            let Some(p) = tof.point_at_depth_camera(u, v, 2.5) else {
                continue;
            };
            let q = [p.x + t[0], p.y + t[1], p.z + t[2]];
            let rho = q[0].hypot(q[1]);
            let th = rho.atan2(q[2]);
            let r = kb(th, k) * 190.0;
            let (uc, vc) = (319.5 + r * q[0] / rho, 239.5 + r * q[1] / rho);
            let (gu, gv, gz) = reg.project(p.to_array()).unwrap();
            assert!(
                (gu - uc).abs() < 1e-9 && (gv - vc).abs() < 1e-9,
                "({u}, {v})"
            );
            assert!((gz - 2.5).abs() < 1e-12);
            checked += 1;
        }
        assert_eq!(checked, 4);
        // pinhole distortion on a fisheye is refused, as is a folding lens
        assert!(
            Registration::new(
                ColourIntrinsics {
                    k1: 0.1,
                    ..colour.clone()
                },
                ColourFromTof::identity()
            )
            .is_err()
        );
        assert!(
            Registration::new(
                ColourIntrinsics {
                    lens: Lens::KannalaBrandt {
                        k: [-0.4, 0.0, 0.0, 0.0]
                    },
                    ..colour
                },
                ColourFromTof::identity()
            )
            .is_err()
        );
        // the identity registration of a fisheye ToF camera maps each pixel onto itself
        let id = Registration::identity(&tof).unwrap();
        let p = tof.point_at_depth_camera(37.0, 201.0, 2.0).unwrap();
        let (a, b, _) = id.project(p.to_array()).unwrap();
        assert!((a - 37.0).abs() < 1e-9 && (b - 201.0).abs() < 1e-9);
    }

    #[test]
    fn the_image_geometry_section_carries_the_lens_and_reads_old_sections() {
        use luxnode::store::geometry::{CameraRecord, GeometrySection, UnseenWallRecord};
        let k = [0.03, -0.008, 0.0005, 0.0];
        let section = GeometrySection {
            scene_name: "s".into(),
            preset: "balanced".into(),
            commissioned_unix_s: 1,
            software: "luxnode".into(),
            maintenance_factor: 0.8,
            groups: Vec::new(),
            patch_corners_m: Vec::new(),
            patch_group: Vec::new(),
            camera: Some(CameraRecord {
                position_m: [1.0, 2.0, 3.0],
                world_from_camera: [1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0],
                intrinsics_px: [105.0, 105.0, 159.5, 119.5],
                size_px: [320, 240],
                lens_k: Some(k),
            }),
            desks: Vec::new(),
            sensors: Vec::new(),
            luminaires: Vec::new(),
            photometries: Vec::new(),
            unseen_walls: vec![UnseenWallRecord {
                side: "x low".into(),
                at_m: -0.11,
                moved_m: 0.5,
            }],
        };
        let framed = section.encode().unwrap();
        let back = GeometrySection::decode(&framed[10..]).unwrap();
        assert_eq!(back, section);
        // a section of a build before the extensions: the camera is a pinhole, no wall unseen
        let old = postcard::to_stdvec(&section).unwrap();
        let back = GeometrySection::decode(&old).unwrap();
        assert_eq!(back.camera.unwrap().lens_k, None);
        assert!(back.unseen_walls.is_empty());
        // a wall placed at a position that is not a number is a corrupt section
        let mut bad = section.clone();
        bad.unseen_walls[0].at_m = f64::NAN;
        let framed = bad.encode().unwrap();
        assert!(GeometrySection::decode(&framed[10..]).is_err());
    }

    #[test]
    fn the_live_section_finds_every_desk_through_the_fisheye() {
        // live light projects the desk sensors through the camera's lens: the sim-fisheye
        // board's camera sees all 7 demo desks, the pinhole demo camera 3
        use luxnode::live_section::{SectionOptions, from_model};
        let o = &board_optics("boards/sim-fisheye/board.toml");
        let world = luxnode::sim::camera::SimWorld::demo_office().unwrap();
        let mut scene = luxnode::sim::demo::demo_office();
        let pinhole = scene.camera.clone().unwrap();
        for (camera, in_view) in [(o.apply(&pinhole), 7), (pinhole, 3)] {
            scene.camera = Some(camera);
            let (section, flags) =
                from_model(&scene, world.model(), &SectionOptions::default()).unwrap();
            let seen = section.windows.iter().filter(|w| !w.is_empty()).count();
            assert_eq!(seen, in_view, "{flags:?}");
            assert_eq!(flags.iter().filter(|&&f| f == 0).count(), in_view);
        }
    }

    #[test]
    fn the_fisheye_demo_office_commissions_from_its_cameras() {
        // the sim board's node (the README's main job): a fisheye that sees all 7 desks
        let o = &board_optics("boards/sim/board.toml");
        let base = super::demo();
        let mut scene = base.scene().clone();
        scene.camera = Some(o.apply(scene.camera.as_ref().unwrap()));
        let w = super::SimWorld::from_model(scene, base.model().clone()).unwrap();
        let (c, _) = super::commission_from_cameras(&w);
        let (err, got, want) = super::all_on_error(&c, &w);
        eprintln!(
            "fisheye demo office: all-on sensor error {:.2} % (mean abs / mean), got {got:.0?}, \
             world {want:.0?}; {} thin objects with a hidden face",
            100.0 * err,
            c.report.hidden_faces
        );
        // docs/cameras.md: 1.8 %
        assert!(err < 0.035, "{err}");
        assert!(c.report.hidden_faces >= 6, "{}", c.report.hidden_faces);
    }

    /// The optics a simulated board's file gives its camera.
    fn board_optics(path: &str) -> luxnode::board::camera::Optics {
        use luxnode::board::Board;
        use luxnode::board::camera::CameraBoard;
        let b = Board::load(std::path::Path::new(path)).unwrap();
        match b.camera {
            CameraBoard::Sim {
                optics: Some(o), ..
            } => o,
            c => panic!("{path}: {c:?}"),
        }
    }

    #[test]
    fn board_files_carry_checked_optics() {
        use luxnode::board::Board;
        let o = &board_optics("boards/sim-fisheye/board.toml");
        // the sim board (the README's main job) has the same node optics
        assert_eq!(&board_optics("boards/sim/board.toml"), o);
        assert_eq!(
            o.lens,
            Lens::KannalaBrandt {
                k: [0.03, -0.008, 0.0005, 0.0]
            }
        );
        let c = o.apply(&luxnode::sim::demo::demo_office().camera.unwrap());
        assert_eq!((c.fx, c.width, c.lens), (105.0, 320, o.lens));
        // every demo desk sensor is in this camera's image
        for s in &luxnode::sim::demo::demo_office().sensors {
            assert!(c.pixel_of(s.position_m).is_some(), "sensor {}", s.id);
        }
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string("boards/sim-fisheye/board.toml").unwrap();
        for (from, to, says) in [
            ("fx = 105.0", "fx = 1e-9", "fx"),
            (
                "k = [0.03, -0.008, 0.0005, 0.0]",
                "k = [-0.5, 0.0, 0.0, 0.0]",
                "folds",
            ),
            (
                "k = [0.03, -0.008, 0.0005, 0.0]",
                "k = [1e300, 0.0, 0.0, 0.0]",
                "k1",
            ),
            ("tilt_deg = 0.0", "tilt_deg = 95.0", "tilt_deg"),
            (
                "model = \"kannala_brandt\"",
                "model = \"fish\"",
                "not known",
            ),
            ("width = 320", "width = 100000", "image size"),
            (
                "tilt_deg = 0.0",
                "tilt_deg = 0.0\nposition_m = [1e9, 3.0, 2.78]",
                "position_m",
            ),
            (
                "tilt_deg = 0.0",
                "tilt_deg = 0.0\nposition_m = [nan, 3.0, 2.78]",
                "position_m",
            ),
        ] {
            assert!(text.contains(from), "{from}");
            let f = dir.path().join("board.toml");
            std::fs::write(&f, text.replace(from, to)).unwrap();
            let e = Board::load(&f).unwrap_err().to_string();
            assert!(e.contains(says), "{to}: {e}");
        }
        // a node's place in the room moves the camera, nothing else
        let f = dir.path().join("board.toml");
        std::fs::write(
            &f,
            text.replace(
                "tilt_deg = 0.0",
                "tilt_deg = 0.0\nposition_m = [2.0, 3.0, 2.78]",
            ),
        )
        .unwrap();
        let moved = board_optics(f.to_str().unwrap());
        let base = luxnode::sim::demo::demo_office().camera.unwrap();
        let (c0, c1) = (o.apply(&base), moved.apply(&base));
        assert_eq!(c1.position_m, DVec3::new(2.0, 3.0, 2.78));
        assert_eq!((c1.fx, c1.world_from_camera), (c0.fx, c0.world_from_camera));
    }
}
