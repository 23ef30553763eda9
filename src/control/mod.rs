//! Lighting control: every desk at its target illuminance for the least electric power, with
//! the daylight each desk already has. `no_std`, no allocation (the caller owns every buffer),
//! so the optimiser and its state run on the node and on a microcontroller alike.
//!
//! ## The model
//!
//! * **Response** `R_kj`: lux on desk k from luminaire j at full output (the image's response
//!   matrix, times each luminaire's ageing factor once live light measures it). Illuminance is
//!   linear in the luminaires' outputs (superposition), so desk k gets
//!   `E_k = Σ_j R_kj x_j + D_k` with `x_j ∈ [0, 1]` the light output of luminaire j and `D_k`
//!   the daylight (any light the model does not know) on desk k.
//! * **Power** ([`LuminairePower`]): `P_j = P_standby + (P_full − P_standby) x_j` while on,
//!   `P_standby` off (the DALI gear stays powered). LED drivers are close to linear in output
//!   above their physical minimum level; the minimum level (`min_arc`, DALI PHM) is the lowest
//!   output a luminaire can be on at.
//! * **Targets** `T_k`: maintained illuminance per desk (EN 12464-1 office work: 500 lx).
//!
//! ## The optimiser ([`optimise`])
//!
//! Minimise `Σ_j (P_full − P_standby)_j x_j` subject to `E_k ≥ T_k` for every desk (and, if
//! asked, `E_k ≥ u · mean(E)`), `0 ≤ x ≤ 1`: a linear programme, solved exactly ([`lp`]). A
//! target no state can meet is not an error: its shortfall is priced above all the power there
//! is, so the answer is the closest feasible state (least total relative shortfall, then least
//! power) and the desk is flagged short. The continuous optimum is then set in DALI arc levels
//! (logarithmic curve, 254 steps of 2.8 %): each output is rounded *up* to a level (so no desk
//! falls below its target) and at least the luminaire's minimum level, then levels are stepped
//! down again, the largest power saving first, while every target still holds.
//!
//! Why an own simplex rather than an LP crate: the node's control loop and the microcontroller
//! variant need it without std and without a heap (the LP crates allocate: `microlp`,
//! `minilp`, `good_lp`'s back ends); the problem has a structure a general solver does not
//! use: its dual has one row per luminaire and a feasible slack basis (no phase 1), the
//! shortfall prices are bounds rather than rows, each luminaire's two bound columns are one
//! column up to sign, and the tableau needs only the nonbasic columns ([`lp`]). It is exact
//! (the tests compare it with the independent `microlp` solver and with brute force) and, for
//! 64 luminaires and 100 desks, about twenty times faster than `microlp` (docs/control.md).

pub mod lp;
pub mod rating;
pub mod regulator;

use core::fmt;

use crate::dali::{ArcLevel, DimmingCurve};

/// Maintained illuminance on an office desk (EN 12464-1, writing, typing, reading), lx.
pub const DEFAULT_TARGET_LX: f64 = 500.0;

/// Whether someone is at a desk, as the control loop takes it (occupancy after its hold).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Presence {
    /// A person at the desk, or seen there within the hold.
    Occupied,
    /// Nobody there for longer than the hold, and the desk's zone seen.
    Vacant,
    /// Not known (occupancy off, the desk not seen, no usable depth, not a desk).
    Unknown,
}

/// What a vacant desk is lit to (board `[control] vacant`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VacantLight {
    /// The immediate surrounding area's level for the desk's target (EN 12464-1:2011
    /// Table 1: 500 → 300 lx): a desk nobody is at is still someone's surroundings.
    #[default]
    Surrounding,
    /// Nothing: the desk's light may go (its neighbours' targets still hold).
    Off,
}

impl VacantLight {
    /// From its name in board files and on the command line: `surrounding` or `off`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "surrounding" => Some(Self::Surrounding),
            "off" => Some(Self::Off),
            _ => None,
        }
    }
}

