//! The ambient light sensor at commissioning: on the simulated board (the demo office, simulated
//! ToF + colour cameras, the VEML7700's register model on a simulated I2C bus reading what the
//! world sends up to the node), the hooded sensor gives the camera's absolute gain straight from
//! the frames, within 0.5 % of the simulated camera's true gain and independent of the unseen
//! walls, and the model then predicts the sensor's reading per luminaire; a bare sensor's gain
//! comes through the model and moves with the unseen walls' default reflectance.

use std::sync::{Arc, Mutex};

use glam::DVec3;
use luxnode::camera::capture_sequence;
use luxnode::commission::{CommissionOptions, Gain};
use luxnode::lsc::{AngularResponse, Lsc};
use luxnode::peripherals::sim::{SimBus, SimClock, SimDelay, SimVeml7700};
use luxnode::peripherals::veml7700::{self, Veml7700};
use luxnode::sim::camera::{SimDepthOptions, SimLuminanceOptions, SimWorld};

/// The world commissioned from `capture` with the camera's gain from a sensor 1 cm below the
/// camera facing down (`response`), which read `lux_lx` of the luminaires' own light with every
/// luminaire on; the unseen walls defaulted to `wall_rho`.
fn commission_with_als(
    w: &SimWorld,
    capture: &luxnode::camera::capture::Capture,
    als_at: DVec3,
    response: &AngularResponse,
    lux_lx: f64,
    wall_rho: f64,
) -> luxnode::commission::Commissioned {
    let scene = w.scene();
    let mut o = CommissionOptions {
        gain: Gain::Ambient {
            position_m: als_at.to_array(),
            normal: [0.0, 0.0, -1.0],
            lux_lx,
            levels: vec![1.0; scene.luminaires.len()],
            response: response.clone(),
        },
        ..CommissionOptions::default()
    };
    o.closure.wall_rho = wall_rho;
    luxnode::commission::from_capture(
        capture,
        scene.luminaires.clone(),
        scene.sensors.clone(),
        scene.desks.clone(),
        &o,
    )
    .unwrap()
}

#[test]
fn the_hooded_ambient_light_sensor_calibrates_the_camera_gain_directly() {
    let w = SimWorld::demo_office().unwrap();
    let ids = w.luminaire_ids();
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
    // the sensor 1 cm below the camera, facing down, under the sim board's 35° hood
    let cam = w.camera().position_m;
    let als_at = cam - DVec3::new(0.0, 0.0, 0.01);
    let down = DVec3::new(0.0, 0.0, -1.0);
    let hood = AngularResponse::Table(Lsc::hooded(35f64.to_radians()).unwrap());
    let commission = |response: &AngularResponse, wall_rho: f64| {
        let per_lum = w.receiver_lx(als_at, down, response, 20_000);
        let truth: f64 = per_lum.iter().sum();
        // the reading goes through the register model and the driver's auto-range
        let light = Arc::new(Mutex::new(truth));
        let l = light.clone();
        let clock = SimClock::virtual_time();
        let bus = SimBus::new(clock.clone())
            .with(SimVeml7700::new(Box::new(move || *l.lock().unwrap()), 5));
        let mut als = Veml7700::new(bus, veml7700::ADDRESS);
        let reading = als.measure_precise(&mut SimDelay(clock), 4).unwrap();
        assert!(
            (reading.lux_lx / truth - 1.0).abs() < 0.01,
            "{} vs {truth}",
            reading.lux_lx
        );
        let c = commission_with_als(&w, &capture, als_at, response, reading.lux_lx, wall_rho);
        let gain = c.report.reflectance.gain_cd_m2_per_unit;
        let err = gain / true_gain - 1.0;
        eprintln!(
            "{response}, unseen walls {wall_rho}: ALS {truth:.2} lx (read {:.2} lx at {:?}), \
             gain {gain:.5} vs {true_gain} ({:+.2} %), direct: {:?}",
            reading.lux_lx,
            reading.setting,
            100.0 * err,
            c.report.ambient_direct
        );
        (err, c, per_lum)
    };
    // Hooded: the gain straight from the frames (docs/peripherals.md: measured -0.20 %), the
    // same whatever the unseen walls' default reflectance. Issue 17's target is 2 %; the guard
    // is 3 × the measured value.
    let (err, c, per_lum) = commission(&hood, 0.5);
    let d = c.report.ambient_direct.clone().unwrap();
    assert!(d.covered > 0.99 && d.saturated == 0.0, "{d:?}");
    assert!(err.abs() < 0.005, "gain off by {:.2} %", 100.0 * err);
    let (err_bright, _, _) = commission(&hood, 0.6);
    assert!((err_bright - err).abs() < 1e-9, "{err} vs {err_bright}");
    // the run-time check's reference: the final model predicts the hooded sensor's reading
    // per luminaire (measured: within 4 % for the luminaires that light its cone). In total
    // -4.8 % since the reflectance fit holds the seen patches at their measured exitance (stop
    // 37): the seen reflectances no longer run high to make up for the unseen walls' default
    // (0.5 here), and the sensor's cone takes in much of those walls; the guard is 6 %.
    let reference = c.report.ambient_response_lx.clone().unwrap();
    let total: f64 = per_lum.iter().sum();
    let predicted: f64 = reference.iter().sum();
    eprintln!("per luminaire truth {per_lum:.2?} model {reference:.2?}");
    assert!(
        (predicted / total - 1.0).abs() < 0.06,
        "{predicted} vs {total}"
    );
    for (j, (m, t)) in reference.iter().zip(&per_lum).enumerate() {
        assert!(
            (m - t).abs() < 0.10 * t + 0.01 * total,
            "luminaire {j}: model {m}, truth {t}"
        );
    }
    // Bare (cosine): the sensor sees walls the camera does not, the gain comes through the model
    // and its unseen walls' default reflectance moves it (docs/peripherals.md: -4.00 % at 0.5,
    // -18.9 % at 0.6, the walls being 0.6 and the window 0.1 in this room).
    let (bare_05, c, _) = commission(&AngularResponse::Cosine, 0.5);
    assert!(c.report.ambient_direct.is_none());
    assert!(
        c.report
            .warnings
            .iter()
            .any(|w| w.contains("sees beyond the camera")),
        "{:?}",
        c.report.warnings
    );
    let (bare_06, _, _) = commission(&AngularResponse::Cosine, 0.6);
    eprintln!(
        "bare sensor: gain {:+.2} % (walls 0.5), {:+.2} % (walls 0.6)",
        100.0 * bare_05,
        100.0 * bare_06
    );
    assert!(bare_05.abs() < 0.06, "{bare_05}");
    assert!(
        (0.12..0.25).contains(&(bare_05 - bare_06)),
        "{bare_05} {bare_06}"
    );
}

