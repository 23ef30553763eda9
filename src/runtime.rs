//! The run-time core: desk illuminance for any dimming state, from an [`Image`] borrowed in
//! place. `no_std`, no allocation: the caller owns every buffer.
//!
//! * [`Runtime::sensor_lux`]: superposition, `E_s = Σ_l x_l R_sl` over the stored response
//!   matrix: one multiply-add per (sensor, luminaire).
//! * [`Runtime::resolve`]: the full radiosity solve over the stored form factors (Gauss-Seidel,
//!   f64 accumulation), then the sensors' reading; agrees with superposition to the solver's
//!   tolerance, because the response matrix was computed from the same stored arrays.
//! * [`Runtime::apply_arc_levels`]: DALI arc levels to levels in [0, 1], MASK keeping the
//!   previous level.

use crate::dali::{ArcLevel, DimmingCurve};
use crate::solver::{self, SolveError, SolveOptions, SolveReport};
use crate::store::Image;

/// Why a run-time request failed; nothing is written to the output on error.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum RuntimeError {
    /// A buffer has the wrong length.
    #[error("buffer length {found}, expected {expected}")]
    Length {
        /// Expected.
        expected: usize,
        /// Found.
        found: usize,
    },
    /// A level outside [0, 1] or not finite.
    #[error("luminaire {index}: level {level} is outside [0, 1]")]
    Level {
        /// Luminaire index.
        index: usize,
        /// The level.
        level: f64,
    },
    /// The re-solve failed.
    #[error("solve: {0}")]
    Solve(SolveError),
    /// A result is not finite (cannot happen with a checked image; guarded anyway).
    #[error("a computed illuminance is not finite")]
    NonFinite,
}

/// The run-time core over one image.
#[derive(Debug, Clone, Copy)]
pub struct Runtime<'i, 'a> {
    image: &'i Image<'a>,
}

/// Superposition: `out[s] = Σ_l response(s · L + l) · levels[l]` with L = `levels.len()`,
/// after checking every level is in [0, 1]; a non-finite result is an error and nothing is
/// written then.
pub fn superpose(
    response: impl Fn(usize) -> f64,
    levels: &[f64],
    out: &mut [f64],
) -> Result<(), RuntimeError> {
    for (index, &level) in levels.iter().enumerate() {
        if !(level.is_finite() && (0.0..=1.0).contains(&level)) {
            return Err(RuntimeError::Level { index, level });
        }
    }
    let l = levels.len();
    for s in 0..out.len() {
        let acc: f64 = levels
            .iter()
            .enumerate()
            .map(|(j, x)| response(s * l + j) * x)
            .sum();
        if !acc.is_finite() {
            return Err(RuntimeError::NonFinite);
        }
    }
    for (s, o) in out.iter_mut().enumerate() {
        *o = levels
            .iter()
            .enumerate()
            .map(|(j, x)| response(s * l + j) * x)
            .sum();
    }
    Ok(())
}

fn expect_len(expected: usize, found: usize) -> Result<(), RuntimeError> {
    if expected == found {
        Ok(())
    } else {
        Err(RuntimeError::Length { expected, found })
    }
}

impl<'i, 'a> Runtime<'i, 'a> {
    /// The core over a parsed image.
    pub fn new(image: &'i Image<'a>) -> Self {
        Self { image }
    }

    /// The image.
    pub fn image(&self) -> &'i Image<'a> {
        self.image
    }

    fn check_levels(&self, levels: &[f64]) -> Result<(), RuntimeError> {
        expect_len(self.image.luminaires(), levels.len())?;
        for (index, &level) in levels.iter().enumerate() {
            if !(level.is_finite() && (0.0..=1.0).contains(&level)) {
                return Err(RuntimeError::Level { index, level });
            }
        }
        Ok(())
    }

    /// Sensor readings (lx) for `levels` (one per luminaire, in [0, 1]) by superposition.
    pub fn sensor_lux(&self, levels: &[f64], out: &mut [f64]) -> Result<(), RuntimeError> {
        expect_len(self.image.luminaires(), levels.len())?;
        expect_len(self.image.sensors(), out.len())?;
        let r = &self.image.payload.response_lx;
        superpose(|i| r.f64_at(i), levels, out)
    }

