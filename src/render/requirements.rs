//! The EN 12464-1:2021 requirements of the activity as one table (required, achieved, pass or
//! fail, and why), and the overall verdict with the reasons it fails: the report's first
//! screen.

use serde::Serialize;

use super::glare::UgrResult;
use super::report::DeskResult;
use super::room_surfaces::RoomValue;
use crate::en12464::{Check, Requirement};
use crate::store::geometry::PhotometryRecord;

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

/// What the task area's Ēm row says of the modified Ēm: not applied, or applied with the
/// declared context modifiers and the steps they raise it by.
fn modified_note(req: &Requirement) -> String {
    let n = req.context_modifiers;
    if n == 0 {
        return format!(
            " (modified Ēm {:.0} lx where the context raises it: not applied, no context \
             modifier declared)",
            req.e_m_modified_lx
        );
    }
    format!(
        " (modified: Ēm {:.0} lx raised one step on the illuminance scale per context modifier, \
         {n} declared, EN 12464-1:2021 §5.3.3; at most the modified Ēm {:.0} lx)",
        req.e_m_lx, req.e_m_modified_lx
    )
}

/// One row per check the desks have (`Ēm task area`...), in the order they first appear: the
/// worst desk, every failing desk. The task area's Ēm row says whether the modified Ēm applies.
fn desk_rows(desks: &[DeskResult], req: &Requirement) -> Vec<RequirementRow> {
    if desks.is_empty() {
        return vec![row(
            "desks",
            "–".into(),
            "none".into(),
            Some(false),
            "the model has no desk to check".into(),
        )];
    }
    let mut names: Vec<&str> = Vec::new();
    for c in desks.iter().flat_map(|d| &d.checks) {
        if !names.contains(&c.what.as_str()) {
            names.push(&c.what);
        }
    }
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let checks: Vec<(u32, &Check)> = desks
                .iter()
                .flat_map(|d| d.checks.iter().map(move |c| (d.id, c)))
                .filter(|(_, c)| c.what == *name)
                .collect();
            let mut r = checks_row(name, &checks);
            if k == 0 {
                r.required.push_str(&modified_note(req));
            }
            r
        })
        .collect()
}

