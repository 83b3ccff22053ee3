//! The built-in recorder: a rosbag2-compatible MCAP file (profile `ros2`, `ros2msg` schemas,
//! CDR payloads, `offered_qos_profiles` per channel) of every output the node publishes and
//! every input it applied, on their topics with their types.
//!
//! The simulation thread hands each frame's share (the inputs it applied, the arm events,
//! the finished frame when an output is due) to a writer thread through a bounded queue;
//! when the queue is full the frame's share is dropped and counted, never waited for. Times
//! are simulated: an input is logged at the simulated time of the frame start at which it was
//! applied (so a replay applies it at the same frame), an output at its frame's end, which is
//! also its header stamp. Outputs follow the scene's rates in simulated time.
//!
//! The file is finished (summary, footer) when the simulation side lets go of it: at the end
//! of `--seconds`, on Ctrl-C, or on any orderly shutdown.
//!
//! Crash safety: the writer closes its chunk at least every `chunk_every` seconds of
//! simulated time and syncs it to disk, so a killed process or a power loss leaves a file
//! whose completed chunks a streaming reader (and `bag recover`, [`crate::ros::recover`])
//! reads back; at most the open chunk is lost. When a write fails (a full disk, a vanished
//! device) the file is cut back to its last completed chunk and sealed with a footer, so
//! every standard reader opens what was written; the simulation goes on without recording.
//!
//! # Recording
//!
//! `run --record out.mcap` writes every output on its topic with its type (arm states, tool
//! wrenches, `/tf`, `tissue/points`, `tissue/surface`, `tissue/pieces`, `tissue/wound_gap`, thread outputs, latched
//! `operating_state` / `error` / ...) and every input the simulation applied (`servo_jp`,
//! `move_cp`, MTM and console topics, ...), with CDR payloads encoded by RustDDS as on the
//! wire. Recording counts as wanting the cloud and surface, so they follow the scene's
//! `[outputs]` rates in simulated time whether or not anyone subscribes. The queue holds at
//! most 256 frames; if the disk falls behind, frames are dropped from the bag and counted in
//! the log. `--record-chunk S` changes the chunk span (default 1 s of simulated time): what a
//! killed run can lose at most. A bag without footer is refused by standard readers;
//! `dvrk-tissue-sim bag recover killed.mcap rebuilt.mcap` copies every readable message into a
//! finished, indexed bag, and `run --replay` on an unfinished bag says so and names that
//! command. A failed write is logged in words ("no space left on the device", "permission
//! denied", "read-only file system"); Ctrl-C then ends with a warning and exit status 0.
//!
//! A scene with a `[camera]` records its pictures at the camera's `rate_hz`, stamped with
//! the simulated time they show, on the topics the node publishes them on
//! ([`crate::ros::camera`]): by default `ECM/image_raw/compressed` (JPEG, encoded on the
//! writer thread) and both eyes' `camera_info`; with `camera.record = "raw"` the `rgb8`
//! image and each eye's `depth` and `labels` instead of the JPEG; with `"off"` none. A bag
//! that keeps pictures has the camera draw them whether or not anyone subscribes. A
//! scripted headless run (and so every `dataset` episode) has no arms: its camera stays
//! where the scene's ECM holds it at `home_joints`, its optical frames on `/tf_static` under
//! `world`. `tests/recording.rs` and `tests/dataset.rs` read the pictures back (with
//! `rosbags` too, `tests/ros/read_camera_bag.py`).
//!
//! `run --headless --record out.mcap` records a scripted run (tools on their keyframes, no ROS,
//! no network) as the node would publish it, for dataset generation from keyframed scenes.
//!
//! The tests read the bags with the PyPI `rosbags` and `mcap` packages (`tests/recording.rs`,
//! `tests/ros/read_bag.py`); `ros2 bag info` / `ros2 bag play` and Foxglove read MCAP files of
//! this form.
//!
//! # Replay
//!
//! `run --replay in.mcap` applies the bag's inputs at the same frames through the same
//! conversion as the live topics ([`crate::ros::replay`]; the input topics are not
//! subscribed), until the bag's end or `--seconds`; with `--headless` there is no DDS
//! participant and frames run as fast as they compute. So on the CPU backend the tissue
//! outputs repeat bit for bit, and a replay that records draws the camera's pictures
//! again from the replayed state: `tests/recording.rs` drives the node with rclpy `servo_jp`
//! commands while it records, replays the bag headless with `--record`, and finds every
//! recorded cloud byte-identical at its stamp. On the GPU a replay with fixed-point P2G
//! (`--p2g fixed`) repeats bit for bit too; with f32 atomics, whose sums may come in a
//! different order each run, it is close with no bit-for-bit guarantee (on llvmpipe within
//! 0.54 µm of the CPU's clouds). A bag from another scene or namespace, without inputs,
//! missing or unreadable is refused with a message saying which.
//!
//! Measured on the default scene (CPU backend, this 2-core machine), the node recording while
//! an rclpy client pushed the gripper down and back with 32 `servo_jp` commands
//! (`run --scene config/default.toml --backend cpu --seconds 4 --record /tmp/default.mcap`,
//! then `run --scene config/default.toml --backend cpu --replay /tmp/default.mcap --headless
//! --record /tmp/default_replay.mcap`): 2,313 messages on 13 topics over 3.98 s simulated
//! (80.5 MB, the clouds dominate), 0 frames dropped, and 120 of 120 replayed clouds
//! byte-identical to the node's recording.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::render::{CameraImages, CameraRecord};
use crate::ros::camera;
use crate::ros::msgs::{to_cdr, CdrError, RosMessage, Time};
use crate::ros::outputs::{self, EventMessage, EventStamps, OutputLayout, SimSchedule};
use crate::ros::schema;
use crate::sim::input::nanos;
use crate::sim::{Due, FrameRecord, FrameSink};

