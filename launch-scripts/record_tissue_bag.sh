#!/usr/bin/env bash
# Records a bag of the tissue topics (needs ROS 2's `ros2 bag`, e.g. from a ROS 2 install).
#   launch-scripts/record_tissue_bag.sh [OUTPUT_DIR] [NAMESPACE]
# Uses the large-data Fast DDS profile so that whole point clouds are recorded.
set -euo pipefail
HERE="$(cd "$(dirname "$0")/.." && pwd)"
OUT=${1:-tissue_$(date +%Y%m%d_%H%M%S)}
NS=${2:-}
if ! command -v ros2 >/dev/null; then
    echo "error: ros2 not found; source your ROS 2 setup (rosbag2 is not on PyPI)" >&2
    exit 1
fi
export RMW_IMPLEMENTATION=${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}
export FASTDDS_DEFAULT_PROFILES_FILE=${FASTDDS_DEFAULT_PROFILES_FILE:-$HERE/config/fastdds_large_data.xml}
exec ros2 bag record -s mcap -o "$OUT" \
    "$NS/tissue/points" "$NS/tissue/surface" /tf \
    --regex "$NS/tools/.*/wrench|$NS/PSM[0-9]/(measured_js|measured_cp|jaw/measured_js)"
