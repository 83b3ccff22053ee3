//! Whether DDS participants may start here (a loopback-only network namespace) and where
//! the Python venv with the ROS 2 wheels is.
//! Elsewhere, or without the venv, such tests print why and pass, unless `CI` is set, where
//! a missing prerequisite fails them.

use std::path::PathBuf;

use dvrk_tissue_sim::ros::msgs::RosMessage;
use ros2_client::{MessageTypeName, Name, QosProfile};

use super::root;

/// The venv `.ci/run` creates with the PyPI ROS 2 wheels and rosbags.
pub fn python() -> PathBuf {
    root().join(".venv/bin/python")
}

/// Whether the venv's python imports `module`.
pub fn python_imports(module: &str) -> bool {
    python().exists()
        && std::process::Command::new(python())
            .args(["-c", &format!("import {module}")])
            .status()
            .is_ok_and(|s| s.success())
}

/// Prints why a test does not run here and lets it pass; panics under `CI`.
pub fn skip_or_fail(reason: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("CI is set but {reason}");
    }
    eprintln!("SKIPPED: {reason}");
}

/// Why DDS tests cannot run here, if they cannot.
pub fn missing_network_prerequisite(need_python: bool) -> Option<String> {
    let interfaces: Vec<String> = std::fs::read_dir("/sys/class/net")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    if interfaces.iter().any(|i| i != "lo") {
        return Some(format!(
            "not inside a loopback-only network namespace (interfaces: {interfaces:?}); \
             DDS tests run only there (see .ci/run)"
        ));
    }
    if need_python && !python().exists() {
        return Some(format!(
            "{} not found: create the venv with the ROS 2 wheels (see .ci/run)",
            python().display()
        ));
    }
    None
}

/// True when a DDS test should go on; otherwise [`skip_or_fail`] with the reason.
pub fn network_prerequisites(need_python: bool) -> bool {
    match missing_network_prerequisite(need_python) {
        None => true,
        Some(reason) => {
            skip_or_fail(&reason);
            false
        }
    }
}

/// The DDS topic `name` of message type `M` on `node`, for a ros2-client peer of the node.
pub fn topic<M: RosMessage>(
    node: &mut ros2_client::Node,
    name: &str,
    qos: &QosProfile,
) -> ros2_client::dds::rustdds::Topic {
    node.create_topic(
        &Name::parse(name).unwrap(),
        MessageTypeName::new(M::PACKAGE, M::NAME),
        qos,
    )
    .unwrap()
}
