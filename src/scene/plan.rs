//! The room plan (`room.json`, format `luxnode-room-plan/1`, `docs/formats.md`):
//! what a commissioning engineer types from the building's floor plan for the parts of the room
//! the ceiling cameras may not see. The outline polygon, the floor and ceiling heights, glazed
//! windows with their transmittance, opaque doors, the site (latitude, longitude, north) and
//! optionally measured reflectances.
//!
//! A plan is checked like every input, before any work: unknown keys, a self-intersecting
//! outline, a window off every wall, lengths that look like millimetres, a reflectance typed as
//! a percentage. [`RoomPlan::check_contents`] then checks the scene's luminaires, sensors and
//! desks against it (each inside the outline, between floor and ceiling).

use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use serde::Deserialize;

use super::files::parse_json;
use super::{Desks, Luminaire, SceneError, SceneErrors, Sensor};

/// The format string of a room plan.
pub const ROOM_PLAN_FORMAT: &str = "luxnode-room-plan/1";

/// A window's or door's corner lies at most this far from its wall's line, m (a plan typed from
/// a drawing to the centimetre; a window on the wall's outer face would be off by the wall's
/// thickness, which is more).
pub const ON_WALL_TOLERANCE_M: f64 = 0.05;
/// The shortest wall of an outline, m (two corners closer are one typed twice).
pub const MIN_WALL_M: f64 = 0.05;
/// The smallest floor area of a room, m².
pub const MIN_FLOOR_AREA_M2: f64 = 1.0;
/// The lowest ceiling above the floor, m.
pub const MIN_ROOM_HEIGHT_M: f64 = 1.8;
/// The highest ceiling above the floor, m.
pub const MAX_ROOM_HEIGHT_M: f64 = 50.0;
/// The longest extent of a plan, m.
pub const MAX_PLAN_EXTENT_M: f64 = 500.0;
/// A luminaire, sensor or desk may stand this far outside the outline (a plan typed to the
/// centimetre), m.
pub const CONTENT_TOLERANCE_M: f64 = 0.02;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanJson {
    format: String,
    outline_m: Vec<[f64; 2]>,
    floor_z_m: f64,
    ceiling_z_m: f64,
    #[serde(default)]
    windows: Vec<WindowJson>,
    #[serde(default)]
    doors: Vec<DoorJson>,
    #[serde(default)]
    site: Option<SiteJson>,
    #[serde(default)]
    wall_rho: Option<f64>,
    #[serde(default)]
    ceiling_rho: Option<f64>,
    #[serde(default)]
    floor_rho: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WindowJson {
    id: String,
    corners_m: Vec<[f64; 3]>,
    transmittance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DoorJson {
    #[serde(default)]
    id: Option<String>,
    corners_m: Vec<[f64; 3]>,
    #[serde(default)]
    rho: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SiteJson {
    latitude_deg: f64,
    longitude_deg: f64,
    north: [f64; 2],
}

/// An opening in a wall of the plan: a glazed window or an opaque door.
#[derive(Debug, Clone, PartialEq)]
pub struct WallOpening {
    /// The plan's id (doors without one are `door_<k>`).
    pub id: String,
    /// The wall it is on: outline edge `wall` runs from corner `wall` to the next.
    pub wall: usize,
    /// Along the wall from its first corner: start and end, m.
    pub along_m: [f64; 2],
    /// Height range, m.
    pub z_m: [f64; 2],
    /// What it is.
    pub kind: OpeningKind,
}

/// What a wall opening is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OpeningKind {
    /// Glazing with its normal-incidence visible transmittance (0..1).
    Window {
        /// τ at normal incidence.
        transmittance: f64,
    },
    /// An opaque door; its reflectance, or the wall's when `None`.
    Door {
        /// ρ.
        rho: Option<f64>,
    },
}

/// Where the room is on the earth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Site {
    /// Latitude, degrees north.
    pub latitude_deg: f64,
    /// Longitude, degrees east.
    pub longitude_deg: f64,
    /// The unit vector in the room's x-y plane that points to geographic north.
    pub north: DVec2,
}

/// A checked room plan.
#[derive(Debug, Clone, PartialEq)]
pub struct RoomPlan {
    /// The floor polygon at the walls' inside faces, counter-clockwise seen from above, m.
    pub outline_m: Vec<DVec2>,
    /// The finished floor's height, m.
    pub floor_z_m: f64,
    /// The (flat) ceiling's height, m.
    pub ceiling_z_m: f64,
    /// Windows and doors, each on one wall.
    pub openings: Vec<WallOpening>,
    /// The site, when given.
    pub site: Option<Site>,
    /// Measured wall reflectance, when given.
    pub wall_rho: Option<f64>,
    /// Measured ceiling reflectance, when given.
    pub ceiling_rho: Option<f64>,
    /// Measured floor reflectance, when given.
    pub floor_rho: Option<f64>,
}

/// Collects one file's errors.
struct Errors {
    path: PathBuf,
    list: Vec<SceneError>,
}

impl Errors {
    fn fail(&mut self, what: impl Into<String>, message: impl Into<String>) {
        self.list.push(SceneError::Invalid {
            path: self.path.clone(),
            what: what.into(),
            message: message.into(),
        });
    }
}

/// Twice the signed area of a polygon (positive counter-clockwise), m².
fn signed_area2(p: &[DVec2]) -> f64 {
    (0..p.len())
        .map(|i| p[i].perp_dot(p[(i + 1) % p.len()]))
        .sum()
}

/// Whether segments ab and cd cross or touch.
fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let orient = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    let on = |p: DVec2, q: DVec2, r: DVec2| {
        r.x >= p.x.min(q.x) - 1e-12
            && r.x <= p.x.max(q.x) + 1e-12
            && r.y >= p.y.min(q.y) - 1e-12
            && r.y <= p.y.max(q.y) + 1e-12
    };
    let (d1, d2) = (orient(c, d, a), orient(c, d, b));
    let (d3, d4) = (orient(a, b, c), orient(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on(c, d, a))
        || (d2 == 0.0 && on(c, d, b))
        || (d3 == 0.0 && on(a, b, c))
        || (d4 == 0.0 && on(a, b, d))
}

/// The first pair of non-adjacent edges that meet, if any.
fn self_intersection(p: &[DVec2]) -> Option<(usize, usize)> {
    let n = p.len();
    for i in 0..n {
        for j in i + 1..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            if !adjacent && segments_meet(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n]) {
                return Some((i, j));
            }
        }
    }
    None
}

