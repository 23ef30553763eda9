//! Commissioning from the ceiling cameras: a capture set (ToF depth + linear luminance frames,
//! one luminaire on at a time) to a [`Scene`] the engine can commission, with no CAD model.
//! RGBD2lux §3.1, made to model only what the light needs.
//!
//! ```text
//! depth frames ─► temporal median, flying pixels, outliers (depth) ─► point grid (grid)
//!   ─► dominant planes (planes) ─► rectangles + cut, smoothed grid mesh (mesh)
//!   ─► room box: inferred floor, walls, ceiling, black openings (closure)
//!   ─► pass model (engine, cheap) ─► ρ = π L / E per pixel, median, per triangle (reflectance)
//!   ─► final model (engine, full settings) ─► flash image (store)
//! ```
//!
//! Stages are timed ([`Report::timings`]); with [`CommissionOptions::progress`] each shows a
//! bar over the stages, each finished stage printed with its time. Bad input is an error ([`CommissionError`]) or a counted warning,
//! never a panic. The capture's `groundtruth/` is never read.

pub mod ambient;
pub mod closure;
pub mod depth;
pub mod grid;
pub mod mesh;
pub mod output;
pub mod placement;
pub mod planes;
pub mod pose;
pub mod refit;
pub mod reflectance;
pub mod uncertainty;

use std::time::{Duration, Instant};

use glam::DVec3;

pub use crate::camera::capture::Capture;
use crate::engine::raycast::RayCaster;
use crate::engine::{self, EngineError, Model, Settings};
use crate::lsc::AngularResponse;
use crate::scene::{Desks, Luminaire, Material, Mesh, ObjReport, Scene, Sensor, Triangle};
use crate::store::sensor_flags;
use crate::units::Reflectance;
pub use closure::{ClosureOptions, RoomBox};
pub use depth::{DepthMap, DepthOptions};
pub use mesh::{MeshOptions, Part, RecoMesh};
pub use planes::{Plane, PlaneOptions};
pub use reflectance::{Estimate, ReflectanceMethod, ReflectanceOptions};

/// The least surface the cameras must see for an image to be written, m².
pub const MIN_SEEN_AREA_M2: f64 = 1.0;
/// The most triangles a commissioned mesh may have (bounds the engine's work and memory).
pub const MAX_TRIANGLES: usize = 400_000;

/// Why commissioning failed. Bad input names the input, carries its value and, where there is
/// one, the range it must be in.
#[derive(Debug, thiserror::Error)]
pub enum CommissionError {
    /// A capture file is missing or unusable.
    #[error(transparent)]
    Capture(#[from] crate::camera::capture::CaptureError),
    /// The engine failed on the reconstructed scene.
    #[error("engine: {0}")]
    Engine(#[from] EngineError),
    /// An option ([`CommissionOptions`]) outside its range.
    #[error("{option}: {value}{unit} {expected}")]
    Option {
        /// The option, for people ("mesh patch size").
        option: &'static str,
        /// Its value.
        value: f64,
        /// The value's unit, with a leading space ("" without one).
        unit: &'static str,
        /// What it must be ("must be within 1..=64").
        expected: String,
    },
    /// The room box option is not a box.
    #[error(
        "room box: {},{},{},{} m must be x0 < x1, y0 < y1, at most 1000 m a side",
        xy_m[0], xy_m[1], xy_m[2], xy_m[3]
    )]
    RoomBoxOption {
        /// `[x0, y0, x1, y1]`, m.
        xy_m: [f64; 4],
    },
    /// A standard uncertainty of the inferred reflectances outside its range.
    #[error("uncertainty: {0}")]
    Uncertainty(String),
    /// No capture set.
    #[error("no capture set")]
    NoCaptureSet,
    /// More capture sets than [`MAX_NODES`].
    #[error("{nodes} capture sets (at most {MAX_NODES} nodes in one room)")]
    TooManyNodes {
        /// Capture sets given.
        nodes: usize,
    },
    /// No luminaires.
    #[error("no luminaires")]
    NoLuminaires,
    /// A capture set's luminance frames are not one per luminaire, in the luminaires' order.
    #[error(
        "{node}the capture's luminance frames do not match the luminaires (frames of \
         {frame_ids:?}, luminaires {luminaire_ids:?})"
    )]
    FramesMismatch {
        /// The capture set.
        node: Node,
        /// The luminaire ids of its frames.
        frame_ids: Vec<u32>,
        /// The luminaires' ids.
        luminaire_ids: Vec<u32>,
    },
    /// A camera's intrinsics are unusable.
    #[error("{node}camera intrinsics: {reason}")]
    CameraIntrinsics {
        /// The capture set.
        node: Node,
        /// What is wrong.
        reason: String,
    },
    /// A camera's position is not finite or more than 10 km from the origin.
    #[error(
        "{node}camera position ({}, {}, {}) m: not finite or more than 10 km away",
        position_m[0], position_m[1], position_m[2]
    )]
    CameraPosition {
        /// The capture set.
        node: Node,
        /// The position, m.
        position_m: [f64; 3],
    },
    /// Several capture sets with a gain that is not each camera's own.
    #[error(
        "several capture sets: each camera's gain must come from its camera.json (a luxmeter or \
         ambient-sensor gain is for one node)"
    )]
    GainForOneNode,
    /// One of several capture sets without its camera's gain.
    #[error(
        "{node}camera.json has no luminance_cd_m2_per_unit (several nodes need every camera's \
         gain)"
    )]
    NodeWithoutGain {
        /// The capture set.
        node: Node,
    },
    /// The camera's gain from camera.json, which has none.
    #[error("camera.json has no luminance_cd_m2_per_unit: give a luxmeter reading")]
    NoCameraGain,
    /// The room box is unusable for a camera (not finite, too large, the camera outside it).
    #[error("{0}")]
    RoomBox(String),
    /// Closing the room would take more than [`closure::MAX_CLOSURE_QUADS`] quads.
    #[error(
        "closing the room would take {quads:.0} quads (at most {}): a larger patch size or a \
         smaller room box",
        closure::MAX_CLOSURE_QUADS
    )]
    ClosureTooLarge {
        /// Quads it would take.
        quads: f64,
    },
    /// The mesh is empty.
    #[error("nothing to model: the mesh is empty")]
    EmptyMesh,
    /// The cameras saw less than [`MIN_SEEN_AREA_M2`] of the room.
    #[error(
        "the cameras saw {seen_m2:.2} m² of the room (at least {MIN_SEEN_AREA_M2} m² needed): \
         commissioning that sees nothing refuses to write an image"
    )]
    SeenTooLittle {
        /// Seen area modelled, m².
        seen_m2: f64,
    },
    /// More than [`MAX_TRIANGLES`] triangles.
    #[error("{triangles} triangles to model (at most {MAX_TRIANGLES}): a larger patch size")]
    TooManyTriangles {
        /// Triangles of the mesh.
        triangles: usize,
    },
    /// A camera's pose disagrees with what it sees ([`pose`]).
    #[error(transparent)]
    Pose(#[from] Box<pose::PoseError>),
    /// Luxmeter readings the fit cannot reproduce with reflectances at their limits.
    #[error(transparent)]
    RefitAtLimit(#[from] refit::AtLimit),
    /// Luxmeter readings ([`CommissionOptions::readings`]) that cannot be used.
    #[error("{0}")]
    Readings(String),
    /// Luxmeter readings with a gain from a luxmeter reading.
    #[error(
        "luxmeter readings set the walls' and ceiling's reflectance with the camera's own gain \
         (camera.json, or a hooded ambient light sensor's); a gain from a luxmeter reading goes \
         through the model, and both cannot be set from the readings"
    )]
    ReadingsWithLuxmeterGain,
    /// Luxmeter readings with an ambient light sensor's gain that came through the model.
    #[error(
        "luxmeter readings combine with the ambient light sensor's gain only where it is \
         measured directly (a hooded sensor the camera sees around); here it came through the \
         model"
    )]
    ReadingsWithModelGain,
    /// The gain's luxmeter reading is at a sensor that is not in the sensors.
    #[error("luxmeter sensor {sensor_id} is not in the sensors")]
    LuxmeterSensor {
        /// The reading's sensor id.
        sensor_id: u32,
    },
    /// The gain's reading is not a reading > 0 lx, or not one level per luminaire.
    #[error(
        "{what} reading: need a reading > 0 lx and one level per luminaire ({lux_lx} lx, \
         {levels} levels for {luminaires} luminaires)"
    )]
    GainReading {
        /// "luxmeter" or "ambient light sensor".
        what: &'static str,
        /// The reading, lx.
        lux_lx: f64,
        /// Levels given.
        levels: usize,
        /// Luminaires.
        luminaires: usize,
    },
    /// The ambient light sensor's facing is not a direction.
    #[error("ambient light sensor: its facing is not a direction")]
    AmbientFacing,
    /// No one-luminaire frame of a node shows light beyond its all-off frame.
    #[error(
        "{node}no one-luminaire frame shows light beyond the all-off frame (brightest \
         {mean_units:.3} units a pixel): every frame black, or the luminaires not switched"
    )]
    NoLightInFrames {
        /// The capture set.
        node: Node,
        /// The brightest frame's mean light per pixel, frame units.
        mean_units: f64,
    },
    /// A luminaire's frames show (almost) none of its light in every node.
    #[error(
        "luminaire {id}: its frames show {share_percent:.2} % of the brightest luminaire's \
         light in every capture set: a dead lamp, a luminaire not at its address, or frames in \
         another order"
    )]
    LuminaireDark {
        /// The luminaire.
        id: u32,
        /// Its light over the brightest luminaire's, %, the best over the nodes.
        share_percent: f64,
    },
    /// The commissioned model gives a desk sensor (almost) no light.
    #[error(
        "sensor {id} at ({:.2}, {:.2}, {:.2}) m gets {lux_lx:.2} lx with every luminaire at \
         full, the median sensor {median_lx:.0} lx: under the floor, inside an object or \
         outside the room? (a position in another unit, or typed wrong)",
        position_m[0], position_m[1], position_m[2]
    )]
    SensorDark {
        /// The sensor.
        id: u32,
        /// Its position, m.
        position_m: [f64; 3],
        /// Its all-on reading, lx.
        lux_lx: f64,
        /// The median sensor's, lx.
        median_lx: f64,
    },
    /// The model cannot read what the gain reading says, however bright or dark the surfaces:
    /// the same rule as for `--luxmeter-rho` (0.5..2 times the model's).
    #[error(
        "{what} reading {reading_lx:.1} lx at {place}: the commissioned model reads \
         {model_lx:.1} lx there ({ratio:.2} times the reading, with every reflectance at its \
         limit); wrong sensor, unit (klx for lx?) or dimming state"
    )]
    GainReadingImpossible {
        /// "luxmeter" or "ambient light sensor".
        what: &'static str,
        /// Where ("sensor 7", a point).
        place: String,
        /// The reading, lx.
        reading_lx: f64,
        /// The final model's reading there, lx.
        model_lx: f64,
        /// Model over reading.
        ratio: f64,
    },
    /// The gain source changed during commissioning (a bug).
    #[error("internal: gain source changed during commissioning")]
    GainSourceChanged,
    /// No depth frames.
    #[error("no depth frames")]
    NoDepthFrames,
    /// Depth frames of different sizes.
    #[error("depth frames of different sizes ({}x{} and {}x{} px)", first[0], first[1], other[0], other[1])]
    DepthSizes {
        /// The first frame's width and height, px.
        first: [u32; 2],
        /// Another frame's, px.
        other: [u32; 2],
    },
    /// A depth frame's data does not match its size.
    #[error("a depth frame's data does not match its size ({values} values for {pixels} pixels)")]
    DepthData {
        /// Values in the frame.
        values: usize,
        /// Pixels of its size.
        pixels: usize,
    },
    /// Less than 1 % of the pixels have a depth after cleaning.
    #[error(
        "depth unusable: {valid} of {pixels} pixels have a depth after cleaning (all zero, beyond \
         {max_depth_m} m, or noise?): the cameras see nothing of the room"
    )]
    DepthUnusable {
        /// Pixels with a depth.
        valid: usize,
        /// Pixels.
        pixels: usize,
        /// The farthest depth kept, m.
        max_depth_m: f64,
    },
}

