//! The uncertainty of what commissioning inferred, per desk sensor (issue 18).
//!
//! A model from the cameras rests on inferences: the walls and ceiling nobody sees take default
//! reflectances, the floor out of view takes the seen floor's, a desk top nobody saw takes the
//! seen tops', a thin object's hidden face takes its seen face's. Each inference has a standard
//! uncertainty `σ_c` of its reflectance ([`UncertaintyOptions`]); a desk's stated uncertainty is
//! what those do to its reading, by first-order propagation with the model itself:
//!
//! `u_s = √(Σ_c Δ_sc²) / E_s`,  `Δ_sc = E_s(ρ + σ_c 1_c) − E_s(ρ)`
//!
//! at the all-on state, each `Δ_sc` from one radiosity solve against the model's own, solved
//! once ([`crate::engine::Model::reflectance_sensitivities_lx`]). The classes are independent
//! (different surfaces, different sources of error), so their squares add. Seen surfaces enter
//! too, with the measurement's uncertainty (gain and pixels). What this does not cover, and the
//! docs say: objects nobody saw that shadow a desk (the direct light of an out-of-view desk is
//! exact only when nothing unseen stands between it and a luminaire), and luminaire photometry.
//!
//! The defaults are the spread of the reflectances offices have about the default values, which
//! sit at the low end of them: a reflectance uniform over `[a, b]` deviates from `a` by
//! `(b − a)/√3` RMS. Ceiling 0.7..0.9 (EN 12464-1's useful range) → 0.115; walls 0.5..0.7 (the
//! lower part of EN 12464-1's 0.5..0.8, where office walls mostly are) → 0.115.

use super::mesh::{Part, RecoMesh};
use crate::engine::{EngineError, Model};
use glam::{DVec2, DVec3};

/// Largest reflectance a perturbed patch is given (the engine needs ρ < 1).
pub const MAX_PERTURBED_RHO: f64 = 0.95;

/// What was inferred: one class of surfaces whose reflectance shares one source of error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inferred {
    /// Walls nobody saw (default reflectance).
    Walls,
    /// The ceiling (default reflectance).
    Ceiling,
    /// Floor out of view (the seen floor's reflectance).
    UnseenFloor,
    /// Desk tops nobody saw (the seen tops' reflectance).
    DeskTops,
    /// Hidden faces of thin objects (their seen faces' reflectance).
    HiddenFaces,
    /// Surfaces the camera saw (measured reflectance: gain and pixel noise).
    Seen,
}

impl Inferred {
    /// Every class, in report order.
    pub const ALL: [Inferred; 6] = [
        Inferred::Walls,
        Inferred::Ceiling,
        Inferred::UnseenFloor,
        Inferred::DeskTops,
        Inferred::HiddenFaces,
        Inferred::Seen,
    ];

    /// The class of a mesh part; `None` for black openings (their reflectance is known: 0).
    pub fn of(part: Part) -> Option<Inferred> {
        match part {
            Part::Plane(_) | Part::Surface => Some(Inferred::Seen),
            Part::FloorFill => Some(Inferred::UnseenFloor),
            Part::Wall | Part::Door(_) => Some(Inferred::Walls),
            Part::Window(_) => None,
            Part::Ceiling => Some(Inferred::Ceiling),
            Part::Opening(_) => None,
            Part::DeskFill => Some(Inferred::DeskTops),
            Part::HiddenFace(_) => Some(Inferred::HiddenFaces),
        }
    }

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Inferred::Walls => "walls",
            Inferred::Ceiling => "ceiling",
            Inferred::UnseenFloor => "unseen floor",
            Inferred::DeskTops => "inferred desk tops",
            Inferred::HiddenFaces => "hidden faces",
            Inferred::Seen => "seen surfaces",
        }
    }
}

/// Standard uncertainties of the inferred reflectances (absolute).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UncertaintyOptions {
    /// Walls at their default (offices: 0.5..0.7 → 0.115).
    pub wall_rho: f64,
    /// Ceiling at its default (0.7..0.9 → 0.115).
    pub ceiling_rho: f64,
    /// Unseen floor at the seen floor's value (one floor finish over a room, mostly).
    pub floor_rho: f64,
    /// Unseen desk tops at the seen tops' value (desks in one room vary 0.3..0.6).
    pub desk_rho: f64,
    /// Hidden faces at their seen face's value (undersides, backs).
    pub hidden_rho: f64,
    /// Seen surfaces: the reflectance estimate (median |Δρ| 0.009 on office_a, docs/commissioning.md)
    /// and a calibrated gain's few per cent.
    pub seen_rho: f64,
}

impl Default for UncertaintyOptions {
    fn default() -> Self {
        Self {
            wall_rho: 0.115,
            ceiling_rho: 0.115,
            floor_rho: 0.05,
            desk_rho: 0.1,
            hidden_rho: 0.1,
            seen_rho: 0.02,
        }
    }
}

/// The standard uncertainty of a reflectance the room plan gives (measured with a reflectance
/// card or a luminance meter and a reference: a few hundredths).
pub const PLAN_RHO_SIGMA: f64 = 0.03;

impl UncertaintyOptions {
    /// These uncertainties with a room plan's measured reflectances: a wall or ceiling
    /// reflectance the plan gives is known to [`PLAN_RHO_SIGMA`].
    pub fn with_plan(&self, plan: Option<&crate::scene::RoomPlan>) -> UncertaintyOptions {
        let mut o = *self;
        if let Some(p) = plan {
            if p.wall_rho.is_some() {
                o.wall_rho = o.wall_rho.min(PLAN_RHO_SIGMA);
            }
            if p.ceiling_rho.is_some() {
                o.ceiling_rho = o.ceiling_rho.min(PLAN_RHO_SIGMA);
            }
        }
        o
    }

