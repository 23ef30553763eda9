//! cargo-fuzz target `flash_image`: the body is `bodies::flash_image` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run flash_image 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::flash_image(data));
