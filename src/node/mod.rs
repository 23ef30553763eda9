//! The node: the application state of a commissioned node, whatever protocol reads it.
//!
//! [`Node`] owns the model copied out of the image (the response matrix, sensors ×
//! luminaires, a few kB), the current dimming levels, the lighting-control state (mode, desk
//! targets, power model), lamp ageing, the latest daylight estimate, the live values and
//! occupancy, the faults and the [`health`] of its servers. Every change of the dimming state
//! (a write of the arc levels, or a poll of the DALI gateway) recomputes the desk values at
//! once by superposition, so a read always returns values consistent with the levels next to
//! them.
//!
//! The state is published in the register layer's snapshot ([`RegisterMap`]); the node knows
//! no protocol. The protocol adapters (`crate::fieldbus`: Modbus TCP, TLS and RTU, the DALI
//! gateway link; BACnet when it comes) share one node behind a mutex ([`SharedNode`]) held
//! only for the few microseconds a request takes, and reach it through its methods
//! ([`Node::on_registers`], [`Node::written`], [`Node::set_arc_levels`], ...).

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

pub mod health;

use crate::control::LuminairePower;
use crate::control::rating::RatedPower;
use crate::control::regulator::{Mode, Settings as RegulatorSettings};
use crate::dali::{ArcLevel, DimmingCurve};
use crate::modbus::access::{AccessPolicy, MAX_CLIENT_SETTINGS, Settings, Source};
use crate::modbus::regmap::{
    Desk, Effect, Identity, MAX_DESKS, MAX_LUMINAIRES, MAX_TARGET_LX, NOT_AVAILABLE_U16, Quality,
    RegisterMap, WordOrder, addr, status,
};
use crate::runtime::superpose;
use crate::store::{Image, MAX_LUX, sensor_flags};
use health::Health;

/// The part of an image the server needs, copied out (the image itself can be dropped).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeModel {
    /// Response matrix, lx at full output, row-major sensors × luminaires.
    pub response_lx: Vec<f64>,
    /// Sensor (desk) ids, sensors.json order.
    pub sensor_ids: Vec<u32>,
    /// Luminaire ids, luminaires.json order.
    pub luminaire_ids: Vec<u32>,
    /// Per-sensor flags of the image.
    pub sensor_flags: Vec<u8>,
    /// Per sensor, the stated relative uncertainty of its modelled light (NaN: not stated).
    pub model_rel_uncertainty: Vec<f64>,
    /// Per sensor and luminaire, the parts of the modelled light's uncertainty at 100 %, lx
    /// (`[sensor][luminaire][part]`, [`crate::runtime::UNCERTAINTY_PARTS`] parts; empty: the
    /// all-on statement holds for every state).
    pub uncertainty_parts_lx: Vec<f64>,
    /// Per sensor and luminaire, its occluder group (`[sensor][luminaire]`,
    /// [`crate::runtime::OCCLUDER_GROUPS`]; empty: every luminaire alone).
    pub occluder_groups: Vec<u8>,
    /// Image generation (from the A/B slots; 0 for a plain file).
    pub generation: u64,
    /// Rated input power per luminaire (the power model's default, [`RatedPower`]).
    pub luminaire_power: Vec<RatedPower>,
    /// Each sensor's point name ([`crate::points`]: `desk 1 (S2)`, `floor S8`; empty: `S<id>`).
    pub point_names: Vec<String>,
}

/// Why a node cannot serve a model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NodeError {
    /// More desks than the register map has room for.
    #[error("{0} desks: the register map serves at most {MAX_DESKS}")]
    TooManyDesks(usize),
    /// More luminaires than the register map has room for.
    #[error("{0} luminaires: the register map serves at most {MAX_LUMINAIRES}")]
    TooManyLuminaires(usize),
    /// A level outside [0, 1].
    #[error("luminaire {index}: level {level} is outside [0, 1]")]
    Level {
        /// Luminaire index.
        index: usize,
        /// The level.
        level: f64,
    },
    /// A desk the model does not have.
    #[error("desk {0}: not in the model")]
    UnknownDesk(u32),
    /// A target outside [0, MAX_TARGET_LX] lx, or not finite.
    #[error("target {0} lx is outside 0..={MAX_TARGET_LX} lx")]
    Target(f64),
    /// Arc levels of the wrong length.
    #[error("{found} levels given, the image has {expected} luminaires")]
    Length {
        /// Luminaires in the model.
        expected: usize,
        /// Levels given.
        found: usize,
    },
}

