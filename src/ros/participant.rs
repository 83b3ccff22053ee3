//! The node's DDS participant: what a packet may make it allocate, which networks it
//! discovers and is discovered on (`ROS_AUTOMATIC_DISCOVERY_RANGE`, `ROS_LOCALHOST_ONLY`),
//! that its name is its own in the domain, and DDS Security when an SROS2 enclave is given
//! ([`super::security`]).
//!
//! - **Fragmented samples are bounded.** A DATA_FRAG submessage says how large its whole
//!   sample is; the claim is the sender's word and its writer may be made up. The node's
//!   readers take small commands, so a sample claiming more than
//!   [`MAX_FRAGMENTED_SAMPLE_BYTES`] is dropped, and new samples are dropped while the
//!   incomplete ones of all readers hold [`MAX_ASSEMBLING_BYTES`], both before anything is
//!   allocated (RustDDS 0.15.1 zero-fills whatever size is claimed, per made-up writer; the
//!   build carries a patched copy, `patches/rustdds/`, with `set_fragment_assembly_limits`).
//! - **Discovery range** as ROS 2 defines it: `ROS_AUTOMATIC_DISCOVERY_RANGE` = `SUBNET`
//!   (the default; also `SYSTEM_DEFAULT` or unset), `LOCALHOST` (multicast on loopback
//!   only, only loopback locators announced, and every socket bound to 127.0.0.1 or the
//!   multicast group, so nothing another host sends reaches the node: the patched RustDDS
//!   binds there when its networks are loopback alone; `tests/hostile_network.rs` reads the
//!   node's sockets from `/proc`), or `OFF` (no automatic discovery);
//!   `ROS_LOCALHOST_ONLY=1` (deprecated in ROS 2) means `LOCALHOST` whatever the range says.
//!   Any other value is refused before the participant exists.
//! - **One node per name**: before creating any topic the node listens to the domain's
//!   `ros_discovery_info` for [`NAME_CHECK_WINDOW`] and refuses to start if another
//!   participant already runs a node with the same name and namespace, naming it.

use std::net::{IpAddr, Ipv4Addr};
use std::path::Path;
use std::time::{Duration, Instant};

use ros2_client::builtin_topics::ros_discovery;
use ros2_client::dds::rustdds::{
    self, policy, DomainParticipantBuilder, QosPolicyBuilder, RTPSEntity, TopicKind,
};
use ros2_client::entities_info::ParticipantEntitiesInfo;
use ros2_client::{Context, Gid, NodeName};

use crate::ros::node::NodeError;

/// The largest sample the node reassembles from fragments (bytes): far above any command
/// or discovery message it takes.
pub const MAX_FRAGMENTED_SAMPLE_BYTES: usize = 64 * 1024;

/// What incomplete fragmented samples may hold, all readers together (bytes).
pub const MAX_ASSEMBLING_BYTES: usize = 8 * 1024 * 1024;

/// Which peers the participant discovers and is discovered by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// Every network the host is on (ROS 2's default, `SUBNET`).
    Subnet,
    /// This host only, over loopback.
    Localhost,
    /// No automatic discovery.
    Off,
}

impl DiscoveryRange {
    /// The range `ROS_LOCALHOST_ONLY` and `ROS_AUTOMATIC_DISCOVERY_RANGE` ask for (their
    /// values given; `None` = unset), or why a value is refused.
    pub fn from_values(localhost_only: Option<&str>, range: Option<&str>) -> Result<Self, String> {
        if localhost_only.map(str::trim) == Some("1") {
            return Ok(DiscoveryRange::Localhost);
        }
        match range.map(str::trim).unwrap_or("") {
            "" | "SUBNET" | "SYSTEM_DEFAULT" => Ok(DiscoveryRange::Subnet),
            "LOCALHOST" => Ok(DiscoveryRange::Localhost),
            "OFF" => Ok(DiscoveryRange::Off),
            other => Err(format!(
                "ROS_AUTOMATIC_DISCOVERY_RANGE = {other:?}: expected SUBNET, LOCALHOST, OFF or \
                 SYSTEM_DEFAULT"
            )),
        }
    }

    /// The range this process's environment asks for.
    pub fn from_env() -> Result<Self, NodeError> {
        let localhost_only = std::env::var("ROS_LOCALHOST_ONLY").ok();
        let range = std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").ok();
        Self::from_values(localhost_only.as_deref(), range.as_deref()).map_err(|reason| {
            NodeError::Ros {
                what: "discovery range".into(),
                detail: reason,
            }
        })
    }
}

