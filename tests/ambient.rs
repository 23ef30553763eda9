//! The ambient light sensor at commissioning: on the simulated board (the demo office, simulated
//! ToF + colour cameras, the VEML7700's register model on a simulated I2C bus reading what the
//! world sends up to the node), the camera's absolute gain found from the sensor's reading is
//! within 2 % of the simulated camera's true gain, and the model then predicts the sensor's
//! reading for other dimming states.

use std::sync::{Arc, Mutex};

use glam::DVec3;
use luxnode::camera::capture_sequence;
use luxnode::commission::{CommissionOptions, Gain};
use luxnode::peripherals::sim::{SimBus, SimClock, SimDelay, SimVeml7700};
use luxnode::peripherals::veml7700::{self, Veml7700};
use luxnode::sim::camera::{SimDepthOptions, SimLuminanceOptions, SimWorld};

#[test]
fn the_ambient_light_sensor_calibrates_the_camera_gain_within_2_percent() {
    let w = SimWorld::demo_office().unwrap();
    let ids = w.luminaire_ids();
    let n = ids.len();
    let mut depth = w.depth_camera(SimDepthOptions::default()).unwrap();
    let lum_opts = SimLuminanceOptions::default();
    let true_gain = lum_opts.cd_m2_per_unit;
    let mut lum = w.luminance_camera(lum_opts).unwrap();
    let mut lights = w.clone();
    let capture = capture_sequence(
        &mut depth,
        &mut lum,
        &mut lights,
        &ids,
        5,
        2,
        &mut |_, _, _| {},
    )
    .unwrap();
    // the sensor 1 cm below the camera, facing down
    let cam = w.camera().position_m;
    let als_at = cam - DVec3::new(0.0, 0.0, 0.01);
    let down = DVec3::new(0.0, 0.0, -1.0);
    let per_lum = w.receiver_lx(als_at, down, 20_000);
    let levels = vec![1.0; n];
    let truth: f64 = per_lum.iter().sum();
    // the reading goes through the register model and the driver's auto-range
    let light = Arc::new(Mutex::new(truth));
    let l = light.clone();
    let clock = SimClock::virtual_time();
    let bus =
        SimBus::new(clock.clone()).with(SimVeml7700::new(Box::new(move || *l.lock().unwrap()), 5));
    let mut als = Veml7700::new(bus, veml7700::ADDRESS);
    let reading = als.measure_auto(&mut SimDelay(clock)).unwrap();
    assert!(
        (reading.lux_lx / truth - 1.0).abs() < 0.01,
        "{} vs {truth}",
        reading.lux_lx
    );
    let scene = w.scene();
    let o = CommissionOptions {
        gain: Gain::Ambient {
            position_m: als_at.to_array(),
            normal: down.to_array(),
            lux_lx: reading.lux_lx,
            levels: levels.clone(),
        },
        ..CommissionOptions::default()
    };
    let c = luxnode::commission::from_capture(
        &capture,
        scene.luminaires.clone(),
        scene.sensors.clone(),
        scene.desks.clone(),
        &o,
    )
    .unwrap();
    let gain = c.report.reflectance.gain_cd_m2_per_unit;
    let err = gain / true_gain - 1.0;
    let reference = c.report.ambient_response_lx.clone().unwrap();
    let predicted: f64 = reference.iter().sum();
    eprintln!(
        "ALS {truth:.2} lx (read {:.2} lx at {:?}), gain {gain:.5} vs {true_gain} ({:+.2} %), \
         model predicts {predicted:.2} lx; per luminaire truth {per_lum:.2?} model {reference:.2?}",
        reading.lux_lx,
        reading.setting,
        100.0 * err
    );
    // Issue 17's target, 2 %. Measured: -0.54 % before the engine's -0.0 ray-direction fix
    // (issue 13), +1.24 % since (the model keeps the light that used to leak out, so the
    // reflectances read lower and the gain higher; the simulated world's truth moved +0.4 %).
    assert!(err.abs() < 0.02, "gain off by {:.2} %", 100.0 * err);
    // the run-time check's reference: one luminaire at a time (measured: within 4.5 %)
    for (j, (m, t)) in reference.iter().zip(&per_lum).enumerate() {
        assert!(
            (m / t - 1.0).abs() < 0.10,
            "luminaire {j}: model {m}, truth {t}"
        );
    }
}