/// Frames whose share may wait for the writer; beyond this they are dropped and counted.
pub const QUEUE_FRAMES: usize = 256;

/// Default longest span of simulated time (s) a killed run can lose from its bag.
pub const DEFAULT_CHUNK_SECONDS: f64 = 1.0;

#[derive(Debug, thiserror::Error)]
/// Why a recording could not be made or finished.
pub enum RecordError {
    #[error("cannot create {}: {}", path.display(), io_cause(source, path))]
    /// The bag file cannot be created.
    Create {
        /// The bag's path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    #[error("--record-chunk {0}: must be a positive number of simulated seconds")]
    /// A chunk span that is not a positive number of seconds (holds the value given).
    ChunkSpan(f64),
    #[error("{}: {source}", path.display())]
    /// Writing the bag failed.
    Write {
        /// The bag's path.
        path: PathBuf,
        /// What failed.
        source: BagError,
    },
}

/// The kind of an I/O error, seen through the wrapper the MCAP writer puts round a failed
/// message-header write (`io::Error::other(binrw::Error::Io(e))`, kind `Other`).
fn error_kind(e: &std::io::Error) -> std::io::ErrorKind {
    match e
        .get_ref()
        .and_then(|inner| inner.downcast_ref::<binrw::Error>())
    {
        Some(binrw::Error::Io(inner)) => error_kind(inner),
        _ => e.kind(),
    }
}

/// What an I/O error means for a bag at `path`, in the user's words (the cause first, then
/// the system's own text).
pub fn io_cause(e: &std::io::Error, path: &Path) -> String {
    use std::io::ErrorKind;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => PathBuf::from("."),
    };
    let cause = match error_kind(e) {
        ErrorKind::StorageFull => "no space left on the device".to_owned(),
        ErrorKind::QuotaExceeded => "disk quota exceeded".to_owned(),
        ErrorKind::PermissionDenied => format!("permission denied (writing in {})", dir.display()),
        ErrorKind::ReadOnlyFilesystem => format!("{} is on a read-only file system", dir.display()),
        ErrorKind::NotFound if !dir.is_dir() => {
            format!("the directory {} does not exist", dir.display())
        }
        ErrorKind::IsADirectory => "it is a directory".to_owned(),
        ErrorKind::AlreadyExists => {
            "it already exists (choose another file, or pass --force to replace it)".to_owned()
        }
        _ => return e.to_string(),
    };
    format!("{cause} ({e})")
}

/// Creates the file at `path`, which must not exist: never overwrites one, and never
/// follows a symlink planted there, dangling or not (O_CREAT | O_EXCL). An existing path
/// fails with `ErrorKind::AlreadyExists`; [`remove_for_overwrite`] clears it first when the
/// user asked to overwrite.
pub fn create_new_file(path: &Path) -> std::io::Result<File> {
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
}