/// Which capture set an error is about: its number (from 1) and directory when there are
/// several, nothing when there is one. Displays as a prefix ("capture set 2 (dir): ").
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Node(pub Option<(usize, std::path::PathBuf)>);

impl std::fmt::Display for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Some((k, dir)) => write!(f, "capture set {k} ({}): ", dir.display()),
            None => Ok(()),
        }
    }
}

/// Where the camera gain (cd/m² per unit of a luminance frame) comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Gain {
    /// `camera.json`'s `luminance_cd_m2_per_unit`.
    Camera,
    /// One luxmeter reading at commissioning: at sensor `sensor_id`, `lux_lx` with the
    /// luminaires at `levels` (luminaire order).
    Luxmeter {
        /// Sensor id.
        sensor_id: u32,
        /// Reading, lx.
        lux_lx: f64,
        /// Dimming state during the reading.
        levels: Vec<f64>,
    },
    /// The node's ambient light sensor (`crate::peripherals`): mounted at `position_m`,
    /// facing `normal` (down), with angular response `response`, it read `lux_lx` of the
    /// luminaires' own light at `levels` (a reading at `levels` less one with every luminaire
    /// off: the daylight in neither). Where the sensor sees only what the camera sees (a hooded
    /// sensor), the gain is measured directly against the frames ([`ambient::direct_gain`]);
    /// otherwise it is the one for which the model predicts that reading.
    Ambient {
        /// Where the sensor is, m.
        position_m: [f64; 3],
        /// Its facing (unit vector; `[0, 0, -1]` looking down).
        normal: [f64; 3],
        /// Reading, lx.
        lux_lx: f64,
        /// Dimming state during the reading.
        levels: Vec<f64>,
        /// The sensor's angular response (ideal cosine for a bare sensor).
        response: AngularResponse,
    },
}

impl Gain {
    /// The reading sensor's angular response (a luxmeter: ideal cosine).
    fn response(&self) -> &AngularResponse {
        const COSINE: &AngularResponse = &AngularResponse::Cosine;
        match self {
            Gain::Ambient { response, .. } => response,
            _ => COSINE,
        }
    }
}

/// Every commissioning knob.
#[derive(Debug, Clone)]
pub struct CommissionOptions {
    /// Depth cleaning.
    pub depth: DepthOptions,
    /// Pixels per grid node.
    pub grid_stride_px: u32,
    /// Plane detection.
    pub planes: PlaneOptions,
    /// Meshing.
    pub mesh: MeshOptions,
    /// Room closure.
    pub closure: ClosureOptions,
    /// Reflectance estimation.
    pub reflectance: ReflectanceOptions,
    /// Reflectance of seen surfaces before estimation, and if estimation is off.
    pub start_rho: f64,
    /// Estimate reflectances (off: `start_rho` everywhere seen; for ablations).
    pub estimate_reflectances: bool,
    /// Camera gain source.
    pub gain: Gain,
    /// The final engine run.
    pub engine: Settings,
    /// Standard uncertainties of the inferred reflectances, for each desk's stated uncertainty.
    pub uncertainty: uncertainty::UncertaintyOptions,
    /// Luxmeter readings with every luminaire at full that set the unseen walls' and ceiling's
    /// reflectance ([`refit`]; with camera.json's gain only).
    pub readings: Vec<refit::Reading>,
    /// Commission even when a check the engineer may override fails (a refit at its limits,
    /// [`refit::ReflectanceFit::check_limits`]): a warning in the report, the desks flagged
    /// [`sensor_flags::ESTIMATED`].
    pub force: bool,
    /// Spinners on stderr.
    pub progress: bool,
    /// The room plan (`--room-plan`, a board's `[room] plan`): walls, windows and ceiling where
    /// the cameras do not see; `None`: the room box is inferred.
    pub room_plan: Option<crate::scene::RoomPlan>,
}

impl Default for CommissionOptions {
    fn default() -> Self {
        Self {
            depth: DepthOptions::default(),
            grid_stride_px: 2,
            planes: PlaneOptions::default(),
            mesh: MeshOptions::default(),
            closure: ClosureOptions::default(),
            reflectance: ReflectanceOptions::default(),
            start_rho: 0.5,
            estimate_reflectances: true,
            gain: Gain::Camera,
            engine: Settings::default(),
            uncertainty: uncertainty::UncertaintyOptions::default(),
            readings: Vec::new(),
            force: false,
            progress: false,
            room_plan: None,
        }
    }
}

impl CommissionOptions {
    /// Checks every knob a person or a board file can set, before any work: reflectances in
    /// [0, 1), sizes within sane bounds, a luxmeter reading that is a positive number. The
    /// error names the option.
    pub fn validate(&self) -> Result<(), CommissionError> {
        let bad = |option: &'static str, value: f64, unit: &'static str, expected: String| {
            Err(CommissionError::Option {
                option,
                value,
                unit,
                expected,
            })
        };
        for (name, v) in [
            ("wall reflectance", self.closure.wall_rho),
            ("ceiling reflectance", self.closure.ceiling_rho),
            ("start reflectance", self.start_rho),
        ] {
            if !(0.0..1.0).contains(&v) {
                return bad(name, v, "", "must be a reflectance in [0, 1)".into());
            }
        }
        self.uncertainty
            .check()
            .map_err(CommissionError::Uncertainty)?;
        let m = &self.mesh;
        if !(m.patch_size_m.is_finite() && (0.05..=100.0).contains(&m.patch_size_m)) {
            return bad(
                "mesh patch size",
                m.patch_size_m,
                " m",
                "must be within 0.05..=100 m".into(),
            );
        }
        if !(m.cell_m.is_finite() && m.cell_m >= 0.005 && m.cell_m <= m.patch_size_m) {
            return bad(
                "mesh cell",
                m.cell_m,
                " m",
                format!(
                    "must be within 0.005 m and the patch size ({} m)",
                    m.patch_size_m
                ),
            );
        }
        if !(1..=64).contains(&self.grid_stride_px) {
            return bad(
                "grid stride",
                f64::from(self.grid_stride_px),
                " px",
                "must be within 1..=64".into(),
            );
        }
        if let Some(xy_m @ [x0, y0, x1, y1]) = self.closure.room_xy_m {
            let finite = xy_m.iter().all(|v| v.is_finite() && v.abs() < 1e4);
            if !(finite && x1 > x0 && y1 > y0 && x1 - x0 <= 1000.0 && y1 - y0 <= 1000.0) {
                return Err(CommissionError::RoomBoxOption { xy_m });
            }
        }
        if let Some(z) = self.closure.ceiling_z_m
            && !(z.is_finite() && z.abs() < 1e3)
        {
            return bad("ceiling height", z, " m", "is not a height".into());
        }
        if let Gain::Luxmeter { lux_lx, levels, .. } | Gain::Ambient { lux_lx, levels, .. } =
            &self.gain
        {
            if !(lux_lx.is_finite() && *lux_lx > 0.0 && *lux_lx < 1e6) {
                return bad(
                    "luxmeter reading",
                    *lux_lx,
                    " lx",
                    "must be within (0, 1e6)".into(),
                );
            }
            if let Some(x) = levels
                .iter()
                .find(|x| !(x.is_finite() && (0.0..=1.0).contains(*x)))
            {
                return bad("luxmeter dimming state", *x, "", "is outside [0, 1]".into());
            }
        }
        Ok(())
    }
}

