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

pub use crate::store::live::{OCCLUDER_GROUPS, UNCERTAINTY_PARTS};

/// The standard uncertainty of a desk's modelled light in a dimming state, lx, from its parts
/// per luminaire at 100 % (`part(l, k)`, `k` < [`UNCERTAINTY_PARTS`]), its luminaires' occluder
/// groups (`group(l)`, 0 to [`OCCLUDER_GROUPS`]) and the levels (in [0, 1]):
/// `√(Σ_c (Σ_l x_l Δ_lc)² + o²)`. Each reflectance class is shared by every luminaire (their
/// changes add before squaring; the light is linear in the emission) and the classes are
/// independent of each other. An unseen object shades one luminaire (group 0) or, standing at
/// a back edge of the desk, every luminaire of its edge's group together:
/// `o = max(max_{g(l)=0} x_l o_l, max_{g≥1} Σ_{g(l)=g} x_l o_l)`.
pub fn state_uncertainty_lx(
    part: impl Fn(usize, usize) -> f64,
    group: impl Fn(usize) -> u8,
    levels: &[f64],
) -> f64 {
    uncertainty_at(&part, &group, |l| levels[l], levels.len())
}

fn uncertainty_at(
    part: &impl Fn(usize, usize) -> f64,
    group: &impl Fn(usize) -> u8,
    x: impl Fn(usize) -> f64,
    n: usize,
) -> f64 {
    let mut var = 0.0;
    for c in 0..UNCERTAINTY_PARTS - 1 {
        let d: f64 = (0..n).map(|l| x(l) * part(l, c)).sum();
        var += d * d;
    }
    let shaded = |l: usize| x(l) * part(l, UNCERTAINTY_PARTS - 1);
    let alone = (0..n)
        .filter(|&l| group(l) == 0)
        .map(shaded)
        .fold(0.0, f64::max);
    // each group once, from its first luminaire (none in an image without groups)
    let mut occluder = alone;
    for l in 0..n {
        let g = group(l);
        if g == 0 || (0..l).any(|k| group(k) == g) {
            continue;
        }
        let sum: f64 = (l..n).filter(|&k| group(k) == g).map(shaded).sum();
        occluder = occluder.max(sum);
    }
    libm::sqrt(var + occluder * occluder)
}

/// A desk's stated relative uncertainty of its modelled light in a dimming state (`levels`),
/// from the one stated with every luminaire on (`stated_all_on`, NaN: not stated), its
/// uncertainty parts per luminaire and their occluder groups ([`state_uncertainty_lx`]'s `part`
/// and `group`) and its response per
/// luminaire at 100 % (`response(l)`, lx). With one or two luminaires on, a desk's light is
/// more interreflected than with all (farther luminaires reach it through the ceiling and the
/// walls), so the reflectances weigh more: `u(x) / E(x)`. Where the all-on statement was
/// widened beyond its parts (the model disagreed with the camera at the desk, or the camera
/// calibrated it), it stays the floor. A state without light keeps the all-on statement.
pub fn state_rel_uncertainty(
    stated_all_on: f64,
    part: impl Fn(usize, usize) -> f64,
    group: impl Fn(usize) -> u8,
    response: impl Fn(usize) -> f64,
    levels: &[f64],
) -> f64 {
    let n = levels.len();
    let lit: f64 = (0..n).map(|l| levels[l] * response(l)).sum();
    let all: f64 = (0..n).map(&response).sum();
    if !(stated_all_on.is_finite() && lit > 0.0 && all > 0.0) {
        return stated_all_on;
    }
    let at = uncertainty_at(&part, &group, |l| levels[l], n) / lit;
    let parts_all_on = uncertainty_at(&part, &group, |_| 1.0, n) / all;
    // the all-on statement above its parts (beyond the f32 parts' rounding) was widened
    if stated_all_on > 1.01 * parts_all_on + 1e-4 {
        at.max(stated_all_on)
    } else {
        at
    }
}

/// [`state_rel_uncertainty`] over one desk's flat rows: `parts` its uncertainty parts
/// (`[luminaire][part]`, [`UNCERTAINTY_PARTS`] each), `groups` its occluder groups (one per
/// luminaire; empty: every luminaire alone) and `response` its response per luminaire, lx, for
/// `levels.len()` luminaires; rows of another length (no parts stored) give the all-on
/// statement.
pub fn state_rel_uncertainty_of_rows(
    stated_all_on: f64,
    parts: &[f64],
    groups: &[u8],
    response: &[f64],
    levels: &[f64],
) -> f64 {
    let l = levels.len();
    if l == 0 || parts.len() != l * UNCERTAINTY_PARTS || response.len() != l {
        return stated_all_on;
    }
    state_rel_uncertainty(
        stated_all_on,
        |j, c| parts[j * UNCERTAINTY_PARTS + c],
        |j| groups.get(j).copied().unwrap_or(0),
        |j| response[j],
        levels,
    )
}

