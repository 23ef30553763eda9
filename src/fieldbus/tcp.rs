//! Modbus TCP server (tokio): MBAP framing around the `no_std` PDU handler, in the clear or in
//! TLS (Modbus/TCP Security, [`super::tls`]).
//!
//! Why not the tokio-modbus server: its request codec drops the connection on a malformed PDU
//! (a 0x10 whose byte count does not match, a truncated request, an unknown MEI type) where a
//! field device must answer exception 0x03, and it computes `quantity * 2` in u16 (overflow).
//! The wire format here is seven bytes of header; everything else is [`crate::modbus::pdu`],
//! fuzzed. tokio-modbus remains the client (the DALI gateway link, the tests).
//!
//! * one task per connection; the shared state is locked only while a request is handled, so a
//!   slow or hostile client (half a header, never reading its answers) never blocks others;
//! * every request is handled as coming from its [`Source`] (address, TLS role): the node
//!   decides what it may write and in which word order it reads floats;
//! * connection caps: at most [`TcpOptions::max_connections`] in all and
//!   [`TcpOptions::max_per_source`] from one address. A new connection over a cap evicts the
//!   connection that has been silent longest (of that address, for the per-source cap), if it
//!   has been silent at least [`TcpOptions::evictable_after`]; otherwise the new one is closed
//!   at once (counted). Idle sockets therefore never lock anyone out: polling clients are never
//!   silent for long, parked sockets are;
//! * idle timeout: a connection silent for that long is closed; a write that cannot complete in
//!   that time closes it too;
//! * TCP_NODELAY on every connection;
//! * an MBAP header with a protocol id other than 0 or a length outside 2..=254 cannot be
//!   resynchronised: the connection is closed (counted); any PDU inside a valid header gets a
//!   response (an exception if need be).
//! * the unit id is echoed and not filtered (a TCP device answers every unit id, as gateways
//!   and most devices do; 0 and 255 are the usual ones). A client may pick its float word order
//!   by the unit id it addresses ([`crate::modbus::access`]).

use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::TcpListener;
use tokio::sync::{Notify, watch};

use super::PduHandler;
use crate::modbus::access::Source;
use crate::modbus::pdu::MAX_PDU;
use crate::modbus::regmap::CommHealth;
use crate::node::health::Beat;
use crate::node::health::{CommCounters, low16};
use crate::node::lock;

/// MBAP header length (transaction, protocol, length, unit).
pub const MBAP_LEN: usize = 7;

/// Default cap of connections: a BMS with 50 pollers, a gateway, tools, and room to spare.
pub const DEFAULT_MAX_CONNECTIONS: usize = 128;
/// Default cap of connections from one address.
pub const DEFAULT_MAX_PER_SOURCE: usize = 64;

/// Server options.
#[derive(Debug, Clone)]
pub struct TcpOptions {
    /// Most connections served at once.
    pub max_connections: usize,
    /// Most connections from one address.
    pub max_per_source: usize,
    /// A connection silent this long is closed.
    pub idle_timeout: Duration,
    /// A connection silent this long may be evicted for a new one when a cap is reached.
    pub evictable_after: Duration,
    /// Serve TLS (Modbus/TCP Security) on this listener.
    pub tls: Option<super::tls::TlsServer>,
}

impl Default for TcpOptions {
    fn default() -> Self {
        Self {
            max_connections: DEFAULT_MAX_CONNECTIONS,
            max_per_source: DEFAULT_MAX_PER_SOURCE,
            idle_timeout: Duration::from_secs(60),
            evictable_after: Duration::from_secs(2),
            tls: None,
        }
    }
}

/// Counters, for logs, registers and tests.
#[derive(Debug, Default)]
pub struct TcpCounters {
    /// Connections accepted.
    pub accepted: AtomicU64,
    /// Connections refused at a cap.
    pub refused: AtomicU64,
    /// Idle connections evicted for a new one.
    pub evicted: AtomicU64,
    /// Connections closed for silence.
    pub idle_closed: AtomicU64,
    /// Connections closed for a broken MBAP header.
    pub framing_closed: AtomicU64,
    /// TLS handshakes that failed (no or a bad client certificate, not TLS).
    pub tls_failed: AtomicU64,
    /// Requests answered.
    pub requests: AtomicU64,
    /// Connections open now.
    pub open: AtomicUsize,
}

