//! The run-time estimator: a registered luminance frame (and, when there is one, a depth frame)
//! in, per-desk total, artificial and daylight lux out, with their source, flags and
//! uncertainty. The method is in the module docs of [`crate::live`]; this file is its code.

use crate::solver::{
    self, Csr, CsrSystem, RhsState, Rows, SolveError, SolveOptions, SolveReport, Workspace,
};
use crate::store::Image;

use super::emitters::{EmitterFit, placement_lx, robust_fit};
use super::nnls::nnls_gram;
use super::sky_fit::{SkyBasis, SkyCoefficients, SunBasis};
use super::sun_fit::{SUN_LIT, SeenSun, SunFit, fit_sun};
use super::window::{farthest_m, window_sigma_m};
use super::{LiveError, flags};
use crate::sky::UnixTime;

/// Where a desk's value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u16)]
pub enum Source {
    /// No usable frame yet: the model's artificial light only (daylight unknown, 0).
    #[default]
    Model = 0,
    /// Measured by the camera on the desk top around the sensor.
    Measured = 1,
    /// Inferred: the artificial light of the model plus daylight propagated from what the
    /// camera sees (the desk is out of view, or covered now with no earlier measurement).
    Inferred = 2,
}

impl Source {
    /// The word in CSV and JSON output.
    pub fn name(self) -> &'static str {
        match self {
            Source::Model => "model",
            Source::Measured => "measured",
            Source::Inferred => "inferred",
        }
    }
}

/// One desk's live value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeskLive {
    /// The sensor id.
    pub id: u32,
    /// Total illuminance, lx.
    pub total_lx: f64,
    /// The luminaires' part at the current dimming state (and ageing), lx.
    pub artificial_lx: f64,
    /// Extraneous light (daylight, unmodelled sources), lx.
    pub daylight_lx: f64,
    /// One standard uncertainty of the total, lx.
    pub uncertainty_lx: f64,
    /// Measured, inferred or model only.
    pub source: Source,
    /// [`flags`] bits.
    pub flags: u16,
    /// Age of the frame the daylight part comes from, s.
    pub frame_age_s: f64,
}

/// What the estimator thought of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Used.
    Ok,
    /// Another size than the commissioned camera's.
    WrongSize,
    /// Older than [`LiveSettings::stale_after_s`].
    Stale,
    /// Far darker than the luminaires alone would make it (a covered lens, a dead sensor).
    Dark,
    /// Too many samples saturated (overexposed).
    Saturated,
    /// Too few usable samples (a depth frame that disagrees everywhere, a frame of zeros).
    Unusable,
    /// Far below the light the luminaires alone give at the commissioned gain: an exposure
    /// the frame's gain does not describe (a tenth of it), or luminaires far dimmer than
    /// their levels say.
    Underexposed,
    /// The frame's edges are not where the room's are: rotated, mirrored, another camera's
    /// view, noise, a depth image passed as luminance.
    NotThisRoom,
}

impl Verdict {
    /// For logs.
    pub fn describe(self) -> &'static str {
        match self {
            Verdict::Ok => "ok",
            Verdict::WrongSize => "wrong size",
            Verdict::Stale => "stale",
            Verdict::Dark => "dark",
            Verdict::Saturated => "saturated",
            Verdict::Unusable => "unusable",
            Verdict::Underexposed => "underexposed",
            Verdict::NotThisRoom => "not this room",
        }
    }
}

/// The knobs of live light (board file `[live]`).
#[derive(Debug, Clone, PartialEq)]
pub struct LiveSettings {
    /// A depth sample disagrees with the commissioned depth by more than this, m ...
    pub depth_tolerance_m: f64,
    /// ... and more than this fraction of it.
    pub depth_tolerance_rel: f64,
    /// A desk is covered when this fraction of its window disagrees in depth.
    pub occluded_fraction: f64,
    /// A desk is unmeasurable (saturated) when this fraction of its window is saturated.
    pub window_saturated_fraction: f64,
    /// A frame is saturated when this fraction of all samples is: overexposed as a whole. Sun
    /// patches and a bright window saturate a part of a good frame (27 % of room_08's tilted
    /// node's samples under the generalization bench's clear sky), which the desks' windows
    /// and the seen patches handle one by one (a saturated sample counts at its floor).
    pub frame_saturated_fraction: f64,
    /// A frame older than this is stale, s.
    pub stale_after_s: f64,
    /// A depth change that lasts this many frames is a change of the room.
    pub geometry_frames: u32,
    /// Changed samples (fraction of those with depth) beyond which recommissioning is advised.
    pub geometry_area_fraction: f64,
    /// A frame is night (no daylight) when the fitted extraneous light is below this fraction
    /// of the measured light.
    pub night_fraction: f64,
    /// Night frames needed before the ageing factors are updated.
    pub ageing_min_frames: u32,
    /// Night frames after which the ageing factors are updated even if the night goes on.
    pub ageing_max_frames: u32,
    /// A desk is flagged for ageing when a luminaire giving it this share of its light...
    pub ageing_flag_share: f64,
    /// ... is below this ageing factor.
    pub maintenance_factor: f64,
    /// Relative standard uncertainty of daylight inferred through a room plan's windows by the
    /// fitted sky (measured on the Radiance bench).
    pub inferred_rel_uncertainty: f64,
    /// Relative standard uncertainty of daylight inferred by the unknown emitters (no room
    /// plan, or no time for the sky): the generalization bench's out-of-view desks by day
    /// without a plan, one node and node b alone, 49 values, relative error median 45 %, 68th
    /// percentile 57 %, 90th 240 % (docs/generalization.md, eleventh measurement).
    pub emitter_rel_uncertainty: f64,
    /// Relative standard uncertainty of a measured total from reflectance and gain: the RMS
    /// error of the desks in view against Radiance (`tests/live_radiance.rs`, 3.8 %).
    pub measured_rel_uncertainty: f64,
    /// Relative standard uncertainty of the model's artificial light at a desk it infers, when
    /// the image states none for it (a CAD model; the same bench, desks out of view at night:
    /// 4 % to 8 %). An image commissioned from cameras states one per desk
    /// (`crate::commission::uncertainty`).
    pub model_rel_uncertainty: f64,
    /// An inferred desk value whose stated relative standard uncertainty exceeds this is
    /// published as not available ([`flags::DAYLIGHT_UNKNOWN`]): its two-uncertainty interval
    /// would be wider than the value itself. By day without a room plan, daylight through
    /// windows the cameras do not see is told only as well as the seen surfaces tell the
    /// candidate windows apart ([`placement_lx`]).
    pub unknown_above_rel_uncertainty: f64,
}

impl Default for LiveSettings {
    fn default() -> Self {
        Self {
            depth_tolerance_m: 0.05,
            depth_tolerance_rel: 0.03,
            occluded_fraction: 0.3,
            window_saturated_fraction: 0.3,
            frame_saturated_fraction: 0.5,
            stale_after_s: 30.0,
            geometry_frames: 30,
            geometry_area_fraction: 0.05,
            night_fraction: 0.005,
            ageing_min_frames: 20,
            ageing_max_frames: 2000,
            ageing_flag_share: 0.1,
            maintenance_factor: 0.9,
            inferred_rel_uncertainty: 0.25,
            emitter_rel_uncertainty: 0.55,
            measured_rel_uncertainty: 0.04,
            model_rel_uncertainty: 0.07,
            unknown_above_rel_uncertainty: 1.0,
        }
    }
}

impl LiveSettings {
    /// Checks every knob before any work.
    pub fn validate(&self) -> Result<(), LiveError> {
        let frac = |name: &str, x: f64| {
            if x.is_finite() && (0.0..=1.0).contains(&x) {
                Ok(())
            } else {
                Err(LiveError::Input(format!(
                    "live {name} {x} is outside [0, 1]"
                )))
            }
        };
        frac("occluded_fraction", self.occluded_fraction)?;
        frac("window_saturated_fraction", self.window_saturated_fraction)?;
        frac("frame_saturated_fraction", self.frame_saturated_fraction)?;
        frac("geometry_area_fraction", self.geometry_area_fraction)?;
        frac("night_fraction", self.night_fraction)?;
        frac("ageing_flag_share", self.ageing_flag_share)?;
        frac("depth_tolerance_rel", self.depth_tolerance_rel)?;
        frac("inferred_rel_uncertainty", self.inferred_rel_uncertainty)?;
        frac("emitter_rel_uncertainty", self.emitter_rel_uncertainty)?;
        frac("measured_rel_uncertainty", self.measured_rel_uncertainty)?;
        frac("model_rel_uncertainty", self.model_rel_uncertainty)?;
        if !(self.unknown_above_rel_uncertainty.is_finite()
            && (0.05..=10.0).contains(&self.unknown_above_rel_uncertainty))
        {
            return Err(LiveError::Input(format!(
                "live unknown_above_rel_uncertainty {} is outside 0.05..=10",
                self.unknown_above_rel_uncertainty
            )));
        }
        if !(self.maintenance_factor.is_finite() && (0.0..=1.5).contains(&self.maintenance_factor))
        {
            return Err(LiveError::Input(format!(
                "live maintenance_factor {} is outside [0, 1.5]",
                self.maintenance_factor
            )));
        }
        if !(self.depth_tolerance_m.is_finite() && (0.001..=2.0).contains(&self.depth_tolerance_m))
        {
            return Err(LiveError::Input(format!(
                "live depth_tolerance_m {} is outside 0.001..=2 m",
                self.depth_tolerance_m
            )));
        }
        if !(self.stale_after_s.is_finite() && self.stale_after_s > 0.0 && self.stale_after_s < 1e6)
        {
            return Err(LiveError::Input(format!(
                "live stale_after_s {} must be a positive number of seconds",
                self.stale_after_s
            )));
        }
        if self.geometry_frames == 0 || self.geometry_frames > 100_000 {
            return Err(LiveError::Input(format!(
                "live geometry_frames {} must be 1..=100000",
                self.geometry_frames
            )));
        }
        if self.ageing_min_frames == 0 || self.ageing_max_frames < self.ageing_min_frames {
            return Err(LiveError::Input(format!(
                "live ageing frames: min {} must be ≥ 1 and ≤ max {}",
                self.ageing_min_frames, self.ageing_max_frames
            )));
        }
        Ok(())
    }
}

/// A seen patch whose unexplained light exceeds this multiple of the median is in direct sun.
const SUN_FACTOR: f64 = 8.0;

/// A seen patch in direct sun gets at least this much unexplained light, lx: the sun's direct
/// normal illuminance on a hazy day (20-40 klx) through clear glass (0.6) 10-15° above the
/// horizon gives 2-6 klx; the diffuse daylight by a window, a few klx at most, and only with
/// [`SUN_FACTOR`] times the median (the noise of a night frame is relative, so the ratio alone
/// finds "sun" in every frame). 5 klx missed the hazy day's sun patches of the generalization
/// bench (seed 28's room_06: 4.5 klx; a desk by them published 75 % low, outside its
/// statement); at 2.5 klx no overcast or night value of 12 rooms changed
/// (docs/generalization.md, sixteenth measurement).
pub const SUN_PATCH_MIN_LX: f64 = 2500.0;

/// The fitted skies that have no sun: ISO 15469's overcast type 1 and the 1942 overcast
/// sky (16). On the generalization bench the overcast day fits one of them at every node, the
/// clear day none (it fits 4-15).
const OVERCAST_SKIES: [u8; 2] = [1, 16];

/// A desk the camera does not see may be in the sun when it sees this much of the sun's sky
/// patch through the plan's windows ([`super::sky_fit::SkyCoefficients::sun_views`]: a tenth of
/// clear glass's view of the whole patch; the interreflected light alone gives a few
/// hundredths).
pub const SUN_VIEW_MIN: f64 = 0.07;

/// A frame on the commissioned camera's grid.
#[derive(Debug, Clone, Copy)]
pub struct LiveFrame<'a> {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear luminance, row-major; 0 = no data, 65535 = saturated.
    pub luminance: &'a [u16],
    /// cd/m² per unit of `luminance`.
    pub cd_m2_per_unit: f64,
    /// Depth along the optical axis, mm (0 = no return), same grid; `None`: no depth frame.
    pub depth_mm: Option<&'a [u16]>,
    /// When it was taken, s (the caller's monotonic clock; the same clock as `now_s`).
    pub taken_s: f64,
}

/// A stored sparse matrix decoded once at boot (f32 values: the stored precision is at most
/// that of u16 fractions for the form factors).
fn decode(s: &crate::store::Sparse<'_>) -> Csr<f32> {
    Csr::from_row_fn(s.rows as usize, |i| {
        s.row_range(i)
            .map(move |k| (s.col_at(k) as u32, s.values.get(k, i) as f32))
    })
}

/// The stop rule of live light's solves: the relative change and residual of 1e-7 reach the
/// published lux's fourth digit within a few dozen sweeps over the unseen patches.
const LIVE_SOLVE: SolveOptions = SolveOptions {
    tolerance: 1e-7,
    max_iterations: 300,
};

