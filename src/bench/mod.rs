//! Benchmarks: scenes with analytic answers, the runtime-against-error sweep and its plot,
//! throughput and scaling.

pub mod analytic;
pub mod meter;
pub mod plot;
pub mod scaling;
pub mod scenes;
pub mod skip;
pub mod stress;
pub mod sweep;
pub mod throughput;
