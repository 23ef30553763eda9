//! The served state: a commissioned image behind the register map.
//!
//! [`Node`] owns the [`RegisterMap`], the response matrix copied out of the image (sensors ×
//! luminaires, a few kB) and the current dimming levels. Every change of the dimming state (a
//! write of the arc-level registers, or a poll of the DALI gateway) recomputes the desk values
//! at once by superposition, so a read always returns values consistent with the arc levels it
//! can read next to them. The servers (TCP, RTU) share one node behind a mutex held only for
//! the few microseconds a request takes.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use super::pdu::MAX_PDU;
use super::regmap::{
    Desk, Effect, Identity, MAX_DESKS, MAX_LUMINAIRES, Quality, RegisterMap, status,
};
use crate::dali::{ArcLevel, DimmingCurve};
use crate::runtime::superpose;
use crate::store::{Image, sensor_flags};

/// What a request handler needs: a PDU in, a response PDU out (`None`: no answer).
pub trait PduHandler: Send {
    /// Handles one request PDU addressed to `unit`; writes the response into `out`.
    fn handle_pdu(&mut self, unit: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize>;
}

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
    /// Image generation (from the A/B slots; 0 for a plain file).
    pub generation: u64,
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
        let mut response_lx = Vec::with_capacity(s * l);
        for si in 0..s {
            for li in 0..l {
                response_lx.push(image.response_lx(si, li));
            }
        }
        Self {
            response_lx,
            sensor_ids: (0..s).map(|k| image.sensor_id(k)).collect(),
            luminaire_ids: (0..l).map(|j| image.luminaire_id(j)).collect(),
            sensor_flags: (0..s).map(|k| image.sensor_flags(k)).collect(),
            generation,
        }
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

/// Serving options.
#[derive(Debug, Clone, Default)]
pub struct NodeOptions {
    /// Identification strings (function 0x2B / 0x0E).
    pub identity: Identity,
    /// A DALI gateway link is configured (the arc levels follow it).
    pub gateway_configured: bool,
    /// Initial arc level of every luminaire (`None`: off).
    pub initial_arc: Option<u8>,
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
    store_ok: bool,
    sensors_ok: bool,
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
        for (k, &id) in model.sensor_ids.iter().enumerate() {
            // capacity checked above
            let _ = map.desks.push(Desk {
                id,
                lux: f64::NAN,
                quality: model.quality(k),
            });
        }
        for &id in &model.luminaire_ids {
            let _ = map.luminaire_ids.push(id);
            let _ = map.arc.push(arc0);
        }
        let now = Instant::now();
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
            store_ok: true,
            sensors_ok: true,
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
        for (slot, &a) in self.map.arc.iter_mut().zip(arc) {
            if a != ArcLevel::MASK.0 {
                *slot = a;
            }
        }
        self.recompute();
        Ok(())
    }

