//! Motion over frames on scripted sequences of sightings at the daemon's default period (a
//! frame every 10 s): the truth is the script's (where a thing stands still, where a person
//! sits and how they move, when they leave).

use super::*;
use crate::occupancy::{DeskOccupancy, Hold};
use crate::rng::{SplitMix64, gaussian};

/// The live task's default period, s.
const PERIOD_S: f64 = 10.0;
/// One frame's jitter of a still head's sighting (σ per axis and of the top), m: above what
/// the sim board's frames show (`tests/occupancy.rs`, `sim_people`).
const JITTER_M: f64 = 0.006;
/// The stated time.
const STATIC_S: f64 = 1800.0;

use Occupied::{No, Unknown, Yes};

/// A frame's report over `desks` desks: a person's desk `1`, the others `0` (all seen).
fn frame(persons: &[PersonSeen], desks: usize) -> OccupancyReport {
    OccupancyReport {
        desks: (0..desks)
            .map(|k| DeskOccupancy {
                id: k as u32 + 1,
                state: if persons.iter().any(|p| p.desk == Some(k)) {
                    Yes
                } else {
                    No
                },
                seen_fraction: 1.0,
            })
            .collect(),
        people: persons.len() as u16,
        persons: persons.to_vec(),
        status: 0,
    }
}

/// A head at desk `desk` (or none) at (x, y) with top `top`, seen with the frame's jitter.
fn seen(rng: &mut SplitMix64, desk: Option<usize>, at_m: [f64; 3]) -> PersonSeen {
    PersonSeen {
        desk,
        x_m: at_m[0] + JITTER_M * gaussian(rng),
        y_m: at_m[1] + JITTER_M * gaussian(rng),
        top_m: at_m[2] + JITTER_M * gaussian(rng),
    }
}

/// A seated person's head sitting still as people do (typing, reading): the head wanders
/// within about 4 cm of where they sit (a random walk of 1.5 cm per frame pulled back to the
/// seat), the top by a couple of centimetres as they nod; no posture shifts at all.
struct StillPerson {
    seat_m: [f64; 3],
    off_m: [f64; 3],
}

impl StillPerson {
    fn step(&mut self, rng: &mut SplitMix64) -> [f64; 3] {
        for (a, o) in self.off_m.iter_mut().enumerate() {
            let step_m = if a == 2 { 0.008 } else { 0.015 };
            *o = 0.6 * *o + step_m * gaussian(rng);
        }
        [0, 1, 2].map(|a| self.seat_m[a] + self.off_m[a])
    }
}

fn motion() -> Motion {
    Motion::new(MotionSettings::default()).unwrap()
}

#[test]
fn a_coat_stand_left_at_a_desk_is_not_a_person_after_the_stated_time() {
    assert_eq!(MotionSettings::default().static_after_s, STATIC_S);
    let mut rng = SplitMix64::new(29);
    let mut m = motion();
    let stand_m = [1.8, 2.45, 1.3];
    // three hours of frames of the still thing (person-shaped: a single frame says "person")
    for i in 0..1080 {
        let t_s = f64::from(i) * PERIOD_S;
        let mut r = frame(&[seen(&mut rng, Some(0), stand_m)], 2);
        m.update(t_s, &mut r);
        let (want, people) = if t_s < STATIC_S {
            (Yes, 1)
        } else {
            (Unknown, 0)
        };
        assert_eq!(r.desks[0].state, want, "{t_s} s");
        assert_eq!(r.desks[1].state, No, "{t_s} s");
        assert_eq!(r.people, people, "{t_s} s");
    }
    // someone sits down at the same desk, 0.5 m from the stand: occupied again, one person
    let mut p = StillPerson {
        seat_m: [2.3, 2.45, 1.25],
        off_m: [0.0; 3],
    };
    for i in 1080..1200 {
        let t_s = f64::from(i) * PERIOD_S;
        let head = p.step(&mut rng);
        let mut r = frame(
            &[
                seen(&mut rng, Some(0), stand_m),
                seen(&mut rng, Some(0), head),
            ],
            2,
        );
        m.update(t_s, &mut r);
        assert_eq!((r.desks[0].state, r.people), (Yes, 1), "{t_s} s");
    }
    // they leave and the stand is carried 0.4 m away: a new thing, a person again for the
    // stated time (fail bright), then not
    let moved_m = [1.8, 2.05, 1.3];
    for i in 1200..1500 {
        let t_s = f64::from(i) * PERIOD_S;
        let mut r = frame(&[seen(&mut rng, Some(0), moved_m)], 2);
        m.update(t_s, &mut r);
        let want = if t_s - 12_000.0 < STATIC_S {
            Yes
        } else {
            Unknown
        };
        assert_eq!(r.desks[0].state, want, "{t_s} s");
    }
}

