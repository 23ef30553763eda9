//! Encoding one property of one object (ReadProperty, ReadPropertyMultiple, COV).

use super::consts::{
    MAX_APDU, NO_SEGMENTATION, PROTOCOL_REVISION, error_class, error_code, object_type as ot,
    property as p, services_supported as ss,
};
use super::objects::{
    ACTIVE_TEXT, ANALOG_PROPERTIES, BINARY_PROPERTIES, DEVICE_PROPERTIES, INACTIVE_TEXT, Kind,
    ObjectClass, VENDOR_NAME, View,
};
use super::wire::{ObjectId, WireError, Writer};

/// Why a property cannot be read (an Error in the reply), or the reply is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PropertyError {
    /// A BACnet error: class and code.
    #[error("error class {class}, code {code}")]
    Bacnet {
        /// Error class.
        class: u32,
        /// Error code.
        code: u32,
    },
    /// The encoding does not fit.
    #[error(transparent)]
    Wire(#[from] WireError),
}

impl PropertyError {
    /// A BACnet error.
    pub const fn bacnet(class: u32, code: u32) -> Self {
        Self::Bacnet { class, code }
    }
}

/// The properties of an object class, ALL order.
pub fn properties(class: &ObjectClass) -> &'static [u32] {
    match class.kind {
        Kind::Device => DEVICE_PROPERTIES,
        Kind::DeskOccupancy => BINARY_PROPERTIES,
        _ => ANALOG_PROPERTIES,
    }
}

/// Property_List: every property but the four the standard leaves out of it.
fn property_list(class: &ObjectClass) -> impl Iterator<Item = u32> {
    properties(class).iter().copied().filter(|&x| {
        !matches!(
            x,
            p::OBJECT_IDENTIFIER | p::OBJECT_NAME | p::OBJECT_TYPE | p::PROPERTY_LIST
        )
    })
}

/// Protocol_Services_Supported.
pub fn services_supported() -> [bool; ss::LEN] {
    let mut bits = [false; ss::LEN];
    for b in [
        ss::CONFIRMED_COV_NOTIFICATION,
        ss::SUBSCRIBE_COV,
        ss::READ_PROPERTY,
        ss::READ_PROPERTY_MULTIPLE,
        ss::WRITE_PROPERTY,
        ss::DEVICE_COMMUNICATION_CONTROL,
        ss::I_AM,
        ss::I_HAVE,
        ss::UNCONFIRMED_COV_NOTIFICATION,
        ss::WHO_HAS,
        ss::WHO_IS,
    ] {
        bits[b] = true;
    }
    bits
}

/// Bits of Protocol_Object_Types_Supported (protocol revision 14: 55 object types).
const OBJECT_TYPES_LEN: usize = 55;