/// Solves `B_i = M_i + ρ_i Σ_j F_ij B_j` over `rows` for the `k` right-hand sides of `b`
/// (patch-major; the other rows held), through the run-time core's iteration.
fn solve_rows(
    ff: &Csr<f32>,
    rho: &[f64],
    rows: Rows<'_>,
    m: &[f64],
    b: &mut [f64],
    k: usize,
) -> Result<SolveReport, SolveError> {
    let system = CsrSystem { f: ff.view(), rho };
    let (mut acc, mut state) = (vec![0.0; k], vec![RhsState::default(); k]);
    let work = Workspace {
        acc: &mut acc,
        state: &mut state,
    };
    solver::solve(
        &system,
        rows,
        solver::Source::Exitance(m),
        b,
        work,
        LIVE_SOLVE,
    )
}

/// A desk's window: samples and their weights.
#[derive(Debug, Clone, Default)]
struct Window {
    sample: Vec<u32>,
    weight: Vec<f64>,
}

/// Everything precomputed from an image (once, at boot).
#[derive(Debug)]
pub struct LiveModel {
    ids: Vec<u32>,
    luminaires: usize,
    width: u32,
    height: u32,
    gain: f64,
    // samples, ordered by patch
    px: Vec<u32>,
    pi_over_rho: Vec<f64>,
    depth_ref: Vec<u16>,
    art: Vec<f32>,
    // patches
    rho: Vec<f64>,
    seen: Vec<u32>,
    seen_range: Vec<(u32, u32)>,
    unseen: Vec<u32>,
    ff: Csr<f32>,
    gather: Csr<f32>,
    // sensors
    response: Vec<f64>,
    calibrated: Vec<f64>,
    // per sensor: commissioning calibrated its response by the camera (the image's
    // `sensor_flags::CALIBRATED`)
    response_calibrated: Vec<bool>,
    model_rel: Vec<f64>,
    // per sensor and luminaire, the model uncertainty's parts ([`crate::runtime::UNCERTAINTY_PARTS`]
    // each; empty: the all-on statement holds for every state)
    model_parts: Vec<f64>,
    // per sensor and luminaire, its occluder group (empty: every luminaire alone)
    model_groups: Vec<u8>,
    /// Per sensor, the model's disagreement with the camera at all on (0 out of view).
    disagreement: Vec<f64>,
    windows: Vec<Window>,
    // emitters: boundary basis (seen exitance fixed), at seen patches and sensors
    k: usize,
    emitter_src: Vec<f64>,
    v_seen: Vec<f64>,
    g_sensor: Vec<f64>,
    // full-model basis at seen patches (the night test), computed at boot
    u_seen: Vec<f64>,
    // daylight coefficients through the plan's unseen windows (None: the emitters alone)
    sky: Option<SkyCoefficients>,
    // per seen patch: it faces up (floor, desk tops: where a sun patch lies; the glass of a
    // window the camera sees, bright with the sky, does not), from the image's geometry
    // section (all false without one)
    seen_up: Vec<bool>,
    // neighbouring samples across an edge of the commissioned luminance: (i, j, ln L_i/L_j)
    edges: Vec<(u32, u32, f32)>,
}

impl LiveModel {
    /// Precomputes the estimator's data from an image with a live section.
    pub fn new(image: &Image<'_>) -> Result<LiveModel, LiveError> {
        let live = image.live.as_ref().ok_or(LiveError::NoSection)?;
        let (n_p, l, s) = (image.patches(), image.luminaires(), image.sensors());
        let rho: Vec<f64> = (0..n_p).map(|i| image.payload.rho.get(i, 0)).collect();
        let n = live.samples();
        let mut order: Vec<usize> = (0..n).filter(|&i| rho[live.patch(i)] > 0.0).collect();
        order.sort_by_key(|&i| (live.patch(i), live.pixel(i)));
        let mut new_index = vec![u32::MAX; n];
        for (k, &i) in order.iter().enumerate() {
            new_index[i] = k as u32;
        }
        let px: Vec<u32> = order.iter().map(|&i| live.pixel(i) as u32).collect();
        let pi_over_rho = order
            .iter()
            .map(|&i| std::f64::consts::PI / rho[live.patch(i)])
            .collect();
        let depth_ref = order.iter().map(|&i| live.depth_mm(i)).collect();
        let mut art = Vec::with_capacity(order.len() * l);
        for &i in &order {
            for j in 0..l {
                art.push(live.artificial_lx(j, i) as f32);
            }
        }
        // seen patches: at least two samples
        let mut seen = Vec::new();
        let mut seen_range = Vec::new();
        let mut is_seen = vec![false; n_p];
        let mut k = 0;
        while k < order.len() {
            let p = live.patch(order[k]);
            let mut e = k;
            while e < order.len() && live.patch(order[e]) == p {
                e += 1;
            }
            if e - k >= 2 {
                seen.push(p as u32);
                seen_range.push((k as u32, e as u32));
                is_seen[p] = true;
            }
            k = e;
        }
        let unseen: Vec<u32> = (0..n_p as u32).filter(|&p| !is_seen[p as usize]).collect();
        let windows = (0..s)
            .map(|sensor| {
                let entries: Vec<(usize, f64, f64)> =
                    live.window(sensor).map(|e| live.window_entry(e)).collect();
                // the residual's Gaussian weights: twice the commissioned fit's width (5 cm in
                // the open, narrower by a shade's edge: window::window_sigma_m on the
                // commissioned all-on irradiance; the window's radius is its farthest pixel)
                let radius_m = farthest_m(entries.iter().map(|&(_, dx, dy)| (dx, dy)));
                let all_on: Vec<(f64, f64, f64)> = entries
                    .iter()
                    .map(|&(i, dx, dy)| {
                        let e: f64 = (0..l).map(|j| live.artificial_lx(j, i)).sum();
                        (dx, dy, e)
                    })
                    .collect();
                let sigma_m = 2.0 * window_sigma_m(&all_on, entries.len(), radius_m.max(0.005));
                let mut w = Window::default();
                for (i, dx, dy) in entries {
                    let k = new_index[i];
                    if k != u32::MAX {
                        w.sample.push(k);
                        w.weight
                            .push((-(dx * dx + dy * dy) / (2.0 * sigma_m * sigma_m)).exp());
                    }
                }
                w
            })
            .collect();
        let response = (0..s)
            .flat_map(|sn| (0..l).map(move |j| (sn, j)))
            .map(|(sn, j)| image.response_lx(sn, j))
            .collect();
        let calibrated = (0..s)
            .flat_map(|sn| (0..l).map(move |j| (sn, j)))
            .map(|(sn, j)| live.sensor_response_lx(sn, j, l))
            .collect();
        let ff = decode(&image.payload.ff);
        let gather = decode(&image.payload.gather);
        // emitter groups on unseen patches only
        let k_em = usize::from(live.n_emitters);
        let mut emitter_src = vec![0.0; n_p * k_em];
        for p in 0..n_p {
            if let Some(g) = live.emitter(p).filter(|_| !is_seen[p]) {
                emitter_src[p * k_em + g] = 1.0;
            }
        }
        let mut model = LiveModel {
            ids: (0..s).map(|k| image.sensor_id(k)).collect(),
            luminaires: l,
            width: u32::from(live.camera.width),
            height: u32::from(live.camera.height),
            gain: live.camera.cd_m2_per_unit,
            px,
            pi_over_rho,
            depth_ref,
            art,
            rho,
            seen,
            seen_range,
            unseen,
            ff,
            gather,
            response,
            calibrated,
            response_calibrated: (0..s)
                .map(|k| image.sensor_flags(k) & crate::store::sensor_flags::CALIBRATED != 0)
                .collect(),
            model_rel: (0..s)
                .map(|k| live.model_rel_uncertainty(k).unwrap_or(f64::NAN))
                .collect(),
            model_parts: live.uncertainty_parts_vec(),
            model_groups: live.occluder_groups_vec(),
            disagreement: Vec::new(),
            windows,
            k: k_em,
            emitter_src,
            v_seen: Vec::new(),
            g_sensor: Vec::new(),
            u_seen: Vec::new(),
            sky: None,
            seen_up: Vec::new(),
            edges: Vec::new(),
        };
        model.sky = SkyCoefficients::from_image(image, &model.seen);
        model.seen_up = seen_faces_up(image, &model.seen);
        model.edges = model.luminance_edges();
        model.disagreement = (0..s).map(|k| model.disagreement_at_boot(k)).collect();
        model.boundary_basis().map_err(LiveError::Solve)?;
        // the night test's basis too, at boot: built at the first night frame it took that
        // frame from 20 to 130 ms (docs/live.md, `luxnode bench live`)
        model.u_seen = model.full_basis().map_err(LiveError::Solve)?;
        Ok(model)
    }

    /// In-view sensor `s`'s disagreement between the model's all-on response and the
    /// camera-calibrated one ([`model_camera_disagreement`]); 0 out of view.
    pub fn disagreement(&self, s: usize) -> f64 {
        self.disagreement.get(s).copied().unwrap_or(0.0)
    }

    /// [`Self::disagreement`], computed once at boot from the stored rows.
    fn disagreement_at_boot(&self, s: usize) -> f64 {
        let l = self.luminaires;
        if !self.in_view(s) {
            return 0.0;
        }
        let row = |v: &[f64]| v.get(s * l..(s + 1) * l).map_or(0.0, |r| r.iter().sum());
        model_camera_disagreement(row(&self.response), row(&self.calibrated)).unwrap_or(0.0)
    }

    /// In-view desk `s`'s extraneous light per valid window sample, with its weight: each
    /// sample's `D(p)` as a share of its own luminaires' light at 100 % `A₁₀₀(p)`, put at the
    /// desk's camera row at 100 % (`Ẽ₁₀₀ D(p) / A₁₀₀(p)`).
    ///
    /// `D(p)` and `A₁₀₀(p)` both go through the pixel's patch reflectance; their ratio does not.
    /// A window whose patch mixes the desk top with a darker monitor (room_03's desk 7: patch
    /// 0.326, desk 0.40) has its luminaires' light right in the plane fit `Ẽ` and its
    /// extraneous light 23 % high in the median of `D`; as a share it is not. Samples the
    /// luminaires do not light are left out; without a camera row or any lit sample the
    /// samples' own `D(p)` is taken.
    fn extraneous_at_desk(&self, s: usize, samples: &[Sample]) -> Vec<(f64, f64)> {
        let l = self.luminaires;
        let e100: f64 = self
            .calibrated
            .get(s * l..(s + 1) * l)
            .map_or(0.0, |r| r.iter().sum());
        extraneous_shares(e100, samples).unwrap_or_else(|| {
            samples
                .iter()
                .map(|p| (p.extraneous_lx, p.weight))
                .collect()
        })
    }

    /// Sensor `s`'s stated relative uncertainty of its modelled light (commissioning's, from
    /// what it inferred), or `default` when the image states none.
    fn model_rel_uncertainty(&self, s: usize, default: f64) -> f64 {
        self.model_rel
            .get(s)
            .copied()
            .filter(|u| u.is_finite())
            .unwrap_or(default)
    }

    /// [`Self::model_rel_uncertainty`] in the dimming state `levels`
    /// ([`crate::runtime::state_rel_uncertainty`]: with fewer luminaires on, a desk's light is
    /// more interreflected, its reflectances weigh more).
    fn model_rel_uncertainty_at(&self, s: usize, levels: &[f64], default: f64) -> f64 {
        let stated = self.model_rel_uncertainty(s, default);
        let (l, p) = (self.luminaires, crate::runtime::UNCERTAINTY_PARTS);
        // a default (not stated) stays as it is
        if levels.len() != l || !self.model_rel.get(s).is_some_and(|u| u.is_finite()) {
            return stated;
        }
        let parts = self
            .model_parts
            .get(s * l * p..(s + 1) * l * p)
            .unwrap_or(&[]);
        let groups = self.model_groups.get(s * l..(s + 1) * l).unwrap_or(&[]);
        let response = self.response.get(s * l..(s + 1) * l).unwrap_or(&[]);
        crate::runtime::state_rel_uncertainty_of_rows(stated, parts, groups, response, levels)
    }

    /// The boundary basis: unit emission of each group, seen patches' exitance held at 0 (it is
    /// measured), interreflected over the unseen patches; its incident light at the seen patches
    /// and the sensors' reading of it.
    fn boundary_basis(&mut self) -> Result<(), SolveError> {
        let (n_p, k) = (self.rho.len(), self.k);
        if k == 0 {
            return Ok(());
        }
        let mut b = vec![0.0; n_p * k];
        let unseen = Rows::Listed(&self.unseen);
        solve_rows(&self.ff, &self.rho, unseen, &self.emitter_src, &mut b, k)?;
        self.v_seen = incident(&self.ff, &self.seen, &b, k);
        let s = self.ids.len();
        let rows: Vec<u32> = (0..s as u32).collect();
        self.g_sensor = incident(&self.gather, &rows, &b, k);
        Ok(())
    }

