//! The image's geometry section to and from the engine's and the scene's types: what goes in at
//! commissioning ([`section_of`]) and the room a report works on, rebuilt from an image alone
//! ([`Room::from_image`]): patches with the stored reflectances, luminaires with the photometry
//! as used, camera, desks, sensors, the stored form factors and direct terms, and the basis
//! exitances solved again from them (so a report shows exactly what the node serves).

use std::sync::Arc;

use glam::{DMat3, DVec3};

use crate::engine::{Csr, Model, Patches};
use crate::photometry::IntensityDistribution;
use crate::scene::{Camera, Desk, Luminaire, Scene};
use crate::solver::{self, SolveOptions};
use crate::store::geometry::{
    CameraRecord, DeskRecord, GeometrySection, LuminaireRecord, PhotometryRecord, SensorRecord,
    UnseenWallRecord,
};
use crate::store::{Image, ImageError};

/// What the commissioning record says besides the geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct CommissionRecord {
    /// The preset's name, or `custom`.
    pub preset: String,
    /// The installation's maintenance factor.
    pub maintenance_factor: f64,
    /// When, seconds since 1970 (UTC).
    pub commissioned_unix_s: u64,
    /// The walls it placed without seeing them ([`unseen_walls_of`]).
    pub unseen_walls: Vec<UnseenWallRecord>,
}

/// The sides of a commissioning's room box that no camera saw and the luminaire grid did not
/// place (`commission::Report::unseen_wall_sides`), where they were put.
pub fn unseen_walls_of(report: &crate::commission::Report) -> Vec<UnseenWallRecord> {
    let (Some(sides), Some(room)) = (report.unseen_wall_sides, report.room.as_ref()) else {
        return Vec::new();
    };
    // RoomBox::xy_m is x0, y0, x1, y1
    const NAMES: [&str; 4] = ["x low", "y low", "x high", "y high"];
    NAMES
        .iter()
        .zip(sides)
        .zip(room.xy_m)
        .filter(|((_, unseen), _)| *unseen)
        .map(|((name, _), at_m)| UnseenWallRecord {
            side: (*name).into(),
            at_m,
            moved_m: crate::commission::placement::UNSEEN_WALL_POSITION_SIGMA_M,
        })
        .collect()
}

impl Default for CommissionRecord {
    fn default() -> Self {
        Self {
            preset: "balanced".into(),
            maintenance_factor: crate::en12464::DEFAULT_MAINTENANCE_FACTOR,
            commissioned_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            unseen_walls: Vec::new(),
        }
    }
}

/// The software, as the report names it.
pub fn software() -> String {
    format!("luxnode {}", env!("CARGO_PKG_VERSION"))
}

