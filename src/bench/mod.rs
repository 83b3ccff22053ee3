//! Benchmarks: scenes with analytic answers, the runtime-against-error sweep and its plot,
//! throughput and scaling, the tissue surface's fidelity and cost.

pub mod analytic;
pub mod frame;
pub mod meter;
pub mod plot;
pub mod scaling;
pub mod scenes;
pub mod skip;
pub mod stress;
pub mod surface;
pub mod sweep;
pub mod throughput;