/// A reflectance from the plan: 0..1, with a hint when it looks like a percentage.
fn check_rho(e: &mut Errors, what: &str, rho: Option<f64>) {
    let Some(r) = rho else { return };
    if !(0.0..1.0).contains(&r) {
        let hint = if (1.0..=100.0).contains(&r) {
            format!(" ({r} looks like a percentage: {:.2})", r / 100.0)
        } else {
            String::new()
        };
        e.fail(what, format!("reflectance {r} is not in 0..1{hint}"));
    }
}

impl RoomPlan {
    /// Reads and checks a room plan. Returns it with its warnings (an outline given clockwise
    /// is reversed, a north vector of nearly unit length normalised).
    pub fn load(path: &Path) -> Result<(RoomPlan, Vec<String>), SceneErrors> {
        let raw: PlanJson = parse_json(path).map_err(|e| SceneErrors {
            dir: path.to_path_buf(),
            errors: vec![e],
        })?;
        let mut e = Errors {
            path: path.to_path_buf(),
            list: Vec::new(),
        };
        let mut warnings = Vec::new();
        let plan = Self::from_json(raw, &mut e, &mut warnings);
        match plan {
            Some(p) if e.list.is_empty() => Ok((p, warnings)),
            _ => Err(SceneErrors {
                dir: path.to_path_buf(),
                errors: e.list,
            }),
        }
    }

