//! The per-frame pass of occupancy ([`super`] has the method): the frame's checks, the
//! foreground's heights over the plan, the blobs and the person test. Its buffers are
//! allocated once, at [`Occupancy::new`]; an update allocates only its report.

use super::{
    DeskOccupancy, NO_SQUARE, NO_ZONE, OccupancyMap, OccupancyReport, Occupied, PersonSeen,
    SATURATED_MM, fraction, status,
};

/// No foreground in a square.
const EMPTY: u16 = 0;
/// A part's head is another's when the blob rises this much above its top next to it, mm.
const OWN_HEAD_MM: u16 = 30;
/// A blob joins squares up to this many squares apart (a gap of one square between the
/// points of neighbouring pixels far from the camera does not split a person).
const REACH: i64 = 2;

/// Occupancy over a map: the map and its per-frame buffers.
#[derive(Debug, Clone)]
pub struct Occupancy {
    map: OccupancyMap,
    /// Highest foreground point per square above the floor, mm ([`EMPTY`]: none).
    top_mm: Vec<u16>,
    /// Squares whose commissioned points return in this frame.
    seen: Vec<bool>,
    /// Squares already in a blob.
    taken: Vec<bool>,
    /// The flood fill's stack and the current blob's squares.
    stack: Vec<u32>,
    blob: Vec<u32>,
}

/// Counts of the frame's cells.
#[derive(Debug, Default, Clone, Copy)]
struct Counts {
    returns: usize,
    saturated: usize,
    farther: usize,
    agree: usize,
}

impl Occupancy {
    /// Occupancy over `map`.
    pub fn new(map: OccupancyMap) -> Self {
        let n = map.zone.len();
        Self {
            top_mm: vec![EMPTY; n],
            seen: vec![false; n],
            taken: vec![false; n],
            stack: Vec::with_capacity(1024),
            blob: Vec::with_capacity(1024),
            map,
        }
    }

    /// The map.
    pub fn map(&self) -> &OccupancyMap {
        &self.map
    }

    /// Bytes held: the map and the per-frame buffers.
    pub fn memory_bytes(&self) -> usize {
        self.map.memory_bytes()
            + self.top_mm.len() * 2
            + self.seen.len()
            + self.taken.len()
            + (self.stack.capacity() + self.blob.capacity()) * 4
    }

    /// Every desk unknown, with `status`.
    fn unknown(&self, status: u16) -> OccupancyReport {
        OccupancyReport {
            desks: self
                .map
                .desks
                .iter()
                .map(|d| DeskOccupancy {
                    id: d.id,
                    state: Occupied::Unknown,
                    seen_fraction: 0.0,
                })
                .collect(),
            people: 0,
            persons: Vec::new(),
            status,
        }
    }

    /// One depth frame (`width` × `height`, mm along the optical axis, 0 no return,
    /// [`SATURATED_MM`] saturated; `None`: no frame): each desk's state.
    pub fn update(&mut self, width: u32, height: u32, depth_mm: Option<&[u16]>) -> OccupancyReport {
        let Some(depth_mm) = depth_mm else {
            return self.unknown(status::BAD_FRAME);
        };
        let pixels = u64::from(width) * u64::from(height);
        if (width, height) != (self.map.width, self.map.height) || depth_mm.len() as u64 != pixels {
            return self.unknown(status::BAD_FRAME);
        }
        let counts = self.foreground(depth_mm);
        let cells = self.map.cells.len();
        let s = &self.map.settings;
        if cells == 0 || (counts.returns as f64) < s.min_return_fraction * cells as f64 {
            let bit = if counts.saturated > cells / 2 {
                status::SATURATED
            } else {
                status::NO_RETURN
            };
            return self.unknown(bit);
        }
        let returns = counts.returns as f64;
        if counts.farther as f64 > s.moved_fraction * returns
            || (counts.agree as f64) < s.min_agree_fraction * returns
        {
            return self.unknown(status::MOVED);
        }
        let persons = self.people();
        let mut occupied = vec![false; self.map.desks.len()];
        for p in &persons {
            if let Some(k) = p.desk {
                occupied[k] = true;
            }
        }
        self.map.plan.close(&self.seen, &mut self.taken);
        let seen = self.map.zone_counts(&self.taken);
        let desks = self
            .map
            .desks
            .iter()
            .enumerate()
            .map(|(k, d)| {
                let seen_fraction = fraction(seen[k], self.map.zone_squares[k]);
                let state = if occupied[k] {
                    Occupied::Yes
                } else if seen_fraction >= self.map.settings.vacant_min_seen {
                    Occupied::No
                } else {
                    Occupied::Unknown
                };
                DeskOccupancy {
                    id: d.id,
                    state,
                    seen_fraction,
                }
            })
            .collect();
        OccupancyReport {
            desks,
            people: u16::try_from(persons.len()).unwrap_or(u16::MAX),
            persons,
            status: 0,
        }
    }

