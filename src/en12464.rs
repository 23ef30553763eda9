//! EN 12464-1 (Light and lighting — Lighting of work places — Part 1: Indoor work places): the
//! rules a lighting engineer checks a design against, named as in the standard.
//!
//! * **Calculation grid** (EN 12464-1:2011 §4.4, kept in the 2021 edition; derived from EN
//!   12193): the largest grid cell is `p = 0.2 × 5^log10(d)` m, `p ≤ 10 m`, where `d` is the
//!   longer side of the calculation area when the ratio of the longer to the shorter side is
//!   below 2, otherwise the shorter side. The number of points along `d` is the next whole
//!   number above `d / p`; the spacing that results (`d / n`) gives the number of points along
//!   the other side the same way, so the cells are close to square. The points lie at the
//!   centres of the cells. A band of 0.5 m from the walls is left out of the room's grid
//!   (unless a task area lies in it, which then has its own grid).
//! * **Task area and immediate surrounding area**: the immediate surrounding is a band of at
//!   least 0.5 m around the task area; its maintained illuminance follows from the task's
//!   (Table 1 of the 2011 edition, [`immediate_surrounding_lx`]) with a uniformity `U0 ≥ 0.40`.
//! * **Maintained values**: `Ēm` is the maintained illuminance, the value below which the
//!   average over the area must never fall; a design computes it as the new-installation value
//!   times the maintenance factor `MF` (CIE 97).
//! * **Requirements per activity** ([`Requirement`]): offices, writing, typing, reading, data
//!   processing (Table 5.26 of the 2011 edition, ref. 34.2.x of the 2021 edition): `Ēm = 500 lx`,
//!   `U0 ≥ 0.60`, the same in both editions, so the report cites the current one, EN
//!   12464-1:2021, with the 2021 edition's further values for the activity: the modified Ēm
//!   (stated), UGR_L, Ra, the cylindrical illuminance and the walls' and ceiling's
//!   illuminance ([`OFFICE_WRITING_READING`]).
//!
//! Statistics over a grid ([`Statistics`]): `Ē` (arithmetic mean of the points), `Emin`, `Emax`,
//! `U0 = Emin / Ē` (the standard's uniformity) and `Emin / Emax` (the diversity, DIALux's g2).

/// Width of the band left out of a room's grid along the walls, m.
pub const WALL_BAND_M: f64 = 0.5;

/// Width of the immediate surrounding area around a task area, m.
pub const IMMEDIATE_SURROUNDING_BAND_M: f64 = 0.5;

/// Least uniformity `U0` on the immediate surrounding area.
pub const IMMEDIATE_SURROUNDING_U0: f64 = 0.40;

/// The largest grid cell allowed, m.
pub const MAX_CELL_M: f64 = 10.0;

/// Why a grid could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// A side is not a length > 0.
    #[error("calculation area {0:.3} m × {1:.3} m: both sides must be lengths > 0")]
    Area(f64, f64),
    /// More points than any room needs (a unit error: a side in millimetres).
    #[error("calculation area {0:.1} m × {1:.1} m needs {2} points, more than {MAX_POINTS}")]
    TooManyPoints(f64, f64, usize),
}

/// Most points in one grid (a 1 km² hall has under 10⁴).
pub const MAX_POINTS: usize = 1_000_000;

/// The largest grid cell `p = 0.2 × 5^log10(d)`, m, for the relevant dimension `d` (m), at most
/// [`MAX_CELL_M`].
pub fn max_cell_m(d_m: f64) -> f64 {
    (0.2 * 5f64.powf(d_m.log10())).min(MAX_CELL_M)
}

/// The dimension `d` the grid rule uses for an area `a × b`: the longer side when the ratio of
/// the longer to the shorter is below 2, otherwise the shorter.
pub fn relevant_dimension_m(a_m: f64, b_m: f64) -> f64 {
    let (long, short) = if a_m >= b_m { (a_m, b_m) } else { (b_m, a_m) };
    // "below 2", with a margin for sides that are 2 : 1 to rounding (1.6 and 0.8 m as 3.4 − 1.8)
    if long < 2.0 * short * (1.0 - 1e-9) {
        long
    } else {
        short
    }
}