    /// The σ of one class.
    pub fn sigma(&self, c: Inferred) -> f64 {
        match c {
            Inferred::Walls => self.wall_rho,
            Inferred::Ceiling => self.ceiling_rho,
            Inferred::UnseenFloor => self.floor_rho,
            Inferred::DeskTops => self.desk_rho,
            Inferred::HiddenFaces => self.hidden_rho,
            Inferred::Seen => self.seen_rho,
        }
    }

    /// Each σ finite and in [0, 0.5].
    pub fn check(&self) -> Result<(), String> {
        for c in Inferred::ALL {
            let s = self.sigma(c);
            if !(s.is_finite() && (0.0..=0.5).contains(&s)) {
                return Err(format!(
                    "the reflectance uncertainty of the {} is {s}: it must be in [0, 0.5]",
                    c.name()
                ));
            }
        }
        Ok(())
    }
}

/// One desk sensor's stated uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorUncertainty {
    /// Sensor id.
    pub sensor_id: u32,
    /// The model's reading with every luminaire at full, lx.
    pub all_on_lx: f64,
    /// Per class, the reading's change for one σ of its reflectance, lx (in
    /// [`Inferred::ALL`]'s order).
    pub by_class_lx: [f64; 6],
    /// What one standard uncertainty of the unseen walls' position changes, lx (every luminaire
    /// at 100 %; `super::placement`; 0 with a plan or every wall seen). Not in
    /// [`Self::by_class_lx`], which holds the reflectances' alone; in [`Self::rel`] and, per
    /// luminaire in quadrature with the walls' reflectance, in [`Self::by_luminaire`].
    pub wall_placement_lx: f64,
    /// Out of every camera's view: what an object nobody saw could shade, lx
    /// ([`UNSEEN_OCCLUDER_SHARE`] of the largest luminaire's direct light at the desk, or of a
    /// back edge's group of luminaires together); 0 in view.
    pub unseen_occluder_lx: f64,
    /// The relative standard uncertainty, `√(Σ Δ² + occluder²) / E`.
    pub rel: f64,
    /// Per luminaire at 100 %: its part of [`Self::by_class_lx`] (they sum to it: the light is
    /// linear in the emission), then what an unseen object could shade of its direct light
    /// (the largest over the lit luminaires is [`Self::unseen_occluder_lx`]'s counterpart in a
    /// dimming state). What `crate::runtime::state_rel_uncertainty` states per dimming state.
    pub by_luminaire: Vec<[f64; 7]>,
    /// Per luminaire, its occluder group ([`Occluders::group`]): the luminaires of one group
    /// are shaded together by one object at a back edge of the desk.
    pub occluder_group: Vec<u8>,
}

/// At a desk no camera sees, an unseen object (a monitor, a cabinet, a partition) may stand
/// between it and a luminaire low in its sky: it blocks about one such luminaire's direct light
/// there, or none. One standard uncertainty is half the largest direct light of a luminaire that
/// such an object could hide ([`occluder_elevation_limit_rad`]; issue 28: on the generalization
/// bench an out-of-view desk behind an unseen monitor read 33 % high, stated at 3.6 %).
pub const UNSEEN_OCCLUDER_SHARE: f64 = 0.5;
/// A luminaire seen from a desk below this elevation can be hidden by desk furniture anywhere
/// on the desk (a 0.45 m monitor 0.45 m from the sensor hides 45°); the luminaires above it
/// only by furniture at the desk's back edge ([`occluder_elevation_limit_rad`]).
pub const UNSEEN_OCCLUDER_ELEVATION_RAD: f64 = core::f64::consts::FRAC_PI_4;
/// The height above the desk top of what stands at a desk's back edge (a monitor on its foot,
/// a desk screen; the common 24-27" monitors: 0.40-0.50 m), m.
pub const EDGE_OCCLUDER_HEIGHT_M: f64 = 0.45;

/// How far in from the back edge that monitor's screen may stand (on its foot, 0.1-0.2 m deep),
/// m: the elevation it hides and where along the edge it shades are taken there, at least
/// [`EDGE_OCCLUDER_MIN_DISTANCE_M`] from the sensor (seed 29's room_07: monitors 0.13 m in from
/// the edge, 0.12 m behind the sensor).
pub const EDGE_OCCLUDER_INSET_M: f64 = 0.15;
/// The least horizontal distance from a sensor to the monitor behind it, m.
pub const EDGE_OCCLUDER_MIN_DISTANCE_M: f64 = 0.05;

/// The horizontal distance from the sensor to a monitor at a back edge `t` away (m), standing
/// [`EDGE_OCCLUDER_INSET_M`] in from it.
fn monitor_distance_m(t: f64) -> f64 {
    (t - EDGE_OCCLUDER_INSET_M).max(EDGE_OCCLUDER_MIN_DISTANCE_M)
}

/// The width of that monitor, m (a 24-27" screen): the luminaires it shades together leave the
/// desk through its back edge within this of each other ([`edge_groups`]).
pub const EDGE_OCCLUDER_WIDTH_M: f64 = 0.6;
/// A desk edge within this distance of another desk's edge, or of the room's boundary, is a
/// back edge (an island's shared edge, a desk's wall side), m.
pub const BACK_EDGE_GAP_M: f64 = 0.3;

