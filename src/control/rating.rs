//! A luminaire's rated input power at full output: from its photometry file's wattage where the
//! file gives one (EULUMDAT's lamp-set wattage, IES LM-63's input watts), otherwise the
//! [`DEFAULT_EFFICACY_LM_PER_W`] guess, which the caller must warn about. The same number feeds
//! control, the report's schedule and the Modbus/BACnet power points.
//!
//! Where the scene declares a flux that differs from the file's own (another lumen package of
//! the same luminaire), the file's efficacy is kept: `P = P_file · Φ / Φ_file`.

use super::{DEFAULT_EFFICACY_LM_PER_W, DEFAULT_STANDBY_W};

/// A declared flux within this fraction of the file's integrated flux is the file's own lumen
/// package (the integral differs from the stated lamp flux by the grid's quadrature).
pub const SAME_PACKAGE: f64 = 0.01;

/// Where a luminaire's rated power came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PowerSource {
    /// The photometry file's wattage (scaled by the declared over the file's flux).
    Photometry,
    /// The file gives none: flux over [`DEFAULT_EFFICACY_LM_PER_W`], a guess.
    AssumedEfficacy,
}

/// A luminaire's rated input power at full output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RatedPower {
    /// Input power at full output, W.
    pub full_w: f64,
    /// Where it came from.
    pub source: PowerSource,
}

impl RatedPower {
    /// The rating of a luminaire of `flux_lm` whose photometry file states `file_power_w`
    /// (NaN or not positive: none) at its own `file_flux_lm`.
    pub fn of(flux_lm: f64, file_power_w: f64, file_flux_lm: f64) -> Self {
        let usable = |v: f64| v.is_finite() && v > 0.0;
        if usable(file_power_w) && usable(file_flux_lm) && usable(flux_lm) {
            // the file's flux is its distribution's integral; a declared flux within
            // SAME_PACKAGE of it is the same lumen package, whose wattage the file states
            let ratio = flux_lm / file_flux_lm;
            let ratio = if (ratio - 1.0).abs() <= SAME_PACKAGE {
                1.0
            } else {
                ratio
            };
            Self {
                full_w: (file_power_w * ratio).max(DEFAULT_STANDBY_W),
                source: PowerSource::Photometry,
            }
        } else {
            Self::assumed(flux_lm)
        }
    }

    /// The guess for a luminaire of `flux_lm`: flux over [`DEFAULT_EFFICACY_LM_PER_W`].
    pub fn assumed(flux_lm: f64) -> Self {
        let flux_lm = if flux_lm.is_finite() { flux_lm } else { 0.0 };
        Self {
            full_w: (flux_lm / DEFAULT_EFFICACY_LM_PER_W).max(DEFAULT_STANDBY_W),
            source: PowerSource::AssumedEfficacy,
        }
    }
}

/// Each luminaire's rating from an image: the file wattage its geometry section records, or the
/// guess where the section or the wattage is missing (the guess's source says so).
#[cfg(feature = "std")]
pub fn rated_powers(image: &crate::store::Image<'_>) -> std::vec::Vec<RatedPower> {
    use crate::store::geometry::GeometrySection;
    let section = image
        .geometry_bytes()
        .and_then(|b| GeometrySection::decode(b).ok());
    rated_powers_in(image, section.as_ref())
}

/// [`rated_powers`] with the image's geometry section already decoded (`None`: it has none).
#[cfg(feature = "std")]
pub fn rated_powers_in(
    image: &crate::store::Image<'_>,
    section: Option<&crate::store::geometry::GeometrySection>,
) -> std::vec::Vec<RatedPower> {
    (0..image.luminaires())
        .map(|j| {
            let flux_lm = image.payload.luminaire_flux_lm.f64_at(j);
            let id = image.luminaire_id(j);
            let file = section.and_then(|s| {
                let rec = s.luminaires.iter().find(|r| r.id == id)?;
                s.photometries.get(rec.photometry as usize)
            });
            match file {
                Some(p) => RatedPower::of(flux_lm, p.power_w, p.file_flux_lm),
                None => RatedPower::assumed(flux_lm),
            }
        })
        .collect()
}

/// The ids of the luminaires whose rating is the guess, for one warning line (`None`: none).
#[cfg(feature = "std")]
pub fn assumed_warning(ids: &[u32], ratings: &[RatedPower]) -> Option<std::string::String> {
    let guessed: std::vec::Vec<std::string::String> = ids
        .iter()
        .zip(ratings)
        .filter(|(_, r)| r.source == PowerSource::AssumedEfficacy)
        .map(|(id, _)| id.to_string())
        .collect();
    (!guessed.is_empty()).then(|| {
        std::format!(
            "luminaire{} {}: the photometry gives no wattage; rated power assumed at {} lm/W \
             (set [control] rated_power_w in the board file, or use a file with its wattage)",
            if guessed.len() > 1 { "s" } else { "" },
            guessed.join(", "),
            DEFAULT_EFFICACY_LM_PER_W
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_files_wattage_is_kept_at_its_own_flux_and_scaled_at_another() {
        // office_a's file: 60 W at 7913 lm, its distribution integrating to 7913.01 lm
        let r = RatedPower::of(7913.0, 60.0, 7913.01);
        assert_eq!(r.source, PowerSource::Photometry);
        assert_eq!(r.full_w, 60.0);
        // 0.9 % more flux is still that package; 2 % more is another, at the file's efficacy
        assert_eq!(RatedPower::of(7913.0 * 1.009, 60.0, 7913.0).full_w, 60.0);
        assert!((RatedPower::of(7913.0 * 1.02, 60.0, 7913.0).full_w - 61.2).abs() < 1e-9);
        // the same luminaire declared at half the flux: the file's efficacy, 131.9 lm/W
        let half = RatedPower::of(3956.5, 60.0, 7913.0);
        assert!((half.full_w - 30.0).abs() < 1e-12);
    }

    #[test]
    fn a_file_without_wattage_falls_back_to_the_assumed_efficacy() {
        for bad in [f64::NAN, 0.0, -5.0, f64::INFINITY] {
            let r = RatedPower::of(6000.0, bad, 6000.0);
            assert_eq!(r.source, PowerSource::AssumedEfficacy);
            assert!((r.full_w - 50.0).abs() < 1e-12, "{bad}: {}", r.full_w);
        }
        // a zero file flux cannot scale a wattage
        assert_eq!(
            RatedPower::of(6000.0, 40.0, 0.0).source,
            PowerSource::AssumedEfficacy
        );
        // a dark luminaire still draws the gear's standby
        assert_eq!(RatedPower::assumed(0.0).full_w, DEFAULT_STANDBY_W);
        assert_eq!(RatedPower::assumed(f64::NAN).full_w, DEFAULT_STANDBY_W);
    }

    #[cfg(feature = "std")]
    #[test]
    fn the_warning_names_only_the_guessed_luminaires() {
        let r = [
            RatedPower::of(1000.0, 10.0, 1000.0),
            RatedPower::assumed(1200.0),
            RatedPower::assumed(1200.0),
        ];
        let w = assumed_warning(&[4, 7, 9], &r).unwrap_or_default();
        assert!(w.starts_with("luminaires 7, 9:"), "{w}");
        assert!(assumed_warning(&[4], &r[..1]).is_none());
    }
}
