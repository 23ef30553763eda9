//! Building the flash image from a commissioned [`Model`] (std): prune and quantise the form
//! factors and direct terms to the chosen precision, then compute the response matrix *from the
//! stored arrays* (by solving the image's own system, with the run-time code), so that
//! superposition and a run-time re-solve agree whatever the precision.
//!
//! This is the "form factors → store" step of the data flow. It sits above both the engine
//! (its input) and the run-time core (which it runs on the image it built); the store format
//! itself ([`crate::store`]) knows neither. [`build_for_region`] is the one entry point that
//! also checks the image fits the `FORMFACTORS` region of `memory.x`.

use std::fmt;

use crate::engine::Model;
use crate::solver;
use crate::store::encode::{SparseBuf, encode};
use crate::store::geometry::GeometrySection;
use crate::store::values::{Bytes, Precision, Sparse, Values};
use crate::store::{FORMAT_VERSION, HEADER_LEN, Header, Image, PayloadV1, SettingsRecord, crc32};

/// How to store a model.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageOptions {
    /// Precision of the form factors and of the direct illuminance on patches.
    pub precision: Precision,
    /// Form factors below this are dropped (each row rescaled to keep its sum); 0 keeps all.
    pub prune_below: f64,
    /// The scene's name, for inspection.
    pub scene_name: String,
    /// Per-sensor flags ([`crate::store::sensor_flags`]); empty means none set.
    pub sensor_flags: Vec<u8>,
    /// The geometry section for reports ([`crate::image_geometry::section_of`]); `None` leaves
    /// it out (the image then holds only what the run time needs).
    pub geometry: Option<GeometrySection>,
}

impl Default for ImageOptions {
    fn default() -> Self {
        Self {
            precision: Precision::U16,
            prune_below: 0.0,
            scene_name: String::new(),
            sensor_flags: Vec::new(),
            geometry: None,
        }
    }
}

/// Why no image was built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// Too many patches, sensors or luminaires for the format.
    #[error("too large for the image format: {0}")]
    Limits(String),
    /// The prune threshold is not a number >= 0.
    #[error("prune threshold {0} must be a number >= 0")]
    Prune(f64),
    /// Solving the stored system failed.
    #[error("solving the stored system for luminaire {luminaire}: {source}")]
    Solve {
        /// Luminaire id.
        luminaire: u32,
        /// Why.
        source: solver::SolveError,
    },
    /// The built image does not parse (a bug).
    #[error("the built image does not parse: {0}")]
    Parse(crate::store::ImageError),
    /// Serialisation failed.
    #[error("serialising the payload: {0}")]
    Serialise(String),
    /// The image does not fit the flash region; the message names the knobs that shrink it.
    #[error("{0}")]
    TooLarge(String),
    /// The node could not serve the image (more desks or luminaires than the register map).
    #[error("the node cannot serve this image: {0}")]
    Served(String),
}

/// What the node's register map refuses, as messages (empty: servable): more than
/// [`crate::modbus::regmap::MAX_DESKS`] desks or [`crate::modbus::regmap::MAX_LUMINAIRES`]
/// luminaires. `image build`, `scene check`, commissioning and the node agree on it.
pub fn served_limits(desks: usize, luminaires: usize) -> Vec<String> {
    use crate::modbus::regmap::{MAX_DESKS, MAX_LUMINAIRES};
    let mut v = Vec::new();
    if desks > MAX_DESKS {
        v.push(format!(
            "{desks} desk sensors: the Modbus register map serves at most {MAX_DESKS}"
        ));
    }
    if luminaires > MAX_LUMINAIRES {
        v.push(format!(
            "{luminaires} luminaires: the Modbus register map serves at most {MAX_LUMINAIRES}"
        ));
    }
    v
}

/// Sizes of the parts of an image, bytes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sections {
    /// (name, bytes) in payload order.
    pub parts: Vec<(&'static str, usize)>,
    /// Whole image, bytes.
    pub total: usize,
}

