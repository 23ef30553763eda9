//! The register map: what a BMS or a DALI gateway reads and writes. `no_std`, no heap.
//!
//! One table ([`TABLE`]) describes every register; `docs/modbus.md` is generated from it
//! (`luxnode modbus map`) and a test keeps the two identical. The handler serves exactly the
//! table: an address outside it is exception 0x02, a value out of range 0x03, an unsupported
//! function 0x01. Read-only blocks answer both function 0x04 (input registers) and 0x03
//! (holding registers, for the many BMS drivers that only speak 0x03) at the same addresses.
//!
//! The fixed core (never moved, only extended around): input 0 map version, 1 desks,
//! 2 luminaires, 3 status bits; input 100 + 2k / 101 + 2k desk k's lux as float32 (word order
//! ABCD by default); input 300 + k desk k's lux as u16; holding 1000 + j luminaire j's DALI arc
//! level. Desk k is the k-th sensor of `sensors.json`; luminaire j the j-th of
//! `luminaires.json`.

use crate::dali::DimmingCurve;

use super::pdu::{
    DecodeError, Exception, MAX_PDU, MAX_WRITE, Request, decode_request, encode_device_id,
    encode_exception, encode_registers, encode_write_echo, function,
};

/// Version of this map (input register 0). Bumped when registers are added; existing ones never
/// move.
pub const MAP_VERSION: u16 = 1;
/// Desks the map has room for.
pub const MAX_DESKS: usize = 100;
/// Luminaires the map has room for.
pub const MAX_LUMINAIRES: usize = 256;

/// Addresses (PDU, 0-based).
pub mod addr {
    /// Register-map version.
    pub const MAP_VERSION: u16 = 0;
    /// Number of desks.
    pub const DESKS: u16 = 1;
    /// Number of luminaires.
    pub const LUMINAIRES: u16 = 2;
    /// Status bits ([`super::status`]).
    pub const STATUS: u16 = 3;
    /// Image generation, u32, high word first (4, 5).
    pub const GENERATION: u16 = 4;
    /// Firmware version, major × 256 + minor.
    pub const FIRMWARE: u16 = 6;
    /// Firmware patch level.
    pub const FIRMWARE_PATCH: u16 = 7;
    /// Uptime, s, u32, high word first (8, 9).
    pub const UPTIME: u16 = 8;
    /// Heartbeat: increments at every publication of desk values (wraps).
    pub const HEARTBEAT: u16 = 10;
    /// Age of the published desk values, s (saturating).
    pub const AGE: u16 = 11;
    /// Float word order in effect (mirror of holding 2000).
    pub const WORD_ORDER_IN_EFFECT: u16 = 12;
    /// Dimming curve in effect (mirror of holding 2001).
    pub const CURVE_IN_EFFECT: u16 = 13;
    /// Last header register.
    pub const HEADER_LAST: u16 = 13;
    /// Desk k's lux, float32: 100 + 2k and 101 + 2k.
    pub const DESK_FLOAT: u16 = 100;
    /// Desk k's lux, u16, rounded and saturating: 300 + k.
    pub const DESK_U16: u16 = 300;
    /// Desk k's quality ([`super::Quality`]): 400 + k.
    pub const DESK_QUALITY: u16 = 400;
    /// Desk k's id (the sensor id of `sensors.json`): 500 + k.
    pub const DESK_ID: u16 = 500;
    /// Luminaire j's id (of `luminaires.json`): 600 + j.
    pub const LUMINAIRE_ID: u16 = 600;
    /// Luminaire j's DALI arc level, read and write: 1000 + j.
    pub const ARC_LEVEL: u16 = 1000;
    /// Float word order of the desk floats: 0 ABCD (big-endian words), 1 CDAB.
    pub const WORD_ORDER: u16 = 2000;
    /// Dimming curve of the arc levels: 0 logarithmic (IEC 62386-102), 1 linear (IEC 62386-207).
    pub const DIMMING_CURVE: u16 = 2001;
}

