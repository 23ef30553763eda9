//! The BACnet/IP wire format (ASHRAE 135 Annex J, clauses 6, 20): parse and emit on byte
//! slices, `no_std`, no allocation, typed errors, no panic on any input.
//!
//! * [`Bvlc`]: the BACnet Virtual Link Control header of a UDP datagram (type 0x81, function,
//!   16-bit length), with the Forwarded-NPDU's original source address;
//! * [`Npdu`]: the network layer header (version 1, control, optional destination and source
//!   network addresses, hop count; network-layer messages recognised and left to the caller);
//! * [`Apdu`]: the application layer header of every PDU type the node sends or receives;
//! * [`Reader`] / [`Writer`]: application-tagged primitives, context tags, opening and closing
//!   tags (clause 20.2).
//!
//! Parsing borrows from the datagram; emitting writes into a caller's buffer and fails with
//! [`WireError::Overflow`] rather than truncate.

/// Why a datagram or a value does not parse, or does not fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum WireError {
    /// Fewer bytes than the header or a tag's length says.
    #[error("truncated")]
    Truncated,
    /// Not a BACnet/IP BVLC (type byte other than 0x81).
    #[error("BVLC type {0:#04x} is not BACnet/IP (0x81)")]
    BvlcType(u8),
    /// The BVLC length disagrees with the datagram's.
    #[error("BVLC length {declared}, datagram {actual} bytes")]
    BvlcLength {
        /// Length in the header.
        declared: u16,
        /// Bytes received.
        actual: usize,
    },
    /// NPDU protocol version other than 1.
    #[error("NPDU version {0} (only 1 exists)")]
    NpduVersion(u8),
    /// An address length that cannot be (a broadcast DLEN 0 in a source, or over 8 bytes).
    #[error("network address length {0}")]
    AddressLength(u8),
    /// A PDU type 8..=15.
    #[error("APDU type {0} does not exist")]
    ApduType(u8),
    /// A tag other than the one the service's grammar expects here.
    #[error("unexpected tag")]
    UnexpectedTag,
    /// A primitive whose length is wrong for its type (a 5-byte Real, an empty Unsigned...).
    #[error("bad length {0} for the value's type")]
    BadLength(u32),
    /// A value too large for the node's integer types.
    #[error("value out of range")]
    OutOfRange,
    /// Application tag 13..=15 (reserved).
    #[error("reserved application tag {0}")]
    ReservedTag(u8),
    /// A character set other than UTF-8 / ANSI X3.4 (0), or invalid UTF-8.
    #[error("character string not UTF-8")]
    CharacterSet,
    /// Opening and closing tags that do not pair.
    #[error("unbalanced opening/closing tags")]
    Unbalanced,
    /// The output buffer is full.
    #[error("output buffer full")]
    Overflow,
}

/// BVLC function codes (Annex J.2).
pub mod bvlc {
    /// BVLC-Result.
    pub const RESULT: u8 = 0x00;
    /// Write-Broadcast-Distribution-Table.
    pub const WRITE_BDT: u8 = 0x01;
    /// Read-Broadcast-Distribution-Table.
    pub const READ_BDT: u8 = 0x02;
    /// Forwarded-NPDU (from a BBMD: carries the original source address).
    pub const FORWARDED_NPDU: u8 = 0x04;
    /// Register-Foreign-Device.
    pub const REGISTER_FOREIGN_DEVICE: u8 = 0x05;
    /// Read-Foreign-Device-Table.
    pub const READ_FDT: u8 = 0x06;
    /// Delete-Foreign-Device-Table-Entry.
    pub const DELETE_FDT_ENTRY: u8 = 0x08;
    /// Distribute-Broadcast-To-Network.
    pub const DISTRIBUTE_BROADCAST: u8 = 0x09;
    /// Original-Unicast-NPDU.
    pub const ORIGINAL_UNICAST: u8 = 0x0A;
    /// Original-Broadcast-NPDU.
    pub const ORIGINAL_BROADCAST: u8 = 0x0B;
    /// The BACnet/IP type byte.
    pub const TYPE_BIP: u8 = 0x81;
    /// BVLC-Result code: successful completion.
    pub const RESULT_OK: u16 = 0x0000;
    /// BVLC-Result code: Register-Foreign-Device NAK.
    pub const RESULT_REGISTER_FD_NAK: u16 = 0x0030;
}

/// The BVLC of one datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bvlc<'a> {
    /// Function ([`bvlc`]).
    pub function: u8,
    /// Forwarded-NPDU: the original source, IPv4 address and port.
    pub origin: Option<([u8; 4], u16)>,
    /// What follows the header (the NPDU, or the function's own data).
    pub payload: &'a [u8],
}

