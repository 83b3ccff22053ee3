//! Scenes with analytic answers (accuracy) and throughput measurement.

pub mod analytic;
pub mod scaling;
pub mod scenes;
pub mod throughput;
