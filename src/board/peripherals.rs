//! Opening a board's peripherals (`[i2c]`, `[i2c.als]`, `[i2c.eeprom]`, `[led]`): on Linux
//! through `linux-embedded-hal`, on the simulated board through the simulated bus and devices.
//! Nothing here stops the node: a bus or a line that cannot be opened is a clear log line and
//! a fault the daemon raises as a status bit; the node serves without it.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::board::camera::{I2cBoard, LedBoard};
use crate::peripherals::at24::At24;
use crate::peripherals::led::StatusLed;
use crate::peripherals::node::{
    AmbientSensor, BoxPin, CalibrationEeprom, Delay, Led, Peripherals, SharedBus,
};
use crate::peripherals::veml7700::Veml7700;

/// What the simulated board supplies (feature `sim`): what the simulated ALS sees, and where
/// the LED's edges go.
#[derive(Default)]
pub struct SimHooks {
    /// The illuminance on the simulated ALS, lx.
    pub light: Option<Box<dyn Fn() -> f64 + Send>>,
    /// The LED's edges, appended as `ms level` lines.
    pub led_trace: Option<std::path::PathBuf>,
    /// A calibration record to put in the simulated EEPROM.
    pub eeprom_record: Option<crate::peripherals::calibration::CameraCalibration>,
}

/// Opens what the board names; `default_als_at` is where the ALS is when the board does not
/// say (1 cm below the ToF camera).
pub fn open(
    i2c: Option<&I2cBoard>,
    led: Option<&LedBoard>,
    default_als_at: Option<[f64; 3]>,
    hooks: SimHooks,
) -> Peripherals {
    let mut p = Peripherals::default();
    let SimHooks {
        light,
        led_trace,
        eeprom_record,
    } = hooks;
    if let Some(i) = i2c {
        let opened = if i.bus == "sim" {
            open_sim_bus(i, light, eeprom_record)
        } else {
            open_linux_bus(&i.bus)
        };
        match opened {
            Ok((bus, delay)) => {
                if let Some(a) = &i.als {
                    let name = format!("VEML7700 at {:#04x} on {}", a.address, i.bus);
                    tracing::info!("peripherals: ambient light sensor {name}");
                    p.als = Some(Arc::new(Mutex::new(AmbientSensor {
                        driver: Veml7700::new(bus.clone(), a.address),
                        delay: delay(),
                        name,
                    })));
                    p.als_pose = a
                        .position_m
                        .or(default_als_at.map(|c| [c[0], c[1], c[2] - 0.01]))
                        .map(|pos| (pos, a.normal));
                    p.als_period = Duration::from_secs_f64(a.period_s);
                    p.als_tolerance = a.tolerance;
                }
                if let Some(e) = &i.eeprom {
                    let name = format!("24C32 at {:#04x} on {}", e.address, i.bus);
                    p.eeprom = Some(CalibrationEeprom {
                        eeprom: At24::new_24c32(bus.clone(), e.address),
                        delay: delay(),
                        name,
                    });
                }
            }
            Err(e) => {
                tracing::error!("peripherals: I2C bus {}: {e}", i.bus);
                p.open_faults.push(format!("I2C bus {}: {e}", i.bus));
            }
        }
    }
    if let Some(l) = led {
        match open_led(l, led_trace) {
            Ok(led) => {
                tracing::info!("peripherals: status LED {}", led.name);
                p.led = Some(led);
            }
            Err(e) => {
                tracing::error!("peripherals: status LED: {e}");
                p.open_faults.push(format!("status LED: {e}"));
            }
        }
    }
    p
}

type DelayMaker = Box<dyn Fn() -> Delay>;

#[cfg(target_os = "linux")]
fn open_linux_bus(path: &str) -> Result<(SharedBus, DelayMaker), String> {
    let bus = crate::peripherals::linux::open_bus(path)?;
    Ok((bus, Box::new(crate::peripherals::linux::delay)))
}

#[cfg(not(target_os = "linux"))]
fn open_linux_bus(path: &str) -> Result<(SharedBus, DelayMaker), String> {
    Err(format!("{path}: I2C devices need Linux"))
}

