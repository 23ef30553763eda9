//! The codec against byte strings worked out by hand from the encoding rules of ASHRAE 135
//! clause 20.2 and the service examples of its Annex F (restated, not quoted): each expected
//! string below was derived octet by octet from the rules, independently of this code.

use super::*;

fn enc(f: impl FnOnce(&mut Writer<'_>) -> Result<(), WireError>) -> ([u8; 64], usize) {
    let mut buf = [0u8; 64];
    let mut w = Writer::new(&mut buf);
    f(&mut w).expect("fits");
    let n = w.len();
    (buf, n)
}

fn same(f: impl FnOnce(&mut Writer<'_>) -> Result<(), WireError>, want: &[u8]) {
    let (b, n) = enc(f);
    assert_eq!(&b[..n], want);
}

#[test]
fn application_primitives_encode_as_clause_20_2_says() {
    same(|w| w.null(), &[0x00]);
    same(|w| w.boolean(false), &[0x10]);
    same(|w| w.boolean(true), &[0x11]);
    // Unsigned 72: tag 2, one octet
    same(|w| w.unsigned(72), &[0x21, 0x48]);
    same(|w| w.unsigned(0), &[0x21, 0x00]);
    same(|w| w.unsigned(1476), &[0x22, 0x05, 0xC4]);
    // Signed 72 and -72: shortest two's complement
    same(|w| w.signed(72), &[0x31, 0x48]);
    same(|w| w.signed(-72), &[0x31, 0xB8]);
    same(|w| w.signed(128), &[0x32, 0x00, 0x80]);
    // Real 72.0 = 0x42900000, Double 72.0 = 0x4052000000000000 (extended length 8)
    same(|w| w.real(72.0), &[0x44, 0x42, 0x90, 0x00, 0x00]);
    same(
        |w| w.double(72.0),
        &[0x55, 0x08, 0x40, 0x52, 0, 0, 0, 0, 0, 0],
    );
    // "AB" in UTF-8: length 3 (charset octet), charset 0
    same(|w| w.char_string("AB"), &[0x73, 0x00, 0x41, 0x42]);
    // Bit string B'10101': 3 unused bits, 0xA8
    same(
        |w| w.bit_string(&[true, false, true, false, true]),
        &[0x82, 0x03, 0xA8],
    );
    // Enumerated 0 (analog-input) and 37 (luxes)
    same(|w| w.enumerated(0), &[0x91, 0x00]);
    same(|w| w.enumerated(37), &[0x91, 0x25]);
    // Object identifier (binary-input, 15): type 3 << 22 | 15 = 0x00C0000F
    same(
        |w| w.object_id(ObjectId::new(3, 15)),
        &[0xC4, 0x00, 0xC0, 0x00, 0x0F],
    );
}

#[test]
fn context_tags_and_extended_forms() {
    // context tag 0, Unsigned 256
    same(|w| w.context_unsigned(0, 256), &[0x0A, 0x01, 0x00]);
    // context tag 33 (extended tag number), Unsigned 72
    same(|w| w.context_unsigned(33, 72), &[0xF9, 0x21, 0x48]);
    same(|w| w.opening(3), &[0x3E]);
    same(|w| w.closing(3), &[0x3F]);
    same(|w| w.opening(20), &[0xFE, 20]);
    // a 300-octet string: length 254 escape then 0x012D (301 with the charset octet)
    let long = "x".repeat(300);
    let mut buf = [0u8; 400];
    let mut w = Writer::new(&mut buf);
    w.char_string(&long).unwrap();
    assert_eq!(&w.written()[..4], &[0x75, 254, 0x01, 0x2D]);
    let mut r = Reader::new(w.written());
    assert_eq!(r.app_value().unwrap(), AppValue::CharString(&long));
    assert!(r.is_empty());
}

#[test]
fn primitives_decode_back() {
    let mut buf = [0u8; 128];
    let mut w = Writer::new(&mut buf);
    w.null().unwrap();
    w.boolean(true).unwrap();
    w.unsigned(u64::from(u32::MAX) + 5).unwrap();
    w.signed(-1).unwrap();
    w.signed(i64::MIN).unwrap();
    w.real(-1.5).unwrap();
    w.double(1e300).unwrap();
    w.char_string("desk 7 lux").unwrap();
    w.bit_string(&[false, true]).unwrap();
    w.enumerated(98).unwrap();
    w.object_id(ObjectId::new(8, 1234)).unwrap();
    let mut r = Reader::new(w.written());
    let want = [
        AppValue::Null,
        AppValue::Boolean(true),
        AppValue::Unsigned(u64::from(u32::MAX) + 5),
        AppValue::Signed(-1),
        AppValue::Signed(i64::MIN),
        AppValue::Real(-1.5),
        AppValue::Double(1e300),
        AppValue::CharString("desk 7 lux"),
        AppValue::BitString {
            unused: 6,
            bytes: &[0x40],
        },
        AppValue::Enumerated(98),
        AppValue::ObjectId(ObjectId::new(8, 1234)),
    ];
    for v in want {
        assert_eq!(r.app_value().unwrap(), v);
    }
    assert!(r.is_empty());
}

#[test]
fn who_is_global_broadcast_datagram() {
    // BVLC Original-Broadcast, length 12; NPDU v1, destination present (0x20), DNET 0xFFFF,
    // DLEN 0, hop count 255; APDU unconfirmed (0x10) Who-Is (8)
    let d = [
        0x81, 0x0B, 0x00, 0x0C, 0x01, 0x20, 0xFF, 0xFF, 0x00, 0xFF, 0x10, 0x08,
    ];
    let b = Bvlc::parse(&d).unwrap();
    assert_eq!(b.function, bvlc::ORIGINAL_BROADCAST);
    let (n, apdu) = Npdu::parse(b.payload).unwrap();
    assert_eq!(n.destination.map(|a| (a.net, a.len)), Some((0xFFFF, 0)));
    assert_eq!(n.hop_count, 255);
    assert_eq!(
        Apdu::parse(apdu).unwrap(),
        Apdu::UnconfirmedRequest {
            service: 8,
            data: &[]
        }
    );
}

#[test]
fn read_property_request_and_ack_of_annex_f() {
    // ReadProperty of (analog-input, 5) Present_Value, invoke id 1, 1476 octets accepted:
    // 00 05 01 0C | 0C 00000005 (context 0, object id) | 19 55 (context 1, property 85)
    let req = [0x00, 0x05, 0x01, 0x0C, 0x0C, 0, 0, 0, 5, 0x19, 0x55];
    let Apdu::ConfirmedRequest {
        invoke_id,
        service,
        data,
        max_apdu,
        segmented,
        ..
    } = Apdu::parse(&req).unwrap()
    else {
        panic!("not a confirmed request");
    };
    assert_eq!(
        (invoke_id, service, max_apdu, segmented),
        (1, 12, 1476, false)
    );
    let mut r = Reader::new(data);
    assert_eq!(r.context_object_id(0).unwrap(), ObjectId::new(0, 5));
    assert_eq!(r.context_unsigned(1).unwrap(), 85);
    // the ACK with Present_Value 72.0: 30 01 0C, object id, property, 3E 44 42900000 3F
    let mut body = [0u8; 32];
    let mut w = Writer::new(&mut body);
    w.context_object_id(0, ObjectId::new(0, 5)).unwrap();
    w.context_unsigned(1, 85).unwrap();
    w.opening(3).unwrap();
    w.real(72.0).unwrap();
    w.closing(3).unwrap();
    let n = w.len();
    let (b, len) = enc(|w| {
        Apdu::ComplexAck {
            invoke_id: 1,
            service: 12,
            data: &body[..n],
        }
        .emit(w)
    });
    assert_eq!(
        &b[..len],
        &[
            0x30, 0x01, 0x0C, 0x0C, 0, 0, 0, 5, 0x19, 0x55, 0x3E, 0x44, 0x42, 0x90, 0, 0, 0x3F
        ]
    );
}

#[test]
fn error_reject_abort_and_i_am() {
    // Error: unknown-object (class object 1, code 31) to ReadProperty, invoke 1
    same(
        |w| {
            Apdu::Error {
                invoke_id: 1,
                service: 12,
                class: 1,
                code: 31,
            }
            .emit(w)
        },
        &[0x50, 0x01, 0x0C, 0x91, 0x01, 0x91, 0x1F],
    );
    same(
        |w| {
            Apdu::Reject {
                invoke_id: 7,
                reason: 9,
            }
            .emit(w)
        },
        &[0x60, 0x07, 0x09],
    );
    same(
        |w| {
            Apdu::Abort {
                server: true,
                invoke_id: 7,
                reason: 4,
            }
            .emit(w)
        },
        &[0x71, 0x07, 0x04],
    );
    // I-Am of device 1234: C4 02 00 04 D2 | 22 05 C4 | 91 03 | 21 vendor
    same(
        |w| {
            w.put(&[0x10, 0x00])?;
            w.object_id(ObjectId::new(8, 1234))?;
            w.unsigned(1476)?;
            w.enumerated(3)?;
            w.unsigned(15)
        },
        &[
            0x10, 0x00, 0xC4, 0x02, 0x00, 0x04, 0xD2, 0x22, 0x05, 0xC4, 0x91, 0x03, 0x21, 0x0F,
        ],
    );
}

#[test]
fn routed_npdu_round_trips() {
    let src = NetAddress {
        net: 5,
        len: 1,
        mac: [0x21, 0, 0, 0, 0, 0, 0, 0],
    };
    let n = Npdu {
        control: npci::EXPECTING_REPLY,
        destination: None,
        source: Some(src),
        hop_count: 0,
        message_type: None,
    };
    let (b, len) = enc(|w| n.emit(w));
    assert_eq!(&b[..len], &[0x01, 0x0C, 0x00, 0x05, 0x01, 0x21]);
    let (back, rest) = Npdu::parse(&b[..len]).unwrap();
    assert_eq!(back.source, Some(src));
    assert!(rest.is_empty());
    // a reply goes to it: DNET 5, DLEN 1, DADR 0x21, hop count 255
    let (b, len) = enc(|w| Npdu::to(Some(src), false).emit(w));
    assert_eq!(&b[..len], &[0x01, 0x20, 0x00, 0x05, 0x01, 0x21, 0xFF]);
}

#[test]
fn bad_input_is_an_error_never_a_panic() {
    assert_eq!(Bvlc::parse(&[0x81, 0x0A]), Err(WireError::Truncated));
    assert_eq!(
        Bvlc::parse(&[0x82, 0x0A, 0, 4]),
        Err(WireError::BvlcType(0x82))
    );
    assert!(matches!(
        Bvlc::parse(&[0x81, 0x0A, 0, 9]),
        Err(WireError::BvlcLength { .. })
    ));
    assert_eq!(
        Npdu::parse(&[2, 0]).map(|x| x.0),
        Err(WireError::NpduVersion(2))
    );
    assert_eq!(
        Npdu::parse(&[1, 0x20, 0, 1, 9]).map(|x| x.0),
        Err(WireError::AddressLength(9))
    );
    assert_eq!(Apdu::parse(&[0x80]), Err(WireError::ApduType(8)));
    // a tag claiming 2^32-1 octets
    let mut r = Reader::new(&[0x25, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
    assert_eq!(r.app_value(), Err(WireError::Truncated));
    // a 3-octet Real, reserved tag 13, a 9-octet Unsigned, bad UTF-8, charset 4
    for bad in [
        &[0x43, 0, 0, 0][..],
        &[0xD1, 0],
        &[0x25, 9, 1, 2, 3, 4, 5, 6, 7, 8, 9],
        &[0x73, 0, 0xC3, 0x28],
        &[0x72, 4, 0x41],
        &[0x82, 3],
    ] {
        assert!(Reader::new(bad).app_value().is_err(), "{bad:02x?}");
    }
    // unbalanced closing tags inside a constructed value
    let mut r = Reader::new(&[0x2E, 0x21, 0x01, 0x4F]);
    r.opening(2).unwrap();
    assert_eq!(r.enclosed(2), Err(WireError::Unbalanced));
    // the writer refuses to overflow
    let mut small = [0u8; 3];
    let mut w = Writer::new(&mut small);
    assert_eq!(w.real(1.0), Err(WireError::Overflow));
}