impl NodeModel {
    /// Copies what the server needs out of a checked image.
    pub fn from_image(image: &Image<'_>, generation: u64) -> Self {
        let (s, l) = (image.sensors(), image.luminaires());
        let sensor_ids: Vec<u32> = (0..s).map(|k| image.sensor_id(k)).collect();
        // the geometry section once, for the luminaires' ratings and the points' names
        let section = image
            .geometry_bytes()
            .and_then(|b| crate::store::geometry::GeometrySection::decode(b).ok());
        let mut response_lx = Vec::with_capacity(s * l);
        for si in 0..s {
            for li in 0..l {
                response_lx.push(image.response_lx(si, li));
            }
        }
        Self {
            response_lx,
            sensor_ids: sensor_ids.clone(),
            luminaire_ids: (0..l).map(|j| image.luminaire_id(j)).collect(),
            sensor_flags: (0..s).map(|k| image.sensor_flags(k)).collect(),
            model_rel_uncertainty: (0..s)
                .map(|k| image.model_rel_uncertainty(k).unwrap_or(f64::NAN))
                .collect(),
            uncertainty_parts_lx: image
                .live
                .as_ref()
                .map_or_else(Vec::new, |live| live.uncertainty_parts_vec()),
            occluder_groups: image
                .live
                .as_ref()
                .map_or_else(Vec::new, |live| live.occluder_groups_vec()),
            generation,
            luminaire_power: crate::control::rating::rated_powers_in(image, section.as_ref()),
            point_names: crate::points::points_in(&sensor_ids, section.as_ref())
                .into_iter()
                .map(|p| p.name)
                .collect(),
        }
    }

    /// Sensor `k`'s stated relative uncertainty of its modelled light at `levels`
    /// ([`crate::runtime::state_rel_uncertainty`]; NaN: not stated).
    pub fn rel_uncertainty_at(&self, k: usize, levels: &[f64]) -> f64 {
        let stated = self
            .model_rel_uncertainty
            .get(k)
            .copied()
            .unwrap_or(f64::NAN);
        let (l, p) = (levels.len(), crate::runtime::UNCERTAINTY_PARTS);
        if l != self.luminaire_ids.len() {
            return stated;
        }
        crate::runtime::state_rel_uncertainty_of_rows(
            stated,
            row(&self.uncertainty_parts_lx, k, l * p),
            self.occluder_groups.get(k * l..(k + 1) * l).unwrap_or(&[]),
            row(&self.response_lx, k, l),
            levels,
        )
    }

    fn quality(&self, k: usize) -> Quality {
        let f = self.sensor_flags.get(k).copied().unwrap_or(0);
        if f & sensor_flags::OUT_OF_VIEW != 0 {
            Quality::OutOfView
        } else if f & sensor_flags::ESTIMATED != 0 {
            Quality::Estimated
        } else {
            Quality::Ok
        }
    }
}

/// Row `k` of a row-major matrix `width` wide (empty when it has no such row).
fn row(v: &[f64], k: usize, width: usize) -> &[f64] {
    v.get(k * width..(k + 1) * width).unwrap_or(&[])
}

/// Serving options.
#[derive(Debug, Clone, Default)]
pub struct NodeOptions {
    /// Identification strings (function 0x2B / 0x0E).
    pub identity: Identity,
    /// A DALI gateway link is configured (the arc levels follow it).
    pub gateway_configured: bool,
    /// Initial arc level of every luminaire (`None`: off, and the dimming state unknown:
    /// values are flagged stale until every luminaire's level has been set).
    pub initial_arc: Option<u8>,
    /// Who may write, and the word orders (default: read-only, ABCD).
    pub policy: AccessPolicy,
    /// Where the settings clients write are persisted (`None`: not persisted).
    pub settings_path: Option<PathBuf>,
    /// The servers' health, for the registers (`None`: a private one).
    pub health: Option<Arc<Health>>,
    /// Lighting control: the board's mode, targets and power model.
    pub control: ControlOptions,
}

/// The board's lighting-control settings (what clients write over Modbus wins, persisted).
#[derive(Debug, Clone)]
pub struct ControlOptions {
    /// Mode at start when no client has set one.
    pub mode: Mode,
    /// Target of every desk, lx, unless `desk_targets_lx` names it.
    pub target_lx: f64,
    /// Targets of named desks (desk id, lx).
    pub desk_targets_lx: Vec<(u32, f64)>,
    /// Rated power of every luminaire at full, W (`None`: each one's photometry wattage, or
    /// its flux over [`crate::control::DEFAULT_EFFICACY_LM_PER_W`] where the file has none).
    pub rated_power_w: Option<f64>,
    /// Standby power of a luminaire that is off, W.
    pub standby_power_w: f64,
    /// The lowest arc level a luminaire can be on at (DALI physical minimum level).
    pub min_arc: u8,
    /// The loop's knobs.
    pub loop_settings: RegulatorSettings,
    /// Daylight estimates older than this are stale, s.
    pub daylight_max_age_s: f64,
    /// Seconds between control ticks.
    pub tick_s: f64,
    /// What a vacant desk (after occupancy's hold) is lit to.
    pub vacant: crate::control::VacantLight,
}

impl Default for ControlOptions {
    fn default() -> Self {
        Self {
            mode: Mode::Off,
            target_lx: crate::control::DEFAULT_TARGET_LX,
            desk_targets_lx: Vec::new(),
            rated_power_w: None,
            standby_power_w: crate::control::DEFAULT_STANDBY_W,
            min_arc: crate::control::DEFAULT_MIN_ARC,
            loop_settings: RegulatorSettings::default(),
            daylight_max_age_s: 60.0,
            tick_s: 1.0,
            vacant: crate::control::VacantLight::default(),
        }
    }
}

