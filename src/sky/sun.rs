//! The sun's position by the NOAA solar calculator's algorithm (the low-accuracy formulas of
//! Meeus, *Astronomical Algorithms*, ch. 25 and 28, as NOAA's spreadsheet uses them): Julian
//! century, geometric mean longitude and anomaly, eccentricity, equation of centre, apparent
//! longitude, corrected obliquity, declination, equation of time, true solar time, hour angle.
//! Accurate to ~0.01° in altitude and azimuth for the years 1800..2100 (NOAA's statement).
//!
//! Atmospheric refraction is computed (NOAA's piecewise approximation) but kept apart:
//! [`SunPosition::altitude_rad`] is the geometric altitude, [`SunPosition::refraction_rad`]
//! what the atmosphere adds, [`SunPosition::apparent_altitude_rad`] their sum.
//!
//! The azimuth is measured from geographic north, clockwise seen from above (east = +90°).

use super::time::UnixTime;
use core::f64::consts::{FRAC_PI_2, PI, TAU};
use libm::{asin, atan2, cos, fmod, sin, sqrt, tan};

const DEG: f64 = PI / 180.0;

/// `x` wrapped into `0..modulus` (`f64::rem_euclid` is std only); `modulus` itself only by
/// rounding of a tiny negative `x`.
fn wrap(x: f64, modulus: f64) -> f64 {
    let r = fmod(x, modulus);
    if r < 0.0 { r + modulus } else { r }
}

/// Where the sun is, seen from a site at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPosition {
    /// Geometric altitude above the horizon (no refraction), −π/2..π/2.
    pub altitude_rad: f64,
    /// Azimuth from geographic north, clockwise seen from above (east = π/2), 0..2π.
    pub azimuth_rad: f64,
    /// The sun's declination.
    pub declination_rad: f64,
    /// The equation of time: apparent minus mean solar time, in minutes.
    pub equation_of_time_min: f64,
    /// The hour angle (0 at solar noon, positive in the afternoon), −π..π.
    pub hour_angle_rad: f64,
    /// Atmospheric refraction at that altitude (NOAA's approximation, standard atmosphere).
    pub refraction_rad: f64,
}

impl SunPosition {
    /// The altitude as seen through the atmosphere: geometric plus refraction.
    pub fn apparent_altitude_rad(&self) -> f64 {
        self.altitude_rad + self.refraction_rad
    }
}

/// The declination and equation of time at a Julian century since J2000.0 (NOAA).
fn declination_and_equation_of_time(t: f64) -> (f64, f64) {
    let mean_longitude_deg = wrap(280.466_46 + t * (36_000.769_83 + t * 0.000_303_2), 360.0);
    let mean_anomaly_deg = 357.529_11 + t * (35_999.050_29 - 0.000_153_7 * t);
    let eccentricity = 0.016_708_634 - t * (0.000_042_037 + 0.000_000_126_7 * t);
    let m = mean_anomaly_deg * DEG;
    let centre_deg = sin(m) * (1.914_602 - t * (0.004_817 + 0.000_014 * t))
        + sin(2.0 * m) * (0.019_993 - 0.000_101 * t)
        + sin(3.0 * m) * 0.000_289;
    let true_longitude_deg = mean_longitude_deg + centre_deg;
    let omega = (125.04 - 1934.136 * t) * DEG;
    let apparent_longitude = (true_longitude_deg - 0.005_69 - 0.004_78 * sin(omega)) * DEG;
    let mean_obliquity_deg =
        23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.000_59 - t * 0.001_813))) / 60.0) / 60.0;
    let obliquity = (mean_obliquity_deg + 0.002_56 * cos(omega)) * DEG;
    let declination = asin(sin(obliquity) * sin(apparent_longitude));
    let y = tan(obliquity / 2.0) * tan(obliquity / 2.0);
    let l0 = mean_longitude_deg * DEG;
    let e = eccentricity;
    let eot_rad = y * sin(2.0 * l0) - 2.0 * e * sin(m) + 4.0 * e * y * sin(m) * cos(2.0 * l0)
        - 0.5 * y * y * sin(4.0 * l0)
        - 1.25 * e * e * sin(2.0 * m);
    (declination, 4.0 * eot_rad / DEG)
}

/// NOAA's atmospheric refraction for a geometric altitude (standard pressure and
/// temperature): Sæmundsson-like terms above 5°, a polynomial down to −0.575°, then the
/// horizon formula; a few arc-minutes near the horizon, 0 above 85°.
pub fn refraction_rad(altitude_rad: f64) -> f64 {
    let h_deg = altitude_rad / DEG;
    let arcsec = if h_deg > 85.0 {
        0.0
    } else if h_deg > 5.0 {
        let t = tan(altitude_rad);
        58.1 / t - 0.07 / (t * t * t) + 0.000_086 / (t * t * t * t * t)
    } else if h_deg > -0.575 {
        1735.0 + h_deg * (-518.2 + h_deg * (103.4 + h_deg * (-12.79 + h_deg * 0.711)))
    } else {
        -20.772 / tan(altitude_rad)
    };
    arcsec / 3600.0 * DEG
}