impl<'a> Bvlc<'a> {
    /// Parses a datagram's BVLC.
    pub fn parse(d: &'a [u8]) -> Result<Self, WireError> {
        let h = d.get(..4).ok_or(WireError::Truncated)?;
        if h[0] != bvlc::TYPE_BIP {
            return Err(WireError::BvlcType(h[0]));
        }
        let declared = u16::from_be_bytes([h[2], h[3]]);
        if usize::from(declared) != d.len() {
            return Err(WireError::BvlcLength {
                declared,
                actual: d.len(),
            });
        }
        let mut payload = &d[4..];
        let mut origin = None;
        if h[1] == bvlc::FORWARDED_NPDU {
            let o = payload.get(..6).ok_or(WireError::Truncated)?;
            origin = Some(([o[0], o[1], o[2], o[3]], u16::from_be_bytes([o[4], o[5]])));
            payload = &payload[6..];
        }
        Ok(Self {
            function: h[1],
            origin,
            payload,
        })
    }

    /// Writes a BVLC header of `function` for `body_len` bytes of payload that the caller
    /// writes next; returns the header length.
    pub fn emit_header(function: u8, body_len: usize, w: &mut Writer<'_>) -> Result<(), WireError> {
        let total = u16::try_from(body_len + 4).map_err(|_| WireError::Overflow)?;
        w.put(&[bvlc::TYPE_BIP, function])?;
        w.put(&total.to_be_bytes())
    }
}

/// A network address: network number and MAC address (up to 8 bytes; empty: broadcast).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NetAddress {
    /// Network number (0xFFFF: global broadcast).
    pub net: u16,
    /// MAC length.
    pub len: u8,
    /// MAC bytes (the first `len`).
    pub mac: [u8; 8],
}

impl NetAddress {
    fn parse(r: &mut Reader<'_>) -> Result<Self, WireError> {
        let net = r.u16()?;
        let len = r.byte()?;
        if len > 8 {
            return Err(WireError::AddressLength(len));
        }
        let mut mac = [0; 8];
        mac[..usize::from(len)].copy_from_slice(r.take(usize::from(len))?);
        Ok(Self { net, len, mac })
    }

    fn emit(&self, w: &mut Writer<'_>) -> Result<(), WireError> {
        w.put(&self.net.to_be_bytes())?;
        w.put(&[self.len])?;
        w.put(&self.mac[..usize::from(self.len.min(8))])
    }
}

/// NPDU control bits (clause 6.2.2).
pub mod npci {
    /// A network-layer message, not an APDU.
    pub const NETWORK_MESSAGE: u8 = 0x80;
    /// DNET, DLEN, DADR and a hop count are present.
    pub const DESTINATION: u8 = 0x20;
    /// SNET, SLEN, SADR are present.
    pub const SOURCE: u8 = 0x08;
    /// A reply is expected (confirmed requests).
    pub const EXPECTING_REPLY: u8 = 0x04;
}

/// The network layer header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Npdu {
    /// Control octet ([`npci`]; the low two bits are the priority).
    pub control: u8,
    /// Destination (a routed or globally broadcast message).
    pub destination: Option<NetAddress>,
    /// Source (a message that came through a router: replies go back to it).
    pub source: Option<NetAddress>,
    /// Hop count (with a destination).
    pub hop_count: u8,
    /// Network-layer message type, when [`npci::NETWORK_MESSAGE`] is set.
    pub message_type: Option<u8>,
}

impl Npdu {
    /// Parses an NPDU; returns it and the APDU (or network message data) after it.
    pub fn parse(d: &[u8]) -> Result<(Self, &[u8]), WireError> {
        let mut r = Reader::new(d);
        let version = r.byte()?;
        if version != 1 {
            return Err(WireError::NpduVersion(version));
        }
        let control = r.byte()?;
        let destination = if control & npci::DESTINATION != 0 {
            Some(NetAddress::parse(&mut r)?)
        } else {
            None
        };
        let source = if control & npci::SOURCE != 0 {
            let s = NetAddress::parse(&mut r)?;
            if s.len == 0 || s.net == 0xFFFF {
                return Err(WireError::AddressLength(s.len));
            }
            Some(s)
        } else {
            None
        };
        let hop_count = if destination.is_some() { r.byte()? } else { 0 };
        let message_type = if control & npci::NETWORK_MESSAGE != 0 {
            let t = r.byte()?;
            if t >= 0x80 {
                r.take(2)?; // vendor id
            }
            Some(t)
        } else {
            None
        };
        let npdu = Self {
            control,
            destination,
            source,
            hop_count,
            message_type,
        };
        Ok((npdu, r.rest()))
    }