/// The back edges of a desk, where monitors and desk screens stand: those that face another
/// desk across at most [`BACK_EDGE_GAP_M`] (an island's shared edge) or the room's boundary
/// `room_xy_m` (`[x0, y0, x1, y1]`; the wall side); when neither long side is one of those (a
/// desk in a row, or alone), both long sides: its monitor stands along one of them (issue 28,
/// seed 29's room_07: row desks with their monitors 0.12-0.26 m behind the sensors, out of
/// view, modelled 22-43 % high at all on and stated at 8.5 %). In the order x low, x high, y
/// low, y high.
pub fn back_edges(
    desk: &crate::scene::Desk,
    desks: &[crate::scene::Desk],
    room_xy_m: Option<[f64; 4]>,
) -> [bool; 4] {
    let g = BACK_EDGE_GAP_M;
    let overlap = |a: [f64; 2], b: [f64; 2]| a[1].min(b[1]) - a[0].max(b[0]) > 0.05;
    let faces = |side: usize, o: &crate::scene::Desk| -> bool {
        let (dx, dy) = (desk.x_m, desk.y_m);
        match side {
            0 => (0.0..=g).contains(&(dx[0] - o.x_m[1])) && overlap(dy, o.y_m),
            1 => (0.0..=g).contains(&(o.x_m[0] - dx[1])) && overlap(dy, o.y_m),
            2 => (0.0..=g).contains(&(dy[0] - o.y_m[1])) && overlap(dx, o.x_m),
            _ => (0.0..=g).contains(&(o.y_m[0] - dy[1])) && overlap(dx, o.x_m),
        }
    };
    let wall = |side: usize| -> bool {
        room_xy_m.is_some_and(|[x0, y0, x1, y1]| match side {
            0 => desk.x_m[0] - x0 <= g,
            1 => x1 - desk.x_m[1] <= g,
            2 => desk.y_m[0] - y0 <= g,
            _ => y1 - desk.y_m[1] <= g,
        })
    };
    let mut back: [bool; 4] = core::array::from_fn(|side| {
        wall(side) || desks.iter().any(|o| o.id != desk.id && faces(side, o))
    });
    // a desk whose long sides face neither a desk nor a wall (a row's desk, one alone): its
    // monitor stands along one of them, which the node cannot tell, so both are back edges
    let long = if desk.x_m[1] - desk.x_m[0] >= desk.y_m[1] - desk.y_m[0] {
        [2, 3]
    } else {
        [0, 1]
    };
    if !long.iter().any(|&side| back[side]) {
        long.iter().for_each(|&side| back[side] = true);
    }
    back
}

/// The highest elevation at which an unseen object may hide a luminaire from a sensor, rad:
/// [`UNSEEN_OCCLUDER_ELEVATION_RAD`], or higher toward a near back edge of the desk the sensor
/// stands on ([`back_edges`]), where a monitor [`EDGE_OCCLUDER_HEIGHT_M`] tall hides
/// `atan(h / d)`, `d` the horizontal distance along the luminaire's direction to the monitor
/// standing [`EDGE_OCCLUDER_INSET_M`] in from the edge
/// (issue 28: room_08's island desk 3, its sensor 0.27 m from the shared edge its monitor stands
/// at, read 28 % high with the luminaire at 47° behind it counted as unhideable).
/// `desk`: the sensor's desk and its back edges (x low, x high, y low, y high).
pub fn occluder_elevation_limit_rad(
    sensor_m: DVec3,
    toward_xy: DVec2,
    desk: Option<(&crate::scene::Desk, [bool; 4])>,
) -> f64 {
    let base = UNSEEN_OCCLUDER_ELEVATION_RAD;
    back_edge_toward(sensor_m, toward_xy, desk).map_or(base, |(_, t)| {
        base.max(EDGE_OCCLUDER_HEIGHT_M.atan2(monitor_distance_m(t)))
    })
}

/// The back edge of the sensor's desk that a direction leaves it through (x low, x high, y low,
/// y high: 0 to 3) and the horizontal distance to it, m; `None` through a front or free edge, or
/// off any desk.
fn back_edge_toward(
    sensor_m: DVec3,
    toward_xy: DVec2,
    desk: Option<(&crate::scene::Desk, [bool; 4])>,
) -> Option<(usize, f64)> {
    let (d, back) = desk?;
    let dir = toward_xy.normalize_or_zero();
    // the ray's exit from the desk's rectangle through each pair of sides, m
    let exit = |p: f64, v: f64, lo: f64, hi: f64| -> (f64, usize) {
        if v > 1e-12 {
            ((hi - p) / v, 1)
        } else if v < -1e-12 {
            ((lo - p) / v, 0)
        } else {
            (f64::INFINITY, 0)
        }
    };
    let (tx, sx) = exit(sensor_m.x, dir.x, d.x_m[0], d.x_m[1]);
    let (ty, sy) = exit(sensor_m.y, dir.y, d.y_m[0], d.y_m[1]);
    let (t, side) = if tx <= ty { (tx, sx) } else { (ty, 2 + sy) };
    (t.is_finite() && t >= 0.0 && back[side]).then_some((side, t))
}

/// Per sensor and luminaire, what an unseen object could shade of its direct light at 100 %.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Occluders {
    /// `[sensor][luminaire]`, lx ([`UNSEEN_OCCLUDER_SHARE`] of the luminaire's direct light
    /// below the sensor's [`occluder_elevation_limit_rad`] toward it, 0 above; toward a back
    /// edge, with its share of the indirect light a monitor there hides,
    /// [`monitor_view_factors`]).
    pub lx: Vec<Vec<f64>>,
    /// `[sensor][luminaire]`: 0, an object shades that luminaire alone; otherwise the group of
    /// luminaires toward a back edge of the sensor's desk that one monitor along it could shade
    /// together ([`edge_groups`]; issue 28: room_08's island desk 3, whose neighbour's monitor
    /// hides two luminaires at once).
    pub group: Vec<Vec<u8>>,
}