/// Removes what is at `path` so that [`create_new_file`] may create it: a file or a symlink
/// (the link itself, never what it points to). A directory is refused; nothing there is
/// fine.
pub fn remove_for_overwrite(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
        Ok(m) if m.is_dir() => Err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "it is a directory",
        )),
        Ok(_) => std::fs::remove_file(path),
    }
}

/// The I/O error behind a bag error, if there is one.
fn io_error(e: &BagError) -> Option<&std::io::Error> {
    match e {
        BagError::Io(e) => Some(e),
        BagError::Mcap(mcap::McapError::Io(e)) => Some(e),
        _ => None,
    }
}

/// Why the bag could not be written.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    #[error("no message definition for {0}")]
    /// No schema text for a ROS type the bag would carry (holds the type name).
    NoSchema(String),
    #[error(transparent)]
    /// The MCAP writer failed.
    Mcap(#[from] mcap::McapError),
    #[error(transparent)]
    /// A message could not be encoded.
    Cdr(#[from] CdrError),
    #[error(transparent)]
    /// A file operation failed.
    Io(#[from] std::io::Error),
    #[error("cannot start the writer thread: {0}")]
    /// The writer thread could not be started.
    Thread(std::io::Error),
    #[error("the writer thread panicked")]
    /// The writer thread panicked.
    Panicked,
    #[error("already finished")]
    /// The recording was already finished.
    Finished,
}

#[derive(Default)]
struct Dropped {
    frames: AtomicU64,
    inputs: AtomicU64,
}

/// The simulation thread's end: decides which outputs are due and queues frames' shares.
pub struct RecordTap {
    tx: SyncSender<FrameRecord>,
    schedule: SimSchedule,
    dropped: Arc<Dropped>,
    last_warning: Option<Instant>,
    /// Block on a full queue instead of dropping the frame.
    lossless: bool,
    /// Whether the bag keeps the camera's pictures (asks for them every frame).
    pictures: bool,
}

impl RecordTap {
    /// Makes the simulation wait for the writer instead of dropping a frame when it is
    /// behind: for runs with no clock to keep up with, whose bag must hold every frame.
    pub fn wait_when_behind(&mut self) {
        self.lossless = true;
    }
}

impl FrameSink for RecordTap {
    /// The outputs to record for the frame ending at `t` (once per frame, in order).
    fn due(&mut self, t: f64) -> Due {
        Due {
            camera: self.pictures,
            ..self.schedule.due(t)
        }
    }

    /// Queues a frame's share; drops it (counted, logged at most once a second) when the
    /// writer is behind.
    fn send(&mut self, record: FrameRecord) {
        let inputs = record.inputs.len() as u64;
        let sent = if self.lossless {
            // A disconnected writer has stopped on an error that `finish` reports.
            self.tx
                .send(record)
                .map_err(|e| TrySendError::Disconnected(e.0))
        } else {
            self.tx.try_send(record)
        };
        match sent {
            Ok(()) => {}
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                let frames = self.dropped.frames.fetch_add(1, Ordering::Relaxed) + 1;
                let lost_inputs = self.dropped.inputs.fetch_add(inputs, Ordering::Relaxed) + inputs;
                let now = Instant::now();
                if self
                    .last_warning
                    .is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1))
                {
                    self.last_warning = Some(now);
                    tracing::warn!(
                        "recorder behind: {frames} frame(s) dropped from the bag so far \
                         ({lost_inputs} input(s) among them)"
                    );
                }
            }
        }
    }
}

/// What was written.
#[derive(Clone, Debug)]
pub struct RecordSummary {
    /// The bag's path.
    pub path: PathBuf,
    /// Messages written.
    pub messages: u64,
    /// Topics (channels) in the bag.
    pub topics: usize,
    /// File size, bytes.
    pub bytes: u64,
    /// Simulated time span of the messages (s).
    pub span: f64,
    /// Frames whose messages were dropped because the writer was behind.
    pub dropped_frames: u64,
    /// Input messages among the dropped frames' messages.
    pub dropped_inputs: u64,
    /// Why recording stopped early (the file then holds what was written before, sealed).
    pub stopped: Option<String>,
}

impl std::fmt::Display for RecordSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} messages on {} topics over {:.3} s simulated, {:.1} MB; {} frame(s) dropped \
             ({} input(s) among them)",
            self.path.display(),
            self.messages,
            self.topics,
            self.span,
            self.bytes as f64 / 1e6,
            self.dropped_frames,
            self.dropped_inputs
        )?;
        if let Some(why) = &self.stopped {
            write!(f, "; recording stopped early: {why}")?;
        }
        Ok(())
    }
}