    /// The full-model basis at the seen patches: unit emission of each group with every patch
    /// reflecting (for the night test).
    fn full_basis(&self) -> Result<Vec<f64>, SolveError> {
        let (n_p, k) = (self.rho.len(), self.k);
        if k == 0 {
            return Ok(Vec::new());
        }
        let mut b = vec![0.0; n_p * k];
        solve_rows(&self.ff, &self.rho, Rows::All, &self.emitter_src, &mut b, k)?;
        Ok(incident(&self.ff, &self.seen, &b, k))
    }

    /// Pairs of neighbouring samples (on the camera grid, at most [`EDGE_REACH_PX`] apart,
    /// right and down) across an edge of the commissioned luminance with every luminaire on:
    /// `|ln L_i / L_j| ≥ `[`EDGE_MIN_LN`]. The luminance is the stored one, `ρ Σ_l E_l / π` per
    /// sample (a texture of the room's surfaces and the luminaires' light, not a model's).
    fn luminance_edges(&self) -> Vec<(u32, u32, f32)> {
        let l = self.luminaires;
        let at: std::collections::HashMap<u32, u32> = self
            .px
            .iter()
            .enumerate()
            .map(|(i, &p)| (p, i as u32))
            .collect();
        let lum = |i: usize| -> f64 {
            let e: f64 = self.art[i * l..(i + 1) * l]
                .iter()
                .map(|&v| f64::from(v))
                .sum();
            e / self.pi_over_rho[i]
        };
        let (w, h) = (self.width, self.height);
        let mut out = Vec::new();
        for (i, &p) in self.px.iter().enumerate() {
            let (x, y) = (p % w, p / w);
            let right = (1..=EDGE_REACH_PX)
                .take_while(|d| x + d < w)
                .find_map(|d| at.get(&(p + d)));
            let down = (1..=EDGE_REACH_PX)
                .take_while(|d| y + d < h)
                .find_map(|d| at.get(&(p + d * w)));
            for &j in right.into_iter().chain(down) {
                let (a, b) = (lum(i), lum(j as usize));
                if a > 0.0 && b > 0.0 && (a / b).ln().abs() >= EDGE_MIN_LN {
                    out.push((i as u32, j, (a / b).ln() as f32));
                }
            }
        }
        out
    }

    /// Samples.
    pub fn samples(&self) -> usize {
        self.px.len()
    }

    /// Seen patches.
    pub fn seen_patches(&self) -> usize {
        self.seen.len()
    }

    /// Candidate emitter groups.
    pub fn emitters(&self) -> usize {
        self.k
    }

    /// Desk sensors.
    pub fn sensors(&self) -> usize {
        self.ids.len()
    }

    /// Luminaires.
    pub fn luminaires(&self) -> usize {
        self.luminaires
    }

    /// The commissioned camera's frame size.
    pub fn frame_size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The camera gain at commissioning, cd/m² per unit (0: not known).
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// True when desk `s` has a window (the camera sees it).
    pub fn in_view(&self, s: usize) -> bool {
        self.windows.get(s).is_some_and(|w| !w.sample.is_empty())
    }

    /// Bytes held (the precomputed arrays; the per-frame scratch of [`Live`] comes on top).
    pub fn memory_bytes(&self) -> usize {
        let f = 8;
        self.px.len() * (4 + f + 2)
            + self.art.len() * 4
            + self.rho.len() * f
            + (self.seen.len() + self.unseen.len()) * 4
            + self.seen_up.len()
            + self.seen_range.len() * 8
            + self.ff.bytes()
            + self.gather.bytes()
            + (self.response.len() + self.calibrated.len()) * f
            + self
                .windows
                .iter()
                .map(|w| w.sample.len() * (4 + f))
                .sum::<usize>()
            + (self.emitter_src.len() + self.v_seen.len() + self.g_sensor.len()) * f
            + self.u_seen.len() * f
            + self.sky.as_ref().map_or(0, SkyCoefficients::memory_bytes)
            + self.edges.len() * 12
    }
}

/// The seen surfaces' measured exitance held (`seen.d`, the glass the sky's coefficients
/// carry at zero), the unseen patches solved (into `b`, the boundary solve's scratch): the
/// light it gives the seen patches and the desks.
fn propagate_seen(
    m: &LiveModel,
    b: &mut [f64],
    seen: &SeenPatches,
    is_glass: &[bool],
) -> Result<(Vec<f64>, Vec<f64>), SolveError> {
    for (r, &p) in m.seen.iter().enumerate() {
        let p = p as usize;
        b[p] = if seen.w[r] > 0.0 && !is_glass[r] {
            m.rho[p] * seen.d[r].max(0.0)
        } else {
            0.0
        };
    }
    let zeros = vec![0.0; b.len()];
    solve_rows(&m.ff, &m.rho, Rows::Listed(&m.unseen), &zeros, b, 1)?;
    let c = incident(&m.ff, &m.seen, b, 1);
    let rows: Vec<u32> = (0..m.sensors() as u32).collect();
    Ok((c, incident(&m.gather, &rows, b, 1)))
}

/// Direct sun: seen patches far brighter than the diffuse daylight of the rest (a sun patch on
/// the floor gets tens of klx where the sky gives hundreds of lx) are measured and propagated
/// as seen exitance, but no diffuse emitter can explain them: left out of the fit (weight 0),
/// which they would otherwise drag to 1e5 lm/m² windows. Returns how many of them are in the
/// sun (above [`SUN_PATCH_MIN_LX`]) and which of those face up (`up`: where
/// [`sun_reach_without_plan`] looks).
fn exclude_sun_patches(y: &[f64], w_use: &mut [f64], up: &[bool]) -> (usize, Vec<usize>) {
    let mut ys: Vec<f64> = (0..y.len())
        .filter(|&r| w_use[r] > 0.0)
        .map(|r| y[r])
        .collect();
    let (mut sun_rows, mut sun_up) = (0usize, Vec::new());
    if let Some(med) = median(&mut ys).filter(|m| *m > 0.0) {
        for r in 0..y.len() {
            if y[r] > SUN_FACTOR * med {
                let sun = w_use[r] > 0.0 && y[r] > SUN_PATCH_MIN_LX;
                sun_rows += usize::from(sun);
                if sun && up.get(r).copied().unwrap_or(false) {
                    sun_up.push(r);
                }
                w_use[r] = 0.0;
            }
        }
    }
    (sun_rows, sun_up)
}

/// Per seen patch, whether it faces up (its normal within 45° of the vertical), from the
/// image's geometry section; all false when the image has none (or it does not decode, or
/// holds another number of patches), which turns off the rule that needs it
/// ([`sun_reach_without_plan`]).
fn seen_faces_up(image: &Image<'_>, seen: &[u32]) -> Vec<bool> {
    let section = image
        .geometry_bytes()
        .map(crate::store::geometry::GeometrySection::decode);
    let g = match section {
        Some(Ok(g)) if g.patch_corners_m.len() == image.patches() => g,
        _ => {
            tracing::info!(
                "live: no geometry section of the image's patches: sun patches are not told \
                 from bright glass"
            );
            return vec![false; seen.len()];
        }
    };
    seen.iter()
        .map(|&p| {
            g.patch_corners_m.get(p as usize).is_some_and(|c| {
                let v = |k: usize| {
                    glam::DVec3::new(
                        f64::from(c[3 * k]),
                        f64::from(c[3 * k + 1]),
                        f64::from(c[3 * k + 2]),
                    )
                };
                let n = (v(1) - v(0)).cross(v(2) - v(0)).normalize_or_zero();
                n.z > core::f64::consts::FRAC_1_SQRT_2
            })
        })
        .collect()
}

/// Without the plan's windows the node cannot trace the sun's beam, but a sun patch it sees
/// tells how near the windows the beam reaches: an upward face (`sun_up`: floor, desk tops)
/// lit far above the diffuse daylight. A desk whose inferred diffuse daylight is at least the
/// fit's diffuse daylight at one of those patches (`diffuse_lx`) is as near the windows as a
/// patch the sun already lights: the sun may lie on it, by a strength nothing seen tells. The
/// others are farther in than any seen sun patch. Fewer than
/// [`super::sun_fit::SUN_MIN_PATCHES`] sun patches: none (a glint).
fn sun_reach_without_plan(sun_up: &[usize], diffuse_lx: &[f64], out: &[f64]) -> Vec<bool> {
    let reach_lx = sun_up
        .iter()
        .filter_map(|&r| diffuse_lx.get(r).copied())
        .filter(|x| x.is_finite())
        .fold(f64::INFINITY, f64::min);
    let seen_sun = sun_up.len() >= super::sun_fit::SUN_MIN_PATCHES && reach_lx.is_finite();
    out.iter().map(|d| seen_sun && *d >= reach_lx).collect()
}

/// `(M b)_i` for the listed rows, `k` right-hand sides: `[row][k]`.
fn incident(m: &Csr<f32>, rows: &[u32], b: &[f64], k: usize) -> Vec<f64> {
    let mut out = vec![0.0; rows.len() * k];
    if k == 0 {
        return out;
    }
    let view = m.view();
    for (o, &i) in out.chunks_exact_mut(k).zip(rows) {
        view.row_dot_k(i as usize, b, o);
    }
    out
}

pub(super) fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let m = v.len() / 2;
    let (_, x, _) = v.select_nth_unstable_by(m, f64::total_cmp);
    Some(*x)
}

/// The weighted median of (value, weight) pairs.
fn weighted_median(v: &mut [(f64, f64)]) -> Option<f64> {
    let total: f64 = v.iter().map(|x| x.1).sum();
    if v.is_empty() || total.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut acc = 0.0;
    for &(x, w) in v.iter() {
        acc += w;
        if acc >= 0.5 * total {
            return Some(x);
        }
    }
    v.last().map(|x| x.0)
}

/// Each sample's extraneous light as a share of its own luminaires' light at 100 %, put at a
/// desk's `all_on_lx` (with the sample's weight); `None` without a positive `all_on_lx` or a
/// sample the luminaires light ([`LiveModel::extraneous_at_desk`]).
fn extraneous_shares(all_on_lx: f64, samples: &[Sample]) -> Option<Vec<(f64, f64)>> {
    if !(all_on_lx > 0.0 && all_on_lx.is_finite()) {
        return None;
    }
    let shares: Vec<(f64, f64)> = samples
        .iter()
        .filter(|p| p.all_on_lx > 0.0 && p.all_on_lx.is_finite())
        .map(|p| (all_on_lx * p.extraneous_lx / p.all_on_lx, p.weight))
        .collect();
    (!shares.is_empty()).then_some(shares)
}

/// Per-desk memory between frames.
#[derive(Debug, Clone, Copy, Default)]
struct Held {
    /// Last good daylight, lx, and when its frame was taken, s.
    daylight: Option<(f64, f64, f64)>,
    /// What a saturated window says the desk's daylight is at least, lx, while its value is
    /// not available for it (0 otherwise): the control plans with it.
    floor_lx: f64,
}

/// The night accumulator of the ageing fit.
#[derive(Debug, Clone, Default)]
struct AgeingAcc {
    g: Vec<f64>,
    h: Vec<f64>,
    frames: u32,
}

/// What one frame did, beyond the desk values (for logs, the Modbus status and tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameReport {
    /// The verdict.
    pub verdict: Verdict,
    /// Samples used.
    pub samples_used: usize,
    /// Samples whose depth disagreed with the commissioned mesh.
    pub samples_occluded: usize,
    /// Fraction of the samples with depth that changed persistently (geometry).
    pub changed_fraction: f64,
    /// Recommissioning advised (a large persistent change).
    pub recommission: bool,
    /// The frame counted as night (no extraneous light).
    pub night: bool,
    /// The ageing factors were updated with this frame.
    pub ageing_updated: bool,
    /// Relative RMS residual of the emitter fit on the seen surfaces.
    pub fit_residual: f64,
    /// Mean daylight the fitted emitters give the seen surfaces, lx.
    pub daylight_seen_lx: f64,
}

/// The live-light state: the model and what it remembers between frames.
#[derive(Debug)]
pub struct Live {
    model: LiveModel,
    settings: LiveSettings,
    ageing: Vec<f64>,
    held: Vec<Held>,
    changed: Vec<u16>,
    b_boundary: Vec<f64>,
    acc: AgeingAcc,
    desks: Vec<DeskLive>,
    report: Option<FrameReport>,
    /// The frame's time for the sky fit (`None`: unknown, the emitters alone).
    time: Option<UnixTime>,
    /// The sky the last frame's fit chose (0: none).
    sky_type: u8,
    // scratch
    d: Vec<f64>,
    state: Vec<u8>,
}

