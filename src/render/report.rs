//! The commissioning report a lighting engineer signs: `report.html` (one self-contained file:
//! pictures inlined as `data:` URIs, no script or style fetched, opens offline) and
//! `results.json` (the same numbers), from a flash image alone (its geometry section:
//! [`crate::image_geometry::Room`]).
//!
//! Contents: the scene, preset, commissioning and report dates, software version; the plan view
//! (false colour, isolines, EN 12464-1 room grid values, desks, sensors); the camera view of dense
//! lux; the reflectance view and the patch mesh; reflectances per surface; the luminaire schedule
//! (photometry file, flux, power); per-desk statistics on the EN 12464-1 grids (Ē, Emin, Emax, U0,
//! Emin/Emax, new and maintained); the immediate surroundings; the room; per-state results; and
//! the EN 12464-1 check (office, writing and reading: Ēm ≥ 500 lx, U0 ≥ 0.60, surroundings per
//! Table 1).
//!
//! Every illuminance is dense ([`crate::engine::dense`]): grid points on a desk or the floor get
//! exact direct light and the interreflection interpolated over the patch mesh; points in the
//! air (the immediate surroundings, at the desk's height) gather the interreflection with rays.

use std::fmt::Write as _;
use std::path::Path;

use glam::DVec3;
use serde::Serialize;

use super::camera_view::{self, ViewDesk, ViewOptions};
use super::energy::{self, Energy, EnergyInput};
use super::glare::{self, UgrResult};
use super::map::{self, PlanDesk, PlanView, TopView};
use super::nice_ceiling;
use super::requirements::{self, RequirementRow};
use super::room_surfaces::{self, RoomValue};
use super::task_points::{self, TaskPoint, covered};
use crate::control::DEFAULT_EFFICACY_LM_PER_W;
use crate::control::rating::{PowerSource, RatedPower};
use crate::en12464::{self, Check, Rect, Requirement, Statistics};
use crate::engine::dense::{DenseField, DenseImage, DenseSettings, Readings, SurfacePoint};
use crate::image_geometry::Room;
use crate::runtime::Runtime;
use crate::scene::Camera;
use crate::store::Image;

/// A dimming state to report: a name and a level per luminaire (image order) in [0, 1].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NamedState {
    /// Name.
    pub name: String,
    /// Levels.
    pub levels: Vec<f64>,
}

/// What to report.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// The states; the first is the design state the EN 12464-1 check uses (all on when empty).
    pub states: Vec<NamedState>,
    /// Overrides the maintenance factor recorded in the image.
    pub maintenance_factor: Option<f64>,
    /// The activity checked.
    pub requirement: Requirement,
    /// Gather rays for points in the air.
    pub air_rays: usize,
    /// Plan-view cell, m.
    pub plan_cell_m: f64,
    /// When the report is made, seconds since 1970.
    pub now_unix_s: u64,
}

impl Default for ReportOptions {
    fn default() -> Self {
        Self {
            states: Vec::new(),
            maintenance_factor: None,
            requirement: en12464::OFFICE_WRITING_READING,
            air_rays: 1000,
            plan_cell_m: 0.1,
            now_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
        }
    }
}

