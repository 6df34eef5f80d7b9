//! Benchmark suites behind `hardbody bench`.

pub mod mc;
pub mod ocsi;
pub mod scene;