/// Gather rays of the ambient light sensor's virtual receiver.
pub const AMBIENT_RAYS: usize = 20_000;

/// Where a gain reading was taken.
#[derive(Debug, Clone, Copy)]
enum Reading {
    /// Desk sensor index and id.
    Sensor(usize, u32),
    /// The node's ambient light sensor: position and facing.
    Point(DVec3, DVec3),
}

impl Reading {
    fn what(&self) -> &'static str {
        match self {
            Reading::Sensor(..) => "luxmeter",
            Reading::Point(..) => "ambient light sensor",
        }
    }

    fn place(&self) -> String {
        match self {
            Reading::Sensor(_, id) => format!("sensor {id}"),
            Reading::Point(p, _) => format!("({:.2}, {:.2}, {:.2}) m", p.x, p.y, p.z),
        }
    }

    /// The final model's reading.
    fn final_reading(
        &self,
        scene: &Scene,
        model: &Model,
        levels: &[f64],
        response: &AngularResponse,
    ) -> Result<f64, CommissionError> {
        Ok(match self {
            Reading::Sensor(s, _) => model.sensor_lux(levels)?[*s],
            Reading::Point(p, n) => {
                engine::points::evaluate_with(scene, model, &[(*p, *n)], AMBIENT_RAYS, response)
                    .lux(levels)[0]
            }
        })
    }
}

fn unreachable_gain<T>() -> Result<T, CommissionError> {
    Err(CommissionError::GainSourceChanged)
}

/// A plane, for people.
#[derive(Debug, Clone, Copy)]
pub struct PlaneSummary {
    /// Unit normal.
    pub normal: DVec3,
    /// Centroid, m.
    pub origin_m: DVec3,
    /// Meshed area, m².
    pub area_m2: f64,
    /// Triangles.
    pub triangles: usize,
    /// RMS distance of its points, m.
    pub rms_m: f64,
}

/// What commissioning found and did.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// (stage, wall time).
    pub timings: Vec<(&'static str, Duration)>,
    /// Depth cleaning counts.
    pub depth: depth::DepthStats,
    /// Planes found.
    pub planes: Vec<PlaneSummary>,
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Seen surface area modelled, m².
    pub seen_area_m2: f64,
    /// Inferred (closure) area, m².
    pub inferred_area_m2: f64,
    /// The room box, when closed.
    pub room: Option<RoomBox>,
    /// Seen planes modelled as thin objects with a hidden face (closure).
    pub hidden_faces: usize,
    /// Desk top area nobody saw, modelled from desks.json and the desk sensors (closure), m².
    pub inferred_desk_m2: f64,
    /// Without a plan, the sides of the inferred room box (x low, y low, x high, y high) whose
    /// wall no camera saw and the luminaire grid did not place: their position is in every
    /// desk's stated uncertainty ([`placement`]); `None` with a plan or a given box.
    pub unseen_wall_sides: Option<[bool; 4]>,
    /// Reflectance estimate outcome.
    pub reflectance: Estimate,
    /// Patches of the final model.
    pub patches: usize,
    /// The ambient light sensor's reading per luminaire at 100 % predicted by the final model,
    /// lx (with [`Gain::Ambient`]): the run-time check's reference.
    pub ambient_response_lx: Option<Vec<f64>>,
    /// The ambient light sensor's direct comparison with the camera, where it sees only what the
    /// camera sees (then the gain came from it).
    pub ambient_direct: Option<ambient::DirectGain>,
    /// What luxmeter readings set ([`CommissionOptions::readings`]).
    pub reflectance_fit: Option<refit::ReflectanceFit>,
    /// Each desk sensor's stated uncertainty from what was inferred (empty when it could not
    /// be computed: a warning says why).
    pub uncertainty: Vec<uncertainty::SensorUncertainty>,
    /// Per node: its camera pose against what it sees ([`pose`]).
    pub pose: Vec<pose::NodePose>,
    /// Warnings (also those of the capture).
    pub warnings: Vec<String>,
}

impl Report {
    /// Total time.
    pub fn total(&self) -> Duration {
        self.timings.iter().map(|t| t.1).sum()
    }

    /// The stated uncertainty of the desk sensor `sensor_id`, if commissioning stated one.
    pub fn uncertainty_of(&self, sensor_id: u32) -> Option<&uncertainty::SensorUncertainty> {
        self.uncertainty.iter().find(|u| u.sensor_id == sensor_id)
    }

    /// Its relative standard uncertainty ([`Self::uncertainty_of`]), NaN when not stated.
    pub fn stated_rel(&self, sensor_id: u32) -> f64 {
        self.uncertainty_of(sensor_id).map_or(f64::NAN, |u| u.rel)
    }
}

/// The result: the reconstructed scene, its model and what was done.
#[derive(Debug, Clone)]
pub struct Commissioned {
    /// The reconstructed scene (mesh with estimated reflectances, luminaires, sensors).
    pub scene: Scene,
    /// The final model.
    pub model: Model,
    /// The mesh with a part per triangle (same triangle order as `scene.mesh`).
    pub reco: RecoMesh,
    /// The cleaned depth map.
    pub depth: DepthMap,
    /// Per-sensor flags for the image ([`sensor_flags`]).
    pub sensor_flags: Vec<u8>,
    /// What was found and done.
    pub report: Report,
    /// Per sensor, the model's light with every luminaire at 100 % before the cameras'
    /// one-luminaire frames calibrated it (`crate::live_section::calibrate`; empty before), lx.
    pub uncalibrated_all_on_lx: Vec<f64>,
}

/// Commissioning's progress on a terminal: one bar over the stages (`[3/7] mesh 0.4 s`), each
/// finished stage printed above it with its time ([`CommissionOptions::progress`]).
struct Progress {
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    /// A bar of `stages` steps when `on` (a terminal), else nothing.
    fn new(on: bool, stages: u64) -> Progress {
        let bar = on.then(|| {
            let b = indicatif::ProgressBar::new(stages);
            let style = indicatif::ProgressStyle::with_template(
                "commissioning [{bar:24}] {pos}/{len} {msg} {elapsed}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> ");
            b.set_style(style);
            b.enable_steady_tick(Duration::from_millis(100));
            b
        });
        Progress { bar }
    }
}

impl Drop for Progress {
    /// Done or failed, the bar leaves the terminal; the stages' lines stay above it.
    fn drop(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// The stages a commissioning with options `o` goes through (the bar's length).
fn stage_count(o: &CommissionOptions) -> u64 {
    // depth, planes, pose, mesh, closure, engine, uncertainty; pass model and reflectances
    7 + if o.estimate_reflectances { 2 } else { 0 }
}

struct Stage<'a> {
    progress: &'a Progress,
    t0: Instant,
    name: &'static str,
}

impl<'a> Stage<'a> {
    fn start(name: &'static str, progress: &'a Progress) -> Stage<'a> {
        if let Some(b) = &progress.bar {
            b.set_message(name);
        }
        Stage {
            progress,
            t0: Instant::now(),
            name,
        }
    }

    fn done(self, report: &mut Report) {
        let dt = self.t0.elapsed();
        if let Some(b) = &self.progress.bar {
            b.println(format!("{}: {:.0} ms", self.name, dt.as_secs_f64() * 1e3));
            b.inc(1);
        }
        report.timings.push((self.name, dt));
    }
}

/// The patches of the room plan's windows (mesh groups `window_<k>` of
/// [`Part::Window`]), or `None` when the room has none.
pub fn glazing_patches(c: &Commissioned) -> Option<Vec<bool>> {
    let groups = &c.scene.mesh.groups;
    let is_window: Vec<bool> = groups.iter().map(|g| g.starts_with("window_")).collect();
    let p = &c.model.patches;
    let mask: Vec<bool> = (0..p.len())
        .map(|i| is_window.get(p.group[i] as usize).copied().unwrap_or(false))
        .collect();
    mask.iter().any(|&m| m).then_some(mask)
}

