//! Occupancy at run time (issue 29): who is at which desk, from one depth frame against the
//! commissioned (empty-room) depth. Depth only: the frame is used and dropped; what is kept is
//! per desk one state (`1`, `0`, unknown), the seen fraction of its workstation zone and the
//! number of people (docs/occupancy.md).
//!
//! ## Method
//!
//! At start ([`OccupancyMap::new`]) from the stored image (or a bench's files): per *cell* (a
//! camera pixel on a grid, the live section's samples) its commissioned depth and its ray; per
//! desk its *workstation zone*: the squares of a plan grid (5 cm) within
//! [`OccupancySettings::zone_margin_m`] (0.75 m) of the desk top, each square given to the
//! nearest desk; and which of those squares the camera sees (a commissioned depth point falls
//! in them, and a ray crosses the lowest head height over them before it meets the room: a
//! zone whose floor is in view but whose people's heads would leave the frame is not seen).
//!
//! Per frame ([`Occupancy::update`]):
//!
//! 1. the frame is checked: its size, the share of pixels with a return (not 0, not
//!    saturated), and the share of pixels *farther* than the commissioned room (a person can
//!    only come nearer; many farther pixels is a camera that moved), and the share that agree
//!    with it (people and things cover less than half a room). A bad frame gives unknown
//!    for every desk and a status bit ([`status`]), never "vacant";
//! 2. *foreground*: a cell nearer than its commissioned depth by more than
//!    max([`OccupancySettings::min_foreground_m`], [`OccupancySettings::foreground_fraction`]
//!    · depth), back-projected to the world: its height above the floor goes into the plan
//!    square under it (the highest point per square);
//! 3. the foreground squares at least [`OccupancySettings::min_blob_height_m`] high are joined
//!    into blobs (flood fill over squares up to two apart), and each blob is cut by the zones;
//! 4. a part is a *person* when, seen from above, it has a head: its top (the 4th highest
//!    square: one or two noisy squares do not make a top) is within
//!    [`OccupancySettings::person_top_m`] (a seated head is 1.2-1.4 m, a standing one 1.5-1.9
//!    m; a chair back, a coat over it, a box, a bag or an open laptop on a desk stay below
//!    1.1 m), and its *head band* (the squares within [`OccupancySettings::head_band_m`] of
//!    the top: head and shoulders) is big ([`OccupancySettings::person_min_area_m2`]), wide
//!    ([`OccupancySettings::person_min_extent_m`]) and solid
//!    ([`OccupancySettings::person_min_solidity`]), and its *cap* (the squares within
//!    [`OccupancySettings::head_cap_m`] of the top) is one head, not leaves scattered over a
//!    plant's crown (at most [`OccupancySettings::person_max_cap_m`] across);
//! 5. a desk is `1` when a person part lies in its zone; `0` when none does and the frame sees
//!    at least [`OccupancySettings::vacant_min_seen`] of its zone (the squares whose
//!    commissioned points return now); otherwise unknown.
//!
//! A single frame cannot tell a still, tall, solid thing put down after commissioning from a
//! person; over frames [`Motion`] can (a head that never moves is a thing), run by the daemon
//! on every good frame. [`Hold`] keeps a desk occupied for the hold time after its person was
//! last seen, and the last answer through bad frames for as long.

mod frame;
pub mod hold;
pub mod motion;

pub use frame::Occupancy;
pub use hold::{DEFAULT_HOLD_S, HeldDesk, Hold};
pub use motion::{Motion, MotionSettings};

/// Status bits of an occupancy update ([`OccupancyReport::status`]).
pub mod status {
    /// No depth frame, or one of the wrong size.
    pub const BAD_FRAME: u16 = 1;
    /// Too few pixels return (all zeros, covered lens).
    pub const NO_RETURN: u16 = 2;
    /// Too many pixels saturated.
    pub const SATURATED: u16 = 4;
    /// The room does not register against the commissioned depth (the camera moved).
    pub const MOVED: u16 = 8;
}

