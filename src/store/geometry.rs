//! The geometry section (std): what a commissioning report needs beyond the run-time arrays
//! (`docs/report.md` says why it lives in the image): the patches' corners and surface labels,
//! the camera, the desk outlines, the sensors, the luminaires with their photometry as used,
//! and the record of the commissioning (scene, preset, date, software version, maintenance
//! factor).
//!
//! It follows the version-1 payload inside the payload's length and CRC, framed as
//! `"LXGS" | section version (u16 LE) | length (u32 LE) | postcard bytes`. A build that does not
//! know it reads the image as before (postcard ignores the bytes after the payload); this one
//! reads images without it (an image of an older build) as images without a report section.
//! The run-time core only checks the frame ([`super::Image::geometry_bytes`]); this module
//! decodes it.
//!
//! Extensions follow the section's postcard bytes inside its length, as postcard bytes of
//! [`SectionExtension`]: a build that does not know them stops reading at the end of the
//! section (postcard ignores trailing bytes); this one reads a section without them as before.
//! The first extension is the camera's lens (a fisheye's Kannala-Brandt coefficients); the
//! second ([`LampExtension`], after the first) the lamps' colour rendering per photometry; the
//! third ([`InferredExtension`]) the walls commissioning placed without seeing them. Each is read
//! when bytes remain after the one before.

use serde::{Deserialize, Serialize};

use super::{ImageError, SECTION_FRAME_LEN, SECTION_MAGIC, SECTION_VERSION};

/// The camera, as commissioning used it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraRecord {
    /// Optical centre, m.
    pub position_m: [f64; 3],
    /// Rotation, columns = camera x, y, z axes in world, column-major.
    pub world_from_camera: [f64; 9],
    /// Focal lengths and principal point, pixels: fx, fy, cx, cy.
    pub intrinsics_px: [f64; 4],
    /// Width and height, pixels.
    pub size_px: [u32; 2],
    /// Kannala-Brandt k1..k4 of a fisheye lens, `None` for a pinhole (carried in the
    /// [`SectionExtension`]).
    #[serde(skip)]
    pub lens_k: Option<[f64; 4]>,
}

/// What follows the section's own bytes (see the module's documentation).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SectionExtension {
    /// The camera lens's Kannala-Brandt coefficients, `None` for a pinhole.
    pub camera_lens_k: Option<[f64; 4]>,
}

/// The second extension: what the photometry files say of their lamps, one entry per
/// [`GeometrySection::photometries`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LampExtension {
    /// Per photometry: the colour rendering field as the file states it, and the least Ra it
    /// means (`None`: not stated).
    pub colour_rendering: Vec<(String, Option<f64>)>,
}

/// The third extension: what commissioning placed without seeing it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct InferredExtension {
    /// See [`GeometrySection::unseen_walls`].
    pub unseen_walls: Vec<UnseenWallRecord>,
}

/// A side of the room box that no camera saw and the luminaire grid did not place: commissioning
/// put it at the seen floor's extent (or behind the sensors), and its position's uncertainty is
/// in every desk's stated uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnseenWallRecord {
    /// Which side: `x low`, `y low`, `x high` or `y high`.
    pub side: String,
    /// Where it was put: its x or y, m.
    pub at_m: f64,
    /// How much farther out it was moved to state its position's uncertainty, m.
    pub moved_m: f64,
}

/// A desk top.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeskRecord {
    /// Id.
    pub id: u32,
    /// Its group label.
    pub group: String,
    /// x0, x1, y0, y1, m.
    pub extent_m: [f64; 4],
    /// Height of the top, m.
    pub z_m: f64,
}

/// A desk sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorRecord {
    /// Id.
    pub id: u32,
    /// Position, m.
    pub position_m: [f64; 3],
    /// Unit normal.
    pub normal: [f64; 3],
}

/// An installed luminaire.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LuminaireRecord {
    /// Id.
    pub id: u32,
    /// Name.
    pub name: String,
    /// Centre of the opening, m.
    pub position_m: [f64; 3],
    /// Aim (γ = 0), C0 and C90 directions, unit vectors.
    pub axes: [[f64; 3]; 3],
    /// Opening along C0 and C90, m.
    pub opening_m: [f64; 2],
    /// Circular opening.
    pub opening_circular: bool,
    /// Flux at 100 %, lm.
    pub flux_lm: f64,
    /// Index into [`GeometrySection::photometries`].
    pub photometry: u32,
}

