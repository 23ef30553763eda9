//! The node's peripherals as the daemon uses them (std): one I2C bus shared by its drivers, the
//! ambient light sensor read on its own thread with a deadline, the status LED blinking on its
//! own thread, the calibration EEPROM.
//!
//! Nothing on the I2C bus can hang the node: every transfer happens on the sensor's thread, and
//! the daemon only looks at [`AlsMonitor::status`], which says when the thread has been stuck
//! in one measurement longer than its deadline (a jammed bus on Linux fails each transfer
//! after the adapter's timeout, about 1 s; a driver bug could block for ever: either way the
//! node flags it and keeps serving).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::OutputPin;
use embedded_hal::i2c::{self, ErrorKind, I2c, Operation};

use super::at24::At24;
use super::led::{NodeState, StatusLed};
use super::veml7700::{Reading, Veml7700};

/// An I2C error with the operating system's words kept for the log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BusError {
    /// The embedded-hal kind.
    pub kind: ErrorKind,
    /// What the bus said.
    pub message: String,
}

impl std::fmt::Display for BusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match self.kind {
            ErrorKind::NoAcknowledge(_) => "no acknowledge (device absent or unplugged)",
            ErrorKind::Bus => "bus error (SDA or SCL held: the bus is stuck)",
            ErrorKind::ArbitrationLoss => "arbitration lost",
            ErrorKind::Overrun => "overrun",
            _ => "transfer failed",
        };
        if self.message.is_empty() {
            f.write_str(what)
        } else {
            write!(f, "{what}: {}", self.message)
        }
    }
}

impl i2c::Error for BusError {
    fn kind(&self) -> ErrorKind {
        self.kind
    }
}

/// Any I2C bus, its errors as [`BusError`].
pub trait Bus: Send {
    /// One transaction.
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), BusError>;
}

impl<T> Bus for T
where
    T: I2c + Send,
    T::Error: std::fmt::Debug,
{
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), BusError> {
        I2c::transaction(self, address, ops).map_err(|e| BusError {
            kind: i2c::Error::kind(&e),
            message: format!("{e:?}"),
        })
    }
}

/// One bus shared by several drivers (each transaction holds the lock).
#[derive(Clone)]
pub struct SharedBus {
    bus: Arc<Mutex<Box<dyn Bus>>>,
    /// The device path, for the log.
    pub name: Arc<str>,
}

impl std::fmt::Debug for SharedBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SharedBus({})", self.name)
    }
}

impl SharedBus {
    /// Shares `bus`.
    pub fn new(bus: impl Bus + 'static, name: &str) -> Self {
        Self {
            bus: Arc::new(Mutex::new(Box::new(bus))),
            name: name.into(),
        }
    }
}

impl i2c::ErrorType for SharedBus {
    type Error = BusError;
}

impl I2c for SharedBus {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), BusError> {
        let mut g = self.bus.lock().unwrap_or_else(|p| p.into_inner());
        g.transaction(address, ops)
    }
}

/// A delay usable from any thread.
pub type Delay = Box<dyn DelayNs + Send>;

/// The ambient light sensor as the node mounts it.
pub struct AmbientSensor {
    /// The driver.
    pub driver: Veml7700<SharedBus>,
    /// Its delay.
    pub delay: Delay,
    /// What it is, for the log ("VEML7700 at 0x10 on /dev/i2c-1").
    pub name: String,
}

impl AmbientSensor {
    /// One auto-ranged measurement.
    pub fn measure(&mut self) -> Result<Reading, String> {
        self.driver
            .measure_auto(&mut *self.delay)
            .map_err(|e| match e {
                super::veml7700::Error::Bus(b) => format!("{}: I2C: {b}", self.name),
                e => format!("{}: {e}", self.name),
            })
    }