/// What an unseen object could shade at each sensor ([`Occluders`]); all 0 where `out_of_view`
/// is false (a sensor some camera sees, or not on a desk, where monitors stand). `desks`: the
/// declared desks (a sensor on one of them takes its back edges, with the room's extent
/// `room_xy_m`).
pub fn unseen_occluder_lx(
    model: &Model,
    sensors: &[crate::scene::Sensor],
    luminaires: &[crate::scene::Luminaire],
    desks: &[crate::scene::Desk],
    room_xy_m: Option<[f64; 4]>,
    out_of_view: &[bool],
) -> Occluders {
    let rows: Vec<Vec<(f64, u8)>> = sensors
        .iter()
        .enumerate()
        .map(|(s, sensor)| {
            let seen = !out_of_view.get(s).copied().unwrap_or(false);
            let row = model.direct_sensor_lx.get(s);
            let desk = desks
                .iter()
                .find(|d| super::closure::on_a_desk(core::slice::from_ref(*d), sensor.position_m))
                .map(|d| (d, back_edges(d, desks, room_xy_m)));
            // per luminaire: what an object could shade, and where along a back edge it would
            // stand (side, m along the edge)
            let shaded: Vec<(f64, Option<(usize, f64)>)> = luminaires
                .iter()
                .enumerate()
                .map(|(j, l)| {
                    let d = l.position_m - sensor.position_m;
                    let limit = occluder_elevation_limit_rad(sensor.position_m, d.truncate(), desk);
                    let low = d.z.atan2(d.truncate().length()) < limit;
                    if seen || !low {
                        return (0.0, None);
                    }
                    let dir = d.truncate().normalize_or_zero();
                    let at =
                        back_edge_toward(sensor.position_m, d.truncate(), desk).map(|(side, t)| {
                            let p = sensor.position_m.truncate() + dir * monitor_distance_m(t);
                            (side, if side < 2 { p.y } else { p.x })
                        });
                    let lx = row.and_then(|r| r.get(j)).copied().unwrap_or(0.0);
                    (lx * UNSEEN_OCCLUDER_SHARE, at)
                })
                .collect();
            let group = edge_groups(&shaded);
            let (shaded, group) = match (seen, desk) {
                (false, Some((d, back))) => {
                    let indirect_lx: Vec<f64> = model
                        .response_lx
                        .get(s)
                        .zip(row)
                        .map(|(r, dir)| r.iter().zip(dir).map(|(r, d)| r - d).collect())
                        .unwrap_or_default();
                    let view = monitor_view_factors(sensor.position_m, d, back);
                    with_monitor_indirect(shaded, group, view, &indirect_lx)
                }
                _ => (shaded, group),
            };
            shaded
                .iter()
                .zip(group)
                .map(|((lx, _), g)| (*lx, g))
                .collect()
        })
        .collect();
    Occluders {
        lx: rows
            .iter()
            .map(|r| r.iter().map(|v| v.0).collect())
            .collect(),
        group: rows
            .iter()
            .map(|r| r.iter().map(|v| v.1).collect())
            .collect(),
    }
}

/// Per luminaire, what an unseen object could shade of its light at a sensor, lx, and where
/// along a back edge it would stand (side, m along the edge); `None` off any back edge.
type Shaded = (f64, Option<(usize, f64)>);

/// The configuration factor from a differential horizontal element to an upright rectangle
/// `w_m` wide and `h_m` tall standing on the element's plane `d_m` away, the element in front of
/// one of the rectangle's lower corners (Howell's catalogue of configuration factors, a plane
/// element to a perpendicular rectangle): `(atan(w/d) - d/√(d²+h²) atan(w/√(d²+h²))) / 2π`.
/// Half an infinite wall gives `(1 - d/√(d²+h²)) / 4`.
pub fn perpendicular_rectangle_factor(d_m: f64, w_m: f64, h_m: f64) -> f64 {
    if !(d_m > 0.0 && w_m > 0.0 && h_m > 0.0) {
        return 0.0;
    }
    let r = d_m.hypot(h_m);
    ((w_m / d_m).atan() - d_m / r * (w_m / r).atan()) / core::f64::consts::TAU
}

/// Per side of the sensor's desk (x low, x high, y low, y high): the configuration factor of a
/// monitor at that back edge ([`EDGE_OCCLUDER_WIDTH_M`] wide centred on the sensor,
/// [`EDGE_OCCLUDER_HEIGHT_M`] tall, standing [`EDGE_OCCLUDER_INSET_M`] in from the edge); 0 at a
/// front edge. Seed 29's room_07: a monitor 0.12 m behind a sensor takes 32 % of its cosine-
/// weighted hemisphere, and with it that share of the light reflected from behind it.
pub fn monitor_view_factors(
    sensor_m: DVec3,
    desk: &crate::scene::Desk,
    back: [bool; 4],
) -> [f64; 4] {
    let t = [
        sensor_m.x - desk.x_m[0],
        desk.x_m[1] - sensor_m.x,
        sensor_m.y - desk.y_m[0],
        desk.y_m[1] - sensor_m.y,
    ];
    core::array::from_fn(|side| {
        if !back[side] || t[side] < 0.0 {
            return 0.0;
        }
        let d = monitor_distance_m(t[side]);
        let half = 0.5 * EDGE_OCCLUDER_WIDTH_M;
        2.0 * perpendicular_rectangle_factor(d, half, EDGE_OCCLUDER_HEIGHT_M)
    })
}