/// Commissioning in daylight: the sensor's reading with the lights on less one with them off
/// and the frames less their all-off frames are both the luminaires' own light, so the hooded
/// sensor's gain is the one it gives in the dark, though the daylight at the sensor is a
/// sizeable share of what it reads and brightens during the capture.
#[test]
fn in_daylight_the_hooded_sensor_gives_the_gain_it_gives_in_the_dark() {
    use luxnode::camera::{LuminanceCamera, LuminanceFrame, capture_sequence};
    use luxnode::sim::camera::WorldExtras;
    let w = SimWorld::demo_office().unwrap();
    let ids = w.luminaire_ids();
    let lum_opts = SimLuminanceOptions::default();
    let true_gain = lum_opts.cd_m2_per_unit;
    let cam = w.camera().position_m;
    let als_at = cam - DVec3::new(0.0, 0.0, 0.01);
    let down = DVec3::new(0.0, 0.0, -1.0);
    let hood = AngularResponse::Table(Lsc::hooded(35f64.to_radians()).unwrap());
    let per_lum = w.receiver_lx(als_at, down, &hood, 20_000);
    let day_per_lm = w.receiver_daylight_lx(als_at, down, &hood, 20_000);
    let lamps: f64 = per_lum.iter().sum();
    assert!(day_per_lm > 0.0, "the hooded sensor sees the daylit floor");

    /// The world's colour camera with the window brightening by 2 % a frame.
    struct Brightening {
        world: SimWorld,
        inner: luxnode::sim::camera::SimLuminanceCamera,
        exitance_lm_m2: f64,
    }
    impl LuminanceCamera for Brightening {
        fn capture_luminance(&mut self) -> Result<LuminanceFrame, luxnode::camera::CameraError> {
            self.world.set_extras(WorldExtras {
                window_exitance_lm_m2: self.exitance_lm_m2,
                ..WorldExtras::default()
            });
            self.exitance_lm_m2 *= 1.02;
            self.inner.capture_luminance()
        }
    }
    let gain_with = |exitance_lm_m2: f64| {
        let mut depth = w.depth_camera(SimDepthOptions::default()).unwrap();
        let mut lum = Brightening {
            world: w.clone(),
            inner: w.luminance_camera(lum_opts.clone()).unwrap(),
            exitance_lm_m2,
        };
        let mut lights = w.clone();
        let capture = capture_sequence(
            &mut depth,
            &mut lum,
            &mut lights,
            &ids,
            3,
            2,
            &mut |_, _, _| {},
        )
        .unwrap();
        // the sensor read after the capture, the daylight brighter again: on less off
        let day_now = lum.exitance_lm_m2 * 1.05 * day_per_lm;
        let (on, off) = (lamps + day_now, day_now);
        let c = commission_with_als(&w, &capture, als_at, &hood, on - off, 0.5);
        assert!(c.report.ambient_direct.is_some());
        let g = c.report.reflectance.gain_cd_m2_per_unit;
        eprintln!(
            "window {exitance_lm_m2} lm/m2: the sensor reads {on:.1} lx on, {off:.1} lx off \
             (daylight {:.0} % of it); gain {g:.5} vs {true_gain} ({:+.2} %)",
            100.0 * off / on,
            100.0 * (g / true_gain - 1.0)
        );
        (g, off / on)
    };
    let (dark, _) = gain_with(0.0);
    let (day, share) = gain_with(1500.0);
    // the daylight is a sizeable share of the reading; had it entered the gain, the gain would
    // be off by about that much
    assert!(share > 0.1, "daylight share {share}");
    // measured: -0.03 % in the dark, +0.27 % in daylight (the daylight brightens geometrically,
    // 2 % a frame, and the all-off frames are interpolated linearly); guards twice that
    assert!((day / dark - 1.0).abs() < 0.006, "{day} vs {dark}");
    assert!(
        (day / true_gain - 1.0).abs() < 0.006,
        "{day} vs {true_gain}"
    );
}
