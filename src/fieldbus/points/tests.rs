use super::*;
use crate::points::{Place, point_name};

/// Sensor 2 on desk 1, sensor 8 on the floor.
fn two_points() -> Vec<Point> {
    [(2, Place::Desk(1)), (8, Place::Floor)]
        .map(|(id, place)| Point {
            sensor_id: id,
            place,
            name: point_name(id, place),
        })
        .to_vec()
}

#[test]
fn the_modbus_rows_expand_each_block_per_point_and_luminaire() {
    let points = two_points();
    let rows = points_list(
        &points,
        &[11, 12, 13],
        ListOptions {
            bacnet: false,
            occupancy: false,
        },
    );
    let find = |q: &str, point: &str| {
        rows.iter()
            .find(|r| r.quantity == q && r.point == point)
            .unwrap_or_else(|| panic!("{q} {point}"))
    };
    // docs/modbus.md: desk k's float at input 100 + 2k (30101 + 2k), two words; its u16 at 300 + k
    assert_eq!(find("desk lux (float)", "floor S8").address, 102);
    assert_eq!(find("desk lux (float)", "floor S8").reference, Some(30_103));
    assert_eq!(find("desk lux (float)", "floor S8").words, 2);
    assert_eq!(
        find("desk lux (integer)", "desk 1 (S2)").reference,
        Some(30_301)
    );
    assert_eq!(find("desk lux (integer)", "desk 1 (S2)").desk_id, Some(1));
    assert_eq!(find("desk live total lux", "floor S8").address, 3002);
    // holding: the arc level of the third luminaire, writable; the target of desk 1's point
    let arc = find("arc level", "luminaire 13");
    assert_eq!(
        (arc.table.as_str(), arc.address, arc.reference),
        ("holding", 1002, Some(41_003))
    );
    assert_eq!(arc.access, "R/W");
    assert_eq!(find("desk target", "desk 1 (S2)").reference, Some(42_101));
    // node-wide rows once; no BACnet without it
    assert_eq!(rows.iter().filter(|r| r.quantity == "status").count(), 1);
    assert!(rows.iter().all(|r| r.protocol == "modbus"));
    // every (table, address) once
    let mut seen = std::collections::BTreeSet::new();
    for r in &rows {
        for w in 0..r.words {
            assert!(
                seen.insert((r.table.clone(), r.address + w)),
                "{} {} twice",
                r.table,
                r.address + w
            );
        }
    }
}

#[test]
fn the_bacnet_rows_and_the_ede_file_name_each_object_by_its_point() {
    let points = two_points();
    let o = ListOptions {
        bacnet: true,
        occupancy: false,
    };
    let rows = points_list(&points, &[11], o);
    let bac: Vec<&PointRow> = rows.iter().filter(|r| r.protocol == "bacnet").collect();
    // 4 analog inputs and a target per point, one level per luminaire; no occupancy inputs
    assert_eq!(bac.len(), 2 * 5 + 1);
    let ai1 = bac
        .iter()
        .find(|r| r.table == "analog-input" && r.address == 1)
        .expect("AI 1");
    assert_eq!(ai1.point, "floor S8");
    assert_eq!(ai1.object_name.as_deref(), Some("floor S8 illuminance"));
    assert_eq!(ai1.unit, "luxes");
    let with_occ = points_list(
        &points,
        &[11],
        ListOptions {
            bacnet: true,
            occupancy: true,
        },
    );
    assert_eq!(
        with_occ
            .iter()
            .filter(|r| r.table == "binary-input")
            .count(),
        2
    );
    let ede = to_ede(&rows, "room 12", 1201, "luxnode-sim 1201");
    let lines: Vec<&str> = ede.lines().filter(|l| !l.starts_with('#')).collect();
    // 4 header keys, then the device and 11 objects, each of 16 fields
    let objects: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| l.split(';').count() == 16)
        .collect();
    assert_eq!(objects.len(), 1 + 11, "{ede}");
    assert!(objects[0].starts_with("luxnode-sim 1201;1201;luxnode-sim 1201;8;1201;"));
    assert!(
        objects.contains(&"floor S8 illuminance;1201;floor S8 illuminance;0;1;floor S8: illuminance;;;;N;Y;;;;37;"),
        "{ede}"
    );
    let csv = to_csv(&rows);
    assert_eq!(csv.lines().count(), rows.len() + 1);
    assert!(csv.lines().all(|l| !l.is_empty()));
}