impl fmt::Display for Sections {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (name, bytes) in &self.parts {
            writeln!(
                f,
                "  {name:<34} {bytes:>10} B  {:>5.1} %",
                100.0 * *bytes as f64 / self.total.max(1) as f64
            )?;
        }
        write!(f, "  {:<34} {:>10} B", "total", self.total)
    }
}

/// The parts of a parsed image.
pub fn sections(image: &Image<'_>) -> Sections {
    let p = &image.payload;
    let sparse = |s: &Sparse<'_>| {
        s.row_ptr.0.len() + s.col.0.len() + s.values.data.0.len() + s.values.scales.0.len()
    };
    let live = image.live.as_ref().map_or(0, |l| {
        l.sample_pixel.0.len()
            + l.sample_patch.0.len()
            + l.sample_depth_mm.0.len()
            + l.artificial_lx.data.0.len()
            + l.artificial_lx.scales.0.len()
            + l.window_ptr.0.len()
            + l.window_sample.0.len()
            + l.window_offset_mm.0.len()
            + l.sensor_response_lx.0.len()
            + l.patch_emitter.0.len()
            + crate::store::SECTION_FRAME_LEN
    });
    let geometry = image
        .geometry_bytes()
        .map_or(0, |g| g.len() + crate::store::SECTION_FRAME_LEN);
    let daylight = image.daylight.as_ref().map_or(0, |d| {
        d.seen_patch.0.len()
            + d.seen_lx.0.len()
            + d.sensor_lx.0.len()
            + crate::store::SECTION_FRAME_LEN
    });
    let mut parts = vec![
        ("header", HEADER_LEN),
        ("form factors (row starts, columns, values)", sparse(&p.ff)),
        (
            "direct illuminance on patches",
            p.direct_patch_lx.data.0.len() + p.direct_patch_lx.scales.0.len(),
        ),
        ("patch reflectances", p.rho.data.0.len()),
        ("sensor gather rows", sparse(&p.gather)),
        (
            "sensor direct, first bounce, response",
            p.direct_sensor_lx.0.len() + p.first_bounce_sensor_lx.0.len() + p.response_lx.0.len(),
        ),
        ("geometry section (for reports)", geometry),
        (
            "ids, flux, settings, names, framing",
            image.len()
                - HEADER_LEN
                - geometry
                - sparse(&p.ff)
                - p.direct_patch_lx.data.0.len()
                - p.direct_patch_lx.scales.0.len()
                - p.rho.data.0.len()
                - sparse(&p.gather)
                - p.direct_sensor_lx.0.len()
                - p.first_bounce_sensor_lx.0.len()
                - p.response_lx.0.len()
                - live
                - daylight,
        ),
    ];
    if image.live.is_some() {
        parts.push(("live light (samples, windows, emitters)", live));
    }
    if image.daylight.is_some() {
        parts.push(("daylight coefficients (unseen windows)", daylight));
    }
    Sections {
        parts,
        total: image.len(),
    }
}

