//! The PICS (protocol implementation conformance statement) as Markdown, generated from the
//! object table ([`super::objects::TABLE`]) and the property lists the server uses;
//! docs/bacnet.md holds it and a test keeps the two identical (`luxnode bacnet pics`).

use std::fmt::Write as _;

use super::consts::{MAX_APDU, PROTOCOL_REVISION, property as p};
use super::objects::{
    ACTIVE_TEXT, ANALOG_PROPERTIES, BINARY_PROPERTIES, DEVICE_PROPERTIES, INACTIVE_TEXT,
    OPTIONAL_PROPERTIES, TABLE, VENDOR_NAME, property_name,
};

fn type_name(t: u16) -> &'static str {
    match t {
        0 => "Analog Input",
        2 => "Analog Value",
        3 => "Binary Input",
        8 => "Device",
        _ => "?",
    }
}

fn datatype(id: u32) -> &'static str {
    match id {
        p::OBJECT_IDENTIFIER => "BACnetObjectIdentifier",
        p::OBJECT_NAME | p::DESCRIPTION | p::VENDOR_NAME | p::MODEL_NAME => "CharacterString",
        p::FIRMWARE_REVISION | p::APPLICATION_SOFTWARE_VERSION | p::LOCATION => "CharacterString",
        p::OBJECT_TYPE | p::EVENT_STATE | p::RELIABILITY | p::UNITS | p::SYSTEM_STATUS => {
            "Enumerated"
        }
        p::SEGMENTATION_SUPPORTED => "Enumerated",
        p::PRESENT_VALUE | p::COV_INCREMENT => "REAL",
        p::STATUS_FLAGS | p::PROTOCOL_SERVICES_SUPPORTED | p::PROTOCOL_OBJECT_TYPES_SUPPORTED => {
            "BIT STRING"
        }
        p::OUT_OF_SERVICE => "BOOLEAN",
        p::POLARITY => "Enumerated",
        p::ACTIVE_TEXT | p::INACTIVE_TEXT => "CharacterString",
        p::OBJECT_LIST => "BACnetARRAY of BACnetObjectIdentifier",
        p::PROPERTY_LIST => "BACnetARRAY of BACnetPropertyIdentifier",
        p::DEVICE_ADDRESS_BINDING => "List of BACnetAddressBinding (always empty)",
        _ => "Unsigned",
    }
}

fn property_table(s: &mut String, props: &[u32], writable: &dyn Fn(u32) -> &'static str) {
    property_table_typed(s, props, writable, &datatype);
}

fn property_table_typed(
    s: &mut String,
    props: &[u32],
    writable: &dyn Fn(u32) -> &'static str,
    datatype: &dyn Fn(u32) -> &'static str,
) {
    let _ = writeln!(s, "| property | id | datatype | required | writable |");
    let _ = writeln!(s, "|---|---:|---|---|---|");
    for &x in props {
        let required = if OPTIONAL_PROPERTIES.contains(&x) {
            "optional"
        } else {
            "required"
        };
        let _ = writeln!(
            s,
            "| {} | {x} | {} | {required} | {} |",
            property_name(x),
            datatype(x),
            writable(x)
        );
    }
}

const BIBBS: &[(&str, &str, &str)] = &[
    (
        "DS-RP-B",
        "yes",
        "ReadProperty of every property of every object; arrays by index",
    ),
    (
        "DS-RPM-B",
        "yes",
        "ReadPropertyMultiple, including ALL, REQUIRED and OPTIONAL; errors per property",
    ),
    (
        "DS-WP-B",
        "yes",
        "WriteProperty of the writable properties below, from sources in the write allowlist only; the priority is accepted and ignored (no object is commandable)",
    ),
    (
        "DS-COV-B",
        "yes, partly",
        "SubscribeCOV, confirmed and unconfirmed, lifetimes (0 = indefinite, at most 86 400 s), up to 256 subscriptions (128 per IP address), an initial notification, Present_Value and Status_Flags notified within 100 ms of a change by COV_Increment or of a flag; a confirmed notification unacknowledged for APDU_Timeout (3 s) is sent again, at most 3 times (Number_Of_APDU_Retries); subscriptions do not survive a restart",
    ),
    (
        "DM-DDB-B",
        "yes, partly",
        "Who-Is (with or without a range; local, global or directed) answered with I-Am, unicast to the requester; an I-Am broadcast at start (to 255.255.255.255 on the node's port; not tested: the tests run on loopback, which cannot broadcast) and, as a foreign device, through the BBMD once registered (tested)",
    ),
    (
        "DM-DOB-B",
        "yes",
        "Who-Has by object identifier or by Object_Name (UTF-8, exact), with or without a device instance range (local, global or directed), answered with I-Have when the node has the object, unicast to the requester like I-Am (not broadcast, the standard's usual form: the tests run on loopback, which cannot broadcast, and bacpypes3, the test peer, answers Who-Has unicast itself); an object the node does not have, or a Who-Has that does not parse: no answer; no I-Have while DeviceCommunicationControl disables initiation",
    ),
    (
        "DM-DCC-B",
        "only when configured",
        "DeviceCommunicationControl is refused (services / service-request-denied) unless the board sets `[bacnet] dcc_password` and the source is in the write allowlist; then enable, disable and disable-initiation with a duration",
    ),
];

