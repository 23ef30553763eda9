//! The services over datagrams, on the fuzzer's sample node (4 desks, 3 luminaires, device
//! 1234, writes from 10.0.0.0/24, DCC password "pw").

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use super::*;
use crate::fieldbus::bacnet::fuzz::{frame, peer, request, sample_node, sample_server};

fn apdus(out: &[Outgoing]) -> Vec<Vec<u8>> {
    out.iter()
        .map(|o| {
            let b = Bvlc::parse(&o.datagram).expect("bvlc");
            let (_, a) = Npdu::parse(b.payload).expect("npdu");
            a.to_vec()
        })
        .collect()
}

fn ask(server: &mut Server, node: &mut Node, from: SocketAddr, d: &[u8]) -> Vec<Vec<u8>> {
    apdus(&server.handle(node, from, d, Instant::now()))
}

fn rp(o: ObjectId, prop: u32, index: Option<u64>) -> Vec<u8> {
    request(confirmed::READ_PROPERTY, |w| {
        let _ = w.context_object_id(0, o);
        let _ = w.context_enumerated(1, prop);
        if let Some(i) = index {
            let _ = w.context_unsigned(2, i);
        }
    })
}

/// The error class and code of an Error APDU.
fn error_of(a: &[u8]) -> Option<(u32, u32)> {
    match Apdu::parse(a) {
        Ok(Apdu::Error { class, code, .. }) => Some((class, code)),
        _ => None,
    }
}

#[test]
fn read_property_errors_and_arrays() {
    let (mut node, mut s) = (sample_node(), sample_server());
    let dev = ObjectId::new(ot::DEVICE, 1234);
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &rp(ObjectId::new(0, 4), p::PRESENT_VALUE, None),
    );
    assert_eq!(
        error_of(&a[0]),
        Some((ec::OBJECT, code::UNKNOWN_OBJECT)),
        "4 desks: 0..=3"
    );
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &rp(ObjectId::new(0, 0), p::LOCATION, None),
    );
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::UNKNOWN_PROPERTY))
    );
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &rp(ObjectId::new(0, 0), p::UNITS, Some(1)),
    );
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::PROPERTY_IS_NOT_AN_ARRAY))
    );
    // Object_List: 1 + 4 × 4 + 3 + 4 objects; index 0 is the count, 25 is past the end
    let a = ask(&mut s, &mut node, peer(), &rp(dev, p::OBJECT_LIST, Some(0)));
    assert_eq!(&a[0][..3], &[0x30, 1, 12]);
    assert!(a[0].ends_with(&[0x3E, 0x21, 24, 0x3F]), "{:02x?}", a[0]);
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &rp(dev, p::OBJECT_LIST, Some(25)),
    );
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::INVALID_ARRAY_INDEX))
    );
    // the wildcard device instance reads this device, its own identifier in the value
    let wild = ObjectId::new(ot::DEVICE, ObjectId::MAX_INSTANCE);
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &rp(wild, p::OBJECT_IDENTIFIER, None),
    );
    assert!(
        a[0].ends_with(&[0x3E, 0xC4, 0x02, 0x00, 0x04, 0xD2, 0x3F]),
        "{:02x?}",
        a[0]
    );
}

#[test]
fn desk_values_the_node_does_not_have_are_nan_and_unreliable() {
    let (mut node, mut s) = (sample_node(), sample_server());
    // desk 1 has no stated uncertainty, and no desk a daylight estimate: NaN, unreliable-other,
    // the fault flag
    for o in [ObjectId::new(0, 301), ObjectId::new(0, 100)] {
        let a = ask(&mut s, &mut node, peer(), &rp(o, p::RELIABILITY, None));
        assert!(
            a[0].ends_with(&[0x3E, 0x91, 7, 0x3F]),
            "{o:?}: {:02x?}",
            a[0]
        );
        let a = ask(&mut s, &mut node, peer(), &rp(o, p::STATUS_FLAGS, None));
        assert!(
            a[0].ends_with(&[0x3E, 0x82, 0x04, 0x40, 0x3F]),
            "fault: {:02x?}",
            a[0]
        );
        let a = ask(&mut s, &mut node, peer(), &rp(o, p::PRESENT_VALUE, None));
        let n = a[0].len();
        let v = f32::from_be_bytes([a[0][n - 5], a[0][n - 4], a[0][n - 3], a[0][n - 2]]);
        assert!(v.is_nan(), "{o:?}: {v}");
    }
    // desk 0's total and stated uncertainty are good
    for o in [ObjectId::new(0, 0), ObjectId::new(0, 300)] {
        let a = ask(&mut s, &mut node, peer(), &rp(o, p::RELIABILITY, None));
        assert!(
            a[0].ends_with(&[0x3E, 0x91, 0, 0x3F]),
            "{o:?}: {:02x?}",
            a[0]
        );
    }
}