    /// An APDU's header going to `destination` (a routed peer's source, if any).
    pub fn to(destination: Option<NetAddress>, expecting_reply: bool) -> Self {
        let mut control = if destination.is_some() {
            npci::DESTINATION
        } else {
            0
        };
        if expecting_reply {
            control |= npci::EXPECTING_REPLY;
        }
        Self {
            control,
            destination,
            source: None,
            hop_count: 255,
            message_type: None,
        }
    }

    /// Writes the header.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), WireError> {
        let mut control = self.control & (npci::NETWORK_MESSAGE | npci::EXPECTING_REPLY | 3);
        if self.destination.is_some() {
            control |= npci::DESTINATION;
        }
        if self.source.is_some() {
            control |= npci::SOURCE;
        }
        w.put(&[1, control])?;
        if let Some(d) = &self.destination {
            d.emit(w)?;
        }
        if let Some(s) = &self.source {
            s.emit(w)?;
        }
        if self.destination.is_some() {
            w.put(&[self.hop_count])?;
        }
        if let Some(t) = self.message_type {
            w.put(&[t])?;
        }
        Ok(())
    }
}

/// APDU types (the high nibble of the first octet).
pub mod pdu_type {
    /// BACnet-Confirmed-Request-PDU.
    pub const CONFIRMED_REQUEST: u8 = 0;
    /// BACnet-Unconfirmed-Request-PDU.
    pub const UNCONFIRMED_REQUEST: u8 = 1;
    /// BACnet-SimpleACK-PDU.
    pub const SIMPLE_ACK: u8 = 2;
    /// BACnet-ComplexACK-PDU.
    pub const COMPLEX_ACK: u8 = 3;
    /// BACnet-SegmentACK-PDU.
    pub const SEGMENT_ACK: u8 = 4;
    /// BACnet-Error-PDU.
    pub const ERROR: u8 = 5;
    /// BACnet-Reject-PDU.
    pub const REJECT: u8 = 6;
    /// BACnet-Abort-PDU.
    pub const ABORT: u8 = 7;
}

/// One APDU's header, and its service data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Apdu<'a> {
    /// A confirmed request.
    ConfirmedRequest {
        /// Segmented-message bit: a segment of a longer request.
        segmented: bool,
        /// The requester accepts a segmented reply.
        segmented_accepted: bool,
        /// Largest APDU the requester accepts, octets.
        max_apdu: u16,
        /// Invoke id.
        invoke_id: u8,
        /// Service choice.
        service: u8,
        /// Service request.
        data: &'a [u8],
    },
    /// An unconfirmed request.
    UnconfirmedRequest {
        /// Service choice.
        service: u8,
        /// Service request.
        data: &'a [u8],
    },
    /// A SimpleACK.
    SimpleAck {
        /// Invoke id.
        invoke_id: u8,
        /// Service acknowledged.
        service: u8,
    },
    /// A ComplexACK (unsegmented).
    ComplexAck {
        /// Invoke id.
        invoke_id: u8,
        /// Service acknowledged.
        service: u8,
        /// Service ACK data.
        data: &'a [u8],
    },
    /// A SegmentACK.
    SegmentAck {
        /// Invoke id.
        invoke_id: u8,
    },
    /// An Error.
    Error {
        /// Invoke id.
        invoke_id: u8,
        /// Service that failed.
        service: u8,
        /// Error class.
        class: u32,
        /// Error code.
        code: u32,
    },
    /// A Reject.
    Reject {
        /// Invoke id.
        invoke_id: u8,
        /// Reason ([`crate::bacnet::consts::reject`]).
        reason: u8,
    },
    /// An Abort.
    Abort {
        /// Sent by the server (of the transaction).
        server: bool,
        /// Invoke id.
        invoke_id: u8,
        /// Reason ([`crate::bacnet::consts::abort`]).
        reason: u8,
    },
}

/// The max-APDU-accepted code (4 bits) in octets (clause 20.1.2.5; codes 6..=15 reserved: 50).
pub fn max_apdu_octets(code: u8) -> u16 {
    match code & 0x0F {
        1 => 128,
        2 => 206,
        3 => 480,
        4 => 1024,
        5 => 1476,
        _ => 50,
    }
}

