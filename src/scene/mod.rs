//! Scene input: what a room is, as files (format in `docs/formats.md`).
//!
//! | file | required | read into |
//! |---|---|---|
//! | `scene.obj` + `scene.mtl` | yes | [`Mesh`]: triangles, group labels, grey diffuse reflectances |
//! | `luminaires.json` | yes | [`Luminaire`]s with their photometry scaled to `flux_lm` |
//! | `sensors.json` | yes | [`Sensor`]s with their angular response |
//! | `desks.json` | no | [`Desk`]s and their grid points |
//! | `camera.json` | no | the ceiling [`Camera`] |
//!
//! Everything is validated on load. A malformed file is an error naming the file and the line
//! (OBJ/MTL) or JSON path; every error of every file is collected so one run shows them all.
//! Zero-area triangles are dropped and counted (a warning), never an error.

mod builder;
mod files;
pub mod lens;
mod obj;
pub mod plan;
mod states;
mod summary;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DMat3, DVec3};

pub use builder::MeshBuilder;
pub use files::{
    LoadOptions, MAX_LUMINAIRE_HEIGHT_M, MAX_ROOM_EXTENT_M, MIN_ROOM_EXTENT_M,
    PhotometryPreference, load_camera_file, load_desks_file, load_luminaires_file,
    load_sensors_file,
};
pub use lens::Lens;
pub use obj::{ObjReport, load_obj};
pub use plan::RoomPlan;
pub use states::{Scenario, TruthRow, UnknownLuminaire, check_scenarios, read_states, read_truth};
pub use summary::SceneSummary;

use crate::lsc::AngularResponse;
use crate::photometry::{IntensityDistribution, PhotometryError};
use crate::units::Reflectance;

/// A material: a name and a grey diffuse reflectance.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name from the MTL file.
    pub name: String,
    /// Diffuse reflectance.
    pub rho: Reflectance,
}

/// A triangle: three vertex indices (counter-clockwise seen from its front), its group label
/// and its material.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Triangle {
    /// Indices into [`Mesh::positions_m`].
    pub v: [u32; 3],
    /// Index into [`Mesh::groups`].
    pub group: u32,
    /// Index into [`Mesh::materials`].
    pub material: u32,
}

/// Triangle geometry in metres, world frame (z up).
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Vertex positions, m.
    pub positions_m: Vec<DVec3>,
    /// Triangles.
    pub triangles: Vec<Triangle>,
    /// Group labels (`floor`, `wall_n`, `desk_3`, `luminaire_4`, ...).
    pub groups: Vec<String>,
    /// Materials.
    pub materials: Vec<Material>,
}

impl Mesh {
    /// The three corners of a triangle, m.
    pub fn corners_m(&self, t: &Triangle) -> [DVec3; 3] {
        t.v.map(|i| self.positions_m[i as usize])
    }

    /// Twice-area vector (cross product of the edges), m².
    fn cross(&self, t: &Triangle) -> DVec3 {
        let [a, b, c] = self.corners_m(t);
        (b - a).cross(c - a)
    }

    /// Area, m².
    pub fn area_m2(&self, t: &Triangle) -> f64 {
        0.5 * self.cross(t).length()
    }

    /// Unit normal of the front face (counter-clockwise winding); zero for a degenerate one.
    pub fn normal(&self, t: &Triangle) -> DVec3 {
        self.cross(t).normalize_or_zero()
    }

    /// True when the triangle has no area to within rounding (collinear or coincident corners).
    /// Slivers with a tiny but real area are kept.
    pub fn is_degenerate(&self, t: &Triangle) -> bool {
        let [a, b, c] = self.corners_m(t);
        let longest = (b - a)
            .length_squared()
            .max((c - b).length_squared())
            .max((a - c).length_squared());
        let cross = (b - a).cross(c - a).length();
        // NaN compares false: a non-finite triangle counts as degenerate too
        let has_area = cross > 1e-12 * longest && longest > 0.0;
        !has_area
    }

    /// Axis-aligned bounds (min, max), m.
    pub fn bounds_m(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for p in self.corners_m(t) {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo, hi)
    }

    /// Total area of each group, m², in group order.
    pub fn area_per_group_m2(&self) -> Vec<f64> {
        let mut a = vec![0.0; self.groups.len()];
        for t in &self.triangles {
            a[t.group as usize] += self.area_m2(t);
        }
        a
    }
}

/// An installed luminaire.
#[derive(Debug, Clone)]
pub struct Luminaire {
    /// Id from `luminaires.json` (the order of that file is the luminaire order everywhere).
    pub id: u32,
    /// Name, if given.
    pub name: String,
    /// Centre of the luminous opening, m.
    pub position_m: DVec3,
    /// Unit vector of the nadir (γ = 0).
    pub aim: DVec3,
    /// Unit vector of the C0 half-plane.
    pub c0: DVec3,
    /// Unit vector of the C90 half-plane (`c0 × aim`: C counter-clockwise seen from above).
    pub c90: DVec3,
    /// Luminaire flux at 100 %, lm.
    pub flux_lm: f64,
    /// Luminous opening (along C0, along C90), m; (0, 0) for a point source; for a circular
    /// opening both are the diameter.
    pub opening_m: [f64; 2],
    /// True when the opening is a disc (of diameter `opening_m[0]`).
    pub opening_circular: bool,
    /// Intensity distribution in cd, scaled to `flux_lm`, installed tilt applied.
    pub photometry: Arc<IntensityDistribution>,
    /// The photometric file it came from.
    pub photometry_path: PathBuf,
    /// The file's own flux before scaling, lm.
    pub file_flux_lm: f64,
}

