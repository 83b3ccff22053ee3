"""The endoscope's topics as a user sees them (tests/scenes/camera.toml: 2 x 160 x 120, 60°,
6 mm baseline, 30 Hz, on the ECM).

Subscribes /ECM/image_raw, /ECM/image_raw/compressed, /ECM/left/camera_info,
/ECM/right/camera_info, /ECM/left/depth and /ECM/left/labels; checks sizes, encodings,
steps, the JPEG's own header, stamps (simulated time, 1/30 s apart, the same on every topic
of one picture), K and P against the scene's optics, and that depth and labels agree
(NaN exactly where nothing was drawn).

Then the ECM as dVRK's clients drive it: its CRTK topics exist with dVRK's types (the
contact wrench included, zero) and no jaw, `measured_js` names its four joints, a
`move_jp` turns it (measured_js follows to the goal, measured_cp moves) and the picture
changes with it.

Prints `RESULT images=.. rate_hz=.. ecm_moved_pixels=..`.
"""

import math
import struct
import time

import rclpy
import rclpy.qos
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState

from common import check, fail

W, H, HFOV, BASELINE, RATE = 160, 120, math.radians(60.0), 0.006, 30.0
F = (W / 2) / math.tan(HFOV / 2)

rclpy.init()
node = rclpy.create_node("camera_probe")
got = {}


def keep(topic):
    def on(msg):
        got.setdefault(topic, []).append(msg)

    return on


for msg_type, topic in [
    (Image, "/ECM/image_raw"),
    (CompressedImage, "/ECM/image_raw/compressed"),
    (CameraInfo, "/ECM/left/camera_info"),
    (CameraInfo, "/ECM/right/camera_info"),
    (Image, "/ECM/left/depth"),
    (Image, "/ECM/left/labels"),
]:
    node.create_subscription(msg_type, topic, keep(topic), 10)

end = time.monotonic() + 60.0
while time.monotonic() < end:
    if all(len(got.get(t, [])) >= 8 for t in ["/ECM/image_raw", "/ECM/left/camera_info"]) and all(
        got.get(t) for t in ["/ECM/image_raw/compressed", "/ECM/right/camera_info",
                             "/ECM/left/depth", "/ECM/left/labels"]
    ):
        break
    rclpy.spin_once(node, timeout_sec=0.01)
else:
    fail("timed out waiting for the camera topics: " + str({t: len(m) for t, m in got.items()}))


def stamp(m):
    return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9


images = got["/ECM/image_raw"]
image = images[-1]
check(image.encoding == "rgb8", f"image encoding {image.encoding}")
check((image.width, image.height) == (2 * W, H), f"side by side: {image.width} x {image.height}")
check(image.step == 3 * 2 * W and len(image.data) == image.step * H, "step and data length")
check(image.header.frame_id == "ECM_left_optical_frame", f"frame {image.header.frame_id}")
data = bytes(image.data)
# Something is drawn in both eyes: not one flat colour.
for eye in range(2):
    pixels = {data[3 * (y * 2 * W + eye * W + x): 3 * (y * 2 * W + eye * W + x) + 3]
              for y in range(0, H, 7) for x in range(0, W, 7)}
    check(len(pixels) > 20, f"eye {eye}: {len(pixels)} distinct colours sampled")

stamps = [stamp(m) for m in images]
check(all(0.0 < s < 1e6 for s in stamps), f"stamps are simulated time ({stamps[0]:.3f} s ...)")
steps = [b - a for a, b in zip(stamps, stamps[1:])]
check(all(s > 0 for s in steps), "stamps rise")
check(min(steps) > 1 / RATE - 1e-3, f"at most {RATE} Hz in simulated time (min step {min(steps):.4f} s)")
rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
check(abs(min(steps) - 1 / RATE) < 2e-3, f"pictures 1/{RATE} s apart (min step {min(steps):.4f} s)")

