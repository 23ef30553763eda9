//! Driving the Radiance harness (`bench/radiance/office_a.py`, pyradiance) for the side-by-side
//! benchmark: one run of the script on a scene, its wall time and its error against the same
//! truth.

use std::path::{Path, PathBuf};

/// Why the harness gave no result.
#[derive(Debug, thiserror::Error)]
pub enum RadianceError {
    /// The script could not be started.
    #[error("running {}: {source}", script.display())]
    Spawn {
        /// The script.
        script: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The script failed.
    #[error("the Radiance harness failed ({0})")]
    Failed(std::process::ExitStatus),
    /// Its result file is missing or not what the harness writes.
    #[error("the Radiance result {}: {reason}", path.display())]
    Result {
        /// The result file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// What the harness measured.
#[derive(Debug, Clone, PartialEq)]
pub struct RadianceRun {
    /// The command run, for the record.
    pub command: String,
    /// The settings it reports (its `-ab -ad ...`).
    pub settings: String,
    /// Wall time for the whole table, s.
    pub wall_time_s: f64,
    /// Its error against the truth (the Table 1 measure).
    pub error: f64,
    /// Its worst sensor's error (NaN when the harness does not say).
    pub worst_sensor_error: f64,
}

/// Runs `python3 SCRIPT --scene SCENE --json TMP ARGS...` and reads its result.
pub fn run(script: &Path, scene: &Path, args: &str) -> Result<RadianceRun, RadianceError> {
    let json = std::env::temp_dir().join(format!("luxnode-radiance-{}.json", std::process::id()));
    let mut cmd = std::process::Command::new("python3");
    cmd.arg(script)
        .arg("--scene")
        .arg(scene)
        .arg("--json")
        .arg(&json);
    cmd.args(args.split_whitespace());
    let command = format!("{cmd:?}");
    let status = cmd.status().map_err(|source| RadianceError::Spawn {
        script: script.to_owned(),
        source,
    })?;
    if !status.success() {
        return Err(RadianceError::Failed(status));
    }
    let bad = |reason: String| RadianceError::Result {
        path: json.clone(),
        reason,
    };
    let text = std::fs::read_to_string(&json).map_err(|e| bad(e.to_string()))?;
    let _ = std::fs::remove_file(&json);
    parse(&text, args, command).map_err(bad)
}

fn parse(text: &str, args: &str, command: String) -> Result<RadianceRun, String> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let number = |key: &str| {
        v[key]
            .as_f64()
            .ok_or_else(|| format!("no number {key} in the result"))
    };
    Ok(RadianceRun {
        command,
        settings: v["settings"].as_str().unwrap_or(args).to_owned(),
        wall_time_s: number("wall_time_s")?,
        error: number("error")?,
        worst_sensor_error: v["worst_sensor_error"].as_f64().unwrap_or(f64::NAN),
    })
}

#[cfg(test)]
mod tests {
    use super::parse;

    #[test]
    fn the_harness_result_is_read() {
        let r = parse(
            r#"{"wall_time_s": 2.3, "error": 0.0024, "worst_sensor_error": 0.0053, "settings": "-ab 8"}"#,
            "",
            "python3".into(),
        )
        .unwrap();
        assert_eq!(
            (r.wall_time_s, r.error, r.settings.as_str()),
            (2.3, 0.0024, "-ab 8")
        );
        assert!(parse(r#"{"error": 0.1}"#, "", String::new()).is_err());
        assert!(parse("not json", "", String::new()).is_err());
    }
}
