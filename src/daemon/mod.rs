//! The node: `luxnode run --board FILE`.
//!
//! ```text
//! boot: flash (A/B slots) ── newest valid image ──────────────────────────────┐
//!         │ none valid                                                       ▼
//!         └─► commission (capture, mesh, reflectances, form factors) ─► write image ─► serve
//! serve: Modbus TCP (+ RTU) over the image; dimming from the holding registers or the DALI
//!        gateway; every change recomputed and published at once; systemd READY / WATCHDOG;
//!        SIGTERM or Ctrl-C: clean shutdown.
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
use crate::modbus::node::{Node, NodeError, NodeModel, NodeOptions, SharedNode, lock};
use crate::modbus::regmap::Identity;
use crate::serve::{ServeError, ServeOptions, serve_node, wait_for_stop};
use crate::store::devices::{DeviceError, FileFlash};
use crate::store::file::{FileError, read_newest};
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
        let model = crate::engine::compute_model(&self.scene, &self.settings)?;
        let mut options = self.image.clone();
        if options.scene_name.is_empty() {
            options.scene_name = self.scene.name.clone();
        }
        Ok(crate::image_build::build_for_region(
            &model,
            &options,
            crate::image_build::formfactors_region_bytes(),
        )?)
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

/// A task that runs beside the servers once they listen (the sim board's simulated controller),
/// given the bound Modbus TCP address.
pub type Companion = Box<dyn FnOnce(SocketAddr) -> Pin<Box<dyn Future<Output = ()> + Send>> + Send>;

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

/// What [`boot`] found or made.
#[derive(Debug)]
pub enum Booted {
    /// An image to serve: (bytes, generation, slot status).
    Image(Vec<u8>, u64, BootStatus),
    /// The simulated power failed during the image write.
    PowerCut,
}

/// Boots from `flash`: its newest valid image, or commissions and writes one.
pub fn boot<F>(
    flash: F,
    flash_path: &Path,
    source: &mut dyn CommissionSource,
    recommission: bool,
) -> Result<Booted, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
    boot_with(flash, flash_path, source, recommission, &|| {})
}

