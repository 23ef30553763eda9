//! The DALI gateway link: a Modbus TCP client (tokio-modbus) that polls a gateway's arc levels
//! into the node and, optionally, writes the desk lux back.
//!
//! Gateways differ in layout, so the layout is configuration (`[gateway]` in the board file,
//! or a TOML file for `luxnode serve --gateway`):
//!
//! ```toml
//! address = "127.0.0.1:1503"   # host:port
//! unit_id = 1
//! poll_interval_ms = 500
//! timeout_ms = 300             # per request
//! retries = 2                  # extra attempts before the link counts as lost
//! [levels]                     # luminaire j's level is at base + stride * j
//! function = "holding"         # or "input"
//! base = 0
//! stride = 1
//! encoding = "dali"            # 0..=254 arc level (255 = no change), or "percent" (0..=100)
//! [lux]                        # optional: desk k's lux written as u16 at base + stride * k
//! base = 200
//! stride = 1
//! scale = 1.0                  # register = round(lux × scale), saturating at 65534
//! ```
//!
//! A value outside its encoding's range leaves that luminaire's level unchanged (counted).
//! When a poll fails `retries + 1` times in a row the link is lost: the node keeps serving the
//! last good values, flagged stale; the next successful poll clears the flag.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use serde::Deserialize;
use tokio::sync::watch;
use tokio_modbus::client::{Context, Reader, Writer};
use tokio_modbus::prelude::Slave;

use crate::modbus::pdu::{MAX_READ, MAX_WRITE};
use crate::modbus::regmap::CommHealth;
use crate::modbus::regmap::U16_LUX_MAX;
use crate::node::NodeError;
use crate::node::health::{CommCounters, low16};
use crate::node::{SharedNode, lock};

/// Why the gateway link, its configuration or a write to the gateway failed.
#[derive(Debug, thiserror::Error)]
pub enum GatewayError {
    /// The configuration is unusable.
    #[error("gateway config: {0}")]
    Config(String),
    /// No answer in time.
    #[error("gateway: timeout {0}")]
    Timeout(String),
    /// The gateway answered with a Modbus exception.
    #[error("gateway exception {code:?} {what}")]
    Exception {
        /// The exception.
        code: tokio_modbus::ExceptionCode,
        /// What was asked.
        what: String,
    },
    /// The gateway answered, but not what was asked.
    #[error("gateway: {0}")]
    Answer(String),
    /// The connection failed.
    #[error("gateway: {0}")]
    Link(#[from] tokio_modbus::Error),
    /// The client's own runtime or socket failed.
    #[error("gateway: {0}")]
    Io(#[from] std::io::Error),
    /// The node refused the levels.
    #[error("gateway levels: {0}")]
    Node(#[from] NodeError),
}

fn exception(what: String) -> impl FnOnce(tokio_modbus::ExceptionCode) -> GatewayError {
    move |code| GatewayError::Exception { code, what }
}

/// Where the levels are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum RegisterKind {
    /// Holding registers (function 0x03).
    #[default]
    Holding,
    /// Input registers (function 0x04).
    Input,
}

/// How a level is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Encoding {
    /// DALI arc level 0..=254, 255 = no change.
    #[default]
    Dali,
    /// Percent of full output, 0..=100.
    Percent,
}

fn one() -> u16 {
    1
}

/// The levels' layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelsLayout {
    /// Register kind.
    #[serde(default)]
    pub function: RegisterKind,
    /// Address of luminaire 0.
    pub base: u16,
    /// Registers between luminaires.
    #[serde(default = "one")]
    pub stride: u16,
    /// Encoding.
    #[serde(default)]
    pub encoding: Encoding,
}

fn unit_scale() -> f64 {
    1.0
}

/// Where desk lux is written back (holding registers).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LuxLayout {
    /// Address of desk 0.
    pub base: u16,
    /// Registers between desks.
    #[serde(default = "one")]
    pub stride: u16,
    /// Register value per lux.
    #[serde(default = "unit_scale")]
    pub scale: f64,
}

fn default_unit() -> u8 {
    1
}
fn default_poll() -> u64 {
    500
}
fn default_timeout() -> u64 {
    300
}
fn default_retries() -> u32 {
    2
}

