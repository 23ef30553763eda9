//! The daylight-coefficient section: how the sky, seen through the room plan's windows that
//! no camera sees, lights the surfaces the camera sees and the desk sensors (issue 28, item 3).
//! `no_std`, borrowed like the rest of the image.
//!
//! Column j < 145 is Tregenza sky patch j, column 145 the ground below the horizon; a value is
//! lx per cd/m² of that column's luminance. Both matrices are *boundary* coefficients: the
//! sky's direct light through the windows plus its interreflections over the patches the
//! camera does not see, with the seen patches held at zero exitance (their light is measured
//! at run time and propagated by the live estimator itself, `crate::live`):
//!
//! * `seen_lx[r][j]`: irradiance on seen patch `seen_patch[r]`;
//! * `sensor_lx[s][j]`: irradiance at desk sensor s (direct sky plus its gather over the
//!   unseen patches' exitance).
//!
//! With the sky's luminance `L_j` (a CIE standard sky at the frame's sun, scaled by the fit),
//! the seen patch gets `Σ_j seen_lx[r][j] L_j` and the sensor `Σ_j sensor_lx[s][j] L_j`.

use serde::{Deserialize, Serialize};

use super::values::f16_bits_to_f64;
use super::{Bytes, ImageError, check};

/// Magic of the daylight-coefficient section.
pub const DAYLIGHT_MAGIC: [u8; 4] = *b"LXDC";
/// Version of the section this build writes (2: with the seen glazing patches).
pub const DAYLIGHT_VERSION: u16 = 2;
/// The first version, without [`DaylightCoefficients::glazing_seen`] (still read: no seen
/// window then).
pub const DAYLIGHT_VERSION_WITHOUT_GLAZING: u16 = 1;
/// Columns: the 145 Tregenza patches and the ground.
pub const COLUMNS: usize = 146;
/// Largest coefficient accepted, lx per cd/m² (a receiver at a window sees at most π sr of
/// sky: π).
pub const MAX_COEFFICIENT: f32 = 4.0;

/// The daylight-coefficient section (version [`DAYLIGHT_VERSION`]; the body is these fields in
/// postcard, then, from version 2, [`Self::glazing_seen`] as one more postcard byte string).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DaylightCoefficients<'a> {
    /// [`DAYLIGHT_VERSION`].
    pub version: u16,
    /// Site latitude, degrees north.
    pub latitude_deg: f64,
    /// Site longitude, degrees east.
    pub longitude_deg: f64,
    /// Geographic north in the room's x-y plane (unit vector).
    pub north: [f64; 2],
    /// Ground reflectance outside (the ground column's luminance is `ρ_g E_h / π`).
    pub ground_rho: f64,
    /// Windows the coefficients go through.
    pub windows: u16,
    /// Their glazed area, m².
    pub window_area_m2: f64,
    /// Seen patches, ascending u32 LE.
    #[serde(borrow)]
    pub seen_patch: Bytes<'a>,
    /// `[seen][COLUMNS]` IEEE half floats (f16) LE, lx per cd/m² (3 significant digits: the
    /// sky fit's scale absorbs a common factor, and the sampling noise of 64 window points per
    /// patch is larger).
    #[serde(borrow)]
    pub seen_lx: Bytes<'a>,
    /// `[sensor][COLUMNS]` f16 LE, lx per cd/m².
    #[serde(borrow)]
    pub sensor_lx: Bytes<'a>,
    /// The seen patches that are glazing, ascending u32 LE (version 2; empty in version 1).
    /// The camera sees a window from the ceiling looking down and out, at the ground's
    /// luminance, not at the sky's light it lets in: its light comes through the coefficients,
    /// and its measured luminance is not the exitance it sends into the room.
    #[serde(skip)]
    pub glazing_seen: Bytes<'a>,
}