impl Luminaire {
    /// Intensity toward a world direction (unit) from the luminaire, cd.
    pub fn intensity_toward_cd(&self, dir: DVec3) -> f64 {
        let cos_gamma = dir.dot(self.aim).clamp(-1.0, 1.0);
        let gamma = cos_gamma.acos();
        let c = dir.dot(self.c90).atan2(dir.dot(self.c0));
        self.photometry.intensity_cd(c, gamma)
    }
}

/// A desk sensor (a luxmeter, or a virtual one).
#[derive(Debug, Clone)]
pub struct Sensor {
    /// Id from `sensors.json` (its order is the sensor order everywhere).
    pub id: u32,
    /// Position, m.
    pub position_m: DVec3,
    /// Unit normal of the receiving surface.
    pub normal: DVec3,
    /// Free text.
    pub note: String,
    /// Angular response.
    pub response: AngularResponse,
}

/// A desk top, axis aligned, m.
#[derive(Debug, Clone, PartialEq)]
pub struct Desk {
    /// Id from `desks.json`.
    pub id: u32,
    /// The OBJ group of its top.
    pub group: String,
    /// Extent in x, m.
    pub x_m: [f64; 2],
    /// Extent in y, m.
    pub y_m: [f64; 2],
    /// Height of the top, m.
    pub z_m: f64,
}

/// Desks and the grid of points on them.
#[derive(Debug, Clone, Default)]
pub struct Desks {
    /// Desk tops.
    pub desks: Vec<Desk>,
    /// Grid spacing, m.
    pub grid_step_m: f64,
    /// Grid points: desk id and position, m.
    pub grid_points: Vec<(u32, DVec3)>,
}

/// The ceiling camera: intrinsics, lens model ([`Lens`]: pinhole or fisheye) and its pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Optical centre, m.
    pub position_m: DVec3,
    /// Columns: camera x (right), y (down), z (forward) axes in world coordinates.
    pub world_from_camera: DMat3,
    /// Focal lengths, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// cd/m² per unit of a luminance frame, when this is a capture set's camera.
    pub luminance_cd_m2_per_unit: Option<f64>,
    /// The lens: how a ray's angle maps to the image.
    pub lens: Lens,
}

impl Camera {
    /// Checks the intrinsics ([`check_intrinsics`]) and the lens ([`Lens::check`]).
    pub fn check(&self) -> Result<(), String> {
        check_intrinsics(self.fx, self.fy, self.cx, self.cy, self.width, self.height)?;
        self.lens.check()
    }

    /// The unit ray through pixel (u, v) in camera coordinates (pixel centres at integer
    /// coordinates), `None` outside the lens's field (a fisheye's corners).
    pub fn ray_camera(&self, u: f64, v: f64) -> Option<DVec3> {
        let m = glam::DVec2::new((u - self.cx) / self.fx, (v - self.cy) / self.fy);
        self.lens.unproject(m)
    }

    /// The world-frame unit ray through pixel (u, v) (pixel centres at integer coordinates),
    /// `None` outside the lens's field.
    pub fn ray_world(&self, u: f64, v: f64) -> Option<DVec3> {
        self.ray_camera(u, v).map(|d| self.world_from_camera * d)
    }

    /// The point in camera coordinates at depth `z_m` along the optical axis through pixel
    /// (u, v), `None` outside the field.
    pub fn point_at_depth_camera(&self, u: f64, v: f64, z_m: f64) -> Option<DVec3> {
        let d = self.ray_camera(u, v)?;
        (d.z > 1e-6).then(|| d * (z_m / d.z))
    }

    /// The world point at depth `z_m` along the optical axis through pixel (u, v), `None`
    /// outside the field.
    pub fn point_at_depth(&self, u: f64, v: f64, z_m: f64) -> Option<DVec3> {
        self.point_at_depth_camera(u, v, z_m)
            .map(|p| self.position_m + self.world_from_camera * p)
    }

    /// Pixel coordinates (u, v) of a point in camera coordinates, `None` outside the lens's
    /// field (the result may lie outside the image).
    pub fn project_camera(&self, p_cam: DVec3) -> Option<(f64, f64)> {
        let m = self.lens.project(p_cam)?;
        Some((self.fx * m.x + self.cx, self.fy * m.y + self.cy))
    }

    /// Pixel coordinates (u, v) of a world point, `None` outside the lens's field.
    pub fn project_world(&self, p_m: DVec3) -> Option<(f64, f64)> {
        self.project_camera(self.camera_from_world(p_m))
    }