/// Status bits (input register 3).
pub mod status {
    /// A commissioned image is loaded.
    pub const COMMISSIONED: u16 = 1 << 0;
    /// The store is healthy (the running image verified, no write error).
    pub const STORE_OK: u16 = 1 << 1;
    /// The sensors (cameras) are healthy.
    pub const SENSORS_OK: u16 = 1 << 2;
    /// A DALI gateway link is configured.
    pub const GATEWAY_CONFIGURED: u16 = 1 << 3;
    /// The gateway answers.
    pub const GATEWAY_LINK_UP: u16 = 1 << 4;
    /// Desk values are stale (the dimming state is not known to be current).
    pub const VALUES_STALE: u16 = 1 << 5;
    /// The last evaluation failed: desk values are not available.
    pub const COMPUTE_ERROR: u16 = 1 << 6;
    /// A peripheral of the node (ambient light sensor, calibration EEPROM, status LED) is
    /// absent, stuck or gives bad readings (the log says which and why).
    pub const PERIPHERAL_FAULT: u16 = 1 << 12;
    /// The ambient light sensor disagrees with the model's prediction for the current dimming
    /// state by more than its tolerance (daylight, a failed luminaire, a changed room).
    pub const LIGHT_CHECK: u16 = 1 << 13;
}

/// A desk value's quality (input 400 + k).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u16)]
pub enum Quality {
    /// Computed from the current dimming state.
    #[default]
    Ok = 0,
    /// The last good value: the dimming state could not be read (gateway lost).
    Stale = 1,
    /// The desk was outside the camera's view at commissioning (modelled, not seen).
    OutOfView = 2,
    /// Resting on estimated reflectances or geometry.
    Estimated = 3,
}

/// Register value meaning "not available" (u16 blocks).
pub const NOT_AVAILABLE_U16: u16 = 0xFFFF;
/// Float32 "not available": a quiet NaN.
pub const NOT_AVAILABLE_F32: u32 = 0x7FC0_0000;
/// The largest lux the u16 block shows (65535 is "not available").
pub const U16_LUX_MAX: u16 = 65534;

/// Word order of 32-bit values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WordOrder {
    /// High word first (ABCD), the default.
    #[default]
    Abcd,
    /// Low word first (CDAB).
    Cdab,
}

/// One desk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Desk {
    /// Its id (the sensor id).
    pub id: u32,
    /// Illuminance, lx; not finite means not available.
    pub lux: f64,
    /// Quality.
    pub quality: Quality,
}

/// The identification strings (function 0x2B / 0x0E).
#[derive(Debug, Clone, Default)]
pub struct Identity {
    /// Model name (the board).
    pub model: heapless::String<32>,
    /// User application name (the commissioned scene).
    pub application: heapless::String<64>,
}

/// The map's state: what reads return and writes change.
#[derive(Debug, Clone, Default)]
pub struct RegisterMap {
    /// Desks in sensors.json order.
    pub desks: heapless::Vec<Desk, MAX_DESKS>,
    /// Luminaire ids in luminaires.json order.
    pub luminaire_ids: heapless::Vec<u32, MAX_LUMINAIRES>,
    /// Current arc level per luminaire.
    pub arc: heapless::Vec<u8, MAX_LUMINAIRES>,
    /// Status bits.
    pub status: u16,
    /// Image generation.
    pub generation: u32,
    /// Uptime, s.
    pub uptime_s: u32,
    /// Publication counter.
    pub heartbeat: u16,
    /// Age of the desk values, s.
    pub age_s: u16,
    /// Word order of the desk floats.
    pub word_order: WordOrder,
    /// Dimming curve of the arc levels.
    pub curve: DimmingCurve,
    /// Identification strings.
    pub identity: Identity,
}

/// What a request changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Effect {
    /// Arc levels were written.
    pub arc_changed: bool,
    /// Configuration (word order, curve) was written.
    pub config_changed: bool,
}

