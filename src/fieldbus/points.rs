//! The integrator's points list (`luxnode points`): every value the node publishes, from the
//! register map ([`crate::modbus::regmap::TABLE`]) and, where the node runs BACnet, the object
//! table ([`crate::bacnet::objects::TABLE`]), each with its point ([`crate::points`]), unit,
//! Modbus address and type, and BACnet object: the shape BMS engineering tools import (CSV,
//! JSON, and BACnet EDE for the objects).

use serde::Serialize;

use crate::bacnet::consts::{object_type as ot, units};
use crate::bacnet::objects::{Kind, TABLE as OBJECTS};
use crate::modbus::regmap::{Space, TABLE as REGISTERS};
use crate::points::Point;

/// One published value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointRow {
    /// The point's name, `luminaire N`, or `node` for the node's own values.
    pub point: String,
    /// The point's sensor id.
    pub sensor_id: Option<u32>,
    /// The desk the point stands on.
    pub desk_id: Option<u32>,
    /// The luminaire (luminaires.json id).
    pub luminaire_id: Option<u32>,
    /// What the value is (the register map's or the object table's name).
    pub quantity: String,
    /// Unit (empty: none).
    pub unit: String,
    /// `modbus` or `bacnet`.
    pub protocol: &'static str,
    /// Modbus: `input` or `holding`; BACnet: the object type (`analog-input`...).
    pub table: String,
    /// Modbus: the 0-based register address; BACnet: the object instance.
    pub address: u32,
    /// Modbus: the 1-based reference (30001 + address, 40001 + address); BACnet: none.
    pub reference: Option<u32>,
    /// Modbus: registers (1 or 2); BACnet: 1.
    pub words: u32,
    /// Data type.
    pub data_type: String,
    /// Scale (raw value × scale = the value in its unit; empty: an enumeration or bits).
    pub scale: String,
    /// `R` or `R/W`.
    pub access: &'static str,
    /// BACnet Object_Name.
    pub object_name: Option<String>,
}

/// What a points list covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListOptions {
    /// The BACnet objects too (the node runs BACnet/IP).
    pub bacnet: bool,
    /// The occupancy objects too (the node has a depth camera and desks; BACnet has them
    /// only then, Modbus always serves its occupancy block).
    pub occupancy: bool,
}

/// Every published value for `points` and luminaires `luminaire_ids`.
pub fn points_list(points: &[Point], luminaire_ids: &[u32], o: ListOptions) -> Vec<PointRow> {
    let mut rows = modbus_rows(points, luminaire_ids);
    if o.bacnet {
        rows.extend(bacnet_rows(points, luminaire_ids, o));
    }
    rows
}

/// The register map's rows, each block expanded per point or luminaire (every register is
/// served whether or not the node has live light or occupancy: unknown values read as such).
fn modbus_rows(points: &[Point], luminaire_ids: &[u32]) -> Vec<PointRow> {
    let mut rows = Vec::new();
    for r in REGISTERS {
        let (space, base) = match r.space {
            Space::Input => ("input", 30_001),
            Space::Holding => ("holding", 40_001),
        };
        let two = r.ty.starts_with("float32");
        let words = if two { 2 } else { 1 };
        let mut push = |point: String, s: Option<&Point>, l: Option<u32>, a: u32, w: u32| {
            rows.push(PointRow {
                point,
                sensor_id: s.map(|p| p.sensor_id),
                desk_id: s.and_then(Point::desk_id),
                luminaire_id: l,
                quantity: r.name.to_owned(),
                unit: r.unit.to_owned(),
                protocol: "modbus",
                table: space.to_owned(),
                address: a,
                reference: Some(base + a),
                words: w,
                data_type: r.ty.to_owned(),
                scale: r.scale.to_owned(),
                access: if r.access.contains('W') { "R/W" } else { "R" },
                object_name: None,
            });
        };
        let a0 = u32::from(r.address);
        match r.count {
            "D" | "2D" | "2 × D" => {
                let stride = if r.count == "D" { 1 } else { 2 };
                for (k, p) in points.iter().enumerate() {
                    push(p.name.clone(), Some(p), None, a0 + stride * k as u32, words);
                }
            }
            "L" => {
                for (j, &id) in luminaire_ids.iter().enumerate() {
                    push(
                        format!("luminaire {id}"),
                        None,
                        Some(id),
                        a0 + j as u32,
                        words,
                    );
                }
            }
            n => {
                let w = n.parse().unwrap_or(words);
                push("node".into(), None, None, a0, w);
            }
        }
    }
    rows
}

/// The object type's name as BACnet spells it.
pub fn object_type_name(t: u16) -> &'static str {
    match t {
        ot::ANALOG_INPUT => "analog-input",
        ot::ANALOG_VALUE => "analog-value",
        ot::BINARY_INPUT => "binary-input",
        ot::DEVICE => "device",
        _ => "unknown",
    }
}

/// An engineering unit's name as BACnet spells it.
pub fn unit_name(u: Option<u32>) -> &'static str {
    match u {
        Some(units::LUXES) => "luxes",
        Some(units::PERCENT) => "percent",
        _ => "",
    }
}