/// The row of one check over the desks that have it.
fn checks_row(name: &str, checks: &[(u32, &Check)]) -> RequirementRow {
    let worst = checks
        .iter()
        .min_by(|a, b| a.1.achieved.total_cmp(&b.1.achieved))
        .map(|(id, c)| format!("{} (desk {id})", value(c.achieved, c.unit)));
    let failing: Vec<String> = checks
        .iter()
        .filter(|(_, c)| !c.pass)
        .map(|(id, c)| {
            format!(
                "desk {id}: {name} {} < {}",
                value(c.achieved, c.unit),
                value(c.required, c.unit)
            )
        })
        .collect();
    let required = checks.first().map_or("–".into(), |(_, c)| {
        format!("≥ {}", value(c.required, c.unit))
    });
    row(
        name,
        required,
        worst.unwrap_or_default(),
        Some(failing.is_empty()),
        failing.join("; "),
    )
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
/// walls, ceiling, cylindrical), Ra (from the luminaires' `photometries`).
pub fn table(
    req: &Requirement,
    desks: &[DeskResult],
    ugr: &UgrResult,
    room: &[RoomValue],
    photometries: &[PhotometryRecord],
) -> Vec<RequirementRow> {
    let mut out = desk_rows(desks, req);
    out.push(ugr_row(ugr));
    let limits = [
        (req.e_m_wall_lx, req.u0_room_surfaces),
        (req.e_m_ceiling_lx, req.u0_room_surfaces),
        (req.e_m_z_lx, req.u0_room_surfaces),
    ];
    for (v, (e, u)) in room.iter().zip(limits) {
        out.extend(room_rows(v, e, u));
    }
    out.push(ra_row(req.ra, photometries));
    out
}

/// Ra from what each photometry file states of its lamps (EULUMDAT's colour rendering group /
/// index): fails when a file states less than `ra`; passes when every file states at least
/// `ra`; otherwise not checked, naming the files that state none (never assumed).
fn ra_row(ra: f64, photometries: &[PhotometryRecord]) -> RequirementRow {
    let name = |p: &PhotometryRecord| {
        if p.colour_rendering.is_empty() {
            p.file_name.clone()
        } else {
            format!("{} ({})", p.file_name, p.colour_rendering)
        }
    };
    let low: Vec<String> = photometries
        .iter()
        .filter_map(|p| p.ra_min.filter(|v| *v < ra).map(|v| (p, v)))
        .map(|(p, v)| format!("Ra {v:.0} of {} < {ra:.0}", name(p)))
        .collect();
    let unknown: Vec<String> = photometries
        .iter()
        .filter(|p| p.ra_min.is_none())
        .map(|p| p.file_name.clone())
        .collect();
    let achieved = photometries
        .iter()
        .map(|p| match p.ra_min {
            Some(v) => format!("≥ {v:.0}: {}", name(p)),
            None => format!("not known: {}", p.file_name),
        })
        .collect::<Vec<_>>()
        .join("; ");
    let (pass, reason) = if !low.is_empty() {
        (Some(false), low.join("; "))
    } else if photometries.is_empty() {
        (None, "not checked: no luminaire".into())
    } else if !unknown.is_empty() {
        (
            None,
            format!(
                "not checked: {} states no colour rendering index of its lamps",
                unknown.join(", ")
            ),
        )
    } else {
        (Some(true), String::new())
    };
    row("Ra", format!("≥ {ra:.0}"), achieved, pass, reason)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::en12464::{OFFICE_WRITING_READING, Statistics, check_task};
    use crate::render::glare::summarise;
    use crate::render::report::AreaResult;

    fn desk(id: u32, values_lx: &[f64]) -> DeskResult {
        let s = Statistics::of(values_lx).unwrap();
        let checks = check_task(&OFFICE_WRITING_READING, &s, None);
        DeskResult {
            id,
            extent_m: [0.0, 1.6, 0.0, 0.8],
            z_m: 0.75,
            grid: ([5, 10], [0.16, 0.16]),
            pass: checks.iter().all(|c| c.pass),
            task: AreaResult {
                new: s,
                maintained: s,
                points: Vec::new(),
            },
            surrounding: None,
            checks,
        }
    }

    fn room(what: &str, values_lx: &[f64]) -> RoomValue {
        RoomValue {
            what: what.into(),
            maintained: Statistics::of(values_lx),
            e_min_at_m: Some([0.0, 1.0, 2.0]),
            covered: 0,
            not_computed: None,
        }
    }

    #[test]
    fn the_verdict_names_each_failing_requirement_and_its_value() {
        // desk 3's Ēm is 450 lx < 500 lx; the walls' U0 is 10/160 = 0.06 < 0.10; no observer
        let desks = [desk(1, &[600.0, 640.0]), desk(3, &[420.0, 480.0])];
        let ugr = summarise(Vec::new());
        let rooms = [
            room("walls", &[10.0, 310.0]),
            room("ceiling", &[120.0, 130.0]),
            room("cylindrical", &[200.0, 220.0]),
        ];
        let rows = table(&OFFICE_WRITING_READING, &desks, &ugr, &rooms, &[]);
        assert_eq!(rows[0].achieved, "450 lx (desk 3)");
        assert!(rows[0].required.contains("1000 lx"), "{:?}", rows[0]);
        let (pass, why) = verdict(&rows);
        assert!(!pass);
        assert_eq!(
            why,
            [
                "desk 3: Ēm task area 450 lx < 500 lx",
                "no desk to place an observer at",
                "U0 walls 0.06 < 0.10 (Emin 10 lx at 0.0, 1.0, 2.0 m)",
            ]
        );
        // Ra is stated, not checked, and does not decide the verdict
        let ra = rows.last().unwrap();
        assert_eq!((ra.what.as_str(), ra.pass), ("Ra", None));
    }

    /// A declared context modifier raises the task area's Ēm to 750 lx and says so: a desk of
    /// 700 lx that passes unmodified fails, with the raised value in its reason.
    #[test]
    fn a_declared_context_modifier_raises_em_with_the_reason_shown() {
        let req = OFFICE_WRITING_READING.with_context_modifiers(1);
        let s = Statistics::of(&[690.0, 710.0]).unwrap();
        let mut d = desk(2, &[690.0, 710.0]);
        d.checks = check_task(&req, &s, None);
        let ugr = summarise(Vec::new());
        let rows = table(&req, &[d], &ugr, &[], &[]);
        assert!(
            rows[0]
                .required
                .starts_with("≥ 750 lx (modified: Ēm 500 lx raised one step")
        );
        assert!(
            rows[0].required.contains("1 declared"),
            "{}",
            rows[0].required
        );
        assert_eq!(rows[0].pass, Some(false));
        assert_eq!(rows[0].reason, "desk 2: Ēm task area 700 lx < 750 lx");
        let plain = table(
            &OFFICE_WRITING_READING,
            &[desk(2, &[690.0, 710.0])],
            &ugr,
            &[],
            &[],
        );
        assert_eq!(plain[0].pass, Some(true));
        assert!(plain[0].required.contains("not applied"));
    }

    fn lamp(file: &str, stated: &str, ra_min: Option<f64>) -> PhotometryRecord {
        PhotometryRecord {
            file_name: file.into(),
            luminaire: String::new(),
            manufacturer: String::new(),
            file_flux_lm: 1000.0,
            power_w: 10.0,
            c_deg: Vec::new(),
            gamma_deg: Vec::new(),
            cd: Vec::new(),
            colour_rendering: stated.into(),
            ra_min,
        }
    }

    /// EN 12464-1's Ra ≥ 80 for offices from the files' lamp data: a known 1B (Ra 80-89) passes,
    /// a known 2A (70-79) fails with its file named and decides the verdict, a file that states
    /// nothing leaves the row unchecked (never assumed) unless another file already fails it.
    #[test]
    fn ra_is_checked_when_the_files_state_it_and_never_assumed() {
        let ra = |p: &[PhotometryRecord]| ra_row(OFFICE_WRITING_READING.ra, p);
        let ok = ra(&[lamp("a.ldt", "1B", Some(80.0))]);
        assert_eq!(
            (ok.pass, ok.achieved.as_str()),
            (Some(true), "≥ 80: a.ldt (1B)")
        );
        let low = ra(&[
            lamp("a.ldt", "1B", Some(80.0)),
            lamp("b.ldt", "2A", Some(70.0)),
        ]);
        assert_eq!(low.pass, Some(false));
        assert_eq!(low.reason, "Ra 70 of b.ldt (2A) < 80");
        assert_eq!(verdict(&[low]).1, ["Ra 70 of b.ldt (2A) < 80"]);
        let unknown = ra(&[lamp("a.ldt", "1B", Some(80.0)), lamp("c.ies", "", None)]);
        assert_eq!(unknown.pass, None);
        assert_eq!(
            unknown.reason,
            "not checked: c.ies states no colour rendering index of its lamps"
        );
        assert!(unknown.achieved.contains("not known: c.ies"));
        let both = ra(&[lamp("c.ies", "", None), lamp("b.ldt", "2A", Some(70.0))]);
        assert_eq!(both.pass, Some(false));
    }
}
