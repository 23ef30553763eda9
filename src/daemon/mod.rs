//! The node: `luxnode run --board FILE`.
//!
//! ```text
//! boot: flash (A/B slots) ── newest image that loads ─────────────────────────────┐
//!         │ none loads              (parse, validate, register map; else the older slot) ▼
//!         └─► commission ─► the same load path ─► write image (keeping the running one) ─► serve
//! serve: Modbus TCP (+ TLS, RTU) over the image; dimming from the holding registers (writes
//!        from the allowlist only) or the DALI gateway; every part supervised; systemd READY,
//!        WATCHDOG only while every part is alive; SIGHUP reloads the board file, SIGUSR1 logs a
//!        status report, SIGTERM or Ctrl-C: clean shutdown.
//! ```
//!
//! First boot commissions through a [`CommissionSource`] (the board decides which: cameras, a
//! recorded capture, or a CAD scene) and writes the image; later boots load it. Nothing here
//! knows a board or a simulator: [`DaemonConfig`] is built from the board file by the binary,
//! the flash device is opened by the caller (who may wrap it in a fault injector), and a
//! [`Companion`] task (the sim board's simulated controller) is only a closure to the daemon.
//!
//! Everything the daemon has to say goes out as `tracing` events (journald-friendly when
//! stderr is not a terminal); it never prints.

pub mod assemble;
pub mod live;
pub mod occupancy;
pub mod source;
pub mod systemd;

use std::future::Future;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::engine::EngineError;
use crate::image_build::{BuildError, ImageOptions};
use crate::modbus::regmap::Identity;
use crate::node::health::Health;
use crate::node::{Node, NodeError, NodeModel, NodeOptions, SharedNode, lock};
use crate::serve::{Reload, ServeError, ServeOptions, Signals, serve_node, wait_for_stop};
use crate::store::devices::{DeviceError, FileFlash};
use crate::store::file::{FileError, read_bootable};
use crate::store::slots::{BootStatus, FlashDevice, SlotState, Slots, WriteError};
use crate::store::{Image, ImageError};