fn bacnet_rows(points: &[Point], luminaire_ids: &[u32], o: ListOptions) -> Vec<PointRow> {
    let mut rows = Vec::new();
    for c in OBJECTS.iter().filter(|c| c.kind != Kind::Device) {
        if c.kind == Kind::DeskOccupancy && !o.occupancy {
            continue;
        }
        let row =
            |point: String, s: Option<&Point>, l: Option<u32>, i: u32, name: String| PointRow {
                point,
                sensor_id: s.map(|p| p.sensor_id),
                desk_id: s.and_then(Point::desk_id),
                luminaire_id: l,
                quantity: c
                    .name
                    .replace("{point} ", "")
                    .replace("luminaire {id} ", ""),
                unit: unit_name(c.units).to_owned(),
                protocol: "bacnet",
                table: object_type_name(c.object_type).to_owned(),
                address: c.base + i,
                reference: None,
                words: 1,
                data_type: if c.object_type == ot::BINARY_INPUT {
                    "enum"
                } else {
                    "real"
                }
                .into(),
                scale: String::new(),
                access: if c.writable { "R/W" } else { "R" },
                object_name: Some(name),
            };
        if c.kind == Kind::LuminaireLevel {
            for (j, &id) in luminaire_ids.iter().enumerate() {
                let name =
                    crate::bacnet::objects::object_name(c.name, &format!("luminaire {id}"), id);
                rows.push(row(
                    format!("luminaire {id}"),
                    None,
                    Some(id),
                    j as u32,
                    name,
                ));
            }
        } else {
            for (k, p) in points.iter().enumerate() {
                let name = crate::bacnet::objects::object_name(c.name, &p.name, p.sensor_id);
                rows.push(row(p.name.clone(), Some(p), None, k as u32, name));
            }
        }
    }
    rows
}

/// The list as CSV (a header line, then one line per value; fields with a comma quoted).
pub fn to_csv(rows: &[PointRow]) -> String {
    let mut out = String::from(
        "point,sensor_id,desk_id,luminaire_id,quantity,unit,protocol,table,address,reference,words,data_type,scale,access,object_name\n",
    );
    let opt = |v: Option<u32>| v.map_or(String::new(), |v| v.to_string());
    for r in rows {
        let fields = [
            r.point.clone(),
            opt(r.sensor_id),
            opt(r.desk_id),
            opt(r.luminaire_id),
            r.quantity.clone(),
            r.unit.clone(),
            r.protocol.into(),
            r.table.clone(),
            r.address.to_string(),
            opt(r.reference),
            r.words.to_string(),
            r.data_type.clone(),
            r.scale.clone(),
            r.access.into(),
            r.object_name.clone().unwrap_or_default(),
        ];
        let line: Vec<String> = fields.iter().map(|f| csv_field(f)).collect();
        out.push_str(&line.join(","));
        out.push('\n');
    }
    out
}

fn csv_field(f: &str) -> String {
    if f.contains([',', '"', '\n']) {
        format!("\"{}\"", f.replace('"', "\"\""))
    } else {
        f.to_owned()
    }
}

/// The BACnet objects as an EDE file (Engineering Data Exchange, BIG-EU layout 2:
/// semicolon-separated, a header block, one line per object; the Device first), for device
/// instance `device_id` named `device_name`.
pub fn to_ede(rows: &[PointRow], project: &str, device_id: u32, device_name: &str) -> String {
    let clean = |s: &str| s.replace([';', '\n'], " ");
    let mut out = String::new();
    out.push_str("#Engineering-Data-Exchange - B.I.G.-EU\n");
    out.push_str(&format!("PROJECT_NAME;{}\n", clean(project)));
    out.push_str("VERSION_OF_REFERENCEFILE;1\n");
    out.push_str("TIMESTAMP_OF_LAST_CHANGE;\n");
    out.push_str("AUTHOR_OF_LAST_CHANGE;luxnode\n");
    out.push_str("VERSION_OF_LAYOUT;2\n");
    out.push_str("#mandatory;mandatory;mandatory;mandatory;mandatory;optional;optional;optional;optional;optional;optional;optional;optional;optional;optional;optional\n");
    out.push_str("# keyname;device obj.-instance;object-name;object-type;object-instance;description;present-value-default;min-present-value;max-present-value;settable;supports COV;hi-limit;low-limit;state-text-reference;unit-code;vendor-specific-address\n");
    let line =
        |key: &str, name: &str, ty: u16, inst: u32, desc: &str, settable: bool, unit: &str| {
            format!(
                "{};{device_id};{};{ty};{inst};{};;;;{};{};;;;{unit};\n",
                clean(key),
                clean(name),
                clean(desc),
                if settable { "Y" } else { "N" },
                // every object but the Device supports COV (docs/bacnet.md)
                if ty == ot::DEVICE { "N" } else { "Y" },
            )
        };
    out.push_str(&line(
        device_name,
        device_name,
        ot::DEVICE,
        device_id,
        "luxnode ceiling lighting node",
        false,
        "",
    ));
    for r in rows.iter().filter(|r| r.protocol == "bacnet") {
        let ty = match r.table.as_str() {
            "analog-input" => ot::ANALOG_INPUT,
            "analog-value" => ot::ANALOG_VALUE,
            _ => ot::BINARY_INPUT,
        };
        let unit = match r.unit.as_str() {
            "luxes" => units::LUXES.to_string(),
            "percent" => units::PERCENT.to_string(),
            _ => String::new(),
        };
        let name = r.object_name.clone().unwrap_or_default();
        let desc = format!("{}: {}", r.point, r.quantity);
        out.push_str(&line(
            &name,
            &name,
            ty,
            r.address,
            &desc,
            r.access == "R/W",
            &unit,
        ));
    }
    out
}

#[cfg(test)]
mod tests;
