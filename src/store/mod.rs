//! The flash image: the commissioned model as the run time needs it, written once at
//! commissioning and read in place for years. `no_std`, no allocation: [`Image::parse`] borrows
//! the bytes (flash mapped in memory on a microcontroller, a buffer on Linux) and never copies
//! the big arrays.
//!
//! ```text
//! | header, 40 bytes (header.rs) | payload: postcard, format version 1 |
//! ```
//!
//! Optional sections may follow the payload, inside its length and CRC, each framed as
//! `magic (4 bytes) | version (u16 LE) | length (u32 LE) | bytes`: the geometry section
//! ([`SECTION_MAGIC`], the patches' corners, the camera, desks, luminaires: what a report needs,
//! `geometry`) and the live-light section ([`live::LIVE_MAGIC`], [`live`]). A build skips a
//! section version it does not read; bytes that are not a known section are an error, never a
//! misread; images without sections parse as before.
//!
//! The payload ([`PayloadV1`]) holds the sparse form factors, patch reflectances, direct
//! illuminance per luminaire on patches and at sensors, the sensors' first bounce and gather
//! rows, the response matrix, the ids, and a record of the commissioning settings. Big arrays are
//! little-endian byte slices decoded per element ([`values`]). The form factors and direct
//! terms take the storage precision chosen at build time ([`Precision`]).
//!
//! Parsing checks, in order: header length, magic, header CRC, format version (another
//! version is an error, never a misread), payload length, payload CRC, postcard decoding, then
//! every array's length, index and value range (illuminance and flux finite, non-negative and
//! at most [`MAX_LUX`] / [`MAX_FLUX_LM`]), with checked length arithmetic so that a crafted
//! image cannot wrap a length on a 32-bit target. After [`Image::parse`] succeeds no accessor
//! can panic and no value is non-finite or negative.

mod crc32;
pub mod daylight;
mod header;
pub mod live;
pub mod nor;
pub mod slots;
pub mod values;

#[cfg(feature = "std")]
pub mod devices;
#[cfg(feature = "std")]
pub mod encode;
#[cfg(feature = "std")]
pub mod file;
#[cfg(feature = "std")]
pub mod geometry;
#[cfg(feature = "std")]
pub mod mtd;

use serde::{Deserialize, Serialize};

pub use crc32::{Crc32, crc32};
pub use daylight::{DAYLIGHT_MAGIC, DaylightCoefficients};
pub use header::{FORMAT_VERSION, HEADER_LEN, Header, MAGIC};
pub use live::{LIVE_MAGIC, LiveV1};
pub use values::{Bytes, Precision, Sparse, Values};

use crate::solver::RadiositySystem;

/// Why an image was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ImageError {
    /// Fewer bytes than the header or the payload needs.
    #[error("image truncated: {needed} bytes needed, {available} available")]
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes present.
        available: usize,
    },
    /// All 0xFF: an erased slot.
    #[error("erased (no image)")]
    Erased,
    /// Not an image.
    #[error("not a luxnode image (bad magic)")]
    BadMagic,
    /// The header checksum fails.
    #[error("header CRC mismatch (stored {stored:#010x}, computed {actual:#010x})")]
    HeaderCrc {
        /// Stored.
        stored: u32,
        /// Computed.
        actual: u32,
    },
    /// Another format version.
    #[error("image format version {found}, this build reads version {supported}")]
    UnsupportedVersion {
        /// In the image.
        found: u16,
        /// Supported.
        supported: u16,
    },
    /// The payload checksum fails.
    #[error("payload CRC mismatch (stored {stored:#010x}, computed {actual:#010x})")]
    PayloadCrc {
        /// Stored.
        stored: u32,
        /// Computed.
        actual: u32,
    },
    /// The payload does not decode.
    #[error("payload does not decode")]
    Decode,
    /// Decoded, but the arrays do not fit together.
    #[error("inconsistent image: {0}")]
    Inconsistent(&'static str),
}