/// The served state.
#[derive(Debug)]
pub struct Node {
    model: NodeModel,
    map: RegisterMap,
    levels: Vec<f64>,
    arc_seen: Vec<u8>,
    curve_seen: DimmingCurve,
    started: Instant,
    computed: Instant,
    gateway_up: bool,
    gateway_link_changes: u64,
    /// Level sets the lighting control delivered to the gateway (a gateway read that started
    /// before one is out of date: [`Node::levels_delivered`]).
    levels_delivered: u64,
    store_ok: bool,
    sensors_ok: bool,
    /// Per luminaire: its level is known (set since start, or given at start).
    arc_known: Vec<bool>,
    policy: AccessPolicy,
    settings: Settings,
    settings_path: Option<PathBuf>,
    health: Arc<Health>,
    last_refusal_log: Option<Instant>,
    control: ControlOptions,
    power: Vec<LuminairePower>,
    /// Per luminaire: the ratio of its measured output to the model's (lamp ageing), 1 new.
    ageing: Vec<f64>,
    /// The latest daylight estimate per desk (lx) and when it was made.
    daylight: Option<(Instant, Vec<f64>)>,
}

impl Node {
    /// A node serving `model`, every luminaire at `options.initial_arc` (default off).
    pub fn new(model: NodeModel, options: NodeOptions) -> Result<Self, NodeError> {
        if model.sensor_ids.len() > MAX_DESKS {
            return Err(NodeError::TooManyDesks(model.sensor_ids.len()));
        }
        if model.luminaire_ids.len() > MAX_LUMINAIRES {
            return Err(NodeError::TooManyLuminaires(model.luminaire_ids.len()));
        }
        let mut map = RegisterMap {
            identity: options.identity,
            generation: model.generation.min(u64::from(u32::MAX)) as u32,
            ..RegisterMap::default()
        };
        let arc0 = options.initial_arc.unwrap_or(0).min(254);
        let settings = match &options.settings_path {
            None => Settings::default(),
            Some(p) => Settings::load(p).unwrap_or_else(|e| {
                // a bad settings file must not keep the node from serving: the defaults
                tracing::warn!("{e}; using the board's defaults");
                Settings::default()
            }),
        };
        if let Some(c) = settings.curve() {
            map.curve = c;
        }
        for (k, &id) in model.sensor_ids.iter().enumerate() {
            // capacity checked above
            let _ = map.desks.push(Desk {
                id,
                lux: f64::NAN,
                quality: model.quality(k),
                model_rel_uncertainty: model
                    .model_rel_uncertainty
                    .get(k)
                    .copied()
                    .unwrap_or(f64::NAN),
            });
        }
        for &id in &model.luminaire_ids {
            let _ = map.luminaire_ids.push(id);
            let _ = map.arc.push(arc0);
        }
        // control: the board's mode and targets, what clients wrote over them
        let mode = settings
            .control_mode
            .and_then(Mode::from_code)
            .unwrap_or(options.control.mode);
        map.control.mode = mode.code();
        for &id in &model.sensor_ids {
            let board = options
                .control
                .desk_targets_lx
                .iter()
                .find(|(d, _)| *d == id)
                .map_or(options.control.target_lx, |t| t.1);
            let t =
                settings.targets_lx.get(&id).copied().unwrap_or_else(|| {
                    libm::round(board.clamp(0.0, f64::from(MAX_TARGET_LX))) as u16
                });
            let _ = map.control.targets_lx.push(t);
            let _ = map.control.met.push(NOT_AVAILABLE_U16);
        }
        let power: Vec<LuminairePower> = model
            .luminaire_power
            .iter()
            .map(|&r| {
                let mut p = LuminairePower::rated(r);
                if let Some(w) = options.control.rated_power_w {
                    p.full_w = w;
                }
                p.standby_w = options.control.standby_power_w.min(p.full_w);
                p.min_arc = options.control.min_arc.clamp(1, 254);
                p
            })
            .collect();
        if options.control.rated_power_w.is_none() {
            let warning = crate::control::rating::assumed_warning(
                &model.luminaire_ids,
                &model.luminaire_power,
            );
            if let Some(w) = warning {
                tracing::warn!("control: {w}");
            }
        }
        map.control.all_on_w = power.iter().map(|p| p.full_w).sum();
        let now = Instant::now();
        let model_luminaires = model.luminaire_ids.len();
        let mut node = Self {
            levels: vec![0.0; model.luminaire_ids.len()],
            // differs from every arc register, so the first computation reads them all
            arc_seen: vec![ArcLevel::MASK.0; model.luminaire_ids.len()],
            curve_seen: DimmingCurve::default(),
            model,
            map,
            started: now,
            computed: now,
            gateway_up: !options.gateway_configured,
            gateway_link_changes: 0,
            levels_delivered: 0,
            store_ok: true,
            sensors_ok: true,
            arc_known: vec![options.initial_arc.is_some(); model_luminaires],
            policy: options.policy,
            settings,
            settings_path: options.settings_path,
            health: options.health.unwrap_or_default(),
            last_refusal_log: None,
            control: options.control,
            power,
            ageing: vec![1.0; model_luminaires],
            daylight: None,
        };
        if options.gateway_configured {
            node.map.status |= status::GATEWAY_CONFIGURED;
        }
        node.recompute();
        Ok(node)
    }