/// Builds the engine's mesh: one material per triangle with its reflectance.
pub fn to_mesh(reco: &RecoMesh, tri_rho: &[f64]) -> Mesh {
    let mut groups: Vec<String> = Vec::new();
    let mut group_of = std::collections::HashMap::new();
    let mut triangles = Vec::with_capacity(reco.tris.len());
    let mut materials = Vec::with_capacity(reco.tris.len());
    for (t, v) in reco.tris.iter().enumerate() {
        let part = reco.part[t];
        let g = *group_of.entry(part).or_insert_with(|| {
            groups.push(part.label());
            groups.len() as u32 - 1
        });
        let rho = if matches!(part, Part::Opening(_)) {
            0.0
        } else {
            tri_rho[t]
        };
        materials.push(Material {
            name: format!("t{t}"),
            rho: Reflectance::new(rho.clamp(0.0, 0.999)).unwrap_or(Reflectance::ZERO),
        });
        triangles.push(Triangle {
            v: *v,
            group: g,
            material: t as u32,
        });
    }
    Mesh {
        positions_m: reco.positions_m.clone(),
        triangles,
        groups,
        materials,
    }
}

/// Runs the engine; if the solve diverges on the reconstructed (possibly open, noisy) mesh,
/// retries without form-factor rectification and says so.
fn run_engine(
    scene: &Scene,
    settings: &Settings,
    warnings: &mut Vec<String>,
) -> Result<Model, CommissionError> {
    match engine::compute_model(scene, settings) {
        Err(EngineError::Solve { what, source }) if settings.rectify => {
            warnings.push(format!(
                "radiosity solve for {what} failed ({source}) with rectified form factors; \
                 retried without rectification"
            ));
            let s = Settings {
                rectify: false,
                ..settings.clone()
            };
            Ok(engine::compute_model(scene, &s)?)
        }
        other => Ok(other?),
    }
}

fn pass_settings(final_settings: &Settings) -> Settings {
    Settings {
        sensor_rays: 2000,
        final_gather_rays: 0,
        ..final_settings.clone()
    }
}

/// Commissions from a capture set.
pub fn from_capture(
    capture: &Capture,
    luminaires: Vec<Luminaire>,
    sensors: Vec<Sensor>,
    desks: Option<Desks>,
    o: &CommissionOptions,
) -> Result<Commissioned, CommissionError> {
    from_captures(std::slice::from_ref(capture), luminaires, sensors, desks, o)?
        .into_iter()
        .next()
        .ok_or(CommissionError::NoCaptureSet)
}

/// At most this many nodes (capture sets) commission one room together.
pub const MAX_NODES: usize = 16;

/// Per sensor: whether no node sees it (see [`node_sees`]).
fn out_of_every_view(captures: &[Capture], depths: &[DepthMap], sensors: &[Sensor]) -> Vec<bool> {
    sensors
        .iter()
        .map(|s| {
            !captures
                .iter()
                .zip(depths)
                .any(|(c, d)| node_sees(&c.camera, d, s.position_m))
        })
        .collect()
}

/// Whether a node sees the world point `p`: it projects into the node's image, where the depth
/// seen puts the surface at `p` ([`DepthMap::sees_at`]).
fn node_sees(cam: &crate::scene::Camera, depth: &DepthMap, p: DVec3) -> bool {
    cam.pixel_of(p)
        .and_then(|(u, v)| depth.sees_at(cam, u, v, p))
        .unwrap_or(false)
}

/// [`from_captures`] with luxmeter readings ([`refit`]): commissions at the default wall and
/// ceiling reflectances, fits them to the readings, and commissions again with the fitted ones
/// (and their posterior uncertainty in each desk's stated uncertainty).
fn with_readings(
    captures: &[Capture],
    luminaires: Vec<Luminaire>,
    sensors: Vec<Sensor>,
    desks: Option<Desks>,
    o: &CommissionOptions,
) -> Result<Vec<Commissioned>, CommissionError> {
    let ids: Vec<u32> = sensors.iter().map(|s| s.id).collect();
    refit::check(&o.readings, &ids).map_err(CommissionError::Readings)?;
    if matches!(o.gain, Gain::Luxmeter { .. }) {
        return Err(CommissionError::ReadingsWithLuxmeterGain);
    }
    let mut plain = o.clone();
    plain.readings.clear();
    // the readings set the walls: both runs keep the default the fit is taken about
    plain.closure.wall_rho_from_seen = false;
    let first = from_captures(
        captures,
        luminaires.clone(),
        sensors.clone(),
        desks.clone(),
        &plain,
    )?;
    let Some(r) = first.first().map(|c| &c.report) else {
        return Err(CommissionError::NoCaptureSet);
    };
    if matches!(o.gain, Gain::Ambient { .. }) && r.ambient_direct.is_none() {
        // a bare sensor's gain comes through the model, whose walls the readings change
        return Err(CommissionError::ReadingsWithModelGain);
    }
    let f = refit::fit(
        &r.uncertainty,
        o.uncertainty.wall_rho,
        o.uncertainty.ceiling_rho,
        o.closure.wall_rho,
        o.closure.ceiling_rho,
        &o.readings,
    )
    .map_err(CommissionError::Readings)?;
    let at_limit = refit_limits(&f, o.force)?;
    plain.closure.wall_rho = f.wall_rho.1;
    plain.closure.ceiling_rho = f.ceiling_rho.1;
    plain.uncertainty.wall_rho = f.sigma_after.0;
    plain.uncertainty.ceiling_rho = f.sigma_after.1;
    let mut nodes = from_captures(captures, luminaires, sensors, desks, &plain)?;
    for n in &mut nodes {
        n.report.reflectance_fit = Some(f.clone());
        if let Some(w) = &at_limit {
            n.report.warnings.push(w.clone());
            n.sensor_flags
                .iter_mut()
                .for_each(|x| *x |= sensor_flags::ESTIMATED);
        }
    }
    Ok(nodes)
}

/// A refit at its reflectance limits that misses a reading: an error, or with `force` the
/// warning for the report (the desks are then flagged estimated).
fn refit_limits(f: &refit::ReflectanceFit, force: bool) -> Result<Option<String>, CommissionError> {
    match f.check_limits() {
        Ok(()) => Ok(None),
        Err(e) if force => Ok(Some(format!("--force: {e}"))),
        Err(e) => Err(e.into()),
    }
}

/// What commissioning works from: the capture sets, the room's luminaires, sensors and desks,
/// and the options.
struct Inputs<'a> {
    captures: &'a [Capture],
    luminaires: &'a [Luminaire],
    sensors: &'a [Sensor],
    desks: Option<&'a Desks>,
    o: &'a CommissionOptions,
    progress: Progress,
}

impl Inputs<'_> {
    /// The first node's capture set (whose camera the room's scene carries).
    fn first(&self) -> &Capture {
        &self.captures[0]
    }

    /// The room's scene with the mesh `reco` at reflectances `rho` (per triangle).
    fn scene(&self, reco: &RecoMesh, rho: &[f64]) -> Scene {
        let first = self.first();
        Scene {
            name: first
                .dir
                .canonicalize()
                .ok()
                .and_then(|p| {
                    p.parent()
                        .and_then(|q| q.file_name())
                        .map(|n| n.to_string_lossy().into_owned())
                })
                .unwrap_or_else(|| "capture".into()),
            mesh: to_mesh(reco, rho),
            luminaires: self.luminaires.to_vec(),
            sensors: self.sensors.to_vec(),
            desks: self.desks.cloned(),
            camera: Some(first.camera.clone()),
            obj_report: ObjReport::default(),
            warnings: Vec::new(),
        }
    }
}

/// Checks the capture sets against the luminaires and each other before any work.
fn check_captures(i: &Inputs) -> Result<(), CommissionError> {
    let captures = i.captures;
    if captures.is_empty() {
        return Err(CommissionError::NoCaptureSet);
    }
    if captures.len() > MAX_NODES {
        return Err(CommissionError::TooManyNodes {
            nodes: captures.len(),
        });
    }
    if i.luminaires.is_empty() {
        return Err(CommissionError::NoLuminaires);
    }
    for (k, capture) in captures.iter().enumerate() {
        let which = Node((captures.len() > 1).then(|| (k + 1, capture.dir.clone())));
        if capture.luminance.len() != i.luminaires.len()
            || capture
                .luminance
                .iter()
                .zip(i.luminaires)
                .any(|((id, _), l)| *id != l.id)
        {
            return Err(CommissionError::FramesMismatch {
                node: which,
                frame_ids: capture.luminance.iter().map(|(id, _)| *id).collect(),
                luminaire_ids: i.luminaires.iter().map(|l| l.id).collect(),
            });
        }
        let cam = &capture.camera;
        cam.check()
            .map_err(|reason| CommissionError::CameraIntrinsics {
                node: which.clone(),
                reason,
            })?;
        if !(cam.position_m.is_finite() && cam.position_m.abs().max_element() <= 1e4) {
            return Err(CommissionError::CameraPosition {
                node: which,
                position_m: cam.position_m.to_array(),
            });
        }
        if captures.len() > 1 {
            if !matches!(i.o.gain, Gain::Camera) {
                return Err(CommissionError::GainForOneNode);
            }
            if !cam
                .luminance_cd_m2_per_unit
                .is_some_and(|g| g.is_finite() && g > 0.0)
            {
                return Err(CommissionError::NodeWithoutGain { node: which });
            }
        }
    }
    check_frames_lit(i)
}

/// A luminaire's share of the brightest below this in every node is a dark luminaire (the
/// farthest luminaire of the reference open plan gives a pinhole node a few per cent).
const MIN_LUMINAIRE_SHARE: f64 = 0.002;
/// A frame whose light beyond the all-off frame is below this per pixel shows none, units.
const MIN_FRAME_LIGHT_UNITS: f64 = 0.5;

