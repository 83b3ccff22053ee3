//! One RustDDS error line that reports no fault, kept out of the log.
//!
//! A reliable subscriber with keep-last history (rclpy's default depth 10 on
//! `tissue/points`) that falls behind on a large, fragmented sample asks the writer to
//! resend fragments of it (NACK_FRAG). The writer's own keep-last history (depth 5) may have
//! replaced that sample already; RustDDS 0.15 then logs, at ERROR, in bursts,
//! `handle_repair_frags_send_worker: SequenceNumber(..) missing from send buffer` and sends
//! nothing, and the reader gets the newer samples instead. That is keep-last working as
//! specified (the reader wanted the newest cloud anyway), so the line is dropped here, matched
//! by its exact target and text; every other RustDDS error still reaches the log.

use std::fmt::Debug;

use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer};

/// The layer that drops RustDDS's "missing from send buffer" repair errors.
pub struct KeepLastRepairNoise;

impl<S: Subscriber> Layer<S> for KeepLastRepairNoise {
    fn event_enabled(&self, event: &Event<'_>, _: Context<'_, S>) -> bool {
        if *event.metadata().level() != Level::ERROR {
            return true;
        }
        // RustDDS logs through the `log` crate: its records arrive with the log target in
        // a `log.target` field (the event's own target is `log`).
        let mut fields = Fields::default();
        event.record(&mut fields);
        let target = fields
            .log_target
            .as_deref()
            .unwrap_or(event.metadata().target());
        !(target == "rustdds::rtps::writer"
            && fields
                .message
                .starts_with("handle_repair_frags_send_worker:")
            && fields.message.contains("missing from send buffer"))
    }
}

#[derive(Default)]
struct Fields {
    message: String,
    log_target: Option<String>,
}

impl Visit for Fields {
    fn record_str(&mut self, field: &Field, value: &str) {
        match field.name() {
            "log.target" => self.log_target = Some(value.to_owned()),
            "message" => self.message = value.to_owned(),
            _ => {}
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn Debug) {
        match field.name() {
            "log.target" => self.log_target = Some(format!("{value:?}")),
            "message" => self.message = format!("{value:?}"),
            _ => {}
        }
    }
}