/// Farthest neighbour of a sample on the camera grid for the edge check, pixels (the grid's
/// stride is at most 8 where a section is within budget; windows are dense).
const EDGE_REACH_PX: u32 = 8;
/// An edge of the commissioned luminance: neighbours differing by 35 % or more.
const EDGE_MIN_LN: f64 = 0.3;
/// Fewest usable edges for the check to decide.
const EDGE_MIN_COUNT: usize = 40;
/// A frame of this room agrees with the commissioned edges' direction for most of them (a
/// shadow that moved or a person turns a few); a frame of another view agrees by chance, half.
const EDGE_MIN_AGREEMENT: f64 = 0.7;
/// A frame whose median measured-to-artificial ratio is below this is not believed: the
/// luminaires alone give more (a wrong exposure, or luminaires far dimmer than their levels).
const MIN_MEASURED_OVER_ARTIFICIAL: f64 = 0.5;
/// ... and a frame where more than this share of the lit samples read below that: daylight only
/// adds, so a view of this room has none but shadows the depth did not see. Measured on the
/// demo office (the frame checks' property test, `tests/live.rs`): genuine frames at 30-100 %
/// levels, by night and day, 0.000; night frames shifted sideways by a desk's period (their
/// edges repeat, 0.72 agreement) 0.10-0.17.
const MAX_BELOW_ARTIFICIAL_SHARE: f64 = 0.05;
/// A frame whose depth is farther than the commissioned room at more than this share of the
/// samples with depth is from a camera that moved (or another room).
const MOVED_FARTHER_SHARE: f64 = 0.2;
/// ... and one whose depth agrees with the room at fewer than this share of them.
const MIN_DEPTH_AGREEMENT: f64 = 0.5;

/// The relative disagreement `|model − camera| / camera` of a desk's all-on light between the
/// commissioned model and the camera-calibrated measurement (issue 28 item 5); `None` without a
/// measurement. Two estimates that disagree by `d` are each uncertain by about `d / √2` (which
/// one is right is not known from them alone): the desk's stated uncertainties take at least
/// that ([`DISAGREEMENT_TO_SIGMA`]).
pub fn model_camera_disagreement(model_lx: f64, camera_lx: f64) -> Option<f64> {
    (camera_lx.is_finite() && model_lx.is_finite() && camera_lx > 0.0)
        .then(|| (model_lx - camera_lx).abs() / camera_lx)
}

/// The standard uncertainty that a disagreement `d` between two estimates implies for each.
pub const DISAGREEMENT_TO_SIGMA: f64 = core::f64::consts::FRAC_1_SQRT_2;

/// The uncertainty to publish with a desk value (at least [`MIN_UNCERTAINTY_LX`]), or `None`
/// when the value is not a number: then it is published as not available, never as one.
pub fn stated_uncertainty_lx(art_lx: f64, day_lx: f64, unc_lx: f64) -> Option<f64> {
    (art_lx.is_finite() && day_lx.is_finite() && unc_lx.is_finite())
        .then(|| unc_lx.max(MIN_UNCERTAINTY_LX))
}

impl DeskLive {
    /// A desk whose value the node cannot estimate now: NaN (the registers' not available),
    /// flagged [`flags::NOT_ESTIMATED`].
    pub fn not_estimated(id: u32, source: Source, f: u16, frame_age_s: f64) -> DeskLive {
        DeskLive {
            id,
            total_lx: f64::NAN,
            artificial_lx: f64::NAN,
            daylight_lx: f64::NAN,
            uncertainty_lx: f64::NAN,
            source,
            flags: f | flags::NOT_ESTIMATED,
            frame_age_s,
        }
    }
}

/// The smallest stated standard uncertainty of a desk value, lx: the registers' resolution
/// (1 lx) and a class-B luxmeter's; a value is never stated exact (issue 28: 0 lx ± 0).
pub const MIN_UNCERTAINTY_LX: f64 = 1.0;

const S_VALID: u8 = 1;
const S_SATURATED: u8 = 2;
const S_OCCLUDED: u8 = 4;
const S_NO_DEPTH: u8 = 8;
/// A valid sample lit mostly by light the luminaires do not give (a window's glass by day, a
/// sun patch): more than [`OTHER_LIGHT_OVER_ARTIFICIAL`] times theirs.
const S_OTHER_LIGHT: u8 = 16;
/// See [`S_OTHER_LIGHT`]: a surface whose luminance the luminaires set at commissioning and
/// something else sets now is a light source in this frame, not the room's texture, and its
/// edges with its neighbours say nothing of the view (room_08's glazing, seen by a tilted node:
/// dark at night, 80 klx by day).
const OTHER_LIGHT_OVER_ARTIFICIAL: f64 = 3.0;

impl Live {
    /// Live light over a model, all ageing factors 1.
    pub fn new(model: LiveModel, settings: LiveSettings) -> Result<Live, LiveError> {
        settings.validate()?;
        let (s, l, n) = (model.sensors(), model.luminaires(), model.samples());
        let desks = (0..s)
            // nothing known before the first update: not available, never 0 ± 0
            .map(|k| {
                DeskLive::not_estimated(
                    model.ids[k],
                    Source::Model,
                    flags::HELD | flags::DAYLIGHT_UNKNOWN,
                    0.0,
                )
            })
            .collect();
        let n_p = model.rho.len();
        Ok(Live {
            ageing: vec![1.0; l],
            held: vec![Held::default(); s],
            changed: vec![0; n],
            b_boundary: vec![0.0; n_p],
            acc: AgeingAcc {
                g: vec![0.0; l * l],
                h: vec![0.0; l],
                frames: 0,
            },
            desks,
            report: None,
            time: None,
            sky_type: 0,
            d: vec![0.0; n],
            state: vec![0; n],
            model,
            settings,
        })
    }

    /// The time of the frames to come, for the sky fit through the room plan's unseen windows
    /// (`None`: unknown; the unknown emitters fit the daylight instead). The caller checks the
    /// clock (`crate::cli` refuses a time in the future, the daemon an unset clock).
    pub fn set_time(&mut self, t: Option<UnixTime>) {
        self.time = t;
    }

    /// Whether the image has daylight coefficients (a room plan with windows no camera sees).
    pub fn has_sky(&self) -> bool {
        self.model.sky.is_some()
    }

    /// The CIE sky type (1..=16) the last frame's fit chose; 0 when none was fitted.
    pub fn sky_type(&self) -> u8 {
        self.sky_type
    }

    /// The model.
    pub fn model(&self) -> &LiveModel {
        &self.model
    }

    /// The settings.
    pub fn settings(&self) -> &LiveSettings {
        &self.settings
    }

    /// The desks as last computed.
    pub fn desks(&self) -> &[DeskLive] {
        &self.desks
    }

    /// Bytes held between frames: the model and the state (the per-frame scratch of
    /// [`Live::update`], proportional to the samples and the seen patches, comes on top).
    pub fn memory_bytes(&self) -> usize {
        let f = 8;
        self.model.memory_bytes()
            + (self.ageing.len() + self.b_boundary.len() + self.d.len()) * f
            + self.held.len() * std::mem::size_of::<Held>()
            + self.changed.len() * 2
            + self.state.len()
            + (self.acc.g.len() + self.acc.h.len()) * f
            + self.desks.len() * std::mem::size_of::<DeskLive>()
    }

    /// What the last frame did.
    pub fn report(&self) -> Option<&FrameReport> {
        self.report.as_ref()
    }

    /// The ageing factor per luminaire (1 = as commissioned): it scales the luminaire's column
    /// of the response matrix.
    pub fn ageing(&self) -> &[f64] {
        &self.ageing
    }

    /// Sets the ageing factors (restored from a previous run). Each in (0, 2].
    pub fn set_ageing(&mut self, a: &[f64]) -> Result<(), LiveError> {
        if a.len() != self.ageing.len()
            || a.iter().any(|x| !(x.is_finite() && *x > 0.0 && *x <= 2.0))
        {
            return Err(LiveError::Input(format!(
                "ageing factors: {} values in (0, 2] needed",
                self.ageing.len()
            )));
        }
        self.ageing.copy_from_slice(a);
        Ok(())
    }

    /// Daylight per desk for the lighting control (`crate::control::regulator::Inputs`), lx:
    /// `None` when any desk's value is older than `max_age_s` (the loop then plans as if there
    /// were no daylight, the safe side) or no frame was used yet. A desk whose daylight is not
    /// known plans with what it is sure of: what its saturated window says it is at least (a
    /// desk in the sun needs no light), else none.
    pub fn daylight_for_control(&self, max_age_s: f64) -> Option<Vec<f64>> {
        let ok = self.desks.iter().all(|d| {
            d.source != Source::Model && d.frame_age_s <= max_age_s && d.flags & flags::STALE == 0
        });
        ok.then(|| {
            self.desks
                .iter()
                .zip(&self.held)
                .map(|(d, h)| finite_or(d.daylight_lx, h.floor_lx))
                .collect()
        })
    }

    fn check_levels(&self, levels: &[f64]) -> Result<(), LiveError> {
        if levels.len() != self.model.luminaires
            || levels
                .iter()
                .any(|x| !(x.is_finite() && (0.0..=1.0).contains(x)))
        {
            return Err(LiveError::Input(format!(
                "{} levels in [0, 1] needed, one per luminaire",
                self.model.luminaires
            )));
        }
        Ok(())
    }

    /// The model's artificial light at desk `s`: its commissioned response at these levels,
    /// or at an in-view desk whose response commissioning did not calibrate, the camera's
    /// stored row.
    ///
    /// A calibrated response is already the camera weighed against the model (commissioning,
    /// [`crate::live::desk_scale`]); the frame's samples then measure only the light the
    /// luminaires do not give. Taking the camera's row there repeated, every frame, the
    /// camera's own error that commissioning had weighed away: on the generalization bench,
    /// in-view desks over 3 % at night went from 31 to 14 of 200 (docs/generalization.md,
    /// eleventh measurement).
    fn artificial(&self, s: usize, levels: &[f64]) -> f64 {
        let l = self.model.luminaires;
        let m = &self.model;
        let row = if m.in_view(s) && !m.response_calibrated.get(s).copied().unwrap_or(false) {
            &m.calibrated[s * l..(s + 1) * l]
        } else {
            &m.response[s * l..(s + 1) * l]
        };
        row.iter()
            .zip(levels)
            .zip(&self.ageing)
            .map(|((r, x), a)| r * x * a)
            .sum()
    }

    fn ageing_flag(&self, s: usize) -> bool {
        let l = self.model.luminaires;
        let row = &self.model.response[s * l..(s + 1) * l];
        let total: f64 = row.iter().sum();
        total > 0.0
            && row.iter().zip(&self.ageing).any(|(r, a)| {
                *r >= self.settings.ageing_flag_share * total
                    && *a < self.settings.maintenance_factor
            })
    }

    /// No frame this time (the camera does not answer): every desk keeps its last daylight with
    /// the artificial part at the current dimming state, flagged stale once the last frame is
    /// older than [`LiveSettings::stale_after_s`].
    pub fn no_frame(&mut self, levels: &[f64], now_s: f64) -> Result<&[DeskLive], LiveError> {
        self.check_levels(levels)?;
        for s in 0..self.desks.len() {
            let age = self.held[s]
                .daylight
                .map_or(f64::INFINITY, |(_, t, _)| now_s - t);
            let extra = if age > self.settings.stale_after_s {
                flags::STALE
            } else {
                0
            };
            self.hold(s, levels, now_s, flags::HELD | extra);
        }
        Ok(&self.desks)
    }

    /// Desk `s` from its held daylight; before any frame was taken, its artificial light
    /// alone, the total and the daylight not available ([`flags::DAYLIGHT_UNKNOWN`]).
    fn hold(&mut self, s: usize, levels: &[f64], now_s: f64, f: u16) {
        let art = self.artificial(s, levels);
        let mut f = f | flags::HELD;
        if self.ageing_flag(s) {
            f |= flags::AGEING;
        }
        let Some((daylight, t, unc)) = self.held[s].daylight else {
            // no frame taken yet: the luminaires' light is known, the daylight is not (it
            // may be night or noon): published as not available, never as 0 lx
            self.desks[s] = DeskLive {
                id: self.model.ids[s],
                total_lx: f64::NAN,
                artificial_lx: finite_or(art, f64::NAN),
                daylight_lx: f64::NAN,
                uncertainty_lx: f64::NAN,
                source: Source::Model,
                flags: f | flags::NOT_ESTIMATED | flags::DAYLIGHT_UNKNOWN,
                frame_age_s: 0.0,
            };
            return;
        };
        let (age, source) = ((now_s - t).max(0.0), self.desks[s].source);
        let source = if source == Source::Model {
            Source::Inferred
        } else {
            source
        };
        let total = art + daylight;
        self.desks[s] = DeskLive {
            id: self.model.ids[s],
            total_lx: finite_or(total, art),
            artificial_lx: finite_or(art, 0.0),
            daylight_lx: finite_or(daylight, 0.0),
            uncertainty_lx: finite_or(
                unc.max(self.settings.measured_rel_uncertainty * total)
                    .max(MIN_UNCERTAINTY_LX),
                f64::NAN,
            ),
            source,
            flags: f,
            frame_age_s: if age.is_finite() { age } else { 0.0 },
        };
    }

