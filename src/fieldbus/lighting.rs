//! The lighting-control task of the node (std): every tick it runs the control loop
//! ([`crate::control::regulator`]) over the node's response matrix (with the luminaires' ageing
//! factors), the desks' targets and mode from the registers, and the latest daylight estimate,
//! then delivers the levels: to the DALI gateway when one is configured (written to its level
//! registers; the gateway poll then reads back what was written), straight into the node
//! otherwise. What it decided is published in the control registers (input 60..=67, 700 + k).
//!
//! While the mode is off the task commands nothing. While control is on, it owns the levels: a
//! level a BMS writes at holding 1000 + j is replaced at the next plan.

use std::time::{Duration, Instant};

use tokio::sync::watch;
use tokio_modbus::client::Context;

use super::gateway::{self, GatewayConfig};
use crate::control::regulator::{Inputs, Mode, Regulator};
use crate::control::{Plant, scratch_len};
use crate::dali::{ArcLevel, DimmingCurve};
use crate::modbus::regmap::control_flags;
use crate::node::{SharedNode, lock};

/// What one tick saw and decided, for the log and the tests.
#[derive(Debug, Clone, PartialEq)]
pub struct TickReport {
    /// The mode.
    pub mode: Mode,
    /// Levels delivered this tick.
    pub delivered: Option<Vec<ArcLevel>>,
    /// Flags published.
    pub flags: u16,
}

/// The control loop bound to a node: its regulator, its scratch and its gateway connection.
pub struct Lighting {
    node: SharedNode,
    gateway: Option<GatewayConfig>,
    ctx: Option<Context>,
    regulator: Regulator,
    scratch: Vec<f64>,
    started: Instant,
    delivered_ok: bool,
    last_mode: Option<Mode>,
    /// The node's count of gateway link changes at the last tick.
    link_changes: u64,
}

impl Lighting {
    /// The loop for `node`, delivering through `gateway` if given.
    pub fn new(node: SharedNode, gateway: Option<GatewayConfig>) -> Self {
        let (settings, link_changes) = {
            let n = lock(&node);
            (n.control_options().loop_settings, n.gateway_link_changes())
        };
        Self {
            node,
            gateway,
            ctx: None,
            regulator: Regulator::new(Mode::Off, settings),
            scratch: Vec::new(),
            started: Instant::now(),
            delivered_ok: true,
            last_mode: None,
            link_changes,
        }
    }

