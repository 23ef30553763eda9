//! The sensor layer against simulated buses: the VEML7700's conversions and auto-range against
//! the datasheet's resolution table, bad and stuck readings, the EEPROM's page writes and
//! acknowledge polling, the calibration record's two copies, the LED patterns, and a stuck bus
//! that never hangs the caller.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use embedded_hal::i2c::{ErrorKind, I2c, NoAcknowledgeSource};
use luxnode::peripherals::at24::{self, At24};
use luxnode::peripherals::calibration::{self, CameraCalibration, RECORD_LEN};
use luxnode::peripherals::led::{NodeState, StatusLed};
use luxnode::peripherals::node::{AlsMonitor, AmbientSensor, SharedBus};
use luxnode::peripherals::sim::{
    AlsFaults, BusControl, BusFaults, SimAt24, SimBus, SimClock, SimDelay, SimPin, SimVeml7700,
};
use luxnode::peripherals::veml7700::{self, Gain, IntegrationTime, Setting, Veml7700};

/// A bus with a VEML7700 seeing `lx` (changeable) and a 24C32 at 0x50, on virtual time.
fn rig(lx: f64) -> (SimBus, SimDelay, Arc<Mutex<f64>>, Arc<Mutex<AlsFaults>>) {
    let clock = SimClock::virtual_time();
    let light = Arc::new(Mutex::new(lx));
    let l = light.clone();
    let als = SimVeml7700::new(Box::new(move || *l.lock().unwrap()), 11);
    let faults = als.faults();
    let bus = SimBus::new(clock.clone())
        .with(als)
        .with(SimAt24::new(0x50));
    (bus, SimDelay(clock), light, faults)
}

#[test]
fn auto_range_follows_the_application_note_and_reads_true_lux() {
    use Gain::*;
    use IntegrationTime::*;
    // (true lx, the setting the application note's flow ends at)
    for (lx, gain, it) in [
        (0.5, X2, Ms800),
        (3.0, X2, Ms100),
        (40.0, X1_4, Ms100),
        (500.0, X1_8, Ms100),
        (8_000.0, X1_8, Ms50),
        (60_000.0, X1_8, Ms25),
    ] {
        let (bus, mut delay, _, _) = rig(lx);
        let mut s = Veml7700::new(bus, veml7700::ADDRESS);
        let r = s.measure_auto(&mut delay).unwrap();
        assert_eq!((r.setting.gain, r.setting.it), (gain, it), "{lx} lx");
        // within the simulated noise (0.2 % + 1 count) and one count of quantisation
        let tol = 0.006 * lx + 2.0 * r.setting.resolution_lx() * (1.0 + lx / 1000.0);
        assert!(
            (r.lux_lx - lx).abs() <= tol,
            "{lx} lx read {} ({:?})",
            r.lux_lx,
            r.setting
        );
        assert!(r.white >= r.als);
    }
}

