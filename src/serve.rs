//! Serving a commissioned image over Modbus: the TCP server, optionally the TLS server
//! (Modbus/TCP Security), the RTU server and the DALI gateway link, all on one [`Node`].
//! `luxnode serve` runs this; the daemon reuses it.
//!
//! Every part is supervised: a TCP or TLS accept loop that fails is rebound, the RTU line is
//! reopened after any error ([`crate::fieldbus::rtu::spawn_supervised`]), the gateway link is
//! restarted; each beats the liveness check of [`Health`] that gates the systemd watchdog, and
//! its state shows in the communication-health registers. Signals: SIGTERM / Ctrl-C stop;
//! SIGHUP reloads the configuration (the caller's [`Reload`], the board file for the daemon:
//! an invalid file is logged and the running configuration kept); SIGUSR1 logs a status report.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::watch;
use tokio::task::JoinHandle;

use crate::fieldbus::gateway::{self, GatewayConfig};
use crate::fieldbus::rtu::{self, RtuError, RtuOptions};
use crate::fieldbus::tcp::{self, BindError, TcpOptions};
use crate::fieldbus::tls::{TlsError, TlsFiles, TlsServer};
use crate::modbus::access::AccessPolicy;
use crate::modbus::regmap::Identity;
use crate::node::health::{Health, state};
use crate::node::{Node, NodeError, NodeModel, NodeOptions, SharedNode, lock};
use crate::store::file::{FileError, read_image_file};
use crate::store::{Image, ImageError};

/// The sim board's Modbus TCP address (port 1502: no root needed, unlike 502).
pub const DEFAULT_BIND: &str = "127.0.0.1:1502";

