//! Benchmark suites behind `hardbody bench`.

pub mod ocsi;
