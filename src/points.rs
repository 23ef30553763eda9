//! The measuring points' names: one name per point, the same in the report, on Modbus, on
//! BACnet and in the integrator's points list (`luxnode points`, [`crate::fieldbus::points`]).
//!
//! A *point* is a sensor of sensors.json (the node publishes one value set per point, Modbus's
//! "desk k"). It stands on a desk of desks.json, on the floor, or elsewhere (a sideboard, a
//! shelf), and is named for it: `desk 1 (S2)` (sensor 2 on desk 1's top), `floor S8`, `S9`
//! (sensor 9 on neither). Desks are desks.json's; a desk with no sensor has no published
//! values.

use serde::Serialize;

use crate::store::Image;
use crate::store::geometry::GeometrySection;

/// A sensor within this height of a desk's top, inside its outline, is on that desk, m.
pub const ON_DESK_M: f64 = 0.05;
/// A sensor within this height of the floor is on the floor, m.
pub const ON_FLOOR_M: f64 = 0.05;

/// Where a point stands.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Place {
    /// On a desk's top (desks.json id).
    Desk(u32),
    /// On the floor.
    Floor,
    /// Elsewhere, this high above the floor (m; NaN when the image has no geometry).
    Other(f64),
}

/// One measuring point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Point {
    /// Its sensor id (sensors.json).
    pub sensor_id: u32,
    /// Where it stands.
    pub place: Place,
    /// Its name: `desk 1 (S2)`, `floor S8`, `S9`.
    pub name: String,
}

impl Point {
    /// The desk it stands on.
    pub fn desk_id(&self) -> Option<u32> {
        match self.place {
            Place::Desk(d) => Some(d),
            _ => None,
        }
    }
}

/// The name of sensor `sensor_id` at `place`.
pub fn point_name(sensor_id: u32, place: Place) -> String {
    match place {
        Place::Desk(d) => format!("desk {d} (S{sensor_id})"),
        Place::Floor => format!("floor S{sensor_id}"),
        Place::Other(_) => format!("S{sensor_id}"),
    }
}

/// The points of an image, in its sensor order (Modbus's desk order).
pub fn points_of(image: &Image<'_>) -> Vec<Point> {
    let ids: Vec<u32> = (0..image.sensors()).map(|k| image.sensor_id(k)).collect();
    let section = image
        .geometry_bytes()
        .and_then(|b| GeometrySection::decode(b).ok());
    points_in(&ids, section.as_ref())
}

/// The points of sensors `ids` placed by `section` (each `S<id>` without one).
pub fn points_in(ids: &[u32], section: Option<&GeometrySection>) -> Vec<Point> {
    let floor_z_m = section.and_then(floor_z_m);
    ids.iter()
        .map(|&id| {
            let sensor = section.and_then(|s| s.sensors.iter().find(|r| r.id == id));
            let place = match (section, sensor) {
                (Some(s), Some(r)) => place_of(s, r.position_m, floor_z_m),
                _ => Place::Other(f64::NAN),
            };
            Point {
                sensor_id: id,
                place,
                name: point_name(id, place),
            }
        })
        .collect()
}

/// The floor's height: the lowest patch corner, m.
fn floor_z_m(s: &GeometrySection) -> Option<f64> {
    s.patch_corners_m
        .iter()
        .flat_map(|c| [c[2], c[5], c[8]])
        .map(f64::from)
        .filter(|z| z.is_finite())
        .reduce(f64::min)
}

fn place_of(s: &GeometrySection, p: [f64; 3], floor_z_m: Option<f64>) -> Place {
    let on = s.desks.iter().find(|d| {
        let [x0, x1, y0, y1] = d.extent_m;
        let within = |v: f64, a: f64, b: f64| v >= a.min(b) - 0.01 && v <= a.max(b) + 0.01;
        within(p[0], x0, x1) && within(p[1], y0, y1) && (p[2] - d.z_m).abs() <= ON_DESK_M
    });
    match (on, floor_z_m) {
        (Some(d), _) => Place::Desk(d.id),
        (None, Some(f)) if p[2] - f <= ON_FLOOR_M => Place::Floor,
        (None, Some(f)) => Place::Other(p[2] - f),
        (None, None) => Place::Other(f64::NAN),
    }
}

#[cfg(test)]
mod tests;