impl<'a> DaylightCoefficients<'a> {
    /// Decodes and checks a section body against an image of `patches` patches and `sensors`
    /// sensors.
    pub fn parse(body: &'a [u8], patches: usize, sensors: usize) -> Result<Self, ImageError> {
        let (mut d, rest): (DaylightCoefficients<'a>, &'a [u8]) =
            postcard::take_from_bytes(body).map_err(|_| ImageError::Decode)?;
        let rest = if d.version >= DAYLIGHT_VERSION {
            let (g, rest): (Bytes<'a>, &'a [u8]) =
                postcard::take_from_bytes(rest).map_err(|_| ImageError::Decode)?;
            d.glazing_seen = g;
            rest
        } else {
            rest
        };
        check(rest.is_empty(), "bytes after the daylight section")?;
        d.validate(patches, sensors)?;
        Ok(d)
    }

    /// The body of this section as [`Self::parse`] reads it.
    #[cfg(feature = "std")]
    pub fn encode(&self) -> Result<std::vec::Vec<u8>, postcard::Error> {
        let mut out = postcard::to_stdvec(self)?;
        if self.version >= DAYLIGHT_VERSION {
            out.extend(postcard::to_stdvec(&self.glazing_seen)?);
        }
        Ok(out)
    }

    fn validate(&self, patches: usize, sensors: usize) -> Result<(), ImageError> {
        check(
            (DAYLIGHT_VERSION_WITHOUT_GLAZING..=DAYLIGHT_VERSION).contains(&self.version),
            "daylight section version",
        )?;
        check(
            self.latitude_deg.is_finite()
                && self.longitude_deg.is_finite()
                && (-90.0..=90.0).contains(&self.latitude_deg)
                && (-180.0..=180.0).contains(&self.longitude_deg),
            "daylight site",
        )?;
        let [nx, ny] = self.north;
        let len2 = nx * nx + ny * ny;
        check(
            len2.is_finite() && (len2 - 1.0).abs() < 1e-6,
            "daylight north",
        )?;
        check(
            self.ground_rho.is_finite() && (0.0..=1.0).contains(&self.ground_rho),
            "daylight ground reflectance",
        )?;
        check(
            self.window_area_m2.is_finite() && self.window_area_m2 >= 0.0,
            "daylight window area",
        )?;
        let n = ascending_patches(
            &self.seen_patch,
            patches,
            [
                "daylight seen",
                "daylight seen patch out of range",
                "daylight seen patches not ascending",
            ],
        )?;
        let rows_ok = |b: &Bytes<'_>, rows: usize| -> Result<(), ImageError> {
            let want = rows.checked_mul(COLUMNS);
            check(
                want.is_some() && b.count(2) == want,
                "daylight coefficients",
            )?;
            for k in 0..rows * COLUMNS {
                let x = f16_bits_to_f64(b.u16_at(k));
                check(
                    x.is_finite() && (0.0..=f64::from(MAX_COEFFICIENT)).contains(&x),
                    "daylight coefficient out of range",
                )?;
            }
            Ok(())
        };
        rows_ok(&self.seen_lx, n)?;
        rows_ok(&self.sensor_lx, sensors)?;
        ascending_patches(
            &self.glazing_seen,
            patches,
            [
                "daylight glazing",
                "daylight glazing patch out of range",
                "daylight glazing patches not ascending",
            ],
        )?;
        Ok(())
    }

    /// Whether seen patch `p` is glazing (a window the camera sees).
    pub fn is_glazing(&self, p: u32) -> bool {
        let n = self.glazing_seen.0.len() / 4;
        // ascending: a binary search over the u32s
        let (mut lo, mut hi) = (0, n);
        while lo < hi {
            let mid = (lo + hi) / 2;
            match self.glazing_seen.u32_at(mid).cmp(&p) {
                core::cmp::Ordering::Less => lo = mid + 1,
                core::cmp::Ordering::Greater => hi = mid,
                core::cmp::Ordering::Equal => return true,
            }
        }
        false
    }

    /// Seen patches.
    pub fn seen(&self) -> usize {
        self.seen_patch.0.len() / 4
    }

    /// Seen patch of row r.
    pub fn seen_patch(&self, r: usize) -> usize {
        self.seen_patch.u32_at(r) as usize
    }

    /// Coefficient of seen row r, column j.
    pub fn seen_lx(&self, r: usize, j: usize) -> f64 {
        f16_bits_to_f64(self.seen_lx.u16_at(r * COLUMNS + j))
    }

    /// Coefficient of sensor s, column j.
    pub fn sensor_lx(&self, s: usize, j: usize) -> f64 {
        f16_bits_to_f64(self.sensor_lx.u16_at(s * COLUMNS + j))
    }
}