/// Stage "inputs", the frames: each node's one-luminaire frames show light beyond the all-off
/// frame (the daylight interpolated over the sequence), and each luminaire's somewhere.
fn check_frames_lit(i: &Inputs) -> Result<(), CommissionError> {
    let captures = i.captures;
    let mut best_share = vec![0.0f64; i.luminaires.len()];
    for (k, capture) in captures.iter().enumerate() {
        let light: Vec<f64> = (0..capture.luminance.len())
            .map(|l| frame_light_units(capture, l))
            .collect();
        let pixels = capture
            .luminance
            .first()
            .map_or(1, |(_, f)| f.data.len().max(1));
        let brightest = light.iter().copied().fold(0.0, f64::max);
        if brightest / pixels as f64 <= MIN_FRAME_LIGHT_UNITS {
            let node = Node((captures.len() > 1).then(|| (k + 1, capture.dir.clone())));
            return Err(CommissionError::NoLightInFrames {
                node,
                mean_units: brightest / pixels as f64,
            });
        }
        for (b, x) in best_share.iter_mut().zip(&light) {
            *b = b.max(x / brightest);
        }
    }
    for (l, share) in i.luminaires.iter().zip(&best_share) {
        if *share < MIN_LUMINAIRE_SHARE {
            return Err(CommissionError::LuminaireDark {
                id: l.id,
                share_percent: 100.0 * share,
            });
        }
    }
    Ok(())
}

/// Luminaire frame `l`'s light beyond the daylight, summed over the pixels where both are
/// valid, frame units (signed: noise averages out).
fn frame_light_units(capture: &crate::camera::capture::Capture, l: usize) -> f64 {
    let Some((_, frame)) = capture.luminance.get(l) else {
        return 0.0;
    };
    frame
        .data
        .iter()
        .enumerate()
        .filter(|&(_, &x)| x != u16::MAX)
        .filter_map(|(p, &x)| Some(f64::from(x) - capture.daylight_value(l, p)?))
        .sum()
}

/// Stage "planes": each node's point grid and the dominant planes found in it.
struct NodePlanes {
    /// Per node: its point grid.
    grids: Vec<grid::PointGrid>,
    /// Per node: the planes found in its grid.
    found: Vec<Vec<Plane>>,
}

impl NodePlanes {
    /// Every node's seen points (the grids' cells with a point), m.
    fn seen_points(&self) -> Vec<DVec3> {
        self.grids
            .iter()
            .flat_map(|g| g.points_m.iter().flatten().copied())
            .collect()
    }
}

/// Stage "depth": each node's depth frames fused into one cleaned depth map.
fn fuse_depths(i: &Inputs) -> Result<Vec<DepthMap>, CommissionError> {
    i.captures
        .iter()
        .map(|c| depth::fuse(&c.depth_mm, &i.o.depth))
        .collect()
}

/// Stage "planes": point grids from the depth maps, and their dominant planes.
fn find_planes(i: &Inputs, depths: &[DepthMap]) -> NodePlanes {
    let o = i.o;
    let grids: Vec<grid::PointGrid> = i
        .captures
        .iter()
        .zip(depths)
        .map(|(c, d)| grid::PointGrid::new(d, &c.camera, o.grid_stride_px, o.depth.edge_rel))
        .collect();
    let found = i
        .captures
        .iter()
        .zip(&grids)
        .map(|(c, g)| planes::detect(g, &c.camera, &o.planes))
        .collect();
    NodePlanes { grids, found }
}

/// The room's floor as the nodes found it.
struct Floor {
    /// Per node: its floor plane (the lowest large horizontal plane it found).
    of: Vec<Option<usize>>,
    /// (node, plane) of the plane that meshes the room's floor: the first node's that found one.
    main: Option<(usize, usize)>,
    /// The floor's height, m.
    z_m: f64,
}

impl Floor {
    /// Whether plane `k` of node `i` is floor: with the room closed, every horizontal plane at
    /// the floor's height; otherwise the node's own floor plane.
    fn is_floor_like(&self, planes: &NodePlanes, closed: bool, i: usize, k: usize) -> bool {
        let p = &planes.found[i][k];
        if closed {
            p.is_horizontal() && (p.origin_m.z - self.z_m).abs() <= mesh::ALSO_SEEN_DISTANCE_M
        } else {
            self.of[i] == Some(k)
        }
    }
}

/// Finds the floor (warning when there is none: then it is at the lowest point seen).
fn find_floor(planes: &NodePlanes, seen_pts: &[DVec3], warnings: &mut Vec<String>) -> Floor {
    let of: Vec<Option<usize>> = planes
        .found
        .iter()
        .map(|found| {
            found
                .iter()
                .enumerate()
                .filter(|(_, p)| p.is_horizontal() && p.nodes.len() >= 100)
                .min_by(|a, b| a.1.origin_m.z.total_cmp(&b.1.origin_m.z))
                .map(|(k, _)| k)
        })
        .collect();
    let main = of
        .iter()
        .position(Option::is_some)
        .and_then(|i| of[i].map(|k| (i, k)));
    let z_m = match main {
        Some((i, k)) => planes.found[i][k].origin_m.z,
        None => {
            warnings.push("no floor plane found: the floor is put at the lowest point seen".into());
            seen_pts.iter().map(|p| p.z).fold(f64::INFINITY, f64::min)
        }
    };
    Floor { of, main, z_m }
}

/// The room (with closure on): the plan's, reconciled with what was seen, or the inferred box;
/// checked to be a bounded amount of work.
fn find_room(
    i: &Inputs,
    seen_pts: &[DVec3],
    floor: &Floor,
    warnings: &mut Vec<String>,
) -> Result<Option<RoomBox>, CommissionError> {
    let o = i.o;
    let floor_z_m = floor.z_m;
    let room = o.closure.enabled.then(|| match &o.room_plan {
        Some(plan) => {
            let seen_floor = floor.main.map(|_| floor_z_m);
            let (room, w) = closure::plan::room_from_plan(plan, seen_pts, seen_floor);
            warnings.extend(w);
            room
        }
        None => closure::room_box(seen_pts, floor_z_m, i.luminaires, i.sensors, &o.closure),
    });
    if let Some(r) = &room {
        // bounded work: a wrong calibration or pose never becomes a room of kilometres
        for c in i.captures {
            r.check(c.camera.position_m)
                .map_err(CommissionError::RoomBox)?;
        }
        let quads = r.closure_quads(o.mesh.patch_size_m);
        if quads > closure::MAX_CLOSURE_QUADS as f64 {
            return Err(CommissionError::ClosureTooLarge { quads });
        }
    }
    Ok(room)
}

/// Stage "mesh": the room's mesh from every node's planes and the rest of its points.
struct Meshed {
    /// The mesh (before closure).
    reco: RecoMesh,
    /// Per global plane index (nodes' planes in order): (normal, origin).
    plane_at: Vec<(DVec3, DVec3)>,
    /// Global index of the room's floor plane.
    floor_idx: Option<usize>,
    /// The room box, when closure is on.
    room: Option<RoomBox>,
}

/// Stage "mesh": floor, room box, each node's mesh, the nodes' meshes merged.
fn mesh_room(
    i: &Inputs,
    depths: &[DepthMap],
    planes: &NodePlanes,
    report: &mut Report,
) -> Result<Meshed, CommissionError> {
    let seen_pts = planes.seen_points();
    let floor = find_floor(planes, &seen_pts, &mut report.warnings);
    let room = find_room(i, &seen_pts, &floor, &mut report.warnings)?;
    let NodeMeshes {
        meshes,
        plane_at,
        floor_idx,
    } = mesh_nodes(i, planes, &floor, room.as_ref(), report);
    let reco = merge_nodes(i.captures, depths, meshes, floor_idx);
    Ok(Meshed {
        reco,
        plane_at,
        floor_idx,
        room,
    })
}

/// Each node's mesh, and the planes' global indices.
struct NodeMeshes {
    /// Per node: its mesh.
    meshes: Vec<RecoMesh>,
    /// Per global plane index (nodes' planes in order): (normal, origin).
    plane_at: Vec<(DVec3, DVec3)>,
    /// Global index of the room's floor plane.
    floor_idx: Option<usize>,
}