    /// Sensor readings (lx) from a full re-solve; `e` and `b` are scratch of one f64 per patch.
    pub fn resolve(
        &self,
        levels: &[f64],
        e: &mut [f64],
        b: &mut [f64],
        out: &mut [f64],
    ) -> Result<SolveReport, RuntimeError> {
        self.check_levels(levels)?;
        let n = self.image.patches();
        expect_len(n, e.len())?;
        expect_len(n, b.len())?;
        expect_len(self.image.sensors(), out.len())?;
        let p = &self.image.payload;
        for (i, ei) in e.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (j, x) in levels.iter().enumerate() {
                acc += x * p.direct_patch_lx.get(j * n + i, j);
            }
            *ei = acc;
        }
        b.iter_mut().for_each(|v| *v = 0.0);
        let options = SolveOptions {
            tolerance: p.solve_tolerance,
            max_iterations: p.solve_max_iterations,
        };
        let report = solver::gauss_seidel(&self.image.system(), e, b, options)
            .map_err(RuntimeError::Solve)?;
        if p.final_gather {
            for i in 0..n {
                b[i] -= p.rho.get(i, 0) * e[i];
            }
        }
        let l = self.image.luminaires();
        for (s, o) in out.iter_mut().enumerate() {
            let mut acc = p.gather.row_dot(s, b);
            for (j, x) in levels.iter().enumerate() {
                acc += x
                    * (p.direct_sensor_lx.f64_at(s * l + j)
                        + p.first_bounce_sensor_lx.f64_at(s * l + j));
            }
            if !acc.is_finite() {
                return Err(RuntimeError::NonFinite);
            }
            *o = acc;
        }
        Ok(report)
    }

    /// Updates `levels` from DALI arc levels on `curve`: MASK (255) keeps the previous level.
    pub fn apply_arc_levels(
        &self,
        arc: &[ArcLevel],
        curve: DimmingCurve,
        levels: &mut [f64],
    ) -> Result<(), RuntimeError> {
        expect_len(self.image.luminaires(), arc.len())?;
        expect_len(self.image.luminaires(), levels.len())?;
        for (a, l) in arc.iter().zip(levels.iter_mut()) {
            if let Some(x) = a.fraction(curve) {
                *l = x;
            }
        }
        Ok(())
    }
}

/// Number of the demo DALI states ([`demo_arc_level`]).
pub const DEMO_STATES: usize = 4;

/// The DALI states the Cortex-M firmware and `luxnode image eval --demo-states` both evaluate:
/// all at 254, all at 229 (50.5 %), a mix of levels (including 1, 0 and MASK), all off.
pub fn demo_arc_level(state: usize, luminaire: usize) -> ArcLevel {
    const MIX: [u8; 8] = [254, 229, 170, 128, 85, 1, 0, 255];
    match state {
        0 => ArcLevel(254),
        1 => ArcLevel(229),
        2 => ArcLevel(MIX[luminaire % MIX.len()]),
        _ => ArcLevel::OFF,
    }
}

/// Evaluates DALI states in sequence (logarithmic curve; MASK keeps the previous state's level,
/// starting from all off) and writes `state,sensor_id,lux_superposition,lux_resolve` lines with
/// 6 decimals: what the Cortex-M firmware prints, so host and target can be compared line by line.
/// Patch scratch lives on the heap here; the firmware uses static buffers.
#[cfg(feature = "std")]
pub fn eval_report(
    image: &Image<'_>,
    states: &[std::vec::Vec<ArcLevel>],
) -> Result<std::string::String, RuntimeError> {
    use core::fmt::Write as _;
    let rt = Runtime::new(image);
    let n = image.patches();
    let (mut e, mut b) = (std::vec![0.0; n], std::vec![0.0; n]);
    let mut levels = std::vec![0.0; image.luminaires()];
    let mut sup = std::vec![0.0; image.sensors()];
    let mut full = std::vec![0.0; image.sensors()];
    let mut out = std::string::String::from("state,sensor_id,lux_superposition,lux_resolve\n");
    for (k, arc) in states.iter().enumerate() {
        rt.apply_arc_levels(arc, DimmingCurve::Logarithmic, &mut levels)?;
        rt.sensor_lux(&levels, &mut sup)?;
        rt.resolve(&levels, &mut e, &mut b, &mut full)?;
        for s in 0..sup.len() {
            let _ = writeln!(
                out,
                "{},{},{:.6},{:.6}",
                k + 1,
                image.sensor_id(s),
                sup[s],
                full[s]
            );
        }
    }
    Ok(out)
}
