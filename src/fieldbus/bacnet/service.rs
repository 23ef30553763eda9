//! The BACnet/IP services over one datagram: what the node answers, and the notifications it
//! owes. [`Server::handle`] takes a datagram and its UDP source and returns the datagrams to
//! send; [`Server::poll_cov`] returns the COV notifications due. Neither blocks nor panics on
//! any input; the UDP task ([`super::serve`]) owns the socket and the node's lock.
//!
//! * Who-Is (local or global broadcast, or unicast; with or without a range) → I-Am, sent
//!   unicast to the requester (through its router when it came through one);
//! * Who-Has (by identifier or name, with or without a range) → I-Have, the same way
//!   ([`who_has`]);
//! * ReadProperty, ReadPropertyMultiple (ALL, REQUIRED, OPTIONAL), WriteProperty,
//!   SubscribeCOV, DeviceCommunicationControl: confirmed, answered with SimpleACK, ComplexACK,
//!   Error, Reject or Abort;
//! * a segmented request, or an answer longer than the requester accepts (or than 1476
//!   octets): Abort segmentation-not-supported (the node does not segment);
//! * a service the node does not execute: Reject unrecognized-service; a request that does not
//!   parse: Reject with the reason (invalid-tag, missing-required-parameter, ...);
//! * BBMD functions (Register-Foreign-Device, Read-BDT, ...) sent to the node: BVLC-Result NAK
//!   (the node is not a BBMD).

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::time::{Duration, Instant};

use crate::bacnet::consts::{
    MAX_APDU, confirmed, error_class as ec, error_code as code, object_type as ot, property as p,
    reject, reliability, unconfirmed,
};
use crate::bacnet::cov::{CovTable, Full, Peer, Told};
use crate::bacnet::objects::{DeviceInfo, Kind, OPTIONAL_PROPERTIES, View};
use crate::bacnet::property::{PropertyError, encode, properties};
use crate::bacnet::wire::{
    Apdu, AppValue, Bvlc, NetAddress, Npdu, ObjectId, Reader, WireError, Writer, bvlc,
};
use crate::modbus::access::Source;
use crate::modbus::regmap::addr;
use crate::node::Node;

/// The server's settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServerConfig {
    /// The Device object.
    pub device: DeviceInfo,
    /// DeviceCommunicationControl is executed only with this password, from a source in the
    /// write allowlist (`None`: always refused).
    pub dcc_password: Option<String>,
}

/// A datagram to send.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outgoing {
    /// UDP destination.
    pub to: SocketAddr,
    /// The whole datagram (BVLC, NPDU, APDU).
    pub datagram: Vec<u8>,
}

/// Counters, for logs and tests.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Counters {
    /// Datagrams received.
    pub received: u64,
    /// Datagrams dropped: not BACnet/IP, malformed NPDU, not for this node.
    pub dropped: u64,
    /// Confirmed requests answered with an ACK.
    pub acked: u64,
    /// Errors, rejects and aborts sent.
    pub refused: u64,
    /// COV notifications sent.
    pub notifications: u64,
}

/// Communication state set by DeviceCommunicationControl.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dcc {
    Enabled,
    /// Nothing but DeviceCommunicationControl is answered.
    Disabled(Option<Instant>),
    /// Nothing is initiated (no COV notification); requests are answered.
    InitiationDisabled(Option<Instant>),
}

/// A confirmed service's answer.
enum Reply {
    Simple,
    Complex(Vec<u8>),
}

/// A confirmed service's refusal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Failure {
    Error(u32, u32),
    Reject(u8),
    Abort(u8),
}

impl From<WireError> for Failure {
    fn from(e: WireError) -> Self {
        Failure::Reject(match e {
            WireError::Truncated => reject::MISSING_REQUIRED_PARAMETER,
            WireError::UnexpectedTag | WireError::Unbalanced | WireError::ReservedTag(_) => {
                reject::INVALID_TAG
            }
            WireError::BadLength(_) | WireError::CharacterSet => {
                reject::INVALID_PARAMETER_DATA_TYPE
            }
            WireError::OutOfRange => reject::PARAMETER_OUT_OF_RANGE,
            WireError::Overflow => {
                return Failure::Abort(crate::bacnet::consts::abort::SEGMENTATION_NOT_SUPPORTED);
            }
            _ => reject::OTHER,
        })
    }
}