/// Each node's mesh: its planes (the room's floor once, over the room box) and the rest of its
/// points; with the planes' global (normal, origin) and the floor's global index. Pushes a
/// [`PlaneSummary`] per plane.
fn mesh_nodes(
    i: &Inputs,
    planes: &NodePlanes,
    floor: &Floor,
    room: Option<&RoomBox>,
    report: &mut Report,
) -> NodeMeshes {
    let o = i.o;
    let closed = room.is_some();
    // Floor is every horizontal plane at the floor's height: a desk island or a wall of
    // cabinets splits the floor a camera sees into several components, and each node sees its
    // own. With the room closed, the floor node meshes the room's floor once, and the other
    // components only mark its raster as seen (meshing them too would model that floor twice).
    let other_floor_m: Vec<DVec3> = planes
        .found
        .iter()
        .enumerate()
        .flat_map(|(n, found)| (0..found.len()).map(move |k| (n, k)))
        .filter(|&(n, k)| Some((n, k)) != floor.main && floor.is_floor_like(planes, closed, n, k))
        .flat_map(|(n, k)| {
            planes.found[n][k]
                .nodes
                .iter()
                .filter_map(|&g| planes.grids[n].points_m[g])
                .collect::<Vec<_>>()
        })
        .collect();
    let mut plane_at: Vec<(DVec3, DVec3)> = Vec::new();
    let mut floor_idx: Option<usize> = None;
    let mut node_meshes: Vec<RecoMesh> = Vec::with_capacity(i.captures.len());
    for (n, capture) in i.captures.iter().enumerate() {
        let node_cam = &capture.camera;
        let mesh_options = MeshOptions {
            wide_angle: o.mesh.wide_angle || node_cam.lens.is_fisheye(),
            ..o.mesh
        };
        let (grid, found) = (&planes.grids[n], &planes.found[n]);
        let mut node = RecoMesh::default();
        let mut on_plane = vec![false; grid.points_m.len()];
        for (k, p) in found.iter().enumerate() {
            let kg = plane_at.len() as u32;
            plane_at.push((p.normal, p.origin_m));
            let is_floor = Some((n, k)) == floor.main;
            let before = node.tris.len();
            if is_floor {
                floor_idx = Some(kg as usize);
            }
            // any other floor component is the room floor's (marked in its raster)
            if is_floor || !floor.is_floor_like(planes, closed, n, k) {
                mesh::mesh_plane(
                    &mut node,
                    grid,
                    p,
                    kg,
                    &mesh_options,
                    room.filter(|_| is_floor).map(|r| r.xy_m),
                    is_floor.then_some(Part::FloorFill),
                    if is_floor { &other_floor_m } else { &[] },
                    room.and_then(|r| r.outline_m.as_deref()),
                );
            }
            for &g in &p.nodes {
                on_plane[g] = true;
            }
            report.planes.push(plane_summary(&node, p, kg, before));
        }
        mesh::mesh_rest(&mut node, grid, &on_plane, node_cam.position_m, &o.mesh);
        node_meshes.push(node);
    }
    NodeMeshes {
        meshes: node_meshes,
        plane_at,
        floor_idx,
    }
}

/// Plane `p` (global index `kg`) as meshed into `node` from triangle `before` on.
fn plane_summary(node: &RecoMesh, p: &Plane, kg: u32, before: usize) -> PlaneSummary {
    let tris = before..node.tris.len();
    let area = tris
        .clone()
        .filter(|&t| node.part[t] == Part::Plane(kg))
        .map(|t| node.area_m2(t))
        .sum();
    PlaneSummary {
        normal: p.normal,
        origin_m: p.origin_m,
        area_m2: area,
        triangles: tris.len(),
        rms_m: p.rms_m,
    }
}

/// The nodes' meshes as one: a surface several nodes see is kept by the nearest of them (the
/// floor by the node that meshed it).
fn merge_nodes(
    captures: &[Capture],
    depths: &[DepthMap],
    mut node_meshes: Vec<RecoMesh>,
    floor_idx: Option<usize>,
) -> RecoMesh {
    if node_meshes.len() == 1 {
        return node_meshes.pop().unwrap_or_default();
    }
    let mut reco = RecoMesh::default();
    for (i, node) in node_meshes.iter().enumerate() {
        for (t, tri) in node.tris.iter().enumerate() {
            let part = node.part[t];
            let [a, b, c] = tri.map(|v| node.positions_m[v as usize]);
            let centre = (a + b + c) / 3.0;
            let on_floor = matches!(part, Part::FloorFill)
                || Some(part) == floor_idx.map(|k| Part::Plane(k as u32));
            let d_i = (centre - captures[i].camera.position_m).length();
            let nearer_elsewhere = captures
                .iter()
                .zip(depths)
                .enumerate()
                .any(|(j, (cj, dj))| {
                    j != i && {
                        let d_j = (centre - cj.camera.position_m).length();
                        (d_j < d_i || (d_j == d_i && j < i)) && node_sees(&cj.camera, dj, centre)
                    }
                });
            if !on_floor && nearer_elsewhere {
                continue;
            }
            let base = reco.positions_m.len() as u32;
            reco.positions_m.extend([a, b, c]);
            reco.tris.push([base, base + 1, base + 2]);
            reco.part.push(part);
        }
    }
    reco
}

/// Stage "closure": hidden faces of thin objects, desk tops nobody saw, the room's box; then
/// the mesh's checks (not empty, enough seen, not too large).
fn close_room(i: &Inputs, meshed: &mut Meshed, report: &mut Report) -> Result<(), CommissionError> {
    let reco = &mut meshed.reco;
    if let Some(r) = &meshed.room {
        let thin: Vec<(u32, DVec3)> = meshed
            .plane_at
            .iter()
            .enumerate()
            .filter(|&(k, &(normal, origin))| {
                Some(k) != meshed.floor_idx && closure::is_thin_object(r, normal, origin)
            })
            .map(|(k, &(normal, _))| (k as u32, normal))
            .collect();
        closure::hidden_faces(reco, &thin);
        report.hidden_faces = thin.len();
        let desk_list = i.desks.map_or(&[][..], |d| &d.desks[..]);
        let tops = closure::desk_tops(r, desk_list, i.sensors);
        report.inferred_desk_m2 = closure::inferred_desk_tops(reco, &tops, i.o.mesh.patch_size_m);
        closure::close(reco, r, i.luminaires, &i.o.mesh);
    }
    report.room = meshed.room.clone();
    report.triangles = reco.tris.len();
    (report.seen_area_m2, report.inferred_area_m2) = reco.areas_m2();
    if reco.tris.is_empty() {
        return Err(CommissionError::EmptyMesh);
    }
    if report.seen_area_m2 < MIN_SEEN_AREA_M2 {
        return Err(CommissionError::SeenTooLittle {
            seen_m2: report.seen_area_m2,
        });
    }
    if reco.tris.len() > MAX_TRIANGLES {
        return Err(CommissionError::TooManyTriangles {
            triangles: reco.tris.len(),
        });
    }
    Ok(())
}

/// Reflectances before estimation: the closure's walls and ceiling at theirs, openings black,
/// every seen surface at the start reflectance.
fn start_rho(reco: &RecoMesh, o: &CommissionOptions, room: Option<&RoomBox>) -> Vec<f64> {
    let plan = o.room_plan.as_ref();
    let wall_rho = plan.and_then(|p| p.wall_rho).unwrap_or(o.closure.wall_rho);
    let ceiling_rho = plan
        .and_then(|p| p.ceiling_rho)
        .unwrap_or(o.closure.ceiling_rho);
    let door_rho = |k: u32| match room.and_then(|r| r.openings.get(k as usize)) {
        Some(crate::scene::plan::WallOpening {
            kind: crate::scene::plan::OpeningKind::Door { rho: Some(r) },
            ..
        }) => *r,
        _ => wall_rho,
    };
    reco.part
        .iter()
        .map(|p| match p {
            Part::Wall => wall_rho,
            Part::Ceiling => ceiling_rho,
            Part::Window(_) => mesh::GLAZING_RHO,
            Part::Door(k) => door_rho(*k),
            Part::Opening(_) => 0.0,
            _ => o.start_rho,
        })
        .collect()
}

/// A gain reading to check the final model against: where, the reading, the dimming state.
struct GainReading {
    /// Where the reading was taken.
    at: Reading,
    /// The reading, lx.
    lux_lx: f64,
    /// The dimming state during it.
    levels: Vec<f64>,
}

/// Stages "pass model" and "reflectances": what they give the final model.
struct Reflectances {
    /// Reflectance per mesh triangle.
    tri_rho: Vec<f64>,
    /// With a luxmeter or (through the model) ambient gain: the reading the final model is
    /// checked against.
    reading: Option<GainReading>,
}

/// One reflectance estimate per camera gain, over the pass model's samples.
struct Estimator<'a> {
    samples: reflectance::Samples,
    pass_model: &'a Model,
    reco: &'a RecoMesh,
    start_rho: &'a [f64],
    floor_part: Option<Part>,
    tops_seen: Vec<Part>,
    walls_seen: Vec<Part>,
    pass: Settings,
    o: &'a ReflectanceOptions,
}

impl Estimator<'_> {
    /// The estimate at camera gain `gain` (cd/m² per unit).
    fn run(&self, gain: f64) -> Result<Estimate, CommissionError> {
        reflectance::estimate(
            &self.samples,
            self.pass_model,
            self.reco,
            self.start_rho,
            self.floor_part,
            (&self.tops_seen, &self.walls_seen),
            gain,
            &self.pass,
            self.o,
        )
        .map_err(|source| pass_solve("the reflectance estimate", source))
    }
}

/// A failed solve of the pass model (reflectances, a receiver's reading) as an engine error:
/// never a value from a solve that did not converge.
fn pass_solve(what: &str, source: crate::solver::SolveError) -> CommissionError {
    CommissionError::Engine(EngineError::Solve {
        what: format!("{what} (pass model)"),
        source,
    })
}

