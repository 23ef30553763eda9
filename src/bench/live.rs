//! `luxnode bench live`: what one live-light update costs (issue 12's target: ≤ 50 ms at
//! 320 × 240 on the development machine) and the memory the estimator holds.
//!
//! Method: the board's simulated room (its scene, its camera optics) is commissioned from its
//! simulated cameras with daylight in the room, exactly as the node does on a first boot, and
//! the live section is built from that capture. Frames for a set of conditions (night, daylight
//! at several dimming states, a person over a desk, a frame without depth) are rendered first;
//! then [`Live::update`] is timed frame by frame, cycling through them. Rendering is not timed:
//! on a node the frame comes from the camera. The boot cost (decoding the live section into
//! [`LiveModel`]) is timed on its own.

use std::time::Instant;

use crate::camera::{
    DepthCamera, LightControl, LuminanceCamera, SequenceOptions, capture_sequence_with,
};
use crate::commission::{self, CommissionOptions};
use crate::image_build::{ImageOptions, build_image, with_live};
use crate::live::{Live, LiveFrame, LiveModel, LiveSettings};
use crate::live_section::{self, SectionOptions};
use crate::scene::Scene;
use crate::sim::camera::{
    Occluder, SimDepthOptions, SimLuminanceOptions, SimWorld, WorldExtras, world_settings,
};
use crate::store::Image;

/// One condition the frames show.
#[derive(Debug, Clone)]
pub struct Condition {
    /// For the table.
    pub name: &'static str,
    /// Luminaire levels, 0..=1.
    pub levels: Vec<f64>,
    /// The world's extras (daylight, people).
    pub extras: WorldExtras,
    /// The depth frame is given.
    pub with_depth: bool,
}

/// The timings of one condition.
#[derive(Debug, Clone)]
pub struct ConditionTimes {
    /// The condition's name.
    pub name: &'static str,
    /// Update times, ms.
    pub update_ms: Vec<f64>,
}

/// What the bench measured.
#[derive(Debug, Clone)]
pub struct LiveBench {
    /// Frame size, pixels.
    pub width: u32,
    /// Frame size, pixels.
    pub height: u32,
    /// Samples in the live section.
    pub samples: usize,
    /// Patches the camera sees (two samples or more).
    pub seen_patches: usize,
    /// Patches of the model.
    pub patches: usize,
    /// Unknown-emitter groups.
    pub emitters: usize,
    /// Desk sensors.
    pub sensors: usize,
    /// Luminaires.
    pub luminaires: usize,
    /// The live section's size in the image, bytes.
    pub section_bytes: usize,
    /// [`LiveModel::memory_bytes`] after the first frames (the night basis built).
    pub model_bytes: usize,
    /// [`Live::memory_bytes`]: the model and the state between frames.
    pub live_bytes: usize,
    /// Decoding the section into the run-time model, ms.
    pub boot_ms: f64,
    /// Per condition.
    pub conditions: Vec<ConditionTimes>,
}

impl LiveBench {
    /// Every update time, ms.
    pub fn all_ms(&self) -> Vec<f64> {
        self.conditions
            .iter()
            .flat_map(|c| c.update_ms.iter().copied())
            .collect()
    }
}

/// (median, 95th percentile, max) of `v`, ms.
pub fn stats(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    if s.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let at = |q: f64| s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)];
    (at(0.5), at(0.95), s[s.len() - 1])
}

/// The conditions for a world with `n` luminaires; a person over the first desk with a sensor.
pub fn conditions(world: &SimWorld) -> Vec<Condition> {
    let n = world.luminaire_ids().len();
    let day = |w: f64| WorldExtras {
        window_exitance_lm_m2: w,
        ..WorldExtras::default()
    };
    let mixed: Vec<f64> = (0..n)
        .map(|j| [0.5, 0.2, 1.0, 0.0, 0.7, 0.3][j % 6])
        .collect();
    let person = world.scene().sensors.first().map(|s| {
        let c = s.position_m;
        Occluder {
            lo_m: glam::DVec3::new(c.x - 0.25, c.y - 0.2, c.z + 0.05),
            hi_m: glam::DVec3::new(c.x + 0.25, c.y + 0.2, 1.4),
            rho: 0.3,
        }
    });
    let mut out = vec![
        Condition {
            name: "night, all on",
            levels: vec![1.0; n],
            extras: day(0.0),
            with_depth: true,
        },
        Condition {
            name: "daylight 1500 lm/m², all on",
            levels: vec![1.0; n],
            extras: day(1500.0),
            with_depth: true,
        },
        Condition {
            name: "daylight 3000 lm/m², mixed dimming",
            levels: mixed.clone(),
            extras: day(3000.0),
            with_depth: true,
        },
        Condition {
            name: "daylight 800 lm/m², all off",
            levels: vec![0.0; n],
            extras: day(800.0),
            with_depth: true,
        },
        Condition {
            name: "no depth frame",
            levels: mixed,
            extras: day(1500.0),
            with_depth: false,
        },
    ];
    if let Some(p) = person {
        out.push(Condition {
            name: "a person over a desk",
            levels: vec![1.0; n],
            extras: WorldExtras {
                window_exitance_lm_m2: 1500.0,
                occluders: vec![p],
                ..WorldExtras::default()
            },
            with_depth: true,
        });
    }
    out
}

