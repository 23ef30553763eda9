//! cargo-fuzz target `calibration_record`: the body is `bodies::calibration_record` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run calibration_record 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::calibration_record(data));