/// The writer thread's handle: [`Recorder::finish`] waits for the file to be complete.
pub struct Recorder {
    path: PathBuf,
    dropped: Arc<Dropped>,
    thread: Option<JoinHandle<Result<RecordSummary, BagError>>>,
}

impl Recorder {
    /// Creates `path` and starts the writer thread for a scene's `layout`; chunks are closed
    /// (and synced to disk) at least every `chunk_every` simulated seconds. An existing file
    /// at `path` is refused unless `replace` is set (see [`create_new_file`]).
    pub fn create(
        path: &Path,
        layout: OutputLayout,
        chunk_every: f64,
        replace: bool,
    ) -> Result<(Recorder, RecordTap), RecordError> {
        if !(chunk_every.is_finite() && chunk_every > 0.0) {
            return Err(RecordError::ChunkSpan(chunk_every));
        }
        let create = |source| RecordError::Create {
            path: path.to_owned(),
            source,
        };
        if replace {
            remove_for_overwrite(path).map_err(create)?;
        }
        let file = create_new_file(path).map_err(create)?;
        let synced = file.try_clone().map_err(create)?;
        let write_error = |e: mcap::McapError| RecordError::Write {
            path: path.to_owned(),
            source: e.into(),
        };
        let mut writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("dvrk-tissue-sim ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(write_error)?;
        // The header on disk now: a full disk shows before the run starts, and a file cut
        // back to its last chunk has at least its header.
        writer.flush().map_err(write_error)?;
        let safe = Safe {
            bytes: synced.metadata().map_err(create)?.len(),
            messages: 0,
            time: 0.0,
        };
        let (tx, rx) = sync_channel(QUEUE_FRAMES);
        let dropped = Arc::new(Dropped::default());
        let schedule = SimSchedule::new(&layout.rates);
        let pictures = layout.camera_record != CameraRecord::Off;
        let bag = Bag {
            writer: Some(writer),
            synced,
            chunk_every,
            next_chunk_end: chunk_every,
            safe,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            layout,
            stamps: EventStamps::default(),
            tf_static_written: false,
            messages: 0,
            first: None,
            last: 0,
        };
        let thread = {
            let file_path = path.to_owned();
            let dropped = dropped.clone();
            std::thread::Builder::new()
                .name("recorder".into())
                .spawn(move || write_all(rx, bag, file_path, &dropped))
                .map_err(|e| RecordError::Write {
                    path: path.to_owned(),
                    source: BagError::Thread(e),
                })?
        };
        Ok((
            Recorder {
                path: path.to_owned(),
                dropped: dropped.clone(),
                thread: Some(thread),
            },
            RecordTap {
                tx,
                schedule,
                dropped,
                last_warning: None,
                lossless: false,
                pictures,
            },
        ))
    }

    /// Waits until the file is finished. Call after the [`RecordTap`] is gone (the
    /// simulation thread has ended); returns what was written.
    pub fn finish(mut self) -> Result<RecordSummary, RecordError> {
        let result = match self.thread.take().map(|t| t.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(BagError::Panicked),
            None => Err(BagError::Finished),
        };
        result.map_err(|source| RecordError::Write {
            path: self.path.clone(),
            source,
        })
    }

    /// Frames dropped so far because the writer was behind.
    pub fn dropped_frames(&self) -> u64 {
        self.dropped.frames.load(Ordering::Relaxed)
    }
}

/// rosbag2's QoS description of a channel (`offered_qos_profiles`).
#[derive(Clone, Copy)]
enum Qos {
    /// The node's periodic outputs: reliable, volatile, keep last 5.
    Periodic,
    /// Latched events: reliable, transient local, keep last 100.
    Latched,
    /// Commands as the node subscribes them: reliable, volatile, keep last 10.
    Command,
}

impl Qos {
    fn yaml(self) -> String {
        let (depth, durability) = match self {
            Qos::Periodic => (5, 2),
            Qos::Latched => (100, 1),
            Qos::Command => (10, 2),
        };
        let infinite = "\n    sec: 9223372036\n    nsec: 854775807";
        format!(
            "- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {durability}\n  \
             deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: 1\n  \
             liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false\n"
        )
    }
}

/// How much of the file is complete on disk: a reader gets this much back whatever happens.
#[derive(Clone, Copy, Debug)]
struct Safe {
    bytes: u64,
    messages: u64,
    /// Simulated time (s) through which every message is in.
    time: f64,
}

struct Bag {
    /// `None` once writing failed.
    writer: Option<mcap::Writer<BufWriter<File>>>,
    /// The same file, to sync completed chunks to disk.
    synced: File,
    chunk_every: f64,
    /// Simulated time (s) at which the open chunk is closed.
    next_chunk_end: f64,
    safe: Safe,
    schemas: HashMap<String, u16>,
    /// Channel id and next sequence number per topic.
    channels: HashMap<String, (u16, u32)>,
    layout: OutputLayout,
    stamps: EventStamps,
    /// `/tf_static` goes in once, with the first `/tf`.
    tf_static_written: bool,
    messages: u64,
    first: Option<u64>,
    last: u64,
}

impl Bag {
    fn writer(&mut self) -> Result<&mut mcap::Writer<BufWriter<File>>, BagError> {
        self.writer.as_mut().ok_or(BagError::Finished)
    }