    /// One frame: the measurement, the split, the inference, the flags. `levels`: each
    /// luminaire's output in [0, 1] at the time of the frame (from the arc levels).
    pub fn update(
        &mut self,
        frame: &LiveFrame<'_>,
        levels: &[f64],
        now_s: f64,
    ) -> Result<&[DeskLive], LiveError> {
        self.check_levels(levels)?;
        let verdict = self.check_frame(frame, now_s);
        if verdict != Verdict::Ok {
            self.reject(verdict, levels, now_s, None);
            return Ok(&self.desks);
        }
        let wa: Vec<f64> = levels
            .iter()
            .zip(&self.ageing)
            .map(|(x, a)| x * a)
            .collect();
        // 1. per sample: measured illuminance π L / ρ less the artificial part
        let counts = self.measure_samples(frame, &wa);
        let verdict = self.judge_samples(&counts, &wa, frame);
        let geometry = counts.geometry(frame.depth_mm.is_some(), &self.settings);
        if verdict != Verdict::Ok {
            self.reject(verdict, levels, now_s, Some((&counts, &geometry)));
            return Ok(&self.desks);
        }
        // 2. per seen patch: the median residual (daylight) and the artificial part
        let seen = self.seen_patches(levels);
        // 3. inference: the seen exitance propagated over the unseen patches, plus emitters
        let inferred = match self.infer(&seen) {
            Ok(inferred) => inferred,
            Err(e) => {
                // the stored system was checked at boot, so this is a broken invariant: no
                // value of this frame is published, every desk is held and flagged
                tracing::warn!("live light: the daylight propagation failed ({e}); frame dropped");
                self.reject(Verdict::Unusable, levels, now_s, None);
                return Ok(&self.desks);
            }
        };
        let Inferred {
            daylight_lx: d_inferred,
            placement_lx,
            fit_residual,
            daylight_seen_lx: daylight_seen,
            by_emitters,
            mut sun_may_reach,
            sun_unc_lx,
            sun_floor_lx,
            sun_unseen_in_beam,
        } = inferred;
        // 4. ageing: night frames accumulate the luminaires' fit
        let (night, ageing_updated) = self.ageing_step(&seen.d, &seen.w, &seen.a, daylight_seen);
        // by day under a sky that is not overcast, a desk in the sun's beam whose light no seen
        // patch tells may be in the sun
        if !night {
            for (m, u) in sun_may_reach.iter_mut().zip(&sun_unseen_in_beam) {
                *m |= *u;
            }
        }
        // 5. desks: decided with the model borrowed, applied after
        let ctx = DeskContext {
            levels,
            no_depth: geometry.no_depth,
            fit_residual,
            placement_lx: &placement_lx,
            daylight_rel: if by_emitters {
                self.settings.emitter_rel_uncertainty
            } else {
                self.settings.inferred_rel_uncertainty
            },
            taken_s: frame.taken_s,
            sun_may_reach: &sun_may_reach,
            sun_unc_lx: &sun_unc_lx,
            sun_floor_lx: &sun_floor_lx,
        };
        let actions: Vec<Action> = (0..self.model.sensors())
            .map(|s| self.desk_action(s, d_inferred.get(s).copied().unwrap_or(0.0), &ctx))
            .collect();
        // a desk whose own window changed for good cannot be measured against the model
        // any more: that alone advises recommissioning, whatever the area
        let recommission = geometry.recommission
            || actions.iter().any(|a| match a {
                Action::Set(.., f) | Action::Hold(f) | Action::Beyond(.., f) => {
                    f & flags::GEOMETRY_CHANGED != 0
                }
            });
        for (s, a) in actions.into_iter().enumerate() {
            match a {
                Action::Set(art, day, unc, source, f) => {
                    self.set_desk(s, art, day, unc, source, f, frame.taken_s, now_s);
                    self.held[s].floor_lx = 0.0;
                }
                Action::Hold(f) => self.hold(s, levels, now_s, f),
                Action::Beyond(art, floor_lx, f) => {
                    let nan = f64::NAN;
                    let src = Source::Inferred;
                    self.set_desk(s, art, nan, nan, src, f, frame.taken_s, now_s);
                    self.held[s].floor_lx = floor_lx;
                }
            }
        }
        self.report = Some(FrameReport {
            verdict: Verdict::Ok,
            samples_used: counts.used,
            samples_occluded: counts.occluded,
            changed_fraction: geometry.changed_fraction,
            recommission,
            night,
            ageing_updated,
            fit_residual,
            daylight_seen_lx: daylight_seen,
        });
        Ok(&self.desks)
    }

    /// A frame not used: every desk held at its last good daylight, flagged; the report
    /// keeps the frame's sample counts when it got that far.
    fn reject(
        &mut self,
        verdict: Verdict,
        levels: &[f64],
        now_s: f64,
        judged: Option<(&SampleCounts, &Geometry)>,
    ) {
        let f = match verdict {
            Verdict::Stale => flags::STALE,
            Verdict::Saturated => flags::BAD_FRAME | flags::SATURATED,
            _ => flags::BAD_FRAME,
        };
        for s in 0..self.desks.len() {
            self.hold(s, levels, now_s, f);
        }
        let previous = self.report.is_some_and(|r| r.recommission);
        let (counts, geometry) = match judged {
            Some((c, g)) => (*c, *g),
            None => (
                SampleCounts::default(),
                Geometry {
                    recommission: previous,
                    ..Geometry::default()
                },
            ),
        };
        self.report = Some(FrameReport {
            verdict,
            samples_used: counts.used,
            samples_occluded: counts.occluded,
            changed_fraction: geometry.changed_fraction,
            recommission: geometry.recommission,
            night: false,
            ageing_updated: false,
            fit_residual: 0.0,
            daylight_seen_lx: 0.0,
        });
    }

    /// The luminaires' part of sample `i` at the aged levels `wa`, lx.
    fn sample_artificial_lx(&self, i: usize, wa: &[f64]) -> f64 {
        let l = self.model.luminaires;
        self.model.art[i * l..(i + 1) * l]
            .iter()
            .zip(wa)
            .map(|(e, w)| f64::from(*e) * w)
            .sum()
    }

    /// Step 1: each sample's state (valid, saturated, occluded by depth, no depth) and its
    /// extraneous light `d = π g L / ρ − A`; the depth's change count per sample.
    fn measure_samples(&mut self, frame: &LiveFrame<'_>, wa: &[f64]) -> SampleCounts {
        let mut c = SampleCounts::default();
        let g = frame.cd_m2_per_unit;
        let (tol_m, tol_rel) = (
            self.settings.depth_tolerance_m,
            self.settings.depth_tolerance_rel,
        );
        for i in 0..self.model.px.len() {
            let p = self.model.px[i] as usize;
            let v = frame.luminance[p];
            let mut state = 0u8;
            match frame.depth_mm {
                Some(depth) => {
                    let (z, r) = (depth[p], self.model.depth_ref[i]);
                    c.with_ref += usize::from(r > 0);
                    if z > 0 && r > 0 {
                        c.with_depth += 1;
                        let tol = (tol_m * 1000.0).max(tol_rel * f64::from(r));
                        if (f64::from(z) - f64::from(r)).abs() > tol {
                            state |= S_OCCLUDED;
                            c.occluded += 1;
                            c.farther += usize::from(z > r);
                            self.changed[i] = self.changed[i].saturating_add(1);
                        } else {
                            self.changed[i] = 0;
                        }
                        if u32::from(self.changed[i]) >= self.settings.geometry_frames {
                            c.changed += 1;
                        }
                    }
                }
                None => state |= S_NO_DEPTH,
            }
            // 0 is a dark surface (the samples are pixels that saw one at commissioning)
            if v == u16::MAX {
                state |= S_SATURATED;
                // what the sample is at least: its light at the saturation level
                let floor = g * f64::from(u16::MAX) * self.model.pi_over_rho[i];
                self.d[i] = floor - self.sample_artificial_lx(i, wa);
            } else if state & S_OCCLUDED == 0 {
                state |= S_VALID;
                c.used += 1;
                let meas = g * f64::from(v) * self.model.pi_over_rho[i];
                let art = self.sample_artificial_lx(i, wa);
                self.d[i] = meas - art;
                if self.d[i] > OTHER_LIGHT_OVER_ARTIFICIAL * art {
                    state |= S_OTHER_LIGHT;
                }
            }
            self.state[i] = state;
        }
        c
    }

    /// The frame as a whole from its samples: too many saturated, too few usable, far
    /// darker than the luminaires alone would make it, or not a view of this room.
    fn judge_samples(&self, c: &SampleCounts, wa: &[f64], frame: &LiveFrame<'_>) -> Verdict {
        let n = self.model.px.len().max(1);
        let saturated = self.state.iter().filter(|s| **s & S_SATURATED != 0).count();
        if saturated as f64 > self.settings.frame_saturated_fraction * n as f64 {
            return Verdict::Saturated;
        }
        if (c.used as f64) < 0.1 * n as f64 {
            return Verdict::Unusable;
        }
        if c.camera_moved() {
            return Verdict::NotThisRoom;
        }
        // against the luminaires alone: the median of measured over artificial light where
        // the luminaires give well above 10 lx (daylight only adds to it)
        let mut rel: Vec<f64> = (0..self.model.px.len())
            .filter(|&i| self.state[i] & S_VALID != 0)
            .filter_map(|i| {
                let art = self.sample_artificial_lx(i, wa);
                (art > 10.0).then(|| (self.d[i] + art) / art)
            })
            .collect();
        let enough = rel.len() * 4 >= c.used;
        let below = rel
            .iter()
            .filter(|r| **r < MIN_MEASURED_OVER_ARTIFICIAL)
            .count();
        match median(&mut rel) {
            Some(r) if enough && r < 0.05 => return Verdict::Dark,
            Some(r) if enough && r < MIN_MEASURED_OVER_ARTIFICIAL => {
                return Verdict::Underexposed;
            }
            _ => {}
        }
        if enough && below as f64 > MAX_BELOW_ARTIFICIAL_SHARE * rel.len() as f64 {
            // light missing where the luminaires put it and present where they do not: the
            // view of another part of the room (a shifted frame of a room with repeated desks)
            return Verdict::NotThisRoom;
        }
        match self.edge_agreement(frame) {
            // a light source in this frame (a window's glass by day, seen by a tilted node)
            // turns its edges: the edges between surfaces the luminaires light decide, when
            // enough of them are left (noise leaves too few)
            Some((agree, _)) if agree < EDGE_MIN_AGREEMENT => {
                match self.edges_agreeing(frame, true) {
                    Some((a, _)) if a >= EDGE_MIN_AGREEMENT => Verdict::Ok,
                    _ => Verdict::NotThisRoom,
                }
            }
            _ => Verdict::Ok,
        }
    }

    /// The fraction of the commissioned luminance edges whose direction the frame repeats,
    /// over the edges with both samples valid and lit (`None` below [`EDGE_MIN_COUNT`]), and
    /// how many were counted. Illumination varies slowly between neighbours a few
    /// centimetres apart and the surfaces' reflectance does not change, so a view of this
    /// room keeps its edges whatever the daylight; another view keeps half by chance.
    pub fn edge_agreement(&self, frame: &LiveFrame<'_>) -> Option<(f64, usize)> {
        self.edges_agreeing(frame, false)
    }

    /// [`Self::edge_agreement`], leaving out the edges of samples lit mostly by other light
    /// ([`S_OTHER_LIGHT`]) when `skip_other_light`.
    fn edges_agreeing(
        &self,
        frame: &LiveFrame<'_>,
        skip_other_light: bool,
    ) -> Option<(f64, usize)> {
        let (mut agree, mut count) = (0usize, 0usize);
        for &(i, j, ln_ref) in &self.model.edges {
            let (i, j) = (i as usize, j as usize);
            if self.state[i] & self.state[j] & S_VALID == 0
                || (skip_other_light && (self.state[i] | self.state[j]) & S_OTHER_LIGHT != 0)
            {
                continue;
            }
            let (a, b) = (
                frame.luminance[self.model.px[i] as usize],
                frame.luminance[self.model.px[j] as usize],
            );
            if a == 0 || b == 0 || a == b {
                continue;
            }
            count += 1;
            agree += usize::from((a > b) == (ln_ref > 0.0));
        }
        (count >= EDGE_MIN_COUNT).then(|| (agree as f64 / count as f64, count))
    }

