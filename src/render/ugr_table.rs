//! The tabular UGR of a luminaire type (CIE 117-1995 §4.5, the method of CIE 190:2010): the
//! standard table of UGR values a catalogue prints, for rooms of X × Y (multiples of H, the
//! height of the luminaires above the eye), five reflectance combinations, the luminaires seen
//! crosswise and endwise.
//!
//! **Standard conditions** (as CIE 190 sets them; restated, not copied):
//!
//! * the observer's eye at the middle of one wall (on the wall), looking horizontally along the
//!   room's Y side, `H` = [`H_M`] = 2 m below the plane of the luminaires;
//! * the luminaires a regular array at spacing `S` = [`SPACING_H`] · H in both directions,
//!   in positions `T = ±S/2, ±3S/2, …` across the line of sight and `R = S/2, 3S/2, …` along it,
//!   filling the room; a luminaire with `T/R >` [`TR_MAX`] or seen more than
//!   [`GAMMA_MAX_DEG`] from its nadir is left out of the sum;
//! * crosswise: the luminaire's C0 plane along the line of sight (`C = arctan(T/R)`); endwise:
//!   its C90 plane along it (`C = 90° − arctan(T/R)`);
//! * `L = I(C, γ) / (A cos γ)`, `ω = A cos γ / r²` (the flat luminous opening `A`, as
//!   [`super::ugr`]); `p` the Guth index of [`super::ugr::guth_position_index`];
//! * `L_b = E_WID / π`, `E_WID` the indirect illuminance of the walls between the eye's plane and
//!   the luminaires' plane: `E_WID = (N Φ / A_w) Σ_s F_Ds · F_T,s`, with `F_Ds` the fractions of
//!   the luminaires' flux that fall directly on the floor cavity (the eye's plane, `s = F`), the
//!   walls (`W`) and the ceiling cavity (`C`), and `F_T,s` the transfer factors of the three-
//!   surface room (the indirect flux the walls receive per unit of direct flux on `s`, times
//!   `A_w`).
//!
//! **Where this departs from CIE 190's worksheet.** The standard reads `F_T` from its Table 5
//! and the floor's direct share from zonal factors (its Table 4); here both are computed: `F_T`
//! from the exact form factors of the three-surface box (which give Table 5's k = 2.67 row to
//! the third decimal: unit test), the direct shares by integrating the photometry over the
//! array (a finer value than the zonal approximation). The Guth index is the closed form (within
//! 9 % of CIE 117's Table 4.1 for `T/R ≤ 2`, less well known beyond).
//!
//! **Flux.** Uncorrected values are for the distribution scaled to 1000 lm of luminaire flux
//! (the image stores the luminaire's flux, not its bare lamps' rated flux: for absolute LED
//! photometry the two are one; for a file with a light output ratio η the standard's
//! per-1000-lm-of-lamp values would be lower by `8 log10(1/η)`). The installation's luminaires
//! add `8 log10(Φ / 1000 lm)` (CIE 190 eq. 2), given with each table.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::DVec3;
use serde::Serialize;

use super::ugr::{SightFrame, guth_position_index};
use crate::image_geometry::Room;
use crate::photometry::IntensityDistribution;

/// Height of the luminaires above the eye in the standard conditions, m.
pub const H_M: f64 = 2.0;

/// The standard spacing of the array, in multiples of H.
pub const SPACING_H: f64 = 0.25;

/// Luminaires farther across the line of sight than this times their distance along it are left
/// out of the sum.
pub const TR_MAX: f64 = 3.0;

/// Luminaires seen farther from their nadir than this are left out of the sum, degrees.
pub const GAMMA_MAX_DEG: f64 = 85.0;

/// The reference flux of uncorrected values, lm.
pub const REFERENCE_FLUX_LM: f64 = 1000.0;

