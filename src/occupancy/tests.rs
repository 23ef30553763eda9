//! Occupancy on a room of columns (a height field seen by a pinhole looking straight down),
//! ray-marched here: the truth is the scene's, not the code's.

use super::*;

const W: u32 = 160;
const H: u32 = 120;
const F_PX: f64 = 80.0;
const CAMERA_M: [f64; 3] = [3.0, 2.0, 3.5];
const STRIDE: u32 = 2;
/// The room's plan: x0, x1, y0, y1 (the floor of [`seen_truth`]'s grid).
const ROOM_M: [f64; 4] = [-2.0, 26.0, -2.0, 6.0];

/// A box standing on the floor (or on something): plan extent and top, m.
#[derive(Clone, Copy)]
struct Column {
    x_m: [f64; 2],
    y_m: [f64; 2],
    top_m: f64,
}

fn desks() -> Vec<DeskTop> {
    vec![
        DeskTop {
            id: 11,
            x_m: [1.0, 2.6],
            y_m: [1.2, 2.0],
            z_m: 0.75,
        },
        DeskTop {
            id: 12,
            x_m: [3.4, 5.0],
            y_m: [1.2, 2.0],
            z_m: 0.75,
        },
        // far outside the view
        DeskTop {
            id: 13,
            x_m: [20.0, 21.6],
            y_m: [1.2, 2.0],
            z_m: 0.75,
        },
    ]
}

fn room() -> Vec<Column> {
    desks()
        .iter()
        .map(|d| Column {
            x_m: d.x_m,
            y_m: d.y_m,
            top_m: d.z_m,
        })
        .collect()
}

/// The pixel's ray per metre of depth (camera x = world x, camera y = world −y, z down).
fn ray(u: u32, v: u32) -> [f64; 3] {
    let cx = f64::from(W - 1) / 2.0;
    let cy = f64::from(H - 1) / 2.0;
    [
        (f64::from(u) - cx) / F_PX,
        -(f64::from(v) - cy) / F_PX,
        -1.0,
    ]
}

fn height_at(cols: &[Column], x: f64, y: f64) -> f64 {
    cols.iter()
        .filter(|c| (c.x_m[0]..=c.x_m[1]).contains(&x) && (c.y_m[0]..=c.y_m[1]).contains(&y))
        .map(|c| c.top_m)
        .fold(0.0, f64::max)
}

/// The depth frame of the columns, mm (only the watched pixels are rendered).
fn render(cols: &[Column]) -> Vec<u16> {
    let mut out = vec![0u16; (W * H) as usize];
    for v in (0..H).step_by(STRIDE as usize) {
        for u in (0..W).step_by(STRIDE as usize) {
            let r = ray(u, v);
            let mut z = 0.0;
            while z < 5.0 {
                let p = [
                    CAMERA_M[0] + z * r[0],
                    CAMERA_M[1] + z * r[1],
                    CAMERA_M[2] + z * r[2],
                ];
                if p[2] <= height_at(cols, p[0], p[1]) {
                    break;
                }
                z += 0.002;
            }
            out[(v * W + u) as usize] = (z * 1e3).round() as u16;
        }
    }
    out
}

/// The share of desk `k`'s zone (squares of 5 cm, nearest desk within 0.75 m) whose top
/// surface the camera sees (marched from the camera to the point, nothing in between) and
/// over which a seated head (1.15 m) would be in the frame.
fn seen_truth(k: usize) -> f64 {
    let (d, cols) = (desks(), room());
    let (mut n, mut seen) = (0, 0);
    for j in -40..120 {
        for i in -40..520 {
            let (x, y) = (0.025 + 0.05 * f64::from(i), 0.025 + 0.05 * f64::from(j));
            let dist: Vec<f64> = d.iter().map(|t| t.distance2_m2(x, y).sqrt()).collect();
            let near = (0..d.len()).min_by(|&a, &b| dist[a].total_cmp(&dist[b]));
            if near != Some(k) || dist[k] > 0.75 {
                continue;
            }
            n += 1;
            let p = [x, y, height_at(&cols, x, y)];
            // the pixels of p and of a head over it (1.15 m), within the frame
            let in_frame = |h: f64| {
                let z = CAMERA_M[2] - h;
                let u = (p[0] - CAMERA_M[0]) / z * F_PX + f64::from(W - 1) / 2.0;
                let v = -(p[1] - CAMERA_M[1]) / z * F_PX + f64::from(H - 1) / 2.0;
                u >= -0.5 && v >= -0.5 && u < f64::from(W) - 0.5 && v < f64::from(H) - 0.5
            };
            if !(in_frame(p[2]) && in_frame(1.15)) {
                continue;
            }
            let clear = (1..200).all(|s| {
                let t = f64::from(s) / 200.0;
                let q = [0, 1, 2].map(|a| CAMERA_M[a] + t * (p[a] - CAMERA_M[a]));
                t > 0.99 || q[2] > height_at(&cols, q[0], q[1]) + 0.01
            });
            seen += usize::from(clear);
        }
    }
    if n == 0 { 0.0 } else { seen as f64 / n as f64 }
}