    /// One tick.
    pub async fn tick(&mut self) -> TickReport {
        let (mode, response, power, targets, daylight, kd, l, link_up, link_changes) = {
            let n = lock(&self.node);
            (
                n.control_mode(),
                n.control_response_lx(),
                n.power().to_vec(),
                n.demand_lx(),
                n.fresh_daylight().map(<[f64]>::to_vec),
                n.model().sensor_ids.len(),
                n.model().luminaire_ids.len(),
                n.gateway_link_up(),
                n.gateway_link_changes(),
            )
        };
        // the link lost and back between two ticks (two changes or more) is a loss too: down for
        // this tick, so the next one resends
        let bounced = link_changes.wrapping_sub(self.link_changes) >= 2;
        self.link_changes = link_changes;
        let up = self.delivered_ok && link_up && !bounced;
        if self.last_mode != Some(mode) {
            tracing::info!("lighting control: mode {mode:?}");
            self.last_mode = Some(mode);
        }
        self.regulator.mode = mode;
        if mode == Mode::Off {
            lock(&self.node).set_control_status(None, 0);
            return TickReport {
                mode,
                delivered: None,
                flags: 0,
            };
        }
        let uniform = self.regulator.settings.uniformity.is_some();
        let need = scratch_len(kd, l, uniform);
        if self.scratch.len() < need {
            self.scratch.resize(need, 0.0);
        }
        let plant = Plant {
            desks: kd,
            luminaires: l,
            response_lx: &response,
            power: &power,
            curve: DimmingCurve::Logarithmic,
        };
        let now_s = self.started.elapsed().as_secs_f64();
        let tick = match self.regulator.tick(
            &plant,
            &targets,
            Inputs {
                now_s,
                daylight_lx: daylight.as_deref(),
                // the gateway poll sees a lost link (and a gateway restarted with its gear at
                // its failure level) even when the loop has nothing to write: the levels are
                // resent when it is back
                gateway_up: up,
            },
            &mut self.scratch,
        ) {
            Ok(t) => t,
            Err(e) => {
                // inputs from the image and the registers are checked; this is a bug: say it,
                // command nothing
                tracing::error!("lighting control: {e}");
                return TickReport {
                    mode,
                    delivered: None,
                    flags: control_flags::NOT_DELIVERED,
                };
            }
        };
        let mut delivered = None;
        if let Some(levels) = &tick.write {
            let levels: Vec<ArcLevel> = levels.iter().copied().collect();
            self.delivered_ok = self.deliver(&levels).await;
            if self.delivered_ok {
                delivered = Some(levels);
            }
        } else if !self.delivered_ok {
            // retry: the regulator resends when the link is back
            self.delivered_ok = self.probe().await;
        }
        let holding = self
            .regulator
            .plan()
            .arc
            .iter()
            .zip(self.regulator.current())
            .any(|(p, c)| p != c);
        // delivered: the link up all along and every level the loop commands sent at least once
        let all_delivered =
            up && self.delivered_ok && !self.regulator.current().contains(&ArcLevel::MASK);
        let flags = if tick.safe { control_flags::SAFE } else { 0 }
            | if all_delivered {
                0
            } else {
                control_flags::NOT_DELIVERED
            }
            | if holding && all_delivered {
                control_flags::HOLDING
            } else {
                0
            };
        let met: Vec<bool> = self.regulator.plan().met.iter().copied().collect();
        lock(&self.node).set_control_status(Some(&met), flags);
        TickReport {
            mode,
            delivered,
            flags,
        }
    }

    /// Sends levels to the gateway (or sets them in the node when there is none).
    async fn deliver(&mut self, levels: &[ArcLevel]) -> bool {
        let raw: Vec<u8> = levels.iter().map(|a| a.0).collect();
        let Some(config) = self.gateway.clone() else {
            return lock(&self.node).set_arc_levels(&raw).is_ok();
        };
        if self.ctx.is_none() {
            match gateway::connect(&config).await {
                Ok(c) => self.ctx = Some(c),
                Err(e) => {
                    tracing::warn!("lighting control: gateway: {e}; levels not delivered");
                    return false;
                }
            }
        }
        let Some(ctx) = self.ctx.as_mut() else {
            return false;
        };
        match gateway::write_arc_levels(ctx, &config, levels).await {
            Ok(()) => {
                tracing::info!(target: "luxnode::audit", "lighting control: levels {raw:?} written to the gateway");
                // the node shows them at once; the gateway poll confirms them (a poll read in
                // flight meanwhile is dropped: it holds the old levels)
                let _ = lock(&self.node).set_arc_levels_delivered(&raw);
                true
            }
            Err(e) => {
                tracing::warn!("lighting control: gateway: {e}; levels not delivered");
                self.ctx = None;
                false
            }
        }
    }

    /// Whether the gateway answers again.
    async fn probe(&mut self) -> bool {
        match &self.gateway {
            None => true,
            Some(config) => match gateway::connect(config).await {
                Ok(c) => {
                    self.ctx = Some(c);
                    true
                }
                Err(_) => false,
            },
        }
    }
}

/// Runs the task until `shutdown` turns true, ticking at the board's interval.
pub async fn run(
    node: SharedNode,
    gateway: Option<GatewayConfig>,
    mut shutdown: watch::Receiver<bool>,
) {
    let tick_s = lock(&node).control_options().tick_s.clamp(0.05, 3600.0);
    let mut lighting = Lighting::new(node, gateway);
    let mut interval = tokio::time::interval(Duration::from_secs_f64(tick_s));
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = interval.tick() => {}
            _ = shutdown.changed() => return,
        }
        lighting.tick().await;
    }
}