    /// The register map (read-only view).
    pub fn map(&self) -> &RegisterMap {
        &self.map
    }

    /// The model served.
    pub fn model(&self) -> &NodeModel {
        &self.model
    }

    /// Current levels in [0, 1], one per luminaire.
    pub fn levels(&self) -> &[f64] {
        &self.levels
    }

    /// Desk values as published: (id, lx, quality).
    pub fn desks(&self) -> Vec<(u32, f64, Quality)> {
        self.map
            .desks
            .iter()
            .map(|d| (d.id, d.lux, d.quality))
            .collect()
    }

    /// Sets the arc levels (MASK keeps a luminaire's level) and recomputes.
    pub fn set_arc_levels(&mut self, arc: &[u8]) -> Result<(), NodeError> {
        if arc.len() != self.map.arc.len() {
            return Err(NodeError::Length {
                expected: self.map.arc.len(),
                found: arc.len(),
            });
        }
        for ((slot, known), &a) in self.map.arc.iter_mut().zip(&mut self.arc_known).zip(arc) {
            if a != ArcLevel::MASK.0 {
                *slot = a;
                *known = true;
            }
        }
        self.recompute();
        Ok(())
    }

    /// Sets the arc levels the lighting control has just written to the gateway
    /// ([`Node::set_arc_levels`]) and counts the delivery, so a gateway poll whose read was in
    /// flight meanwhile (the old levels) does not overwrite them.
    pub fn set_arc_levels_delivered(&mut self, arc: &[u8]) -> Result<(), NodeError> {
        self.set_arc_levels(arc)?;
        self.levels_delivered = self.levels_delivered.wrapping_add(1);
        Ok(())
    }

    /// How many level sets the lighting control has delivered ([`Node::set_arc_levels_delivered`]).
    pub fn levels_delivered(&self) -> u64 {
        self.levels_delivered
    }

    /// The DALI gateway link went up (`true`) or was lost (`false`). While it is lost the desk
    /// values are the last good ones, flagged stale (quality and status bit).
    pub fn set_gateway_link(&mut self, up: bool) {
        if self.gateway_up != up {
            self.gateway_up = up;
            self.gateway_link_changes = self.gateway_link_changes.wrapping_add(1);
            self.refresh_flags();
        }
    }

    /// Whether the DALI gateway link is up (always, when none is configured).
    pub fn gateway_link_up(&self) -> bool {
        self.gateway_up
    }

    /// How often the gateway link went up or down so far: a reader that samples
    /// [`Self::gateway_link_up`] now and then sees from this that it was lost in between.
    pub fn gateway_link_changes(&self) -> u64 {
        self.gateway_link_changes
    }

    /// Store health (status bit).
    pub fn set_store_ok(&mut self, ok: bool) {
        self.store_ok = ok;
        self.refresh_flags();
    }

    /// A peripheral fault (status bit [`status::PERIPHERAL_FAULT`]).
    pub fn set_peripheral_fault(&mut self, fault: bool) {
        self.set_extra(status::PERIPHERAL_FAULT, fault);
    }

    /// The ambient light check disagrees (status bit [`status::LIGHT_CHECK`]).
    pub fn set_light_check(&mut self, disagrees: bool) {
        self.set_extra(status::LIGHT_CHECK, disagrees);
    }

    fn set_extra(&mut self, bit: u16, on: bool) {
        if on {
            self.map.status |= bit;
        } else {
            self.map.status &= !bit;
        }
        self.refresh_flags();
    }

    /// Sensor health (status bit).
    pub fn set_sensors_ok(&mut self, ok: bool) {
        if self.sensors_ok != ok {
            if ok {
                tracing::info!("sensors: healthy again");
            } else {
                tracing::warn!("sensors: not healthy (status bit 2 cleared)");
            }
        }
        self.sensors_ok = ok;
        self.refresh_flags();
    }

    /// Replaces the access policy (configuration reload).
    pub fn set_policy(&mut self, policy: AccessPolicy) {
        self.policy = policy;
        self.refresh_flags();
    }

    /// The access policy in force.
    pub fn policy(&self) -> &AccessPolicy {
        &self.policy
    }

    /// The settings clients wrote.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The shared health.
    pub fn health(&self) -> &Arc<Health> {
        &self.health
    }

    /// The lighting-control mode in effect.
    pub fn control_mode(&self) -> Mode {
        Mode::from_code(self.map.control.mode).unwrap_or_default()
    }

    /// The board's control settings.
    pub fn control_options(&self) -> &ControlOptions {
        &self.control
    }

    /// Target per desk, lx.
    pub fn targets_lx(&self) -> Vec<f64> {
        self.map
            .control
            .targets_lx
            .iter()
            .map(|&t| f64::from(t))
            .collect()
    }

