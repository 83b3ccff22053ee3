//! The suture thread: a position-based Cosserat rod (seed 001 §III, Kugelstadt & Schömer 2016)
//! solved with XPBD compliance, all constraints at once by a direct block-tridiagonal solve.
//!
//! `material` turns moduli and radius into the rod's stiffnesses, `state` holds the centreline
//! points and one frame quaternion per segment, `constraints` linearises stretch-shear and
//! bend-twist, `direct` solves them together along the chain each iteration, `solver` runs
//! the substeps, `environment` adds the table, tools and grasps a frame meets and
//! `self_contact` keeps the thread from passing through itself, and `crossing` scales back the
//! length restoration after the contacts wherever it would pull a strand through another.

pub mod constraints;
pub mod crossing;
pub mod direct;
pub mod environment;
pub mod knot;
pub mod material;
pub mod self_contact;
pub mod solver;
pub mod state;

pub use environment::{RodAttachment, RodCollider, RodEnvironment, RodFrameReport};
pub use material::ThreadMaterial;
pub use solver::RodSolver;
pub use state::Rod;
