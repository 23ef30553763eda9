//! cargo-fuzz target `capture_png`: the body is `bodies::capture_png` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run capture_png 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::capture_png(data));