    /// A calibration measurement ([`Veml7700::measure_precise`], `conversions` averaged).
    pub fn measure_precise(&mut self, conversions: u8) -> Result<Reading, String> {
        self.driver
            .measure_precise(&mut *self.delay, conversions)
            .map_err(|e| match e {
                super::veml7700::Error::Bus(b) => format!("{}: I2C: {b}", self.name),
                e => format!("{}: {e}", self.name),
            })
    }
}

/// The status LED as the node drives it.
pub struct Led {
    /// The LED.
    pub led: StatusLed<BoxPin>,
    /// What it is ("GPIO 17 of /dev/gpiochip0").
    pub name: String,
}

/// Any output pin, boxed.
pub struct BoxPin(pub Box<dyn OutputPin<Error = embedded_hal::digital::ErrorKind> + Send>);

impl embedded_hal::digital::ErrorType for BoxPin {
    type Error = embedded_hal::digital::ErrorKind;
}

impl OutputPin for BoxPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.0.set_low()
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.0.set_high()
    }
}

/// Adapts any output pin to the error type [`BoxPin`] holds.
pub struct AnyPin<P>(pub P);

impl<P: OutputPin> embedded_hal::digital::ErrorType for AnyPin<P> {
    type Error = embedded_hal::digital::ErrorKind;
}

impl<P: OutputPin> OutputPin for AnyPin<P> {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.0
            .set_low()
            .map_err(|e| embedded_hal::digital::Error::kind(&e))
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.0
            .set_high()
            .map_err(|e| embedded_hal::digital::Error::kind(&e))
    }
}

/// The calibration EEPROM as the node mounts it.
pub struct CalibrationEeprom {
    /// The driver.
    pub eeprom: At24<SharedBus>,
    /// Its delay (page writes).
    pub delay: Delay,
    /// What it is.
    pub name: String,
}

/// Told the node's luminaire levels (fractions, luminaire order) whenever they change.
pub type LevelsHook = Box<dyn FnMut(&[f64]) + Send>;

/// The node's peripherals (any may be absent).
pub struct Peripherals {
    /// Ambient light sensor (shared: commissioning reads it, then the run-time monitor).
    pub als: Option<Arc<Mutex<AmbientSensor>>>,
    /// Calibration EEPROM of the camera module.
    pub eeprom: Option<CalibrationEeprom>,
    /// Status LED.
    pub led: Option<Led>,
    /// Where the ALS sits and faces: (position, unit normal), m, world frame.
    pub als_pose: Option<([f64; 3], [f64; 3])>,
    /// The simulated board's light model follows the node's levels through this (real boards:
    /// none; the room's light is real).
    pub levels_hook: Option<LevelsHook>,
    /// Run-time readings of the ALS: how often, and the tolerance of the check.
    pub als_period: Duration,
    /// Relative tolerance of the run-time check.
    pub als_tolerance: f64,
    /// Peripherals the board names that could not be opened, and why.
    pub open_faults: Vec<String>,
}

impl Default for Peripherals {
    fn default() -> Self {
        Self {
            als: None,
            eeprom: None,
            led: None,
            als_pose: None,
            levels_hook: None,
            als_period: Duration::from_secs(5),
            als_tolerance: 0.2,
            open_faults: Vec::new(),
        }
    }
}

impl std::fmt::Debug for Peripherals {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Peripherals")
            .field("als", &self.als.as_ref().map(|a| lock(a).name.clone()))
            .field("eeprom", &self.eeprom.as_ref().map(|a| &a.name))
            .field("led", &self.led.as_ref().map(|a| &a.name))
            .finish()
    }
}

/// What the ALS thread knows.
#[derive(Debug, Clone, Default)]
pub struct AlsStatus {
    /// The latest good reading and when it was taken.
    pub last: Option<(Reading, Instant)>,
    /// The latest failure (cleared by a good reading).
    pub fault: Option<String>,
    /// A measurement in progress since then.
    pub busy_since: Option<Instant>,
    /// Good readings so far.
    pub readings: u64,
    /// Failed readings so far.
    pub failures: u64,
}

