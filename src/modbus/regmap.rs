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
pub const MAP_VERSION: u16 = 6;
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
    /// Communication health, first register (40..=51, [`super::CommHealth`]).
    pub const COMM_FIRST: u16 = 40;
    /// Communication health, last register.
    pub const COMM_LAST: u16 = 51;
    /// Float word order of the desk floats for the reading client: 0 ABCD (big-endian words),
    /// 1 CDAB, 2 BADC, 3 DCBA.
    pub const WORD_ORDER: u16 = 2000;
    /// Dimming curve of the arc levels: 0 logarithmic (IEC 62386-102), 1 linear (IEC 62386-207).
    pub const DIMMING_CURVE: u16 = 2001;
    /// Lighting control mode: 0 off, 1 constant light, 2 daylight harvesting.
    pub const CONTROL_MODE: u16 = 2002;
    /// Desk k's target (maintained) illuminance, lx: 2100 + k.
    pub const DESK_TARGET: u16 = 2100;
    /// Lighting control mode in effect (mirror of holding 2002).
    pub const CONTROL_MODE_IN_EFFECT: u16 = 60;
    /// Desks short of their target under the control plan.
    pub const CONTROL_SHORT: u16 = 61;
    /// Control flags ([`super::control_flags`]).
    pub const CONTROL_FLAGS: u16 = 62;
    /// Electric power of the luminaires now, W, float32 (63, 64).
    pub const POWER_NOW: u16 = 63;
    /// Electric power with every luminaire at full, W, float32 (65, 66).
    pub const POWER_ALL_ON: u16 = 65;
    /// Power saved against all at full, 0.1 %.
    pub const POWER_SAVED: u16 = 67;
    /// Last register of the control block.
    pub const CONTROL_LAST: u16 = 67;
    /// Desk k meets its target under the control plan: 700 + k.
    pub const DESK_MET: u16 = 700;
    /// Desk k's stated model uncertainty from commissioning, 0.1 %: 800 + k.
    pub const DESK_MODEL_UNCERTAINTY: u16 = 800;
    /// Live-light status bits ([`super::live_status`]).
    pub const LIVE_STATUS: u16 = 70;
    /// Age of the last camera frame live light used, s (saturating; 65535 none yet).
    pub const LIVE_LAST_FRAME_AGE: u16 = 71;
    /// Desk k's live total lux (daylight included), float32: 3000 + 2k, 3001 + 2k.
    pub const LIVE_TOTAL_FLOAT: u16 = 3000;
    /// Desk k's live artificial lux (the luminaires now), float32: 3200 + 2k, 3201 + 2k.
    pub const LIVE_ARTIFICIAL_FLOAT: u16 = 3200;
    /// Desk k's live daylight (extraneous) lux, float32: 3400 + 2k, 3401 + 2k.
    pub const LIVE_DAYLIGHT_FLOAT: u16 = 3400;
    /// Desk k's live total lux, u16: 3600 + k.
    pub const LIVE_TOTAL_U16: u16 = 3600;
    /// Desk k's live artificial lux, u16: 3700 + k.
    pub const LIVE_ARTIFICIAL_U16: u16 = 3700;
    /// Desk k's live daylight lux, u16: 3800 + k.
    pub const LIVE_DAYLIGHT_U16: u16 = 3800;
    /// Desk k's live source ([`super::LiveSource`]): 3900 + k.
    pub const LIVE_SOURCE: u16 = 3900;
    /// Desk k's live standard uncertainty of the total, lx, u16: 4000 + k.
    pub const LIVE_UNCERTAINTY: u16 = 4000;
    /// Desk k's live flags ([`super::live_flags`]): 4100 + k.
    pub const LIVE_FLAGS: u16 = 4100;
    /// Age of the frame desk k's daylight comes from, s (saturating): 4200 + k.
    pub const LIVE_FRAME_AGE: u16 = 4200;
    /// Luminaire j's ageing factor, 0.001 (1000 = as commissioned): 4300 + j.
    pub const AGEING: u16 = 4300;
    /// Occupancy status bits ([`super::occupancy_status`]).
    pub const OCCUPANCY_STATUS: u16 = 72;
    /// People the last good depth frame saw (65535: not known).
    pub const PEOPLE: u16 = 73;
    /// Occupancy's hold time in effect, s (board `[occupancy] hold_s`).
    pub const OCCUPANCY_HOLD: u16 = 74;
    /// Desk k's occupancy ([`super::Occupancy`]): 4600 + k.
    pub const DESK_OCCUPIED: u16 = 4600;
    /// Desk k's occupancy flags ([`super::occupancy_flags`]): 4700 + k.
    pub const DESK_OCCUPANCY_FLAGS: u16 = 4700;
}

/// Occupancy status bits (input register 72).
pub mod occupancy_status {
    /// Occupancy runs (the image has desks and a live section, the board a depth camera).
    pub const ON: u16 = 1 << 0;
    /// No usable depth frame for longer than live light's stale limit: every desk's frame
    /// answer is unknown (the last good state is held for the hold time, then unknown).
    pub const STALE: u16 = 1 << 1;
    /// The last depth frame was missing or of the wrong size.
    pub const BAD_FRAME: u16 = 1 << 2;
    /// Too few pixels of the last depth frame returned (all zeros, covered lens).
    pub const NO_RETURN: u16 = 1 << 3;
    /// Too many pixels of the last depth frame were saturated.
    pub const SATURATED: u16 = 1 << 4;
    /// The last depth frame did not register against the commissioned room (the camera moved).
    pub const MOVED: u16 = 1 << 5;
}