info_l = got["/ECM/left/camera_info"][-1]
info_r = got["/ECM/right/camera_info"][-1]
info_stamps = {stamp(m) for m in got["/ECM/left/camera_info"]}
check(stamps[-1] in info_stamps or stamps[-2] in info_stamps, "camera_info stamps match the image's")
for name, info in [("left", info_l), ("right", info_r)]:
    check((info.width, info.height) == (W, H), f"{name} camera_info size {info.width} x {info.height}")
    k = list(info.k)
    check(abs(k[0] - F) < 1e-3 and abs(k[4] - F) < 1e-3, f"{name} K fx = fy = {k[0]:.3f} (expected {F:.3f})")
    check(k[2] == W / 2 and k[5] == H / 2 and k[8] == 1.0, f"{name} K principal point ({k[2]}, {k[5]})")
    check(info.distortion_model == "plumb_bob" and all(d == 0 for d in info.d), f"{name} no distortion")
    check(info.header.frame_id == f"ECM_{name}_optical_frame", f"{name} frame {info.header.frame_id}")
check(info_l.p[3] == 0.0, "left P Tx = 0")
check(abs(info_r.p[3] + F * BASELINE) < 1e-6, f"right P Tx = {info_r.p[3]:.5f} = -f b")

jpeg = bytes(got["/ECM/image_raw/compressed"][-1].data)
check(got["/ECM/image_raw/compressed"][-1].format == "jpeg", "compressed format jpeg")
check(jpeg[:2] == b"\xff\xd8" and jpeg[-2:] == b"\xff\xd9", f"JPEG SOI/EOI ({len(jpeg)} bytes)")
# The frame header (SOF0) holds the JPEG's own height and width.
i = 2
size = None
while i < len(jpeg) - 4:
    marker, length = jpeg[i + 1], struct.unpack(">H", jpeg[i + 2:i + 4])[0]
    if marker in (0xC0, 0xC1, 0xC2):
        size = struct.unpack(">HH", jpeg[i + 5:i + 9])
        break
    i += 2 + length
check(size == (H, 2 * W), f"JPEG frame header height, width {size}")

depth = got["/ECM/left/depth"][-1]
labels = got["/ECM/left/labels"][-1]
check(depth.encoding == "32FC1" and (depth.width, depth.height) == (W, H), "depth 32FC1, one eye")
check(labels.encoding == "mono8" and (labels.width, labels.height) == (W, H), "labels mono8, one eye")
z = struct.unpack(f"<{W * H}f", bytes(depth.data))
lab = bytes(labels.data)
if stamp(depth) == stamp(labels):
    check(all(math.isnan(d) == (l == 0) for d, l in zip(z, lab)), "depth NaN exactly where no label")
finite = [d for d in z if not math.isnan(d)]
check(finite and 0.02 < min(finite) and max(finite) < 1.0, f"depth {min(finite):.4f}..{max(finite):.4f} m")
check({1, 10, 100} <= set(lab), f"table, tissue and the probe labelled: {sorted(set(lab))}")

# --- The ECM: topics, move_jp, and the view following it.
topics = dict(node.get_topic_names_and_types())
for topic, type_name in [
    ("/ECM/measured_js", "sensor_msgs/msg/JointState"),
    ("/ECM/setpoint_js", "sensor_msgs/msg/JointState"),
    ("/ECM/measured_cp", "geometry_msgs/msg/PoseStamped"),
    ("/ECM/setpoint_cp", "geometry_msgs/msg/PoseStamped"),
    ("/ECM/measured_cv", "geometry_msgs/msg/TwistStamped"),
    ("/ECM/operating_state", "crtk_msgs/msg/OperatingState"),
    ("/ECM/move_jp", "sensor_msgs/msg/JointState"),
    ("/ECM/servo_jp", "sensor_msgs/msg/JointState"),
    ("/ECM/state_command", "crtk_msgs/msg/StringStamped"),
]:
    check(type_name in topics.get(topic, []), f"{topic} as {type_name}: {topics.get(topic)}")