    /// Step 2: per seen patch, the median extraneous light of its valid samples, its weight
    /// (their count, at most 64) and the mean artificial light per luminaire at `levels`. A
    /// saturated sample counts at its floor (its light at the saturation level): a sun patch
    /// the camera sees saturated is at least that bright, not dark.
    fn seen_patches(&self, levels: &[f64]) -> SeenPatches {
        let m = &self.model;
        let (l, n_seen) = (m.luminaires, m.seen.len());
        let mut out = SeenPatches {
            d: vec![0.0; n_seen],
            w: vec![0.0; n_seen],
            a: vec![0.0; n_seen * l],
            sat: vec![false; n_seen],
        };
        let mut buf = Vec::new();
        for (r, &(a, b)) in m.seen_range.iter().enumerate() {
            buf.clear();
            let mut cnt = 0.0f64;
            for i in a as usize..b as usize {
                let stt = self.state[i];
                if stt & S_VALID != 0 || (stt & S_SATURATED != 0 && stt & S_OCCLUDED == 0) {
                    out.sat[r] |= stt & S_VALID == 0;
                    buf.push(self.d[i]);
                    let art = m.art[i * l..(i + 1) * l].iter().zip(levels);
                    for (o, (e, x)) in out.a[r * l..(r + 1) * l].iter_mut().zip(art) {
                        *o += f64::from(*e) * x;
                    }
                    cnt += 1.0;
                }
            }
            if let Some(med) = median(&mut buf) {
                out.d[r] = med;
                out.w[r] = cnt.min(64.0);
                out.a[r * l..(r + 1) * l].iter_mut().for_each(|o| *o /= cnt);
            }
        }
        out
    }

    /// Step 5, one desk: out of view (the model's light and the inferred daylight), covered
    /// or saturated (held, or inferred once the hold is stale), or measured over its window.
    fn desk_action(&self, s: usize, inferred_lx: f64, ctx: &DeskContext<'_>) -> Action {
        let st = &self.settings;
        let mut extra = 0u16;
        if ctx.no_depth {
            extra |= flags::NO_DEPTH;
        }
        if self.ageing_flag(s) {
            extra |= flags::AGEING;
        }
        let art = self.artificial(s, ctx.levels);
        let model_rel =
            self.model
                .model_rel_uncertainty_at(s, ctx.levels, st.model_rel_uncertainty);
        let day = inferred_lx.max(0.0);
        let placement = ctx.placement_lx.get(s).copied().unwrap_or(0.0);
        if self.model.windows[s].sample.is_empty() {
            if ctx.sun_may_reach.get(s).copied().unwrap_or(false) {
                // a sun patch nobody sees may lie on it: tens of klx the diffuse sky's
                // coefficients do not give; at least what the sun's bound says
                let f = extra | flags::SUN_MAY_REACH;
                return match ctx.sun_floor_lx.get(s).copied().filter(|f| *f > 0.0) {
                    Some(floor) => Action::Beyond(art, floor, f | flags::DAYLIGHT_UNKNOWN),
                    None => Action::daylight_unknown(art, f),
                };
            }
            // out of view: the model's light and the inferred daylight
            let sun_unc = ctx.sun_unc_lx.get(s).copied().unwrap_or(0.0);
            let unc = ((ctx.daylight_rel * day).powi(2)
                + (ctx.fit_residual * day).powi(2)
                + placement.powi(2)
                + sun_unc.powi(2)
                + (model_rel * art).powi(2))
            .sqrt();
            return self.inferred(art, day, unc, extra);
        }
        let w = self.window_state(s, ctx);
        if w.changed {
            extra |= flags::GEOMETRY_CHANGED;
        }
        if w.covered || w.saturated {
            let f = extra
                | if w.saturated { flags::SATURATED } else { 0 }
                | if w.covered { flags::OCCLUDED } else { 0 };
            // a saturated window is at least this bright: a value below that contradicts the
            // camera (a desk in the sun the model does not put there) and is not published
            let floor_day = if w.saturated && !w.covered {
                let floor = [&w.values[..], &w.saturated_at_floor[..]].concat();
                weighted_median(&mut self.model.extraneous_at_desk(s, &floor))
            } else {
                None
            };
            let below_floor = |day_lx: f64| floor_day.is_some_and(|f| day_lx < f);
            // held while the last good value is fresh (a person leaning over the desk);
            // covered for longer (a box left on it, a desk moved away), the inferred
            // daylight is the better value, as for a desk out of view
            let held = self.held[s]
                .daylight
                .filter(|(_, t, _)| ctx.taken_s - t <= st.stale_after_s);
            if held.is_some_and(|(d, _, _)| !below_floor(d)) {
                return Action::Hold(f);
            }
            if ctx.sun_may_reach.get(s).copied().unwrap_or(false) {
                // the sun may be on it, by a strength the node cannot tell
                let sun_floor = ctx.sun_floor_lx.get(s).copied().unwrap_or(0.0);
                let floor_lx = floor_day.unwrap_or(0.0).max(sun_floor);
                let f = f | flags::SUN_MAY_REACH;
                return if floor_lx > 0.0 {
                    Action::Beyond(art, floor_lx, f | flags::DAYLIGHT_UNKNOWN)
                } else {
                    Action::daylight_unknown(art, f)
                };
            }
            if let Some(floor_lx) = floor_day.filter(|f| day < *f) {
                return Action::Beyond(art, floor_lx, f | flags::DAYLIGHT_UNKNOWN);
            }
            let sun_unc = ctx.sun_unc_lx.get(s).copied().unwrap_or(0.0);
            let unc = ((ctx.daylight_rel * day).powi(2)
                + placement.powi(2)
                + sun_unc.powi(2)
                + (model_rel * art).powi(2))
            .sqrt();
            return self.inferred(art, day, unc, f);
        }
        // the weighted median residual of the window; spread for the uncertainty
        let values = self.model.extraneous_at_desk(s, &w.values);
        let mut v2 = values.clone();
        let dm = weighted_median(&mut v2).unwrap_or(0.0);
        let mut dev: Vec<f64> = values.iter().map(|(x, _)| (x - dm).abs()).collect();
        let mad = median(&mut dev).unwrap_or(0.0) * 1.4826;
        let n_eff = values.len() as f64;
        let total = art + dm;
        let day = dm.max(0.0);
        // the measurement's own spread, and at least what its disagreement with the model says
        // (the stored model uncertainty of an in-view desk holds the model's disagreement with
        // the camera before calibration: a desk hard for the model is hard for the camera too)
        let rel = st
            .measured_rel_uncertainty
            .max(DISAGREEMENT_TO_SIGMA * self.model.disagreement(s))
            .max(self.model.model_rel_uncertainty(s, 0.0));
        let unc = ((1.2533 * mad / n_eff.sqrt()).powi(2) + (rel * total).powi(2)).sqrt();
        Action::Set(total - day, day, unc, Source::Measured, extra)
    }

    /// An inferred desk value, or, when its stated uncertainty is beyond
    /// [`LiveSettings::unknown_above_rel_uncertainty`], its artificial part alone with the
    /// total and the daylight not available ([`flags::DAYLIGHT_UNKNOWN`]).
    fn inferred(&self, art: f64, day: f64, unc: f64, f: u16) -> Action {
        let total = art + day;
        if unc > self.settings.unknown_above_rel_uncertainty * total {
            return Action::daylight_unknown(art, f);
        }
        Action::Set(art, day, unc, Source::Inferred, f)
    }