/// Occupancy flags per desk (input 4700 + k).
pub mod occupancy_flags {
    /// The state is the hold's (the person was seen within the hold time, or the last answer
    /// is kept through bad frames), not the last frame's answer.
    pub const HELD: u16 = 1 << 0;
    /// The desk sensor is on no desk top: it has no workstation zone (always unknown).
    pub const NO_DESK: u16 = 1 << 1;
}

/// A desk's occupancy (input 4600 + k).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u16)]
pub enum Occupancy {
    /// Nobody at the desk after the hold, and the node sees enough of its zone to say so.
    Vacant = 0,
    /// A person at the desk (or seen there within the hold time).
    Occupied = 1,
    /// Not known: occupancy off, the desk not seen, or no usable depth frame for longer than
    /// the hold. Never published as vacant.
    #[default]
    Unknown = NOT_AVAILABLE_U16,
}

/// One desk's occupancy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OccupancyDesk {
    /// Its state, the hold applied.
    pub state: Occupancy,
    /// [`occupancy_flags`].
    pub flags: u16,
}

/// The occupancy registers (`crate::occupancy` through the daemon's hold): per desk its state
/// and flags, the people count and the status. Only aggregates: no depth frame leaves the node.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyRegisters {
    /// Per desk (empty: occupancy off; the blocks then read unknown).
    pub desks: heapless::Vec<OccupancyDesk, MAX_DESKS>,
    /// People the last good depth frame saw (`None`: not known).
    pub people: Option<u16>,
    /// [`occupancy_status`] bits.
    pub status: u16,
    /// The hold in effect, s (not finite: occupancy off).
    pub hold_s: f64,
}

impl Default for OccupancyRegisters {
    fn default() -> Self {
        Self {
            desks: heapless::Vec::new(),
            people: None,
            status: 0,
            hold_s: f64::NAN,
        }
    }
}

/// Live-light status bits (input register 70).
pub mod live_status {
    /// Live light runs (the image has a live section and the board a camera).
    pub const ON: u16 = 1 << 0;
    /// The camera does not answer (or only gives rejected frames) for longer than the stale
    /// limit: the values are held, then model only.
    pub const CAMERA_STALE: u16 = 1 << 1;
    /// A large part of the room changed for good: recommissioning advised.
    pub const RECOMMISSION: u16 = 1 << 2;
    /// The last frame had no daylight (ageing is measured on such frames).
    pub const NIGHT: u16 = 1 << 3;
    /// The last frame was rejected (dark, saturated, wrong size, stale).
    pub const FRAME_REJECTED: u16 = 1 << 4;
    /// The node's clock is not set (earlier than the firmware's date): the sky fit through
    /// the room plan's unseen windows is off (the unknown emitters fit the daylight instead).
    pub const CLOCK_UNSET: u16 = 1 << 5;
}

/// Live-light flags per desk (input 4100 + k); the same bits as `crate::live::flags`.
pub mod live_flags {
    /// Something covers the desk now: the value is held.
    pub const OCCLUDED: u16 = 1 << 0;
    /// The daylight part is the last good one (see the frame age).
    pub const HELD: u16 = 1 << 1;
    /// No fresh frame for longer than the stale limit.
    pub const STALE: u16 = 1 << 2;
    /// The last frame was rejected.
    pub const BAD_FRAME: u16 = 1 << 3;
    /// The desk's window (or the frame) is saturated.
    pub const SATURATED: u16 = 1 << 4;
    /// A luminaire lighting this desk aged below the maintenance factor.
    pub const AGEING: u16 = 1 << 5;
    /// The desk's surroundings changed for good: recommissioning advised.
    pub const GEOMETRY_CHANGED: u16 = 1 << 6;
    /// No depth frame: covering judged from luminance alone.
    pub const NO_DEPTH: u16 = 1 << 7;
    /// The node cannot estimate this desk's value now (its computation gave no finite
    /// number): the value and its uncertainty are published as not available (NaN, 0xFFFF),
    /// never as a number.
    pub const NOT_ESTIMATED: u16 = 1 << 8;
    /// With [`NOT_ESTIMATED`]: by day, the daylight at this desk is not bounded by what the
    /// cameras see (no room plan; light may enter through windows out of view), so the total
    /// and the daylight are not available; the artificial part is the model's. A room plan
    /// with the windows (`--room-plan`) removes it. Also before the camera's first frame was
    /// taken (boot, a camera that never answered, every frame refused): the daylight is not
    /// known at all, day or night.
    pub const DAYLIGHT_UNKNOWN: u16 = 1 << 9;
    /// With [`DAYLIGHT_UNKNOWN`]: the sun may be on this desk now, by a strength no camera
    /// sees (the desk out of view, covered or saturated, and as near the windows as a sun
    /// patch a camera sees, or in the beam the room plan's windows trace). Another node's
    /// inferred value of the same desk does not know of that sun either and is not a
    /// substitute; only a node that measures the desk is.
    pub const SUN_MAY_REACH: u16 = 1 << 10;
}

/// Where a desk's live value comes from (input 3900 + k).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u16)]
pub enum LiveSource {
    /// The model's artificial light only (no usable frame yet, or live light off).
    #[default]
    Model = 0,
    /// Measured by the camera on the desk top.
    Measured = 1,
    /// Inferred: the model's light plus daylight propagated from what the camera sees.
    Inferred = 2,
}

/// One desk's live value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveDesk {
    /// Total, lx (not finite: not available).
    pub total_lx: f64,
    /// The luminaires' part, lx.
    pub artificial_lx: f64,
    /// Daylight (extraneous) part, lx.
    pub daylight_lx: f64,
    /// Standard uncertainty of the total, lx.
    pub uncertainty_lx: f64,
    /// Source.
    pub source: LiveSource,
    /// [`live_flags`].
    pub flags: u16,
    /// Age of the frame the daylight comes from, s.
    pub frame_age_s: f64,
}

