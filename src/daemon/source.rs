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
    /// Where to write the commissioning report picture (camera view, false-colour lux, desks);
    /// only with the `report` feature.
    pub report_png: Option<std::path::PathBuf>,
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
        #[cfg(feature = "report")]
        if let Some(path) = &self.report_png {
            match crate::render::camera_view::report_png(&c, path) {
                Ok(()) => tracing::info!("commission: report picture {}", path.display()),
                // a picture for people: its failure never stops the node
                Err(e) => tracing::warn!("commission: report picture {}: {e}", path.display()),
            }
        }
        let mut options = self.image.clone();
        options.scene_name = format!("{} (commissioned from cameras)", c.scene.name);
        options.sensor_flags = c.sensor_flags.clone();
        let image = build_for_region(&c.model, &options, formfactors_region_bytes())?;
        Ok(with_live_section(image, &c, &seq.capture))
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