impl<'a> Apdu<'a> {
    /// Parses an APDU.
    pub fn parse(d: &'a [u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(d);
        let first = r.byte()?;
        Ok(match first >> 4 {
            pdu_type::CONFIRMED_REQUEST => {
                let segmented = first & 0x08 != 0;
                let segmented_accepted = first & 0x02 != 0;
                let sizes = r.byte()?;
                let invoke_id = r.byte()?;
                if segmented {
                    r.take(2)?; // sequence number, proposed window size
                }
                let service = r.byte()?;
                Apdu::ConfirmedRequest {
                    segmented,
                    segmented_accepted,
                    max_apdu: max_apdu_octets(sizes),
                    invoke_id,
                    service,
                    data: r.rest(),
                }
            }
            pdu_type::UNCONFIRMED_REQUEST => Apdu::UnconfirmedRequest {
                service: r.byte()?,
                data: r.rest(),
            },
            pdu_type::SIMPLE_ACK => Apdu::SimpleAck {
                invoke_id: r.byte()?,
                service: r.byte()?,
            },
            pdu_type::COMPLEX_ACK => {
                let invoke_id = r.byte()?;
                if first & 0x08 != 0 {
                    r.take(2)?;
                }
                Apdu::ComplexAck {
                    invoke_id,
                    service: r.byte()?,
                    data: r.rest(),
                }
            }
            pdu_type::SEGMENT_ACK => {
                let invoke_id = r.byte()?;
                r.take(2)?;
                Apdu::SegmentAck { invoke_id }
            }
            pdu_type::ERROR => {
                let invoke_id = r.byte()?;
                let service = r.byte()?;
                let class = r.enumerated()?;
                let code = r.enumerated()?;
                Apdu::Error {
                    invoke_id,
                    service,
                    class,
                    code,
                }
            }
            pdu_type::REJECT => Apdu::Reject {
                invoke_id: r.byte()?,
                reason: r.byte()?,
            },
            pdu_type::ABORT => Apdu::Abort {
                server: first & 1 != 0,
                invoke_id: r.byte()?,
                reason: r.byte()?,
            },
            t => return Err(WireError::ApduType(t)),
        })
    }

    /// Writes the APDU.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), WireError> {
        match *self {
            Apdu::ConfirmedRequest {
                segmented_accepted,
                max_apdu,
                invoke_id,
                service,
                data,
                ..
            } => {
                let code = match max_apdu {
                    1476.. => 5,
                    1024.. => 4,
                    480.. => 3,
                    206.. => 2,
                    128.. => 1,
                    _ => 0,
                };
                let first = if segmented_accepted { 0x02 } else { 0 };
                w.put(&[first, code, invoke_id, service])?;
                w.put(data)
            }
            Apdu::UnconfirmedRequest { service, data } => {
                w.put(&[0x10, service])?;
                w.put(data)
            }
            Apdu::SimpleAck { invoke_id, service } => w.put(&[0x20, invoke_id, service]),
            Apdu::ComplexAck {
                invoke_id,
                service,
                data,
            } => {
                w.put(&[0x30, invoke_id, service])?;
                w.put(data)
            }
            Apdu::SegmentAck { invoke_id } => w.put(&[0x40, invoke_id, 0, 1]),
            Apdu::Error {
                invoke_id,
                service,
                class,
                code,
            } => {
                w.put(&[0x50, invoke_id, service])?;
                w.enumerated(class)?;
                w.enumerated(code)
            }
            Apdu::Reject { invoke_id, reason } => w.put(&[0x60, invoke_id, reason]),
            Apdu::Abort {
                server,
                invoke_id,
                reason,
            } => w.put(&[0x70 | u8::from(server), invoke_id, reason]),
        }
    }
}

/// Application tag numbers (clause 20.2.1.4).
pub mod app_tag {
    /// Null.
    pub const NULL: u8 = 0;
    /// Boolean.
    pub const BOOLEAN: u8 = 1;
    /// Unsigned Integer.
    pub const UNSIGNED: u8 = 2;
    /// Signed Integer.
    pub const SIGNED: u8 = 3;
    /// Real (IEEE 754 single).
    pub const REAL: u8 = 4;
    /// Double (IEEE 754 double).
    pub const DOUBLE: u8 = 5;
    /// Octet String.
    pub const OCTET_STRING: u8 = 6;
    /// Character String.
    pub const CHARACTER_STRING: u8 = 7;
    /// Bit String.
    pub const BIT_STRING: u8 = 8;
    /// Enumerated.
    pub const ENUMERATED: u8 = 9;
    /// Date.
    pub const DATE: u8 = 10;
    /// Time.
    pub const TIME: u8 = 11;
    /// BACnetObjectIdentifier.
    pub const OBJECT_ID: u8 = 12;
}

/// An object identifier: 10-bit type, 22-bit instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ObjectId {
    /// Object type.
    pub object_type: u16,
    /// Instance number (0..=4_194_303; 4_194_303 is the wildcard).
    pub instance: u32,
}

impl ObjectId {
    /// Largest instance number (also the "any device" wildcard).
    pub const MAX_INSTANCE: u32 = 0x3F_FFFF;

    /// An identifier (the instance masked to 22 bits).
    pub const fn new(object_type: u16, instance: u32) -> Self {
        Self {
            object_type: object_type & 0x3FF,
            instance: instance & Self::MAX_INSTANCE,
        }
    }

