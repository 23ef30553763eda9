//! Reads the memory regions from `memory.x` so that the code sizes things against the linker
//! script itself, never a copied number. Writes `$OUT_DIR/memory_layout.rs` with the
//! `FORMFACTORS` region's origin and length. (Bare-metal targets also get `memory.x` on the
//! linker search path, for cortex-m-rt.)

use std::env;
use std::fs;
use std::path::PathBuf;

fn parse_number(s: &str) -> Option<u64> {
    let s = s.trim();
    let (digits, mult) = match s.chars().last()? {
        'K' | 'k' => (&s[..s.len() - 1], 1024),
        'M' | 'm' => (&s[..s.len() - 1], 1024 * 1024),
        _ => (s, 1),
    };
    let v = if let Some(hex) = digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
    {
        u64::from_str_radix(&hex.replace('_', ""), 16).ok()?
    } else {
        digits.replace('_', "").parse().ok()?
    };
    v.checked_mul(mult)
}

/// (origin, length) of a named region in the MEMORY block.
fn region(text: &str, name: &str) -> Option<(u64, u64)> {
    // strip /* */ comments
    let mut clean = String::new();
    let mut rest = text;
    while let Some(start) = rest.find("/*") {
        clean.push_str(&rest[..start]);
        rest = rest[start..]
            .find("*/")
            .map_or("", |end| &rest[start + end + 2..]);
    }
    clean.push_str(rest);
    for line in clean.lines() {
        let line = line.trim();
        let Some((head, attrs)) = line.split_once(':') else {
            continue;
        };
        if head.split_whitespace().next() != Some(name) {
            continue;
        }
        let mut origin = None;
        let mut length = None;
        for part in attrs.split(',') {
            let Some((k, v)) = part.split_once('=') else {
                continue;
            };
            match k.trim().to_ascii_uppercase().as_str() {
                "ORIGIN" | "ORG" | "O" => origin = parse_number(v),
                "LENGTH" | "LEN" | "L" => length = parse_number(v),
                _ => {}
            }
        }
        return Some((origin?, length?));
    }
    None
}

fn main() {
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    let text = fs::read_to_string("memory.x").expect("memory.x must exist at the package root");
    let (origin, length) = region(&text, "FORMFACTORS")
        .expect("memory.x must define a FORMFACTORS region with ORIGIN and LENGTH");
    let (_, ram) = region(&text, "RAM").expect("memory.x must define RAM");
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    fs::write(
        out.join("memory_layout.rs"),
        format!(
            "/// Start address of the `FORMFACTORS` flash region (from memory.x).\n\
             pub const FORMFACTORS_ORIGIN: u64 = {origin:#x};\n\
             /// Size of the `FORMFACTORS` flash region in bytes (from memory.x).\n\
             pub const FORMFACTORS_LEN_BYTES: u64 = {length};\n\
             /// Size of the RAM region in bytes (from memory.x).\n\
             pub const RAM_LEN_BYTES: u64 = {ram};\n"
        ),
    )
    .expect("write memory_layout.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        fs::copy("memory.x", out.join("memory.x")).expect("copy memory.x");
        println!("cargo:rustc-link-search={}", out.display());
    }
}