/// A simulated room commissioned from its cameras as a first boot does (the world's extras as
/// they are: daylight during the capture is subtracted with the all-off frame).
pub struct DaylightCommissioning {
    /// The image with its live section.
    pub image: Vec<u8>,
    /// The same image without it.
    pub image_without_live: Vec<u8>,
    /// The live section.
    pub section: crate::image_build::LiveSectionData,
    /// Per-sensor flags of the commissioning (out of view, ...).
    pub sensor_flags: Vec<u8>,
}

/// Commissions `world` from its simulated cameras (default options), with the geometry section
/// for reports when `geometry` is set.
pub fn commission_in_daylight(
    world: &SimWorld,
    geometry: bool,
) -> Result<DaylightCommissioning, String> {
    let e = |x: &dyn std::fmt::Display| x.to_string();
    let ids = world.luminaire_ids();
    let mut depth = world
        .depth_camera(SimDepthOptions::default())
        .map_err(|x| e(&x))?;
    let mut lum = world
        .luminance_camera(SimLuminanceOptions::default())
        .map_err(|x| e(&x))?;
    let mut lights = world.clone();
    let seq = capture_sequence_with(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        &SequenceOptions::default(),
        &mut |_, _, _| {},
    )
    .map_err(|x| e(&x))?;
    if seq.capture.off.is_none() {
        return Err("the capture sequence took no all-off frame".into());
    }
    let sc = world.scene();
    let c = commission::from_capture(
        &seq.capture,
        sc.luminaires.clone(),
        sc.sensors.clone(),
        sc.desks.clone(),
        &CommissionOptions::default(),
    )
    .map_err(|x| e(&x))?;
    let img = build_image(
        &c.model,
        &ImageOptions {
            sensor_flags: c.sensor_flags.clone(),
            geometry: geometry.then(|| {
                crate::image_geometry::section_of(
                    &c.scene,
                    &c.model,
                    &crate::image_geometry::CommissionRecord::default(),
                )
            }),
            ..ImageOptions::default()
        },
    )
    .map_err(|x| e(&x))?;
    let section = live_section::from_capture(&c, &seq.capture, &SectionOptions::default())
        .map_err(|x| e(&x))?;
    let image = with_live(&img, Some(&section)).map_err(|x| e(&x))?;
    Ok(DaylightCommissioning {
        image,
        image_without_live: img,
        section,
        sensor_flags: c.sensor_flags,
    })
}

/// Runs the bench on `scene` (with the board's optics applied): `frames` timed updates in all.
pub fn run(scene: Scene, frames: usize) -> Result<LiveBench, String> {
    if !(1..=100_000).contains(&frames) {
        return Err(format!("{frames} frames: 1..=100000"));
    }
    let e = |x: &dyn std::fmt::Display| x.to_string();
    let world = SimWorld::new(scene, &world_settings()).map_err(|x| e(&x))?;
    // commissioning in daylight, as on a first boot
    world.set_extras(WorldExtras {
        window_exitance_lm_m2: 1500.0,
        ..WorldExtras::default()
    });
    let c = commission_in_daylight(&world, false)?;
    let (bytes, img) = (c.image, c.image_without_live);
    let image = Image::parse(&bytes).map_err(|x| e(&x))?;
    let t = Instant::now();
    let model = LiveModel::new(&image).map_err(|x| e(&x))?;
    let boot_ms = t.elapsed().as_secs_f64() * 1e3;
    let (width, height) = model.frame_size();
    let (samples, seen_patches, emitters) =
        (model.samples(), model.seen_patches(), model.emitters());
    let mut live = Live::new(model, LiveSettings::default()).map_err(|x| e(&x))?;
    // the frames, rendered once
    let conds = conditions(&world);
    let mut rendered = Vec::with_capacity(conds.len());
    for cond in &conds {
        world.set_extras(cond.extras.clone());
        let mut l = world.clone();
        l.set_levels(&cond.levels).map_err(|x| e(&x))?;
        let f = world
            .luminance_camera(SimLuminanceOptions::default())
            .map_err(|x| e(&x))?
            .capture_luminance()
            .map_err(|x| e(&x))?;
        let d = world
            .depth_camera(SimDepthOptions::default())
            .map_err(|x| e(&x))?
            .capture_depth()
            .map_err(|x| e(&x))?;
        rendered.push((f, d));
    }
    let mut times: Vec<ConditionTimes> = conds
        .iter()
        .map(|c| ConditionTimes {
            name: c.name,
            update_ms: Vec::new(),
        })
        .collect();
    for i in 0..frames {
        let k = i % conds.len();
        let (f, d) = &rendered[k];
        let frame = LiveFrame {
            width: f.width,
            height: f.height,
            luminance: &f.data,
            cd_m2_per_unit: f.cd_m2_per_unit,
            depth_mm: conds[k].with_depth.then_some(d.depth_mm.as_slice()),
            taken_s: i as f64,
        };
        let t = Instant::now();
        let desks = live
            .update(&frame, &conds[k].levels, i as f64)
            .map_err(|x| e(&x))?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        if desks.iter().any(|d| !d.total_lx.is_finite()) {
            return Err(format!("{}: a value that is not finite", conds[k].name));
        }
        times[k].update_ms.push(ms);
    }
    Ok(LiveBench {
        width,
        height,
        samples,
        seen_patches,
        patches: image.patches(),
        emitters,
        sensors: image.sensors(),
        luminaires: image.luminaires(),
        section_bytes: bytes.len() - img.len(),
        model_bytes: live.model().memory_bytes(),
        live_bytes: live.memory_bytes(),
        boot_ms,
        conditions: times,
    })
}