/// The commissioning settings, recorded for inspection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct SettingsRecord {
    /// Rays per patch.
    pub rays: u32,
    /// Rays per sensor.
    pub sensor_rays: u32,
    /// Final-gather rays per sensor (0: none).
    pub final_gather_rays: u32,
    /// Base patch size, mm.
    pub patch_size_mm: u32,
    /// Sensor detail ratio.
    pub detail_ratio: f32,
    /// Light-gradient ratio.
    pub light_ratio: f32,
    /// Opening points for patches.
    pub opening_samples: u16,
    /// Direct points per patch.
    pub patch_direct_points: u16,
    /// Rectified form factors.
    pub rectified: bool,
    /// Exact direct light (false: the paper's formulation).
    pub direct_exact: bool,
    /// LDC modelled.
    pub ldc: bool,
    /// LSC modelled.
    pub lsc: bool,
    /// Seed.
    pub seed: u64,
    /// Form factors below this were pruned (0: none).
    pub prune_below: f32,
}

/// Format version 1 of the payload.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PayloadV1<'a> {
    /// The scene's name.
    #[serde(borrow)]
    pub scene_name: &'a str,
    /// Commissioning settings.
    pub settings: SettingsRecord,
    /// Patches.
    pub n_patches: u32,
    /// Luminaires.
    pub n_luminaires: u16,
    /// Sensors.
    pub n_sensors: u16,
    /// Luminaire ids, u32 LE, in luminaires.json order.
    #[serde(borrow)]
    pub luminaire_ids: Bytes<'a>,
    /// Luminaire flux at 100 %, lm, f64 LE.
    #[serde(borrow)]
    pub luminaire_flux_lm: Bytes<'a>,
    /// Sensor (desk) ids, u32 LE, in sensors.json order.
    #[serde(borrow)]
    pub sensor_ids: Bytes<'a>,
    /// Per sensor, one byte of [`sensor_flags`] (out of the camera's view, estimated).
    #[serde(borrow)]
    pub sensor_flags: Bytes<'a>,
    /// Patch reflectances (f32).
    #[serde(borrow)]
    pub rho: Values<'a>,
    /// Form factors, patch × patch.
    #[serde(borrow)]
    pub ff: Sparse<'a>,
    /// Direct illuminance on patches at 100 %, lx, row = luminaire.
    #[serde(borrow)]
    pub direct_patch_lx: Values<'a>,
    /// Direct reading at sensors at 100 %, lx, f64 LE `[sensor][luminaire]`.
    #[serde(borrow)]
    pub direct_sensor_lx: Bytes<'a>,
    /// First bounce at sensors (final gather) at 100 %, lx, f64 LE `[sensor][luminaire]`.
    #[serde(borrow)]
    pub first_bounce_sensor_lx: Bytes<'a>,
    /// Gather rows apply to the exitance beyond the first bounce (final gather) or all of it.
    pub final_gather: bool,
    /// Sensor gather rows, sensor × patch.
    #[serde(borrow)]
    pub gather: Sparse<'a>,
    /// Reading per luminaire at 100 %, lx, f64 LE `[sensor][luminaire]`, computed from the
    /// stored arrays (so superposition and a re-solve of this image agree).
    #[serde(borrow)]
    pub response_lx: Bytes<'a>,
    /// Solver tolerance for re-solves.
    pub solve_tolerance: f64,
    /// Solver sweep limit.
    pub solve_max_iterations: u32,
}

/// Bits of [`PayloadV1::sensor_flags`].
pub mod sensor_flags {
    /// The sensor lies outside the camera's view at commissioning (its surroundings were
    /// modelled, not seen).
    pub const OUT_OF_VIEW: u8 = 1;
    /// Its reading rests on estimated (defaulted) reflectances or geometry.
    pub const ESTIMATED: u8 = 2;
    /// The camera sees it, and its modelled response was calibrated by the one-luminaire frames
    /// where they showed less (or more) light from some luminaires than the model: a shade the
    /// mesh lost (`crate::live::desk_scale`).
    pub const CALIBRATED: u8 = 4;
}

/// Magic of the optional geometry section after the payload ([`geometry`] with std).
pub const SECTION_MAGIC: [u8; 4] = *b"LXGS";
/// Version of the geometry section this build writes and reads.
pub const SECTION_VERSION: u16 = 1;
/// Frame length before the section's bytes: magic, version (u16 LE), length (u32 LE).
pub const SECTION_FRAME_LEN: usize = 10;

/// The sections found after the version-1 payload (their bodies, unframed).
#[derive(Debug, Clone, Copy, Default)]
struct Found<'a> {
    geometry: Option<&'a [u8]>,
    live: Option<&'a [u8]>,
    live_version: u16,
    daylight: Option<&'a [u8]>,
}

