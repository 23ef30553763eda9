//! The numbers of ASHRAE 135 the node uses (clause 21's enumerations).

/// Object types.
pub mod object_type {
    /// Analog Input.
    pub const ANALOG_INPUT: u16 = 0;
    /// Analog Value.
    pub const ANALOG_VALUE: u16 = 2;
    /// Binary Input.
    pub const BINARY_INPUT: u16 = 3;
    /// Device.
    pub const DEVICE: u16 = 8;
}

/// Property identifiers.
pub mod property {
    /// Active_Text.
    pub const ACTIVE_TEXT: u32 = 4;
    /// Inactive_Text.
    pub const INACTIVE_TEXT: u32 = 46;
    /// Polarity.
    pub const POLARITY: u32 = 84;
    /// All (ReadPropertyMultiple).
    pub const ALL: u32 = 8;
    /// APDU_Timeout.
    pub const APDU_TIMEOUT: u32 = 11;
    /// Application_Software_Version.
    pub const APPLICATION_SOFTWARE_VERSION: u32 = 12;
    /// COV_Increment.
    pub const COV_INCREMENT: u32 = 22;
    /// Description.
    pub const DESCRIPTION: u32 = 28;
    /// Device_Address_Binding.
    pub const DEVICE_ADDRESS_BINDING: u32 = 30;
    /// Event_State.
    pub const EVENT_STATE: u32 = 36;
    /// Firmware_Revision.
    pub const FIRMWARE_REVISION: u32 = 44;
    /// Location.
    pub const LOCATION: u32 = 58;
    /// Max_APDU_Length_Accepted.
    pub const MAX_APDU_LENGTH_ACCEPTED: u32 = 62;
    /// Model_Name.
    pub const MODEL_NAME: u32 = 70;
    /// Number_Of_APDU_Retries.
    pub const NUMBER_OF_APDU_RETRIES: u32 = 73;
    /// Object_Identifier.
    pub const OBJECT_IDENTIFIER: u32 = 75;
    /// Object_List.
    pub const OBJECT_LIST: u32 = 76;
    /// Object_Name.
    pub const OBJECT_NAME: u32 = 77;
    /// Object_Type.
    pub const OBJECT_TYPE: u32 = 79;
    /// Optional (ReadPropertyMultiple).
    pub const OPTIONAL: u32 = 80;
    /// Out_Of_Service.
    pub const OUT_OF_SERVICE: u32 = 81;
    /// Present_Value.
    pub const PRESENT_VALUE: u32 = 85;
    /// Protocol_Object_Types_Supported.
    pub const PROTOCOL_OBJECT_TYPES_SUPPORTED: u32 = 96;
    /// Protocol_Services_Supported.
    pub const PROTOCOL_SERVICES_SUPPORTED: u32 = 97;
    /// Protocol_Version.
    pub const PROTOCOL_VERSION: u32 = 98;
    /// Reliability.
    pub const RELIABILITY: u32 = 103;
    /// Required (ReadPropertyMultiple).
    pub const REQUIRED: u32 = 105;
    /// Segmentation_Supported.
    pub const SEGMENTATION_SUPPORTED: u32 = 107;
    /// Status_Flags.
    pub const STATUS_FLAGS: u32 = 111;
    /// System_Status.
    pub const SYSTEM_STATUS: u32 = 112;
    /// Units.
    pub const UNITS: u32 = 117;
    /// Vendor_Identifier.
    pub const VENDOR_IDENTIFIER: u32 = 120;
    /// Vendor_Name.
    pub const VENDOR_NAME: u32 = 121;
    /// Protocol_Revision.
    pub const PROTOCOL_REVISION: u32 = 139;
    /// Database_Revision.
    pub const DATABASE_REVISION: u32 = 155;
    /// Property_List.
    pub const PROPERTY_LIST: u32 = 371;
}

/// Confirmed services.
pub mod confirmed {
    /// ConfirmedCOVNotification.
    pub const COV_NOTIFICATION: u8 = 1;
    /// SubscribeCOV.
    pub const SUBSCRIBE_COV: u8 = 5;
    /// ReadProperty.
    pub const READ_PROPERTY: u8 = 12;
    /// ReadPropertyMultiple.
    pub const READ_PROPERTY_MULTIPLE: u8 = 14;
    /// WriteProperty.
    pub const WRITE_PROPERTY: u8 = 15;
    /// DeviceCommunicationControl.
    pub const DEVICE_COMMUNICATION_CONTROL: u8 = 17;
    /// ReinitializeDevice.
    pub const REINITIALIZE_DEVICE: u8 = 20;
}

/// Unconfirmed services.
pub mod unconfirmed {
    /// I-Am.
    pub const I_AM: u8 = 0;
    /// I-Have.
    pub const I_HAVE: u8 = 1;
    /// UnconfirmedCOVNotification.
    pub const COV_NOTIFICATION: u8 = 2;
    /// Who-Has.
    pub const WHO_HAS: u8 = 7;
    /// Who-Is.
    pub const WHO_IS: u8 = 8;
}

