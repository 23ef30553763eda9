//! The Tregenza sky subdivision: 145 patches of nearly equal solid angle, the basis of
//! daylight coefficients.
//!
//! Seven bands 12° high, with 30, 30, 24, 24, 18, 12 and 6 patches, centred at altitudes
//! 6°, 18°, …, 78°, and a cap above 84° around the zenith.
//!
//! Numbering follows Radiance (`tregenza.cal`, `tregsrc.cal`, used by `genskyvec` and
//! `gendaymtx`): our index `i` (0..145) is Radiance's bin `i + 1` (Radiance's bin 0 is the
//! ground). Patch 0 is centred on geographic north at the horizon band, and the numbers go
//! round towards the east (clockwise seen from above) in each band, band after band upwards;
//! the cap is patch 144. A band of `n` patches is cut at azimuths `(k − ½)·360°/n`, so
//! patch `k` of the band spans `[(k − ½), (k + ½)) · 360°/n` from north and is centred at
//! `k · 360°/n`. A direction exactly on a cut belongs to the patch to the east of it, and one
//! exactly at 12°·b to band b (the upper one), as in Radiance.

use super::sun::{altitude_azimuth, sky_direction};
use core::f64::consts::{FRAC_PI_2, PI, TAU};
use libm::{floor, sin};

/// The number of patches.
pub const PATCH_COUNT: usize = 145;

/// Patches in each 12° band from the horizon up (the zenith cap is not a band).
pub const PATCHES_PER_BAND: [usize; 7] = [30, 30, 24, 24, 18, 12, 6];

/// The height of a band.
pub const BAND_HEIGHT_RAD: f64 = 12.0 * PI / 180.0;

/// The index of the first patch of each band, and of the cap (`FIRST_PATCH[7] == 144`).
const FIRST_PATCH: [usize; 8] = [0, 30, 60, 84, 108, 126, 138, 144];

/// One patch of the Tregenza sky, in the sky frame (x east, y north, z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Patch {
    /// The lowest altitude of the patch.
    pub altitude_min_rad: f64,
    /// The highest altitude of the patch (π/2 for the cap).
    pub altitude_max_rad: f64,
    /// Where the patch starts, from north clockwise; negative for the patches centred on
    /// north (−π for the cap, which spans every azimuth).
    pub azimuth_min_rad: f64,
    /// Where the patch ends, from north clockwise (`azimuth_min_rad + width`).
    pub azimuth_max_rad: f64,
    /// The centre's altitude (the middle of the band; π/2 for the cap).
    pub altitude_rad: f64,
    /// The centre's azimuth, from north clockwise (0 for the cap).
    pub azimuth_rad: f64,
    /// The solid angle, `Δazimuth · (sin altitude_max − sin altitude_min)`.
    pub solid_angle_sr: f64,
    /// The projected solid angle onto the horizontal,
    /// `Δazimuth · (sin² altitude_max − sin² altitude_min) / 2`: a patch of uniform
    /// luminance L gives L times this in horizontal illuminance.
    pub projected_solid_angle_sr: f64,
}

impl Patch {
    /// The unit vector to the patch's centre, in the sky frame.
    pub fn centre(&self) -> [f64; 3] {
        sky_direction(self.altitude_rad, self.azimuth_rad)
    }
}

/// Patch `index` (0..145), `None` past the last.
pub fn patch(index: usize) -> Option<Patch> {
    if index >= PATCH_COUNT {
        return None;
    }
    let band = FIRST_PATCH.iter().rposition(|&first| first <= index)?;
    let altitude_min_rad = band as f64 * BAND_HEIGHT_RAD;
    if band == 7 {
        let s = sin(altitude_min_rad);
        return Some(Patch {
            altitude_min_rad,
            altitude_max_rad: FRAC_PI_2,
            azimuth_min_rad: -PI,
            azimuth_max_rad: PI,
            altitude_rad: FRAC_PI_2,
            azimuth_rad: 0.0,
            solid_angle_sr: TAU * (1.0 - s),
            projected_solid_angle_sr: PI * (1.0 - s * s),
        });
    }
    let altitude_max_rad = altitude_min_rad + BAND_HEIGHT_RAD;
    let width_rad = TAU / PATCHES_PER_BAND[band] as f64;
    let azimuth_rad = (index - FIRST_PATCH[band]) as f64 * width_rad;
    let (s0, s1) = (sin(altitude_min_rad), sin(altitude_max_rad));
    Some(Patch {
        altitude_min_rad,
        altitude_max_rad,
        azimuth_min_rad: azimuth_rad - width_rad / 2.0,
        azimuth_max_rad: azimuth_rad + width_rad / 2.0,
        altitude_rad: altitude_min_rad + BAND_HEIGHT_RAD / 2.0,
        azimuth_rad,
        solid_angle_sr: width_rad * (s1 - s0),
        projected_solid_angle_sr: width_rad * (s1 * s1 - s0 * s0) / 2.0,
    })
}

/// All 145 patches, in order.
pub fn patches() -> impl Iterator<Item = Patch> {
    (0..PATCH_COUNT).filter_map(patch)
}

