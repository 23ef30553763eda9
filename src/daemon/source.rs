//! Commissioning from cameras: the first boot's [`CommissionSource`] of a board with cameras.
//!
//! The sequence is the issue's: depth frames, then one luminaire on at a time (and all on, as
//! a consistency check), all off at the end ([`crate::camera::capture_sequence_with`]); then
//! commissioning from that capture ([`crate::commission::from_captures`]) with the luminaires'
//! installed positions and photometry and the desk sensors (known: luminaires.json,
//! sensors.json), and the flash image with the sensors' quality flags.

use std::time::Instant;

use super::{CommissionSource, SourceError};
use crate::camera::{
    CameraError, DepthCamera, LightControl, LuminanceCamera, Sequence, SequenceOptions,
    capture_sequence_with,
};
use crate::commission::{self, CommissionOptions, Commissioned};
use crate::fieldbus::gateway::GatewayWriter;
use crate::image_build::{ImageOptions, formfactors_region_bytes};
use crate::scene::{Desks, Luminaire, Sensor};

/// The DALI gateway switches the luminaires for the capture.
impl LightControl for GatewayWriter {
    fn set_levels(&mut self, levels: &[f64]) -> Result<(), CameraError> {
        self.write_levels(levels)
            .map_err(|e| CameraError::Lights(e.to_string()))
    }
}

/// Cameras, the lights they need switched, and what is known of the room.
pub struct CameraSource {
    /// What the cameras are ("simulated ToF + luminance over the demo office").
    pub what: String,
    /// Depth camera.
    pub depth: Box<dyn DepthCamera>,
    /// Luminance camera.
    pub colour: Box<dyn LuminanceCamera>,
    /// Switches the luminaires.
    pub lights: Box<dyn LightControl>,
    /// Installed luminaires (positions, photometry).
    pub luminaires: Vec<Luminaire>,
    /// Desk sensors.
    pub sensors: Vec<Sensor>,
    /// Desk outlines, if known.
    pub desks: Option<Desks>,
    /// Capture sequence.
    pub sequence: SequenceOptions,
    /// Commissioning.
    pub commission: CommissionOptions,
    /// Image.
    pub image: ImageOptions,
    /// The commissioning record and where to write the report (`report.html`, `results.json`;
    /// written only with the `report` feature).
    pub report: ReportTarget,
    /// The node's ambient light sensor, if fitted: the camera's absolute gain at commissioning.
    pub ambient: Option<AmbientAtCommissioning>,
}

/// What the commissioning report records, and where it goes.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportTarget {
    /// The directory for `report.html` and `results.json` (none: no report written).
    pub dir: Option<std::path::PathBuf>,
    /// The preset's name.
    pub preset: String,
    /// The installation's maintenance factor.
    pub maintenance_factor: f64,
    /// The EN 12464-1:2021 context modifiers declared (the board's `[engine]
    /// context_modifiers`).
    pub context_modifiers: u32,
}

impl ReportTarget {
    /// The image's geometry section for a commissioned scene and model (the report's input).
    pub fn section(
        &self,
        scene: &crate::scene::Scene,
        model: &crate::engine::Model,
    ) -> crate::store::geometry::GeometrySection {
        crate::image_geometry::section_of(
            scene,
            model,
            &crate::image_geometry::CommissionRecord {
                preset: self.preset.clone(),
                maintenance_factor: self.maintenance_factor,
                ..Default::default()
            },
        )
    }

    /// Writes the report of a built image, if there is a directory and the `report` feature; a
    /// failure is logged, never fatal (a report is for people; the node serves without it).
    pub fn write(&self, image_bytes: &[u8]) {
        let Some(dir) = &self.dir else {
            return;
        };
        #[cfg(feature = "report")]
        {
            let done = crate::store::Image::parse(image_bytes)
                .map_err(|e| e.to_string())
                .and_then(|image| {
                    let r = crate::render::report::compute(
                        &image,
                        &crate::render::report::ReportOptions {
                            requirement: crate::en12464::OFFICE_WRITING_READING
                                .with_context_modifiers(self.context_modifiers),
                            ..Default::default()
                        },
                    )
                    .map_err(|e| e.to_string())?;
                    crate::render::report::write(&r, dir).map_err(|e| e.to_string())?;
                    Ok(r.results.seconds)
                });
            match done {
                Ok(s) => tracing::info!(
                    "commission: report {} ({s:.1} s)",
                    dir.join("report.html").display()
                ),
                Err(e) => tracing::warn!("commission: report in {}: {e}", dir.display()),
            }
        }
        #[cfg(not(feature = "report"))]
        {
            let _ = image_bytes;
            tracing::info!(
                "commission: no report in {} (a build without the report feature)",
                dir.display()
            );
        }
    }
}