#[test]
fn read_property_multiple_expands_and_reports_errors_per_property() {
    let (mut node, mut s) = (sample_node(), sample_server());
    let d = request(confirmed::READ_PROPERTY_MULTIPLE, |w| {
        let _ = w.context_object_id(0, ObjectId::new(0, 1));
        let _ = w.opening(1);
        let _ = w.context_enumerated(0, p::OPTIONAL);
        let _ = w.closing(1);
        let _ = w.context_object_id(0, ObjectId::new(0, 99));
        let _ = w.opening(1);
        let _ = w.context_enumerated(0, p::PRESENT_VALUE);
        let _ = w.closing(1);
    });
    let a = ask(&mut s, &mut node, peer(), &d);
    let Ok(Apdu::ComplexAck { data, .. }) = Apdu::parse(&a[0]) else {
        panic!("{:02x?}", a[0]);
    };
    let mut r = Reader::new(data);
    assert_eq!(r.context_object_id(0), Ok(ObjectId::new(0, 1)));
    r.opening(1).unwrap();
    // OPTIONAL of an Analog Input: Description, Reliability, COV_Increment, each a value
    for want in [p::DESCRIPTION, p::RELIABILITY, p::COV_INCREMENT] {
        assert_eq!(r.context_enumerated(2), Ok(want));
        r.opening(4).unwrap();
        r.enclosed(4).unwrap();
    }
    r.closing(1).unwrap();
    assert_eq!(r.context_object_id(0), Ok(ObjectId::new(0, 99)));
    r.opening(1).unwrap();
    assert_eq!(r.context_enumerated(2), Ok(p::PRESENT_VALUE));
    r.opening(5).unwrap();
    assert_eq!(
        r.enclosed(5),
        Ok(&[0x91, 0x01, 0x91, 0x1F][..]),
        "unknown-object"
    );
    r.closing(1).unwrap();
    assert!(r.is_empty());
    // an empty property list: reject, missing-required-parameter
    let d = request(confirmed::READ_PROPERTY_MULTIPLE, |w| {
        let _ = w.context_object_id(0, ObjectId::new(0, 1));
        let _ = w.opening(1);
        let _ = w.closing(1);
    });
    assert_eq!(ask(&mut s, &mut node, peer(), &d)[0], vec![0x60, 1, 5]);
}

#[test]
fn a_bbmd_function_gets_a_nak_and_routed_and_forwarded_requests_are_answered_back() {
    let (mut node, mut s) = (sample_node(), sample_server());
    let out = s.handle(
        &mut node,
        peer(),
        &[0x81, 0x05, 0, 6, 0, 60],
        Instant::now(),
    );
    assert_eq!(out[0].datagram, vec![0x81, 0x00, 0, 6, 0x00, 0x30]);
    // Who-Is from network 5, MAC 0x21, through a router: I-Am back to DNET 5 / DADR 0x21
    let routed = [
        0x81, 0x0B, 0x00, 0x10, 0x01, 0x08, 0x00, 0x05, 0x01, 0x21, 0x10, 0x08, 0x09, 0x00, 0x1A,
        0x13,
    ];
    let mut routed = routed.to_vec();
    routed.truncate(12);
    routed[3] = 12;
    let out = s.handle(&mut node, peer(), &routed, Instant::now());
    assert_eq!(
        &out[0].datagram[4..11],
        &[0x01, 0x20, 0x00, 0x05, 0x01, 0x21, 0xFF]
    );
    assert_eq!(&out[0].datagram[11..13], &[0x10, 0x00], "I-Am");
    // Forwarded-NPDU: the answer goes to the original source, not to the BBMD
    let fwd = [
        0x81, 0x04, 0x00, 0x0E, 10, 0, 0, 7, 0xBA, 0xC0, 0x01, 0x00, 0x10, 0x08,
    ];
    let out = s.handle(&mut node, peer(), &fwd, Instant::now());
    assert_eq!(out[0].to, SocketAddr::from(([10, 0, 0, 7], 47808)));
    // a Who-Is for another range, a network message, a message for network 9: silence
    for d in [
        frame(true, &[0x10, 0x08, 0x09, 0x01, 0x19, 0x02]),
        vec![0x81, 0x0A, 0, 7, 0x01, 0x80, 0x00],
        vec![0x81, 0x0A, 0, 11, 0x01, 0x20, 0x00, 0x09, 0x00, 0xFF, 0x10],
    ] {
        assert!(
            s.handle(&mut node, peer(), &d, Instant::now()).is_empty(),
            "{d:02x?}"
        );
    }
}