#[cfg(feature = "sim")]
fn open_sim_bus(
    i: &I2cBoard,
    light: Option<Box<dyn Fn() -> f64 + Send>>,
    record: Option<crate::peripherals::calibration::CameraCalibration>,
) -> Result<(SharedBus, DelayMaker), String> {
    use crate::peripherals::sim::{BusFaults, SimAt24, SimBus, SimClock, SimDelay, SimVeml7700};
    // the devices' own time is simulated: an 800 ms integration takes no wall time (the
    // ambient light sensor's readings at commissioning slept 10 s of every sim board's first
    // boot); a stuck bus still holds its thread in real time, which the node's deadline watches
    let clock = SimClock::virtual_time();
    let t0 = std::time::Instant::now();
    let f = i.sim.clone().unwrap_or_default();
    let daylight = move || {
        if f.daylight_lx > 0.0 && t0.elapsed().as_secs_f64() >= f.daylight_after_s {
            f.daylight_lx
        } else {
            0.0
        }
    };
    let light = light.unwrap_or_else(|| Box::new(|| 0.0));
    let mut bus = SimBus::new(clock.clone());
    let mut als_faults = None;
    if i.als.is_some() {
        let als = SimVeml7700::new(Box::new(move || light() + daylight()), 7);
        als_faults = Some(als.faults());
        bus = bus.with(als);
    }
    if let Some(e) = &i.eeprom {
        let mut dev = SimAt24::new(e.address);
        if let Some(r) = record {
            let b = r.encode(1);
            dev.mem[..b.len()].copy_from_slice(&b);
        }
        bus = bus.with(dev);
    }
    let control = bus.control();
    if let Some(s) = i.sim.clone() {
        // the faults come at their times, on a timer thread of the simulated world
        let timeout = Duration::from_secs_f64(s.stuck_timeout_s);
        let mut events: Vec<(f64, u8)> = Vec::new();
        if let Some(t) = s.als_unplugged_after_s {
            events.push((t, 0));
        }
        if let Some(t) = s.als_frozen_after_s {
            events.push((t, 1));
        }
        if let Some(t) = s.bus_stuck_after_s {
            events.push((t, 2));
        }
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        let _ = std::thread::Builder::new()
            .name("sim-i2c-faults".into())
            .spawn(move || {
                for (t, what) in events {
                    let left = t - t0.elapsed().as_secs_f64();
                    if left > 0.0 {
                        std::thread::sleep(Duration::from_secs_f64(left));
                    }
                    match what {
                        0 => control
                            .update(|f| f.unplugged.push(crate::peripherals::veml7700::ADDRESS)),
                        1 => {
                            if let Some(a) = &als_faults {
                                a.lock().unwrap_or_else(|p| p.into_inner()).frozen = true;
                            }
                        }
                        _ => control.update(|f| {
                            *f = BusFaults {
                                stuck: true,
                                stuck_timeout: timeout,
                                ..f.clone()
                            }
                        }),
                    }
                }
            });
    }
    let c = clock.clone();
    Ok((
        SharedBus::new(bus, "sim"),
        Box::new(move || Box::new(SimDelay(c.clone())) as Delay),
    ))
}

#[cfg(not(feature = "sim"))]
fn open_sim_bus(
    _i: &I2cBoard,
    _light: Option<Box<dyn Fn() -> f64 + Send>>,
    _record: Option<crate::peripherals::calibration::CameraCalibration>,
) -> Result<(SharedBus, DelayMaker), String> {
    Err("the simulated bus is part of the `sim` feature".into())
}

fn open_led(l: &LedBoard, trace: Option<std::path::PathBuf>) -> Result<Led, String> {
    let t0 = 0;
    if l.chip == "sim" {
        return open_sim_led(l, trace);
    }
    #[cfg(target_os = "linux")]
    {
        let pin = crate::peripherals::linux::open_output(&l.chip, l.line, l.active_high)?;
        let boxed = BoxPin(Box::new(crate::peripherals::node::AnyPin(pin)));
        Ok(Led {
            led: StatusLed::new(boxed, l.active_high, t0),
            name: format!("GPIO {} of {}", l.line, l.chip),
        })
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = (trace, t0);
        Err(format!("{}: GPIO lines need Linux", l.chip))
    }
}

#[cfg(feature = "sim")]
fn open_sim_led(l: &LedBoard, trace: Option<std::path::PathBuf>) -> Result<Led, String> {
    use crate::peripherals::sim::{SimClock, SimPin};
    let mut pin = SimPin::new(SimClock::real());
    if let Some(path) = trace {
        let f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        pin.trace = Some(Arc::new(Mutex::new(f)));
    }
    Ok(Led {
        led: StatusLed::new(BoxPin(Box::new(pin)), l.active_high, 0),
        name: "simulated GPIO line".into(),
    })
}

#[cfg(not(feature = "sim"))]
fn open_sim_led(_l: &LedBoard, _trace: Option<std::path::PathBuf>) -> Result<Led, String> {
    Err("the simulated GPIO is part of the `sim` feature".into())
}

/// The colour camera's calibration record from its module's EEPROM applied to a hardware board:
/// the record's intrinsics, pose and luminance calibration replace the board file's (a replaced
/// camera module brings its own). The record's image size must be the board's `width` ×
/// `height`.
pub fn apply_calibration(
    camera: &crate::board::camera::CameraBoard,
    cal: &crate::peripherals::calibration::CameraCalibration,
) -> Result<crate::board::camera::CameraBoard, String> {
    use crate::board::camera::{CameraBoard, ColourBoard};
    use crate::camera::register::{ColourFromTof, ColourIntrinsics, Registration};
    let CameraBoard::Hardware { tof, colour } = camera else {
        return Err("the board's cameras are not hardware".into());
    };
    let ColourBoard::V4l2 {
        device, options, ..
    } = colour;
    if (cal.width, cal.height) != (options.width, options.height) {
        return Err(format!(
            "the record is for {}x{} frames, the board captures {}x{}",
            cal.width, cal.height, options.width, options.height
        ));
    }
    let registration = Registration::new(
        ColourIntrinsics {
            width: cal.width,
            height: cal.height,
            fx: cal.fx,
            fy: cal.fy,
            cx: cal.cx,
            cy: cal.cy,
            k1: cal.k1,
            k2: cal.k2,
            lens: match cal.fisheye_k {
                Some(k) => crate::scene::Lens::KannalaBrandt { k },
                None => crate::scene::Lens::Pinhole,
            },
        },
        ColourFromTof {
            rotation: cal.rotation,
            translation_m: cal.translation_m,
        },
    )
    .map_err(|e| format!("the record's registration: {e}"))?;
    let mut options = options.clone();
    options.calibration_cd_m2_s = cal.calibration_cd_m2_s;
    Ok(CameraBoard::Hardware {
        tof: tof.clone(),
        colour: ColourBoard::V4l2 {
            device: device.clone(),
            options,
            registration: Some(registration),
        },
    })
}