/// The two register spaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Space {
    /// Input registers (function 0x04).
    Input,
    /// Holding registers (functions 0x03, 0x06, 0x10).
    Holding,
}

fn crate_version() -> (u16, u16, u16) {
    fn parse(s: &str) -> u16 {
        s.bytes().fold(0u16, |a, b| {
            a.saturating_mul(10)
                .saturating_add(u16::from(b.wrapping_sub(b'0')) % 10)
        })
    }
    (
        parse(env!("CARGO_PKG_VERSION_MAJOR")),
        parse(env!("CARGO_PKG_VERSION_MINOR")),
        parse(env!("CARGO_PKG_VERSION_PATCH")),
    )
}

impl RegisterMap {
    /// Number of desks.
    pub fn desk_count(&self) -> usize {
        self.desks.len()
    }

    fn float_bits(&self, k: usize) -> u32 {
        let d = &self.desks[k];
        if d.lux.is_finite() {
            (d.lux as f32).to_bits()
        } else {
            NOT_AVAILABLE_F32
        }
    }

    /// The value of one register, or `None` when the address is not in the map.
    pub fn read(&self, space: Space, address: u16) -> Option<u16> {
        let a = address;
        let d = self.desks.len() as u16;
        let l = self.luminaire_ids.len() as u16;
        let (major, minor, patch) = crate_version();
        let in_block = |base: u16, count: u16| a >= base && a < base.saturating_add(count);
        let v = if a <= addr::HEADER_LAST {
            match a {
                addr::MAP_VERSION => MAP_VERSION,
                addr::DESKS => d,
                addr::LUMINAIRES => l,
                addr::STATUS => self.status,
                addr::GENERATION => (self.generation >> 16) as u16,
                5 => self.generation as u16,
                addr::FIRMWARE => major.saturating_mul(256).saturating_add(minor.min(255)),
                addr::FIRMWARE_PATCH => patch,
                addr::UPTIME => (self.uptime_s >> 16) as u16,
                9 => self.uptime_s as u16,
                addr::HEARTBEAT => self.heartbeat,
                addr::AGE => self.age_s,
                addr::WORD_ORDER_IN_EFFECT => self.word_order as u16,
                _ => self.curve as u16,
            }
        } else if in_block(addr::DESK_FLOAT, 2 * d) {
            let off = a - addr::DESK_FLOAT;
            let bits = self.float_bits(usize::from(off / 2));
            let (hi, lo) = ((bits >> 16) as u16, bits as u16);
            let first = off % 2 == 0;
            match (self.word_order, first) {
                (WordOrder::Abcd, true) | (WordOrder::Cdab, false) => hi,
                _ => lo,
            }
        } else if in_block(addr::DESK_U16, d) {
            let lux = self.desks[usize::from(a - addr::DESK_U16)].lux;
            if lux.is_finite() {
                let r = libm::round(lux.max(0.0));
                if r >= f64::from(U16_LUX_MAX) {
                    U16_LUX_MAX
                } else {
                    r as u16
                }
            } else {
                NOT_AVAILABLE_U16
            }
        } else if in_block(addr::DESK_QUALITY, d) {
            let desk = &self.desks[usize::from(a - addr::DESK_QUALITY)];
            if desk.lux.is_finite() {
                desk.quality as u16
            } else {
                NOT_AVAILABLE_U16
            }
        } else if in_block(addr::DESK_ID, d) {
            self.desks[usize::from(a - addr::DESK_ID)]
                .id
                .min(u32::from(u16::MAX)) as u16
        } else if in_block(addr::LUMINAIRE_ID, l) {
            self.luminaire_ids[usize::from(a - addr::LUMINAIRE_ID)].min(u32::from(u16::MAX)) as u16
        } else if space == Space::Holding && in_block(addr::ARC_LEVEL, self.arc.len() as u16) {
            u16::from(self.arc[usize::from(a - addr::ARC_LEVEL)])
        } else if space == Space::Holding && a == addr::WORD_ORDER {
            self.word_order as u16
        } else if space == Space::Holding && a == addr::DIMMING_CURVE {
            self.curve as u16
        } else {
            return None;
        };
        Some(v)
    }

