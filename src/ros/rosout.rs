//! `/rosout`: the node's WARN and ERROR log lines and its arms' `error`, `warning` and
//! `status` events as rcl_interfaces/msg/Log, so rqt_console and `ros2 topic echo /rosout`
//! show what the terminal shows.
//!
//! [`RosoutLayer`] (installed with the process's log subscriber) keeps WARN and ERROR lines
//! while a node is up, at most [`QUEUE_LIMIT`] of them between two frames of the node's loop;
//! the node publishes them with its logger name (`namespace.name`, as rcl names a node's
//! logger) and the level of the line, stamped with the simulated time. A line that an arm
//! also reports as an `error` event is logged under the target [`ARM_EVENT_TARGET`] and
//! published once, from the event, at ERROR (dVRK's level for its `error` topic); `warning`
//! events go out at WARN and `status` events at INFO.

use std::collections::VecDeque;
use std::fmt::Debug;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use ros2_client::log::Log;
use ros2_client::rosout::RosoutRaw;
use ros2_client::{Node, Publisher};
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer};

use crate::ros::msgs::Time;
pub use crate::sim::log::ARM_EVENT_TARGET;

/// Lines kept between two publications; older ones are dropped first.
pub const QUEUE_LIMIT: usize = 256;

/// One log line waiting for `/rosout`.
struct Line {
    level: u8,
    message: String,
    file: String,
    line: u32,
}

static ACTIVE: AtomicBool = AtomicBool::new(false);
static QUEUE: Mutex<VecDeque<Line>> = Mutex::new(VecDeque::new());

/// The tracing layer that hands WARN and ERROR lines to the node's `/rosout` publisher.
pub struct RosoutLayer;

impl<S: Subscriber> Layer<S> for RosoutLayer {
    fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
        let meta = event.metadata();
        let level = match *meta.level() {
            Level::ERROR => Log::ERROR,
            Level::WARN => Log::WARN,
            _ => return,
        };
        if !ACTIVE.load(Ordering::Relaxed) || meta.target() == ARM_EVENT_TARGET {
            return;
        }
        let mut message = Message::default();
        event.record(&mut message);
        let line = Line {
            level,
            message: message.0,
            file: meta.file().unwrap_or_default().to_owned(),
            line: meta.line().unwrap_or_default(),
        };
        let mut queue = QUEUE.lock().unwrap_or_else(|e| e.into_inner());
        if queue.len() == QUEUE_LIMIT {
            queue.pop_front();
        }
        queue.push_back(line);
    }
}

#[derive(Default)]
struct Message(String);

impl Visit for Message {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.0 = value.to_owned();
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

/// The node's `/rosout` publisher; while it exists, [`RosoutLayer`] keeps lines for it.
pub struct Rosout {
    publisher: Arc<Option<Publisher<Log>>>,
    logger: String,
}

impl Rosout {
    /// Publishes on `node`'s own `/rosout` writer (the node must enable rosout).
    pub fn start(node: &Node) -> Rosout {
        ACTIVE.store(true, Ordering::Relaxed);
        Rosout {
            publisher: node.logging_handle().rosout_writer(),
            logger: logger_name(&node.fully_qualified_name()),
        }
    }

    /// Publishes one line at `level` (one of [`Log`]'s constants).
    pub fn publish(&self, stamp: Time, level: u8, message: &str) {
        self.send(stamp, level, message, "", 0);
    }

    /// Publishes the lines logged since the last call.
    pub fn publish_logged(&self, stamp: Time) {
        let lines = std::mem::take(&mut *QUEUE.lock().unwrap_or_else(|e| e.into_inner()));
        // Published outside the lock: a line logged while publishing must not wait for it.
        for l in lines {
            self.send(stamp, l.level, &l.message, &l.file, l.line);
        }
    }

    fn send(&self, stamp: Time, level: u8, message: &str, file: &str, line: u32) {
        let Some(publisher) = self.publisher.as_ref() else {
            return;
        };
        let log = Log {
            stamp: ros2_client::builtin_interfaces::Time::new(stamp.sec, stamp.nanosec),
            level,
            name: self.logger.clone(),
            msg: message.to_owned(),
            file: file.to_owned(),
            function: String::new(),
            line,
        };
        if let Err(e) = publisher.publish(log) {
            tracing::debug!("/rosout: {e:?}");
        }
    }
}

impl Drop for Rosout {
    fn drop(&mut self) {
        ACTIVE.store(false, Ordering::Relaxed);
        QUEUE.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }
}

/// rcl's logger name of a node: its fully qualified name without the leading `/`, with `.`
/// for `/` (`/sim/dvrk` → `sim.dvrk`).
fn logger_name(fully_qualified: &str) -> String {
    fully_qualified.trim_start_matches('/').replace('/', ".")
}

#[cfg(test)]
mod tests {
    use super::logger_name;

    #[test]
    fn logger_names_follow_rcl() {
        assert_eq!(logger_name("/dvrk_tissue_sim"), "dvrk_tissue_sim");
        assert_eq!(logger_name("/sim/dvrk"), "sim.dvrk");
    }
}