/// Stages "pass model" and "reflectances": a cheap model at the start reflectances, every
/// node's pixels sampled against it, and the estimate at the camera's gain (camera.json's, the
/// hooded ambient sensor's, or the one for which the model predicts a reading).
fn estimate_reflectances(
    i: &Inputs,
    depths: &[DepthMap],
    meshed: &Meshed,
    start_rho: &[f64],
    report: &mut Report,
) -> Result<Reflectances, CommissionError> {
    let o = i.o;
    let reco = &meshed.reco;
    let st = Stage::start("pass model", &i.progress);
    let pass = pass_settings(&o.engine);
    let pass_model = run_engine(&i.scene(reco, start_rho), &pass, &mut report.warnings)?;
    let pass = pass_model.settings.clone();
    st.done(report);

    let st = Stage::start("reflectances", &i.progress);
    let caster = RayCaster::new(&pass_model.patches);
    let first = i.first();
    let sample = |k: usize| {
        let on = (&pass_model, &caster, reco);
        reflectance::sample(&i.captures[k], &depths[k], i.luminaires, on, &o.reflectance)
    };
    let mut samples = sample(0);
    // the other nodes' pixels, in the first camera's units
    let g0 = first.camera.luminance_cd_m2_per_unit.unwrap_or(1.0);
    for (k, c) in i.captures.iter().enumerate().skip(1) {
        samples.extend(
            sample(k),
            c.camera.luminance_cd_m2_per_unit.unwrap_or(g0) / g0,
        );
    }
    // seen furniture tops: the inferred desk tops take their reflectance
    let tops_seen: Vec<Part> = meshed
        .plane_at
        .iter()
        .enumerate()
        .filter(|&(k, &(n, _))| Some(k) != meshed.floor_idx && n.z > 0.98)
        .map(|(k, _)| Part::Plane(k as u32))
        .collect();
    let est = Estimator {
        samples,
        pass_model: &pass_model,
        reco,
        start_rho,
        floor_part: meshed.floor_idx.map(|k| Part::Plane(k as u32)),
        tops_seen,
        walls_seen: walls_seen(i, meshed),
        pass,
        o: &o.reflectance,
    };
    let direct = ambient_direct(i, report);
    report.ambient_direct = direct.clone();
    let scale = match o.gain {
        Gain::Camera => first.camera.luminance_cd_m2_per_unit,
        Gain::Luxmeter { .. } | Gain::Ambient { .. } => None,
    };
    let (e, reading) = match (&o.gain, scale) {
        (Gain::Camera, Some(g)) => (est.run(g)?, None),
        (Gain::Ambient { .. }, _) if direct.is_some() => (
            est.run(direct.as_ref().map_or(1.0, |d| d.gain_cd_m2_per_unit))?,
            None,
        ),
        (Gain::Camera, None) => {
            return Err(CommissionError::NoCameraGain);
        }
        (Gain::Luxmeter { .. } | Gain::Ambient { .. }, _) => {
            let (e, r) = gain_through_model(i, reco, &est, &caster, report)?;
            (e, Some(r))
        }
    };
    if e.clamped > 0 {
        report.warnings.push(format!(
            "{} triangles had reflectances outside [{}, {}] and were clamped",
            e.clamped, o.reflectance.rho_min, o.reflectance.rho_max
        ));
    }
    let tri_rho = e.tri_rho.clone();
    report.reflectance = e;
    st.done(report);
    Ok(Reflectances { tri_rho, reading })
}

/// The seen planes on the room's walls, whose reflectance the walls nobody saw take (none when
/// the walls' reflectance is given: `--wall-rho`, the room plan's, a luxmeter refit's).
fn walls_seen(i: &Inputs, meshed: &Meshed) -> Vec<Part> {
    let given = !i.o.closure.wall_rho_from_seen
        || i.o.room_plan.as_ref().is_some_and(|p| p.wall_rho.is_some());
    let Some(room) = meshed.room.as_ref().filter(|_| !given) else {
        return Vec::new();
    };
    meshed
        .plane_at
        .iter()
        .enumerate()
        .filter(|&(k, &(n, origin))| {
            Some(k) != meshed.floor_idx
                && n.z.abs() < 0.1
                && !closure::is_thin_object(room, n, origin)
        })
        .map(|(k, _)| Part::Plane(k as u32))
        .collect()
}

/// With [`Gain::Ambient`]: the sensor's gain straight from the frames, where it sees only what
/// the camera sees (otherwise a warning, and the gain comes through the model).
fn ambient_direct(i: &Inputs, report: &mut Report) -> Option<ambient::DirectGain> {
    let Gain::Ambient {
        normal,
        lux_lx,
        levels,
        response,
        ..
    } = &i.o.gain
    else {
        return None;
    };
    match ambient::direct_gain(
        i.first(),
        response,
        DVec3::from_array(*normal),
        *lux_lx,
        levels,
    ) {
        Ok(d) => {
            tracing::info!(
                "ambient light sensor: the camera's gain measured directly, {:.6} cd/m2 \
                 per unit ({:.1} % of the sensor's view in the image, {:.2} % saturated)",
                d.gain_cd_m2_per_unit,
                100.0 * d.covered,
                100.0 * d.saturated
            );
            Some(d)
        }
        Err(e) => {
            report.warnings.push(format!(
                "ambient light sensor: {e}; the gain comes through the model instead \
                 (its unseen surfaces' default reflectances enter it)"
            ));
            None
        }
    }
}

/// The gain reading of a luxmeter or ambient gain: the reading, the dimming state and where.
fn gain_reading(i: &Inputs) -> Result<GainReading, CommissionError> {
    let (lux_lx, levels, at) = match &i.o.gain {
        Gain::Luxmeter {
            sensor_id,
            lux_lx,
            levels,
        } => {
            let s = i.sensors.iter().position(|s| s.id == *sensor_id).ok_or(
                CommissionError::LuxmeterSensor {
                    sensor_id: *sensor_id,
                },
            )?;
            (*lux_lx, levels.clone(), Reading::Sensor(s, *sensor_id))
        }
        Gain::Ambient {
            position_m,
            normal,
            lux_lx,
            levels,
            ..
        } => (
            *lux_lx,
            levels.clone(),
            Reading::Point(
                DVec3::from_array(*position_m),
                DVec3::from_array(*normal).normalize_or_zero(),
            ),
        ),
        Gain::Camera => unreachable_gain()?,
    };
    if levels.len() != i.luminaires.len() || !(lux_lx.is_finite() && lux_lx > 0.0) {
        return Err(CommissionError::GainReading {
            what: at.what(),
            lux_lx,
            levels: levels.len(),
            luminaires: i.luminaires.len(),
        });
    }
    if let Reading::Point(_, n) = at
        && n == DVec3::ZERO
    {
        return Err(CommissionError::AmbientFacing);
    }
    Ok(GainReading { at, lux_lx, levels })
}

/// The estimate at the gain for which the model reads the luxmeter's (or a bare ambient
/// sensor's) reading: bisection on log(gain) with the pass model, twice: the second time
/// against the target corrected by the final model's reading at the first gain.
fn gain_through_model(
    i: &Inputs,
    reco: &RecoMesh,
    est: &Estimator,
    caster: &RayCaster,
    report: &mut Report,
) -> Result<(Estimate, GainReading), CommissionError> {
    let g = gain_reading(i)?;
    let pass_model = est.pass_model;
    let point = match g.at {
        Reading::Point(p, n) => Some(reflectance::PointReceiver::new(
            pass_model,
            i.luminaires,
            caster,
            p,
            n,
            i.o.gain.response(),
            AMBIENT_RAYS,
        )),
        Reading::Sensor(..) => None,
    };
    let reading = |e: &Estimate| {
        let patch_rho: Vec<f64> = pass_model
            .patches
            .source_triangle
            .iter()
            .map(|&t| e.tri_rho[t as usize])
            .collect();
        match (&g.at, &point) {
            (Reading::Sensor(s, _), _) => {
                reflectance::sensor_reading_lx(pass_model, *s, &g.levels, &patch_rho, &est.pass)
            }
            (_, Some(r)) => r.reading_lx(pass_model, &g.levels, &patch_rho, &est.pass),
            _ => Ok(0.0),
        }
        .map_err(|source| pass_solve("the gain reading", source))
    };
    let bisect = |target: f64| -> Result<Estimate, CommissionError> {
        let (mut lo, mut hi) = (1e-6f64.ln(), 1e3f64.ln());
        let mut best = est.run(1.0)?;
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            let e = est.run(mid.exp())?;
            if reading(&e)? < target {
                lo = mid;
            } else {
                hi = mid;
            }
            best = e;
            if hi - lo < 1e-3 {
                break;
            }
        }
        Ok(best)
    };
    let first = bisect(g.lux_lx)?;
    let pass_reading = reading(&first)?;
    let scene = i.scene(reco, &first.tri_rho);
    let full = run_engine(&scene, &i.o.engine, &mut report.warnings)?;
    let full_reading =
        g.at.final_reading(&scene, &full, &g.levels, i.o.gain.response())?;
    let target = if full_reading > 0.0 {
        g.lux_lx * pass_reading / full_reading
    } else {
        g.lux_lx
    };
    Ok((bisect(target)?, g))
}

/// A sensor reading below this share of the median sensor's, every luminaire at full, is one
/// the model cannot give (the cosine of a desk at the room's far edge is tens of per cent).
const MIN_SENSOR_SHARE: f64 = 0.02;
/// ... or below this, whatever the others read (every sensor under the floor): lx.
const MIN_SENSOR_LX: f64 = 1.0;

