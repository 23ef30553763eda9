//! cargo-fuzz target `eulumdat`: the body is `bodies::eulumdat` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run eulumdat 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::eulumdat(data));