impl CommCounters for TcpCounters {
    fn report(&self, into: &mut CommHealth) {
        let r = |a: &AtomicU64| low16(a.load(Ordering::Relaxed));
        into.tcp_open = self.open.load(Ordering::Relaxed).min(usize::from(u16::MAX)) as u16;
        into.tcp_refused = r(&self.refused);
        into.tcp_evicted = r(&self.evicted);
        into.tls_failed = r(&self.tls_failed);
    }
}

/// One open connection, as the admission sees it.
struct Conn {
    id: u64,
    ip: IpAddr,
    last_ms: Arc<AtomicU64>,
    kill: Arc<Notify>,
}

struct Registry {
    start: Instant,
    conns: Mutex<Vec<Conn>>,
    next: AtomicU64,
    /// When a refusal or eviction was last logged, ms.
    last_refusal_log_ms: AtomicU64,
}

impl Registry {
    fn now_ms(&self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    /// Admits a connection from `ip`, evicting the longest-silent evictable one at a cap.
    /// Returns its id, activity clock and kill switch, or `None` (refused).
    fn admit(
        &self,
        ip: IpAddr,
        options: &TcpOptions,
        counters: &TcpCounters,
    ) -> Option<(u64, Arc<AtomicU64>, Arc<Notify>)> {
        let now = self.now_ms();
        let evictable = options.evictable_after.as_millis() as u64;
        let mut conns = lock(&self.conns);
        let same = conns.iter().filter(|c| c.ip == ip).count();
        let cap_hit = if same >= options.max_per_source {
            Some(true)
        } else if conns.len() >= options.max_connections {
            Some(false)
        } else {
            None
        };
        if let Some(per_source) = cap_hit {
            let victim = conns
                .iter()
                .enumerate()
                .filter(|(_, c)| !per_source || c.ip == ip)
                .map(|(k, c)| (k, c.last_ms.load(Ordering::Relaxed)))
                .filter(|(_, last)| now.saturating_sub(*last) >= evictable)
                .min_by_key(|(_, last)| *last)
                .map(|(k, _)| k);
            let Some(k) = victim else {
                counters.refused.fetch_add(1, Ordering::Relaxed);
                return None;
            };
            let v = conns.swap_remove(k);
            v.kill.notify_one();
            counters.evicted.fetch_add(1, Ordering::Relaxed);
            tracing::info!(
                "modbus tcp: {} cap reached; evicted the connection from {} silent {} ms",
                if per_source {
                    "per-source"
                } else {
                    "connection"
                },
                v.ip,
                now.saturating_sub(v.last_ms.load(Ordering::Relaxed))
            );
        }
        let id = self.next.fetch_add(1, Ordering::Relaxed);
        let last_ms = Arc::new(AtomicU64::new(now));
        let kill = Arc::new(Notify::new());
        conns.push(Conn {
            id,
            ip,
            last_ms: last_ms.clone(),
            kill: kill.clone(),
        });
        Some((id, last_ms, kill))
    }

    /// True at most once a second: an attack must not flood the journal.
    fn may_log(&self) -> bool {
        let now = self.now_ms().max(1);
        let last = self.last_refusal_log_ms.load(Ordering::Relaxed);
        if last == 0 || now.saturating_sub(last) >= 1000 {
            self.last_refusal_log_ms.store(now, Ordering::Relaxed);
            true
        } else {
            false
        }
    }

    fn remove(&self, id: u64) {
        lock(&self.conns).retain(|c| c.id != id);
    }
}

struct OpenGuard {
    counters: Arc<TcpCounters>,
    registry: Arc<Registry>,
    id: u64,
}

impl Drop for OpenGuard {
    fn drop(&mut self) {
        self.counters.open.fetch_sub(1, Ordering::SeqCst);
        self.registry.remove(self.id);
    }
}

/// Serves `handler` on `listener` until `shutdown` turns true; beats `beat` at least once a
/// second while the accept loop runs.
pub async fn serve<H: PduHandler + 'static>(
    listener: TcpListener,
    handler: Arc<Mutex<H>>,
    options: TcpOptions,
    counters: Arc<TcpCounters>,
    mut shutdown: watch::Receiver<bool>,
    beat: Option<Beat>,
) -> std::io::Result<()> {
    let registry = Arc::new(Registry {
        start: Instant::now(),
        conns: Mutex::new(Vec::new()),
        next: AtomicU64::new(0),
        last_refusal_log_ms: AtomicU64::new(0),
    });
    let mut tick = tokio::time::interval(Duration::from_secs(1));
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
            _ = tick.tick() => {
                if let Some(b) = &beat {
                    b.beat();
                }
                continue;
            }
            _ = shutdown.changed() => return Ok(()),
        };
        if *shutdown.borrow() {
            return Ok(());
        }
        let Some((id, last_ms, kill)) = registry.admit(peer.ip(), &options, &counters) else {
            // at most one line a second, with the running count
            if registry.may_log() {
                tracing::warn!(
                    "modbus tcp: {peer} refused: caps of {} connections, {} per address reached \
                     and none silent for {:?} ({} refused so far)",
                    options.max_connections,
                    options.max_per_source,
                    options.evictable_after,
                    counters.refused.load(Ordering::Relaxed)
                );
            }
            drop(stream);
            continue;
        };
        counters.open.fetch_add(1, Ordering::SeqCst);
        let guard = OpenGuard {
            counters: counters.clone(),
            registry: registry.clone(),
            id,
        };
        counters.accepted.fetch_add(1, Ordering::Relaxed);
        let _ = stream.set_nodelay(true);
        let (handler, counters, options) = (handler.clone(), counters.clone(), options.clone());
        let mut shutdown = shutdown.clone();
        let registry = registry.clone();
        tokio::spawn(async move {
            let _guard = guard;
            let activity = Activity {
                registry: &registry,
                last_ms: &last_ms,
            };
            let run = async {
                match &options.tls {
                    None => {
                        let source = Source::Tcp(peer);
                        connection(stream, &source, &handler, &options, &counters, &activity).await
                    }
                    Some(tls) => {
                        let limit = options.idle_timeout.min(Duration::from_secs(10));
                        let accepted =
                            tokio::time::timeout(limit, tls.acceptor().accept(stream)).await;
                        let tls_stream = match accepted {
                            Ok(Ok(s)) => s,
                            Ok(Err(e)) => {
                                counters.tls_failed.fetch_add(1, Ordering::Relaxed);
                                tracing::warn!("modbus tls {peer}: handshake failed: {e}");
                                return Err(ConnectionEnd::Closed);
                            }
                            Err(_) => {
                                counters.tls_failed.fetch_add(1, Ordering::Relaxed);
                                tracing::warn!("modbus tls {peer}: no handshake in {limit:?}");
                                return Err(ConnectionEnd::Idle(limit));
                            }
                        };
                        let role = tls_stream
                            .get_ref()
                            .1
                            .peer_certificates()
                            .and_then(|c| c.first())
                            .and_then(|c| super::tls::modbus_role(c.as_ref()));
                        let source = Source::Tls { peer, role };
                        tracing::debug!("modbus tls: {source} connected");
                        connection(
                            tls_stream, &source, &handler, &options, &counters, &activity,
                        )
                        .await
                    }
                }
            };
            tokio::select! {
                r = run => {
                    if let Err(e) = r {
                        tracing::debug!("modbus tcp {peer}: {e}");
                    }
                }
                _ = kill.notified() => {
                    tracing::debug!("modbus tcp {peer}: evicted");
                }
                _ = shutdown.changed() => {}
            }
        });
    }
}