/// The sections of what follows the version-1 payload, checked: none for no bytes; each frame
/// must be whole and of a known kind (an error for bytes that are not a section, or a frame
/// longer than what is left); a version this build does not read is skipped; a section twice is
/// an error.
fn unframe(mut rest: &[u8]) -> Result<Found<'_>, ImageError> {
    let mut found = Found::default();
    while !rest.is_empty() {
        if rest.len() < SECTION_FRAME_LEN {
            return Err(ImageError::Inconsistent("bytes after the payload"));
        }
        let magic = [rest[0], rest[1], rest[2], rest[3]];
        let version = u16::from_le_bytes([rest[4], rest[5]]);
        let len = u32::from_le_bytes([rest[6], rest[7], rest[8], rest[9]]) as usize;
        if rest.len() - SECTION_FRAME_LEN < len {
            return Err(ImageError::Inconsistent("section length"));
        }
        let body = &rest[SECTION_FRAME_LEN..SECTION_FRAME_LEN + len];
        rest = &rest[SECTION_FRAME_LEN + len..];
        let slot = match magic {
            SECTION_MAGIC if version == SECTION_VERSION => &mut found.geometry,
            live::LIVE_MAGIC
                if (live::LIVE_VERSION_WITHOUT_PARTS..=live::LIVE_VERSION).contains(&version) =>
            {
                found.live_version = version;
                &mut found.live
            }
            daylight::DAYLIGHT_MAGIC
                if (daylight::DAYLIGHT_VERSION_WITHOUT_GLAZING..=daylight::DAYLIGHT_VERSION)
                    .contains(&version) =>
            {
                &mut found.daylight
            }
            // a known section at a version this build does not read
            SECTION_MAGIC | live::LIVE_MAGIC | daylight::DAYLIGHT_MAGIC => continue,
            _ => return Err(ImageError::Inconsistent("bytes after the payload")),
        };
        check(slot.is_none(), "a section twice")?;
        *slot = Some(body);
    }
    Ok(found)
}

/// Frames a section body: `magic | version | length | body`.
#[cfg(feature = "std")]
pub fn frame_section(magic: [u8; 4], version: u16, body: &[u8]) -> Option<std::vec::Vec<u8>> {
    let len = u32::try_from(body.len()).ok()?;
    let mut out = std::vec::Vec::with_capacity(SECTION_FRAME_LEN + body.len());
    out.extend_from_slice(&magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(body);
    Some(out)
}

/// A parsed, fully checked image borrowing its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Image<'a> {
    /// The header.
    pub header: Header,
    /// The payload.
    pub payload: PayloadV1<'a>,
    /// The geometry section's bytes, when the image has one this build reads.
    geometry: Option<&'a [u8]>,
    /// The live-light section, when the image has one ([`live`]).
    pub live: Option<LiveV1<'a>>,
    /// The daylight coefficients through the room plan's unseen windows ([`daylight`]).
    pub daylight: Option<DaylightCoefficients<'a>>,
}

fn check(ok: bool, what: &'static str) -> Result<(), ImageError> {
    if ok {
        Ok(())
    } else {
        Err(ImageError::Inconsistent(what))
    }
}

/// The largest illuminance an image may hold, lx (direct sunlight is about 1e5 lx; a desk
/// reading above this is a corrupt or crafted image, never a room).
pub const MAX_LUX: f64 = 1.0e6;
/// The largest luminaire flux an image may hold, lm.
pub const MAX_FLUX_LM: f64 = 1.0e7;

/// `a * b` or an inconsistency (lengths from a crafted image must not wrap on 32-bit targets).
fn mul(a: usize, b: usize, what: &'static str) -> Result<usize, ImageError> {
    a.checked_mul(b).ok_or(ImageError::Inconsistent(what))
}

pub(crate) fn check_values(
    v: &Values<'_>,
    rows: usize,
    len: usize,
    what: &'static str,
) -> Result<(), ImageError> {
    let p = Precision::from_code(v.precision).ok_or(ImageError::Inconsistent(what))?;
    check(v.data.count(p.width()) == Some(len), what)?;
    if p.scaled() {
        check(v.scales.count(4) == Some(rows), what)?;
        for r in 0..rows {
            let s = v.scales.f32_at(r);
            check(s.is_finite() && s >= 0.0, what)?;
        }
    } else {
        check(v.scales.0.is_empty(), what)?;
        for i in 0..len {
            let x = v.get(i, 0);
            check(x.is_finite() && x >= 0.0, what)?;
        }
    }
    Ok(())
}

