//! Serving a commissioned image over Modbus: the TCP server, optionally the RTU server and the
//! DALI gateway link, all on one [`Node`]. `luxnode serve` runs this; the daemon reuses it.

use std::net::SocketAddr;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::watch;

use crate::modbus::gateway::{self, GatewayConfig, GatewayCounters};
use crate::modbus::node::{Node, NodeError, NodeModel, NodeOptions, SharedNode};
use crate::modbus::regmap::Identity;
use crate::modbus::rtu::{self, RtuCounters, RtuError, RtuOptions};
use crate::modbus::tcp::{self, BindError, TcpCounters, TcpOptions};
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
}

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
    let node = load_node(
        image,
        NodeOptions {
            identity: identity(&options.model_name, image),
            gateway_configured: options.gateway.is_some(),
            initial_arc: options.initial_arc,
        },
    )?;
    let node: SharedNode = Arc::new(Mutex::new(node));
    let rt = runtime()?;
    let run_for = options.run_for;
    rt.block_on(async move {
        let listener = tcp::bind(options.bind).await?;
        serve_node(node, listener, options, wait_for_stop(run_for)).await
    })
}

/// Serves an existing node on a bound listener until `stop` completes (the daemon builds its
/// own node and stop condition).
pub async fn serve_node(
    node: SharedNode,
    listener: tokio::net::TcpListener,
    options: ServeOptions,
    stop: impl std::future::Future<Output = ()>,
) -> Result<(), ServeError> {
    let (stop_tx, stop_rx) = watch::channel(false);
    let local = listener.local_addr()?;
    tracing::info!(address = %local, "modbus tcp listening on {local}");
    let tcp_counters = Arc::new(TcpCounters::default());
    let tcp_task = tokio::spawn(tcp::serve(
        listener,
        node.clone(),
        options.tcp.clone(),
        tcp_counters.clone(),
        stop_rx.clone(),
    ));

    let rtu_stop = Arc::new(AtomicBool::new(false));
    let rtu_thread = match &options.rtu {
        Some((device, line)) => {
            let port = rtu::open_port(device, line)?;
            tracing::info!(
                "modbus rtu on {device}: unit {}, {} baud, parity {:?}, t3.5 {:?}",
                line.unit_id,
                line.baud,
                line.parity,
                line.t35()
            );
            Some(rtu::spawn(
                port,
                node.clone(),
                line.unit_id,
                Arc::new(RtuCounters::default()),
                rtu_stop.clone(),
            ))
        }
        None => None,
    };

    let gateway_task = options.gateway.clone().map(|config| {
        tracing::info!("dali gateway link: polling {}", config.address);
        tokio::spawn(gateway::run(
            config,
            node.clone(),
            Arc::new(GatewayCounters::default()),
            stop_rx.clone(),
        ))
    });

    stop.await;
    let _ = stop_tx.send(true);
    rtu_stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let _ = tcp_task.await;
    if let Some(t) = gateway_task {
        let _ = t.await;
    }
    if let Some(t) = rtu_thread {
        let _ = tokio::task::spawn_blocking(move || t.join()).await;
    }
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