/// A gateway link configuration.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatewayConfig {
    /// host:port.
    pub address: String,
    /// Unit id of the gateway.
    #[serde(default = "default_unit")]
    pub unit_id: u8,
    /// Poll period, ms.
    #[serde(default = "default_poll")]
    pub poll_interval_ms: u64,
    /// Per-request timeout, ms.
    #[serde(default = "default_timeout")]
    pub timeout_ms: u64,
    /// Extra attempts before the link counts as lost.
    #[serde(default = "default_retries")]
    pub retries: u32,
    /// Levels layout.
    pub levels: LevelsLayout,
    /// Lux write-back, if any.
    #[serde(default)]
    pub lux: Option<LuxLayout>,
}

impl GatewayConfig {
    /// Parses and checks a TOML description.
    pub fn from_toml(text: &str) -> Result<Self, GatewayError> {
        let c: GatewayConfig =
            toml::from_str(text).map_err(|e| GatewayError::Config(e.to_string()))?;
        c.validate()?;
        Ok(c)
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), GatewayError> {
        let ensure = |ok: bool, what: String| {
            if ok {
                Ok(())
            } else {
                Err(GatewayError::Config(what))
            }
        };
        self.socket_addr()?;
        ensure(self.levels.stride >= 1, "levels.stride must be >= 1".into())?;
        ensure(
            (10..=3_600_000).contains(&self.poll_interval_ms),
            format!(
                "poll_interval_ms {} outside 10..=3600000",
                self.poll_interval_ms
            ),
        )?;
        ensure(
            (10..=60_000).contains(&self.timeout_ms),
            format!("timeout_ms {} outside 10..=60000", self.timeout_ms),
        )?;
        ensure(self.retries <= 10, format!("retries {} > 10", self.retries))?;
        if let Some(l) = &self.lux {
            ensure(l.stride >= 1, "lux.stride must be >= 1".into())?;
            ensure(
                l.scale.is_finite() && l.scale > 0.0,
                "lux.scale must be > 0".into(),
            )?;
        }
        Ok(())
    }

    /// The gateway's socket address.
    pub fn socket_addr(&self) -> Result<SocketAddr, GatewayError> {
        use std::net::ToSocketAddrs;
        self.address
            .to_socket_addrs()
            .map_err(|e| GatewayError::Config(format!("address {:?}: {e}", self.address)))?
            .next()
            .ok_or_else(|| {
                GatewayError::Config(format!("address {:?} resolves to nothing", self.address))
            })
    }

    /// Register addresses of `count` luminaires' levels; an error if they pass 65535.
    pub fn level_addresses(&self, count: usize) -> Result<Vec<u16>, GatewayError> {
        addresses(self.levels.base, self.levels.stride, count, "levels")
    }
}

fn addresses(base: u16, stride: u16, count: usize, what: &str) -> Result<Vec<u16>, GatewayError> {
    (0..count)
        .map(|j| {
            u16::try_from(usize::from(base) + usize::from(stride) * j).map_err(|_| {
                GatewayError::Config(format!("{what}: register of item {j} is past 65535"))
            })
        })
        .collect()
}

/// Decodes one level register: `Some(fraction)`, `None` for "no change" or an invalid value
/// (the second element says it was invalid).
pub fn decode_level(
    encoding: Encoding,
    value: u16,
    curve: crate::dali::DimmingCurve,
) -> (Option<f64>, bool) {
    match encoding {
        Encoding::Dali => match value {
            255 => (None, false),
            0..=254 => (crate::dali::ArcLevel(value as u8).fraction(curve), false),
            _ => (None, true),
        },
        Encoding::Percent => {
            if value <= 100 {
                (Some(f64::from(value) / 100.0), false)
            } else {
                (None, true)
            }
        }
    }
}

/// The levels a poll's level registers give, and how many were out of range. A gateway that
/// answers with nothing but out-of-range levels tells nothing of the dimming state: a failed
/// poll (the link goes down, the values stale), not a good one.
pub fn levels_of(
    encoding: Encoding,
    words: &[u16],
    curve: crate::dali::DimmingCurve,
) -> Result<(Vec<Option<f64>>, usize), GatewayError> {
    let mut levels = Vec::with_capacity(words.len());
    let mut invalid_now = 0;
    for &w in words {
        let (x, invalid) = decode_level(encoding, w, curve);
        invalid_now += usize::from(invalid);
        levels.push(x);
    }
    if !words.is_empty() && invalid_now == words.len() {
        return Err(GatewayError::Answer(format!(
            "every one of the {} level registers is out of range ({:?})",
            words.len(),
            &words[..words.len().min(8)]
        )));
    }
    Ok((levels, invalid_now))
}

