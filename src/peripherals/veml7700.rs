//! Vishay VEML7700 ambient light sensor on I2C: register model, conversion to lux, auto-range,
//! and the checks that catch a bad or stuck sensor. `no_std`, written against the
//! `embedded-hal` 1.0 [`I2c`] and [`DelayNs`] traits.
//!
//! Sources, restated (not copied): Vishay VEML7700 datasheet (document 84286) and the
//! application note "Designing the VEML7700 Into an Application" (document 84323).
//!
//! ## Register model
//!
//! Slave address 0x10 (7-bit). Every register is 16 bits, sent and received low byte first
//! (a write is `command, LSB, MSB`; a read is `command`, repeated start, `LSB, MSB`).
//!
//! | command | register | what |
//! |---:|---|---|
//! | 0x00 | `ALS_CONF_0` | bits 12:11 gain (00 ×1, 01 ×2, 10 ×1/8, 11 ×1/4); bits 9:6 integration time (1100 25 ms, 1000 50 ms, 0000 100 ms, 0001 200 ms, 0010 400 ms, 0011 800 ms); bits 5:4 persistence; bit 1 interrupt enable; bit 0 shutdown (1 = off). Power-on value 0x0001: shut down |
//! | 0x01 / 0x02 | `ALS_WH` / `ALS_WL` | interrupt window (unused here) |
//! | 0x03 | power saving | bits 2:1 mode, bit 0 enable (left 0: a conversion every integration time) |
//! | 0x04 | `ALS` | 16-bit ALS count |
//! | 0x05 | `WHITE` | 16-bit white-channel count |
//! | 0x06 | `ALS_INT` | interrupt flags |
//!
//! ## Counts to lux
//!
//! The resolution is 0.0036 lx per count at gain ×2 and 800 ms and scales inversely with gain
//! and integration time: `res = 0.0036 · (2 / gain) · (800 ms / IT)`, from 0.0036 lx/count
//! (236 lx full scale) to 1.8432 lx/count (120 796 lx full scale at ×1/8, 25 ms). (Later
//! datasheet revisions restate the base resolution as 0.0042 lx/count; [`BASE_RESOLUTION_LX`]
//! is the one constant to change with a unit calibrated against a luxmeter.) At gains ×1/8 and
//! ×1/4 the response is not linear above a few hundred lux; the application note's polynomial
//! corrects it: `lx = 6.0135e-13 x⁴ − 9.3924e-9 x³ + 8.1488e-5 x² + 1.0023 x`.
//!
//! ## Auto-range (the application note's flow)
//!
//! Start at ×1/8, 100 ms. If the count is at most 100, raise the gain (×1/4, ×1, ×2), then the
//! integration time (200, 400, 800 ms) until the count exceeds 100; if it exceeds 10 000 at the
//! start, shorten the integration time (50, 25 ms) while it does. Every change of setting waits
//! a full integration time (plus 10 %) before the next count is read, so no count mixes two
//! settings.
//!
//! ## Bad and stuck readings
//!
//! * **Saturated**: the count is 65 535 at ×1/8 and 25 ms, or the corrected reading is above
//!   the datasheet's 120 klx range (the correction polynomial is not meant beyond it): an
//!   error, never a clipped value.
//! * **Configuration lost**: `ALS_CONF_0` reads back something else than was written (a
//!   brown-out resets it to 0x0001, shut down, and the counts freeze at their last value).
//! * **Stuck**: [`STUCK_REPEATS`] conversions in a row with identical ALS and white counts at
//!   the same setting, while the count is at least [`STUCK_MIN_COUNT`]. Real light at such a
//!   count carries photon and flicker noise of several counts between conversions; in the dark
//!   (small counts) repeats are legitimate and not flagged.
//! * **Inconsistent**: an ALS count of at least [`STUCK_MIN_COUNT`] with a white count of zero
//!   (the white photodiode sees a superset of the ALS spectrum).

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;

