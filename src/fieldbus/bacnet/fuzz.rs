//! A mutational fuzzer for the BACnet/IP server (deterministic for a seed).
//!
//! Seeds are valid datagrams of every service the node answers (and some it refuses); each
//! round mutates one (bit flips, boundary bytes, truncation, extension, random bytes, the BVLC
//! length fixed up half the time so the mutation reaches the NPDU and APDU decoders) or makes
//! one of random bytes, and hands it to [`Server::handle`] on a node like a commissioned
//! one's, with writes allowed from the fuzzer's address. Every answer must be well formed:
//!
//! * it parses as BVLC (length right), NPDU and APDU with the node's own decoder;
//! * an answer to a confirmed request carries the request's invoke id and is an ACK, Error,
//!   Reject or Abort; nothing answers a datagram that is not BACnet/IP;
//! * after the run, a clean ReadProperty is still answered with the right value.
//!
//! The fuzz crate's `bacnet_datagram` target and `tests/bacnet.rs` run it.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use super::service::{Outgoing, Server, ServerConfig};
use crate::bacnet::consts::{confirmed, property, unconfirmed};
use crate::bacnet::objects::DeviceInfo;
use crate::bacnet::who_has::{Wanted, WhoHas};
use crate::bacnet::wire::{Apdu, Bvlc, Npdu, ObjectId, Writer};
use crate::modbus::access::AccessPolicy;
use crate::node::{Node, NodeModel, NodeOptions};
use crate::rng::SplitMix64;

/// Outcome counts.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct FuzzReport {
    /// Datagrams tried.
    pub datagrams: u64,
    /// Datagrams answered.
    pub answered: u64,
    /// Answers that are ACKs.
    pub acks: u64,
    /// Answers that are Error, Reject or Abort.
    pub refusals: u64,
    /// The longest time one datagram took.
    pub slowest: Duration,
}

/// An invariant broken by one datagram.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("datagram {datagram:02x?}: {what}")]
pub struct FuzzFailure {
    /// The datagram.
    pub datagram: Vec<u8>,
    /// What was wrong.
    pub what: String,
}

/// The fuzzer's peer address.
pub fn peer() -> SocketAddr {
    SocketAddr::from(([10, 0, 0, 9], 47808))
}

/// A node like a commissioned one's: 4 desks (desk 1 without a stated uncertainty), 3
/// luminaires at arc 200, writes allowed from [`peer`].
pub fn sample_node() -> Node {
    let model = NodeModel {
        response_lx: vec![
            100.0, 200.0, 300.0, 10.0, 20.0, 30.0, 5.0, 0.0, 1.0, 1.0, 1.0, 1.0,
        ],
        sensor_ids: vec![7, 9, 11, 13],
        luminaire_ids: vec![1, 2, 3],
        sensor_flags: vec![0; 4],
        model_rel_uncertainty: vec![0.03, f64::NAN, 0.1, 0.1],
        uncertainty_parts_lx: Vec::new(),
        occluder_groups: Vec::new(),
        generation: 3,
        luminaire_power: vec![crate::control::rating::RatedPower::assumed(1000.0); 3],
        point_names: Vec::new(),
    };
    let options = NodeOptions {
        initial_arc: Some(200),
        policy: AccessPolicy::default()
            .with_writers(&["10.0.0.0/24".into()])
            .unwrap_or_default(),
        ..NodeOptions::default()
    };
    // the model is valid by construction; a failure would be a bug in Node::new
    Node::new(model, options).unwrap_or_else(|e| panic!("sample node: {e}"))
}

/// `node` with occupancy published (its Binary Inputs exist): desk 0 occupied, desk 1 vacant,
/// the others unknown after a bad depth frame.
pub fn with_occupancy(mut node: Node) -> Node {
    use crate::modbus::regmap::{Occupancy, OccupancyDesk, occupancy_status};
    let mut desks = vec![OccupancyDesk::default(); node.map().desks.len()];
    for (d, state) in desks
        .iter_mut()
        .zip([Occupancy::Occupied, Occupancy::Vacant])
    {
        d.state = state;
    }
    node.set_occupancy(
        &desks,
        Some(1),
        occupancy_status::ON | occupancy_status::MOVED,
        900.0,
    );
    node
}

/// A server for device 1234 with DeviceCommunicationControl allowed (password "pw").
pub fn sample_server() -> Server {
    Server::new(ServerConfig {
        device: DeviceInfo::new(1234, "fuzz"),
        dcc_password: Some("pw".into()),
    })
}

/// A datagram: Original-Unicast (or Broadcast), NPDU, `apdu`.
pub fn frame(broadcast: bool, apdu: &[u8]) -> Vec<u8> {
    let mut d = vec![0x81, if broadcast { 0x0B } else { 0x0A }, 0, 0, 0x01, 0x04];
    d.extend_from_slice(apdu);
    let n = d.len() as u16;
    d[2..4].copy_from_slice(&n.to_be_bytes());
    d
}

