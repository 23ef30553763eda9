//! The control loop around [`super::optimise`]: modes, fades, hysteresis and a dead band, and
//! what it does when an input is lost. `no_std`, no heap (state in `heapless` vectors of the
//! register map's capacity).
//!
//! * **Modes.** `Off`: the loop commands nothing (the lights follow the BMS or the gateway).
//!   `ConstantLight`: the least-power state that meets every target with no daylight (a new
//!   installation is not over-lit; lamp ageing is compensated as its factor is measured).
//!   `DaylightHarvesting`: the same with each desk's measured daylight.
//! * **Daylight filter.** Each desk's daylight estimate is smoothed before anything looks at it:
//!   an exponential filter that follows a falling estimate quickly (`daylight_fall_s`, a cloud
//!   must brighten the lights within seconds) and a rising one slowly (`daylight_rise_s`). A
//!   frame's noise is damped, and what noise is left errs low: toward more light, the safe side.
//! * **Dead band.** A new plan is made only when a target changes, the mode changes, or the
//!   filtered daylight on some desk has moved by more than `dead_band` of its target since the
//!   last plan: camera noise below that never moves a light.
//! * **Keep what works.** A new plan replaces the levels only when the levels as they are leave
//!   some desk short, or when it saves more than `min_saving` of their power: a room with
//!   several near-equal least-power states does not hop between them on noise.
//! * **Hysteresis.** A plan is applied at once when some desk is short as things are (more than
//!   the dead band below its target); a plan that only saves power waits until it has been
//!   wanted for `dim_hold_s`. Clouds passing do not make the lights pump.
//! * **Fades.** Levels move toward the plan by at most `fade_steps_per_s` DALI steps a second
//!   (the logarithmic curve makes equal steps equal in perception).
//! * **Lost inputs.** Without a fresh daylight estimate (camera stale or gone) the loop plans as
//!   if there were no daylight: every desk meets its target from the luminaires alone, the safe
//!   side. Without the gateway it keeps its plan and resends it when the link is back.

use heapless::Vec;

use super::{ControlError, Demand, PlanOut, Plant, optimise};
use crate::dali::ArcLevel;

/// Luminaires the loop has room for (the register map's capacity).
pub const MAX_LUMINAIRES: usize = 256;
/// Desks the loop has room for (the register map's capacity).
pub const MAX_DESKS: usize = 100;

/// What the loop does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Commands nothing.
    #[default]
    Off,
    /// Targets from the luminaires alone.
    ConstantLight,
    /// Targets with the measured daylight.
    DaylightHarvesting,
}

impl Mode {
    /// The register value (0 off, 1 constant light, 2 daylight harvesting).
    pub fn code(self) -> u16 {
        match self {
            Mode::Off => 0,
            Mode::ConstantLight => 1,
            Mode::DaylightHarvesting => 2,
        }
    }

    /// The mode of a register value.
    pub fn from_code(v: u16) -> Option<Self> {
        match v {
            0 => Some(Mode::Off),
            1 => Some(Mode::ConstantLight),
            2 => Some(Mode::DaylightHarvesting),
            _ => None,
        }
    }
}

/// The loop's knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Largest change of a level, DALI steps per second.
    pub fade_steps_per_s: f64,
    /// Daylight change on a desk, as a fraction of its target, below which nothing is replanned.
    pub dead_band: f64,
    /// How long brighter daylight must last before the lights are dimmed, s.
    pub dim_hold_s: f64,
    /// Optional uniformity constraint for the optimiser.
    pub uniformity: Option<f64>,
    /// Time constant of the daylight filter while the estimate rises, s.
    pub daylight_rise_s: f64,
    /// Time constant of the daylight filter while the estimate falls, s.
    pub daylight_fall_s: f64,
    /// Least fraction of the present levels' power a new plan must save to replace levels that
    /// meet every target.
    pub min_saving: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            fade_steps_per_s: 20.0,
            dead_band: 0.05,
            dim_hold_s: 60.0,
            uniformity: None,
            daylight_rise_s: 30.0,
            daylight_fall_s: 10.0,
            min_saving: 0.03,
        }
    }
}

