//! A compute pass that counts the dispatches recorded into it: `bench frame` reports the
//! dispatches a substep records as they were recorded, not an estimate.

use std::ops::{Deref, DerefMut};

/// A `wgpu::ComputePass` and the number of dispatches recorded into it so far. Pipelines
/// and bind groups are set through the pass it derefs to; dispatches go through here.
pub struct CountingPass<'e> {
    pass: wgpu::ComputePass<'e>,
    dispatches: u32,
}

impl<'e> CountingPass<'e> {
    pub fn new(pass: wgpu::ComputePass<'e>) -> Self {
        CountingPass {
            pass,
            dispatches: 0,
        }
    }

    /// Records a dispatch of `x`·`y`·`z` workgroups.
    pub fn dispatch_workgroups(&mut self, x: u32, y: u32, z: u32) {
        self.dispatches += 1;
        self.pass.dispatch_workgroups(x, y, z);
    }

    /// Records a dispatch whose size the device reads from `args` at `offset`.
    pub fn dispatch_workgroups_indirect(&mut self, args: &wgpu::Buffer, offset: u64) {
        self.dispatches += 1;
        self.pass.dispatch_workgroups_indirect(args, offset);
    }

    /// Dispatches recorded so far.
    pub fn dispatches(&self) -> u32 {
        self.dispatches
    }
}

impl<'e> Deref for CountingPass<'e> {
    type Target = wgpu::ComputePass<'e>;
    fn deref(&self) -> &Self::Target {
        &self.pass
    }
}

impl DerefMut for CountingPass<'_> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.pass
    }
}