/// [`boot`], calling `commissioning` when it starts to commission (the LED shows it).
pub fn boot_with<F>(
    flash: F,
    flash_path: &Path,
    source: &mut dyn CommissionSource,
    recommission: bool,
    commissioning: &dyn Fn(),
) -> Result<Booted, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
    let mut slots = Slots::new(flash);
    let status = slots.boot();
    tracing::info!(flash = %flash_path.display(), "boot: {status}");
    if !recommission && let Some((bytes, generation)) = read_newest(&mut slots)? {
        tracing::info!(
            generation,
            bytes = bytes.len(),
            "boot: loaded image generation {generation} ({} bytes)",
            bytes.len()
        );
        return Ok(Booted::Image(bytes, generation, status));
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
    let image = source
        .commission()
        .map_err(|source| DaemonError::Commission { from, source })?;
    tracing::info!(
        bytes = image.len(),
        "commissioned in {:.1} s: image of {} bytes",
        t0.elapsed().as_secs_f64(),
        image.len()
    );
    match slots.write_image(&image) {
        Ok(report) => tracing::info!(
            "flash: image written to slot {} as generation {}, verified",
            report.slot,
            report.generation
        ),
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
    }
    let status = slots.boot();
    tracing::info!("boot: {status}");
    match read_newest(&mut slots)? {
        Some((bytes, generation)) => Ok(Booted::Image(bytes, generation, status)),
        None => Err(DaemonError::NotBootable(status.to_string())),
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

fn run_inner<F>(
    mut config: DaemonConfig,
    flash: F,
    source: &mut dyn CommissionSource,
    led: Option<Arc<crate::peripherals::node::LedMonitor>>,
) -> Result<Exit, DaemonError>
where
    F: FlashDevice<Error = DeviceError>,
{
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
    let (bytes, generation, status) = match boot_with(
        flash,
        &config.flash_path,
        source,
        config.recommission,
        &|| show(NodeState::Commissioning),
    )? {
        Booted::Image(b, g, s) => (b, g, s),
        Booted::PowerCut => return Ok(Exit::PowerCut),
    };
    let image = Image::parse(&bytes)?;
    let model = NodeModel::from_image(&image, generation);
    let mut identity = Identity::default();
    for c in config.board.chars() {
        if identity.model.push(c).is_err() {
            break;
        }
    }
    let _ = identity.application.push_str("commissioned room");
    let mut node = Node::new(
        model,
        NodeOptions {
            identity,
            gateway_configured: config.serve.gateway.is_some(),
            initial_arc: config.serve.initial_arc,
        },
    )?;
    // store health: the other slot is erased (never written) or valid; a corrupt one is
    // reported (the next commissioning overwrites it)
    let other_bad = damaged(status.a) || damaged(status.b);
    if other_bad {
        tracing::warn!("store: one slot holds a damaged image; running from the other");
    }
    node.set_store_ok(!other_bad);
    let luminaires = node.levels().len();
    let payload_crc = image.header.payload_crc32;
    let node: SharedNode = Arc::new(Mutex::new(node));
    let periph = std::mem::take(&mut config.peripherals);
    let reference = match (&config.ambient_reference, &periph.als) {
        (Some(p), Some(_)) => source::AmbientReference::load(p, payload_crc, luminaires),
        _ => None,
    };
    let watch = Watch {
        node: node.clone(),
        als: periph
            .als
            .clone()
            .map(|a| crate::peripherals::node::AlsMonitor::spawn(a, periph.als_period)),
        reference,
        tolerance: periph.als_tolerance,
        led: led.clone(),
        hook: periph.levels_hook,
        open_faults: periph.open_faults,
    };
    let rt = crate::serve::runtime()?;
    let serve = config.serve;
    let companion = config.companion;
    rt.block_on(async move {
        let listener = crate::modbus::tcp::bind(serve.bind)
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
        let watchdog = tokio::spawn(systemd::watchdog_loop());
        let watcher = tokio::spawn(watch.run());
        systemd::notify("READY=1");
        let stop = async move {
            tokio::select! {
                _ = wait_for_stop(serve.run_for) => {}
                _ = async { let _ = done_rx.await; }, if stops_with_companion => {}
            }
            systemd::notify("STOPPING=1");
        };
        let r = serve_node(node.clone(), listener, serve, stop).await;
        watchdog.abort();
        watcher.abort();
        if let Some(t) = companion_task {
            t.abort();
        }
        let n = lock(&node);
        tracing::info!("stopped; {} publications", n.map().heartbeat);
        r
    })?;
    Ok(Exit::Stopped)
}

/// The node's peripherals while it serves: the ALS's health and check as status bits, the LED
/// following the status, the simulated board's light following the levels.
struct Watch {
    node: SharedNode,
    als: Option<crate::peripherals::node::AlsMonitor>,
    reference: Option<source::AmbientReference>,
    tolerance: f64,
    led: Option<Arc<crate::peripherals::node::LedMonitor>>,
    hook: Option<crate::peripherals::node::LevelsHook>,
    open_faults: Vec<String>,
}

/// A reading counts for the check only this long after the last change of levels (a full
/// auto-range at the longest integration takes about 2 s).
const CHECK_SETTLE: Duration = Duration::from_secs(3);

impl Watch {
    async fn run(mut self) {
        use crate::modbus::regmap::status;
        let mut last_levels: Vec<f64> = Vec::new();
        let mut changed_at = Instant::now();
        let mut last_problem: Option<String> = None;
        let mut last_check: Option<bool> = None;
        let mut last_led: Option<NodeState> = None;
        loop {
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
                                    "daylight or another source: the published desk values are the luminaires' light only"
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
                    || st & status::STORE_OK == 0;
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