    /// The 32-bit encoding.
    pub fn to_u32(self) -> u32 {
        (u32::from(self.object_type) << 22) | (self.instance & Self::MAX_INSTANCE)
    }

    /// From the 32-bit encoding.
    pub fn from_u32(v: u32) -> Self {
        Self {
            object_type: (v >> 22) as u16,
            instance: v & Self::MAX_INSTANCE,
        }
    }
}

/// Where a tag's value lies: a length, or an opening or closing tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TagKind {
    /// A primitive of this many octets (for an application Boolean: its value).
    Length(u32),
    /// Opening tag (context only).
    Opening,
    /// Closing tag (context only).
    Closing,
}

/// A decoded tag header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tag {
    /// Tag number.
    pub number: u8,
    /// Context-specific (class bit set).
    pub context: bool,
    /// Length or opening/closing.
    pub kind: TagKind,
}

impl Tag {
    /// True for context tag `n` with a primitive value.
    pub fn is_context(&self, n: u8) -> bool {
        self.context && self.number == n && matches!(self.kind, TagKind::Length(_))
    }
    /// True for opening tag `n`.
    pub fn is_opening(&self, n: u8) -> bool {
        self.context && self.number == n && self.kind == TagKind::Opening
    }
    /// True for closing tag `n`.
    pub fn is_closing(&self, n: u8) -> bool {
        self.context && self.number == n && self.kind == TagKind::Closing
    }
}

