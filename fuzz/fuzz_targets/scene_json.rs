//! cargo-fuzz target `scene_json`: the body is `bodies::scene_json` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run scene_json 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::scene_json(data));