    /// Closes the open chunk once its span reaches `chunk_every` at simulated time `t`.
    fn close_chunk_if_due(&mut self, t: f64) -> Result<(), BagError> {
        if t + 1e-9 < self.next_chunk_end {
            return Ok(());
        }
        self.writer()?.flush()?;
        self.synced.sync_data()?;
        self.safe = Safe {
            bytes: self.synced.metadata()?.len(),
            messages: self.messages,
            time: t,
        };
        while self.next_chunk_end <= t + 1e-9 {
            self.next_chunk_end += self.chunk_every;
        }
        tracing::debug!(
            "bag chunk closed: {} messages through t = {:.3} s on disk ({} bytes)",
            self.safe.messages,
            self.safe.time,
            self.safe.bytes
        );
        Ok(())
    }

    /// After a failed write: drops the writer, cuts the file back to its last completed
    /// chunk and seals it (data end, footer, magic) so that every reader opens it.
    fn seal_after_failure(&mut self) -> std::io::Result<()> {
        // Dropping tries to finish the file; whatever that appends is cut off below.
        drop(self.writer.take());
        let file = &mut self.synced;
        file.set_len(self.safe.bytes)?;
        file.seek(SeekFrom::Start(self.safe.bytes))?;
        file.write_all(&sealing_tail())?;
        file.sync_data()
    }

    fn channel(&mut self, topic: &str, type_name: &str, qos: Qos) -> Result<(u16, u32), BagError> {
        if let Some(entry) = self.channels.get_mut(topic) {
            let current = *entry;
            entry.1 = entry.1.wrapping_add(1);
            return Ok(current);
        }
        let schema = match self.schemas.get(type_name) {
            Some(&id) => id,
            None => {
                let text = schema::ros2msg(type_name)
                    .ok_or_else(|| BagError::NoSchema(type_name.to_owned()))?;
                let id = self
                    .writer()?
                    .add_schema(type_name, "ros2msg", text.as_bytes())?;
                self.schemas.insert(type_name.to_owned(), id);
                id
            }
        };
        let metadata = BTreeMap::from([("offered_qos_profiles".to_owned(), qos.yaml())]);
        let id = self
            .writer()?
            .add_channel(schema, topic, "cdr", &metadata)?;
        self.channels.insert(topic.to_owned(), (id, 2));
        Ok((id, 1))
    }

