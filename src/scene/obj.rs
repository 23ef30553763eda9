//! Wavefront OBJ + MTL reader for scene geometry: triangles with a group label and a grey
//! diffuse reflectance (`Kd`). Polygons are fanned into triangles; zero-area triangles are
//! dropped and counted; every malformed statement is an error naming file and line.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::{Material, Mesh, SceneError, Triangle};
use crate::units::Reflectance;

/// What the OBJ reader found besides the mesh.
#[derive(Debug, Default, Clone)]
pub struct ObjReport {
    /// Triangles dropped because their area is zero (degenerate).
    pub zero_area_dropped: usize,
    /// Statements that were skipped (texture coordinates, normals, lines, unknown keywords).
    pub skipped_statements: usize,
    /// Non-fatal findings (coloured `Kd` reduced to grey, unused materials).
    pub warnings: Vec<String>,
}

/// Reads `path` (and the MTL files it names, relative to it). Coordinates are multiplied by
/// `unit_to_m` (1 for metres, 0.001 for millimetres).
pub fn load_obj(path: &Path, unit_to_m: f64) -> Result<(Mesh, ObjReport), SceneError> {
    let text = super::read_text(path)?;
    parse_obj(&text, path, unit_to_m, &|name: &str| {
        let p = path.parent().unwrap_or(Path::new(".")).join(name);
        let t = super::read_text(&p)?;
        parse_mtl(&t, &p)
    })
}

type MtlLoader<'a> = dyn Fn(&str) -> Result<(Vec<Material>, Vec<String>), SceneError> + 'a;

pub(crate) fn parse_obj(
    text: &str,
    path: &Path,
    unit_to_m: f64,
    load_mtl: &MtlLoader<'_>,
) -> Result<(Mesh, ObjReport), SceneError> {
    let err = |line: usize, message: String| SceneError::Syntax {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut report = ObjReport::default();
    let mut mesh = Mesh::default();
    let mut material_index: HashMap<String, u32> = HashMap::new();
    let mut group_index: HashMap<String, u32> = HashMap::new();
    let mut current_group: Option<u32> = None;
    let mut current_material: Option<u32> = None;
    let mut used_materials: Vec<bool> = Vec::new();

    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let mut parts = line.split_whitespace();
        let keyword = parts.next().unwrap_or("");
        match keyword {
            "v" => {
                let p = vertex(&mut parts, unit_to_m).map_err(|m| err(line_no, m))?;
                mesh.positions_m.push(p);
            }
            "f" => {
                let Some(material) = current_material else {
                    return Err(err(
                        line_no,
                        "face before any `usemtl`: every face needs a material (its reflectance)"
                            .into(),
                    ));
                };
                let group = match current_group {
                    Some(g) => g,
                    None => intern(&mut group_index, &mut mesh.groups, "default"),
                };
                let idx = face(parts, mesh.positions_m.len()).map_err(|m| err(line_no, m))?;
                used_materials[material as usize] = true;
                for k in 1..idx.len() - 1 {
                    let t = Triangle {
                        v: [idx[0], idx[k], idx[k + 1]],
                        group,
                        material,
                    };
                    if mesh.is_degenerate(&t) {
                        report.zero_area_dropped += 1;
                    } else {
                        mesh.triangles.push(t);
                    }
                }
            }
            "g" | "o" => {
                let name = parts.collect::<Vec<_>>().join(" ");
                let name = if name.is_empty() { "default" } else { &name };
                current_group = Some(intern(&mut group_index, &mut mesh.groups, name));
            }
            "usemtl" => {
                let name = parts.collect::<Vec<_>>().join(" ");
                let m = material_index.get(&name).copied().ok_or_else(|| {
                    err(
                        line_no,
                        format!("material {name:?} is not defined in any mtllib"),
                    )
                })?;
                current_material = Some(m);
            }
            "mtllib" => {
                for name in parts {
                    let (materials, warnings) = load_mtl(name)?;
                    report.warnings.extend(warnings);
                    for m in materials {
                        if let Some(&existing) = material_index.get(&m.name) {
                            mesh.materials[existing as usize] = m;
                        } else {
                            material_index.insert(m.name.clone(), mesh.materials.len() as u32);
                            mesh.materials.push(m);
                            used_materials.push(false);
                        }
                    }
                }
            }
            "vt" | "vn" | "vp" | "s" | "l" | "p" => report.skipped_statements += 1,
            "curv" | "curv2" | "surf" | "cstype" | "deg" | "bmat" | "step" => {
                return Err(err(
                    line_no,
                    format!("free-form geometry ({keyword}) is not supported; triangulate it"),
                ));
            }
            _ => report.skipped_statements += 1,
        }
    }
    for (m, used) in mesh.materials.iter().zip(&used_materials) {
        if !used {
            report
                .warnings
                .push(format!("material {:?} is defined but never used", m.name));
        }
    }
    if mesh.triangles.is_empty() {
        return Err(SceneError::Invalid {
            path: path.to_path_buf(),
            what: "geometry".into(),
            message: "no triangles with non-zero area".into(),
        });
    }
    Ok((mesh, report))
}