/// Default 7-bit address.
pub const ADDRESS: u8 = 0x10;
/// lx per count at gain ×2, 800 ms.
pub const BASE_RESOLUTION_LX: f64 = 0.0036;
/// Identical conversions in a row that mean a stuck sensor.
pub const STUCK_REPEATS: u8 = 5;
/// Counts below this may legitimately repeat (darkness).
pub const STUCK_MIN_COUNT: u16 = 20;
/// The datasheet's range, lx: a reading above it is refused as saturated.
pub const MAX_LX: f64 = 120_000.0;
/// `ALS_CONF_0` after power-on: shut down.
pub const POWER_ON_CONF: u16 = 0x0001;

/// Command codes (register addresses).
pub mod reg {
    /// Configuration.
    pub const ALS_CONF_0: u8 = 0x00;
    /// High threshold.
    pub const ALS_WH: u8 = 0x01;
    /// Low threshold.
    pub const ALS_WL: u8 = 0x02;
    /// Power saving.
    pub const POWER_SAVING: u8 = 0x03;
    /// ALS count.
    pub const ALS: u8 = 0x04;
    /// White count.
    pub const WHITE: u8 = 0x05;
    /// Interrupt status.
    pub const ALS_INT: u8 = 0x06;
}

/// [`Veml7700::measure_precise`] keeps the count below this (headroom for flicker and drift).
pub const PRECISE_MAX_COUNT: f64 = 20_000.0;

/// Analog gain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Gain {
    /// ×1/8.
    X1_8,
    /// ×1/4.
    X1_4,
    /// ×1.
    X1,
    /// ×2.
    X2,
}

impl Gain {
    /// The gain factor.
    pub fn factor(self) -> f64 {
        match self {
            Gain::X1_8 => 0.125,
            Gain::X1_4 => 0.25,
            Gain::X1 => 1.0,
            Gain::X2 => 2.0,
        }
    }
    fn bits(self) -> u16 {
        match self {
            Gain::X1 => 0b00,
            Gain::X2 => 0b01,
            Gain::X1_8 => 0b10,
            Gain::X1_4 => 0b11,
        }
    }
    fn from_bits(b: u16) -> Gain {
        match b & 0b11 {
            0b00 => Gain::X1,
            0b01 => Gain::X2,
            0b10 => Gain::X1_8,
            _ => Gain::X1_4,
        }
    }
    fn up(self) -> Option<Gain> {
        match self {
            Gain::X1_8 => Some(Gain::X1_4),
            Gain::X1_4 => Some(Gain::X1),
            Gain::X1 => Some(Gain::X2),
            Gain::X2 => None,
        }
    }
}

/// Integration time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum IntegrationTime {
    /// 25 ms.
    Ms25,
    /// 50 ms.
    Ms50,
    /// 100 ms.
    Ms100,
    /// 200 ms.
    Ms200,
    /// 400 ms.
    Ms400,
    /// 800 ms.
    Ms800,
}