fn check_sparse(
    s: &Sparse<'_>,
    rows: usize,
    cols: usize,
    what: &'static str,
) -> Result<(), ImageError> {
    check(s.rows as usize == rows, what)?;
    let ptrs = rows.checked_add(1).ok_or(ImageError::Inconsistent(what))?;
    check(s.row_ptr.count(4) == Some(ptrs), what)?;
    check(s.col_width == 2 || s.col_width == 4, what)?;
    check(s.row_ptr.u32_at(0) == 0, what)?;
    for i in 0..rows {
        check(s.row_ptr.u32_at(i) <= s.row_ptr.u32_at(i + 1), what)?;
    }
    let nnz = s.row_ptr.u32_at(rows) as usize;
    check(s.col.count(usize::from(s.col_width)) == Some(nnz), what)?;
    for k in 0..nnz {
        check(s.col_at(k) < cols, what)?;
    }
    check_values(&s.values, rows, nnz, what)
}

/// `len` f64 values, each finite and within `[0, max]` (illuminance and flux are never
/// negative: a crafted image must not publish −8000 lx or +inf with quality OK).
fn check_f64s(b: &Bytes<'_>, len: usize, max: f64, what: &'static str) -> Result<(), ImageError> {
    check(b.count(8) == Some(len), what)?;
    for i in 0..len {
        let x = b.f64_at(i);
        check(x.is_finite() && (0.0..=max).contains(&x), what)?;
    }
    Ok(())
}

impl<'a> Image<'a> {
    /// Parses and checks an image (header, CRCs, version, every array).
    pub fn parse(bytes: &'a [u8]) -> Result<Self, ImageError> {
        let header = Header::parse(bytes)?;
        let end = usize::try_from(header.payload_len)
            .ok()
            .and_then(|len| HEADER_LEN.checked_add(len))
            .ok_or(ImageError::Inconsistent("payload length"))?;
        if bytes.len() < end {
            return Err(ImageError::Truncated {
                needed: end,
                available: bytes.len(),
            });
        }
        let payload_bytes = &bytes[HEADER_LEN..end];
        let actual = crc32(payload_bytes);
        if actual != header.payload_crc32 {
            return Err(ImageError::PayloadCrc {
                stored: header.payload_crc32,
                actual,
            });
        }
        let (payload, rest): (PayloadV1<'a>, &'a [u8]) =
            postcard::take_from_bytes(payload_bytes).map_err(|_| ImageError::Decode)?;
        let found = unframe(rest)?;
        let mut image = Self {
            header,
            payload,
            geometry: found.geometry,
            live: None,
            daylight: None,
        };
        image.validate()?;
        if let Some(body) = found.live {
            image.live = Some(LiveV1::parse(
                found.live_version,
                body,
                image.patches(),
                image.luminaires(),
                image.sensors(),
            )?);
        }
        if let Some(body) = found.daylight {
            image.daylight = Some(DaylightCoefficients::parse(
                body,
                image.patches(),
                image.sensors(),
            )?);
        }
        Ok(image)
    }

    fn validate(&self) -> Result<(), ImageError> {
        let p = &self.payload;
        let (n, l, s) = (
            p.n_patches as usize,
            usize::from(p.n_luminaires),
            usize::from(p.n_sensors),
        );
        check(n > 0, "no patches")?;
        check(p.luminaire_ids.count(4) == Some(l), "luminaire ids")?;
        check(p.sensor_ids.count(4) == Some(s), "sensor ids")?;
        check(p.sensor_flags.count(1) == Some(s), "sensor flags")?;
        check_f64s(&p.luminaire_flux_lm, l, MAX_FLUX_LM, "luminaire flux")?;
        check(
            p.rho.precision == Precision::F32 as u8,
            "reflectance precision",
        )?;
        check_values(&p.rho, 0, n, "reflectances")?;
        for i in 0..n {
            check(p.rho.get(i, 0) < 1.0, "a reflectance is 1 or more")?;
        }
        check_sparse(&p.ff, n, n, "form factors")?;
        check_values(
            &p.direct_patch_lx,
            l,
            mul(l, n, "direct illuminance on patches")?,
            "direct illuminance on patches",
        )?;
        let sl = mul(s, l, "sensors × luminaires")?;
        check_f64s(
            &p.direct_sensor_lx,
            sl,
            MAX_LUX,
            "direct illuminance at sensors",
        )?;
        check_f64s(
            &p.first_bounce_sensor_lx,
            sl,
            MAX_LUX,
            "first bounce at sensors",
        )?;
        check_f64s(&p.response_lx, sl, MAX_LUX, "response matrix")?;
        // every dimming state sums the responses of all luminaires: the sum must stay in range
        for si in 0..s {
            let total: f64 = (0..l).map(|li| p.response_lx.f64_at(si * l + li)).sum();
            check(
                total <= MAX_LUX,
                "a desk's response at full output exceeds 1e6 lx",
            )?;
        }
        check_sparse(&p.gather, s, n, "gather rows")?;
        check(
            p.solve_tolerance.is_finite() && p.solve_tolerance > 0.0 && p.solve_max_iterations > 0,
            "solver settings",
        )?;
        check(
            self.header.precision == p.ff.values.precision,
            "header precision differs from the payload's",
        )?;
        Ok(())
    }

