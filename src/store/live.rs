//! The live-light section of an image: what the node needs at run time to turn a camera frame
//! into measured desk lux (`crate::live`), written at commissioning. `no_std`, borrowed in place
//! like the rest of the image.
//!
//! ## Framing
//!
//! The section follows the payload like the geometry section, framed as
//! `"LXLV" | version (u16 LE) | length (u32 LE) | postcard body` ([`LIVE_MAGIC`],
//! [`LIVE_VERSION`]; [`super`] reads the frames). An image without it (every image written
//! before live light) parses exactly as before; a build skips a live version it does not read. The
//! header's payload length and CRC cover the sections, so a damaged section fails the payload CRC
//! like any other byte.
//!
//! ## The live section ([`LiveV1`])
//!
//! Per *sample* (a camera pixel that sees a modelled surface of reflectance ≥ 0.02, on a grid of
//! every `stride`-th pixel plus every pixel around an in-view desk sensor):
//!
//! | field | per sample | what |
//! |---|---|---|
//! | `sample_pixel` | u32 | `v · width + u` |
//! | `sample_patch` | u32 | the patch it sees (its reflectance is the image's `rho`) |
//! | `sample_depth_mm` | u16 | the commissioned depth along the optical axis, mm (0: unknown) |
//! | `artificial_lx` | one value per luminaire | irradiance on the surface there from luminaire l at 100 %, lx |
//!
//! `artificial_lx` comes from the one-luminaire frames of the capture, daylight subtracted
//! (`source` = [`live_source::CAPTURE`]: `E = π g (L_l − L_off) / ρ`), or from the engine on a CAD
//! model (`source` = [`live_source::MODEL`]: exact direct light at the pixel's point plus the
//! patch's interreflected light). Rows are luminaires, stored as u16 fractions of a per-row scale
//! (0.0015 % of the row's largest value).
//!
//! Per desk sensor: its *window* (the samples on the desk top within a few centimetres of it, with
//! their offsets from it in the plane, mm) and its camera-calibrated response per luminaire at
//! 100 % (`sensor_response_lx`: the artificial irradiance at the sensor's point from the window's
//! samples; 0 for a sensor the camera does not see), and the stated relative uncertainty of its
//! modelled light from what commissioning inferred (`sensor_model_uncertainty`, 0.01 %;
//! `crate::commission::uncertainty`; [`NOT_STATED`] for a CAD model) with, from version 3, its
//! parts per luminaire at 100 % (`sensor_uncertainty_parts_lx`, f32, six reflectance classes and an
//! unseen occluder: 28 bytes per sensor and luminaire), from which any dimming state's uncertainty
//! follows (the run-time kernel's `state_rel_uncertainty`), and, from version 4, which of a
//! sensor's luminaires one unseen object shades together (`sensor_occluder_group`, one byte per
//! sensor and luminaire: 0 alone, 1 to [`OCCLUDER_GROUPS`] the luminaires one monitor at a
//! back edge of the desk could shade together). Per patch: the group it belongs to as a
//! candidate *unknown emitter* (daylight through a window, any unmodelled light: walls, floor
//! and other surfaces the camera does not see, grouped by plane and position), or
//! [`NO_EMITTER`].
//!
//! Size: about 10 + 2 L bytes per sample (L luminaires): 0.35 MB for office_a's 8 luminaires at
//! every second pixel of 320 × 240 (`image_build` picks the stride to stay within a budget).

use serde::{Deserialize, Serialize};

use super::values::{Bytes, Precision, Values};
use super::{ImageError, check, check_values};

/// The largest magnitude of a stored uncertainty part, lx (the image's [`super::MAX_LUX`]).
const MAX_LUX_F32: f32 = super::MAX_LUX as f32;
/// Parts of a desk's modelled-light uncertainty per luminaire at 100 % in
/// `sensor_uncertainty_parts_lx`: six independent reflectance classes
/// (`crate::commission::uncertainty::Inferred`), then what an unseen object could shade of that
/// luminaire's direct light.
pub const UNCERTAINTY_PARTS: usize = 7;
/// Occluder groups of a sensor's luminaires in `sensor_occluder_group`: 0, an unseen object
/// shades that luminaire alone; `1..=OCCLUDER_GROUPS`, one object at a back edge of the desk
/// shades every luminaire of the group together (their parts add).
pub const OCCLUDER_GROUPS: u8 = 32;
/// A sensor's stated uncertainty that is not stated.
pub const NOT_STATED: u16 = u16::MAX;
/// The largest stated uncertainty, 0.01 % units (100 %).
pub const MAX_UNCERTAINTY_HUNDREDTHS: u16 = 10_000;

