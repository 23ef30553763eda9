//! A board's cameras and lights: for commissioning (the rig), for live light, for the sensor
//! probe; the simulated ones are the sim board's ([`super::sim`]), the others a recorded
//! capture or the hardware.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::AssembleError;
use crate::board::camera::{CameraBoard, ColourBoard, TofBoard};
use crate::board::{Board, SceneSource};
use crate::camera::replay::ReplayWorld;
use crate::camera::{DepthCamera, LightControl, LuminanceCamera, SequenceOptions};
use crate::daemon::SensorProbe;
use crate::daemon::live::{FrameSource, LiveTask, OpenedCameras, camera_source};
use crate::daemon::source::AmbientAtCommissioning;
use crate::fieldbus::gateway::GatewayWriter;
use crate::peripherals::node::LevelsHook;
use crate::scene::Scene;

/// What a commissioning capture needs: a name, the two cameras, the lights.
pub type Rig = (
    String,
    Box<dyn DepthCamera>,
    Box<dyn LuminanceCamera>,
    Box<dyn LightControl>,
);

/// What the simulated ALS sees, set once the simulated world exists.
pub type LightSlot = Arc<Mutex<Option<Box<dyn Fn() -> f64 + Send>>>>;

/// The board's cameras and lights over `scene` (the simulated world with the board's optics, a
/// recorded capture, or the hardware), `None` for hardware cameras without a DALI gateway to
/// switch the luminaires. With an ambient light sensor on a simulated board, `light` and
/// `levels_hook` are set so the simulated sensor reads what the world sends up to it.
pub fn rig(
    board: &Board,
    scene: &Scene,
    ambient: Option<&AmbientAtCommissioning>,
    light: &LightSlot,
    levels_hook: &mut Option<LevelsHook>,
) -> Result<Option<Rig>, AssembleError> {
    let rig: Rig = match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim { .. } => super::sim::rig(board, scene, ambient, light, levels_hook)?,
        CameraBoard::Replay { dir } => {
            let ids: Vec<u32> = scene.luminaires.iter().map(|l| l.id).collect();
            let world = ReplayWorld::open(dir, &ids)?;
            (
                format!("recorded capture {}", dir.display()),
                Box::new(world.depth_camera()),
                Box::new(world.luminance_camera()),
                Box::new(world),
            )
        }
        CameraBoard::Hardware { .. } => {
            let Some(gateway) = &board.modbus.gateway else {
                return Ok(None);
            };
            let (d, c) = crate::board::hardware::open(&board.camera)?;
            let lights = GatewayWriter::connect(gateway)?;
            (
                format!("A010 ToF + V4L2 colour cameras of board {}", board.name),
                d,
                c,
                Box::new(lights),
            )
        }
    };
    #[cfg(not(feature = "sim"))]
    let _ = (ambient, light, levels_hook);
    Ok(Some(rig))
}

/// The capture sequence's settings for a board's cameras.
pub fn sequence_options(board: &Board) -> SequenceOptions {
    match &board.camera {
        // lamp run-up / DALI fade, and auto exposure catching up, on real hardware
        CameraBoard::Hardware { .. } => SequenceOptions {
            registration: board.camera.registration().cloned(),
            settle: Duration::from_millis(500),
            discard_after_switch: 2,
            ..SequenceOptions::default()
        },
        _ => SequenceOptions::default(),
    }
}

/// Live light's cameras at run time (`[live]`): the simulated cameras over the board's scene
/// (their room follows the node's dimming state), a recorded capture replayed at the node's
/// levels, or the hardware cameras (opened again at each failure).
pub fn live_task(board: &Board) -> Option<LiveTask> {
    if !board.live.enabled {
        tracing::info!("live: off (board [live] enabled = false)");
        return None;
    }
    let capture: FrameSource = match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim { .. } => super::sim::live_cameras(board)?,
        CameraBoard::Replay { dir } => replay_live(dir.clone(), board.scene.clone()),
        CameraBoard::Hardware { .. } => {
            // the colour frames resampled onto the ToF grid through each frame's depth, with
            // the calibration commissioning used (the board's, or the camera module's EEPROM)
            let camera = board.camera.clone();
            let registration = board.camera.registration().cloned();
            camera_source(
                move || -> Result<OpenedCameras, String> {
                    let (d, c) =
                        crate::board::hardware::open(&camera).map_err(|e| e.to_string())?;
                    Ok((d, c, None))
                },
                registration,
            )
        }
    };
    Some(LiveTask {
        period: board.live.period,
        settings: crate::live::LiveSettings::default(),
        capture,
        occupancy_hold_s: board.occupancy_hold_s,
        occupancy_static_after_s: board.occupancy_static_after_s,
    })
}

/// A recorded capture replayed at the node's levels.
fn replay_live(dir: std::path::PathBuf, scene_source: SceneSource) -> FrameSource {
    camera_source(
        move || -> Result<OpenedCameras, String> {
            let ids: Vec<u32> = match &scene_source {
                SceneSource::Directory(d) => Scene::load(d, &Default::default())
                    .map_err(|e| e.to_string())?
                    .luminaires
                    .iter()
                    .map(|l| l.id)
                    .collect(),
                SceneSource::DemoOffice => {
                    return Err("a recorded capture needs the scene's directory".into());
                }
            };
            let world = ReplayWorld::open(&dir, &ids).map_err(|e| e.to_string())?;
            Ok((
                Box::new(world.depth_camera()),
                Box::new(world.luminance_camera()),
                Some(Box::new(world)),
            ))
        },
        None,
    )
}

/// The sensors' health check while serving: simulated cameras take a frame (through their
/// fault injector, so an injected disconnect shows); hardware cameras must still be there
/// (their device nodes open); a recorded capture has nothing to check.
pub fn sensor_probe(board: &Board) -> Option<SensorProbe> {
    let every = board.sensor_check;
    let probe: Box<dyn FnMut() -> Result<(), String> + Send> = match &board.camera {
        #[cfg(feature = "sim")]
        CameraBoard::Sim { .. } => super::sim::probe(board)?,
        CameraBoard::Replay { .. } => return None,
        CameraBoard::Hardware { tof, colour } => {
            let tof = match tof {
                TofBoard::A010 { device, .. } | TofBoard::V4l2 { device, .. } => device,
            };
            let ColourBoard::V4l2 { device: video, .. } = colour;
            let devices = [tof.clone(), video.clone()];
            Box::new(move || {
                for d in &devices {
                    std::fs::OpenOptions::new()
                        .read(true)
                        .open(d)
                        .map_err(|e| format!("{d}: {e}"))?;
                }
                Ok(())
            })
        }
    };
    Some(SensorProbe { every, probe })
}