/// A saturated depth pixel (the sensor's overflow value).
pub const SATURATED_MM: u16 = u16::MAX;
/// Most desks a map takes (a zone label is a byte).
pub const MAX_DESKS: usize = 254;
/// Most plan squares (a 25 m × 25 m room at 5 cm).
pub const MAX_SQUARES: usize = 250_000;
/// The widest gap between seen squares that counts as seen, squares either side.
const CLOSE_SQUARES: usize = 2;
/// Most squares either side a point covers.
const MAX_REACH: usize = 3;
/// Row neighbours farther apart than this, pixels, are not neighbours.
const MAX_NEIGHBOUR_PX: u32 = 8;
/// Zone label of a square in no zone.
const NO_ZONE: u8 = u8::MAX;
/// Square index of a cell whose commissioned point lies off the plan grid.
const NO_SQUARE: u32 = u32::MAX;

/// Why an occupancy map cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OccupancyError {
    /// A setting or an input is unusable.
    #[error("occupancy: {0}")]
    Input(String),
}

/// A desk top, in the world frame (z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeskTop {
    /// Its id.
    pub id: u32,
    /// Extent along x, m.
    pub x_m: [f64; 2],
    /// Extent along y, m.
    pub y_m: [f64; 2],
    /// Height of the top, m.
    pub z_m: f64,
}

impl DeskTop {
    /// Plan distance from (x, y) to the top's rectangle, squared, m² (0 inside).
    fn distance2_m2(&self, x: f64, y: f64) -> f64 {
        let dx = (self.x_m[0] - x).max(x - self.x_m[1]).max(0.0);
        let dy = (self.y_m[0] - y).max(y - self.y_m[1]).max(0.0);
        dx * dx + dy * dy
    }
}

/// One camera pixel the map watches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellInput {
    /// `v · width + u`.
    pub pixel: u32,
    /// Commissioned depth along the optical axis, mm (0: unknown; such a cell is skipped).
    pub background_mm: u16,
    /// The pixel's ray in the world per metre of depth along the optical axis: the world
    /// point at depth `z` m is `camera + z · ray`.
    pub ray_per_m: [f64; 3],
}

/// The knobs (defaults: docs/occupancy.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OccupancySettings {
    /// The workstation zone: plan distance from the desk top, m.
    pub zone_margin_m: f64,
    /// Side of a plan square, m.
    pub plan_square_m: f64,
    /// A pixel is foreground when nearer than the room by more than this, m ...
    pub min_foreground_m: f64,
    /// ... and by more than this fraction of its commissioned depth.
    pub foreground_fraction: f64,
    /// Foreground lower than this above the floor is not joined into blobs, m.
    pub min_blob_height_m: f64,
    /// A person's top lies within this, m (above the floor).
    pub person_top_m: [f64; 2],
    /// The head band: squares within this of the top, m.
    pub head_band_m: f64,
    /// Smallest head band, m².
    pub person_min_area_m2: f64,
    /// Narrowest head band (its larger side), m.
    pub person_min_extent_m: f64,
    /// Least share of the head band's bounding box it fills.
    pub person_min_solidity: f64,
    /// The head cap: squares within this of the top, m ...
    pub head_cap_m: f64,
    /// ... span at most this (a head, not leaves scattered over a crown), m.
    pub person_max_cap_m: f64,
    /// `0` only where the frame sees at least this share of the zone.
    pub vacant_min_seen: f64,
    /// A frame is bad when fewer than this share of the cells return.
    pub min_return_fraction: f64,
    /// The camera moved when more than this share of the returning cells lie farther than
    /// the room ...
    pub moved_fraction: f64,
    /// ... or fewer than this share agree with it (people and things cover less of a room;
    /// a frame of noise or of another room agrees nowhere).
    pub min_agree_fraction: f64,
}