impl IntegrationTime {
    /// Milliseconds.
    pub fn ms(self) -> u32 {
        match self {
            IntegrationTime::Ms25 => 25,
            IntegrationTime::Ms50 => 50,
            IntegrationTime::Ms100 => 100,
            IntegrationTime::Ms200 => 200,
            IntegrationTime::Ms400 => 400,
            IntegrationTime::Ms800 => 800,
        }
    }
    fn bits(self) -> u16 {
        match self {
            IntegrationTime::Ms25 => 0b1100,
            IntegrationTime::Ms50 => 0b1000,
            IntegrationTime::Ms100 => 0b0000,
            IntegrationTime::Ms200 => 0b0001,
            IntegrationTime::Ms400 => 0b0010,
            IntegrationTime::Ms800 => 0b0011,
        }
    }
    fn from_bits(b: u16) -> Option<IntegrationTime> {
        Some(match b & 0b1111 {
            0b1100 => IntegrationTime::Ms25,
            0b1000 => IntegrationTime::Ms50,
            0b0000 => IntegrationTime::Ms100,
            0b0001 => IntegrationTime::Ms200,
            0b0010 => IntegrationTime::Ms400,
            0b0011 => IntegrationTime::Ms800,
            _ => return None,
        })
    }
    fn longer(self) -> Option<IntegrationTime> {
        match self {
            IntegrationTime::Ms25 => Some(IntegrationTime::Ms50),
            IntegrationTime::Ms50 => Some(IntegrationTime::Ms100),
            IntegrationTime::Ms100 => Some(IntegrationTime::Ms200),
            IntegrationTime::Ms200 => Some(IntegrationTime::Ms400),
            IntegrationTime::Ms400 => Some(IntegrationTime::Ms800),
            IntegrationTime::Ms800 => None,
        }
    }
    fn shorter(self) -> Option<IntegrationTime> {
        match self {
            IntegrationTime::Ms25 => None,
            IntegrationTime::Ms50 => Some(IntegrationTime::Ms25),
            IntegrationTime::Ms100 => Some(IntegrationTime::Ms50),
            IntegrationTime::Ms200 => Some(IntegrationTime::Ms100),
            IntegrationTime::Ms400 => Some(IntegrationTime::Ms200),
            IntegrationTime::Ms800 => Some(IntegrationTime::Ms400),
        }
    }
}

/// A measurement setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Setting {
    /// Gain.
    pub gain: Gain,
    /// Integration time.
    pub it: IntegrationTime,
}

impl Setting {
    /// Where auto-range starts: ×1/8, 100 ms.
    pub const START: Setting = Setting {
        gain: Gain::X1_8,
        it: IntegrationTime::Ms100,
    };
    /// The least sensitive setting: ×1/8, 25 ms.
    pub const LEAST: Setting = Setting {
        gain: Gain::X1_8,
        it: IntegrationTime::Ms25,
    };

    /// `ALS_CONF_0` for this setting, powered on, persistence 1, no interrupt.
    pub fn conf(self) -> u16 {
        (self.gain.bits() << 11) | (self.it.bits() << 6)
    }

    /// The setting a configuration word holds, and whether it is powered on; `None` for an
    /// integration-time code the datasheet does not define.
    pub fn from_conf(conf: u16) -> Option<(Setting, bool)> {
        let it = IntegrationTime::from_bits(conf >> 6)?;
        Some((
            Setting {
                gain: Gain::from_bits(conf >> 11),
                it,
            },
            conf & 1 == 0,
        ))
    }

    /// lx per count.
    pub fn resolution_lx(self) -> f64 {
        BASE_RESOLUTION_LX * (2.0 / self.gain.factor()) * (800.0 / f64::from(self.it.ms()))
    }

    /// Full scale, lx (65 535 counts, before the non-linearity correction).
    pub fn full_scale_lx(self) -> f64 {
        65535.0 * self.resolution_lx()
    }

    /// Whether the application note's non-linearity correction applies (gains ×1/8 and ×1/4).
    pub fn corrected(self) -> bool {
        matches!(self.gain, Gain::X1_8 | Gain::X1_4)
    }
}

/// The application note's non-linearity correction of a linear lux value.
pub fn correct_lx(x: f64) -> f64 {
    ((6.0135e-13 * x - 9.3924e-9) * x + 8.1488e-5) * x * x + 1.0023 * x
}

/// Lux from a count at a setting (with the correction where it applies).
pub fn counts_to_lx(count: u16, setting: Setting) -> f64 {
    let x = f64::from(count) * setting.resolution_lx();
    if setting.corrected() {
        correct_lx(x)
    } else {
        x
    }
}

/// One measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Illuminance on the sensor, lx.
    pub lux_lx: f64,
    /// ALS count.
    pub als: u16,
    /// White count.
    pub white: u16,
    /// The setting it was taken at.
    pub setting: Setting,
}