/// A connection's activity clock.
struct Activity<'a> {
    registry: &'a Registry,
    last_ms: &'a AtomicU64,
}

impl Activity<'_> {
    fn touch(&self) {
        self.last_ms
            .store(self.registry.now_ms(), Ordering::Relaxed);
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

async fn read_exact_within<S: AsyncRead + Unpin>(
    stream: &mut S,
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

async fn connection<S: AsyncRead + AsyncWrite + Unpin, H: PduHandler>(
    mut stream: S,
    source: &Source,
    handler: &Mutex<H>,
    options: &TcpOptions,
    counters: &TcpCounters,
    activity: &Activity<'_>,
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
                tracing::debug!("modbus tcp {source}: idle {d:?}, closing");
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
        activity.touch();
        let unit = header[6];
        let answer = {
            let mut h = lock(handler);
            h.handle_from(source, unit, body, &mut out)
        };
        let Some(n) = answer else { continue };
        counters.requests.fetch_add(1, Ordering::Relaxed);
        frame[..4].copy_from_slice(&header[..4]);
        frame[4..6].copy_from_slice(&((n + 1) as u16).to_be_bytes());
        frame[6] = unit;
        frame[MBAP_LEN..MBAP_LEN + n].copy_from_slice(&out[..n]);
        let write = async {
            stream.write_all(&frame[..MBAP_LEN + n]).await?;
            stream.flush().await
        };
        match tokio::time::timeout(options.idle_timeout, write).await {
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