fn occupancy() -> Occupancy {
    let bg = render(&room());
    let cells: Vec<CellInput> = (0..H)
        .step_by(STRIDE as usize)
        .flat_map(|v| (0..W).step_by(STRIDE as usize).map(move |u| (u, v)))
        .map(|(u, v)| CellInput {
            pixel: v * W + u,
            background_mm: bg[(v * W + u) as usize],
            ray_per_m: ray(u, v),
        })
        .collect();
    let map = OccupancyMap::new(
        W,
        H,
        CAMERA_M,
        0.0,
        Some(ROOM_M),
        &desks(),
        &cells,
        OccupancySettings::default(),
    )
    .unwrap();
    Occupancy::new(map)
}

/// A seated person seen from above: a torso and shoulders to 1.05 m, a head to `head_m`,
/// centred at (x, y).
fn person(x: f64, y: f64, head_m: f64) -> [Column; 2] {
    [
        Column {
            x_m: [x - 0.22, x + 0.22],
            y_m: [y - 0.12, y + 0.12],
            top_m: 1.05,
        },
        Column {
            x_m: [x - 0.09, x + 0.09],
            y_m: [y - 0.1, y + 0.1],
            top_m: head_m,
        },
    ]
}

fn states(r: &OccupancyReport) -> Vec<Occupied> {
    r.desks.iter().map(|d| d.state).collect()
}

#[test]
fn the_empty_room_is_vacant_where_seen_and_unknown_where_not() {
    let mut o = occupancy();
    // the seen share of each zone is the scene's (the floor behind a desk's far edge is
    // hidden), the third desk not seen at all
    let m = o.map();
    for k in 0..3 {
        let truth = seen_truth(k);
        let got = m.commissioned_seen_fraction(k);
        assert!(
            (got - truth).abs() < 0.06,
            "desk {k}: {got} seen, truly {truth}"
        );
    }
    assert!(seen_truth(0) > 0.6 && seen_truth(1) > 0.6);
    assert_eq!(m.commissioned_seen_fraction(2), 0.0);
    let r = o.update(W, H, Some(&render(&room())));
    assert_eq!(r.status, 0);
    assert_eq!(r.people, 0);
    assert_eq!(
        states(&r),
        [Occupied::No, Occupied::No, Occupied::Unknown],
        "{r:?}"
    );
}

#[test]
fn a_seated_person_occupies_the_desk_whose_zone_holds_them() {
    let mut o = occupancy();
    for (k, x) in [(0, 1.8), (1, 4.2)] {
        for head in [1.2, 1.3, 1.4] {
            let mut cols = room();
            // on the desk's far side, 0.45 m from its edge
            cols.extend(person(x, 2.45, head));
            let r = o.update(W, H, Some(&render(&cols)));
            let mut want = [Occupied::No, Occupied::No, Occupied::Unknown];
            want[k] = Occupied::Yes;
            assert_eq!(states(&r), want, "head {head} m at desk {k}: {r:?}");
            assert_eq!(r.people, 1);
        }
    }
}

#[test]
fn things_below_a_head_are_not_people() {
    let mut o = occupancy();
    let things = [
        // a box on the desk, a coat over a chair, a chair back
        Column {
            x_m: [1.5, 1.9],
            y_m: [1.4, 1.7],
            top_m: 1.05,
        },
        Column {
            x_m: [1.6, 2.1],
            y_m: [2.3, 2.6],
            top_m: 1.08,
        },
        Column {
            x_m: [4.0, 4.5],
            y_m: [2.4, 2.47],
            top_m: 1.0,
        },
    ];
    for t in things {
        let mut cols = room();
        cols.push(t);
        let r = o.update(W, H, Some(&render(&cols)));
        assert_eq!(
            states(&r),
            [Occupied::No, Occupied::No, Occupied::Unknown],
            "{r:?}"
        );
    }
    // a thin pole as tall as a person (a plant's stem) is not one either
    let mut cols = room();
    cols.push(Column {
        x_m: [1.8, 1.85],
        y_m: [2.4, 2.45],
        top_m: 1.5,
    });
    let r = o.update(W, H, Some(&render(&cols)));
    assert_eq!(r.people, 0, "{r:?}");
}