/// The rooms of the standard table, (X, Y) in multiples of H: X across the line of sight, Y
/// along it.
pub const ROOMS_H: [(f64, f64); 19] = [
    (2.0, 2.0),
    (2.0, 3.0),
    (2.0, 4.0),
    (2.0, 6.0),
    (2.0, 8.0),
    (2.0, 12.0),
    (4.0, 2.0),
    (4.0, 3.0),
    (4.0, 4.0),
    (4.0, 6.0),
    (4.0, 8.0),
    (4.0, 12.0),
    (8.0, 4.0),
    (8.0, 6.0),
    (8.0, 8.0),
    (8.0, 12.0),
    (12.0, 4.0),
    (12.0, 6.0),
    (12.0, 8.0),
];

/// The reflectance combinations of the standard table: ceiling cavity, walls, floor cavity.
pub const REFLECTANCES: [[f64; 3]; 5] = [
    [0.70, 0.50, 0.20],
    [0.70, 0.30, 0.20],
    [0.50, 0.50, 0.20],
    [0.50, 0.30, 0.20],
    [0.30, 0.30, 0.20],
];

/// How the luminaires are seen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum View {
    /// The C0 plane along the line of sight.
    Crosswise,
    /// The C90 plane along the line of sight.
    Endwise,
}

impl View {
    /// The luminaire's C0 and C90 directions in the room's frame (eye at the origin on the wall
    /// y = 0, looking along +y, x across; nadir −z; C90 = C0 × nadir).
    pub fn frame(self) -> (DVec3, DVec3) {
        match self {
            View::Crosswise => (DVec3::NEG_Y, DVec3::X),
            View::Endwise => (DVec3::NEG_X, DVec3::NEG_Y),
        }
    }
}

/// The form factor between two parallel, directly opposed rectangles `x × y` at distance `h`
/// (all m).
pub fn parallel_rectangles_ff(x_m: f64, y_m: f64, h_m: f64) -> f64 {
    let (x, y) = (x_m / h_m, y_m / h_m);
    let (x1, y1) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    let log = (x1 * y1 / (1.0 + x * x + y * y).sqrt()).ln();
    2.0 / (PI * x * y)
        * (log + x * y1 * (x / y1).atan() + y * x1 * (y / x1).atan() - x * x.atan() - y * y.atan())
}

/// The transfer factors `[F_T,FW, F_T,WW, F_T,CW]` of the box `x × y` m with walls `h` m high
/// and reflectances `[ceiling, walls, floor]`: the flux the walls receive by reflection (not
/// directly from the luminaires) per unit of flux falling directly on the floor, the walls and
/// the ceiling (`E_WID A_w / Φ_direct,s`). Each surface uniform (the three-surface radiosity of
/// CIE 190), with the exact form factors of the box.
pub fn transfer_factors(x_m: f64, y_m: f64, h_m: f64, rho: [f64; 3]) -> [f64; 3] {
    let [rc, rw, rf] = rho;
    let a_f = x_m * y_m;
    let a_w = 2.0 * h_m * (x_m + y_m);
    let f_fc = parallel_rectangles_ff(x_m, y_m, h_m);
    let f_fw = 1.0 - f_fc;
    let f_wf = a_f * f_fw / a_w;
    let f_ww = 1.0 - 2.0 * f_wf;
    // surfaces: 0 floor, 1 walls, 2 ceiling; F[i][j] from i to j
    let f = [[0.0, f_fw, f_fc], [f_wf, f_ww, f_wf], [f_fc, f_fw, 0.0]];
    let area = [a_f, a_w, a_f];
    let r = [rf, rw, rc];
    let mut out = [0.0; 3];
    for (s, o) in out.iter_mut().enumerate() {
        // M = ρ (E_direct + F M): (I − diag(ρ) F) M = ρ E_direct, unit flux on surface s
        let mut a = [[0.0; 3]; 3];
        let mut b = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] = if i == j { 1.0 } else { 0.0 } - r[i] * f[i][j];
            }
            b[i] = if i == s { r[i] / area[i] } else { 0.0 };
        }
        let m = solve3(a, b);
        // indirect illuminance of the walls, times their area
        *o = (f[1][0] * m[0] + f[1][1] * m[1] + f[1][2] * m[2]) * a_w;
    }
    out
}

