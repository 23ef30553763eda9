//! The EN 12464-1:2021 requirements of the activity as one table (required, achieved, pass or
//! fail, and why), and the overall verdict with the reasons it fails: the report's first
//! screen.

use serde::Serialize;

use super::glare::UgrResult;
use super::report::DeskResult;
use super::room_surfaces::RoomValue;
use crate::en12464::Requirement;

/// One requirement of the activity, checked.
#[derive(Debug, Clone, Serialize)]
pub struct RequirementRow {
    /// The quantity (`Ēm task area`, `UGR`, `Ēm walls`...).
    pub what: String,
    /// What the standard asks, as printed.
    pub required: String,
    /// What the design achieves (the worst place), as printed.
    pub achieved: String,
    /// Pass; `None` when not checked.
    pub pass: Option<bool>,
    /// Why it fails or is not checked (empty when it passes).
    pub reason: String,
}

fn row(
    what: &str,
    required: String,
    achieved: String,
    pass: Option<bool>,
    reason: String,
) -> RequirementRow {
    RequirementRow {
        what: what.into(),
        required,
        achieved,
        pass,
        reason,
    }
}

fn value(v: f64, unit: &str) -> String {
    if unit.is_empty() {
        format!("{v:.2}")
    } else {
        format!("{v:.0} {unit}")
    }
}

/// One row per check the desks share (`Ēm task area`...): the worst desk, every failing desk.
fn desk_rows(desks: &[DeskResult]) -> Vec<RequirementRow> {
    let Some(first) = desks.first() else {
        return vec![row(
            "desks",
            "–".into(),
            "none".into(),
            Some(false),
            "the model has no desk to check".into(),
        )];
    };
    let mut out = Vec::new();
    for (k, c0) in first.checks.iter().enumerate() {
        let checks: Vec<(u32, &crate::en12464::Check)> = desks
            .iter()
            .filter_map(|d| d.checks.get(k).map(|c| (d.id, c)))
            .collect();
        let worst = checks
            .iter()
            .min_by(|a, b| a.1.achieved.total_cmp(&b.1.achieved))
            .map(|(id, c)| format!("{} (desk {id})", value(c.achieved, c.unit)));
        let failing: Vec<String> = checks
            .iter()
            .filter(|(_, c)| !c.pass)
            .map(|(id, c)| {
                format!(
                    "desk {id}: {} {} < {}",
                    c0.what,
                    value(c.achieved, c.unit),
                    value(c.required, c.unit)
                )
            })
            .collect();
        let mut required = format!("≥ {}", value(c0.required, c0.unit));
        if k == 0 {
            required.push_str(" (modified Ēm 1000 lx where the context raises it: not applied)");
        }
        out.push(row(
            &c0.what,
            required,
            worst.unwrap_or_default(),
            Some(failing.is_empty()),
            failing.join("; "),
        ));
    }
    out
}

fn ugr_row(u: &UgrResult) -> RequirementRow {
    let mut reasons: Vec<String> = u
        .observers
        .iter()
        .filter_map(|o| {
            o.not_computed
                .as_ref()
                .map(|why| format!("desk {}: not computed: {why}", o.desk))
        })
        .collect();
    reasons.extend(u.observers.iter().filter_map(|o| {
        o.ugr
            .filter(|v| (v * 10.0).round() / 10.0 > u.limit)
            .map(|v| format!("UGR {v:.1} at desk {} > {:.0}", o.desk, u.limit))
    }));
    let achieved = match u.max {
        Some((v, d)) => format!("max {v:.1} (desk {d})"),
        None if u.observers.is_empty() => "no observer".into(),
        None => "no luminaire in view".into(),
    };
    if u.observers.is_empty() {
        reasons.push("no desk to place an observer at".into());
    }
    row(
        "UGR (per desk observer)",
        format!("≤ {:.0} (UGR_L)", u.limit),
        achieved,
        Some(u.pass),
        reasons.join("; "),
    )
}

/// ` at (x, y, z) m` where the least value lies.
fn at(v: &RoomValue) -> String {
    v.e_min_at_m.map_or(String::new(), |p| {
        format!(" at {:.1}, {:.1}, {:.1} m", p[0], p[1], p[2])
    })
}

/// `Ēm` and `U0` of a room value against `e_lx` and `u0`.
fn room_rows(v: &RoomValue, e_lx: f64, u0: f64) -> [RequirementRow; 2] {
    let (what_e, what_u) = (format!("Ēm {}", v.what), format!("U0 {}", v.what));
    match (&v.maintained, &v.not_computed) {
        (Some(s), _) => {
            let (pe, pu) = (s.e_mean_lx >= e_lx, s.u0 >= u0);
            [
                row(
                    &what_e,
                    format!("≥ {e_lx:.0} lx"),
                    format!("{:.0} lx", s.e_mean_lx),
                    Some(pe),
                    if pe {
                        String::new()
                    } else {
                        format!("{what_e} {:.0} lx < {e_lx:.0} lx", s.e_mean_lx)
                    },
                ),
                row(
                    &what_u,
                    format!("≥ {u0:.2}"),
                    format!("{:.2}", s.u0),
                    Some(pu),
                    if pu {
                        String::new()
                    } else {
                        format!(
                            "{what_u} {:.2} < {u0:.2} (Emin {:.0} lx{})",
                            s.u0,
                            s.e_min_lx,
                            at(v)
                        )
                    },
                ),
            ]
        }
        (None, why) => {
            let why = format!("not computed: {}", why.as_deref().unwrap_or("no value"));
            [
                row(
                    &what_e,
                    format!("≥ {e_lx:.0} lx"),
                    "–".into(),
                    Some(false),
                    why.clone(),
                ),
                row(&what_u, format!("≥ {u0:.2}"), "–".into(), Some(false), why),
            ]
        }
    }
}

/// The table: the desks' checks, UGR, the cylindrical, walls' and ceiling's values (`room`:
/// walls, ceiling, cylindrical), Ra.
pub fn table(
    req: &Requirement,
    desks: &[DeskResult],
    ugr: &UgrResult,
    room: &[RoomValue],
) -> Vec<RequirementRow> {
    let mut out = desk_rows(desks);
    out.push(ugr_row(ugr));
    let limits = [
        (req.e_m_wall_lx, req.u0_room_surfaces),
        (req.e_m_ceiling_lx, req.u0_room_surfaces),
        (req.e_m_z_lx, req.u0_room_surfaces),
    ];
    for (v, (e, u)) in room.iter().zip(limits) {
        out.extend(room_rows(v, e, u));
    }
    out.push(row(
        "Ra",
        format!("≥ {:.0}", req.ra),
        "–".into(),
        None,
        "not checked: the image holds no colour rendering index of the lamps".into(),
    ));
    out
}

/// The overall verdict: pass when every checked row passes; otherwise the reasons.
pub fn verdict(rows: &[RequirementRow]) -> (bool, Vec<String>) {
    let reasons: Vec<String> = rows
        .iter()
        .filter(|r| r.pass == Some(false))
        .map(|r| {
            if r.reason.is_empty() {
                format!("{} fails", r.what)
            } else {
                r.reason.clone()
            }
        })
        .collect();
    (reasons.is_empty(), reasons)
}