/// An application-tagged value, borrowed from the datagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AppValue<'a> {
    /// Null.
    Null,
    /// Boolean.
    Boolean(bool),
    /// Unsigned (up to 64 bits).
    Unsigned(u64),
    /// Signed (up to 64 bits).
    Signed(i64),
    /// Real.
    Real(f32),
    /// Double.
    Double(f64),
    /// Octet string.
    OctetString(&'a [u8]),
    /// Character string (UTF-8).
    CharString(&'a str),
    /// Bit string: unused bits in the last octet, then the octets (bit 0 = MSB of the first).
    BitString {
        /// Unused bits in the last octet (0..=7).
        unused: u8,
        /// The octets.
        bytes: &'a [u8],
    },
    /// Enumerated.
    Enumerated(u32),
    /// Date (year - 1900, month, day, weekday; 0xFF: unspecified).
    Date([u8; 4]),
    /// Time (hour, minute, second, hundredths).
    Time([u8; 4]),
    /// Object identifier.
    ObjectId(ObjectId),
}

/// A cursor over encoded bytes.
#[derive(Debug, Clone, Copy)]
pub struct Reader<'a> {
    d: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Reads `d` from its start.
    pub fn new(d: &'a [u8]) -> Self {
        Self { d, at: 0 }
    }

    /// True when every byte was read.
    pub fn is_empty(&self) -> bool {
        self.at >= self.d.len()
    }

    /// The bytes not yet read.
    pub fn rest(&self) -> &'a [u8] {
        self.d.get(self.at..).unwrap_or(&[])
    }

    /// Bytes read so far.
    pub fn position(&self) -> usize {
        self.at
    }

    fn byte(&mut self) -> Result<u8, WireError> {
        let b = *self.d.get(self.at).ok_or(WireError::Truncated)?;
        self.at += 1;
        Ok(b)
    }

    fn u16(&mut self) -> Result<u16, WireError> {
        let b = self.take(2)?;
        Ok(u16::from_be_bytes([b[0], b[1]]))
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], WireError> {
        let end = self.at.checked_add(n).ok_or(WireError::Truncated)?;
        let s = self.d.get(self.at..end).ok_or(WireError::Truncated)?;
        self.at = end;
        Ok(s)
    }

    /// The next tag, without consuming it.
    pub fn peek_tag(&self) -> Result<Tag, WireError> {
        let mut c = *self;
        c.tag()
    }

    /// Reads a tag header.
    pub fn tag(&mut self) -> Result<Tag, WireError> {
        let first = self.byte()?;
        let mut number = first >> 4;
        if number == 0x0F {
            number = self.byte()?;
        }
        let context = first & 0x08 != 0;
        let lvt = first & 0x07;
        let kind = match lvt {
            6 if context => TagKind::Opening,
            7 if context => TagKind::Closing,
            5 => {
                let n = self.byte()?;
                TagKind::Length(match n {
                    254 => u32::from(self.u16()?),
                    255 => {
                        let b = self.take(4)?;
                        u32::from_be_bytes([b[0], b[1], b[2], b[3]])
                    }
                    n => u32::from(n),
                })
            }
            n => TagKind::Length(u32::from(n)),
        };
        Ok(Tag {
            number,
            context,
            kind,
        })
    }

    /// The content octets of a primitive tag.
    fn content(&mut self, tag: &Tag) -> Result<&'a [u8], WireError> {
        match tag.kind {
            TagKind::Length(n) => self.take(usize::try_from(n).map_err(|_| WireError::Truncated)?),
            _ => Err(WireError::UnexpectedTag),
        }
    }

    /// Reads an application-tagged value.
    pub fn app_value(&mut self) -> Result<AppValue<'a>, WireError> {
        let tag = self.tag()?;
        if tag.context {
            return Err(WireError::UnexpectedTag);
        }
        if tag.number == app_tag::BOOLEAN {
            return match tag.kind {
                TagKind::Length(0) => Ok(AppValue::Boolean(false)),
                TagKind::Length(1) => Ok(AppValue::Boolean(true)),
                TagKind::Length(n) => Err(WireError::BadLength(n)),
                _ => Err(WireError::UnexpectedTag),
            };
        }
        let c = self.content(&tag)?;
        decode_primitive(tag.number, c)
    }

    /// Reads an application-tagged Enumerated.
    pub fn enumerated(&mut self) -> Result<u32, WireError> {
        match self.app_value()? {
            AppValue::Enumerated(v) => Ok(v),
            _ => Err(WireError::UnexpectedTag),
        }
    }

    /// Reads context tag `n` as an Unsigned.
    pub fn context_unsigned(&mut self, n: u8) -> Result<u64, WireError> {
        let c = self.context_content(n)?;
        unsigned(c)
    }

    /// Reads context tag `n` as an Enumerated.
    pub fn context_enumerated(&mut self, n: u8) -> Result<u32, WireError> {
        let c = self.context_content(n)?;
        u32::try_from(unsigned(c)?).map_err(|_| WireError::OutOfRange)
    }

    /// Reads context tag `n` as a Boolean (one content octet).
    pub fn context_bool(&mut self, n: u8) -> Result<bool, WireError> {
        match self.context_content(n)? {
            [b] => Ok(*b != 0),
            c => Err(WireError::BadLength(c.len() as u32)),
        }
    }

    /// Reads context tag `n` as an object identifier.
    pub fn context_object_id(&mut self, n: u8) -> Result<ObjectId, WireError> {
        match self.context_content(n)? {
            [a, b, c, d] => Ok(ObjectId::from_u32(u32::from_be_bytes([*a, *b, *c, *d]))),
            c => Err(WireError::BadLength(c.len() as u32)),
        }
    }

    /// Reads context tag `n` as a character string.
    pub fn context_char_string(&mut self, n: u8) -> Result<&'a str, WireError> {
        let c = self.context_content(n)?;
        char_string(c)
    }

    /// Reads context tag `n`'s content octets.
    pub fn context_content(&mut self, n: u8) -> Result<&'a [u8], WireError> {
        let tag = self.tag()?;
        if !tag.is_context(n) {
            return Err(WireError::UnexpectedTag);
        }
        self.content(&tag)
    }

    /// Reads context tag `n` if it is next.
    pub fn optional_context_unsigned(&mut self, n: u8) -> Result<Option<u64>, WireError> {
        if self.is_empty() || !self.peek_tag()?.is_context(n) {
            return Ok(None);
        }
        self.context_unsigned(n).map(Some)
    }

    /// True (and consumed) when opening tag `n` is next.
    pub fn opening(&mut self, n: u8) -> Result<(), WireError> {
        if self.tag()?.is_opening(n) {
            Ok(())
        } else {
            Err(WireError::UnexpectedTag)
        }
    }

    /// Consumes closing tag `n`.
    pub fn closing(&mut self, n: u8) -> Result<(), WireError> {
        if self.tag()?.is_closing(n) {
            Ok(())
        } else {
            Err(WireError::UnexpectedTag)
        }
    }

    /// True when closing tag `n` is next (not consumed).
    pub fn at_closing(&self, n: u8) -> bool {
        self.peek_tag().is_ok_and(|t| t.is_closing(n))
    }

    /// Everything between opening tag `n` (already consumed) and its closing tag, which is
    /// consumed; nested opening/closing pairs are skipped whatever their numbers.
    pub fn enclosed(&mut self, n: u8) -> Result<&'a [u8], WireError> {
        let start = self.at;
        let mut depth = 0u32;
        loop {
            let before = self.at;
            let tag = self.tag()?;
            match tag.kind {
                TagKind::Opening => depth += 1,
                TagKind::Closing if depth == 0 => {
                    if tag.number != n {
                        return Err(WireError::Unbalanced);
                    }
                    return Ok(&self.d[start..before]);
                }
                TagKind::Closing => depth -= 1,
                TagKind::Length(_) if !tag.context && tag.number == app_tag::BOOLEAN => {}
                TagKind::Length(_) => {
                    self.content(&tag)?;
                }
            }
        }
    }
}