    /// The DALI gateway link went up (`true`) or was lost (`false`). While it is lost the desk
    /// values are the last good ones, flagged stale (quality and status bit).
    pub fn set_gateway_link(&mut self, up: bool) {
        if self.gateway_up != up {
            self.gateway_up = up;
            self.refresh_flags();
        }
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
        self.sensors_ok = ok;
        self.refresh_flags();
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
        if ok {
            for (d, v) in self.map.desks.iter_mut().zip(out) {
                d.lux = v;
            }
            self.computed = Instant::now();
            self.map.heartbeat = self.map.heartbeat.wrapping_add(1);
            self.map.status &= !status::COMPUTE_ERROR;
        } else {
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
        let stale = !self.gateway_up;
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
    }

    /// Handles a request PDU: clocks updated, request handled, desk values recomputed when the
    /// arc levels or the dimming curve changed.
    pub fn process(&mut self, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<(usize, Effect)> {
        self.tick();
        let r = self.map.process(pdu, out);
        if let Some((_, effect)) = r
            && (effect.arc_changed || effect.config_changed)
        {
            self.recompute();
        }
        r
    }
}

impl PduHandler for Node {
    fn handle_pdu(&mut self, _unit: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize> {
        self.process(pdu, out).map(|(n, _)| n)
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
    use crate::modbus::regmap::addr;

    fn model() -> NodeModel {
        NodeModel {
            // 2 sensors × 3 luminaires
            response_lx: vec![100.0, 200.0, 300.0, 10.0, 20.0, 30.0],
            sensor_ids: vec![7, 9],
            luminaire_ids: vec![1, 2, 3],
            sensor_flags: vec![0, sensor_flags::OUT_OF_VIEW],
            generation: 5,
        }
    }

    fn read_input(node: &mut Node, a: u16, q: u16) -> Vec<u16> {
        let mut out = [0u8; MAX_PDU];
        let req = [4, (a >> 8) as u8, a as u8, 0, q as u8];
        let (n, _) = node.process(&req, &mut out).unwrap();
        assert_eq!(out[0], 4, "{:?}", &out[..n]);
        out[2..n]
            .chunks(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect()
    }

    #[test]
    fn arc_writes_recompute_by_superposition() {
        let mut node = Node::new(model(), NodeOptions::default()).unwrap();
        assert_eq!(read_input(&mut node, addr::DESK_U16, 2), vec![0, 0]);
        // write all three arc levels: 254 (100 %), 0 (off), 1 (0.1 %)
        let mut out = [0u8; MAX_PDU];
        let req = [0x10, 0x03, 0xE8, 0, 3, 6, 0, 254, 0, 0, 0, 1];
        node.process(&req, &mut out).unwrap();
        let expect0 = 100.0 + 300.0 * 0.001;
        let d = node.desks();
        assert!((d[0].1 - expect0).abs() < 1e-12, "{d:?}");
        assert_eq!(read_input(&mut node, addr::DESK_U16, 2), vec![100, 10]);
        // quality: ok, out of view
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 2), vec![0, 2]);
        // MASK keeps
        node.set_arc_levels(&[255, 254, 255]).unwrap();
        assert!((node.desks()[0].1 - (100.0 + 200.0 + 0.3)).abs() < 1e-9);
        assert!(node.set_arc_levels(&[1, 2]).is_err());
        // levels set directly (percent gateways): exact, arc registers show the nearest level
        node.set_levels(&[Some(0.5), None, Some(0.0)]).unwrap();
        assert!((node.desks()[0].1 - (50.0 + 200.0)).abs() < 1e-9);
        assert_eq!(node.map().arc[0], 229);
        assert!(node.set_levels(&[Some(1.5), None, None]).is_err());
        assert!((node.desks()[0].1 - 250.0).abs() < 1e-9, "unchanged");
    }

    #[test]
    fn gateway_loss_flags_stale_and_keeps_values() {
        let options = NodeOptions {
            gateway_configured: true,
            initial_arc: Some(254),
            ..NodeOptions::default()
        };
        let mut node = Node::new(model(), options).unwrap();
        // not up until the first successful poll
        let st = read_input(&mut node, addr::STATUS, 1)[0];
        assert_ne!(st & status::VALUES_STALE, 0);
        node.set_gateway_link(true);
        let st = read_input(&mut node, addr::STATUS, 1)[0];
        assert_eq!(st & status::VALUES_STALE, 0);
        assert_ne!(st & status::GATEWAY_LINK_UP, 0);
        let before = read_input(&mut node, addr::DESK_FLOAT, 4);
        node.set_gateway_link(false);
        assert_eq!(read_input(&mut node, addr::DESK_FLOAT, 4), before);
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 2), vec![1, 1]);
        let st = read_input(&mut node, addr::STATUS, 1)[0];
        assert_ne!(st & status::VALUES_STALE, 0);
        assert_eq!(st & status::GATEWAY_LINK_UP, 0);
    }
}
