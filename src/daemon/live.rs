//! The node's live-light task (`crate::live`): every period (board `[live] period_s`, default
//! 10 s) it takes a luminance frame (and a depth frame) from the board's cameras on a blocking
//! thread, runs the estimator at the node's current dimming state, and publishes the result: the
//! live registers (per desk total, artificial and daylight lux, source, flags, frame age; per
//! luminaire the ageing factor), the daylight for the lighting control (`Node::set_daylight`,
//! only while it is fresh) and the ageing factors (`Node::set_ageing`, the control plant). Frames
//! are used and dropped: no image leaves the node.
//!
//! A camera that fails or gives rejected frames leaves the last good values in place, flagged
//! held, then stale ([`LiveSettings::stale_after_s`]); the node keeps serving the model.

use std::time::{Duration, Instant};

use super::occupancy::OccupancyTracker;
use crate::camera::{DepthCamera, LightControl, LuminanceCamera};
use crate::live::{DeskLive, Live, LiveFrame, LiveModel, LiveSettings, Source, Verdict};
use crate::modbus::regmap::{LiveDesk, LiveSource, live_status};
use crate::node::{Node, SharedNode, lock};
use crate::store::Image;

/// One frame from the board's cameras, registered to the ToF grid.
#[derive(Debug, Clone, PartialEq)]
pub struct CapturedFrame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear luminance (0 no data, 65535 saturated).
    pub luminance: Vec<u16>,
    /// cd/m² per unit.
    pub cd_m2_per_unit: f64,
    /// Depth along the optical axis, mm, when the board has a depth frame.
    pub depth_mm: Option<Vec<u16>>,
    /// The luminaires' levels when the frame was taken (the node's, read before the capture).
    pub levels: Vec<f64>,
}

/// Takes one frame (blocking), given the luminaires' levels now (a simulated or recorded room
/// shows them; real cameras ignore them).
pub type FrameSource = Box<dyn FnMut(&[f64]) -> Result<CapturedFrame, String> + Send>;

/// The cameras a frame source opens (at its first frame, on the task's thread): depth, colour
/// (registered to the depth grid), and for a simulated or recorded room its light control.
pub type OpenedCameras = (
    Box<dyn DepthCamera>,
    Box<dyn LuminanceCamera>,
    Option<Box<dyn LightControl + Send>>,
);

/// A frame source over cameras opened at the first frame (and opened again after an error).
///
/// Without `registration` (simulated and recorded rooms: the colour frames are on the ToF grid
/// already) the luminance frame, then the depth frame (a depth failure leaves the frame without
/// depth: the estimator then judges covering from the luminance alone). With it (hardware: a
/// colour camera of its own resolution and pose), the depth frame first, then the colour frame
/// resampled onto the ToF grid through that depth exactly as at commissioning
/// ([`Registration::register`](crate::camera::Registration::register)); without a depth frame
/// there is nothing to register onto, and the frame is an error.
pub fn camera_source(
    mut open: impl FnMut() -> Result<OpenedCameras, String> + Send + 'static,
    registration: Option<crate::camera::Registration>,
) -> FrameSource {
    let mut cams: Option<OpenedCameras> = None;
    Box::new(move |levels: &[f64]| {
        if cams.is_none() {
            cams = Some(open()?);
        }
        let Some((depth, colour, lights)) = cams.as_mut() else {
            return Err("no camera".into());
        };
        if let Some(l) = lights.as_mut() {
            l.set_levels(levels).map_err(|e| e.to_string())?;
        }
        let registered = match &registration {
            None => None,
            Some(r) => {
                let d = match depth.capture_depth() {
                    Ok(d) => d,
                    Err(e) => {
                        cams = None;
                        return Err(format!(
                            "ToF camera: {e} (the colour frame needs its depth)"
                        ));
                    }
                };
                Some((r, d))
            }
        };
        let lum = match colour.capture_luminance() {
            Ok(f) => f,
            Err(e) => {
                cams = None;
                return Err(format!("colour camera: {e}"));
            }
        };
        let (lum, depth_mm) = match registered {
            Some((r, d)) => {
                let lum = r
                    .register(depth.camera(), &d.to_frame(), &lum)
                    .map_err(|e| format!("registering the colour frame: {e}"))?;
                (lum, Some(d.depth_mm))
            }
            None => {
                let depth_mm = match depth.capture_depth() {
                    Ok(d) if d.width == lum.width && d.height == lum.height => Some(d.depth_mm),
                    Ok(_) => None,
                    Err(e) => {
                        tracing::debug!("live: ToF camera: {e}");
                        None
                    }
                };
                (lum, depth_mm)
            }
        };
        Ok(CapturedFrame {
            width: lum.width,
            height: lum.height,
            luminance: lum.data,
            cd_m2_per_unit: lum.cd_m2_per_unit,
            depth_mm,
            levels: levels.to_vec(),
        })
    })
}