/// One tick's inputs.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    /// Seconds since any fixed origin (monotonic).
    pub now_s: f64,
    /// Daylight per desk from live light; `None` when it is stale or unknown.
    pub daylight_lx: Option<&'a [f64]>,
    /// The gateway link is up (levels can be written).
    pub gateway_up: bool,
}

/// What a tick decided.
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    /// Levels to write now (`None`: nothing to write).
    pub write: Option<Vec<ArcLevel, MAX_LUMINAIRES>>,
    /// A new plan was made this tick.
    pub replanned: bool,
    /// The plan assumes no daylight because the estimate is stale.
    pub safe: bool,
}

/// The plan being followed and what it promises.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    /// Goal level per luminaire.
    pub arc: Vec<ArcLevel, MAX_LUMINAIRES>,
    /// Desk illuminance at the goal, lx.
    pub lux: Vec<f64, MAX_DESKS>,
    /// Desk meets its target at the goal.
    pub met: Vec<bool, MAX_DESKS>,
    /// Input power at the goal, W.
    pub power_w: f64,
    /// Input power with everything at full, W.
    pub all_on_w: f64,
}

/// The loop's state.
#[derive(Debug, Clone, Default)]
pub struct Regulator {
    /// Mode.
    pub mode: Mode,
    /// Knobs.
    pub settings: Settings,
    plan: Plan,
    /// Levels as last commanded.
    current: Vec<ArcLevel, MAX_LUMINAIRES>,
    /// Daylight the plan was made for.
    planned_daylight: Vec<f64, MAX_DESKS>,
    /// The filtered daylight estimate (empty: none yet, or it went stale).
    daylight_filtered: Vec<f64, MAX_DESKS>,
    planned_targets: Vec<f64, MAX_DESKS>,
    planned_mode: Option<Mode>,
    planned_safe: bool,
    /// Since when a plan that dims is waiting out the hold, s.
    pending_dim: Option<f64>,
    last_tick_s: Option<f64>,
    gateway_was_up: bool,
}

fn vec_of<T: Copy, const N: usize>(v: T, n: usize) -> Vec<T, N> {
    let mut out = Vec::new();
    for _ in 0..n.min(N) {
        let _ = out.push(v);
    }
    out
}

impl Regulator {
    /// A loop in `mode` with `settings`.
    pub fn new(mode: Mode, settings: Settings) -> Self {
        Self {
            mode,
            settings,
            ..Self::default()
        }
    }

    /// The plan being followed.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Levels as last commanded.
    pub fn current(&self) -> &[ArcLevel] {
        &self.current
    }

    /// One step of the daylight filter toward the estimate `d`, `dt` seconds after the last.
    fn filter_daylight(&mut self, d: &[f64], dt: f64) {
        if self.daylight_filtered.len() != d.len() {
            self.daylight_filtered = d.iter().copied().take(MAX_DESKS).collect();
            return;
        }
        let gain = |tau: f64| {
            if tau <= 0.0 {
                1.0
            } else {
                1.0 - libm::exp(-dt / tau)
            }
        };
        let (rise, fall) = (
            gain(self.settings.daylight_rise_s),
            gain(self.settings.daylight_fall_s),
        );
        for (f, &e) in self.daylight_filtered.iter_mut().zip(d) {
            let a = if e < *f { fall } else { rise };
            *f += a * (e - *f);
        }
    }

    /// The desk lux and power of the levels as they are, if they meet every target within the
    /// dead band with this daylight (`None` before the first write or when some desk is short).
    fn holds(
        &self,
        plant: &Plant<'_>,
        targets: &[f64],
        daylight: &[f64],
    ) -> Option<(Vec<f64, MAX_DESKS>, f64)> {
        if self.current.len() != plant.luminaires || self.current.contains(&ArcLevel::MASK) {
            return None;
        }
        let mut x: Vec<f64, MAX_LUMINAIRES> = Vec::new();
        let mut power = 0.0;
        for (a, p) in self.current.iter().zip(plant.power) {
            let f = a.fraction(plant.curve)?;
            power += p.power_w(f);
            let _ = x.push(f);
        }
        let mut lux: Vec<f64, MAX_DESKS> = vec_of(0.0, plant.desks);
        super::desk_lux(plant, daylight, &x, &mut lux);
        let band = 1.0 - self.settings.dead_band;
        let ok = lux.iter().zip(targets).all(|(e, t)| *e >= *t * band);
        if self.settings.uniformity.is_some() {
            // the uniformity constraint is the optimiser's to keep
            return None;
        }
        ok.then_some((lux, power))
    }