    /// Step 2: each cell against the room; the foreground's heights into the plan squares.
    fn foreground(&mut self, depth_mm: &[u16]) -> Counts {
        self.top_mm.fill(EMPTY);
        self.seen.fill(false);
        let m = &self.map;
        let s = &m.settings;
        let min_mm = s.min_foreground_m * 1e3;
        let mut c = Counts::default();
        for cell in &m.cells {
            let d = depth_mm[cell.pixel as usize];
            if d == 0 {
                continue;
            }
            if d == SATURATED_MM {
                c.saturated += 1;
                continue;
            }
            c.returns += 1;
            if cell.square != NO_SQUARE {
                let reach = m.plan.reach_within(f64::from(cell.spacing_mm) * 1e-3);
                let (seen, head) = (&mut self.seen, &m.head_seen);
                m.plan
                    .around(cell.square as usize, reach, |q| seen[q] = head[q]);
            }
            let bg = f64::from(cell.background_mm);
            let nearer_mm = bg - f64::from(d);
            let threshold_mm = min_mm.max(s.foreground_fraction * bg);
            if nearer_mm < -threshold_mm {
                c.farther += 1;
            } else if nearer_mm <= threshold_mm {
                c.agree += 1;
            }
            if nearer_mm <= threshold_mm {
                continue;
            }
            let z = f64::from(d) * 1e-3;
            let r = cell.ray_per_m.map(f64::from);
            let (x, y) = (m.camera_m[0] + z * r[0], m.camera_m[1] + z * r[1]);
            let h_m = m.camera_m[2] + z * r[2] - m.floor_z_m;
            if let Some(sq) = m.plan.square(x, y) {
                let h_mm = (h_m * 1e3).clamp(1.0, f64::from(u16::MAX - 1)) as u16;
                // the footprint shrinks with the depth
                let reach = m
                    .plan
                    .reach(f64::from(cell.spacing_mm) * 1e-3 * f64::from(d) / bg);
                let top = &mut self.top_mm;
                m.plan.around(sq, reach, |q| top[q] = top[q].max(h_mm));
            }
        }
        c
    }

    /// Steps 3-5: the blobs, cut by the zones, and the person test: the people seen (each
    /// with its desk, if its part lies in a zone).
    fn people(&mut self) -> Vec<PersonSeen> {
        let min_mm = (self.map.settings.min_blob_height_m * 1e3) as u16;
        let mut persons = Vec::new();
        self.taken.fill(false);
        for start in 0..self.top_mm.len() {
            if self.taken[start] || self.top_mm[start] < min_mm.max(1) {
                continue;
            }
            self.flood(start, min_mm.max(1));
            // the blob's parts, zone by zone
            let zone = &self.map.zone;
            self.blob.sort_unstable_by_key(|&q| (zone[q as usize], q));
            let mut begin = 0;
            while begin < self.blob.len() {
                let z = zone[self.blob[begin] as usize];
                let end = begin
                    + self.blob[begin..]
                        .iter()
                        .take_while(|&&q| zone[q as usize] == z)
                        .count();
                if let Some(head) = self.person(begin..end) {
                    persons.push(PersonSeen {
                        desk: (z != NO_ZONE).then_some(usize::from(z)),
                        ..head
                    });
                }
                begin = end;
            }
        }
        persons
    }

    /// The blob of `start` (squares at least `min_mm` high) into `self.blob`.
    fn flood(&mut self, start: usize, min_mm: u16) {
        let (nx, ny) = (self.map.plan.nx, self.map.plan.ny);
        self.blob.clear();
        self.stack.clear();
        self.stack.push(start as u32);
        self.taken[start] = true;
        while let Some(q) = self.stack.pop() {
            self.blob.push(q);
            let (i, j) = (q as usize % nx, q as usize / nx);
            for dj in -REACH..=REACH {
                for di in -REACH..=REACH {
                    let (a, b) = (i as i64 + di, j as i64 + dj);
                    if a < 0 || b < 0 || a >= nx as i64 || b >= ny as i64 {
                        continue;
                    }
                    let n = b as usize * nx + a as usize;
                    if !self.taken[n] && self.top_mm[n] >= min_mm {
                        self.taken[n] = true;
                        self.stack.push(n as u32);
                    }
                }
            }
        }
    }

