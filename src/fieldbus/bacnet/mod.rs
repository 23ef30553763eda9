//! The BACnet/IP adapter of the node: the services over datagrams ([`service`]), and the
//! server (tokio, UDP): datagrams onto [`service::Server`] with
//! the node locked only while one is handled, COV notifications every
//! [`crate::bacnet::cov::POLL`], and, when the board names a BBMD, foreign-device registration
//! (renewed at half its time-to-live; retried with a doubling backoff of 1 s to 60 s when the
//! BBMD does not answer or refuses; the state in [`BacnetCounters::fd_registered`] and the
//! log; while the BBMD does not accept the registration, Modbus status bit 9
//! ([`crate::modbus::regmap::status::BBMD_FAILING`]) and the Device's Reliability
//! communication-failure). Local service never waits for the BBMD.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use tokio::net::UdpSocket;
use tokio::sync::watch;

use crate::bacnet::cov::POLL;
use crate::bacnet::wire::bvlc;
use crate::modbus::regmap::{CommHealth, status};
use crate::node::health::{Beat, CommCounters};
use crate::node::{SharedNode, lock};
use service::{Outgoing, Server, ServerConfig};

pub mod service;

#[cfg(feature = "sim")]
pub mod fuzz;

/// The BACnet/IP port (0xBAC0).
pub const DEFAULT_PORT: u16 = 47808;

/// A BBMD to register with as a foreign device.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BbmdConfig {
    /// The BBMD's B/IP address.
    pub address: SocketAddr,
    /// Time-to-live asked for, s.
    pub ttl_s: u16,
}

/// How to serve BACnet/IP.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BacnetOptions {
    /// UDP address (port 0: any, logged at start).
    pub bind: SocketAddr,
    /// Device object and DCC settings.
    pub server: ServerConfig,
    /// Foreign-device registration.
    pub bbmd: Option<BbmdConfig>,
}

/// Counters, for logs and tests.
#[derive(Debug, Default)]
pub struct BacnetCounters {
    /// Datagrams received.
    pub received: AtomicU64,
    /// COV notifications sent.
    pub notifications: AtomicU64,
    /// Registered with the BBMD now (false without one).
    pub fd_registered: AtomicBool,
    /// Registration attempts not answered or refused.
    pub fd_failures: AtomicU64,
    /// The last registration attempt was not answered or refused (status bit
    /// [`status::BBMD_FAILING`], the Device's Reliability).
    pub fd_failing: AtomicBool,
}

impl CommCounters for BacnetCounters {
    // the Modbus communication registers have no BACnet entries (yet)
    fn report(&self, _into: &mut CommHealth) {}

    fn status(&self) -> u16 {
        if self.fd_failing.load(Ordering::Relaxed) {
            status::BBMD_FAILING
        } else {
            0
        }
    }
}

/// Foreign-device registration state.
struct Registration {
    config: BbmdConfig,
    next: Instant,
    sent: Option<Instant>,
    backoff: Duration,
}

/// How long the node waits for the BBMD's BVLC-Result.
const RESULT_WAIT: Duration = Duration::from_secs(2);
const BACKOFF_MAX: Duration = Duration::from_secs(60);

impl Registration {
    fn new(config: BbmdConfig) -> Self {
        Self {
            config,
            next: Instant::now(),
            sent: None,
            backoff: Duration::from_secs(1),
        }
    }

    /// The Register-Foreign-Device datagram when one is due.
    fn due(&mut self, now: Instant, counters: &BacnetCounters) -> Option<Vec<u8>> {
        if let Some(t) = self.sent
            && now.duration_since(t) >= RESULT_WAIT
        {
            self.failed(now, counters, "no answer");
        }
        if self.sent.is_some() || now < self.next {
            return None;
        }
        self.sent = Some(now);
        let ttl = self.config.ttl_s.to_be_bytes();
        Some(vec![
            bvlc::TYPE_BIP,
            bvlc::REGISTER_FOREIGN_DEVICE,
            0,
            6,
            ttl[0],
            ttl[1],
        ])
    }

    fn failed(&mut self, now: Instant, counters: &BacnetCounters, why: &str) {
        counters.fd_registered.store(false, Ordering::Relaxed);
        counters.fd_failures.fetch_add(1, Ordering::Relaxed);
        counters.fd_failing.store(true, Ordering::Relaxed);
        tracing::warn!(
            "bacnet: foreign-device registration with {} failed ({why}); retrying in {:?}",
            self.config.address,
            self.backoff
        );
        self.sent = None;
        self.next = now + self.backoff;
        self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
    }

    /// Takes the BBMD's answer; true when the node has just become registered.
    fn result(&mut self, now: Instant, code: u16, counters: &BacnetCounters) -> bool {
        if code == bvlc::RESULT_OK {
            counters.fd_failing.store(false, Ordering::Relaxed);
            let new = !counters.fd_registered.swap(true, Ordering::Relaxed);
            if new {
                tracing::info!(
                    "bacnet: registered as a foreign device with {} (ttl {} s)",
                    self.config.address,
                    self.config.ttl_s
                );
            }
            self.sent = None;
            self.backoff = Duration::from_secs(1);
            self.next = now + Duration::from_secs(u64::from(self.config.ttl_s / 2).max(1));
            new
        } else {
            self.failed(now, counters, &format!("result code {code:#06x}"));
            false
        }
    }
}

