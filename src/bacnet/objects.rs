//! The node's BACnet objects, read from its register snapshot: one table ([`TABLE`]) says
//! which objects exist, their instance numbers, names, units and properties; docs/bacnet.md is
//! generated from it ([`crate::bacnet::pics::markdown`]).
//!
//! Instance numbers follow the desks' and luminaires' order in the image (k = desk index,
//! j = luminaire index, both from 0), like the Modbus blocks:
//!
//! | object | instance | Present_Value |
//! |---|---|---|
//! | Analog Input | k | desk total, lx |
//! | Analog Input | 100 + k | desk daylight, lx |
//! | Analog Input | 200 + k | desk artificial light, lx |
//! | Analog Input | 300 + k | desk stated standard uncertainty, lx |
//! | Analog Value | j | luminaire level, % |
//! | Analog Value | 1000 + k | desk target, lx |
//! | Binary Input | k | desk occupied (active) or vacant (inactive), when the node has occupancy |
//!
//! A value the node does not have (NaN in the map) is published as NaN with Reliability
//! `unreliable-other` and the fault flag; a value that is stale (the dimming state is not known
//! to be current) keeps its last number with Reliability `communication-failure` and the fault
//! flag. An unknown occupancy is inactive with a Reliability other than no-fault-detected
//! (`communication-failure` when the depth is stale, `unreliable-other` after a bad depth frame,
//! `no-sensor` where the node does not see the desk's zone) and the fault flag. Nothing unknown
//! is ever published as good.

use std::collections::HashMap;

use super::consts::{object_type as ot, property as p, reliability, units};
use super::wire::ObjectId;
use crate::modbus::regmap::{Occupancy, Quality, RegisterMap, addr, live_flags, occupancy_status};

/// What kind of object, and the desk or luminaire index it serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The Device object.
    Device,
    /// Desk total illuminance (Analog Input k).
    DeskTotal,
    /// Desk daylight (Analog Input 100 + k).
    DeskDaylight,
    /// Desk artificial light (Analog Input 200 + k).
    DeskArtificial,
    /// Desk stated standard uncertainty (Analog Input 300 + k).
    DeskUncertainty,
    /// Luminaire level (Analog Value j).
    LuminaireLevel,
    /// Desk target (Analog Value 1000 + k).
    DeskTarget,
    /// Desk occupancy (Binary Input k), when the node has occupancy.
    DeskOccupancy,
}

/// One row of the object table.
#[derive(Debug, Clone, Copy)]
pub struct ObjectClass {
    /// Kind.
    pub kind: Kind,
    /// Object type.
    pub object_type: u16,
    /// First instance (index 0).
    pub base: u32,
    /// Engineering units (None for the Device).
    pub units: Option<u32>,
    /// Object_Name pattern (`{point}`: the point's name, [`crate::points`]; `{id}`: the
    /// luminaire's id).
    pub name: &'static str,
    /// What Present_Value is, for the PICS.
    pub meaning: &'static str,
    /// Present_Value writable (from the write allowlist).
    pub writable: bool,
}