/// Points per side `(n_a, n_b)` of the grid over an `a × b` rectangle.
pub fn grid_counts(a_m: f64, b_m: f64) -> Result<(usize, usize), GridError> {
    if !(a_m.is_finite() && b_m.is_finite() && a_m > 0.0 && b_m > 0.0) {
        return Err(GridError::Area(a_m, b_m));
    }
    let d = relevant_dimension_m(a_m, b_m);
    let p = max_cell_m(d);
    let count = |len: f64, cell: f64| -> f64 { (len / cell - 1e-9).ceil().max(1.0) };
    let n_d = count(d, p);
    let spacing = d / n_d;
    let (na, nb) = if d == a_m {
        (n_d, count(b_m, spacing))
    } else {
        (count(a_m, spacing), n_d)
    };
    let total = na * nb;
    if total.is_nan() || total > MAX_POINTS as f64 {
        return Err(GridError::TooManyPoints(a_m, b_m, total as usize));
    }
    Ok((na as usize, nb as usize))
}

/// An axis-aligned rectangle in plan, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// x extent, m.
    pub x_m: [f64; 2],
    /// y extent, m.
    pub y_m: [f64; 2],
}

impl Rect {
    /// Side along x, m.
    pub fn width_m(&self) -> f64 {
        self.x_m[1] - self.x_m[0]
    }

    /// Side along y, m.
    pub fn depth_m(&self) -> f64 {
        self.y_m[1] - self.y_m[0]
    }

    /// Area, m².
    pub fn area_m2(&self) -> f64 {
        self.width_m() * self.depth_m()
    }

    /// Grown by `band_m` on every side (shrunk for a negative band).
    pub fn grown(&self, band_m: f64) -> Rect {
        Rect {
            x_m: [self.x_m[0] - band_m, self.x_m[1] + band_m],
            y_m: [self.y_m[0] - band_m, self.y_m[1] + band_m],
        }
    }

    /// True when (x, y) lies inside (edges included).
    pub fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x_m[0] && x <= self.x_m[1] && y >= self.y_m[0] && y <= self.y_m[1]
    }

    /// The overlap with another rectangle, if any.
    pub fn intersect(&self, o: &Rect) -> Option<Rect> {
        let r = Rect {
            x_m: [self.x_m[0].max(o.x_m[0]), self.x_m[1].min(o.x_m[1])],
            y_m: [self.y_m[0].max(o.y_m[0]), self.y_m[1].min(o.y_m[1])],
        };
        (r.width_m() > 0.0 && r.depth_m() > 0.0).then_some(r)
    }
}

/// A calculation grid: the centres of its cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Cell centres (x, y), m, row by row (y outer).
    pub points_m: Vec<[f64; 2]>,
    /// Points along x and along y (of the full rectangle, before any point was left out).
    pub counts: [usize; 2],
    /// Cell size along x and y, m.
    pub cell_m: [f64; 2],
}

/// The grid over a rectangle (a task area, or a room less its wall band).
pub fn grid(area: &Rect) -> Result<Grid, GridError> {
    let (nx, ny) = grid_counts(area.width_m(), area.depth_m())?;
    let (cx, cy) = (area.width_m() / nx as f64, area.depth_m() / ny as f64);
    let mut points_m = Vec::with_capacity(nx * ny);
    for iy in 0..ny {
        for ix in 0..nx {
            points_m.push([
                area.x_m[0] + (ix as f64 + 0.5) * cx,
                area.y_m[0] + (iy as f64 + 0.5) * cy,
            ]);
        }
    }
    Ok(Grid {
        points_m,
        counts: [nx, ny],
        cell_m: [cx, cy],
    })
}