    /// A world point in camera coordinates.
    pub fn camera_from_world(&self, p_m: DVec3) -> DVec3 {
        self.world_from_camera.transpose() * (p_m - self.position_m)
    }

    /// The pixel of a world point when it falls inside the image: (column, row).
    pub fn pixel_of(&self, p_m: DVec3) -> Option<(u32, u32)> {
        let (u, v) = self.project_world(p_m)?;
        let (ur, vr) = (u.round(), v.round());
        (ur >= 0.0 && vr >= 0.0 && ur < f64::from(self.width) && vr < f64::from(self.height))
            .then_some((ur as u32, vr as u32))
    }

    /// The solid angle pixel (u, v) subtends, sr (0 outside the field).
    pub fn pixel_solid_angle_sr(&self, u: f64, v: f64) -> f64 {
        match self.ray_camera(u, v) {
            Some(d) => {
                self.lens.solid_angle_per_area(d.z.clamp(-1.0, 1.0).acos()) / (self.fx * self.fy)
            }
            None => 0.0,
        }
    }
}

/// Plausible camera intrinsics, checked before any work: a focal length that gives a field of
/// view between about 1° and 178° (`0.02 ≤ f / size ≤ 60`, in pixels of the image's width for
/// `fx`, height for `fy`), at most 4:1 between `fx` and `fy`, and the principal point inside
/// the image (a focal length of 1e-9 or a principal point at 1e7 pixels would otherwise turn
/// into a room of terabytes). The error names the value.
pub fn check_intrinsics(
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    width: u32,
    height: u32,
) -> Result<(), String> {
    let (w, h) = (f64::from(width), f64::from(height));
    for (name, f, size) in [("fx", fx, w), ("fy", fy, h)] {
        if !(f.is_finite() && f >= 0.02 * size && f <= 60.0 * size) {
            return Err(format!(
                "{name} = {f} pixels is not a focal length for {size} pixels (field of view \
                 between 1° and 178°: {:.1}..={:.0} pixels)",
                0.02 * size,
                60.0 * size
            ));
        }
    }
    if !(0.25..=4.0).contains(&(fy / fx)) {
        return Err(format!("fx = {fx} and fy = {fy} differ by more than 4:1"));
    }
    for (name, c, size) in [("cx", cx, w), ("cy", cy, h)] {
        if !(c.is_finite() && (-0.5..=size - 0.5).contains(&c)) {
            return Err(format!(
                "{name} = {c} pixels: the principal point must lie in the image (-0.5..={})",
                size - 0.5
            ));
        }
    }
    Ok(())
}

/// A room: geometry, luminaires, sensors, optionally desks and the camera.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Name (the directory name, or the generator's name).
    pub name: String,
    /// Geometry.
    pub mesh: Mesh,
    /// Luminaires, in file order.
    pub luminaires: Vec<Luminaire>,
    /// Sensors, in file order.
    pub sensors: Vec<Sensor>,
    /// Desks, if `desks.json` exists.
    pub desks: Option<Desks>,
    /// The camera, if `camera.json` exists.
    pub camera: Option<Camera>,
    /// What the OBJ reader found.
    pub obj_report: ObjReport,
    /// Non-fatal findings from every file.
    pub warnings: Vec<String>,
}

/// A problem with one scene file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A line of an OBJ/MTL file is malformed.
    #[error("{}:{line}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A JSON file does not have the expected shape.
    #[error("{}: {json_path}: {message}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// Where in the document (`[2].position[1]`).
        json_path: String,
        /// What is wrong, with line and column.
        message: String,
    },
    /// Well-formed, but a value is not acceptable.
    #[error("{}: {what}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Which item (`luminaires[3].aim`, `geometry`).
        what: String,
        /// What is wrong.
        message: String,
    },
    /// A luminaire's photometric file is unusable.
    #[error("luminaire {id}: {source}")]
    Photometry {
        /// The luminaire id.
        id: u32,
        /// The photometry error (names its file and line).
        source: PhotometryError,
    },
}

/// Every error found while loading a scene (at least one).
#[derive(Debug, thiserror::Error)]
#[error("{} error(s) in scene {}:\n  {}", errors.len(), dir.display(), errors.iter().map(|e| e.to_string()).collect::<Vec<_>>().join("\n  "))]
pub struct SceneErrors {
    /// The scene directory.
    pub dir: PathBuf,
    /// The errors, in the order found.
    pub errors: Vec<SceneError>,
}

pub(crate) fn read_text(path: &Path) -> Result<String, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(String::from_utf8(bytes)
        .unwrap_or_else(|e| e.into_bytes().iter().map(|&b| char::from(b)).collect()))
}

impl Scene {
    /// Loads and validates a scene directory.
    pub fn load(dir: &Path, options: &LoadOptions) -> Result<Scene, SceneErrors> {
        files::load_dir(dir, options)
    }

    /// Luminaire by id.
    pub fn luminaire(&self, id: u32) -> Option<&Luminaire> {
        self.luminaires.iter().find(|l| l.id == id)
    }

    /// A summary for people (`luxnode scene check`).
    pub fn summary(&self) -> SceneSummary<'_> {
        SceneSummary { scene: self }
    }
}