    /// Desk `s`'s window in this frame: its valid samples' (extraneous light, weight), and
    /// whether it is covered (by depth, or by darkness without depth), saturated or changed.
    fn window_state(&self, s: usize, ctx: &DeskContext<'_>) -> WindowState {
        let st = &self.settings;
        let (m, l) = (&self.model, self.model.luminaires);
        let w = &m.windows[s];
        let (mut n_occ, mut n_sat, mut n_chg, mut n_dark) = (0usize, 0usize, 0usize, 0usize);
        let mut values: Vec<Sample> = Vec::with_capacity(w.sample.len());
        let mut saturated_at_floor: Vec<Sample> = Vec::new();
        for (&i, &wt) in w.sample.iter().zip(&w.weight) {
            let i = i as usize;
            let stt = self.state[i];
            n_occ += usize::from(stt & S_OCCLUDED != 0);
            n_sat += usize::from(stt & S_SATURATED != 0);
            n_chg += usize::from(u32::from(self.changed[i]) >= st.geometry_frames);
            if stt & (S_VALID | S_SATURATED) == 0 || stt & S_OCCLUDED != 0 {
                continue;
            }
            // at these levels, and every luminaire at 100 % (for the share)
            let (art, all_on) = m.art[i * l..(i + 1) * l]
                .iter()
                .zip(ctx.levels.iter().zip(&self.ageing))
                .fold((0.0, 0.0), |(a_lx, on_lx), (e, (x, a))| {
                    let e = f64::from(*e);
                    (a_lx + e * x * a, on_lx + e)
                });
            let sample = Sample {
                extraneous_lx: self.d[i],
                all_on_lx: all_on,
                weight: wt,
            };
            if stt & S_VALID != 0 {
                if self.d[i] < -(0.3 * art + 5.0) {
                    n_dark += 1;
                }
                values.push(sample);
            } else {
                saturated_at_floor.push(sample);
            }
        }
        let total_w = w.sample.len() as f64;
        let covered_depth = n_occ as f64 > st.occluded_fraction * total_w;
        // without depth: most of the window far darker than the luminaires make it
        let covered_light = ctx.no_depth && n_dark as f64 > 0.5 * values.len().max(1) as f64;
        let saturated = n_sat as f64 > st.window_saturated_fraction * total_w;
        WindowState {
            // too few valid samples: covered, unless saturation took them
            covered: covered_depth || covered_light || (values.len() < 3 && !saturated),
            saturated,
            changed: n_chg as f64 > 0.5 * total_w,
            values,
            saturated_at_floor,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn set_desk(
        &mut self,
        s: usize,
        art: f64,
        day: f64,
        unc: f64,
        source: Source,
        f: u16,
        taken_s: f64,
        now_s: f64,
    ) {
        let age_s = finite_or((now_s - taken_s).max(0.0), 0.0);
        let Some(unc) = stated_uncertainty_lx(art, day, unc) else {
            let mut d = DeskLive::not_estimated(self.model.ids[s], source, f, age_s);
            if f & flags::DAYLIGHT_UNKNOWN != 0 {
                // the luminaires' part is known; the daylight and so the total are not
                d.artificial_lx = art;
            }
            self.desks[s] = d;
            return;
        };
        // a held value is not new, and a covered desk's inferred one is not its own
        if f & (flags::HELD | flags::OCCLUDED) == 0 {
            self.held[s].daylight = Some((day, taken_s, unc));
        }
        self.desks[s] = DeskLive {
            id: self.model.ids[s],
            total_lx: art + day,
            artificial_lx: art,
            daylight_lx: day,
            uncertainty_lx: unc,
            source,
            flags: f,
            frame_age_s: finite_or((now_s - taken_s).max(0.0), 0.0),
        };
    }

    fn check_frame(&self, f: &LiveFrame<'_>, now_s: f64) -> Verdict {
        let (w, h) = self.model.frame_size();
        let n = (w as usize) * (h as usize);
        if f.width != w
            || f.height != h
            || f.luminance.len() != n
            || f.depth_mm.is_some_and(|d| d.len() != n)
            || !(f.cd_m2_per_unit.is_finite() && f.cd_m2_per_unit > 0.0)
        {
            return Verdict::WrongSize;
        }
        if !(f.taken_s.is_finite() && now_s - f.taken_s <= self.settings.stale_after_s) {
            return Verdict::Stale;
        }
        Verdict::Ok
    }

    /// Daylight at every sensor from the seen residuals: the seen surfaces' measured exitance
    /// `ρ D` propagated over the unseen patches (Gauss-Seidel, warm), plus unknown emitters
    /// fitted to what that leaves unexplained on the seen surfaces (robust NNLS). Returns
    /// (daylight per sensor, relative RMS residual, mean fitted daylight on the seen surfaces).
    fn infer(&mut self, seen: &SeenPatches) -> Result<Inferred, SolveError> {
        let (d_seen, w_seen) = (&seen.d[..], &seen.w[..]);
        let m = &self.model;
        let (k, n_seen, s_count) = (m.k, m.seen.len(), m.sensors());
        // the sky through the plan's windows when the image has its coefficients and the time
        // is known; else the unknown emitters
        let bases = match (&m.sky, self.time) {
            (Some(sky), Some(t)) => sky.bases(t).filter(|b| !b.is_empty()).map(|b| (sky, b)),
            _ => None,
        };
        // a window's glass the camera sees: its light is in the sky's coefficients, and its
        // luminance (the ground's, seen through it from the ceiling) is not what it lets in
        let glass = |r: usize| bases.as_ref().is_some_and(|(sky, _)| sky.glazing(r));
        let is_glass: Vec<bool> = (0..n_seen).map(glass).collect();
        // the sun's beam through the plan's windows at this time (a version-3 image)
        let sun = (m.sky.as_ref().zip(self.time)).and_then(|(sky, t)| sky.sun(t, n_seen));
        let (c, from_seen) = propagate_seen(m, &mut self.b_boundary, seen, &is_glass)?;
        // emitters: y = D − c ≈ V w, weighted, twice (the second without outliers: sun patches)
        let mut w_use: Vec<f64> = (0..n_seen)
            .map(|r| if glass(r) { 0.0 } else { w_seen[r] })
            .collect();
        let y: Vec<f64> = (0..n_seen).map(|r| d_seen[r] - c[r]).collect();
        let (sun_rows, sun_up) = exclude_sun_patches(&y, &mut w_use, &m.seen_up);
        // the sun shines into the room (the camera sees its patches): the desks out of view
        // that see the sun's sky patch through a window may be in one, which the sky's
        // coefficients (diffuse light) do not give
        let views = match (&bases, self.time) {
            (Some((sky, _)), Some(t)) if sun_rows > 0 => sky.sun_views(t),
            _ => None,
        };
        let mut sun_may_reach: Vec<bool> = (0..s_count)
            .map(|s| {
                sun.is_none()
                    && views
                        .as_ref()
                        .and_then(|v| v.get(s))
                        .is_some_and(|v| *v >= SUN_VIEW_MIN)
            })
            .collect();
        let (x, resid, w_use, chosen, gram) = match bases {
            Some((sky, mut bases)) => {
                // the fit over the seen rows whose coefficients the image stores
                for (r, w) in w_use.iter_mut().enumerate() {
                    if !sky.stored(r) {
                        *w = 0.0;
                    }
                }
                let (best, x, resid, w) = best_sky(&bases, &y, &w_use, d_seen);
                let b = bases.swap_remove(best);
                (x, resid, w, Some(b), Vec::new())
            }
            _ => {
                let mut w = w_use;
                let f = robust_fit(&m.v_seen, k, &y, &mut w);
                (f.x, f.resid, w, None, f.gram)
            }
        };
        self.sky_type = chosen.as_ref().map_or(0, |b| b.sky_type);
        let (v_basis, g_basis, k): (&[f64], &[f64], usize) = match &chosen {
            Some(b) => (&b.seen_lx, &b.sensor_lx, 1),
            None => (&m.v_seen, &m.g_sensor, k),
        };
        let (mut num, mut den, mut sw, mut fitted) = (0.0, 0.0, 0.0, 0.0);
        for r in 0..n_seen {
            let wr = w_use[r];
            if wr > 0.0 {
                num += wr * resid[r] * resid[r];
                den += wr * d_seen[r].max(1.0).powi(2);
                sw += wr;
                fitted += wr * (c[r] + (0..k).map(|q| v_basis[r * k + q] * x[q]).sum::<f64>());
            }
        }
        let rel = if den > 0.0 { (num / den).sqrt() } else { 0.0 };
        let mut out: Vec<f64> = (0..s_count)
            .map(|s| {
                let e: f64 = (0..k).map(|q| g_basis[s * k + q] * x[q]).sum();
                finite_or(from_seen[s] + e, 0.0)
            })
            .collect();
        // without the sky (no plan): the desks as near the windows as a seen sun patch (the
        // fit's diffuse light wanted only at the sun patches, and only when there are some)
        if chosen.is_none() && sun_up.len() >= super::sun_fit::SUN_MIN_PATCHES {
            let mut diffuse = vec![f64::NAN; n_seen];
            for &r in &sun_up {
                diffuse[r] = c[r] + (0..k).map(|q| v_basis[r * k + q] * x[q]).sum::<f64>();
            }
            let reach = sun_reach_without_plan(&sun_up, &diffuse, &out);
            for (m, r) in sun_may_reach.iter_mut().zip(reach) {
                *m |= r;
            }
        }
        // the sun: its strength from the seen patches in its beam, its light at every desk
        let sun_out = match (&sun, &chosen) {
            (Some(sun), Some(b)) => SunStage {
                sun,
                sky: (b, x.first().copied().unwrap_or(0.0)),
                seen,
                y: &y,
                incident: &c,
                is_glass: &is_glass,
                from_seen: &from_seen,
                sun_rows,
            }
            .apply(&mut out, &mut sun_may_reach),
            _ => SunOutcome::none(s_count),
        };
        // without the sky: where the emitters are is known only as well as the seen surfaces
        // tell them apart
        let placement_lx = if chosen.is_none() {
            let fit = EmitterFit {
                gram: &gram,
                g: g_basis,
                k,
                resid: &resid,
                w: &w_use,
            };
            placement_lx(&fit, s_count)
        } else {
            vec![0.0; s_count]
        };
        Ok(Inferred {
            daylight_lx: out,
            placement_lx,
            fit_residual: finite_or(rel, 0.0),
            daylight_seen_lx: if sw > 0.0 { fitted / sw } else { 0.0 },
            by_emitters: chosen.is_none(),
            sun_may_reach,
            sun_unc_lx: sun_out.unc_lx,
            sun_floor_lx: sun_out.floor_lx,
            sun_unseen_in_beam: sun_out.unseen_in_beam,
        })
    }

    /// The night test and the ageing fit. A frame is night when both fits of the unknown
    /// emitters give them less than [`LiveSettings::night_fraction`] of the measured light on
    /// the seen surfaces: the joint fit of the luminaires (one factor each) and the emitters,
    /// and the emitters' fit at the current factors (`daylight_seen_lx`, from
    /// [`Live::infer`]). The joint fit alone takes a window's light for luminaires brighter than
    /// modelled (the two are nearly collinear on the seen surfaces: 15 % daylight was taken for
    /// night); the fit at the current factors alone would take a luminaire brighter than its
    /// factor (a new lamp) for daylight. Night frames accumulate the
    /// luminaires' fit; after [`LiveSettings::ageing_min_frames`] of them, the first day frame
    /// (or [`LiveSettings::ageing_max_frames`]) sets the ageing factors. Returns (night, updated).
    fn ageing_step(
        &mut self,
        d_seen: &[f64],
        w_seen: &[f64],
        a_seen: &[f64],
        daylight_seen_lx: f64,
    ) -> (bool, bool) {
        let l = self.model.luminaires;
        let n_seen = self.model.seen.len();
        // measured light per seen patch: the residual plus the artificial part at the current
        // ageing
        let meas: Vec<f64> = (0..n_seen)
            .map(|r| {
                d_seen[r]
                    + (0..l)
                        .map(|j| a_seen[r * l + j] * self.ageing[j])
                        .sum::<f64>()
            })
            .collect();
        let signal: f64 = (0..n_seen).map(|r| w_seen[r] * meas[r].max(0.0)).sum();
        let positive: f64 = (0..n_seen).map(|r| w_seen[r] * d_seen[r].max(0.0)).sum();
        let weight: f64 = w_seen.iter().sum();
        let mean_measured = if weight > 0.0 { signal / weight } else { 0.0 };
        let mut night = false;
        if signal > 0.0
            && positive <= 0.25 * signal
            && daylight_seen_lx <= self.settings.night_fraction * mean_measured
        {
            // a candidate: fit luminaires and emitters together
            let k = self.model.k;
            let u = &self.model.u_seen;
            let nv = l + k;
            let mut g = vec![0.0; nv * nv];
            let mut h = vec![0.0; nv];
            let col = |r: usize, c: usize| -> f64 {
                if c < l {
                    a_seen[r * l + c]
                } else {
                    u[r * k + (c - l)]
                }
            };
            for r in 0..n_seen {
                let wr = w_seen[r];
                if wr <= 0.0 {
                    continue;
                }
                for a in 0..nv {
                    let ca = col(r, a);
                    if ca == 0.0 {
                        continue;
                    }
                    h[a] += wr * ca * meas[r];
                    for b in 0..nv {
                        g[a * nv + b] += wr * ca * col(r, b);
                    }
                }
            }
            let x = nnls_gram(&g, &h, nv);
            let extraneous: f64 = (0..n_seen)
                .map(|r| w_seen[r] * (0..k).map(|q| u[r * k + q] * x[l + q]).sum::<f64>())
                .sum();
            night = extraneous <= self.settings.night_fraction * signal;
        }
        if night {
            for r in 0..n_seen {
                let wr = w_seen[r];
                if wr <= 0.0 {
                    continue;
                }
                for a in 0..l {
                    self.acc.h[a] += wr * a_seen[r * l + a] * meas[r];
                    for b in 0..l {
                        self.acc.g[a * l + b] += wr * a_seen[r * l + a] * a_seen[r * l + b];
                    }
                }
            }
            self.acc.frames += 1;
        }
        let enough = self.acc.frames >= self.settings.ageing_min_frames;
        let commit = enough && (!night || self.acc.frames >= self.settings.ageing_max_frames);
        let mut updated = false;
        if commit {
            let alpha = nnls_gram(&self.acc.g, &self.acc.h, l);
            let max_diag = (0..l).map(|j| self.acc.g[j * l + j]).fold(0.0f64, f64::max);
            for (j, &a) in alpha.iter().enumerate() {
                // a luminaire that lit the seen surfaces enough during the night
                if self.acc.g[j * l + j] >= 1e-3 * max_diag
                    && a.is_finite()
                    && (0.2..=1.5).contains(&a)
                {
                    self.ageing[j] = a;
                    updated = true;
                }
            }
            self.acc = AgeingAcc {
                g: vec![0.0; l * l],
                h: vec![0.0; l],
                frames: 0,
            };
            if updated {
                tracing::info!(
                    "live: ageing factors updated after a night: {}",
                    self.ageing
                        .iter()
                        .map(|a| format!("{a:.3}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
        (night, updated)
    }
}

/// What to do with a desk after a frame.
/// What the samples of one frame came to.
#[derive(Debug, Clone, Copy, Default)]
struct SampleCounts {
    used: usize,
    occluded: usize,
    /// Of the occluded, those farther than the room (nobody stands behind a wall).
    farther: usize,
    with_depth: usize,
    with_ref: usize,
    changed: usize,
}

/// The room's geometry as one frame's depth tells it.
#[derive(Debug, Clone, Copy, Default)]
struct Geometry {
    /// No depth frame, or one with a return on under a tenth of the samples.
    no_depth: bool,
    /// Samples changed for good, over those with depth.
    changed_fraction: f64,
    /// More of the room changed than [`LiveSettings::geometry_area_fraction`].
    recommission: bool,
}

impl SampleCounts {
    /// The depth says the camera moved (occupancy's rule, `crate::occupancy`): more than
    /// [`MOVED_FARTHER_SHARE`] of the samples with depth farther than the room (people only
    /// come nearer), or fewer than [`MIN_DEPTH_AGREEMENT`] of them where the room was.
    fn camera_moved(&self) -> bool {
        let with = self.with_depth as f64;
        self.with_depth > 0
            && self.with_depth * 10 >= self.with_ref
            && (self.farther as f64 > MOVED_FARTHER_SHARE * with
                || ((self.with_depth - self.occluded) as f64) < MIN_DEPTH_AGREEMENT * with)
    }

    fn geometry(&self, has_depth: bool, st: &LiveSettings) -> Geometry {
        // a depth frame with a return on under a tenth of the samples (a dead or blinded ToF)
        // is judged like no depth frame
        let no_depth = !has_depth || self.with_depth * 10 < self.with_ref;
        let changed_fraction = if self.with_depth > 0 {
            self.changed as f64 / self.with_depth as f64
        } else {
            0.0
        };
        Geometry {
            no_depth,
            changed_fraction,
            recommission: changed_fraction > st.geometry_area_fraction,
        }
    }
}

/// Per seen patch (the model's seen order): median extraneous light, weight, and artificial
/// light per luminaire (`[patch][luminaire]`).
struct SeenPatches {
    d: Vec<f64>,
    w: Vec<f64>,
    a: Vec<f64>,
    /// Some of the patch's samples saturated: its light is a lower bound.
    sat: Vec<bool>,
}

/// What every desk of one frame shares.
/// What [`Live::infer`] found in a frame.
struct Inferred {
    /// Per sensor, the inferred daylight, lx.
    daylight_lx: Vec<f64>,
    /// Per sensor, its standard uncertainty from where the emitters may be, lx.
    placement_lx: Vec<f64>,
    /// The fit's relative residual on the seen surfaces.
    fit_residual: f64,
    /// The fitted daylight on the seen surfaces (weighted mean), lx.
    daylight_seen_lx: f64,
    /// The unknown emitters gave the daylight (no sky fit).
    by_emitters: bool,
    /// Per sensor: the sun shines into the room and may reach it, by a strength the node
    /// cannot tell ([`SUN_VIEW_MIN`], or the sun's grid with its strength bounded only).
    sun_may_reach: Vec<bool>,
    /// Per sensor, the standard uncertainty of the sun's part of its daylight, lx.
    sun_unc_lx: Vec<f64>,
    /// Per sensor, its daylight's lower bound where the sun may reach it, lx (0: none).
    sun_floor_lx: Vec<f64>,
    /// Per sensor: in the sun's beam, with no seen patch in the beam to tell whether the sun
    /// shines, under a fitted sky that is not overcast (taken as [`Self::sun_may_reach`] by
    /// day).
    sun_unseen_in_beam: Vec<bool>,
}

struct DeskContext<'a> {
    levels: &'a [f64],
    no_depth: bool,
    fit_residual: f64,
    /// Per sensor, the standard uncertainty of its inferred daylight from where the
    /// emitters may be ([`placement_lx`]; 0 with the sky fit), lx.
    placement_lx: &'a [f64],
    /// The inferred daylight's relative standard uncertainty: the sky fit's or the unknown
    /// emitters' ([`LiveSettings`]).
    daylight_rel: f64,
    taken_s: f64,
    /// Per sensor: the sun may reach it where no camera sees ([`Inferred::sun_may_reach`]).
    sun_may_reach: &'a [bool],
    /// Per sensor, the standard uncertainty of its sun part ([`Inferred::sun_unc_lx`]).
    sun_unc_lx: &'a [f64],
    /// Per sensor, its daylight's lower bound where the sun may reach it, lx (0: none).
    sun_floor_lx: &'a [f64],
}

/// A desk's window in one frame.
struct WindowState {
    covered: bool,
    saturated: bool,
    changed: bool,
    /// The valid samples.
    values: Vec<Sample>,
    /// The saturated samples at their saturation level: with the valid ones, the window's
    /// light is at least what they say.
    saturated_at_floor: Vec<Sample>,
}

/// One valid sample of a desk's window in a frame.
#[derive(Debug, Clone, Copy)]
struct Sample {
    /// Its extraneous light `D(p)`, lx (in the camera's units: through the pixel's patch
    /// reflectance).
    extraneous_lx: f64,
    /// Its luminaires' light at 100 % `Σ_l E_l(p)`, lx (through the same reflectance).
    all_on_lx: f64,
    /// Its Gaussian weight in the window.
    weight: f64,
}

enum Action {
    /// (artificial, daylight, uncertainty, source, flags).
    Set(f64, f64, f64, Source, u16),
    /// Keep the last good daylight, with these flags.
    Hold(u16),
    /// Daylight not available, at least this much (a saturated window): (artificial, the
    /// floor, flags).
    Beyond(f64, f64, u16),
}

impl Action {
    /// The artificial part alone: the daylight and the total not available, flagged.
    fn daylight_unknown(art: f64, f: u16) -> Action {
        let nan = f64::NAN;
        Action::Set(art, nan, nan, Source::Inferred, f | flags::DAYLIGHT_UNKNOWN)
    }
}

/// Step 3b, the sun through the plan's windows: its beam at this time and what the sky's fit
/// left on the seen patches.
struct SunStage<'a> {
    sun: &'a SunBasis,
    /// The fitted sky's basis and its scale.
    sky: (&'a SkyBasis, f64),
    seen: &'a SeenPatches,
    /// Per seen patch, its daylight beyond the seen exitance's reflections, lx.
    y: &'a [f64],
    /// Per seen patch, the seen exitance's reflections on it, lx.
    incident: &'a [f64],
    is_glass: &'a [bool],
    /// Per sensor, the seen surfaces' measured light propagated to it, lx.
    from_seen: &'a [f64],
    /// Seen patches far brighter than the rest (sun patches).
    sun_rows: usize,
}

/// What step 3b gives each desk.
struct SunOutcome {
    unc_lx: Vec<f64>,
    floor_lx: Vec<f64>,
    unseen_in_beam: Vec<bool>,
}

impl SunOutcome {
    fn none(sensors: usize) -> Self {
        Self {
            unc_lx: vec![0.0; sensors],
            floor_lx: vec![0.0; sensors],
            unseen_in_beam: vec![false; sensors],
        }
    }
}

impl SunStage<'_> {
    /// The sun's strength from the seen patches in its beam ([`fit_sun`]).
    fn fit(&self) -> Option<SunFit> {
        let (b, scale) = self.sky;
        let (sun, seen) = (self.sun, self.seen);
        let rows = (0..seen.w.len()).filter(|&r| seen.w[r] > 0.0 && !self.is_glass[r]);
        fit_sun(rows.map(|r| SeenSun {
            beyond_sky_lx: self.y[r] - b.seen_lx[r] * scale,
            sky_lx: self.incident[r] + b.seen_lx[r] * scale,
            coefficient: sun.seen_lx[r],
            coefficient_min: sun.seen_min_lx[r],
            saturated: seen.sat[r],
        }))
    }

    /// Adds the fitted sun to the daylight of each desk in its beam, with its uncertainty (the
    /// fit's, and a sun patch's edge between the grid's positions); a desk out of the beam gets
    /// its reflected share as uncertainty only. With the sun's strength bounded only, a desk in
    /// the beam is not published (at least its bound's light); with no seen patch in the beam,
    /// a desk in it is not published when the camera sees sun elsewhere, and is marked for the
    /// day rule ([`SunOutcome::unseen_in_beam`]) under a sky that is not overcast; under clouds
    /// (the sun not standing out), no desk gets sun, each the fit's doubt.
    fn apply(&self, out: &mut [f64], may_reach: &mut [bool]) -> SunOutcome {
        let fit = self.fit();
        tracing::debug!(
            "live: the sun's fit {fit:?}, {} seen patches in sun",
            self.sun_rows
        );
        let overcast = OVERCAST_SKIES.contains(&self.sky.0.sky_type);
        let sun = self.sun;
        let mut o = SunOutcome::none(out.len());
        for s in 0..out.len() {
            let (c, lo, hi) = (sun.sensor_lx[s], sun.sensor_min_lx[s], sun.sensor_max_lx[s]);
            // in the beam at the sun's blend of the grid's positions (half lit: on a patch's
            // edge between them)
            let in_beam = c >= 0.5 * SUN_LIT;
            let Some(f) = fit else {
                may_reach[s] = self.sun_rows > 0 && in_beam;
                o.unseen_in_beam[s] = in_beam && !overcast;
                continue;
            };
            let e = f.e_dn_lx;
            let edge = 0.5 * (hi - lo) * e;
            if !f.present {
                // under clouds: no sun, as much doubt as the sky's residual allows
                o.unc_lx[s] = edge.hypot(c * e);
            } else if f.bounded_only && in_beam {
                // at least the bound's light: the desk's daylight is beyond what is known
                may_reach[s] = true;
                o.floor_lx[s] = self.from_seen.get(s).copied().unwrap_or(0.0) + lo * e;
            } else if !in_beam {
                // the sun's light reflected off what no camera sees: the sky's fit has taken
                // most of it already (the seen surfaces get it too, and the stored sky is all
                // the fit has to explain them), so it is a doubt, not an addition
                o.unc_lx[s] = edge.hypot(c * e);
            } else {
                out[s] += c * e;
                o.unc_lx[s] = edge.hypot(f.rel * c * e);
            }
        }
        o
    }
}

fn finite_or(x: f64, fallback: f64) -> f64 {
    if x.is_finite() { x } else { fallback }
}

/// One sky's fit: its index, scale, residuals and weights.
struct SkyFitResult {
    index: usize,
    x: Vec<f64>,
    resid: Vec<f64>,
    w: Vec<f64>,
}

/// The sky whose basis explains the seen daylight best (least weighted residual over every
/// seen patch after the robust fit of its scale). Returns (its index, its scale, residuals,
/// weights).
fn best_sky(
    bases: &[SkyBasis],
    y: &[f64],
    w0: &[f64],
    d_seen: &[f64],
) -> (usize, Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut best: Option<(f64, SkyFitResult)> = None;
    for (index, b) in bases.iter().enumerate() {
        let mut w = w0.to_vec();
        let f = robust_fit(&b.seen_lx, 1, y, &mut w);
        let (x, resid) = (f.x, f.resid);
        let (mut num, mut den) = (0.0, 0.0);
        for r in 0..y.len() {
            if w0[r] > 0.0 {
                // every seen patch counts in the comparison (not only each fit's inliers)
                num += w0[r] * resid[r] * resid[r];
                den += w0[r] * d_seen[r].max(1.0).powi(2);
            }
        }
        let score = if den > 0.0 { num / den } else { f64::INFINITY };
        if best.as_ref().is_none_or(|(s, _)| score < *s) {
            best = Some((score, SkyFitResult { index, x, resid, w }));
        }
    }
    match best {
        Some((_, f)) => (f.index, f.x, f.resid, f.w),
        None => (0, vec![0.0], vec![0.0; y.len()], w0.to_vec()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without a plan: the seen sun patches on upward faces lie where the fit's diffuse
    /// daylight is 250 and 300 lx; a desk with at least 250 lx of diffuse daylight is as near
    /// the windows as one of them, a desk with less is farther in. One sun patch (a glint) or
    /// none: no desk. A non-finite diffuse value is not a threshold.
    #[test]
    fn the_sun_may_reach_the_desks_as_near_the_windows_as_a_seen_sun_patch() {
        let diffuse = [100.0, 300.0, 250.0, f64::NAN];
        let desks = [240.0, 250.0, 900.0];
        assert_eq!(
            sun_reach_without_plan(&[1, 2], &diffuse, &desks),
            [false, true, true]
        );
        assert_eq!(
            sun_reach_without_plan(&[1, 2, 3], &diffuse, &desks),
            [false, true, true]
        );
        assert_eq!(sun_reach_without_plan(&[2], &diffuse, &desks), [false; 3]);
        assert_eq!(sun_reach_without_plan(&[], &diffuse, &desks), [false; 3]);
        assert_eq!(
            sun_reach_without_plan(&[3, 3], &diffuse, &desks),
            [false; 3]
        );
        // a patch beyond the seen rows (a malformed list) is no threshold either
        assert_eq!(
            sun_reach_without_plan(&[9, 9], &diffuse, &desks),
            [false; 3]
        );
    }

    /// The weighted rows' median is about 100 lx: rows above 8 times it leave the fit; those
    /// above 2.5 klx are sun (a hazy day's 3 klx too), and of them the upward ones are listed.
    #[test]
    fn sun_patches_leave_the_fit_and_the_upward_ones_are_listed() {
        let mut y = vec![
            100.0, 90.0, 110.0, 95.0, 105.0, 100.0, 98.0, 102.0, 97.0, 103.0,
        ];
        // 1 klx, sun, glass-like sun, an unweighted row, a hazy day's sun patch, 2 klx
        y.extend([1000.0, 6000.0, 20_000.0, 7000.0, 3000.0, 2000.0]);
        let mut w = vec![1.0; 16];
        w[13] = 0.0;
        let mut up = vec![true; 16];
        up[12] = false;
        let (rows, upward) = exclude_sun_patches(&y, &mut w, &up);
        // the unweighted row is not a measured sun patch; the glass-like row is sun but not
        // upward; 2 klx leaves the fit but is not sun
        assert_eq!((rows, upward), (3, vec![11, 14]));
        let mut want = vec![1.0; 10];
        want.extend([0.0; 6]);
        assert_eq!(w, want);
    }

    /// room_03's desk 7: a window whose patch (reflectance 0.326) mixes the desk top (0.40)
    /// with a monitor (0.10). Both the frame's and the luminaires' light go through the patch's
    /// reflectance, so each sample's extraneous light read as `D = π L / ρ_patch` is off by
    /// `ρ_true / ρ_patch` (the desk's samples 23 % high), while its share of the sample's own
    /// luminaire light is exact.
    #[test]
    fn a_window_mixing_two_reflectances_measures_the_daylight_as_a_share() {
        let (rho_patch, e_art_lx, e_day_lx) = (0.326, 700.0, 250.0);
        let samples: Vec<Sample> = [0.40, 0.40, 0.40, 0.10, 0.10]
            .iter()
            .map(|rho| {
                // what the camera reads through the patch's reflectance
                let through = |e: f64| e * rho / rho_patch;
                Sample {
                    extraneous_lx: through(e_day_lx),
                    all_on_lx: through(e_art_lx),
                    weight: 1.0,
                }
            })
            .collect();
        let mut plain: Vec<(f64, f64)> = samples
            .iter()
            .map(|p| (p.extraneous_lx, p.weight))
            .collect();
        let d_plain = weighted_median(&mut plain).expect("samples");
        assert!((d_plain / e_day_lx - 0.40 / 0.326).abs() < 1e-12);
        let mut shares = extraneous_shares(e_art_lx, &samples).expect("lit samples");
        let d = weighted_median(&mut shares).expect("samples");
        assert!((d - e_day_lx).abs() < 1e-9, "{d}");
        // unlit samples are left out; nothing lit, or no desk light, gives none
        let dark = Sample {
            extraneous_lx: 10.0,
            all_on_lx: 0.0,
            weight: 1.0,
        };
        assert_eq!(extraneous_shares(e_art_lx, &[dark]), None);
        assert_eq!(extraneous_shares(0.0, &samples), None);
        assert_eq!(extraneous_shares(f64::NAN, &samples), None);
    }
}