impl Default for LiveDesk {
    fn default() -> Self {
        Self {
            total_lx: f64::NAN,
            artificial_lx: f64::NAN,
            daylight_lx: f64::NAN,
            uncertainty_lx: f64::NAN,
            source: LiveSource::Model,
            flags: 0,
            frame_age_s: f64::NAN,
        }
    }
}

/// The live-light registers (`crate::live`): per desk total, artificial and daylight lux with
/// source, flags and frame age; per luminaire the ageing factor. Only aggregates: no image
/// leaves the node.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LiveRegisters {
    /// Per desk (empty: live light off; the blocks then read "not available").
    pub desks: heapless::Vec<LiveDesk, MAX_DESKS>,
    /// Ageing factor per luminaire (empty: all 1).
    pub ageing: heapless::Vec<f64, MAX_LUMINAIRES>,
    /// [`live_status`] bits.
    pub status: u16,
    /// Age of the last frame used, s (not finite: none yet).
    pub last_frame_age_s: f64,
}

/// A lux value as a rounded, saturating u16 ([`NOT_AVAILABLE_U16`] when not finite).
pub fn lux_u16(lux: f64) -> u16 {
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
}

/// Seconds as a saturating u16 ([`NOT_AVAILABLE_U16`] when not finite).
fn seconds_u16(s: f64) -> u16 {
    if s.is_finite() {
        libm::round(s.clamp(0.0, 65534.0)) as u16
    } else {
        NOT_AVAILABLE_U16
    }
}

/// Control flags (input register 62).
pub mod control_flags {
    /// The plan assumes no daylight: the daylight estimate is stale or missing (safe side).
    pub const SAFE: u16 = 1 << 0;
    /// The planned levels could not be delivered (the gateway is lost).
    pub const NOT_DELIVERED: u16 = 1 << 1;
    /// A plan that only saves power is waiting out the dim hold.
    pub const HOLDING: u16 = 1 << 2;
}

/// Largest target a desk may be given, lx.
pub const MAX_TARGET_LX: u16 = 10_000;

/// The lighting-control registers (`crate::control`): mode and targets (written by the BMS or
/// the board file), what the plan achieves, and the power.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ControlRegisters {
    /// Mode code (holding 2002): 0 off, 1 constant light, 2 daylight harvesting.
    pub mode: u16,
    /// Target per desk, lx (holding 2100 + k).
    pub targets_lx: heapless::Vec<u16, MAX_DESKS>,
    /// Per desk: 1 meets its target under the plan, 0 short, 65535 control off.
    pub met: heapless::Vec<u16, MAX_DESKS>,
    /// Desks short (input 61).
    pub short: u16,
    /// Flags (input 62).
    pub flags: u16,
    /// Power now, W.
    pub power_w: f64,
    /// Power with every luminaire at full, W.
    pub all_on_w: f64,
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
    /// Every configured server (TCP, TLS, RTU) is up (details at input 40..=51).
    pub const COMM_OK: u16 = 1 << 7;
    /// Writes are enabled for some sources (the board's allowlist is not empty).
    pub const WRITES_ENABLED: u16 = 1 << 8;
    /// The board's BBMD does not accept the node's foreign-device registration (its last
    /// attempt got no answer or a NAK; retried with backoff; local BACnet service goes on).
    pub const BBMD_FAILING: u16 = 1 << 9;
    /// A peripheral of the node (ambient light sensor, calibration EEPROM, status LED) is
    /// absent, stuck or gives bad readings (the log says which and why).
    pub const PERIPHERAL_FAULT: u16 = 1 << 12;
    /// The ambient light sensor disagrees with the model's prediction for the current dimming
    /// state by more than its tolerance (daylight, a failed luminaire, a changed room).
    pub const LIGHT_CHECK: u16 = 1 << 13;
}

/// Communication health (input 40..=51): what the servers and links are doing, so a BMS sees a
/// dead serial line or an attack without reading logs. Counters wrap at 65536.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CommHealth {
    /// 40: TCP (and TLS) connections open.
    pub tcp_open: u16,
    /// 41: connections refused at a cap (wraps).
    pub tcp_refused: u16,
    /// 42: idle connections evicted for a new one (wraps).
    pub tcp_evicted: u16,
    /// 43: RTU line: 0 not configured, 1 up, 2 down (being reopened).
    pub rtu_state: u16,
    /// 44: times the RTU line was reopened (wraps).
    pub rtu_reopens: u16,
    /// 45: RTU frames answered (wraps).
    pub rtu_answered: u16,
    /// 46: RTU frames discarded: CRC, short, overlong (wraps).
    pub rtu_discarded: u16,
    /// 47: DALI gateway poll failures (wraps).
    pub gateway_failures: u16,
    /// 48: writes executed (wraps).
    pub writes_accepted: u16,
    /// 49: writes refused: source not allowed (wraps).
    pub writes_refused: u16,
    /// 50: TLS: 0 not configured, 1 listening, 2 down.
    pub tls_state: u16,
    /// 51: TLS handshakes failed (wraps).
    pub tls_failed: u16,
}

impl CommHealth {
    fn get(&self, a: u16) -> u16 {
        match a - addr::COMM_FIRST {
            0 => self.tcp_open,
            1 => self.tcp_refused,
            2 => self.tcp_evicted,
            3 => self.rtu_state,
            4 => self.rtu_reopens,
            5 => self.rtu_answered,
            6 => self.rtu_discarded,
            7 => self.gateway_failures,
            8 => self.writes_accepted,
            9 => self.writes_refused,
            10 => self.tls_state,
            _ => self.tls_failed,
        }
    }
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

/// Byte order of 32-bit values over two registers (A = most significant byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WordOrder {
    /// High word first, big-endian words (ABCD), the default.
    #[default]
    Abcd = 0,
    /// Low word first (CDAB, "word swap").
    Cdab = 1,
    /// High word first, bytes swapped in each word (BADC, "byte swap").
    Badc = 2,
    /// Low word first, bytes swapped (DCBA, little-endian).
    Dcba = 3,
}

