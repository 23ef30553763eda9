//! Lighting scenarios (`states.csv`) and the Radiance truth (`truth.csv`).
//!
//! A states file is CSV whose header names at least `scenario_id` and `luminaires_on`
//! (luminaire ids separated by `;`, empty for all off); other columns are ignored, and a
//! scenario repeated on several lines (as in `truth.csv`, one line per sensor) counts once.

use std::path::Path;

use super::{SceneError, read_text};

/// One lighting scenario: which luminaires are on (at 100 %).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scenario {
    /// Its id as written.
    pub id: String,
    /// Luminaire ids switched on.
    pub on: Vec<u32>,
}

impl Scenario {
    /// Every luminaire of `luminaire_ids` on.
    pub fn all_on(luminaire_ids: &[u32]) -> Self {
        Self {
            id: "all_on".into(),
            on: luminaire_ids.to_vec(),
        }
    }

    /// These luminaires on, the others off; the id lists them (`on:1;3;8`).
    pub fn only(on: &[u32]) -> Self {
        Self {
            id: format!(
                "on:{}",
                on.iter().map(u32::to_string).collect::<Vec<_>>().join(";")
            ),
            on: on.to_vec(),
        }
    }

    /// The dimming state of this scenario: 1 for each luminaire of `luminaire_ids` that is on,
    /// 0 for the others (luminaire order).
    pub fn levels(&self, luminaire_ids: &[u32]) -> Vec<f64> {
        luminaire_ids
            .iter()
            .map(|id| if self.on.contains(id) { 1.0 } else { 0.0 })
            .collect()
    }
}

/// A scenario that switches on a luminaire the model does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("scenario {scenario}: luminaire {luminaire} is not in the scene")]
pub struct UnknownLuminaire {
    /// The scenario.
    pub scenario: String,
    /// The luminaire id.
    pub luminaire: u32,
}

/// Checks that every scenario names only luminaires of `luminaire_ids`.
pub fn check_scenarios(
    scenarios: &[Scenario],
    luminaire_ids: &[u32],
) -> Result<(), UnknownLuminaire> {
    for s in scenarios {
        if let Some(&luminaire) = s.on.iter().find(|id| !luminaire_ids.contains(id)) {
            return Err(UnknownLuminaire {
                scenario: s.id.clone(),
                luminaire,
            });
        }
    }
    Ok(())
}

/// One line of `truth.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthRow {
    /// Scenario id.
    pub scenario: String,
    /// Sensor id.
    pub sensor: u32,
    /// Illuminance, lx.
    pub lux: f64,
    /// Its direct part, lx (when given).
    pub lux_direct: Option<f64>,
}

fn invalid(path: &Path, line: usize, message: String) -> SceneError {
    SceneError::Syntax {
        path: path.to_path_buf(),
        line,
        message,
    }
}

/// Column index of each wanted name in a header line.
fn columns(path: &Path, header: &str, wanted: &[&str]) -> Result<Vec<Option<usize>>, SceneError> {
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    Ok(wanted
        .iter()
        .map(|w| names.iter().position(|n| n.eq_ignore_ascii_case(w)))
        .collect::<Vec<_>>())
    .and_then(|c: Vec<Option<usize>>| {
        if c[0].is_none() {
            Err(invalid(
                path,
                1,
                format!("header must name `{}`", wanted[0]),
            ))
        } else {
            Ok(c)
        }
    })
}

/// Reads scenarios from a states file (or a truth file).
pub fn read_states(path: &Path) -> Result<Vec<Scenario>, SceneError> {
    let text = read_text(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(invalid(path, 1, "empty file: no header".into()));
    };
    let cols = columns(path, header, &["scenario_id", "luminaires_on"])?;
    let Some(on_col) = cols[1] else {
        return Err(invalid(path, 1, "header must name `luminaires_on`".into()));
    };
    let id_col = cols[0].unwrap_or(0);
    let mut out: Vec<Scenario> = Vec::new();
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let (Some(id), Some(on)) = (fields.get(id_col), fields.get(on_col)) else {
            return Err(invalid(
                path,
                i + 1,
                "missing scenario_id or luminaires_on".into(),
            ));
        };
        if id.is_empty() {
            return Err(invalid(path, i + 1, "empty scenario_id".into()));
        }
        let mut ids = Vec::new();
        for t in on.split(';').map(str::trim).filter(|t| !t.is_empty()) {
            let v: u32 = t
                .parse()
                .map_err(|_| invalid(path, i + 1, format!("luminaire id {t:?} is not a number")))?;
            if !ids.contains(&v) {
                ids.push(v);
            }
        }
        match out.iter().find(|s| s.id == *id) {
            Some(s) if s.on != ids => {
                return Err(invalid(
                    path,
                    i + 1,
                    format!("scenario {id} appears again with other luminaires"),
                ));
            }
            Some(_) => {}
            None => out.push(Scenario {
                id: (*id).to_owned(),
                on: ids,
            }),
        }
    }
    Ok(out)
}

/// Reads `truth.csv` rows.
pub fn read_truth(path: &Path) -> Result<Vec<TruthRow>, SceneError> {
    let text = read_text(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(invalid(path, 1, "empty file: no header".into()));
    };
    let cols = columns(
        path,
        header,
        &["scenario_id", "sensor_id", "lux", "lux_direct"],
    )?;
    let (Some(sc), Some(lc)) = (cols[1], cols[2]) else {
        return Err(invalid(
            path,
            1,
            "header must name sensor_id and lux".into(),
        ));
    };
    let id_col = cols[0].unwrap_or(0);
    let mut out = Vec::new();
    for (i, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |c: usize| f.get(c).copied().unwrap_or("");
        let sensor: u32 = get(sc).parse().map_err(|_| {
            invalid(
                path,
                i + 1,
                format!("sensor_id {:?} is not a number", get(sc)),
            )
        })?;
        let lux: f64 = get(lc)
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| invalid(path, i + 1, format!("lux {:?} is not a number", get(lc))))?;
        let lux_direct = cols[3].and_then(|c| get(c).parse().ok());
        out.push(TruthRow {
            scenario: get(id_col).to_owned(),
            sensor,
            lux,
            lux_direct,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("s.csv");
        std::fs::write(&p, text).unwrap();
        (d, p)
    }

    #[test]
    fn repeated_scenarios_count_once_and_extra_columns_are_ignored() {
        let (_d, p) =
            write("scenario_id,luminaires_on,sensor_id,lux\n1,1;3,1,5\n1,1;3,2,6\n2,,1,0\n");
        let s = read_states(&p).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].on, vec![1, 3]);
        assert!(s[1].on.is_empty());
    }

    #[test]
    fn malformed_lines_are_errors_with_line_numbers() {
        let (_d, p) = write("scenario_id,luminaires_on\n1,1;x\n");
        let e = read_states(&p).unwrap_err().to_string();
        assert!(e.contains(":2:"), "{e}");
        let (_d, p) = write("id,on\n1,2\n");
        assert!(read_states(&p).is_err());
        let (_d, p) = write("scenario_id,luminaires_on\n1,1\n1,2\n");
        assert!(read_states(&p).unwrap_err().to_string().contains("again"));
    }
}
