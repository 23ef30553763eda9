//! EN 12464-1:2021's illuminances beyond the task area: the walls' and the ceiling's mean
//! illuminance and uniformity, and the cylindrical illuminance of the activity area.
//!
//! * **Walls and ceiling**: one point per patch of the surfaces named `wall…` (facing
//!   sideways) and `ceiling…` (facing down), at the patch's centroid, with the dense field's
//!   illuminance there (exact direct light, interreflection interpolated over the patch mesh);
//!   `Ē` is the area-weighted mean over the patches, `Emin` the least point, `U0 = Emin / Ē`.
//!   A patch whose centroid is covered (furniture standing within 5 cm of the surface, as a
//!   desk's covered task points) is left out: no light reaches it and no luxmeter goes there.
//!   The points follow the radiosity mesh, not the EN 12464-1 grid rule.
//! * **Cylindrical illuminance** `E_z` at the room grid's points (the floor's grid less the
//!   0.5 m wall band) at [`super::glare::EYE_HEIGHT_SEATED_M`] above the floor: the mean of the
//!   vertical illuminance over [`CYLINDER_DIRECTIONS`] horizontal directions (direct light
//!   exact, interreflection gathered with rays). The mean of `E_v(φ)` over all azimuths is
//!   exactly `E_z = (1/π) ∫ L sin θ dω`; eight directions approximate it.
//!
//! All values maintained (× MF), in the design state.

use glam::DVec3;
use serde::Serialize;

use super::glare::EYE_HEIGHT_SEATED_M;
use super::task_points::COVER_CLEARANCE_M;
use crate::en12464::{self, Rect, Statistics};
use crate::engine::dense::{DenseField, SurfacePoint};
use crate::engine::raycast::Hit;
use crate::image_geometry::Room;

/// Horizontal directions averaged for the cylindrical illuminance.
pub const CYLINDER_DIRECTIONS: usize = 8;

/// A room surface's (or the cylinder's) maintained statistics, or why there are none.
#[derive(Debug, Clone, Serialize)]
pub struct RoomValue {
    /// What (`walls`, `ceiling`, `cylindrical at 1.2 m`).
    pub what: String,
    /// Maintained statistics (area-weighted mean for surfaces).
    pub maintained: Option<Statistics>,
    /// Where the least value lies, m.
    pub e_min_at_m: Option<[f64; 3]>,
    /// Points left out as covered (furniture standing against the surface).
    pub covered: usize,
    /// Why not computed.
    pub not_computed: Option<String>,
}

fn group_patches(room: &Room, prefix: &str, facing: &dyn Fn(DVec3) -> bool) -> Vec<usize> {
    let p = &room.patches;
    (0..p.len())
        .filter(|&i| {
            room.section
                .groups
                .get(p.group[i] as usize)
                .is_some_and(|g| g.to_ascii_lowercase().starts_with(prefix))
                && facing(p.normal[i])
        })
        .collect()
}

/// The maintained statistics of the surfaces named `prefix…` facing as `facing` says.
pub fn surface(
    field: &DenseField<'_>,
    room: &Room,
    what: &str,
    prefix: &str,
    facing: &dyn Fn(DVec3) -> bool,
    levels: &[f64],
    mf: f64,
) -> RoomValue {
    let all = group_patches(room, prefix, facing);
    let ids: Vec<usize> = all
        .iter()
        .copied()
        .filter(|&i| !covered_along(field, room.patches.centroid_m(i), room.patches.normal[i]))
        .collect();
    let covered = all.len() - ids.len();
    let none = |why: String| RoomValue {
        what: what.into(),
        maintained: None,
        e_min_at_m: None,
        covered: 0,
        not_computed: Some(why),
    };
    if ids.is_empty() {
        return none(format!("the model has no surface named {prefix}…"));
    }
    let pts: Vec<SurfacePoint> = ids
        .iter()
        .map(|&i| SurfacePoint {
            position_m: room.patches.centroid_m(i),
            normal: room.patches.normal[i],
            patch: i as u32,
        })
        .collect();
    let lux = match field.points(&pts).lux(levels) {
        Ok(v) => v,
        Err(e) => return none(e.to_string()),
    };
    let lux: Vec<f64> = lux.iter().map(|v| v * mf).collect();
    let areas: Vec<f64> = ids.iter().map(|&i| room.patches.area_m2[i]).collect();
    match Statistics::weighted(&lux, &areas) {
        Some(s) => RoomValue {
            what: what.into(),
            maintained: Some(s),
            e_min_at_m: argmin(&lux).map(|k| pts[k].position_m.to_array()),
            covered,
            not_computed: None,
        },
        None => none("no finite illuminance on its patches".into()),
    }
}

