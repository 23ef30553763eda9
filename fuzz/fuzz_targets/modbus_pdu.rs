//! cargo-fuzz target `modbus_pdu`: the body is `bodies::modbus_pdu` (fuzz/bodies.rs), shared with the stable
//! smoke test. Run: `scripts/fuzz.sh run modbus_pdu 300` (docs/fuzzing.md).
#![no_main]

#[path = "../bodies.rs"]
mod bodies;

libfuzzer_sys::fuzz_target!(|data: &[u8]| bodies::modbus_pdu(data));
