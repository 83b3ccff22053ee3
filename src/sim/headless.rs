//! One headless driver for every run without a network or a clock: a scripted run (tools on
//! their keyframes, no inputs) and a replay (a bag's inputs, each at the frame it was applied
//! originally) both step the same [`FrameLoop`] here, frame after frame as fast as frames
//! compute. Due inputs, snapshots and the recorder are the loop's; what a run prints or
//! logs per frame is its observer's.

use std::ops::ControlFlow;
use std::sync::Arc;

use crate::sim::frame::Frame;
use crate::sim::frame_loop::{FrameLoop, Stepped, Wanted};

/// Steps `frames` until its stop time, or until `observe` (called after each frame with the
/// loop and what the frame did) breaks or fails. Each frame's tissue outputs are built while
/// the next one runs, as the simulation thread does when it runs behind. Returns the last
/// frame, outputs built (the state before any step when none ran).
pub fn run<E>(
    frames: &mut FrameLoop,
    mut observe: impl FnMut(&mut FrameLoop, Stepped) -> Result<ControlFlow<()>, E>,
) -> Result<Arc<Frame>, E> {
    let mut held = None;
    let mut last = None;
    while !frames.done() {
        let (finished, stepped) = frames.step(
            std::iter::empty(),
            Wanted::default(),
            held.take(),
            |frame| {
                last = Some(frame);
            },
        );
        held = Some(finished);
        if observe(frames, stepped)?.is_break() {
            break;
        }
    }
    Ok(match held {
        Some(h) => frames.finish(h),
        None => last.unwrap_or_else(|| Arc::new(frames.current())),
    })
}
