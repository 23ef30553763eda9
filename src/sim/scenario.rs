//! A scripted day in the simulated room, for live light and the HIL rig: daylight through the
//! window from sunrise to sunset with passing clouds, people at desks, an ageing luminaire, a
//! moved desk, a camera that fails. A [`Scenario`] gives the world's [`WorldExtras`] at any time
//! since it started ([`SimWorld::start_scenario`](crate::sim::camera::SimWorld::start_scenario)).
//!
//! File format (TOML; the sim board names it with `[camera.sim] scenario = "FILE"`):
//!
//! ```toml
//! [day]                        # optional: no [day], no daylight
//! seconds_per_hour = 2.0       # the simulated day's pace (wall-clock seconds per hour)
//! start_hour = 5.0             # the hour at time 0
//! sunrise_hour = 6.0
//! sunset_hour = 18.0
//! noon_exitance_lm_m2 = 3000.0 # the window's exitance at solar noon, clear
//!
//! [[events]]                   # at_s: seconds since the scenario started
//! at_s = 10.0
//! kind = "person"              # person | person_leaves | sits | gets_up | stands | age |
//!                              # move_desk | clouds | camera_fails
//! desk = 3                     # person, person_leaves, sits, gets_up, move_desk: a desk id
//! # stands: x_m = 2.9, y_m = 2.9, duration_s = 8.0 (a person standing there, in plan)
//! # age: luminaire = 2, factor = 0.8
//! # move_desk: dx_m = 0.8, dy_m = 0.0
//! # clouds: factor = 0.3, duration_s = 5.0
//! # camera_fails: duration_s = 10.0 (0: for good)
//! ```
//!
//! Daylight: `W(h) = W_noon · sin(π (h − sunrise) / (sunset − sunrise))^1.3` between sunrise and
//! sunset, 0 outside, times the factor of any cloud passing.
//!
//! People: `person` is a box leaning over a desk's sensor (live light's occlusion, not a
//! person's shape); `sits` / `gets_up` and `stands` are people of solids the depth camera sees
//! as occupancy does (a seated person at the desk, one standing; [`super::people`]).

use std::path::Path;

use glam::DVec3;
use serde::Deserialize;

use super::camera::{Occluder, WorldExtras};
use crate::scene::Scene;

/// Why a scenario file was rejected.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ScenarioError {
    /// The file.
    pub path: String,
    /// What is wrong.
    pub message: String,
}

/// The simulated day.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Day {
    /// Wall-clock seconds per simulated hour.
    pub seconds_per_hour: f64,
    /// Hour at time 0.
    pub start_hour: f64,
    /// Sunrise, hour.
    pub sunrise_hour: f64,
    /// Sunset, hour.
    pub sunset_hour: f64,
    /// Window exitance at solar noon, lm/m².
    pub noon_exitance_lm_m2: f64,
}

/// What happens.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum EventKind {
    /// Someone leans over a desk (a box over its sensor, 0.5 × 0.4 m, up to 1.4 m).
    Person {
        /// Desk id.
        desk: u32,
    },
    /// They leave.
    PersonLeaves {
        /// Desk id.
        desk: u32,
    },
    /// A person sits down at a desk ([`super::people::seated`]).
    Sits {
        /// Desk id.
        desk: u32,
    },
    /// The person seated at a desk gets up and leaves.
    GetsUp {
        /// Desk id.
        desk: u32,
    },
    /// A person stands at (x, y) for `duration_s` ([`super::people::standing`]).
    Stands {
        /// Plan x, m.
        x_m: f64,
        /// Plan y, m.
        y_m: f64,
        /// How long, s.
        duration_s: f64,
    },
    /// A luminaire gives `factor` of its light from now on.
    Age {
        /// Luminaire id.
        luminaire: u32,
        /// Output factor.
        factor: f64,
    },
    /// A desk moves by (dx, dy) for good.
    MoveDesk {
        /// Desk id.
        desk: u32,
        /// Along x, m.
        dx_m: f64,
        /// Along y, m.
        dy_m: f64,
    },
    /// A cloud passes: the daylight is `factor` of itself for `duration_s`.
    Clouds {
        /// Daylight factor.
        factor: f64,
        /// How long, s.
        duration_s: f64,
    },
    /// Both cameras stop answering for `duration_s` (0: for good).
    CameraFails {
        /// How long, s.
        duration_s: f64,
    },
}

/// One event. (Unknown keys are refused by [`EventKind`]: serde cannot deny them on a struct
/// with a flattened field.)
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Event {
    /// When, s since the start.
    pub at_s: f64,
    /// What.
    #[serde(flatten)]
    pub kind: EventKind,
}

