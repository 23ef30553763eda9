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
//!
//! From version 3, the sun's direct beam the same way, per position k of a [`SunGrid`] (the
//! site's suns over a year), lx per lx of the sun's direct normal illuminance `E_dn`:
//! `sun_sensor_lx[k][s]` dense (0 where the sun is below the horizon), and at the seen patches
//! only where the beam falls (at least [`SUN_SEEN_MIN`]): per position, a u16 count and that
//! many (seen row u16, f16) pairs, rows ascending. The run time uses the seen coefficients to
//! find the patches in the beam and fit the sun's strength; a room's sun patches cover a few of
//! its seen patches at any one position, so the sparse form is a fifth of the dense one.

use serde::{Deserialize, Serialize};

use super::values::f16_bits_to_f64;
use super::{Bytes, ImageError, check};
use crate::sky::SunGrid;

/// Magic of the daylight-coefficient section.
pub const DAYLIGHT_MAGIC: [u8; 4] = *b"LXDC";
/// Version of the section this build writes (3: with the sun's grid).
pub const DAYLIGHT_VERSION: u16 = 3;
/// The second version: the seen glazing patches, no sun (still read: the sky alone).
pub const DAYLIGHT_VERSION_WITHOUT_SUN: u16 = 2;
/// The first version, without [`DaylightCoefficients::glazing_seen`] (still read: no seen
/// window then).
pub const DAYLIGHT_VERSION_WITHOUT_GLAZING: u16 = 1;
/// Columns: the 145 Tregenza patches and the ground.
pub const COLUMNS: usize = 146;
/// The least sun coefficient stored at a seen patch (lx per lx of direct normal illuminance):
/// the beam through clear glass at 85° incidence; below it, interreflections only.
pub const SUN_SEEN_MIN: f32 = 0.05;
/// Largest coefficient accepted, lx per cd/m² (a receiver at a window sees at most π sr of
/// sky: π).
pub const MAX_COEFFICIENT: f32 = 4.0;

/// The daylight-coefficient section (version [`DAYLIGHT_VERSION`]; the body is these fields in
/// postcard, then, from version 2, [`Self::glazing_seen`] as one more postcard byte string,
/// then, from version 3, [`Self::sun_grid`], [`Self::sun_seen_lx`] and
/// [`Self::sun_sensor_lx`] in postcard).
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
    /// The sun's positions (version 3; `None` before).
    #[serde(skip)]
    pub sun_grid: Option<SunGrid>,
    /// Per position: a u16 LE count, then (seen row u16 LE, f16 LE) pairs with ascending rows,
    /// lx per lx of direct normal illuminance (version 3; see the module's documentation).
    #[serde(skip)]
    pub sun_seen_lx: Bytes<'a>,
    /// `[position][sensor]` f16 LE, lx per lx of direct normal illuminance (version 3).
    #[serde(skip)]
    pub sun_sensor_lx: Bytes<'a>,
}

/// The version-3 tail, in postcard.
#[derive(Serialize, Deserialize)]
struct SunTail<'a> {
    grid: SunGrid,
    #[serde(borrow)]
    seen_lx: Bytes<'a>,
    #[serde(borrow)]
    sensor_lx: Bytes<'a>,
}