/// Solves a 3 × 3 system by Cramer's rule (the matrix is diagonally dominant: never singular
/// for reflectances below 1).
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> [f64; 3] {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *xk = det(m) / d;
    }
    x
}

/// The distribution's flux on a (C, γ) quadrature, for the direct shares: per C column the
/// cumulative flux from the nadir up to each γ step, lm.
struct FluxColumns {
    /// C of each column, radians (midpoints).
    c_rad: Vec<f64>,
    /// γ step, radians.
    step_rad: f64,
    /// `cum[k][j]`: flux of column k from γ = 0 to `j · step` (j = 0..=steps to 90°), lm.
    cum: Vec<Vec<f64>>,
    /// Flux above the horizontal, lm.
    up_lm: f64,
}

/// Columns of 1° in C, steps of 0.25° in γ (midpoint rule).
const C_COLUMNS: usize = 360;
const GAMMA_STEPS_90: usize = 360;

impl FluxColumns {
    fn of(d: &IntensityDistribution) -> FluxColumns {
        let dc = TAU / C_COLUMNS as f64;
        let step_rad = FRAC_PI_2 / GAMMA_STEPS_90 as f64;
        let c_rad: Vec<f64> = (0..C_COLUMNS).map(|k| (k as f64 + 0.5) * dc).collect();
        let mut up_lm = 0.0;
        let cum = c_rad
            .iter()
            .map(|&c| {
                let mut acc = 0.0;
                let mut col = Vec::with_capacity(GAMMA_STEPS_90 + 1);
                col.push(0.0);
                for j in 0..GAMMA_STEPS_90 {
                    let g = (j as f64 + 0.5) * step_rad;
                    acc += d.intensity_cd(c, g) * g.sin() * step_rad * dc;
                    col.push(acc);
                }
                for j in 0..GAMMA_STEPS_90 {
                    let g = FRAC_PI_2 + (j as f64 + 0.5) * step_rad;
                    up_lm += d.intensity_cd(c, g) * g.sin() * step_rad * dc;
                }
                col
            })
            .collect();
        FluxColumns {
            c_rad,
            step_rad,
            cum,
            up_lm,
        }
    }

    /// The downward flux, lm.
    fn down_lm(&self) -> f64 {
        self.cum.iter().map(|c| c[GAMMA_STEPS_90]).sum()
    }

    /// Column k's flux from the nadir to `gamma_rad` (linear within a step), lm.
    fn below(&self, k: usize, gamma_rad: f64) -> f64 {
        let x = (gamma_rad / self.step_rad).clamp(0.0, GAMMA_STEPS_90 as f64);
        let j = (x.floor() as usize).min(GAMMA_STEPS_90 - 1);
        let t = x - j as f64;
        let col = &self.cum[k];
        col[j] + t * (col[j + 1] - col[j])
    }
}

/// The direct shares `[F_DF, F_DW, F_DC]` of the array's flux: on the floor cavity (the
/// rectangle `|x| ≤ X/2, 0 ≤ y ≤ Y` a height `h` below the luminaires), on the walls (the rest
/// of the downward flux) and on the ceiling cavity (the upward flux).
fn direct_shares(
    cols: &FluxColumns,
    positions_m: &[(f64, f64)],
    room_m: (f64, f64),
    h_m: f64,
    view: View,
) -> [f64; 3] {
    let (c0, c90) = view.frame();
    let (half_x, y_m) = (0.5 * room_m.0, room_m.1);
    let dirs: Vec<(f64, f64)> = cols
        .c_rad
        .iter()
        .map(|c| {
            let d = c0 * c.cos() + c90 * c.sin();
            (d.x, d.y)
        })
        .collect();
    let total = cols.down_lm() + cols.up_lm;
    if total.is_nan() || total <= 0.0 || positions_m.is_empty() {
        return [0.0; 3];
    }
    let mut floor_lm = 0.0;
    for &(px, py) in positions_m {
        for (k, &(dx, dy)) in dirs.iter().enumerate() {
            // distance along (dx, dy) from (px, py) to the rectangle's edge
            let tx = if dx > 0.0 {
                (half_x - px) / dx
            } else if dx < 0.0 {
                (-half_x - px) / dx
            } else {
                f64::INFINITY
            };
            let ty = if dy > 0.0 {
                (y_m - py) / dy
            } else if dy < 0.0 {
                -py / dy
            } else {
                f64::INFINITY
            };
            let reach_m = tx.min(ty).max(0.0);
            floor_lm += cols.below(k, reach_m.atan2(h_m));
        }
    }
    let n = positions_m.len() as f64;
    let f_df = floor_lm / (n * total);
    let f_down = cols.down_lm() / total;
    [f_df, (f_down - f_df).max(0.0), cols.up_lm / total]
}

