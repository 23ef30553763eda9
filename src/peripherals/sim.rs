//! Simulated peripherals (feature `sim`): an I2C bus with devices behind the `embedded-hal`
//! traits, with fault injection in the manner of smoltcp's `FaultInjector`, for the tests and
//! the HIL rig.
//!
//! | part | what it models |
//! |---|---|
//! | [`SimBus`] | an I2C bus: devices by address; a missing (unplugged) device does not acknowledge; a stuck bus (SDA held low) makes every transfer fail after the adapter's timeout, as Linux's i2c drivers do |
//! | [`SimVeml7700`] | the VEML7700 register model: configuration, shutdown at power-on, conversions every integration time, counts from an illuminance through the inverse of the datasheet's non-linearity, saturation, a white channel; faults: frozen output, brown-out reset |
//! | [`SimAt24`] | a 24C32: 4 KiB, page writes that wrap inside their 32-byte page, a 5 ms write cycle without acknowledge, write protect |
//! | [`SimPin`] | an output pin that records its edges with time stamps |
//! | [`SimClock`] / [`SimDelay`] | time: real, or virtual (a delay advances the clock at once, so tests of 800 ms conversions take microseconds) |
//!
//! Faults are changed while the bus runs through [`BusControl`] (shared), so a test or the HIL
//! rig can unplug a device or jam the bus mid-run.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::i2c::{self, ErrorKind, I2c, NoAcknowledgeSource, Operation};

use super::veml7700::{self, POWER_ON_CONF, Setting};
use crate::rng::SplitMix64;

/// Time for simulated devices: the process's monotonic clock, or a virtual one.
#[derive(Debug, Clone)]
pub struct SimClock {
    virtual_ns: Option<Arc<AtomicU64>>,
    start: Instant,
}

impl SimClock {
    /// Real time.
    pub fn real() -> Self {
        Self {
            virtual_ns: None,
            start: Instant::now(),
        }
    }

    /// Virtual time from 0; only delays advance it.
    pub fn virtual_time() -> Self {
        Self {
            virtual_ns: Some(Arc::new(AtomicU64::new(0))),
            start: Instant::now(),
        }
    }

    /// Time since the clock started.
    pub fn now(&self) -> Duration {
        match &self.virtual_ns {
            Some(ns) => Duration::from_nanos(ns.load(Ordering::SeqCst)),
            None => self.start.elapsed(),
        }
    }

    /// A transfer that holds its thread for `d` (a stuck bus's adapter timeout): sleeps in
    /// real time on either clock, since what watches it (the node's deadline) runs in real
    /// time, and moves a virtual clock on by `d` too.
    pub fn stall(&self, d: Duration) {
        std::thread::sleep(d);
        if self.virtual_ns.is_some() {
            self.advance(d);
        }
    }

    /// Lets `d` pass (sleeps in real time).
    pub fn advance(&self, d: Duration) {
        match &self.virtual_ns {
            Some(ns) => {
                ns.fetch_add(
                    d.as_nanos().min(u128::from(u64::MAX)) as u64,
                    Ordering::SeqCst,
                );
            }
            None => std::thread::sleep(d),
        }
    }
}

/// A delay on a [`SimClock`].
#[derive(Debug, Clone)]
pub struct SimDelay(pub SimClock);

impl DelayNs for SimDelay {
    fn delay_ns(&mut self, ns: u32) {
        self.0.advance(Duration::from_nanos(u64::from(ns)));
    }
}

/// A data byte was not acknowledged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Nack;

/// A device on the simulated bus.
pub trait SimDevice: Send {
    /// Its 7-bit address.
    fn address(&self) -> u8;
    /// A write transfer (the bytes after the address); `Err` = no acknowledge of a data byte.
    fn write(&mut self, bytes: &[u8], now: Duration) -> Result<(), Nack>;
    /// A read transfer.
    fn read(&mut self, buf: &mut [u8], now: Duration);
    /// Whether it acknowledges its address now (an EEPROM in its write cycle does not).
    fn acknowledges(&self, now: Duration) -> bool {
        let _ = now;
        true
    }
}

