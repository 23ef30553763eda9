//! cargo-fuzz target `live_section`: the body is `bodies::live_section` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run live_section 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

// the base image is built in `init`, outside libFuzzer's per-input timeout
libfuzzer_sys::fuzz_target!(
    init: bodies::live_section_init(),
    |data: &[u8]| bodies::live_section(data)
);
