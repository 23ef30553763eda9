//! The sensor layer on Linux, through `linux-embedded-hal`: the I2C bus as `/dev/i2c-N`
//! ([`I2cdev`], the kernel's i2c-dev interface) and the LED's GPIO line through the GPIO
//! character device ([`CdevPin`], `/dev/gpiochipN`).

use linux_embedded_hal::gpio_cdev::{Chip, LineRequestFlags};
use linux_embedded_hal::{CdevPin, Delay as LinuxDelay, I2cdev};

use super::node::{AnyPin, Delay, SharedBus};

/// Opens an I2C bus device (`/dev/i2c-1`).
pub fn open_bus(path: &str) -> Result<SharedBus, String> {
    let bus = I2cdev::new(path).map_err(|e| format!("{path}: {e}"))?;
    Ok(SharedBus::new(bus, path))
}

/// The delay of `linux-embedded-hal` (thread sleeps).
pub fn delay() -> Delay {
    Box::new(LinuxDelay)
}

/// Requests GPIO `line` of `chip` (`/dev/gpiochip0`) as an output, initially off.
pub fn open_output(chip: &str, line: u32, active_high: bool) -> Result<AnyPin<CdevPin>, String> {
    let mut c = Chip::new(chip).map_err(|e| format!("{chip}: {e}"))?;
    let l = c
        .get_line(line)
        .map_err(|e| format!("{chip} line {line}: {e}"))?;
    let off = u8::from(!active_high);
    let handle = l
        .request(LineRequestFlags::OUTPUT, off, "luxnode-status-led")
        .map_err(|e| format!("{chip} line {line}: {e} (in use by another process?)"))?;
    let pin = CdevPin::new(handle).map_err(|e| format!("{chip} line {line}: {e}"))?;
    Ok(AnyPin(pin))
}
