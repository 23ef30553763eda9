//! Motion over frames (issue 29 item 1): a single frame cannot tell a still, tall, solid thing
//! put down after commissioning (a coat stand with coats, a tall box on a chair) from a seated
//! person; over frames it can, because a person is never perfectly still. Pure logic over
//! [`OccupancyReport`]s, fed every good depth frame at the frame's time by the daemon
//! (`crate::daemon::occupancy`), before the hold.
//!
//! Each person a frame sees ([`PersonSeen`]) is matched to a *track*: the nearest track of the
//! last good frame within [`MotionSettings::match_m`] in plan. A track keeps an *anchor*: the
//! mean of its head's sightings (plan centre of the cap, and top) since it last moved, which
//! the depth noise of one frame hardly shifts. The head has *moved* when a frame sees it
//! farther from the anchor than [`MotionSettings::still_plan_m`] in plan or
//! [`MotionSettings::still_height_m`] in height; the anchor then starts again from that
//! sighting. A track whose head has not moved for [`MotionSettings::static_after_s`] is a
//! *static object*: not counted as a person, and its desk reads **unknown** (not vacant)
//! unless a moving person is there too. Fail bright: a person who sat perfectly still for that
//! long keeps the light at its target (the control loop's answer for unknown) and is counted
//! again at their first move; a still thing is taken for a person for that time after it last
//! moved, no longer; and nothing here ever makes a desk vacant.
//!
//! A track not matched in a good frame ends (its person left or was missed: a new track starts
//! when it is seen again, its clock from zero, which again errs to "person"). A bad frame
//! (status not 0) is skipped: the tracks wait.

use super::{OccupancyError, OccupancyReport, Occupied, PersonSeen};

/// The knobs (defaults: docs/occupancy.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSettings {
    /// A head not moved for this long is a static object, s.
    pub static_after_s: f64,
    /// Moved: a sighting of the head farther from its anchor than this in plan, m ...
    pub still_plan_m: f64,
    /// ... or its top farther than this in height, m.
    pub still_height_m: f64,
    /// A person is the same track as the last frame's nearest within this, m.
    pub match_m: f64,
}

impl Default for MotionSettings {
    fn default() -> Self {
        Self {
            static_after_s: 1800.0,
            still_plan_m: 0.03,
            still_height_m: 0.03,
            match_m: 0.3,
        }
    }
}

impl MotionSettings {
    fn validate(&self) -> Result<(), OccupancyError> {
        let within = |x: f64, lo: f64, hi: f64| x.is_finite() && (lo..=hi).contains(&x);
        let ok = within(self.static_after_s, 1.0, 86_400.0)
            && within(self.still_plan_m, 0.0, 1.0)
            && within(self.still_height_m, 0.0, 1.0)
            && within(self.match_m, 0.0, 5.0);
        if ok {
            Ok(())
        } else {
            Err(OccupancyError::Input(format!("motion settings {self:?}")))
        }
    }
}

/// A head followed over frames.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Track {
    /// The last frame's sighting (its desk, for the answer).
    seen: PersonSeen,
    /// The sum of the sightings since it last moved: plan x, y and top, m.
    sum_m: [f64; 3],
    /// Their number.
    n: f64,
    /// When it last moved (or was first seen), s.
    moved_s: f64,
}

impl Track {
    fn new(p: PersonSeen, now_s: f64) -> Self {
        Self {
            seen: p,
            sum_m: [p.x_m, p.y_m, p.top_m],
            n: 1.0,
            moved_s: now_s,
        }
    }

    /// The mean of the sightings since it last moved, m.
    fn anchor_m(&self) -> [f64; 3] {
        self.sum_m.map(|x| x / self.n)
    }

    /// This frame's sighting of the track's head.
    fn follow(&mut self, p: PersonSeen, now_s: f64, s: &MotionSettings) {
        let [x, y, z] = self.anchor_m();
        let plan_m = (p.x_m - x).hypot(p.y_m - y);
        if plan_m > s.still_plan_m || (p.top_m - z).abs() > s.still_height_m {
            *self = Self::new(p, now_s);
        } else {
            self.seen = p;
            for (m, v) in self.sum_m.iter_mut().zip([p.x_m, p.y_m, p.top_m]) {
                *m += v;
            }
            self.n += 1.0;
        }
    }

    fn is_static(&self, now_s: f64, s: &MotionSettings) -> bool {
        now_s - self.moved_s >= s.static_after_s
    }
}

/// Motion over a node's frames.
#[derive(Debug, Clone)]
pub struct Motion {
    settings: MotionSettings,
    tracks: Vec<Track>,
}

impl Motion {
    /// Motion with `settings`.
    pub fn new(settings: MotionSettings) -> Result<Self, OccupancyError> {
        settings.validate()?;
        Ok(Self {
            settings,
            tracks: Vec::new(),
        })
    }

    /// The frame taken at `now_s` (monotonic s): its people into the tracks, and the report
    /// with static objects taken out (the people count lowered; a desk whose only people are
    /// static objects unknown). A bad frame passes unchanged.
    pub fn update(&mut self, now_s: f64, report: &mut OccupancyReport) {
        if report.status != 0 || !now_s.is_finite() {
            return;
        }
        self.track(now_s, &report.persons);
        let s = self.settings;
        let mut moving = vec![false; report.desks.len()];
        let mut still = vec![false; report.desks.len()];
        let mut statics = 0usize;
        for t in &self.tracks {
            let mark = if t.is_static(now_s, &s) {
                statics += 1;
                &mut still
            } else {
                &mut moving
            };
            if let Some(m) = t.seen.desk.and_then(|k| mark.get_mut(k)) {
                *m = true;
            }
        }
        for (k, d) in report.desks.iter_mut().enumerate() {
            if d.state == Occupied::Yes && still[k] && !moving[k] {
                d.state = Occupied::Unknown;
            }
        }
        let n = u16::try_from(statics).unwrap_or(u16::MAX);
        report.people = report.people.saturating_sub(n);
    }

    /// Matches this frame's people to the tracks (nearest first); unmatched tracks end,
    /// unmatched people start new ones.
    fn track(&mut self, now_s: f64, persons: &[PersonSeen]) {
        let s = self.settings;
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (i, t) in self.tracks.iter().enumerate() {
            for (j, p) in persons.iter().enumerate() {
                let d_m = (p.x_m - t.seen.x_m).hypot(p.y_m - t.seen.y_m);
                if d_m <= s.match_m {
                    pairs.push((d_m, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (mut track_of, mut taken) = (vec![None; persons.len()], vec![false; self.tracks.len()]);
        for (_, i, j) in pairs {
            if !taken[i] && track_of[j].is_none() {
                taken[i] = true;
                track_of[j] = Some(i);
            }
        }
        let mut next = Vec::with_capacity(persons.len());
        for (p, t) in persons.iter().zip(track_of) {
            next.push(match t {
                Some(i) => {
                    let mut t = self.tracks[i];
                    t.follow(*p, now_s, &s);
                    t
                }
                None => Track::new(*p, now_s),
            });
        }
        self.tracks = next;
    }

    /// Tracks now followed (heads seen in the last good frame).
    pub fn tracks(&self) -> usize {
        self.tracks.len()
    }
}

#[cfg(test)]
mod tests;