/// Magic of the live-light section's frame.
pub const LIVE_MAGIC: [u8; 4] = *b"LXLV";
/// The largest camera side a live section may give, pixels (the frames the node allocates).
pub const MAX_SIDE_PX: u16 = 4096;
/// Version of the live section's layout.
pub const LIVE_VERSION: u16 = 4;
/// The live section with the uncertainty's parts per luminaire but not their occluder groups
/// (read with every luminaire alone).
pub const LIVE_VERSION_WITHOUT_GROUPS: u16 = 3;
/// The oldest live section this build reads: version 2, without the uncertainty's parts per
/// luminaire (its sensors' model uncertainty is then stated at every luminaire on).
pub const LIVE_VERSION_WITHOUT_PARTS: u16 = 2;
/// `patch_emitter` value of a patch that is not a candidate emitter.
pub const NO_EMITTER: u8 = 0xFF;
/// Most candidate emitter groups.
pub const MAX_EMITTERS: usize = 254;

/// Where the per-sample artificial irradiance came from.
pub mod live_source {
    /// The engine on a CAD model (exact direct light at the pixel's point, interreflected light
    /// of its patch).
    pub const MODEL: u8 = 0;
    /// The commissioning capture's one-luminaire frames, the all-off frame subtracted.
    pub const CAPTURE: u8 = 1;
}

/// The camera the samples belong to (the ToF grid every frame is registered to) and the gain of
/// its luminance frames at commissioning.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraRecord {
    /// Width, pixels.
    pub width: u16,
    /// Height, pixels.
    pub height: u16,
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
    /// Optical centre, m.
    pub position_m: [f64; 3],
    /// The camera's x, y, z axes in world coordinates, one after the other.
    pub world_from_camera: [f64; 9],
    /// Luminance per frame unit at commissioning, cd/m² (0: not known, a CAD image).
    pub cd_m2_per_unit: f64,
    /// A fisheye's Kannala-Brandt coefficients k1..k4 (`None`: a pinhole).
    pub lens_k: Option<[f64; 4]>,
}