impl WordOrder {
    /// From the register value (holding 2000).
    pub fn from_code(c: u16) -> Option<Self> {
        Some(match c {
            0 => Self::Abcd,
            1 => Self::Cdab,
            2 => Self::Badc,
            3 => Self::Dcba,
            _ => return None,
        })
    }

    /// From its name, `abcd`, `cdab`, `badc` or `dcba` (any case).
    pub fn from_name(s: &str) -> Option<Self> {
        let mut b = [0u8; 4];
        if s.len() != 4 {
            return None;
        }
        for (d, c) in b.iter_mut().zip(s.bytes()) {
            *d = c.to_ascii_lowercase();
        }
        Some(match &b {
            b"abcd" => Self::Abcd,
            b"cdab" => Self::Cdab,
            b"badc" => Self::Badc,
            b"dcba" => Self::Dcba,
            _ => return None,
        })
    }

    /// The two registers of `bits`, first then second.
    pub fn words(self, bits: u32) -> [u16; 2] {
        let (hi, lo) = ((bits >> 16) as u16, bits as u16);
        match self {
            Self::Abcd => [hi, lo],
            Self::Cdab => [lo, hi],
            Self::Badc => [hi.swap_bytes(), lo.swap_bytes()],
            Self::Dcba => [lo.swap_bytes(), hi.swap_bytes()],
        }
    }
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
    /// Stated relative standard uncertainty of its modelled light from what commissioning
    /// inferred (not finite: not stated).
    pub model_rel_uncertainty: f64,
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
    /// Communication health (input 40..=51).
    pub comm: CommHealth,
    /// Lighting control.
    pub control: ControlRegisters,
    /// Live light.
    pub live: LiveRegisters,
    /// Occupancy.
    pub occupancy: OccupancyRegisters,
}

