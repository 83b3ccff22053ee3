//! The node's status (`/diagnostics`, diagnostic_msgs/msg/DiagnosticArray, latched, once a
//! second): how fast the simulation runs against the wall clock (real-time factor), how many
//! substeps a frame takes, the backend and its adapter. Each figure is measured over the
//! last few seconds (`WINDOW`), not since the start: a slow scene advances only a frame or
//! two per wall second, too few to count over one second.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::mpm::backend::Backend;
use crate::ros::msgs::{DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time};
use crate::sim::realtime::slower_than_real_time;
use crate::world::World;

/// Below this real-time factor the status is a warning: the simulation runs slower than
/// real time.
pub const SLOW_FACTOR: f64 = 0.9;

/// The span of wall time the rates are measured over.
pub const WINDOW: Duration = Duration::from_secs(5);

/// What one status interval measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rates {
    /// Simulated seconds per wall-clock second.
    pub real_time_factor: f64,
    /// Mean substeps per frame over the interval (0 when no frame ended).
    pub substeps_per_frame: f64,
    /// Frames per wall-clock second.
    pub frames_per_second: f64,
}

/// Progress at one moment: wall clock, simulated time, frames and substeps so far.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// The wall-clock instant.
    pub wall: Instant,
    /// Simulated time, s.
    pub time: f64,
    /// Frames completed.
    pub frames: u64,
    /// Substeps completed.
    pub substeps: u64,
}

impl Rates {
    /// Rates between two moments; `None` when no wall time passed.
    pub fn between(a: &Progress, b: &Progress) -> Option<Rates> {
        let wall = b.wall.checked_duration_since(a.wall)?.as_secs_f64();
        if wall <= 0.0 {
            return None;
        }
        let frames = b.frames.saturating_sub(a.frames);
        Some(Rates {
            real_time_factor: (b.time - a.time).max(0.0) / wall,
            substeps_per_frame: if frames == 0 {
                0.0
            } else {
                b.substeps.saturating_sub(a.substeps) as f64 / frames as f64
            },
            frames_per_second: frames as f64 / wall,
        })
    }
}

/// The backend's name and its adapter's (`cpu` for the CPU backend).
pub fn backend_and_adapter(world: &World) -> (String, String) {
    let backend = world.backend();
    let adapter = match backend {
        Backend::Cpu(_) => "cpu".to_owned(),
        Backend::Gpu(gpu) => gpu.adapter_name().to_owned(),
    };
    (backend.name().to_owned(), adapter)
}

/// Decides when a status is due and builds it.
pub struct StatusReport {
    name: String,
    backend: String,
    adapter: String,
    period: Duration,
    /// One sample per status, the oldest at most `WINDOW` before the newest.
    samples: VecDeque<Progress>,
}

impl StatusReport {
    /// A report for the node `name`, naming the backend and its adapter.
    pub fn new(name: &str, backend: &str, adapter: &str) -> StatusReport {
        StatusReport {
            name: format!("{name}: simulation"),
            backend: backend.to_owned(),
            adapter: adapter.to_owned(),
            period: Duration::from_secs(1),
            samples: VecDeque::new(),
        }
    }

    /// The status at `now`, once `period` has passed since the previous one (the first
    /// call only starts the measurement), with rates over the last `WINDOW`.
    pub fn due(&mut self, now: Progress) -> Option<DiagnosticArray> {
        let latest = self.samples.back()?;
        if now.wall.duration_since(latest.wall) < self.period {
            return None;
        }
        self.samples.push_back(now);
        while self.samples.len() > 2 && now.wall.duration_since(self.samples[1].wall) >= WINDOW {
            self.samples.pop_front();
        }
        let rates = Rates::between(&self.samples[0], &now)?;
        Some(self.message(&rates, now.time))
    }

    /// Starts the measurement at `now`.
    pub fn start(&mut self, now: Progress) {
        self.samples.clear();
        self.samples.push_back(now);
    }

    fn message(&self, rates: &Rates, time: f64) -> DiagnosticArray {
        let slow = rates.real_time_factor < SLOW_FACTOR;
        let message = if slow {
            slower_than_real_time(rates.real_time_factor)
        } else {
            "real time".to_owned()
        };
        let value = |key: &str, value: String| KeyValue {
            key: key.to_owned(),
            value,
        };
        DiagnosticArray {
            header: Header {
                stamp: Time::from_secs(time),
                frame_id: String::new(),
            },
            status: vec![DiagnosticStatus {
                level: u8::from(slow),
                name: self.name.clone(),
                message,
                hardware_id: self.adapter.clone(),
                values: vec![
                    value("real_time_factor", format!("{:.4}", rates.real_time_factor)),
                    value(
                        "substeps_per_frame",
                        format!("{:.2}", rates.substeps_per_frame),
                    ),
                    value(
                        "frames_per_second",
                        format!("{:.2}", rates.frames_per_second),
                    ),
                    value("simulated_time", format!("{time:.4}")),
                    value("backend", self.backend.clone()),
                    value("adapter", self.adapter.clone()),
                ],
            }],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(wall: Instant, time: f64, frames: u64, substeps: u64) -> Progress {
        Progress {
            wall,
            time,
            frames,
            substeps,
        }
    }

    #[test]
    fn rates_are_measured_over_the_interval() {
        let t0 = Instant::now();
        let a = at(t0, 1.0, 60, 600);
        let b = at(t0 + Duration::from_secs(4), 1.2, 72, 792);
        let r = Rates::between(&a, &b).unwrap();
        assert!((r.real_time_factor - 0.05).abs() < 1e-12);
        assert!((r.substeps_per_frame - 16.0).abs() < 1e-12);
        assert!((r.frames_per_second - 3.0).abs() < 1e-12);
        assert!(Rates::between(&b, &a).is_none());
    }

    #[test]
    fn a_slow_interval_is_a_warning_that_says_by_how_much() {
        let t0 = Instant::now();
        let mut report = StatusReport::new("sim", "cpu", "cpu");
        assert!(report.due(at(t0, 0.0, 0, 0)).is_none(), "not started");
        report.start(at(t0, 0.0, 0, 0));
        assert!(report
            .due(at(t0 + Duration::from_millis(500), 0.1, 6, 60))
            .is_none());
        let m = report
            .due(at(t0 + Duration::from_secs(2), 0.1, 6, 60))
            .unwrap();
        let s = &m.status[0];
        assert_eq!(s.level, 1);
        assert_eq!(
            s.message,
            "slower than real time: 0.050× (1 s simulated takes 20.0 s)"
        );
        let v = |k: &str| s.values.iter().find(|v| v.key == k).unwrap().value.clone();
        assert_eq!(v("real_time_factor"), "0.0500");
        assert_eq!(v("substeps_per_frame"), "10.00");
        assert_eq!(v("backend"), "cpu");
        // Later statuses measure over the last WINDOW only: 0.5× from t0 + 4 s on.
        let mut last = None;
        for k in 4..=12u64 {
            let t = 0.1 + 0.5 * (k as f64 - 4.0).max(0.0);
            last = report.due(at(t0 + Duration::from_secs(k), t, 6 + k, 60));
        }
        let s = &last.unwrap().status[0];
        let v = |k: &str| s.values.iter().find(|v| v.key == k).unwrap().value.clone();
        assert_eq!(v("real_time_factor"), "0.5000");
        assert_eq!(
            s.message,
            "slower than real time: 0.500× (1 s simulated takes 2.0 s)"
        );
    }
}