fn f64_bytes(rows: &[Vec<f64>]) -> Vec<u8> {
    rows.iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

fn u32_bytes(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn serialise(
    header_precision: u8,
    payload: &PayloadV1<'_>,
    section: &[u8],
) -> Result<Vec<u8>, BuildError> {
    let mut body =
        postcard::to_stdvec(payload).map_err(|e| BuildError::Serialise(e.to_string()))?;
    body.extend_from_slice(section);
    let header = Header {
        format_version: FORMAT_VERSION,
        generation: 0,
        payload_len: u32::try_from(body.len())
            .map_err(|_| BuildError::Limits("payload over 4 GiB".into()))?,
        payload_crc32: crc32(&body),
        precision: header_precision,
    };
    let mut out = header.emit().to_vec();
    out.extend_from_slice(&body);
    Ok(out)
}

/// Builds the image of a model.
pub fn build_image(model: &Model, options: &ImageOptions) -> Result<Vec<u8>, BuildError> {
    if !(options.prune_below.is_finite() && options.prune_below >= 0.0) {
        return Err(BuildError::Prune(options.prune_below));
    }
    let n = model.patches.len();
    let (l, s) = (model.luminaires(), model.sensors());
    if n > u32::MAX as usize / 2 || l > usize::from(u16::MAX) || s > usize::from(u16::MAX) {
        return Err(BuildError::Limits(format!(
            "{n} patches, {l} luminaires, {s} sensors"
        )));
    }
    let st = &model.settings;
    let settings = SettingsRecord {
        rays: st.rays as u32,
        sensor_rays: st.sensor_rays as u32,
        final_gather_rays: if model.final_gather {
            st.final_gather_rays as u32
        } else {
            0
        },
        patch_size_mm: (st.patches.patch_size_m * 1000.0).round() as u32,
        detail_ratio: st.patches.detail_ratio as f32,
        light_ratio: st.patches.light_ratio as f32,
        opening_samples: st.opening_samples.min(usize::from(u16::MAX)) as u16,
        patch_direct_points: st.patch_direct_points.min(usize::from(u16::MAX)) as u16,
        rectified: st.rectify,
        direct_exact: st.direct == crate::engine::DirectModel::Exact,
        ldc: st.ldc,
        lsc: st.lsc,
        seed: st.seed,
        prune_below: options.prune_below as f32,
    };
    let ff = SparseBuf::new(&model.ff.f, n, options.precision, options.prune_below);
    let gather = SparseBuf::new(&model.gather, n, Precision::F32, 0.0);
    let rho: Vec<u8> = model
        .patches
        .rho
        .iter()
        .flat_map(|r| (*r as f32).to_le_bytes())
        .collect();
    let direct_flat: Vec<f64> = model.direct_patch_lx.iter().flatten().copied().collect();
    let bounds: Vec<usize> = (0..=l).map(|j| j * n).collect();
    let (d_scales, d_data) = encode(&direct_flat, &bounds, options.precision);
    let luminaire_ids = u32_bytes(&model.luminaire_ids);
    let sensor_ids = u32_bytes(&model.sensor_ids);
    let sensor_flags: Vec<u8> = (0..s)
        .map(|k| options.sensor_flags.get(k).copied().unwrap_or(0))
        .collect();
    let flux: Vec<u8> = model
        .luminaire_flux_lm
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let direct_sensor = f64_bytes(&model.direct_sensor_lx);
    let first_bounce = f64_bytes(&model.first_bounce_sensor_lx);
    let zero_response = vec![0u8; 8 * s * l];
    let mut payload = PayloadV1 {
        scene_name: &options.scene_name,
        settings,
        n_patches: n as u32,
        n_luminaires: l as u16,
        n_sensors: s as u16,
        luminaire_ids: Bytes(&luminaire_ids),
        luminaire_flux_lm: Bytes(&flux),
        sensor_ids: Bytes(&sensor_ids),
        sensor_flags: Bytes(&sensor_flags),
        rho: Values {
            precision: Precision::F32 as u8,
            scales: Bytes(&[]),
            data: Bytes(&rho),
        },
        ff: ff.view(),
        direct_patch_lx: Values {
            precision: options.precision as u8,
            scales: Bytes(&d_scales),
            data: Bytes(&d_data),
        },
        direct_sensor_lx: Bytes(&direct_sensor),
        first_bounce_sensor_lx: Bytes(&first_bounce),
        final_gather: model.final_gather,
        gather: gather.view(),
        response_lx: Bytes(&zero_response),
        solve_tolerance: st.solve.tolerance,
        solve_max_iterations: st.solve.max_iterations,
    };
    // The response of the *stored* system: one solve per luminaire on the image itself.
    let section = match &options.geometry {
        Some(g) => g
            .encode()
            .map_err(|e| BuildError::Serialise(format!("geometry section: {e}")))?,
        None => Vec::new(),
    };
    let provisional = serialise(options.precision as u8, &payload, &section)?;
    let image = Image::parse(&provisional).map_err(BuildError::Parse)?;
    let runtime = crate::runtime::Runtime::new(&image);
    let mut response = vec![vec![0.0; l]; s];
    let (mut e, mut b, mut out) = (vec![0.0; n], vec![0.0; n], vec![0.0; s]);
    let mut levels = vec![0.0; l];
    for j in 0..l {
        levels.iter_mut().for_each(|x| *x = 0.0);
        levels[j] = 1.0;
        runtime
            .resolve(&levels, &mut e, &mut b, &mut out)
            .map_err(|err| match err {
                crate::runtime::RuntimeError::Solve(source) => BuildError::Solve {
                    luminaire: model.luminaire_ids[j],
                    source,
                },
                other => BuildError::Serialise(other.to_string()),
            })?;
        for (k, v) in out.iter().enumerate() {
            response[k][j] = *v;
        }
    }
    let response_bytes = f64_bytes(&response);
    payload.response_lx = Bytes(&response_bytes);
    let bytes = serialise(options.precision as u8, &payload, &section)?;
    Image::parse(&bytes).map_err(BuildError::Parse)?;
    Ok(bytes)
}

/// Builds the image of a model, checks that the node can serve it ([`served_limits`]) and that
/// it fits a flash region of `region_bytes`
/// (the `FORMFACTORS` region: [`crate::layout::FORMFACTORS_LEN_BYTES`]). An image that does not
/// fit is an error naming the knobs that would shrink it, with their estimated savings.
pub fn build_for_region(
    model: &Model,
    options: &ImageOptions,
    region_bytes: usize,
) -> Result<Vec<u8>, BuildError> {
    let limits = served_limits(model.sensors(), model.luminaires());
    if !limits.is_empty() {
        return Err(BuildError::Served(limits.join("; ")));
    }
    let bytes = build_image(model, options)?;
    if bytes.len() > region_bytes {
        let image = Image::parse(&bytes).map_err(BuildError::Parse)?;
        return Err(BuildError::TooLarge(too_large_message(
            &image,
            region_bytes,
        )));
    }
    Ok(bytes)
}

/// Room kept after the model for the sections that follow it (the live-light section) when an
/// image is shrunk to fit, bytes. The live-light section adapts to the room it gets; below this
/// it samples the seen surfaces too coarsely.
pub const SECTION_RESERVE_BYTES: usize = 128 * 1024;

/// The prune threshold [`fit_steps`] tries: free on office_a (docs/tradeoffs.md: 4 % fewer
/// entries, the same error).
pub const FIT_PRUNE_BELOW: f64 = 1e-4;

/// The storage steps [`build_to_fit`] tries, in order: `options` as given; pruning at
/// [`FIT_PRUNE_BELOW`]; 8-bit form factors; both. Each step is at least as small as the one
/// before; none changes the geometry or the patches. u8 is as accurate as u16 on office_a
/// (docs/tradeoffs.md) with less margin for rooms of high reflectance.
pub fn fit_steps(options: &ImageOptions) -> Vec<ImageOptions> {
    let prune = options.prune_below.max(FIT_PRUNE_BELOW);
    let smaller = |p: Precision| {
        if p.width() > Precision::U8.width() {
            Precision::U8
        } else {
            p
        }
    };
    let mut out = vec![options.clone()];
    for (precision, prune_below) in [
        (options.precision, prune),
        (smaller(options.precision), options.prune_below),
        (smaller(options.precision), prune),
    ] {
        let step = ImageOptions {
            precision,
            prune_below,
            ..options.clone()
        };
        if !out.contains(&step) {
            out.push(step);
        }
    }
    out
}

/// An image shrunk to fit ([`build_to_fit`]).
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The image.
    pub bytes: Vec<u8>,
    /// The storage options it was built with.
    pub options: ImageOptions,
    /// The step of [`fit_steps`] used: 0 means `options` as given.
    pub step: usize,
    /// The size at `options` as given, bytes (when it was built).
    pub first_bytes: Option<usize>,
}

/// Builds the image of a model to fit a flash region of `region_bytes` with `reserve_bytes`
/// left for the sections that follow ([`SECTION_RESERVE_BYTES`]): the first of
/// [`fit_steps`] that does; else the first that fits without the reserve; else the error of
/// `options` as given, which names the knobs that would shrink the model itself (patch size,
/// rays). Commissioning takes this when the engineer has not chosen a storage precision: a
/// larger room, seen by several nodes, should not fail for a choice the node can make.
pub fn build_to_fit(
    model: &Model,
    options: &ImageOptions,
    region_bytes: usize,
    reserve_bytes: usize,
) -> Result<Fitted, BuildError> {
    let mut first_fit: Option<Fitted> = None;
    let mut first_error: Option<BuildError> = None;
    let mut first_bytes: Option<usize> = None;
    for (step, o) in fit_steps(options).into_iter().enumerate() {
        match build_for_region(model, &o, region_bytes) {
            Ok(bytes) => {
                if step == 0 {
                    first_bytes = Some(bytes.len());
                }
                let roomy = bytes.len().saturating_add(reserve_bytes) <= region_bytes;
                let fitted = Fitted {
                    bytes,
                    options: o,
                    step,
                    first_bytes,
                };
                if roomy {
                    return Ok(fitted);
                }
                if first_fit.is_none() {
                    first_fit = Some(fitted);
                }
            }
            Err(BuildError::TooLarge(m)) => {
                if first_error.is_none() {
                    first_error = Some(BuildError::TooLarge(m));
                }
            }
            Err(e) => return Err(e),
        }
    }
    match (first_fit, first_error) {
        (Some(f), _) => Ok(f),
        (None, Some(e)) => Err(e),
        (None, None) => Err(BuildError::Limits("no storage step to try".into())),
    }
}

/// The `FORMFACTORS` region of `memory.x`, bytes.
pub fn formfactors_region_bytes() -> usize {
    usize::try_from(crate::layout::FORMFACTORS_LEN_BYTES).unwrap_or(usize::MAX)
}

/// How an image compares with the `FORMFACTORS` region, and what would help if it does not fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Image length, bytes.
    pub image_bytes: usize,
    /// Region length, bytes.
    pub region_bytes: usize,
}

