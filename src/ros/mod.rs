//! The ROS 2 side: message types, the simulated / mirrored arm state machine, the
//! simulation thread and the node that wires them to topics.

pub mod arm;
pub mod msgs;
pub mod node;
pub mod sim_thread;

pub use node::{build_setup, run_node, NodeError, NodeSettings};