/// Counters.
#[derive(Debug, Default)]
pub struct GatewayCounters {
    /// Successful polls.
    pub polls_ok: AtomicU64,
    /// Polls whose levels were not applied: the lighting control delivered new levels while the
    /// read was in flight.
    pub superseded_reads: AtomicU64,
    /// Failed attempts.
    pub failures: AtomicU64,
    /// Times the link was declared lost.
    pub lost: AtomicU64,
    /// Register values outside the encoding's range.
    pub invalid_values: AtomicU64,
    /// Lux write-backs done.
    pub lux_writes: AtomicU64,
}

impl CommCounters for GatewayCounters {
    fn report(&self, into: &mut CommHealth) {
        into.gateway_failures = low16(self.failures.load(Ordering::Relaxed));
    }
}

/// Reads the registers at `addrs` (contiguous runs in as few requests as possible).
async fn read_registers(
    ctx: &mut Context,
    kind: RegisterKind,
    addrs: &[u16],
    timeout: Duration,
) -> Result<Vec<u16>, GatewayError> {
    let mut out = Vec::with_capacity(addrs.len());
    let (Some(&first), Some(&last)) = (addrs.first(), addrs.last()) else {
        return Ok(out);
    };
    // read the span in chunks of at most 125 registers and pick
    let mut span = Vec::with_capacity(usize::from(last - first) + 1);
    let mut a = first;
    loop {
        let n = (usize::from(last - a) + 1).min(MAX_READ) as u16;
        let fut = async {
            match kind {
                RegisterKind::Holding => ctx.read_holding_registers(a, n).await,
                RegisterKind::Input => ctx.read_input_registers(a, n).await,
            }
        };
        let words = tokio::time::timeout(timeout, fut)
            .await
            .map_err(|_| GatewayError::Timeout(format!("reading registers {a}..{}", a + n)))??
            .map_err(exception(format!("reading {a}..{}", a + n)))?;
        if words.len() != usize::from(n) {
            return Err(GatewayError::Answer(format!(
                "{} registers for {n}",
                words.len()
            )));
        }
        span.extend(words);
        match a.checked_add(n) {
            Some(next) if next <= last => a = next,
            _ => break,
        }
    }
    for &x in addrs {
        out.push(span[usize::from(x - first)]);
    }
    Ok(out)
}

async fn write_lux(
    ctx: &mut Context,
    layout: &LuxLayout,
    lux: &[f64],
    timeout: Duration,
) -> Result<(), GatewayError> {
    let values: Vec<u16> = lux
        .iter()
        .map(|&x| {
            let v = x * layout.scale;
            if !v.is_finite() {
                crate::modbus::regmap::NOT_AVAILABLE_U16
            } else {
                v.round().clamp(0.0, f64::from(U16_LUX_MAX)) as u16
            }
        })
        .collect();
    let addrs = addresses(layout.base, layout.stride, values.len(), "lux")?;
    if layout.stride == 1 {
        for (chunk, a) in values.chunks(MAX_WRITE).zip(addrs.chunks(MAX_WRITE)) {
            let fut = ctx.write_multiple_registers(a[0], chunk);
            tokio::time::timeout(timeout, fut)
                .await
                .map_err(|_| GatewayError::Timeout("writing lux".into()))??
                .map_err(exception("writing lux".into()))?;
        }
    } else {
        for (&v, &a) in values.iter().zip(&addrs) {
            let fut = ctx.write_single_register(a, v);
            tokio::time::timeout(timeout, fut)
                .await
                .map_err(|_| GatewayError::Timeout("writing lux".into()))??
                .map_err(exception("writing lux".into()))?;
        }
    }
    Ok(())
}