/// The node's participant on `domain_id` over `range`, with the fragment limits set, and
/// secured by the SROS2 enclave `enclave` when there is one (see [`super::security`]).
pub fn open(
    domain_id: u16,
    range: DiscoveryRange,
    enclave: Option<&Path>,
) -> Result<Context, NodeError> {
    rustdds::set_fragment_assembly_limits(MAX_FRAGMENTED_SAMPLE_BYTES, MAX_ASSEMBLING_BYTES);
    let builder = secure(DomainParticipantBuilder::new(domain_id), enclave);
    let builder = match range {
        DiscoveryRange::Subnet => builder,
        DiscoveryRange::Localhost => builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]),
        DiscoveryRange::Off => builder
            .with_only_networks(Vec::<IpAddr>::new())
            .same_host_loopback(false),
    };
    let participant = builder.build().map_err(|e| NodeError::Ros {
        what: "DDS participant".into(),
        detail: format!("{e:?}"),
    })?;
    Context::from_domain_participant(participant).map_err(|e| NodeError::Ros {
        what: "DDS participant".into(),
        detail: format!("{e:?}"),
    })
}

/// `builder` with DDS Security's builtin plugins configured from `enclave`'s files (SROS2's
/// names; the private key unencrypted, as SROS2 writes it).
#[cfg(feature = "sros2")]
fn secure(builder: DomainParticipantBuilder, enclave: Option<&Path>) -> DomainParticipantBuilder {
    match enclave {
        Some(dir) => builder.builtin_security(
            rustdds::DomainParticipantSecurityConfigFiles::with_ros_default_names(
                dir,
                String::new(),
            ),
        ),
        None => builder,
    }
}

/// Without the `sros2` feature there is no enclave to use ([`super::security`] refuses or
/// warns before the participant exists).
#[cfg(not(feature = "sros2"))]
fn secure(builder: DomainParticipantBuilder, enclave: Option<&Path>) -> DomainParticipantBuilder {
    debug_assert!(enclave.is_none(), "an enclave without DDS Security");
    builder
}

/// How long the node listens for a namesake before it starts: over loopback a running
/// node's `ros_discovery_info` (transient local) arrives within a few hundred milliseconds.
pub const NAME_CHECK_WINDOW: Duration = Duration::from_millis(1500);

/// Refuses `name` when another participant in the domain already runs a node with the same
/// name and namespace: listens to `ros_discovery_info` for [`NAME_CHECK_WINDOW`].
pub fn ensure_name_is_free(context: &Context, name: &NodeName) -> Result<(), NodeError> {
    let fail = |e: &dyn std::fmt::Debug| NodeError::Ros {
        what: "node name check".into(),
        detail: format!("{e:?}"),
    };
    let participant = context.domain_participant();
    let qos = QosPolicyBuilder::new()
        .durability(policy::Durability::TransientLocal)
        .reliable(rustdds::Duration::ZERO)
        .history(policy::History::KeepLast { depth: 64 })
        .build();
    let topic = participant
        .create_topic(
            ros_discovery::TOPIC_NAME.to_owned(),
            ros_discovery::TYPE_NAME.to_owned(),
            &qos,
            TopicKind::NoKey,
        )
        .map_err(|e| fail(&e))?;
    let subscriber = participant.create_subscriber(&qos).map_err(|e| fail(&e))?;
    let mut reader = subscriber
        .create_datareader_no_key_cdr::<ParticipantEntitiesInfo>(&topic, Some(qos))
        .map_err(|e| fail(&e))?;
    let own = Gid::from(participant.guid());
    let deadline = Instant::now() + NAME_CHECK_WINDOW;
    while Instant::now() < deadline {
        while let Ok(Some(sample)) = reader.take_next_sample() {
            let info = sample.value();
            if info.gid() == own {
                continue;
            }
            if info
                .nodes()
                .iter()
                .any(|n| n.name() == name.base_name() && n.namespace() == name.namespace())
            {
                return Err(NodeError::NameTaken {
                    node: name.fully_qualified_name(),
                    participant: format!("{:?}", info.gid()),
                });
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discovery_range_follows_ros_2() {
        let r = DiscoveryRange::from_values;
        assert_eq!(r(None, None), Ok(DiscoveryRange::Subnet));
        assert_eq!(r(None, Some("SYSTEM_DEFAULT")), Ok(DiscoveryRange::Subnet));
        assert_eq!(r(None, Some("LOCALHOST")), Ok(DiscoveryRange::Localhost));
        assert_eq!(r(None, Some("OFF")), Ok(DiscoveryRange::Off));
        assert_eq!(r(Some("1"), Some("SUBNET")), Ok(DiscoveryRange::Localhost));
        assert_eq!(r(Some("0"), None), Ok(DiscoveryRange::Subnet));
        let refused = r(None, Some("localhost")).unwrap_err();
        assert!(refused.contains("\"localhost\""), "{refused}");
    }
}
