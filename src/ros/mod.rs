//! The ROS 2 side: message types, the simulated / mirrored arm state machine, the
//! simulation thread, the node that wires them to topics, and the bag recorder and replay.

pub mod arm;
pub mod inputs;
pub mod msgs;
pub mod node;
pub mod outputs;
pub mod recorder;
pub mod replay;
pub mod schema;
pub mod sim_thread;

pub use node::{build_setup, run_node, NodeError, NodeSettings};