/// The live task as the board configures it.
pub struct LiveTask {
    /// Frame period.
    pub period: Duration,
    /// The estimator's settings.
    pub settings: LiveSettings,
    /// The cameras.
    pub capture: FrameSource,
    /// Occupancy's hold, s (board `[occupancy] hold_s`).
    pub occupancy_hold_s: f64,
    /// Occupancy's motion over frames: still this long is a thing, s (board `[occupancy]
    /// static_after_s`).
    pub occupancy_static_after_s: f64,
}

/// Live light over a booted image: the estimator, or why not (logged by the caller).
pub fn estimator(image: &Image<'_>, settings: &LiveSettings) -> Result<Live, String> {
    let model = LiveModel::new(image).map_err(|e| e.to_string())?;
    tracing::info!(
        "live: {} samples over {} seen patches, {} emitter groups, {} of {} desks in view, {:.1} MB",
        model.samples(),
        model.seen_patches(),
        model.emitters(),
        (0..model.sensors()).filter(|&s| model.in_view(s)).count(),
        model.sensors(),
        model.memory_bytes() as f64 / 1e6
    );
    Live::new(model, settings.clone()).map_err(|e| e.to_string())
}

fn register(d: &DeskLive) -> LiveDesk {
    LiveDesk {
        total_lx: d.total_lx,
        artificial_lx: d.artificial_lx,
        daylight_lx: d.daylight_lx,
        uncertainty_lx: d.uncertainty_lx,
        source: match d.source {
            Source::Model => LiveSource::Model,
            Source::Measured => LiveSource::Measured,
            Source::Inferred => LiveSource::Inferred,
        },
        flags: d.flags,
        frame_age_s: d.frame_age_s,
    }
}

/// The firmware's date: a wall clock earlier than this was never set (an RTC without a
/// battery, no NTP yet), and the sky fit is not given its time (`live_status::CLOCK_UNSET`).
pub const FIRMWARE_DATE: &str = "2026-11-26T00:00:00Z";

/// The wall clock's time for the sky fit, or `None` when the clock is not set (before
/// [`FIRMWARE_DATE`]).
pub fn wall_clock() -> Option<crate::sky::UnixTime> {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .ok()?;
    let floor = crate::sky::parse_rfc3339(FIRMWARE_DATE).ok()?;
    let t = crate::sky::UnixTime::from_seconds(i64::try_from(now.as_secs()).ok()?);
    (t.as_seconds_f64() >= floor.as_seconds_f64()).then_some(t)
}

/// What the task remembers between frames.
#[derive(Debug, Clone, Copy, Default)]
pub struct StepState {
    /// When the last frame was used (task clock, s).
    pub last_used_s: Option<f64>,
}