/// Why commissioning produced no image.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The engine failed on the scene.
    #[error("engine: {0}")]
    Engine(#[from] EngineError),
    /// The image could not be built (or does not fit the flash region).
    #[error("image: {0}")]
    Build(#[from] BuildError),
    /// The capture failed (a camera, or switching the lights).
    #[error("capture: {0}")]
    Capture(#[from] crate::camera::CameraError),
    /// Commissioning from the capture failed.
    #[error("commissioning: {0}")]
    Commission(#[from] crate::commission::CommissionError),
    /// This source cannot commission, and says why.
    #[error("{0}")]
    Unavailable(String),
}

/// Why the node stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    /// The flash device failed.
    #[error("flash {}: {source}", path.display())]
    Flash {
        /// The device.
        path: PathBuf,
        /// Why.
        source: DeviceError,
    },
    /// Reading the booted image back failed.
    #[error(transparent)]
    File(#[from] FileError),
    /// Commissioning failed.
    #[error("commissioning from {from}: {source}")]
    Commission {
        /// The source.
        from: String,
        /// Why.
        source: SourceError,
    },
    /// Writing the new image failed (the previous image, if any, is untouched).
    #[error("writing the image to {}: {reason}", path.display())]
    Write {
        /// The device.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The image just written does not boot.
    #[error("the image just written does not boot: {0}")]
    NotBootable(String),
    /// The booted image does not parse.
    #[error("the booted image: {0}")]
    Image(#[from] ImageError),
    /// The register map refused the image.
    #[error("the booted image: {0}")]
    Node(#[from] NodeError),
    /// Serving failed.
    #[error(transparent)]
    Serve(#[from] ServeError),
}

/// Where the first boot's model comes from.
pub trait CommissionSource {
    /// What it is, for the log ("simulated cameras over the demo office", ...).
    fn describe(&self) -> String;
    /// Commissions the room; returns the flash image.
    fn commission(&mut self) -> Result<Vec<u8>, SourceError>;
}

/// Commissioning from a CAD scene (no cameras): the engine on the scene as given.
pub struct CadSource {
    /// The scene.
    pub scene: crate::scene::Scene,
    /// Engine settings.
    pub settings: crate::engine::Settings,
    /// Image settings.
    pub image: ImageOptions,
    /// The commissioning record and where the report goes.
    pub report: source::ReportTarget,
}

impl CommissionSource for CadSource {
    fn describe(&self) -> String {
        format!(
            "CAD scene {} ({} triangles, {} luminaires, {} sensors)",
            self.scene.name,
            self.scene.mesh.triangles.len(),
            self.scene.luminaires.len(),
            self.scene.sensors.len()
        )
    }

    fn commission(&mut self) -> Result<Vec<u8>, SourceError> {
        check_served(self.scene.sensors.len(), self.scene.luminaires.len())?;
        let model = crate::engine::compute_model(&self.scene, &self.settings)?;
        let mut options = self.image.clone();
        if options.scene_name.is_empty() {
            options.scene_name = self.scene.name.clone();
        }
        options.geometry = Some(self.report.section(&self.scene, &model));
        let bytes = crate::image_build::build_for_region(
            &model,
            &options,
            crate::image_build::formfactors_region_bytes(),
        )?;
        self.report.write(&bytes);
        Ok(bytes)
    }
}

/// Refuses, before any work, a room the node could not serve.
pub fn check_served(desks: usize, luminaires: usize) -> Result<(), SourceError> {
    let limits = crate::image_build::served_limits(desks, luminaires);
    if limits.is_empty() {
        Ok(())
    } else {
        Err(SourceError::Build(BuildError::Served(limits.join("; "))))
    }
}

/// A source that cannot commission, and says why (a board whose cameras cannot commission
/// yet still boots a valid image from flash).
pub struct Unavailable(pub String);

impl CommissionSource for Unavailable {
    fn describe(&self) -> String {
        "no commissioning source".into()
    }

    fn commission(&mut self) -> Result<Vec<u8>, SourceError> {
        Err(SourceError::Unavailable(self.0.clone()))
    }
}

/// An image commissioned elsewhere (several nodes of one room merged on a laptop or another
/// node), checked when read, installed as the next generation.
pub struct ImageFile {
    /// Where it came from, for the log.
    pub path: std::path::PathBuf,
    /// The image.
    pub bytes: Vec<u8>,
}

impl CommissionSource for ImageFile {
    fn describe(&self) -> String {
        format!("the image {}", self.path.display())
    }

    fn commission(&mut self) -> Result<Vec<u8>, SourceError> {
        Ok(self.bytes.clone())
    }
}

/// A task that runs beside the servers once they listen (the sim board's simulated controller),
/// given the bound Modbus TCP address.
pub type Companion = Box<dyn FnOnce(SocketAddr) -> Pin<Box<dyn Future<Output = ()> + Send>> + Send>;

/// A health check of the sensors (cameras), run every `every` while the node serves: an error
/// clears the "sensors healthy" status bit (and says why in the log); the next success sets it.
pub struct SensorProbe {
    /// Period.
    pub every: Duration,
    /// The check (blocking; runs on a blocking thread).
    pub probe: Box<dyn FnMut() -> Result<(), String> + Send>,
}

/// Everything the daemon needs, resolved from the board file.
pub struct DaemonConfig {
    /// Board name (device identification's model name).
    pub board: String,
    /// The flash device's path, for the log and errors.
    pub flash_path: PathBuf,
    /// Modbus and gateway.
    pub serve: ServeOptions,
    /// A companion task, and whether the daemon stops when it ends.
    pub companion: Option<(Companion, bool)>,
    /// Re-commission even if a valid image exists.
    pub recommission: bool,
    /// Re-reads the configuration on SIGHUP.
    pub reload: Option<Reload>,
    /// The sensors' health check.
    pub sensor_probe: Option<SensorProbe>,
    /// Live light: the cameras at run time (runs when the image has a live section).
    pub live: Option<live::LiveTask>,
    /// The node's peripherals (ambient light sensor, status LED; none by default).
    pub peripherals: crate::peripherals::node::Peripherals,
    /// The ambient light check's reference file (written at commissioning).
    pub ambient_reference: Option<PathBuf>,
}

/// How the daemon ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Exit {
    /// Signal, `run_for`, or the companion finished.
    Stopped,
    /// The (simulated) power failed during the image write.
    PowerCut,
}

/// Opens (creating it if needed) a flash file of `capacity` bytes.
pub fn open_flash_file(path: &Path, capacity: usize) -> Result<FileFlash, DaemonError> {
    let flash = |source| DaemonError::Flash {
        path: path.to_owned(),
        source,
    };
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|source| {
            flash(DeviceError::Io {
                path: dir.to_owned(),
                source,
            })
        })?;
    }
    FileFlash::open(path, capacity).map_err(flash)
}

/// An image the node can run.
#[derive(Debug)]
pub struct BootedImage {
    /// Its bytes.
    pub bytes: Vec<u8>,
    /// Its generation.
    pub generation: u64,
    /// The slots as the CRCs saw them.
    pub status: BootStatus,
    /// The store is healthy: no slot damaged, none refused by the load path.
    pub store_ok: bool,
    /// The sensors were healthy (false: a re-commissioning failed on a camera and the node
    /// runs its last good image).
    pub sensors_ok: bool,
}

/// What [`boot`] found or made.
#[derive(Debug)]
pub enum Booted {
    /// An image to serve.
    Image(BootedImage),
    /// The simulated power failed during the image write.
    PowerCut,
}

/// The whole load path's last step, given by the caller: the register map takes the image.
pub type Accept<'a> = &'a mut dyn FnMut(&Image<'_>, u64) -> Result<(), String>;

/// Boots from `flash`: the newest image that passes the whole load path (parse, validation,
/// `accept`), falling back to the older slot; or commissions, checks the new image through the
/// same path before writing it (an image the node would refuse is never written), writes it
/// keeping the image it runs, and loads it back.
pub fn boot<F>(
    flash: F,
    flash_path: &Path,
    source: &mut dyn CommissionSource,
    recommission: bool,
    accept: Accept<'_>,
) -> Result<Booted, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
    boot_with(flash, flash_path, source, recommission, accept, &|| {})
}

/// [`boot`], calling `commissioning` when it starts to commission (the LED shows it).
pub fn boot_with<F>(
    flash: F,
    flash_path: &Path,
    source: &mut dyn CommissionSource,
    recommission: bool,
    accept: Accept<'_>,
    commissioning: &dyn Fn(),
) -> Result<Booted, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
    let mut slots = Slots::new(flash);
    let found = read_bootable(&mut slots, &mut *accept);
    let status = found.status;
    tracing::info!(flash = %flash_path.display(), "boot: {status}");
    let store_ok = found.refused.is_empty() && !damaged(status.a) && !damaged(status.b);
    let running = found.image.as_ref().map(|(_, slot, g)| (*slot, *g));
    if !recommission && let Some((bytes, slot, generation)) = found.image {
        tracing::info!(
            "boot: loaded image generation {generation} ({} bytes) from slot {slot}",
            bytes.len()
        );
        return Ok(Booted::Image(BootedImage {
            bytes,
            generation,
            status,
            store_ok,
            sensors_ok: true,
        }));
    }
    let from = source.describe();
    tracing::info!(
        "boot: {}; commissioning from {from}",
        if recommission {
            "re-commissioning requested"
        } else {
            "no valid image"
        }
    );
    commissioning();
    let t0 = Instant::now();
    let image = match source.commission() {
        Ok(i) => i,
        Err(e) => {
            // a failed re-commissioning never costs the node its last good image
            if let Some((bytes, slot, generation)) = found.image {
                let camera = matches!(e, SourceError::Capture(_));
                tracing::error!(
                    "commissioning from {from} failed: {e}; running the last good image \
                     (generation {generation}, slot {slot}){}",
                    if camera { "; sensors not healthy" } else { "" }
                );
                return Ok(Booted::Image(BootedImage {
                    bytes,
                    generation,
                    status,
                    store_ok,
                    sensors_ok: !camera,
                }));
            }
            return Err(DaemonError::Commission { from, source: e });
        }
    };
    tracing::info!(
        "commissioned in {:.1} s: image of {} bytes",
        t0.elapsed().as_secs_f64(),
        image.len()
    );
    // the whole load path before anything is written
    let next = running.map_or(1, |(_, g)| g.saturating_add(1));
    let parsed = Image::parse(&image).map_err(|e| {
        DaemonError::NotBootable(format!("the commissioned image does not parse: {e}"))
    })?;
    accept(&parsed, next).map_err(|e| {
        DaemonError::NotBootable(format!(
            "the commissioned image would not load: {e}; nothing written"
        ))
    })?;
    let report = match slots.write_image_keeping(&image, running.map(|r| r.0)) {
        Ok(report) => {
            tracing::info!(
                "flash: image written to slot {} as generation {}, verified",
                report.slot,
                report.generation
            );
            report
        }
        Err(WriteError::Device(DeviceError::PowerCut)) => {
            tracing::error!(
                "flash: POWER CUT during the image write (simulated); the node stops here"
            );
            return Ok(Booted::PowerCut);
        }
        Err(e) => {
            return Err(DaemonError::Write {
                path: flash_path.to_owned(),
                reason: e.to_string(),
            });
        }
    };
    let again = read_bootable(&mut slots, &mut *accept);
    tracing::info!("boot: {}", again.status);
    match again.image {
        Some((bytes, slot, generation)) if slot == report.slot => Ok(Booted::Image(BootedImage {
            bytes,
            generation,
            status: again.status,
            store_ok: again.refused.is_empty()
                && !damaged(again.status.a)
                && !damaged(again.status.b),
            sensors_ok: true,
        })),
        _ => Err(DaemonError::NotBootable(again.status.to_string())),
    }
}

/// A slot that holds something other than an image or erased flash.
fn damaged(s: SlotState) -> bool {
    match s {
        SlotState::Invalid(e) => e != ImageError::Erased,
        SlotState::Unreadable => true,
        SlotState::Valid { .. } => false,
    }
}

/// How long the LED shows the fault pattern before the node exits with an error.
pub const FAULT_LINGER: Duration = Duration::from_secs(2);

/// Runs the node until a signal, `run_for`, or the end of a stopping companion.
pub fn run<F>(
    mut config: DaemonConfig,
    flash: F,
    source: &mut dyn CommissionSource,
) -> Result<Exit, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
    let led = config
        .peripherals
        .led
        .take()
        .map(|l| Arc::new(crate::peripherals::node::LedMonitor::spawn(l)));
    let r = run_inner(config, flash, source, led.clone());
    if let (Err(_), Some(l)) = (&r, &led) {
        l.set(NodeState::Fault);
        std::thread::sleep(FAULT_LINGER);
    }
    r
}

use crate::peripherals::led::NodeState;

/// The node's options from the daemon's configuration: the board's name in the device
/// identification, the servers' settings, the shared health.
fn node_options(config: &DaemonConfig, health: &Arc<Health>) -> NodeOptions {
    let mut identity = Identity::default();
    for c in config.board.chars() {
        if identity.model.push(c).is_err() {
            break;
        }
    }
    let _ = identity.application.push_str("commissioned room");
    NodeOptions {
        identity,
        gateway_configured: config.serve.gateway.is_some(),
        initial_arc: config.serve.initial_arc,
        policy: config.serve.access.clone(),
        settings_path: config.serve.settings_path.clone(),
        health: Some(health.clone()),
        control: config.serve.control.clone(),
    }
}

fn run_inner<F>(
    mut config: DaemonConfig,
    flash: F,
    source: &mut dyn CommissionSource,
    led: Option<Arc<crate::peripherals::node::LedMonitor>>,
) -> Result<Exit, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
    // the runtime and the signal handlers first: a SIGHUP or SIGUSR1 during commissioning
    // must not kill the node
    let rt = crate::serve::runtime()?;
    let signals = {
        let _enter = rt.enter();
        Signals::install().map_err(ServeError::Io)?
    };
    let health = Arc::new(Health::default());
    for f in &config.peripherals.open_faults {
        tracing::error!("peripherals: {f}");
    }
    let show = |s: NodeState| {
        if let Some(l) = &led {
            l.set(s);
            tracing::info!("status LED: {}", s.name());
        }
    };
    show(NodeState::Booting);
    let options = node_options(&config, &health);
    let mut accept = |image: &Image<'_>, generation: u64| -> Result<(), String> {
        let probe = NodeOptions {
            settings_path: None,
            ..options.clone()
        };
        Node::new(NodeModel::from_image(image, generation), probe)
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    let booted = match boot_with(
        flash,
        &config.flash_path,
        source,
        config.recommission,
        &mut accept,
        &|| show(NodeState::Commissioning),
    )? {
        Booted::Image(b) => b,
        Booted::PowerCut => return Ok(Exit::PowerCut),
    };
    let image = Image::parse(&booted.bytes)?;
    let model = NodeModel::from_image(&image, booted.generation);
    let mut node = Node::new(model, options)?;
    if !booted.store_ok {
        tracing::warn!("store: a slot holds a damaged or unloadable image; running from the other");
    }
    node.set_store_ok(booted.store_ok);
    node.set_sensors_ok(booted.sensors_ok);
    let live_task = config
        .live
        .and_then(|task| match live::estimator(&image, &task.settings) {
            Ok(l) => {
                let o = occupancy_tracker(&image, &task);
                Some((task, l, o))
            }
            Err(e) => {
                tracing::warn!("live: {e}; serving the model only");
                None
            }
        });
    let luminaires = node.levels().len();
    let payload_crc = image.header.payload_crc32;
    let node: SharedNode = Arc::new(Mutex::new(node));
    let periph = std::mem::take(&mut config.peripherals);
    let reference = match (&config.ambient_reference, &periph.als) {
        (Some(p), Some(_)) => source::AmbientReference::load(p, payload_crc, luminaires),
        _ => None,
    };
    let watch = Watch::new(&node, periph, reference, led.clone(), &health);
    let serve = config.serve;
    let companion = config.companion;
    let reload = config.reload;
    let probe = config.sensor_probe;
    rt.block_on(async move {
        let listener = crate::fieldbus::tcp::bind(serve.bind)
            .await
            .map_err(ServeError::from)?;
        let addr = listener.local_addr().map_err(ServeError::Io)?;
        let (done_tx, done_rx) = tokio::sync::oneshot::channel::<()>();
        let stops_with_companion = companion.as_ref().is_some_and(|c| c.1);
        let companion_task = companion.map(|(task, stops)| {
            tokio::spawn(async move {
                task(addr).await;
                if stops {
                    let _ = done_tx.send(());
                }
            })
        });
        let probe_task = probe.map(|p| tokio::spawn(sensor_probe_loop(p, node.clone())));
        let live_handle = live_task.map(|(task, l, o)| {
            if let Some(o) = &o {
                o.publish_start(&mut lock(&node));
            }
            tokio::spawn(live::live_loop(task, l, o, node.clone()))
        });
        let watchdog = tokio::spawn(systemd::watchdog_loop(health.clone(), node.clone()));
        let watcher = tokio::spawn(watch.run());
        systemd::notify("READY=1");
        let stop = async move {
            tokio::select! {
                _ = wait_for_stop(serve.run_for) => {}
                _ = async { let _ = done_rx.await; }, if stops_with_companion => {}
            }
            systemd::notify("STOPPING=1");
        };
        let r = serve_node(node.clone(), listener, serve, stop, reload, signals).await;
        watchdog.abort();
        watcher.abort();
        if let Some(t) = companion_task {
            t.abort();
        }
        if let Some(t) = probe_task {
            t.abort();
        }
        if let Some(t) = live_handle {
            t.abort();
        }
        let n = lock(&node);
        tracing::info!("stopped; {} publications", n.map().heartbeat);
        r
    })?;
    Ok(Exit::Stopped)
}

/// Occupancy over a booted image for the live task (its depth frames, its stale limit, the
/// board's hold), or `None` (logged) when the image has no desks or no live section.
fn occupancy_tracker(
    image: &crate::store::Image<'_>,
    task: &live::LiveTask,
) -> Option<occupancy::OccupancyTracker> {
    let built = crate::live_section::occupancy_map(image, Default::default())
        .map_err(|e| e.to_string())
        .and_then(|(map, sensor_desk)| {
            occupancy::OccupancyTracker::new(
                map,
                sensor_desk,
                task.occupancy_hold_s,
                task.settings.stale_after_s,
            )
            .and_then(|t| {
                t.with_motion(crate::occupancy::MotionSettings {
                    static_after_s: task.occupancy_static_after_s,
                    ..Default::default()
                })
            })
            .map_err(|e| e.to_string())
        });
    match built {
        Ok(t) => {
            tracing::info!(
                "occupancy: on, hold {} s, still {} s is a thing, {:.2} MB",
                task.occupancy_hold_s,
                task.occupancy_static_after_s,
                t.memory_bytes() as f64 / 1e6
            );
            Some(t)
        }
        Err(e) => {
            tracing::warn!("occupancy: off: {e}");
            None
        }
    }
}

/// Runs the sensor probe every period; its outcome sets the "sensors healthy" bit.
async fn sensor_probe_loop(p: SensorProbe, node: SharedNode) {
    let health = lock(&node).health().clone();
    let beat = health.register("sensor probe", p.every * 2 + Duration::from_secs(60));
    let probe = Arc::new(Mutex::new(p.probe));
    let mut tick = tokio::time::interval(p.every);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        let probe = probe.clone();
        let r = tokio::task::spawn_blocking(move || (lock(&probe))())
            .await
            .unwrap_or_else(|e| Err(format!("the probe failed: {e}")));
        beat.beat();
        if let Err(e) = &r {
            tracing::warn!("sensor probe: {e}");
        }
        lock(&node).set_sensors_ok(r.is_ok());
    }
}