impl Default for OccupancySettings {
    fn default() -> Self {
        Self {
            zone_margin_m: 0.75,
            plan_square_m: 0.05,
            min_foreground_m: 0.10,
            foreground_fraction: 0.03,
            min_blob_height_m: 0.2,
            person_top_m: [1.15, 2.1],
            head_band_m: 0.35,
            person_min_area_m2: 0.06,
            person_min_extent_m: 0.25,
            person_min_solidity: 0.4,
            head_cap_m: 0.12,
            person_max_cap_m: 0.47,
            vacant_min_seen: 0.6,
            min_return_fraction: 0.3,
            moved_fraction: 0.2,
            min_agree_fraction: 0.5,
        }
    }
}

impl OccupancySettings {
    fn validate(&self) -> Result<(), OccupancyError> {
        let within = |x: f64, lo: f64, hi: f64| x.is_finite() && (lo..=hi).contains(&x);
        let ok = within(self.zone_margin_m, 0.0, 5.0)
            && within(self.plan_square_m, 0.01, 0.5)
            && within(self.min_foreground_m, 0.01, 1.0)
            && within(self.foreground_fraction, 0.0, 0.5)
            && within(self.min_blob_height_m, 0.0, 2.0)
            && within(self.person_top_m[0], 0.3, 3.0)
            && within(self.person_top_m[1], self.person_top_m[0], 3.0)
            && within(self.head_band_m, 0.05, 1.0)
            && within(self.person_min_area_m2, 0.0, 2.0)
            && within(self.person_min_extent_m, 0.0, 2.0)
            && within(self.person_min_solidity, 0.0, 1.0)
            && within(self.head_cap_m, 0.01, 0.5)
            && within(self.person_max_cap_m, 0.05, 2.0)
            && within(self.vacant_min_seen, 0.3, 1.0)
            && within(self.min_return_fraction, 0.0, 1.0)
            && within(self.moved_fraction, 0.0, 1.0)
            && within(self.min_agree_fraction, 0.0, 1.0);
        if ok {
            Ok(())
        } else {
            Err(OccupancyError::Input(format!(
                "settings out of range: {self:?}"
            )))
        }
    }
}

/// A watched pixel, ready for the per-frame pass.
#[derive(Debug, Clone, Copy)]
struct Cell {
    pixel: u32,
    background_mm: u16,
    /// The plan square of its commissioned point ([`NO_SQUARE`]: off the grid).
    square: u32,
    /// The pixel's footprint in the plan at its commissioned point, mm (its neighbours'
    /// distances; [`spacings_mm`]), which a point covers (scaled by depth).
    spacing_mm: u16,
    ray_per_m: [f32; 3],
}

/// The plan grid: squares of side `side_m` from (`x0_m`, `y0_m`), `nx` × `ny`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Plan {
    x0_m: f64,
    y0_m: f64,
    side_m: f64,
    nx: usize,
    ny: usize,
}

impl Plan {
    /// The square under (x, y), if on the grid.
    fn square(&self, x: f64, y: f64) -> Option<usize> {
        let i = ((x - self.x0_m) / self.side_m).floor();
        let j = ((y - self.y0_m) / self.side_m).floor();
        let inside = i >= 0.0 && j >= 0.0 && i < self.nx as f64 && j < self.ny as f64;
        inside.then(|| j as usize * self.nx + i as usize)
    }

    /// How many squares either side a point with a footprint of `spacing_m` covers.
    fn reach(&self, spacing_m: f64) -> usize {
        ((spacing_m / (2.0 * self.side_m) + 0.5).floor() as usize).min(MAX_REACH)
    }

    /// How many squares either side a point surely covers (the coverage of the floor: never
    /// more than the footprint, so that the floor hidden behind an edge stays unseen).
    fn reach_within(&self, spacing_m: f64) -> usize {
        ((spacing_m / (2.0 * self.side_m)).floor() as usize).min(MAX_REACH)
    }