impl From<PropertyError> for Failure {
    fn from(e: PropertyError) -> Self {
        match e {
            PropertyError::Bacnet { class, code } => Failure::Error(class, code),
            PropertyError::Wire(w) => w.into(),
        }
    }
}

const fn error(class: u32, c: u32) -> Failure {
    Failure::Error(class, c)
}

/// How long a confirmed notification waits for its acknowledgement (Device APDU_Timeout).
pub const APDU_TIMEOUT: Duration = Duration::from_secs(3);
/// How often an unacknowledged confirmed notification is sent again (Number_Of_APDU_Retries).
pub const APDU_RETRIES: u8 = 3;
/// Most confirmed notifications awaiting an acknowledgement (the oldest is given up).
const MAX_PENDING: usize = 256;

/// A confirmed notification awaiting its acknowledgement.
#[derive(Debug)]
struct Pending {
    invoke_id: u8,
    to: SocketAddr,
    datagram: Vec<u8>,
    sent: Instant,
    tries: u8,
}

/// The BACnet/IP server state: settings, COV subscriptions, written COV increments.
#[derive(Debug)]
pub struct Server {
    config: ServerConfig,
    cov_increments: HashMap<ObjectId, f64>,
    cov: CovTable,
    invoke_id: u8,
    dcc: Dcc,
    /// Confirmed notifications not yet acknowledged.
    pending: Vec<Pending>,
    /// Counters.
    pub counters: Counters,
    /// The last BVLC-Result received: its sender and code (the BBMD's answer to a
    /// registration).
    pub last_bvlc_result: Option<(SocketAddr, u16)>,
}

fn view<'a>(node: &'a Node, config: &'a ServerConfig, inc: &'a HashMap<ObjectId, f64>) -> View<'a> {
    View {
        map: node.map(),
        levels: node.levels(),
        daylight: node.fresh_daylight(),
        device: &config.device,
        cov_increments: inc,
        points: &node.model().point_names,
    }
}

/// Buffer for one datagram: BVLC (4, or 10 forwarded), NPDU (up to 2 + 2 × 11 + 1), APDU.
const DATAGRAM_MAX: usize = 64 + MAX_APDU;