impl AlsStatus {
    /// The problem, if any: a failure, or a measurement running past `deadline`.
    pub fn problem(&self, deadline: Duration) -> Option<String> {
        if let Some(t) = self.busy_since
            && t.elapsed() > deadline
        {
            return Some(format!(
                "no answer for {:.1} s (the measurement is stuck; deadline {:.1} s)",
                t.elapsed().as_secs_f64(),
                deadline.as_secs_f64()
            ));
        }
        self.fault.clone()
    }
}

/// The ALS on its own thread, measuring every `period`.
pub struct AlsMonitor {
    status: Arc<Mutex<AlsStatus>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    /// Longest a measurement may take (auto-range at 800 ms takes about 8 conversions).
    pub deadline: Duration,
}

impl AlsMonitor {
    /// Starts measuring.
    pub fn spawn(sensor: Arc<Mutex<AmbientSensor>>, period: Duration) -> Self {
        let status = Arc::new(Mutex::new(AlsStatus::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let (s, st) = (status.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("luxnode-als".into())
            .spawn(move || {
                while !st.load(Ordering::SeqCst) {
                    let t0 = Instant::now();
                    lock(&s).busy_since = Some(t0);
                    let r = lock(&sensor).measure();
                    let mut g = lock(&s);
                    g.busy_since = None;
                    match r {
                        Ok(reading) => {
                            g.last = Some((reading, Instant::now()));
                            g.fault = None;
                            g.readings += 1;
                        }
                        Err(e) => {
                            g.fault = Some(e);
                            g.failures += 1;
                        }
                    }
                    drop(g);
                    let mut left = period.saturating_sub(t0.elapsed());
                    while !left.is_zero() && !st.load(Ordering::SeqCst) {
                        let step = left.min(Duration::from_millis(50));
                        std::thread::sleep(step);
                        left -= step;
                    }
                }
            })
            .ok();
        Self {
            status,
            stop,
            thread,
            deadline: Duration::from_secs(5),
        }
    }

    /// The thread's latest news.
    pub fn status(&self) -> AlsStatus {
        lock(&self.status).clone()
    }
}

impl Drop for AlsMonitor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // a thread stuck on the bus is left behind (never joined): the node must not hang
        if let Some(t) = self.thread.take()
            && t.is_finished()
        {
            let _ = t.join();
        }
    }
}

/// The LED on its own thread, following the state set by the daemon.
pub struct LedMonitor {
    state: Arc<Mutex<NodeState>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    failed: Arc<Mutex<Option<String>>>,
}

impl LedMonitor {
    /// Starts blinking (state booting).
    pub fn spawn(mut led: Led) -> Self {
        let state = Arc::new(Mutex::new(NodeState::Booting));
        let stop = Arc::new(AtomicBool::new(false));
        let failed = Arc::new(Mutex::new(None));
        let (s, st, f) = (state.clone(), stop.clone(), failed.clone());
        let t0 = Instant::now();
        let thread = std::thread::Builder::new()
            .name("luxnode-led".into())
            .spawn(move || {
                while !st.load(Ordering::SeqCst) {
                    let now = t0.elapsed().as_millis() as u64;
                    let want = *lock(&s);
                    led.led.set_state(want, now);
                    if let Err(e) = led.led.tick(now) {
                        let mut g = lock(&f);
                        if g.is_none() {
                            *g = Some(format!("{}: {e:?}", led.name));
                        }
                    }
                    std::thread::sleep(Duration::from_millis(10));
                }
            })
            .ok();
        Self {
            state,
            stop,
            thread,
            failed,
        }
    }

    /// Shows `state`.
    pub fn set(&self, state: NodeState) {
        *lock(&self.state) = state;
    }

    /// The state shown.
    pub fn state(&self) -> NodeState {
        *lock(&self.state)
    }

    /// The pin's first failure, if any.
    pub fn failure(&self) -> Option<String> {
        lock(&self.failed).clone()
    }
}

impl Drop for LedMonitor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
