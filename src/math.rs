//! The vector and matrix types every folder shares.
//!
//! Solvers store f32, the GPU's type (the CPU matches it so the two backends can be compared
//! bit for bit where the math allows); the rod's constraint linearisations and the robot's
//! kinematics are solved in f64, where f32 cancellation would show (see `rod::direct`).

/// A position, velocity or force in solver precision (m, m/s, N).
pub type Vec3 = nalgebra::Vector3<f32>;
/// A grid cell or node index.
pub type IVec3 = nalgebra::Vector3<i32>;
/// A deformation gradient, stress or affine velocity field in solver precision.
pub type Mat3 = nalgebra::Matrix3<f32>;
/// A vector in the f64 linearisations (the rod's direct solve).
pub type Vec3d = nalgebra::Vector3<f64>;
/// A matrix in the f64 linearisations (the rod's direct solve).
pub type Mat3d = nalgebra::Matrix3<f64>;
