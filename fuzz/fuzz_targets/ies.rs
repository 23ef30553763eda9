//! cargo-fuzz target `ies`: the body is `bodies::ies` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run ies 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::ies(data));
