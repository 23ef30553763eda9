//! The Modbus adapter of the node: register requests onto [`Node`].
//!
//! A request PDU is checked against the node's access policy (who may write), read or
//! written on the node's register snapshot in the client's word order, and an executed write
//! is logged and handed to the node, which keeps what it changed of the settings. The servers
//! (TCP, TLS, RTU) call it through [`PduHandler`].

use crate::modbus::access::{Source, write_span};
use crate::modbus::pdu::{Exception, MAX_PDU, encode_exception, function};
use crate::modbus::regmap::Effect;
use crate::node::Node;

/// What a request handler needs: a PDU in, a response PDU out (`None`: no answer).
pub trait PduHandler: Send {
    /// Handles one request PDU addressed to `unit`; writes the response into `out`.
    fn handle_pdu(&mut self, unit: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize>;

    /// Handles one request PDU from `source` (the servers call this: the node decides per
    /// source what it may write and how it reads floats). By default the source is ignored.
    fn handle_from(
        &mut self,
        source: &Source,
        unit: u8,
        pdu: &[u8],
        out: &mut [u8; MAX_PDU],
    ) -> Option<usize> {
        let _ = source;
        self.handle_pdu(unit, pdu, out)
    }
}

/// Handles a request PDU from `source` addressed to `unit`: writes only from the allowlist
/// (others: exception 0x01, counted, logged), floats in the client's word order, every
/// executed write logged and its settings persisted.
pub fn process_from(
    node: &mut Node,
    source: &Source,
    unit: u8,
    pdu: &[u8],
    out: &mut [u8; MAX_PDU],
) -> Option<(usize, Effect)> {
    let span = write_span(pdu);
    if let Some((address, count)) = span
        && !node.policy().may_write(source, address, count)
    {
        if let Some(refused) = node.write_refused() {
            tracing::warn!(
                target: "luxnode::audit",
                %source,
                address,
                count,
                "modbus write refused: {source} is not in the write allowlist \
                 ({count} registers at {address}; {refused} refused so far)"
            );
        }
        let n = encode_exception(pdu[0], Exception::IllegalFunction, out);
        return Some((n, Effect::default()));
    }
    let order = node.policy().word_order(node.settings(), source, unit);
    let curve = node.map().curve;
    let r = node.on_registers(Some(order), |map| map.process(pdu, out));
    if let (Some((address, count)), Some((n, _))) = (span, r)
        && n > 0
        && out[0] == pdu[0]
    {
        let values = written_values(pdu, count);
        tracing::info!(
            target: "luxnode::audit",
            %source,
            address,
            count,
            "modbus write by {source}: {count} registers at {address} = {values:?}"
        );
        node.written(source, (address, count), &values, order, curve);
    }
    r
}

/// The register values of an executed write request.
fn written_values(pdu: &[u8], count: u16) -> Vec<u16> {
    if pdu[0] == function::WRITE_SINGLE {
        pdu.get(3..5)
            .map(|b| vec![u16::from_be_bytes([b[0], b[1]])])
            .unwrap_or_default()
    } else {
        pdu.get(6..)
            .unwrap_or(&[])
            .chunks_exact(2)
            .take(usize::from(count))
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect()
    }
}

/// Handles a request PDU with no source (internal): clocks updated, request handled, desk
/// values recomputed when the arc levels or the dimming curve changed.
pub fn process(node: &mut Node, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<(usize, Effect)> {
    node.on_registers(None, |map| map.process(pdu, out))
}

impl PduHandler for Node {
    fn handle_pdu(&mut self, unit: u8, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<usize> {
        process_from(self, &Source::Internal, unit, pdu, out).map(|(n, _)| n)
    }

    fn handle_from(
        &mut self,
        source: &Source,
        unit: u8,
        pdu: &[u8],
        out: &mut [u8; MAX_PDU],
    ) -> Option<usize> {
        process_from(self, source, unit, pdu, out).map(|(n, _)| n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::Ordering;

    use crate::dali::DimmingCurve;
    use crate::modbus::access::AccessPolicy;
    use crate::modbus::regmap::{WordOrder, addr, status};
    use crate::node::{NodeModel, NodeOptions};
    use crate::store::sensor_flags;

    fn model() -> NodeModel {
        NodeModel {
            // 2 sensors × 3 luminaires
            response_lx: vec![100.0, 200.0, 300.0, 10.0, 20.0, 30.0],
            sensor_ids: vec![7, 9],
            luminaire_ids: vec![1, 2, 3],
            sensor_flags: vec![0, sensor_flags::OUT_OF_VIEW],
            model_rel_uncertainty: vec![0.03, f64::NAN],
            uncertainty_parts_lx: Vec::new(),
            occluder_groups: Vec::new(),
            generation: 5,
            luminaire_power: vec![crate::control::rating::RatedPower::assumed(1200.0); 3],
            point_names: Vec::new(),
        }
    }

    fn read_input(node: &mut Node, a: u16, q: u16) -> Vec<u16> {
        let mut out = [0u8; MAX_PDU];
        let req = [4, (a >> 8) as u8, a as u8, 0, q as u8];
        let (n, _) = process(node, &req, &mut out).unwrap();
        assert_eq!(out[0], 4, "{:?}", &out[..n]);
        out[2..n]
            .chunks(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect()
    }

    #[test]
    fn arc_writes_recompute_by_superposition() {
        let mut node = Node::new(model(), NodeOptions::default()).unwrap();
        assert_eq!(
            read_input(&mut node, addr::DESK_U16, 2),
            vec![0xFFFF, 0xFFFF],
            "unknown at start"
        );
        // write all three arc levels: 254 (100 %), 0 (off), 1 (0.1 %)
        let mut out = [0u8; MAX_PDU];
        let req = [0x10, 0x03, 0xE8, 0, 3, 6, 0, 254, 0, 0, 0, 1];
        process_from(&mut node, &Source::Internal, 1, &req, &mut out).unwrap();
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

    fn ask(node: &mut Node, src: &Source, unit: u8, pdu: &[u8]) -> Vec<u8> {
        let mut out = [0u8; MAX_PDU];
        let (n, _) = process_from(node, src, unit, pdu, &mut out).unwrap();
        out[..n].to_vec()
    }

    fn tcp(a: &str) -> Source {
        Source::Tcp(format!("{a}:1234").parse().unwrap())
    }

    #[test]
    fn read_only_by_default_and_writes_only_from_the_allowlist() {
        let mut node = Node::new(model(), NodeOptions::default()).unwrap();
        let stranger = tcp("10.9.9.9");
        // every write function, every writable register: exception 0x01, nothing changes
        for pdu in [
            vec![6, 0x03, 0xE8, 0, 0],
            vec![6, 0x07, 0xD0, 0, 1],
            vec![6, 0x07, 0xD1, 0, 1],
            vec![0x10, 0x03, 0xE8, 0, 3, 6, 0, 0, 0, 0, 0, 0],
        ] {
            assert_eq!(ask(&mut node, &stranger, 1, &pdu), vec![pdu[0] | 0x80, 1]);
        }
        assert_eq!(node.map().arc[..], [0, 0, 0]);
        assert_eq!(node.health().writes_refused.load(Ordering::Relaxed), 4);
        let st = read_input(&mut node, addr::STATUS, 1)[0];
        assert_eq!(st & status::WRITES_ENABLED, 0);
        // RTU broadcast and master: refused too
        let rtu = Source::Rtu("/dev/ttyS1".into());
        assert_eq!(
            ask(&mut node, &rtu, 0, &[6, 0x03, 0xE8, 0, 0]),
            vec![0x86, 1]
        );
        // reads are open to all
        assert_eq!(
            ask(&mut node, &stranger, 1, &[4, 0, 1, 0, 1]),
            vec![4, 2, 0, 2]
        );
        let policy = AccessPolicy::default()
            .with_writers(&["10.0.0.0/8".into()])
            .unwrap();
        node.set_policy(policy);
        assert_eq!(
            ask(&mut node, &stranger, 1, &[6, 0x03, 0xE8, 0, 254]),
            vec![6, 0x03, 0xE8, 0, 254]
        );
        assert_eq!(node.map().arc[0], 254);
        assert_eq!(node.health().writes_accepted.load(Ordering::Relaxed), 1);
        assert_ne!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::WRITES_ENABLED,
            0
        );
        assert_eq!(
            ask(&mut node, &tcp("192.168.1.1"), 1, &[6, 0x03, 0xE8, 0, 0]),
            vec![0x86, 1]
        );
    }

    #[test]
    fn word_order_is_per_client_and_persists() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("settings.json");
        let mut policy = AccessPolicy::default()
            .with_writers(&["10.0.0.1".into(), "10.0.0.2".into()])
            .unwrap();
        policy.word_orders.units.insert(9, WordOrder::Dcba);
        let options = NodeOptions {
            initial_arc: Some(254),
            policy,
            settings_path: Some(path.clone()),
            ..NodeOptions::default()
        };
        let mut node = Node::new(model(), options.clone()).unwrap();
        let (a, b) = (tcp("10.0.0.1"), tcp("10.0.0.2"));
        // desk 0 at full output: 600 lx = 0x44160000
        let float = |node: &mut Node, src: &Source, unit: u8| {
            ask(node, src, unit, &[4, 0, 100, 0, 2])[2..].to_vec()
        };
        assert_eq!(float(&mut node, &a, 1), [0x44, 0x16, 0, 0]);
        // client a asks for CDAB: only a reads CDAB
        ask(&mut node, &a, 1, &[6, 0x07, 0xD0, 0, 1]);
        assert_eq!(float(&mut node, &a, 1), [0, 0, 0x44, 0x16]);
        assert_eq!(float(&mut node, &b, 1), [0x44, 0x16, 0, 0]);
        assert_eq!(
            ask(&mut node, &b, 1, &[3, 0x07, 0xD0, 0, 1]),
            vec![3, 2, 0, 0]
        );
        assert_eq!(ask(&mut node, &a, 1, &[4, 0, 12, 0, 1]), vec![4, 2, 0, 1]);
        // unit 9 reads DCBA (board table) unless the client set its own
        assert_eq!(float(&mut node, &b, 9), [0, 0, 0x16, 0x44]);
        assert_eq!(float(&mut node, &a, 9), [0, 0, 0x44, 0x16]);
        // the dimming curve is global, and persisted with the word order
        ask(&mut node, &b, 1, &[6, 0x07, 0xD1, 0, 1]);
        drop(node);
        let mut node = Node::new(model(), options).unwrap();
        assert_eq!(node.map().curve, DimmingCurve::Linear);
        assert_eq!(float(&mut node, &a, 1), [0, 0, 0x44, 0x16]);
        assert_eq!(float(&mut node, &b, 1), [0x44, 0x16, 0, 0]);
        let saved = std::fs::read_to_string(&path).unwrap();
        assert!(saved.contains("\"10.0.0.1\": 1"), "{saved}");
    }

    #[test]
    fn values_are_stale_until_every_level_is_known() {
        let mut node = Node::new(model(), NodeOptions::default()).unwrap();
        let me = Source::Internal;
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 2), vec![1, 1]);
        // unknown, not dark: NaN and 0xFFFF
        assert_eq!(read_input(&mut node, addr::DESK_FLOAT, 2), vec![0x7FC0, 0]);
        assert_eq!(read_input(&mut node, addr::DESK_U16, 2), vec![0xFFFF; 2]);
        assert_ne!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::VALUES_STALE,
            0
        );
        // two of three set, the third masked: still unknown
        ask(
            &mut node,
            &me,
            1,
            &[0x10, 0x03, 0xE8, 0, 3, 6, 0, 254, 0, 10, 0, 255],
        );
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 2), vec![1, 1]);
        assert_eq!(read_input(&mut node, addr::DESK_U16, 2), vec![0xFFFF; 2]);
        ask(&mut node, &me, 1, &[6, 0x03, 0xEA, 0, 0]);
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 2), vec![0, 2]);
        assert!(
            read_input(&mut node, addr::DESK_U16, 2)
                .iter()
                .all(|&v| v < 0xFFFF)
        );
        assert_eq!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::VALUES_STALE,
            0
        );
        // given at start: known
        let known = NodeOptions {
            initial_arc: Some(0),
            ..NodeOptions::default()
        };
        let mut node = Node::new(model(), known).unwrap();
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 2), vec![0, 2]);
    }

    #[test]
    fn out_of_range_values_are_never_published() {
        let mut m = model();
        m.response_lx[0] = -8000.0;
        let options = NodeOptions {
            initial_arc: Some(254),
            ..NodeOptions::default()
        };
        let mut node = Node::new(m, options).unwrap();
        assert_eq!(read_input(&mut node, addr::DESK_FLOAT, 2), vec![0x7FC0, 0]);
        assert_eq!(read_input(&mut node, addr::DESK_QUALITY, 1), vec![0xFFFF]);
        assert_ne!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::COMPUTE_ERROR,
            0
        );
    }

    #[test]
    fn the_sensors_bit_is_cleared_and_set_again() {
        let mut node = Node::new(model(), NodeOptions::default()).unwrap();
        assert_ne!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::SENSORS_OK,
            0
        );
        node.set_sensors_ok(false);
        assert_eq!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::SENSORS_OK,
            0
        );
        node.set_sensors_ok(true);
        assert_ne!(
            read_input(&mut node, addr::STATUS, 1)[0] & status::SENSORS_OK,
            0
        );
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
