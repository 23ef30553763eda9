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
    "occupancy",
    "daemon/live.rs",
    "daemon/occupancy.rs",
];

/// The commissioning side's modules.
const COMMISSIONING: &[&str] = &[
    "commission",
    "engine",
    "image_build",
    "image_geometry",
    "live_section",
    "daylight_section",
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

/// The most lines a function in `src/` may span, from its `fn` line to its closing brace.
const MAX_FN_LINES: usize = 150;

/// Functions allowed over [`MAX_FN_LINES`], as `path under src/::name` with their length when
/// listed: none since issue 27 (a long function is split into its stages, not listed). The
/// test fails on a listed function that grew, and on an entry whose function is no longer over.
const LONG_FNS_ALLOWED: &[(&str, usize)] = &[];

/// Source with comments, strings and character literals blanked to spaces (every newline
/// kept, so lines still count): nested block comments, raw and byte strings, escapes, and
/// lifetimes (which are not character literals).
fn blank_non_code(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |out: &mut String, s: &[char]| {
        for &ch in s {
            out.push(if ch == '\n' { '\n' } else { ' ' });
        }
    };
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let prev_ident = i > 0 && ident(c[i - 1]);
        if c[i] == '/' && c.get(i + 1) == Some(&'/') {
            let end = (i..c.len()).find(|&k| c[k] == '\n').unwrap_or(c.len());
            blank(&mut out, &c[i..end]);
            i = end;
        } else if c[i] == '/' && c.get(i + 1) == Some(&'*') {
            let (mut k, mut depth) = (i + 2, 1);
            while k < c.len() && depth > 0 {
                if c[k] == '/' && c.get(k + 1) == Some(&'*') {
                    depth += 1;
                    k += 2;
                } else if c[k] == '*' && c.get(k + 1) == Some(&'/') {
                    depth -= 1;
                    k += 2;
                } else {
                    k += 1;
                }
            }
            blank(&mut out, &c[i..k.min(c.len())]);
            i = k;
        } else if !prev_ident && (c[i] == 'r' || (c[i] == 'b' && c.get(i + 1) == Some(&'r'))) && {
            let mut k = i + if c[i] == 'b' { 2 } else { 1 };
            while c.get(k) == Some(&'#') {
                k += 1;
            }
            c.get(k) == Some(&'"')
        } {
            // raw string: r"..", r#".."#, br".."
            let mut k = i + if c[i] == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while c[k] == '#' {
                hashes += 1;
                k += 1;
            }
            k += 1;
            while k < c.len() && !(c[k] == '"' && (1..=hashes).all(|h| c.get(k + h) == Some(&'#')))
            {
                k += 1;
            }
            let end = (k + 1 + hashes).min(c.len());
            blank(&mut out, &c[i..end]);
            i = end;
        } else if c[i] == '"' {
            let mut k = i + 1;
            while k < c.len() && c[k] != '"' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            let end = (k + 1).min(c.len());
            blank(&mut out, &c[i..end]);
            i = end;
        } else if c[i] == '\'' {
            // a character literal ('x', '\n', '\'', '\u{7b}'), or a lifetime ('a)
            let end = if c.get(i + 1) == Some(&'\\') {
                (i + 2..c.len()).find(|&k| c[k] == '\'' && k > i + 2)
            } else if c.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match end {
                Some(e) => {
                    blank(&mut out, &c[i..=e]);
                    i = e + 1;
                }
                None => {
                    out.push('\'');
                    i += 1;
                }
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// Every function with a body in `code` (blanked by [`blank_non_code`]): (name, first line
/// from 1, lines from its `fn` to its closing brace).
fn functions(code: &str) -> Vec<(String, usize, usize)> {
    let c: Vec<char> = code.chars().collect();
    // line (from 1) of every char
    let mut line_of = Vec::with_capacity(c.len());
    let mut line = 1;
    for &ch in &c {
        line_of.push(line);
        if ch == '\n' {
            line += 1;
        }
    }
    let line_at = |k: usize| line_of[k];
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut out = Vec::new();
    for i in 0..c.len() {
        let is_fn = c[i] == 'f'
            && c.get(i + 1) == Some(&'n')
            && (i == 0 || !ident(c[i - 1]))
            && c.get(i + 2).is_some_and(|ch| ch.is_whitespace());
        if !is_fn {
            continue;
        }
        let start = (i + 2..c.len())
            .find(|&k| !c[k].is_whitespace())
            .unwrap_or(c.len());
        let end = (start..c.len()).find(|&k| !ident(c[k])).unwrap_or(c.len());
        if end == start {
            continue; // `fn(u32) -> u32`, a pointer type
        }
        let name: String = c[start..end].iter().collect();
        // the body's `{`, unless a `;` ends a declaration first (outside () and [])
        let mut nest = 0i32;
        let mut open = None;
        for (k, &ch) in c.iter().enumerate().skip(end) {
            match ch {
                '(' | '[' => nest += 1,
                ')' | ']' => nest -= 1,
                ';' if nest == 0 => break,
                '{' if nest == 0 => {
                    open = Some(k);
                    break;
                }
                _ => {}
            }
        }
        let Some(open) = open else { continue };
        let mut depth = 0;
        let mut close = c.len() - 1;
        for (k, &ch) in c.iter().enumerate().skip(open) {
            match ch {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        close = k;
                        break;
                    }
                }
                _ => {}
            }
        }
        let first = line_at(i);
        out.push((name, first, line_at(close) - first + 1));
    }
    out
}

#[test]
fn every_function_is_at_most_150_lines() {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    files.sort();
    let allowed: BTreeMap<&str, usize> = LONG_FNS_ALLOWED.iter().copied().collect();
    let mut long: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for f in &files {
        let rel = f.strip_prefix(src()).expect("under src").to_owned();
        let code = blank_non_code(&std::fs::read_to_string(f).expect("read"));
        for (name, line, lines) in functions(&code) {
            if lines > MAX_FN_LINES {
                let key = format!("{}::{name}", rel.display()).replace('\\', "/");
                let e = long.entry(key).or_insert((line, 0));
                e.1 = e.1.max(lines);
            }
        }
    }
    let over: Vec<String> = long
        .iter()
        .filter(|(k, _)| !allowed.contains_key(k.as_str()))
        .map(|(k, (line, n))| format!("src/{k} (line {line}): {n} lines"))
        .collect();
    assert!(
        over.is_empty(),
        "functions over {MAX_FN_LINES} lines (split them into named stages):\n  {}",
        over.join("\n  ")
    );
    let grown: Vec<String> = long
        .iter()
        .filter_map(|(k, (_, n))| {
            let listed = *allowed.get(k.as_str())?;
            (*n > listed).then(|| format!("src/{k}: {n} lines, listed at {listed}"))
        })
        .collect();
    assert!(
        grown.is_empty(),
        "allowed long functions grew (split them instead):\n  {}",
        grown.join("\n  ")
    );
    let stale: Vec<&str> = allowed
        .keys()
        .filter(|k| !long.contains_key(**k))
        .copied()
        .collect();
    assert!(
        stale.is_empty(),
        "no longer over {MAX_FN_LINES} lines: take them off LONG_FNS_ALLOWED:\n  {}",
        stale.join("\n  ")
    );
}

#[test]
fn the_line_counter_sees_what_it_must() {
    let code = blank_non_code(
        "fn a() {\n\
         \x20   let s = \"}\\\" {\";\n\
         \x20   let r = r#\"}\"{\"#;\n\
         \x20   let c = '}';\n\
         \x20   let e = '\\'';\n\
         \x20   let u = '\\u{7b}';\n\
         \x20   // }\n\
         \x20   /* } /* nested } */ } */\n\
         \x20   fn inner<'a>(x: &'a [u8; 4]) -> &'a u8 { if true { &x[0] } else { &x[1] } }\n\
         }\n\
         trait T { fn decl(&self) -> [u8; 2]; fn with_default(&self) {} }\n\
         fn p(f: fn(u32) -> u32) -> u32 {\n\
         \x20   f(1)\n\
         }\n",
    );
    assert_eq!(code.lines().count(), 14, "newlines kept");
    let found = functions(&code);
    let get = |n: &str| found.iter().find(|f| f.0 == n).map(|f| (f.1, f.2));
    assert_eq!(get("a"), Some((1, 10)));
    assert_eq!(get("inner"), Some((9, 1)));
    assert_eq!(get("decl"), None);
    assert_eq!(get("with_default"), Some((11, 1)));
    assert_eq!(get("p"), Some((12, 3)));
    assert_eq!(found.len(), 4, "{found:?}");
}

/// docs/architecture.md's picture of the house names every module of the layer table with its
/// layer number, so the page a newcomer reads stays the rule's picture.
#[test]
fn the_architecture_picture_names_every_module_at_its_layer() {
    let lib = std::fs::read_to_string(src().join("lib.rs")).expect("lib.rs");
    let layer = layers(&lib);
    let doc_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md");
    let doc = std::fs::read_to_string(&doc_path).expect("docs/architecture.md");
    let picture = doc
        .split("```text")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("a ```text picture in docs/architecture.md");
    let names = |line: &str| -> BTreeSet<String> {
        line.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .filter(|w| !w.is_empty())
            .map(str::to_owned)
            .collect()
    };
    let missing: Vec<String> = layer
        .iter()
        .filter(|(name, l)| {
            !picture
                .lines()
                .any(|line| names(line).contains(*name) && line.contains(&format!("({l})")))
        })
        .map(|(name, l)| format!("{name} (layer {l})"))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/architecture.md's picture misses: {}",
        missing.join(", ")
    );
}

/// Issue 31 items 6 and 9: the repository stands alone. No tracked text file names a path of a
/// developer's machine, or a file of `../shared/` (the reference material outside the
/// repository); `reference/README.md` alone may, to say where its copies came from.
#[test]
fn no_tracked_file_names_a_machine_path_or_a_file_outside_the_repository() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let Ok(out) = std::process::Command::new("git")
        .args(["ls-files"])
        .current_dir(root)
        .output()
    else {
        eprintln!("SKIP: git is not installed; the tracked files cannot be listed");
        return;
    };
    let files = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(files.lines().count() > 100, "git ls-files: {files}");
    let text = [
        "rs", "py", "sh", "toml", "md", "json", "yml", "yaml", "html", "txt", "csv",
    ];
    let mut bad = Vec::new();
    for f in files.lines() {
        let is_text = Path::new(f)
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| text.contains(&e));
        if !is_text || f == "reference/README.md" || f.starts_with("reference/scenes/") {
            continue;
        }
        let Ok(s) = std::fs::read_to_string(root.join(f)) else {
            continue;
        };
        for (n, line) in s.lines().enumerate() {
            let outside = line
                .match_indices("../shared/")
                .any(|(i, m)| line[i + m.len()..].starts_with(|c: char| c.is_ascii_alphabetic()));
            let machine = ["work", "home", "root", "Users"]
                .iter()
                .any(|d| line.contains(&format!("/{d}/")));
            if outside || machine {
                bad.push(format!("{f}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "paths outside the repository:\n{}",
        bad.join("\n")
    );
}
