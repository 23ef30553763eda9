//! The sim board's parts (feature `sim`): its simulated cameras over the board's scene (with
//! the board's optics), for commissioning, live light and the sensor probe; the demo office;
//! the simulated controller.

use std::time::Duration;

use super::cameras::{LightSlot, Rig};
use super::{AssembleError, SimController};
use crate::board::camera::{CameraBoard, Optics};
use crate::board::{Board, SceneSource};
use crate::camera::{DepthCamera, FaultInjector, LuminanceCamera};
use crate::daemon::Companion;
use crate::daemon::live::{FrameSource, OpenedCameras, camera_source};
use crate::daemon::source::AmbientAtCommissioning;
use crate::peripherals::node::LevelsHook;
use crate::scene::Scene;
use crate::sim::camera::{SimWorld, world_settings};

/// The scene with the board's camera optics (`[camera.sim.optics]`) on its camera.
pub fn with_optics(mut scene: Scene, optics: Option<&Optics>) -> Scene {
    if let (Some(o), Some(c)) = (optics, scene.camera.as_ref()) {
        scene.camera = Some(o.apply(c));
    }
    scene
}

/// The board's scene, loaded again on a camera's thread.
fn load_scene(source: &SceneSource) -> Result<Scene, String> {
    Ok(match source {
        SceneSource::DemoOffice => crate::sim::demo::demo_office(),
        SceneSource::Directory(dir) => {
            Scene::load(dir, &Default::default()).map_err(|e| e.to_string())?
        }
    })
}

/// The simulated cameras and lights over `scene`; with an ambient light sensor, `light` and
/// `levels_hook` are set so the simulated sensor reads what the world sends up to it.
pub(super) fn rig(
    board: &Board,
    scene: &Scene,
    ambient: Option<&AmbientAtCommissioning>,
    light: &LightSlot,
    levels_hook: &mut Option<LevelsHook>,
) -> Result<Rig, AssembleError> {
    let CameraBoard::Sim {
        depth,
        luminance,
        faults,
        optics,
        ..
    } = &board.camera
    else {
        return Err(AssembleError::Config(format!(
            "board {}: not simulated cameras",
            board.name
        )));
    };
    // the simulated room is the scene; the node sees it only through the cameras (with the
    // board's optics, when it gives them)
    let world = SimWorld::new(
        with_optics(scene.clone(), optics.as_ref()),
        &world_settings(),
    )
    .map_err(|e| AssembleError::Config(format!("board {}: simulated cameras: {e}", board.name)))?;
    if let Some(a) = ambient {
        // the simulated ALS reads what the world sends up to it at the current levels, with
        // the running scenario's ageing and daylight
        let (p, n) = a.pose;
        let (p, n) = (glam::DVec3::from_array(p), glam::DVec3::from_array(n));
        let per = world.receiver_lx(p, n, &a.response, 20_000);
        let day = world.receiver_daylight_lx(p, n, &a.response, 20_000);
        let w = world.clone();
        *light.lock().unwrap_or_else(|p| p.into_inner()) = Some(Box::new(move || {
            let x = w.extras();
            let art: f64 = w
                .levels()
                .iter()
                .zip(&per)
                .enumerate()
                .map(|(l, (level, e))| level * x.ageing.get(l).copied().unwrap_or(1.0) * e)
                .sum();
            art + x.window_exitance_lm_m2 * day
        }));
        let w = world.clone();
        *levels_hook = Some(Box::new(move |l: &[f64]| w.follow_levels(l)));
    }
    let d = world.depth_camera(depth.clone())?;
    let c = world.luminance_camera(luminance.clone())?;
    let (d, c): (Box<dyn DepthCamera>, Box<dyn LuminanceCamera>) = match faults {
        Some(f) => (
            Box::new(FaultInjector::new(d, f.clone(), "simulated ToF camera")?),
            Box::new(FaultInjector::new(c, f.clone(), "simulated colour camera")?),
        ),
        None => (Box::new(d), Box::new(c)),
    };
    Ok((
        format!("simulated ToF + colour cameras over {}", scene.name),
        d,
        c,
        Box::new(world),
    ))
}

