//! The JSON files of a scene directory, their validation, and the whole-directory loader.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DMat3, DVec3};
use serde::Deserialize;

use super::obj::load_obj;
use super::{Camera, Desk, Desks, Luminaire, Scene, SceneError, SceneErrors, Sensor, read_text};
use crate::lsc::{AngularResponse, Lsc};
use crate::photometry::IntensityDistribution;

/// Which photometric file to use when a luminaire names both.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PhotometryPreference {
    /// EULUMDAT when given, else IES.
    #[default]
    Ldt,
    /// IES when given, else EULUMDAT.
    Ies,
}

/// How to read a scene directory.
#[derive(Debug, Clone)]
pub struct LoadOptions {
    /// Length of one file unit in metres (1 for metres, 0.001 for millimetres). Applies to
    /// OBJ coordinates and JSON positions; fields named `_m` are always metres.
    pub unit_to_m: f64,
    /// Which photometric file wins when a luminaire names both.
    pub photometry: PhotometryPreference,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            unit_to_m: 1.0,
            photometry: PhotometryPreference::Ldt,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LuminaireJson {
    id: u32,
    #[serde(default)]
    name: String,
    position: [f64; 3],
    aim: [f64; 3],
    #[serde(default)]
    rotation_deg: f64,
    c0_direction: Option<[f64; 3]>,
    c90_direction: Option<[f64; 3]>,
    photometry_ldt: Option<String>,
    photometry_ies: Option<String>,
    flux_lm: Option<f64>,
    luminous_opening_m: Option<[f64; 2]>,
    /// "rectangle" (default) or "circle" (diameter = the first size).
    luminous_opening_shape: Option<String>,
    #[serde(rename = "cct_K")]
    #[allow(dead_code)]
    cct_k: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorJson {
    id: u32,
    position: [f64; 3],
    normal: [f64; 3],
    #[serde(default)]
    note: String,
    lsc: Option<Vec<[f64; 2]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DesksJson {
    desks: Vec<DeskJson>,
    #[serde(default)]
    grid_step_m: f64,
    #[serde(default)]
    grid_points: Vec<GridPointJson>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DeskJson {
    id: u32,
    group: String,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    z: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GridPointJson {
    desk_id: u32,
    x: f64,
    y: f64,
    z: f64,
}

#[derive(Deserialize)]
struct CameraJson {
    position: [f64; 3],
    #[serde(rename = "R_world_from_camera")]
    r_world_from_camera: [[f64; 3]; 3],
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    luminance_cd_m2_per_unit: Option<f64>,
    /// Lens model: "pinhole" (default), "equidistant" or "kannala_brandt".
    #[serde(default)]
    model: Option<String>,
    /// Kannala-Brandt k1..k4.
    #[serde(default)]
    k: Option<[f64; 4]>,
}

/// Parses a JSON document into `T`, reporting the JSON path and line of any mismatch.
pub(crate) fn parse_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, SceneError> {
    let text = read_text(path)?;
    let de = &mut serde_json::Deserializer::from_str(&text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let json_path = e.path().to_string();
        SceneError::Json {
            path: path.to_path_buf(),
            json_path: if json_path == "." {
                "document".into()
            } else {
                json_path
            },
            message: e.into_inner().to_string(),
        }
    })
}

/// Collects validation errors of one file.
struct Checker<'a> {
    path: &'a Path,
    errors: &'a mut Vec<SceneError>,
}

impl Checker<'_> {
    fn fail(&mut self, what: impl Into<String>, message: impl Into<String>) {
        self.errors.push(SceneError::Invalid {
            path: self.path.to_path_buf(),
            what: what.into(),
            message: message.into(),
        });
    }

    fn point(&mut self, what: String, v: [f64; 3], scale: f64) -> Option<DVec3> {
        if v.iter().all(|x| x.is_finite()) {
            Some(DVec3::from_array(v) * scale)
        } else {
            self.fail(what, format!("{v:?} is not a finite point"));
            None
        }
    }

    fn unit(&mut self, what: String, v: [f64; 3], warnings: &mut Vec<String>) -> Option<DVec3> {
        let d = DVec3::from_array(v);
        let len = d.length();
        if !len.is_finite() || len < 1e-9 {
            self.fail(
                what,
                format!("{v:?} is not a direction (zero or not finite)"),
            );
            return None;
        }
        if (len - 1.0).abs() > 1e-3 {
            warnings.push(format!(
                "{}: {what} has length {len:.4}; normalised",
                self.path.display()
            ));
        }
        Some(d / len)
    }
}

fn unique_ids(c: &mut Checker<'_>, list: &str, ids: impl Iterator<Item = u32>) {
    let mut seen = HashSet::new();
    for (i, id) in ids.enumerate() {
        if !seen.insert(id) {
            c.fail(
                format!("{list}[{i}].id"),
                format!("id {id} is used more than once"),
            );
        }
    }
}

/// C0 for a nadir `aim` and a rotation: world +x (or +y when the aim is along x) projected
/// onto the plane normal to the aim, then turned counter-clockwise seen from behind the
/// luminaire (about −aim) by `rotation_rad`.
fn derive_c0(aim: DVec3, rotation_rad: f64) -> DVec3 {
    let reference = if aim.x.abs() > 0.9 {
        DVec3::Y
    } else {
        DVec3::X
    };
    let c0 = (reference - aim * reference.dot(aim)).normalize();
    let c90 = c0.cross(aim);
    c0 * rotation_rad.cos() + c90 * rotation_rad.sin()
}

fn load_luminaires(
    path: &Path,
    options: &LoadOptions,
    errors: &mut Vec<SceneError>,
    warnings: &mut Vec<String>,
) -> Vec<Luminaire> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let path = path.to_path_buf();
    let list: Vec<LuminaireJson> = match parse_json(&path) {
        Ok(l) => l,
        Err(e) => {
            errors.push(e);
            return Vec::new();
        }
    };
    let mut c = Checker {
        path: &path,
        errors,
    };
    unique_ids(&mut c, "luminaires", list.iter().map(|l| l.id));
    if list.is_empty() {
        warnings.push(format!("{}: no luminaires", path.display()));
    }
    let mut cache: PhotometryCache = HashMap::new();
    let mut out = Vec::new();
    for (i, l) in list.iter().enumerate() {
        let at = |field: &str| format!("luminaires[{i}].{field}");
        let position = c.point(at("position"), l.position, options.unit_to_m);
        let aim = c.unit(at("aim"), l.aim, warnings);
        if !l.rotation_deg.is_finite() {
            c.fail(at("rotation_deg"), "not finite");
        }
        let (Some(position_m), Some(aim)) = (position, aim) else {
            continue;
        };
        let Some((c0, c90)) = c_axes(&mut c, i, l, aim, warnings) else {
            continue;
        };
        let opening_m = match l.luminous_opening_m {
            Some(o) if o.iter().all(|x| x.is_finite() && *x >= 0.0) => Some(o),
            Some(o) => {
                c.fail(
                    at("luminous_opening_m"),
                    format!("{o:?} must be two sizes >= 0 m"),
                );
                continue;
            }
            None => None,
        };
        if let Some(f) = l.flux_lm
            && !(f.is_finite() && f >= 0.0)
        {
            c.fail(at("flux_lm"), format!("{f} is not a flux >= 0 lm"));
            continue;
        }
        let Some((photometry_path, dist)) =
            photometry_of(&mut c, i, l, dir, options, &mut cache, warnings)
        else {
            continue;
        };
        let file_flux_lm = dist.flux_lm();
        let flux_lm = l.flux_lm.unwrap_or(file_flux_lm);
        let tilt_rad = aim.dot(DVec3::NEG_Z).clamp(-1.0, 1.0).acos();
        let scaled = match dist.scaled_to_flux(flux_lm) {
            Ok(d) => d.with_installed_tilt(tilt_rad),
            Err(e) => {
                c.fail(at("flux_lm"), e.kind.to_string());
                continue;
            }
        };
        let circular = match l.luminous_opening_shape.as_deref() {
            None => opening_m.is_none() && dist.meta.opening.is_some_and(|o| o.circular),
            Some("rectangle") => false,
            Some("circle") => true,
            Some(other) => {
                c.fail(
                    at("luminous_opening_shape"),
                    format!("{other:?} is not \"rectangle\" or \"circle\""),
                );
                continue;
            }
        };
        let opening_m = opening_m
            .or_else(|| {
                dist.meta
                    .opening
                    .map(|o| [o.length_m, if o.circular { o.length_m } else { o.width_m }])
            })
            .map(|o| if circular { [o[0], o[0]] } else { o })
            .unwrap_or([0.0, 0.0]);
        out.push(Luminaire {
            id: l.id,
            name: l.name.clone(),
            position_m,
            aim,
            c0,
            c90,
            flux_lm,
            opening_m,
            opening_circular: circular,
            photometry: Arc::new(scaled),
            photometry_path,
            file_flux_lm,
        });
    }
    out
}

/// Photometric files read so far (`None`: unreadable), by path.
type PhotometryCache = HashMap<PathBuf, Option<Arc<IntensityDistribution>>>;

/// Luminaire `i`'s C0 and C90 directions: C0 from `c0_direction` or from aim and
/// `rotation_deg`; a given `c90_direction` must be C0 × aim. `None` after an error.
fn c_axes(
    c: &mut Checker,
    i: usize,
    l: &LuminaireJson,
    aim: DVec3,
    warnings: &mut Vec<String>,
) -> Option<(DVec3, DVec3)> {
    let at = |field: &str| format!("luminaires[{i}].{field}");
    let derived = derive_c0(aim, l.rotation_deg.to_radians());
    let c0 = match l.c0_direction {
        None => derived,
        Some(v) => {
            let c0 = c.unit(at("c0_direction"), v, warnings)?;
            if c0.dot(aim).abs() > 1e-3 {
                c.fail(at("c0_direction"), "must be perpendicular to aim");
                return None;
            }
            if c0.dot(derived) < 1.0 - 1e-3 {
                warnings.push(format!(
                    "{}: luminaire {}: c0_direction disagrees with aim and rotation_deg \
                     (C0 counter-clockwise about the upward axis); c0_direction is used",
                    c.path.display(),
                    l.id
                ));
            }
            c0
        }
    };
    let c90 = c0.cross(aim);
    if let Some(v) = l.c90_direction {
        let given = c.unit(at("c90_direction"), v, warnings)?;
        if given.dot(c90) < 1.0 - 1e-3 {
            c.fail(
                at("c90_direction"),
                format!(
                    "must equal c0_direction × aim = {:?} (C angles run counter-clockwise \
                     seen from above); found {v:?}",
                    c90.to_array()
                ),
            );
            return None;
        }
    }
    Some((c0, c90))
}

/// Luminaire `i`'s photometric file (the preferred format when both are named) and its
/// distribution, read once per file; when both formats are named, a warning if they differ.
/// `None` after an error.
fn photometry_of(
    c: &mut Checker,
    i: usize,
    l: &LuminaireJson,
    dir: &Path,
    options: &LoadOptions,
    cache: &mut PhotometryCache,
    warnings: &mut Vec<String>,
) -> Option<(PathBuf, Arc<IntensityDistribution>)> {
    let at = |field: &str| format!("luminaires[{i}].{field}");
    let (first, second) = match options.photometry {
        PhotometryPreference::Ldt => (&l.photometry_ldt, &l.photometry_ies),
        PhotometryPreference::Ies => (&l.photometry_ies, &l.photometry_ldt),
    };
    let Some(file) = first.as_ref().or(second.as_ref()) else {
        c.fail(
            at("photometry_ldt"),
            "names no photometric file (photometry_ldt or photometry_ies)",
        );
        return None;
    };
    let photometry_path = dir.join(file);
    let dist = cache
        .entry(photometry_path.clone())
        .or_insert_with(|| match IntensityDistribution::load(&photometry_path) {
            Ok(d) => {
                for w in &d.meta.warnings {
                    warnings.push(format!("{}: {w}", photometry_path.display()));
                }
                Some(Arc::new(d))
            }
            Err(source) => {
                c.errors.push(SceneError::Photometry { id: l.id, source });
                None
            }
        })
        .clone()?;
    // When both formats are named, they must describe the same distribution.
    if let (Some(a), Some(b)) = (&l.photometry_ldt, &l.photometry_ies) {
        let other_path = dir.join(if file == a { b } else { a });
        if let std::collections::hash_map::Entry::Vacant(slot) = cache.entry(other_path.clone()) {
            let other = IntensityDistribution::load(&other_path).ok().map(Arc::new);
            match &other {
                Some(o) => {
                    let dev = shape_deviation(&dist, o);
                    if dev > 0.01 {
                        warnings.push(format!(
                            "luminaire {}: {} and {} differ by up to {:.1} % of the peak \
                             intensity; {} is used",
                            l.id,
                            photometry_path.display(),
                            other_path.display(),
                            100.0 * dev,
                            photometry_path.display()
                        ));
                    }
                }
                None => warnings.push(format!(
                    "luminaire {}: {} cannot be read; {} is used",
                    l.id,
                    other_path.display(),
                    photometry_path.display()
                )),
            }
            slot.insert(other);
        }
    }
    Some((photometry_path, dist))
}

/// Largest difference of two distributions, each scaled to 1 lm, sampled every 5°, relative
/// to the larger peak.
fn shape_deviation(a: &IntensityDistribution, b: &IntensityDistribution) -> f64 {
    let (fa, fb) = (a.flux_lm(), b.flux_lm());
    if fa <= 0.0 || fb <= 0.0 {
        return if fa == fb { 0.0 } else { 1.0 };
    }
    let mut max_diff: f64 = 0.0;
    let mut peak: f64 = 0.0;
    for ic in 0..72 {
        let c = (ic as f64 * 5.0).to_radians();
        for ig in 0..=36 {
            let g = (ig as f64 * 5.0).to_radians();
            let (x, y) = (a.intensity_cd(c, g) / fa, b.intensity_cd(c, g) / fb);
            max_diff = max_diff.max((x - y).abs());
            peak = peak.max(x).max(y);
        }
    }
    if peak > 0.0 { max_diff / peak } else { 0.0 }
}

fn load_sensors(
    path: &Path,
    options: &LoadOptions,
    errors: &mut Vec<SceneError>,
    warnings: &mut Vec<String>,
) -> Vec<Sensor> {
    let path = path.to_path_buf();
    let list: Vec<SensorJson> = match parse_json(&path) {
        Ok(l) => l,
        Err(e) => {
            errors.push(e);
            return Vec::new();
        }
    };
    let mut c = Checker {
        path: &path,
        errors,
    };
    unique_ids(&mut c, "sensors", list.iter().map(|s| s.id));
    let mut out = Vec::new();
    for (i, s) in list.iter().enumerate() {
        let position = c.point(
            format!("sensors[{i}].position"),
            s.position,
            options.unit_to_m,
        );
        let normal = c.unit(format!("sensors[{i}].normal"), s.normal, warnings);
        let response = match &s.lsc {
            None => AngularResponse::Cosine,
            Some(table) => match Lsc::from_table_deg(table) {
                Ok((lsc, renormalised)) => {
                    if renormalised {
                        warnings.push(format!(
                            "{}: sensor {}: LSC normalised to a response of 1 at 0 degrees",
                            path.display(),
                            s.id
                        ));
                    }
                    AngularResponse::Table(lsc)
                }
                Err(e) => {
                    c.fail(format!("sensors[{i}].lsc"), e.to_string());
                    continue;
                }
            },
        };
        if let (Some(position_m), Some(normal)) = (position, normal) {
            out.push(Sensor {
                id: s.id,
                position_m,
                normal,
                note: s.note.clone(),
                response,
            });
        }
    }
    out
}

fn load_desks(
    dir: &Path,
    options: &LoadOptions,
    groups: &[String],
    errors: &mut Vec<SceneError>,
    warnings: &mut Vec<String>,
) -> Option<Desks> {
    let path = dir.join("desks.json");
    if !path.exists() {
        return None;
    }
    let json: DesksJson = match parse_json(&path) {
        Ok(d) => d,
        Err(e) => {
            errors.push(e);
            return None;
        }
    };
    let mut c = Checker {
        path: &path,
        errors,
    };
    unique_ids(&mut c, "desks", json.desks.iter().map(|d| d.id));
    let s = options.unit_to_m;
    let mut desks = Vec::new();
    for (i, d) in json.desks.iter().enumerate() {
        let vals = [d.x0, d.x1, d.y0, d.y1, d.z];
        if !vals.iter().all(|v| v.is_finite()) || d.x1 <= d.x0 || d.y1 <= d.y0 {
            c.fail(
                format!("desks[{i}]"),
                format!(
                    "extent x {}..{}, y {}..{} is empty or not finite",
                    d.x0, d.x1, d.y0, d.y1
                ),
            );
            continue;
        }
        if !groups.iter().any(|g| g == &d.group) {
            warnings.push(format!(
                "{}: desk {}: group {:?} is not in the geometry",
                path.display(),
                d.id,
                d.group
            ));
        }
        desks.push(Desk {
            id: d.id,
            group: d.group.clone(),
            x_m: [d.x0 * s, d.x1 * s],
            y_m: [d.y0 * s, d.y1 * s],
            z_m: d.z * s,
        });
    }
    let mut grid_points = Vec::new();
    for (i, p) in json.grid_points.iter().enumerate() {
        if !desks.iter().any(|d| d.id == p.desk_id) {
            c.fail(
                format!("grid_points[{i}].desk_id"),
                format!("desk {} does not exist", p.desk_id),
            );
            continue;
        }
        if let Some(pos) = c.point(format!("grid_points[{i}]"), [p.x, p.y, p.z], s) {
            grid_points.push((p.desk_id, pos));
        }
    }
    if !(json.grid_step_m.is_finite() && json.grid_step_m >= 0.0) {
        c.fail("grid_step_m", "must be a length >= 0");
    }
    Some(Desks {
        desks,
        grid_step_m: json.grid_step_m,
        grid_points,
    })
}

/// Reads and validates a `camera.json` (a scene's or a capture set's).
pub(crate) fn load_camera(path: &Path, unit_to_m: f64) -> Result<Camera, SceneError> {
    let j: CameraJson = parse_json(path)?;
    let invalid = |what: &str, message: String| SceneError::Invalid {
        path: path.to_path_buf(),
        what: what.into(),
        message,
    };
    if !j.position.iter().all(|v| v.is_finite()) {
        return Err(invalid("position", "not finite".into()));
    }
    let r = j.r_world_from_camera;
    // rows in the file: R[row][col]; columns are the camera axes in world
    let m = DMat3::from_cols(
        DVec3::new(r[0][0], r[1][0], r[2][0]),
        DVec3::new(r[0][1], r[1][1], r[2][1]),
        DVec3::new(r[0][2], r[1][2], r[2][2]),
    );
    let orth = (m.transpose() * m - DMat3::IDENTITY).to_cols_array();
    if orth.iter().any(|v| !v.is_finite() || v.abs() > 1e-4) || (m.determinant() - 1.0).abs() > 1e-4
    {
        return Err(invalid(
            "R_world_from_camera",
            "must be a rotation (orthonormal, determinant +1)".into(),
        ));
    }
    if j.width == 0 || j.height == 0 || j.width > 16384 || j.height > 16384 {
        return Err(invalid(
            "width",
            format!(
                "image size {}x{} must be 1..16384 pixels",
                j.width, j.height
            ),
        ));
    }
    super::check_intrinsics(j.fx, j.fy, j.cx, j.cy, j.width, j.height)
        .map_err(|m| invalid("intrinsics", m))?;
    let lens = super::Lens::from_model(j.model.as_deref().unwrap_or("pinhole"), j.k)
        .map_err(|m| invalid("model", m))?;
    if j.position.iter().any(|v| v.abs() * unit_to_m > 1e4) {
        return Err(invalid(
            "position",
            "more than 10 km from the origin: not a camera in a room (a length in another \
             unit: --unit?)"
                .into(),
        ));
    }
    if let Some(s) = j.luminance_cd_m2_per_unit
        && !(s.is_finite() && s > 0.0)
    {
        return Err(invalid(
            "luminance_cd_m2_per_unit",
            format!("{s} must be > 0"),
        ));
    }
    Ok(Camera {
        position_m: DVec3::from_array(j.position) * unit_to_m,
        world_from_camera: m,
        fx: j.fx,
        fy: j.fy,
        cx: j.cx,
        cy: j.cy,
        width: j.width,
        height: j.height,
        luminance_cd_m2_per_unit: j.luminance_cd_m2_per_unit,
        lens,
    })
}

/// Reads and validates one `luminaires.json` file (photometric files relative to its
/// directory): the luminaires and the warnings.
pub fn load_luminaires_file(
    path: &Path,
    options: &LoadOptions,
) -> Result<(Vec<Luminaire>, Vec<String>), SceneErrors> {
    let (mut errors, mut warnings) = (Vec::new(), Vec::new());
    let l = load_luminaires(path, options, &mut errors, &mut warnings);
    if errors.is_empty() {
        Ok((l, warnings))
    } else {
        Err(SceneErrors {
            dir: path.to_path_buf(),
            errors,
        })
    }
}

/// Reads and validates one `sensors.json` file: the sensors and the warnings.
pub fn load_sensors_file(
    path: &Path,
    options: &LoadOptions,
) -> Result<(Vec<Sensor>, Vec<String>), SceneErrors> {
    let (mut errors, mut warnings) = (Vec::new(), Vec::new());
    let s = load_sensors(path, options, &mut errors, &mut warnings);
    if errors.is_empty() {
        Ok((s, warnings))
    } else {
        Err(SceneErrors {
            dir: path.to_path_buf(),
            errors,
        })
    }
}

/// Reads and validates one `desks.json` file without a mesh to check the groups against.
pub fn load_desks_file(path: &Path, options: &LoadOptions) -> Result<Desks, SceneErrors> {
    let (mut errors, mut warnings) = (Vec::new(), Vec::new());
    if path.file_name() != Some(std::ffi::OsStr::new("desks.json")) || !path.is_file() {
        errors.push(SceneError::Invalid {
            path: path.to_path_buf(),
            what: "file".into(),
            message: "expected an existing file named desks.json".into(),
        });
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let d = load_desks(dir, options, &[], &mut errors, &mut warnings);
    match d {
        Some(d) if errors.is_empty() => Ok(d),
        _ => Err(SceneErrors {
            dir: path.to_path_buf(),
            errors,
        }),
    }
}

/// Reads and validates a `camera.json` (a scene's or a capture set's).
pub fn load_camera_file(path: &Path) -> Result<Camera, SceneError> {
    load_camera(path, 1.0)
}

/// A room is at least this wide in its largest horizontal extent, m.
pub const MIN_ROOM_EXTENT_M: f64 = 1.0;
/// A room (or a floor of rooms) is at most this long in any extent, m.
pub const MAX_ROOM_EXTENT_M: f64 = 500.0;
/// A luminaire hangs at most this high above the geometry's lowest point, m.
pub const MAX_LUMINAIRE_HEIGHT_M: f64 = 50.0;

/// The unit the lengths look like they are in, for an extent `extent_m` read as `unit_to_m`.
fn likely_unit(extent_m: f64, unit_to_m: f64) -> &'static str {
    // the unit that brings the extent into 3..100 m
    let in_units = extent_m / unit_to_m;
    [("m", 1.0), ("cm", 0.01), ("mm", 0.001)]
        .iter()
        .find(|(_, u)| (3.0..=100.0).contains(&(in_units * u)))
        .map_or("m", |(name, _)| name)
}

/// Lengths that cannot be a room's, checked before any work (issue 34: a CAD scene drawn in
/// millimetres read as metres made a 6 km room and a 24 GB commissioning; read as mm with
/// metres in the file, a 1 cm room passed): the geometry's extent, the luminaires' heights and
/// the desks' tops against it, each refusal with the unit the numbers look like.
fn plausible_extent(
    dir: &Path,
    lo: DVec3,
    hi: DVec3,
    unit_to_m: f64,
    luminaires: &[Luminaire],
    desks: &Option<Desks>,
) -> Vec<SceneError> {
    let mut out = Vec::new();
    let size = hi - lo;
    let horizontal = size.x.max(size.y);
    let largest = size.max_element();
    let bad = |what: &str, message: String| SceneError::Invalid {
        path: dir.join("scene.obj"),
        what: what.into(),
        message,
    };
    if largest > MAX_ROOM_EXTENT_M || horizontal < MIN_ROOM_EXTENT_M {
        out.push(bad(
            "geometry",
            format!(
                "spans {:.3} x {:.3} x {:.3} m, not a room ({MIN_ROOM_EXTENT_M}..{MAX_ROOM_EXTENT_M} m \
                 across); the file's lengths look like {} (--unit {})",
                size.x,
                size.y,
                size.z,
                likely_unit(largest, unit_to_m),
                likely_unit(largest, unit_to_m)
            ),
        ));
        return out;
    }
    for l in luminaires {
        let height_m = l.position_m.z - lo.z;
        if height_m > MAX_LUMINAIRE_HEIGHT_M {
            out.push(SceneError::Invalid {
                path: dir.join("luminaires.json"),
                what: format!("luminaire {}", l.id),
                message: format!(
                    "hangs {height_m:.1} m above the floor (at most {MAX_LUMINAIRE_HEIGHT_M} m): \
                     a length in another unit (--unit), or a position typed wrong"
                ),
            });
        }
    }
    for d in desks.iter().flat_map(|d| &d.desks) {
        if d.z_m < lo.z - 0.01 {
            out.push(SceneError::Invalid {
                path: dir.join("desks.json"),
                what: format!("desk {}", d.id),
                message: format!(
                    "top at {:.3} m is under the floor ({:.3} m): a length in another unit \
                     (--unit), or a height typed wrong",
                    d.z_m, lo.z
                ),
            });
        }
    }
    out
}

pub(super) fn load_dir(dir: &Path, options: &LoadOptions) -> Result<Scene, SceneErrors> {
    let mut errors = Vec::new();
    let mut warnings = Vec::new();
    if !(options.unit_to_m.is_finite() && options.unit_to_m > 0.0) {
        errors.push(SceneError::Invalid {
            path: dir.to_path_buf(),
            what: "unit".into(),
            message: format!("unit length {} m must be > 0", options.unit_to_m),
        });
    }
    let obj = match load_obj(&dir.join("scene.obj"), options.unit_to_m) {
        Ok(m) => Some(m),
        Err(e) => {
            errors.push(e);
            None
        }
    };
    let luminaires = load_luminaires(
        &dir.join("luminaires.json"),
        options,
        &mut errors,
        &mut warnings,
    );
    let sensors = load_sensors(
        &dir.join("sensors.json"),
        options,
        &mut errors,
        &mut warnings,
    );
    let groups = obj
        .as_ref()
        .map(|(m, _)| m.groups.clone())
        .unwrap_or_default();
    let desks = load_desks(dir, options, &groups, &mut errors, &mut warnings);
    let camera_path = dir.join("camera.json");
    let camera = if camera_path.exists() {
        match load_camera(&camera_path, options.unit_to_m) {
            Ok(c) => Some(c),
            Err(e) => {
                errors.push(e);
                None
            }
        }
    } else {
        None
    };
    let Some((mesh, obj_report)) = obj.filter(|_| errors.is_empty()) else {
        return Err(SceneErrors {
            dir: dir.to_path_buf(),
            errors,
        });
    };
    if obj_report.zero_area_dropped > 0 {
        warnings.push(format!(
            "scene.obj: {} zero-area triangles dropped",
            obj_report.zero_area_dropped
        ));
    }
    warnings.extend(obj_report.warnings.iter().cloned());
    let (lo, hi) = mesh.bounds_m();
    let implausible = plausible_extent(dir, lo, hi, options.unit_to_m, &luminaires, &desks);
    if !implausible.is_empty() {
        return Err(SceneErrors {
            dir: dir.to_path_buf(),
            errors: implausible,
        });
    }
    let margin = 0.01 * (hi - lo).length().max(1e-9);
    let inside = |p: DVec3| p.cmpge(lo - margin).all() && p.cmple(hi + margin).all();
    for l in &luminaires {
        if !inside(l.position_m) {
            warnings.push(format!(
                "luminaire {} lies outside the geometry's bounds",
                l.id
            ));
        }
    }
    for s in &sensors {
        if !inside(s.position_m) {
            warnings.push(format!(
                "sensor {} lies outside the geometry's bounds",
                s.id
            ));
        }
    }
    let name = dir
        .canonicalize()
        .ok()
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| dir.display().to_string());
    Ok(Scene {
        name,
        mesh,
        luminaires,
        sensors,
        desks,
        camera,
        obj_report,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c0_derivation_for_a_downlight() {
        let aim = DVec3::NEG_Z;
        assert!((derive_c0(aim, 0.0) - DVec3::X).length() < 1e-12);
        // 90° counter-clockwise seen from above: +x -> +y
        assert!((derive_c0(aim, std::f64::consts::FRAC_PI_2) - DVec3::Y).length() < 1e-12);
        assert!((DVec3::X.cross(aim) - DVec3::Y).length() < 1e-12);
    }
}