    /// Total length in bytes (header + payload).
    pub fn len(&self) -> usize {
        HEADER_LEN + self.header.payload_len as usize
    }

    /// Never empty once parsed (a header is always there).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The geometry section's bytes (decoded by [`geometry::GeometrySection::decode`] with
    /// std), when the image has one.
    pub fn geometry_bytes(&self) -> Option<&'a [u8]> {
        self.geometry
    }

    /// Patches.
    pub fn patches(&self) -> usize {
        self.payload.n_patches as usize
    }

    /// Luminaires.
    pub fn luminaires(&self) -> usize {
        usize::from(self.payload.n_luminaires)
    }

    /// Sensors.
    pub fn sensors(&self) -> usize {
        usize::from(self.payload.n_sensors)
    }

    /// Luminaire id `j`.
    pub fn luminaire_id(&self, j: usize) -> u32 {
        self.payload.luminaire_ids.u32_at(j)
    }

    /// Sensor id `k`.
    pub fn sensor_id(&self, k: usize) -> u32 {
        self.payload.sensor_ids.u32_at(k)
    }

    /// Flags of sensor `k` ([`sensor_flags`]).
    pub fn sensor_flags(&self, k: usize) -> u8 {
        self.payload.sensor_flags.0[k]
    }

    /// Sensor `k`'s stated relative uncertainty of its modelled light, from what commissioning
    /// inferred (the live section's; `None` without one, or not stated: a CAD model).
    pub fn model_rel_uncertainty(&self, k: usize) -> Option<f64> {
        self.live.as_ref().and_then(|l| l.model_rel_uncertainty(k))
    }

    /// Response of sensor `s` to luminaire `l` at 100 %, lx.
    pub fn response_lx(&self, s: usize, l: usize) -> f64 {
        self.payload.response_lx.f64_at(s * self.luminaires() + l)
    }

    /// The responses of these sensors, row-major `[row][luminaire]`, lx (the control's
    /// `Plant::response_lx` over those desks).
    #[cfg(feature = "std")]
    pub fn response_rows_lx(&self, sensors: impl IntoIterator<Item = usize>) -> std::vec::Vec<f64> {
        let l = self.luminaires();
        sensors
            .into_iter()
            .flat_map(|s| (0..l).map(move |j| self.response_lx(s, j)))
            .collect()
    }

    /// The radiosity system of this image, for the solver.
    pub fn system(&self) -> ImageSystem<'_, 'a> {
        ImageSystem { image: self }
    }
}

/// The stored form factors and reflectances as a [`RadiositySystem`].
#[derive(Debug, Clone, Copy)]
pub struct ImageSystem<'i, 'a> {
    image: &'i Image<'a>,
}

impl RadiositySystem for ImageSystem<'_, '_> {
    fn len(&self) -> usize {
        self.image.patches()
    }
    fn rho(&self, i: usize) -> f64 {
        self.image.payload.rho.get(i, 0)
    }
    fn gather(&self, i: usize, x: &[f64]) -> f64 {
        self.image.payload.ff.row_dot(i, x)
    }
    fn gather_k(&self, i: usize, x: &[f64], acc: &mut [f64]) {
        self.image.payload.ff.row_dot_k(i, x, acc)
    }
    fn gather_column(&self, i: usize, x: &[f64], k: usize, q: usize) -> f64 {
        self.image.payload.ff.row_dot_column(i, x, k, q)
    }
}