    fn write_cdr(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: Qos,
        time: u64,
        cdr: &[u8],
    ) -> Result<(), BagError> {
        let (channel_id, sequence) = self.channel(topic, type_name, qos)?;
        self.writer()?.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id,
                sequence,
                log_time: time,
                publish_time: time,
            },
            cdr,
        )?;
        self.messages += 1;
        self.first.get_or_insert(time);
        self.last = self.last.max(time);
        Ok(())
    }

    fn write<M: RosMessage + Serialize>(
        &mut self,
        relative: &str,
        qos: Qos,
        time: u64,
        message: &M,
    ) -> Result<(), BagError> {
        let topic = self.layout.topic(relative);
        let cdr = to_cdr(message)?;
        self.write_cdr(&topic, &M::type_name(), qos, time, &cdr)
    }

    fn write_record(&mut self, record: FrameRecord) -> Result<(), BagError> {
        let start = nanos(record.start);
        for input in &record.inputs {
            self.write_cdr(
                &input.topic,
                &input.type_name,
                Qos::Command,
                start,
                &input.cdr,
            )?;
        }
        let frame = record.frame;
        let end = nanos(frame.time);
        let stamp = Time::from_secs(frame.time);
        for (arm, event) in record.events {
            let Some(name) = self
                .layout
                .arms
                .get(arm)
                .filter(|a| a.simulated)
                .map(|a| a.name.clone())
            else {
                continue;
            };
            match self.stamps.message(arm, event) {
                EventMessage::State(m) => {
                    self.write(&format!("{name}/operating_state"), Qos::Latched, end, &m)?
                }
                EventMessage::Text { suffix, message } => {
                    self.write(&format!("{name}/{suffix}"), Qos::Latched, end, &message)?
                }
            }
        }
        let due = record.due;
        if due.arm {
            let arms: Vec<_> = self.layout.arms.clone();
            for (arm, status) in arms.iter().zip(&frame.arms) {
                if !arm.simulated {
                    continue;
                }
                let m = outputs::arm_messages(arm, status, stamp);
                let n = &arm.name;
                self.write(&format!("{n}/measured_js"), Qos::Periodic, end, &m.js)?;
                self.write(&format!("{n}/setpoint_js"), Qos::Periodic, end, &m.js)?;
                if let (Some(jaw), Some(setpoint)) = (&m.jaw, &m.jaw_setpoint) {
                    self.write(&format!("{n}/jaw/measured_js"), Qos::Periodic, end, jaw)?;
                    self.write(
                        &format!("{n}/jaw/setpoint_js"),
                        Qos::Periodic,
                        end,
                        setpoint,
                    )?;
                }
                self.write(&format!("{n}/measured_cp"), Qos::Periodic, end, &m.cp)?;
                self.write(&format!("{n}/setpoint_cp"), Qos::Periodic, end, &m.cp)?;
                self.write(&format!("{n}/measured_cv"), Qos::Periodic, end, &m.cv)?;
            }
            for f in self.layout.force_feedback.clone() {
                if let Some(tool) = frame.tools.get(f.tool) {
                    let m = outputs::wrench_message(tool, f.scale, stamp);
                    self.write(&f.topic, Qos::Periodic, end, &m)?;
                }
            }
        }
        if due.wrench {
            let names = self.layout.tools.clone();
            for (name, tool) in names.iter().zip(&frame.tools) {
                let m = outputs::wrench_message(tool, 1.0, stamp);
                self.write(&format!("tools/{name}/wrench"), Qos::Periodic, end, &m)?;
            }
        }
        if due.tf {
            if !self.tf_static_written {
                self.tf_static_written = true;
                let m = outputs::tf_static_message(&self.layout);
                self.write("/tf_static", Qos::Latched, end, &m)?;
            }
            let all_links = self.layout.tf_arm_links;
            let m = outputs::tf_message(&self.layout.arms, &frame, stamp, all_links);
            self.write("/tf", Qos::Periodic, end, &m)?;
        }
        if due.points {
            if let Some(cloud) = &frame.cloud {
                let m = outputs::cloud_message(cloud, stamp);
                self.write("tissue/points", Qos::Periodic, end, &m)?;
            }
        }
        if due.surface {
            if let Some(surface) = &frame.surface {
                let m = outputs::surface_message(surface, stamp);
                self.write("tissue/surface", Qos::Periodic, end, &m)?;
            }
        }
        if due.thread {
            for thread in &frame.threads {
                let m = outputs::thread_centreline_message(thread, stamp);
                self.write(
                    &outputs::thread_centreline_topic(&thread.name),
                    Qos::Periodic,
                    end,
                    &m,
                )?;
                let m = outputs::thread_tension_message(thread, stamp);
                self.write(
                    &outputs::thread_tension_topic(&thread.name),
                    Qos::Periodic,
                    end,
                    &m,
                )?;
            }
        }
        if due.pieces {
            if let Some(pieces) = frame.pieces {
                let m = outputs::pieces_message(pieces);
                self.write(outputs::PIECES_TOPIC, Qos::Periodic, end, &m)?;
            }
            if let Some(gap) = frame.wound_gap {
                let m = outputs::wound_gap_message(gap);
                self.write(outputs::WOUND_GAP_TOPIC, Qos::Periodic, end, &m)?;
            }
        }
        if let (true, Some(images)) = (due.camera, &frame.camera) {
            self.write_pictures(images, end)?;
        }
        self.close_chunk_if_due(frame.time)
    }

    /// The camera's picture as [`OutputLayout::camera_record`] says, on the topics the node
    /// publishes it on ([`crate::ros::camera`]), stamped `time`.
    fn write_pictures(&mut self, images: &CameraImages, time: u64) -> Result<(), BagError> {
        let eyes = images.eyes.len().min(camera::EYES.len());
        match self.layout.camera_record {
            CameraRecord::Off => return Ok(()),
            CameraRecord::Compressed => match camera::compressed_message(images) {
                Ok(m) => self.write(camera::COMPRESSED_TOPIC, Qos::Periodic, time, &m)?,
                // A picture the encoder refuses is left out; the run goes on recording.
                Err(e) => tracing::warn!("{}: not encoded: {e}", camera::COMPRESSED_TOPIC),
            },
            CameraRecord::Raw => {
                let m = camera::image_message(images);
                self.write(camera::IMAGE_TOPIC, Qos::Periodic, time, &m)?;
                for (index, eye) in camera::EYES.iter().enumerate().take(eyes) {
                    let m = camera::depth_message(images, index);
                    self.write(&camera::depth_topic(eye), Qos::Periodic, time, &m)?;
                    let m = camera::labels_message(images, index);
                    self.write(&camera::labels_topic(eye), Qos::Periodic, time, &m)?;
                }
            }
        }
        for (index, eye) in camera::EYES.iter().enumerate().take(eyes) {
            let m = camera::info_message(images, index);
            self.write(&camera::info_topic(eye), Qos::Periodic, time, &m)?;
        }
        Ok(())
    }
}

