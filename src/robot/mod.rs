//! Robot models: URDF loading, serial kinematic chains (FK, Jacobian, IK), the dVRK PSM with its
//! tool and jaw, the ECM that carries the endoscope, joint-command validation and `move_jp` trajectories, and the MTM→PSM
//! teleoperation mapping.
//!
//! Everything here is plain math on `f64` (SI units, nalgebra types): no ROS types and no clocks,
//! so the ROS layer and the simulation loop can both drive it and tests can check it exactly.

pub mod chain;
pub mod dh;
pub mod ecm;
pub mod ik;
pub mod joints;
pub mod psm;
pub mod teleop;
pub mod trajectory;
pub mod urdf;

pub use chain::{ActuatedJoint, Chain, ChainError, JointKind};
pub use ik::{IkError, IkOptions, IkSolution};
pub use joints::{JointCommandError, JointGroup};
pub use psm::{ArmKind, CartesianSolution, LinkFrame, Psm, PsmError, RcmPolicy, SafeTarget};
pub use teleop::{Teleop, TeleopConfig, TeleopError, TeleopState, TeleopTarget};
pub use trajectory::{Trajectory, TrajectoryError};
pub use urdf::UrdfError;