/// The walls (`wall…`, facing sideways) and the ceiling (`ceiling…`, facing down).
pub fn walls_and_ceiling(
    field: &DenseField<'_>,
    room: &Room,
    levels: &[f64],
    mf: f64,
) -> [RoomValue; 2] {
    [
        surface(
            field,
            room,
            "walls",
            "wall",
            &|n| n.z.abs() < 0.3,
            levels,
            mf,
        ),
        surface(
            field,
            room,
            "ceiling",
            "ceiling",
            &|n| n.z < -0.7,
            levels,
            mf,
        ),
    ]
}

/// The cylindrical illuminance over the room grid at seated eye height.
pub fn cylindrical(
    field: &DenseField<'_>,
    room: &Room,
    room_rect: &Rect,
    floor_z_m: f64,
    levels: &[f64],
    mf: f64,
    rays: usize,
) -> RoomValue {
    let what = "cylindrical at 1.2 m (room grid)".to_string();
    let inner = room_rect.grown(-en12464::WALL_BAND_M);
    let grid = match en12464::grid(&inner) {
        Ok(g) => g,
        Err(e) => {
            return RoomValue {
                what,
                maintained: None,
                e_min_at_m: None,
                covered: 0,
                not_computed: Some(e.to_string()),
            };
        }
    };
    let z = floor_z_m + EYE_HEIGHT_SEATED_M;
    let mut probes = Vec::with_capacity(grid.points_m.len() * CYLINDER_DIRECTIONS);
    for p in &grid.points_m {
        for k in 0..CYLINDER_DIRECTIONS {
            let phi = std::f64::consts::TAU * k as f64 / CYLINDER_DIRECTIONS as f64;
            let n = DVec3::new(phi.cos(), phi.sin(), 0.0);
            probes.push((DVec3::new(p[0], p[1], z), n));
        }
    }
    let ez: Result<Vec<f64>, _> = field
        .air_points(&probes, &room.basis_b, rays)
        .lux(levels)
        .map(|v| {
            v.chunks(CYLINDER_DIRECTIONS)
                .map(|c| mf * c.iter().sum::<f64>() / CYLINDER_DIRECTIONS as f64)
                .collect()
        });
    let ez = ez.unwrap_or_default();
    let stats = Statistics::of(&ez);
    RoomValue {
        what,
        not_computed: stats.is_none().then(|| "no finite value".to_string()),
        maintained: stats,
        e_min_at_m: argmin(&ez).map(|k| [grid.points_m[k][0], grid.points_m[k][1], z]),
        covered: 0,
    }
}

/// True when a surface point is covered: looking out along its normal from 1 mm off it, it sees
/// the inside of a solid or any surface within [`COVER_CLEARANCE_M`] (a sideboard standing
/// against the wall), as a desk's task points are.
fn covered_along(field: &DenseField<'_>, p_m: DVec3, normal: DVec3) -> bool {
    let c = field.caster();
    let from = c.offset(p_m + normal * 0.001, normal);
    match c.closest(from, normal) {
        Hit::Back { .. } => true,
        Hit::Front { t_m, .. } => t_m + 0.001 < COVER_CLEARANCE_M,
        Hit::Miss => false,
    }
}

/// The index of the least value.
fn argmin(v: &[f64]) -> Option<usize> {
    (0..v.len()).min_by(|&a, &b| v[a].total_cmp(&v[b]))
}
