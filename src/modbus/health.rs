//! The node's health, shared by its servers, its links and the watchdog.
//!
//! * **Counters and states** of every server (TCP, TLS, RTU) and link (the DALI gateway),
//!   published in the communication-health registers (input 40..=51) and the status bit
//!   "communication ok".
//! * **Liveness.** Every long-running part (the TCP accept loop, the RTU line, the gateway
//!   link, the sensor probe) beats at least once per its limit, even when idle. The systemd
//!   watchdog is petted only while no registered part is late ([`Health::late`]): a part that
//!   hangs or dies (a panic ends its beats, since a handle is only retired on purpose) stops
//!   the petting and systemd restarts the node. A part that is alive but degraded (a serial
//!   line being reopened, a gateway that does not answer) keeps beating: a restart would not
//!   bring a cable back, so that shows in the registers and the log instead.

use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::gateway::GatewayCounters;
use super::regmap::CommHealth;
use super::rtu::RtuCounters;
use super::tcp::TcpCounters;

/// A server's or link's state.
pub mod state {
    /// Not configured.
    pub const NONE: u8 = 0;
    /// Up (listening, line open, link answering).
    pub const UP: u8 = 1;
    /// Configured but down (being reopened or rebound).
    pub const DOWN: u8 = 2;
}

/// One registered part's beat.
#[derive(Debug)]
struct Part {
    name: String,
    last_ms: Arc<AtomicU64>,
    limit: Duration,
}

const RETIRED: u64 = u64::MAX;

/// A part's handle: beat it, retire it when it stops on purpose.
#[derive(Debug, Clone)]
pub struct Beat {
    last_ms: Arc<AtomicU64>,
    start: Instant,
}

impl Beat {
    /// Marks the part alive now.
    pub fn beat(&self) {
        let ms = self
            .start
            .elapsed()
            .as_millis()
            .min(u128::from(RETIRED - 1)) as u64;
        self.last_ms.store(ms, Ordering::Relaxed);
    }

    /// The part stopped on purpose (shutdown, reload): it no longer counts.
    pub fn retire(&self) {
        self.last_ms.store(RETIRED, Ordering::Relaxed);
    }
}

/// Everything the servers and links report.
#[derive(Debug)]
pub struct Health {
    start: Instant,
    parts: Mutex<Vec<Part>>,
    /// TCP and TLS servers' counters.
    pub tcp: Arc<TcpCounters>,
    /// RTU server's counters.
    pub rtu: Arc<RtuCounters>,
    /// Gateway link's counters.
    pub gateway: Arc<GatewayCounters>,
    /// Plain TCP server state ([`state`]).
    pub tcp_state: AtomicU8,
    /// RTU line state.
    pub rtu_state: AtomicU8,
    /// TLS server state.
    pub tls_state: AtomicU8,
    /// Writes executed.
    pub writes_accepted: AtomicU64,
    /// Writes refused (source not allowed).
    pub writes_refused: AtomicU64,
}

impl Default for Health {
    fn default() -> Self {
        Self {
            start: Instant::now(),
            parts: Mutex::new(Vec::new()),
            tcp: Arc::default(),
            rtu: Arc::default(),
            gateway: Arc::default(),
            tcp_state: AtomicU8::new(state::NONE),
            rtu_state: AtomicU8::new(state::NONE),
            tls_state: AtomicU8::new(state::NONE),
            writes_accepted: AtomicU64::new(0),
            writes_refused: AtomicU64::new(0),
        }
    }
}

fn low16(x: u64) -> u16 {
    x as u16
}

impl Health {
    /// Registers a part that beats at least every `limit`; it counts as alive from now.
    pub fn register(&self, name: &str, limit: Duration) -> Beat {
        let beat = Beat {
            last_ms: Arc::new(AtomicU64::new(0)),
            start: self.start,
        };
        beat.beat();
        let mut parts = super::node::lock(&self.parts);
        // retired parts are forgotten when new ones come
        parts.retain(|p| p.last_ms.load(Ordering::Relaxed) != RETIRED);
        parts.push(Part {
            name: name.to_owned(),
            last_ms: beat.last_ms.clone(),
            limit,
        });
        beat
    }

    /// The parts that missed their beat (empty: all alive), with how long they are silent.
    pub fn late(&self) -> Vec<(String, Duration)> {
        let now = self.start.elapsed();
        super::node::lock(&self.parts)
            .iter()
            .filter_map(|p| {
                let last = p.last_ms.load(Ordering::Relaxed);
                if last == RETIRED {
                    return None;
                }
                let silent = now.saturating_sub(Duration::from_millis(last));
                (silent > p.limit).then(|| (p.name.clone(), silent))
            })
            .collect()
    }

    /// True when every configured server is up.
    pub fn comm_ok(&self) -> bool {
        [&self.tcp_state, &self.rtu_state, &self.tls_state]
            .iter()
            .all(|s| s.load(Ordering::Relaxed) != state::DOWN)
    }

    /// The registers' view.
    pub fn snapshot(&self) -> CommHealth {
        let r = |a: &AtomicU64| low16(a.load(Ordering::Relaxed));
        CommHealth {
            tcp_open: self
                .tcp
                .open
                .load(Ordering::Relaxed)
                .min(usize::from(u16::MAX)) as u16,
            tcp_refused: r(&self.tcp.refused),
            tcp_evicted: r(&self.tcp.evicted),
            rtu_state: u16::from(self.rtu_state.load(Ordering::Relaxed)),
            rtu_reopens: r(&self.rtu.reopens),
            rtu_answered: r(&self.rtu.answered),
            rtu_discarded: r(&self.rtu.discarded),
            gateway_failures: r(&self.gateway.failures),
            writes_accepted: r(&self.writes_accepted),
            writes_refused: r(&self.writes_refused),
            tls_state: u16::from(self.tls_state.load(Ordering::Relaxed)),
            tls_failed: r(&self.tcp.tls_failed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_silent_part_is_late_a_retired_one_is_not() {
        let h = Health::default();
        let a = h.register("a", Duration::from_millis(30));
        let b = h.register("b", Duration::from_secs(60));
        assert!(h.late().is_empty());
        std::thread::sleep(Duration::from_millis(60));
        let late = h.late();
        assert_eq!(late.len(), 1, "{late:?}");
        assert_eq!(late[0].0, "a");
        a.beat();
        assert!(h.late().is_empty());
        std::thread::sleep(Duration::from_millis(60));
        a.retire();
        assert!(h.late().is_empty());
        b.beat();
        h.rtu_state.store(state::DOWN, Ordering::Relaxed);
        assert!(!h.comm_ok());
        h.rtu.reopens.store(70_000, Ordering::Relaxed);
        assert_eq!(h.snapshot().rtu_reopens, (70_000 % 65_536) as u16);
    }
}
