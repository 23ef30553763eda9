//! Command-line pieces of the `luxnode` binary, one file per command family (the library
//! holds the logic).

pub mod bench_scaling;
pub mod modbus;
pub mod run;
pub mod tradeoffs;