#[test]
fn a_person_sitting_still_with_micro_motion_stays_a_person_all_day() {
    let mut rng = SplitMix64::new(7);
    let mut m = motion();
    let mut p = StillPerson {
        seat_m: [1.8, 2.45, 1.3],
        off_m: [0.0; 3],
    };
    let (mut moves, mut last_move_s, mut longest_still_s) = (0, 0.0, 0.0f64);
    // eight hours at a frame every 10 s
    for i in 0..2880 {
        let t_s = f64::from(i) * PERIOD_S;
        let head = p.step(&mut rng);
        let mut r = frame(&[seen(&mut rng, Some(0), head)], 1);
        m.update(t_s, &mut r);
        assert_eq!((r.desks[0].state, r.people), (Yes, 1), "{t_s} s");
        let moved_s = m.tracks.first().map_or(f64::NAN, |t| t.moved_s);
        if moved_s == t_s && i > 0 {
            moves += 1;
            longest_still_s = longest_still_s.max(t_s - last_move_s);
            last_move_s = t_s;
        }
    }
    // it is the motion that keeps them: many moves, none of the still spells near the limit
    assert!(moves > 100, "{moves} moves");
    assert!(longest_still_s < STATIC_S / 3.0, "{longest_still_s} s");
}

#[test]
fn a_person_who_leaves_is_vacant_after_the_hold_and_a_bad_frame_waits() {
    let mut rng = SplitMix64::new(3);
    let mut m = motion();
    let mut hold = Hold::new(1, 900.0).unwrap();
    let mut p = StillPerson {
        seat_m: [1.8, 2.45, 1.3],
        off_m: [0.0; 3],
    };
    let leave_s = 3600.0;
    for i in 0..720 {
        let t_s = f64::from(i) * PERIOD_S;
        let persons = if t_s < leave_s {
            let head = p.step(&mut rng);
            vec![seen(&mut rng, Some(0), head)]
        } else {
            Vec::new()
        };
        let mut r = frame(&persons, 1);
        if i == 100 {
            // a bad frame: passes unchanged, the track waits
            r = OccupancyReport {
                desks: Vec::new(),
                people: 0,
                persons: Vec::new(),
                status: crate::occupancy::status::MOVED,
            };
        }
        let tracks = m.tracks();
        m.update(t_s, &mut r);
        if i == 100 {
            assert_eq!((m.tracks(), r.desks.len()), (tracks, 0));
        }
        let held = hold.update(t_s, &r)[0].state;
        let want = if t_s <= leave_s - PERIOD_S + 900.0 {
            Yes
        } else {
            No
        };
        assert_eq!(held, want, "{t_s} s");
    }
}

#[test]
fn a_still_thing_in_the_aisle_leaves_the_count_and_no_desk() {
    let mut rng = SplitMix64::new(5);
    let mut m = Motion::new(MotionSettings {
        static_after_s: 60.0,
        ..MotionSettings::default()
    })
    .unwrap();
    for i in 0..20 {
        let t_s = f64::from(i) * PERIOD_S;
        let mut r = frame(&[seen(&mut rng, None, [4.0, 2.9, 1.7])], 2);
        m.update(t_s, &mut r);
        assert_eq!(r.people, u16::from(t_s < 60.0), "{t_s} s");
        assert!(r.desks.iter().all(|d| d.state == No), "{t_s} s");
    }
}

#[test]
fn settings_out_of_range_are_refused() {
    let d = MotionSettings::default();
    for bad in [
        MotionSettings {
            static_after_s: 0.0,
            ..d
        },
        MotionSettings {
            still_plan_m: f64::NAN,
            ..d
        },
        MotionSettings {
            still_height_m: -0.1,
            ..d
        },
        MotionSettings {
            match_m: f64::INFINITY,
            ..d
        },
    ] {
        assert!(Motion::new(bad).is_err(), "{bad:?}");
    }
    // a frame time that is not a number changes nothing
    let mut m = motion();
    let mut r = frame(
        &[PersonSeen {
            desk: Some(0),
            x_m: 1.0,
            y_m: 1.0,
            top_m: 1.3,
        }],
        1,
    );
    m.update(f64::NAN, &mut r);
    assert_eq!((m.tracks(), r.desks[0].state), (0, Yes));
}
