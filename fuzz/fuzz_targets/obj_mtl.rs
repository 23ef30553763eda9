//! cargo-fuzz target `obj_mtl`: the body is `bodies::obj_mtl` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run obj_mtl 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::obj_mtl(data));