/// The patch a sky-frame direction (x east, y north, z up; any length > 0) falls in; `None`
/// below the horizon (altitude < 0) or for a direction that is not finite or zero.
pub fn patch_of(direction_sky: [f64; 3]) -> Option<usize> {
    if !direction_sky.iter().all(|c| c.is_finite()) || direction_sky == [0.0; 3] {
        return None;
    }
    let (altitude_rad, azimuth_rad) = altitude_azimuth(direction_sky);
    if altitude_rad < 0.0 {
        return None;
    }
    let band = floor(altitude_rad / BAND_HEIGHT_RAD) as usize;
    if band >= 7 {
        return Some(PATCH_COUNT - 1);
    }
    let n = PATCHES_PER_BAND[band];
    let width_rad = TAU / n as f64;
    // shift by half a patch so that the cut before patch 0 is at 0; wrap past the last
    let k = floor(azimuth_rad / width_rad + 0.5) as usize % n;
    Some(FIRST_PATCH[band] + k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const DEG: f64 = PI / 180.0;

    #[test]
    fn solid_angles_sum_to_the_hemisphere() {
        let total: f64 = patches().map(|p| p.solid_angle_sr).sum();
        assert!((total - TAU).abs() < 1e-12, "{total}");
        let projected: f64 = patches().map(|p| p.projected_solid_angle_sr).sum();
        assert!((projected - PI).abs() < 1e-12, "{projected}");
        assert_eq!(patches().count(), 145);
        // Radiance's tregsrc.cal: the cap's solid angle is 0.0344199465 sr
        let cap = patch(144).expect("cap");
        assert!((cap.solid_angle_sr - 0.034_419_946_5).abs() < 1e-10);
        assert!(patch(145).is_none());
    }

    #[test]
    fn radiance_numbering() {
        // Radiance bin 1 (our 0): due north at the horizon band, bin 2 is 12° east of it;
        // bin 31 (our 30) starts the second band at north; bin 145 the zenith
        let p0 = patch(0).expect("patch");
        assert_eq!((p0.altitude_rad / DEG, p0.azimuth_rad), (6.0, 0.0));
        let p1 = patch(1).expect("patch");
        assert!((p1.azimuth_rad / DEG - 12.0).abs() < 1e-12);
        let c = p1.centre();
        assert!(c[0] > 0.0 && c[1] > 0.0, "patch 1 is north-east: {c:?}");
        let p30 = patch(30).expect("patch");
        assert!((p30.altitude_rad / DEG - 18.0).abs() < 1e-12 && p30.azimuth_rad == 0.0);
        // the band of 6 (Radiance 139..144) is centred at 78°, every 60°
        let p143 = patch(143).expect("patch");
        assert!((p143.altitude_rad / DEG - 78.0).abs() < 1e-12);
        assert!((p143.azimuth_rad / DEG - 300.0).abs() < 1e-12);
        // 1° east of due east at 10°: band 0, 91°/12° = 7.6 → patch 8 (centred at 96°)
        assert_eq!(patch_of(sky_direction(10.0 * DEG, 91.0 * DEG)), Some(8));
        // just west of north wraps to patch 0; just below the horizon is no patch
        assert_eq!(patch_of(sky_direction(3.0 * DEG, 359.0 * DEG)), Some(0));
        assert_eq!(patch_of(sky_direction(3.0 * DEG, 353.0 * DEG)), Some(29));
        assert_eq!(patch_of([1.0, 0.0, -1e-9]), None);
        assert_eq!(patch_of([0.0, 0.0, 1.0]), Some(144));
        assert_eq!(patch_of([0.0, 0.0, 0.0]), None);
        assert_eq!(patch_of([f64::NAN, 0.0, 1.0]), None);
    }

    proptest! {
        #[test]
        fn the_centre_of_a_patch_is_in_it(i in 0usize..PATCH_COUNT) {
            let p = patch(i).expect("patch");
            prop_assert_eq!(patch_of(p.centre()), Some(i));
        }

        #[test]
        fn a_direction_is_in_the_patch_whose_ranges_hold_it(
            altitude_deg in 0.0f64..90.0, azimuth_deg in 0.0f64..360.0,
        ) {
            let i = patch_of(sky_direction(altitude_deg * DEG, azimuth_deg * DEG))
                .expect("above the horizon");
            let p = patch(i).expect("patch");
            let tol = 1e-9;
            prop_assert!(altitude_deg * DEG >= p.altitude_min_rad - tol);
            prop_assert!(altitude_deg * DEG <= p.altitude_max_rad + tol);
            if i < PATCH_COUNT - 1 {
                // the azimuth, brought into the patch's range by whole turns
                let a = azimuth_deg * DEG;
                let inside = [a - TAU, a, a + TAU].iter().any(|&a| {
                    a >= p.azimuth_min_rad - tol && a <= p.azimuth_max_rad + tol
                });
                prop_assert!(inside, "{} {} in {:?}", altitude_deg, azimuth_deg, p);
            }
        }
    }
}