    /// Each desk's demand on the control loop, lx: its target, lowered where occupancy says
    /// nobody is there after the hold ([`crate::control::presence_demand_lx`]); without
    /// occupancy, or where it is unknown, the target (fail bright).
    pub fn demand_lx(&self) -> Vec<f64> {
        use crate::control::{Presence, presence_demand_lx};
        use crate::modbus::regmap::Occupancy;
        let occ = &self.map.occupancy.desks;
        self.targets_lx()
            .into_iter()
            .enumerate()
            .map(|(k, t)| {
                let presence = match occ.get(k).map(|d| d.state) {
                    Some(Occupancy::Occupied) => Presence::Occupied,
                    Some(Occupancy::Vacant) => Presence::Vacant,
                    Some(Occupancy::Unknown) | None => Presence::Unknown,
                };
                presence_demand_lx(t, presence, self.control.vacant)
            })
            .collect()
    }

    /// The power model per luminaire.
    pub fn power(&self) -> &[LuminairePower] {
        &self.power
    }

    /// The response matrix the controller plans with: the image's, each luminaire's column
    /// scaled by its ageing factor (row-major desks × luminaires).
    pub fn control_response_lx(&self) -> Vec<f64> {
        let l = self.ageing.len().max(1);
        self.model
            .response_lx
            .iter()
            .enumerate()
            .map(|(i, r)| r * self.ageing.get(i % l).copied().unwrap_or(1.0))
            .collect()
    }

    /// Sets the ageing factor of every luminaire (measured output over the model's, in
    /// (0, 2]; anything else is ignored for that luminaire).
    pub fn set_ageing(&mut self, factors: &[f64]) {
        for (a, &f) in self.ageing.iter_mut().zip(factors) {
            if f.is_finite() && f > 0.0 && f <= 2.0 {
                *a = f;
            }
        }
    }

    /// Publishes live light (`crate::live`): per desk values (desk order; a slice of another
    /// length is refused and the blocks read "not available"), the ageing factor per luminaire
    /// (also applied to the control plant, [`Self::set_ageing`]), the live status bits and the
    /// age of the last frame used, s.
    pub fn set_live(
        &mut self,
        desks: &[crate::modbus::regmap::LiveDesk],
        ageing: &[f64],
        status: u16,
        last_frame_age_s: f64,
    ) {
        let live = &mut self.map.live;
        live.desks.clear();
        if desks.len() == self.map.desks.len() {
            for d in desks {
                let _ = live.desks.push(*d);
            }
        }
        live.ageing.clear();
        for &a in ageing.iter().take(self.ageing.len()) {
            let _ = live.ageing.push(a);
        }
        live.status = status;
        live.last_frame_age_s = last_frame_age_s;
        self.set_ageing(ageing);
    }

    /// Publishes occupancy (`crate::occupancy` through the daemon's hold): per desk its state
    /// and flags (desk order; a slice of another length is refused and every desk reads
    /// unknown), the people count (`None`: not known), the status bits
    /// ([`crate::modbus::regmap::occupancy_status`]) and the hold in effect, s.
    pub fn set_occupancy(
        &mut self,
        desks: &[crate::modbus::regmap::OccupancyDesk],
        people: Option<u16>,
        status: u16,
        hold_s: f64,
    ) {
        let occ = &mut self.map.occupancy;
        occ.desks.clear();
        if desks.len() == self.map.desks.len() {
            for d in desks {
                let _ = occ.desks.push(*d);
            }
        }
        occ.people = people;
        occ.status = status;
        occ.hold_s = hold_s;
    }

    /// Publishes a daylight estimate per desk, lx (desk order); one of the wrong length or with a
    /// value that is not a finite lux >= 0 is refused and the last one kept.
    pub fn set_daylight(&mut self, daylight_lx: &[f64]) -> bool {
        let ok = daylight_lx.len() == self.map.desks.len()
            && daylight_lx
                .iter()
                .all(|v| v.is_finite() && (0.0..=MAX_LUX).contains(v));
        if ok {
            self.daylight = Some((Instant::now(), daylight_lx.to_vec()));
        }
        ok
    }

    /// The daylight estimate if it is younger than the board's limit.
    pub fn fresh_daylight(&self) -> Option<&[f64]> {
        let (t, v) = self.daylight.as_ref()?;
        (t.elapsed().as_secs_f64() <= self.control.daylight_max_age_s).then_some(v.as_slice())
    }

    /// Publishes what the control loop decided: per desk met or not (`None`: control off),
    /// and its flags ([`crate::modbus::regmap::control_flags`]).
    pub fn set_control_status(&mut self, met: Option<&[bool]>, flags: u16) {
        match met {
            Some(m) => {
                for (slot, &ok) in self.map.control.met.iter_mut().zip(m) {
                    *slot = u16::from(ok);
                }
                self.map.control.short = m.iter().filter(|&&ok| !ok).count() as u16;
            }
            None => {
                self.map
                    .control
                    .met
                    .iter_mut()
                    .for_each(|v| *v = NOT_AVAILABLE_U16);
                self.map.control.short = 0;
            }
        }
        self.map.control.flags = flags;
    }