/// The count of a list of ascending u32 patch ids below `patches`, or the error named by
/// `what` (length, range, order).
fn ascending_patches(
    b: &Bytes<'_>,
    patches: usize,
    what: [&'static str; 3],
) -> Result<usize, ImageError> {
    let n = b.count(4).ok_or(ImageError::Inconsistent(what[0]))?;
    let mut last: Option<u32> = None;
    for r in 0..n {
        let p = b.u32_at(r);
        check((p as usize) < patches, what[1])?;
        check(last.is_none_or(|q| q < p), what[2])?;
        last = Some(p);
    }
    Ok(n)
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    /// A section body over `seen` patches (of 10) and 2 sensors, seen coefficients `c`.
    fn body(seen: &[u32], c: f32, north: [f64; 2]) -> Vec<u8> {
        body_with(DAYLIGHT_VERSION, seen, &[seen[0]], c, north)
    }

    /// [`body`] at `version` with the seen patches `glazing` on a window.
    fn body_with(version: u16, seen: &[u32], glazing: &[u32], c: f32, north: [f64; 2]) -> Vec<u8> {
        let glazing_b: Vec<u8> = glazing.iter().flat_map(|p| p.to_le_bytes()).collect();
        let seen_b: Vec<u8> = seen.iter().flat_map(|p| p.to_le_bytes()).collect();
        let seen_lx = f16s(&std::vec![c; seen.len() * COLUMNS]);
        let sensor_lx = f16s(&std::vec![0.5; 2 * COLUMNS]);
        let d = DaylightCoefficients {
            version,
            latitude_deg: 47.4,
            longitude_deg: 8.5,
            north,
            ground_rho: 0.2,
            windows: 1,
            window_area_m2: 6.0,
            seen_patch: Bytes(&seen_b),
            seen_lx: Bytes(&seen_lx),
            sensor_lx: Bytes(&sensor_lx),
            glazing_seen: Bytes(&glazing_b),
        };
        d.encode().expect("encode")
    }

    /// A valid body: 3 seen patches of 10, 2 sensors.
    fn valid_body() -> Vec<u8> {
        body(&[1, 4, 9], 0.25, [0.0, 1.0])
    }

    proptest! {
        /// A corrupted section (bytes flipped, or cut short) is refused or, when it still
        /// parses, every coefficient it gives is finite and in range: never a panic, never a
        /// NaN into the sky fit.
        #[test]
        fn a_corrupted_section_is_refused_or_sane(
            flips in proptest::collection::vec((0usize..4096, any::<u8>()), 1..8),
            cut in 0usize..4096,
        ) {
            let mut body = valid_body();
            for (at, x) in flips {
                let n = body.len();
                body[at % n] ^= x;
            }
            body.truncate(body.len() - cut % body.len().max(1));
            if let Ok(d) = DaylightCoefficients::parse(&body, 10, 2) {
                for r in 0..d.seen() {
                    prop_assert!(d.seen_patch(r) < 10);
                    for j in 0..COLUMNS {
                        let x = d.seen_lx(r, j);
                        prop_assert!(x.is_finite() && (0.0..=4.0).contains(&x));
                    }
                }
                for s in 0..2 {
                    for j in 0..COLUMNS {
                        let x = d.sensor_lx(s, j);
                        prop_assert!(x.is_finite() && (0.0..=4.0).contains(&x));
                    }
                }
            }
        }
    }

    fn f16s(v: &[f32]) -> Vec<u8> {
        v.iter()
            .flat_map(|x| half::f16::from_f32(*x).to_bits().to_le_bytes())
            .collect()
    }

    /// The parse of [`body`]`(seen, c, north)`.
    fn parse_with(seen: &[u32], c: f32, north: [f64; 2]) -> Result<(), ImageError> {
        let body = body(seen, c, north);
        let parsed = DaylightCoefficients::parse(&body, 10, 2)?;
        assert_eq!(parsed.seen(), seen.len());
        assert!((parsed.sensor_lx(1, 7) - 0.5).abs() < 1e-3);
        Ok(())
    }

    #[test]
    fn a_section_parses_and_every_corruption_is_refused() {
        assert_eq!(parse_with(&[1, 4, 9], 0.25, [0.0, 1.0]), Ok(()));
        for (seen, c, north, what) in [
            (&[1u32, 4, 4][..], 0.25, [0.0, 1.0], "not ascending"),
            (&[1, 4, 10][..], 0.25, [0.0, 1.0], "out of range"),
            (&[1][..], f32::NAN, [0.0, 1.0], "coefficient"),
            (&[1][..], -0.5, [0.0, 1.0], "coefficient"),
            (&[1][..], 9.0, [0.0, 1.0], "coefficient"),
            (&[1][..], 0.25, [0.0, 2.0], "north"),
        ] {
            match parse_with(seen, c, north) {
                Err(ImageError::Inconsistent(w)) => assert!(w.contains(what), "{w} / {what}"),
                other => panic!("{what}: {other:?}"),
            }
        }
        for (glazing, what) in [
            (&[4u32, 1][..], "not ascending"),
            (&[11][..], "out of range"),
        ] {
            let b = body_with(DAYLIGHT_VERSION, &[1, 4, 9], glazing, 0.25, [0.0, 1.0]);
            match DaylightCoefficients::parse(&b, 10, 2) {
                Err(ImageError::Inconsistent(w)) => assert!(w.contains(what), "{w} / {what}"),
                other => panic!("glazing {what}: {other:?}"),
            }
        }
        // a truncated body
        assert_eq!(
            DaylightCoefficients::parse(&[1, 2, 3], 10, 2).err(),
            Some(ImageError::Decode)
        );
    }

    #[test]
    fn version_2_names_the_seen_glazing_and_version_1_still_reads_without_it() {
        let b = body_with(DAYLIGHT_VERSION, &[1, 4, 9], &[4, 9], 0.25, [0.0, 1.0]);
        let d = DaylightCoefficients::parse(&b, 10, 2).expect("v2");
        assert!(d.is_glazing(4) && d.is_glazing(9));
        assert!(!d.is_glazing(1) && !d.is_glazing(5) && !d.is_glazing(0));
        // version 1: the same fields without the glazing string (it is not written)
        let b1 = body_with(
            DAYLIGHT_VERSION_WITHOUT_GLAZING,
            &[1, 4, 9],
            &[4],
            0.25,
            [0.0, 1.0],
        );
        assert_eq!(b.len(), b1.len() + 1 + 8, "v1 has no glazing string");
        let d1 = DaylightCoefficients::parse(&b1, 10, 2).expect("v1");
        assert_eq!(d1.seen(), 3);
        assert!(!d1.is_glazing(4));
        // a v1 body with bytes after it, or a v2 body without its glazing string
        let mut longer = b1.clone();
        longer.push(0);
        assert!(DaylightCoefficients::parse(&longer, 10, 2).is_err());
        let mut v2_short = b.clone();
        v2_short.truncate(b1.len());
        assert!(DaylightCoefficients::parse(&v2_short, 10, 2).is_err());
    }
}
