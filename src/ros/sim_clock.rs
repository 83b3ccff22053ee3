//! `/clock`: the simulated time (rosgraph_msgs/msg/Clock) once per frame, so that a node
//! with `use_sim_time` follows the simulation, also when it runs slower than real time.
//!
//! The node never runs ros2-client's spinner: the spinner subscribes `/clock` under the type
//! `builtin_interfaces/msg/Time`, which would put a second type on `/clock` in the graph
//! (`ros2 topic echo /clock` and `ros2 bag record` refuse such a topic). Nothing the node
//! uses needs the spinner: subscriber counts come from DDS discovery, `/rosout` and the
//! parameter services are served from the node's own loop.

use ros2_client::{
    qos::{Durability, History, Reliability, WhenFull},
    MessageTypeName, Name, Node, Publisher, QosProfile,
};

use crate::ros::msgs::{Clock, RosMessage, Time};
use crate::ros::node::NodeError;
use crate::sim::Frame;

/// The `/clock` publisher.
pub struct SimClock {
    publisher: Publisher<Clock>,
    /// Index of the last frame published.
    last: Option<u64>,
}

impl SimClock {
    /// `/clock` on `node` (reliable, keep last 1: a late sample is of no use).
    pub fn start(node: &mut Node) -> Result<SimClock, NodeError> {
        let err = |e: &dyn std::fmt::Debug| NodeError::Ros {
            what: "/clock".to_owned(),
            detail: format!("{e:?}"),
        };
        let qos = QosProfile::publisher_default()
            .reliability(Reliability::Reliable {
                when_full: WhenFull::Wait(std::time::Duration::from_millis(1)),
            })
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 1 });
        let topic = node
            .create_topic(
                &Name::new("/", "clock").map_err(|e| err(&e))?,
                MessageTypeName::new(Clock::PACKAGE, Clock::NAME),
                &qos,
            )
            .map_err(|e| err(&e))?;
        let publisher = node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| err(&e))?;
        Ok(SimClock {
            publisher,
            last: None,
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