    /// Checks that `value` may be written at `address` (holding); the exception otherwise.
    fn check_write(&self, address: u16, value: u16) -> Result<(), Exception> {
        let l = self.arc.len() as u16;
        if address >= addr::ARC_LEVEL && address < addr::ARC_LEVEL + l {
            return if value <= 255 {
                Ok(())
            } else {
                Err(Exception::IllegalDataValue)
            };
        }
        if address == addr::WORD_ORDER || address == addr::DIMMING_CURVE {
            return if value <= 1 {
                Ok(())
            } else {
                Err(Exception::IllegalDataValue)
            };
        }
        Err(Exception::IllegalDataAddress)
    }

    fn apply_write(&mut self, address: u16, value: u16, effect: &mut Effect) {
        if address == addr::WORD_ORDER {
            self.word_order = if value == 0 {
                WordOrder::Abcd
            } else {
                WordOrder::Cdab
            };
            effect.config_changed = true;
        } else if address == addr::DIMMING_CURVE {
            self.curve = if value == 0 {
                DimmingCurve::Logarithmic
            } else {
                DimmingCurve::Linear
            };
            effect.config_changed = true;
        } else if let Some(level) = self.arc.get_mut(usize::from(address - addr::ARC_LEVEL)) {
            // 255 is MASK: no change
            if value != 255 {
                *level = value as u8;
            }
            effect.arc_changed = true;
        }
    }

    /// Handles a decoded request; writes the response PDU into `out`.
    pub fn handle(
        &mut self,
        request: &Request<'_>,
        out: &mut [u8; MAX_PDU],
    ) -> Result<(usize, Effect), Exception> {
        let mut effect = Effect::default();
        let fc = request.function();
        match *request {
            Request::ReadHolding { address, quantity }
            | Request::ReadInput { address, quantity } => {
                let space = if fc == function::READ_HOLDING {
                    Space::Holding
                } else {
                    Space::Input
                };
                let mut values = [0u16; super::pdu::MAX_READ];
                let values = values
                    .get_mut(..usize::from(quantity))
                    .ok_or(Exception::IllegalDataValue)?;
                for (k, value) in values.iter_mut().enumerate() {
                    let a = address
                        .checked_add(k as u16)
                        .ok_or(Exception::IllegalDataAddress)?;
                    *value = self.read(space, a).ok_or(Exception::IllegalDataAddress)?;
                }
                Ok((encode_registers(fc, values, out), effect))
            }
            Request::WriteSingle { address, value } => {
                self.check_write(address, value)?;
                self.apply_write(address, value, &mut effect);
                Ok((encode_write_echo(fc, address, value, out), effect))
            }
            Request::WriteMultiple { address, values } => {
                // all or nothing: check every register before changing any
                for (k, v) in values.iter().enumerate() {
                    let a = address
                        .checked_add(k as u16)
                        .ok_or(Exception::IllegalDataAddress)?;
                    self.check_write(a, *v)?;
                }
                for (k, v) in values.iter().enumerate() {
                    self.apply_write(address + k as u16, *v, &mut effect);
                }
                Ok((
                    encode_write_echo(fc, address, values.len() as u16, out),
                    effect,
                ))
            }
            Request::ReadDeviceId { code, object } => {
                let (major, minor, patch) = crate_version();
                let mut revision: heapless::String<16> = heapless::String::new();
                let _ = core::fmt::write(&mut revision, format_args!("{major}.{minor}.{patch}"));
                let objects: [(u8, &str); 7] = [
                    (0x00, "luxnode"),
                    (0x01, "LXN-1"),
                    (0x02, revision.as_str()),
                    (0x03, "https://github.com/luxnode"),
                    (0x04, "luxnode desk illuminance node"),
                    (0x05, self.identity.model.as_str()),
                    (0x06, self.identity.application.as_str()),
                ];
                let (first, last) = match code {
                    1 => (0x00u8, 0x02u8),
                    4 => {
                        if usize::from(object) >= objects.len() {
                            return Err(Exception::IllegalDataAddress);
                        }
                        (object, object)
                    }
                    _ => (0x00, 0x06),
                };
                // a stream starting past its category restarts at its beginning (specification)
                let start = if code != 4 && (object < first || object > last) {
                    first
                } else {
                    object.max(first)
                };
                let selected = &objects[usize::from(start)..=usize::from(last)];
                Ok((encode_device_id(code, 0x82, selected, out), effect))
            }
        }
    }

