//! Modbus TCP server (tokio): MBAP framing around the `no_std` PDU handler.
//!
//! Why not the tokio-modbus server: its request codec drops the connection on a malformed PDU
//! (a 0x10 whose byte count does not match, a truncated request, an unknown MEI type) where a
//! field device must answer exception 0x03, and it computes `quantity * 2` in u16 (overflow).
//! The wire format here is seven bytes of header; everything else is [`super::pdu`], fuzzed.
//! tokio-modbus remains the client (the DALI gateway link, the tests).
//!
//! * one task per connection; the shared state is locked only while a request is handled, so a
//!   slow or hostile client (half a header, never reading its answers) never blocks others;
//! * connection cap: a connection beyond it is closed at once (counted);
//! * idle timeout: a connection silent for that long is closed; a write that cannot complete in
//!   that time closes it too;
//! * TCP_NODELAY on every connection;
//! * an MBAP header with a protocol id other than 0 or a length outside 2..=254 cannot be
//!   resynchronised: the connection is closed (counted); any PDU inside a valid header gets a
//!   response (an exception if need be).
//! * the unit id is echoed and not filtered (a TCP device answers every unit id, as gateways
//!   and most devices do; 0 and 255 are the usual ones).

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;

use super::node::{PduHandler, lock};
use super::pdu::MAX_PDU;

/// MBAP header length (transaction, protocol, length, unit).
pub const MBAP_LEN: usize = 7;

/// Server options.
#[derive(Debug, Clone)]
pub struct TcpOptions {
    /// Most connections served at once.
    pub max_connections: usize,
    /// A connection silent this long is closed.
    pub idle_timeout: Duration,
}

impl Default for TcpOptions {
    fn default() -> Self {
        Self {
            max_connections: 16,
            idle_timeout: Duration::from_secs(60),
        }
    }
}

/// Counters, for logs and tests.
#[derive(Debug, Default)]
pub struct TcpCounters {
    /// Connections accepted.
    pub accepted: AtomicU64,
    /// Connections refused at the cap.
    pub refused: AtomicU64,
    /// Connections closed for silence.
    pub idle_closed: AtomicU64,
    /// Connections closed for a broken MBAP header.
    pub framing_closed: AtomicU64,
    /// Requests answered.
    pub requests: AtomicU64,
    /// Connections open now.
    pub open: AtomicUsize,
}

struct OpenGuard(Arc<TcpCounters>);