async fn send_all(socket: &UdpSocket, out: Vec<Outgoing>) {
    for o in out {
        if let Err(e) = socket.send_to(&o.datagram, o.to).await {
            tracing::debug!("bacnet: send to {}: {e}", o.to);
        }
    }
}

/// Serves BACnet/IP on `socket` until `shutdown` turns true.
pub async fn serve(
    socket: UdpSocket,
    node: SharedNode,
    options: BacnetOptions,
    counters: Arc<BacnetCounters>,
    mut shutdown: watch::Receiver<bool>,
    beat: Option<Beat>,
) -> std::io::Result<()> {
    let mut server = Server::new(options.server.clone());
    let mut registration = options.bbmd.clone().map(Registration::new);
    // a new socket registers anew: nothing has failed yet
    counters.fd_registered.store(false, Ordering::Relaxed);
    counters.fd_failing.store(false, Ordering::Relaxed);
    let mut tick = tokio::time::interval(POLL);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut buf = vec![0u8; 2048];
    // announce the device on the local network (a socket on loopback cannot broadcast: said in
    // the debug log, nothing else)
    if let (Ok(local), None) = (socket.local_addr(), &registration) {
        let all = SocketAddr::from(([255, 255, 255, 255], local.port()));
        if let Some(o) = server.i_am(bvlc::ORIGINAL_BROADCAST, all, None)
            && let Err(e) = socket.send_to(&o.datagram, o.to).await
        {
            tracing::debug!("bacnet: I-Am broadcast at start: {e}");
        }
    }
    loop {
        tokio::select! {
            r = socket.recv_from(&mut buf) => {
                let (n, from) = match r {
                    Ok(x) => x,
                    Err(e) => {
                        // ICMP port unreachable from an earlier send, and such: keep serving
                        tracing::debug!("bacnet recv: {e}");
                        continue;
                    }
                };
                counters.received.fetch_add(1, Ordering::Relaxed);
                let now = Instant::now();
                server.set_registration_failing(counters.fd_failing.load(Ordering::Relaxed));
                let out = {
                    let mut n_ = lock(&node);
                    server.handle(&mut n_, from, &buf[..n], now)
                };
                if let (Some(reg), Some((at, code))) = (registration.as_mut(), server.last_bvlc_result.take())
                    && at == reg.config.address
                    && reg.result(now, code, &counters)
                    && let Some(o) = server.i_am(bvlc::DISTRIBUTE_BROADCAST, at, None)
                {
                    // registered: announce the device through the BBMD
                    send_all(&socket, vec![o]).await;
                }
                send_all(&socket, out).await;
            }
            _ = tick.tick() => {
                if let Some(b) = &beat {
                    b.beat();
                }
                let now = Instant::now();
                let out = {
                    let n_ = lock(&node);
                    server.poll_cov(&n_, now)
                };
                counters.notifications.fetch_add(out.len() as u64, Ordering::Relaxed);
                send_all(&socket, out).await;
                if let Some(reg) = registration.as_mut()
                    && let Some(d) = reg.due(now, &counters)
                    && let Err(e) = socket.send_to(&d, reg.config.address).await
                {
                    tracing::debug!("bacnet: registration to {}: {e}", reg.config.address);
                }
            }
            _ = shutdown.changed() => return Ok(()),
        }
        if *shutdown.borrow() {
            return Ok(());
        }
    }
}

/// Binds `addr` (IPv4 broadcasts allowed: Who-Is arrives as one).
pub async fn bind(addr: SocketAddr) -> std::io::Result<UdpSocket> {
    let s = UdpSocket::bind(addr).await?;
    s.set_broadcast(true)?;
    Ok(s)
}

/// Serves BACnet/IP, rebinding after a failure, until stop.
pub async fn supervise(
    node: SharedNode,
    options: BacnetOptions,
    health: Arc<crate::node::health::Health>,
    stop_rx: watch::Receiver<bool>,
) {
    let beat = health.register("bacnet", Duration::from_secs(10));
    let mut addr = options.bind;
    loop {
        if *stop_rx.borrow() {
            break;
        }
        beat.beat();
        let socket = match bind(addr).await {
            Ok(s) => s,
            Err(e) => {
                tracing::error!("bacnet: cannot bind {addr}: {e}; retrying in 2 s");
                tokio::time::sleep(Duration::from_secs(2)).await;
                continue;
            }
        };
        if let Ok(a) = socket.local_addr() {
            tracing::info!(address = %a, "bacnet listening on {a} (device {})", options.server.device.instance);
            addr = a;
        }
        let inner = tokio::spawn(serve(
            socket,
            node.clone(),
            options.clone(),
            health.counters::<BacnetCounters>(),
            stop_rx.clone(),
            Some(beat.clone()),
        ));
        match inner.await {
            Ok(Ok(())) => break,
            Ok(Err(e)) => tracing::error!("bacnet on {addr} failed: {e}; rebinding"),
            Err(e) => tracing::error!("bacnet on {addr} failed: {e}; rebinding"),
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
    beat.retire();
}