/// Conversions averaged in the ambient light sensor's calibration reading.
const AMBIENT_CONVERSIONS: u8 = 4;

/// The ambient light sensor as commissioning uses it.
pub struct AmbientAtCommissioning {
    /// The sensor (shared with the run-time monitor).
    pub sensor: std::sync::Arc<std::sync::Mutex<crate::peripherals::node::AmbientSensor>>,
    /// Where it is and which way it faces, m.
    pub pose: ([f64; 3], [f64; 3]),
    /// Its angular response (a hooded sensor's cone, or a bare cosine sensor).
    pub response: crate::lsc::AngularResponse,
    /// Where the run-time check's reference goes ([`AmbientReference`]).
    pub reference: std::path::PathBuf,
}

/// The run-time check's reference, written at commissioning next to the image: the ALS's
/// reading per luminaire at 100 % as the commissioned model predicts it, tied to the image by
/// its payload CRC (a reference of another image is never used).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AmbientReference {
    /// The image's payload CRC-32.
    pub image_payload_crc32: u32,
    /// The sensor's position, m.
    pub position_m: [f64; 3],
    /// Its facing.
    pub normal: [f64; 3],
    /// Predicted reading per luminaire at 100 %, lx.
    pub per_luminaire_lx: Vec<f64>,
}

impl AmbientReference {
    /// Reads a reference; `None` (with the reason logged) if it is missing, unreadable or for
    /// another image.
    pub fn load(
        path: &std::path::Path,
        image_payload_crc32: u32,
        luminaires: usize,
    ) -> Option<Self> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) => {
                tracing::info!(
                    "ambient light check: no reference ({}: {e}); it starts after the next commissioning",
                    path.display()
                );
                return None;
            }
        };
        match serde_json::from_str::<Self>(&text) {
            Ok(r)
                if r.image_payload_crc32 == image_payload_crc32
                    && r.per_luminaire_lx.len() == luminaires
                    && r.per_luminaire_lx
                        .iter()
                        .all(|x| x.is_finite() && *x >= 0.0) =>
            {
                Some(r)
            }
            Ok(_) => {
                tracing::warn!(
                    "ambient light check: {} belongs to another image; the check is off until the next commissioning",
                    path.display()
                );
                None
            }
            Err(e) => {
                tracing::warn!("ambient light check: {}: {e}", path.display());
                None
            }
        }
    }

    /// The predicted reading for a dimming state, lx.
    pub fn predict_lx(&self, levels: &[f64]) -> f64 {
        self.per_luminaire_lx
            .iter()
            .zip(levels)
            .map(|(a, x)| a * x)
            .sum()
    }
}

/// How many times the ALS is read at commissioning before giving up on it.
const AMBIENT_TRIES: usize = 3;

impl CommissionSource for CameraSource {
    fn describe(&self) -> String {
        format!(
            "{} ({} luminaires, {} desk sensors)",
            self.what,
            self.luminaires.len(),
            self.sensors.len()
        )
    }

    fn commission(&mut self) -> Result<Vec<u8>, SourceError> {
        super::check_served(self.sensors.len(), self.luminaires.len())?;
        let seq = self.capture()?;
        let mut options = self.commission.clone();
        self.ambient_gain(&mut options);
        let go = |o: &CommissionOptions| {
            commission::from_capture(
                &seq.capture,
                self.luminaires.clone(),
                self.sensors.clone(),
                self.desks.clone(),
                o,
            )
        };
        let mut c = match go(&options) {
            // the board's luxmeter readings need a gain they do not change: the sensor's,
            // measured directly, or else the camera's own
            Err(e)
                if !options.readings.is_empty()
                    && matches!(options.gain, commission::Gain::Ambient { .. }) =>
            {
                tracing::warn!("commission: {e}; the camera's own gain instead");
                options.gain = commission::Gain::Camera;
                go(&options)?
            }
            r => r?,
        };
        if let commission::Gain::Ambient { .. } = options.gain {
            log_ambient_gain(
                c.report.reflectance.gain_cd_m2_per_unit,
                seq.capture.camera.luminance_cd_m2_per_unit,
            );
        }
        log_report(&c.report);
        let calibrated = crate::live_section::calibrate::calibrate_desks(
            core::slice::from_mut(&mut c),
            core::slice::from_ref(&seq.capture),
        );
        crate::live_section::calibrate::log(&calibrated);
        let bytes = self.image(&c, &seq)?;
        self.report.write(&bytes);
        self.write_reference(&bytes, &c);
        Ok(bytes)
    }
}