/// An intensity distribution as the engine used it (scaled to the luminaire's flux, tilt
/// applied), with the file it came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhotometryRecord {
    /// The file's name (no directory).
    pub file_name: String,
    /// The luminaire named in the file.
    pub luminaire: String,
    /// The manufacturer named in the file.
    pub manufacturer: String,
    /// The file's own flux before scaling, lm.
    pub file_flux_lm: f64,
    /// Input power from the file, W (NaN when it gives none).
    pub power_w: f64,
    /// Full C grid, degrees.
    pub c_deg: Vec<f64>,
    /// γ grid, degrees.
    pub gamma_deg: Vec<f64>,
    /// Intensities, cd, `[ic * gammas + ig]`.
    pub cd: Vec<f32>,
    /// The lamps' colour rendering field as the file states it (EULUMDAT's group / index), empty
    /// when none (carried in the [`LampExtension`]).
    #[serde(skip)]
    pub colour_rendering: String,
    /// The least Ra it means, `None` when not stated (carried in the [`LampExtension`]).
    #[serde(skip)]
    pub ra_min: Option<f64>,
}

/// Everything a report needs that the run-time arrays do not hold.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeometrySection {
    /// The scene's name.
    pub scene_name: String,
    /// The preset commissioning used (`balanced`...), or `custom`.
    pub preset: String,
    /// When it was commissioned, seconds since 1970 (UTC).
    pub commissioned_unix_s: u64,
    /// The software that commissioned it (`luxnode 0.1.0`).
    pub software: String,
    /// The maintenance factor of the installation (the board's setting).
    pub maintenance_factor: f64,
    /// Surface group labels.
    pub groups: Vec<String>,
    /// Corners of each patch, m, as x0 y0 z0 x1 ... (f32), counter-clockwise seen from the front.
    pub patch_corners_m: Vec<[f32; 9]>,
    /// The group of each patch.
    pub patch_group: Vec<u32>,
    /// The camera, if there is one.
    pub camera: Option<CameraRecord>,
    /// Desk tops.
    pub desks: Vec<DeskRecord>,
    /// Desk sensors, in the image's sensor order.
    pub sensors: Vec<SensorRecord>,
    /// Luminaires, in the image's luminaire order.
    pub luminaires: Vec<LuminaireRecord>,
    /// Distinct intensity distributions.
    pub photometries: Vec<PhotometryRecord>,
    /// The walls commissioning placed without seeing them (carried in the
    /// [`InferredExtension`]; empty in images from before it and in CAD models).
    #[serde(skip)]
    pub unseen_walls: Vec<UnseenWallRecord>,
}

impl GeometrySection {
    /// The framed section, to append after the version-1 payload.
    pub fn encode(&self) -> Result<Vec<u8>, postcard::Error> {
        let mut body = postcard::to_stdvec(self)?;
        let ext = SectionExtension {
            camera_lens_k: self.camera.as_ref().and_then(|c| c.lens_k),
        };
        body.extend_from_slice(&postcard::to_stdvec(&ext)?);
        let lamps = LampExtension {
            colour_rendering: self
                .photometries
                .iter()
                .map(|p| (p.colour_rendering.clone(), p.ra_min))
                .collect(),
        };
        body.extend_from_slice(&postcard::to_stdvec(&lamps)?);
        let inferred = InferredExtension {
            unseen_walls: self.unseen_walls.clone(),
        };
        body.extend_from_slice(&postcard::to_stdvec(&inferred)?);
        let mut out = Vec::with_capacity(SECTION_FRAME_LEN + body.len());
        out.extend_from_slice(&SECTION_MAGIC);
        out.extend_from_slice(&SECTION_VERSION.to_le_bytes());
        out.extend_from_slice(&(body.len() as u32).to_le_bytes());
        out.extend_from_slice(&body);
        Ok(out)
    }

    /// Decodes the section's bytes ([`super::Image::geometry_bytes`]).
    pub fn decode(bytes: &[u8]) -> Result<GeometrySection, ImageError> {
        let (mut section, rest): (GeometrySection, &[u8]) =
            postcard::take_from_bytes(bytes).map_err(|_| ImageError::Decode)?;
        if rest.is_empty() {
            return Ok(section);
        }
        let (ext, rest): (SectionExtension, &[u8]) =
            postcard::take_from_bytes(rest).map_err(|_| ImageError::Decode)?;
        if let Some(c) = section.camera.as_mut() {
            c.lens_k = ext.camera_lens_k;
        }
        if rest.is_empty() {
            return Ok(section);
        }
        let (lamps, rest): (LampExtension, &[u8]) =
            postcard::take_from_bytes(rest).map_err(|_| ImageError::Decode)?;
        if lamps.colour_rendering.len() != section.photometries.len() {
            return Err(ImageError::Decode);
        }
        for (p, (stated, ra)) in section.photometries.iter_mut().zip(lamps.colour_rendering) {
            p.colour_rendering = stated;
            p.ra_min = ra;
        }
        if rest.is_empty() {
            return Ok(section);
        }
        let inferred: InferredExtension =
            postcard::from_bytes(rest).map_err(|_| ImageError::Decode)?;
        if inferred
            .unseen_walls
            .iter()
            .any(|w| !(w.at_m.is_finite() && w.moved_m.is_finite()))
        {
            return Err(ImageError::Decode);
        }
        section.unseen_walls = inferred.unseen_walls;
        Ok(section)
    }
}