fn array<T: Copy>(
    items: &[T],
    index: Option<u64>,
    w: &mut Writer<'_>,
    mut one: impl FnMut(T, &mut Writer<'_>) -> Result<(), WireError>,
) -> Result<(), PropertyError> {
    match index {
        None => {
            for &x in items {
                one(x, w)?;
            }
            Ok(())
        }
        Some(0) => Ok(w.unsigned(items.len() as u64)?),
        Some(i) => {
            let x = usize::try_from(i - 1)
                .ok()
                .and_then(|k| items.get(k))
                .ok_or(PropertyError::bacnet(
                    error_class::PROPERTY,
                    error_code::INVALID_ARRAY_INDEX,
                ))?;
            Ok(one(*x, w)?)
        }
    }
}

/// Encodes property `prop` (element `index` of an array) of object `id` into `w`.
pub fn encode(
    view: &View<'_>,
    id: ObjectId,
    (class, k): (&ObjectClass, usize),
    prop: u32,
    index: Option<u64>,
    w: &mut Writer<'_>,
) -> Result<(), PropertyError> {
    if !properties(class).contains(&prop) {
        return Err(PropertyError::bacnet(
            error_class::PROPERTY,
            error_code::UNKNOWN_PROPERTY,
        ));
    }
    match prop {
        p::OBJECT_LIST => return array(&view.object_list(), index, w, |o, w| w.object_id(o)),
        p::PROPERTY_LIST => {
            let list: Vec<u32> = property_list(class).collect();
            return array(&list, index, w, |x, w| w.enumerated(x));
        }
        _ if index.is_some() => {
            return Err(PropertyError::bacnet(
                error_class::PROPERTY,
                error_code::PROPERTY_IS_NOT_AN_ARRAY,
            ));
        }
        _ => {}
    }
    // the object's own identifier, even when asked through the device wildcard
    let own = if class.kind == Kind::Device {
        view.device.id()
    } else {
        id
    };
    match prop {
        p::OBJECT_IDENTIFIER => w.object_id(own)?,
        p::OBJECT_NAME => w.char_string(&view.name(class, k))?,
        p::OBJECT_TYPE => w.enumerated(u32::from(class.object_type))?,
        p::DESCRIPTION => w.char_string(&view.description(class, k))?,
        _ if class.kind == Kind::Device => device_property(view, prop, w)?,
        _ if class.kind == Kind::DeskOccupancy => binary_property(view, k, prop, w)?,
        _ => analog_property(view, own, (class, k), prop, w)?,
    }
    Ok(())
}

fn analog_property(
    view: &View<'_>,
    id: ObjectId,
    (class, k): (&ObjectClass, usize),
    prop: u32,
    w: &mut Writer<'_>,
) -> Result<(), WireError> {
    let reading = view.reading(class.kind, k);
    match prop {
        p::PRESENT_VALUE => w.real(reading.value as f32),
        p::STATUS_FLAGS => w.bit_string(&reading.status_flags()),
        p::EVENT_STATE => w.enumerated(0),
        p::RELIABILITY => w.enumerated(reading.reliability),
        p::OUT_OF_SERVICE => w.boolean(false),
        p::UNITS => w.enumerated(class.units.unwrap_or(95)),
        p::COV_INCREMENT => w.real(view.cov_increment(id, class.kind, k) as f32),
        _ => Err(WireError::UnexpectedTag),
    }
}

/// A property of an occupancy Binary Input: Present_Value inactive (0) or active (1),
/// Polarity normal.
fn binary_property(
    view: &View<'_>,
    k: usize,
    prop: u32,
    w: &mut Writer<'_>,
) -> Result<(), WireError> {
    let reading = view.reading(Kind::DeskOccupancy, k);
    match prop {
        p::PRESENT_VALUE => w.enumerated(u32::from(reading.value > 0.5)),
        p::STATUS_FLAGS => w.bit_string(&reading.status_flags()),
        p::EVENT_STATE => w.enumerated(0),
        p::RELIABILITY => w.enumerated(reading.reliability),
        p::OUT_OF_SERVICE => w.boolean(false),
        p::POLARITY => w.enumerated(0),
        p::INACTIVE_TEXT => w.char_string(INACTIVE_TEXT),
        p::ACTIVE_TEXT => w.char_string(ACTIVE_TEXT),
        _ => Err(WireError::UnexpectedTag),
    }
}

fn device_property(view: &View<'_>, prop: u32, w: &mut Writer<'_>) -> Result<(), WireError> {
    let d = view.device;
    match prop {
        p::SYSTEM_STATUS => w.enumerated(0),
        p::RELIABILITY => w.enumerated(d.reliability),
        p::VENDOR_NAME => w.char_string(VENDOR_NAME),
        p::VENDOR_IDENTIFIER => w.unsigned(u64::from(d.vendor_id)),
        p::MODEL_NAME => w.char_string(&d.model),
        p::FIRMWARE_REVISION => w.char_string(env!("CARGO_PKG_VERSION")),
        p::APPLICATION_SOFTWARE_VERSION => w.char_string(&format!(
            "{} (image generation {})",
            view.map.identity.application, view.map.generation
        )),
        p::LOCATION => w.char_string(&d.location),
        p::PROTOCOL_VERSION => w.unsigned(1),
        p::PROTOCOL_REVISION => w.unsigned(PROTOCOL_REVISION),
        p::PROTOCOL_SERVICES_SUPPORTED => w.bit_string(&services_supported()),
        p::PROTOCOL_OBJECT_TYPES_SUPPORTED => {
            let mut bits = [false; OBJECT_TYPES_LEN];
            for t in [
                ot::ANALOG_INPUT,
                ot::ANALOG_VALUE,
                ot::BINARY_INPUT,
                ot::DEVICE,
            ] {
                bits[usize::from(t)] = true;
            }
            w.bit_string(&bits)
        }
        p::MAX_APDU_LENGTH_ACCEPTED => w.unsigned(MAX_APDU as u64),
        p::SEGMENTATION_SUPPORTED => w.enumerated(NO_SEGMENTATION),
        p::APDU_TIMEOUT => w.unsigned(3000),
        p::NUMBER_OF_APDU_RETRIES => w.unsigned(3),
        // an empty list: the node binds no device addresses
        p::DEVICE_ADDRESS_BINDING => Ok(()),
        p::DATABASE_REVISION => w.unsigned(u64::from(view.map.generation)),
        _ => Err(WireError::UnexpectedTag),
    }
}