    fn needs_plan(&self, targets: &[f64], daylight: &[f64], safe: bool) -> bool {
        if self.planned_mode != Some(self.mode)
            || self.planned_safe != safe
            || self.planned_targets.as_slice() != targets
            || self.planned_daylight.len() != daylight.len()
        {
            return true;
        }
        daylight
            .iter()
            .zip(&self.planned_daylight)
            .zip(targets)
            .any(|((d, p), t)| (d - p).abs() > self.settings.dead_band * t.max(1.0))
    }

    /// One tick: maybe replan, then move the commanded levels toward the plan.
    pub fn tick(
        &mut self,
        plant: &Plant<'_>,
        targets_lx: &[f64],
        inputs: Inputs<'_>,
        scratch: &mut [f64],
    ) -> Result<Tick, ControlError> {
        let (kd, l) = (plant.desks, plant.luminaires);
        if kd > MAX_DESKS || l > MAX_LUMINAIRES || targets_lx.len() != kd {
            return Err(ControlError::Shape);
        }
        if self.current.len() != l {
            // first tick: nothing is known of the lights; the plan is written whole
            self.current = vec_of(ArcLevel::MASK, l);
        }
        let dt = self
            .last_tick_s
            .map_or(0.0, |t| (inputs.now_s - t).max(0.0));
        self.last_tick_s = Some(inputs.now_s);
        if self.mode == Mode::Off {
            self.planned_mode = Some(Mode::Off);
            return Ok(Tick {
                write: None,
                replanned: false,
                safe: false,
            });
        }
        let zeros = [0.0; MAX_DESKS];
        let safe = match (self.mode, inputs.daylight_lx) {
            (Mode::DaylightHarvesting, Some(d)) if d.len() == kd => {
                self.filter_daylight(d, dt);
                false
            }
            (Mode::DaylightHarvesting, _) => {
                self.daylight_filtered.clear();
                true
            }
            _ => false,
        };
        let filtered = self.daylight_filtered.clone();
        let daylight: &[f64] = if self.mode == Mode::DaylightHarvesting && !safe {
            &filtered
        } else {
            &zeros[..kd]
        };
        let replanned = self.needs_plan(targets_lx, daylight, safe);
        if replanned {
            self.replan(plant, targets_lx, daylight, safe, scratch)?;
        }
        let first = self.current.contains(&ArcLevel::MASK);
        let goal = self.goal(plant, targets_lx, daylight, inputs.now_s, first);
        // fade toward the goal
        let max_steps = if first {
            255.0
        } else {
            (self.settings.fade_steps_per_s * dt).max(1.0)
        };
        let mut next: Vec<ArcLevel, MAX_LUMINAIRES> = Vec::new();
        for j in 0..l {
            let (g, c) = (goal[j], self.current[j]);
            let n = if first { g } else { fade(c, g, max_steps) };
            let _ = next.push(n);
        }
        let changed = next != self.current;
        let resend = inputs.gateway_up && !self.gateway_was_up;
        self.gateway_was_up = inputs.gateway_up;
        let write = if inputs.gateway_up && (changed || resend) {
            self.current = next.clone();
            Some(next)
        } else {
            if !inputs.gateway_up {
                // nothing reaches the lights: keep the last commanded levels
            } else {
                self.current = next;
            }
            None
        };
        Ok(Tick {
            write,
            replanned,
            safe,
        })
    }