    /// `closed` = `seen` with every square that has seen ones on both sides within
    /// [`CLOSE_SQUARES`] (along x, y or a diagonal) seen too: the gaps between the footprints
    /// of neighbouring pixels, not the edge of a hidden area.
    fn close(&self, seen: &[bool], closed: &mut [bool]) {
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let at =
            |i: i64, j: i64| i >= 0 && j >= 0 && i < nx && j < ny && seen[(j * nx + i) as usize];
        for (q, c) in closed.iter_mut().enumerate() {
            let (i, j) = (q as i64 % nx, q as i64 / nx);
            let across = |di: i64, dj: i64| {
                let k = CLOSE_SQUARES as i64;
                (1..=k).any(|a| at(i - a * di, j - a * dj))
                    && (1..=k).any(|a| at(i + a * di, j + a * dj))
            };
            *c = seen[q] || across(1, 0) || across(0, 1) || across(1, 1) || across(1, -1);
        }
    }

    /// `f` of every square within `reach` squares of square `s` (on the grid).
    fn around(&self, s: usize, reach: usize, mut f: impl FnMut(usize)) {
        let (i, j) = (s % self.nx, s / self.nx);
        for b in j.saturating_sub(reach)..=(j + reach).min(self.ny - 1) {
            for a in i.saturating_sub(reach)..=(i + reach).min(self.nx - 1) {
                f(b * self.nx + a);
            }
        }
    }

    /// Centre of square `s`, m.
    fn centre_m(&self, s: usize) -> (f64, f64) {
        let (i, j) = (s % self.nx, s / self.nx);
        (
            self.x0_m + (i as f64 + 0.5) * self.side_m,
            self.y0_m + (j as f64 + 0.5) * self.side_m,
        )
    }
}

/// What occupancy needs of the commissioned room: the watched cells, the plan grid, each
/// square's zone, and how much of each zone the camera sees. Built once at start.
#[derive(Debug, Clone)]
pub struct OccupancyMap {
    width: u32,
    height: u32,
    camera_m: [f64; 3],
    floor_z_m: f64,
    settings: OccupancySettings,
    desks: Vec<DeskTop>,
    cells: Vec<Cell>,
    plan: Plan,
    /// Zone label per square ([`NO_ZONE`]: none).
    zone: Vec<u8>,
    /// Squares per zone.
    zone_squares: Vec<u32>,
    /// Squares per zone the commissioned depth sees.
    zone_seen_squares: Vec<u32>,
    /// Per square, whether a head over it would be in the field.
    head_seen: Vec<bool>,
}