    /// True when every luminaire's level is known.
    pub fn dimming_known(&self) -> bool {
        self.arc_known.iter().all(|&k| k)
    }

    fn curve(&self) -> DimmingCurve {
        self.map.curve
    }

    /// Levels from the arc registers (MASK keeps a level), then desk lux.
    /// Only luminaires whose arc register changed since the last computation are re-read
    /// (a level set exactly by a percent gateway stays exact), all of them when the dimming
    /// curve changed.
    fn recompute(&mut self) {
        let curve = self.curve();
        let all = curve != self.curve_seen;
        for ((l, &a), seen) in self
            .levels
            .iter_mut()
            .zip(self.map.arc.iter())
            .zip(self.arc_seen.iter_mut())
        {
            if all || a != *seen {
                if let Some(x) = ArcLevel(a).fraction(curve) {
                    *l = x;
                }
                *seen = a;
            }
        }
        self.curve_seen = curve;
        self.compute();
    }

    /// Sets levels in [0, 1] directly (a gateway speaking percent); `None` keeps a level. The
    /// arc registers show the nearest arc level on the current curve. A level outside [0, 1]
    /// or not finite is an error and changes nothing.
    pub fn set_levels(&mut self, levels: &[Option<f64>]) -> Result<(), NodeError> {
        if levels.len() != self.levels.len() {
            return Err(NodeError::Length {
                expected: self.levels.len(),
                found: levels.len(),
            });
        }
        let curve = self.curve();
        let mut arcs = Vec::with_capacity(levels.len());
        for (j, x) in levels.iter().enumerate() {
            arcs.push(match x {
                None => None,
                Some(x) => Some(ArcLevel::nearest(*x, curve).ok_or(NodeError::Level {
                    index: j,
                    level: *x,
                })?),
            });
        }
        for (j, (x, a)) in levels.iter().zip(arcs).enumerate() {
            if let (Some(x), Some(a)) = (x, a) {
                self.levels[j] = *x;
                self.map.arc[j] = a.0;
                self.arc_seen[j] = a.0;
                self.arc_known[j] = true;
            }
        }
        self.compute();
        Ok(())
    }

    /// Desk lux by superposition from the current levels. A failure (cannot happen with a
    /// checked image) keeps the last values and raises the compute-error bit.
    fn compute(&mut self) {
        let mut out = vec![0.0; self.model.sensor_ids.len()];
        let r = &self.model.response_lx;
        let ok = superpose(
            |i| r.get(i).copied().unwrap_or(f64::NAN),
            &self.levels,
            &mut out,
        )
        .is_ok();
        // a checked image cannot produce these; never publish them as values
        let ok = ok
            && out
                .iter()
                .all(|v| v.is_finite() && (0.0..=MAX_LUX).contains(v));
        self.map.control.power_w = self
            .power
            .iter()
            .zip(&self.levels)
            .map(|(p, &x)| p.power_w(x))
            .sum();
        // a dimming state never known (a start without levels, before the gateway or a write
        // set each one) gives no value: NaN (0xFFFF in u16), never the lux of all-off
        let known = self.dimming_known();
        if ok {
            for (k, (d, v)) in self.map.desks.iter_mut().zip(out).enumerate() {
                d.lux = if known { v } else { f64::NAN };
                d.model_rel_uncertainty = self.model.rel_uncertainty_at(k, &self.levels);
            }
            self.computed = Instant::now();
            self.map.heartbeat = self.map.heartbeat.wrapping_add(1);
            self.map.status &= !status::COMPUTE_ERROR;
        } else {
            for d in self.map.desks.iter_mut() {
                d.lux = f64::NAN;
            }
            self.map.status |= status::COMPUTE_ERROR;
        }
        self.refresh_flags();
    }

    fn refresh_flags(&mut self) {
        let mut s = self.map.status
            & (status::GATEWAY_CONFIGURED
                | status::COMPUTE_ERROR
                | status::PERIPHERAL_FAULT
                | status::LIGHT_CHECK);
        s |= status::COMMISSIONED;
        if self.store_ok {
            s |= status::STORE_OK;
        }
        if self.sensors_ok {
            s |= status::SENSORS_OK;
        }
        if self.gateway_up && s & status::GATEWAY_CONFIGURED != 0 {
            s |= status::GATEWAY_LINK_UP;
        }
        if self.health.comm_ok() {
            s |= status::COMM_OK;
        }
        if self.policy.writable() {
            s |= status::WRITES_ENABLED;
        }
        // what the servers and links raise (a BBMD that does not accept the registration)
        s |= self.health.raised();
        // the dimming state is unknown while the gateway is lost, and after a start until
        // every luminaire's level was set (by the gateway or a write)
        let stale = !self.gateway_up || !self.dimming_known();
        if stale {
            s |= status::VALUES_STALE;
        }
        self.map.status = s;
        for (k, d) in self.map.desks.iter_mut().enumerate() {
            d.quality = if stale {
                Quality::Stale
            } else {
                self.model.quality(k)
            };
        }
    }