# /tf_static as tf2's static broadcaster offers it (latched: transient local, reliable, so a
# late tf2 listener still gets the optical frames). tf2_msgs has no PyPI wheel to decode it
# with here: tests/ros_contract.rs decodes /tf_static with a DDS peer of its own and
# tests/camera.rs checks the optical frames it carries.
check("tf2_msgs/msg/TFMessage" in topics.get("/tf_static", []), f"/tf_static: {topics.get('/tf_static')}")
static = node.get_publishers_info_by_topic("/tf_static")
check(len(static) >= 1, f"/tf_static publishers: {len(static)}")
for info in static:
    qos = info.qos_profile
    check(qos.durability == rclpy.qos.DurabilityPolicy.TRANSIENT_LOCAL
          and qos.reliability == rclpy.qos.ReliabilityPolicy.RELIABLE,
          f"/tf_static latched and reliable: {qos.durability.name}, {qos.reliability.name}")
ecm_jaw = [t for t in topics if t.startswith("/ECM/jaw")]
check(not ecm_jaw, f"no jaw for the ECM: {ecm_jaw}")
# dVRK's ecm client opens the contact wrench too: the scope's, zero.
check({"/ECM/body/measured_cf", "/ECM/spatial/measured_cf"} <= set(topics),
      "the ECM's body/ and spatial/measured_cf, as dVRK's ecm client opens them")

node.create_subscription(JointState, "/ECM/measured_js", keep("/ECM/measured_js"), 10)
node.create_subscription(PoseStamped, "/ECM/measured_cp", keep("/ECM/measured_cp"), 10)
move = node.create_publisher(JointState, "/ECM/move_jp", 10)


def spin_until(predicate, seconds, what):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return
        rclpy.spin_once(node, timeout_sec=0.01)
    fail(f"timed out waiting for {what}")


spin_until(lambda: got.get("/ECM/measured_js") and got.get("/ECM/measured_cp")
           and move.get_subscription_count() > 0, 10.0, "the ECM's state and move_jp")
js = got["/ECM/measured_js"][-1]
check(list(js.name) == ["outer_yaw", "outer_pitch", "insertion", "outer_roll"], f"ECM joints {js.name}")
check(max(abs(a - b) for a, b in zip(js.position, [0.0, 0.0, 0.05, 0.0])) < 1e-9, f"ECM home {js.position}")
cp0 = got["/ECM/measured_cp"][-1]
check(cp0.header.frame_id == "ECM_base", f"measured_cp frame {cp0.header.frame_id}")
before = bytes(got["/ECM/image_raw"][-1].data)

goal = [0.25, -0.1, 0.05, 0.0]
move.publish(JointState(name=list(js.name), position=goal))
spin_until(lambda: max(abs(a - b) for a, b in zip(got["/ECM/measured_js"][-1].position, goal)) < 1e-9,
           10.0, "measured_js to reach the move_jp goal")
moved_at = stamp(got["/ECM/measured_js"][-1])
cp1 = got["/ECM/measured_cp"][-1].pose.position
p0 = cp0.pose.position
shift = math.dist((p0.x, p0.y, p0.z), (cp1.x, cp1.y, cp1.z))
check(shift > 0.005, f"measured_cp moved {shift * 1000:.1f} mm")
spin_until(lambda: stamp(got["/ECM/image_raw"][-1]) > moved_at + 0.05, 10.0, "a picture after the move")
after = bytes(got["/ECM/image_raw"][-1].data)
changed = sum(1 for i in range(0, len(after), 3)
              if sum(abs(a - b) for a, b in zip(after[i:i + 3], before[i:i + 3])) > 30)
check(changed > 0.1 * W * 2 * H, f"the picture follows the ECM: {changed} pixels changed")
print(f"RESULT images={len(images)} rate_hz={rate:.1f} ecm_moved_pixels={changed}", flush=True)
