//! Rate-limited log lines: bad input can arrive at hundreds of messages a second, and each
//! rejection is worth one line, not hundreds.

use std::collections::HashMap;
use std::time::{Duration, Instant};

/// The log target of lines that an arm also reports as an `error` event: the ROS node
/// publishes those on `/rosout` once, from the event.
pub const ARM_EVENT_TARGET: &str = "dvrk_tissue_sim::arm_event";

/// One log line per key and second at most, with a count of the ones held back.
#[derive(Default)]
pub struct RateLimitedLog {
    last: HashMap<String, (Instant, u32)>,
}

impl RateLimitedLog {
    /// Returns the line to log (and publish) now, or `None` when it is held back. Control
    /// characters in `message` come back escaped (`\n`, `\u{1b}`): text from the network
    /// (a joint name) cannot start a line of its own in the log.
    pub fn admit(&mut self, key: &str, message: &str) -> Option<String> {
        let now = Instant::now();
        let escaped;
        let message = if message.chars().any(char::is_control) {
            escaped = escape_control(message);
            escaped.as_str()
        } else {
            message
        };
        match self.last.get_mut(key) {
            Some((at, held)) if now.duration_since(*at) < Duration::from_secs(1) => {
                *held += 1;
                None
            }
            Some((at, held)) => {
                let line = if *held > 0 {
                    format!("{message} ({held} similar held back)")
                } else {
                    message.to_owned()
                };
                *at = now;
                *held = 0;
                Some(line)
            }
            None => {
                self.last.insert(key.to_owned(), (now, 0));
                Some(message.to_owned())
            }
        }
    }
}

/// `text` with its control characters escaped, everything else as it is.
fn escape_control(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_are_rate_limited_per_key() {
        let mut log = RateLimitedLog::default();
        assert!(log.admit("a", "first").is_some());
        assert!(log.admit("a", "again").is_none());
        assert!(log.admit("b", "other key").is_some());
    }

    #[test]
    fn control_characters_cannot_forge_a_log_line() {
        let mut log = RateLimitedLog::default();
        let line = log
            .admit("a", "unknown joint `yaw\nWARN forged`, é kept")
            .unwrap();
        assert_eq!(line, "unknown joint `yaw\\nWARN forged`, é kept");
    }
}