/// A desk's demand on the control loop by its presence (issue 29 item 3): occupied → its
/// target; vacant → [`VacantLight`] (never above the target); unknown → its target (fail
/// bright: a desk the node cannot see may have someone at it).
#[cfg(feature = "std")]
pub fn presence_demand_lx(target_lx: f64, presence: Presence, vacant: VacantLight) -> f64 {
    match (presence, vacant) {
        (Presence::Occupied | Presence::Unknown, _) => target_lx,
        (Presence::Vacant, VacantLight::Surrounding) => {
            crate::en12464::immediate_surrounding_lx(target_lx).min(target_lx)
        }
        (Presence::Vacant, VacantLight::Off) => 0.0,
    }
}
/// Luminous efficacy assumed when a board gives no rated power: a luminaire's rated power is
/// its flux over this, lm/W (a current LED office luminaire).
pub const DEFAULT_EFFICACY_LM_PER_W: f64 = 120.0;
/// Standby power of DALI gear that is off, W (IEC 62386-102 gear draws well under 0.5 W).
pub const DEFAULT_STANDBY_W: f64 = 0.3;
/// The physical minimum arc level assumed when a board gives none (DALI PHM; 85 is 1 %).
pub const DEFAULT_MIN_ARC: u8 = 85;
/// How much more one unit of relative shortfall costs than all the luminaires at full.
const SHORTFALL_PRICE: f64 = 1e4;
/// Outputs below this are off.
const OFF_BELOW: f64 = 1e-9;

/// One luminaire's electric power against its output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LuminairePower {
    /// Rated input power at full output, W.
    pub full_w: f64,
    /// Input power when off (gear powered), W.
    pub standby_w: f64,
    /// The lowest arc level it can be on at (physical minimum level), 1..=254.
    pub min_arc: u8,
}

impl LuminairePower {
    /// The defaults for a luminaire of `flux_lm`: [`DEFAULT_EFFICACY_LM_PER_W`],
    /// [`DEFAULT_STANDBY_W`], [`DEFAULT_MIN_ARC`].
    pub fn for_flux(flux_lm: f64) -> Self {
        Self::rated(rating::RatedPower::assumed(flux_lm))
    }

    /// A luminaire of a [`rating::RatedPower`], with [`DEFAULT_STANDBY_W`] and
    /// [`DEFAULT_MIN_ARC`].
    pub fn rated(r: rating::RatedPower) -> Self {
        Self {
            full_w: r.full_w,
            standby_w: DEFAULT_STANDBY_W.min(r.full_w),
            min_arc: DEFAULT_MIN_ARC,
        }
    }

    /// Input power at a light output fraction (0: off), W.
    pub fn power_w(&self, output: f64) -> f64 {
        if output <= 0.0 {
            self.standby_w
        } else {
            self.standby_w + (self.full_w - self.standby_w) * output.min(1.0)
        }
    }

    /// W per unit of output above standby.
    pub fn slope_w(&self) -> f64 {
        (self.full_w - self.standby_w).max(0.0)
    }

    fn check(&self) -> bool {
        self.full_w.is_finite()
            && self.standby_w.is_finite()
            && self.standby_w >= 0.0
            && self.full_w >= self.standby_w
            && (1..=254).contains(&self.min_arc)
    }
}

/// The room as the optimiser sees it.
#[derive(Debug, Clone, Copy)]
pub struct Plant<'a> {
    /// Desks.
    pub desks: usize,
    /// Luminaires.
    pub luminaires: usize,
    /// `R_kj`, lx on desk k from luminaire j at full output, row-major (`k * luminaires + j`).
    pub response_lx: &'a [f64],
    /// Power model per luminaire.
    pub power: &'a [LuminairePower],
    /// The gear's dimming curve.
    pub curve: DimmingCurve,
}

/// What the desks need.
#[derive(Debug, Clone, Copy)]
pub struct Demand<'a> {
    /// Target (maintained) illuminance per desk, lx.
    pub target_lx: &'a [f64],
    /// Daylight (light the model does not know) per desk, lx; zeros when unknown.
    pub daylight_lx: &'a [f64],
    /// Optional uniformity: every desk at least this fraction of the mean desk illuminance.
    pub uniformity: Option<f64>,
}