/// Encodes a datagram to `peer`: Original-Unicast, NPDU, then what `apdu` writes.
fn datagram(
    peer: &Peer,
    expecting_reply: bool,
    apdu: impl FnOnce(&mut Writer<'_>) -> Result<(), WireError>,
) -> Result<Outgoing, WireError> {
    datagram_as(bvlc::ORIGINAL_UNICAST, peer, expecting_reply, apdu)
}

/// [`datagram`] with another BVLC function (a broadcast).
fn datagram_as(
    function: u8,
    peer: &Peer,
    expecting_reply: bool,
    apdu: impl FnOnce(&mut Writer<'_>) -> Result<(), WireError>,
) -> Result<Outgoing, WireError> {
    let mut buf = vec![0u8; DATAGRAM_MAX];
    let mut w = Writer::new(&mut buf[4..]);
    Npdu::to(peer.route, expecting_reply).emit(&mut w)?;
    apdu(&mut w)?;
    let body = w.len();
    let mut h = Writer::new(&mut buf[..4]);
    Bvlc::emit_header(function, body, &mut h)?;
    buf.truncate(4 + body);
    Ok(Outgoing {
        to: peer.addr,
        datagram: buf,
    })
}

/// The BVLC-Result NAK code for a BBMD function sent to the node (Annex J.2.1.1).
fn nak(function: u8) -> Option<u16> {
    Some(match function {
        bvlc::WRITE_BDT => 0x0010,
        bvlc::READ_BDT => 0x0020,
        bvlc::REGISTER_FOREIGN_DEVICE => bvlc::RESULT_REGISTER_FD_NAK,
        bvlc::READ_FDT => 0x0040,
        bvlc::DELETE_FDT_ENTRY => 0x0050,
        bvlc::DISTRIBUTE_BROADCAST => 0x0060,
        _ => return None,
    })
}

/// A BVLC-Result datagram.
fn bvlc_result(to: SocketAddr, result: u16) -> Outgoing {
    let mut d = vec![bvlc::TYPE_BIP, bvlc::RESULT, 0, 6];
    d.extend_from_slice(&result.to_be_bytes());
    Outgoing { to, datagram: d }
}

impl Server {
    /// A server with no subscriptions.
    pub fn new(config: ServerConfig) -> Self {
        Self {
            config,
            cov_increments: HashMap::new(),
            cov: CovTable::default(),
            invoke_id: 0,
            dcc: Dcc::Enabled,
            pending: Vec::new(),
            counters: Counters::default(),
            last_bvlc_result: None,
        }
    }

    /// Foreign-device registration with the board's BBMD is failing (no answer, or a NAK):
    /// the Device's Reliability is communication-failure until it succeeds again.
    pub fn set_registration_failing(&mut self, failing: bool) {
        self.config.device.reliability = if failing {
            reliability::COMMUNICATION_FAILURE
        } else {
            reliability::NO_FAULT_DETECTED
        };
    }

    /// The settings.
    pub fn config(&self) -> &ServerConfig {
        &self.config
    }

    /// COV subscriptions held.
    pub fn subscriptions(&self) -> usize {
        self.cov.len()
    }

    fn dcc_now(&mut self, now: Instant) -> Dcc {
        if let Dcc::Disabled(Some(t)) | Dcc::InitiationDisabled(Some(t)) = self.dcc
            && now >= t
        {
            self.dcc = Dcc::Enabled;
        }
        self.dcc
    }

    /// Handles one datagram from `from`; returns what to send.
    pub fn handle(
        &mut self,
        node: &mut Node,
        from: SocketAddr,
        d: &[u8],
        now: Instant,
    ) -> Vec<Outgoing> {
        self.counters.received += 1;
        let out = self.handle_inner(node, from, d, now);
        if out.is_empty() {
            self.counters.dropped += 1;
        }
        out
    }

    fn handle_inner(
        &mut self,
        node: &mut Node,
        from: SocketAddr,
        d: &[u8],
        now: Instant,
    ) -> Vec<Outgoing> {
        let Ok(b) = Bvlc::parse(d) else {
            return Vec::new();
        };
        let addr = match (b.function, b.origin) {
            (bvlc::FORWARDED_NPDU, Some((ip, port))) => {
                SocketAddr::new(IpAddr::V4(Ipv4Addr::from(ip)), port)
            }
            (bvlc::ORIGINAL_UNICAST | bvlc::ORIGINAL_BROADCAST, _) => from,
            (bvlc::RESULT, _) => {
                if let [a, b] = b.payload {
                    self.last_bvlc_result = Some((from, u16::from_be_bytes([*a, *b])));
                }
                return Vec::new();
            }
            // a BBMD's functions: the node is none, NAK
            (f, _) if nak(f).is_some() => {
                return vec![bvlc_result(from, nak(f).unwrap_or_default())];
            }
            _ => return Vec::new(),
        };
        let Ok((npdu, apdu)) = Npdu::parse(b.payload) else {
            return Vec::new();
        };
        // network-layer messages are for routers; a message for another network is not ours
        if npdu.message_type.is_some() || npdu.destination.is_some_and(|d| d.net != 0xFFFF) {
            return Vec::new();
        }
        let peer = Peer {
            addr,
            route: npdu.source,
        };
        let Ok(apdu) = Apdu::parse(apdu) else {
            return Vec::new();
        };
        match apdu {
            Apdu::UnconfirmedRequest { service, data } => self
                .unconfirmed(node, &peer, service, data, now)
                .into_iter()
                .collect(),
            Apdu::ConfirmedRequest { .. } => self.confirmed(node, &peer, apdu, now),
            // an answer to a confirmed notification: delivered (an Error, Reject or Abort too:
            // the subscriber heard it and refused; resending would not change that)
            Apdu::SimpleAck { invoke_id, .. }
            | Apdu::Error { invoke_id, .. }
            | Apdu::Reject { invoke_id, .. }
            | Apdu::Abort { invoke_id, .. } => {
                self.pending
                    .retain(|x| !(x.invoke_id == invoke_id && x.to.ip() == addr.ip()));
                Vec::new()
            }
            _ => Vec::new(),
        }
    }

    /// Who-Is and Who-Has: nothing while communication is disabled; no I-Have while
    /// initiation is (the standard excepts only I-Am).
    fn unconfirmed(
        &mut self,
        node: &Node,
        peer: &Peer,
        service: u8,
        data: &[u8],
        now: Instant,
    ) -> Option<Outgoing> {
        match (self.dcc_now(now), service) {
            (Dcc::Disabled(_), _) => None,
            (_, unconfirmed::WHO_IS) => self.who_is(peer, data),
            (Dcc::Enabled, unconfirmed::WHO_HAS) => self.who_has(node, peer, data),
            _ => None,
        }
    }

    fn who_is(&self, peer: &Peer, data: &[u8]) -> Option<Outgoing> {
        let mut r = Reader::new(data);
        if !r.is_empty() {
            let low = r.context_unsigned(0).ok()?;
            let high = r.context_unsigned(1).ok()?;
            let me = u64::from(self.config.device.instance);
            if !r.is_empty() || me < low || me > high {
                return None;
            }
        }
        self.i_am(bvlc::ORIGINAL_UNICAST, peer.addr, peer.route)
    }

    /// An I-Am datagram to `to` as BVLC `function` (Original-Unicast to a requester,
    /// Original-Broadcast on the local network, Distribute-Broadcast-To-Network to a BBMD);
    /// none while DeviceCommunicationControl disables initiation.
    pub fn i_am(
        &self,
        function: u8,
        to: SocketAddr,
        route: Option<NetAddress>,
    ) -> Option<Outgoing> {
        if matches!(self.dcc, Dcc::Disabled(_))
            || (function != bvlc::ORIGINAL_UNICAST
                && matches!(self.dcc, Dcc::InitiationDisabled(_)))
        {
            return None;
        }
        let device = self.config.device.id();
        let vendor = u64::from(self.config.device.vendor_id);
        let peer = Peer { addr: to, route };
        datagram_as(function, &peer, false, |w| {
            w.put(&[0x10, unconfirmed::I_AM])?;
            w.object_id(device)?;
            w.unsigned(MAX_APDU as u64)?;
            w.enumerated(crate::bacnet::consts::NO_SEGMENTATION)?;
            w.unsigned(vendor)
        })
        .ok()
    }

    fn confirmed(
        &mut self,
        node: &mut Node,
        peer: &Peer,
        apdu: Apdu<'_>,
        now: Instant,
    ) -> Vec<Outgoing> {
        let Apdu::ConfirmedRequest {
            segmented,
            max_apdu,
            invoke_id,
            service,
            data,
            ..
        } = apdu
        else {
            return Vec::new();
        };
        if matches!(self.dcc_now(now), Dcc::Disabled(_))
            && service != confirmed::DEVICE_COMMUNICATION_CONTROL
        {
            return Vec::new();
        }
        let result = if segmented {
            Err(Failure::Abort(
                crate::bacnet::consts::abort::SEGMENTATION_NOT_SUPPORTED,
            ))
        } else {
            self.dispatch(node, peer, service, data, now)
        };
        let limit = usize::from(max_apdu).min(MAX_APDU);
        let mut out = Vec::new();
        let reply = match &result {
            Ok(Reply::Complex(body)) if body.len() + 3 > limit => Err(Failure::Abort(
                crate::bacnet::consts::abort::SEGMENTATION_NOT_SUPPORTED,
            )),
            Ok(r) => Ok(r),
            Err(f) => Err(*f),
        };
        let apdu = match reply {
            Ok(Reply::Simple) => Apdu::SimpleAck { invoke_id, service },
            Ok(Reply::Complex(body)) => Apdu::ComplexAck {
                invoke_id,
                service,
                data: body,
            },
            Err(Failure::Error(class, code)) => Apdu::Error {
                invoke_id,
                service,
                class,
                code,
            },
            Err(Failure::Reject(reason)) => Apdu::Reject { invoke_id, reason },
            Err(Failure::Abort(reason)) => Apdu::Abort {
                server: true,
                invoke_id,
                reason,
            },
        };
        if matches!(apdu, Apdu::SimpleAck { .. } | Apdu::ComplexAck { .. }) {
            self.counters.acked += 1;
        } else {
            self.counters.refused += 1;
        }
        if let Ok(o) = datagram(peer, false, |w| apdu.emit(w)) {
            out.push(o);
        }
        // a new subscription is owed its initial notification at once
        if service == confirmed::SUBSCRIBE_COV && matches!(apdu, Apdu::SimpleAck { .. }) {
            out.extend(self.poll_cov(node, now));
        }
        out
    }

    fn dispatch(
        &mut self,
        node: &mut Node,
        peer: &Peer,
        service: u8,
        data: &[u8],
        now: Instant,
    ) -> Result<Reply, Failure> {
        let mut r = Reader::new(data);
        let reply = match service {
            confirmed::READ_PROPERTY => self.read_property(node, &mut r)?,
            confirmed::READ_PROPERTY_MULTIPLE => self.read_property_multiple(node, &mut r)?,
            confirmed::WRITE_PROPERTY => self.write_property(node, peer, &mut r)?,
            confirmed::SUBSCRIBE_COV => self.subscribe_cov(node, peer, &mut r, now)?,
            confirmed::DEVICE_COMMUNICATION_CONTROL => {
                self.communication_control(node, peer, &mut r, now)?
            }
            _ => return Err(Failure::Reject(reject::UNRECOGNIZED_SERVICE)),
        };
        if !r.is_empty() {
            return Err(Failure::Reject(reject::TOO_MANY_ARGUMENTS));
        }
        Ok(reply)
    }

    fn read_property(&self, node: &Node, r: &mut Reader<'_>) -> Result<Reply, Failure> {
        let id = r.context_object_id(0)?;
        let prop = r.context_enumerated(1)?;
        let index = r.optional_context_unsigned(2)?;
        if !r.is_empty() {
            return Err(Failure::Reject(reject::TOO_MANY_ARGUMENTS));
        }
        let v = view(node, &self.config, &self.cov_increments);
        let object = v
            .resolve(id)
            .ok_or(error(ec::OBJECT, code::UNKNOWN_OBJECT))?;
        // ALL, REQUIRED and OPTIONAL belong to ReadPropertyMultiple
        if matches!(prop, p::ALL | p::REQUIRED | p::OPTIONAL) {
            return Err(error(ec::PROPERTY, code::UNKNOWN_PROPERTY));
        }
        let mut buf = vec![0u8; MAX_APDU];
        let mut w = Writer::new(&mut buf);
        w.context_object_id(0, id)?;
        w.context_enumerated(1, prop)?;
        if let Some(i) = index {
            w.context_unsigned(2, i)?;
        }
        w.opening(3)?;
        encode(&v, id, object, prop, index, &mut w)?;
        w.closing(3)?;
        let n = w.len();
        buf.truncate(n);
        Ok(Reply::Complex(buf))
    }

    fn read_property_multiple(&self, node: &Node, r: &mut Reader<'_>) -> Result<Reply, Failure> {
        // parse the whole request first: a malformed one is rejected, not half answered
        let specs = parse_rpm(r)?;
        let v = view(node, &self.config, &self.cov_increments);
        let mut buf = vec![0u8; MAX_APDU];
        let mut scratch = vec![0u8; MAX_APDU];
        let mut w = Writer::new(&mut buf);
        for spec in &specs {
            w.context_object_id(0, spec.id)?;
            w.opening(1)?;
            let object = v.resolve(spec.id);
            for &(prop, index) in &spec.props {
                for x in expand(object.map(|o| o.0), prop) {
                    w.context_enumerated(2, x)?;
                    if let Some(i) = index {
                        w.context_unsigned(3, i)?;
                    }
                    let mut s = Writer::new(&mut scratch);
                    let result = match object {
                        None => Err(PropertyError::bacnet(ec::OBJECT, code::UNKNOWN_OBJECT)),
                        Some(o) => encode(&v, spec.id, o, x, index, &mut s),
                    };
                    match result {
                        Ok(()) => {
                            w.opening(4)?;
                            w.put(s.written())?;
                            w.closing(4)?;
                        }
                        Err(PropertyError::Bacnet { class, code }) => {
                            w.opening(5)?;
                            w.enumerated(class)?;
                            w.enumerated(code)?;
                            w.closing(5)?;
                        }
                        Err(PropertyError::Wire(e)) => return Err(e.into()),
                    }
                }
            }
            w.closing(1)?;
        }
        let n = w.len();
        buf.truncate(n);
        Ok(Reply::Complex(buf))
    }

    fn write_property(
        &mut self,
        node: &mut Node,
        peer: &Peer,
        r: &mut Reader<'_>,
    ) -> Result<Reply, Failure> {
        let id = r.context_object_id(0)?;
        let prop = r.context_enumerated(1)?;
        let index = r.optional_context_unsigned(2)?;
        r.opening(3)?;
        let value = r.enclosed(3)?;
        let priority = r.optional_context_unsigned(4)?;
        if priority.is_some_and(|x| !(1..=16).contains(&x)) {
            return Err(Failure::Reject(reject::PARAMETER_OUT_OF_RANGE));
        }
        let v = view(node, &self.config, &self.cov_increments);
        let (class, k) = v
            .resolve(id)
            .ok_or(error(ec::OBJECT, code::UNKNOWN_OBJECT))?;
        if !properties(class).contains(&prop) {
            return Err(error(ec::PROPERTY, code::UNKNOWN_PROPERTY));
        }
        let writable = (prop == p::PRESENT_VALUE && class.writable)
            || (prop == p::COV_INCREMENT && class.kind != Kind::Device);
        if !writable {
            return Err(error(ec::PROPERTY, code::WRITE_ACCESS_DENIED));
        }
        if index.is_some() {
            return Err(error(ec::PROPERTY, code::PROPERTY_IS_NOT_AN_ARRAY));
        }
        let x = number(value).ok_or(error(ec::PROPERTY, code::INVALID_DATA_TYPE))?;
        let desk_id = v.owner_id(class.kind, k);
        // the Modbus register the write stands for, for the one access decision
        let register = match (class.kind, prop) {
            (Kind::LuminaireLevel, p::PRESENT_VALUE) => addr::ARC_LEVEL.saturating_add(k as u16),
            (Kind::DeskTarget, p::PRESENT_VALUE) => addr::DESK_TARGET.saturating_add(k as u16),
            _ => u16::MAX,
        };
        let source = Source::Bacnet(peer.addr);
        if !node.policy().may_write(&source, register, 1) {
            if let Some(n) = node.write_refused() {
                tracing::warn!(
                    target: "luxnode::audit",
                    %source,
                    "bacnet write refused: {source} is not in the write allowlist ({id:?} \
                     property {prop}; {n} refused so far)"
                );
            }
            return Err(error(ec::PROPERTY, code::WRITE_ACCESS_DENIED));
        }
        let out_of_range = error(ec::PROPERTY, code::VALUE_OUT_OF_RANGE);
        match (class.kind, prop) {
            (_, p::COV_INCREMENT) => {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(out_of_range);
                }
                self.cov_increments.insert(id, x);
            }
            (Kind::LuminaireLevel, _) => {
                if !(0.0..=100.0).contains(&x) {
                    return Err(out_of_range);
                }
                let mut levels = vec![None; node.levels().len()];
                levels[k] = Some(x / 100.0);
                node.set_levels(&levels).map_err(|_| out_of_range)?;
            }
            (Kind::DeskTarget, _) => {
                node.set_target_lx(desk_id, x).map_err(|_| out_of_range)?;
            }
            _ => return Err(error(ec::PROPERTY, code::WRITE_ACCESS_DENIED)),
        }
        node.health()
            .writes_accepted
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        tracing::info!(
            target: "luxnode::audit",
            %source,
            "bacnet write by {source}: {id:?} property {prop} = {x} (priority {priority:?} ignored)"
        );
        Ok(Reply::Simple)
    }

    fn subscribe_cov(
        &mut self,
        node: &Node,
        peer: &Peer,
        r: &mut Reader<'_>,
        now: Instant,
    ) -> Result<Reply, Failure> {
        let process_id = u32::try_from(r.context_unsigned(0)?)
            .map_err(|_| Failure::Reject(reject::PARAMETER_OUT_OF_RANGE))?;
        let id = r.context_object_id(1)?;
        let confirmed = if !r.is_empty() && r.peek_tag()?.is_context(2) {
            Some(r.context_bool(2)?)
        } else {
            None
        };
        let lifetime = r.optional_context_unsigned(3)?;
        let v = view(node, &self.config, &self.cov_increments);
        let (class, _) = v
            .resolve(id)
            .ok_or(error(ec::OBJECT, code::UNKNOWN_OBJECT))?;
        if class.kind == Kind::Device {
            return Err(error(
                ec::OBJECT,
                code::OPTIONAL_FUNCTIONALITY_NOT_SUPPORTED,
            ));
        }
        match (confirmed, lifetime) {
            (None, None) => self.cov.cancel(peer, process_id, id),
            (Some(c), l) => self
                .cov
                .subscribe(*peer, process_id, id, c, l.unwrap_or(0), now)
                .map_err(|Full| error(ec::RESOURCES, code::COV_SUBSCRIPTION_FAILED))?,
            (None, Some(_)) => return Err(Failure::Reject(reject::MISSING_REQUIRED_PARAMETER)),
        }
        Ok(Reply::Simple)
    }

    fn communication_control(
        &mut self,
        node: &mut Node,
        peer: &Peer,
        r: &mut Reader<'_>,
        now: Instant,
    ) -> Result<Reply, Failure> {
        let minutes = r.optional_context_unsigned(0)?;
        let state = r.context_enumerated(1)?;
        let password = if r.is_empty() {
            None
        } else {
            Some(r.context_char_string(2)?)
        };
        if state > 2 {
            return Err(Failure::Reject(reject::PARAMETER_OUT_OF_RANGE));
        }
        let denied = error(ec::SERVICES, code::SERVICE_REQUEST_DENIED);
        let Some(want) = &self.config.dcc_password else {
            tracing::warn!(
                "bacnet: DeviceCommunicationControl from {} refused (not allowed on this board)",
                peer.addr
            );
            return Err(denied);
        };
        if !node
            .policy()
            .may_write(&Source::Bacnet(peer.addr), u16::MAX, 1)
        {
            node.write_refused();
            return Err(denied);
        }
        if password != Some(want.as_str()) {
            return Err(error(ec::SECURITY, code::PASSWORD_FAILURE));
        }
        let until = minutes
            .filter(|m| *m > 0)
            .map(|m| now + Duration::from_secs(m.min(u64::from(u16::MAX)) * 60));
        self.dcc = match state {
            0 => Dcc::Enabled,
            1 => Dcc::Disabled(until),
            _ => Dcc::InitiationDisabled(until),
        };
        tracing::info!(target: "luxnode::audit", "bacnet: DeviceCommunicationControl by {}: state {state}, {minutes:?} min", peer.addr);
        Ok(Reply::Simple)
    }

    /// Confirmed notifications unanswered for [`APDU_TIMEOUT`]: sent again, at most
    /// [`APDU_RETRIES`] times, then given up.
    fn retries(&mut self, now: Instant) -> Vec<Outgoing> {
        let mut out = Vec::new();
        self.pending.retain_mut(|x| {
            if now.duration_since(x.sent) < APDU_TIMEOUT {
                return true;
            }
            if x.tries >= APDU_RETRIES {
                tracing::debug!("bacnet: COV notification to {} not acknowledged", x.to);
                return false;
            }
            x.tries += 1;
            x.sent = now;
            out.push(Outgoing {
                to: x.to,
                datagram: x.datagram.clone(),
            });
            true
        });
        out
    }

    /// The COV notifications due now, and confirmed ones to send again (none while
    /// communication is disabled).
    pub fn poll_cov(&mut self, node: &Node, now: Instant) -> Vec<Outgoing> {
        if !matches!(self.dcc_now(now), Dcc::Enabled) {
            return Vec::new();
        }
        let mut out = self.retries(now);
        if self.cov.is_empty() {
            return out;
        }
        let v = view(node, &self.config, &self.cov_increments);
        let due = self.cov.due(now, |id| {
            let (class, k) = v.resolve(id)?;
            let reading = v.reading(class.kind, k);
            let told = Told {
                value: f64::from(reading.value as f32),
                flags: reading.status_flags(),
            };
            Some((told, v.cov_increment(id, class.kind, k)))
        });
        let device = self.config.device.id();
        for s in due {
            let Some(told) = s.told else { continue };
            let invoke_id = self.invoke_id;
            if s.confirmed {
                self.invoke_id = self.invoke_id.wrapping_add(1);
            }
            let sent = datagram(&s.peer, s.confirmed, |w| {
                if s.confirmed {
                    w.put(&[0x00, 0x05, invoke_id, confirmed::COV_NOTIFICATION])?;
                } else {
                    w.put(&[0x10, unconfirmed::COV_NOTIFICATION])?;
                }
                w.context_unsigned(0, u64::from(s.process_id))?;
                w.context_object_id(1, device)?;
                w.context_object_id(2, s.object)?;
                w.context_unsigned(3, s.remaining_s(now))?;
                w.opening(4)?;
                w.context_enumerated(0, p::PRESENT_VALUE)?;
                w.opening(2)?;
                if s.object.object_type == ot::BINARY_INPUT {
                    w.enumerated(u32::from(told.value > 0.5))?;
                } else {
                    w.real(told.value as f32)?;
                }
                w.closing(2)?;
                w.context_enumerated(0, p::STATUS_FLAGS)?;
                w.opening(2)?;
                w.bit_string(&told.flags)?;
                w.closing(2)?;
                w.closing(4)
            });
            if let Ok(o) = sent {
                self.counters.notifications += 1;
                if s.confirmed {
                    if self.pending.len() >= MAX_PENDING {
                        self.pending.remove(0);
                    }
                    self.pending.push(Pending {
                        invoke_id,
                        to: o.to,
                        datagram: o.datagram.clone(),
                        sent: now,
                        tries: 0,
                    });
                }
                out.push(o);
            }
        }
        out
    }
}

/// A property reference: identifier and array index.
type PropertyRef = (u32, Option<u64>);

/// One ReadAccessSpecification of ReadPropertyMultiple.
struct ReadAccessSpec {
    id: ObjectId,
    props: Vec<PropertyRef>,
}

/// The ReadAccessSpecifications of a ReadPropertyMultiple request (at least one, each with at
/// least one property).
fn parse_rpm(r: &mut Reader<'_>) -> Result<Vec<ReadAccessSpec>, Failure> {
    let mut specs = Vec::new();
    while !r.is_empty() {
        let id = r.context_object_id(0)?;
        r.opening(1)?;
        let mut props = Vec::new();
        while !r.at_closing(1) {
            let prop = r.context_enumerated(0)?;
            props.push((prop, r.optional_context_unsigned(1)?));
        }
        r.closing(1)?;
        if props.is_empty() {
            return Err(Failure::Reject(reject::MISSING_REQUIRED_PARAMETER));
        }
        specs.push(ReadAccessSpec { id, props });
    }
    if specs.is_empty() {
        return Err(Failure::Reject(reject::MISSING_REQUIRED_PARAMETER));
    }
    Ok(specs)
}

/// ALL, REQUIRED and OPTIONAL as the object's properties (an unknown object: as asked).
fn expand(class: Option<&crate::bacnet::objects::ObjectClass>, prop: u32) -> Vec<u32> {
    let Some(class) = class else {
        return vec![prop];
    };
    let all = properties(class).iter().copied();
    match prop {
        p::ALL => all.collect(),
        p::REQUIRED => all.filter(|x| !OPTIONAL_PROPERTIES.contains(x)).collect(),
        p::OPTIONAL => all.filter(|x| OPTIONAL_PROPERTIES.contains(x)).collect(),
        _ => vec![prop],
    }
}

/// A written value as a number: Real, Double, Unsigned or Signed, alone.
fn number(value: &[u8]) -> Option<f64> {
    let mut r = Reader::new(value);
    let x = match r.app_value().ok()? {
        AppValue::Real(x) => f64::from(x),
        AppValue::Double(x) => x,
        AppValue::Unsigned(x) => x as f64,
        AppValue::Signed(x) => x as f64,
        _ => return None,
    };
    r.is_empty().then_some(x)
}

/// Whether `id` is one of the node's object types (for callers that only check the type).
pub fn is_served_type(id: ObjectId) -> bool {
    matches!(
        id.object_type,
        ot::DEVICE | ot::ANALOG_INPUT | ot::ANALOG_VALUE | ot::BINARY_INPUT
    )
}

mod who_has;

#[cfg(all(test, feature = "sim"))]
mod tests;
