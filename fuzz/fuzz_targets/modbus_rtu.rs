//! cargo-fuzz target `modbus_rtu`: the body is `bodies::modbus_rtu` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run modbus_rtu 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::modbus_rtu(data));