impl Fit {
    /// True when the image fits.
    pub fn fits(&self) -> bool {
        self.image_bytes <= self.region_bytes
    }

    /// Region use, percent.
    pub fn usage_pct(&self) -> f64 {
        100.0 * self.image_bytes as f64 / self.region_bytes.max(1) as f64
    }
}

/// The message for an image that does not fit, naming the knobs that shrink it, with their
/// estimated savings for this image.
pub fn too_large_message(image: &Image<'_>, region_bytes: usize) -> String {
    let mib = |b: f64| b / (1024.0 * 1024.0);
    let total = image.len() as f64;
    let over = total - region_bytes as f64;
    let p = &image.payload;
    let nnz = p.ff.nnz() as f64;
    let width = p.ff.values.precision().width() as f64;
    let mut hints = Vec::new();
    for (name, w) in [("f16", 2.0), ("u8", 1.0)] {
        if w < width {
            hints.push(format!(
                "--precision {name} saves about {:.2} MiB",
                mib(nnz * (width - w))
            ));
        }
    }
    hints.push("--prune 1e-5 drops the smallest form factors (their row sums are kept)".into());
    hints.push("a larger --patch-size or a smaller --detail has fewer patches (entries fall about with the square)".into());
    hints.push("fewer --rays has fewer non-zero form factors per patch".into());
    format!(
        "the image is {:.2} MiB, {:.2} MiB ({:.0} %) over the {:.2} MiB FORMFACTORS region of memory.x; \
         its form factors take {:.2} MiB ({} entries of {} bytes plus columns). What helps: {}",
        mib(total),
        mib(over),
        100.0 * over / region_bytes as f64,
        mib(region_bytes as f64),
        mib(nnz * (width + f64::from(p.ff.col_width))),
        nnz,
        width,
        hints.join("; ")
    )
}

