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
//! knows a board: [`DaemonConfig`] is built from the board file by the binary.

pub mod controller;
pub mod source;
pub mod systemd;

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};

use crate::modbus::node::{Node, NodeModel, NodeOptions, SharedNode, lock};
use crate::modbus::regmap::Identity;
use crate::serve::{ServeOptions, serve_node, wait_for_stop};
use crate::store::devices::{DeviceError, Faults, FaultyFlash, FileFlash};
use crate::store::slots::{BootStatus, FlashDevice, Slots, WriteError};
use crate::store::{Image, build::ImageOptions};

/// Where the first boot's model comes from.
pub trait CommissionSource {
    /// What it is, for the log ("simulated cameras over the demo office", ...).
    fn describe(&self) -> String;
    /// Commissions the room; returns the flash image.
    fn commission(&mut self) -> anyhow::Result<Vec<u8>>;
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

    fn commission(&mut self) -> anyhow::Result<Vec<u8>> {
        let model = crate::engine::commission(&self.scene, &self.settings)?;
        let mut options = self.image.clone();
        if options.scene_name.is_empty() {
            options.scene_name = self.scene.name.clone();
        }
        Ok(crate::store::build::build_image(&model, &options)?)
    }
}

/// A source that cannot commission, and says why (a board whose cameras cannot commission
/// yet still boots a valid image from flash).
pub struct Unavailable(pub String);

impl CommissionSource for Unavailable {
    fn describe(&self) -> String {
        "no commissioning source".into()
    }

    fn commission(&mut self) -> anyhow::Result<Vec<u8>> {
        bail!("{}", self.0)
    }
}

/// The flash the image lives in.
#[derive(Debug, Clone)]
pub struct FlashConfig {
    /// A file or an MTD block device.
    pub path: PathBuf,
    /// Device size, bytes (two slots).
    pub capacity: usize,
    /// Test only (HIL): power fails after this many bytes of the image write.
    pub power_cut_after_bytes: Option<usize>,
}

/// Everything the daemon needs, resolved from the board file.
pub struct DaemonConfig {
    /// Board name (device identification's model name).
    pub board: String,
    /// Flash.
    pub flash: FlashConfig,
    /// Modbus and gateway.
    pub serve: ServeOptions,
    /// The simulated controller (sim board): steps through dimming states and prints the live
    /// table; the daemon stops when it has finished, unless it runs forever.
    pub controller: Option<controller::SimController>,
    /// Re-commission even if a valid image exists.
    pub recommission: bool,
}

/// How the daemon ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Exit {
    /// Signal or the controller's sequence finished.
    Stopped,
    /// The (simulated) power failed during the image write.
    PowerCut,
}

fn slots_status_line(status: &BootStatus) -> String {
    status.to_string()
}

fn open_flash(flash: &FlashConfig) -> anyhow::Result<FileFlash> {
    if let Some(dir) = flash.path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    FileFlash::open(&flash.path, flash.capacity)
        .map_err(|e| anyhow::anyhow!("flash {}: {e}", flash.path.display()))
}

/// Reads the newest valid image of a flash device.
fn read_newest<F: FlashDevice>(slots: &mut Slots<F>) -> anyhow::Result<Option<(Vec<u8>, u64)>>
where
    F::Error: std::fmt::Debug,
{
    let status = slots.boot();
    let (Some(slot), Some(generation)) = (status.chosen, status.generation()) else {
        return Ok(None);
    };
    let mut buf = vec![0u8; slots.slot_len()];
    let n = slots
        .read_image(slot, &mut buf)
        .map_err(|e| anyhow::anyhow!("reading slot {slot}: {e}"))?;
    buf.truncate(n);
    Ok(Some((buf, generation)))
}

/// The newest valid image of a flash file (A/B slots), without changing it.
pub fn read_flash_image(path: &std::path::Path) -> anyhow::Result<Option<(Vec<u8>, u64)>> {
    let len = std::fs::metadata(path)
        .with_context(|| format!("{}", path.display()))?
        .len();
    let len = usize::try_from(len)?;
    let dev = FileFlash::open(path, len).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    read_newest(&mut Slots::new(dev))
}

/// An image file, or a flash file with A/B slots (its newest valid image). Anything else is
/// returned as read, for the caller's parse to report what is wrong with it.
pub fn read_image_file(path: &std::path::Path) -> anyhow::Result<Vec<u8>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    // an image file is exactly header + payload; a flash device is longer (two slots)
    let exact = crate::store::Header::parse(&bytes)
        .is_ok_and(|h| bytes.len() == crate::store::HEADER_LEN + h.payload_len as usize);
    if exact {
        return Ok(bytes);
    }
    if let Ok(Some((image, generation))) = read_flash_image(path) {
        eprintln!(
            "{}: flash with A/B slots; using its newest valid image (generation {generation})",
            path.display()
        );
        return Ok(image);
    }
    Ok(bytes)
}