    fn from_json(raw: PlanJson, e: &mut Errors, warnings: &mut Vec<String>) -> Option<RoomPlan> {
        if raw.format != ROOM_PLAN_FORMAT {
            e.fail(
                "format",
                format!("is {:?}, expected {ROOM_PLAN_FORMAT:?}", raw.format),
            );
        }
        let outline = check_outline(e, &raw.outline_m, warnings)?;
        check_heights(e, raw.floor_z_m, raw.ceiling_z_m)?;
        check_rho(e, "wall_rho", raw.wall_rho);
        check_rho(e, "ceiling_rho", raw.ceiling_rho);
        check_rho(e, "floor_rho", raw.floor_rho);
        let mut plan = RoomPlan {
            outline_m: outline,
            floor_z_m: raw.floor_z_m,
            ceiling_z_m: raw.ceiling_z_m,
            openings: Vec::new(),
            site: raw.site.and_then(|s| check_site(e, s, warnings)),
            wall_rho: raw.wall_rho,
            ceiling_rho: raw.ceiling_rho,
            floor_rho: raw.floor_rho,
        };
        for (k, w) in raw.windows.iter().enumerate() {
            let what = format!("windows[{k}] ({})", w.id);
            if !(0.0..=1.0).contains(&w.transmittance) {
                e.fail(
                    &what,
                    format!("transmittance {} is not in 0..1", w.transmittance),
                );
            }
            let kind = OpeningKind::Window {
                transmittance: w.transmittance,
            };
            if let Some(o) = plan.place_opening(e, &what, w.id.clone(), &w.corners_m, kind) {
                plan.openings.push(o);
            }
        }
        for (k, d) in raw.doors.iter().enumerate() {
            let id = d.id.clone().unwrap_or_else(|| format!("door_{k}"));
            let what = format!("doors[{k}] ({id})");
            check_rho(e, &what, d.rho);
            let kind = OpeningKind::Door { rho: d.rho };
            if let Some(o) = plan.place_opening(e, &what, id, &d.corners_m, kind) {
                plan.openings.push(o);
            }
        }
        plan.check_openings_apart(e);
        Some(plan)
    }

    /// Number of walls (outline edges).
    pub fn walls(&self) -> usize {
        self.outline_m.len()
    }

    /// Wall `i`: its first and second corner.
    pub fn wall(&self, i: usize) -> (DVec2, DVec2) {
        let n = self.outline_m.len();
        (self.outline_m[i % n], self.outline_m[(i + 1) % n])
    }

    /// The unit normal of wall `i` into the room.
    pub fn wall_inward(&self, i: usize) -> DVec2 {
        let (a, b) = self.wall(i);
        (b - a).perp().normalize_or_zero()
    }

    /// The bounding box x0, y0, x1, y1, m.
    pub fn bounds_xy_m(&self) -> [f64; 4] {
        self.outline_m.iter().fold(
            [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ],
            |b, p| [b[0].min(p.x), b[1].min(p.y), b[2].max(p.x), b[3].max(p.y)],
        )
    }

    /// Whether a point (x, y) is inside the outline (even-odd rule).
    pub fn contains(&self, p: DVec2) -> bool {
        polygon_contains(&self.outline_m, p)
    }

    /// The distance from (x, y) to the outline, m, and the nearest wall.
    pub fn distance_to_walls_m(&self, p: DVec2) -> (f64, usize) {
        (0..self.walls())
            .map(|i| {
                let (a, b) = self.wall(i);
                (segment_distance(a, b, p), i)
            })
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .unwrap_or((f64::INFINITY, 0))
    }

    /// Signed distance from the outline: positive outside, negative inside, m.
    pub fn signed_distance_m(&self, p: DVec2) -> (f64, usize) {
        let (d, w) = self.distance_to_walls_m(p);
        (if self.contains(p) { -d } else { d }, w)
    }