/// Every object class the node has.
pub const TABLE: &[ObjectClass] = &[
    ObjectClass {
        kind: Kind::Device,
        object_type: ot::DEVICE,
        base: 0,
        units: None,
        name: "the board's name",
        meaning: "the node; instance from `--bacnet-device-id` or the board's `[bacnet] device_id`",
        writable: false,
    },
    ObjectClass {
        kind: Kind::DeskTotal,
        object_type: ot::ANALOG_INPUT,
        base: 0,
        units: Some(units::LUXES),
        name: "{point} illuminance",
        meaning: "total illuminance on desk k: the live total when live light runs, else the model's value for the dimming state (Modbus input 100 + 2k)",
        writable: false,
    },
    ObjectClass {
        kind: Kind::DeskDaylight,
        object_type: ot::ANALOG_INPUT,
        base: 100,
        units: Some(units::LUXES),
        name: "{point} daylight",
        meaning: "daylight part (live light, else the lighting control's fresh estimate; NaN and unreliable-other when neither has one)",
        writable: false,
    },
    ObjectClass {
        kind: Kind::DeskArtificial,
        object_type: ot::ANALOG_INPUT,
        base: 200,
        units: Some(units::LUXES),
        name: "{point} artificial",
        meaning: "the luminaires' part (live light, else the model's value)",
        writable: false,
    },
    ObjectClass {
        kind: Kind::DeskUncertainty,
        object_type: ot::ANALOG_INPUT,
        base: 300,
        units: Some(units::LUXES),
        name: "{point} uncertainty",
        meaning: "stated standard uncertainty of the total (live light, else the image's relative uncertainty × the value; NaN and unreliable-other when not stated)",
        writable: false,
    },
    ObjectClass {
        kind: Kind::LuminaireLevel,
        object_type: ot::ANALOG_VALUE,
        base: 0,
        units: Some(units::PERCENT),
        name: "luminaire {id} level",
        meaning: "luminaire j's level, 0..=100 % of full output (writes set it like Modbus holding 1000 + j)",
        writable: true,
    },
    ObjectClass {
        kind: Kind::DeskTarget,
        object_type: ot::ANALOG_VALUE,
        base: 1000,
        units: Some(units::LUXES),
        name: "{point} target",
        meaning: "desk k's lighting-control target, 0..=10000 lx, whole lux (Modbus holding 2100 + k; persisted)",
        writable: true,
    },
    ObjectClass {
        kind: Kind::DeskOccupancy,
        object_type: ot::BINARY_INPUT,
        base: 0,
        units: None,
        name: "{point} occupancy",
        meaning: "desk k occupied (active, \"Occupied\") or vacant (inactive, \"Vacant\") after the hold time; unknown: inactive with the fault flag (Modbus input 4600 + k); only when the node has occupancy (a depth camera and an image with desks)",
        writable: false,
    },
];

/// The Binary Input properties (ReadPropertyMultiple ALL order).
pub const BINARY_PROPERTIES: &[u32] = &[
    p::OBJECT_IDENTIFIER,
    p::OBJECT_NAME,
    p::OBJECT_TYPE,
    p::PRESENT_VALUE,
    p::DESCRIPTION,
    p::STATUS_FLAGS,
    p::EVENT_STATE,
    p::RELIABILITY,
    p::OUT_OF_SERVICE,
    p::POLARITY,
    p::INACTIVE_TEXT,
    p::ACTIVE_TEXT,
    p::PROPERTY_LIST,
];

/// Active_Text of the occupancy Binary Inputs.
pub const ACTIVE_TEXT: &str = "Occupied";
/// Inactive_Text of the occupancy Binary Inputs.
pub const INACTIVE_TEXT: &str = "Vacant";

/// The Analog Input and Analog Value properties (ReadPropertyMultiple ALL order).
pub const ANALOG_PROPERTIES: &[u32] = &[
    p::OBJECT_IDENTIFIER,
    p::OBJECT_NAME,
    p::OBJECT_TYPE,
    p::PRESENT_VALUE,
    p::DESCRIPTION,
    p::STATUS_FLAGS,
    p::EVENT_STATE,
    p::RELIABILITY,
    p::OUT_OF_SERVICE,
    p::UNITS,
    p::COV_INCREMENT,
    p::PROPERTY_LIST,
];

/// The Device object's properties.
pub const DEVICE_PROPERTIES: &[u32] = &[
    p::OBJECT_IDENTIFIER,
    p::OBJECT_NAME,
    p::OBJECT_TYPE,
    p::SYSTEM_STATUS,
    p::RELIABILITY,
    p::VENDOR_NAME,
    p::VENDOR_IDENTIFIER,
    p::MODEL_NAME,
    p::FIRMWARE_REVISION,
    p::APPLICATION_SOFTWARE_VERSION,
    p::LOCATION,
    p::DESCRIPTION,
    p::PROTOCOL_VERSION,
    p::PROTOCOL_REVISION,
    p::PROTOCOL_SERVICES_SUPPORTED,
    p::PROTOCOL_OBJECT_TYPES_SUPPORTED,
    p::OBJECT_LIST,
    p::MAX_APDU_LENGTH_ACCEPTED,
    p::SEGMENTATION_SUPPORTED,
    p::APDU_TIMEOUT,
    p::NUMBER_OF_APDU_RETRIES,
    p::DEVICE_ADDRESS_BINDING,
    p::DATABASE_REVISION,
    p::PROPERTY_LIST,
];