/// The sun's position at `time` (UTC) from a site at `latitude_deg` (north positive) and
/// `longitude_deg` (east positive), by NOAA's algorithm (see the module docs).
pub fn sun_position(time: UnixTime, latitude_deg: f64, longitude_deg: f64) -> SunPosition {
    let t = (time.julian_date() - 2_451_545.0) / 36_525.0;
    let (declination_rad, equation_of_time_min) = declination_and_equation_of_time(t);
    let minutes_of_day =
        (time.seconds.rem_euclid(86_400) as f64 + f64::from(time.nanoseconds) * 1e-9) / 60.0;
    let true_solar_min = wrap(
        minutes_of_day + equation_of_time_min + 4.0 * longitude_deg,
        1440.0,
    );
    let hour_angle_rad = (true_solar_min / 4.0 - 180.0) * DEG;
    let (altitude_rad, azimuth_rad) =
        horizontal_of_equatorial(declination_rad, hour_angle_rad, latitude_deg);
    SunPosition {
        altitude_rad,
        azimuth_rad,
        declination_rad,
        equation_of_time_min,
        hour_angle_rad,
        refraction_rad: refraction_rad(altitude_rad),
    }
}

/// The geometric `(altitude_rad, azimuth_rad)` (azimuth from north, clockwise, 0..2π) of a
/// body at `declination_rad` and `hour_angle_rad` (0 at the meridian, positive west) seen from
/// latitude `latitude_deg`: the spherical triangle pole-zenith-body.
pub fn horizontal_of_equatorial(
    declination_rad: f64,
    hour_angle_rad: f64,
    latitude_deg: f64,
) -> (f64, f64) {
    let lat = latitude_deg * DEG;
    let sin_alt =
        sin(lat) * sin(declination_rad) + cos(lat) * cos(declination_rad) * cos(hour_angle_rad);
    let altitude_rad = asin(sin_alt.clamp(-1.0, 1.0));
    // azimuth from north, clockwise: atan2(east, north) of the direction to the body
    let east = -cos(declination_rad) * sin(hour_angle_rad);
    let north =
        cos(lat) * sin(declination_rad) - sin(lat) * cos(declination_rad) * cos(hour_angle_rad);
    (altitude_rad, wrap(atan2(east, north), TAU))
}

/// The unit vector in the sky frame (x east, y north, z up; Radiance's frame) of a direction
/// at `altitude_rad` above the horizon and `azimuth_rad` from north, clockwise.
pub fn sky_direction(altitude_rad: f64, azimuth_rad: f64) -> [f64; 3] {
    let c = cos(altitude_rad);
    [
        c * sin(azimuth_rad),
        c * cos(azimuth_rad),
        sin(altitude_rad),
    ]
}

/// `(altitude_rad, azimuth_rad)` of a sky-frame direction (any length > 0); the azimuth is
/// 0..=2π from north, clockwise (2π only by rounding), and 0 straight up or down.
pub fn altitude_azimuth(direction_sky: [f64; 3]) -> (f64, f64) {
    let [x, y, z] = direction_sky;
    let horizontal = sqrt(x * x + y * y);
    let altitude_rad = atan2(z, horizontal);
    let azimuth_rad = if horizontal == 0.0 {
        0.0
    } else {
        wrap(atan2(x, y), TAU)
    };
    (altitude_rad, azimuth_rad)
}

/// The room's orientation: which way geographic north is in the world frame.
///
/// The world frame is right-handed with z up; north is a unit vector in its x-y plane (the
/// room plan's `site.north`), and east is north turned clockwise seen from above,
/// `east = (north.y, −north.x)`, so that east × north = up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyFrame {
    north: [f64; 2],
}

impl SkyFrame {
    /// The frame of a room whose `north` is given in world x-y (normalised here); `None` when
    /// it is not finite or shorter than 1e-9.
    pub fn new(north: [f64; 2]) -> Option<Self> {
        let length = sqrt(north[0] * north[0] + north[1] * north[1]);
        (length.is_finite() && length > 1e-9).then(|| Self {
            north: [north[0] / length, north[1] / length],
        })
    }

    /// North in world x-y (unit length).
    pub fn north(&self) -> [f64; 2] {
        self.north
    }

    /// East in world x-y: north turned clockwise seen from above.
    pub fn east(&self) -> [f64; 2] {
        [self.north[1], -self.north[0]]
    }