/// The live-light section as commissioning builds it (owned; the stored layout and its meaning
/// are in [`crate::store::live`]). `crate::live` fills it from a capture or a CAD model.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveSectionData {
    /// The camera and its gain.
    pub camera: crate::store::live::CameraRecord,
    /// [`crate::store::live::live_source`].
    pub source: u8,
    /// Grid stride of the samples, pixels.
    pub stride: u16,
    /// Pixel index per sample.
    pub pixel: Vec<u32>,
    /// Patch per sample.
    pub patch: Vec<u32>,
    /// Commissioned depth per sample, mm (0: unknown).
    pub depth_mm: Vec<u16>,
    /// Artificial irradiance at 100 %, lx: `[luminaire][sample]`.
    pub artificial_lx: Vec<Vec<f64>>,
    /// Per sensor: (sample, offset along world x, along world y, mm).
    pub windows: Vec<Vec<(u32, i16, i16)>>,
    /// Camera-calibrated response, lx: `[sensor][luminaire]`.
    pub sensor_response_lx: Vec<Vec<f64>>,
    /// Stated relative standard uncertainty of each sensor's modelled light (not finite: not
    /// stated).
    pub model_rel_uncertainty: Vec<f64>,
    /// The parts of each sensor's modelled-light uncertainty per luminaire at 100 %, lx:
    /// `[sensor][luminaire]` ([`crate::runtime::UNCERTAINTY_PARTS`] each); empty: not stated.
    pub model_uncertainty_parts_lx: Vec<Vec<[f64; crate::runtime::UNCERTAINTY_PARTS]>>,
    /// Each sensor's occluder group per luminaire (`[sensor][luminaire]`,
    /// [`crate::store::live::OCCLUDER_GROUPS`]); empty: every luminaire alone.
    pub model_occluder_groups: Vec<Vec<u8>>,
    /// Candidate emitter group per patch ([`crate::store::live::NO_EMITTER`]: none).
    pub patch_emitter: Vec<u8>,
    /// Number of emitter groups.
    pub n_emitters: u16,
}

