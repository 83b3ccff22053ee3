//! Rate-limited log lines: bad input can arrive at hundreds of messages a second, and each
//! rejection is worth one line, not hundreds.

use std::collections::HashMap;
use std::time::{Duration, Instant};

/// One log line per key and second at most, with a count of the ones held back.
#[derive(Default)]
pub struct RateLimitedLog {
    last: HashMap<String, (Instant, u32)>,
}

impl RateLimitedLog {
    /// Returns the line to log (and publish) now, or `None` when it is held back.
    pub fn admit(&mut self, key: &str, message: &str) -> Option<String> {
        let now = Instant::now();
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
}