/// A scripted day.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// The daylight over the day (none: night all along).
    #[serde(default)]
    pub day: Option<Day>,
    /// Events in any order.
    #[serde(default)]
    pub events: Vec<Event>,
}

impl Scenario {
    /// Reads and checks a scenario file.
    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let bad = |message: String| ScenarioError {
            path: path.display().to_string(),
            message,
        };
        let len = std::fs::metadata(path)
            .map_err(|e| bad(format!("cannot read: {e}")))?
            .len();
        if len > 1 << 20 {
            return Err(bad(format!(
                "{len} bytes: a scenario file is at most 1 MiB"
            )));
        }
        let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let s: Scenario = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        s.validate().map_err(bad)?;
        Ok(s)
    }

    /// Checks the numbers.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(d) = &self.day {
            let ok = d.seconds_per_hour.is_finite()
                && d.seconds_per_hour > 0.0
                && d.seconds_per_hour < 1e5
                && [d.start_hour, d.sunrise_hour, d.sunset_hour]
                    .iter()
                    .all(|h| h.is_finite() && (0.0..=48.0).contains(h))
                && d.sunrise_hour < d.sunset_hour
                && d.noon_exitance_lm_m2.is_finite()
                && (0.0..=1e6).contains(&d.noon_exitance_lm_m2);
            if !ok {
                return Err(format!(
                    "[day]: {d:?}: seconds_per_hour > 0, hours in 0..=48 with sunrise before \
                     sunset, noon exitance in 0..=1e6 lm/m²"
                ));
            }
        }
        for e in &self.events {
            if !(e.at_s.is_finite() && e.at_s >= 0.0) {
                return Err(format!("event at {} s: a time ≥ 0 s", e.at_s));
            }
            match &e.kind {
                EventKind::Age { factor, .. }
                    if !(factor.is_finite() && (0.0..=2.0).contains(factor)) =>
                {
                    return Err(format!("age factor {factor}: 0..=2"));
                }
                EventKind::Clouds { factor, duration_s }
                    if !(factor.is_finite()
                        && (0.0..=1.0).contains(factor)
                        && duration_s.is_finite()
                        && *duration_s > 0.0) =>
                {
                    return Err(format!(
                        "clouds factor {factor} in 0..=1 for {duration_s} s > 0"
                    ));
                }
                EventKind::CameraFails { duration_s }
                    if !(duration_s.is_finite() && *duration_s >= 0.0) =>
                {
                    return Err(format!("camera_fails duration {duration_s} s ≥ 0"));
                }
                EventKind::Stands {
                    x_m,
                    y_m,
                    duration_s,
                } if !(x_m.is_finite()
                    && y_m.is_finite()
                    && x_m.abs() < 1e3
                    && y_m.abs() < 1e3
                    && duration_s.is_finite()
                    && *duration_s > 0.0) =>
                {
                    return Err(format!("stands at ({x_m}, {y_m}) m for {duration_s} s > 0"));
                }
                EventKind::MoveDesk { dx_m, dy_m, .. }
                    if !(dx_m.is_finite()
                        && dy_m.is_finite()
                        && dx_m.abs() < 50.0
                        && dy_m.abs() < 50.0) =>
                {
                    return Err(format!("move_desk by ({dx_m}, {dy_m}) m"));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// The simulated hour at time `t_s`.
    pub fn hour_at(&self, t_s: f64) -> Option<f64> {
        self.day
            .as_ref()
            .map(|d| d.start_hour + t_s / d.seconds_per_hour)
    }

    /// The window exitance at time `t_s`, lm/m².
    pub fn window_exitance_at(&self, t_s: f64) -> f64 {
        let Some(d) = &self.day else { return 0.0 };
        let h = d.start_hour + t_s / d.seconds_per_hour;
        let x = (h - d.sunrise_hour) / (d.sunset_hour - d.sunrise_hour);
        let clear = if (0.0..=1.0).contains(&x) {
            d.noon_exitance_lm_m2 * (std::f64::consts::PI * x).sin().max(0.0).powf(1.3)
        } else {
            0.0
        };
        let cloud = self
            .events
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::Clouds { factor, duration_s }
                    if t_s >= e.at_s && t_s < e.at_s + duration_s =>
                {
                    Some(factor)
                }
                _ => None,
            })
            .fold(1.0, f64::min);
        clear * cloud
    }

    /// The world's extras at time `t_s`.
    pub fn extras_at(&self, t_s: f64, scene: &Scene) -> WorldExtras {
        let mut events: Vec<&Event> = self.events.iter().filter(|e| e.at_s <= t_s).collect();
        events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        let mut x = WorldExtras {
            window_exitance_lm_m2: self.window_exitance_at(t_s),
            ageing: vec![1.0; scene.luminaires.len()],
            ..WorldExtras::default()
        };
        let mut people: Vec<u32> = Vec::new();
        let mut seated: Vec<u32> = Vec::new();
        let camera_xy = scene
            .camera
            .as_ref()
            .map_or([0.0; 2], |c| [c.position_m.x, c.position_m.y]);
        for e in events {
            match &e.kind {
                EventKind::Person { desk } => {
                    if !people.contains(desk) {
                        people.push(*desk);
                    }
                }
                EventKind::PersonLeaves { desk } => people.retain(|d| d != desk),
                EventKind::Sits { desk } => {
                    if !seated.contains(desk) {
                        seated.push(*desk);
                    }
                }
                EventKind::GetsUp { desk } => seated.retain(|d| d != desk),
                EventKind::Stands {
                    x_m,
                    y_m,
                    duration_s,
                } => {
                    if t_s < e.at_s + duration_s {
                        x.occluders.extend(super::people::standing(*x_m, *y_m, t_s));
                    }
                }
                EventKind::Age { luminaire, factor } => {
                    if let Some(k) = scene.luminaires.iter().position(|l| l.id == *luminaire) {
                        x.ageing[k] = *factor;
                    }
                }
                EventKind::MoveDesk { desk, dx_m, dy_m } => {
                    if let Some(d) = desk_of(scene, *desk) {
                        x.removed_groups.push(d.group.clone());
                        x.occluders.push(Occluder {
                            lo_m: DVec3::new(d.x_m[0] + dx_m, d.y_m[0] + dy_m, 0.0),
                            hi_m: DVec3::new(d.x_m[1] + dx_m, d.y_m[1] + dy_m, d.z_m),
                            rho: 0.45,
                        });
                    }
                }
                EventKind::CameraFails { duration_s } => {
                    if *duration_s == 0.0 || t_s < e.at_s + duration_s {
                        x.cameras_fail = true;
                    }
                }
                EventKind::Clouds { .. } => {}
            }
        }
        for desk in seated {
            if let Some(d) = desk_of(scene, desk) {
                x.occluders.extend(super::people::seated(d, camera_xy, t_s));
            }
        }
        for desk in people {
            // over the desk's sensor (the sensor with the desk's id, else the desk's centre)
            let centre = scene
                .sensors
                .iter()
                .find(|s| s.id == desk)
                .map(|s| s.position_m)
                .or_else(|| {
                    desk_of(scene, desk).map(|d| {
                        DVec3::new(
                            0.5 * (d.x_m[0] + d.x_m[1]),
                            0.5 * (d.y_m[0] + d.y_m[1]),
                            d.z_m,
                        )
                    })
                });
            if let Some(c) = centre {
                x.occluders.push(Occluder {
                    lo_m: DVec3::new(c.x - 0.25, c.y - 0.2, c.z + 0.05),
                    hi_m: DVec3::new(c.x + 0.25, c.y + 0.2, 1.4),
                    rho: 0.3,
                });
            }
        }
        x
    }
}