fn v3(v: DVec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn photometry_record(l: &Luminaire) -> PhotometryRecord {
    let d = &l.photometry;
    let c_deg = d.c_grid_deg().to_vec();
    let gamma_deg = d.gamma_grid_deg().to_vec();
    let mut cd = Vec::with_capacity(c_deg.len() * gamma_deg.len());
    let lamps = d.meta.lamp_sets.get(d.meta.lamp_set_used);
    for ic in 0..c_deg.len() {
        for ig in 0..gamma_deg.len() {
            cd.push(d.grid_cd(ic, ig) as f32);
        }
    }
    PhotometryRecord {
        file_name: l
            .photometry_path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default(),
        luminaire: d.meta.luminaire.clone(),
        manufacturer: d.meta.manufacturer.clone(),
        file_flux_lm: l.file_flux_lm,
        power_w: d.meta.power_w.unwrap_or(f64::NAN),
        c_deg,
        gamma_deg,
        cd,
        colour_rendering: lamps.map(|s| s.cri.clone()).unwrap_or_default(),
        ra_min: lamps.and_then(|s| s.ra_min()),
    }
}

/// The geometry section of a commissioned model of `scene`.
pub fn section_of(scene: &Scene, model: &Model, record: &CommissionRecord) -> GeometrySection {
    let p = &model.patches;
    let patch_corners_m = p
        .corners_m
        .iter()
        .map(|t| {
            let mut a = [0f32; 9];
            for (k, c) in t.iter().enumerate() {
                a[3 * k] = c.x as f32;
                a[3 * k + 1] = c.y as f32;
                a[3 * k + 2] = c.z as f32;
            }
            a
        })
        .collect();
    let mut photometries: Vec<PhotometryRecord> = Vec::new();
    let luminaires = scene
        .luminaires
        .iter()
        .map(|l| {
            let rec = photometry_record(l);
            let idx = match photometries.iter().position(|p| *p == rec) {
                Some(i) => i,
                None => {
                    photometries.push(rec);
                    photometries.len() - 1
                }
            };
            LuminaireRecord {
                id: l.id,
                name: l.name.clone(),
                position_m: v3(l.position_m),
                axes: [v3(l.aim), v3(l.c0), v3(l.c90)],
                opening_m: l.opening_m,
                opening_circular: l.opening_circular,
                flux_lm: l.flux_lm,
                photometry: idx as u32,
            }
        })
        .collect();
    let camera = scene.camera.as_ref().map(|c| CameraRecord {
        position_m: v3(c.position_m),
        world_from_camera: c.world_from_camera.to_cols_array(),
        intrinsics_px: [c.fx, c.fy, c.cx, c.cy],
        size_px: [c.width, c.height],
        lens_k: c.lens.is_fisheye().then(|| c.lens.k()),
    });
    let desks = scene
        .desks
        .as_ref()
        .map(|d| {
            d.desks
                .iter()
                .map(|d| DeskRecord {
                    id: d.id,
                    group: d.group.clone(),
                    extent_m: [d.x_m[0], d.x_m[1], d.y_m[0], d.y_m[1]],
                    z_m: d.z_m,
                })
                .collect()
        })
        .unwrap_or_default();
    GeometrySection {
        scene_name: scene.name.clone(),
        preset: record.preset.clone(),
        commissioned_unix_s: record.commissioned_unix_s,
        software: software(),
        maintenance_factor: record.maintenance_factor,
        groups: scene.mesh.groups.clone(),
        patch_corners_m,
        patch_group: p.group.clone(),
        camera,
        desks,
        sensors: scene
            .sensors
            .iter()
            .map(|s| SensorRecord {
                id: s.id,
                position_m: v3(s.position_m),
                normal: v3(s.normal),
            })
            .collect(),
        luminaires,
        photometries,
        unseen_walls: record.unseen_walls.clone(),
    }
}

/// Why an image cannot be reported on.
#[derive(Debug, thiserror::Error)]
pub enum RoomError {
    /// The image has no geometry section.
    #[error(
        "the image has no geometry section (it was built without one, or by an older build): rebuild it with `luxnode image build` or recommission"
    )]
    NoGeometry,
    /// The section does not decode.
    #[error("the geometry section: {0}")]
    Decode(ImageError),
    /// The section does not fit the image.
    #[error("the geometry section does not fit the image: {0}")]
    Inconsistent(String),
    /// A stored photometry is unusable.
    #[error("luminaire {id}: stored photometry: {reason}")]
    Photometry {
        /// Luminaire id.
        id: u32,
        /// Why.
        reason: String,
    },
    /// Solving the stored system failed.
    #[error("solving the stored system for luminaire {id}: {source}")]
    Solve {
        /// Luminaire id.
        id: u32,
        /// Why.
        source: solver::SolveError,
    },
}

/// A desk sensor of the room.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoomSensor {
    /// Id.
    pub id: u32,
    /// Position, m.
    pub position_m: DVec3,
    /// Unit normal.
    pub normal: DVec3,
}

