//! Occupancy in the live task (issue 29): every depth frame the live task takes goes through
//! [`Occupancy`] against the commissioned room, motion over frames ([`Motion`]: a head that has
//! not moved for the board's `[occupancy] static_after_s`, 30 min by default, is a thing, not
//! a person) and the answer through the board's hold
//! ([`Hold`], `[occupancy] hold_s`) at the frame's time; the node gets per desk sensor its
//! desk's state after the hold (occupied, vacant, unknown), the people count and the status
//! ([`crate::modbus::regmap::occupancy_status`]), which every protocol reads.
//!
//! Bad input is never "vacant": a camera error, a frame without depth, a depth frame of the
//! wrong size, all zeros, saturated or from a camera that moved, and a frame older than live
//! light's stale limit are all an unknown answer for every desk (with the frame's status bit);
//! the hold keeps the last good state for the hold time, then unknown. No usable depth frame
//! for longer than the stale limit sets the stale bit and makes the people count unknown.
//!
//! The map ([`crate::occupancy::OccupancyMap`]) is built at boot from the image by the caller;
//! this file only runs it, so the live task's path stays off the commissioning side.

use super::live::CapturedFrame;
use crate::modbus::regmap::occupancy_status as bits;
use crate::modbus::regmap::{Occupancy as DeskState, OccupancyDesk, occupancy_flags};
use crate::node::Node;
use crate::occupancy::{
    HeldDesk, Hold, Motion, MotionSettings, Occupancy, OccupancyError, OccupancyMap,
    OccupancyReport, Occupied, status,
};

/// What one period publishes: per desk sensor its registers, the people count (`None`: not
/// known) and the status bits.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyUpdate {
    /// Per desk sensor, the node's desk order.
    pub desks: Vec<OccupancyDesk>,
    /// People the last good depth frame saw, while it is fresh.
    pub people: Option<u16>,
    /// [`crate::modbus::regmap::occupancy_status`] bits.
    pub status: u16,
}

/// Occupancy and its hold over a node's desks.
#[derive(Debug, Clone)]
pub struct OccupancyTracker {
    occupancy: Occupancy,
    motion: Motion,
    hold: Hold,
    hold_s: f64,
    stale_after_s: f64,
    /// Per desk sensor (the node's desk order), its desk in the map (`None`: on no desk top).
    sensor_desk: Vec<Option<usize>>,
    /// When the last good depth frame was taken (task clock, s), and its people count.
    last_good: Option<(f64, u16)>,
}

impl OccupancyTracker {
    /// Occupancy over `map` for the desk sensors `sensor_desk` (per sensor its desk in the
    /// map), held `hold_s` (0..=86 400 s); a depth frame older than `stale_after_s` (live
    /// light's stale limit, > 0) is not used.
    pub fn new(
        map: OccupancyMap,
        sensor_desk: Vec<Option<usize>>,
        hold_s: f64,
        stale_after_s: f64,
    ) -> Result<Self, OccupancyError> {
        if !(stale_after_s.is_finite() && stale_after_s > 0.0) {
            return Err(OccupancyError::Input(format!(
                "stale limit {stale_after_s} s must be a positive number of seconds"
            )));
        }
        let desks = map.desks().len();
        if let Some(k) = sensor_desk.iter().flatten().find(|&&k| k >= desks) {
            return Err(OccupancyError::Input(format!(
                "a sensor on desk {k} of a map of {desks} desks"
            )));
        }
        Ok(Self {
            hold: Hold::new(desks, hold_s)?,
            motion: Motion::new(MotionSettings::default())?,
            occupancy: Occupancy::new(map),
            hold_s,
            stale_after_s,
            sensor_desk,
            last_good: None,
        })
    }

    /// The same tracker with motion over frames set by `settings` (the default:
    /// [`MotionSettings::default`]).
    pub fn with_motion(mut self, settings: MotionSettings) -> Result<Self, OccupancyError> {
        self.motion = Motion::new(settings)?;
        Ok(self)
    }