/// A `v` statement's point (its first three coordinates, times `unit_to_m`), or why not.
fn vertex<'a>(parts: &mut impl Iterator<Item = &'a str>, unit_to_m: f64) -> Result<DVec3, String> {
    let mut xyz = [0.0f64; 3];
    for (k, c) in xyz.iter_mut().enumerate() {
        let t = parts
            .next()
            .ok_or_else(|| format!("vertex needs 3 coordinates, found {k}"))?;
        let v: f64 = t
            .parse()
            .map_err(|_| format!("vertex coordinate {t:?} is not a number"))?;
        if !v.is_finite() {
            return Err(format!("vertex coordinate {t:?} is not finite"));
        }
        *c = v * unit_to_m;
    }
    Ok(DVec3::from_array(xyz))
}

/// An `f` statement's vertex indices (from 0; negative ones count back from the `n` vertices so
/// far), at least 3, or why not.
fn face<'a>(parts: impl Iterator<Item = &'a str>, n: usize) -> Result<Vec<u32>, String> {
    let n = n as i64;
    let mut idx = Vec::new();
    for t in parts {
        let first = t.split('/').next().unwrap_or("");
        let k: i64 = first
            .parse()
            .map_err(|_| format!("face vertex {t:?} is not an index"))?;
        let resolved = if k > 0 { k - 1 } else { n + k };
        if k == 0 || resolved < 0 || resolved >= n {
            return Err(format!(
                "face vertex index {k} out of range (1..={n} vertices so far)"
            ));
        }
        idx.push(resolved as u32);
    }
    if idx.len() < 3 {
        return Err(format!(
            "a face needs at least 3 vertices, found {}",
            idx.len()
        ));
    }
    Ok(idx)
}

fn intern(index: &mut HashMap<String, u32>, names: &mut Vec<String>, name: &str) -> u32 {
    if let Some(&i) = index.get(name) {
        return i;
    }
    let i = names.len() as u32;
    names.push(name.to_owned());
    index.insert(name.to_owned(), i);
    i
}