/// The grid of the immediate surrounding area of `task`: the band of `band_m` around it,
/// clipped to `room`. The largest cell follows from the outer rectangle; the cells are aligned
/// with the task's edges (each side of the band and the task's own span divided separately), so
/// no cell straddles the task's edge; the centres inside the task (or outside the room) are left
/// out.
pub fn immediate_surrounding_grid(
    task: &Rect,
    band_m: f64,
    room: &Rect,
) -> Result<Grid, GridError> {
    let outer = task.grown(band_m);
    let outer = outer.intersect(room).unwrap_or(outer);
    let d = relevant_dimension_m(outer.width_m(), outer.depth_m());
    if !(d.is_finite() && d > 0.0) {
        return Err(GridError::Area(outer.width_m(), outer.depth_m()));
    }
    let p = max_cell_m(d);
    let axis = |lo: f64, a: f64, b: f64, hi: f64| -> Vec<f64> {
        let mut c = Vec::new();
        for (s, e) in [(lo, a), (a, b), (b, hi)] {
            let len = e - s;
            if len <= 1e-9 {
                continue;
            }
            let n = (len / p - 1e-9).ceil().max(1.0) as usize;
            c.extend((0..n).map(|k| s + (k as f64 + 0.5) * len / n as f64));
        }
        c
    };
    let xs = axis(
        outer.x_m[0],
        task.x_m[0].max(outer.x_m[0]),
        task.x_m[1].min(outer.x_m[1]),
        outer.x_m[1],
    );
    let ys = axis(
        outer.y_m[0],
        task.y_m[0].max(outer.y_m[0]),
        task.y_m[1].min(outer.y_m[1]),
        outer.y_m[1],
    );
    if xs.len() * ys.len() > MAX_POINTS {
        return Err(GridError::TooManyPoints(
            outer.width_m(),
            outer.depth_m(),
            xs.len() * ys.len(),
        ));
    }
    let mut points_m = Vec::new();
    for &y in &ys {
        for &x in &xs {
            if !task.contains(x, y) {
                points_m.push([x, y]);
            }
        }
    }
    Ok(Grid {
        points_m,
        counts: [xs.len(), ys.len()],
        cell_m: [p.min(outer.width_m()), p.min(outer.depth_m())],
    })
}

/// Illuminance statistics over the points of a grid, lx.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Statistics {
    /// Points.
    pub points: usize,
    /// `Ē`: arithmetic mean, lx.
    pub e_mean_lx: f64,
    /// `Emin`, lx.
    pub e_min_lx: f64,
    /// `Emax`, lx.
    pub e_max_lx: f64,
    /// `U0 = Emin / Ē` (0 when Ē is 0).
    pub u0: f64,
    /// `Emin / Emax` (0 when Emax is 0).
    pub e_min_over_e_max: f64,
}

impl Statistics {
    /// Statistics of a set of values, lx; `None` when there is none or one is not finite.
    pub fn of(values_lx: &[f64]) -> Option<Statistics> {
        Self::weighted(values_lx, &vec![1.0; values_lx.len()])
    }

    /// The statistics of values with weights (areas): the weighted mean, and U0 and Emin/Emax
    /// from it (`None` for no values, a value that is not finite, or no positive total weight).
    pub fn weighted(values_lx: &[f64], weights: &[f64]) -> Option<Statistics> {
        let w: f64 = weights.iter().sum();
        if values_lx.is_empty()
            || w.is_nan()
            || w <= 0.0
            || values_lx.iter().any(|v| !v.is_finite())
        {
            return None;
        }
        let mean = values_lx
            .iter()
            .zip(weights)
            .map(|(v, w)| v * w)
            .sum::<f64>()
            / w;
        let min = values_lx.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values_lx.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Some(Statistics {
            points: values_lx.len(),
            e_mean_lx: mean,
            e_min_lx: min,
            e_max_lx: max,
            u0: if mean > 0.0 { min / mean } else { 0.0 },
            e_min_over_e_max: if max > 0.0 { min / max } else { 0.0 },
        })
    }

    /// The maintained values: every illuminance times the maintenance factor (the ratios stay).
    pub fn maintained(&self, maintenance_factor: f64) -> Statistics {
        Statistics {
            e_mean_lx: self.e_mean_lx * maintenance_factor,
            e_min_lx: self.e_min_lx * maintenance_factor,
            e_max_lx: self.e_max_lx * maintenance_factor,
            ..*self
        }
    }
}

/// Why a maintenance factor is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("maintenance factor {0} must lie in (0, 1]")]
pub struct MaintenanceFactorError(pub f64);

/// The maintenance factor when none is set (a clean office, LED, three-yearly cleaning: CIE 97).
pub const DEFAULT_MAINTENANCE_FACTOR: f64 = 0.8;

/// Checks a maintenance factor: in (0, 1].
pub fn check_maintenance_factor(mf: f64) -> Result<f64, MaintenanceFactorError> {
    if mf.is_finite() && mf > 0.0 && mf <= 1.0 {
        Ok(mf)
    } else {
        Err(MaintenanceFactorError(mf))
    }
}

