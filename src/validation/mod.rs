//! Validation: scenes with analytic answers run through the same `World` as any scene file,
//! and the metrics of a run (frames, substeps, wall and simulated time). Tests check error
//! bounds against these; the `bench` command times them. `thread`: the suture thread against
//! beam theory.

pub mod analytic;
pub mod meter;
pub mod thread;
