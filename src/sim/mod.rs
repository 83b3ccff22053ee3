//! The simulation around the world, transport-agnostic: scene assembly ([`setup`]), the arm
//! state machine ([`arm`]), what comes in ([`input`]) and what a finished frame shows
//! ([`frame`]), the frame loop ([`frame_loop`]), and the two ways of driving it: its own
//! thread at the scene's rate ([`realtime`], the node's) and [`headless`] (scripted runs and
//! replays). Nothing here knows ROS: `crate::ros` maps topics to [`SimInput`] and
//! [`Frame`] to messages, and records through the [`FrameSink`] interface.

pub mod arm;
pub mod frame;
pub mod frame_loop;
pub mod headless;
pub mod input;
pub mod log;
pub mod realtime;
pub mod setup;
pub mod sink;

pub use frame::{Due, Frame, ToolState};
pub use frame_loop::{FrameLoop, Stepped};
pub use input::{RecordedInput, SimInput};
pub use setup::{
    build_setup, check_arm_swages, check_arm_urdfs, ArmUrdfProblem, SetupError, SimSetup,
};
pub use sink::{FrameRecord, FrameSink};
