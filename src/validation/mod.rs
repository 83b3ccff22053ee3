//! Validation: scenes with analytic answers run through the same `World` as any scene file,
//! and the metrics of a run (frames, substeps, wall and simulated time). Tests check error
//! bounds against these; the `bench` command times them.

pub mod analytic;
pub mod meter;