    /// The opening placed on its wall, or an error naming the item.
    fn place_opening(
        &self,
        e: &mut Errors,
        what: &str,
        id: String,
        corners: &[[f64; 3]],
        kind: OpeningKind,
    ) -> Option<WallOpening> {
        if corners.len() != 4 || corners.iter().flatten().any(|v| !v.is_finite()) {
            e.fail(what, "corners_m must be 4 finite points [x, y, z]");
            return None;
        }
        let pts: Vec<DVec3> = corners.iter().map(|c| DVec3::from_array(*c)).collect();
        let on = (0..self.walls()).find(|&i| {
            pts.iter().all(|p| {
                segment_distance(self.wall(i).0, self.wall(i).1, p.truncate())
                    <= ON_WALL_TOLERANCE_M
            })
        });
        let Some(wall) = on else {
            let (d, w) = pts
                .iter()
                .map(|p| self.distance_to_walls_m(p.truncate()))
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap_or((f64::INFINITY, 0));
            e.fail(
                what,
                format!(
                    "is on no wall of the outline: a corner is {d:.2} m from the nearest (wall \
                     {w}); every corner must lie within {ON_WALL_TOLERANCE_M} m of one wall's \
                     inside face"
                ),
            );
            return None;
        };
        let (a, b) = self.wall(wall);
        let dir = (b - a).normalize_or_zero();
        let along: Vec<f64> = pts.iter().map(|p| (p.truncate() - a).dot(dir)).collect();
        let z: Vec<f64> = pts.iter().map(|p| p.z).collect();
        let span = |v: &[f64]| {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            [lo, hi]
        };
        let (along_m, z_m) = (span(&along), span(&z));
        let tol = ON_WALL_TOLERANCE_M;
        if z_m[0] < self.floor_z_m - tol || z_m[1] > self.ceiling_z_m + tol {
            e.fail(
                what,
                format!(
                    "spans z {:.2}..{:.2} m, beyond the floor and ceiling ({:.2}..{:.2} m)",
                    z_m[0], z_m[1], self.floor_z_m, self.ceiling_z_m
                ),
            );
            return None;
        }
        if (along_m[1] - along_m[0]) * (z_m[1] - z_m[0]) < 0.01 {
            e.fail(what, "has no area (under 0.01 m²)");
            return None;
        }
        let len = (b - a).length();
        Some(WallOpening {
            id,
            wall,
            along_m: [along_m[0].max(0.0), along_m[1].min(len)],
            z_m: [z_m[0].max(self.floor_z_m), z_m[1].min(self.ceiling_z_m)],
            kind,
        })
    }

    /// Two openings on one wall must not overlap.
    fn check_openings_apart(&self, e: &mut Errors) {
        for (i, p) in self.openings.iter().enumerate() {
            for q in &self.openings[i + 1..] {
                let overlap = |a: [f64; 2], b: [f64; 2]| a[0] < b[1] - 1e-3 && b[0] < a[1] - 1e-3;
                if p.wall == q.wall && overlap(p.along_m, q.along_m) && overlap(p.z_m, q.z_m) {
                    e.fail(
                        format!("{} and {}", p.id, q.id),
                        format!("overlap on wall {}", p.wall),
                    );
                }
            }
        }
    }

    /// The scene's contents against the plan: every luminaire, sensor and desk inside the
    /// outline (within [`CONTENT_TOLERANCE_M`]) and between floor and ceiling. Each error names
    /// the item and how far out it is.
    pub fn check_contents(
        &self,
        path: &Path,
        luminaires: &[Luminaire],
        sensors: &[Sensor],
        desks: Option<&Desks>,
    ) -> Result<(), SceneErrors> {
        let mut e = Errors {
            path: path.to_path_buf(),
            list: Vec::new(),
        };
        let mut check = |what: String, p: DVec3| {
            let (d, w) = self.signed_distance_m(p.truncate());
            if d > CONTENT_TOLERANCE_M {
                e.fail(
                    what.clone(),
                    format!(
                        "at ({:.2}, {:.2}) m is {d:.2} m outside the plan's outline (beyond wall \
                         {w}): the plan, or the position, is wrong",
                        p.x, p.y
                    ),
                );
            }
            let tol = CONTENT_TOLERANCE_M;
            if p.z < self.floor_z_m - tol || p.z > self.ceiling_z_m + tol {
                e.fail(
                    what,
                    format!(
                        "at z {:.2} m is not between the plan's floor and ceiling ({:.2}..{:.2} m)",
                        p.z, self.floor_z_m, self.ceiling_z_m
                    ),
                );
            }
        };
        for l in luminaires {
            check(format!("luminaire {}", l.id), l.position_m);
        }
        for s in sensors {
            check(format!("sensor {}", s.id), s.position_m);
        }
        for d in desks.iter().flat_map(|d| &d.desks) {
            let c = DVec3::new(
                0.5 * (d.x_m[0] + d.x_m[1]),
                0.5 * (d.y_m[0] + d.y_m[1]),
                d.z_m,
            );
            check(format!("desk {}", d.id), c);
        }
        if e.list.is_empty() {
            Ok(())
        } else {
            Err(SceneErrors {
                dir: path.to_path_buf(),
                errors: e.list,
            })
        }
    }
}

