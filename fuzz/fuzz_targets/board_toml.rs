//! cargo-fuzz target `board_toml`: the body is `bodies::board_toml` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run board_toml 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::board_toml(data));
