//! The house stays straight: every `crate::` path in `src/` (outside the binary) goes from a
//! module to a module of a lower layer of the table in `src/lib.rs`, and every module of
//! `src/` is in that table. The table is parsed from the crate docs, so the docs are the rule.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The layer table of `src/lib.rs`: module -> layer.
fn layers(lib_rs: &str) -> BTreeMap<String, u32> {
    let mut out = BTreeMap::new();
    for line in lib_rs.lines() {
        let Some(row) = line.strip_prefix("//! | ") else {
            continue;
        };
        let mut cells = row.split('|');
        let (Some(layer), Some(modules)) = (cells.next(), cells.next()) else {
            continue;
        };
        let Ok(layer) = layer.trim().parse::<u32>() else {
            continue;
        };
        for name in modules.split(',') {
            let name = name.trim().trim_matches('`');
            assert!(
                !name.is_empty()
                    && name
                        .chars()
                        .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'),
                "layer {layer}: {name:?} is not a module name"
            );
            assert!(
                out.insert(name.to_owned(), layer).is_none(),
                "{name} is in the table twice"
            );
        }
    }
    out
}

/// Source without comments and string contents (doc links are not dependencies).
fn strip(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' {
            out.push('"');
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                }
                i += 1;
            }
            out.push('"');
            i += 1;
        } else if b[i] == b'\'' && b.get(i + 2) == Some(&b'\'') {
            // a char literal such as '"' or '{'
            out.push_str("' '");
            i += 3;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

fn ident_at(s: &str) -> Option<&str> {
    let s = s.trim_start();
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    (end > 0).then(|| &s[..end])
}

/// The top-level modules a file's code names: `crate::x`, `crate::{x::.., y}`, and `super::x`
/// where the `super`s climb to the crate root (`depth` is the file's module depth).
fn named_modules(code: &str, depth: usize) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(k) = rest.find("crate::") {
        let after = &rest[k + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            // the items of the group at depth 1
            let mut level = 1;
            let mut item_start = true;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => level += 1,
                    '}' => {
                        level -= 1;
                        if level == 0 {
                            break;
                        }
                    }
                    ',' if level == 1 => item_start = true,
                    c if item_start && level == 1 && !c.is_whitespace() => {
                        if let Some(id) = ident_at(&group[i..]) {
                            out.insert(id.to_owned());
                        }
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else if let Some(id) = ident_at(after) {
            out.insert(id.to_owned());
        }
        rest = after;
    }
    let mut rest = code;
    while let Some(k) = rest.find("super::") {
        // count the chain
        let mut n = 0;
        let mut tail = &rest[k..];
        while let Some(t) = tail.strip_prefix("super::") {
            n += 1;
            tail = t;
        }
        let word_start = k == 0 || !rest[..k].ends_with(|c: char| c.is_alphanumeric() || c == '_');
        if word_start
            && n == depth
            && let Some(id) = ident_at(tail)
        {
            out.insert(id.to_owned());
        }
        rest = tail;
    }
    out
}

/// (top-level module, module depth) of a file under `src/`, `None` for the binary.
fn module_of(rel: &Path) -> Option<(String, usize)> {
    let parts: Vec<String> = rel
        .with_extension("")
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let first = parts.first()?.clone();
    if first == "main" || first == "cli" || first == "lib" {
        return None;
    }
    let depth = if parts.last().map(String::as_str) == Some("mod") {
        parts.len() - 1
    } else {
        parts.len()
    };
    Some((first, depth))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("src") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Every edge `from -> to` between top-level modules, with a file that makes it.
fn edges(known: &BTreeSet<String>) -> BTreeMap<(String, String), PathBuf> {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    files.sort();
    let mut out = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(src()).expect("under src").to_owned();
        let Some((from, depth)) = module_of(&rel) else {
            continue;
        };
        let code = strip(&std::fs::read_to_string(&f).expect("read"));
        for to in named_modules(&code, depth) {
            if to != from && known.contains(&to) {
                out.entry((from.clone(), to)).or_insert_with(|| rel.clone());
            }
        }
    }
    out
}

#[test]
fn every_module_uses_only_lower_layers() {
    let lib = std::fs::read_to_string(src().join("lib.rs")).expect("lib.rs");
    let layer = layers(&lib);
    assert!(layer.len() > 10, "the layer table of src/lib.rs: {layer:?}");
    // every module the crate declares is in the table, and nothing else is
    let declared: BTreeSet<String> = strip(&lib)
        .lines()
        .filter_map(|l| {
            let l = l.trim();
            let l = l.strip_prefix("pub ").unwrap_or(l);
            l.strip_prefix("mod ")
                .and_then(|r| ident_at(r).map(str::to_owned))
        })
        .collect();
    let table: BTreeSet<String> = layer.keys().cloned().collect();
    assert_eq!(
        declared, table,
        "the modules of src/lib.rs and the layer table differ"
    );
    let mut wrong = Vec::new();
    for ((from, to), file) in edges(&table) {
        if layer[&to] >= layer[&from] {
            wrong.push(format!(
                "{from} (layer {}) uses {to} (layer {}) in src/{}",
                layer[&from],
                layer[&to],
                file.display()
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "edges against the layer order of src/lib.rs:\n  {}",
        wrong.join("\n  ")
    );
}

#[test]
fn the_checker_sees_what_it_must() {
    // paths, groups, super chains to the root; not comments, strings or deeper supers
    let code = strip(
        "use crate::engine::Model;\n\
         use crate::{scene::{Scene, Camera}, store, units::Lux};\n\
         // crate::daemon in a comment\n\
         let s = \"crate::board in a string\";\n\
         let c = '{';\n\
         fn f() { crate::render::draw(); super::super::sim::x(); super::local(); }",
    );
    let at_depth_2: Vec<String> = named_modules(&code, 2).into_iter().collect();
    assert_eq!(
        at_depth_2,
        ["engine", "render", "scene", "sim", "store", "units"]
    );
    let at_depth_1: Vec<String> = named_modules(&code, 1).into_iter().collect();
    assert!(at_depth_1.contains(&"local".to_owned()));
    assert!(!at_depth_1.contains(&"sim".to_owned()));
    assert_eq!(
        module_of(Path::new("engine/mod.rs")),
        Some(("engine".into(), 1))
    );
    assert_eq!(
        module_of(Path::new("engine/raycast.rs")),
        Some(("engine".into(), 2))
    );
    assert_eq!(
        module_of(Path::new("evaluate.rs")),
        Some(("evaluate".into(), 1))
    );
    assert_eq!(module_of(Path::new("cli/run.rs")), None);
    let t = layers("//! | 0 | `units`, `rng` | x |\n//! | 2 | `store` | y |\n//! | a | b |");
    assert_eq!(t.get("rng"), Some(&0));
    assert_eq!(t.get("store"), Some(&2));
    assert_eq!(t.len(), 3);
}

#[test]
fn the_node_knows_no_protocol() {
    // the application state: no wire format, no server, no network; the protocols are
    // adapters over it (`fieldbus`), never the other way round
    let mut files = Vec::new();
    rust_files(&src().join("node"), &mut files);
    assert!(!files.is_empty(), "src/node/");
    for f in files {
        let code = strip(&std::fs::read_to_string(&f).expect("read"));
        for word in [
            "modbus::pdu",
            "modbus::frame",
            "fieldbus",
            "tokio",
            "PduHandler",
        ] {
            assert!(
                !code.contains(word),
                "{} names {word}: the node must not know a protocol",
                f.display()
            );
        }
    }
}

/// The node's run-time path: boot from the image, the run-time core, live light, control and
/// the registers. None of it may reach the commissioning side (a node that has its image runs
/// without the mesh, the engine or the section builder).
const RUN_TIME_PATH: &[&str] = &[
    "solver.rs",
    "store",
    "runtime.rs",
    "control",
    "modbus",
    "node",
    "fieldbus",
    "live",
    "daemon/live.rs",
];

/// The commissioning side's modules.
const COMMISSIONING: &[&str] = &[
    "commission",
    "engine",
    "image_build",
    "image_geometry",
    "live_section",
    "scene",
    "photometry",
];

#[test]
fn the_run_time_path_does_not_reach_commissioning() {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    files.sort();
    let mut wrong = Vec::new();
    let mut checked = 0;
    for f in files {
        let rel = f.strip_prefix(src()).expect("under src").to_owned();
        let on_path = RUN_TIME_PATH
            .iter()
            .any(|p| rel == Path::new(p) || (!p.ends_with(".rs") && rel.starts_with(Path::new(p))));
        let Some((_, depth)) = module_of(&rel).filter(|_| on_path) else {
            continue;
        };
        checked += 1;
        let code = strip(&std::fs::read_to_string(&f).expect("read"));
        for to in named_modules(&code, depth) {
            if COMMISSIONING.contains(&to.as_str()) {
                wrong.push(format!("src/{} uses {to}", rel.display()));
            }
        }
    }
    assert!(checked > 20, "only {checked} files on the run-time path");
    assert!(
        wrong.is_empty(),
        "the run-time path reaches the commissioning side:\n  {}",
        wrong.join("\n  ")
    );
}