/// Sensor `k`'s stated relative uncertainty of its modelled light in a dimming state
/// (`levels`, one per luminaire in [0, 1]; [`state_rel_uncertainty`] over the image's live
/// section): the all-on statement when the image has no parts per luminaire; `None`: not stated.
pub fn model_rel_uncertainty_at(image: &Image<'_>, k: usize, levels: &[f64]) -> Option<f64> {
    let live = image.live.as_ref()?;
    let stated = live.model_rel_uncertainty(k)?;
    let l = image.luminaires();
    if levels.len() != l || !live.has_uncertainty_parts() || k >= image.sensors() {
        return Some(stated);
    }
    let part = |j: usize, c: usize| live.uncertainty_part_lx(k, j, c, l);
    Some(state_rel_uncertainty(
        stated,
        part,
        |j| live.occluder_group(k, j, l),
        |j| image.response_lx(k, j),
        levels,
    ))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Two luminaires: the near one gives 1000 lx, the far one 100 lx (through the ceiling);
    /// the ceiling's reflectance moves each by 10 lx, an unseen object could shade 40 lx of
    /// the near one and 5 lx of the far one.
    fn part(l: usize, k: usize) -> f64 {
        match (l, k) {
            (_, 1) => 10.0,
            (0, 6) => 40.0,
            (1, 6) => 5.0,
            _ => 0.0,
        }
    }

    fn response(l: usize) -> f64 {
        [1000.0, 100.0][l]
    }

    fn alone(_: usize) -> u8 {
        0
    }

    /// `state_uncertainty_lx` of these groups at these levels against its closed form.
    fn assert_state(groups: fn(usize) -> u8, levels: &[f64], want_lx: f64) {
        let got = state_uncertainty_lx(part, groups, levels);
        assert!(
            (got - want_lx).abs() < 1e-9,
            "{levels:?}: {got} for {want_lx}"
        );
    }

    #[test]
    fn the_uncertainty_of_a_state_in_closed_form() {
        // all on: √(20² + 40²) = 44.72 lx; near only: √(10² + 40²); far only: √(10² + 5²)
        assert_state(alone, &[1.0, 1.0], 20f64.hypot(40.0));
        assert_state(alone, &[1.0, 0.0], 10f64.hypot(40.0));
        assert_state(alone, &[0.0, 1.0], 10f64.hypot(5.0));
        // half the far one: the class adds linearly, the occluder takes the largest
        assert_state(alone, &[0.0, 0.5], 5f64.hypot(2.5));
        assert_state(alone, &[0.0, 0.0], 0.0);
    }

    #[test]
    fn one_object_at_a_back_edge_shades_its_group_together() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        // both luminaires behind the same back edge (group 2): their parts add, 40 + 5
        let edge = |_: usize| 2u8;
        assert_state(edge, &[1.0, 1.0], 20f64.hypot(45.0));
        // one of them lit: its part alone
        assert_state(edge, &[0.0, 1.0], 10f64.hypot(5.0));
        assert_state(edge, &[0.5, 1.0], 15f64.hypot(25.0));
        // behind different edges, or one alone: the larger of them
        let apart = |l: usize| [1u8, 3][l];
        assert_state(apart, &[1.0, 1.0], 20f64.hypot(40.0));
        let mixed = |l: usize| [0u8, 4][l];
        assert_state(mixed, &[1.0, 1.0], 20f64.hypot(40.0));
        // the flat rows read the same groups (empty: alone)
        let parts: Vec<f64> = (0..2)
            .flat_map(|l| (0..UNCERTAINTY_PARTS).map(move |c| part(l, c)))
            .collect();
        let resp = [1000.0, 100.0];
        let stated = 20f64.hypot(45.0) / 1100.0;
        let grouped = state_rel_uncertainty_of_rows(stated, &parts, &[2, 2], &resp, &[1.0, 1.0]);
        assert!(close(grouped, stated));
        let single = state_rel_uncertainty_of_rows(stated, &parts, &[], &resp, &[1.0, 1.0]);
        // the all-on statement (45 lx of occluder) is above the ungrouped parts' 40: it stays
        assert!(close(single, stated));
        let lone = state_rel_uncertainty_of_rows(stated, &parts, &[], &resp, &[1.0, 0.0]);
        assert!(close(lone, stated.max(10f64.hypot(40.0) / 1000.0)));
    }

    #[test]
    fn a_state_lit_through_the_ceiling_states_more_and_a_widened_statement_stays_the_floor() {
        let all_on = 20f64.hypot(40.0) / 1100.0;
        // stated as the parts give it: each state its own
        let near = state_rel_uncertainty(all_on, part, alone, response, &[1.0, 0.0]);
        let far = state_rel_uncertainty(all_on, part, alone, response, &[0.0, 1.0]);
        let all = state_rel_uncertainty(all_on, part, alone, response, &[1.0, 1.0]);
        assert!((all - all_on).abs() < 1e-12);
        assert!((near - 10f64.hypot(40.0) / 1000.0).abs() < 1e-12);
        assert!((far - 10f64.hypot(5.0) / 100.0).abs() < 1e-12);
        assert!(far > 2.5 * all);
        // widened at commissioning to 10 % (the camera disagreed): never below it
        assert_eq!(
            state_rel_uncertainty(0.10, part, alone, response, &[1.0, 0.0]),
            0.10
        );
        assert!(
            (state_rel_uncertainty(0.10, part, alone, response, &[0.0, 1.0]) - far).abs() < 1e-12
        );
        // not stated, or no light: the all-on statement as it is
        assert!(state_rel_uncertainty(f64::NAN, part, alone, response, &[0.0, 1.0]).is_nan());
        assert_eq!(
            state_rel_uncertainty(0.04, part, alone, response, &[0.0, 0.0]),
            0.04
        );
    }
}
