//! Commissioning from cameras: the first boot's [`CommissionSource`] of a board with cameras.
//!
//! The sequence is the issue's: depth frames, then one luminaire on at a time (and all on, as
//! a consistency check), all off at the end ([`crate::camera::capture_sequence_with`]); then
//! commissioning from that capture ([`crate::commission::commission`]) with the luminaires'
//! installed positions and photometry and the desk sensors (known: luminaires.json,
//! sensors.json), and the flash image with the sensors' quality flags.

use std::time::Instant;

use super::{CommissionSource, SourceError};
use crate::camera::{
    CameraError, DepthCamera, LightControl, LuminanceCamera, SequenceOptions, capture_sequence_with,
};
use crate::commission::{self, CommissionOptions};
use crate::image_build::{ImageOptions, build_for_region, formfactors_region_bytes};
use crate::modbus::gateway::GatewayWriter;
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
                        &crate::render::report::ReportOptions::default(),
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
        let c = commission::from_capture(
            &seq.capture,
            self.luminaires.clone(),
            self.sensors.clone(),
            self.desks.clone(),
            &self.commission,
        )?;
        let r = &c.report;
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
        let mut options = self.image.clone();
        options.scene_name = format!("{} (commissioned from cameras)", c.scene.name);
        options.sensor_flags = c.sensor_flags.clone();
        options.geometry = Some(self.report.section(&c.scene, &c.model));
        let image = build_for_region(&c.model, &options, formfactors_region_bytes())?;
        let bytes = with_live_section(image, &c, &seq.capture);
        self.report.write(&bytes);
        Ok(bytes)
    }
}

/// The image with its live-light section (crate::live), or as it is when the section cannot be
/// built or does not fit (the node then serves the model only, and says so).
fn with_live_section(
    image: Vec<u8>,
    c: &commission::Commissioned,
    capture: &crate::camera::capture::Capture,
) -> Vec<u8> {
    let o = crate::live::SectionOptions::default();
    match crate::live::attach(
        &image,
        |o| crate::live::from_capture(c, capture, o),
        &o,
        formfactors_region_bytes(),
    ) {
        Ok(Some(bytes)) => {
            tracing::info!(
                "commission: live-light section of {} bytes added",
                bytes.len() - image.len()
            );
            bytes
        }
        Ok(None) => {
            tracing::warn!(
                "commission: no room for the live-light section in the flash region; live light \
                 is off"
            );
            image
        }
        Err(e) => {
            tracing::warn!("commission: live-light section: {e}; live light is off");
            image
        }
    }
}