/// One period: the frame (or the camera's error) into the estimator at the node's dimming state,
/// the result into the node. `now_s` and the frame's time are on the task's clock. Returns the
/// live status bits published.
pub fn step(
    live: &mut Live,
    state: &mut StepState,
    frame: Result<CapturedFrame, String>,
    taken_s: f64,
    node: &mut Node,
    now_s: f64,
) -> u16 {
    let levels: Vec<f64> = node.levels().to_vec();
    let mut status = live_status::ON;
    let known = node.dimming_known();
    // the levels changed while the frame was taken: the frame shows neither state (nor, on
    // hardware, a fade between them), so it is not used; the desks keep their last daylight at
    // the new state, flagged held, until the next frame
    let moved = frame.as_ref().is_ok_and(|f| {
        f.levels.len() != levels.len()
            || f.levels
                .iter()
                .zip(&levels)
                .any(|(a, b)| (a - b).abs() > 1e-9)
    });
    if moved {
        tracing::debug!("live: the dimming state changed during the frame; frame skipped");
    }
    if live.has_sky() {
        let t = wall_clock();
        if t.is_none() {
            status |= live_status::CLOCK_UNSET;
        }
        live.set_time(t);
    }
    let result = match (&frame, known && !moved) {
        (Ok(f), true) => live.update(
            &LiveFrame {
                width: f.width,
                height: f.height,
                luminance: &f.luminance,
                cd_m2_per_unit: f.cd_m2_per_unit,
                depth_mm: f.depth_mm.as_deref(),
                taken_s,
            },
            &levels,
            now_s,
        ),
        _ => live.no_frame(&levels, now_s),
    };
    if let Err(e) = result {
        tracing::warn!("live: {e}");
    }
    match &frame {
        Err(e) => {
            tracing::warn!("live: no frame: {e}");
            status |= live_status::FRAME_REJECTED;
        }
        Ok(_) if !known => {
            tracing::debug!("live: dimming state not known yet; frame skipped");
        }
        Ok(_) if moved => {
            // no new frame used: the night bit stays that of the last frame used
            if live
                .report()
                .is_some_and(|r| r.verdict == Verdict::Ok && r.night)
            {
                status |= live_status::NIGHT;
            }
        }
        Ok(_) => match live.report() {
            Some(r) if r.verdict == Verdict::Ok => {
                state.last_used_s = Some(taken_s);
                if r.night {
                    status |= live_status::NIGHT;
                }
            }
            Some(r) => {
                tracing::warn!("live: frame rejected ({})", r.verdict.describe());
                status |= live_status::FRAME_REJECTED;
            }
            None => {}
        },
    }
    if live.report().is_some_and(|r| r.recommission) {
        status |= live_status::RECOMMISSION;
    }
    let age = state.last_used_s.map_or(f64::NAN, |t| (now_s - t).max(0.0));
    if age.is_nan() || age > live.settings().stale_after_s {
        status |= live_status::CAMERA_STALE;
    }
    let desks: Vec<LiveDesk> = live.desks().iter().map(register).collect();
    node.set_live(&desks, live.ageing(), status, age);
    let max_age = node.control_options().daylight_max_age_s;
    if let Some(d) = live.daylight_for_control(max_age) {
        node.set_daylight(&d);
    }
    status
}