/// The commissioned model checks its own result: no desk sensor left (almost) dark with every
/// luminaire at full (issue 28: a wall through a sensor published 0 lx; issue 34: sensors under
/// the floor). Names the sensor, never a silent 0 lx.
fn check_sensors_lit(i: &Inputs, model: &Model) -> Result<(), CommissionError> {
    let all_on: Vec<f64> = model.response_lx.iter().map(|r| r.iter().sum()).collect();
    let mut sorted = all_on.clone();
    sorted.sort_by(f64::total_cmp);
    let Some(&median_lx) = sorted.get(sorted.len() / 2) else {
        return Ok(());
    };
    for (s, &lux_lx) in i.sensors.iter().zip(&all_on) {
        if !(lux_lx.is_finite() && lux_lx >= (MIN_SENSOR_SHARE * median_lx).max(MIN_SENSOR_LX)) {
            return Err(CommissionError::SensorDark {
                id: s.id,
                position_m: s.position_m.to_array(),
                lux_lx,
                median_lx,
            });
        }
    }
    Ok(())
}

/// Stage "engine": the final model at the estimated reflectances; with a gain reading, the
/// model's own reading checked against it; with an ambient sensor, its response per luminaire.
fn final_model(
    i: &Inputs,
    reco: &RecoMesh,
    refl: &Reflectances,
    report: &mut Report,
) -> Result<(Scene, Model), CommissionError> {
    let o = i.o;
    let scene = i.scene(reco, &refl.tri_rho);
    let model = run_engine(&scene, &o.engine, &mut report.warnings)?;
    report.patches = model.patches.len();
    check_sensors_lit(i, &model)?;
    if let Some(GainReading { at, lux_lx, levels }) = &refl.reading {
        let (r, lux) = (
            at.final_reading(&scene, &model, levels, o.gain.response())?,
            *lux_lx,
        );
        let ratio = r / lux;
        if !(refit::MIN_RATIO..=refit::MAX_RATIO).contains(&ratio) {
            return Err(CommissionError::GainReadingImpossible {
                what: at.what(),
                place: at.place(),
                reading_lx: lux,
                model_lx: r,
                ratio,
            });
        }
        if (r - lux).abs() > 0.05 * lux {
            report.warnings.push(format!(
                "{} gain: the model reads {r:.0} lx at {}, not {lux:.0} lx \
                 (reflectances at their limits?)",
                at.what(),
                at.place()
            ));
        }
    }
    if let Gain::Ambient {
        position_m,
        normal,
        response,
        ..
    } = &o.gain
    {
        let p = engine::points::evaluate_with(
            &scene,
            &model,
            &[(
                DVec3::from_array(*position_m),
                DVec3::from_array(*normal).normalize_or_zero(),
            )],
            AMBIENT_RAYS,
            response,
        );
        report.ambient_response_lx = p.per_luminaire_lx.into_iter().next();
    }
    Ok((scene, model))
}

/// Commissions one room from the capture sets of several nodes (each camera with its pose in
/// the room's frame): one room model, and one [`Commissioned`] per node with that node's camera,
/// depth and sensor flags (each node serves the desks it sees; every node's model holds the
/// whole room).
///
/// Each node's depth is meshed on its own. The floor is one plane for the room: the first node
/// that found a floor meshes it over the room box, its cells seen where any node saw floor, the
/// rest inferred. Every other seen triangle is kept by the node nearest to it among those that
/// see it, so a surface two nodes see is modelled once. Reflectances come from every node's
/// frames, each at its camera's gain (several nodes need their gains in camera.json).
///
/// The stages, each a function: depth fusion ([`fuse_depths`]: depth maps), planes
/// ([`find_planes`]: [`NodePlanes`]), mesh ([`mesh_room`]: [`Meshed`]), closure
/// ([`close_room`]), reflectances ([`estimate_reflectances`]: [`Reflectances`]), engine
/// ([`final_model`]: scene and model), uncertainty ([`uncertainty::per_sensor`]).
pub fn from_captures(
    captures: &[Capture],
    luminaires: Vec<Luminaire>,
    sensors: Vec<Sensor>,
    desks: Option<Desks>,
    o: &CommissionOptions,
) -> Result<Vec<Commissioned>, CommissionError> {
    o.validate()?;
    if !o.readings.is_empty() {
        return with_readings(captures, luminaires, sensors, desks, o);
    }
    let i = Inputs {
        captures,
        luminaires: &luminaires,
        sensors: &sensors,
        desks: desks.as_ref(),
        o,
        progress: Progress::new(o.progress, stage_count(o)),
    };
    check_captures(&i)?;
    let mut report = Report {
        warnings: captures.iter().flat_map(|c| c.warnings.clone()).collect(),
        ..Report::default()
    };

    let st = Stage::start("depth", &i.progress);
    let depths = fuse_depths(&i)?;
    report.depth = depths[0].stats;
    st.done(&mut report);

    let st = Stage::start("planes", &i.progress);
    let planes = find_planes(&i, &depths);
    st.done(&mut report);

    let st = Stage::start("pose", &i.progress);
    pose::check(&i, &planes, &mut report)?;
    st.done(&mut report);

    let st = Stage::start("mesh", &i.progress);
    let mut meshed = mesh_room(&i, &depths, &planes, &mut report)?;
    st.done(&mut report);

    let st = Stage::start("closure", &i.progress);
    close_room(&i, &mut meshed, &mut report)?;
    st.done(&mut report);

    let start_rho = start_rho(&meshed.reco, o, meshed.room.as_ref());
    let refl = if o.estimate_reflectances {
        estimate_reflectances(&i, &depths, &meshed, &start_rho, &mut report)?
    } else {
        Reflectances {
            tri_rho: start_rho,
            reading: None,
        }
    };

    let st = Stage::start("engine", &i.progress);
    let (scene, model) = final_model(&i, &meshed.reco, &refl, &mut report)?;
    st.done(&mut report);

    let st = Stage::start("uncertainty", &i.progress);
    let placement =
        placement::wall_placement_lx(&i, &depths, &planes, &meshed, &refl, &model, &mut report);
    let sigma = o.uncertainty.with_plan(o.room_plan.as_ref());
    // an unseen monitor stands on a desk: a sensor out of view on a declared desk (on any,
    // without desks.json) may be behind one
    let desks = i.desks.map(|d| &d.desks[..]);
    let out_of_view: Vec<bool> = out_of_every_view(captures, &depths, &scene.sensors)
        .into_iter()
        .zip(&scene.sensors)
        .map(|(out, s)| out && desks.is_none_or(|d| closure::on_a_desk(d, s.position_m)))
        .collect();
    let occluders = uncertainty::unseen_occluder_lx(
        &model,
        &scene.sensors,
        &scene.luminaires,
        desks.unwrap_or(&[]),
        meshed.room.as_ref().map(|r| r.xy_m),
        &out_of_view,
    );
    match uncertainty::per_sensor(
        &model,
        &meshed.reco,
        &sigma,
        &occluders,
        placement.as_deref(),
    ) {
        Ok(u) => report.uncertainty = u,
        Err(e) => report
            .warnings
            .push(format!("the desks' stated uncertainty: {e}")),
    }
    st.done(&mut report);
    Ok(per_node(
        captures,
        depths,
        scene,
        model,
        meshed.reco,
        report,
    ))
}

/// One [`Commissioned`] per node: its camera, depth and view of the desks; the room's model.
fn per_node(
    captures: &[Capture],
    depths: Vec<DepthMap>,
    scene: Scene,
    model: Model,
    reco: RecoMesh,
    report: Report,
) -> Vec<Commissioned> {
    captures
        .iter()
        .zip(depths)
        .map(|(c, depth)| {
            let scene = Scene {
                camera: Some(c.camera.clone()),
                ..scene.clone()
            };
            let flags = sensor_flags_for(&scene, &depth, &reco, &model);
            Commissioned {
                scene,
                model: model.clone(),
                reco: reco.clone(),
                depth,
                sensor_flags: flags,
                report: report.clone(),
                uncalibrated_all_on_lx: Vec::new(),
            }
        })
        .collect()
}

/// Flags per sensor: out of view when the camera does not see its position (outside the
/// image, or something nearer along the ray); estimated when the surface under it was inferred.
pub fn sensor_flags_for(
    scene: &Scene,
    depth: &DepthMap,
    reco: &RecoMesh,
    model: &Model,
) -> Vec<u8> {
    let Some(cam) = &scene.camera else {
        return vec![0; scene.sensors.len()];
    };
    let caster = RayCaster::new(&model.patches);
    scene
        .sensors
        .iter()
        .map(|s| {
            let mut f = 0;
            let p_cam = cam.camera_from_world(s.position_m);
            let visible = cam
                .pixel_of(s.position_m)
                .is_some_and(|(u, v)| depth.at(u, v).is_none_or(|z| z >= p_cam.z - 0.05));
            if !visible {
                f |= sensor_flags::OUT_OF_VIEW;
            }
            let under = engine::points::surface_below(
                &caster,
                s.position_m.x,
                s.position_m.y,
                s.position_m.z + 0.02,
            );
            let inferred = match under {
                Some((_, patch)) => {
                    let t = model.patches.source_triangle[patch as usize] as usize;
                    !reco.part.get(t).is_some_and(|p| p.seen())
                }
                None => true,
            };
            if inferred {
                f |= sensor_flags::ESTIMATED;
            }
            f
        })
        .collect()
}
