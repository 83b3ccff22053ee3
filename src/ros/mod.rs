//! The ROS 2 side, transport only: message types ([`msgs`], [`schema`]), topic names
//! ([`names`]), messages to simulation inputs ([`inputs`]) and finished frames to messages
//! ([`outputs`]), the node's topic wiring ([`node`]), the bag recorder and replay
//! ([`recorder`], [`replay`], [`recover`] for a bag a killed run left) and a run's setup shared by the node and a headless replay
//! ([`session`]), `/clock` ([`sim_clock`]) and the node's status ([`status`]). The
//! simulation itself is `crate::sim`.

pub mod inputs;
pub mod msgs;
pub mod names;
pub mod node;
pub mod outputs;
pub mod recorder;
pub mod recover;
pub mod replay;
pub mod schema;
pub mod session;
pub mod shutdown;
pub mod sim_clock;
pub mod status;

pub use node::{run_node, NodeError};
pub use session::{NodeSettings, SessionError};