const NOT_SUPPORTED: &[&str] = &[
    "segmentation (either way): a request in segments, or an answer longer than the requester accepts or than 1476 octets, is aborted with segmentation-not-supported; read a long Object_List by index",
    "Priority_Array and Relinquish_Default: no object is commandable",
    "alarms and events, trends, schedules, time synchronization, ReinitializeDevice, ReadRange, WritePropertyMultiple, file services (rejected: unrecognized-service, or not answered when unconfirmed)",
    "COV subscriptions to the Device object (error: optional-functionality-not-supported)",
    "BBMD functions: the node is not a BBMD (BVLC-Result NAK); it can register as a foreign device (`[bacnet] bbmd`, renewed at half the time-to-live, retried 1 s doubling to 60 s; while the BBMD does not answer or refuses, the Device's Reliability is communication-failure (12) and Modbus status bit 9 is set, and local service goes on; tested)",
    "routing, BACnet/IPv6, MS/TP, BACnet/SC",
    "a Vendor_Identifier: none is assigned to luxnode; 65535 is reported until the board sets `vendor_id`",
];

/// The PICS as Markdown.
pub fn markdown() -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# luxnode BACnet/IP: protocol implementation conformance statement\n"
    );
    let _ = writeln!(
        s,
        "Generated by `luxnode bacnet pics` from the object table the server uses\n\
         (`src/bacnet/objects.rs`); a test keeps this file identical to it.\n"
    );
    let _ = writeln!(s, "| | |\n|---|---|");
    let _ = writeln!(s, "| vendor name | {VENDOR_NAME} |");
    let _ = writeln!(
        s,
        "| product | luxnode ceiling lighting node, firmware {} |",
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(s, "| protocol revision claimed | {PROTOCOL_REVISION} |");
    let _ = writeln!(
        s,
        "| device profile aimed at | B-ASC (application specific controller); see the BIBBs for what holds |"
    );
    let _ = writeln!(
        s,
        "| data link | BACnet/IP (Annex J), UDP, default port 47808; foreign device |"
    );
    let _ = writeln!(s, "| max APDU length accepted | {MAX_APDU} |");
    let _ = writeln!(s, "| segmentation | none |");
    let _ = writeln!(s, "| character set | UTF-8 (ISO 10646, code 0) |");
    let _ = writeln!(s, "| static device address binding | no |\n");
    let _ = writeln!(s, "## BIBBs\n\n| BIBB | supported | notes |\n|---|---|---|");
    for (b, yes, note) in BIBBS {
        let _ = writeln!(s, "| {b} | {yes} | {note} |");
    }
    let _ = writeln!(s, "\n## Objects\n");
    let _ = writeln!(
        s,
        "k = desk index, j = luminaire index, both from 0 in the image's order (as in the Modbus\n\
         map); `{{point}}` is the measuring point's name, the same in the report and the points\n\
         list (`desk 1 (S2)`: sensor 2 on desk 1; `floor S8`; `S9`: on neither; `luxnode points`),\n\
         `{{id}}` the luminaire's id. No object can be created or deleted.\n"
    );
    let _ = writeln!(
        s,
        "| object type | instances | Object_Name | units | Present_Value | writable |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for c in TABLE {
        let inst = match c.kind {
            super::objects::Kind::Device => "1 (configurable)".to_string(),
            super::objects::Kind::LuminaireLevel => format!("{} + j", c.base),
            _ => format!("{} + k", c.base),
        };
        let units = match c.units {
            Some(37) => "luxes (37)",
            Some(98) => "percent (98)",
            _ => "",
        };
        let w = if c.writable {
            "Present_Value, COV_Increment"
        } else if c.units.is_some() {
            "COV_Increment"
        } else {
            "no"
        };
        let _ = writeln!(
            s,
            "| {} | {inst} | {} | {units} | {} | {w} |",
            type_name(c.object_type),
            c.name,
            c.meaning
        );
    }
    let _ = writeln!(
        s,
        "\nReliability and Status_Flags: a value the node does not have (NaN in the Modbus map)\n\
         is NaN with Reliability unreliable-other (7) and the fault flag; a stale value (the dimming\n\
         state is not known to be current, Modbus quality 1, or live light's stale flag) keeps its\n\
         last number (NaN while the dimming state was never known since the start, as on Modbus: never 0)\n\
         with Reliability communication-failure (12) and the fault flag; a held or not\n\
         estimated live value is unreliable-other. Event_State is always normal, Out_Of_Service\n\
         always false. COV_Increment defaults to 1 % of the desk's target for lux objects and to 1\n\
         for the Analog Values; a written one holds until the node restarts.\n"
    );
    let _ = writeln!(
        s,
        "Occupancy (Binary Input k, docs/occupancy.md): Present_Value active (\"{ACTIVE_TEXT}\") while a\n\
         person is at desk k or was seen there within the hold time, inactive (\"{INACTIVE_TEXT}\")\n\
         after the hold where the node sees the desk's zone. An unknown occupancy is never a plain\n\
         inactive: it is inactive with the fault flag and Reliability communication-failure (12)\n\
         when no usable depth frame came for longer than live light's stale limit, unreliable-other\n\
         (7) after a bad depth frame (missing, wrong size, no returns, saturated, the camera moved),\n\
         no-sensor (1) where the node does not see the desk's zone (or the sensor is on no desk).\n\
         The Binary Inputs exist only on a node with occupancy (a depth camera and an image with\n\
         desks); COV notifications on any change of Present_Value or Status_Flags.\n"
    );
    let _ = writeln!(s, "### Device\n");
    property_table(&mut s, DEVICE_PROPERTIES, &|_| "no");
    let _ = writeln!(s, "\n### Analog Input, Analog Value\n");
    property_table(&mut s, ANALOG_PROPERTIES, &|x| match x {
        p::PRESENT_VALUE => "Analog Value only",
        p::COV_INCREMENT => "yes",
        _ => "no",
    });
    let _ = writeln!(s, "\n### Binary Input\n");
    property_table_typed(&mut s, BINARY_PROPERTIES, &|_| "no", &|x| match x {
        p::PRESENT_VALUE => "BACnetBinaryPV",
        _ => datatype(x),
    });
    let _ = writeln!(
        s,
        "\n## Services\n\n| service | executed | initiated |\n|---|---|---|"
    );
    for (name, ex, init) in [
        ("Who-Is", "yes", "no"),
        ("I-Am", "no", "yes (answer to Who-Is; at start)"),
        ("Who-Has", "yes", "no"),
        ("I-Have", "no", "yes (answer to Who-Has)"),
        ("ReadProperty", "yes", "no"),
        ("ReadPropertyMultiple", "yes", "no"),
        ("WriteProperty", "yes", "no"),
        ("SubscribeCOV", "yes", "no"),
        ("ConfirmedCOVNotification", "no", "yes"),
        ("UnconfirmedCOVNotification", "no", "yes"),
        ("DeviceCommunicationControl", "when configured", "no"),
    ] {
        let _ = writeln!(s, "| {name} | {ex} | {init} |");
    }
    let _ = writeln!(
        s,
        "\nErrors: unknown object (object, unknown-object), unknown property (property,\n\
         unknown-property), a write to a read-only property or from a source outside the write\n\
         allowlist (property, write-access-denied), a value of the wrong type (property,\n\
         invalid-data-type) or out of range (property, value-out-of-range), an index into a\n\
         non-array (property, property-is-not-an-array) or past its end (property,\n\
         invalid-array-index), a full subscription table (resources, cov-subscription-failed).\n\
         A request that does not parse is rejected with the reason (invalid-tag,\n\
         missing-required-parameter, invalid-parameter-data-type, parameter-out-of-range,\n\
         too-many-arguments); a service not executed: reject unrecognized-service.\n"
    );
    let _ = writeln!(s, "## Not supported\n");
    for n in NOT_SUPPORTED {
        let _ = writeln!(s, "* {n}");
    }
    s
}