/// One poll: connect if needed, read the levels, apply them, write the lux back.
async fn poll_once(
    ctx: &mut Option<Context>,
    config: &GatewayConfig,
    addr: SocketAddr,
    node: &SharedNode,
    counters: &GatewayCounters,
) -> Result<(), GatewayError> {
    let timeout = Duration::from_millis(config.timeout_ms);
    if ctx.is_none() {
        let c = tokio::time::timeout(
            timeout,
            tokio_modbus::client::tcp::connect_slave(addr, Slave(config.unit_id)),
        )
        .await
        .map_err(|_| GatewayError::Timeout(format!("connecting to {addr}")))??;
        *ctx = Some(c);
    }
    let Some(c) = ctx.as_mut() else {
        return Err(GatewayError::Answer("no connection".into()));
    };
    let (count, curve, delivered_before) = {
        let n = lock(node);
        (n.levels().len(), n.map().curve, n.levels_delivered())
    };
    let addrs = config.level_addresses(count)?;
    let words = read_registers(c, config.levels.function, &addrs, timeout).await?;
    let (levels, invalid_now) = levels_of(config.levels.encoding, &words, curve)?;
    counters
        .invalid_values
        .fetch_add(invalid_now as u64, Ordering::Relaxed);
    let lux: Vec<f64> = {
        let mut n = lock(node);
        if n.levels_delivered() == delivered_before {
            n.set_levels(&levels)?;
        } else {
            // the lighting control wrote new levels while this read was in flight: the read may
            // hold the old ones; the next poll reads the new
            counters.superseded_reads.fetch_add(1, Ordering::Relaxed);
        }
        n.set_gateway_link(true);
        n.desks().iter().map(|d| d.1).collect()
    };
    counters.polls_ok.fetch_add(1, Ordering::Relaxed);
    if let Some(layout) = &config.lux {
        write_lux(c, layout, &lux, timeout).await?;
        counters.lux_writes.fetch_add(1, Ordering::Relaxed);
    }
    Ok(())
}

impl GatewayConfig {
    /// The longest a healthy link loop goes without a beat: a poll period plus every attempt
    /// timing out, plus a margin.
    pub fn beat_limit(&self) -> Duration {
        let attempts = u64::from(self.retries) + 1;
        Duration::from_millis(self.poll_interval_ms + attempts * 2 * self.timeout_ms)
            + Duration::from_secs(10)
    }
}

/// Runs the link until `shutdown` turns true; beats `beat` at every poll.
pub async fn run(
    config: GatewayConfig,
    node: SharedNode,
    counters: Arc<GatewayCounters>,
    mut shutdown: watch::Receiver<bool>,
    beat: Option<crate::node::health::Beat>,
) -> Result<(), GatewayError> {
    config.validate()?;
    let addr = config.socket_addr()?;
    let mut ctx: Option<Context> = None;
    let mut interval = tokio::time::interval(Duration::from_millis(config.poll_interval_ms));
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut up = false;
    loop {
        tokio::select! {
            _ = interval.tick() => {}
            _ = shutdown.changed() => return Ok(()),
        }
        if let Some(b) = &beat {
            b.beat();
        }
        let mut attempt = 0;
        loop {
            match poll_once(&mut ctx, &config, addr, &node, &counters).await {
                Ok(()) => {
                    if !up {
                        tracing::info!("dali gateway {addr}: link up");
                    }
                    up = true;
                    break;
                }
                Err(e) => {
                    counters.failures.fetch_add(1, Ordering::Relaxed);
                    ctx = None; // reconnect: the stream may be out of step after a timeout
                    attempt += 1;
                    if let Some(b) = &beat {
                        b.beat();
                    }
                    if attempt > config.retries {
                        if up {
                            tracing::warn!(
                                "dali gateway {addr}: link lost ({e}); serving the last values as stale"
                            );
                            counters.lost.fetch_add(1, Ordering::Relaxed);
                        } else {
                            tracing::debug!("dali gateway {addr}: {e}");
                        }
                        up = false;
                        lock(&node).set_gateway_link(false);
                        break;
                    }
                }
            }
        }
    }
}

/// Writes the luminaires' levels to the gateway, in the configured layout and encoding: the
/// commissioning capture switches them one at a time through it. Synchronous (the capture runs
/// before the servers start), on its own small runtime.
pub struct GatewayWriter {
    rt: tokio::runtime::Runtime,
    ctx: Context,
    config: GatewayConfig,
}

impl GatewayWriter {
    /// Connects to the gateway.
    pub fn connect(config: &GatewayConfig) -> Result<Self, GatewayError> {
        config.validate()?;
        let addr = config.socket_addr()?;
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        let timeout = Duration::from_millis(config.timeout_ms);
        let unit = Slave(config.unit_id);
        let ctx = rt
            .block_on(async {
                tokio::time::timeout(
                    timeout,
                    tokio_modbus::client::tcp::connect_slave(addr, unit),
                )
                .await
            })
            .map_err(|_| GatewayError::Timeout(format!("connecting to the gateway {addr}")))??;
        Ok(Self {
            rt,
            ctx,
            config: config.clone(),
        })
    }