/// The node's peripherals while it serves: the ALS's health and check as status bits, the LED
/// following the status, the simulated board's light following the levels.
struct Watch {
    node: SharedNode,
    als: Option<crate::peripherals::node::AlsMonitor>,
    reference: Option<source::AmbientReference>,
    tolerance: f64,
    led: Option<Arc<crate::peripherals::node::LedMonitor>>,
    /// Its beat for the watchdog (it is one of the node's supervised parts).
    beat: crate::node::health::Beat,
    hook: Option<crate::peripherals::node::LevelsHook>,
    open_faults: Vec<String>,
}

/// The watch beats every 250 ms; silent this long, it counts as dead (the watchdog is not
/// petted).
const WATCH_LIMIT: Duration = Duration::from_secs(30);

/// A reading counts for the check only this long after the last change of levels (a full
/// auto-range at the longest integration takes about 2 s).
const CHECK_SETTLE: Duration = Duration::from_secs(3);

impl Watch {
    /// The peripherals' watch over `node`: the ambient light sensor (its monitor started) and
    /// its check against `reference`, the LED, the levels hook, the faults found at opening.
    fn new(
        node: &SharedNode,
        periph: crate::peripherals::node::Peripherals,
        reference: Option<source::AmbientReference>,
        led: Option<Arc<crate::peripherals::node::LedMonitor>>,
        health: &Health,
    ) -> Self {
        Self {
            node: node.clone(),
            als: periph
                .als
                .clone()
                .map(|a| crate::peripherals::node::AlsMonitor::spawn(a, periph.als_period)),
            reference,
            tolerance: periph.als_tolerance,
            led,
            beat: health.register("peripherals watch", WATCH_LIMIT),
            hook: periph.levels_hook,
            open_faults: periph.open_faults,
        }
    }