/// The outline: at least 3 finite corners, walls at least [`MIN_WALL_M`], not self-intersecting,
/// a room's area and extent; counter-clockwise (a clockwise one is reversed, with a warning).
fn check_outline(
    e: &mut Errors,
    raw: &[[f64; 2]],
    warnings: &mut Vec<String>,
) -> Option<Vec<DVec2>> {
    if raw.len() < 3 || raw.iter().flatten().any(|v| !v.is_finite()) {
        e.fail("outline_m", "needs at least 3 finite corners [x, y]");
        return None;
    }
    let mut p: Vec<DVec2> = raw.iter().map(|c| DVec2::from_array(*c)).collect();
    let n = p.len();
    if let Some(i) = (0..n).find(|&i| (p[(i + 1) % n] - p[i]).length() < MIN_WALL_M) {
        e.fail(
            format!("outline_m[{i}]"),
            format!(
                "corners {i} and {} are less than {MIN_WALL_M} m apart (a corner typed twice?)",
                (i + 1) % n
            ),
        );
        return None;
    }
    let lo = p.iter().fold(DVec2::INFINITY, |a, b| a.min(*b));
    let hi = p.iter().fold(DVec2::NEG_INFINITY, |a, b| a.max(*b));
    let extent = (hi - lo).max_element();
    if extent > MAX_PLAN_EXTENT_M {
        e.fail(
            "outline_m",
            format!(
                "spans {extent:.0} m, not a room (at most {MAX_PLAN_EXTENT_M} m): the lengths \
                 look like millimetres; the plan is in metres"
            ),
        );
        return None;
    }
    if let Some((i, j)) = self_intersection(&p) {
        e.fail(
            "outline_m",
            format!("walls {i} and {j} cross: the outline intersects itself"),
        );
        return None;
    }
    let area2 = signed_area2(&p);
    if area2.abs() * 0.5 < MIN_FLOOR_AREA_M2 {
        e.fail(
            "outline_m",
            format!(
                "encloses {:.3} m², less than a room ({MIN_FLOOR_AREA_M2} m²): lengths in another \
                 unit?",
                area2.abs() * 0.5
            ),
        );
        return None;
    }
    if area2 < 0.0 {
        p.reverse();
        warnings.push("room plan: the outline is clockwise; read counter-clockwise".into());
    }
    Some(p)
}

fn check_heights(e: &mut Errors, floor_z_m: f64, ceiling_z_m: f64) -> Option<()> {
    let h = ceiling_z_m - floor_z_m;
    if !(floor_z_m.is_finite() && ceiling_z_m.is_finite()) {
        e.fail("floor_z_m, ceiling_z_m", "must be finite");
        return None;
    }
    if !(MIN_ROOM_HEIGHT_M..=MAX_ROOM_HEIGHT_M).contains(&h) {
        let hint = if h > 100.0 {
            ": the lengths look like millimetres or centimetres"
        } else {
            ""
        };
        e.fail(
            "ceiling_z_m",
            format!(
                "the ceiling is {h:.2} m above the floor, not {MIN_ROOM_HEIGHT_M}..\
                 {MAX_ROOM_HEIGHT_M} m{hint}"
            ),
        );
        return None;
    }
    Some(())
}

fn check_site(e: &mut Errors, s: SiteJson, warnings: &mut Vec<String>) -> Option<Site> {
    let mut ok = true;
    if !(-90.0..=90.0).contains(&s.latitude_deg) {
        e.fail(
            "site.latitude_deg",
            format!("{} is not in -90..90", s.latitude_deg),
        );
        ok = false;
    }
    if !(-180.0..=180.0).contains(&s.longitude_deg) {
        e.fail(
            "site.longitude_deg",
            format!("{} is not in -180..180", s.longitude_deg),
        );
        ok = false;
    }
    let north = DVec2::from_array(s.north);
    let len = north.length();
    if !(len.is_finite() && (0.5..=2.0).contains(&len)) {
        e.fail(
            "site.north",
            format!("{:?} is not a unit vector in the x-y plane", s.north),
        );
        ok = false;
    } else if (len - 1.0).abs() > 1e-3 {
        warnings.push(format!(
            "room plan: site.north has length {len:.3}; normalised"
        ));
    }
    ok.then(|| Site {
        latitude_deg: s.latitude_deg,
        longitude_deg: s.longitude_deg,
        north: north / len,
    })
}

/// Whether `p` is inside the polygon (even-odd rule).
pub fn polygon_contains(poly: &[DVec2], p: DVec2) -> bool {
    let n = poly.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
            if p.x < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Distance from `p` to segment ab, m.
pub fn segment_distance(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

#[cfg(test)]
mod tests;