    /// Decodes a request PDU, handles it and encodes the response (or the exception) into
    /// `out`. `None`: nothing to answer (an empty PDU).
    pub fn process(&mut self, pdu: &[u8], out: &mut [u8; MAX_PDU]) -> Option<(usize, Effect)> {
        let mut words = [0u16; MAX_WRITE];
        match decode_request(pdu, &mut words) {
            Err(DecodeError::Empty) => None,
            Err(DecodeError::Exception { function, code }) => {
                Some((encode_exception(function, code, out), Effect::default()))
            }
            Ok(request) => {
                let fc = request.function();
                Some(match self.handle(&request, out) {
                    Ok(r) => r,
                    Err(code) => (encode_exception(fc, code, out), Effect::default()),
                })
            }
        }
    }
}

/// One row of the register table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RegisterDoc {
    /// Space: input (also readable with 0x03 at the same address) or holding.
    pub space: Space,
    /// First address of the row.
    pub address: u16,
    /// How many registers, in words (for blocks: as a formula of D desks or L luminaires).
    pub count: &'static str,
    /// Name.
    pub name: &'static str,
    /// Data type.
    pub ty: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Scaling.
    pub scale: &'static str,
    /// Access.
    pub access: &'static str,
    /// What it means.
    pub description: &'static str,
}

macro_rules! row {
    ($space:ident, $a:expr, $count:expr, $name:expr, $ty:expr, $unit:expr, $scale:expr, $access:expr, $desc:expr) => {
        RegisterDoc {
            space: Space::$space,
            address: $a,
            count: $count,
            name: $name,
            ty: $ty,
            unit: $unit,
            scale: $scale,
            access: $access,
            description: $desc,
        }
    };
}