/// Why a measurement failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error<E> {
    /// The bus failed (no acknowledge: unplugged; timeout: bus stuck).
    Bus(E),
    /// `ALS_CONF_0` reads back another value than written (brown-out reset, wrong device).
    ConfigLost {
        /// Written.
        wrote: u16,
        /// Read back.
        read: u16,
    },
    /// Full scale at the least sensitive setting.
    Saturated,
    /// The same counts conversion after conversion.
    Stuck {
        /// The repeated ALS count.
        als: u16,
        /// Conversions seen identical.
        repeats: u8,
    },
    /// An ALS count with no white count.
    Inconsistent {
        /// ALS count.
        als: u16,
        /// White count.
        white: u16,
    },
}

impl<E: core::fmt::Debug> core::fmt::Display for Error<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "I2C: {e:?}"),
            Error::ConfigLost { wrote, read } => write!(
                f,
                "configuration lost: wrote ALS_CONF_0 {wrote:#06x}, read back {read:#06x} \
                 (reset by a brown-out, or not a VEML7700)"
            ),
            Error::Saturated => f.write_str("saturated at the least sensitive setting (> 120 klx)"),
            Error::Stuck { als, repeats } => write!(
                f,
                "stuck: the same counts ({als}) in {repeats} conversions in a row"
            ),
            Error::Inconsistent { als, white } => {
                write!(f, "inconsistent counts: ALS {als} with white {white}")
            }
        }
    }
}

/// The sensor on a bus.
#[derive(Debug)]
pub struct Veml7700<I> {
    i2c: I,
    address: u8,
    setting: Option<Setting>,
    last: Option<(u16, u16, Setting)>,
    repeats: u8,
}

impl<I: I2c> Veml7700<I> {
    /// The sensor at `address` (0x10 for every VEML7700) on `i2c`; nothing is sent yet.
    pub fn new(i2c: I, address: u8) -> Self {
        Self {
            i2c,
            address,
            setting: None,
            last: None,
            repeats: 0,
        }
    }

    /// The bus back.
    pub fn release(self) -> I {
        self.i2c
    }

    /// The setting in effect (after [`Self::configure`]).
    pub fn setting(&self) -> Option<Setting> {
        self.setting
    }

    /// Writes a register.
    pub fn write_register(&mut self, command: u8, value: u16) -> Result<(), Error<I::Error>> {
        let [lo, hi] = value.to_le_bytes();
        self.i2c
            .write(self.address, &[command, lo, hi])
            .map_err(Error::Bus)
    }

    /// Reads a register.
    pub fn read_register(&mut self, command: u8) -> Result<u16, Error<I::Error>> {
        let mut b = [0u8; 2];
        self.i2c
            .write_read(self.address, &[command], &mut b)
            .map_err(Error::Bus)?;
        Ok(u16::from_le_bytes(b))
    }

    /// Powers the sensor on at `setting` (power saving off), checks the configuration reads
    /// back, and waits one integration time (+10 %) so the next count is of this setting.
    pub fn configure<D: DelayNs + ?Sized>(
        &mut self,
        delay: &mut D,
        setting: Setting,
    ) -> Result<(), Error<I::Error>> {
        self.setting = None;
        let conf = setting.conf();
        self.write_register(reg::POWER_SAVING, 0)?;
        self.write_register(reg::ALS_CONF_0, conf)?;
        let read = self.read_register(reg::ALS_CONF_0)?;
        if read != conf {
            return Err(Error::ConfigLost { wrote: conf, read });
        }
        self.setting = Some(setting);
        // the datasheet's start-up time after leaving shutdown is 2.5 ms
        delay.delay_ms(setting.it.ms() * 11 / 10 + 3);
        Ok(())
    }

    /// Puts the sensor in shutdown.
    pub fn shutdown(&mut self) -> Result<(), Error<I::Error>> {
        self.setting = None;
        self.write_register(reg::ALS_CONF_0, POWER_ON_CONF)
    }