    /// Whether the part's cap (its squares at least `cap_mm` high) is a head of its own: no
    /// square of the blob across the zone's border next to it rises above the part's top
    /// (`top_mm`) by more than a few centimetres (else the head is the neighbour's, and this
    /// part holds only its edge).
    fn own_head(&self, part: &[u32], cap_mm: u16, top_mm: u16) -> bool {
        let plan = &self.map.plan;
        let zone = &self.map.zone;
        let above = top_mm.saturating_add(OWN_HEAD_MM);
        part.iter()
            .filter(|&&q| self.top_mm[q as usize] >= cap_mm)
            .all(|&q| {
                let z = zone[q as usize];
                let mut own = true;
                plan.around(q as usize, REACH as usize, |n| {
                    own &= zone[n] == z || self.top_mm[n] <= above;
                });
                own
            })
    }

    /// The plan centre of the squares of `part` at least `min_mm` high, m.
    fn centre_m(&self, part: &[u32], min_mm: u16) -> (f64, f64) {
        let (mut n, mut x, mut y) = (0.0, 0.0, 0.0);
        for &q in part.iter().filter(|&&q| self.top_mm[q as usize] >= min_mm) {
            let (qx, qy) = self.map.plan.centre_m(q as usize);
            (n, x, y) = (n + 1.0, x + qx, y + qy);
        }
        if n > 0.0 { (x / n, y / n) } else { (0.0, 0.0) }
    }

    /// The squares of `part` at least `min_mm` high: their count, the larger side of their
    /// bounding box (m) and the share of the box they fill.
    fn band(&self, part: &[u32], min_mm: u16) -> (usize, f64, f64) {
        let nx = self.map.plan.nx;
        let (mut n, mut lo, mut hi) = (0usize, [usize::MAX; 2], [0usize; 2]);
        for &q in part.iter().filter(|&&q| self.top_mm[q as usize] >= min_mm) {
            let (i, j) = (q as usize % nx, q as usize / nx);
            n += 1;
            lo = [lo[0].min(i), lo[1].min(j)];
            hi = [hi[0].max(i), hi[1].max(j)];
        }
        if n == 0 {
            return (0, 0.0, 0.0);
        }
        let (w, h) = (hi[0] + 1 - lo[0], hi[1] + 1 - lo[1]);
        (
            n,
            w.max(h) as f64 * self.map.plan.side_m,
            n as f64 / (w * h) as f64,
        )
    }

    /// The person test (step 4) of the blob's squares `range`: the head (its cap's plan
    /// centre and its top) of a person, or `None` (its desk is the caller's).
    fn person(&self, range: core::ops::Range<usize>) -> Option<PersonSeen> {
        let s = &self.map.settings;
        let part = &self.blob[range];
        if part.len() < 4 {
            return None;
        }
        // the top: the 4th highest square
        let mut tops = [0u16; 4];
        for &q in part {
            let h = self.top_mm[q as usize];
            if h > tops[3] {
                tops[3] = h;
                tops.sort_unstable_by(|a, b| b.cmp(a));
            }
        }
        let top_m = f64::from(tops[3]) * 1e-3;
        if !(s.person_top_m[0]..=s.person_top_m[1]).contains(&top_m) {
            return None;
        }
        let below_top = |m: f64| ((top_m - m) * 1e3).max(0.0) as u16;
        let (n, extent_m, solidity) = self.band(part, below_top(s.head_band_m));
        let side = self.map.plan.side_m;
        let area_m2 = n as f64 * side * side;
        let cap_mm = below_top(s.head_cap_m);
        let (_, cap_m, _) = self.band(part, cap_mm);
        let head = area_m2 >= s.person_min_area_m2
            && extent_m >= s.person_min_extent_m
            && solidity >= s.person_min_solidity
            && cap_m <= s.person_max_cap_m
            && self.own_head(part, cap_mm, tops[3]);
        head.then(|| {
            let (x_m, y_m) = self.centre_m(part, cap_mm);
            PersonSeen {
                desk: None,
                x_m,
                y_m,
                top_m,
            }
        })
    }
}