impl LiveSectionData {
    /// Bytes the section takes in an image (postcard framing included, approximately).
    pub fn encoded_len(&self) -> usize {
        let n = self.pixel.len();
        let l = self.artificial_lx.len();
        let w: usize = self.windows.iter().map(Vec::len).sum();
        64 + 10 * n
            + 2 * l * n
            + 4 * l
            + 8 * w
            + 4 * (self.windows.len() + 1)
            + 8 * self.sensor_response_lx.len() * l
            + 2 * self.model_rel_uncertainty.len()
            + 4 * crate::runtime::UNCERTAINTY_PARTS * self.model_uncertainty_parts_lx.len() * l
            + self.model_occluder_groups.len() * l
            + self.patch_emitter.len()
    }
}

/// The postcard body of a live section.
pub fn encode_live(d: &LiveSectionData) -> Result<Vec<u8>, BuildError> {
    let n = d.pixel.len();
    if d.patch.len() != n || d.depth_mm.len() != n || d.artificial_lx.iter().any(|r| r.len() != n) {
        return Err(BuildError::Limits(
            "live section: per-sample arrays differ in length".into(),
        ));
    }
    let l = d.artificial_lx.len();
    let pixel = u32_bytes(&d.pixel);
    let patch = u32_bytes(&d.patch);
    let depth: Vec<u8> = d.depth_mm.iter().flat_map(|v| v.to_le_bytes()).collect();
    let flat: Vec<f64> = d.artificial_lx.iter().flatten().copied().collect();
    let bounds: Vec<usize> = (0..=l).map(|j| j * n).collect();
    let (scales, data) = encode(&flat, &bounds, Precision::U16);
    let mut ptr = vec![0u32];
    let mut wsample = Vec::new();
    let mut woff = Vec::new();
    for w in &d.windows {
        for &(i, dx, dy) in w {
            wsample.push(i);
            woff.extend_from_slice(&dx.to_le_bytes());
            woff.extend_from_slice(&dy.to_le_bytes());
        }
        ptr.push(wsample.len() as u32);
    }
    let ptr = u32_bytes(&ptr);
    let wsample = u32_bytes(&wsample);
    let response = f64_bytes(&d.sensor_response_lx);
    if d.model_rel_uncertainty.len() != d.windows.len() {
        return Err(BuildError::Limits(format!(
            "live section: {} stated uncertainties for {} sensors",
            d.model_rel_uncertainty.len(),
            d.windows.len()
        )));
    }
    let uncertainty: Vec<u8> = d
        .model_rel_uncertainty
        .iter()
        .flat_map(|u| {
            use crate::store::live::{MAX_UNCERTAINTY_HUNDREDTHS, NOT_STATED};
            let v = if u.is_finite() && *u >= 0.0 {
                (u * 1e4).round().min(f64::from(MAX_UNCERTAINTY_HUNDREDTHS)) as u16
            } else {
                NOT_STATED
            };
            v.to_le_bytes()
        })
        .collect();
    let live = crate::store::LiveV1 {
        version: crate::store::live::LIVE_VERSION,
        camera: d.camera,
        source: d.source,
        stride: d.stride,
        n_samples: u32::try_from(n)
            .map_err(|_| BuildError::Limits("live section: too many samples".into()))?,
        sample_pixel: Bytes(&pixel),
        sample_patch: Bytes(&patch),
        sample_depth_mm: Bytes(&depth),
        artificial_lx: Values {
            precision: Precision::U16 as u8,
            scales: Bytes(&scales),
            data: Bytes(&data),
        },
        window_ptr: Bytes(&ptr),
        window_sample: Bytes(&wsample),
        window_offset_mm: Bytes(&woff),
        sensor_response_lx: Bytes(&response),
        sensor_model_uncertainty: Bytes(&uncertainty),
        patch_emitter: Bytes(&d.patch_emitter),
        n_emitters: d.n_emitters,
        sensor_uncertainty_parts_lx: Bytes(&[]),
        sensor_occluder_group: Bytes(&[]),
    };
    let parts = uncertainty_parts_bytes(d, l)?;
    let groups = occluder_group_bytes(d, l)?;
    let mut body = postcard::to_stdvec(&live).map_err(|e| BuildError::Serialise(e.to_string()))?;
    for tail in [&parts, &groups] {
        let tail =
            postcard::to_stdvec(&Bytes(tail)).map_err(|e| BuildError::Serialise(e.to_string()))?;
        body.extend_from_slice(&tail);
    }
    Ok(body)
}