/// Why serving did not start or stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The image file could not be read.
    #[error(transparent)]
    File(#[from] FileError),
    /// The image does not parse.
    #[error("image {path}: {source}")]
    Image {
        /// The file.
        path: String,
        /// Why.
        source: ImageError,
    },
    /// The register map refused the image.
    #[error(transparent)]
    Node(#[from] NodeError),
    /// The TCP socket did not open.
    #[error(transparent)]
    Bind(#[from] BindError),
    /// The RTU line did not open.
    #[error(transparent)]
    Rtu(#[from] RtuError),
    /// The TLS certificates or key are unusable.
    #[error(transparent)]
    Tls(#[from] TlsError),
    /// The async runtime or a socket failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// How to serve (where the image comes from is the caller's business).
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// TCP address.
    pub bind: SocketAddr,
    /// TCP limits.
    pub tcp: TcpOptions,
    /// Modbus/TCP Security: address (port 802) and PEM files.
    pub tls: Option<(SocketAddr, TlsFiles)>,
    /// RTU: serial device and line settings.
    pub rtu: Option<(String, RtuOptions)>,
    /// DALI gateway link.
    pub gateway: Option<GatewayConfig>,
    /// Model name for device identification.
    pub model_name: String,
    /// Initial arc level of every luminaire (default: off, or whatever the gateway says).
    pub initial_arc: Option<u8>,
    /// Stop after this long (tests, benchmarks); `None`: until Ctrl-C / SIGTERM.
    pub run_for: Option<Duration>,
    /// Who may write; word orders.
    pub access: AccessPolicy,
    /// Where client settings persist.
    pub settings_path: Option<PathBuf>,
    /// Lighting control: mode, targets, power model, loop knobs (the board's `[control]`).
    pub control: crate::node::ControlOptions,
    /// BACnet/IP server (`--bacnet`, the board's `[bacnet]`).
    pub bacnet: Option<crate::fieldbus::bacnet::BacnetOptions>,
}

/// Re-reads the configuration (SIGHUP): new options, or why they are refused.
pub type Reload = Box<dyn FnMut() -> Result<ServeOptions, String> + Send>;

/// The async runtime of the servers: two workers (the node's SoC class has 2 to 4 cores).
pub fn runtime() -> Result<tokio::runtime::Runtime, ServeError> {
    Ok(tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?)
}

/// Builds the node for an image file (or a flash file's newest image).
pub fn load_node(path: &Path, options: NodeOptions) -> Result<Node, ServeError> {
    let bytes = read_image_file(path)?;
    let image = Image::parse(&bytes).map_err(|source| ServeError::Image {
        path: path.display().to_string(),
        source,
    })?;
    let model = NodeModel::from_image(&image, image.header.generation);
    Ok(Node::new(model, options)?)
}

fn identity(model_name: &str, image: &Path) -> Identity {
    let mut id = Identity::default();
    for c in model_name.chars() {
        if id.model.push(c).is_err() {
            break;
        }
    }
    let app = image
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    for c in app.chars() {
        if id.application.push(c).is_err() {
            break;
        }
    }
    id
}

/// Serves the image file `image` until Ctrl-C, SIGTERM or `run_for`. Logs `modbus tcp
/// listening on ADDR` (the bound address: with port 0 the kernel picks one) once the socket is
/// open.
pub fn serve(image: &Path, options: ServeOptions) -> Result<(), ServeError> {
    let health = Arc::new(Health::default());
    let node = load_node(
        image,
        NodeOptions {
            identity: identity(&options.model_name, image),
            gateway_configured: options.gateway.is_some(),
            initial_arc: options.initial_arc,
            policy: options.access.clone(),
            settings_path: options.settings_path.clone(),
            health: Some(health),
            control: options.control.clone(),
        },
    )?;
    let node: SharedNode = Arc::new(Mutex::new(node));
    let rt = runtime()?;
    let run_for = options.run_for;
    rt.block_on(async move {
        let signals = Signals::install()?;
        let listener = tcp::bind(options.bind).await?;
        serve_node(
            node,
            listener,
            options,
            wait_for_stop(run_for),
            None,
            signals,
        )
        .await
    })
}

/// The signals the node handles besides SIGTERM: installed early (before commissioning) so
/// that a SIGHUP or SIGUSR1 at any time never kills the process.
pub struct Signals {
    #[cfg(unix)]
    hup: tokio::signal::unix::Signal,
    #[cfg(unix)]
    usr1: tokio::signal::unix::Signal,
    #[cfg(unix)]
    usr2: tokio::signal::unix::Signal,
}

impl Signals {
    /// Installs the handlers (needs a tokio runtime context).
    pub fn install() -> std::io::Result<Self> {
        #[cfg(unix)]
        {
            use tokio::signal::unix::{SignalKind, signal};
            Ok(Self {
                hup: signal(SignalKind::hangup())?,
                usr1: signal(SignalKind::user_defined1())?,
                usr2: signal(SignalKind::user_defined2())?,
            })
        }
        #[cfg(not(unix))]
        Ok(Self {})
    }
}

/// What a signal asked for.
enum Asked {
    Reload,
    Status,
}

impl Signals {
    async fn next(&mut self) -> Asked {
        #[cfg(unix)]
        tokio::select! {
            _ = self.hup.recv() => Asked::Reload,
            _ = self.usr1.recv() => Asked::Status,
            _ = self.usr2.recv() => Asked::Status,
        }
        #[cfg(not(unix))]
        std::future::pending().await
    }
}

/// The running servers and link of one configuration.
struct Parts {
    stop_tx: watch::Sender<bool>,
    tasks: Vec<JoinHandle<()>>,
    rtu_stop: Arc<AtomicBool>,
    rtu: Option<std::thread::JoinHandle<()>>,
}

/// The communication part of the options: a change restarts the servers.
fn comm_key(o: &ServeOptions) -> String {
    let t = &o.tcp;
    format!(
        "{:?} {} {} {:?} {:?} {:?} {:?} {:?} {:?}",
        o.bind,
        t.max_connections,
        t.max_per_source,
        t.idle_timeout,
        t.evictable_after,
        o.tls,
        o.rtu,
        o.gateway,
        o.bacnet
    )
}

/// Starts the servers and the link. `listener`: the plain TCP socket, already bound.
fn start_parts(
    node: &SharedNode,
    health: &Arc<Health>,
    listener: Option<tokio::net::TcpListener>,
    options: &ServeOptions,
    tls: Option<TlsServer>,
    rtu_port: Option<Box<dyn serialport::SerialPort>>,
) -> Parts {
    let (stop_tx, stop_rx) = watch::channel(false);
    let mut tasks = Vec::new();
    tasks.push(tokio::spawn(supervise_tcp(
        "modbus tcp",
        listener,
        options.bind,
        options.tcp.clone(),
        node.clone(),
        health.clone(),
        stop_rx.clone(),
        false,
    )));
    if let (Some((addr, _)), Some(server)) = (&options.tls, tls) {
        let tcp = TcpOptions {
            tls: Some(server),
            ..options.tcp.clone()
        };
        tasks.push(tokio::spawn(supervise_tcp(
            "modbus tls",
            None,
            *addr,
            tcp,
            node.clone(),
            health.clone(),
            stop_rx.clone(),
            true,
        )));
    } else {
        health.tls_state.store(state::NONE, Ordering::Relaxed);
    }
    let rtu_stop = Arc::new(AtomicBool::new(false));
    let rtu = options.rtu.as_ref().map(|(device, line)| {
        tracing::info!(
            "modbus rtu on {device}: unit {}, {} baud, parity {:?}, t3.5 {:?}",
            line.unit_id,
            line.baud,
            line.parity,
            line.t35()
        );
        rtu::spawn_supervised(
            device.clone(),
            *line,
            rtu_port,
            node.clone(),
            health.clone(),
            rtu_stop.clone(),
            health.register("modbus rtu", Duration::from_secs(15)),
        )
    });
    if rtu.is_none() {
        health.rtu_state.store(state::NONE, Ordering::Relaxed);
    }
    if let Some(config) = options.gateway.clone() {
        tracing::info!("dali gateway link: polling {}", config.address);
        let (node, health, stop_rx) = (node.clone(), health.clone(), stop_rx.clone());
        tasks.push(tokio::spawn(async move {
            let beat = health.register("dali gateway link", config.beat_limit());
            loop {
                let inner = tokio::spawn(gateway::run(
                    config.clone(),
                    node.clone(),
                    health.counters::<crate::fieldbus::gateway::GatewayCounters>(),
                    stop_rx.clone(),
                    Some(beat.clone()),
                ));
                match inner.await {
                    Ok(Ok(())) => break,
                    Ok(Err(e)) => tracing::error!("dali gateway link stopped: {e}; restarting"),
                    Err(e) => tracing::error!("dali gateway link failed: {e}; restarting"),
                }
                if *stop_rx.borrow() {
                    break;
                }
                beat.beat();
                tokio::time::sleep(Duration::from_secs(1)).await;
            }
            beat.retire();
        }));
    }
    if let Some(bacnet) = options.bacnet.clone() {
        tasks.push(tokio::spawn(crate::fieldbus::bacnet::supervise(
            node.clone(),
            bacnet,
            health.clone(),
            stop_rx.clone(),
        )));
    }
    {
        // lighting control: always running, commanding nothing while the mode is off
        let (node, gateway, stop_rx) = (node.clone(), options.gateway.clone(), stop_rx.clone());
        tasks.push(tokio::spawn(crate::fieldbus::lighting::run(
            node, gateway, stop_rx,
        )));
    }
    Parts {
        stop_tx,
        tasks,
        rtu_stop,
        rtu,
    }
}

impl Parts {
    async fn stop(self) {
        let _ = self.stop_tx.send(true);
        self.rtu_stop.store(true, Ordering::Relaxed);
        for t in self.tasks {
            let _ = t.await;
        }
        if let Some(t) = self.rtu {
            let _ = tokio::task::spawn_blocking(move || t.join()).await;
        }
    }
}

/// Serves on `listener` (or a socket bound to `addr`), rebinding after a failure, until stop.
#[allow(clippy::too_many_arguments)]
async fn supervise_tcp(
    name: &'static str,
    listener: Option<tokio::net::TcpListener>,
    addr: SocketAddr,
    options: TcpOptions,
    node: SharedNode,
    health: Arc<Health>,
    stop_rx: watch::Receiver<bool>,
    tls: bool,
) {
    let st = if tls {
        &health.tls_state
    } else {
        &health.tcp_state
    };
    let beat = health.register(name, Duration::from_secs(10));
    let mut listener = listener;
    // after a failure, rebind the address actually bound (port 0 picks one once)
    let mut addr = addr;
    loop {
        if *stop_rx.borrow() {
            break;
        }
        beat.beat();
        let l = match listener.take() {
            Some(l) => l,
            None => match tcp::bind(addr).await {
                Ok(l) => l,
                Err(e) => {
                    st.store(state::DOWN, Ordering::Relaxed);
                    tracing::error!("{e}; retrying in 2 s");
                    tokio::time::sleep(Duration::from_secs(2)).await;
                    continue;
                }
            },
        };
        if let Ok(a) = l.local_addr() {
            if tls || a != addr {
                tracing::info!(address = %a, "{name} listening on {a}");
            }
            addr = a;
        }
        st.store(state::UP, Ordering::Relaxed);
        let inner = tokio::spawn(tcp::serve(
            l,
            node.clone(),
            options.clone(),
            health.counters::<crate::fieldbus::tcp::TcpCounters>(),
            stop_rx.clone(),
            Some(beat.clone()),
        ));
        match inner.await {
            Ok(Ok(())) => break,
            Ok(Err(e)) => tracing::error!("{name} on {addr} failed: {e}; rebinding"),
            Err(e) => tracing::error!("{name} on {addr} failed: {e}; rebinding"),
        }
        st.store(state::DOWN, Ordering::Relaxed);
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
    beat.retire();
}

/// A status report, for SIGUSR1.
fn log_status(node: &SharedNode) {
    let n = lock(node);
    let c = n.health().snapshot();
    let m = n.map();
    tracing::info!(
        "status: image generation {}, {} desks, {} luminaires, status bits {:#06x}, dimming \
         state {}; tcp {} open ({} refused, {} evicted); rtu state {} ({} reopens, {} \
         answered, {} discarded); tls state {} ({} failed handshakes); gateway {} failures; \
         writes {} executed, {} refused; late parts: {:?}",
        m.generation,
        m.desks.len(),
        m.arc.len(),
        m.status,
        if n.dimming_known() {
            "known"
        } else {
            "unknown"
        },
        c.tcp_open,
        c.tcp_refused,
        c.tcp_evicted,
        c.rtu_state,
        c.rtu_reopens,
        c.rtu_answered,
        c.rtu_discarded,
        c.tls_state,
        c.tls_failed,
        c.gateway_failures,
        c.writes_accepted,
        c.writes_refused,
        n.health().late()
    );
    let b = n
        .health()
        .counters::<crate::fieldbus::bacnet::BacnetCounters>();
    tracing::info!(
        "status: bacnet {} datagrams received, {} COV notifications sent, foreign device \
         registered {} ({} failed registrations)",
        b.received.load(Ordering::Relaxed),
        b.notifications.load(Ordering::Relaxed),
        b.fd_registered.load(Ordering::Relaxed),
        b.fd_failures.load(Ordering::Relaxed)
    );
}

/// A configuration's TLS acceptor and opened RTU line.
type Prepared = (Option<TlsServer>, Option<Box<dyn serialport::SerialPort>>);

/// Opens what a configuration needs before it replaces the running one: the TLS files and, at
/// start, the RTU line (a wrong device or key is an error at start; on a reload a bad key keeps
/// the old servers, and the RTU line, which the old server holds open exclusively until it
/// stops, is opened by its supervisor, which says so and retries if it cannot).
fn prepare(options: &ServeOptions, open_rtu: bool) -> Result<Prepared, ServeError> {
    let tls = options
        .tls
        .as_ref()
        .map(|(_, files)| TlsServer::load(files))
        .transpose()?;
    let port = match &options.rtu {
        Some((device, line)) if open_rtu => Some(rtu::open_port(device, line)?),
        Some((_, line)) => {
            line.validate()?;
            None
        }
        None => None,
    };
    Ok((tls, port))
}

/// Serves an existing node on a bound listener until `stop` completes (the daemon builds its
/// own node and stop condition). `reload` answers SIGHUP.
pub async fn serve_node(
    node: SharedNode,
    listener: tokio::net::TcpListener,
    options: ServeOptions,
    stop: impl std::future::Future<Output = ()>,
    mut reload: Option<Reload>,
    mut signals: Signals,
) -> Result<(), ServeError> {
    let local = listener.local_addr()?;
    tracing::info!(address = %local, "modbus tcp listening on {local}");
    let health = lock(&node).health().clone();
    let (tls, port) = prepare(&options, true)?;
    let mut options = ServeOptions {
        bind: local,
        ..options
    };
    let mut parts = start_parts(&node, &health, Some(listener), &options, tls, port);
    tokio::pin!(stop);
    loop {
        tokio::select! {
            _ = &mut stop => break,
            asked = signals.next() => match asked {
                Asked::Status => log_status(&node),
                Asked::Reload => {
                    let Some(r) = reload.as_mut() else {
                        tracing::info!("SIGHUP: nothing to reload (no configuration file)");
                        continue;
                    };
                    let mut new = match r() {
                        Ok(n) => n,
                        Err(e) => {
                            tracing::error!("reload: {e}; the running configuration stays");
                            continue;
                        }
                    };
                    // a port chosen by the kernel (0) stays the one bound
                    if new.bind.port() == 0 {
                        new.bind = options.bind;
                    }
                    lock(&node).set_policy(new.access.clone());
                    if comm_key(&new) == comm_key(&options) {
                        tracing::info!(
                            "reload: configuration applied (write allowlist: {} rules; word \
                             orders); servers unchanged",
                            new.access.writers.len()
                        );
                        options = new;
                        continue;
                    }
                    let (tls, port) = match prepare(&new, false) {
                        Ok(x) => x,
                        Err(e) => {
                            tracing::error!("reload: {e}; the running servers stay");
                            continue;
                        }
                    };
                    parts.stop().await;
                    parts = start_parts(&node, &health, None, &new, tls, port);
                    tracing::info!("reload: configuration applied; servers restarted");
                    options = new;
                }
            },
        }
    }
    parts.stop().await;
    Ok(())
}

/// Completes after `run_for` (if any), on Ctrl-C, or on SIGTERM.
pub async fn wait_for_stop(run_for: Option<Duration>) {
    let timer = async {
        match run_for {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending::<()>().await,
        }
    };
    #[cfg(unix)]
    {
        let term = async {
            match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
                Ok(mut s) => {
                    s.recv().await;
                }
                Err(_) => std::future::pending::<()>().await,
            }
        };
        tokio::select! {
            _ = timer => {}
            _ = tokio::signal::ctrl_c() => {}
            _ = term => {}
        }
    }
    #[cfg(not(unix))]
    tokio::select! {
        _ = timer => {}
        _ = tokio::signal::ctrl_c() => {}
    }
}