/// The requirements of one activity of the standard's tables.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Requirement {
    /// The activity, as the table names it.
    pub activity: &'static str,
    /// The table's reference.
    pub reference: &'static str,
    /// `Ēm` required on the task area, lx.
    pub e_m_lx: f64,
    /// `U0` required on the task area.
    pub u0: f64,
    /// The "modified" `Ēm` (2021), lx: the value the task area needs where the context raises
    /// it (visual work critical, errors costly, small details or low contrast, long duration,
    /// low visual capacity: EN 12464-1:2021 §5.3.3); stated, applied only when the designer
    /// says the context applies.
    pub e_m_modified_lx: f64,
    /// `UGR_L`: the largest Unified Glare Rating allowed.
    pub ugr_l: f64,
    /// `Ra`: the least colour rendering index of the lamps.
    pub ra: f64,
    /// `Ēm,z`: the least mean cylindrical illuminance on the activity area (1.2 m seated), lx.
    pub e_m_z_lx: f64,
    /// `Ēm,wall`: the least mean illuminance on the walls, lx.
    pub e_m_wall_lx: f64,
    /// `Ēm,ceiling`: the least mean illuminance on the ceiling, lx.
    pub e_m_ceiling_lx: f64,
    /// The least `U0` for the cylindrical, wall and ceiling illuminances.
    pub u0_room_surfaces: f64,
    /// The context modifiers the designer declares apply (EN 12464-1:2021 §5.3.3): each raises
    /// the task area's Ēm one step on the illuminance scale, up to `e_m_modified_lx`; 0, the
    /// table's Ēm, unless declared.
    pub context_modifiers: u32,
}

/// The scale of illuminance (EN 12464-1 §5.3.2), lx: the steps a context modifier moves Ēm by.
pub const ILLUMINANCE_SCALE_LX: [f64; 19] = [
    20.0, 30.0, 50.0, 75.0, 100.0, 150.0, 200.0, 300.0, 500.0, 750.0, 1000.0, 1500.0, 2000.0,
    3000.0, 5000.0, 7500.0, 10000.0, 15000.0, 20000.0,
];

impl Requirement {
    /// The same activity with `n` context modifiers declared.
    pub fn with_context_modifiers(self, n: u32) -> Requirement {
        Requirement {
            context_modifiers: n,
            ..self
        }
    }

    /// The Ēm the task area must reach: the table's Ēm raised one step on the scale per
    /// declared context modifier, at most the table's modified Ēm (never below the table's
    /// Ēm; a value off the scale steps from the next scale value above it).
    pub fn task_e_m_lx(&self) -> f64 {
        if self.context_modifiers == 0 {
            return self.e_m_lx;
        }
        let from = ILLUMINANCE_SCALE_LX
            .iter()
            .position(|v| *v >= self.e_m_lx - 1e-9)
            .unwrap_or(ILLUMINANCE_SCALE_LX.len() - 1);
        let to = (from + self.context_modifiers as usize).min(ILLUMINANCE_SCALE_LX.len() - 1);
        ILLUMINANCE_SCALE_LX[to]
            .min(self.e_m_modified_lx)
            .max(self.e_m_lx)
    }
}

/// Offices: writing, typing, reading, data processing. The 2021 values as the edition's office
/// table gives them (Ēm 500 lx, modified 1000 lx, UGR_L 19, U0 0.60, Ra 80, Ēm,z 150 lx,
/// Ēm,wall 150 lx, Ēm,ceiling 100 lx, U0 ≥ 0.10 for the last three; read from a luminaire
/// maker's reprint of the table, Glamox's "Beleuchtungsanforderungen gemäss EN 12464-1:2021",
/// not from a copy of the standard). The table's note: in small single offices the wall value
/// is for the front wall, the other walls may get at least 75 lx; the 2021 edition's general
/// floor for any room is walls ≥ 75 lx and ceiling ≥ 50 lx with U0 ≥ 0.10 (Trilux's summary).
pub const OFFICE_WRITING_READING: Requirement = Requirement {
    activity: "offices: writing, typing, reading, data processing",
    reference: "EN 12464-1:2021, offices (writing, typing, reading, data processing; Ēm and U0 as in EN 12464-1:2011 Table 5.26, ref. 5.26.2)",
    e_m_lx: 500.0,
    u0: 0.60,
    e_m_modified_lx: 1000.0,
    ugr_l: 19.0,
    ra: 80.0,
    e_m_z_lx: 150.0,
    e_m_wall_lx: 150.0,
    e_m_ceiling_lx: 100.0,
    u0_room_surfaces: 0.10,
    context_modifiers: 0,
};