/// The live section's occluder groups, u8 `[sensor][luminaire]` (empty: every luminaire alone),
/// checked against the section's sensors, `l` luminaires and its uncertainty parts (groups
/// without parts group nothing).
fn occluder_group_bytes(d: &LiveSectionData, l: usize) -> Result<Vec<u8>, BuildError> {
    let groups = &d.model_occluder_groups;
    if groups.is_empty() {
        return Ok(Vec::new());
    }
    if d.model_uncertainty_parts_lx.is_empty()
        || groups.len() != d.windows.len()
        || groups.iter().any(|r| r.len() != l)
    {
        return Err(BuildError::Limits(format!(
            "live section: occluder groups for {} sensors and {:?} luminaires, the section has \
             {} sensors, {l} luminaires and {} rows of uncertainty parts",
            groups.len(),
            groups.first().map(Vec::len),
            d.windows.len(),
            d.model_uncertainty_parts_lx.len()
        )));
    }
    let max = crate::store::live::OCCLUDER_GROUPS;
    if let Some(g) = groups.iter().flatten().find(|g| **g > max) {
        return Err(BuildError::Limits(format!(
            "live section: occluder group {g} (at most {max})"
        )));
    }
    Ok(groups.iter().flatten().copied().collect())
}

/// The live section's uncertainty parts, f32 LE `[sensor][luminaire][part]` (empty when not
/// stated), checked against the section's sensors and `l` luminaires.
fn uncertainty_parts_bytes(d: &LiveSectionData, l: usize) -> Result<Vec<u8>, BuildError> {
    let parts = &d.model_uncertainty_parts_lx;
    if parts.is_empty() {
        return Ok(Vec::new());
    }
    if parts.len() != d.windows.len() || parts.iter().any(|r| r.len() != l) {
        return Err(BuildError::Limits(format!(
            "live section: uncertainty parts for {} sensors and {:?} luminaires, the section has \
             {} sensors and {l} luminaires",
            parts.len(),
            parts.first().map(Vec::len),
            d.windows.len()
        )));
    }
    let max = crate::store::MAX_LUX;
    let flat = parts.iter().flatten().flatten();
    if let Some(v) = flat.clone().find(|v| !(v.is_finite() && v.abs() <= max)) {
        return Err(BuildError::Limits(format!(
            "live section: an uncertainty part of {v} lx"
        )));
    }
    Ok(flat.flat_map(|v| (*v as f32).to_le_bytes()).collect())
}