/// A confirmed request APDU: invoke id 1, 1476 octets accepted.
pub fn request(service: u8, body: impl FnOnce(&mut Writer<'_>)) -> Vec<u8> {
    let mut buf = [0u8; 256];
    let mut w = Writer::new(&mut buf);
    body(&mut w);
    let mut a = vec![0x00, 0x05, 0x01, service];
    a.extend_from_slice(w.written());
    frame(false, &a)
}

/// A broadcast Who-Has datagram.
pub fn who_has(limits: Option<(u32, u32)>, object: Wanted<'_>) -> Vec<u8> {
    let mut buf = [0u8; 128];
    let mut w = Writer::new(&mut buf);
    let _ = w.put(&[0x10, unconfirmed::WHO_HAS]);
    let _ = WhoHas { limits, object }.emit(&mut w);
    frame(true, w.written())
}

/// Valid datagrams of every service, and some refused ones.
pub fn seeds() -> Vec<Vec<u8>> {
    let ai = ObjectId::new(0, 1);
    let av = ObjectId::new(2, 0);
    let bi = ObjectId::new(3, 2);
    let dev = ObjectId::new(8, 1234);
    let rp = |o: ObjectId, prop: u32| {
        request(confirmed::READ_PROPERTY, |w| {
            let _ = w.context_object_id(0, o);
            let _ = w.context_enumerated(1, prop);
        })
    };
    let mut v = vec![
        frame(true, &[0x10, 0x08]),
        frame(true, &[0x10, 0x08, 0x09, 0x00, 0x1A, 0x04, 0xD2]),
        // a global broadcast Who-Is through a router
        vec![
            0x81, 0x0B, 0x00, 0x12, 0x01, 0x28, 0xFF, 0xFF, 0x00, 0x00, 0x05, 0x01, 0x21, 0xFF,
            0x10, 0x08, 0x00, 0x00,
        ],
        // Forwarded-NPDU from a BBMD
        vec![
            0x81, 0x04, 0x00, 0x0C, 10, 0, 0, 7, 0xBA, 0xC0, 0x01, 0x00, 0x10, 0x08,
        ],
        vec![0x81, 0x05, 0x00, 0x06, 0x00, 0x3C],
        rp(ai, property::PRESENT_VALUE),
        rp(dev, property::OBJECT_LIST),
        rp(
            ObjectId::new(8, ObjectId::MAX_INSTANCE),
            property::OBJECT_NAME,
        ),
        rp(ObjectId::new(0, 77), property::PRESENT_VALUE),
        request(confirmed::READ_PROPERTY, |w| {
            let _ = w.context_object_id(0, dev);
            let _ = w.context_enumerated(1, property::OBJECT_LIST);
            let _ = w.context_unsigned(2, 3);
        }),
        rp(bi, property::PRESENT_VALUE),
        request(confirmed::READ_PROPERTY_MULTIPLE, |w| {
            for o in [dev, ai, av, bi] {
                let _ = w.context_object_id(0, o);
                let _ = w.opening(1);
                let _ = w.context_enumerated(0, property::ALL);
                let _ = w.closing(1);
            }
        }),
        request(confirmed::WRITE_PROPERTY, |w| {
            let _ = w.context_object_id(0, av);
            let _ = w.context_enumerated(1, property::PRESENT_VALUE);
            let _ = w.opening(3);
            let _ = w.real(50.0);
            let _ = w.closing(3);
            let _ = w.context_unsigned(4, 8);
        }),
        request(confirmed::SUBSCRIBE_COV, |w| {
            let _ = w.context_unsigned(0, 17);
            let _ = w.context_object_id(1, ai);
            let _ = w.context_bool(2, false);
            let _ = w.context_unsigned(3, 60);
        }),
        request(confirmed::SUBSCRIBE_COV, |w| {
            let _ = w.context_unsigned(0, 18);
            let _ = w.context_object_id(1, bi);
            let _ = w.context_bool(2, true);
            let _ = w.context_unsigned(3, 60);
        }),
        request(confirmed::DEVICE_COMMUNICATION_CONTROL, |w| {
            let _ = w.context_unsigned(0, 1);
            let _ = w.context_enumerated(1, 2);
        }),
        request(20, |w| {
            let _ = w.context_enumerated(0, 0);
        }),
    ];
    // a segmented request
    v.push(frame(
        false,
        &[0x08, 0x05, 0x02, 0x00, 0x01, 0x0C, 0x0C, 0, 0, 0, 1],
    ));
    // Who-Has by name, and by identifier within a device range
    v.push(who_has(None, Wanted::Name("desk 9 illuminance")));
    v.push(who_has(Some((1000, 2000)), Wanted::Id(bi)));
    v
}

fn mutate(rng: &mut SplitMix64, seed: &[u8]) -> Vec<u8> {
    let mut f = seed.to_vec();
    for _ in 0..1 + rng.next_u64() % 3 {
        let r = rng.next_u64();
        let pos = if f.is_empty() {
            0
        } else {
            (r >> 8) as usize % f.len()
        };
        match r % 12 {
            0..=3 if !f.is_empty() => f[pos] ^= 1 << ((r >> 40) % 8),
            4..=5 if !f.is_empty() => {
                const EDGE: [u8; 8] = [0x00, 0x01, 0x0E, 0x0F, 0x7F, 0x80, 0xFE, 0xFF];
                f[pos] = EDGE[((r >> 40) % 8) as usize];
            }
            6 => f.truncate(pos),
            7 | 8 => {
                for k in 0..(r >> 40) % 9 {
                    f.insert(pos.min(f.len()), (r >> (k * 5)) as u8);
                }
            }
            9 => {
                let n = ((r >> 40) % 1600) as usize;
                f = (0..n).map(|_| rng.next_u64() as u8).collect();
            }
            _ if !f.is_empty() => f[pos] = (r >> 48) as u8,
            _ => {}
        }
    }
    // half the time the BVLC is made valid again, so the mutation reaches the decoders below
    if rng.next_u64().is_multiple_of(2) && f.len() >= 4 && f.len() <= usize::from(u16::MAX) {
        f[0] = 0x81;
        let n = f.len() as u16;
        f[2..4].copy_from_slice(&n.to_be_bytes());
    }
    f
}

/// Checks one answer; `request` is the datagram answered.
fn check(request: &[u8], o: &Outgoing, report: &mut FuzzReport) -> Result<(), String> {
    let b = Bvlc::parse(&o.datagram).map_err(|e| format!("answer BVLC: {e}"))?;
    if b.function == 0x00 {
        return Ok(()); // a BVLC-Result NAK
    }
    let (_, apdu) = Npdu::parse(b.payload).map_err(|e| format!("answer NPDU: {e}"))?;
    let answer = Apdu::parse(apdu).map_err(|e| format!("answer APDU: {e}"))?;
    let asked = Bvlc::parse(request)
        .ok()
        .and_then(|b| Npdu::parse(b.payload).ok())
        .and_then(|(_, a)| Apdu::parse(a).ok());
    if let Some(Apdu::ConfirmedRequest { invoke_id, .. }) = asked {
        let id = match answer {
            Apdu::SimpleAck { invoke_id, .. } | Apdu::ComplexAck { invoke_id, .. } => {
                report.acks += 1;
                invoke_id
            }
            Apdu::Error { invoke_id, .. }
            | Apdu::Reject { invoke_id, .. }
            | Apdu::Abort { invoke_id, .. } => {
                report.refusals += 1;
                invoke_id
            }
            // the initial COV notification after a SubscribeCOV's ACK
            Apdu::ConfirmedRequest { .. } | Apdu::UnconfirmedRequest { .. } => return Ok(()),
            other => return Err(format!("answer {other:?} to a confirmed request")),
        };
        if id != invoke_id {
            return Err(format!("invoke id {id}, asked {invoke_id}"));
        }
    }
    Ok(())
}

/// A node and a server under fuzzing, and what they answered so far.
pub struct Fuzzer {
    node: Node,
    server: Server,
    now: Instant,
    /// Counts.
    pub report: FuzzReport,
}

impl Default for Fuzzer {
    fn default() -> Self {
        Self {
            node: with_occupancy(sample_node()),
            server: sample_server(),
            now: Instant::now(),
            report: FuzzReport::default(),
        }
    }
}

impl Fuzzer {
    /// Hands one datagram to the server from [`peer`] and checks every answer.
    pub fn feed(&mut self, d: &[u8]) -> Result<(), FuzzFailure> {
        let t = Instant::now();
        // time does not pass for the server: DCC and lifetimes stay as the datagrams set them
        let answers = self.server.handle(&mut self.node, peer(), d, self.now);
        let r = &mut self.report;
        r.slowest = r.slowest.max(t.elapsed());
        r.datagrams += 1;
        if !answers.is_empty() {
            r.answered += 1;
        }
        for o in &answers {
            check(d, o, r).map_err(|what| FuzzFailure {
                datagram: d.to_vec(),
                what,
            })?;
        }
        Ok(())
    }
}

/// Runs `n` datagrams from `seed`: three in four mutated seeds, one in four random bytes.
pub fn run(n: u64, seed: u64) -> Result<FuzzReport, FuzzFailure> {
    let mut f = Fuzzer::default();
    let mut rng = SplitMix64::new(seed);
    let seeds = seeds();
    for i in 0..n {
        let d = if i % 4 == 3 {
            let len = (rng.next_u64() % 64) as usize;
            (0..len).map(|_| rng.next_u64() as u8).collect()
        } else {
            let s = &seeds[(rng.next_u64() % seeds.len() as u64) as usize];
            mutate(&mut rng, s)
        };
        f.feed(&d)?;
    }
    Ok(f.report)
}

#[cfg(test)]
mod tests {
    /// Writes the seeds as the fuzz corpus (run by hand: `cargo test write_bacnet_corpus --
    /// --ignored`).
    #[test]
    #[ignore = "writes fuzz/corpus/bacnet_datagram"]
    fn write_bacnet_corpus() {
        let dir =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/bacnet_datagram");
        std::fs::create_dir_all(&dir).unwrap();
        for (k, s) in super::seeds().iter().enumerate() {
            std::fs::write(dir.join(format!("seed{k:02}")), s).unwrap();
        }
    }
}