    fn tick(&mut self) {
        let now = Instant::now();
        self.map.uptime_s = now
            .duration_since(self.started)
            .as_secs()
            .min(u64::from(u32::MAX)) as u32;
        self.map.age_s = now
            .duration_since(self.computed)
            .as_secs()
            .min(u64::from(u16::MAX)) as u16;
        self.map.comm = self.health.snapshot();
        self.refresh_flags();
    }

    /// Runs a register-map operation (a protocol adapter's request) with the clocks updated
    /// first; `word_order` (when given) is the requesting client's. The desk values are
    /// recomputed when the operation changed the arc levels or the dimming curve.
    pub fn on_registers(
        &mut self,
        word_order: Option<WordOrder>,
        op: impl FnOnce(&mut RegisterMap) -> Option<(usize, Effect)>,
    ) -> Option<(usize, Effect)> {
        self.tick();
        if let Some(order) = word_order {
            self.map.word_order = order;
        }
        let r = op(&mut self.map);
        if let Some((_, effect)) = r
            && (effect.arc_changed || effect.config_changed)
        {
            self.recompute();
        }
        r
    }

    /// Counts a refused write (clocks updated); returns the refusals so far when one is worth
    /// a log line (at most one a second), `None` otherwise.
    pub fn write_refused(&mut self) -> Option<u64> {
        self.tick();
        let total = self.health.writes_refused.fetch_add(1, Ordering::Relaxed) + 1;
        let now = Instant::now();
        if self
            .last_refusal_log
            .is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1))
        {
            self.last_refusal_log = Some(now);
            Some(total)
        } else {
            None
        }
    }

    /// Records an executed write of `count` registers at `address` (`values`: what was
    /// written) by `source`, who read floats in `order` and found the curve `curve` before it:
    /// counts it, marks the levels it set as known, keeps what it changed of the settings (the
    /// client's word order, the dimming curve, the control mode, desk targets) and persists
    /// them.
    pub fn written(
        &mut self,
        source: &Source,
        (address, count): (u16, u16),
        values: &[u16],
        order: WordOrder,
        curve: DimmingCurve,
    ) {
        self.health.writes_accepted.fetch_add(1, Ordering::Relaxed);
        let was_known = self.dimming_known();
        for (k, v) in values.iter().enumerate() {
            let a = usize::from(address) + k;
            if let Some(j) = a.checked_sub(usize::from(addr::ARC_LEVEL))
                && *v != u16::from(ArcLevel::MASK.0)
                && let Some(known) = self.arc_known.get_mut(j)
            {
                *known = true;
            }
        }
        let changed = self.keep_word_order(source, order)
            | self.keep_curve(curve)
            | self.keep_control(address, count);
        if changed {
            self.save_settings();
        }
        if !was_known && self.dimming_known() {
            // the write made the dimming state known: its values replace the NaNs
            self.compute();
        } else {
            self.refresh_flags();
        }
    }

    /// Persists the settings clients wrote (when the node has a settings file).
    fn save_settings(&self) {
        if let Some(path) = &self.settings_path {
            match self.settings.save(path) {
                Ok(()) => tracing::info!(
                    target: "luxnode::audit",
                    "settings saved to {}",
                    path.display()
                ),
                Err(e) => tracing::error!("{e}: the setting holds until the node restarts"),
            }
        }
    }

    /// Sets the lighting-control mode (an adapter other than the register map: what a client
    /// writes wins over the board's, and is persisted).
    pub fn set_control_mode(&mut self, mode: Mode) {
        self.map.control.mode = mode.code();
        self.settings.control_mode = Some(mode.code());
        self.save_settings();
        self.refresh_flags();
    }

    /// Sets the target of desk `desk_id`, lx, rounded to whole lux (an adapter other than the
    /// register map; persisted like a register write).
    pub fn set_target_lx(&mut self, desk_id: u32, target_lx: f64) -> Result<(), NodeError> {
        let k = self
            .model
            .sensor_ids
            .iter()
            .position(|&id| id == desk_id)
            .ok_or(NodeError::UnknownDesk(desk_id))?;
        if !(target_lx.is_finite() && (0.0..=f64::from(MAX_TARGET_LX)).contains(&target_lx)) {
            return Err(NodeError::Target(target_lx));
        }
        let t = libm::round(target_lx) as u16;
        if let Some(slot) = self.map.control.targets_lx.get_mut(k) {
            *slot = t;
        }
        self.settings.targets_lx.insert(desk_id, t);
        self.save_settings();
        Ok(())
    }

    /// Keeps the client's word order when a write changed it; true when the settings changed.
    fn keep_word_order(&mut self, source: &Source, order: WordOrder) -> bool {
        if self.map.word_order == order {
            return false;
        }
        let key = source.client_key();
        if self.settings.word_orders.len() < MAX_CLIENT_SETTINGS
            || self.settings.word_orders.contains_key(&key)
        {
            self.settings
                .word_orders
                .insert(key, self.map.word_order as u16);
            true
        } else {
            tracing::warn!("word order of {source} not kept: too many clients with one");
            false
        }
    }

    /// Keeps the dimming curve when a write changed it; true when the settings changed.
    fn keep_curve(&mut self, curve: DimmingCurve) -> bool {
        if self.map.curve == curve {
            return false;
        }
        self.settings.dimming_curve = Some(self.map.curve as u16);
        true
    }

    /// Keeps the control mode and the desk targets a write touched; true when it touched any.
    fn keep_control(&mut self, address: u16, count: u16) -> bool {
        let touches = |first: u16, n: usize| {
            let end = usize::from(address) + usize::from(count);
            usize::from(address) < usize::from(first) + n && end > usize::from(first)
        };
        let mut changed = false;
        if touches(addr::CONTROL_MODE, 1) {
            self.settings.control_mode = Some(self.map.control.mode);
            changed = true;
        }
        let d = self.map.control.targets_lx.len();
        if touches(addr::DESK_TARGET, d) {
            for (k, id) in self.model.sensor_ids.iter().enumerate() {
                let a = usize::from(addr::DESK_TARGET) + k;
                if a >= usize::from(address) && a < usize::from(address) + usize::from(count) {
                    self.settings
                        .targets_lx
                        .insert(*id, self.map.control.targets_lx[k]);
                }
            }
            changed = true;
        }
        changed
    }
}