/// The board file's colour calibration as a record (to write into a module's EEPROM).
pub fn record_from_board(
    camera: &crate::board::camera::CameraBoard,
    serial: &str,
) -> Result<crate::peripherals::calibration::CameraCalibration, String> {
    use crate::board::camera::{CameraBoard, ColourBoard};
    let CameraBoard::Hardware {
        colour:
            ColourBoard::V4l2 {
                options,
                registration,
                ..
            },
        ..
    } = camera
    else {
        return Err("the board's cameras are not hardware".into());
    };
    let r = registration
        .as_ref()
        .ok_or("the board has no [camera.colour.registration] to record")?;
    let i = r.intrinsics();
    let p = r.colour_from_tof();
    let mut s = [0u8; 16];
    let b = serial.as_bytes();
    if b.len() > 16 || !b.iter().all(|c| c.is_ascii_graphic()) {
        return Err(format!(
            "serial {serial:?}: at most 16 printable ASCII characters"
        ));
    }
    s[..b.len()].copy_from_slice(b);
    let cal = crate::peripherals::calibration::CameraCalibration {
        serial: s,
        width: i.width,
        height: i.height,
        fx: i.fx,
        fy: i.fy,
        cx: i.cx,
        cy: i.cy,
        k1: i.k1,
        k2: i.k2,
        rotation: p.rotation,
        translation_m: p.translation_m,
        calibration_cd_m2_s: options.calibration_cd_m2_s,
        fisheye_k: match i.lens {
            crate::scene::Lens::KannalaBrandt { k } => Some(k),
            crate::scene::Lens::Pinhole => None,
        },
    };
    cal.validate().map_err(|e| e.to_string())?;
    Ok(cal)
}

/// Reads the calibration EEPROM and, when it holds a valid record, applies it to the board's
/// cameras; otherwise keeps the board file's calibration and says why.
pub fn calibrated_cameras(
    camera: &crate::board::camera::CameraBoard,
    eeprom: Option<&mut CalibrationEeprom>,
) -> crate::board::camera::CameraBoard {
    let Some(e) = eeprom else {
        return camera.clone();
    };
    match crate::peripherals::calibration::read(&mut e.eeprom) {
        Ok(stored) => match stored.newest() {
            Some((cal, generation, copy)) => match apply_calibration(camera, &cal) {
                Ok(b) => {
                    tracing::info!(
                        "camera calibration: from {} (module {}, record generation {generation}, copy {})",
                        e.name,
                        cal.serial_str(),
                        if copy == 0 { "A" } else { "B" }
                    );
                    b
                }
                Err(why) => {
                    tracing::warn!(
                        "camera calibration: {}: {why}; the board file's calibration is used",
                        e.name
                    );
                    camera.clone()
                }
            },
            None => {
                let why = stored.a.err().map(|x| x.to_string()).unwrap_or_default();
                tracing::warn!(
                    "camera calibration: {} holds no valid record (copy A: {why}); the board \
                     file's calibration is used",
                    e.name
                );
                camera.clone()
            }
        },
        Err(err) => {
            tracing::error!(
                "camera calibration: {}: {err}; the board file's calibration is used",
                e.name
            );
            camera.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::Board;
    use crate::board::camera::{CameraBoard, ColourBoard};

    #[test]
    fn a_modules_record_replaces_the_board_files_calibration() {
        let b = Board::load(std::path::Path::new("boards/rpi4/board.toml")).unwrap();
        let mut cal = record_from_board(&b.camera, "CAM-1").unwrap();
        assert_eq!(cal.fx, 554.3);
        cal.fx = 600.0;
        cal.calibration_cd_m2_s = 13.5;
        let c = apply_calibration(&b.camera, &cal).unwrap();
        let CameraBoard::Hardware {
            colour:
                ColourBoard::V4l2 {
                    options,
                    registration,
                    ..
                },
            ..
        } = c
        else {
            panic!()
        };
        assert_eq!(options.calibration_cd_m2_s, 13.5);
        assert_eq!(registration.unwrap().intrinsics().fx, 600.0);
        cal.width = 1280;
        assert!(
            apply_calibration(&b.camera, &cal)
                .unwrap_err()
                .contains("1280x480")
        );
    }
}