/// Bit positions of BACnetServicesSupported (Protocol_Services_Supported).
pub mod services_supported {
    /// confirmedCOVNotification (initiated).
    pub const CONFIRMED_COV_NOTIFICATION: usize = 1;
    /// subscribeCOV.
    pub const SUBSCRIBE_COV: usize = 5;
    /// readProperty.
    pub const READ_PROPERTY: usize = 12;
    /// readPropertyMultiple.
    pub const READ_PROPERTY_MULTIPLE: usize = 14;
    /// writeProperty.
    pub const WRITE_PROPERTY: usize = 15;
    /// deviceCommunicationControl.
    pub const DEVICE_COMMUNICATION_CONTROL: usize = 17;
    /// i-Am (initiated).
    pub const I_AM: usize = 26;
    /// i-Have (initiated).
    pub const I_HAVE: usize = 27;
    /// unconfirmedCOVNotification (initiated).
    pub const UNCONFIRMED_COV_NOTIFICATION: usize = 28;
    /// who-Has.
    pub const WHO_HAS: usize = 33;
    /// who-Is.
    pub const WHO_IS: usize = 34;
    /// Bits in the string (protocol revision 14 and later).
    pub const LEN: usize = 49;
}

/// Error classes.
pub mod error_class {
    /// device.
    pub const DEVICE: u32 = 0;
    /// object.
    pub const OBJECT: u32 = 1;
    /// property.
    pub const PROPERTY: u32 = 2;
    /// resources.
    pub const RESOURCES: u32 = 3;
    /// security.
    pub const SECURITY: u32 = 4;
    /// services.
    pub const SERVICES: u32 = 5;
}

/// Error codes.
pub mod error_code {
    /// other.
    pub const OTHER: u32 = 0;
    /// invalid-data-type.
    pub const INVALID_DATA_TYPE: u32 = 9;
    /// password-failure.
    pub const PASSWORD_FAILURE: u32 = 26;
    /// service-request-denied.
    pub const SERVICE_REQUEST_DENIED: u32 = 29;
    /// unknown-object.
    pub const UNKNOWN_OBJECT: u32 = 31;
    /// unknown-property.
    pub const UNKNOWN_PROPERTY: u32 = 32;
    /// value-out-of-range.
    pub const VALUE_OUT_OF_RANGE: u32 = 37;
    /// write-access-denied.
    pub const WRITE_ACCESS_DENIED: u32 = 40;
    /// invalid-array-index.
    pub const INVALID_ARRAY_INDEX: u32 = 42;
    /// cov-subscription-failed.
    pub const COV_SUBSCRIPTION_FAILED: u32 = 43;
    /// not-cov-property.
    pub const NOT_COV_PROPERTY: u32 = 44;
    /// optional-functionality-not-supported.
    pub const OPTIONAL_FUNCTIONALITY_NOT_SUPPORTED: u32 = 45;
    /// property-is-not-an-array.
    pub const PROPERTY_IS_NOT_AN_ARRAY: u32 = 50;
}

/// Reject reasons.
pub mod reject {
    /// other.
    pub const OTHER: u8 = 0;
    /// buffer-overflow.
    pub const BUFFER_OVERFLOW: u8 = 1;
    /// invalid-parameter-data-type.
    pub const INVALID_PARAMETER_DATA_TYPE: u8 = 3;
    /// invalid-tag.
    pub const INVALID_TAG: u8 = 4;
    /// missing-required-parameter.
    pub const MISSING_REQUIRED_PARAMETER: u8 = 5;
    /// parameter-out-of-range.
    pub const PARAMETER_OUT_OF_RANGE: u8 = 6;
    /// too-many-arguments.
    pub const TOO_MANY_ARGUMENTS: u8 = 7;
    /// unrecognized-service.
    pub const UNRECOGNIZED_SERVICE: u8 = 9;
}

/// Abort reasons.
pub mod abort {
    /// other.
    pub const OTHER: u8 = 0;
    /// buffer-overflow.
    pub const BUFFER_OVERFLOW: u8 = 1;
    /// segmentation-not-supported.
    pub const SEGMENTATION_NOT_SUPPORTED: u8 = 4;
}

/// Engineering units.
pub mod units {
    /// luxes.
    pub const LUXES: u32 = 37;
    /// percent.
    pub const PERCENT: u32 = 98;
}

/// Reliability.
pub mod reliability {
    /// no-fault-detected.
    pub const NO_FAULT_DETECTED: u32 = 0;
    /// no-sensor.
    pub const NO_SENSOR: u32 = 1;
    /// unreliable-other.
    pub const UNRELIABLE_OTHER: u32 = 7;
    /// communication-failure.
    pub const COMMUNICATION_FAILURE: u32 = 12;
}

/// Segmentation_Supported: no-segmentation.
pub const NO_SEGMENTATION: u32 = 3;
/// The largest APDU over BACnet/IP, octets.
pub const MAX_APDU: usize = 1476;
/// The protocol revision the node claims.
pub const PROTOCOL_REVISION: u64 = 14;