impl CameraSource {
    /// The capture sequence, one log line per kind of step.
    fn capture(&mut self) -> Result<Sequence, SourceError> {
        let ids: Vec<u32> = self.luminaires.iter().map(|l| l.id).collect();
        let t0 = Instant::now();
        let mut last = String::new();
        let mut progress = |step: usize, total: usize, what: &str| {
            // one line per kind of step, not per frame
            let kind = what.split_whitespace().next().unwrap_or("").to_string();
            if kind != last {
                tracing::info!("capture: {what} ({step}/{total})");
                last = kind;
            }
        };
        let seq = capture_sequence_with(
            self.depth.as_mut(),
            self.colour.as_mut(),
            self.lights.as_mut(),
            &ids,
            &self.sequence,
            &mut progress,
        )?;
        tracing::info!(
            "capture: {} depth frames, {} luminance frames in {:.2} s; {} retries{}",
            seq.capture.depth_mm.len(),
            seq.capture.luminance.len(),
            t0.elapsed().as_secs_f64(),
            seq.retries_used,
            seq.superposition_error.map_or(String::new(), |e| format!(
                "; all-on frame vs sum of singles: {:.2} %",
                e * 100.0
            ))
        );
        for w in &seq.capture.warnings {
            tracing::warn!("capture: {w}");
        }
        Ok(seq)
    }

    /// With an ambient light sensor, the camera's absolute gain from what the luminaires give
    /// the sensor (else the camera's own calibration).
    fn ambient_gain(&mut self, options: &mut CommissionOptions) {
        let ambient = self.ambient.take();
        if let Some(a) = &ambient {
            match self.read_ambient(a) {
                Ok(lux) => {
                    tracing::info!(
                        "ambient light sensor: the luminaires give it {lux:.2} lx; the camera's \
                     absolute gain comes from it"
                    );
                    options.gain = commission::Gain::Ambient {
                        position_m: a.pose.0,
                        normal: a.pose.1,
                        lux_lx: lux,
                        levels: vec![1.0; self.luminaires.len()],
                        response: a.response.clone(),
                    };
                }
                Err(e) => tracing::warn!(
                    "ambient light sensor: {e}; the camera's own calibration gives the gain"
                ),
            }
        }
        self.ambient = ambient;
    }

    /// The flash image of a commissioned room, with its live light section, fitted to the
    /// flash region.
    fn image(&self, c: &Commissioned, seq: &Sequence) -> Result<Vec<u8>, SourceError> {
        let mut options = self.image.clone();
        options.scene_name = format!("{} (commissioned from cameras)", c.scene.name);
        options.sensor_flags = c.sensor_flags.clone();
        let mut section = self.report.section(&c.scene, &c.model);
        section.unseen_walls = crate::image_geometry::unseen_walls_of(&c.report);
        options.geometry = Some(section);
        let plan = self.commission.room_plan.as_ref();
        let daylight = crate::daylight_section::reserve_bytes(plan, c.scene.sensors.len());
        let image = crate::image_build::build_to_fit(
            &c.model,
            &options,
            formfactors_region_bytes(),
            crate::image_build::SECTION_RESERVE_BYTES + daylight,
        )?;
        if image.step > 0 {
            tracing::warn!(
                "commission: the model is stored at {} with form factors below {:.0e} dropped, to \
             fit the flash region with room for live light",
                image.options.precision.name(),
                image.options.prune_below
            );
        }
        let image = image.bytes;
        let bytes = crate::live_section::with_capture_section(image, c, &seq.capture, daylight);
        Ok(crate::daylight_section::with_daylight_section(
            bytes, c, plan,
        ))
    }