/// The array of the standard conditions in a room `x × y` m: the luminaires' (x, y), m.
pub fn array_m(x_m: f64, y_m: f64, spacing_m: f64) -> Vec<(f64, f64)> {
    let nx = (x_m / spacing_m).round() as usize;
    let ny = (y_m / spacing_m).round() as usize;
    let mut out = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            out.push((
                -0.5 * x_m + (i as f64 + 0.5) * spacing_m,
                (j as f64 + 0.5) * spacing_m,
            ));
        }
    }
    out
}

/// `Σ L² ω / p²` of the array seen by the eye at the origin (flux as the distribution's),
/// cd²/m⁴·sr.
fn glare_sum(
    d: &IntensityDistribution,
    area_m2: f64,
    positions_m: &[(f64, f64)],
    h_m: f64,
    view: View,
) -> f64 {
    let (c0, c90) = view.frame();
    let mut sum = 0.0;
    for &(x, y) in positions_m {
        let (t, r) = (x.abs(), y);
        if r <= 0.0 || t / r > TR_MAX {
            continue;
        }
        let dist_m = (x * x + y * y + h_m * h_m).sqrt();
        let gamma = (x.hypot(y)).atan2(h_m);
        if gamma.to_degrees() > GAMMA_MAX_DEG {
            continue;
        }
        // direction from the luminaire to the eye, in its C frame
        let to_eye = DVec3::new(-x, -y, 0.0);
        let c = to_eye.dot(c90).atan2(to_eye.dot(c0));
        let i_cd = d.intensity_cd(c, gamma);
        let Some(p) = guth_position_index(&SightFrame {
            r_m: r,
            t_m: t,
            h_m,
        }) else {
            continue;
        };
        let projected_m2 = area_m2 * gamma.cos();
        if i_cd <= 0.0 || projected_m2 <= 0.0 {
            continue;
        }
        let l = i_cd / projected_m2;
        let omega = projected_m2 / (dist_m * dist_m);
        sum += l * l * omega / (p * p);
    }
    sum
}

/// One cell of the table: UGR, or why not.
pub type Cell = Option<f64>;

/// One room's row: the five reflectance combinations, crosswise and endwise.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// X (across the line of sight), multiples of H.
    pub x_h: f64,
    /// Y (along the line of sight), multiples of H.
    pub y_h: f64,
    /// Luminaires in the array.
    pub luminaires: usize,
    /// Background luminance per reflectance combination, crosswise then endwise (the direct
    /// shares differ with the turn of an asymmetric luminaire), cd/m².
    pub l_b_cd_per_m2: [[f64; 5]; 2],
    /// Crosswise UGR per reflectance combination (order of [`REFLECTANCES`]).
    pub crosswise: [Cell; 5],
    /// Endwise UGR per reflectance combination.
    pub endwise: [Cell; 5],
}