    /// Reads the counts of the latest conversion at the current setting (configure first),
    /// checking that the configuration is still the one written and that the counts are not
    /// stuck or inconsistent.
    pub fn read_counts(&mut self) -> Result<(u16, u16, Setting), Error<I::Error>> {
        let Some(setting) = self.setting else {
            let read = self.read_register(reg::ALS_CONF_0)?;
            return Err(Error::ConfigLost {
                wrote: Setting::START.conf(),
                read,
            });
        };
        let conf = self.read_register(reg::ALS_CONF_0)?;
        if conf != setting.conf() {
            self.setting = None;
            return Err(Error::ConfigLost {
                wrote: setting.conf(),
                read: conf,
            });
        }
        let als = self.read_register(reg::ALS)?;
        let white = self.read_register(reg::WHITE)?;
        // (a conversion may complete between the two reads: only a clear count counts)
        if als >= STUCK_MIN_COUNT && white == 0 {
            return Err(Error::Inconsistent { als, white });
        }
        if self.last == Some((als, white, setting)) && als >= STUCK_MIN_COUNT {
            self.repeats = self.repeats.saturating_add(1);
        } else {
            self.repeats = 1;
        }
        self.last = Some((als, white, setting));
        if self.repeats >= STUCK_REPEATS {
            return Err(Error::Stuck {
                als,
                repeats: self.repeats,
            });
        }
        Ok((als, white, setting))
    }

    /// One measurement at the current setting: waits a conversion, reads, converts.
    pub fn measure<D: DelayNs + ?Sized>(
        &mut self,
        delay: &mut D,
    ) -> Result<Reading, Error<I::Error>> {
        if let Some(s) = self.setting {
            delay.delay_ms(s.it.ms() * 11 / 10);
        }
        let (als, white, setting) = self.read_counts()?;
        Ok(Reading {
            lux_lx: counts_to_lx(als, setting),
            als,
            white,
            setting,
        })
    }

    /// A calibration measurement (the camera's gain at commissioning): the application note's
    /// auto-range, then more sensitivity (gain first, to leave the corrected low gains, then
    /// integration time) while the count stays below [`PRECISE_MAX_COUNT`], then the mean of
    /// `conversions` conversions (clamped to 1..=16). At 14 lx: ×2, 800 ms, about 3 800 counts
    /// instead of the auto-range's 240 (one count 0.03 % instead of 0.4 %).
    pub fn measure_precise<D: DelayNs + ?Sized>(
        &mut self,
        delay: &mut D,
        conversions: u8,
    ) -> Result<Reading, Error<I::Error>> {
        let first = self.measure_auto(delay)?;
        let mut s = first.setting;
        let mut count = f64::from(first.als);
        loop {
            let next = match s.gain.up() {
                Some(gain) => Setting { gain, ..s },
                None => match s.it.longer() {
                    Some(it) => Setting { it, ..s },
                    None => break,
                },
            };
            let projected = count * s.resolution_lx() / next.resolution_lx();
            if projected > PRECISE_MAX_COUNT {
                break;
            }
            s = next;
            count = projected;
        }
        if s != first.setting {
            self.configure(delay, s)?;
        }
        let n = conversions.clamp(1, 16);
        let (mut lux, mut als, mut white) = (0.0, 0u32, 0u32);
        for _ in 0..n {
            let r = self.measure(delay)?;
            if r.als == u16::MAX {
                return Err(Error::Saturated);
            }
            lux += r.lux_lx;
            als += u32::from(r.als);
            white += u32::from(r.white);
        }
        let k = u32::from(n);
        Ok(Reading {
            lux_lx: lux / f64::from(n),
            als: u16::try_from(als / k).unwrap_or(u16::MAX),
            white: u16::try_from(white / k).unwrap_or(u16::MAX),
            setting: s,
        })
    }

