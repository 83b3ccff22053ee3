//! Where the frame loop hands each frame's share besides the latest-value frame: a bag
//! recorder, in practice. The loop knows only this interface, so the simulation never
//! depends on how (or whether) frames are written.

use std::sync::Arc;

use crate::sim::arm::ArmEvent;
use crate::sim::frame::{Due, Frame};
use crate::sim::input::RecordedInput;

/// One frame's share of the recording.
pub struct FrameRecord {
    /// Simulated time at the frame start, when `inputs` were applied (s).
    pub start: f64,
    /// Input messages applied at the frame start, as received.
    pub inputs: Vec<RecordedInput>,
    /// Arm events of the frame: scene arm index and event.
    pub events: Vec<(usize, ArmEvent)>,
    /// The finished frame (outputs are built from it when due).
    pub frame: Arc<Frame>,
    /// Which outputs are due at this frame.
    pub due: Due,
}

/// Takes frames' shares from the simulation thread; must never block it.
pub trait FrameSink: Send {
    /// The outputs to record for the frame ending at `t` (once per frame, in order).
    fn due(&mut self, t: f64) -> Due;

    /// Takes a frame's share (dropping it, counted, rather than waiting when behind).
    fn send(&mut self, record: FrameRecord);
}
