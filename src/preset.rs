//! Three named trade-offs between commissioning time, image size and accuracy: `fast`,
//! `balanced` (the engine's and the store's defaults) and `accurate`. Each fixes every engine
//! knob ([`Settings`]) and the image's storage ([`StoreSettings`]); the figures measured on
//! office_a are in README.md and docs/tradeoffs.md (`luxnode bench tradeoffs`).
//!
//! Chosen from the board file (`[engine] preset = "fast"`) or on the command line
//! (`--preset fast` on `simulate`, `image build` and `commission`); single knobs given on the
//! command line override the preset's.

use std::fmt;
use std::str::FromStr;

use crate::engine::{PatchSettings, RaySetKind, Settings};
use crate::solver::SolveOptions;
use crate::store::Precision;

/// How the flash image stores a model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StoreSettings {
    /// Precision of the stored form factors and direct terms.
    pub precision: Precision,
    /// Form factors below this are dropped (rows keep their sums); 0 keeps all.
    pub prune_below: f64,
}

impl Default for StoreSettings {
    fn default() -> Self {
        Self {
            precision: Precision::U16,
            prune_below: 0.0,
        }
    }
}

/// A named set of engine and store settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Preset {
    /// For a weak processor or a quick look: coarse 2 m patches refined like balanced's, 10
    /// rays per patch, rectified, no final gather, 2 opening and 2 direct points, 8-bit form
    /// factors. Under half a per cent on office_a (docs/tradeoffs.md).
    Fast,
    /// The defaults: adaptive 1 m patches, 300 rays, exact direct light and final gather,
    /// rectified, 16-bit form factors. At the noise of the Radiance truth on office_a.
    #[default]
    Balanced,
    /// Finer patches (0.5 m) with fewer rays each (100), so that the image stays about the
    /// balanced one's size class; more sensor and final-gather rays, more opening and direct
    /// points, a tighter solver stop; 16-bit form factors. The patches are what converges the
    /// interreflected light: with the balanced 1 m patches the later bounces a sensor gathers
    /// read about 0.7 % low however many rays the rest gets (docs/accuracy.md).
    Accurate,
}

impl Preset {
    /// Every preset, fastest first.
    pub const ALL: [Preset; 3] = [Preset::Fast, Preset::Balanced, Preset::Accurate];

    /// The name used in board files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Fast => "fast",
            Preset::Balanced => "balanced",
            Preset::Accurate => "accurate",
        }
    }

    /// The engine settings.
    pub fn engine(self) -> Settings {
        let d = Settings::default();
        match self {
            Preset::Balanced => d,
            // On the speed-accuracy curve (docs/performance.md, "At equal error against
            // Radiance"): coarse 2 m patches refined where the light and detail ask for it, few
            // rays per patch (rectification restores reciprocity), no final gather, and few
            // opening and direct points: on office_a the cost is direct light on the patches and
            // the gather, not the form factors.
            Preset::Fast => Settings {
                patches: PatchSettings {
                    patch_size_m: 2.0,
                    ..d.patches
                },
                rays: 10,
                sensor_rays: 3000,
                final_gather_rays: 0,
                ray_set: RaySetKind::Isocell,
                opening_samples: 2,
                patch_direct_points: 2,
                ..d
            },
            // Half-size patches: the later bounces converge with the patch size, not with rays
            // (office_a's interreflected light: −0.7 % at 1 m, −0.2 % at 0.5 m, 0.0 % at 0.35 m;
            // docs/accuracy.md). 100 rays per patch keep the image in the FORMFACTORS region
            // (office_a: 90 % at 0.5 m; 150 rays would not fit) and cost no accuracy with the final
            // gather carrying the first bounce.
            Preset::Accurate => Settings {
                patches: PatchSettings {
                    patch_size_m: 0.5,
                    ..d.patches
                },
                rays: 100,
                sensor_rays: 30_000,
                final_gather_rays: 3000,
                opening_samples: 32,
                patch_direct_points: 8,
                solve: SolveOptions {
                    tolerance: 1e-12,
                    ..d.solve
                },
                ..d
            },
        }
    }

    /// The store settings.
    pub fn store(self) -> StoreSettings {
        match self {
            Preset::Fast => StoreSettings {
                precision: Precision::U8,
                prune_below: 0.0,
            },
            Preset::Balanced => StoreSettings::default(),
            // f32 would not fit the FORMFACTORS region at 1000 rays per patch (5.6 MB on
            // office_a); u16 is as accurate (docs/tradeoffs.md)
            Preset::Accurate => StoreSettings::default(),
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown preset name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown preset {0:?}: use \"fast\", \"balanced\" or \"accurate\"")]
pub struct UnknownPreset(pub String);

impl FromStr for Preset {
    type Err = UnknownPreset;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| UnknownPreset(s.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_balanced_is_the_default() {
        for p in Preset::ALL {
            assert_eq!(p.name().parse::<Preset>(), Ok(p));
        }
        assert!("Fast".parse::<Preset>().is_err());
        assert_eq!(Preset::default().engine(), Settings::default());
        assert_eq!(Preset::default().store(), StoreSettings::default());
    }

    #[test]
    fn presets_order_cost() {
        let (f, b, a) = (
            Preset::Fast.engine(),
            Preset::Balanced.engine(),
            Preset::Accurate.engine(),
        );
        assert!(f.rays < b.rays);
        // the accurate preset spends its rays on finer patches
        assert!(a.patches.patch_size_m < b.patches.patch_size_m);
        assert!(a.patches.patch_size_m < f.patches.patch_size_m);
        assert!(b.opening_samples < a.opening_samples);
        assert!(f.final_gather_rays < b.final_gather_rays);
        assert!(b.final_gather_rays < a.final_gather_rays);
        assert!(
            Preset::Fast.store().precision.width() < Preset::Accurate.store().precision.width()
        );
    }
}