/// The maintained illuminance the immediate surrounding area needs for a task area of
/// `task_lx` (EN 12464-1:2011 Table 1): ≥ 750 → 500, 500 → 300, 300 → 200, ≤ 200 → the task's
/// own; between rows, the row at or below the task's value.
pub fn immediate_surrounding_lx(task_lx: f64) -> f64 {
    if task_lx >= 750.0 {
        500.0
    } else if task_lx >= 500.0 {
        300.0
    } else if task_lx >= 300.0 {
        200.0
    } else {
        task_lx
    }
}

/// One requirement checked.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Check {
    /// What is checked (`Ēm task area`, `U0 immediate surrounding`...).
    pub what: String,
    /// Required value (a least value).
    pub required: f64,
    /// Achieved value (maintained).
    pub achieved: f64,
    /// Unit (`lx`, or empty for a ratio).
    pub unit: &'static str,
    /// achieved ≥ required.
    pub pass: bool,
}

impl Check {
    /// A "least value" check.
    pub fn at_least(
        what: impl Into<String>,
        required: f64,
        achieved: f64,
        unit: &'static str,
    ) -> Check {
        Check {
            what: what.into(),
            required,
            achieved,
            unit,
            pass: achieved.is_finite() && achieved >= required,
        }
    }
}

/// The checks of one task area and its immediate surrounding area (maintained statistics).
pub fn check_task(
    req: &Requirement,
    task: &Statistics,
    surrounding: Option<&Statistics>,
) -> Vec<Check> {
    let mut out = vec![
        Check::at_least("Ēm task area", req.task_e_m_lx(), task.e_mean_lx, "lx"),
        Check::at_least("U0 task area", req.u0, task.u0, ""),
    ];
    if let Some(s) = surrounding {
        out.push(Check::at_least(
            "Ēm immediate surrounding",
            immediate_surrounding_lx(req.task_e_m_lx()),
            s.e_mean_lx,
            "lx",
        ));
        out.push(Check::at_least(
            "U0 immediate surrounding",
            IMMEDIATE_SURROUNDING_U0,
            s.u0,
            "",
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// EN 12464-1:2021 §5.3.3, as the office table's two columns read: Ēm 500 lx, modified
    /// 1000 lx; one context modifier raises 500 one step on the scale to 750 lx, two to 1000 lx,
    /// more stay at the modified 1000 lx; the immediate surroundings follow the raised value
    /// (Table 1: 750 → 500 lx).
    #[test]
    fn context_modifiers_raise_em_a_step_each_up_to_the_modified_value() {
        let r = OFFICE_WRITING_READING;
        let at = |n| r.with_context_modifiers(n).task_e_m_lx();
        assert_eq!(
            [at(0), at(1), at(2), at(3), at(6)],
            [500.0, 750.0, 1000.0, 1000.0, 1000.0]
        );
        let s = Statistics::of(&[700.0, 720.0]).unwrap();
        let plain = check_task(&r, &s, Some(&s));
        let raised = check_task(&r.with_context_modifiers(1), &s, Some(&s));
        assert!(plain[0].pass && !raised[0].pass);
        assert_eq!((plain[0].required, raised[0].required), (500.0, 750.0));
        assert_eq!((plain[2].required, raised[2].required), (300.0, 500.0));
        // an Ēm off the scale steps from the scale value above it, never below itself
        let odd = Requirement {
            e_m_lx: 400.0,
            e_m_modified_lx: 2000.0,
            ..r
        };
        assert_eq!(odd.with_context_modifiers(1).task_e_m_lx(), 750.0);
    }

    #[test]
    fn grid_rule_of_the_standard() {
        // p = 0.2 × 5^log10(d): 0.2 m at 1 m, 1 m at 10 m, 5 m at 100 m, capped at 10 m
        assert!((max_cell_m(1.0) - 0.2).abs() < 1e-12);
        assert!((max_cell_m(10.0) - 1.0).abs() < 1e-12);
        assert!((max_cell_m(100.0) - 5.0).abs() < 1e-12);
        assert_eq!(max_cell_m(1e4), MAX_CELL_M);
        // a 1.6 × 0.8 m desk: ratio 2, so d is the shorter side: p = 0.171 m, 5 × 10 points
        assert_eq!(relevant_dimension_m(1.6, 0.8), 0.8);
        assert_eq!(grid_counts(0.8, 1.6).unwrap(), (5, 10));
        // a 5 × 6.2 m room (ratio < 2): d = 6.2 m, p = 0.716 m, n = 9, spacing 0.689 m → 8
        assert_eq!(grid_counts(5.0, 6.2).unwrap(), (8, 9));
        // 1 × 1 m: exactly 5 cells of 0.2 m (no sixth from rounding)
        assert_eq!(grid_counts(1.0, 1.0).unwrap(), (5, 5));
        assert!(grid_counts(0.0, 1.0).is_err());
        assert!(grid_counts(f64::NAN, 1.0).is_err());
        assert!(matches!(
            grid_counts(1e6, 1e6),
            Err(GridError::TooManyPoints(..))
        ));
    }

    #[test]
    fn grid_points_are_cell_centres() {
        let g = grid(&Rect {
            x_m: [1.0, 1.8],
            y_m: [1.8, 3.4],
        })
        .unwrap();
        assert_eq!(g.counts, [5, 10], "3.4 − 1.8 is 1.5999…: still 2 : 1");
        assert_eq!(g.points_m.len(), 50);
        assert!((g.points_m[0][0] - 1.08).abs() < 1e-12);
        assert!((g.points_m[0][1] - 1.88).abs() < 1e-12);
        assert!((g.points_m[49][0] - 1.72).abs() < 1e-12);
        assert!((g.points_m[49][1] - 3.32).abs() < 1e-12);
    }

    #[test]
    fn surrounding_band_leaves_the_task_out() {
        let task = Rect {
            x_m: [1.0, 1.8],
            y_m: [1.8, 3.4],
        };
        let room = Rect {
            x_m: [0.0, 6.0],
            y_m: [0.0, 7.0],
        };
        let g = immediate_surrounding_grid(&task, 0.5, &room).unwrap();
        assert!(!g.points_m.is_empty());
        for p in &g.points_m {
            assert!(!task.contains(p[0], p[1]));
            assert!(task.grown(0.5).contains(p[0], p[1]));
        }
        // against a wall: clipped to the room
        let corner = Rect {
            x_m: [0.0, 0.8],
            y_m: [0.0, 0.8],
        };
        let g = immediate_surrounding_grid(&corner, 0.5, &room).unwrap();
        assert!(g.points_m.iter().all(|p| p[0] > 0.0 && p[1] > 0.0));
    }

    #[test]
    fn statistics_and_maintained_values() {
        let s = Statistics::of(&[400.0, 500.0, 600.0]).unwrap();
        assert_eq!(s.e_mean_lx, 500.0);
        assert!((s.u0 - 0.8).abs() < 1e-12);
        assert!((s.e_min_over_e_max - 400.0 / 600.0).abs() < 1e-12);
        let m = s.maintained(0.8);
        assert!((m.e_mean_lx - 400.0).abs() < 1e-12);
        assert_eq!(m.u0, s.u0);
        assert!(Statistics::of(&[]).is_none());
        assert!(Statistics::of(&[1.0, f64::NAN]).is_none());
        assert!(check_maintenance_factor(0.0).is_err());
        assert!(check_maintenance_factor(1.2).is_err());
        assert_eq!(check_maintenance_factor(0.8), Ok(0.8));
    }

    #[test]
    fn office_requirements() {
        assert_eq!(immediate_surrounding_lx(500.0), 300.0);
        assert_eq!(immediate_surrounding_lx(1000.0), 500.0);
        assert_eq!(immediate_surrounding_lx(150.0), 150.0);
        let task = Statistics::of(&[520.0, 600.0, 640.0]).unwrap();
        let surr = Statistics::of(&[250.0, 350.0, 400.0]).unwrap();
        let c = check_task(&OFFICE_WRITING_READING, &task, Some(&surr));
        assert_eq!(c.len(), 4);
        assert!(c[0].pass && c[1].pass);
        assert!(c[2].pass, "{:?}", c[2]);
        assert!(c[3].pass);
        let dim = Statistics::of(&[200.0, 480.0]).unwrap();
        let c = check_task(&OFFICE_WRITING_READING, &dim, None);
        assert!(!c[0].pass && !c[1].pass);
    }
}