    /// One measurement with the application note's auto-range.
    pub fn measure_auto<D: DelayNs + ?Sized>(
        &mut self,
        delay: &mut D,
    ) -> Result<Reading, Error<I::Error>> {
        let mut s = Setting::START;
        self.configure(delay, s)?;
        let (mut als, mut white, _) = self.read_counts()?;
        if als <= 100 {
            while als <= 100 {
                let next = match s.gain.up() {
                    Some(g) => Setting { gain: g, ..s },
                    None => match s.it.longer() {
                        Some(it) => Setting { it, ..s },
                        None => break,
                    },
                };
                s = next;
                self.configure(delay, s)?;
                (als, white, _) = self.read_counts()?;
            }
        } else {
            while als > 10_000 {
                let Some(it) = s.it.shorter() else { break };
                s = Setting { it, ..s };
                self.configure(delay, s)?;
                (als, white, _) = self.read_counts()?;
            }
            if als == u16::MAX && s == Setting::LEAST {
                return Err(Error::Saturated);
            }
        }
        let lux_lx = counts_to_lx(als, s);
        if lux_lx > MAX_LX {
            return Err(Error::Saturated);
        }
        Ok(Reading {
            lux_lx,
            als,
            white,
            setting: s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configuration_words_follow_the_datasheet() {
        // ×2, 800 ms: gain bits 01 at 12:11, IT 0011 at 9:6
        let s = Setting {
            gain: Gain::X2,
            it: IntegrationTime::Ms800,
        };
        assert_eq!(s.conf(), (0b01 << 11) | (0b0011 << 6));
        assert_eq!(s.conf(), 0x08C0);
        // ×1/8, 25 ms: 10 and 1100
        assert_eq!(Setting::LEAST.conf(), (0b10 << 11) | (0b1100 << 6));
        assert_eq!(
            Setting::from_conf(Setting::LEAST.conf()),
            Some((Setting::LEAST, true))
        );
        assert_eq!(Setting::from_conf(POWER_ON_CONF).map(|x| x.1), Some(false));
        // an undefined IT code
        assert_eq!(Setting::from_conf(0b0111 << 6), None);
    }

    #[test]
    fn resolution_table_of_the_application_note() {
        // the application note's table: 0.0036 lx/ct at ×2 800 ms ... 1.8432 at ×1/8 25 ms
        let r = |g, it| Setting { gain: g, it }.resolution_lx();
        use Gain::*;
        use IntegrationTime::*;
        for (g, it, want) in [
            (X2, Ms800, 0.0036),
            (X1, Ms800, 0.0072),
            (X1_4, Ms800, 0.0288),
            (X1_8, Ms800, 0.0576),
            (X2, Ms100, 0.0288),
            (X1_8, Ms100, 0.4608),
            (X2, Ms25, 0.1152),
            (X1_8, Ms25, 1.8432),
        ] {
            assert!((r(g, it) - want).abs() < 1e-12, "{g:?} {it:?}");
        }
        // the datasheet rounds 65 536 × 1.8432 to 120 796 lx; 65 535 counts are 120 794 lx
        assert!((Setting::LEAST.full_scale_lx() - 120_794.1).abs() < 0.1);
    }

    #[test]
    fn nonlinearity_correction_of_the_application_note() {
        // at 1000 lx the polynomial adds 7.5 %; at 10 lx it is 1.0031 x to 0.01 %
        let c = correct_lx(1000.0);
        assert!((c - 1075.0).abs() < 0.01, "{c}");
        assert!((correct_lx(10.0) / 10.0 - 1.0031).abs() < 1e-4);
        // only gains ×1/8 and ×1/4 are corrected
        let s = Setting {
            gain: Gain::X1,
            it: IntegrationTime::Ms100,
        };
        assert_eq!(counts_to_lx(1000, s), 1000.0 * 0.0576);
        assert!(counts_to_lx(1000, Setting::START) > 1000.0 * 0.4608);
    }
}