impl<'a> DaylightCoefficients<'a> {
    /// Decodes and checks a section body against an image of `patches` patches and `sensors`
    /// sensors.
    pub fn parse(body: &'a [u8], patches: usize, sensors: usize) -> Result<Self, ImageError> {
        let (mut d, rest): (DaylightCoefficients<'a>, &'a [u8]) =
            postcard::take_from_bytes(body).map_err(|_| ImageError::Decode)?;
        let rest = if d.version >= DAYLIGHT_VERSION_WITHOUT_SUN {
            let (g, rest): (Bytes<'a>, &'a [u8]) =
                postcard::take_from_bytes(rest).map_err(|_| ImageError::Decode)?;
            d.glazing_seen = g;
            rest
        } else {
            rest
        };
        let rest = if d.version >= DAYLIGHT_VERSION {
            let (t, rest): (SunTail<'a>, &'a [u8]) =
                postcard::take_from_bytes(rest).map_err(|_| ImageError::Decode)?;
            d.sun_grid = Some(t.grid);
            d.sun_seen_lx = t.seen_lx;
            d.sun_sensor_lx = t.sensor_lx;
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
        if self.version >= DAYLIGHT_VERSION_WITHOUT_SUN {
            out.extend(postcard::to_stdvec(&self.glazing_seen)?);
        }
        if self.version >= DAYLIGHT_VERSION {
            let grid = self.sun_grid.ok_or(postcard::Error::SerializeBufferFull)?;
            out.extend(postcard::to_stdvec(&SunTail {
                grid,
                seen_lx: self.sun_seen_lx,
                sensor_lx: self.sun_sensor_lx,
            })?);
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
        coefficients_ok(
            &self.seen_lx,
            n.checked_mul(COLUMNS),
            "daylight coefficients",
        )?;
        coefficients_ok(
            &self.sensor_lx,
            sensors.checked_mul(COLUMNS),
            "daylight coefficients",
        )?;
        ascending_patches(
            &self.glazing_seen,
            patches,
            [
                "daylight glazing",
                "daylight glazing patch out of range",
                "daylight glazing patches not ascending",
            ],
        )?;
        if let Some(g) = &self.sun_grid {
            check(g.is_valid(), "daylight sun grid")?;
            let p = g.positions();
            sparse_ok(&self.sun_seen_lx, p, n)?;
            coefficients_ok(
                &self.sun_sensor_lx,
                p.checked_mul(sensors),
                "daylight sun coefficients",
            )?;
        }
        Ok(())
    }

    /// The sun's grid, when the section has one (version 3).
    pub fn sun_grid(&self) -> Option<SunGrid> {
        self.sun_grid
    }

    /// Every stored sun coefficient at the seen patches: `f(position, seen row, lx per lx)`.
    pub fn for_each_sun_seen(&self, mut f: impl FnMut(usize, usize, f64)) {
        let b = &self.sun_seen_lx.0;
        let word = |i: usize| {
            b.get(2 * i..2 * i + 2)
                .map(|w| u16::from_le_bytes([w[0], w[1]]))
        };
        let (mut at, mut k) = (0usize, 0usize);
        while let Some(count) = word(at) {
            for e in 0..usize::from(count) {
                let (Some(r), Some(x)) = (word(at + 1 + 2 * e), word(at + 2 + 2 * e)) else {
                    return;
                };
                f(k, usize::from(r), f16_bits_to_f64(x));
            }
            at += 1 + 2 * usize::from(count);
            k += 1;
        }
    }

    /// The sun's coefficient at sensor s for grid position k, with `sensors` sensors.
    pub fn sun_sensor_lx(&self, k: usize, s: usize, sensors: usize) -> f64 {
        f16_bits_to_f64(self.sun_sensor_lx.u16_at(k * sensors + s))
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

/// Checks the sparse seen sun coefficients: `positions` runs of a count and (row, f16) pairs,
/// rows ascending below `rows`, values in range, nothing after.
fn sparse_ok(b: &Bytes<'_>, positions: usize, rows: usize) -> Result<(), ImageError> {
    const WHAT: &str = "daylight sun coefficients at the seen patches";
    let words = b.count(2).ok_or(ImageError::Inconsistent(WHAT))?;
    let mut at = 0usize;
    for _ in 0..positions {
        check(at < words, WHAT)?;
        let count = usize::from(b.u16_at(at));
        check(at + 1 + 2 * count <= words, WHAT)?;
        let mut last: Option<u16> = None;
        for e in 0..count {
            let r = b.u16_at(at + 1 + 2 * e);
            let x = f16_bits_to_f64(b.u16_at(at + 2 + 2 * e));
            check(usize::from(r) < rows && last.is_none_or(|l| l < r), WHAT)?;
            check(
                x.is_finite() && (0.0..=f64::from(MAX_COEFFICIENT)).contains(&x),
                "daylight coefficient out of range",
            )?;
            last = Some(r);
        }
        at += 1 + 2 * count;
    }
    check(at == words, WHAT)
}

/// Checks `want` f16 coefficients, each finite in `0..=MAX_COEFFICIENT`.
fn coefficients_ok(
    b: &Bytes<'_>,
    want: Option<usize>,
    what: &'static str,
) -> Result<(), ImageError> {
    let n = want.filter(|w| b.count(2) == Some(*w));
    let n = n.ok_or(ImageError::Inconsistent(what))?;
    for k in 0..n {
        let x = f16_bits_to_f64(b.u16_at(k));
        check(
            x.is_finite() && (0.0..=f64::from(MAX_COEFFICIENT)).contains(&x),
            "daylight coefficient out of range",
        )?;
    }
    Ok(())
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
        let grid = SunGrid {
            declination0_rad: -0.4,
            declination_step_rad: 0.4,
            declinations: 3,
            hour0_rad: -0.5,
            hour_step_rad: 0.5,
            hours: 3,
        };
        // every position: one entry, at the last seen row
        let sun_seen: Vec<u8> = (0..9)
            .flat_map(|_| {
                [
                    1u16,
                    seen.len() as u16 - 1,
                    half::f16::from_f32(0.3).to_bits(),
                ]
                .into_iter()
                .flat_map(u16::to_le_bytes)
            })
            .collect();
        let sun_sensor = f16s(&std::vec![0.6; 9 * 2]);
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
            sun_grid: (version >= DAYLIGHT_VERSION).then_some(grid),
            sun_seen_lx: Bytes(&sun_seen),
            sun_sensor_lx: Bytes(&sun_sensor),
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
                // the sun's: every stored entry in range, at a position and row that exist
                let mut sun = Vec::new();
                d.for_each_sun_seen(|k, r, x| sun.push((k, r, x)));
                if let Some(g) = d.sun_grid() {
                    for (k, r, x) in sun {
                        prop_assert!(k < g.positions() && r < d.seen());
                        prop_assert!(x.is_finite() && (0.0..=4.0).contains(&x));
                    }
                    for k in 0..g.positions() {
                        let x = d.sun_sensor_lx(k, 1, 2);
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
    fn version_3_holds_the_suns_grid_and_version_2_still_reads_without_it() {
        let b = body_with(DAYLIGHT_VERSION, &[1, 4, 9], &[4, 9], 0.25, [0.0, 1.0]);
        let d = DaylightCoefficients::parse(&b, 10, 2).expect("v3");
        let g = d.sun_grid().expect("grid");
        assert_eq!(g.positions(), 9);
        let mut entries = Vec::new();
        d.for_each_sun_seen(|k, r, x| entries.push((k, r, x)));
        assert_eq!(entries.len(), 9);
        assert!(
            entries
                .iter()
                .enumerate()
                .all(|(i, (k, r, x))| *k == i && *r == 2 && (x - 0.3).abs() < 1e-3)
        );
        assert!((d.sun_sensor_lx(8, 1, 2) - 0.6).abs() < 1e-3);
        assert!(d.is_glazing(4));
        let b2 = body_with(
            DAYLIGHT_VERSION_WITHOUT_SUN,
            &[1, 4, 9],
            &[4, 9],
            0.25,
            [0.0, 1.0],
        );
        let d2 = DaylightCoefficients::parse(&b2, 10, 2).expect("v2");
        assert!(d2.sun_grid().is_none() && d2.is_glazing(9));
        // a seen row out of range in the last position's entry (before the sensors' 36 bytes
        // and their length)
        let mut bad_row = b.clone();
        let at = b.len() - 37 - 4;
        bad_row[at..at + 2].copy_from_slice(&3u16.to_le_bytes());
        assert!(DaylightCoefficients::parse(&bad_row, 10, 2).is_err());
        // a v3 body cut inside its sun coefficients, and a grid of a NaN step
        assert!(DaylightCoefficients::parse(&b[..b.len() - 2], 10, 2).is_err());
        let at = b2.len() + 8; // inside the grid's first f64s
        let mut bad = b.clone();
        bad[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(DaylightCoefficients::parse(&bad, 10, 2).is_err());
    }

    #[test]
    fn version_2_names_the_seen_glazing_and_version_1_still_reads_without_it() {
        let b = body_with(
            DAYLIGHT_VERSION_WITHOUT_SUN,
            &[1, 4, 9],
            &[4, 9],
            0.25,
            [0.0, 1.0],
        );
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
