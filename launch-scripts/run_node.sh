#!/usr/bin/env bash
# Starts the simulation node on a scene (default: config/default.toml).
#   launch-scripts/run_node.sh [SCENE] [--node-name NAME] [--namespace /NS] [--seconds S]
# The node joins ROS_DOMAIN_ID (0 by default). On a machine that must not put DDS traffic
# on the network, run it (and your ROS tools) inside a loopback-only network namespace.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENE=${1:-config/default.toml}
shift || true
export ROS_DISTRO=${ROS_DISTRO:-kilted}
cargo build --release --quiet
exec target/release/dvrk-tissue-sim run --scene "$SCENE" "$@"