/// Boots: the newest valid image, or commissions and writes one. `Ok(None)`: the simulated
/// power cut hit the write.
pub fn boot(
    flash: &FlashConfig,
    source: &mut dyn CommissionSource,
    recommission: bool,
) -> anyhow::Result<Option<(Vec<u8>, u64, BootStatus)>> {
    let mut slots = Slots::new(open_flash(flash)?);
    let status = slots.boot();
    tracing::info!(
        "flash {}: {}",
        flash.path.display(),
        slots_status_line(&status)
    );
    println!("boot: {status}");
    if !recommission && let Some((bytes, generation)) = read_newest(&mut slots)? {
        println!(
            "boot: loaded image generation {generation} ({} bytes)",
            bytes.len()
        );
        return Ok(Some((bytes, generation, status)));
    }
    println!(
        "boot: {}; commissioning from {}",
        if recommission {
            "re-commissioning requested"
        } else {
            "no valid image"
        },
        source.describe()
    );
    let t0 = Instant::now();
    let image = source.commission().context("commissioning")?;
    println!(
        "commissioned in {:.1} s: image of {} bytes",
        t0.elapsed().as_secs_f64(),
        image.len()
    );
    let dev = slots.into_inner();
    let faults = Faults {
        cut_after_bytes: flash.power_cut_after_bytes,
        ..Faults::default()
    };
    let mut slots = Slots::new(FaultyFlash::new(dev, faults));
    match slots.write_image(&image) {
        Ok(report) => println!(
            "flash: image written to slot {} as generation {}, verified",
            report.slot, report.generation
        ),
        Err(WriteError::Device(DeviceError::PowerCut)) if slots.device().power_cut() => {
            println!("flash: POWER CUT during the image write (simulated); the node stops here");
            return Ok(None);
        }
        Err(e) => bail!("writing the image to {}: {e}", flash.path.display()),
    }
    let mut slots = Slots::new(slots.into_inner().into_inner());
    let status = slots.boot();
    println!("boot: {status}");
    match read_newest(&mut slots)? {
        Some((bytes, generation)) => Ok(Some((bytes, generation, status))),
        None => bail!("the image just written does not boot: {status}"),
    }
}

/// Runs the node until a signal (or the simulated controller's end).
pub fn run(config: DaemonConfig, source: &mut dyn CommissionSource) -> anyhow::Result<Exit> {
    let Some((bytes, generation, status)) = boot(&config.flash, source, config.recommission)?
    else {
        return Ok(Exit::PowerCut);
    };
    let image = Image::parse(&bytes).context("the booted image")?;
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
    let damaged = |s: crate::store::slots::SlotState| match s {
        crate::store::slots::SlotState::Invalid(e) => e != crate::store::ImageError::Erased,
        crate::store::slots::SlotState::Unreadable => true,
        crate::store::slots::SlotState::Valid { .. } => false,
    };
    let other_bad = damaged(status.a) || damaged(status.b);
    if other_bad {
        println!("store: one slot holds a damaged image; running from the other");
    }
    node.set_store_ok(!other_bad);
    let node: SharedNode = Arc::new(Mutex::new(node));
    let rt = crate::serve::runtime()?;
    let serve = config.serve.clone();
    let controller = config.controller.clone();
    rt.block_on(async move {
        let listener = crate::modbus::tcp::bind(serve.bind).await?;
        let addr = listener.local_addr()?;
        let (done_tx, done_rx) = tokio::sync::oneshot::channel::<()>();
        let controller_task = controller.map(|c| {
            let node = node.clone();
            tokio::spawn(async move {
                let r = c.run(addr, node).await;
                if let Err(e) = &r {
                    tracing::error!("simulated controller: {e:#}");
                }
                if !c.forever {
                    let _ = done_tx.send(());
                }
                r
            })
        });
        let watchdog = tokio::spawn(systemd::watchdog_loop());
        systemd::notify("READY=1");
        let stop = async move {
            tokio::select! {
                _ = wait_for_stop(serve.run_for) => {}
                _ = async { let _ = done_rx.await; }, if controller_task.is_some() => {}
            }
            systemd::notify("STOPPING=1");
        };
        let r = serve_node(node.clone(), listener, serve, stop).await;
        watchdog.abort();
        let n = lock(&node);
        tracing::info!("stopped; {} publications", n.map().heartbeat);
        r
    })?;
    Ok(Exit::Stopped)
}

/// How long a sim demo step lasts by default.
pub const DEFAULT_STEP: Duration = Duration::from_millis(400);