fn unsigned(c: &[u8]) -> Result<u64, WireError> {
    if c.is_empty() || c.len() > 8 {
        return Err(WireError::BadLength(c.len() as u32));
    }
    Ok(c.iter().fold(0u64, |a, &b| (a << 8) | u64::from(b)))
}

fn signed(c: &[u8]) -> Result<i64, WireError> {
    let u = unsigned(c)?;
    let bits = 8 * c.len() as u32;
    Ok(if bits == 64 {
        u as i64
    } else {
        // sign-extend
        ((u << (64 - bits)) as i64) >> (64 - bits)
    })
}

fn char_string(c: &[u8]) -> Result<&str, WireError> {
    match c.split_first() {
        Some((0, s)) => core::str::from_utf8(s).map_err(|_| WireError::CharacterSet),
        Some(_) => Err(WireError::CharacterSet),
        None => Err(WireError::BadLength(0)),
    }
}

fn four(c: &[u8]) -> Result<[u8; 4], WireError> {
    c.try_into()
        .map_err(|_| WireError::BadLength(c.len() as u32))
}

fn decode_primitive(number: u8, c: &[u8]) -> Result<AppValue<'_>, WireError> {
    let len = c.len() as u32;
    Ok(match number {
        app_tag::NULL if c.is_empty() => AppValue::Null,
        app_tag::NULL => return Err(WireError::BadLength(len)),
        app_tag::UNSIGNED => AppValue::Unsigned(unsigned(c)?),
        app_tag::SIGNED => AppValue::Signed(signed(c)?),
        app_tag::REAL => AppValue::Real(f32::from_be_bytes(four(c)?)),
        app_tag::DOUBLE => AppValue::Double(f64::from_be_bytes(
            c.try_into().map_err(|_| WireError::BadLength(len))?,
        )),
        app_tag::OCTET_STRING => AppValue::OctetString(c),
        app_tag::CHARACTER_STRING => AppValue::CharString(char_string(c)?),
        app_tag::BIT_STRING => match c.split_first() {
            Some((&unused, bytes)) if unused <= 7 && !(bytes.is_empty() && unused > 0) => {
                AppValue::BitString { unused, bytes }
            }
            _ => return Err(WireError::BadLength(len)),
        },
        app_tag::ENUMERATED => {
            AppValue::Enumerated(u32::try_from(unsigned(c)?).map_err(|_| WireError::OutOfRange)?)
        }
        app_tag::DATE => AppValue::Date(four(c)?),
        app_tag::TIME => AppValue::Time(four(c)?),
        app_tag::OBJECT_ID => AppValue::ObjectId(ObjectId::from_u32(u32::from_be_bytes(four(c)?))),
        n => return Err(WireError::ReservedTag(n)),
    })
}

/// Writes encoded bytes into a caller's buffer.
#[derive(Debug)]
pub struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
}

/// The shortest big-endian octets of `v` (at least one).
fn minimal(v: u64) -> ([u8; 8], usize) {
    let b = v.to_be_bytes();
    let n = (8 - (v.leading_zeros() / 8) as usize).max(1);
    (b, n)
}