/// Properties that are optional in the standard (the rest of each list is required).
pub const OPTIONAL_PROPERTIES: &[u32] = &[
    p::DESCRIPTION,
    p::RELIABILITY,
    p::COV_INCREMENT,
    p::LOCATION,
    p::ACTIVE_TEXT,
    p::INACTIVE_TEXT,
];

/// A property's name, for the PICS.
pub fn property_name(id: u32) -> &'static str {
    match id {
        p::OBJECT_IDENTIFIER => "Object_Identifier",
        p::OBJECT_NAME => "Object_Name",
        p::OBJECT_TYPE => "Object_Type",
        p::PRESENT_VALUE => "Present_Value",
        p::DESCRIPTION => "Description",
        p::STATUS_FLAGS => "Status_Flags",
        p::EVENT_STATE => "Event_State",
        p::RELIABILITY => "Reliability",
        p::OUT_OF_SERVICE => "Out_Of_Service",
        p::UNITS => "Units",
        p::COV_INCREMENT => "COV_Increment",
        p::PROPERTY_LIST => "Property_List",
        p::SYSTEM_STATUS => "System_Status",
        p::VENDOR_NAME => "Vendor_Name",
        p::VENDOR_IDENTIFIER => "Vendor_Identifier",
        p::MODEL_NAME => "Model_Name",
        p::FIRMWARE_REVISION => "Firmware_Revision",
        p::APPLICATION_SOFTWARE_VERSION => "Application_Software_Version",
        p::LOCATION => "Location",
        p::PROTOCOL_VERSION => "Protocol_Version",
        p::PROTOCOL_REVISION => "Protocol_Revision",
        p::PROTOCOL_SERVICES_SUPPORTED => "Protocol_Services_Supported",
        p::PROTOCOL_OBJECT_TYPES_SUPPORTED => "Protocol_Object_Types_Supported",
        p::OBJECT_LIST => "Object_List",
        p::MAX_APDU_LENGTH_ACCEPTED => "Max_APDU_Length_Accepted",
        p::SEGMENTATION_SUPPORTED => "Segmentation_Supported",
        p::APDU_TIMEOUT => "APDU_Timeout",
        p::NUMBER_OF_APDU_RETRIES => "Number_Of_APDU_Retries",
        p::DEVICE_ADDRESS_BINDING => "Device_Address_Binding",
        p::DATABASE_REVISION => "Database_Revision",
        p::POLARITY => "Polarity",
        p::ACTIVE_TEXT => "Active_Text",
        p::INACTIVE_TEXT => "Inactive_Text",
        _ => "?",
    }
}

/// The Device object's identification (the board and the build), and its Reliability.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Device instance (0..=4_194_302).
    pub instance: u32,
    /// Object_Name (unique on the internetwork: the board name and the instance by default).
    pub name: String,
    /// Vendor_Identifier (ASHRAE-assigned; the node has none: set it in the board file).
    pub vendor_id: u16,
    /// Model_Name.
    pub model: String,
    /// Location.
    pub location: String,
    /// Description (the register-map version is appended).
    pub description: String,
    /// Reliability: no-fault-detected, or communication-failure while the board's BBMD does
    /// not accept the foreign-device registration (the server sets it).
    pub reliability: u32,
}

/// The vendor name the node reports.
pub const VENDOR_NAME: &str = "luxnode";
/// The default Vendor_Identifier: 0xFFFF, which ASHRAE never assigns, until the product has one.
pub const DEFAULT_VENDOR_ID: u16 = 0xFFFF;

impl DeviceInfo {
    /// A device `instance` named after `model`.
    pub fn new(instance: u32, model: &str) -> Self {
        Self {
            instance,
            name: format!("{model} {instance}"),
            vendor_id: DEFAULT_VENDOR_ID,
            model: model.to_owned(),
            location: String::new(),
            description: "luxnode ceiling lighting node".to_owned(),
            reliability: reliability::NO_FAULT_DETECTED,
        }
    }

    /// The Device object's identifier.
    pub fn id(&self) -> ObjectId {
        ObjectId::new(ot::DEVICE, self.instance)
    }
}

/// One analog reading: the value and its reliability.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Present_Value (NaN: not available).
    pub value: f64,
    /// Reliability ([`reliability`]).
    pub reliability: u32,
}

