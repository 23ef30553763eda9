//! The HIL rig's BMS over BACnet/IP: a small blocking client on the project's own codec
//! (`luxnode::bacnet::wire`) that reads Present_Value of several objects with one
//! ReadPropertyMultiple, as a BMS polls a controller. The server is tested against an
//! independent stack (bacpypes3, tests/bacnet.rs); this client is the rig's second reader
//! beside its Modbus one, so the two protocols can be compared during a simulated run.

use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;

use luxnode::bacnet::consts::{MAX_APDU, confirmed, property};
use luxnode::bacnet::wire::{
    Apdu, AppValue, Bvlc, Npdu, ObjectId, Reader, WireError, Writer, bvlc,
};

/// A BACnet/IP client of one node.
pub struct BacnetBms {
    socket: UdpSocket,
    node: SocketAddr,
    invoke_id: u8,
}

impl BacnetBms {
    /// A client on a free loopback port for the node at `node`.
    pub fn new(node: SocketAddr) -> std::io::Result<Self> {
        let socket = UdpSocket::bind("127.0.0.1:0")?;
        socket.set_read_timeout(Some(Duration::from_secs(2)))?;
        Ok(Self {
            socket,
            node,
            invoke_id: 0,
        })
    }

    /// Present_Value of each object (Real), in order, read with one ReadPropertyMultiple.
    pub fn present_values(&mut self, objects: &[ObjectId]) -> Result<Vec<f32>, String> {
        self.invoke_id = self.invoke_id.wrapping_add(1);
        let request = rpm_request(self.invoke_id, objects).map_err(|e| e.to_string())?;
        self.socket
            .send_to(&request, self.node)
            .map_err(|e| e.to_string())?;
        let mut buf = [0u8; 2048];
        loop {
            let (n, _) = self
                .socket
                .recv_from(&mut buf)
                .map_err(|e| format!("no answer: {e}"))?;
            let b = Bvlc::parse(&buf[..n]).map_err(|e| e.to_string())?;
            let (_, apdu) = Npdu::parse(b.payload).map_err(|e| e.to_string())?;
            match Apdu::parse(apdu).map_err(|e| e.to_string())? {
                Apdu::ComplexAck {
                    invoke_id, data, ..
                } if invoke_id == self.invoke_id => {
                    return parse_rpm_ack(data).map_err(|e| e.to_string());
                }
                // an answer to an earlier request, or an I-Am: not this one
                Apdu::ComplexAck { .. } | Apdu::UnconfirmedRequest { .. } => continue,
                other => return Err(format!("answer {other:?}")),
            }
        }
    }
}

/// The ReadPropertyMultiple datagram: Present_Value of every object.
fn rpm_request(invoke_id: u8, objects: &[ObjectId]) -> Result<Vec<u8>, WireError> {
    let mut body = vec![0u8; MAX_APDU];
    let mut w = Writer::new(&mut body);
    for &o in objects {
        w.context_object_id(0, o)?;
        w.opening(1)?;
        w.context_enumerated(0, property::PRESENT_VALUE)?;
        w.closing(1)?;
    }
    let n = w.len();
    let apdu = Apdu::ConfirmedRequest {
        segmented: false,
        segmented_accepted: false,
        max_apdu: MAX_APDU as u16,
        invoke_id,
        service: confirmed::READ_PROPERTY_MULTIPLE,
        data: &body[..n],
    };
    let mut buf = vec![0u8; MAX_APDU + 64];
    let mut w = Writer::new(&mut buf[4..]);
    Npdu::to(None, true).emit(&mut w)?;
    apdu.emit(&mut w)?;
    let len = w.len();
    Bvlc::emit_header(bvlc::ORIGINAL_UNICAST, len, &mut Writer::new(&mut buf[..4]))?;
    buf.truncate(4 + len);
    Ok(buf)
}

/// The Present_Values of a ReadPropertyMultiple-ACK (an error for any object is an error).
fn parse_rpm_ack(data: &[u8]) -> Result<Vec<f32>, WireError> {
    let mut r = Reader::new(data);
    let mut out = Vec::new();
    while !r.is_empty() {
        r.context_object_id(0)?;
        r.opening(1)?;
        r.context_enumerated(2)?;
        r.optional_context_unsigned(3)?;
        r.opening(4)?;
        let AppValue::Real(v) = r.app_value()? else {
            return Err(WireError::UnexpectedTag);
        };
        r.closing(4)?;
        r.closing(1)?;
        out.push(v);
    }
    Ok(out)
}