/// The live section (version [`LIVE_VERSION`]; version 1 lacked
/// `sensor_model_uncertainty` and is skipped; version 2 lacks `sensor_uncertainty_parts_lx` and
/// is read without it; version 3 lacks `sensor_occluder_group` and is read without it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LiveV1<'a> {
    /// [`LIVE_VERSION`].
    pub version: u16,
    /// The camera.
    pub camera: CameraRecord,
    /// [`live_source`].
    pub source: u8,
    /// Grid stride of the samples, pixels.
    pub stride: u16,
    /// Samples.
    pub n_samples: u32,
    /// Pixel index per sample, u32 LE.
    #[serde(borrow)]
    pub sample_pixel: Bytes<'a>,
    /// Patch per sample, u32 LE.
    #[serde(borrow)]
    pub sample_patch: Bytes<'a>,
    /// Commissioned depth per sample along the optical axis, mm, u16 LE (0: unknown).
    #[serde(borrow)]
    pub sample_depth_mm: Bytes<'a>,
    /// Artificial irradiance at 100 % per luminaire (row) and sample, lx.
    #[serde(borrow)]
    pub artificial_lx: Values<'a>,
    /// Window of sensor s: entries `window_ptr[s]..window_ptr[s + 1]`, u32 LE, S + 1 values.
    #[serde(borrow)]
    pub window_ptr: Bytes<'a>,
    /// Sample index per window entry, u32 LE.
    #[serde(borrow)]
    pub window_sample: Bytes<'a>,
    /// Offset of each window entry's surface point from its sensor in the desk plane, mm,
    /// two i16 LE (along the world x and y axes).
    #[serde(borrow)]
    pub window_offset_mm: Bytes<'a>,
    /// Camera-calibrated response of each sensor per luminaire at 100 %, lx, f64 LE
    /// `[sensor][luminaire]` (0 for a sensor without a window).
    #[serde(borrow)]
    pub sensor_response_lx: Bytes<'a>,
    /// Stated relative standard uncertainty of each sensor's modelled artificial light from
    /// what commissioning inferred, 0.01 % units, u16 LE, one per sensor
    /// ([`NOT_STATED`]: none, e.g. a CAD model).
    #[serde(borrow)]
    pub sensor_model_uncertainty: Bytes<'a>,
    /// Candidate emitter group per patch (u8, [`NO_EMITTER`] for none).
    #[serde(borrow)]
    pub patch_emitter: Bytes<'a>,
    /// Number of emitter groups.
    pub n_emitters: u16,
    /// The parts of each sensor's modelled-light uncertainty per luminaire at 100 %, lx, f32 LE
    /// `[sensor][luminaire][part]` with [`UNCERTAINTY_PARTS`] parts (six
    /// reflectance classes, then an unseen occluder): the uncertainty of any dimming state
    /// (the run-time kernel's `state_uncertainty_lx`). Empty: not stated (a CAD model, or a
    /// version-2 section). Version 3 appends it to the body as one more postcard byte string
    /// after the fields above (so a version-2 body is a version-3 body without it).
    #[serde(skip)]
    pub sensor_uncertainty_parts_lx: Bytes<'a>,
    /// Each sensor's occluder group per luminaire, u8 `[sensor][luminaire]` (0 to
    /// [`OCCLUDER_GROUPS`]). Empty: every luminaire alone (a version-3 section, a CAD model).
    /// Version 4 appends it after the parts as one more postcard byte string.
    #[serde(skip)]
    pub sensor_occluder_group: Bytes<'a>,
}