/// A monitor at a back edge hides the luminaires' direct light toward it and also the light
/// that reaches the sensor off the room's surfaces behind it: its configuration factor `view`
/// (per side, [`monitor_view_factors`]) times the model's indirect light at the sensor (issue
/// 28, seed 29's room_07: a desk 0.12 m in front of its monitor modelled 43 % high at all on,
/// stated at 11 % from the direct light alone). Each luminaire's own indirect light `indirect_lx`
/// enters at [`UNSEEN_OCCLUDER_SHARE`], so a dimming state weighs it by its level: a luminaire
/// shaded toward a back edge with that edge's factor, one no object can shade directly (above
/// every limit) with the nearest monitor's, and joins that monitor's largest group (a new one
/// when it has none), which then holds what one monitor there hides. Returns the luminaires'
/// parts and groups.
fn with_monitor_indirect(
    mut shaded: Vec<Shaded>,
    mut group: Vec<u8>,
    view: [f64; 4],
    indirect_lx: &[f64],
) -> (Vec<Shaded>, Vec<u8>) {
    let nearest = (0..4)
        .max_by(|&a, &b| view[a].total_cmp(&view[b]))
        .unwrap_or(0);
    if view[nearest] <= 0.0 {
        return (shaded, group);
    }
    // the nearest monitor's group: of the groups with a member at that edge, the one whose
    // members (wherever they are) sum to the most; else the next free number
    let sum = |g: u8| -> f64 {
        shaded
            .iter()
            .zip(&group)
            .filter(|(_, h)| **h == g)
            .map(|(x, _)| x.0)
            .sum()
    };
    let target = shaded
        .iter()
        .zip(&group)
        .filter(|((_, at), g)| **g > 0 && at.is_some_and(|a| a.0 == nearest))
        .map(|(_, g)| *g)
        .max_by(|a, b| sum(*a).total_cmp(&sum(*b)))
        .filter(|g| sum(*g) > 0.0)
        .or_else(|| {
            let next = group.iter().max().map_or(1, |m| m + 1);
            (next <= crate::store::live::OCCLUDER_GROUPS).then_some(next)
        });
    for (l, ((lx, at), g)) in shaded.iter_mut().zip(group.iter_mut()).enumerate() {
        let own = indirect_lx.get(l).copied().unwrap_or(0.0).max(0.0);
        let hidden = |side: usize| UNSEEN_OCCLUDER_SHARE * view[side] * own;
        if let Some((side, _)) = *at {
            *lx += hidden(side);
        } else if *lx == 0.0
            && let Some(t) = target
        {
            *lx = hidden(nearest);
            *g = t;
        }
    }
    (shaded, group)
}

/// The luminaires one monitor along a back edge could shade together: per edge, the window of
/// [`EDGE_OCCLUDER_WIDTH_M`] along it (where each luminaire's direction leaves the desk) that
/// holds the most shadable light becomes a group, then the next among the rest, and so on; a
/// luminaire alone in its window stays alone (group 0). Groups are numbered from 1 up to
/// [`crate::store::live::OCCLUDER_GROUPS`] (any beyond stay alone).
fn edge_groups(shaded: &[(f64, Option<(usize, f64)>)]) -> Vec<u8> {
    let mut group = vec![0u8; shaded.len()];
    let mut next = 1u8;
    for side in 0..4 {
        // (along the edge, m; shadable light, lx; luminaire) on this edge, by position
        let mut left: Vec<(f64, f64, usize)> = shaded
            .iter()
            .enumerate()
            .filter_map(|(l, (lx, at))| at.filter(|a| a.0 == side).map(|a| (a.1, *lx, l)))
            .collect();
        left.sort_by(|a, b| a.0.total_cmp(&b.0));
        while left.len() >= 2 && next <= crate::store::live::OCCLUDER_GROUPS {
            // the window starting at each luminaire; the one that holds the most
            let best = (0..left.len())
                .map(|i| {
                    let end = left[i..]
                        .iter()
                        .take_while(|m| m.0 - left[i].0 <= EDGE_OCCLUDER_WIDTH_M)
                        .count();
                    (i, end, left[i..i + end].iter().map(|m| m.1).sum::<f64>())
                })
                .max_by(|a, b| a.2.total_cmp(&b.2));
            let Some((i, end, _)) = best.filter(|b| b.1 >= 2) else {
                break;
            };
            for m in left.drain(i..i + end) {
                group[m.2] = next;
            }
            next += 1;
        }
    }
    group
}

impl SensorUncertainty {
    /// The largest source by name (a reflectance class or unseen occluders) and its share of
    /// the variance.
    pub fn largest_source(&self) -> (&'static str, f64) {
        let place_var = self.wall_placement_lx * self.wall_placement_lx;
        let occl_var = self.unseen_occluder_lx * self.unseen_occluder_lx;
        let total: f64 = self.by_class_lx.iter().map(|d| d * d).sum::<f64>() + occl_var + place_var;
        let (c, _) = self.dominant();
        let class_var = self.by_class_lx.iter().map(|d| d * d).fold(0.0, f64::max);
        if total <= 0.0 {
            return (c.name(), 0.0);
        }
        if occl_var > class_var.max(place_var) {
            ("unseen occluders", occl_var / total)
        } else if place_var > class_var {
            ("unseen walls' position", place_var / total)
        } else {
            (c.name(), class_var / total)
        }
    }

    /// The class that contributes most, and its share of the variance.
    pub fn dominant(&self) -> (Inferred, f64) {
        let total: f64 = self.by_class_lx.iter().map(|d| d * d).sum();
        let (k, d) = self
            .by_class_lx
            .iter()
            .enumerate()
            .fold(
                (0, 0.0),
                |a, (k, d)| if d.abs() > a.1 { (k, d.abs()) } else { a },
            );
        let share = if total > 0.0 { d * d / total } else { 0.0 };
        (Inferred::ALL[k], share)
    }
}