impl<'a> Writer<'a> {
    /// Writes into `buf` from its start.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, len: 0 }
    }

    /// Bytes written.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when nothing was written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// What was written.
    pub fn written(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Appends bytes.
    pub fn put(&mut self, b: &[u8]) -> Result<(), WireError> {
        let end = self.len.checked_add(b.len()).ok_or(WireError::Overflow)?;
        self.buf
            .get_mut(self.len..end)
            .ok_or(WireError::Overflow)?
            .copy_from_slice(b);
        self.len = end;
        Ok(())
    }

    /// A tag header: number, class, length (or 6/7 for opening/closing via `lvt_raw`).
    fn tag(&mut self, number: u8, context: bool, len: usize) -> Result<(), WireError> {
        let class = if context { 0x08 } else { 0 };
        let lvt = if len <= 4 { len as u8 } else { 5 };
        if number <= 14 {
            self.put(&[(number << 4) | class | lvt])?;
        } else {
            self.put(&[0xF0 | class | lvt, number])?;
        }
        if len > 4 {
            if len <= 253 {
                self.put(&[len as u8])?;
            } else if let Ok(l) = u16::try_from(len) {
                self.put(&[254])?;
                self.put(&l.to_be_bytes())?;
            } else {
                let l = u32::try_from(len).map_err(|_| WireError::Overflow)?;
                self.put(&[255])?;
                self.put(&l.to_be_bytes())?;
            }
        }
        Ok(())
    }

    fn tagged(&mut self, number: u8, context: bool, content: &[u8]) -> Result<(), WireError> {
        self.tag(number, context, content.len())?;
        self.put(content)
    }

    /// Opening tag `n`.
    pub fn opening(&mut self, n: u8) -> Result<(), WireError> {
        if n <= 14 {
            self.put(&[(n << 4) | 0x0E])
        } else {
            self.put(&[0xFE, n])
        }
    }

    /// Closing tag `n`.
    pub fn closing(&mut self, n: u8) -> Result<(), WireError> {
        if n <= 14 {
            self.put(&[(n << 4) | 0x0F])
        } else {
            self.put(&[0xFF, n])
        }
    }

    /// Application Null.
    pub fn null(&mut self) -> Result<(), WireError> {
        self.put(&[0x00])
    }

    /// Application Boolean (the value in the tag's length field).
    pub fn boolean(&mut self, v: bool) -> Result<(), WireError> {
        self.put(&[0x10 | u8::from(v)])
    }

    /// Application Unsigned.
    pub fn unsigned(&mut self, v: u64) -> Result<(), WireError> {
        let (b, n) = minimal(v);
        self.tagged(app_tag::UNSIGNED, false, &b[8 - n..])
    }

    /// Application Signed (shortest two's complement).
    pub fn signed(&mut self, v: i64) -> Result<(), WireError> {
        let b = v.to_be_bytes();
        let mut n = 8;
        while n > 1 {
            let (hi, next) = (b[8 - n], b[9 - n]);
            if (hi == 0 && next & 0x80 == 0) || (hi == 0xFF && next & 0x80 != 0) {
                n -= 1;
            } else {
                break;
            }
        }
        self.tagged(app_tag::SIGNED, false, &b[8 - n..])
    }

    /// Application Real.
    pub fn real(&mut self, v: f32) -> Result<(), WireError> {
        self.tagged(app_tag::REAL, false, &v.to_be_bytes())
    }

    /// Application Double.
    pub fn double(&mut self, v: f64) -> Result<(), WireError> {
        self.tagged(app_tag::DOUBLE, false, &v.to_be_bytes())
    }

    /// Application Character String, UTF-8 (character set 0).
    pub fn char_string(&mut self, s: &str) -> Result<(), WireError> {
        self.tag(app_tag::CHARACTER_STRING, false, s.len() + 1)?;
        self.put(&[0])?;
        self.put(s.as_bytes())
    }

    /// Application Bit String of `bits` (bit 0 first).
    pub fn bit_string(&mut self, bits: &[bool]) -> Result<(), WireError> {
        let octets = bits.len().div_ceil(8);
        let unused = (octets * 8 - bits.len()) as u8;
        self.tag(app_tag::BIT_STRING, false, octets + 1)?;
        self.put(&[unused])?;
        for chunk in bits.chunks(8) {
            let b = chunk
                .iter()
                .enumerate()
                .fold(0u8, |a, (i, &on)| a | (u8::from(on) << (7 - i)));
            self.put(&[b])?;
        }
        Ok(())
    }

    /// Application Enumerated.
    pub fn enumerated(&mut self, v: u32) -> Result<(), WireError> {
        let (b, n) = minimal(u64::from(v));
        self.tagged(app_tag::ENUMERATED, false, &b[8 - n..])
    }

    /// Application Object Identifier.
    pub fn object_id(&mut self, id: ObjectId) -> Result<(), WireError> {
        self.tagged(app_tag::OBJECT_ID, false, &id.to_u32().to_be_bytes())
    }

    /// Context Unsigned.
    pub fn context_unsigned(&mut self, n: u8, v: u64) -> Result<(), WireError> {
        let (b, len) = minimal(v);
        self.tagged(n, true, &b[8 - len..])
    }

    /// Context Enumerated.
    pub fn context_enumerated(&mut self, n: u8, v: u32) -> Result<(), WireError> {
        self.context_unsigned(n, u64::from(v))
    }

    /// Context Boolean (one content octet).
    pub fn context_bool(&mut self, n: u8, v: bool) -> Result<(), WireError> {
        self.tagged(n, true, &[u8::from(v)])
    }

    /// Context Object Identifier.
    pub fn context_object_id(&mut self, n: u8, id: ObjectId) -> Result<(), WireError> {
        self.tagged(n, true, &id.to_u32().to_be_bytes())
    }

    /// Context Character String, UTF-8 (character set 0).
    pub fn context_char_string(&mut self, n: u8, s: &str) -> Result<(), WireError> {
        self.tag(n, true, s.len() + 1)?;
        self.put(&[0])?;
        self.put(s.as_bytes())
    }
}

#[cfg(test)]
mod tests;