    async fn run(mut self) {
        use crate::modbus::regmap::status;
        let mut last_levels: Vec<f64> = Vec::new();
        let mut changed_at = Instant::now();
        let mut last_problem: Option<String> = None;
        let mut last_check: Option<bool> = None;
        let mut last_led: Option<NodeState> = None;
        loop {
            self.beat.beat();
            let levels = lock(&self.node).levels().to_vec();
            if levels != last_levels {
                changed_at = Instant::now();
                if let Some(h) = self.hook.as_mut() {
                    h(&levels);
                }
                last_levels = levels.clone();
            }
            let mut problem = self.open_faults.first().cloned();
            let mut check = None;
            if let Some(m) = &self.als {
                let st = m.status();
                if let Some(p) = st.problem(m.deadline) {
                    problem = Some(p);
                } else if let (Some(r), Some((reading, at))) = (&self.reference, st.last)
                    && at > changed_at + CHECK_SETTLE
                {
                    let predicted = r.predict_lx(&levels);
                    let off = (reading.lux_lx - predicted).abs() > self.tolerance * predicted + 2.0;
                    if last_check != Some(off) {
                        if off {
                            tracing::warn!(
                                "ambient light check: the sensor reads {:.1} lx, the model predicts \
                                 {predicted:.1} lx for the current levels ({}): {}; status bit 13 set",
                                reading.lux_lx,
                                if reading.lux_lx > predicted {
                                    "more light than modelled"
                                } else {
                                    "less light than modelled"
                                },
                                if reading.lux_lx > predicted {
                                    "daylight or another source: the model's desk values are the luminaires' light only (live light, where on, measures the rest)"
                                } else {
                                    "a luminaire gives less than modelled, or the room changed"
                                }
                            );
                        } else {
                            tracing::info!(
                                "ambient light check: the sensor reads {:.1} lx, the model predicts \
                                 {predicted:.1} lx: agree within {:.0} %",
                                reading.lux_lx,
                                self.tolerance * 100.0
                            );
                        }
                    }
                    check = Some(off);
                }
            }
            if problem != last_problem {
                match &problem {
                    Some(p) => tracing::error!("peripheral fault: {p}; status bit 12 set"),
                    None => tracing::info!("peripherals: healthy again; status bit 12 cleared"),
                }
                last_problem = problem.clone();
            }
            let st = {
                let mut n = lock(&self.node);
                n.set_peripheral_fault(problem.is_some());
                if let Some(c) = check {
                    n.set_light_check(c);
                    last_check = Some(c);
                }
                n.map().status
            };
            if let Some(l) = &self.led {
                let degraded = st
                    & (status::PERIPHERAL_FAULT
                        | status::LIGHT_CHECK
                        | status::VALUES_STALE
                        | status::COMPUTE_ERROR)
                    != 0
                    || st & (status::STORE_OK | status::SENSORS_OK | status::COMM_OK)
                        != (status::STORE_OK | status::SENSORS_OK | status::COMM_OK);
                let want = if degraded {
                    NodeState::Degraded
                } else {
                    NodeState::Serving
                };
                if last_led != Some(want) {
                    l.set(want);
                    tracing::info!("status LED: {}", want.name());
                    last_led = Some(want);
                }
                if let Some(f) = l.failure() {
                    self.open_faults.retain(|x| x != &f);
                    self.open_faults.push(f);
                }
            }
            tokio::time::sleep(Duration::from_millis(250)).await;
        }
    }
}

/// How long a sim demo step lasts by default.
pub const DEFAULT_STEP: Duration = Duration::from_millis(400);