impl OccupancyMap {
    /// The map of a `width` × `height` depth camera at `camera_m` over a floor at
    /// `floor_z_m`, watching `cells`, for `desks`. The plan grid covers the room's plan,
    /// `room_m` (x0, x1, y0, y1; `None`: the commissioned points' extent, right when the
    /// camera sees the walls); a zone ends at the room's walls.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
        camera_m: [f64; 3],
        floor_z_m: f64,
        room_m: Option<[f64; 4]>,
        desks: &[DeskTop],
        cells: &[CellInput],
        settings: OccupancySettings,
    ) -> Result<Self, OccupancyError> {
        settings.validate()?;
        let bad = |m: String| Err(OccupancyError::Input(m));
        let pixels = u64::from(width) * u64::from(height);
        if pixels == 0 || pixels > u64::from(u32::MAX) {
            return bad(format!("a {width}x{height} camera"));
        }
        if !(camera_m.iter().all(|x| x.is_finite()) && floor_z_m.is_finite()) {
            return bad("the camera's position or the floor is not finite".into());
        }
        if desks.len() > MAX_DESKS {
            return bad(format!("{} desks, at most {MAX_DESKS}", desks.len()));
        }
        for d in desks {
            let finite = d.x_m.iter().chain(&d.y_m).all(|x| x.is_finite()) && d.z_m.is_finite();
            if !(finite && d.x_m[0] <= d.x_m[1] && d.y_m[0] <= d.y_m[1]) {
                return bad(format!("desk {}: not a rectangle", d.id));
            }
        }
        let points: Vec<(usize, [f64; 3])> = cells
            .iter()
            .enumerate()
            .filter(|(_, c)| {
                c.background_mm > 0
                    && c.background_mm != SATURATED_MM
                    && u64::from(c.pixel) < pixels
                    && c.ray_per_m.iter().all(|x| x.is_finite())
            })
            .map(|(k, c)| (k, world(camera_m, c.ray_per_m, c.background_mm)))
            .collect();
        let plan = plan_over(&points, room_m, &settings)?;
        let spacing = spacings_mm(&points, cells, width);
        let mut out_cells = Vec::with_capacity(points.len());
        for ((k, p), spacing_mm) in points.iter().zip(spacing) {
            let c = &cells[*k];
            out_cells.push(Cell {
                pixel: c.pixel,
                background_mm: c.background_mm,
                square: plan.square(p[0], p[1]).map_or(NO_SQUARE, |s| s as u32),
                spacing_mm,
                ray_per_m: c.ray_per_m.map(|x| x as f32),
            });
        }
        let zone = zones(&plan, desks, settings.zone_margin_m);
        let mut zone_squares = vec![0u32; desks.len()];
        for &z in zone.iter().filter(|&&z| z != NO_ZONE) {
            zone_squares[usize::from(z)] += 1;
        }
        let mut map = Self {
            width,
            height,
            camera_m,
            floor_z_m,
            settings,
            desks: desks.to_vec(),
            cells: out_cells,
            plan,
            zone,
            zone_squares,
            zone_seen_squares: Vec::new(),
            head_seen: Vec::new(),
        };
        map.head_seen = map.head_squares();
        let all_seen = map.seen_squares(|_| true);
        let mut closed = vec![false; all_seen.len()];
        map.plan.close(&all_seen, &mut closed);
        map.zone_seen_squares = map.zone_counts(&closed);
        Ok(map)
    }

    /// Per square, whether some cell's ray crosses the lowest head height over it before it
    /// meets the room: a person there would be in the field.
    fn head_squares(&self) -> Vec<bool> {
        let mut seen = vec![false; self.zone.len()];
        let head_z_m = self.floor_z_m + self.settings.person_top_m[0];
        for c in &self.cells {
            let r = c.ray_per_m.map(f64::from);
            let bg_m = f64::from(c.background_mm) * 1e-3;
            if r[2] >= -1e-9 {
                continue;
            }
            let t = (head_z_m - self.camera_m[2]) / r[2];
            if !(t > 0.0 && t < bg_m) {
                continue;
            }
            let (x, y) = (self.camera_m[0] + t * r[0], self.camera_m[1] + t * r[1]);
            if let Some(q) = self.plan.square(x, y) {
                let reach = self.plan.reach(f64::from(c.spacing_mm) * 1e-3 * t / bg_m);
                self.plan.around(q, reach, |n| seen[n] = true);
            }
        }
        seen
    }

    /// Per square, whether a cell that `returns` covers it with its commissioned point, and
    /// a person's head over it would be in the field.
    fn seen_squares(&self, returns: impl Fn(&Cell) -> bool) -> Vec<bool> {
        let mut seen = vec![false; self.zone.len()];
        for c in self.cells.iter().filter(|c| c.square != NO_SQUARE) {
            if returns(c) {
                let reach = self.plan.reach_within(f64::from(c.spacing_mm) * 1e-3);
                self.plan
                    .around(c.square as usize, reach, |q| seen[q] = self.head_seen[q]);
            }
        }
        seen
    }

    /// Per zone, the flagged squares.
    fn zone_counts(&self, flagged: &[bool]) -> Vec<u32> {
        let mut n = vec![0u32; self.desks.len()];
        for (&z, _) in self
            .zone
            .iter()
            .zip(flagged)
            .filter(|(z, f)| **f && **z != NO_ZONE)
        {
            n[usize::from(z)] += 1;
        }
        n
    }

    /// Frame size, pixels.
    pub fn frame_size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The desks, in the order of the report.
    pub fn desks(&self) -> &[DeskTop] {
        &self.desks
    }

    /// The desk whose top holds the point (x, y, z) (within 2 cm of its rectangle, 10 cm of
    /// its height): a desk sensor's desk. A point on no desk top (a floor sensor) has none.
    pub fn desk_under(&self, point_m: [f64; 3]) -> Option<usize> {
        self.desks.iter().position(|d| {
            d.distance2_m2(point_m[0], point_m[1]) <= 0.02 * 0.02
                && (point_m[2] - d.z_m).abs() <= 0.1
        })
    }

    /// Watched cells.
    pub fn cells(&self) -> usize {
        self.cells.len()
    }

    /// Share of desk `k`'s zone the commissioned depth sees (the most any frame can see).
    pub fn commissioned_seen_fraction(&self, k: usize) -> f64 {
        fraction(self.zone_seen_squares[k], self.zone_squares[k])
    }

    /// Bytes the map holds (cells, plan squares, desks).
    pub fn memory_bytes(&self) -> usize {
        self.cells.len() * core::mem::size_of::<Cell>()
            + self.zone.len() * 2
            + self.desks.len() * (core::mem::size_of::<DeskTop>() + 8)
            + core::mem::size_of::<Self>()
    }
}