/// What ends an MCAP file without a summary section: a Data End record (no data CRC), a
/// Footer pointing at no summary, and the closing magic.
fn sealing_tail() -> Vec<u8> {
    let mut tail = Vec::with_capacity(13 + 29 + 8);
    tail.push(0x0f); // Data End
    tail.extend_from_slice(&4u64.to_le_bytes());
    tail.extend_from_slice(&0u32.to_le_bytes());
    tail.push(0x02); // Footer
    tail.extend_from_slice(&20u64.to_le_bytes());
    tail.extend_from_slice(&0u64.to_le_bytes()); // summary start: none
    tail.extend_from_slice(&0u64.to_le_bytes()); // summary offset start: none
    tail.extend_from_slice(&0u32.to_le_bytes()); // summary CRC: not computed
    tail.extend_from_slice(mcap::MAGIC);
    tail
}

fn write_all(
    rx: Receiver<FrameRecord>,
    mut bag: Bag,
    path: PathBuf,
    dropped: &Dropped,
) -> Result<RecordSummary, BagError> {
    let mut stopped: Option<String> = None;
    // Ends when the simulation side lets go of its sender.
    for record in rx {
        if stopped.is_some() {
            continue;
        }
        if let Err(e) = bag.write_record(record) {
            let cause = match io_error(&e) {
                Some(io) => io_cause(io, &path),
                None => e.to_string(),
            };
            let kept = bag.safe;
            match bag.seal_after_failure() {
                Ok(()) => tracing::error!(
                    "recording to {} stopped: {cause}; the simulation goes on unrecorded. The \
                     bag keeps the {} messages through t = {:.3} s simulated, readable",
                    path.display(),
                    kept.messages,
                    kept.time
                ),
                Err(seal) => tracing::error!(
                    "recording to {} stopped: {cause}; the simulation goes on unrecorded. \
                     Sealing the file failed too ({}): `bag recover` reads back the {} \
                     messages through t = {:.3} s simulated",
                    path.display(),
                    io_cause(&seal, &path),
                    kept.messages,
                    kept.time
                ),
            }
            bag.messages = kept.messages;
            bag.last = bag.last.min(nanos(kept.time));
            stopped = Some(format!(
                "{cause} at t = {:.3} s simulated; {} messages kept",
                kept.time, kept.messages
            ));
        }
    }
    if stopped.is_none() {
        let mut writer = bag.writer.take().ok_or(BagError::Finished)?;
        writer.finish()?;
        writer.into_inner().flush()?;
    }
    let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let summary = RecordSummary {
        path,
        messages: bag.messages,
        topics: bag.channels.len(),
        bytes,
        span: bag.last.saturating_sub(bag.first.unwrap_or(0)) as f64 * 1e-9,
        dropped_frames: dropped.frames.load(Ordering::Relaxed),
        dropped_inputs: dropped.inputs.load(Ordering::Relaxed),
        stopped,
    };
    if summary.dropped_frames > 0 || summary.stopped.is_some() {
        tracing::warn!("recorded {summary}");
    } else {
        tracing::info!("recorded {summary}");
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::outputs::OutputRates;
    use crate::sim::{Frame, RecordedInput};

    /// A full disk reads as one however the writer wrapped the system's error: as it is, or
    /// as the MCAP writer's message-header write returns it (inside binrw's error, kind
    /// `Other`).
    #[test]
    fn a_full_disk_is_named_through_the_mcap_writer_s_binrw_wrapper() {
        let path = Path::new("/tmp/a.mcap");
        let full = || std::io::Error::from_raw_os_error(28);
        let text = full().to_string();
        assert!(io_cause(&full(), path).starts_with("no space left on the device ("));
        // As mcap 0.26 wraps a message header's failed write.
        let wrapped = std::io::Error::other(binrw::Error::Io(full()));
        assert_eq!(wrapped.kind(), std::io::ErrorKind::Other);
        assert_eq!(
            io_cause(&wrapped, path),
            format!("no space left on the device ({text})")
        );
        // Any other wrapped error stays as it is.
        let other = std::io::Error::other("writes now fail");
        assert_eq!(io_cause(&other, path), "writes now fail");
    }

    fn record(inputs: usize) -> FrameRecord {
        FrameRecord {
            start: 0.0,
            inputs: vec![
                RecordedInput {
                    topic: "PSM1/servo_jp".into(),
                    type_name: "sensor_msgs/msg/JointState".into(),
                    cdr: vec![0, 1, 0, 0],
                };
                inputs
            ],
            events: Vec::new(),
            frame: Arc::new(Frame::default()),
            due: Due::default(),
        }
    }

    /// A dropping tap sending into `tx`, and its drop counters.
    fn tap(tx: SyncSender<FrameRecord>) -> (RecordTap, Arc<Dropped>) {
        let dropped = Arc::new(Dropped::default());
        let rates = OutputRates {
            arm: 60.0,
            points: 30.0,
            surface: 10.0,
            wrench: 60.0,
            tf: 50.0,
            thread: 30.0,
            pieces: 5.0,
        };
        let tap = RecordTap {
            tx,
            schedule: SimSchedule::new(&rates),
            dropped: dropped.clone(),
            last_warning: None,
            lossless: false,
            pictures: false,
        };
        (tap, dropped)
    }

    #[test]
    fn a_writer_behind_costs_whole_frames_counted_never_a_wait() {
        // A writer that never drains: the queue fills and every further frame is dropped
        // whole (inputs with it) and counted, without blocking the caller.
        let (tx, rx) = sync_channel(3);
        let (mut tap, dropped) = tap(tx);
        for _ in 0..10 {
            tap.send(record(2));
        }
        assert_eq!(rx.try_iter().count(), 3, "the queue holds its capacity");
        assert_eq!(dropped.frames.load(Ordering::Relaxed), 7);
        assert_eq!(dropped.inputs.load(Ordering::Relaxed), 14);
        // Once the writer catches up, frames are queued again.
        tap.send(record(1));
        assert_eq!(rx.try_iter().count(), 1);
        assert_eq!(dropped.frames.load(Ordering::Relaxed), 7);
    }

    #[test]
    fn a_lossless_tap_waits_for_the_writer_and_drops_nothing() {
        let (tx, rx) = sync_channel(3);
        let (mut tap, dropped) = tap(tx);
        tap.wait_when_behind();
        // A slow writer: the queue of 3 fills, and the sender waits instead of dropping.
        let writer = std::thread::spawn(move || {
            let mut n = 0;
            while rx.recv().is_ok() {
                std::thread::sleep(std::time::Duration::from_millis(2));
                n += 1;
            }
            n
        });
        for _ in 0..10 {
            tap.send(record(1));
        }
        drop(tap);
        assert_eq!(writer.join().unwrap(), 10);
        assert_eq!(dropped.frames.load(Ordering::Relaxed), 0);
    }
}