/// The table of one luminaire type.
#[derive(Debug, Clone, Serialize)]
pub struct TypeTable {
    /// Photometry file.
    pub photometry_file: String,
    /// Luminaire named in the file.
    pub luminaire: String,
    /// The luminaires of this type in the room (ids).
    pub ids: Vec<u32>,
    /// Luminous opening (along C0, along C90), m.
    pub opening_m: [f64; 2],
    /// Flux of one luminaire as installed, lm.
    pub flux_lm: f64,
    /// `8 log10(Φ / 1000 lm)`: add to the uncorrected values for the installed flux.
    pub flux_correction: f64,
    /// Reflectances (ceiling, walls, floor cavity) of the columns.
    pub reflectances: [[f64; 3]; 5],
    /// Spacing in multiples of H.
    pub spacing_h: f64,
    /// Rows in the standard order (empty when not computed).
    pub rows: Vec<Row>,
    /// Why the table was not computed.
    pub not_computed: Option<String>,
    /// Spacing corrections (S = 1.0H, 1.5H, 2.0H): not computed, and why.
    pub spacing_corrections: String,
}

/// What the spacing corrections say.
pub const SPACING_CORRECTIONS: &str = "not computed: CIE 117's variation of UGR with the observer's position for spacings of 1.0H, 1.5H and 2.0H needs the standard's own observer grid and room, which this build does not have; the table holds only the standard spacing 0.25H";

