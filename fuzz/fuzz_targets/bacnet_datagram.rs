//! cargo-fuzz target `bacnet_datagram`: the body is `bodies::bacnet_datagram` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run bacnet_datagram 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::bacnet_datagram(data));