/// Live light's simulated cameras over the board's scene: one world for the node's life, so
/// cameras opened again after a failure see the same room, and a scenario runs on from where
/// it was. With `[camera.sim.faults]` the cameras go through the fault injector as at
/// commissioning (issue 34: live light ignored them), its seed advanced at each opening so a
/// camera opened again after a fault does not replay the same faults.
pub(super) fn live_cameras(board: &Board) -> Option<FrameSource> {
    let CameraBoard::Sim {
        depth,
        luminance,
        optics,
        scenario,
        faults,
    } = &board.camera
    else {
        return None;
    };
    let (scene_source, depth, luminance, optics, scenario, faults) = (
        board.scene.clone(),
        depth.clone(),
        luminance.clone(),
        optics.clone(),
        scenario.clone(),
        faults.clone(),
    );
    let mut opened: u64 = 0;
    let mut world: Option<SimWorld> = None;
    Some(camera_source(
        move || -> Result<OpenedCameras, String> {
            if world.is_none() {
                // the same camera as at commissioning: the board's optics
                let scene = with_optics(load_scene(&scene_source)?, optics.as_ref());
                let w = SimWorld::new(scene, &world_settings()).map_err(|e| e.to_string())?;
                if let Some(s) = &scenario {
                    tracing::info!(
                        "live: the simulated room runs the board's scenario from now on"
                    );
                    w.start_scenario(s.clone());
                }
                world = Some(w);
            }
            let Some(world) = world.clone() else {
                return Err("no simulated world".into());
            };
            let d = world
                .depth_camera(depth.clone())
                .map_err(|e| e.to_string())?;
            let c = world
                .luminance_camera(luminance.clone())
                .map_err(|e| e.to_string())?;
            let Some(f) = &faults else {
                return Ok((Box::new(d), Box::new(c), Some(Box::new(world))));
            };
            let f = crate::camera::Faults {
                seed: f.seed.wrapping_add(opened),
                ..f.clone()
            };
            opened += 1;
            let d = FaultInjector::new(d, f.clone(), "simulated ToF camera")
                .map_err(|e| e.to_string())?;
            let c =
                FaultInjector::new(c, f, "simulated colour camera").map_err(|e| e.to_string())?;
            Ok((Box::new(d), Box::new(c), Some(Box::new(world))))
        },
        None,
    ))
}

/// The sensor probe of simulated cameras: the ToF camera takes a frame (through its fault
/// injector, so an injected disconnect shows); it is built at the first check (on the probe's
/// thread), not before the node serves.
pub(super) fn probe(board: &Board) -> Option<Box<dyn FnMut() -> Result<(), String> + Send>> {
    let CameraBoard::Sim {
        depth,
        faults,
        optics,
        ..
    } = &board.camera
    else {
        return None;
    };
    let (scene_source, depth, faults, optics) = (
        board.scene.clone(),
        depth.clone(),
        faults.clone(),
        optics.clone(),
    );
    let mut cam: Option<Box<dyn DepthCamera>> = None;
    Some(Box::new(move || {
        if cam.is_none() {
            let scene = with_optics(load_scene(&scene_source)?, optics.as_ref());
            let world = SimWorld::new(scene, &world_settings()).map_err(|e| e.to_string())?;
            let c = world
                .depth_camera(depth.clone())
                .map_err(|e| e.to_string())?;
            cam = Some(match &faults {
                Some(f) => Box::new(
                    FaultInjector::new(c, f.clone(), "simulated ToF camera")
                        .map_err(|e| e.to_string())?,
                ),
                None => Box::new(c),
            });
        }
        let Some(c) = cam.as_mut() else {
            return Err("no camera".into());
        };
        c.capture_depth()
            .map(|_| ())
            .map_err(|e| format!("ToF camera: {e}"))
    }))
}

/// The sim board's simulated controller: steps through dimming states over Modbus TCP and
/// prints the live table on stdout (the program's output: the sim board's demo); the node
/// stops after it unless `forever`.
pub(super) fn controller(c: &SimController) -> (Companion, bool) {
    let c = crate::sim::controller::SimController {
        period: Duration::from_millis(c.step_ms),
        cycles: c.cycles,
        forever: c.forever,
    };
    let stops = !c.forever;
    let task: Companion = Box::new(move |addr| {
        Box::pin(async move {
            let mut out = std::io::stdout();
            if let Err(e) = c.run(addr, &mut out).await {
                tracing::error!("simulated controller: {e}");
            }
        })
    });
    (task, stops)
}