/// The task: a frame every period until aborted; each depth frame also goes through
/// occupancy when the node has it ([`OccupancyTracker`]).
pub async fn live_loop(
    mut task: LiveTask,
    mut live: Live,
    mut occupancy: Option<OccupancyTracker>,
    node: SharedNode,
) {
    let health = lock(&node).health().clone();
    let beat = health.register("live light", task.period * 3 + Duration::from_secs(60));
    let mut tick = tokio::time::interval(task.period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let t0 = Instant::now();
    let mut state = StepState::default();
    loop {
        tick.tick().await;
        let mut capture = task.capture;
        let levels = lock(&node).levels().to_vec();
        let (frame, capture) = tokio::task::spawn_blocking(move || {
            let f = capture(&levels);
            (f, capture)
        })
        .await
        .unwrap_or_else(|e| {
            // the camera thread panicked: no camera from here on
            let dead: FrameSource = Box::new(|_: &[f64]| Err("the camera thread died".into()));
            (Err(format!("the camera thread failed: {e}")), dead)
        });
        task.capture = capture;
        let taken_s = t0.elapsed().as_secs_f64();
        // the estimator runs on a blocking thread too (tens of ms)
        let node2 = node.clone();
        let done = tokio::task::spawn_blocking(move || {
            // occupancy's work before the node's lock, its result published under it
            let occupied = occupancy.as_mut().map(|o| {
                let u = o.update(frame.as_ref(), taken_s, t0.elapsed().as_secs_f64());
                (&*o, u)
            });
            let mut n = lock(&node2);
            if let Some((o, u)) = occupied {
                o.publish(&u, &mut n);
            }
            let now_s = t0.elapsed().as_secs_f64();
            step(&mut live, &mut state, frame, taken_s, &mut n, now_s);
            (live, state, occupancy)
        })
        .await;
        match done {
            Ok((l, st, o)) => {
                live = l;
                state = st;
                occupancy = o;
                beat.beat();
            }
            Err(e) => {
                // a bug: the task ends, its missing beats stop the watchdog's petting
                tracing::error!("live: the estimator failed: {e}; live light stops");
                return;
            }
        }
    }
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;
    use crate::camera::Registration;
    use crate::sim::camera::{SimDepthOptions, SimLuminanceOptions, SimWorld};

    fn source(registration: Option<Registration>) -> FrameSource {
        camera_source(
            move || -> Result<OpenedCameras, String> {
                let w = SimWorld::demo_office().map_err(|e| e.to_string())?;
                let d = w
                    .depth_camera(SimDepthOptions {
                        dropout_chance: 0.0,
                        flying_pixel_chance: 0.0,
                        range_noise_rel: 0.0,
                        ..SimDepthOptions::default()
                    })
                    .map_err(|e| e.to_string())?;
                let c = w
                    .luminance_camera(SimLuminanceOptions::default())
                    .map_err(|e| e.to_string())?;
                Ok((Box::new(d), Box::new(c), Some(Box::new(w))))
            },
            registration,
        )
    }

    #[test]
    fn registered_frames_come_through_the_depth_like_at_commissioning() {
        let w = SimWorld::demo_office().unwrap();
        let identity = Registration::identity(w.camera()).unwrap();
        let levels = vec![1.0; w.luminaire_ids().len()];
        let plain = source(None)(&levels).unwrap();
        let reg = source(Some(identity))(&levels).unwrap();
        assert_eq!((reg.width, reg.height), (plain.width, plain.height));
        assert_eq!(reg.cd_m2_per_unit, plain.cd_m2_per_unit);
        assert!(reg.depth_mm.is_some());
        // the identity registration resamples every pixel with depth onto itself
        let depth = reg.depth_mm.as_ref().unwrap();
        let (mut same, mut with_depth) = (0usize, 0usize);
        for ((a, b), z) in reg.luminance.iter().zip(&plain.luminance).zip(depth) {
            if *z > 0 {
                with_depth += 1;
                same += usize::from(a.abs_diff(*b) <= 1);
            }
        }
        assert!(with_depth > 70_000, "{with_depth}");
        assert!(same * 1000 >= with_depth * 999, "{same} of {with_depth}");
    }
}

#[cfg(test)]
mod clock_tests {
    use super::*;

    /// The firmware's date parses, and this machine's clock (set: CI and development machines
    /// run NTP) reads after it, so the sky fit gets its time; a date far ahead would not.
    #[test]
    fn the_firmware_date_is_a_valid_floor_for_the_clock() {
        let floor = crate::sky::parse_rfc3339(FIRMWARE_DATE).expect("FIRMWARE_DATE parses");
        let t = wall_clock().expect("this machine's clock is set");
        assert!(t.as_seconds_f64() >= floor.as_seconds_f64());
        assert!(
            crate::sky::parse_rfc3339("2999-01-01T00:00:00Z")
                .expect("parses")
                .seconds
                > t.seconds
        );
    }
}
