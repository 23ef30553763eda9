//! The node's health, shared by its servers, its links and the watchdog.
//!
//! * **Counters and states** of every server (TCP, TLS, RTU) and link (the DALI gateway),
//!   published in the communication-health registers (input 40..=51) and the status bit
//!   "communication ok". The counters belong to their servers (`crate::fieldbus`): each kind
//!   implements [`CommCounters`] and is kept here once ([`Health::counters`]), so health reads
//!   them without knowing the servers.
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

use std::any::Any;

use crate::modbus::regmap::CommHealth;

/// A server's or link's state.
pub mod state {
    /// Not configured.
    pub const NONE: u8 = 0;
    /// Up (listening, line open, link answering).
    pub const UP: u8 = 1;
    /// Configured but down (being reopened or rebound).
    pub const DOWN: u8 = 2;
}

/// A server's or link's counters, as the registers show them.
pub trait CommCounters: Any + Send + Sync + std::fmt::Debug {
    /// Writes this part's counters into the registers' view.
    fn report(&self, into: &mut CommHealth);

    /// The status bits this part raises now (`crate::modbus::regmap::status`; none by
    /// default).
    fn status(&self) -> u16 {
        0
    }
}

/// One kind of counters kept: the same object as a reporter and as itself.
#[derive(Debug)]
struct Kept {
    reporter: Arc<dyn CommCounters>,
    any: Arc<dyn Any + Send + Sync>,
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
    /// The servers' and links' counters, one of each kind ([`Health::counters`]).
    counters: Mutex<Vec<Kept>>,
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
            counters: Mutex::new(Vec::new()),
            tcp_state: AtomicU8::new(state::NONE),
            rtu_state: AtomicU8::new(state::NONE),
            tls_state: AtomicU8::new(state::NONE),
            writes_accepted: AtomicU64::new(0),
            writes_refused: AtomicU64::new(0),
        }
    }
}

impl Health {
    /// The counters of kind `T` (a server's or link's), made at the first call and the same
    /// ones after (they count on across a reload).
    pub fn counters<T: CommCounters + Default>(&self) -> Arc<T> {
        let mut kept = super::lock(&self.counters);
        if let Some(c) = kept.iter().find_map(|k| k.any.clone().downcast::<T>().ok()) {
            return c;
        }
        let c = Arc::new(T::default());
        kept.push(Kept {
            reporter: c.clone(),
            any: c.clone(),
        });
        c
    }

    /// Registers a part that beats at least every `limit`; it counts as alive from now.
    pub fn register(&self, name: &str, limit: Duration) -> Beat {
        let beat = Beat {
            last_ms: Arc::new(AtomicU64::new(0)),
            start: self.start,
        };
        beat.beat();
        let mut parts = super::lock(&self.parts);
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
        super::lock(&self.parts)
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

    /// The status bits the servers' and links' counters raise now.
    pub fn raised(&self) -> u16 {
        super::lock(&self.counters)
            .iter()
            .fold(0, |s, k| s | k.reporter.status())
    }

    /// The registers' view.
    pub fn snapshot(&self) -> CommHealth {
        let r = |a: &AtomicU64| low16(a.load(Ordering::Relaxed));
        let mut c = CommHealth {
            rtu_state: u16::from(self.rtu_state.load(Ordering::Relaxed)),
            writes_accepted: r(&self.writes_accepted),
            writes_refused: r(&self.writes_refused),
            tls_state: u16::from(self.tls_state.load(Ordering::Relaxed)),
            ..CommHealth::default()
        };
        for k in super::lock(&self.counters).iter() {
            k.reporter.report(&mut c);
        }
        c
    }
}

/// The low 16 bits of a counter, as the registers show it (it wraps).
pub fn low16(x: u64) -> u16 {
    x as u16
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
        h.counters::<Reopens>().0.store(70_000, Ordering::Relaxed);
        assert_eq!(h.snapshot().rtu_reopens, (70_000 % 65_536) as u16);
        // the same counters at the second call
        assert_eq!(h.counters::<Reopens>().0.load(Ordering::Relaxed), 70_000);
    }

    #[derive(Debug, Default)]
    struct Reopens(AtomicU64);

    impl CommCounters for Reopens {
        fn report(&self, into: &mut CommHealth) {
            into.rtu_reopens = low16(self.0.load(Ordering::Relaxed));
        }
    }
}