    /// The ambient light check's reference: what the luminaires give the sensor, for the
    /// image just built.
    fn write_reference(&self, bytes: &[u8], c: &Commissioned) {
        if let (Some(a), Some(per)) = (&self.ambient, &c.report.ambient_response_lx)
            && let Ok(h) = crate::store::Header::parse(bytes)
        {
            let r = AmbientReference {
                image_payload_crc32: h.payload_crc32,
                position_m: a.pose.0,
                normal: a.pose.1,
                per_luminaire_lx: per.clone(),
            };
            let written = serde_json::to_string_pretty(&r)
                .map_err(std::io::Error::other)
                .and_then(|t| std::fs::write(&a.reference, t));
            match written {
                Ok(()) => tracing::info!(
                    "ambient light check: reference {} ({:.1} lx with every luminaire on)",
                    a.reference.display(),
                    per.iter().sum::<f64>()
                ),
                Err(e) => tracing::warn!(
                    "ambient light check: cannot write {}: {e}",
                    a.reference.display()
                ),
            }
        }
    }
}

/// The camera gain the ambient light sensor gave (`g`), against the camera's calibration
/// (`camera_gain`), cd/m² per unit.
fn log_ambient_gain(g: f64, camera_gain: Option<f64>) {
    match camera_gain {
        Some(k) => tracing::info!(
            "camera gain from the ambient light sensor: {g:.6} cd/m2 per unit; the \
             camera's calibration says {k:.6} ({:+.2} %)",
            100.0 * (g / k - 1.0)
        ),
        None => tracing::info!("camera gain from the ambient light sensor: {g:.6} cd/m2 per unit"),
    }
    if let Some(k) = camera_gain
        && (g / k - 1.0).abs() > 0.10
    {
        tracing::warn!(
            "camera gain: the ambient light sensor and the camera's calibration differ \
             by {:+.1} %: check the camera's exposure and calibration",
            100.0 * (g / k - 1.0)
        );
    }
}

/// The commissioning report's summary in the log.
fn log_report(r: &commission::Report) {
    if let Some(f) = &r.reflectance_fit {
        tracing::info!("commission: {f}");
    }
    for (name, dt) in &r.timings {
        tracing::info!("commission: {name} {:.0} ms", dt.as_secs_f64() * 1e3);
    }
    tracing::info!(
        "commission: {} planes, {} triangles (seen {:.1} m², inferred {:.1} m²), {} patches, {} warnings",
        r.planes.len(),
        r.triangles,
        r.seen_area_m2,
        r.inferred_area_m2,
        r.patches,
        r.warnings.len()
    );
}

impl CameraSource {
    /// The luminaires' own light at the ALS: a reading with every luminaire on less one with
    /// them all off (each after the settle time), so daylight during commissioning enters
    /// neither the gain nor the reference. Leaves the lights off.
    fn read_ambient(&mut self, a: &AmbientAtCommissioning) -> Result<f64, String> {
        let n = self.luminaires.len();
        let mut read_at = |level: f64| -> Result<f64, String> {
            self.lights
                .set_levels(&vec![level; n])
                .map_err(|e| format!("switching the lights to {level}: {e}"))?;
            std::thread::sleep(self.sequence.settle);
            let mut last = String::new();
            for _ in 0..AMBIENT_TRIES {
                let r = a
                    .sensor
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .measure_precise(AMBIENT_CONVERSIONS);
                match r {
                    Ok(r) => return Ok(r.lux_lx),
                    Err(e) => last = e,
                }
            }
            Err(last)
        };
        let on = read_at(1.0);
        // the lights go off whatever the first reading did
        let off = read_at(0.0);
        let (on, off) = (on?, off?);
        let lux = on - off;
        if off > 0.5 {
            tracing::info!(
                "ambient light sensor: {on:.2} lx with every luminaire on, {off:.2} lx with them \
                 off (daylight): the luminaires give {lux:.2} lx"
            );
        }
        if lux > 0.5 && lux.is_finite() {
            Ok(lux)
        } else {
            Err(format!(
                "the luminaires give {lux:.2} lx at the sensor ({on:.2} lx on, {off:.2} lx off): \
                 too little light to calibrate on"
            ))
        }
    }
}