/// The stated uncertainty of every sensor of `model`, whose patches come from `reco`'s
/// triangles (`model.patches.source_triangle`); `wall_placement_lx` per sensor and luminaire:
/// what one standard uncertainty of the unseen walls' position changes (`super::placement`).
pub fn per_sensor(
    model: &Model,
    reco: &RecoMesh,
    o: &UncertaintyOptions,
    occluders: &Occluders,
    wall_placement_lx: Option<&[Vec<f64>]>,
) -> Result<Vec<SensorUncertainty>, EngineError> {
    o.check().map_err(EngineError::Settings)?;
    let lums = model.luminaires();
    let levels = vec![1.0; lums];
    let lux = model.sensor_lux(&levels)?;
    let class: Vec<Option<Inferred>> = model
        .patches
        .source_triangle
        .iter()
        .map(|&t| reco.part.get(t as usize).copied().and_then(Inferred::of))
        .collect();
    // every class's perturbed reflectances, then one batch of solves (the model's own once)
    let mut perturbed: Vec<(usize, Vec<f64>)> = Vec::new();
    for (ci, c) in Inferred::ALL.into_iter().enumerate() {
        let sigma = o.sigma(c);
        if sigma == 0.0 || !class.contains(&Some(c)) {
            continue;
        }
        let rho: Vec<f64> = model
            .patches
            .rho
            .iter()
            .zip(&class)
            .map(|(&r, k)| {
                if *k == Some(c) {
                    (r + sigma).min(MAX_PERTURBED_RHO).max(r)
                } else {
                    r
                }
            })
            .collect();
        perturbed.push((ci, rho));
    }
    let rhos: Vec<&[f64]> = perturbed.iter().map(|(_, r)| r.as_slice()).collect();
    let deltas = model.reflectance_sensitivities_per_luminaire_lx(&rhos)?;
    // [sensor][luminaire]: six classes, then the occluder
    let mut by_luminaire = vec![vec![[0.0; 7]; lums]; model.sensors()];
    for ((ci, _), per_lum) in perturbed.iter().zip(deltas) {
        for (l, d) in per_lum.into_iter().enumerate() {
            for (s, v) in d.into_iter().enumerate() {
                by_luminaire[s][l][*ci] = v;
            }
        }
    }
    // the reflectances' part alone (the luxmeter refit's sensitivities, `super::refit`)
    let by_class: Vec<[f64; 6]> = by_luminaire
        .iter()
        .map(|rows| {
            let mut c = [0.0; 6];
            for row in rows {
                for (c, d) in c.iter_mut().zip(row) {
                    *c += d;
                }
            }
            c
        })
        .collect();
    let mut placement = vec![0.0; model.sensors()];
    for (s, rows) in by_luminaire.iter_mut().enumerate() {
        for (l, row) in rows.iter_mut().enumerate() {
            // where the walls nobody saw stand is the walls' too: in quadrature with their
            // reflectance, luminaire by luminaire (`super::placement`)
            let placed = wall_placement_lx
                .and_then(|p| p.get(s))
                .and_then(|r| r.get(l))
                .copied()
                .filter(|d| d.is_finite())
                .unwrap_or(0.0);
            placement[s] += placed;
            row[0] = row[0].hypot(placed);
            row[6] = occluders
                .lx
                .get(s)
                .and_then(|o| o.get(l))
                .copied()
                .unwrap_or(0.0);
        }
    }
    Ok(model
        .sensor_ids
        .iter()
        .enumerate()
        .zip(lux)
        .zip(by_luminaire)
        .zip(by_class.into_iter().zip(placement))
        .map(
            |((((s, &sensor_id), all_on_lx), by_luminaire), (by_class_lx, wall_placement_lx))| {
                let occluder_group = occluders
                    .group
                    .get(s)
                    .cloned()
                    .unwrap_or_else(|| vec![0; lums]);
                let group = |l: usize| occluder_group.get(l).copied().unwrap_or(0);
                let part = |l: usize, c: usize| by_luminaire[l][c];
                // the stated uncertainty as the run-time kernel states it with every luminaire
                // on: the walls' with their placement, luminaire by luminaire, and the occluder
                // of the largest group
                let ones = vec![1.0; lums];
                let all_on_u = crate::runtime::state_uncertainty_lx(part, group, &ones);
                let zero_occluder = |l: usize, c: usize| if c == 6 { 0.0 } else { part(l, c) };
                let classes_u = crate::runtime::state_uncertainty_lx(zero_occluder, group, &ones);
                let unseen_occluder_lx = (all_on_u * all_on_u - classes_u * classes_u)
                    .max(0.0)
                    .sqrt();
                let rel = if all_on_lx > 0.0 {
                    all_on_u / all_on_lx
                } else {
                    0.0
                };
                SensorUncertainty {
                    sensor_id,
                    all_on_lx,
                    by_class_lx,
                    wall_placement_lx,
                    unseen_occluder_lx,
                    rel,
                    by_luminaire,
                    occluder_group,
                }
            },
        )
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Desk;

    fn desk(id: u32, x_m: [f64; 2], y_m: [f64; 2]) -> Desk {
        Desk {
            id,
            group: format!("desk_{id}"),
            x_m,
            y_m,
            z_m: 0.75,
        }
    }

    /// room_08's island: desks 3 and 4 share the edge y = 3.5; desk 6 stands by the wall y = 7.
    fn island() -> Vec<Desk> {
        vec![
            desk(3, [5.05, 6.65], [2.7, 3.5]),
            desk(4, [5.05, 6.65], [3.5, 4.3]),
            desk(6, [0.84, 2.44], [6.18, 6.98]),
        ]
    }

    #[test]
    fn an_islands_shared_edge_and_a_desks_wall_side_are_its_back_edges() {
        let d = island();
        let room = Some([0.0, 0.0, 10.1, 7.0]);
        assert_eq!(back_edges(&d[0], &d, room), [false, false, false, true]);
        assert_eq!(back_edges(&d[1], &d, room), [false, false, true, false]);
        assert_eq!(back_edges(&d[2], &d, room), [false, false, false, true]);
        // without the room's extent the wall side is not known: either long side may hold
        // its monitor
        assert_eq!(back_edges(&d[2], &d, None), [false, false, true, true]);
        // so too for a desk alone in the room's middle, and for one turned by 90°
        let alone = [desk(1, [4.0, 5.6], [3.0, 3.8])];
        assert_eq!(
            back_edges(&alone[0], &alone, room),
            [false, false, true, true]
        );
        let turned = [desk(1, [4.0, 4.8], [3.0, 4.6])];
        assert_eq!(
            back_edges(&turned[0], &turned, room),
            [true, true, false, false]
        );
    }

    #[test]
    fn toward_a_near_back_edge_a_monitor_there_hides_steeper_luminaires() {
        let d = island();
        let back = back_edges(&d[0], &d, None);
        let s = DVec3::new(5.525, 3.229, 0.751);
        // straight toward the shared edge, 0.271 m away, its monitor 0.15 m in from it:
        // atan(0.45 / 0.121) = 75.0°
        let up = occluder_elevation_limit_rad(s, DVec2::new(0.0, 1.0), Some((&d[0], back)));
        assert!(
            (up - 0.45f64.atan2(0.121)).abs() < 1e-9,
            "{}",
            up.to_degrees()
        );
        // diagonally toward room_08's luminaire 7 at (6.312, 5.25): the ray leaves through the
        // same edge after 0.271 / sin(atan2(2.021, 0.787)) m, and meets the monitor 0.15 m
        // before
        let dir = DVec2::new(6.312 - 5.525, 5.25 - 3.229);
        let t = 0.271 / (dir.y / dir.length());
        let diag = occluder_elevation_limit_rad(s, dir, Some((&d[0], back)));
        assert!((diag - 0.45f64.atan2(t - EDGE_OCCLUDER_INSET_M)).abs() < 1e-9);
        // a sensor at the edge: the monitor no nearer than 0.05 m
        let at_edge = DVec3::new(5.525, 3.49, 0.751);
        let near = occluder_elevation_limit_rad(at_edge, DVec2::new(0.0, 1.0), Some((&d[0], back)));
        assert!((near - 0.45f64.atan2(EDGE_OCCLUDER_MIN_DISTANCE_M)).abs() < 1e-9);
        // that luminaire, 2.306 m above the sensor, stands at 46.8°: below the limit now,
        // above the 45° of furniture anywhere on the desk
        let elev = (3.057f64 - 0.751).atan2(dir.length());
        assert!(elev > UNSEEN_OCCLUDER_ELEVATION_RAD && elev < diag);
    }

    #[test]
    fn a_monitors_width_along_the_edge_makes_a_group() {
        // room_08's desk 3: luminaires 6, 7 and 8 leave the desk through its y-high edge at
        // x = 5.29, 5.63 and 5.97 m (0.68 m apart at most), luminaire 1 through no back edge
        let on = |x: f64| Some((3usize, x));
        let rows = |lx: [f64; 3]| {
            vec![
                (20.0, None),
                (lx[0], on(5.29)),
                (lx[1], on(5.63)),
                (lx[2], on(5.97)),
            ]
        };
        // 6 + 7 hold more than 7 + 8: they are the group, 8 stays alone
        assert_eq!(edge_groups(&rows([30.0, 50.0, 25.0])), [0, 1, 1, 0]);
        // 7 + 8 hold more
        assert_eq!(edge_groups(&rows([10.0, 50.0, 45.0])), [0, 0, 1, 1]);
        // another edge's luminaires make groups of their own
        let mut two = rows([30.0, 50.0, 25.0]);
        two.push((5.0, Some((0, 3.0))));
        two.push((6.0, Some((0, 3.4))));
        assert_eq!(
            edge_groups(&two),
            [0, 2, 2, 0, 1, 1],
            "numbered edge by edge"
        );
        // nothing behind an edge, or one luminaire there: every luminaire alone
        assert_eq!(edge_groups(&[(1.0, None), (2.0, on(1.0))]), [0, 0]);
    }

    #[test]
    fn luminaires_toward_one_back_edge_are_one_group() {
        // room_08's desk 3 (sensor at y = 3.229, 0.271 m from the shared edge y = 3.5): two
        // luminaires behind the neighbour's monitor leave through the same back edge (y high,
        // side 3), one in front through the front edge, one to the side through a free edge
        let d = island();
        let back = Some((&d[0], back_edges(&d[0], &d, None)));
        let s = DVec3::new(5.525, 3.229, 0.751);
        for toward in [DVec2::new(-0.6, 1.0), DVec2::new(0.8, 1.0)] {
            let (side, t) = back_edge_toward(s, toward, back).expect("through the back edge");
            assert_eq!(side, 3);
            // the distance along the direction to y = 3.5
            assert!((t - 0.271 * toward.length() / toward.y).abs() < 1e-9, "{t}");
        }
        assert_eq!(back_edge_toward(s, DVec2::new(0.0, -1.0), back), None);
        assert_eq!(back_edge_toward(s, DVec2::new(-1.0, 0.0), back), None);
        assert_eq!(back_edge_toward(s, DVec2::new(0.0, 1.0), None), None);
    }

    /// The configuration factor against its own limits and a midpoint sum of
    /// `cos θ₁ cos θ₂ / (π r²)` over the rectangle.
    #[test]
    fn a_monitors_configuration_factor_is_the_plane_element_to_rectangle_one() {
        let wall = |d: f64, h: f64| (1.0 - d / d.hypot(h)) / 4.0;
        for (d, h) in [(0.1, 0.45), (0.3, 0.45), (1.0, 0.2)] {
            let f = perpendicular_rectangle_factor(d, 1e6, h);
            assert!((f - wall(d, h)).abs() < 1e-6, "{d} {h}: {f}");
        }
        let (d, w, h, n) = (0.12, 0.3, 0.42, 600);
        let (dx, dz) = (w / n as f64, h / n as f64);
        let mut sum = 0.0;
        for i in 0..n {
            for k in 0..n {
                let (x, z) = ((i as f64 + 0.5) * dx, (k as f64 + 0.5) * dz);
                let r2 = x * x + z * z + d * d;
                sum += z * d / (core::f64::consts::PI * r2 * r2) * dx * dz;
            }
        }
        let f = perpendicular_rectangle_factor(d, w, h);
        assert!((f / sum - 1.0).abs() < 1e-3, "{f} against {sum}");
        // seed 29's room_07: a monitor 0.12 m behind the sensor takes about a third
        assert!((0.3..0.4).contains(&(2.0 * f)), "{f}");
        for bad in [(0.0, w, h), (d, -w, h), (d, w, f64::NAN)] {
            assert_eq!(perpendicular_rectangle_factor(bad.0, bad.1, bad.2), 0.0);
        }
    }

    /// A monitor's hidden indirect light: each luminaire's own at its edge's factor; a luminaire
    /// no object shades directly joins the nearest monitor's largest group with the nearest
    /// factor; one shaded toward a front edge (`None`, by an object anywhere) takes none.
    #[test]
    fn a_monitors_hidden_indirect_light_is_each_luminaires_own_by_its_edge() {
        let shaded = vec![
            (30.0, Some((3, 0.1))),
            (10.0, Some((3, 0.3))),
            (20.0, Some((0, 0.5))),
            (5.0, None),
            (0.0, None),
        ];
        let group = vec![1, 1, 0, 0, 0];
        let view = [0.1, 0.0, 0.0, 0.3];
        let indirect = [100.0, 50.0, 80.0, 60.0, 40.0];
        let (out, g) = with_monitor_indirect(shaded, group, view, &indirect);
        let hidden = |v: f64, i: f64| UNSEEN_OCCLUDER_SHARE * v * i;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(out[0].0, 30.0 + hidden(0.3, 100.0)), "{out:?}");
        assert!(close(out[1].0, 10.0 + hidden(0.3, 50.0)), "{out:?}");
        assert!(close(out[2].0, 20.0 + hidden(0.1, 80.0)), "{out:?}");
        assert_eq!(out[3].0, 5.0);
        assert!(close(out[4].0, hidden(0.3, 40.0)), "{out:?}");
        assert_eq!(g, vec![1, 1, 0, 0, 1]);
        // no group at the nearest edge: the unshaded luminaire makes one of its own
        let (out, g) = with_monitor_indirect(
            vec![(20.0, Some((0, 0.5))), (0.0, None)],
            vec![0, 0],
            [0.1, 0.0, 0.0, 0.3],
            &[80.0, 40.0],
        );
        assert_eq!(g, vec![0, 1]);
        assert!(close(out[1].0, hidden(0.3, 40.0)), "{out:?}");
        // no back edge: nothing changes
        let (out, g) = with_monitor_indirect(vec![(7.0, None)], vec![0], [0.0; 4], &[9.0]);
        assert_eq!((out[0].0, g), (7.0, vec![0]));
    }

    /// A monitor's configuration factor per side: behind the sensor at a back edge, none at a
    /// front edge, more the nearer the edge.
    #[test]
    fn a_monitor_nearer_the_sensor_takes_more_of_its_hemisphere() {
        let d = desk(1, [0.0, 1.6], [0.0, 0.8]);
        let v = monitor_view_factors(DVec3::new(0.8, 0.55, 0.75), &d, [false, false, true, true]);
        assert_eq!((v[0], v[1]), (0.0, 0.0));
        assert!(v[3] > v[2] && v[2] > 0.0, "{v:?}");
        // 0.25 m from the edge: the monitor 0.10 m away
        let want = 2.0 * perpendicular_rectangle_factor(0.10, 0.3, EDGE_OCCLUDER_HEIGHT_M);
        assert!((v[3] - want).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn toward_a_front_edge_or_off_any_desk_the_limit_is_the_anywhere_one() {
        let d = island();
        let back = back_edges(&d[0], &d, None);
        let s = DVec3::new(5.525, 3.229, 0.751);
        let base = UNSEEN_OCCLUDER_ELEVATION_RAD;
        // toward the front edge y = 2.7, 0.529 m away, and a side edge 0.475 m away: not back
        for dir in [DVec2::new(0.0, -1.0), DVec2::new(-1.0, 0.0)] {
            assert_eq!(
                occluder_elevation_limit_rad(s, dir, Some((&d[0], back))),
                base
            );
        }
        // the same side edge as a back edge: its monitor 0.475 − 0.15 m away hides 54.2°
        let all = Some((&d[0], [true; 4]));
        let side = occluder_elevation_limit_rad(s, DVec2::new(-1.0, 0.0), all);
        assert!(
            (side - 0.45f64.atan2(0.325)).abs() < 1e-9,
            "{}",
            side.to_degrees()
        );
        // the far side edge x = 6.65 as a back edge: 1.125 − 0.15 m gives 24.8°, below the
        // anywhere limit
        assert_eq!(
            occluder_elevation_limit_rad(s, DVec2::new(1.0, 0.0), all),
            base
        );
        assert_eq!(
            occluder_elevation_limit_rad(s, DVec2::new(0.0, 1.0), None),
            base
        );
        // a luminaire straight above: no horizontal direction
        assert_eq!(occluder_elevation_limit_rad(s, DVec2::ZERO, all), base);
    }
}