/// `n / total`, 0 for an empty zone.
fn fraction(n: u32, total: u32) -> f64 {
    if total == 0 {
        0.0
    } else {
        f64::from(n) / f64::from(total)
    }
}

/// The world point at depth `mm` on a ray.
fn world(camera_m: [f64; 3], ray_per_m: [f64; 3], mm: u16) -> [f64; 3] {
    let z = f64::from(mm) * 1e-3;
    [
        camera_m[0] + z * ray_per_m[0],
        camera_m[1] + z * ray_per_m[1],
        camera_m[2] + z * ray_per_m[2],
    ]
}

/// Per point, its footprint in the plan, mm: the larger of its plan distances to its nearest
/// neighbour in the same pixel row and in the same pixel column among the watched cells (the
/// median of the known ones for a point without neighbours).
fn spacings_mm(points: &[(usize, [f64; 3])], cells: &[CellInput], width: u32) -> Vec<u16> {
    let row = |p: u32| (p / width, p % width);
    let column = |p: u32| (p % width, p / width);
    let along_rows = nearest_mm(points, cells, row);
    let along_columns = nearest_mm(points, cells, column);
    let mut out: Vec<u16> = along_rows
        .iter()
        .zip(&along_columns)
        .map(|(&a, &b)| match (a, b) {
            (u16::MAX, x) | (x, u16::MAX) => x,
            (a, b) => a.max(b),
        })
        .collect();
    let mut known: Vec<u16> = out.iter().copied().filter(|&x| x != u16::MAX).collect();
    let median = if known.is_empty() {
        0
    } else {
        let m = known.len() / 2;
        *known.select_nth_unstable(m).1
    };
    for x in out.iter_mut().filter(|x| **x == u16::MAX) {
        *x = median;
    }
    out
}

/// Per point, the plan distance to its nearest neighbour along one pixel line, mm
/// (`u16::MAX`: none); `key` gives (line, position along it) of a pixel.
fn nearest_mm(
    points: &[(usize, [f64; 3])],
    cells: &[CellInput],
    key: impl Fn(u32) -> (u32, u32),
) -> Vec<u16> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_unstable_by_key(|&i| key(cells[points[i].0].pixel));
    let mut out = vec![u16::MAX; points.len()];
    for w in order.windows(2) {
        let (a, b) = (&points[w[0]], &points[w[1]]);
        let (ka, kb) = (key(cells[a.0].pixel), key(cells[b.0].pixel));
        if ka.0 != kb.0 || kb.1 - ka.1 > MAX_NEIGHBOUR_PX {
            continue;
        }
        let d_m = (a.1[0] - b.1[0]).hypot(a.1[1] - b.1[1]);
        let mm = (d_m * 1e3).round().clamp(0.0, f64::from(u16::MAX - 1)) as u16;
        for k in [w[0], w[1]] {
            out[k] = out[k].min(mm);
        }
    }
    out
}