/// The uncorrected table of a distribution (any flux: it is scaled to 1000 lm) with a flat
/// opening of `area_m2`.
pub fn uncorrected_rows(d: &IntensityDistribution, area_m2: f64) -> Result<Vec<Row>, String> {
    if !(area_m2.is_finite() && area_m2 > 0.0) {
        return Err("the luminaire has no luminous opening size".into());
    }
    let flux = d.flux_lm();
    if !(flux.is_finite() && flux > 0.0) {
        return Err("the photometry emits no light".into());
    }
    let d = d.scaled(REFERENCE_FLUX_LM / flux);
    let cols = FluxColumns::of(&d);
    let total_lm = cols.down_lm() + cols.up_lm;
    let mut rows = Vec::with_capacity(ROOMS_H.len());
    for &(x_h, y_h) in &ROOMS_H {
        let (x_m, y_m) = (x_h * H_M, y_h * H_M);
        let pos = array_m(x_m, y_m, SPACING_H * H_M);
        let a_w = 2.0 * H_M * (x_m + y_m);
        let b = total_lm * pos.len() as f64 / a_w;
        let mut row = Row {
            x_h,
            y_h,
            luminaires: pos.len(),
            l_b_cd_per_m2: [[0.0; 5]; 2],
            crosswise: [None; 5],
            endwise: [None; 5],
        };
        for view in [View::Crosswise, View::Endwise] {
            let shares = direct_shares(&cols, &pos, (x_m, y_m), H_M, view);
            let sum = glare_sum(&d, area_m2, &pos, H_M, view);
            for (k, rho) in REFLECTANCES.iter().enumerate() {
                let ft = transfer_factors(x_m, y_m, H_M, *rho);
                let e_wid = b * (shares[0] * ft[0] + shares[1] * ft[1] + shares[2] * ft[2]);
                let l_b = e_wid / PI;
                let u = (l_b > 0.0 && sum > 0.0).then(|| 8.0 * (0.25 / l_b * sum).log10());
                let u = u.filter(|v| v.is_finite());
                match view {
                    View::Crosswise => {
                        row.l_b_cd_per_m2[0][k] = l_b;
                        row.crosswise[k] = u;
                    }
                    View::Endwise => {
                        row.l_b_cd_per_m2[1][k] = l_b;
                        row.endwise[k] = u;
                    }
                }
            }
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The tables of the room's luminaire types (a type: one photometry with one opening).
pub fn tables(room: &Room) -> Vec<TypeTable> {
    let mut out: Vec<(u32, TypeTable)> = Vec::new();
    for (rec, lum) in room.section.luminaires.iter().zip(&room.luminaires) {
        let same = |(ph, t): &&mut (u32, TypeTable)| {
            *ph == rec.photometry
                && t.opening_m == rec.opening_m
                && (t.flux_lm - rec.flux_lm).abs() < 1e-6 * rec.flux_lm.abs().max(1.0)
        };
        if let Some((_, t)) = out.iter_mut().find(same) {
            t.ids.push(rec.id);
            continue;
        }
        let ph = room.section.photometries.get(rec.photometry as usize);
        let area_m2 = super::glare::opening(lum).area_m2;
        let (rows, not_computed) = match uncorrected_rows(&lum.photometry, area_m2) {
            Ok(r) => (r, None),
            Err(why) => (Vec::new(), Some(why)),
        };
        out.push((
            rec.photometry,
            TypeTable {
                photometry_file: ph.map(|p| p.file_name.clone()).unwrap_or_default(),
                luminaire: ph.map(|p| p.luminaire.clone()).unwrap_or_default(),
                ids: vec![rec.id],
                opening_m: rec.opening_m,
                flux_lm: rec.flux_lm,
                flux_correction: 8.0 * (rec.flux_lm / REFERENCE_FLUX_LM).log10(),
                reflectances: REFLECTANCES,
                spacing_h: SPACING_H,
                rows,
                not_computed,
                spacing_corrections: SPACING_CORRECTIONS.into(),
            },
        ));
    }
    out.into_iter().map(|(_, t)| t).collect()
}

fn cell(c: &Cell) -> String {
    c.map_or_else(|| "–".into(), |v| format!("{v:.1}"))
}

/// The appendix: one table per luminaire type, as a catalogue prints it.
pub fn html(h: &mut String, tables: &[TypeTable]) {
    use std::fmt::Write as _;
    let _ = writeln!(
        h,
        "<h2 id=\"ugr-table\">Appendix: UGR tables (CIE 117 / CIE 190)</h2>\n<p>Uncorrected UGR \
of each luminaire type in the standard conditions: observer at the middle of a wall, eye {H_M:.1} m \
(H) below the luminaires, a regular array at spacing {SPACING_H}H filling a room of X × Y; \
reflectances ceiling cavity / walls / floor cavity in percent; background luminance from the walls' \
indirect illuminance (three-surface room, exact form factors). Values for 1000 lm of luminaire \
flux; add the flux correction for the installed luminaires. Spacing corrections: {SPACING_CORRECTIONS}.</p>"
    );
    for t in tables {
        let _ = writeln!(
            h,
            "<h3>{} ({}), luminaires {}</h3>",
            super::report::esc(&t.photometry_file),
            super::report::esc(&t.luminaire),
            t.ids
                .iter()
                .map(|i| format!("L{i}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        if let Some(why) = &t.not_computed {
            let _ = writeln!(h, "<p>Not computed: {}.</p>", super::report::esc(why));
            continue;
        }
        let _ = writeln!(
            h,
            "<p>Opening {:.3} × {:.3} m; installed flux {:.0} lm: add {:+.1} to every value.</p>",
            t.opening_m[0], t.opening_m[1], t.flux_lm, t.flux_correction
        );
        let refl: String = t
            .reflectances
            .iter()
            .map(|r| {
                format!(
                    "<th>{:.0}/{:.0}/{:.0}</th>",
                    100.0 * r[0],
                    100.0 * r[1],
                    100.0 * r[2]
                )
            })
            .collect();
        let _ = writeln!(
            h,
            "<table class=\"ugr-table\"><tr><th rowspan=\"2\">X</th><th rowspan=\"2\">Y</th>\
<th colspan=\"5\">viewed crosswise</th><th colspan=\"5\">viewed endwise</th></tr>\n<tr>{refl}{refl}</tr>"
        );
        for r in &t.rows {
            let cells: String = r
                .crosswise
                .iter()
                .chain(&r.endwise)
                .map(|c| format!("<td>{}</td>", cell(c)))
                .collect();
            let _ = writeln!(
                h,
                "<tr><td>{:.0}H</td><td>{:.0}H</td>{cells}</tr>",
                r.x_h, r.y_h
            );
        }
        h.push_str("</table>\n");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transfer_factors_give_cie_190_table_5_at_k_2_67() {
        // CIE 190:2010 Table 5, the row of the 4H × 8H room (k = 2.67), as restated by the
        // MIT-licensed eulumdat-ugr package: (ceiling, walls, floor) → F_T,FW, F_T,WW-1, F_T,CW
        let table = [
            ([0.7, 0.5, 0.2], [0.115, 0.211, 0.307]),
            ([0.7, 0.3, 0.2], [0.106, 0.117, 0.283]),
            ([0.5, 0.5, 0.2], [0.100, 0.187, 0.211]),
            ([0.5, 0.3, 0.2], [0.093, 0.104, 0.196]),
            ([0.3, 0.3, 0.2], [0.081, 0.092, 0.114]),
        ];
        for (rho, want) in table {
            for (got, want) in transfer_factors(8.0, 16.0, 2.0, rho).iter().zip(want) {
                assert!((got - want).abs() < 0.0006, "{rho:?}: {got} vs {want}");
            }
        }
        // 8H × 4H is the same room turned
        let a = transfer_factors(16.0, 8.0, 2.0, [0.7, 0.5, 0.2]);
        let b = transfer_factors(8.0, 16.0, 2.0, [0.7, 0.5, 0.2]);
        assert!((a[0] - b[0]).abs() < 1e-12);
        // black walls receive indirect light still; a black room none
        assert_eq!(transfer_factors(8.0, 16.0, 2.0, [0.0; 3]), [0.0; 3]);
    }

    /// The form factor from a differential area to a parallel rectangle with a corner above it
    /// (sides a, b, distance h), closed form.
    fn corner_ff(a: f64, b: f64, h: f64) -> f64 {
        let (x, y) = (a / h, b / h);
        let (x1, y1) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / x1 * (y / x1).atan() + y / y1 * (x / y1).atan()) / TAU
    }

    #[test]
    fn a_cosine_luminaires_floor_share_is_the_form_factor_to_the_floor() {
        // a Lambertian (cosine) luminaire sends to a parallel rectangle the share of its flux
        // that is the differential-area form factor: the sum over four corner rectangles
        let d = IntensityDistribution::from_gamma_fn(1.0, "cosine", |g| {
            if g <= FRAC_PI_2 { 100.0 * g.cos() } else { 0.0 }
        });
        let cols = FluxColumns::of(&d);
        for &(x_h, y_h) in &[(2.0, 4.0), (8.0, 4.0), (12.0, 8.0)] {
            let (x_m, y_m) = (x_h * H_M, y_h * H_M);
            let pos = array_m(x_m, y_m, SPACING_H * H_M);
            let closed: f64 = pos
                .iter()
                .map(|&(px, py)| {
                    let (l, r) = (px + 0.5 * x_m, 0.5 * x_m - px);
                    let (n, f) = (py, y_m - py);
                    corner_ff(l, n, H_M)
                        + corner_ff(l, f, H_M)
                        + corner_ff(r, n, H_M)
                        + corner_ff(r, f, H_M)
                })
                .sum::<f64>()
                / pos.len() as f64;
            for view in [View::Crosswise, View::Endwise] {
                let s = direct_shares(&cols, &pos, (x_m, y_m), H_M, view);
                assert!(
                    (s[0] / closed - 1.0).abs() < 0.002,
                    "{x_h}H × {y_h}H: {} vs {closed}",
                    s[0]
                );
                assert!((s[0] + s[1] - 1.0).abs() < 1e-3 && s[2] < 1e-9, "{s:?}");
            }
        }
    }

    #[test]
    fn the_array_fills_the_room_at_the_spacing() {
        let p = array_m(8.0, 16.0, 0.5);
        assert_eq!(p.len(), 16 * 32);
        assert!((p[0].0 + 3.75).abs() < 1e-12 && (p[0].1 - 0.25).abs() < 1e-12);
        let parallel = parallel_rectangles_ff(1e3, 1e3, 1.0);
        assert!((parallel - 1.0).abs() < 0.01, "{parallel}");
    }
}
