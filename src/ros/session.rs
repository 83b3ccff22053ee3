//! One run of a scene as the ROS side sets it up: the node's settings, the simulation side
//! with the run's snapshots, replayed bag and recorder attached ([`prepare`]), and the
//! headless replay, which drives that same setup through [`crate::sim::headless`] with no
//! DDS participant. The node and a headless replay share everything
//! here, so a bag is read and recorded the same way by both.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::config::Scene;
use crate::output::snapshot::SnapshotSchedule;
use crate::ros::outputs::OutputLayout;
use crate::ros::recorder::{RecordError, RecordSummary, Recorder};
use crate::ros::replay::{self, ReplayError};
use crate::sim::{build_setup, headless, FrameLoop, SetupError, SimSetup};

/// Node identity on the ROS graph.
#[derive(Clone, Debug)]
pub struct NodeSettings {
    /// The node's name on the ROS graph (without namespace).
    pub name: String,
    /// Absolute namespace (`/` for none); every topic but `/tf` lives under it.
    pub namespace: String,
    /// Stop after this much simulated time (s); `None` runs until SIGINT, SIGTERM or SIGHUP.
    pub seconds: Option<f64>,
    /// Pictures during the run (taken on the simulation thread, which pauses for each).
    pub snapshots: Option<SnapshotSchedule>,
    /// Record inputs and outputs to this MCAP file (which must not exist, unless
    /// `record_replace`).
    pub record: Option<PathBuf>,
    /// Replace an existing file at `record` (a symlink there is replaced, never followed).
    pub record_replace: bool,
    /// Longest span of simulated time (s) between two chunks of the bag closed on disk.
    pub record_chunk: f64,
    /// Drive the arms from this bag's inputs (the input topics are not subscribed).
    pub replay: Option<PathBuf>,
    /// Topic remaps (`--ros-args -r FROM:=TO`), in order; relative names resolve in
    /// `namespace`.
    pub remaps: Vec<(String, String)>,
    /// The declared parameters and their values, served read-only
    /// ([`crate::ros::parameters`]).
    pub parameters: Vec<(String, crate::ros::ros_args::ParamValue)>,
}

/// Why a run could not be set up or finished.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error(transparent)]
    /// The scene could not be set up.
    Setup(Box<SetupError>),
    #[error(transparent)]
    /// The bag to replay cannot be used.
    Replay(#[from] ReplayError),
    #[error(transparent)]
    /// The recording cannot be made.
    Record(#[from] RecordError),
    #[error("tokio runtime: {0:?}")]
    /// The tokio runtime could not be started.
    Runtime(std::io::Error),
}

impl From<SetupError> for SessionError {
    fn from(e: SetupError) -> SessionError {
        SessionError::Setup(Box::new(e))
    }
}

/// A scene's simulation side with the run's snapshots, replayed inputs (and its end as the
/// stop time unless `seconds` is given) and recorder attached.
pub fn prepare(
    scene: &Scene,
    settings: &NodeSettings,
) -> Result<(SimSetup, Option<Recorder>), SessionError> {
    let mut setup = build_setup(scene)?;
    setup.snapshots = settings.snapshots.clone();
    setup.stop_at = settings.seconds;
    let layout = OutputLayout::new(scene, &setup, &settings.namespace);
    if let Some(path) = &settings.replay {
        let bag = replay::load(path, scene, &layout, &settings.namespace)?;
        tracing::info!(
            "replaying {} inputs of {} messages from {} ({:.3} s simulated)",
            bag.inputs.len(),
            bag.messages,
            path.display(),
            bag.end
        );
        // Through the frame that starts at the bag's last message.
        let through = bag.end + setup.world.frame_dt();
        setup.stop_at = Some(settings.seconds.unwrap_or(through));
        setup.replay = Some(bag.inputs);
    }
    let recorder = match &settings.record {
        None => None,
        Some(path) => {
            let (recorder, tap) =
                Recorder::create(path, layout, settings.record_chunk, settings.record_replace)?;
            setup.recorder = Some(Box::new(tap));
            tracing::info!("recording to {}", path.display());
            Some(recorder)
        }
    };
    Ok((setup, recorder))
}

/// Ends a recording started by [`prepare`], after the simulation has ended.
pub fn finish_recording(recorder: Option<Recorder>) -> Result<Option<RecordSummary>, SessionError> {
    Ok(recorder.map(|r| r.finish()).transpose()?)
}

/// What a run without the network ([`run_headless`]) did.
#[derive(Clone, Debug)]
pub struct HeadlessRun {
    /// Frames run.
    pub frames: u64,
    /// Simulated time reached (s).
    pub time: f64,
    /// Wall-clock time the run took.
    pub wall: Duration,
    /// What the recording wrote, when the run recorded a bag.
    pub record: Option<RecordSummary>,
}

/// Replays `settings.replay` on `scene` with no DDS participant, frames as fast as they
/// compute, recording to `settings.record` if given. Ctrl-C ends it early with the bag
/// finished.
pub fn run_headless(scene: &Scene, settings: &NodeSettings) -> Result<HeadlessRun, SessionError> {
    let started = Instant::now();
    let (mut setup, recorder) = prepare(scene, settings)?;
    setup.paced = false;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(SessionError::Runtime)?;
    let stop = Arc::new(AtomicBool::new(false));
    let frame = runtime.block_on(async {
        let replay = tokio::task::spawn_blocking({
            let stop = stop.clone();
            move || {
                let mut frames = FrameLoop::new(setup, None);
                let observe = |frames: &mut FrameLoop, stepped: crate::sim::Stepped| {
                    if let Some(snapshot) = stepped.snapshot {
                        frames.log_snapshot(snapshot);
                    }
                    Ok::<_, std::convert::Infallible>(if stop.load(Ordering::Relaxed) {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    })
                };
                match headless::run(&mut frames, observe) {
                    Ok(frame) => frame,
                    Err(never) => match never {},
                }
            }
        });
        tokio::pin!(replay);
        tokio::select! {
            signal = crate::ros::shutdown::polite_stop() => {
                tracing::info!("{signal}: stopping the replay");
                stop.store(true, Ordering::Relaxed);
                (&mut replay).await
            }
            frame = &mut replay => frame,
        }
    });
    let frame = frame.unwrap_or_else(|e| std::panic::resume_unwind(e.into_panic()));
    let record = finish_recording(recorder)?;
    Ok(HeadlessRun {
        frames: frame.index,
        time: frame.time,
        wall: started.elapsed(),
        record,
    })
}