#[test]
fn writes_and_cov_notifications() {
    let (mut node, mut s) = (sample_node(), sample_server());
    let level = ObjectId::new(ot::ANALOG_VALUE, 0);
    let ai = ObjectId::new(ot::ANALOG_INPUT, 0);
    let sub = request(confirmed::SUBSCRIBE_COV, |w| {
        let _ = w.context_unsigned(0, 5);
        let _ = w.context_object_id(1, ai);
        let _ = w.context_bool(2, false);
        let _ = w.context_unsigned(3, 30);
    });
    let a = ask(&mut s, &mut node, peer(), &sub);
    assert_eq!(a[0], vec![0x20, 1, confirmed::SUBSCRIBE_COV]);
    assert_eq!(
        &a[1][..2],
        &[0x10, unconfirmed::COV_NOTIFICATION],
        "initial"
    );
    assert!(
        s.poll_cov(&node, Instant::now()).is_empty(),
        "nothing changed"
    );
    let write = |o: ObjectId, prop: u32, v: f32| {
        request(confirmed::WRITE_PROPERTY, |w| {
            let _ = w.context_object_id(0, o);
            let _ = w.context_enumerated(1, prop);
            let _ = w.opening(3);
            let _ = w.real(v);
            let _ = w.closing(3);
        })
    };
    // from outside the allowlist: refused, nothing notified
    let stranger = SocketAddr::from(([192, 168, 1, 1], 47808));
    let a = ask(
        &mut s,
        &mut node,
        stranger,
        &write(level, p::PRESENT_VALUE, 0.0),
    );
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::WRITE_ACCESS_DENIED))
    );
    assert!(s.poll_cov(&node, Instant::now()).is_empty());
    // luminaire 0 off: desk 0 loses 100 lx × 200-arc level: notified
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &write(level, p::PRESENT_VALUE, 0.0),
    );
    assert_eq!(a[0], vec![0x20, 1, confirmed::WRITE_PROPERTY]);
    assert_eq!(node.levels()[0], 0.0);
    let n = apdus(&s.poll_cov(&node, Instant::now()));
    assert_eq!(n.len(), 1);
    // a COV_Increment of 1000 lx: a small change is not notified
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &write(ai, p::COV_INCREMENT, 1000.0),
    );
    assert_eq!(a[0], vec![0x20, 1, confirmed::WRITE_PROPERTY]);
    ask(
        &mut s,
        &mut node,
        peer(),
        &write(level, p::PRESENT_VALUE, 100.0),
    );
    assert!(s.poll_cov(&node, Instant::now()).is_empty());
    // a Real for a read-only property, a string for a level: errors
    let a = ask(&mut s, &mut node, peer(), &write(ai, p::PRESENT_VALUE, 1.0));
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::WRITE_ACCESS_DENIED))
    );
    let bad = request(confirmed::WRITE_PROPERTY, |w| {
        let _ = w.context_object_id(0, level);
        let _ = w.context_enumerated(1, p::PRESENT_VALUE);
        let _ = w.opening(3);
        let _ = w.char_string("50");
        let _ = w.closing(3);
    });
    let a = ask(&mut s, &mut node, peer(), &bad);
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::INVALID_DATA_TYPE))
    );
    // the subscription ends with its lifetime
    assert!(
        s.poll_cov(&node, Instant::now() + Duration::from_secs(31))
            .is_empty()
    );
    assert_eq!(s.subscriptions(), 0);
}