    /// The register value of a level in [0, 1].
    pub fn encode(&self, level: f64) -> Option<u16> {
        match self.config.levels.encoding {
            Encoding::Dali => {
                crate::dali::ArcLevel::nearest(level, crate::dali::DimmingCurve::Logarithmic)
                    .map(|a| u16::from(a.0))
            }
            Encoding::Percent => (level.is_finite() && (0.0..=1.0).contains(&level))
                .then(|| (level * 100.0).round() as u16),
        }
    }
}

impl GatewayWriter {
    /// Writes one level in [0, 1] per luminaire (luminaire order).
    pub fn write_levels(&mut self, levels: &[f64]) -> Result<(), GatewayError> {
        if self.config.levels.function != RegisterKind::Holding {
            return Err(GatewayError::Config(
                "the gateway's levels are input registers: they cannot be written".into(),
            ));
        }
        let addrs = self.config.level_addresses(levels.len())?;
        let timeout = Duration::from_millis(self.config.timeout_ms);
        for (&x, &a) in levels.iter().zip(&addrs) {
            let v = self
                .encode(x)
                .ok_or_else(|| GatewayError::Config(format!("level {x} outside [0, 1]")))?;
            let ctx = &mut self.ctx;
            self.rt
                .block_on(async {
                    tokio::time::timeout(timeout, ctx.write_single_register(a, v)).await
                })
                .map_err(|_| GatewayError::Timeout(format!("writing register {a}")))??
                .map_err(exception(format!("writing register {a}")))?;
        }
        Ok(())
    }
}

/// The register value of an arc level in a gateway's encoding: the level itself for DALI, its
/// light output in whole per cent (on the logarithmic curve) for percent gateways.
pub fn encode_arc(encoding: Encoding, arc: crate::dali::ArcLevel) -> u16 {
    match encoding {
        Encoding::Dali => u16::from(arc.0),
        Encoding::Percent => arc
            .fraction(crate::dali::DimmingCurve::Logarithmic)
            .map_or(0, |x| (x * 100.0).round() as u16),
    }
}

/// Writes arc levels (luminaire order) to the gateway's level registers, one request per
/// contiguous run (write multiple registers), each within the configured timeout.
pub async fn write_arc_levels(
    ctx: &mut Context,
    config: &GatewayConfig,
    arcs: &[crate::dali::ArcLevel],
) -> Result<(), GatewayError> {
    if config.levels.function != RegisterKind::Holding {
        return Err(GatewayError::Config(
            "the gateway's levels are input registers: they cannot be written".into(),
        ));
    }
    let addrs = config.level_addresses(arcs.len())?;
    let values: Vec<u16> = arcs
        .iter()
        .map(|&a| encode_arc(config.levels.encoding, a))
        .collect();
    let timeout = Duration::from_millis(config.timeout_ms);
    let mut start = 0;
    while start < values.len() {
        // the longest run of consecutive addresses, at most one request's worth
        let mut end = start + 1;
        while end < values.len() && end - start < MAX_WRITE && addrs[end] == addrs[end - 1] + 1 {
            end += 1;
        }
        let a = addrs[start];
        let chunk = &values[start..end];
        let fut = async {
            if chunk.len() == 1 {
                ctx.write_single_register(a, chunk[0]).await
            } else {
                ctx.write_multiple_registers(a, chunk).await
            }
        };
        tokio::time::timeout(timeout, fut)
            .await
            .map_err(|_| GatewayError::Timeout(format!("writing levels at {a}")))??
            .map_err(exception(format!("writing levels at {a}")))?;
        start = end;
    }
    Ok(())
}