/// Why no plan was made (all are input errors: a valid plant and demand always have a plan).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ControlError {
    /// A length does not match the plant.
    Shape,
    /// A response, target, daylight or power value is not usable (not finite, negative).
    Input(&'static str),
    /// The scratch is too short.
    Scratch {
        /// Needed, f64s.
        needed: usize,
        /// Given.
        given: usize,
    },
    /// The linear programme failed.
    Lp(lp::LpError),
}

impl fmt::Display for ControlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ControlError::Shape => f.write_str("control: lengths do not match the plant"),
            ControlError::Input(what) => write!(f, "control: unusable {what}"),
            ControlError::Scratch { needed, given } => {
                write!(f, "control: scratch of {given} values, {needed} needed")
            }
            ControlError::Lp(e) => write!(f, "control: {e}"),
        }
    }
}

impl core::error::Error for ControlError {}

/// The plan's outputs, written into the caller's slices.
#[derive(Debug)]
pub struct PlanOut<'a> {
    /// Arc level per luminaire.
    pub arc: &'a mut [ArcLevel],
    /// Illuminance each desk will get (artificial at the plan + daylight), lx.
    pub lux: &'a mut [f64],
    /// Whether each desk meets its target (and the uniformity, if asked).
    pub met: &'a mut [bool],
}

/// The plan in numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanReport {
    /// Total input power of the plan, W (standby of luminaires off included).
    pub power_w: f64,
    /// Total input power with every luminaire at full, W.
    pub all_on_w: f64,
    /// The linear programme's optimum as power, W (continuous outputs: a lower bound).
    pub lp_power_w: f64,
    /// Desks short of their target.
    pub short: usize,
    /// Simplex iterations.
    pub iterations: u32,
}

/// A plan with owned outputs: what hosts, benches and tests use ([`plan`], [`photocell`]); the
/// node's loop keeps [`optimise`] over its own buffers.
#[cfg(feature = "std")]
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Arc level per luminaire.
    pub arc: Vec<ArcLevel>,
    /// Illuminance each desk will get (artificial at the plan + daylight), lx.
    pub lux: Vec<f64>,
    /// Whether each desk meets its target (and the uniformity, if asked).
    pub met: Vec<bool>,
    /// The plan in numbers.
    pub report: PlanReport,
}