impl<'a> LiveV1<'a> {
    /// Decodes and checks a live section body against an image of `patches` patches,
    /// `luminaires` luminaires and `sensors` sensors.
    pub fn parse(
        version: u16,
        body: &'a [u8],
        patches: usize,
        luminaires: usize,
        sensors: usize,
    ) -> Result<Self, ImageError> {
        let (mut live, rest): (LiveV1<'a>, _) =
            postcard::take_from_bytes(body).map_err(|_| ImageError::Decode)?;
        // the byte strings later versions append, in order
        let mut rest = rest;
        for (since, field) in [
            (
                LIVE_VERSION_WITHOUT_GROUPS,
                &mut live.sensor_uncertainty_parts_lx,
            ),
            (LIVE_VERSION, &mut live.sensor_occluder_group),
        ] {
            if version >= since {
                let (bytes, r): (Bytes<'a>, _) =
                    postcard::take_from_bytes(rest).map_err(|_| ImageError::Decode)?;
                *field = bytes;
                rest = r;
            }
        }
        check(rest.is_empty(), "bytes after the live section")?;
        check(live.version == version, "live section version")?;
        live.validate(patches, luminaires, sensors)?;
        Ok(live)
    }

    fn validate(&self, patches: usize, l: usize, s: usize) -> Result<(), ImageError> {
        check(
            (LIVE_VERSION_WITHOUT_PARTS..=LIVE_VERSION).contains(&self.version),
            "live section version",
        )?;
        let c = &self.camera;
        let finite = [c.fx, c.fy, c.cx, c.cy, c.cd_m2_per_unit]
            .iter()
            .chain(&c.position_m)
            .chain(&c.world_from_camera)
            .all(|x| x.is_finite());
        check(
            finite
                && (1..=MAX_SIDE_PX).contains(&c.width)
                && (1..=MAX_SIDE_PX).contains(&c.height)
                && c.fx > 0.0
                && c.fy > 0.0,
            "live camera",
        )?;
        check(c.cd_m2_per_unit >= 0.0, "live camera gain")?;
        check(
            self.source == live_source::MODEL || self.source == live_source::CAPTURE,
            "live source",
        )?;
        let n = self.n_samples as usize;
        let pixels = usize::from(c.width) * usize::from(c.height);
        check(self.sample_pixel.count(4) == Some(n), "live sample pixels")?;
        check(self.sample_patch.count(4) == Some(n), "live sample patches")?;
        check(
            self.sample_depth_mm.count(2) == Some(n),
            "live sample depth",
        )?;
        for i in 0..n {
            check(
                (self.sample_pixel.u32_at(i) as usize) < pixels,
                "live sample pixel outside the frame",
            )?;
            check(
                (self.sample_patch.u32_at(i) as usize) < patches,
                "live sample patch out of range",
            )?;
        }
        check(
            Precision::from_code(self.artificial_lx.precision).is_some(),
            "live artificial precision",
        )?;
        check_values(&self.artificial_lx, l, l * n, "live artificial irradiance")?;
        check(self.window_ptr.count(4) == Some(s + 1), "live windows")?;
        check(self.window_ptr.u32_at(0) == 0, "live windows")?;
        for k in 0..s {
            check(
                self.window_ptr.u32_at(k) <= self.window_ptr.u32_at(k + 1),
                "live windows",
            )?;
        }
        let entries = self.window_ptr.u32_at(s) as usize;
        check(
            self.window_sample.count(4) == Some(entries),
            "live window samples",
        )?;
        check(
            self.window_offset_mm.count(4) == Some(entries),
            "live window offsets",
        )?;
        for k in 0..entries {
            check(
                (self.window_sample.u32_at(k) as usize) < n,
                "live window sample out of range",
            )?;
        }
        check(
            self.sensor_response_lx.count(8) == Some(s * l),
            "live sensor response",
        )?;
        for k in 0..s * l {
            let x = self.sensor_response_lx.f64_at(k);
            check(x.is_finite() && x >= 0.0, "live sensor response")?;
        }
        check(
            self.sensor_model_uncertainty.count(2) == Some(s),
            "live sensor uncertainty",
        )?;
        for k in 0..s {
            let u = self.sensor_model_uncertainty.u16_at(k);
            check(
                u == NOT_STATED || u <= MAX_UNCERTAINTY_HUNDREDTHS,
                "live sensor uncertainty",
            )?;
        }
        let parts = self.sensor_uncertainty_parts_lx.count(4);
        check(
            parts == Some(0) || parts == Some(s * l * UNCERTAINTY_PARTS),
            "live sensor uncertainty parts",
        )?;
        for k in 0..parts.unwrap_or(0) {
            let x = self.sensor_uncertainty_parts_lx.f32_at(k);
            check(
                x.is_finite() && x.abs() <= MAX_LUX_F32,
                "live sensor uncertainty parts",
            )?;
        }
        let groups = self.sensor_occluder_group.0;
        check(
            groups.is_empty()
                || (parts == Some(s * l * UNCERTAINTY_PARTS) && groups.len() == s * l),
            "live sensor occluder groups",
        )?;
        check(
            groups.iter().all(|&g| g <= OCCLUDER_GROUPS),
            "live sensor occluder group",
        )?;
        check(
            self.patch_emitter.count(1) == Some(patches),
            "live patch emitters",
        )?;
        check(
            usize::from(self.n_emitters) <= MAX_EMITTERS,
            "live emitter count",
        )?;
        for &g in self.patch_emitter.0 {
            check(
                g == NO_EMITTER || u16::from(g) < self.n_emitters,
                "live patch emitter group",
            )?;
        }
        Ok(())
    }

    /// Samples.
    pub fn samples(&self) -> usize {
        self.n_samples as usize
    }

    /// Pixel index (`v · width + u`) of sample `i`.
    pub fn pixel(&self, i: usize) -> usize {
        self.sample_pixel.u32_at(i) as usize
    }

    /// Patch of sample `i`.
    pub fn patch(&self, i: usize) -> usize {
        self.sample_patch.u32_at(i) as usize
    }

    /// Commissioned depth of sample `i`, mm (0: unknown).
    pub fn depth_mm(&self, i: usize) -> u16 {
        self.sample_depth_mm.u16_at(i)
    }

    /// Irradiance at sample `i` from luminaire `l` at 100 %, lx.
    pub fn artificial_lx(&self, l: usize, i: usize) -> f64 {
        let n = self.samples();
        self.artificial_lx.get(l * n + i, l)
    }

    /// Window entries of sensor `s` (indices into [`Self::window_entry`]).
    pub fn window(&self, s: usize) -> core::ops::Range<usize> {
        self.window_ptr.u32_at(s) as usize..self.window_ptr.u32_at(s + 1) as usize
    }

    /// Window entry `k`: (sample index, offset from the sensor along world x and y, m).
    pub fn window_entry(&self, k: usize) -> (usize, f64, f64) {
        let b = &self.window_offset_mm.0[4 * k..4 * k + 4];
        let dx = i16::from_le_bytes([b[0], b[1]]);
        let dy = i16::from_le_bytes([b[2], b[3]]);
        (
            self.window_sample.u32_at(k) as usize,
            f64::from(dx) * 1e-3,
            f64::from(dy) * 1e-3,
        )
    }

    /// Camera-calibrated response of sensor `s` to luminaire `l` at 100 %, lx (for `L`
    /// luminaires).
    pub fn sensor_response_lx(&self, s: usize, l: usize, luminaires: usize) -> f64 {
        self.sensor_response_lx.f64_at(s * luminaires + l)
    }

    /// Stated relative standard uncertainty of sensor `s`'s modelled artificial light (`None`:
    /// not stated).
    pub fn model_rel_uncertainty(&self, s: usize) -> Option<f64> {
        let u = self.sensor_model_uncertainty.u16_at(s);
        (u != NOT_STATED).then(|| f64::from(u) * 1e-4)
    }

    /// The section states each sensor's modelled-light uncertainty per luminaire (its parts;
    /// checked at parse to be `[sensor][luminaire][part]` when present).
    pub fn has_uncertainty_parts(&self) -> bool {
        !self.sensor_uncertainty_parts_lx.0.is_empty()
    }

    /// Part `k` (< [`UNCERTAINTY_PARTS`]) of sensor `s`'s modelled-light
    /// uncertainty from luminaire `l` at 100 %, lx, for `luminaires` luminaires (0 without
    /// parts).
    pub fn uncertainty_part_lx(&self, s: usize, l: usize, k: usize, luminaires: usize) -> f64 {
        let p = UNCERTAINTY_PARTS;
        let i = (s * luminaires + l) * p + k;
        if !self.has_uncertainty_parts() || 4 * i + 4 > self.sensor_uncertainty_parts_lx.0.len() {
            return 0.0;
        }
        f64::from(self.sensor_uncertainty_parts_lx.f32_at(i))
    }

    /// The occluder group of sensor `s`'s luminaire `l` (for `luminaires` luminaires): 0 alone,
    /// `1..=OCCLUDER_GROUPS` shaded together with the group's others; 0 without groups.
    pub fn occluder_group(&self, s: usize, l: usize, luminaires: usize) -> u8 {
        self.sensor_occluder_group
            .0
            .get(s * luminaires + l)
            .copied()
            .unwrap_or(0)
    }

    /// Every sensor's occluder groups, copied out flat (`[sensor][luminaire]`); empty without.
    #[cfg(feature = "std")]
    pub fn occluder_groups_vec(&self) -> std::vec::Vec<u8> {
        self.sensor_occluder_group.0.to_vec()
    }

    /// Every sensor's uncertainty parts, copied out flat (`[sensor][luminaire][part]`, the
    /// layout checked at parse); empty without parts.
    #[cfg(feature = "std")]
    pub fn uncertainty_parts_vec(&self) -> std::vec::Vec<f64> {
        let n = self.sensor_uncertainty_parts_lx.count(4).unwrap_or(0);
        (0..n)
            .map(|i| f64::from(self.sensor_uncertainty_parts_lx.f32_at(i)))
            .collect()
    }

    /// Candidate emitter group of patch `p`.
    pub fn emitter(&self, p: usize) -> Option<usize> {
        let g = self.patch_emitter.0[p];
        (g != NO_EMITTER).then_some(usize::from(g))
    }
}
