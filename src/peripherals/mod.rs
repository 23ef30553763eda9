//! The sensor layer: the node's peripherals, written against the `embedded-hal` 1.0 traits
//! (`I2c`, `OutputPin`, `DelayNs`) so the same drivers run on Linux (through
//! `linux-embedded-hal`), on a microcontroller, and on the simulated buses of the tests and
//! the HIL rig.
//!
//! | module | what | std? |
//! |---|---|---|
//! | [`veml7700`] | ambient light sensor (Vishay VEML7700): register model, counts to lux, auto-range, saturation, stuck and inconsistent readings | no_std |
//! | [`at24`] | I2C EEPROM (AT24C32 family): random reads, page writes that never cross a page, acknowledge polling, read-back | no_std |
//! | [`calibration`] | the per-unit camera calibration record in that EEPROM: versioned, CRC-checked, two copies | no_std |
//! | [`led`] | the status LED: one blink pattern per node state | no_std |
//! | `node` | the daemon's view: a shared bus, the ALS on its own thread with a deadline, the LED thread | std |
//! | `linux` | opening the bus (`I2cdev`) and the LED line (`CdevPin`) on Linux | std, Linux |
//! | `sim` | simulated bus and devices with fault injection (unplugged, stuck bus, bit flips, frozen output, brown-out) | feature `sim` |
//!
//! ## Where the ambient light sensor looks (the geometry)
//!
//! The sensor sits on the node's underside next to the cameras, facing straight down. With a
//! hood (a matt black tube over it, `[i2c.als] hood_half_angle_deg`, response
//! `lsc::Lsc::hooded`) it sees a cone inside the colour camera's view; bare, it sees
//! the whole lower hemisphere, `E = ∫ L cos θ dω`, the light the floor, the desks and the walls
//! send up. Luminaires flush with the ceiling send it (almost) nothing directly. The
//! commissioned model predicts that reading for any dimming state (a virtual sensor at the node
//! with the sensor's response: `engine::points::evaluate_with`), so:
//!
//! * at commissioning, hooded, the camera's absolute gain is measured directly against the
//!   frames (`commission::ambient`: the sensor and the camera see the same luminances);
//!   bare, it is the one for which the model predicts what the sensor reads with every
//!   luminaire on (`commission::Gain::Ambient`, instead of a luxmeter reading on a desk), which
//!   depends on the unseen walls' default reflectance (docs/peripherals.md);
//! * at run time the reading is compared with the prediction for the current dimming state:
//!   below it by more than the tolerance means a luminaire gives less light than modelled (or
//!   the room changed); above it means daylight or another source; both raise a status bit.

pub mod at24;
pub mod calibration;
pub mod led;
pub mod veml7700;

#[cfg(all(feature = "std", target_os = "linux"))]
pub mod linux;
#[cfg(feature = "std")]
pub mod node;
#[cfg(feature = "sim")]
pub mod sim;