#[test]
fn device_communication_control_needs_the_password_and_the_allowlist() {
    let (mut node, mut s) = (sample_node(), sample_server());
    let dcc = |state: u32, pw: Option<&str>| {
        request(confirmed::DEVICE_COMMUNICATION_CONTROL, |w| {
            let _ = w.context_enumerated(1, state);
            if let Some(pw) = pw {
                // context tag 2, extended length: character set 0, then the UTF-8 octets
                let _ = w.put(&[0x2D, pw.len() as u8 + 1, 0]);
                let _ = w.put(pw.as_bytes());
            }
        })
    };
    let stranger = SocketAddr::from(([192, 168, 1, 1], 47808));
    let a = ask(&mut s, &mut node, stranger, &dcc(1, Some("pw")));
    assert_eq!(
        error_of(&a[0]),
        Some((ec::SERVICES, code::SERVICE_REQUEST_DENIED))
    );
    let a = ask(&mut s, &mut node, peer(), &dcc(1, Some("nope")));
    assert_eq!(
        error_of(&a[0]),
        Some((ec::SECURITY, code::PASSWORD_FAILURE))
    );
    let a = ask(&mut s, &mut node, peer(), &dcc(1, Some("pw")));
    assert_eq!(a[0], vec![0x20, 1, confirmed::DEVICE_COMMUNICATION_CONTROL]);
    let read = rp(ObjectId::new(0, 0), p::PRESENT_VALUE, None);
    assert!(
        ask(&mut s, &mut node, peer(), &read).is_empty(),
        "disabled: silent"
    );
    assert!(ask(&mut s, &mut node, peer(), &frame(true, &[0x10, 0x08])).is_empty());
    let a = ask(&mut s, &mut node, peer(), &dcc(0, Some("pw")));
    assert_eq!(a[0], vec![0x20, 1, confirmed::DEVICE_COMMUNICATION_CONTROL]);
    assert_eq!(
        ask(&mut s, &mut node, peer(), &read).len(),
        1,
        "enabled again"
    );
    // without a board password: always refused
    let mut plain = Server::new(ServerConfig {
        dcc_password: None,
        ..s.config().clone()
    });
    let a = ask(&mut plain, &mut node, peer(), &dcc(1, Some("pw")));
    assert_eq!(
        error_of(&a[0]),
        Some((ec::SERVICES, code::SERVICE_REQUEST_DENIED))
    );
}

#[test]
fn confirmed_notifications_are_sent_again_until_acknowledged() {
    let (mut node, mut s) = (sample_node(), sample_server());
    let ai = ObjectId::new(ot::ANALOG_INPUT, 0);
    let sub = request(confirmed::SUBSCRIBE_COV, |w| {
        let _ = w.context_unsigned(0, 5);
        let _ = w.context_object_id(1, ai);
        let _ = w.context_bool(2, true);
        let _ = w.context_unsigned(3, 600);
    });
    let t0 = Instant::now();
    let a = apdus(&s.handle(&mut node, peer(), &sub, t0));
    assert_eq!(a.len(), 2, "ACK and the initial notification");
    let Ok(Apdu::ConfirmedRequest {
        invoke_id, service, ..
    }) = Apdu::parse(&a[1])
    else {
        panic!("{:02x?}", a[1]);
    };
    assert_eq!(service, confirmed::COV_NOTIFICATION);
    // not acknowledged: the same datagram again after 3 s, 3 times, then given up
    assert!(s.poll_cov(&node, t0 + Duration::from_secs(2)).is_empty());
    let mut t = t0;
    for _ in 0..APDU_RETRIES {
        t += APDU_TIMEOUT;
        let again = apdus(&s.poll_cov(&node, t));
        assert_eq!(again, vec![a[1].clone()]);
    }
    assert!(s.poll_cov(&node, t + APDU_TIMEOUT).is_empty(), "given up");
    // a change, acknowledged at once: never sent again
    let level = request(confirmed::WRITE_PROPERTY, |w| {
        let _ = w.context_object_id(0, ObjectId::new(ot::ANALOG_VALUE, 0));
        let _ = w.context_enumerated(1, p::PRESENT_VALUE);
        let _ = w.opening(3);
        let _ = w.real(0.0);
        let _ = w.closing(3);
    });
    s.handle(&mut node, peer(), &level, t);
    let n = apdus(&s.poll_cov(&node, t));
    let Ok(Apdu::ConfirmedRequest { invoke_id: id2, .. }) = Apdu::parse(&n[0]) else {
        panic!("{:02x?}", n[0]);
    };
    assert_ne!(id2, invoke_id);
    let ack = frame(false, &[0x20, id2, confirmed::COV_NOTIFICATION]);
    assert!(s.handle(&mut node, peer(), &ack, t).is_empty());
    assert!(
        s.poll_cov(&node, t + APDU_TIMEOUT).is_empty(),
        "acknowledged"
    );
}