fn desk_of(scene: &Scene, id: u32) -> Option<&crate::scene::Desk> {
    scene.desks.as_ref()?.desks.iter().find(|d| d.id == id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_day_rises_peaks_and_clouds_pass() {
        let s: Scenario = toml::from_str(
            "[day]\nseconds_per_hour = 1.0\nstart_hour = 5.0\nsunrise_hour = 6.0\nsunset_hour = 18.0\nnoon_exitance_lm_m2 = 1000.0\n[[events]]\nat_s = 7.0\nkind = \"clouds\"\nfactor = 0.25\nduration_s = 1.0\n",
        )
        .unwrap();
        s.validate().unwrap();
        assert_eq!(s.window_exitance_at(0.0), 0.0);
        assert!(
            (s.window_exitance_at(7.0) - 250.0).abs() < 1e-9,
            "noon under a cloud"
        );
        assert!(
            (s.window_exitance_at(8.0)
                - 1000.0 * (std::f64::consts::PI * 7.0 / 12.0).sin().powf(1.3))
            .abs()
                < 1e-9
        );
        assert!(s.window_exitance_at(3.0) < s.window_exitance_at(6.0));
        for bad in [
            "[day]\nseconds_per_hour = 0\nstart_hour = 5\nsunrise_hour = 6\nsunset_hour = 18\nnoon_exitance_lm_m2 = 1\n",
            "[[events]]\nat_s = 1\nkind = \"age\"\nluminaire = 1\nfactor = -1\n",
            "[[events]]\nat_s = 1\nkind = \"teleport\"\n",
            "[[events]]\nat_s = 1\nkind = \"clouds\"\nfactor = 0.5\nduraton_s = 2\n",
        ] {
            let r: Result<Scenario, _> = toml::from_str(bad);
            assert!(r.is_err() || r.unwrap().validate().is_err(), "{bad}");
        }
    }
}