#[test]
fn the_calibration_reading_uses_the_most_sensitive_setting_and_averages() {
    // the commissioning reading of the camera's gain: more counts than the auto-range's
    for (lx, gain, it) in [
        (13.6, Gain::X2, IntegrationTime::Ms800),
        (150.0, Gain::X2, IntegrationTime::Ms200),
        (2_000.0, Gain::X1_4, IntegrationTime::Ms100),
    ] {
        let (bus, mut delay, _, _) = rig(lx);
        let mut s = Veml7700::new(bus, veml7700::ADDRESS);
        let auto = s.measure_auto(&mut delay).unwrap();
        let r = s.measure_precise(&mut delay, 8).unwrap();
        assert_eq!((r.setting.gain, r.setting.it), (gain, it), "{lx} lx");
        assert!(
            f64::from(r.als) > 1.9 * f64::from(auto.als),
            "{lx}: {r:?} vs {auto:?}"
        );
        assert!(f64::from(r.als) <= veml7700::PRECISE_MAX_COUNT, "{r:?}");
        // 8 conversions of 0.2 % noise: 0.07 % σ, plus a count
        let tol = 0.003 * lx + r.setting.resolution_lx();
        assert!((r.lux_lx - lx).abs() <= tol, "{lx} lx read {}", r.lux_lx);
    }
    // the conversion count is clamped, never zero
    let (bus, mut delay, _, _) = rig(300.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    assert!(s.measure_precise(&mut delay, 0).unwrap().lux_lx > 290.0);
    let (bus, mut delay, _, _) = rig(150_000.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    assert_eq!(
        s.measure_precise(&mut delay, 4),
        Err(veml7700::Error::Saturated)
    );
}

#[test]
fn saturation_is_an_error_never_a_clipped_value() {
    let (bus, mut delay, _, _) = rig(150_000.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    assert_eq!(s.measure_auto(&mut delay), Err(veml7700::Error::Saturated));
    // 120 klx is the datasheet's range: 110 klx still reads
    let (bus, mut delay, _, _) = rig(110_000.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    let r = s.measure_auto(&mut delay).unwrap();
    assert!((r.lux_lx / 110_000.0 - 1.0).abs() < 0.01, "{}", r.lux_lx);
}

#[test]
fn a_frozen_sensor_is_reported_stuck_but_darkness_is_not() {
    let (bus, mut delay, _, faults) = rig(300.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    s.configure(&mut delay, Setting::START).unwrap();
    for _ in 0..4 {
        s.measure(&mut delay).unwrap();
    }
    faults.lock().unwrap().frozen = true;
    let mut err = None;
    for _ in 0..8 {
        if let Err(e) = s.measure(&mut delay) {
            err = Some(e);
            break;
        }
    }
    assert!(
        matches!(err, Some(veml7700::Error::Stuck { repeats: 5, .. })),
        "{err:?}"
    );
    // in the dark the counts legitimately repeat (0 or 1 count): no false alarm
    let (bus, mut delay, _, _) = rig(0.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    s.configure(&mut delay, Setting::START).unwrap();
    for _ in 0..20 {
        let r = s.measure(&mut delay).unwrap();
        assert!(r.lux_lx < 1.0);
    }
}

#[test]
fn a_brownout_reset_is_configuration_lost() {
    let (bus, mut delay, _, faults) = rig(300.0);
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    s.configure(&mut delay, Setting::START).unwrap();
    s.measure(&mut delay).unwrap();
    faults.lock().unwrap().brownout_at = Some(Duration::ZERO);
    let e = s.measure(&mut delay).unwrap_err();
    assert_eq!(
        e,
        veml7700::Error::ConfigLost {
            wrote: Setting::START.conf(),
            read: veml7700::POWER_ON_CONF
        }
    );
    assert!(e.to_string().contains("brown-out"), "{e}");
    // the next auto-ranged measurement configures it again
    assert!(s.measure_auto(&mut delay).is_ok());
}

#[test]
fn unplugged_and_stuck_buses_fail_fast_with_their_kind() {
    let (bus, mut delay, _, _) = rig(300.0);
    let control: BusControl = bus.control();
    let mut s = Veml7700::new(bus, veml7700::ADDRESS);
    control.set(BusFaults {
        unplugged: vec![veml7700::ADDRESS],
        ..BusFaults::default()
    });
    assert_eq!(
        s.measure_auto(&mut delay),
        Err(veml7700::Error::Bus(ErrorKind::NoAcknowledge(
            NoAcknowledgeSource::Address
        )))
    );
    control.set(BusFaults {
        stuck: true,
        stuck_timeout: Duration::from_secs(1),
        ..BusFaults::default()
    });
    assert_eq!(
        s.measure_auto(&mut delay),
        Err(veml7700::Error::Bus(ErrorKind::Bus))
    );
    // one transfer, one timeout: the driver does not retry a dead bus
    assert_eq!(control.stats().timeouts, 1);
    control.set(BusFaults::default());
    assert!(s.measure_auto(&mut delay).is_ok());
}

#[test]
fn eeprom_page_writes_never_cross_a_page_and_poll_the_write_cycle() {
    let (bus, mut delay, _, _) = rig(0.0);
    let control = bus.control();
    let mut e = At24::new_24c32(bus, at24::BASE_ADDRESS);
    let data: Vec<u8> = (0..100u32).map(|i| (i * 7 + 3) as u8).collect();
    // from byte 30: 2 bytes to the end of page 0, then pages 1, 2 and 8 bytes of page 3
    e.write(&mut delay, 30, &data).unwrap();
    let mut back = vec![0u8; 100];
    e.read(30, &mut back).unwrap();
    assert_eq!(back, data);
    let mut before = [0u8; 30];
    e.read(0, &mut before).unwrap();
    assert!(
        before.iter().all(|&b| b == 0xFF),
        "bytes before the write untouched"
    );
    // four page writes, each polled through its 5 ms write cycle (not acknowledged meanwhile)
    assert!(control.stats().nacks >= 4 * 4, "{:?}", control.stats());
    assert!(matches!(
        e.write(&mut delay, 4090, &[0; 10]),
        Err(at24::Error::OutOfRange { .. })
    ));
}

#[test]
fn the_simulated_eeprom_wraps_inside_its_page_as_the_datasheet_says() {
    // a raw 40-byte write at 0: the last 8 bytes wrap onto bytes 0..8 of the same page
    let (mut bus, mut delay, _, _) = rig(0.0);
    let mut frame = vec![0u8, 0];
    frame.extend((0..40u8).map(|i| i + 1));
    bus.write(0x50, &frame).unwrap();
    embedded_hal::delay::DelayNs::delay_ms(&mut delay, 10);
    let mut e = At24::new_24c32(bus, 0x50);
    let mut page = [0u8; 33];
    e.read(0, &mut page).unwrap();
    assert_eq!(&page[..8], &[33, 34, 35, 36, 37, 38, 39, 40]);
    assert_eq!(page[8], 9);
    assert_eq!(page[31], 32);
    assert_eq!(page[32], 0xFF, "the next page is untouched");
}

fn example() -> CameraCalibration {
    let mut serial = [0u8; 16];
    serial[..6].copy_from_slice(b"UVC-07");
    CameraCalibration {
        serial,
        width: 1280,
        height: 720,
        fx: 762.8,
        fy: 762.8,
        cx: 639.5,
        cy: 359.5,
        k1: -0.12,
        k2: 0.03,
        rotation: [
            [0.999848, -0.017452, 0.0],
            [0.017452, 0.999848, 0.0],
            [0.0, 0.0, 1.0],
        ],
        translation_m: [0.0, -0.025, 0.0],
        calibration_cd_m2_s: 9.5,
        fisheye_k: None,
    }
}

#[test]
fn calibration_record_survives_a_torn_update_and_flipped_bits() {
    let clock = SimClock::virtual_time();
    let dev = SimAt24::new(0x50);
    let bus = SimBus::new(clock.clone()).with(dev);
    let mut delay = SimDelay(clock);
    let mut e = At24::new_24c32(bus, 0x50);
    // blank: nothing
    let s = calibration::read(&mut e).unwrap();
    assert_eq!(s.newest(), None);
    let c1 = example();
    assert_eq!(calibration::write(&mut e, &mut delay, &c1), Ok((1, 0)));
    let mut c2 = c1;
    c2.calibration_cd_m2_s = 9.8;
    assert_eq!(calibration::write(&mut e, &mut delay, &c2), Ok((2, 1)));
    assert_eq!(
        calibration::read(&mut e).unwrap().newest(),
        Some((c2, 2, 1))
    );
    // the update after that goes to copy A; tear it after 40 bytes (a power cut)
    let mut c3 = c1;
    c3.fx = 700.0;
    let torn = c3.encode(3);
    e.write(&mut delay, 0, &torn[..40]).unwrap();
    let s = calibration::read(&mut e).unwrap();
    assert!(
        matches!(s.a, Err(calibration::RecordError::Crc { .. })),
        "{:?}",
        s.a
    );
    assert_eq!(s.newest(), Some((c2, 2, 1)), "the last good record stays");
    // a flipped bit in copy B too: nothing valid, and it says why
    let mut b = [0u8; 1];
    e.read(2048 + 60, &mut b).unwrap();
    e.write(&mut delay, 2048 + 60, &[b[0] ^ 4]).unwrap();
    let s = calibration::read(&mut e).unwrap();
    assert_eq!(s.newest(), None);
    assert!(s.b.unwrap_err().to_string().contains("CRC"));
    // version 2: the version 1 body (176 bytes) + lens (1) + four fisheye coefficients (32)
    assert_eq!(RECORD_LEN, 12 + 176 + 1 + 32 + 4);
}

#[test]
fn a_write_protected_eeprom_is_a_verify_error() {
    let clock = SimClock::virtual_time();
    let mut dev = SimAt24::new(0x50);
    dev.write_protect = true;
    let bus = SimBus::new(clock.clone()).with(dev);
    let mut e = At24::new_24c32(bus, 0x50);
    let r = calibration::write(&mut e, &mut SimDelay(clock), &example());
    assert!(
        matches!(
            r,
            Err(calibration::UpdateError::Eeprom(at24::Error::Verify {
                offset: 0
            }))
        ),
        "{r:?}"
    );
}

#[test]
fn the_led_blinks_each_state_with_its_pattern() {
    let clock = SimClock::virtual_time();
    let pin = SimPin::new(clock.clone());
    let edges = pin.edges.clone();
    let mut led = StatusLed::new(pin, true, 0);
    let mut t = 0u64;
    let mut run = |led: &mut StatusLed<SimPin>, until: u64| {
        while t < until {
            led.tick(t).unwrap();
            clock.advance(Duration::from_millis(10));
            t += 10;
        }
    };
    led.set_state(NodeState::Commissioning, 0);
    run(&mut led, 3000);
    led.set_state(NodeState::Serving, 3000);
    run(&mut led, 5000);
    let e = edges.lock().unwrap().clone();
    let ms: Vec<(u64, bool)> = e.iter().map(|(d, l)| (d.as_millis() as u64, *l)).collect();
    // commissioning: edges every 500 ms from t = 0; then steady on from 3 s
    assert_eq!(
        ms,
        vec![
            (0, true),
            (500, false),
            (1000, true),
            (1500, false),
            (2000, true),
            (2500, false),
            (3000, true)
        ]
    );
}

#[test]
fn a_stuck_bus_never_hangs_the_node() {
    // real time: the bus jams for 30 s per transfer; the monitor reports it within its
    // deadline and the caller is never blocked
    let clock = SimClock::real();
    let bus = SimBus::new(clock.clone()).with(SimVeml7700::new(Box::new(|| 200.0), 3));
    let control = bus.control();
    let shared = SharedBus::new(bus, "sim-i2c");
    let sensor = AmbientSensor {
        driver: Veml7700::new(shared, veml7700::ADDRESS),
        delay: Box::new(SimDelay(clock)),
        name: "VEML7700 at 0x10 on sim-i2c".into(),
    };
    let mut m = AlsMonitor::spawn(Arc::new(Mutex::new(sensor)), Duration::from_millis(50));
    m.deadline = Duration::from_millis(400);
    let t0 = Instant::now();
    while m.status().readings == 0 {
        assert!(t0.elapsed() < Duration::from_secs(5), "no first reading");
        std::thread::sleep(Duration::from_millis(20));
    }
    let lx = m.status().last.unwrap().0.lux_lx;
    assert!((lx / 200.0 - 1.0).abs() < 0.01, "{lx}");
    control.set(BusFaults {
        stuck: true,
        stuck_timeout: Duration::from_secs(30),
        ..BusFaults::default()
    });
    let t1 = Instant::now();
    let problem = loop {
        let st = m.status(); // never blocks
        assert!(t1.elapsed() < Duration::from_secs(3), "no problem reported");
        if let Some(p) = st.problem(m.deadline) {
            break p;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(problem.contains("no answer"), "{problem}");
    // dropping the monitor with its thread stuck on the bus returns at once
    let t2 = Instant::now();
    drop(m);
    assert!(t2.elapsed() < Duration::from_millis(200));
    // and an unplugged sensor is a clear error, not a hang
    let clock = SimClock::virtual_time();
    let bus = SimBus::new(clock.clone());
    let mut s = AmbientSensor {
        driver: Veml7700::new(SharedBus::new(bus, "sim-i2c"), veml7700::ADDRESS),
        delay: Box::new(SimDelay(clock)),
        name: "VEML7700 at 0x10 on sim-i2c".into(),
    };
    let e = s.measure().unwrap_err();
    assert!(e.contains("no acknowledge"), "{e}");
}

#[test]
fn the_calibration_record_carries_the_boards_lens_both_ways() {
    use luxnode::board::Board;
    use luxnode::board::peripherals::{apply_calibration, record_from_board};
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("boards/rock5b/board.toml"),
    )
    .unwrap();
    let pinhole = "k1 = -0.12                   # radial distortion (OpenCV k1, k2)\nk2 = 0.03";
    assert!(text.contains(pinhole));
    let dir = tempfile::tempdir().unwrap();
    for fisheye in [false, true] {
        let t = if fisheye {
            text.replace(
                pinhole,
                "model = \"kannala_brandt\"\nk = [0.03, -0.008, 0.0005, 0.0]",
            )
            .replace("fx = 762.8  ", "fx = 420.0  ")
            .replace("fy = 762.8", "fy = 420.0")
        } else {
            text.clone()
        };
        let path = dir.path().join("board.toml");
        std::fs::write(&path, t).unwrap();
        let b = Board::load(&path).unwrap();
        let rec = record_from_board(&b.camera, "MOD-7").unwrap();
        assert_eq!(rec.fisheye_k.is_some(), fisheye);
        if fisheye {
            assert_eq!(rec.fisheye_k, Some([0.03, -0.008, 0.0005, 0.0]));
            assert_eq!((rec.k1, rec.k2, rec.fx), (0.0, 0.0, 420.0));
        }
        // through the EEPROM's bytes and back onto the board: the same cameras
        let (back, g) = CameraCalibration::decode(&rec.encode(5)).unwrap();
        assert_eq!((back, g), (rec, 5));
        assert_eq!(apply_calibration(&b.camera, &back).unwrap(), b.camera);
    }
}