/// Every register of the map.
pub const TABLE: &[RegisterDoc] = &[
    row!(
        Input,
        addr::MAP_VERSION,
        "1",
        "map version",
        "u16",
        "",
        "1",
        "R",
        "version of this register map (fixed core never moves)"
    ),
    row!(
        Input,
        addr::DESKS,
        "1",
        "desks",
        "u16",
        "",
        "1",
        "R",
        "number of desks D (sensors of sensors.json, in that order)"
    ),
    row!(
        Input,
        addr::LUMINAIRES,
        "1",
        "luminaires",
        "u16",
        "",
        "1",
        "R",
        "number of luminaires L (luminaires.json order)"
    ),
    row!(
        Input,
        addr::STATUS,
        "1",
        "status",
        "bits",
        "",
        "",
        "R",
        "bit 0 commissioned, 1 store healthy, 2 sensors healthy, 3 gateway configured, 4 gateway link up, 5 values stale, 6 compute error, 12 peripheral fault, 13 ambient light disagrees with the model"
    ),
    row!(
        Input,
        addr::GENERATION,
        "2",
        "image generation",
        "u32 (high word first)",
        "",
        "1",
        "R",
        "generation of the commissioned image in flash"
    ),
    row!(
        Input,
        addr::FIRMWARE,
        "1",
        "firmware version",
        "u16",
        "",
        "major × 256 + minor",
        "R",
        "luxnode version"
    ),
    row!(
        Input,
        addr::FIRMWARE_PATCH,
        "1",
        "firmware patch",
        "u16",
        "",
        "1",
        "R",
        "luxnode patch level"
    ),
    row!(
        Input,
        addr::UPTIME,
        "2",
        "uptime",
        "u32 (high word first)",
        "s",
        "1",
        "R",
        "time since start"
    ),
    row!(
        Input,
        addr::HEARTBEAT,
        "1",
        "heartbeat",
        "u16",
        "",
        "1",
        "R",
        "counts publications of desk values (wraps)"
    ),
    row!(
        Input,
        addr::AGE,
        "1",
        "value age",
        "u16",
        "s",
        "1",
        "R",
        "age of the published desk values (saturates at 65535)"
    ),
    row!(
        Input,
        addr::WORD_ORDER_IN_EFFECT,
        "1",
        "word order in effect",
        "u16",
        "",
        "",
        "R",
        "0 ABCD, 1 CDAB (set at holding 2000)"
    ),
    row!(
        Input,
        addr::CURVE_IN_EFFECT,
        "1",
        "dimming curve in effect",
        "u16",
        "",
        "",
        "R",
        "0 logarithmic, 1 linear (set at holding 2001)"
    ),
    row!(
        Input,
        addr::DESK_FLOAT,
        "2 × D",
        "desk lux (float)",
        "float32, word order per 2000 (ABCD default)",
        "lx",
        "1",
        "R",
        "desk k at 100 + 2k and 101 + 2k; NaN (0x7FC00000) when not available"
    ),
    row!(
        Input,
        addr::DESK_U16,
        "D",
        "desk lux (integer)",
        "u16",
        "lx",
        "1 (rounded, saturating at 65534)",
        "R",
        "desk k at 300 + k; 65535 when not available"
    ),
    row!(
        Input,
        addr::DESK_QUALITY,
        "D",
        "desk quality",
        "u16",
        "",
        "",
        "R",
        "desk k at 400 + k: 0 ok, 1 stale (dimming state unknown), 2 out of the camera's view, 3 estimated; 65535 not available"
    ),
    row!(
        Input,
        addr::DESK_ID,
        "D",
        "desk id",
        "u16",
        "",
        "",
        "R",
        "desk k at 500 + k: its sensor id in sensors.json"
    ),
    row!(
        Input,
        addr::LUMINAIRE_ID,
        "L",
        "luminaire id",
        "u16",
        "",
        "",
        "R",
        "luminaire j at 600 + j: its id in luminaires.json"
    ),
    row!(
        Holding,
        addr::ARC_LEVEL,
        "L",
        "arc level",
        "u16",
        "DALI arc level",
        "0 off, 1..254 on the curve of 2001, 255 no change",
        "R/W",
        "luminaire j at 1000 + j; writing sets the dimming state; values above 255 are exception 0x03"
    ),
    row!(
        Holding,
        addr::WORD_ORDER,
        "1",
        "float word order",
        "u16",
        "",
        "0 ABCD, 1 CDAB",
        "R/W",
        "word order of the desk floats; other values are exception 0x03"
    ),
    row!(
        Holding,
        addr::DIMMING_CURVE,
        "1",
        "dimming curve",
        "u16",
        "",
        "0 logarithmic (IEC 62386-102), 1 linear (IEC 62386-207)",
        "R/W",
        "how arc levels map to light output; other values are exception 0x03"
    ),
];