/// Faults of the simulated bus, changeable while it runs.
#[derive(Debug, Clone, Default)]
pub struct BusFaults {
    /// Addresses that do not acknowledge (unplugged).
    pub unplugged: Vec<u8>,
    /// SDA held low: every transfer fails after `stuck_timeout`.
    pub stuck: bool,
    /// How long a transfer on a stuck bus takes to fail (Linux i2c adapters: about 1 s).
    pub stuck_timeout: Duration,
    /// Chance that a read byte has one bit flipped (noise on the lines).
    pub bit_flip_chance: f64,
    /// Seed of the flips.
    pub seed: u64,
}

/// A shared handle on a running bus's faults and statistics.
#[derive(Debug, Clone, Default)]
pub struct BusControl {
    inner: Arc<Mutex<(BusFaults, BusStats)>>,
}

/// Transfers seen by the bus.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BusStats {
    /// Transactions.
    pub transactions: u64,
    /// Not acknowledged.
    pub nacks: u64,
    /// Failed on a stuck bus.
    pub timeouts: u64,
}

impl BusControl {
    /// Replaces the faults.
    pub fn set(&self, faults: BusFaults) {
        self.lock().0 = faults;
    }
    /// Changes the faults.
    pub fn update(&self, f: impl FnOnce(&mut BusFaults)) {
        f(&mut self.lock().0);
    }
    /// The statistics so far.
    pub fn stats(&self) -> BusStats {
        self.lock().1
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, (BusFaults, BusStats)> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The simulated bus.
pub struct SimBus {
    devices: Vec<Box<dyn SimDevice>>,
    clock: SimClock,
    control: BusControl,
    rng: SplitMix64,
    rng_seed: u64,
}

impl std::fmt::Debug for SimBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimBus")
            .field(
                "devices",
                &self.devices.iter().map(|d| d.address()).collect::<Vec<_>>(),
            )
            .finish()
    }
}

impl SimBus {
    /// An empty bus on `clock`.
    pub fn new(clock: SimClock) -> Self {
        Self {
            devices: Vec::new(),
            clock,
            control: BusControl::default(),
            rng: SplitMix64::new(0),
            rng_seed: 0,
        }
    }

    /// Adds a device.
    pub fn with(mut self, device: impl SimDevice + 'static) -> Self {
        self.devices.push(Box::new(device));
        self
    }

    /// The fault and statistics handle.
    pub fn control(&self) -> BusControl {
        self.control.clone()
    }
}

impl i2c::ErrorType for SimBus {
    type Error = ErrorKind;
}