/// A node shared by servers and the gateway link.
pub type SharedNode = Arc<Mutex<Node>>;

/// Locks a shared handler; a poisoned lock (a panic elsewhere) still yields the state, which
/// is never left half-updated by the handlers.
pub fn lock<T: ?Sized>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> NodeModel {
        NodeModel {
            response_lx: vec![100.0, 200.0, 10.0, 20.0],
            sensor_ids: vec![7, 9],
            luminaire_ids: vec![1, 2],
            sensor_flags: vec![0, 0],
            model_rel_uncertainty: vec![f64::NAN; 2],
            uncertainty_parts_lx: Vec::new(),
            occluder_groups: Vec::new(),
            generation: 1,
            luminaire_power: vec![RatedPower::assumed(1000.0); 2],
            point_names: Vec::new(),
        }
    }

    #[test]
    fn the_demand_follows_people_and_fails_bright() {
        use crate::control::VacantLight;
        use crate::modbus::regmap::{Occupancy, OccupancyDesk};
        let desk = |state| OccupancyDesk { state, flags: 0 };
        for (vacant, vacant_lx) in [(VacantLight::Surrounding, 300.0), (VacantLight::Off, 0.0)] {
            let options = NodeOptions {
                control: ControlOptions {
                    vacant,
                    ..ControlOptions::default()
                },
                ..NodeOptions::default()
            };
            let mut node = Node::new(model(), options).expect("node");
            // no occupancy: every desk its target
            assert_eq!(node.demand_lx(), [500.0, 500.0]);
            node.set_occupancy(
                &[desk(Occupancy::Occupied), desk(Occupancy::Vacant)],
                Some(1),
                0,
                900.0,
            );
            assert_eq!(node.demand_lx(), [500.0, vacant_lx]);
            // unknown (a bad frame, a desk not seen) is never taken as vacant
            node.set_occupancy(
                &[desk(Occupancy::Unknown), desk(Occupancy::Unknown)],
                None,
                0,
                900.0,
            );
            assert_eq!(node.demand_lx(), [500.0, 500.0]);
            // the registers keep what clients wrote
            assert_eq!(node.targets_lx(), [500.0, 500.0]);
        }
        // a 300 lx target's surroundings: 200 lx; a 150 lx target's: its own
        use crate::control::{Presence, presence_demand_lx};
        let s = VacantLight::Surrounding;
        assert_eq!(presence_demand_lx(300.0, Presence::Vacant, s), 200.0);
        assert_eq!(presence_demand_lx(150.0, Presence::Vacant, s), 150.0);
        assert_eq!(presence_demand_lx(750.0, Presence::Vacant, s), 500.0);
    }

    #[test]
    fn an_adapter_sets_mode_and_targets_without_registers() {
        let dir = std::env::temp_dir().join(format!("luxnode-node-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        let path = dir.join("settings.json");
        let _ = std::fs::remove_file(&path);
        let options = NodeOptions {
            settings_path: Some(path.clone()),
            ..NodeOptions::default()
        };
        let mut node = Node::new(model(), options.clone()).expect("node");
        node.set_control_mode(Mode::DaylightHarvesting);
        assert_eq!(node.control_mode(), Mode::DaylightHarvesting);
        node.set_target_lx(9, 420.4).expect("target");
        assert_eq!(node.targets_lx()[1], 420.0);
        assert!(matches!(
            node.set_target_lx(8, 100.0),
            Err(NodeError::UnknownDesk(8))
        ));
        assert!(matches!(
            node.set_target_lx(7, f64::NAN),
            Err(NodeError::Target(_))
        ));
        // kept across a restart, like a register write
        let again = Node::new(model(), options).expect("node");
        assert_eq!(again.control_mode(), Mode::DaylightHarvesting);
        assert_eq!(again.targets_lx()[1], 420.0);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
