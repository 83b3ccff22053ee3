//! The simulation on its own thread: steps the world at the scene's frame rate (never faster
//! than real time), applies the latest commands at frame boundaries, and hands each finished
//! frame to the ROS side as a latest value (a `watch` channel: a slow reader skips frames, it
//! never queues them). Commands come in through a bounded channel; when it is full a command
//! is dropped with a log line rather than blocking the network side.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use crate::sim::arm::ArmEvent;
use crate::sim::frame::Frame;
use crate::sim::frame_loop::{Finished, FrameLoop, Wanted};
use crate::sim::input::{Received, RecordedInput, SimInput};
use crate::sim::setup::SimSetup;

/// Commands waiting for the next frame; beyond this, new ones are dropped (and logged).
pub const INPUT_CAPACITY: usize = 1024;
/// Arm events waiting for the ROS side.
pub const EVENT_CAPACITY: usize = 1024;

/// The network side's handles.
pub struct SimHandle {
    /// Where received inputs go; applied at the next frame start.
    pub inputs: SyncSender<Received>,
    /// The latest finished frame.
    pub frames: watch::Receiver<Arc<Frame>>,
    /// Arm events: scene arm index and event.
    pub events: Receiver<(usize, ArmEvent)>,
    /// Set while someone subscribes to the point cloud.
    pub points_wanted: Arc<AtomicBool>,
    /// Set while someone subscribes to the surface.
    pub surface_wanted: Arc<AtomicBool>,
    /// Set while someone subscribes to the piece count.
    pub pieces_wanted: Arc<AtomicBool>,
    /// Set while someone subscribes to a camera topic.
    pub camera_wanted: Arc<AtomicBool>,
    /// Substeps taken so far (for the node's status).
    pub substeps: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl SimHandle {
    /// Queues an input for the next frame (with its message when recording); drops it
    /// (false) when the queue is full.
    pub fn send(&self, input: Option<SimInput>, record: Option<RecordedInput>) -> bool {
        match self.inputs.try_send(Received { input, record }) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => false,
        }
    }

    /// True once the thread has ended (at `stop_at`, or after [`SimHandle::shutdown`]).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    /// Stops the thread after its current frame and waits for it.
    pub fn shutdown(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for SimHandle {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Which tissue outputs the ROS side asks for.
#[derive(Clone)]
struct WantedFlags {
    points: Arc<AtomicBool>,
    surface: Arc<AtomicBool>,
    pieces: Arc<AtomicBool>,
    camera: Arc<AtomicBool>,
}

impl WantedFlags {
    fn load(&self) -> Wanted {
        Wanted {
            points: self.points.load(Ordering::Relaxed),
            surface: self.surface.load(Ordering::Relaxed),
            pieces: self.pieces.load(Ordering::Relaxed),
            camera: self.camera.load(Ordering::Relaxed),
        }
    }
}

/// Starts the simulation thread.
pub fn spawn(setup: SimSetup) -> SimHandle {
    let (input_tx, input_rx) = sync_channel(INPUT_CAPACITY);
    let (event_tx, event_rx) = sync_channel(EVENT_CAPACITY);
    let wanted = WantedFlags {
        points: Arc::new(AtomicBool::new(false)),
        surface: Arc::new(AtomicBool::new(false)),
        pieces: Arc::new(AtomicBool::new(false)),
        camera: Arc::new(AtomicBool::new(false)),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let substeps = Arc::new(AtomicU64::new(0));
    let frames = FrameLoop::new(setup, Some(event_tx));
    let first = Arc::new(frames.current());
    let (frame_tx, frame_rx) = watch::channel(first);
    let thread = {
        let wanted = wanted.clone();
        let stop = stop.clone();
        let substeps = substeps.clone();
        std::thread::Builder::new()
            .name("simulation".into())
            .spawn(move || run(frames, input_rx, frame_tx, &wanted, &substeps, &stop))
            .expect("cannot start the simulation thread")
    };
    SimHandle {
        inputs: input_tx,
        frames: frame_rx,
        events: event_rx,
        points_wanted: wanted.points,
        surface_wanted: wanted.surface,
        pieces_wanted: wanted.pieces,
        camera_wanted: wanted.camera,
        substeps,
        stop,
        thread: Some(thread),
    }
}

fn run(
    mut frames: FrameLoop,
    inputs: Receiver<Received>,
    latest: watch::Sender<Arc<Frame>>,
    wanted: &WantedFlags,
    substeps: &AtomicU64,
    stop: &AtomicBool,
) {
    let period = Duration::from_secs_f64(frames.world().frame_dt());
    let mut deadline = Instant::now();
    // Since when (wall clock, simulated time) frames have been late.
    let mut lagging_since: Option<(Instant, f64)> = None;
    // A finished frame whose tissue outputs are still to be built: while the simulation runs
    // behind real time, they are built during the next frame's GPU work instead of before it.
    let mut held: Option<Finished> = None;
    let mut received = Vec::new();
    'frames: while !stop.load(Ordering::Relaxed) {
        if frames.done() {
            break;
        }
        loop {
            match inputs.try_recv() {
                Ok(r) => received.push(r),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => break 'frames,
            }
        }
        let (finished, stepped) =
            frames.step(received.drain(..), wanted.load(), held.take(), |frame| {
                latest.send_replace(frame);
            });
        if let Ok(report) = &stepped.report {
            substeps.fetch_add(report.substeps as u64, Ordering::Relaxed);
        }
        if let Some(snapshot) = stepped.snapshot {
            frames.log_snapshot(snapshot);
        }

        if !frames.paced() {
            // As fast as frames compute: always build outputs during the next frame.
            held = Some(finished);
            continue;
        }
        deadline += period;
        let now = Instant::now();
        if deadline > now {
            // Ahead of real time: publish at once, the lowest latency.
            latest.send_replace(frames.finish(finished));
            std::thread::sleep(deadline - now);
            lagging_since = None;
        } else {
            held = Some(finished);
            // Slower than real time: carry on at full speed, without trying to catch up.
            deadline = now;
            let time = frames.world().time();
            let (since, from) = *lagging_since.get_or_insert((now, time));
            let wall = now.duration_since(since);
            if wall > Duration::from_secs(10) {
                tracing::info!(
                    "simulation runs {} over the last {:.0} s (t = {time:.3} s simulated)",
                    slower_than_real_time((time - from) / wall.as_secs_f64()),
                    wall.as_secs_f64()
                );
                lagging_since = Some((now, time));
            }
        }
    }
    if let Some(h) = held {
        latest.send_replace(frames.finish(h));
    }
}

/// "slower than real time: 0.050× (1 s simulated takes 20.0 s)" for a real-time factor.
pub fn slower_than_real_time(factor: f64) -> String {
    if factor > 0.0 {
        format!(
            "slower than real time: {factor:.3}× (1 s simulated takes {:.1} s)",
            1.0 / factor
        )
    } else {
        "slower than real time: simulated time stands still".to_owned()
    }
}