#[test]
fn occupancy_binary_inputs_are_read_notified_and_never_written() {
    use crate::modbus::regmap::{Occupancy, OccupancyDesk, occupancy_status};
    let (mut node, mut s) = (sample_node(), sample_server());
    let (bi0, bi1) = (
        ObjectId::new(ot::BINARY_INPUT, 0),
        ObjectId::new(ot::BINARY_INPUT, 1),
    );
    // no occupancy on this node: no Binary Input
    let a = ask(&mut s, &mut node, peer(), &rp(bi0, p::PRESENT_VALUE, None));
    assert_eq!(error_of(&a[0]), Some((ec::OBJECT, code::UNKNOWN_OBJECT)));
    let publish = |node: &mut Node, first: Occupancy, status: u16| {
        let mut desks = [OccupancyDesk::default(); 4];
        desks[0].state = first;
        node.set_occupancy(&desks, Some(1), status, 900.0);
    };
    publish(&mut node, Occupancy::Occupied, occupancy_status::ON);
    // one per desk: Object_List 1 + 4 × 4 + 3 + 4 + 4
    let dev = ObjectId::new(ot::DEVICE, 1234);
    let a = ask(&mut s, &mut node, peer(), &rp(dev, p::OBJECT_LIST, Some(0)));
    assert!(a[0].ends_with(&[0x3E, 0x21, 28, 0x3F]), "{:02x?}", a[0]);
    // Present_Value active (enumerated 1); desk 1 unknown: inactive, no-sensor, fault
    let a = ask(&mut s, &mut node, peer(), &rp(bi0, p::PRESENT_VALUE, None));
    assert!(a[0].ends_with(&[0x3E, 0x91, 0x01, 0x3F]), "{:02x?}", a[0]);
    let a = ask(&mut s, &mut node, peer(), &rp(bi1, p::PRESENT_VALUE, None));
    assert!(a[0].ends_with(&[0x3E, 0x91, 0x00, 0x3F]), "{:02x?}", a[0]);
    let a = ask(&mut s, &mut node, peer(), &rp(bi1, p::RELIABILITY, None));
    assert!(a[0].ends_with(&[0x3E, 0x91, 0x01, 0x3F]), "{:02x?}", a[0]);
    let a = ask(&mut s, &mut node, peer(), &rp(bi1, p::STATUS_FLAGS, None));
    assert!(
        a[0].ends_with(&[0x3E, 0x82, 0x04, 0x40, 0x3F]),
        "{:02x?}",
        a[0]
    );
    let a = ask(&mut s, &mut node, peer(), &rp(bi0, p::COV_INCREMENT, None));
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::UNKNOWN_PROPERTY))
    );
    // never written, even from the allowlist
    let write = request(confirmed::WRITE_PROPERTY, |w| {
        let _ = w.context_object_id(0, bi0);
        let _ = w.context_enumerated(1, p::PRESENT_VALUE);
        let _ = w.opening(3);
        let _ = w.enumerated(0);
        let _ = w.closing(3);
    });
    let a = ask(&mut s, &mut node, peer(), &write);
    assert_eq!(
        error_of(&a[0]),
        Some((ec::PROPERTY, code::WRITE_ACCESS_DENIED))
    );
    // COV: the initial notification, then each change of the value or of the fault flag,
    // the value as an enumerated BACnetBinaryPV
    let sub = request(confirmed::SUBSCRIBE_COV, |w| {
        let _ = w.context_unsigned(0, 6);
        let _ = w.context_object_id(1, bi0);
        let _ = w.context_bool(2, false);
        let _ = w.context_unsigned(3, 60);
    });
    let pv = |v: u8| [0x09, 0x55, 0x2E, 0x91, v, 0x2F];
    let has = |a: &[u8], x: &[u8]| a.windows(x.len()).any(|w| w == x);
    let a = ask(&mut s, &mut node, peer(), &sub);
    assert!(has(&a[1], &pv(1)), "initial {:02x?}", a[1]);
    assert!(s.poll_cov(&node, Instant::now()).is_empty());
    publish(&mut node, Occupancy::Vacant, occupancy_status::ON);
    let n = apdus(&s.poll_cov(&node, Instant::now()));
    assert_eq!(n.len(), 1);
    assert!(has(&n[0], &pv(0)), "{:02x?}", n[0]);
    // unknown (stale depth): the same inactive, now with the fault flag: notified
    publish(
        &mut node,
        Occupancy::Unknown,
        occupancy_status::ON | occupancy_status::STALE,
    );
    let n = apdus(&s.poll_cov(&node, Instant::now()));
    assert_eq!(n.len(), 1);
    assert!(has(&n[0], &[0x2E, 0x82, 0x04, 0x40, 0x2F]), "{:02x?}", n[0]);
    let a = ask(&mut s, &mut node, peer(), &rp(bi0, p::RELIABILITY, None));
    assert!(a[0].ends_with(&[0x3E, 0x91, 12, 0x3F]), "{:02x?}", a[0]);
}

