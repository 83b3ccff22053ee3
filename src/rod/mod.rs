//! The suture thread: a position-based Cosserat rod (seed 001 §III, Kugelstadt & Schömer 2016)
//! solved with XPBD compliance, its length held by a direct (tridiagonal) distance solve.
//!
//! `material` turns moduli and radius into the rod's stiffnesses, `state` holds the centreline
//! points and one frame quaternion per segment, `constraints` projects stretch-shear and
//! bend-twist, `distance` solves the chain's distance constraints directly each iteration,
//! `solver` runs the substeps, `collision` keeps the thread out of the table, the tools and
//! itself with Coulomb friction.

pub mod constraints;
pub mod distance;
pub mod material;
pub mod solver;
pub mod state;

pub use material::ThreadMaterial;
pub use solver::RodSolver;
pub use state::Rod;