/// The plan grid over the room (or the commissioned points).
fn plan_over(
    points: &[(usize, [f64; 3])],
    room_m: Option<[f64; 4]>,
    s: &OccupancySettings,
) -> Result<Plan, OccupancyError> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    match room_m {
        Some(r) => {
            if !(r.iter().all(|x| x.is_finite()) && r[0] < r[1] && r[2] < r[3]) {
                return Err(OccupancyError::Input(format!("the room's plan {r:?}")));
            }
            (lo, hi) = ([r[0], r[2]], [r[1], r[3]]);
        }
        None => {
            for (_, p) in points {
                lo = [lo[0].min(p[0]), lo[1].min(p[1])];
                hi = [hi[0].max(p[0]), hi[1].max(p[1])];
            }
        }
    }
    if !(lo[0].is_finite() && hi[0].is_finite()) {
        return Err(OccupancyError::Input(
            "no commissioned depth and no room: nothing to watch".into(),
        ));
    }
    let n = |a: f64, b: f64| ((b - a) / s.plan_square_m).ceil().max(1.0);
    let (nx, ny) = (n(lo[0], hi[0]), n(lo[1], hi[1]));
    if nx * ny > MAX_SQUARES as f64 {
        return Err(OccupancyError::Input(format!(
            "a room of {:.1} m × {:.1} m is more than {MAX_SQUARES} squares of {} m",
            hi[0] - lo[0],
            hi[1] - lo[1],
            s.plan_square_m
        )));
    }
    Ok(Plan {
        x0_m: lo[0],
        y0_m: lo[1],
        side_m: s.plan_square_m,
        nx: nx as usize,
        ny: ny as usize,
    })
}

/// The zone label of every square: the nearest desk within `margin_m`.
fn zones(plan: &Plan, desks: &[DeskTop], margin_m: f64) -> Vec<u8> {
    let margin2 = margin_m * margin_m;
    (0..plan.nx * plan.ny)
        .map(|s| {
            let (x, y) = plan.centre_m(s);
            let mut best = (f64::INFINITY, NO_ZONE);
            for (k, d) in desks.iter().enumerate() {
                let d2 = d.distance2_m2(x, y);
                if d2 <= margin2 && d2 < best.0 {
                    best = (d2, k as u8);
                }
            }
            best.1
        })
        .collect()
}

/// A desk's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Occupied {
    /// A person is at it.
    Yes,
    /// No person, and enough of its zone is seen to say so.
    No,
    /// Not known (too little seen, or a bad frame).
    Unknown,
}

impl Occupied {
    /// `1`, `0`, or empty.
    pub fn as_csv(&self) -> &'static str {
        match self {
            Occupied::Yes => "1",
            Occupied::No => "0",
            Occupied::Unknown => "",
        }
    }
}

/// One desk after an update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeskOccupancy {
    /// The desk's id.
    pub id: u32,
    /// Its state.
    pub state: Occupied,
    /// Share of its zone the frame sees.
    pub seen_fraction: f64,
}

/// A person a frame sees: where its head is (what [`Motion`] follows over frames).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PersonSeen {
    /// The desk in whose zone it is (the map's order; `None`: in no zone).
    pub desk: Option<usize>,
    /// Plan centre of its head's cap, m.
    pub x_m: f64,
    /// Plan centre of its head's cap, m.
    pub y_m: f64,
    /// Its top above the floor, m.
    pub top_m: f64,
}

/// An update's result.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyReport {
    /// Per desk, in the map's order.
    pub desks: Vec<DeskOccupancy>,
    /// People seen (at desks and elsewhere).
    pub people: u16,
    /// Each of them (empty for a bad frame).
    pub persons: Vec<PersonSeen>,
    /// [`status`] bits (0: a good frame).
    pub status: u16,
}

#[cfg(test)]
mod tests;