    /// Publishes "on, nothing known yet" (every desk unknown, stale): the state before the
    /// first frame.
    pub fn publish_start(&self, node: &mut Node) {
        let desks: Vec<OccupancyDesk> = self
            .sensor_desk
            .iter()
            .map(|d| OccupancyDesk {
                state: DeskState::Unknown,
                flags: if d.is_none() {
                    occupancy_flags::NO_DESK
                } else {
                    0
                },
            })
            .collect();
        node.set_occupancy(&desks, None, bits::ON | bits::STALE, self.hold_s);
    }

    /// One period of the live task: the frame (or the camera's error), taken at `taken_s`, at
    /// `now_s` (both on the task's clock), into the node. Returns the status bits published.
    pub fn step(
        &mut self,
        frame: Result<&CapturedFrame, &String>,
        taken_s: f64,
        node: &mut Node,
        now_s: f64,
    ) -> u16 {
        let u = self.update(frame, taken_s, now_s);
        self.publish(&u, node);
        u.status
    }

    /// [`Self::step`] without the node: the frame through occupancy and the hold (the work;
    /// the live task does it before it takes the node's lock).
    pub fn update(
        &mut self,
        frame: Result<&CapturedFrame, &String>,
        taken_s: f64,
        now_s: f64,
    ) -> OccupancyUpdate {
        let fresh = |t: f64| t.is_finite() && now_s - t <= self.stale_after_s;
        let (mut report, at_s) = match frame {
            Ok(f) if fresh(taken_s) => (
                self.occupancy
                    .update(f.width, f.height, f.depth_mm.as_deref()),
                taken_s,
            ),
            // no frame, or one too old to say anything of now
            _ => (unknown(status::BAD_FRAME), now_s),
        };
        self.motion.update(at_s, &mut report);
        if report.status == 0 {
            self.last_good = Some((at_s, report.people));
        }
        let held = self.hold.update(at_s, &report);
        let mut out = bits::ON | frame_bits(report.status);
        let people = match self.last_good {
            Some((t, n)) if fresh(t) => Some(n),
            _ => {
                out |= bits::STALE;
                None
            }
        };
        let desks = self
            .sensor_desk
            .iter()
            .map(|d| desk_register(d.and_then(|k| held.get(k)), d.is_some()))
            .collect();
        OccupancyUpdate {
            desks,
            people,
            status: out,
        }
    }

    /// An update into the node (a few microseconds under its lock).
    pub fn publish(&self, u: &OccupancyUpdate, node: &mut Node) {
        node.set_occupancy(&u.desks, u.people, u.status, self.hold_s);
    }

    /// Bytes held: the map and the per-frame buffers.
    pub fn memory_bytes(&self) -> usize {
        self.occupancy.memory_bytes()
    }
}

/// Every desk unknown (the hold takes desks a report lacks as unknown), with `status`.
fn unknown(status: u16) -> OccupancyReport {
    OccupancyReport {
        desks: Vec::new(),
        people: 0,
        persons: Vec::new(),
        status,
    }
}

/// The register bits of an update's [`status`] bits.
fn frame_bits(s: u16) -> u16 {
    [
        (status::BAD_FRAME, bits::BAD_FRAME),
        (status::NO_RETURN, bits::NO_RETURN),
        (status::SATURATED, bits::SATURATED),
        (status::MOVED, bits::MOVED),
    ]
    .iter()
    .filter(|(from, _)| s & from != 0)
    .fold(0, |acc, (_, to)| acc | to)
}

/// A desk sensor's registers from its desk's held state (`None`: unknown).
fn desk_register(held: Option<&HeldDesk>, on_desk: bool) -> OccupancyDesk {
    let state = match held.map(|h| h.state) {
        Some(Occupied::Yes) => DeskState::Occupied,
        Some(Occupied::No) => DeskState::Vacant,
        Some(Occupied::Unknown) | None => DeskState::Unknown,
    };
    let mut flags = 0;
    if held.is_some_and(|h| h.held) {
        flags |= occupancy_flags::HELD;
    }
    if !on_desk {
        flags |= occupancy_flags::NO_DESK;
    }
    OccupancyDesk { state, flags }
}