    /// A new plan: the least-power levels for the targets and daylight (the safe plan without
    /// daylight), unless the levels as they are meet every target and the plan saves little.
    fn replan(
        &mut self,
        plant: &Plant<'_>,
        targets_lx: &[f64],
        daylight: &[f64],
        safe: bool,
        scratch: &mut [f64],
    ) -> Result<(), ControlError> {
        let (kd, l) = (plant.desks, plant.luminaires);
        let mut arc: Vec<ArcLevel, MAX_LUMINAIRES> = vec_of(ArcLevel::OFF, l);
        let mut lux: Vec<f64, MAX_DESKS> = vec_of(0.0, kd);
        let mut met: Vec<bool, MAX_DESKS> = vec_of(false, kd);
        let report = optimise(
            plant,
            &Demand {
                target_lx: targets_lx,
                daylight_lx: daylight,
                uniformity: self.settings.uniformity,
            },
            PlanOut {
                arc: &mut arc,
                lux: &mut lux,
                met: &mut met,
            },
            scratch,
        )?;
        let mut power_w = report.power_w;
        // (not for the safe plan: that one is the guarantee, taken as it is)
        if !safe
            && let Some((lux_now, power_now)) = self.holds(plant, targets_lx, daylight)
            && report.power_w > (1.0 - self.settings.min_saving) * power_now
        {
            // the levels as they are meet every target and the new plan saves little:
            // keep them
            arc = self.current.clone();
            lux = lux_now;
            met = vec_of(true, kd);
            power_w = power_now;
        }
        self.plan = Plan {
            arc,
            lux,
            met,
            power_w,
            all_on_w: report.all_on_w,
        };
        self.planned_daylight = daylight.iter().copied().take(MAX_DESKS).collect();
        self.planned_targets = targets_lx.iter().copied().take(MAX_DESKS).collect();
        self.planned_mode = Some(self.mode);
        self.planned_safe = safe;
        Ok(())
    }

    /// The levels to fade toward at `now_s`.
    fn goal(
        &mut self,
        plant: &Plant<'_>,
        targets_lx: &[f64],
        daylight: &[f64],
        now_s: f64,
        first: bool,
    ) -> Vec<ArcLevel, MAX_LUMINAIRES> {
        let kd = plant.desks;
        // the goal: the whole plan at once when a desk is short now; a plan that only saves
        // power (every desk meets its target as things are) after the dim hold
        let now = now_s;
        let short_now = !first && {
            let mut x: Vec<f64, MAX_LUMINAIRES> = Vec::new();
            for a in &self.current {
                let _ = x.push(a.fraction(plant.curve).unwrap_or(0.0));
            }
            let mut lux: Vec<f64, MAX_DESKS> = vec_of(0.0, kd);
            super::desk_lux(plant, daylight, &x, &mut lux);
            lux.iter()
                .zip(targets_lx)
                .any(|(e, t)| *e < t * (1.0 - self.settings.dead_band))
        };
        let dims = self
            .plan
            .arc
            .iter()
            .zip(&self.current)
            .any(|(p, c)| p.0 < c.0);
        let apply = if first || short_now || !dims {
            self.pending_dim = None;
            true
        } else {
            let since = *self.pending_dim.get_or_insert(now);
            if now - since >= self.settings.dim_hold_s {
                self.pending_dim = None;
                true
            } else {
                false
            }
        };
        if apply {
            self.plan.arc.clone()
        } else {
            self.current.clone()
        }
    }
}

/// One fade step from `c` toward `g`, at most `max_steps` DALI steps. Switching on goes to the
/// goal at once (a luminaire cannot be on below its minimum level); fading out steps down and
/// then switches off (the gear holds its minimum level on the way).
fn fade(c: ArcLevel, g: ArcLevel, max_steps: f64) -> ArcLevel {
    if c == g || c == ArcLevel::OFF {
        return g;
    }
    let steps = max_steps.clamp(1.0, 254.0) as i32;
    let (ci, gi) = (i32::from(c.0), i32::from(g.0));
    let n = if gi > ci {
        (ci + steps).min(gi)
    } else {
        (ci - steps).max(gi)
    };
    ArcLevel(n as u8)
}
