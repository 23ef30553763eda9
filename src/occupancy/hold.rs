//! The hold time over single-frame answers (issue 29; DALI-2 part 303's hold, 15 min by
//! default): a desk stays occupied for the hold after its person was last seen, and a bad frame
//! or an unseen desk keeps the last answer for the hold, then becomes unknown. Pure logic over
//! [`OccupancyReport`]s; the daemon feeds it every depth frame at the frame's time
//! (`crate::daemon::occupancy`).

use super::{OccupancyError, OccupancyReport, Occupied};

/// The default hold, s (DALI-2 part 303: 15 min).
pub const DEFAULT_HOLD_S: f64 = 900.0;

/// One desk after the hold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldDesk {
    /// The state with the hold applied.
    pub state: Occupied,
    /// True when it is not this frame's answer but a held one.
    pub held: bool,
}

/// The hold over a node's desks.
#[derive(Debug, Clone)]
pub struct Hold {
    hold_s: f64,
    /// Per desk, when a person was last seen, s.
    last_yes_s: Vec<Option<f64>>,
    /// Per desk, the last answer (`1` or `0`) and when, s.
    last_answer: Vec<Option<(Occupied, f64)>>,
}

impl Hold {
    /// A hold of `hold_s` (0..=86 400 s) over `desks` desks.
    pub fn new(desks: usize, hold_s: f64) -> Result<Self, OccupancyError> {
        if !(hold_s.is_finite() && (0.0..=86_400.0).contains(&hold_s)) {
            return Err(OccupancyError::Input(format!(
                "hold {hold_s} s must be within 0..=86400 s"
            )));
        }
        Ok(Self {
            hold_s,
            last_yes_s: vec![None; desks],
            last_answer: vec![None; desks],
        })
    }

    /// The report of a frame taken at `now_s` (monotonic seconds), held. Desks the report
    /// lacks count as unknown.
    pub fn update(&mut self, now_s: f64, report: &OccupancyReport) -> Vec<HeldDesk> {
        let within = |t: Option<f64>| t.is_some_and(|t| now_s - t <= self.hold_s);
        let mut out = Vec::with_capacity(self.last_yes_s.len());
        for k in 0..self.last_yes_s.len() {
            let now = report.desks.get(k).map_or(Occupied::Unknown, |d| d.state);
            let held = match now {
                Occupied::Yes => {
                    self.last_yes_s[k] = Some(now_s);
                    self.last_answer[k] = Some((Occupied::Yes, now_s));
                    HeldDesk {
                        state: Occupied::Yes,
                        held: false,
                    }
                }
                Occupied::No => {
                    self.last_answer[k] = Some((Occupied::No, now_s));
                    let recent = within(self.last_yes_s[k]);
                    HeldDesk {
                        state: if recent { Occupied::Yes } else { Occupied::No },
                        held: recent,
                    }
                }
                Occupied::Unknown => match self.last_answer[k] {
                    Some((state, t)) if within(Some(t)) => HeldDesk { state, held: true },
                    _ if within(self.last_yes_s[k]) => HeldDesk {
                        state: Occupied::Yes,
                        held: true,
                    },
                    _ => HeldDesk {
                        state: Occupied::Unknown,
                        held: false,
                    },
                },
            };
            out.push(held);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::occupancy::DeskOccupancy;

    fn report(states: &[Occupied], status: u16) -> OccupancyReport {
        OccupancyReport {
            desks: states
                .iter()
                .enumerate()
                .map(|(k, &state)| DeskOccupancy {
                    id: k as u32,
                    state,
                    seen_fraction: 1.0,
                })
                .collect(),
            people: 0,
            persons: Vec::new(),
            status,
        }
    }

    use Occupied::{No, Unknown, Yes};

    fn states(h: &[HeldDesk]) -> Vec<(Occupied, bool)> {
        h.iter().map(|d| (d.state, d.held)).collect()
    }

    #[test]
    fn a_desk_stays_occupied_for_the_hold_after_its_person_leaves() {
        let mut h = Hold::new(2, 900.0).unwrap();
        assert_eq!(
            states(&h.update(0.0, &report(&[Yes, No], 0))),
            [(Yes, false), (No, false)]
        );
        // gone, within the hold: still occupied, held
        assert_eq!(
            states(&h.update(899.0, &report(&[No, No], 0))),
            [(Yes, true), (No, false)]
        );
        // the hold over: vacant
        assert_eq!(
            states(&h.update(901.0, &report(&[No, No], 0))),
            [(No, false), (No, false)]
        );
    }

    #[test]
    fn a_bad_frame_keeps_the_last_answer_for_the_hold_then_unknown() {
        let mut h = Hold::new(2, 60.0).unwrap();
        h.update(0.0, &report(&[Yes, No], 0));
        let bad = report(&[Unknown, Unknown], crate::occupancy::status::MOVED);
        assert_eq!(states(&h.update(30.0, &bad)), [(Yes, true), (No, true)]);
        assert_eq!(
            states(&h.update(61.0, &bad)),
            [(Unknown, false), (Unknown, false)]
        );
        // never an answer: unknown, never vacant
        let mut fresh = Hold::new(1, 60.0).unwrap();
        assert_eq!(
            states(&fresh.update(0.0, &report(&[Unknown], 0))),
            [(Unknown, false)]
        );
        // a report missing desks: unknown for them
        assert_eq!(
            states(&fresh.update(1.0, &report(&[], 0))),
            [(Unknown, false)]
        );
    }

    #[test]
    fn a_hold_out_of_range_is_refused() {
        for s in [-1.0, f64::NAN, f64::INFINITY, 1e6] {
            assert!(Hold::new(1, s).is_err(), "{s}");
        }
        assert!(Hold::new(1, DEFAULT_HOLD_S).is_ok());
    }
}
