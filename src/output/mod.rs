//! What the simulation shows the outside world: per-particle deformation measures and
//! pictures.

pub mod snapshot;
pub mod strain;