#[cfg(feature = "std")]
impl Plan {
    fn with(
        plant: &Plant<'_>,
        f: impl FnOnce(PlanOut<'_>) -> Result<PlanReport, ControlError>,
    ) -> Result<Self, ControlError> {
        let (kd, l) = (plant.desks, plant.luminaires);
        let (mut arc, mut lux, mut met) = (vec![ArcLevel::OFF; l], vec![0.0; kd], vec![false; kd]);
        let report = f(PlanOut {
            arc: &mut arc,
            lux: &mut lux,
            met: &mut met,
        })?;
        Ok(Self {
            arc,
            lux,
            met,
            report,
        })
    }
}

/// [`optimise`] with owned outputs and scratch.
#[cfg(feature = "std")]
pub fn plan(plant: &Plant<'_>, demand: &Demand<'_>) -> Result<Plan, ControlError> {
    let mut scratch =
        vec![0.0; scratch_len(plant.desks, plant.luminaires, demand.uniformity.is_some())];
    Plan::with(plant, |out| optimise(plant, demand, out, &mut scratch))
}

/// [`photocell_plan`] with owned outputs.
#[cfg(feature = "std")]
pub fn photocell(plant: &Plant<'_>, demand: &Demand<'_>) -> Result<Plan, ControlError> {
    Plan::with(plant, |out| photocell_plan(plant, demand, out))
}

/// Rows of the programme.
fn rows(desks: usize, uniformity: bool) -> usize {
    if uniformity { 2 * desks } else { desks }
}

/// Scratch f64s [`optimise`] needs.
pub const fn scratch_len(desks: usize, luminaires: usize, uniformity: bool) -> usize {
    let rows = if uniformity { 2 * desks } else { desks };
    // a, b, c, m, x (continuous), x (quantised), lux of the LP, the exchange's trial outputs,
    // steps up and covers, its deficits and each desk's best two lux per watt, then the LP's
    // tableau
    rows * luminaires + 2 * rows + 7 * luminaires + 6 * desks + lp::scratch_len(rows, luminaires)
}

/// The arc level of at least `output` on `curve` (the smallest such level), at least
/// `min_arc`; 0 for outputs that are off.
pub fn arc_at_least(output: f64, min_arc: u8, curve: DimmingCurve) -> ArcLevel {
    if output <= OFF_BELOW {
        return ArcLevel::OFF;
    }
    let mut n = ArcLevel::nearest(output.min(1.0), curve)
        .map_or(254, |a| a.0)
        .max(min_arc);
    while n < 254 && fraction(ArcLevel(n), curve) < output * (1.0 - 1e-12) {
        n += 1;
    }
    while n > min_arc && fraction(ArcLevel(n - 1), curve) >= output * (1.0 - 1e-12) {
        n -= 1;
    }
    ArcLevel(n)
}

fn fraction(a: ArcLevel, curve: DimmingCurve) -> f64 {
    a.fraction(curve).unwrap_or(0.0)
}

/// The next lower level a luminaire can be at: one step down, or off from its minimum.
fn step_down(a: ArcLevel, min_arc: u8) -> ArcLevel {
    if a.0 <= min_arc {
        ArcLevel::OFF
    } else {
        ArcLevel(a.0 - 1)
    }
}

/// Desk illuminances of a set of outputs: `lux_k = Σ_j R_kj x_j + D_k`.
pub fn desk_lux(plant: &Plant<'_>, daylight_lx: &[f64], x: &[f64], lux: &mut [f64]) {
    let l = plant.luminaires;
    for (k, e) in lux.iter_mut().enumerate() {
        let row = &plant.response_lx[k * l..(k + 1) * l];
        *e = row.iter().zip(x).map(|(r, x)| r * x).sum::<f64>() + daylight_lx[k];
    }
}

/// Whether every desk that can be met is, within `tolerance_lx` (uniformity included).
fn met(lux: &[f64], demand: &Demand<'_>, tolerance_lx: f64, out: &mut [bool]) -> usize {
    let mean = lux.iter().sum::<f64>() / lux.len().max(1) as f64;
    let mut short = 0;
    for (k, m) in out.iter_mut().enumerate() {
        let mut ok = lux[k] >= demand.target_lx[k] - tolerance_lx;
        if let Some(u) = demand.uniformity {
            ok &= lux[k] >= u * mean - tolerance_lx;
        }
        *m = ok;
        short += usize::from(!ok);
    }
    short
}

fn check(plant: &Plant<'_>, demand: &Demand<'_>, out: &PlanOut<'_>) -> Result<(), ControlError> {
    let (k, l) = (plant.desks, plant.luminaires);
    if plant.response_lx.len() != k * l
        || plant.power.len() != l
        || demand.target_lx.len() != k
        || demand.daylight_lx.len() != k
        || out.arc.len() != l
        || out.lux.len() != k
        || out.met.len() != k
    {
        return Err(ControlError::Shape);
    }
    let ok = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
    if !ok(plant.response_lx) {
        return Err(ControlError::Input("response (lx)"));
    }
    if !ok(demand.target_lx) || demand.target_lx.iter().any(|&t| t > 1e6) {
        return Err(ControlError::Input("target (lx)"));
    }
    if !ok(demand.daylight_lx) {
        return Err(ControlError::Input("daylight (lx)"));
    }
    if !plant.power.iter().all(LuminairePower::check) {
        return Err(ControlError::Input("luminaire power"));
    }
    if let Some(u) = demand.uniformity
        && !(u.is_finite() && (0.0..=1.0).contains(&u))
    {
        return Err(ControlError::Input("uniformity"));
    }
    Ok(())
}

/// The least-power plan that meets every desk's target (or comes closest), in DALI levels.
pub fn optimise(
    plant: &Plant<'_>,
    demand: &Demand<'_>,
    out: PlanOut<'_>,
    scratch: &mut [f64],
) -> Result<PlanReport, ControlError> {
    check(plant, demand, &out)?;
    let (kd, l) = (plant.desks, plant.luminaires);
    let uni = demand.uniformity.is_some();
    let nr = rows(kd, uni);
    let needed = scratch_len(kd, l, uni);
    if scratch.len() < needed {
        return Err(ControlError::Scratch {
            needed,
            given: scratch.len(),
        });
    }
    let (a, rest) = scratch.split_at_mut(nr * l);
    let (b, rest) = rest.split_at_mut(nr);
    let (m, rest) = rest.split_at_mut(nr);
    let (c, rest) = rest.split_at_mut(l);
    let (x, rest) = rest.split_at_mut(l);
    let (xq, rest) = rest.split_at_mut(l);
    let (lux_lp, rest) = rest.split_at_mut(kd);
    let (exchange, tableau) = rest.split_at_mut(4 * l + 5 * kd);
    for (cj, p) in c.iter_mut().zip(plant.power) {
        *cj = p.slope_w();
    }
    let total_slope: f64 = c.iter().sum();
    let price = SHORTFALL_PRICE * (total_slope + 1.0);
    let r = plant.response_lx;
    for k in 0..kd {
        a[k * l..(k + 1) * l].copy_from_slice(&r[k * l..(k + 1) * l]);
        b[k] = demand.target_lx[k] - demand.daylight_lx[k];
        m[k] = price / demand.target_lx[k].max(1.0);
    }
    if let Some(u) = demand.uniformity {
        // E_k ≥ u mean(E):  Σ_j (R_kj − u R̄_j) x_j ≥ u D̄ − D_k
        let inv = 1.0 / kd.max(1) as f64;
        let d_mean = demand.daylight_lx.iter().sum::<f64>() * inv;
        for k in 0..kd {
            let row = kd + k;
            for j in 0..l {
                let mean_j = (0..kd).map(|i| r[i * l + j]).sum::<f64>() * inv;
                a[row * l + j] = r[k * l + j] - u * mean_j;
            }
            b[row] = u * d_mean - demand.daylight_lx[k];
            m[row] = price / demand.target_lx[k].max(1.0);
        }
    }
    let problem = lp::Lp {
        rows: nr,
        luminaires: l,
        a,
        b,
        c,
        m,
        max_iterations: 50 * (nr + l) as u32 + 1000,
    };
    let report = problem.solve(x, tableau).map_err(ControlError::Lp)?;
    let lp_power_w: f64 = plant
        .power
        .iter()
        .zip(x.iter())
        .map(|(p, &x)| p.standby_w + p.slope_w() * x)
        .sum();
    // which desks the continuous optimum meets: the rounding must keep those met, and no desk
    // may end darker than the optimum left it
    desk_lux(plant, demand.daylight_lx, x, lux_lp);
    let floor = lux_lp;
    for (k, f) in floor.iter_mut().enumerate() {
        let t = demand.target_lx[k];
        let tol = 1e-6 * t.max(1.0);
        *f = if *f >= t - tol { t - tol } else { *f - tol };
    }
    // round every output up to a level, at least the minimum level
    for j in 0..l {
        out.arc[j] = arc_at_least(x[j], plant.power[j].min_arc, plant.curve);
        xq[j] = fraction(out.arc[j], plant.curve);
    }
    desk_lux(plant, demand.daylight_lx, xq, out.lux);
    // step levels down again, the largest saving first, while every desk holds
    for _ in 0..(l * 255) {
        let mut best: Option<(usize, f64, f64)> = None; // (luminaire, Δx, saving W)
        for j in 0..l {
            if out.arc[j] == ArcLevel::OFF {
                continue;
            }
            let down = step_down(out.arc[j], plant.power[j].min_arc);
            let dx = xq[j] - fraction(down, plant.curve);
            let saving = plant.power[j].slope_w() * dx;
            if best.is_some_and(|(_, _, s)| s >= saving) {
                continue;
            }
            let desks_hold = (0..kd).all(|k| out.lux[k] - r[k * l + j] * dx >= floor[k]);
            let uniform = demand
                .uniformity
                .is_none_or(|u| uniform_after(r, l, out.lux, j, dx, u));
            if desks_hold && uniform {
                best = Some((j, dx, saving));
            }
        }
        let Some((j, dx, _)) = best else {
            break;
        };
        out.arc[j] = step_down(out.arc[j], plant.power[j].min_arc);
        xq[j] = fraction(out.arc[j], plant.curve);
        for k in 0..kd {
            out.lux[k] -= r[k * l + j] * dx;
        }
    }
    if demand.uniformity.is_none() {
        exchange_down(plant, floor, out.arc, xq, out.lux, exchange);
    }
    desk_lux(plant, demand.daylight_lx, xq, out.lux);
    let short = met(out.lux, demand, 1e-6 * DEFAULT_TARGET_LX, out.met);
    let power_w = plant
        .power
        .iter()
        .zip(xq.iter())
        .map(|(p, &x)| p.power_w(x))
        .sum();
    let all_on_w = plant.power.iter().map(|p| p.full_w).sum();
    Ok(PlanReport {
        power_w,
        all_on_w,
        lp_power_w,
        short,
        iterations: report.iterations,
    })
}

/// Exchange passes after the greedy descent.
const EXCHANGE_PASSES: usize = 4;

/// The level above `a` (from off: the minimum level); `None` at full.
fn step_up(a: ArcLevel, min_arc: u8) -> Option<ArcLevel> {
    match a.0 {
        0 => Some(ArcLevel(min_arc)),
        254.. => None,
        n => Some(ArcLevel(n + 1)),
    }
}

/// Local search over DALI levels: one luminaire one step down, the desks it would leave short
/// covered by stepping others up (the most lux per watt first), kept when it saves power. The
/// greedy descent alone stops where no single step down is possible; rounding each output up on
/// its own loses up to one 2.8 % step per luminaire, which this wins back.
fn exchange_down(
    plant: &Plant<'_>,
    floor: &[f64],
    arc: &mut [ArcLevel],
    xq: &mut [f64],
    lux: &mut [f64],
    work: &mut [f64],
) {
    let (kd, l, r) = (plant.desks, plant.luminaires, plant.response_lx);
    let (trial_x, rest) = work.split_at_mut(l);
    let (trial_arc, rest) = rest.split_at_mut(l);
    let (up_dx, rest) = rest.split_at_mut(l); // each luminaire's next step up (0: none)
    let (cover, rest) = rest.split_at_mut(l); // the deficit each step up would cover, lx
    let (deficit, rest) = rest.split_at_mut(kd);
    let (short, rest) = rest.split_at_mut(kd); // indices of the desks in deficit
    // per desk: the most lux per watt any luminaire adds, the second most, and whose the most
    // is. Covering a deficit d of desk k costs at least d / (most lux per watt of the others):
    // a bound that ends a trial as soon as it cannot pay (the same trials succeed, sooner)
    let (best, rest) = rest.split_at_mut(kd);
    let (second, rest) = rest.split_at_mut(kd);
    let best_of = &mut rest[..kd];
    best_lux_per_watt(plant, best, second, best_of);
    // the least cost of covering the deficits left without luminaire j, W
    let bound = |deficit: &[f64], short: &[f64], j: usize| -> f64 {
        let mut most = 0.0f64;
        for (d, s) in deficit.iter().zip(short) {
            if *d > 0.0 {
                let k = *s as usize;
                let ratio = if best_of[k] as usize == j {
                    second[k]
                } else {
                    best[k]
                };
                most = most.max(if ratio > 0.0 {
                    d / ratio
                } else {
                    f64::INFINITY
                });
            }
        }
        most
    };
    let frac = |a: ArcLevel| fraction(a, plant.curve);
    for _ in 0..EXCHANGE_PASSES {
        let mut improved = false;
        for j in 0..l {
            if arc[j] == ArcLevel::OFF {
                continue;
            }
            let pj = plant.power[j];
            let down = step_down(arc[j], pj.min_arc);
            let dxj = xq[j] - frac(down);
            let saving = pj.slope_w() * dxj;
            // the desks this step would leave short
            let mut n_short = 0;
            for k in 0..kd {
                let d = floor[k] - (lux[k] - r[k * l + j] * dxj);
                if d > 0.0 {
                    deficit[n_short] = d;
                    short[n_short] = k as f64;
                    n_short += 1;
                }
            }
            if n_short == 0 {
                continue;
            }
            if bound(&deficit[..n_short], &short[..n_short], j) >= saving {
                continue;
            }

            trial_x.copy_from_slice(xq);
            for (t, a) in trial_arc.iter_mut().zip(arc.iter()) {
                *t = f64::from(a.0);
            }
            trial_x[j] = frac(down);
            trial_arc[j] = f64::from(down.0);
            for i in 0..l {
                up_dx[i] = match step_up(ArcLevel(trial_arc[i] as u8), plant.power[i].min_arc) {
                    Some(up) if i != j => frac(up) - trial_x[i],
                    _ => 0.0,
                };
            }
            let mut cost = 0.0;
            let mut ok = true;
            while deficit[..n_short].iter().any(|&d| d > 0.0) {
                // the step up that covers the most deficit per watt; the desks' rows of R are
                // contiguous over luminaires, so the covers add up a row at a time
                cover.iter_mut().for_each(|c| *c = 0.0);
                for (d, s) in deficit[..n_short].iter().zip(&short[..n_short]) {
                    let d = d.max(0.0);
                    let row = &r[*s as usize * l..(*s as usize + 1) * l];
                    for ((c, &rk), &du) in cover.iter_mut().zip(row).zip(up_dx.iter()) {
                        *c += d.min(rk * du);
                    }
                }
                let mut best: Option<(usize, f64)> = None; // (i, ratio)
                for i in 0..l {
                    if cover[i] <= 0.0 {
                        continue;
                    }
                    let ratio = cover[i] / (plant.power[i].slope_w() * up_dx[i]).max(1e-12);
                    if best.is_none_or(|b| ratio > b.1) {
                        best = Some((i, ratio));
                    }
                }
                let Some((i, _)) = best else {
                    ok = false;
                    break;
                };
                let du = up_dx[i];
                let up = step_up(ArcLevel(trial_arc[i] as u8), plant.power[i].min_arc)
                    .unwrap_or(ArcLevel::MAX);
                trial_x[i] += du;
                trial_arc[i] = f64::from(up.0);
                up_dx[i] = match step_up(up, plant.power[i].min_arc) {
                    Some(next) => frac(next) - trial_x[i],
                    None => 0.0,
                };
                cost += plant.power[i].slope_w() * du;
                for s in 0..n_short {
                    deficit[s] -= r[short[s] as usize * l + i] * du;
                }
                if cost + bound(&deficit[..n_short], &short[..n_short], j) >= saving {
                    ok = false;
                    break;
                }
            }
            if ok && cost < saving - 1e-9 {
                take_trial(plant, (trial_x, trial_arc), arc, xq, lux);
                improved = true;
            }
        }
        if !improved {
            break;
        }
    }
}

/// Per desk: the most lux per watt any luminaire adds (`best`), the second most (`second`),
/// and whose the most is (`best_of`, as f64).
fn best_lux_per_watt(plant: &Plant<'_>, best: &mut [f64], second: &mut [f64], best_of: &mut [f64]) {
    let (kd, l, r) = (plant.desks, plant.luminaires, plant.response_lx);
    for k in 0..kd {
        let (mut b1, mut b2, mut i1) = (0.0f64, 0.0f64, usize::MAX);
        for i in 0..l {
            let ratio = r[k * l + i] / plant.power[i].slope_w().max(1e-12);
            if ratio > b1 {
                (b2, b1, i1) = (b1, ratio, i);
            } else if ratio > b2 {
                b2 = ratio;
            }
        }
        (best[k], second[k], best_of[k]) = (b1, b2, i1 as f64);
    }
}

/// Takes a trial's outputs and levels (`trial`: x, arc as f64): each changed luminaire's
/// output, level and its light on the desks.
fn take_trial(
    plant: &Plant<'_>,
    (trial_x, trial_arc): (&[f64], &[f64]),
    arc: &mut [ArcLevel],
    xq: &mut [f64],
    lux: &mut [f64],
) {
    let (kd, l, r) = (plant.desks, plant.luminaires, plant.response_lx);
    for i in 0..l {
        let dx = trial_x[i] - xq[i];
        if dx != 0.0 {
            for k in 0..kd {
                lux[k] += r[k * l + i] * dx;
            }
            xq[i] = trial_x[i];
            arc[i] = ArcLevel(trial_arc[i] as u8);
        }
    }
}

/// Whether every desk keeps at least `u` of the mean after luminaire j loses `dx` of output.
fn uniform_after(r: &[f64], l: usize, lux: &[f64], j: usize, dx: f64, u: f64) -> bool {
    let kd = lux.len();
    let after = |k: usize| lux[k] - r[k * l + j] * dx;
    let mean = (0..kd).map(after).sum::<f64>() / kd.max(1) as f64;
    (0..kd).all(|k| after(k) >= u * mean - 1e-9 * mean.abs().max(1.0))
}

/// The conventional controller the optimiser is compared with: one photocell for the room,
/// every luminaire dimmed together to the lowest common arc level at which the darkest desk
/// meets its target (all at full when none does). Writes the levels and the desk lux; returns
/// the plan's power.
pub fn photocell_plan(
    plant: &Plant<'_>,
    demand: &Demand<'_>,
    out: PlanOut<'_>,
) -> Result<PlanReport, ControlError> {
    check(plant, demand, &out)?;
    let (kd, l) = (plant.desks, plant.luminaires);
    let min_arc = plant.power.iter().map(|p| p.min_arc).max().unwrap_or(1);
    let lux_at = |a: ArcLevel, k: usize| -> f64 {
        let x = fraction(a, plant.curve);
        plant.response_lx[k * l..(k + 1) * l].iter().sum::<f64>() * x + demand.daylight_lx[k]
    };
    let meets = |a: ArcLevel| (0..kd).all(|k| lux_at(a, k) >= demand.target_lx[k] * (1.0 - 1e-9));
    // light output grows with the level: the lowest level that meets every desk, by bisection
    let level = if meets(ArcLevel::OFF) {
        ArcLevel::OFF
    } else if !meets(ArcLevel::MAX) {
        ArcLevel::MAX
    } else {
        // levels below the minimum cannot be on: the minimum, or bisection above it
        let (mut lo, mut hi) = (min_arc, 254u8);
        if meets(ArcLevel(min_arc)) {
            lo = min_arc;
            hi = min_arc;
        }
        while hi > lo + 1 {
            let mid = lo + (hi - lo) / 2;
            if meets(ArcLevel(mid)) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        ArcLevel(hi)
    };
    out.arc.iter_mut().for_each(|a| *a = level);
    for (k, e) in out.lux.iter_mut().enumerate() {
        *e = lux_at(level, k);
    }
    let short = met(out.lux, demand, 1e-6 * DEFAULT_TARGET_LX, out.met);
    let x = fraction(level, plant.curve);
    Ok(PlanReport {
        power_w: plant.power.iter().map(|p| p.power_w(x)).sum(),
        all_on_w: plant.power.iter().map(|p| p.full_w).sum(),
        lp_power_w: f64::NAN,
        short,
        iterations: 0,
    })
}