impl Drop for OpenGuard {
    fn drop(&mut self) {
        self.0.open.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Serves `handler` on `listener` until `shutdown` turns true.
pub async fn serve<H: PduHandler + 'static>(
    listener: TcpListener,
    handler: Arc<Mutex<H>>,
    options: TcpOptions,
    counters: Arc<TcpCounters>,
    mut shutdown: watch::Receiver<bool>,
) -> std::io::Result<()> {
    loop {
        let (stream, peer) = tokio::select! {
            r = listener.accept() => match r {
                Ok(x) => x,
                Err(e) => {
                    // EMFILE and friends: back off, keep serving the open connections
                    tracing::warn!("modbus tcp accept: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            _ = shutdown.changed() => return Ok(()),
        };
        if *shutdown.borrow() {
            return Ok(());
        }
        let open = counters.open.fetch_add(1, Ordering::SeqCst);
        let guard = OpenGuard(counters.clone());
        if open >= options.max_connections {
            counters.refused.fetch_add(1, Ordering::Relaxed);
            tracing::warn!(
                "modbus tcp: {peer} refused, {} connections open (cap)",
                options.max_connections
            );
            drop(stream);
            drop(guard);
            continue;
        }
        counters.accepted.fetch_add(1, Ordering::Relaxed);
        let _ = stream.set_nodelay(true);
        let (handler, counters, options) = (handler.clone(), counters.clone(), options.clone());
        let mut shutdown = shutdown.clone();
        tokio::spawn(async move {
            let _guard = guard;
            tokio::select! {
                r = connection(stream, peer, handler, &options, &counters) => {
                    if let Err(e) = r {
                        tracing::debug!("modbus tcp {peer}: {e}");
                    }
                }
                _ = shutdown.changed() => {}
            }
        });
    }
}

/// Why a connection ended.
#[derive(Debug, thiserror::Error)]
enum ConnectionEnd {
    #[error("closed by peer")]
    Closed,
    #[error("idle for {0:?}")]
    Idle(Duration),
    #[error("broken MBAP header: {0}")]
    Framing(&'static str),
    #[error("io: {0}")]
    Io(#[from] std::io::Error),
}

async fn read_exact_within(
    stream: &mut TcpStream,
    buf: &mut [u8],
    limit: Duration,
) -> Result<(), ConnectionEnd> {
    match tokio::time::timeout(limit, stream.read_exact(buf)).await {
        Err(_) => Err(ConnectionEnd::Idle(limit)),
        Ok(Err(e)) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(ConnectionEnd::Closed),
        Ok(Err(e)) => Err(e.into()),
        Ok(Ok(_)) => Ok(()),
    }
}

async fn connection<H: PduHandler>(
    mut stream: TcpStream,
    peer: SocketAddr,
    handler: Arc<Mutex<H>>,
    options: &TcpOptions,
    counters: &TcpCounters,
) -> Result<(), ConnectionEnd> {
    let mut header = [0u8; MBAP_LEN];
    let mut pdu = [0u8; MAX_PDU];
    let mut out = [0u8; MAX_PDU];
    let mut frame = [0u8; MBAP_LEN + MAX_PDU];
    loop {
        match read_exact_within(&mut stream, &mut header, options.idle_timeout).await {
            Ok(()) => {}
            Err(ConnectionEnd::Idle(d)) => {
                counters.idle_closed.fetch_add(1, Ordering::Relaxed);
                tracing::debug!("modbus tcp {peer}: idle {d:?}, closing");
                return Err(ConnectionEnd::Idle(d));
            }
            Err(e) => return Err(e),
        }
        let protocol = u16::from_be_bytes([header[2], header[3]]);
        let length = usize::from(u16::from_be_bytes([header[4], header[5]]));
        if protocol != 0 {
            counters.framing_closed.fetch_add(1, Ordering::Relaxed);
            return Err(ConnectionEnd::Framing("protocol id is not 0"));
        }
        if !(2..=MAX_PDU + 1).contains(&length) {
            counters.framing_closed.fetch_add(1, Ordering::Relaxed);
            return Err(ConnectionEnd::Framing("length outside 2..=254"));
        }
        let body = &mut pdu[..length - 1];
        read_exact_within(&mut stream, body, options.idle_timeout).await?;
        let unit = header[6];
        let answer = {
            let mut h = lock(&handler);
            h.handle_pdu(unit, body, &mut out)
        };
        let Some(n) = answer else { continue };
        counters.requests.fetch_add(1, Ordering::Relaxed);
        frame[..4].copy_from_slice(&header[..4]);
        frame[4..6].copy_from_slice(&((n + 1) as u16).to_be_bytes());
        frame[6] = unit;
        frame[MBAP_LEN..MBAP_LEN + n].copy_from_slice(&out[..n]);
        match tokio::time::timeout(
            options.idle_timeout,
            stream.write_all(&frame[..MBAP_LEN + n]),
        )
        .await
        {
            Err(_) => return Err(ConnectionEnd::Idle(options.idle_timeout)),
            Ok(r) => r?,
        }
    }
}

/// The listening socket did not open.
#[derive(Debug, thiserror::Error)]
#[error("modbus tcp: cannot bind {addr}: {source}")]
pub struct BindError {
    /// The address.
    pub addr: SocketAddr,
    /// The operating system's reason.
    pub source: std::io::Error,
}

/// Binds `addr` (with a clear error naming it).
pub async fn bind(addr: SocketAddr) -> Result<TcpListener, BindError> {
    TcpListener::bind(addr)
        .await
        .map_err(|source| BindError { addr, source })
}
