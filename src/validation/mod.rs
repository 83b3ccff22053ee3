//! Validation: scenes with analytic answers run through the same `World` as any scene file,
//! and the metrics of a run (frames, substeps, wall and simulated time). Tests check error
//! bounds against these; the `bench` command times them. [`thread`]: the suture thread against
//! beam theory.
//!
//! The scenes ([`analytic`]):
//! - **Hertz**: a frictionless sphere pressed slowly into a block 6R × 6R × 3R bonded at the
//!   bottom; the force from the sphere's contact wrench against F = 4/3·E/(1−ν²)·√R·d^{3/2},
//!   RMS over d/R 0.05–0.3.
//! - **Vibrating bar**: the first axial mode of a bar clamped at one end, its period against
//!   4L/√(E/ρ).
//! - **Stretch**: a block between two sticky grips pulled to 1.3×, the grip reaction against
//!   the compressible Neo-Hookean uniaxial answer (the lateral stretch solved numerically).
//!
//! `cargo run --release -- bench accuracy` (this 2-core machine):
//!
//! | scene | resolution | simulated | analytic | relative error |
//! |---|---|---|---|---|
//! | Hertz, d/R 0.05–0.3 | R = 4 dx | F(0.3R) = 0.1852 N | 0.2381 N | RMS 15.4% |
//! | Hertz, d/R 0.05–0.3 | R = 6 dx | F(0.3R) = 0.2171 N | 0.2406 N | RMS 7.5% |
//! | vibrating bar, L = 10 h | h = 4 dx | T = 0.05194 s | 0.05060 s | +2.7% |
//! | vibrating bar, L = 10 h | h = 8 dx | T = 0.05119 s | 0.05060 s | +1.2% |
//! | Neo-Hookean stretch 1.3× | h = 4 dx | F = 0.03689 N | 0.03976 N | -7.2% |
//! | Neo-Hookean stretch 1.3× | h = 8 dx | F = 0.03821 N | 0.03976 N | -3.9% |
//!
//! `tests/accuracy.rs` asserts these bounds with margin and that every error shrinks as dx
//! shrinks. `bench` sweeps the same scenes over every solver setting and backend (see
//! [`crate::mpm`], "Choosing a method"); `bench thread` runs the thread's beam cases
//! (cantilever, end moment, beam-column, catenary) at 10, 20 and 40 segments.

pub mod analytic;
pub mod meter;
pub mod thread;
