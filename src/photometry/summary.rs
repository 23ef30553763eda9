//! What `luxnode photometry` says of a distribution: the summary a person reads and a script
//! parses (the same fields), and the warnings a lighting engineer would raise.

use serde::Serialize;

use super::IntensityDistribution;

/// How far an integrated light output ratio may exceed 100 % before it is suspect, percent
/// points (measurement noise of real files is a few tenths).
const LOR_OVER_100_PCT: f64 = 0.5;
/// Relative tolerance between a declared and an integrated light output ratio.
const LOR_MISMATCH_REL: f64 = 0.02;

/// One distribution's summary (`luxnode photometry --json` prints it as is).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// The file.
    pub file: String,
    /// EULUMDAT or IES.
    pub format: String,
    /// Symmetry name.
    pub symmetry: &'static str,
    /// EULUMDAT symmetry indicator.
    pub isym: u8,
    /// Luminaire name.
    pub luminaire: String,
    /// Manufacturer.
    pub manufacturer: String,
    /// C planes in the file.
    pub c_planes_stored: usize,
    /// C planes after unfolding to 0..360°.
    pub c_planes_unfolded: usize,
    /// γ angles.
    pub gamma_angles: usize,
    /// First γ, degrees.
    pub gamma_min_deg: Option<f64>,
    /// Last γ, degrees.
    pub gamma_max_deg: Option<f64>,
    /// Total flux, lm.
    pub flux_lm: f64,
    /// Flux below the horizontal, lm.
    pub downward_flux_lm: f64,
    /// Largest intensity, cd.
    pub max_cd: f64,
    /// Its C angle, degrees.
    pub max_c_deg: f64,
    /// Its γ angle, degrees.
    pub max_gamma_deg: f64,
    /// Absolute photometry (no lamp flux).
    pub absolute_photometry: bool,
    /// Rated lamp flux, lm (relative photometry).
    pub lamp_flux_lm: Option<f64>,
    /// Integrated light output ratio, percent.
    pub lor_pct: Option<f64>,
    /// Declared light output ratio, percent.
    pub declared_lor_pct: Option<f64>,
    /// The file has a tilt table.
    pub tilt_include: bool,
    /// Everything suspect, in words.
    pub warnings: Vec<String>,
}

impl IntensityDistribution {
    /// Every warning about this distribution: the parser's, and the light output ratio checks
    /// (integrated flux above the rated lamp flux; a declared ratio the table does not
    /// integrate to).
    pub fn warnings(&self) -> Vec<String> {
        let mut warnings = self.meta.warnings.clone();
        if let Some(lor) = self.lor_pct() {
            if lor > 100.0 + LOR_OVER_100_PCT {
                warnings.push(format!(
                    "integrated flux exceeds the rated lamp flux (light output ratio {lor:.1} %)"
                ));
            }
            if let Some(declared) = self.meta.declared_lor_pct
                && (lor - declared).abs() > LOR_MISMATCH_REL * declared.max(1.0)
            {
                warnings.push(format!(
                    "declared light output ratio {declared} % but the table integrates to {lor:.1} %"
                ));
            }
        }
        warnings
    }

    /// The summary of this distribution, read from `file`.
    pub fn summary(&self, file: &str) -> Summary {
        let (max_cd, max_c_deg, max_gamma_deg) = self.max_intensity();
        Summary {
            file: file.to_owned(),
            format: self.format().to_string(),
            symmetry: self.symmetry().name(),
            isym: self.symmetry().isym(),
            luminaire: self.meta.luminaire.clone(),
            manufacturer: self.meta.manufacturer.clone(),
            c_planes_stored: self.stored_c_deg().len(),
            c_planes_unfolded: self.c_grid_deg().len(),
            gamma_angles: self.gamma_grid_deg().len(),
            gamma_min_deg: self.gamma_grid_deg().first().copied(),
            gamma_max_deg: self.gamma_grid_deg().last().copied(),
            flux_lm: self.flux_lm(),
            downward_flux_lm: self.zonal_flux_lm(0.0, 90.0),
            max_cd,
            max_c_deg,
            max_gamma_deg,
            absolute_photometry: self.meta.absolute,
            lamp_flux_lm: self.meta.lamp_flux_lm,
            lor_pct: self.lor_pct(),
            declared_lor_pct: self.meta.declared_lor_pct,
            tilt_include: self.meta.tilt.is_some(),
            warnings: self.warnings(),
        }
    }
}

/// "N (a .. b°, step s°)" for an angle grid, degrees.
pub fn describe_grid(v: &[f64]) -> String {
    let n = v.len();
    match v {
        [] => "none".into(),
        [only] => format!("1 ({only}°)"),
        [first, second, .., last] | [first, second @ last] => {
            let step = second - first;
            let uniform = v.windows(2).all(|w| ((w[1] - w[0]) - step).abs() < 1e-6);
            let spacing = if uniform {
                format!("step {step}°")
            } else {
                "non-uniform".into()
            };
            format!("{n} ({first} .. {last}°, {spacing})")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::describe_grid;

    #[test]
    fn grids_are_described() {
        assert_eq!(describe_grid(&[]), "none");
        assert_eq!(describe_grid(&[5.0]), "1 (5°)");
        assert_eq!(describe_grid(&[0.0, 90.0]), "2 (0 .. 90°, step 90°)");
        assert_eq!(
            describe_grid(&[0.0, 5.0, 10.0, 15.0]),
            "4 (0 .. 15°, step 5°)"
        );
        assert_eq!(
            describe_grid(&[0.0, 5.0, 15.0]),
            "3 (0 .. 15°, non-uniform)"
        );
    }
}