    /// A sky-frame direction (x east, y north, z up) in the world frame.
    pub fn to_world(&self, direction_sky: [f64; 3]) -> [f64; 3] {
        let [e, n, u] = direction_sky;
        let east = self.east();
        [
            e * east[0] + n * self.north[0],
            e * east[1] + n * self.north[1],
            u,
        ]
    }

    /// A world direction in the sky frame (x east, y north, z up).
    pub fn to_sky(&self, direction_world: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = direction_world;
        let east = self.east();
        [
            x * east[0] + y * east[1],
            x * self.north[0] + y * self.north[1],
            z,
        ]
    }

    /// The unit world vector pointing to a body at `altitude_rad`, `azimuth_rad` (from
    /// north, clockwise).
    pub fn world_direction(&self, altitude_rad: f64, azimuth_rad: f64) -> [f64; 3] {
        self.to_world(sky_direction(altitude_rad, azimuth_rad))
    }

    /// The unit world vector pointing to the sun, at its apparent (refracted) altitude.
    pub fn sun_direction(&self, sun: &SunPosition) -> [f64; 3] {
        self.world_direction(sun.apparent_altitude_rad(), sun.azimuth_rad)
    }
}

/// The zenith angle of an altitude: π/2 − altitude.
pub fn zenith_angle_rad(altitude_rad: f64) -> f64 {
    FRAC_PI_2 - altitude_rad
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::time::parse_rfc3339;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// Meeus, *Astronomical Algorithms* (2nd ed.), example 25.a (1992-10-13 0h TD, the
    /// low-accuracy method NOAA uses): declination −7.78507°; example 28.b (the same formula
    /// 28.3 at that instant): equation of time 13m42.6s = 13.710 min. (TD − UT ≈ 1 min in
    /// 1992, 0.0007° of solar longitude, below these tolerances.)
    #[test]
    fn meeus_examples() {
        let time = parse_rfc3339("1992-10-13T00:00:00Z").expect("valid");
        let sun = sun_position(time, 0.0, 0.0);
        let declination_deg = sun.declination_rad / DEG;
        assert!(
            close(declination_deg, -7.785_07, 0.001),
            "{declination_deg}"
        );
        assert!(
            close(sun.equation_of_time_min, 13.71, 0.002),
            "{}",
            sun.equation_of_time_min
        );
    }

    #[test]
    fn noon_on_the_equator_at_an_equinox() {
        // 2024-03-20 near 12:07 UTC at 0°E: the sun crosses the meridian close to the zenith
        let time = parse_rfc3339("2024-03-20T12:07:00Z").expect("valid");
        let sun = sun_position(time, 0.0, 0.0);
        assert!(sun.altitude_rad / DEG > 89.5, "{sun:?}");
        // the equinox was at 03:06 UTC: the declination has grown to ~0.15° by noon
        assert!(sun.declination_rad.abs() / DEG < 0.2, "{sun:?}");
    }

    #[test]
    fn frame_handedness() {
        // north along +y: east is +x (the usual map)
        let f = SkyFrame::new([0.0, 2.0]).expect("north");
        assert_eq!(f.east(), [1.0, 0.0]);
        let east = f.world_direction(0.0, PI / 2.0);
        assert!(close(east[0], 1.0, 1e-15) && close(east[1], 0.0, 1e-15));
        // north along +x (the room plan's example): east is −y, south −x, west +y
        let f = SkyFrame::new([1.0, 0.0]).expect("north");
        assert_eq!(f.east(), [0.0, -1.0]);
        let south = f.world_direction(0.0, PI);
        assert!(close(south[0], -1.0, 1e-15) && close(south[1], 0.0, 1e-15));
        // east × north = up
        let [ex, ey] = f.east();
        let [nx, ny] = f.north();
        assert_eq!(ex * ny - ey * nx, 1.0);
        // to_sky undoes to_world
        let d = [0.3, -0.5, 0.8];
        let back = f.to_sky(f.to_world(d));
        for (b, d) in back.iter().zip(d) {
            assert!(close(*b, d, 1e-15));
        }
        assert!(SkyFrame::new([0.0, 0.0]).is_none());
        assert!(SkyFrame::new([f64::NAN, 1.0]).is_none());
    }

    #[test]
    fn refraction_is_about_half_a_degree_at_the_horizon() {
        let r_deg = refraction_rad(0.0) / DEG;
        assert!(close(r_deg, 0.482, 0.001), "{r_deg}"); // 1735″
        assert_eq!(refraction_rad(86.0 * DEG), 0.0);
        // 45°: 58.1″ − 0.07″ + 0.000086″ ≈ 58″
        assert!(close(
            refraction_rad(45.0 * DEG) / DEG * 3600.0,
            58.03,
            0.01
        ));
    }
}
