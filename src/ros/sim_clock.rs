//! `/clock`: the simulated time (rosgraph_msgs/msg/Clock) once per frame, so that a node
//! with `use_sim_time` follows the simulation, also when it runs slower than real time.
//!
//! It is published from a second DDS participant, by a node of its own (`<name>_clock`) that
//! never spins. ros2-client's spinner subscribes `/clock` under the type
//! `builtin_interfaces/msg/Time` on the participant of the node it spins, and one participant
//! cannot hold topic `/clock` under two types; on a participant whose node has no spinner
//! there is no such subscription, and our writer is the only `/clock` endpoint there.

use ros2_client::{
    qos::{Durability, History, Reliability, WhenFull},
    Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher,
    QosProfile,
};

use crate::ros::msgs::{Clock, RosMessage, Time};
use crate::ros::node::NodeError;
use crate::sim::Frame;

/// The `/clock` publisher and the participant it lives on.
pub struct SimClock {
    publisher: Publisher<Clock>,
    /// Index of the last frame published.
    last: Option<u64>,
    // Kept alive with the publisher; dropped after it.
    _node: Node,
    _context: Context,
}

impl SimClock {
    /// A participant on `domain_id` with a node `<name>_clock` in `namespace` publishing
    /// `/clock` (reliable, keep last 1: a late sample is of no use).
    pub fn start(domain_id: u16, name: &str, namespace: &str) -> Result<SimClock, NodeError> {
        let err = |what: &str, e: &dyn std::fmt::Debug| NodeError::Ros {
            what: what.to_owned(),
            detail: format!("{e:?}"),
        };
        let context = Context::with_options(ContextOptions::new().domain_id(domain_id))
            .map_err(|e| err("/clock participant", &e))?;
        let node_name = NodeName::new(namespace, &format!("{name}_clock"))
            .map_err(|e| err("/clock node name", &e))?;
        let mut node = context
            .new_node(node_name, NodeOptions::new())
            .map_err(|e| err("/clock node", &e))?;
        let qos = QosProfile::publisher_default()
            .reliability(Reliability::Reliable {
                when_full: WhenFull::Wait(std::time::Duration::from_millis(1)),
            })
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 1 });
        let topic = node
            .create_topic(
                &Name::new("/", "clock").map_err(|e| err("/clock", &e))?,
                MessageTypeName::new(Clock::PACKAGE, Clock::NAME),
                &qos,
            )
            .map_err(|e| err("/clock", &e))?;
        let publisher = node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| err("/clock", &e))?;
        Ok(SimClock {
            publisher,
            last: None,
            _node: node,
            _context: context,
        })
    }

    /// Publishes the end time of `frame` unless that frame was published already.
    pub fn publish(&mut self, frame: &Frame) {
        if self.last == Some(frame.index) {
            return;
        }
        self.last = Some(frame.index);
        let clock = Clock {
            clock: Time::from_secs(frame.time),
        };
        if let Err(e) = self.publisher.publish(clock) {
            tracing::debug!("/clock: {e:?}");
        }
    }
}