impl I2c for SimBus {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), ErrorKind> {
        let (faults, seed) = {
            let mut g = self.control.lock();
            g.1.transactions += 1;
            (g.0.clone(), g.0.seed)
        };
        if faults.stuck {
            self.control.lock().1.timeouts += 1;
            self.clock.stall(faults.stuck_timeout);
            return Err(ErrorKind::Bus);
        }
        let now = self.clock.now();
        let nack = |c: &BusControl, src| {
            c.lock().1.nacks += 1;
            Err(ErrorKind::NoAcknowledge(src))
        };
        let Some(dev) = self
            .devices
            .iter_mut()
            .find(|d| d.address() == address)
            .filter(|_| !faults.unplugged.contains(&address))
        else {
            return nack(&self.control, NoAcknowledgeSource::Address);
        };
        if !dev.acknowledges(now) {
            return nack(&self.control, NoAcknowledgeSource::Address);
        }
        if seed != self.rng_seed {
            self.rng_seed = seed;
            self.rng = SplitMix64::new(seed);
        }
        for op in operations.iter_mut() {
            match op {
                Operation::Write(bytes) => {
                    if dev.write(bytes, now).is_err() {
                        return nack(&self.control, NoAcknowledgeSource::Data);
                    }
                }
                Operation::Read(buf) => {
                    dev.read(buf, now);
                    if faults.bit_flip_chance > 0.0 {
                        for b in buf.iter_mut() {
                            if self.rng.next_f64() < faults.bit_flip_chance {
                                *b ^= 1 << (self.rng.next_u64() % 8);
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// What the simulated ambient light sensor sees, lx (called at each conversion).
pub type LightSource = Box<dyn Fn() -> f64 + Send>;

/// Faults of the simulated VEML7700.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AlsFaults {
    /// The output registers stop updating (a hung conversion).
    pub frozen: bool,
    /// A brown-out resets the configuration to its power-on value at this time.
    pub brownout_at: Option<Duration>,
}

/// The VEML7700's register model.
pub struct SimVeml7700 {
    conf: u16,
    thresholds: [u16; 2],
    power_saving: u16,
    pointer: u8,
    configured_at: Duration,
    als: u16,
    white: u16,
    light: LightSource,
    /// White channel count per ALS count (spectrum dependent; about 1.2 for white LEDs).
    pub white_ratio: f64,
    /// Relative noise of a conversion (σ), plus one count.
    pub noise_rel: f64,
    rng: SplitMix64,
    faults: Arc<Mutex<AlsFaults>>,
    brownout_done: bool,
    conversion: Option<(Duration, u64)>,
}

impl SimVeml7700 {
    /// A sensor seeing `light` lx; seeded noise.
    pub fn new(light: LightSource, seed: u64) -> Self {
        Self {
            conf: POWER_ON_CONF,
            thresholds: [0; 2],
            power_saving: 0,
            pointer: 0,
            configured_at: Duration::ZERO,
            als: 0,
            white: 0,
            light,
            white_ratio: 1.2,
            noise_rel: 0.002,
            rng: SplitMix64::new(seed),
            faults: Arc::new(Mutex::new(AlsFaults::default())),
            brownout_done: false,
            conversion: None,
        }
    }

    /// The fault handle.
    pub fn faults(&self) -> Arc<Mutex<AlsFaults>> {
        self.faults.clone()
    }

    /// The count a real sensor gives for `lx` at `setting` (noise free): the inverse of the
    /// driver's conversion, so the datasheet's non-linearity is in the device.
    pub fn ideal_count(lx: f64, setting: Setting) -> f64 {
        let x = if setting.corrected() {
            // invert correct_lx (monotonic on the range) by Newton's method
            let mut x = lx / 1.0023;
            for _ in 0..50 {
                let f = veml7700::correct_lx(x) - lx;
                let d = 4.0 * 6.0135e-13 * x.powi(3) - 3.0 * 9.3924e-9 * x * x
                    + 2.0 * 8.1488e-5 * x
                    + 1.0023;
                let step = f / d;
                x -= step;
                if step.abs() < 1e-9 * (1.0 + x.abs()) {
                    break;
                }
            }
            x
        } else {
            lx
        };
        x / setting.resolution_lx()
    }

    fn convert(&mut self, now: Duration) {
        let faults = *self.faults.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(t) = faults.brownout_at
            && now >= t
            && !self.brownout_done
        {
            self.brownout_done = true;
            self.conf = POWER_ON_CONF;
        }
        if faults.frozen {
            return;
        }
        let Some((setting, on)) = Setting::from_conf(self.conf) else {
            return;
        };
        // conversions complete every integration time after the configuration was written;
        // the output registers hold the latest until the next
        let it = Duration::from_millis(u64::from(setting.it.ms()));
        if !on || now < self.configured_at + it {
            return;
        }
        let k = ((now - self.configured_at).as_nanos() / it.as_nanos()) as u64;
        if self.conversion == Some((self.configured_at, k)) {
            return;
        }
        self.conversion = Some((self.configured_at, k));
        let lx = (self.light)().max(0.0);
        let ideal = Self::ideal_count(lx, setting);
        let noise = self.noise_rel * ideal * crate::rng::gaussian(&mut self.rng)
            + (self.rng.next_f64() - 0.5) * 2.0;
        let count = (ideal + noise).round().clamp(0.0, 65535.0);
        self.als = count as u16;
        self.white = (count * self.white_ratio).round().clamp(0.0, 65535.0) as u16;
        if self.als > 0 && self.white == 0 {
            self.white = 1;
        }
    }
}

impl SimDevice for SimVeml7700 {
    fn address(&self) -> u8 {
        veml7700::ADDRESS
    }

    fn write(&mut self, bytes: &[u8], now: Duration) -> Result<(), Nack> {
        let Some((&cmd, rest)) = bytes.split_first() else {
            return Ok(());
        };
        self.pointer = cmd;
        if rest.len() >= 2 {
            let v = u16::from_le_bytes([rest[0], rest[1]]);
            match cmd {
                veml7700::reg::ALS_CONF_0 => {
                    self.conf = v;
                    self.configured_at = now;
                }
                veml7700::reg::ALS_WH => self.thresholds[0] = v,
                veml7700::reg::ALS_WL => self.thresholds[1] = v,
                veml7700::reg::POWER_SAVING => self.power_saving = v,
                _ => return Err(Nack),
            }
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], now: Duration) {
        self.convert(now);
        let v = match self.pointer {
            veml7700::reg::ALS_CONF_0 => self.conf,
            veml7700::reg::ALS_WH => self.thresholds[0],
            veml7700::reg::ALS_WL => self.thresholds[1],
            veml7700::reg::POWER_SAVING => self.power_saving,
            veml7700::reg::ALS => self.als,
            veml7700::reg::WHITE => self.white,
            _ => 0,
        };
        for (k, b) in buf.iter_mut().enumerate() {
            *b = v.to_le_bytes()[k % 2];
        }
    }
}

/// A simulated 24C32.
#[derive(Debug)]
pub struct SimAt24 {
    address: u8,
    /// The memory.
    pub mem: Vec<u8>,
    pointer: usize,
    busy_until: Duration,
    /// Write cycle time.
    pub t_wr: Duration,
    /// Write-protect pin high: data is acknowledged and not stored.
    pub write_protect: bool,
}

impl SimAt24 {
    /// A blank (0xFF) 24C32 at `address`.
    pub fn new(address: u8) -> Self {
        Self {
            address,
            mem: vec![0xFF; 4096],
            pointer: 0,
            busy_until: Duration::ZERO,
            t_wr: Duration::from_millis(5),
            write_protect: false,
        }
    }
}

impl SimDevice for SimAt24 {
    fn address(&self) -> u8 {
        self.address
    }

    fn acknowledges(&self, now: Duration) -> bool {
        now >= self.busy_until
    }

    fn write(&mut self, bytes: &[u8], now: Duration) -> Result<(), Nack> {
        if bytes.len() < 2 {
            return Ok(());
        }
        let n = self.mem.len();
        self.pointer = usize::from(u16::from_be_bytes([bytes[0], bytes[1]])) % n;
        let data = &bytes[2..];
        if data.is_empty() {
            return Ok(());
        }
        if !self.write_protect {
            let page = self.pointer - self.pointer % 32;
            let mut at = self.pointer % 32;
            for &b in data {
                // past the page's end the address wraps to the page's start
                self.mem[page + at] = b;
                at = (at + 1) % 32;
            }
        }
        self.busy_until = now + self.t_wr;
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], _now: Duration) {
        let n = self.mem.len();
        for b in buf.iter_mut() {
            *b = self.mem[self.pointer];
            self.pointer = (self.pointer + 1) % n;
        }
    }
}

/// An output pin recording its edges: (time since the clock's start, level).
#[derive(Debug, Clone)]
pub struct SimPin {
    clock: SimClock,
    /// Edges so far.
    pub edges: Arc<Mutex<Vec<(Duration, bool)>>>,
    /// Every set fails (a GPIO line taken by another process).
    pub broken: bool,
    /// Each edge is also appended to this file as `ms level` (the HIL rig reads it).
    pub trace: Option<Arc<Mutex<std::fs::File>>>,
}

impl SimPin {
    /// A pin on `clock`.
    pub fn new(clock: SimClock) -> Self {
        Self {
            clock,
            edges: Arc::new(Mutex::new(Vec::new())),
            broken: false,
            trace: None,
        }
    }

    fn set(&mut self, level: bool) -> Result<(), embedded_hal::digital::ErrorKind> {
        if self.broken {
            return Err(embedded_hal::digital::ErrorKind::Other);
        }
        let mut e = self.edges.lock().unwrap_or_else(|p| p.into_inner());
        if e.last().map(|x| x.1) != Some(level) {
            let t = self.clock.now();
            e.push((t, level));
            if let Some(f) = &self.trace {
                use std::io::Write;
                let mut f = f.lock().unwrap_or_else(|p| p.into_inner());
                let _ = writeln!(f, "{} {}", t.as_millis(), u8::from(level));
                let _ = f.flush();
            }
        }
        Ok(())
    }
}

impl PinErrorType for SimPin {
    type Error = embedded_hal::digital::ErrorKind;
}

impl OutputPin for SimPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.set(false)
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.set(true)
    }
}