/// Reads an MTL file: `newmtl` and its grey diffuse reflectance `Kd`. Other statements
/// (`Ka`, `Ks`, `Ns`, `d`, `illum`, maps) do not affect a diffuse radiosity model and are
/// ignored. Returns the materials and warnings.
pub(crate) fn parse_mtl(
    text: &str,
    path: &Path,
) -> Result<(Vec<Material>, Vec<String>), SceneError> {
    let err = |line: usize, message: String| SceneError::Syntax {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut out: Vec<(Material, usize, bool)> = Vec::new();
    let mut warnings = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("newmtl") => {
                let name = parts.collect::<Vec<_>>().join(" ");
                if name.is_empty() {
                    return Err(err(line_no, "newmtl without a name".into()));
                }
                out.push((
                    Material {
                        name,
                        rho: Reflectance::ZERO,
                    },
                    line_no,
                    false,
                ));
            }
            Some("Kd") => {
                let Some((m, _, has_kd)) = out.last_mut() else {
                    return Err(err(line_no, "Kd before any newmtl".into()));
                };
                let vals: Vec<&str> = parts.collect();
                if vals.first().is_some_and(|v| {
                    v.eq_ignore_ascii_case("spectral") || v.eq_ignore_ascii_case("xyz")
                }) {
                    return Err(err(line_no, "Kd must be given as r g b values".into()));
                }
                let nums = vals
                    .iter()
                    .map(|t| {
                        t.parse::<f64>()
                            .ok()
                            .filter(|v| v.is_finite())
                            .ok_or_else(|| err(line_no, format!("Kd value {t:?} is not a number")))
                    })
                    .collect::<Result<Vec<f64>, _>>()?;
                let rho = match nums.as_slice() {
                    [g] => *g,
                    [r, g, b] => {
                        if (r - g).abs() > 1e-6 || (g - b).abs() > 1e-6 {
                            let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
                            warnings.push(format!(
                                "{}:{line_no}: material {:?} has a coloured Kd; its luminance \
                                 {y:.4} is used",
                                path.display(),
                                m.name
                            ));
                            y
                        } else {
                            *g
                        }
                    }
                    _ => {
                        return Err(err(
                            line_no,
                            format!("Kd needs 1 or 3 values, found {}", nums.len()),
                        ));
                    }
                };
                m.rho = Reflectance::new(rho)
                    .map_err(|e| err(line_no, format!("material {:?}: {e}", m.name)))?;
                *has_kd = true;
            }
            _ => {}
        }
    }
    for (m, line, has_kd) in &out {
        if !has_kd {
            return Err(err(
                *line,
                format!("material {:?} has no Kd (diffuse reflectance)", m.name),
            ));
        }
    }
    Ok((out.into_iter().map(|(m, _, _)| m).collect(), warnings))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    const MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl black\nKd 0\n";

    fn parse(obj: &str) -> Result<(Mesh, ObjReport), SceneError> {
        parse_obj(obj, &PathBuf::from("t.obj"), 1.0, &|_| {
            parse_mtl(MTL, &PathBuf::from("t.mtl"))
        })
    }

    fn line_of(e: &SceneError) -> usize {
        match e {
            SceneError::Syntax { line, .. } => *line,
            other => panic!("not a syntax error: {other}"),
        }
    }

    #[test]
    fn quad_is_fanned_and_degenerate_dropped() {
        let obj = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\ng floor\n\
                   usemtl grey\nf 1 2 3 4\nf 1/1/1 2//1 5\n";
        let (mesh, report) = parse(obj).unwrap();
        assert_eq!(mesh.triangles.len(), 2);
        assert_eq!(report.zero_area_dropped, 1);
        assert!((mesh.area_m2(&mesh.triangles[0]) - 0.5).abs() < 1e-12);
        assert_eq!(mesh.groups, vec!["floor"]);
        assert!(report.warnings.iter().any(|w| w.contains("black")));
    }

    #[test]
    fn negative_indices_are_relative() {
        let obj = "mtllib t.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n";
        let (mesh, _) = parse(obj).unwrap();
        assert_eq!(mesh.triangles[0].v, [0, 1, 2]);
    }

    #[test]
    fn errors_name_the_line() {
        let bad_index = "mtllib t.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nf 1 2 9\n";
        assert_eq!(line_of(&parse(bad_index).unwrap_err()), 5);
        let no_mtl = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        assert_eq!(line_of(&parse(no_mtl).unwrap_err()), 4);
        let unknown_mtl = "mtllib t.mtl\nusemtl gold\n";
        assert_eq!(line_of(&parse(unknown_mtl).unwrap_err()), 2);
        let nan = "v 0 nan 0\n";
        assert_eq!(line_of(&parse(nan).unwrap_err()), 1);
        let inf = "v 0 1e999 0\n";
        assert_eq!(line_of(&parse(inf).unwrap_err()), 1);
        let short = "v 0 1\n";
        assert_eq!(line_of(&parse(short).unwrap_err()), 1);
        let two = "mtllib t.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nf 1 2\n";
        assert_eq!(line_of(&parse(two).unwrap_err()), 5);
    }

    #[test]
    fn reflectance_must_be_below_one() {
        let e = parse_mtl("newmtl white\nKd 1 1 1\n", Path::new("w.mtl")).unwrap_err();
        assert_eq!(line_of(&e), 2);
        assert!(e.to_string().contains("[0, 1)"), "{e}");
        let e = parse_mtl("newmtl neg\nKd -0.1\n", Path::new("w.mtl")).unwrap_err();
        assert_eq!(line_of(&e), 2);
        let e = parse_mtl("newmtl none\nKs 1 1 1\n", Path::new("w.mtl")).unwrap_err();
        assert!(e.to_string().contains("no Kd"), "{e}");
        let (m, w) = parse_mtl("newmtl red\nKd 0.5 0.1 0.1\n", Path::new("w.mtl")).unwrap();
        assert!((m[0].rho.get() - (0.2126 * 0.5 + 0.7152 * 0.1 + 0.0722 * 0.1)).abs() < 1e-12);
        assert_eq!(w.len(), 1);
    }

    #[test]
    fn millimetres_scale_to_metres() {
        let obj = "mtllib t.mtl\nusemtl grey\nv 0 0 0\nv 1000 0 0\nv 0 2000 0\nf 1 2 3\n";
        let (mesh, _) = parse_obj(obj, Path::new("t.obj"), 0.001, &|_| {
            parse_mtl(MTL, Path::new("t.mtl"))
        })
        .unwrap();
        assert!((mesh.area_m2(&mesh.triangles[0]) - 1.0).abs() < 1e-12);
    }
}