/// Why no report was made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The image cannot be reported on.
    #[error(transparent)]
    Room(#[from] crate::image_geometry::RoomError),
    /// A computation failed.
    #[error(transparent)]
    Engine(#[from] crate::engine::EngineError),
    /// A grid could not be made.
    #[error(transparent)]
    Grid(#[from] en12464::GridError),
    /// A bad maintenance factor.
    #[error(transparent)]
    MaintenanceFactor(#[from] en12464::MaintenanceFactorError),
    /// A state does not fit the image.
    #[error("state {0}: {1}")]
    State(String, String),
    /// The run-time core refused a state.
    #[error("run-time core: {0}")]
    Runtime(#[from] crate::runtime::RuntimeError),
    /// A picture could not be encoded.
    #[error("encoding a picture: {0}")]
    Png(#[from] image::ImageError),
    /// Writing the files.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// Serialising results.json.
    #[error("results.json: {0}")]
    Json(#[from] serde_json::Error),
}

/// Reflectance of one surface (group).
#[derive(Debug, Clone, Serialize)]
pub struct SurfaceRow {
    /// Group label.
    pub surface: String,
    /// Area, m².
    pub area_m2: f64,
    /// Area-weighted mean reflectance.
    pub rho: f64,
    /// Patches.
    pub patches: usize,
}

/// A luminaire of the schedule.
#[derive(Debug, Clone, Serialize)]
pub struct LuminaireRow {
    /// Id.
    pub id: u32,
    /// Name.
    pub name: String,
    /// Photometry file.
    pub photometry_file: String,
    /// Luminaire named in the file.
    pub luminaire: String,
    /// Flux at 100 %, lm.
    pub flux_lm: f64,
    /// Rated input power, W ([`crate::control::rating::RatedPower`]: the file's wattage,
    /// or the assumed efficacy's guess when it gives none).
    pub power_w: Option<f64>,
    /// The power is the assumed efficacy's guess, not the file's.
    pub power_assumed: bool,
    /// Efficacy, lm/W.
    pub efficacy_lm_per_w: Option<f64>,
    /// Position, m.
    pub position_m: [f64; 3],
    /// Luminous opening, m.
    pub opening_m: [f64; 2],
}

/// Statistics of one area, new and maintained.
#[derive(Debug, Clone, Serialize)]
pub struct AreaResult {
    /// New installation.
    pub new: Statistics,
    /// Maintained (× MF).
    pub maintained: Statistics,
    /// A task area's grid points (new, every luminaire on; covered points marked, out of the
    /// statistics); empty (and not in results.json) for the other areas.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<TaskPoint>,
}

/// One desk in the design state.
#[derive(Debug, Clone, Serialize)]
pub struct DeskResult {
    /// Id.
    pub id: u32,
    /// Outline x0, x1, y0, y1, m.
    pub extent_m: [f64; 4],
    /// Height, m.
    pub z_m: f64,
    /// Grid points along x and y, cell size (m).
    pub grid: ([usize; 2], [f64; 2]),
    /// Task area.
    pub task: AreaResult,
    /// Immediate surrounding area (band of 0.5 m at the desk's height).
    pub surrounding: Option<AreaResult>,
    /// The EN 12464-1 checks (maintained values).
    pub checks: Vec<Check>,
    /// Every check passed.
    pub pass: bool,
}

/// One state.
#[derive(Debug, Clone, Serialize)]
pub struct StateResult {
    /// Name.
    pub name: String,
    /// Levels per luminaire (image order).
    pub levels: Vec<f64>,
    /// Per desk: (id, maintained statistics on the task grid).
    pub desks: Vec<(u32, Statistics)>,
    /// The room grid, maintained.
    pub room: Option<Statistics>,
    /// Desk sensors as the node publishes them (new installation, what a luxmeter reads): (id, lx).
    pub sensors_lx: Vec<(u32, f64)>,
}

/// One desk sensor: where its published value comes from and how far to trust it.
#[derive(Debug, Clone, Serialize)]
pub struct SensorRow {
    /// Id.
    pub id: u32,
    /// Its point's name, the same on Modbus, BACnet and the points list ([`crate::points`]).
    pub name: String,
    /// The camera sees it (the model there rests on what the camera saw).
    pub in_view: bool,
    /// Its surroundings were partly inferred (commissioning's flag).
    pub estimated: bool,
    /// Its modelled light was calibrated by the camera's one-luminaire frames (a shade the mesh
    /// lost, the desks' common reflectance; commissioning's flag).
    pub calibrated: bool,
    /// The stated relative standard uncertainty of its modelled light from what commissioning
    /// inferred (the image's live section; none for a CAD model).
    pub stated_rel_uncertainty: Option<f64>,
}

/// Everything the report says, as `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Results {
    /// Scene.
    pub scene: String,
    /// Preset.
    pub preset: String,
    /// Commissioned, ISO 8601 UTC.
    pub commissioned: String,
    /// Report made, ISO 8601 UTC.
    pub reported: String,
    /// Software that commissioned.
    pub commissioned_by: String,
    /// Software that reported.
    pub reported_by: String,
    /// Maintenance factor.
    pub maintenance_factor: f64,
    /// The activity checked.
    pub requirement: Requirement,
    /// Patches, luminaires, sensors of the image.
    pub counts: [usize; 3],
    /// Surfaces.
    pub surfaces: Vec<SurfaceRow>,
    /// Luminaires.
    pub luminaires: Vec<LuminaireRow>,
    /// Total flux, lm, and power, W (of the luminaires whose power is known).
    pub totals: (f64, Option<f64>),
    /// Room floor outline x0, x1, y0, y1, m, and floor height.
    pub room_extent_m: ([f64; 4], f64),
    /// The windows drawn on the plan (none when the model has no surface labelled `window…`).
    pub windows: Vec<map::PlanWindow>,
    /// Room grid (floor, less the 0.5 m wall band) in the design state.
    pub room: Option<AreaResult>,
    /// Desks in the design state.
    pub desks: Vec<DeskResult>,
    /// Every state.
    pub states: Vec<StateResult>,
    /// The desk sensors.
    pub sensors: Vec<SensorRow>,
    /// The walls commissioning placed without seeing them (none for a CAD model).
    pub unseen_walls: Vec<crate::store::geometry::UnseenWallRecord>,
    /// UGR at a seated observer per desk (design state, new installation).
    pub ugr: UgrResult,
    /// The standard UGR table (CIE 117 / CIE 190) of each luminaire type.
    pub ugr_table: Vec<super::ugr_table::TypeTable>,
    /// Walls, ceiling and the cylindrical illuminance (design state, maintained).
    pub room_surfaces: Vec<RoomValue>,
    /// The EN 12464-1:2021 requirements of the activity, checked.
    pub requirements: Vec<RequirementRow>,
    /// All desks pass their task-area and surrounding checks.
    pub desks_pass: bool,
    /// Every checked requirement passes.
    pub pass: bool,
    /// Why the design fails (empty when it passes).
    pub fails_because: Vec<String>,
    /// Installed power, power densities and LENI (EN 15193-1) with their assumptions.
    pub energy: Energy,
    /// LENI, kWh/(m²·year) (the key; `energy` holds its assumptions).
    pub leni_kwh_per_m2_year: Option<f64>,
    /// Seconds the report took (computing, not writing).
    pub seconds: f64,
}

/// A finished report: the numbers and the pictures (PNG bytes).
pub struct Report {
    /// The numbers.
    pub results: Results,
    /// (file stem, caption, PNG bytes).
    pub pictures: Vec<(String, String, Vec<u8>)>,
    /// The boxes of the labels placed on the plan's map, pixels: x0, y0, x1, y1.
    pub plan_label_boxes: Vec<[f64; 4]>,
}

/// Seconds since 1970 as `YYYY-MM-DD hh:mm UTC`.
pub fn iso_utc(unix_s: u64) -> String {
    let days = (unix_s / 86_400) as i64;
    let secs = unix_s % 86_400;
    // civil from days (H. Hinnant)
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        secs / 3600,
        (secs % 3600) / 60
    )
}

fn is_floor(name: &str) -> bool {
    name.eq_ignore_ascii_case("floor") || name.starts_with("floor")
}

/// The floor: its outline in plan, its height and its area, m² (the `floor` group's up-facing
/// patches, or the lowest up-facing patches).
fn floor_of(room: &Room) -> ([f64; 4], f64, f64) {
    let p = &room.patches;
    let up: Vec<usize> = (0..p.len()).filter(|&i| p.normal[i].z > 0.9).collect();
    let named: Vec<usize> = up
        .iter()
        .copied()
        .filter(|&i| {
            room.section
                .groups
                .get(p.group[i] as usize)
                .is_some_and(|g| is_floor(g))
        })
        .collect();
    let chosen = if named.is_empty() {
        let zmin = up
            .iter()
            .map(|&i| p.centroid_m(i).z)
            .fold(f64::INFINITY, f64::min);
        up.into_iter()
            .filter(|&i| (p.centroid_m(i).z - zmin).abs() < 0.05)
            .collect()
    } else {
        named
    };
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut z = 0.0;
    let mut area = 0.0;
    for &i in &chosen {
        for c in &p.corners_m[i] {
            b[0] = b[0].min(c.x);
            b[1] = b[1].max(c.x);
            b[2] = b[2].min(c.y);
            b[3] = b[3].max(c.y);
        }
        z += p.centroid_m(i).z * p.area_m2[i];
        area += p.area_m2[i];
    }
    if area > 0.0 {
        (b, z / area, area)
    } else {
        ([0.0, 1.0, 0.0, 1.0], 0.0, 0.0)
    }
}

fn area_result(values: &[f64], mf: f64) -> Option<AreaResult> {
    let new = Statistics::of(values)?;
    Some(AreaResult {
        new,
        maintained: new.maintained(mf),
        points: Vec::new(),
    })
}

/// Readings at the points of a desk's task grid: exact direct light at each point, and the
/// interreflection gathered from the patches' exitance with `rays` rays from 1 mm above the
/// point, on a desk top as in the air (a desk the model has no top for). Gathered, not
/// interpolated over the desk's patches: a point beside a monitor sees the monitor's back
/// where the patch's mean sees the room (room_02's points 2 cm behind a monitor read 56-69 %
/// high interpolated; docs/report.md). Hits close to a large patch take the exitance at the hit
/// point, not the patch's mean ([`super::near_gather`]).
fn plane_points(field: &DenseField<'_>, room: &Room, pts: &[DVec3], rays: usize) -> Readings {
    super::near_gather::plane_readings(field, &room.patches, pts, &room.basis_b, rays)
}

struct DeskGrids {
    id: u32,
    /// Every task-grid point, m.
    positions_m: Vec<DVec3>,
    /// Per point: under an object standing on the desk ([`task_points::covered`]).
    covered: Vec<bool>,
    /// The free points' readings.
    task: Readings,
    grid: ([usize; 2], [f64; 2]),
    surrounding: Option<Readings>,
}

/// The states to report: the options' (the first is the design state), or all on; each with
/// one level in [0, 1] per luminaire.
fn checked_states(opts: &ReportOptions, l: usize) -> Result<Vec<NamedState>, ReportError> {
    let mut states = opts.states.clone();
    if states.is_empty() {
        states.push(NamedState {
            name: "all on".into(),
            levels: vec![1.0; l],
        });
    }
    for s in &states {
        if s.levels.len() != l || s.levels.iter().any(|x| !(0.0..=1.0).contains(x)) {
            return Err(ReportError::State(
                s.name.clone(),
                format!("{} levels in [0, 1] needed", l),
            ));
        }
    }
    Ok(states)
}

/// The room's plan: its floor's extent and height, the room's and the desks' rectangles.
struct Plan {
    /// Floor extent `[x0, x1, y0, y1]`, m.
    floor_ext: [f64; 4],
    /// Floor height, m.
    floor_z: f64,
    /// Floor area (its patches), m².
    floor_area_m2: f64,
    /// The floor's rectangle.
    room_rect: Rect,
    /// Each desk's rectangle (the room's desk order).
    desk_rects: Vec<Rect>,
    /// The windows, from the surfaces labelled `window…`.
    windows: Vec<map::PlanWindow>,
}

impl Plan {
    fn of(room: &Room) -> Plan {
        let (floor_ext, floor_z, floor_area_m2) = floor_of(room);
        Plan {
            floor_ext,
            floor_z,
            floor_area_m2,
            room_rect: Rect {
                x_m: [floor_ext[0], floor_ext[1]],
                y_m: [floor_ext[2], floor_ext[3]],
            },
            desk_rects: room
                .desks
                .iter()
                .map(|d| Rect {
                    x_m: d.x_m,
                    y_m: d.y_m,
                })
                .collect(),
            windows: map::windows_of(
                &room.patches.corners_m,
                &room.patches.normal,
                &room.patches.group,
                &room.section.groups,
            ),
        }
    }
}

/// Each desk's EN 12464-1 task grid (points under an object standing on it left out) and its
/// immediate surrounding (off every desk).
fn desk_grids(
    room: &Room,
    field: &DenseField<'_>,
    plan: &Plan,
    opts: &ReportOptions,
) -> Result<Vec<DeskGrids>, ReportError> {
    let mut out = Vec::new();
    for (d, rect) in room.desks.iter().zip(&plan.desk_rects) {
        let g = en12464::grid(rect)?;
        // points under an object standing on the desk (a monitor's foot): no light arrives
        // there and no luxmeter goes there
        let positions_m: Vec<DVec3> = g
            .points_m
            .iter()
            .map(|p| DVec3::new(p[0], p[1], d.z_m))
            .collect();
        let flags: Vec<bool> = positions_m.iter().map(|p| covered(field, *p)).collect();
        let pts: Vec<DVec3> = positions_m
            .iter()
            .zip(&flags)
            .filter(|(_, c)| !**c)
            .map(|(p, _)| *p)
            .collect();
        let task = plane_points(field, room, &pts, opts.air_rays);
        let sg = en12464::immediate_surrounding_grid(
            rect,
            en12464::IMMEDIATE_SURROUNDING_BAND_M,
            &plan.room_rect,
        )?;
        let air: Vec<(DVec3, DVec3)> = sg
            .points_m
            .iter()
            .filter(|p| !plan.desk_rects.iter().any(|r| r.contains(p[0], p[1])))
            .map(|p| (DVec3::new(p[0], p[1], d.z_m + 0.001), DVec3::Z))
            .collect();
        let surrounding =
            (!air.is_empty()).then(|| field.air_points(&air, &room.basis_b, opts.air_rays));
        out.push(DeskGrids {
            id: d.id,
            positions_m,
            covered: flags,
            task,
            grid: (g.counts, g.cell_m),
            surrounding,
        });
    }
    Ok(out)
}

/// The room grid's points on the floor, less the wall band; points inside furniture left out.
fn room_points(field: &DenseField<'_>, plan: &Plan) -> Result<Vec<SurfacePoint>, ReportError> {
    let inner = plan.room_rect.grown(-en12464::WALL_BAND_M);
    let mut room_points = Vec::new();
    if inner.width_m() > 0.0 && inner.depth_m() > 0.0 {
        let g = en12464::grid(&inner)?;
        for p in &g.points_m {
            if let Some(sp) = field.surface_at(p[0], p[1], plan.floor_z)
                && !covered(field, sp.position_m)
            {
                room_points.push(sp);
            }
        }
    }
    Ok(room_points)
}

/// Every state's desks, room and sensors (maintained values at `mf`).
fn state_results(
    image: &Image<'_>,
    room: &Room,
    states: &[NamedState],
    desk_grids: &[DeskGrids],
    room_readings: &Readings,
    mf: f64,
) -> Result<Vec<StateResult>, ReportError> {
    let runtime = Runtime::new(image);
    let mut state_results = Vec::new();
    for s in states {
        let mut sensors = vec![0.0; image.sensors()];
        runtime.sensor_lux(&s.levels, &mut sensors)?;
        let desks = desk_grids
            .iter()
            .map(|g| {
                let v = g.task.lux(&s.levels)?;
                Ok(Statistics::of(&v).map(|st| (g.id, st.maintained(mf))))
            })
            .collect::<Result<Vec<_>, crate::engine::EngineError>>()?
            .into_iter()
            .flatten()
            .collect();
        let room_v = room_readings.lux(&s.levels)?;
        state_results.push(StateResult {
            name: s.name.clone(),
            levels: s.levels.clone(),
            desks,
            room: Statistics::of(&room_v).map(|st| st.maintained(mf)),
            sensors_lx: room.sensors.iter().map(|x| x.id).zip(sensors).collect(),
        });
    }
    Ok(state_results)
}

/// The desks in the design state `design`, with their checks against the requirement.
fn design_desks(
    room: &Room,
    desk_grids: &[DeskGrids],
    design: &[f64],
    mf: f64,
    opts: &ReportOptions,
) -> Result<Vec<DeskResult>, ReportError> {
    let mut desks = Vec::new();
    for (g, d) in desk_grids.iter().zip(&room.desks) {
        let Some(mut task) = area_result(&g.task.lux(design)?, mf) else {
            continue;
        };
        let all_on = g.task.lux(&vec![1.0; design.len()])?;
        task.points =
            task_points::task_points(&g.positions_m, &g.covered, &all_on).unwrap_or_default();
        let surrounding = match &g.surrounding {
            Some(r) => area_result(&r.lux(design)?, mf),
            None => None,
        };
        let checks = en12464::check_task(
            &opts.requirement,
            &task.maintained,
            surrounding.as_ref().map(|s| &s.maintained),
        );
        desks.push(DeskResult {
            id: d.id,
            extent_m: [d.x_m[0], d.x_m[1], d.y_m[0], d.y_m[1]],
            z_m: d.z_m,
            grid: g.grid,
            pass: checks.iter().all(|c| c.pass),
            task,
            surrounding,
            checks,
        });
    }
    Ok(desks)
}

/// The surfaces table: area, area-weighted reflectance and patches per surface (group).
fn surface_rows(room: &Room) -> Vec<SurfaceRow> {
    let mut surfaces: Vec<SurfaceRow> = room
        .section
        .groups
        .iter()
        .map(|g| SurfaceRow {
            surface: g.clone(),
            area_m2: 0.0,
            rho: 0.0,
            patches: 0,
        })
        .collect();
    for i in 0..room.patches.len() {
        if let Some(r) = surfaces.get_mut(room.patches.group[i] as usize) {
            r.area_m2 += room.patches.area_m2[i];
            r.rho += room.patches.rho[i] * room.patches.area_m2[i];
            r.patches += 1;
        }
    }
    surfaces.retain(|r| r.patches > 0);
    for r in &mut surfaces {
        r.rho /= r.area_m2.max(1e-12);
    }
    surfaces
}

/// The luminaires table.
fn luminaire_rows(room: &Room) -> Vec<LuminaireRow> {
    room.section
        .luminaires
        .iter()
        .map(|rec| {
            let ph = room.section.photometries.get(rec.photometry as usize);
            let rated = match ph {
                Some(p) => RatedPower::of(rec.flux_lm, p.power_w, p.file_flux_lm),
                None => RatedPower::assumed(rec.flux_lm),
            };
            let power = Some(rated.full_w);
            LuminaireRow {
                id: rec.id,
                name: rec.name.clone(),
                photometry_file: ph.map(|p| p.file_name.clone()).unwrap_or_default(),
                luminaire: ph.map(|p| p.luminaire.clone()).unwrap_or_default(),
                flux_lm: rec.flux_lm,
                power_w: power,
                power_assumed: rated.source == PowerSource::AssumedEfficacy,
                efficacy_lm_per_w: power.map(|w| rec.flux_lm / w),
                position_m: rec.position_m,
                opening_m: rec.opening_m,
            }
        })
        .collect()
}

/// The sensors table, from the image.
fn sensor_rows(image: &Image<'_>) -> Vec<SensorRow> {
    let points = crate::points::points_of(image);
    (0..image.sensors())
        .map(|k| {
            let f = image.sensor_flags(k);
            SensorRow {
                id: image.sensor_id(k),
                name: points
                    .get(k)
                    .map_or_else(|| format!("S{}", image.sensor_id(k)), |p| p.name.clone()),
                in_view: f & crate::store::sensor_flags::OUT_OF_VIEW == 0,
                estimated: f & crate::store::sensor_flags::ESTIMATED != 0,
                calibrated: f & crate::store::sensor_flags::CALIBRATED != 0,
                stated_rel_uncertainty: image.model_rel_uncertainty(k),
            }
        })
        .collect()
}

/// What the pictures show: the room in its design state.
struct Design<'a> {
    room: &'a Room,
    plan: &'a Plan,
    /// The design state's name and levels.
    name: &'a str,
    levels: &'a [f64],
    /// Maintenance factor.
    mf: f64,
    /// The desks' results in the design state.
    desks: &'a [DeskResult],
}

/// One picture: (file stem, caption, PNG bytes).
type Picture = (String, String, Vec<u8>);

impl Design<'_> {
    /// The plan view: the top view's map (upward-facing surfaces), the room grid's values off
    /// the desks, the desks, the luminaires and the sensors. Also the colour scale's top, lx,
    /// and the placed labels' boxes.
    fn plan_picture(
        &self,
        field: &DenseField<'_>,
        room_points: &[SurfacePoint],
        room_readings: &Readings,
        opts: &ReportOptions,
    ) -> Result<(Picture, f64, Vec<[f64; 4]>), ReportError> {
        let (room, mf, design) = (self.room, self.mf, self.levels);
        let (origin_m, cells, map_pts) = map::map_points(
            field,
            self.plan.floor_ext,
            room.patches
                .corners_m
                .iter()
                .flatten()
                .map(|c| c.z)
                .fold(f64::NEG_INFINITY, f64::max)
                + 1.0,
            opts.plan_cell_m,
        );
        let found: Vec<SurfacePoint> = map_pts.iter().flatten().copied().collect();
        let map_vals = field.map_readings(&found).lux(design)?;
        let mut k = 0;
        let map_lux: Vec<f64> = map_pts
            .iter()
            .map(|p| match p {
                Some(_) => {
                    k += 1;
                    mf * map_vals[k - 1]
                }
                None => f64::NAN,
            })
            .collect();
        let surface = map_pts
            .iter()
            .map(|p| {
                p.map_or(u64::MAX, |p| {
                    map::surface_key(room.patches.group[p.patch as usize], p.position_m.z)
                })
            })
            .collect();
        let top = TopView {
            origin_m,
            cells,
            cell_m: opts.plan_cell_m,
            lux: map_lux,
            desk_mean_lx: Vec::new(),
            surface,
        };
        // the floor grid's values, except under a desk (the plan shows the desk top there)
        let room_values: Vec<([f64; 2], f64)> = room_points
            .iter()
            .zip(room_readings.lux(design)?)
            .filter(|(p, _)| {
                !self
                    .plan
                    .desk_rects
                    .iter()
                    .any(|r| r.contains(p.position_m.x, p.position_m.y))
            })
            .map(|(p, v)| ([p.position_m.x, p.position_m.y], mf * v))
            .collect();
        let scale_max = nice_ceiling(top.max_lx());
        let view = PlanView {
            title: format!(
                "{}: maintained illuminance, {} (MF {:.2})",
                room.section.scene_name, self.name, mf
            ),
            subtitle: format!(
                "Upward-facing surfaces; isolines white; numbers: EN 12464-1 floor grid (lx, not under desks); red: sensors{}.",
                if self.plan.windows.is_empty() {
                    ""
                } else {
                    "; blue bars: windows"
                }
            ),
            bounds_m: self.plan.floor_ext,
            map: top,
            desks: self
                .desks
                .iter()
                .map(|d| PlanDesk {
                    extent_m: d.extent_m,
                    label: vec![
                        format!("desk {}", d.id),
                        format!("Ēm {:.0} lx", d.task.maintained.e_mean_lx),
                        format!("U0 {:.2}", d.task.maintained.u0),
                    ],
                })
                .collect(),
            sensors: room
                .sensors
                .iter()
                .map(|s| (s.id, s.position_m.x, s.position_m.y))
                .collect(),
            luminaires: room
                .section
                .luminaires
                .iter()
                .map(|l| (l.id, [l.position_m[0], l.position_m[1]], l.opening_m))
                .collect(),
            values: room_values,
            scale_max_lx: scale_max,
            pixels_per_m: 100.0,
            windows: self.plan.windows.clone(),
        };
        let plan = map::draw_plan(&view);
        let boxes = map::plan_labels(&view)
            .iter()
            .map(super::Label::bbox)
            .collect();
        Ok((
            (
                "plan".to_string(),
                "Plan view: maintained illuminance on the upward-facing surfaces (floor, desk tops) in the design state, with isolines, the values of the EN 12464-1 room grid, the desks and the desk sensors.".to_string(),
                plan.png_bytes()?,
            ),
            scale_max,
            boxes,
        ))
    }

    /// The camera views: dense lux (colour scale up to `scale_max`), reflectance, mesh.
    fn camera_pictures(
        &self,
        view: &DenseImage,
        cam: &Camera,
        scale_max: f64,
    ) -> Result<Vec<Picture>, ReportError> {
        let (room, mf) = (self.room, self.mf);
        let lux: Vec<f64> = view.lux(self.levels)?.iter().map(|v| v * mf).collect();
        let vdesks: Vec<ViewDesk> = room
            .desks
            .iter()
            .map(|d| ViewDesk {
                desk: d.clone(),
                label: self
                    .desks
                    .iter()
                    .find(|r| r.id == d.id)
                    .map(|r| {
                        vec![
                            format!("desk {}", d.id),
                            format!("Ēm {:.0} lx", r.task.maintained.e_mean_lx),
                        ]
                    })
                    .unwrap_or_else(|| vec![format!("desk {}", d.id)]),
            })
            .collect();
        let zoom = if cam.width <= 400 { 2 } else { 1 };
        let lux_pic = camera_view::lux_picture(
            view,
            &lux,
            cam,
            &vdesks,
            &ViewOptions {
                title: format!("Camera view: maintained illuminance, {}", self.name),
                subtitle: format!(
                    "Lux at every pixel's surface point (MF {mf:.2}); luminaire openings white, nothing seen grey."
                ),
                zoom,
            },
            scale_max,
        );
        let mut pictures = vec![(
            "camera-lux".into(),
            "Camera view: the illuminance of every pixel's surface point (dense: exact direct light, interreflection interpolated over the patch mesh).".into(),
            lux_pic.png_bytes()?,
        )];
        let names: Vec<ViewDesk> = room
            .desks
            .iter()
            .map(|d| ViewDesk {
                desk: d.clone(),
                label: vec![format!("desk {}", d.id)],
            })
            .collect();
        let rho_pic = camera_view::reflectance_picture(
            view,
            &room.patches,
            cam,
            &names,
            &ViewOptions {
                title: "Camera view: reflectance ρ the model uses".into(),
                subtitle:
                    "Diffuse reflectance per pixel (black 0, white 1); amber: luminaire openings."
                        .into(),
                zoom,
            },
        );
        pictures.push((
            "camera-reflectance".into(),
            "Reflectance view: the diffuse reflectance of every surface the camera sees, as estimated at commissioning.".into(),
            rho_pic.png_bytes()?,
        ));
        let mesh_pic = camera_view::mesh_picture(
            view,
            &room.patches,
            &ViewOptions {
                title: format!("Camera view: the mesh, {} patches", room.patches.len()),
                subtitle:
                    "Patch edges dark, one pastel colour per surface; amber: luminaire openings."
                        .into(),
                zoom,
            },
        );
        pictures.push((
            "camera-mesh".into(),
            "The mesh: the patches radiosity solves for, as the camera sees them.".into(),
            mesh_pic.png_bytes()?,
        ));
        Ok(pictures)
    }
}

/// EN 12464-1:2021's checks beyond the desks in the design state: UGR per desk observer, the
/// walls, the ceiling and the cylindrical illuminance; and the requirements table with them.
fn room_checks(
    field: &DenseField<'_>,
    room: &Room,
    plan: &Plan,
    design: &[f64],
    mf: f64,
    opts: &ReportOptions,
    desks: &[DeskResult],
) -> (UgrResult, Vec<RoomValue>, Vec<RequirementRow>) {
    let (rect, z) = (&plan.room_rect, plan.floor_z);
    let ugr = glare::room_ugr(field, room, rect, z, design, opts.air_rays);
    let mut values = room_surfaces::walls_and_ceiling(field, room, design, mf).to_vec();
    values.push(room_surfaces::cylindrical(
        field,
        room,
        rect,
        z,
        design,
        mf,
        opts.air_rays,
    ));
    let table = requirements::table(
        &opts.requirement,
        desks,
        &ugr,
        &values,
        &room.section.photometries,
    );
    (ugr, values, table)
}

/// The energy figures: the schedule's powers, the floor's area, the maintained mean of the room
/// grid (or, without one, the task areas' area-weighted mean), the daylight the image holds.
fn energy_of(
    image: &Image<'_>,
    room_model: &Room,
    plan: &Plan,
    luminaires: &[LuminaireRow],
    room: Option<&AreaResult>,
    desks: &[DeskResult],
    (mf, target_lx): (f64, f64),
) -> Energy {
    let powers_w: Vec<f64> = luminaires.iter().filter_map(|l| l.power_w).collect();
    let task = || {
        let (mut sum, mut area) = (0.0, 0.0);
        for d in desks {
            let a = (d.extent_m[1] - d.extent_m[0]) * (d.extent_m[3] - d.extent_m[2]);
            sum += d.task.maintained.e_mean_lx * a;
            area += a;
        }
        (area > 0.0).then(|| {
            (
                sum / area,
                "the task areas' maintained Ēm (area-weighted), design state".to_string(),
            )
        })
    };
    let em = room
        .map(|r| {
            (
                r.maintained.e_mean_lx,
                "the room grid's maintained Ēm (floor less the 0.5 m wall band), design state"
                    .to_string(),
            )
        })
        .or_else(task);
    let daylight = super::daylight_factor::of_image(image.daylight.as_ref(), room_model);
    let daylight_year = daylight
        .as_ref()
        .and_then(|d| daylight_year_of(image, d, target_lx));
    energy::energy(&EnergyInput {
        powers_w: &powers_w,
        power_assumed: luminaires.iter().any(|l| l.power_assumed),
        floor_area_m2: plan.floor_area_m2,
        em,
        maintenance_factor: mf,
        daylight,
        daylight_year,
    })
}

/// The node's daylight control over a year at the image's site, every desk sensor (every
/// sensor when none lies on a desk) held at the activity's `Ēm` (`None` when the controller
/// refuses the image's numbers).
fn daylight_year_of(
    image: &Image<'_>,
    daylight: &super::daylight_factor::DaylightSupply,
    target_lx: f64,
) -> Option<super::daylight_year::DaylightYear> {
    use crate::control::{LuminairePower, Plant, rating::rated_powers};
    let site = image.daylight.as_ref()?;
    let l = image.luminaires();
    if daylight.sensors.len() != image.sensors() {
        return None;
    }
    let on_desk: Vec<usize> = (0..daylight.sensors.len())
        .filter(|&k| daylight.sensors[k].desk.is_some())
        .collect();
    let rows: Vec<usize> = if on_desk.is_empty() {
        (0..daylight.sensors.len()).collect()
    } else {
        on_desk
    };
    let response = image.response_rows_lx(rows.iter().copied());
    let power: Vec<LuminairePower> = rated_powers(image)
        .into_iter()
        .map(LuminairePower::rated)
        .collect();
    let d: Vec<f64> = rows
        .iter()
        .map(|&k| daylight.sensors[k].d_pct / 100.0)
        .collect();
    super::daylight_year::daylight_dependency(&super::daylight_year::YearInput {
        plant: Plant {
            desks: rows.len(),
            luminaires: l,
            response_lx: &response,
            power: &power,
            curve: crate::dali::DimmingCurve::Logarithmic,
        },
        target_lx: &vec![target_lx; rows.len()],
        daylight_factor: &d,
        latitude_deg: site.latitude_deg,
        longitude_deg: site.longitude_deg,
    })
    .ok()
}

/// Computes the report of an image: the states checked, the dense field, the desks' and the
/// room's grids, every state's results, the design state's desks, the tables and the pictures.
pub fn compute(image: &Image<'_>, opts: &ReportOptions) -> Result<Report, ReportError> {
    let t0 = std::time::Instant::now();
    let room = Room::from_image(image)?;
    let mf = en12464::check_maintenance_factor(
        opts.maintenance_factor
            .unwrap_or(room.section.maintenance_factor),
    )?;
    let states = checked_states(opts, room.luminaires.len())?;
    let field = DenseField::new(
        &room.patches,
        &room.luminaires,
        &room.ff,
        &room.basis_b,
        DenseSettings::default(),
    )?;
    let plan = Plan::of(&room);
    let desk_grids = desk_grids(&room, &field, &plan, opts)?;
    let room_points = room_points(&field, &plan)?;
    let room_readings = field.points(&room_points);
    let view = match &room.camera {
        Some(cam) => Some(field.camera_view(cam)?),
        None => None,
    };
    let state_results = state_results(image, &room, &states, &desk_grids, &room_readings, mf)?;

    // the design state: desks with their checks, the room
    let design = &states[0].levels;
    let desks = design_desks(&room, &desk_grids, design, mf, opts)?;
    let room_result = area_result(&room_readings.lux(design)?, mf);
    let surfaces = surface_rows(&room);
    let luminaires = luminaire_rows(&room);
    let total_flux: f64 = luminaires.iter().map(|r| r.flux_lm).sum();
    let total_power = luminaires
        .iter()
        .map(|r| r.power_w)
        .collect::<Option<Vec<f64>>>()
        .map(|v| v.iter().sum());

    let d = Design {
        room: &room,
        plan: &plan,
        name: &states[0].name,
        levels: design,
        mf,
        desks: &desks,
    };
    let (plan_pic, scale_max, plan_label_boxes) =
        d.plan_picture(&field, &room_points, &room_readings, opts)?;
    let mut pictures = vec![plan_pic];
    if let (Some(view), Some(cam)) = (&view, &room.camera) {
        pictures.extend(d.camera_pictures(view, cam, scale_max)?);
    }
    let desks_pass = !desks.is_empty() && desks.iter().all(|d| d.pass);
    let (ugr, room_surfaces, requirements) =
        room_checks(&field, &room, &plan, design, mf, opts, &desks);
    let (pass, fails_because) = requirements::verdict(&requirements);
    let energy = energy_of(
        image,
        &room,
        &plan,
        &luminaires,
        room_result.as_ref(),
        &desks,
        (mf, opts.requirement.e_m_lx),
    );
    let results = Results {
        scene: room.section.scene_name.clone(),
        preset: room.section.preset.clone(),
        commissioned: iso_utc(room.section.commissioned_unix_s),
        reported: iso_utc(opts.now_unix_s),
        commissioned_by: room.section.software.clone(),
        reported_by: crate::image_geometry::software(),
        maintenance_factor: mf,
        requirement: opts.requirement,
        counts: [image.patches(), image.luminaires(), image.sensors()],
        surfaces,
        luminaires,
        totals: (total_flux, total_power),
        room_extent_m: (plan.floor_ext, plan.floor_z),
        windows: plan.windows.clone(),
        room: room_result,
        desks,
        states: state_results,
        sensors: sensor_rows(image),
        unseen_walls: room.section.unseen_walls.clone(),
        ugr,
        ugr_table: super::ugr_table::tables(&room),
        room_surfaces,
        requirements,
        desks_pass,
        pass,
        fails_because,
        leni_kwh_per_m2_year: energy.leni_kwh_per_m2_year,
        energy,
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok(Report {
        results,
        pictures,
        plan_label_boxes,
    })
}

pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Standard base64 (RFC 4648) of some bytes, for `data:` URIs.
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        out.push(A[(n >> 18) as usize & 63] as char);
        out.push(A[(n >> 12) as usize & 63] as char);
        out.push(if c.len() > 1 {
            A[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        out.push(if c.len() > 2 {
            A[n as usize & 63] as char
        } else {
            '='
        });
    }
    out
}

fn stats_cells(s: &Statistics) -> String {
    format!(
        "<td>{:.0}</td><td>{:.0}</td><td>{:.0}</td><td>{:.2}</td><td>{:.2}</td>",
        s.e_mean_lx, s.e_min_lx, s.e_max_lx, s.u0, s.e_min_over_e_max
    )
}

fn verdict(pass: bool) -> &'static str {
    if pass {
        "<span class=\"pass\">pass</span>"
    } else {
        "<span class=\"fail\">fail</span>"
    }
}

/// The HTML of a report (self-contained).
pub fn html(r: &Report) -> String {
    let x = &r.results;
    let mut h = String::new();
    html_head(&mut h, x);
    html_pictures(&mut h, &r.pictures);
    html_checks(&mut h, x);
    html_ugr(&mut h, x);
    html_desks(&mut h, x);
    html_points(&mut h, x);
    html_states(&mut h, x);
    html_energy(&mut h, &x.energy);
    html_tables(&mut h, x);
    super::ugr_table::html(&mut h, &x.ugr_table);
    html_tail(&mut h, x);
    h
}

/// The head, the title, the overall result and the facts of the model and the report.
fn html_head(h: &mut String, x: &Results) {
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
<title>Lighting commissioning report: {scene}</title>\
<style>body{{font-family:'DejaVu Sans',Verdana,sans-serif;margin:2em auto;max-width:1100px;color:#222;font-size:14px}}\
h1{{font-size:24px}}h2{{font-size:19px;border-bottom:1px solid #bbb;margin-top:1.6em}}\
table{{border-collapse:collapse;margin:0.6em 0}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}\
th{{background:#f0f0f0}}td:first-child,th:first-child{{text-align:left}}\
figure{{margin:1em 0}}img{{max-width:100%;border:1px solid #ddd}}figcaption{{color:#555}}\
.ptgrid{{display:flex;flex-wrap:wrap;gap:0 2em}}.ptdesk{{display:grid;grid-template-columns:auto auto;gap:0 1em;align-items:start}}.ptdesk h3{{font-size:15px;grid-column:1/-1}}.pts td,.pts th{{padding:1px 6px}}tr.covered td{{color:#999;background:#eee;font-style:italic}}.pass{{color:#0a7a2a;font-weight:bold}}.fail{{color:#b00020;font-weight:bold}}.meta td{{text-align:left}}#requirements td{{text-align:left}}.ugr-table td,.ugr-table th{{padding:1px 5px;font-size:12px}}\
@media print{{body{{margin:0;max-width:none;font-size:10pt}}h2{{break-after:avoid}}table,figure,.ptdesk{{break-inside:avoid}}.ugr-table td,.ugr-table th{{font-size:8pt;padding:1px 3px}}\
img{{max-width:100%;border:none}}#imgstatus{{display:none}}th{{background:#eee;-webkit-print-color-adjust:exact;print-color-adjust:exact}}\
@page{{size:A4;margin:12mm}}}}</style></head>\n<body data-images=\"pending\">\n",
        scene = esc(&x.scene)
    );
    let _ = write!(
        h,
        "<h1>Lighting commissioning report: {}</h1>\n<p id=\"verdict\">Overall EN 12464-1:2021 result ({}): {}{}</p>\n",
        esc(&x.scene),
        esc(x.requirement.activity),
        verdict(x.pass),
        if x.pass {
            String::new()
        } else {
            format!(" because {}", esc(&x.fails_because.join("; ")))
        }
    );
    html_requirements(h, x);
    let _ = write!(
        h,
        "<table class=\"meta\"><tr><th>scene</th><td>{}</td></tr><tr><th>preset</th><td>{}</td></tr>\
<tr><th>commissioned</th><td>{} by {}</td></tr><tr><th>report</th><td>{} by {}</td></tr>\
<tr><th>maintenance factor</th><td>{:.2} (maintained values = new values × MF)</td></tr>\
<tr><th>model</th><td>{} patches, {} luminaires, {} desk sensors</td></tr>\
<tr><th>pictures</th><td id=\"imgstatus\">loading</td></tr></table>",
        esc(&x.scene),
        esc(&x.preset),
        esc(&x.commissioned),
        esc(&x.commissioned_by),
        esc(&x.reported),
        esc(&x.reported_by),
        x.maintenance_factor,
        x.counts[0],
        x.counts[1],
        x.counts[2]
    );
}

/// The requirements of the activity: required, achieved, result, why.
fn html_requirements(h: &mut String, x: &Results) {
    h.push_str("<table id=\"requirements\"><tr><th>requirement</th><th>required</th><th>achieved (worst)</th><th>result</th><th>why</th></tr>\n");
    for r in &x.requirements {
        let result = match r.pass {
            Some(p) => verdict(p).to_string(),
            None => "not checked".into(),
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{result}</td><td>{}</td></tr>",
            esc(&r.what),
            esc(&r.required),
            esc(&r.achieved),
            esc(&r.reason)
        );
    }
    let _ = writeln!(
        h,
        "</table>\n<p>Maintained values (MF {:.2}) except UGR (new installation, as CIE 117 rates it); the values from {}.</p>",
        x.maintenance_factor,
        esc(x.requirement.reference)
    );
}

/// A value to `decimals` places, or "–" when it is not a number.
fn finite(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "–".into()
    }
}

/// UGR per observer.
fn html_ugr(h: &mut String, x: &Results) {
    let u = &x.ugr;
    let _ = write!(
        h,
        "<h2>Glare: UGR (CIE 117)</h2>\n<p>UGR = 8 log<sub>10</sub>((0.25/L<sub>b</sub>) Σ L² ω / p²) at {} observer(s); limit UGR<sub>L</sub> {:.0}: {}. Convention: {}.</p>\n\
<table><tr><th>desk</th><th>eye (m)</th><th>looking</th><th>E<sub>ind</sub> (lx)</th><th>L<sub>b</sub> (cd/m²)</th><th>luminaires in view</th><th>UGR</th></tr>\n",
        u.observers.len(),
        u.limit,
        verdict(u.pass),
        esc(u.convention)
    );
    for o in &u.observers {
        let value = match (&o.ugr, &o.not_computed) {
            (Some(v), _) => format!("{v:.1}"),
            (None, Some(why)) => format!("not computed: {}", esc(why)),
            (None, None) => "no luminaire in view".into(),
        };
        let _ = writeln!(
            h,
            "<tr><td>desk {}</td><td>{:.2}, {:.2}, {:.2}</td><td>{:+.0}, {:+.0}</td><td>{}</td><td>{}</td><td>{}</td><td>{value}</td></tr>",
            o.desk,
            o.eye_m[0],
            o.eye_m[1],
            o.eye_m[2],
            o.sight[0],
            o.sight[1],
            finite(o.e_ind_lx, 0),
            finite(o.l_b_cd_per_m2, 1),
            o.terms.len()
        );
    }
    h.push_str("</table>\n");
}

/// The pictures, embedded.
fn html_pictures(h: &mut String, pictures: &[(String, String, Vec<u8>)]) {
    h.push_str("\n<h2>Pictures</h2>\n");
    for (stem, caption, png) in pictures {
        let _ = writeln!(
            h,
            "<figure id=\"{stem}\"><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
            esc(caption),
            base64(png),
            esc(caption)
        );
    }
}

/// The EN 12464-1 checks per desk.
fn html_checks(h: &mut String, x: &Results) {
    let _ = write!(
        h,
        "<h2>EN 12464-1 check</h2>\n<p>{} ({}): Ēm ≥ {:.0} lx and U0 ≥ {:.2} on each desk (task area); \
immediate surrounding area (0.5 m band at desk height): Ēm ≥ {:.0} lx, U0 ≥ {:.2}. Maintained values.</p>\n\
<table><tr><th>desk</th><th>check</th><th>required</th><th>achieved</th><th>result</th></tr>\n",
        esc(x.requirement.activity),
        esc(x.requirement.reference),
        x.requirement.task_e_m_lx(),
        x.requirement.u0,
        en12464::immediate_surrounding_lx(x.requirement.task_e_m_lx()),
        en12464::IMMEDIATE_SURROUNDING_U0
    );
    for d in &x.desks {
        for c in &d.checks {
            let fmt = |v: f64| {
                if c.unit.is_empty() {
                    format!("{v:.2}")
                } else {
                    format!("{v:.0} {}", c.unit)
                }
            };
            let _ = writeln!(
                h,
                "<tr><td>desk {}</td><td>{}</td><td>≥ {}</td><td>{}</td><td>{}</td></tr>",
                d.id,
                esc(&c.what),
                fmt(c.required),
                fmt(c.achieved),
                verdict(c.pass)
            );
        }
    }
    h.push_str("</table>\n");
}

/// The desks' grids and statistics, and the room's.
fn html_desks(h: &mut String, x: &Results) {
    let _ = write!(
        h,
        "<h2>Desks ({})</h2>\n<p>EN 12464-1 grids: cells of at most p = 0.2 × 5<sup>log10(d)</sup> m, points at the cell centres. \
Illuminance in lx; U0 = Emin/Ē.</p>\n<table><tr><th>desk</th><th>grid</th><th>values</th><th>Ē</th><th>Emin</th><th>Emax</th><th>U0</th><th>Emin/Emax</th></tr>\n",
        esc(&states_name(x))
    );
    for d in &x.desks {
        let grid = format!(
            "{} × {} ({:.2} × {:.2} m)",
            d.grid.0[0], d.grid.0[1], d.grid.1[0], d.grid.1[1]
        );
        let _ = writeln!(
            h,
            "<tr><td>desk {}</td><td>{grid}</td><td>maintained</td>{}</tr><tr><td></td><td></td><td>new</td>{}</tr>",
            d.id,
            stats_cells(&d.task.maintained),
            stats_cells(&d.task.new)
        );
        if let Some(s) = &d.surrounding {
            let _ = writeln!(
                h,
                "<tr><td>desk {} surrounding</td><td>{} points</td><td>maintained</td>{}</tr>",
                d.id,
                s.new.points,
                stats_cells(&s.maintained)
            );
        }
    }
    if let Some(rm) = &x.room {
        let _ = writeln!(
            h,
            "<tr><td>room (floor)</td><td>{} points</td><td>maintained</td>{}</tr>",
            rm.new.points,
            stats_cells(&rm.maintained)
        );
    }
}

/// The point values: a table per task area (new, every luminaire on).
fn html_points(h: &mut String, x: &Results) {
    h.push_str(
        "<h2>Point values</h2>\n<p>Each desk's task grid, new installation, every luminaire on, \
illuminance in lx. Points under an object standing on the desk (a monitor's foot) are covered: \
greyed, without a value, and left out of Ēm, Emin, Emax and U0.</p>\n<div class=\"ptgrid\">\n",
    );
    for d in &x.desks {
        task_points::html_table(h, d.id, &d.task.points);
    }
    h.push_str("</div>\n");
}

/// The states: each desk's, the floor's and each sensor's light.
fn html_states(h: &mut String, x: &Results) {
    h.push_str("</table>\n<h2>States</h2>\n<p>Maintained Ē per desk grid and on the floor, lx; the desk sensors as the node publishes them (new installation, what a luxmeter on the desk reads), lx.</p>\n<table><tr><th>state</th><th>levels</th>");
    if let Some(s) = x.states.first() {
        for (id, _) in &s.desks {
            let _ = write!(h, "<th>desk {id}</th>");
        }
        h.push_str("<th>floor</th>");
        for (id, _) in &s.sensors_lx {
            let _ = write!(h, "<th>S{id}</th>");
        }
    }
    h.push_str("</tr>\n");
    for s in &x.states {
        let levels: Vec<String> = s
            .levels
            .iter()
            .map(|v| format!("{:.0}", 100.0 * v))
            .collect();
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{} %</td>",
            esc(&s.name),
            levels.join(" ")
        );
        for (_, st) in &s.desks {
            let _ = write!(h, "<td>{:.0}</td>", st.e_mean_lx);
        }
        let _ = write!(
            h,
            "<td>{}</td>",
            s.room.map_or("–".into(), |r| format!("{:.0}", r.e_mean_lx))
        );
        for (_, v) in &s.sensors_lx {
            let _ = write!(h, "<td>{v:.0}</td>");
        }
        h.push_str("</tr>\n");
    }
}

/// A figure or "–" with the reason.
fn or_dash(v: Option<f64>, decimals: usize, why: &str) -> String {
    v.filter(|v| v.is_finite()).map_or_else(
        || format!("– ({})", esc(why)),
        |v| format!("{v:.decimals$}"),
    )
}

/// Installed power, power densities and LENI (EN 15193-1) with the factors they rest on.
fn html_energy(h: &mut String, e: &Energy) {
    let why = e.not_computed.as_deref().unwrap_or("no maintained mean");
    let flag = e.flag.as_ref().map_or(String::new(), |f| {
        format!(" <span class=\"fail\">{}</span>", esc(f))
    });
    let _ = write!(
        h,
        "<h2>Energy (EN 15193-1)</h2>\n<table id=\"energy\" class=\"meta\">\
<tr><th>installed power</th><td>{:.1} W{flag}</td></tr>\
<tr><th>floor area</th><td>{:.2} m²</td></tr>\
<tr><th>power density</th><td>{} W/m²</td></tr>\
<tr><th>per 100 lx</th><td>{} W/m²/100 lx, against {} ({} lx)</td></tr>\
<tr><th>W<sub>L</sub> + W<sub>P</sub></th><td>{:.1} + {:.1} kWh/year</td></tr>\
<tr><th>LENI</th><td id=\"leni\">{} kWh/(m²·year){flag}</td></tr></table>\n",
        e.installed_w,
        e.floor_area_m2,
        or_dash(e.w_per_m2, 2, why),
        or_dash(e.w_per_m2_per_100lx, 2, why),
        esc(&e.em_basis),
        or_dash(e.em_lx, 0, why),
        e.w_l_kwh,
        e.w_p_kwh,
        or_dash(e.leni_kwh_per_m2_year, 1, why),
    );
    let a = &e.assumptions;
    let rows = [
        ("t<sub>D</sub>, t<sub>N</sub>", format!("{:.0} h, {:.0} h", a.t_d_h, a.t_n_h), "EN 15193-1 default operating hours of an office".to_string()),
        ("F<sub>C</sub>", format!("{:.3}", a.f_c), a.f_c_source.clone()),
        ("F<sub>O</sub>", format!("{:.2}", a.f_o), a.f_o_source.clone()),
        ("F<sub>D</sub>", format!("{:.2}", a.f_d), a.f_d_source.clone()),
        ("parasitic", format!("{:.1} W × {:.0} h per luminaire", a.standby_w_per_luminaire, a.standby_h), "the gear's and the node's rated standby, in the hours t<sub>y</sub> − t<sub>D</sub> − t<sub>N</sub> the lighting is not operated".to_string()),
        ("emergency", format!("{:.0} kWh", a.emergency_kwh), "no emergency lighting charged".to_string()),
    ];
    h.push_str("<table id=\"energy-assumptions\"><tr><th>assumption</th><th>value</th><th>source</th></tr>\n");
    for (name, value, source) in rows {
        let _ = writeln!(
            h,
            "<tr><td>{name}</td><td>{value}</td><td style=\"text-align:left\">{}</td></tr>",
            source.replace('&', "&amp;")
        );
    }
    h.push_str("</table>\n<p>LENI = (W<sub>L</sub> + W<sub>P</sub>)/A, W<sub>L</sub> = Σ P<sub>n</sub> F<sub>C</sub> (t<sub>D</sub> F<sub>O</sub> F<sub>D</sub> + t<sub>N</sub> F<sub>O</sub>)/1000.</p>\n");
    if let Some(d) = &e.daylight {
        let _ = writeln!(
            h,
            "<p>Daylight factors: {}.</p>\n<table id=\"daylight-factors\"><tr><th>sensor</th><th>desk</th><th>D (%)</th></tr>",
            esc(d.scope)
        );
        for s in &d.sensors {
            let desk = s
                .desk
                .map_or_else(|| "–".to_string(), |k| format!("desk {k}"));
            let _ = writeln!(
                h,
                "<tr><td>S{}</td><td>{desk}</td><td>{:.2}</td></tr>",
                s.sensor, s.d_pct
            );
        }
        h.push_str("</table>\n");
    }
}

/// The desk sensors, the surfaces and the luminaire schedule.
fn html_tables(h: &mut String, x: &Results) {
    h.push_str("</table>\n<h2>Desk sensors</h2>\n<p>Where each desk sensor's value comes from, and its stated relative standard uncertainty: what the surfaces commissioning inferred (walls and ceiling nobody saw, floor out of view, desk tops, hidden faces) can do to its modelled light (first-order, at the all-on state). A model from a CAD scene states none.</p>\n\n");
    html_unseen_walls(h, x);
    h.push_str("<table><tr><th>sensor</th><th>camera</th><th>surroundings</th><th>stated uncertainty</th></tr>\n");
    for r in &x.sensors {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&r.name),
            match (r.in_view, r.calibrated) {
                (true, true) => "in view, model calibrated by its frames",
                (true, false) => "in view",
                (false, _) => "out of view",
            },
            if r.estimated {
                "partly inferred"
            } else {
                "seen"
            },
            r.stated_rel_uncertainty
                .map_or("not stated".into(), |u| format!("± {:.1} %", 100.0 * u))
        );
    }
    h.push_str("</table>\n<h2>Surfaces</h2>\n<table><tr><th>surface</th><th>area (m²)</th><th>ρ</th><th>patches</th></tr>\n");
    for s in &x.surfaces {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{:.2}</td><td>{:.3}</td><td>{}</td></tr>",
            esc(&s.surface),
            s.area_m2,
            s.rho,
            s.patches
        );
    }
    h.push_str("</table>\n<h2>Luminaire schedule</h2>\n<table><tr><th>id</th><th>name</th><th>photometry file</th><th>luminaire</th><th>flux (lm)</th><th>power (W)</th><th>efficacy (lm/W)</th><th>position (m)</th><th>opening (m)</th></tr>\n");
    for l in &x.luminaires {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.0}</td><td>{}</td><td>{}</td><td>{:.2}, {:.2}, {:.2}</td><td>{:.2} × {:.2}</td></tr>",
            l.id,
            esc(&l.name),
            esc(&l.photometry_file),
            esc(&l.luminaire),
            l.flux_lm,
            l.power_w.map_or("–".into(), |w| if l.power_assumed {
                format!("{w:.1} (assumed: {DEFAULT_EFFICACY_LM_PER_W} lm/W, the file gives none)")
            } else {
                format!("{w:.1}")
            }),
            l.efficacy_lm_per_w
                .map_or("–".into(), |e| format!("{e:.0}")),
            l.position_m[0],
            l.position_m[1],
            l.position_m[2],
            l.opening_m[0],
            l.opening_m[1]
        );
    }
    let _ = writeln!(
        h,
        "<tr><th>total</th><td></td><td></td><td></td><td>{:.0}</td><td>{}</td><td></td><td></td><td></td></tr></table>",
        x.totals.0,
        x.totals.1.map_or("–".into(), |w| format!("{w:.1}"))
    );
}

/// The walls commissioning placed without seeing them, if any: the engineer's to confirm (a room
/// plan gives them).
fn html_unseen_walls(h: &mut String, x: &Results) {
    if x.unseen_walls.is_empty() {
        return;
    }
    let sides: Vec<String> = x
        .unseen_walls
        .iter()
        .map(|w| {
            let axis = if w.side.starts_with('x') { 'x' } else { 'y' };
            format!("{} ({axis} = {:.2} m)", esc(&w.side), w.at_m)
        })
        .collect();
    let moved = x.unseen_walls.iter().map(|w| w.moved_m).fold(0.0, f64::max);
    let _ = writeln!(
        h,
        "<p class=\"unseen-walls\">Walls no camera saw and the luminaire grid did not place: {}. \
         Commissioning put them at the seen floor's edge or behind the sensors; what moving them \
         {moved:.2} m farther out does to each desk is in its stated uncertainty. Confirm them on \
         site, or give the room plan (<code>--room-plan</code>).</p>",
        sides.join(", ")
    );
}

/// The time taken, and the script that checks the pictures loaded.
fn html_tail(h: &mut String, x: &Results) {
    let _ = write!(
        h,
        "<p>Computed in {:.2} s. The numbers are also in results.json.</p>\n\
<script>\nfunction luxnodeCheckImages(){{var im=document.images,ok=im.length>0;\
for(var i=0;i<im.length;i++){{if(!(im[i].complete&&im[i].naturalWidth>0)){{ok=false;}}}}\
document.body.setAttribute('data-images',ok?'loaded':'missing');\
document.getElementById('imgstatus').textContent=ok?('all '+im.length+' pictures loaded'):'a picture did not load';}}\n\
window.addEventListener('load',luxnodeCheckImages);\n</script>\n</body></html>\n",
        x.seconds
    );
}

fn states_name(x: &Results) -> String {
    x.states
        .first()
        .map_or_else(|| "all on".into(), |s| s.name.clone())
}

/// Writes `report.html`, `results.json` and the pictures as PNG files (the report does not need
/// them: it holds its own copies) into `dir` (created if missing).
pub fn write(r: &Report, dir: &Path) -> Result<(), ReportError> {
    let io = |p: &Path| {
        let path = p.display().to_string();
        move |source| ReportError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let html_path = dir.join("report.html");
    std::fs::write(&html_path, html(r)).map_err(io(&html_path))?;
    for (stem, _, png) in &r.pictures {
        let p = dir.join(format!("{stem}.png"));
        std::fs::write(&p, png).map_err(io(&p))?;
    }
    let json_path = dir.join("results.json");
    let json = serde_json::to_string_pretty(&r.results)?;
    std::fs::write(&json_path, json).map_err(io(&json_path))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_and_dates() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
        assert_eq!(iso_utc(0), "1970-01-01 00:00 UTC");
        assert_eq!(iso_utc(951_782_400), "2000-02-29 00:00 UTC");
        assert_eq!(iso_utc(1_700_000_000), "2023-11-14 22:13 UTC");
    }
}