#[test]
fn who_has_is_answered_with_i_have_only_for_objects_the_node_has() {
    use crate::bacnet::who_has::{IHave, Wanted};
    use crate::fieldbus::bacnet::fuzz::{who_has, with_occupancy};
    let (mut node, mut s) = (with_occupancy(sample_node()), sample_server());
    let i_have = |a: &[u8]| {
        assert_eq!(&a[..2], &[0x10, unconfirmed::I_HAVE], "{a:02x?}");
        let h = IHave::parse(&a[2..]).expect("I-Have parses");
        (h.device, h.object, h.name.to_owned())
    };
    let dev = ObjectId::new(ot::DEVICE, 1234);
    // by name: sensor 9 is desk index 1 (sensor ids 7, 9, 11, 13; no geometry: named S<id>)
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &who_has(None, Wanted::Name("S9 daylight")),
    );
    let want = (
        dev,
        ObjectId::new(ot::ANALOG_INPUT, 101),
        "S9 daylight".into(),
    );
    assert_eq!(i_have(&a[0]), want);
    // by identifier, inside the range; the Device by its own identifier
    let bi = ObjectId::new(ot::BINARY_INPUT, 3);
    let a = ask(
        &mut s,
        &mut node,
        peer(),
        &who_has(Some((1234, 1234)), Wanted::Id(bi)),
    );
    assert_eq!(i_have(&a[0]), (dev, bi, "S13 occupancy".into()));
    let a = ask(&mut s, &mut node, peer(), &who_has(None, Wanted::Id(dev)));
    assert_eq!(i_have(&a[0]), (dev, dev, "fuzz 1234".into()));
    // silence: outside the range, an object or name the node does not have, the Device's
    // wildcard, a name in another case, disabled initiation
    for q in [
        who_has(Some((0, 1233)), Wanted::Id(bi)),
        who_has(None, Wanted::Id(ObjectId::new(ot::ANALOG_INPUT, 4))),
        who_has(
            None,
            Wanted::Id(ObjectId::new(ot::DEVICE, ObjectId::MAX_INSTANCE)),
        ),
        who_has(None, Wanted::Name("desk 8 daylight")),
        who_has(None, Wanted::Name("Desk 9 daylight")),
    ] {
        assert!(ask(&mut s, &mut node, peer(), &q).is_empty(), "{q:02x?}");
    }
    let dcc = request(confirmed::DEVICE_COMMUNICATION_CONTROL, |w| {
        let _ = w.context_enumerated(1, 2);
        let _ = w.context_char_string(2, "pw");
    });
    let a = ask(&mut s, &mut node, peer(), &dcc);
    assert_eq!(a[0], vec![0x20, 1, confirmed::DEVICE_COMMUNICATION_CONTROL]);
    let q = who_has(None, Wanted::Id(dev));
    assert!(
        ask(&mut s, &mut node, peer(), &q).is_empty(),
        "initiation disabled"
    );
    assert_eq!(
        ask(&mut s, &mut node, peer(), &frame(true, &[0x10, 0x08])).len(),
        1,
        "I-Am still"
    );
}
