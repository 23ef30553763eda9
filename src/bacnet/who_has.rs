//! Who-Has and I-Have (ASHRAE 135 clauses 16.8 and 16.9; BIBB DM-DOB-B): the service data of
//! both, parse and emit, `no_std`, no allocation, no panic on any input.
//!
//! ```text
//! Who-Has-Request ::= SEQUENCE {
//!     limits SEQUENCE {
//!         deviceInstanceRangeLowLimit  [0] Unsigned (0..4194303),
//!         deviceInstanceRangeHighLimit [1] Unsigned (0..4194303)
//!     } OPTIONAL,
//!     object CHOICE {
//!         objectIdentifier [2] BACnetObjectIdentifier,
//!         objectName       [3] CharacterString
//!     }
//! }
//! I-Have-Request ::= SEQUENCE {
//!     deviceIdentifier BACnetObjectIdentifier,
//!     objectIdentifier BACnetObjectIdentifier,
//!     objectName       CharacterString
//! }
//! ```

use super::wire::{AppValue, ObjectId, Reader, WireError, Writer};

/// The object a Who-Has looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wanted<'a> {
    /// By its identifier.
    Id(ObjectId),
    /// By its Object_Name (UTF-8; another character set does not parse).
    Name(&'a str),
}

/// A Who-Has request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WhoHas<'a> {
    /// Device instance range, low and high limit (both included); `None`: every device.
    pub limits: Option<(u32, u32)>,
    /// The object looked for.
    pub object: Wanted<'a>,
}

/// An instance number of the range limits (22 bits).
fn instance(v: u64) -> Result<u32, WireError> {
    u32::try_from(v)
        .ok()
        .filter(|&x| x <= ObjectId::MAX_INSTANCE)
        .ok_or(WireError::OutOfRange)
}

impl<'a> WhoHas<'a> {
    /// Parses the service data (everything after the service choice).
    pub fn parse(data: &'a [u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(data);
        let limits = if r.peek_tag()?.is_context(0) {
            let low = instance(r.context_unsigned(0)?)?;
            let high = instance(r.context_unsigned(1)?)?;
            Some((low, high))
        } else {
            None
        };
        let tag = r.peek_tag()?;
        let object = if tag.is_context(2) {
            Wanted::Id(r.context_object_id(2)?)
        } else if tag.is_context(3) {
            Wanted::Name(r.context_char_string(3)?)
        } else {
            return Err(WireError::UnexpectedTag);
        };
        if !r.is_empty() {
            return Err(WireError::UnexpectedTag);
        }
        Ok(Self { limits, object })
    }

    /// Writes the service data.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), WireError> {
        if let Some((low, high)) = self.limits {
            w.context_unsigned(0, u64::from(low))?;
            w.context_unsigned(1, u64::from(high))?;
        }
        match self.object {
            Wanted::Id(id) => w.context_object_id(2, id),
            Wanted::Name(n) => w.context_char_string(3, n),
        }
    }

    /// Whether device `instance` is asked (inside the limits, or there are none).
    pub fn asks(&self, instance: u32) -> bool {
        self.limits
            .is_none_or(|(low, high)| (low..=high).contains(&instance))
    }
}

/// An I-Have request: the device that has the object, the object's identifier and name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IHave<'a> {
    /// The device's identifier.
    pub device: ObjectId,
    /// The object's identifier.
    pub object: ObjectId,
    /// The object's Object_Name.
    pub name: &'a str,
}

impl<'a> IHave<'a> {
    /// Parses the service data.
    pub fn parse(data: &'a [u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(data);
        let (AppValue::ObjectId(device), AppValue::ObjectId(object), AppValue::CharString(name)) =
            (r.app_value()?, r.app_value()?, r.app_value()?)
        else {
            return Err(WireError::UnexpectedTag);
        };
        if !r.is_empty() {
            return Err(WireError::UnexpectedTag);
        }
        Ok(Self {
            device,
            object,
            name,
        })
    }

    /// Writes the service data.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), WireError> {
        w.object_id(self.device)?;
        w.object_id(self.object)?;
        w.char_string(self.name)
    }
}

#[cfg(test)]
mod tests {
    //! Expected octets worked out by hand from clause 20.2 (context tags 0..3, the object
    //! identifier's 10/22-bit split, the character string's charset octet), not from this
    //! code.

    use super::*;

    fn emitted(f: impl FnOnce(&mut Writer<'_>) -> Result<(), WireError>) -> Vec<u8> {
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf);
        f(&mut w).expect("fits");
        w.written().to_vec()
    }

    #[test]
    fn who_has_by_name_with_limits_encodes_as_clause_20_2_says() {
        // [0] 4000 = 0x0FA0, [1] 4400 = 0x1130, [3] "AI" (charset 0)
        let want = [0x0A, 0x0F, 0xA0, 0x1A, 0x11, 0x30, 0x3B, 0x00, 0x41, 0x49];
        let q = WhoHas {
            limits: Some((4000, 4400)),
            object: Wanted::Name("AI"),
        };
        assert_eq!(emitted(|w| q.emit(w)), want);
        assert_eq!(WhoHas::parse(&want), Ok(q));
        assert!(q.asks(4000) && q.asks(4400) && !q.asks(3999) && !q.asks(4401));
    }

    #[test]
    fn who_has_by_identifier_without_limits() {
        // [2] (analog-input, 3): 0x00000003
        let want = [0x2C, 0x00, 0x00, 0x00, 0x03];
        let q = WhoHas {
            limits: None,
            object: Wanted::Id(ObjectId::new(0, 3)),
        };
        assert_eq!(emitted(|w| q.emit(w)), want);
        assert_eq!(WhoHas::parse(&want), Ok(q));
        assert!(q.asks(0) && q.asks(ObjectId::MAX_INSTANCE));
    }

    #[test]
    fn malformed_who_has_is_an_error_not_a_panic() {
        let bad: &[&[u8]] = &[
            &[],                                                  // no object
            &[0x09, 0x01],                                        // a low limit alone
            &[0x09, 0x01, 0x19, 0x02],                            // limits, no object
            &[0x2C, 0x00, 0x00, 0x03],                            // a 3-octet identifier
            &[0x3B, 0x05, 0x41, 0x49],                            // a name in another character set
            &[0x2C, 0, 0, 0, 3, 0x3A, 0, 0x41],                   // identifier and name both
            &[0x4C, 0, 0, 0, 3],                                  // context tag 4
            &[0x0C, 0x01, 0, 0, 0, 0x19, 0x02, 0x2C, 0, 0, 0, 3], // low limit 2^24
        ];
        for b in bad {
            assert!(WhoHas::parse(b).is_err(), "{b:02x?}");
        }
    }

    #[test]
    fn i_have_encodes_three_application_values() {
        // device 4321 = 0x020010E1, (analog-input, 3), "AI"
        let want = [
            0xC4, 0x02, 0x00, 0x10, 0xE1, 0xC4, 0x00, 0x00, 0x00, 0x03, 0x73, 0x00, 0x41, 0x49,
        ];
        let a = IHave {
            device: ObjectId::new(8, 4321),
            object: ObjectId::new(0, 3),
            name: "AI",
        };
        assert_eq!(emitted(|w| a.emit(w)), want);
        assert_eq!(IHave::parse(&want), Ok(a));
        assert!(IHave::parse(&want[..10]).is_err());
        assert!(IHave::parse(&[want.as_slice(), &[0x00]].concat()).is_err());
    }
}