#[cfg(feature = "std")]
/// The register table as Markdown (docs/modbus.md).
pub fn markdown() -> std::string::String {
    use core::fmt::Write as _;
    let mut s = std::string::String::new();
    let _ = writeln!(s, "# luxnode Modbus register map (version {MAP_VERSION})\n");
    let _ = writeln!(
        s,
        "Generated by `luxnode modbus map` from the table the server uses (`src/modbus/regmap.rs`); a test\n\
         keeps this file identical to it. Addresses are PDU addresses (0-based, what goes on the wire);\n\
         the reference column is the 1-based 3xxxx/4xxxx notation of device manuals (add 1). Read-only\n\
         input registers answer function 0x04 and, at the same addresses, 0x03. D = number of desks\n\
         (input 1), L = number of luminaires (input 2); addresses past a block's end are exception 0x02.\n"
    );
    let _ = writeln!(
        s,
        "| address | reference | registers | name | type | unit | scaling | access | meaning |"
    );
    let _ = writeln!(s, "|---:|---:|---|---|---|---|---|---|---|");
    for r in TABLE {
        let reference = match r.space {
            Space::Input => 30_001 + u32::from(r.address),
            Space::Holding => 40_001 + u32::from(r.address),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.address, reference, r.count, r.name, r.ty, r.unit, r.scale, r.access, r.description
        );
    }
    let _ = writeln!(
        s,
        "\nFunctions: 0x03, 0x04 (1..125 registers), 0x06, 0x10 (1..123 registers; all-or-nothing),\n\
         0x2B/0x0E read device identification (objects 0x00 VendorName `luxnode`, 0x01 ProductCode\n\
         `LXN-1`, 0x02 MajorMinorRevision, 0x03 VendorUrl, 0x04 ProductName, 0x05 ModelName (the\n\
         board), 0x06 UserApplicationName (the commissioned scene)). Exceptions: 0x01 unsupported\n\
         function, 0x02 address not in the map or not writable, 0x03 value or quantity out of range.\n\
         Over RTU the node answers only its own unit id and never a broadcast (unit 0), whose writes\n\
         it still executes."
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> RegisterMap {
        let mut m = RegisterMap::default();
        for (k, lux) in [523.25, 70000.0, f64::NAN].into_iter().enumerate() {
            let _ = m.desks.push(Desk {
                id: 10 + k as u32,
                lux,
                quality: Quality::Ok,
            });
        }
        for j in 0..2 {
            let _ = m.luminaire_ids.push(j + 1);
            let _ = m.arc.push(254);
        }
        m.status = status::COMMISSIONED;
        m
    }

    fn read(m: &mut RegisterMap, fc: u8, a: u16, q: u16) -> Vec<u8> {
        let mut out = [0u8; MAX_PDU];
        let pdu = [fc, (a >> 8) as u8, a as u8, (q >> 8) as u8, q as u8];
        let (n, _) = m.process(&pdu, &mut out).unwrap();
        out[..n].to_vec()
    }

    #[test]
    fn fixed_core_and_float_word_orders() {
        let mut m = map();
        assert_eq!(read(&mut m, 4, 0, 4), vec![4, 8, 0, 1, 0, 3, 0, 2, 0, 1]);
        // 523.25 = 0x4402D000: ABCD
        assert_eq!(read(&mut m, 4, 100, 2), vec![4, 4, 0x44, 0x02, 0xD0, 0x00]);
        // the same through function 0x03
        assert_eq!(read(&mut m, 3, 100, 2), vec![3, 4, 0x44, 0x02, 0xD0, 0x00]);
        // u16: rounded, saturating, not available
        assert_eq!(
            read(&mut m, 4, 300, 3),
            vec![4, 6, 0x02, 0x0B, 0xFF, 0xFE, 0xFF, 0xFF]
        );
        // NaN sentinel for the unavailable desk, quality not available
        assert_eq!(read(&mut m, 4, 104, 2), vec![4, 4, 0x7F, 0xC0, 0, 0]);
        assert_eq!(read(&mut m, 4, 402, 1), vec![4, 2, 0xFF, 0xFF]);
        // CDAB after writing holding 2000 = 1
        let mut out = [0u8; MAX_PDU];
        let (_, e) = m.process(&[6, 0x07, 0xD0, 0, 1], &mut out).unwrap();
        assert!(e.config_changed);
        assert_eq!(read(&mut m, 4, 100, 2), vec![4, 4, 0xD0, 0x00, 0x44, 0x02]);
    }

    #[test]
    fn exceptions() {
        let mut m = map();
        assert_eq!(read(&mut m, 4, 50, 1), vec![0x84, 2]); // gap
        assert_eq!(read(&mut m, 4, 104, 3), vec![0x84, 2]); // past the float block (D = 3)
        assert_eq!(read(&mut m, 4, 1000, 1), vec![0x84, 2]); // arc levels are holding only
        assert_eq!(read(&mut m, 4, 0xFFFF, 2), vec![0x84, 2]); // wraps past 65535
        let mut out = [0u8; MAX_PDU];
        // writes: read-only address, out of range value, unknown function
        let (n, _) = m.process(&[6, 0, 100, 0, 1], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x86, 2]);
        let (n, _) = m.process(&[6, 0x03, 0xE8, 0x01, 0x00], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x86, 3]);
        let (n, _) = m.process(&[0x05, 0, 0, 0xFF, 0], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x85, 1]);
        // all or nothing: the second register is invalid, the first is not applied
        let (n, _) = m
            .process(&[0x10, 0x03, 0xE8, 0, 2, 4, 0, 10, 0x01, 0x00], &mut out)
            .unwrap();
        assert_eq!(&out[..n], &[0x90, 3]);
        assert_eq!(m.arc[0], 254);
    }

    #[test]
    fn arc_level_writes_and_mask() {
        let mut m = map();
        let mut out = [0u8; MAX_PDU];
        let (n, e) = m
            .process(&[0x10, 0x03, 0xE8, 0, 2, 4, 0, 229, 0, 255], &mut out)
            .unwrap();
        assert_eq!(&out[..n], &[0x10, 0x03, 0xE8, 0, 2]);
        assert!(e.arc_changed);
        assert_eq!(&m.arc[..], &[229, 254]); // 255 = no change
        assert_eq!(read(&mut m, 3, 1000, 2), vec![3, 4, 0, 229, 0, 254]);
    }

    #[test]
    fn device_identification() {
        let mut m = map();
        let _ = m.identity.model.push_str("sim");
        let mut out = [0u8; MAX_PDU];
        let (n, _) = m.process(&[0x2B, 0x0E, 1, 0], &mut out).unwrap();
        assert_eq!(&out[..9], &[0x2B, 0x0E, 1, 0x82, 0, 0, 3, 0, 7]);
        assert_eq!(&out[9..16], b"luxnode");
        assert!(n > 16);
        let (n, _) = m.process(&[0x2B, 0x0E, 4, 5], &mut out).unwrap();
        assert_eq!(
            &out[..n],
            &[0x2B, 0x0E, 4, 0x82, 0, 0, 1, 5, 3, b's', b'i', b'm']
        );
        let (n, _) = m.process(&[0x2B, 0x0E, 4, 0x80], &mut out).unwrap();
        assert_eq!(&out[..n], &[0xAB, 2]);
    }

    #[test]
    fn every_documented_register_behaves_as_documented() {
        let mut m = map();
        for r in TABLE {
            let fc = match r.space {
                Space::Input => 4,
                Space::Holding => 3,
            };
            let got = read(&mut m, fc, r.address, 1);
            assert_eq!(got[0], fc, "{} at {}: {got:?}", r.name, r.address);
            if r.space == Space::Input {
                // read-only blocks also answer 0x03 and refuse writes
                assert_eq!(read(&mut m, 3, r.address, 1)[0], 3, "{}", r.name);
                let mut out = [0u8; MAX_PDU];
                let a = r.address;
                let (n, _) = m
                    .process(&[6, (a >> 8) as u8, a as u8, 0, 0], &mut out)
                    .unwrap();
                assert_eq!(&out[..n], &[0x86, 2], "{} is read-only", r.name);
            } else {
                assert_eq!(r.access, "R/W");
                let mut out = [0u8; MAX_PDU];
                let a = r.address;
                let (n, _) = m
                    .process(&[6, (a >> 8) as u8, a as u8, 0, 1], &mut out)
                    .unwrap();
                assert_eq!(out[0], 6, "{} is writable ({:?})", r.name, &out[..n]);
            }
        }
    }
}