/// The room of an image: everything dense illuminance and the report need.
#[derive(Debug, Clone)]
pub struct Room {
    /// The section as stored.
    pub section: GeometrySection,
    /// Patches (stored corners, reflectances and groups).
    pub patches: Patches,
    /// Luminaires, in the image's order.
    pub luminaires: Vec<Luminaire>,
    /// The camera.
    pub camera: Option<Camera>,
    /// Desk tops.
    pub desks: Vec<Desk>,
    /// Desk sensors, in the image's order.
    pub sensors: Vec<RoomSensor>,
    /// Stored form factors.
    pub ff: Csr,
    /// Stored direct illuminance per luminaire at 100 % on each patch, lx: `[luminaire][patch]`.
    pub direct_patch_lx: Vec<Vec<f64>>,
    /// Exitance per luminaire at 100 %, lm/m², solved from the stored arrays.
    pub basis_b: Vec<Vec<f64>>,
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn unit(v: [f64; 3]) -> Option<DVec3> {
    let d = DVec3::from(v);
    (finite(&v) && (d.length() - 1.0).abs() < 1e-3).then(|| d.normalize())
}

impl Room {
    /// Rebuilds the room of a parsed image: its patches, luminaires, camera, desks and sensors
    /// from the geometry section, checked against the image, and the stored arrays solved.
    pub fn from_image(image: &Image<'_>) -> Result<Room, RoomError> {
        let bytes = image.geometry_bytes().ok_or(RoomError::NoGeometry)?;
        let section = GeometrySection::decode(bytes).map_err(RoomError::Decode)?;
        let bad = RoomError::Inconsistent;
        let n = image.patches();
        if section.patch_corners_m.len() != n || section.patch_group.len() != n {
            return Err(bad(format!(
                "{} patch corners and {} groups for {n} patches",
                section.patch_corners_m.len(),
                section.patch_group.len()
            )));
        }
        if section
            .patch_group
            .iter()
            .any(|g| *g as usize >= section.groups.len())
        {
            return Err(bad("a patch's group is not in the group list".into()));
        }
        let patches = patches_of(image, &section)?;
        let luminaires = luminaires_of(image, &section)?;
        let camera = section.camera.as_ref().map(camera_of).transpose()?;
        let desks = desks_of(&section)?;
        let sensors = sensors_of(image, &section)?;
        let (ff, direct_patch_lx, basis_b) = stored_arrays(image)?;
        Ok(Room {
            section,
            patches,
            luminaires,
            camera,
            desks,
            sensors,
            ff,
            direct_patch_lx,
            basis_b,
        })
    }
}

/// The patches of the section's corners (normals and areas from them) and the image's
/// reflectances.
fn patches_of(image: &Image<'_>, section: &GeometrySection) -> Result<Patches, RoomError> {
    let bad = RoomError::Inconsistent;
    let mut patches = Patches::default();
    for (i, c) in section.patch_corners_m.iter().enumerate() {
        if c.iter().any(|x| !x.is_finite()) {
            return Err(bad(format!("patch {i} has a corner that is not a number")));
        }
        let t = [0, 1, 2].map(|k| {
            DVec3::new(
                f64::from(c[3 * k]),
                f64::from(c[3 * k + 1]),
                f64::from(c[3 * k + 2]),
            )
        });
        let cross = (t[1] - t[0]).cross(t[2] - t[0]);
        patches.corners_m.push(t);
        patches.normal.push(cross.normalize_or_zero());
        patches.area_m2.push(0.5 * cross.length());
        patches.rho.push(image.payload.rho.get(i, 0));
        patches.group.push(section.patch_group[i]);
        patches.source_triangle.push(i as u32);
    }
    Ok(patches)
}

/// The section's luminaires with their photometry, checked against the image's.
fn luminaires_of(
    image: &Image<'_>,
    section: &GeometrySection,
) -> Result<Vec<Luminaire>, RoomError> {
    let bad = RoomError::Inconsistent;
    let l = image.luminaires();
    if section.luminaires.len() != l {
        return Err(bad(format!(
            "{} luminaires for the image's {l}",
            section.luminaires.len()
        )));
    }
    let mut luminaires = Vec::with_capacity(l);
    for (j, rec) in section.luminaires.iter().enumerate() {
        if rec.id != image.luminaire_id(j) {
            return Err(bad(format!(
                "luminaire {j} is {} in the section, {} in the image",
                rec.id,
                image.luminaire_id(j)
            )));
        }
        let ph = section
            .photometries
            .get(rec.photometry as usize)
            .ok_or_else(|| bad(format!("luminaire {}: no photometry", rec.id)))?;
        let dist = IntensityDistribution::from_full_grid(
            ph.c_deg.clone(),
            ph.gamma_deg.clone(),
            ph.cd.iter().map(|v| f64::from(*v)).collect(),
            &ph.luminaire,
        )
        .map_err(|e| RoomError::Photometry {
            id: rec.id,
            reason: e.to_string(),
        })?;
        let (Some(aim), Some(c0), Some(c90)) =
            (unit(rec.axes[0]), unit(rec.axes[1]), unit(rec.axes[2]))
        else {
            return Err(bad(format!(
                "luminaire {}: axes are not unit vectors",
                rec.id
            )));
        };
        if !(finite(&rec.position_m)
            && finite(&rec.opening_m)
            && rec.opening_m.iter().all(|x| *x >= 0.0)
            && rec.flux_lm.is_finite()
            && rec.flux_lm >= 0.0)
        {
            return Err(bad(format!(
                "luminaire {}: position, opening or flux",
                rec.id
            )));
        }
        luminaires.push(Luminaire {
            id: rec.id,
            name: rec.name.clone(),
            position_m: DVec3::from(rec.position_m),
            aim,
            c0,
            c90,
            flux_lm: rec.flux_lm,
            opening_m: rec.opening_m,
            opening_circular: rec.opening_circular,
            photometry: Arc::new(dist),
            photometry_path: ph.file_name.clone().into(),
            file_flux_lm: ph.file_flux_lm,
        });
    }
    Ok(luminaires)
}

/// The section's camera, checked.
fn camera_of(c: &CameraRecord) -> Result<Camera, RoomError> {
    let bad = RoomError::Inconsistent;
    let ok = finite(&c.position_m)
        && finite(&c.world_from_camera)
        && finite(&c.intrinsics_px)
        && c.intrinsics_px[0] > 0.0
        && c.intrinsics_px[1] > 0.0
        && c.size_px[0] > 0
        && c.size_px[1] > 0
        && u64::from(c.size_px[0]) * u64::from(c.size_px[1]) <= 16_000_000;
    if !ok {
        return Err(bad("the camera".into()));
    }
    let lens = match c.lens_k {
        None => crate::scene::Lens::Pinhole,
        Some(k) => {
            let l = crate::scene::Lens::KannalaBrandt { k };
            l.check()
                .map_err(|m| bad(format!("the camera lens: {m}")))?;
            l
        }
    };
    Ok(Camera {
        position_m: DVec3::from(c.position_m),
        world_from_camera: DMat3::from_cols_array(&c.world_from_camera),
        fx: c.intrinsics_px[0],
        fy: c.intrinsics_px[1],
        cx: c.intrinsics_px[2],
        cy: c.intrinsics_px[3],
        width: c.size_px[0],
        height: c.size_px[1],
        luminance_cd_m2_per_unit: None,
        lens,
    })
}

/// The section's desks, checked.
fn desks_of(section: &GeometrySection) -> Result<Vec<Desk>, RoomError> {
    let bad = RoomError::Inconsistent;
    let mut desks = Vec::new();
    for d in &section.desks {
        let e = d.extent_m;
        if !(finite(&e) && d.z_m.is_finite() && e[1] > e[0] && e[3] > e[2]) {
            return Err(bad(format!("desk {}: outline", d.id)));
        }
        desks.push(Desk {
            id: d.id,
            group: d.group.clone(),
            x_m: [e[0], e[1]],
            y_m: [e[2], e[3]],
            z_m: d.z_m,
        });
    }
    Ok(desks)
}

/// The section's sensors, checked against the image's.
fn sensors_of(image: &Image<'_>, section: &GeometrySection) -> Result<Vec<RoomSensor>, RoomError> {
    let bad = RoomError::Inconsistent;
    let s = image.sensors();
    if section.sensors.len() != s {
        return Err(bad(format!(
            "{} sensors for the image's {s}",
            section.sensors.len()
        )));
    }
    let mut sensors = Vec::with_capacity(s);
    for (k, rec) in section.sensors.iter().enumerate() {
        let normal = unit(rec.normal);
        if rec.id != image.sensor_id(k) || normal.is_none() || !finite(&rec.position_m) {
            return Err(bad(format!("sensor {k}")));
        }
        sensors.push(RoomSensor {
            id: rec.id,
            position_m: DVec3::from(rec.position_m),
            normal: normal.unwrap_or(DVec3::Z),
        });
    }
    Ok(sensors)
}

/// The image's stored arrays, decoded: form factors, direct light per luminaire on each patch,
/// and each luminaire's exitance solved from them.
#[allow(clippy::type_complexity)]
fn stored_arrays(image: &Image<'_>) -> Result<(Csr, Vec<Vec<f64>>, Vec<Vec<f64>>), RoomError> {
    let (n, l) = (image.patches(), image.luminaires());
    // the stored arrays, decoded
    let ffs = &image.payload.ff;
    let rows = (0..n)
        .map(|i| {
            ffs.row_range(i)
                .map(|k| (ffs.col_at(k) as u32, ffs.values.get(k, i)))
                .collect()
        })
        .collect();
    let ff = Csr::from_rows(rows);
    let direct_patch_lx: Vec<Vec<f64>> = (0..l)
        .map(|j| {
            (0..n)
                .map(|i| image.payload.direct_patch_lx.get(j * n + i, j))
                .collect()
        })
        .collect();
    let options = SolveOptions {
        tolerance: image.payload.solve_tolerance,
        max_iterations: image.payload.solve_max_iterations,
    };
    let system = image.system();
    let mut basis_b = Vec::with_capacity(l);
    for (j, e) in direct_patch_lx.iter().enumerate() {
        let mut b = vec![0.0; n];
        solver::gauss_seidel(&system, e, &mut b, options).map_err(|source| RoomError::Solve {
            id: image.luminaire_id(j),
            source,
        })?;
        basis_b.push(b);
    }
    Ok((ff, direct_patch_lx, basis_b))
}
