//! Benchmark suites behind `hardbody bench`.

pub mod compress;
pub mod edmd;
pub mod edmd_speed;
pub mod effects;
pub mod mc;
pub mod ocsi;
pub mod plot;
pub mod scene;