/// Connects to the gateway within its timeout.
pub async fn connect(config: &GatewayConfig) -> Result<Context, GatewayError> {
    let addr = config.socket_addr()?;
    Ok(tokio::time::timeout(
        Duration::from_millis(config.timeout_ms),
        tokio_modbus::client::tcp::connect_slave(addr, Slave(config.unit_id)),
    )
    .await
    .map_err(|_| GatewayError::Timeout(format!("connecting to {addr}")))??)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dali::DimmingCurve;

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config {
            cases: 2048,
            rng_seed: proptest::test_runner::RngSeed::Fixed(34),
            failure_persistence: None,
            ..proptest::test_runner::Config::default()
        })]
        /// Issue 34 item 5: a poll's level registers, in either encoding and curve, give a
        /// level in [0, 1] for every in-range word (percent 0..=100; DALI arc 0..=254, 255 the
        /// MASK "no change" and no level), count every out-of-range word, and fail the poll
        /// (link down, values stale) exactly when every word is out of range.
        #[test]
        fn level_registers_decode_or_fail_the_poll_exactly_when_all_are_out_of_range(
            words in proptest::collection::vec(
                proptest::prop_oneof![0u16..=300, proptest::prelude::any::<u16>()], 0..16),
            dali in proptest::prelude::any::<bool>(),
            linear in proptest::prelude::any::<bool>(),
        ) {
            let encoding = if dali { Encoding::Dali } else { Encoding::Percent };
            let curve = if linear { DimmingCurve::Linear } else { DimmingCurve::Logarithmic };
            let out_of_range = |w: u16| if dali { w > 255 } else { w > 100 };
            let invalid = words.iter().filter(|&&w| out_of_range(w)).count();
            match levels_of(encoding, &words, curve) {
                Err(_) => proptest::prop_assert!(!words.is_empty() && invalid == words.len()),
                Ok((levels, n)) => {
                    proptest::prop_assert!(words.is_empty() || invalid < words.len());
                    proptest::prop_assert_eq!(n, invalid);
                    for (&w, x) in words.iter().zip(&levels) {
                        let expect_level = !(out_of_range(w) || (dali && w == 255));
                        proptest::prop_assert_eq!(x.is_some(), expect_level, "{}", w);
                        if let Some(x) = x {
                            proptest::prop_assert!((0.0..=1.0).contains(x), "{} -> {}", w, x);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn arc_levels_are_encoded_per_gateway() {
        use crate::dali::ArcLevel;
        assert_eq!(encode_arc(Encoding::Dali, ArcLevel(229)), 229);
        assert_eq!(encode_arc(Encoding::Percent, ArcLevel(229)), 51);
        assert_eq!(encode_arc(Encoding::Percent, ArcLevel(254)), 100);
        assert_eq!(encode_arc(Encoding::Percent, ArcLevel::OFF), 0);
    }

    #[test]
    fn config_parses_and_is_checked() {
        let c = GatewayConfig::from_toml(
            "address = \"127.0.0.1:1503\"\n[levels]\nbase = 10\nstride = 4\nencoding = \"percent\"\n[lux]\nbase = 200\n",
        )
        .unwrap();
        assert_eq!(c.level_addresses(3).unwrap(), vec![10, 14, 18]);
        assert_eq!(c.levels.encoding, Encoding::Percent);
        assert_eq!(c.lux.unwrap().stride, 1);
        assert_eq!((c.unit_id, c.retries), (1, 2));
        for bad in [
            "address = \"nohost\"\n[levels]\nbase = 0\n",
            "address = \"127.0.0.1:1\"\n[levels]\nbase = 0\nstride = 0\n",
            "address = \"127.0.0.1:1\"\n[levels]\nbase = 0\nencoding = \"dim\"\n",
            "address = \"127.0.0.1:1\"\ntimeout_ms = 0\n[levels]\nbase = 0\n",
            "address = \"127.0.0.1:1\"\n[levels]\nbase = 0\nbsae = 1\n",
        ] {
            assert!(GatewayConfig::from_toml(bad).is_err(), "{bad}");
        }
        let c = GatewayConfig::from_toml(
            "address = \"127.0.0.1:1\"\n[levels]\nbase = 65000\nstride = 100\n",
        )
        .unwrap();
        assert!(c.level_addresses(8).is_err());
    }

    #[test]
    fn levels_decode_per_encoding() {
        let log = DimmingCurve::Logarithmic;
        assert_eq!(decode_level(Encoding::Dali, 254, log), (Some(1.0), false));
        assert_eq!(decode_level(Encoding::Dali, 0, log), (Some(0.0), false));
        assert_eq!(decode_level(Encoding::Dali, 255, log), (None, false));
        assert_eq!(decode_level(Encoding::Dali, 256, log), (None, true));
        assert_eq!(decode_level(Encoding::Percent, 50, log), (Some(0.5), false));
        assert_eq!(decode_level(Encoding::Percent, 101, log), (None, true));
        let (x, _) = decode_level(Encoding::Dali, 1, log);
        assert!((x.unwrap() - 0.001).abs() < 1e-12);
    }
}