/// The image with its live section replaced by `live` (added when it has none; removed with
/// `None`): the payload and every other section are kept byte for byte, the header's length and
/// CRC rewritten, and the result parsed and checked.
pub fn with_live(image: &[u8], live: Option<&LiveSectionData>) -> Result<Vec<u8>, BuildError> {
    use crate::store::{LIVE_MAGIC, live::LIVE_VERSION};
    let body = live.map(encode_live).transpose()?;
    with_section(image, LIVE_MAGIC, LIVE_VERSION, body.as_deref())
}

/// The image with its section `magic` replaced by `body` (added when it has none; removed with
/// `None`): the payload and every other section kept byte for byte, the header's length and CRC
/// rewritten, and the result parsed and checked.
pub fn with_section(
    image: &[u8],
    magic: [u8; 4],
    version: u16,
    section: Option<&[u8]>,
) -> Result<Vec<u8>, BuildError> {
    use crate::store::SECTION_FRAME_LEN;
    let parsed = Image::parse(image).map_err(BuildError::Parse)?;
    let payload = &image[HEADER_LEN..parsed.len()];
    let (_, mut rest): (PayloadV1<'_>, &[u8]) = postcard::take_from_bytes(payload)
        .map_err(|_| BuildError::Parse(crate::store::ImageError::Decode))?;
    let mut body = payload[..payload.len() - rest.len()].to_vec();
    // keep every other section as it is (the frames were checked by the parse)
    while rest.len() >= SECTION_FRAME_LEN {
        let len = u32::from_le_bytes([rest[6], rest[7], rest[8], rest[9]]) as usize;
        let end = (SECTION_FRAME_LEN + len).min(rest.len());
        if rest[0..4] != magic {
            body.extend_from_slice(&rest[..end]);
        }
        rest = &rest[end..];
    }
    if let Some(encoded) = section {
        let frame = crate::store::frame_section(magic, version, encoded)
            .ok_or_else(|| BuildError::Limits("section over 4 GiB".into()))?;
        body.extend(frame);
    }
    let header = Header {
        payload_len: u32::try_from(body.len())
            .map_err(|_| BuildError::Limits("payload over 4 GiB".into()))?,
        payload_crc32: crc32(&body),
        ..parsed.header
    };
    let mut out = header.emit().to_vec();
    out.extend_from_slice(&body);
    Image::parse(&out).map_err(BuildError::Parse)?;
    Ok(out)
}