#[test]
fn bad_frames_are_unknown_everywhere_with_a_status_bit() {
    let mut o = occupancy();
    let good = render(&room());
    let unknown = [Occupied::Unknown; 3];
    // wrong size, no frame
    let r = o.update(W - 2, H, Some(&good[..((W - 2) * H) as usize]));
    assert_eq!(
        (states(&r), r.status),
        (unknown.to_vec(), status::BAD_FRAME)
    );
    let r = o.update(W, H, Some(&good[1..]));
    assert_eq!(r.status, status::BAD_FRAME);
    assert_eq!(o.update(W, H, None).status, status::BAD_FRAME);
    // all zeros, all saturated
    let r = o.update(W, H, Some(&vec![0; (W * H) as usize]));
    assert_eq!(
        (states(&r), r.status),
        (unknown.to_vec(), status::NO_RETURN)
    );
    let r = o.update(W, H, Some(&vec![SATURATED_MM; (W * H) as usize]));
    assert_eq!(
        (states(&r), r.status),
        (unknown.to_vec(), status::SATURATED)
    );
    // the camera moved: it hangs 0.3 m lower on its bracket, everything is farther
    let moved: Vec<u16> = good
        .iter()
        .map(|&d| if d > 0 { d + 300 } else { 0 })
        .collect();
    let r = o.update(W, H, Some(&moved));
    assert_eq!((states(&r), r.status), (unknown.to_vec(), status::MOVED));
    // a good frame after them answers again
    assert_eq!(o.update(W, H, Some(&good)).status, 0);
}

#[test]
fn a_desk_half_hidden_is_never_called_vacant() {
    let mut o = occupancy();
    // the pixels over desk 0's zone return nothing (a dead corner of the sensor)
    let mut f = render(&room());
    for v in 0..H {
        for u in 0..W {
            let r = ray(u, v);
            let x = CAMERA_M[0] + 3.5 * r[0];
            if x < 2.4 {
                f[(v * W + u) as usize] = 0;
            }
        }
    }
    let r = o.update(W, H, Some(&f));
    assert_eq!(r.status, 0);
    assert!(r.desks[0].seen_fraction < 0.6, "{r:?}");
    assert_eq!(
        states(&r),
        [Occupied::Unknown, Occupied::No, Occupied::Unknown]
    );
}

#[test]
fn bad_settings_and_inputs_are_refused() {
    let s = OccupancySettings {
        vacant_min_seen: 0.2,
        ..OccupancySettings::default()
    };
    assert!(OccupancyMap::new(W, H, CAMERA_M, 0.0, None, &desks(), &[], s).is_err());
    let s = OccupancySettings::default();
    assert!(OccupancyMap::new(0, H, CAMERA_M, 0.0, None, &desks(), &[], s).is_err());
    assert!(OccupancyMap::new(W, H, [f64::NAN; 3], 0.0, None, &desks(), &[], s).is_err());
    let mut d = desks();
    d[0].x_m = [3.0, 1.0];
    assert!(OccupancyMap::new(W, H, CAMERA_M, 0.0, None, &d, &[], s).is_err());
    assert!(OccupancyMap::new(W, H, CAMERA_M, 0.0, None, &[], &[], s).is_err());
    let flat = Some([1.0, 1.0, 0.0, 2.0]);
    assert!(OccupancyMap::new(W, H, CAMERA_M, 0.0, flat, &desks(), &[], s).is_err());
}

#[test]
fn a_walker_beside_the_zone_does_not_occupy_the_desk() {
    let mut o = occupancy();
    // standing 0.9 m beyond desk 0's far edge (outside its 0.75 m zone, the nearest desk's
    // zone nonetheless): head over the aisle, a shoulder reaching into the zone
    let mut cols = room();
    let (x, y) = (1.8, 2.9);
    cols.push(Column {
        x_m: [x - 0.24, x + 0.24],
        y_m: [y - 0.2, y + 0.2],
        top_m: 1.45,
    });
    cols.push(Column {
        x_m: [x - 0.09, x + 0.09],
        y_m: [y - 0.05, y + 0.15],
        top_m: 1.75,
    });
    let r = o.update(W, H, Some(&render(&cols)));
    assert_eq!(r.status, 0);
    assert_eq!(r.people, 1, "{r:?}");
    assert_eq!(
        states(&r),
        [Occupied::No, Occupied::No, Occupied::Unknown],
        "{r:?}"
    );
}

#[test]
fn garbage_depth_is_never_vacant() {
    let mut o = occupancy();
    // deterministic noise over the whole range, and over the room's own depths' range
    let mut x = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    for span in [u64::from(u16::MAX), 4000] {
        let f: Vec<u16> = (0..W * H).map(|_| (next() % span) as u16).collect();
        let r = o.update(W, H, Some(&f));
        assert_ne!(r.status, 0, "{r:?}");
        assert!(
            r.desks.iter().all(|d| d.state == Occupied::Unknown),
            "{r:?}"
        );
    }
}