impl Reading {
    /// Status_Flags: in-alarm, fault, overridden, out-of-service.
    pub fn status_flags(&self) -> [bool; 4] {
        [
            false,
            self.reliability != reliability::NO_FAULT_DETECTED,
            false,
            false,
        ]
    }
}

/// What the objects are read from: the node's snapshot and the server's own settings.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The register snapshot.
    pub map: &'a RegisterMap,
    /// Luminaire levels in [0, 1].
    pub levels: &'a [f64],
    /// The control loop's fresh daylight estimate per desk, lx.
    pub daylight: Option<&'a [f64]>,
    /// The device.
    pub device: &'a DeviceInfo,
    /// COV_Increment written by clients, by object.
    pub cov_increments: &'a HashMap<ObjectId, f64>,
    /// Each desk's point name ([`crate::points`]; `S<id>` where missing).
    pub points: &'a [String],
}

impl View<'_> {
    /// The object `id`: its class and index, if the node has it (the device also answers to
    /// the wildcard instance 4194303).
    pub fn resolve(&self, id: ObjectId) -> Option<(&'static ObjectClass, usize)> {
        if id.object_type == ot::DEVICE {
            let ok = id.instance == self.device.instance || id.instance == ObjectId::MAX_INSTANCE;
            return ok.then_some((&TABLE[0], 0));
        }
        TABLE[1..].iter().find_map(|c| {
            let n = self.count(c.kind);
            let k = id.instance.checked_sub(c.base)? as usize;
            (c.object_type == id.object_type && k < n).then_some((c, k))
        })
    }

    /// How many objects of a kind the node has: per luminaire, or per desk (the occupancy
    /// Binary Inputs only while the node has occupancy).
    pub fn count(&self, kind: Kind) -> usize {
        match kind {
            Kind::Device => 1,
            Kind::LuminaireLevel => self.levels.len(),
            Kind::DeskOccupancy if self.map.occupancy.status & occupancy_status::ON == 0 => 0,
            _ => self.map.desks.len(),
        }
    }

    /// Every object, Device first.
    pub fn object_list(&self) -> Vec<ObjectId> {
        let mut v = vec![self.device.id()];
        for c in &TABLE[1..] {
            let n = self.count(c.kind);
            v.extend((0..n as u32).map(|k| ObjectId::new(c.object_type, c.base + k)));
        }
        v
    }

    /// The desk's or luminaire's id behind an object.
    pub fn owner_id(&self, kind: Kind, index: usize) -> u32 {
        match kind {
            Kind::Device => self.device.instance,
            Kind::LuminaireLevel => self.map.luminaire_ids.get(index).copied().unwrap_or(0),
            _ => self.map.desks.get(index).map_or(0, |d| d.id),
        }
    }

    /// Object_Name.
    pub fn name(&self, class: &ObjectClass, index: usize) -> String {
        match class.kind {
            Kind::Device => self.device.name.clone(),
            _ => {
                let id = self.owner_id(class.kind, index);
                let point = match self.points.get(index) {
                    Some(p) if class.kind != Kind::LuminaireLevel => p.clone(),
                    _ => format!("S{id}"),
                };
                object_name(class.name, &point, id)
            }
        }
    }

    /// The reading of an analog object.
    pub fn reading(&self, kind: Kind, k: usize) -> Reading {
        let map = self.map;
        let live = map.live.desks.get(k);
        let desk = map.desks.get(k);
        let model_lx = desk.map_or(f64::NAN, |d| d.lux);
        let value = match kind {
            Kind::Device => f64::NAN,
            Kind::DeskTotal => live.map_or(model_lx, |l| l.total_lx),
            Kind::DeskArtificial => live.map_or(model_lx, |l| l.artificial_lx),
            Kind::DeskDaylight => live.map_or_else(
                || {
                    self.daylight
                        .and_then(|d| d.get(k).copied())
                        .unwrap_or(f64::NAN)
                },
                |l| l.daylight_lx,
            ),
            Kind::DeskUncertainty => live.map_or_else(
                || desk.map_or(f64::NAN, |d| d.model_rel_uncertainty * d.lux),
                |l| l.uncertainty_lx,
            ),
            Kind::LuminaireLevel => {
                return Reading {
                    value: 100.0 * self.levels.get(k).copied().unwrap_or(f64::NAN),
                    reliability: if self.levels.get(k).is_some_and(|x| x.is_finite()) {
                        reliability::NO_FAULT_DETECTED
                    } else {
                        reliability::UNRELIABLE_OTHER
                    },
                };
            }
            Kind::DeskTarget => {
                let t = map
                    .control
                    .targets_lx
                    .get(k)
                    .map_or(f64::NAN, |&t| f64::from(t));
                return Reading {
                    value: t,
                    reliability: reliability::NO_FAULT_DETECTED,
                };
            }
            Kind::DeskOccupancy => return self.occupancy(k),
        };
        let desk_stale = desk.is_some_and(|d| d.quality == Quality::Stale);
        let stale = desk_stale || live.is_some_and(|l| l.flags & live_flags::STALE != 0);
        let held =
            live.is_some_and(|l| l.flags & (live_flags::HELD | live_flags::NOT_ESTIMATED) != 0);
        // a stale desk's NaN (the dimming state never known since start) is the link's fault,
        // as Modbus quality 1 says: communication-failure, like its stale numbers
        let reliability = if (!value.is_finite() && !desk_stale) || held {
            reliability::UNRELIABLE_OTHER
        } else if stale {
            reliability::COMMUNICATION_FAILURE
        } else {
            reliability::NO_FAULT_DETECTED
        };
        Reading { value, reliability }
    }

    /// An occupancy Binary Input's reading: 1 active (occupied), 0 inactive (vacant, or
    /// unknown with a fault Reliability: stale depth, a bad depth frame, the zone not seen).
    fn occupancy(&self, k: usize) -> Reading {
        let occ = &self.map.occupancy;
        let state =
            u16::try_from(k).map_or(Occupancy::Unknown, |k| self.map.occupancy_desk(k).state);
        let frame_fault = occupancy_status::BAD_FRAME
            | occupancy_status::NO_RETURN
            | occupancy_status::SATURATED
            | occupancy_status::MOVED;
        let (value, reliability) = match state {
            Occupancy::Occupied => (1.0, reliability::NO_FAULT_DETECTED),
            Occupancy::Vacant => (0.0, reliability::NO_FAULT_DETECTED),
            Occupancy::Unknown if occ.status & occupancy_status::STALE != 0 => {
                (0.0, reliability::COMMUNICATION_FAILURE)
            }
            Occupancy::Unknown if occ.status & frame_fault != 0 => {
                (0.0, reliability::UNRELIABLE_OTHER)
            }
            Occupancy::Unknown => (0.0, reliability::NO_SENSOR),
        };
        Reading { value, reliability }
    }

    /// COV_Increment: what a client wrote, else 1 % of the desk's target for lux objects and
    /// 1 % for levels.
    pub fn cov_increment(&self, id: ObjectId, kind: Kind, k: usize) -> f64 {
        if let Some(v) = self.cov_increments.get(&id) {
            return *v;
        }
        match kind {
            Kind::LuminaireLevel | Kind::DeskTarget => 1.0,
            // any change of a binary value
            Kind::DeskOccupancy => 0.5,
            _ => {
                0.01 * self
                    .map
                    .control
                    .targets_lx
                    .get(k)
                    .map_or(0.0, |&t| f64::from(t))
            }
        }
    }

    /// Description of an object (the Device's carries the register-map version).
    pub fn description(&self, class: &ObjectClass, index: usize) -> String {
        match class.kind {
            Kind::Device => format!(
                "{} (Modbus register map version {})",
                self.device.description,
                crate::modbus::regmap::MAP_VERSION
            ),
            Kind::LuminaireLevel => format!(
                "level of luminaire {} (Modbus holding {})",
                self.owner_id(class.kind, index),
                u32::from(addr::ARC_LEVEL) + index as u32
            ),
            _ => format!(
                "{} (sensor {}, Modbus desk index {index})",
                self.name(class, index),
                self.owner_id(class.kind, index)
            ),
        }
    }
}

/// A desk object's Object_Name: its pattern with the point's name (`{point}`) and sensor id
/// (`{id}`).
pub fn object_name(pattern: &str, point: &str, id: u32) -> String {
    pattern
        .replace("{point}", point)
        .replace("{id}", &id.to_string())
}