/// What a request changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Effect {
    /// Arc levels were written.
    pub arc_changed: bool,
    /// Configuration (word order, curve) was written.
    pub config_changed: bool,
    /// The control mode or a desk target was written.
    pub control_changed: bool,
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
        } else if (addr::COMM_FIRST..=addr::COMM_LAST).contains(&a) {
            self.comm.get(a)
        } else if (addr::CONTROL_MODE_IN_EFFECT..=addr::CONTROL_LAST).contains(&a) {
            let c = &self.control;
            let float = |v: f64, word: u16| {
                let bits = if v.is_finite() {
                    (v as f32).to_bits()
                } else {
                    NOT_AVAILABLE_F32
                };
                self.word_order.words(bits)[usize::from(word)]
            };
            match a {
                addr::CONTROL_MODE_IN_EFFECT => c.mode,
                addr::CONTROL_SHORT => c.short,
                addr::CONTROL_FLAGS => c.flags,
                63 | 64 => float(c.power_w, a - addr::POWER_NOW),
                65 | 66 => float(c.all_on_w, a - addr::POWER_ALL_ON),
                _ => {
                    if c.all_on_w > 0.0 && c.power_w.is_finite() {
                        let saved = 1000.0 * (1.0 - c.power_w / c.all_on_w);
                        libm::round(saved.clamp(0.0, 1000.0)) as u16
                    } else {
                        NOT_AVAILABLE_U16
                    }
                }
            }
        } else if a == addr::LIVE_STATUS {
            self.live.status
        } else if a == addr::LIVE_LAST_FRAME_AGE {
            seconds_u16(self.live.last_frame_age_s)
        } else if a == addr::OCCUPANCY_STATUS {
            self.occupancy.status
        } else if a == addr::PEOPLE {
            self.occupancy.people.unwrap_or(NOT_AVAILABLE_U16)
        } else if a == addr::OCCUPANCY_HOLD {
            seconds_u16(self.occupancy.hold_s)
        } else if in_block(addr::DESK_OCCUPIED, d) {
            self.occupancy_desk(a - addr::DESK_OCCUPIED).state as u16
        } else if in_block(addr::DESK_OCCUPANCY_FLAGS, d) {
            self.occupancy_desk(a - addr::DESK_OCCUPANCY_FLAGS).flags
        } else if (addr::LIVE_TOTAL_FLOAT..addr::AGEING + l).contains(&a) {
            return self.read_live(a, d, l);
        } else if in_block(addr::DESK_MODEL_UNCERTAINTY, d) {
            let u = self.desks[usize::from(a - addr::DESK_MODEL_UNCERTAINTY)].model_rel_uncertainty;
            if u.is_finite() && u >= 0.0 {
                libm::round((1000.0 * u).min(65534.0)) as u16
            } else {
                NOT_AVAILABLE_U16
            }
        } else if in_block(addr::DESK_MET, self.control.met.len() as u16) {
            self.control.met[usize::from(a - addr::DESK_MET)]
        } else if in_block(addr::DESK_FLOAT, 2 * d) {
            let off = a - addr::DESK_FLOAT;
            let bits = self.float_bits(usize::from(off / 2));
            self.word_order.words(bits)[usize::from(off % 2)]
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
            // stale says why a value is missing: the dimming state is not known yet
            if desk.lux.is_finite() || desk.quality == Quality::Stale {
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
        } else if space == Space::Holding && a == addr::CONTROL_MODE {
            self.control.mode
        } else if space == Space::Holding
            && in_block(addr::DESK_TARGET, self.control.targets_lx.len() as u16)
        {
            self.control.targets_lx[usize::from(a - addr::DESK_TARGET)]
        } else {
            return None;
        };
        Some(v)
    }

    /// Desk k's occupancy (unknown when occupancy is off).
    pub fn occupancy_desk(&self, k: u16) -> OccupancyDesk {
        self.occupancy
            .desks
            .get(usize::from(k))
            .copied()
            .unwrap_or_default()
    }

    /// The live blocks (3000..): `None` outside them.
    fn read_live(&self, a: u16, d: u16, l: u16) -> Option<u16> {
        let live = &self.live;
        let desk = |k: u16| live.desks.get(usize::from(k)).copied().unwrap_or_default();
        let float = |v: f64, word: u16| {
            let bits = if v.is_finite() {
                (v as f32).to_bits()
            } else {
                NOT_AVAILABLE_F32
            };
            self.word_order.words(bits)[usize::from(word)]
        };
        let in_block = |base: u16, count: u16| a >= base && a < base.saturating_add(count);
        let v = if in_block(addr::LIVE_TOTAL_FLOAT, 2 * d) {
            let o = a - addr::LIVE_TOTAL_FLOAT;
            float(desk(o / 2).total_lx, o % 2)
        } else if in_block(addr::LIVE_ARTIFICIAL_FLOAT, 2 * d) {
            let o = a - addr::LIVE_ARTIFICIAL_FLOAT;
            float(desk(o / 2).artificial_lx, o % 2)
        } else if in_block(addr::LIVE_DAYLIGHT_FLOAT, 2 * d) {
            let o = a - addr::LIVE_DAYLIGHT_FLOAT;
            float(desk(o / 2).daylight_lx, o % 2)
        } else if in_block(addr::LIVE_TOTAL_U16, d) {
            lux_u16(desk(a - addr::LIVE_TOTAL_U16).total_lx)
        } else if in_block(addr::LIVE_ARTIFICIAL_U16, d) {
            lux_u16(desk(a - addr::LIVE_ARTIFICIAL_U16).artificial_lx)
        } else if in_block(addr::LIVE_DAYLIGHT_U16, d) {
            lux_u16(desk(a - addr::LIVE_DAYLIGHT_U16).daylight_lx)
        } else if in_block(addr::LIVE_SOURCE, d) {
            desk(a - addr::LIVE_SOURCE).source as u16
        } else if in_block(addr::LIVE_UNCERTAINTY, d) {
            lux_u16(desk(a - addr::LIVE_UNCERTAINTY).uncertainty_lx)
        } else if in_block(addr::LIVE_FLAGS, d) {
            desk(a - addr::LIVE_FLAGS).flags
        } else if in_block(addr::LIVE_FRAME_AGE, d) {
            seconds_u16(desk(a - addr::LIVE_FRAME_AGE).frame_age_s)
        } else if in_block(addr::AGEING, l) {
            let f = live
                .ageing
                .get(usize::from(a - addr::AGEING))
                .copied()
                .unwrap_or(1.0);
            if f.is_finite() {
                libm::round((1000.0 * f).clamp(0.0, 65534.0)) as u16
            } else {
                NOT_AVAILABLE_U16
            }
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
        let targets = self.control.targets_lx.len() as u16;
        let max = match address {
            addr::WORD_ORDER => 3,
            addr::DIMMING_CURVE => 1,
            addr::CONTROL_MODE => 2,
            a if a >= addr::DESK_TARGET && a < addr::DESK_TARGET + targets => MAX_TARGET_LX,
            _ => return Err(Exception::IllegalDataAddress),
        };
        if value <= max {
            Ok(())
        } else {
            Err(Exception::IllegalDataValue)
        }
    }

    fn apply_write(&mut self, address: u16, value: u16, effect: &mut Effect) {
        if address == addr::WORD_ORDER {
            self.word_order = WordOrder::from_code(value).unwrap_or_default();
            effect.config_changed = true;
        } else if address == addr::DIMMING_CURVE {
            self.curve = if value == 0 {
                DimmingCurve::Logarithmic
            } else {
                DimmingCurve::Linear
            };
            effect.config_changed = true;
        } else if address == addr::CONTROL_MODE {
            self.control.mode = value;
            effect.control_changed = true;
        } else if address >= addr::DESK_TARGET {
            if let Some(t) = self
                .control
                .targets_lx
                .get_mut(usize::from(address - addr::DESK_TARGET))
            {
                *t = value;
                effect.control_changed = true;
            }
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
        "bit 0 commissioned, 1 store healthy, 2 sensors healthy, 3 gateway configured, 4 gateway link up, 5 values stale (dimming state unknown: gateway lost, or not yet set since start), 6 compute error, 7 communication ok (every configured server up), 8 writes enabled for some sources, 9 BACnet BBMD not answering (the board's foreign-device registration got no answer or a NAK; retried with backoff; local BACnet service goes on), 12 peripheral fault (ambient light sensor, calibration EEPROM or status LED absent, stuck or bad), 13 ambient light disagrees with the model"
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
        "for this client: 0 ABCD, 1 CDAB, 2 BADC, 3 DCBA (holding 2000)"
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
        addr::COMM_FIRST,
        "12",
        "communication health",
        "u16 × 12",
        "",
        "1",
        "R",
        "40 TCP+TLS connections open, 41 refused at a cap, 42 idle connections evicted, 43 RTU line (0 none, 1 up, 2 down: reopening), 44 RTU reopens, 45 RTU frames answered, 46 RTU frames discarded, 47 gateway poll failures, 48 writes executed, 49 writes refused (source not allowed), 50 TLS (0 none, 1 listening, 2 down), 51 TLS handshakes failed; counters wrap at 65536"
    ),
    row!(
        Input,
        addr::DESK_FLOAT,
        "2 × D",
        "desk lux (float)",
        "float32, word order per client (holding 2000; ABCD default)",
        "lx",
        "1",
        "R",
        "desk k at 100 + 2k and 101 + 2k; NaN (0x7FC00000) when not available (never 0 for unknown: before the dimming state is first known, quality 1)"
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
        "desk k at 300 + k; 65535 when not available (as the float)"
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
        "desk k at 400 + k: 0 ok, 1 stale (dimming state unknown: never known since start, the lux NaN / 65535; or the gateway lost, the last good lux kept), 2 out of the camera's view, 3 estimated; 65535 not available"
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
        "0 ABCD, 1 CDAB, 2 BADC, 3 DCBA",
        "R/W",
        "word order of the desk floats as this client reads them (its own setting, persisted; the board file sets defaults per client and per unit id); other values are exception 0x03"
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
    row!(
        Holding,
        addr::CONTROL_MODE,
        "1",
        "lighting control mode",
        "u16",
        "",
        "0 off, 1 constant light, 2 daylight harvesting",
        "R/W",
        "off: the node commands nothing (the lights follow the arc levels written here or the gateway); constant light: every desk at its target from the luminaires alone, least power; daylight harvesting: the same with each desk's measured daylight; persisted; other values are exception 0x03"
    ),
    row!(
        Holding,
        addr::DESK_TARGET,
        "D",
        "desk target",
        "u16",
        "lx",
        "1, 0..=10000",
        "R/W",
        "desk k at 2100 + k: its maintained illuminance target (board default, EN 12464-1 office: 500 lx); persisted; above 10000 is exception 0x03"
    ),
    row!(
        Input,
        addr::CONTROL_MODE_IN_EFFECT,
        "1",
        "control mode in effect",
        "u16",
        "",
        "",
        "R",
        "mirror of holding 2002"
    ),
    row!(
        Input,
        addr::CONTROL_SHORT,
        "1",
        "desks short",
        "u16",
        "",
        "1",
        "R",
        "desks the control plan cannot bring to their target (the closest state is applied)"
    ),
    row!(
        Input,
        addr::CONTROL_FLAGS,
        "1",
        "control flags",
        "bits",
        "",
        "",
        "R",
        "bit 0 safe plan (no daylight estimate: planned without daylight), 1 levels not delivered (gateway lost), 2 a power-saving plan waits out the dim hold"
    ),
    row!(
        Input,
        addr::POWER_NOW,
        "2",
        "power now",
        "float32, word order per client",
        "W",
        "1",
        "R",
        "electric power of the luminaires at the current levels (standby of those off included)"
    ),
    row!(
        Input,
        addr::POWER_ALL_ON,
        "2",
        "power all on",
        "float32, word order per client",
        "W",
        "1",
        "R",
        "electric power with every luminaire at full (each at its rated power: the photometry file's wattage, as in the report; flux / 120 lm/W only where the file has none, with a warning; the board's `[control] rated_power_w` overrides)"
    ),
    row!(
        Input,
        addr::POWER_SAVED,
        "1",
        "power saved",
        "u16",
        "%",
        "0.1",
        "R",
        "power saved now against every luminaire at full; 65535 when not available"
    ),
    row!(
        Input,
        addr::DESK_MET,
        "D",
        "desk target met",
        "u16",
        "",
        "",
        "R",
        "desk k at 700 + k: 1 the control plan meets its target, 0 short, 65535 control off"
    ),
    row!(
        Input,
        addr::DESK_MODEL_UNCERTAINTY,
        "D",
        "desk model uncertainty",
        "u16",
        "%",
        "0.1",
        "R",
        "desk k at 800 + k: one relative standard uncertainty of the desk's modelled light in the current dimming state, from what commissioning inferred (walls, ceiling, floor and desk tops the cameras did not see; docs/commissioning.md); 65535 not stated (a CAD model)"
    ),
    row!(
        Input,
        addr::LIVE_STATUS,
        "1",
        "live status",
        "bits",
        "",
        "",
        "R",
        "live light: bit 0 on (the image has a live section and the board a camera), 1 camera stale (values held, then model only), 2 recommissioning advised (a large part of the room changed), 3 the last frame had no daylight, 4 the last frame was rejected, 5 the clock is not set (the sky fit through the plan's unseen windows is off)"
    ),
    row!(
        Input,
        addr::LIVE_LAST_FRAME_AGE,
        "1",
        "live frame age",
        "u16",
        "s",
        "1",
        "R",
        "age of the last camera frame live light used (saturating); 65535 none yet"
    ),
    row!(
        Input,
        addr::LIVE_TOTAL_FLOAT,
        "2D",
        "desk live total lux",
        "float32, word order per client",
        "lx",
        "1",
        "R",
        "desk k at 3000 + 2k: measured or inferred total (daylight included); NaN when not available (live light off)"
    ),
    row!(
        Input,
        addr::LIVE_ARTIFICIAL_FLOAT,
        "2D",
        "desk live artificial lux",
        "float32, word order per client",
        "lx",
        "1",
        "R",
        "desk k at 3200 + 2k: the luminaires' part at the current dimming state and ageing"
    ),
    row!(
        Input,
        addr::LIVE_DAYLIGHT_FLOAT,
        "2D",
        "desk live daylight lux",
        "float32, word order per client",
        "lx",
        "1",
        "R",
        "desk k at 3400 + 2k: daylight and any unmodelled light (total − artificial, ≥ 0)"
    ),
    row!(
        Input,
        addr::LIVE_TOTAL_U16,
        "D",
        "desk live total lux (u16)",
        "u16",
        "lx",
        "1",
        "R",
        "desk k at 3600 + k: as 3000 + 2k, rounded, saturating at 65534; 65535 not available"
    ),
    row!(
        Input,
        addr::LIVE_ARTIFICIAL_U16,
        "D",
        "desk live artificial lux (u16)",
        "u16",
        "lx",
        "1",
        "R",
        "desk k at 3700 + k: as 3200 + 2k, rounded"
    ),
    row!(
        Input,
        addr::LIVE_DAYLIGHT_U16,
        "D",
        "desk live daylight lux (u16)",
        "u16",
        "lx",
        "1",
        "R",
        "desk k at 3800 + k: as 3400 + 2k, rounded"
    ),
    row!(
        Input,
        addr::LIVE_SOURCE,
        "D",
        "desk live source",
        "enum",
        "",
        "",
        "R",
        "desk k at 3900 + k: 0 model only (no usable frame), 1 measured (the camera sees the desk top), 2 inferred (daylight propagated from what the camera sees)"
    ),
    row!(
        Input,
        addr::LIVE_UNCERTAINTY,
        "D",
        "desk live uncertainty",
        "u16",
        "lx",
        "1",
        "R",
        "desk k at 4000 + k: one standard uncertainty of the total"
    ),
    row!(
        Input,
        addr::LIVE_FLAGS,
        "D",
        "desk live flags",
        "bits",
        "",
        "",
        "R",
        "desk k at 4100 + k: bit 0 occluded (value held), 1 held (daylight from an older frame), 2 stale, 3 bad frame, 4 saturated, 5 ageing (a luminaire lighting it below the maintenance factor), 6 geometry changed (recommission), 7 no depth frame, 8 not estimated (the value is NaN / 0xFFFF), 9 daylight unknown (with 8: by day without a room plan, the daylight is not bounded by what the cameras see; the total and daylight are NaN / 0xFFFF, the artificial part is the model's), 10 sun may reach (with 9: a sun patch may lie on the desk, which no camera sees; another node's inferred value is no substitute, a node measuring the desk is)"
    ),
    row!(
        Input,
        addr::LIVE_FRAME_AGE,
        "D",
        "desk live frame age",
        "u16",
        "s",
        "1",
        "R",
        "desk k at 4200 + k: age of the frame its daylight comes from (saturating)"
    ),
    row!(
        Input,
        addr::AGEING,
        "L",
        "luminaire ageing factor",
        "u16",
        "",
        "0.001",
        "R",
        "luminaire j at 4300 + j: measured light over the commissioned model's (1000 = as commissioned), from night frames; it scales the luminaire in the control plant"
    ),
    row!(
        Input,
        addr::OCCUPANCY_STATUS,
        "1",
        "occupancy status",
        "bits",
        "",
        "",
        "R",
        "occupancy (docs/occupancy.md): bit 0 on (the image has desks and a live section, the board a depth camera), 1 depth stale (no usable depth frame for longer than live light's stale limit: the last good states are held for the hold time, then unknown), the last depth frame's faults: 2 missing or wrong size, 3 too few returns, 4 saturated, 5 the camera moved (does not register against the commissioned room)"
    ),
    row!(
        Input,
        addr::PEOPLE,
        "1",
        "people",
        "u16",
        "",
        "1",
        "R",
        "people the last good depth frame saw (at desks and elsewhere); 65535 not known (occupancy off, or depth stale)"
    ),
    row!(
        Input,
        addr::OCCUPANCY_HOLD,
        "1",
        "occupancy hold",
        "u16",
        "s",
        "1",
        "R",
        "the hold time in effect (board `[occupancy] hold_s`, default 900 s); 65535 occupancy off"
    ),
    row!(
        Input,
        addr::DESK_OCCUPIED,
        "D",
        "desk occupied",
        "enum",
        "",
        "",
        "R",
        "desk k at 4600 + k: 1 occupied (a person seen at the desk within the hold time), 0 vacant (nobody for the hold time, and the node sees at least 60 % of the desk's workstation zone), 65535 unknown (occupancy off, the zone not seen, no usable depth frame for longer than the hold, or a sensor on no desk); never 0 from a bad frame"
    ),
    row!(
        Input,
        addr::DESK_OCCUPANCY_FLAGS,
        "D",
        "desk occupancy flags",
        "bits",
        "",
        "",
        "R",
        "desk k at 4700 + k: bit 0 held (the hold's state, not the last frame's answer), 1 no desk (the sensor is on no desk top)"
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
         function, or a write from a source outside the board's write allowlist (the node is\n\
         read-only by default), 0x02 address not in the map or not writable, 0x03 value or quantity\n\
         out of range.\n\
         Over RTU the node answers only its own unit id and never a broadcast (unit 0), whose writes\n\
         it still executes when the allowlist admits \"rtu\"."
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> RegisterMap {
        let mut m = RegisterMap::default();
        for (k, (lux, u)) in [(523.25, 0.0456), (70000.0, 120.0), (f64::NAN, f64::NAN)]
            .into_iter()
            .enumerate()
        {
            let _ = m.desks.push(Desk {
                id: 10 + k as u32,
                lux,
                quality: Quality::Ok,
                model_rel_uncertainty: u,
            });
        }
        for j in 0..2 {
            let _ = m.luminaire_ids.push(j + 1);
            let _ = m.arc.push(254);
        }
        for t in [500, 300, 750] {
            let _ = m.control.targets_lx.push(t);
            let _ = m.control.met.push(NOT_AVAILABLE_U16);
        }
        m.control.power_w = 120.5;
        m.control.all_on_w = 480.0;
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
        assert_eq!(read(&mut m, 4, 0, 4), vec![4, 8, 0, 6, 0, 3, 0, 2, 0, 1]);
        // stated model uncertainty, 0.1 %: 4.56 % -> 46, saturating, not stated
        assert_eq!(
            read(&mut m, 4, addr::DESK_MODEL_UNCERTAINTY, 3),
            vec![4, 6, 0, 46, 0xFF, 0xFE, 0xFF, 0xFF]
        );
        assert_eq!(
            read(&mut m, 4, addr::DESK_MODEL_UNCERTAINTY + 3, 1),
            vec![0x84, 2]
        );
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
        // BADC and DCBA; 5 is not an order
        m.process(&[6, 0x07, 0xD0, 0, 2], &mut out).unwrap();
        assert_eq!(read(&mut m, 4, 100, 2), vec![4, 4, 0x02, 0x44, 0x00, 0xD0]);
        m.process(&[6, 0x07, 0xD0, 0, 3], &mut out).unwrap();
        assert_eq!(read(&mut m, 4, 100, 2), vec![4, 4, 0x00, 0xD0, 0x02, 0x44]);
        let (n, _) = m.process(&[6, 0x07, 0xD0, 0, 4], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x86, 3]);
        assert_eq!(read(&mut m, 4, 12, 1), vec![4, 2, 0, 3]);
        // communication health block
        m.comm.rtu_state = 2;
        m.comm.writes_refused = 9;
        assert_eq!(
            read(&mut m, 4, addr::COMM_FIRST + 3, 7),
            vec![4, 14, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 9]
        );
        assert_eq!(read(&mut m, 4, addr::COMM_LAST + 1, 1), vec![0x84, 2]);
    }

    #[test]
    fn exceptions() {
        let mut m = map();
        assert_eq!(read(&mut m, 4, 52, 1), vec![0x84, 2]); // gap
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

    #[test]
    fn control_registers_read_write_and_check() {
        let mut m = map();
        let mut out = [0u8; MAX_PDU];
        // mode 2, then desk 1's target 750 -> 400; 10001 lx and mode 3 are refused
        let (_, e) = m.process(&[6, 0x07, 0xD2, 0, 2], &mut out).unwrap();
        assert!(e.control_changed);
        assert_eq!(m.control.mode, 2);
        assert_eq!(
            read(&mut m, 4, addr::CONTROL_MODE_IN_EFFECT, 1),
            vec![4, 2, 0, 2]
        );
        let a = addr::DESK_TARGET + 1;
        m.process(&[6, (a >> 8) as u8, a as u8, 0x01, 0x90], &mut out)
            .unwrap();
        assert_eq!(m.control.targets_lx[1], 400);
        let (n, _) = m
            .process(&[6, (a >> 8) as u8, a as u8, 0x27, 0x11], &mut out)
            .unwrap();
        assert_eq!(&out[..n], &[0x86, 3]);
        let (n, _) = m.process(&[6, 0x07, 0xD2, 0, 3], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x86, 3]);
        assert_eq!(
            read(&mut m, 3, addr::DESK_TARGET, 3),
            vec![3, 6, 1, 0xF4, 1, 0x90, 2, 0xEE]
        );
        // power now 120.5 W = 0x42F10000, all on 480 W = 0x43F00000, saved 74.9 %
        assert_eq!(
            read(&mut m, 4, addr::POWER_NOW, 5),
            vec![4, 10, 0x42, 0xF1, 0, 0, 0x43, 0xF0, 0, 0, 0x02, 0xED]
        );
        // met: not available until the loop says, then 1 / 0
        assert_eq!(read(&mut m, 4, addr::DESK_MET, 1), vec![4, 2, 0xFF, 0xFF]);
        m.control.met[0] = 1;
        assert_eq!(read(&mut m, 4, addr::DESK_MET, 1), vec![4, 2, 0, 1]);
        assert_eq!(read(&mut m, 4, addr::DESK_MET + 3, 1), vec![0x84, 2]);
    }

    #[test]
    fn occupancy_registers_read_unknown_until_published() {
        let mut m = map();
        // occupancy off: every desk unknown, the count unknown, the status 0
        assert_eq!(
            read(&mut m, 4, addr::DESK_OCCUPIED, 3),
            vec![4, 6, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]
        );
        assert_eq!(
            read(&mut m, 4, addr::OCCUPANCY_STATUS, 3),
            vec![4, 6, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF]
        );
        // published: desk 0 occupied (held), desk 1 vacant, desk 2 unknown; 2 people
        for (state, flags) in [
            (Occupancy::Occupied, occupancy_flags::HELD),
            (Occupancy::Vacant, 0),
            (Occupancy::Unknown, occupancy_flags::NO_DESK),
        ] {
            let _ = m.occupancy.desks.push(OccupancyDesk { state, flags });
        }
        m.occupancy.people = Some(2);
        m.occupancy.status = occupancy_status::ON | occupancy_status::MOVED;
        m.occupancy.hold_s = 900.0;
        assert_eq!(
            read(&mut m, 4, addr::DESK_OCCUPIED, 3),
            vec![4, 6, 0, 1, 0, 0, 0xFF, 0xFF]
        );
        assert_eq!(
            read(&mut m, 3, addr::DESK_OCCUPANCY_FLAGS, 3),
            vec![3, 6, 0, 1, 0, 0, 0, 2]
        );
        assert_eq!(
            read(&mut m, 4, addr::OCCUPANCY_STATUS, 3),
            vec![4, 6, 0, 0x21, 0, 2, 0x03, 0x84]
        );
        // past the blocks (D = 3)
        assert_eq!(read(&mut m, 4, addr::DESK_OCCUPIED + 3, 1), vec![0x84, 2]);
        assert_eq!(
            read(&mut m, 4, addr::DESK_OCCUPANCY_FLAGS + 3, 1),
            vec![0x84, 2]
        );
        assert_eq!(read(&mut m, 4, addr::OCCUPANCY_HOLD + 1, 1), vec![0x84, 2]);
    }
}
