"""A scripted push into the tissue displaces points and yields a wrench opposing the motion."""

import struct

from sensor_msgs.msg import JointState, PointCloud2
from geometry_msgs.msg import WrenchStamped
from visualization_msgs.msg import Marker

from common import Recorder, check

rec = Recorder("push_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(PointCloud2, "/tissue/points")
rec.subscribe(WrenchStamped, "/tools/probe/wrench")
rec.subscribe(Marker, "/tissue/surface")
servo = rec.publisher(JointState, "/PSM1/servo_jp")
rec.wait_for(lambda: rec.latest("/tissue/points") is not None
             and rec.latest("/PSM1/measured_js") is not None, 10.0, "a point cloud")
rec.wait_subscribers(servo)
rec.spin_for(0.5)


def points(cloud):
    names = [f.name for f in cloud.fields]
    assert names == ["x", "y", "z", "volumetric_strain"], names
    data = bytes(cloud.data)
    return [struct.unpack_from("<4f", data, i * cloud.point_step) for i in range(cloud.width)]


before = points(rec.latest("/tissue/points"))
check(len(before) > 1000, f"cloud of {len(before)} points with a volumetric strain field")
q = list(rec.latest("/PSM1/measured_js").position)
# The instrument points straight down: more insertion pushes the 8 mm sphere into the tissue.
start_insertion = q[2]
for i in range(1, 33):
    q[2] = start_insertion + 0.0005 * i  # 16 mm down at 30 mm/s
    servo.publish(JointState(position=list(q)))
    rec.spin_for(1.0 / 60.0)
rec.spin_for(0.6)
print("final joints", list(rec.latest("/PSM1/measured_js").position))
wrenches = [m for _, m in rec.messages["/tools/probe/wrench"][-10:]]
after = points(rec.latest("/tissue/points"))
moved = max(((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2) ** 0.5
            for a, b in zip(after, before))
lowest_drop = max(b[2] - a[2] for a, b in zip(after, before))
compressed = min(a[3] for a in after)
fz = sum(w.wrench.force.z for w in wrenches) / len(wrenches)
print(f"RESULT max_displacement_m={moved:.4f} max_drop_m={lowest_drop:.4f} "
      f"min_deformation={compressed:.3f} tool_frame_force_z_N={fz:.4f}")
check(moved > 0.002, f"points moved (max {moved * 1000:.1f} mm)")
check(lowest_drop > 0.002, "points under the probe were pushed down")
check(compressed < -0.05, "volumetric strain (J - 1) shows compression")
check(wrenches[-1].header.frame_id == "PSM1", "wrench in the tool frame PSM1")
# Tool z points along the push (down): the tissue pushes back along -z of the tool frame.
check(fz < -0.005, f"contact force opposes the push ({fz:.4f} N along the tool's z)")
rec.wait_for(lambda: rec.latest("/tissue/surface") is not None, 5.0, "the surface marker")
surface = rec.latest("/tissue/surface")
check(surface.type == Marker.TRIANGLE_LIST and surface.header.frame_id == "world"
      and len(surface.points) > 0 and len(surface.points) % 3 == 0,
      f"tissue surface: TRIANGLE_LIST of {len(surface.points) // 3} triangles in world")
# The mesh keeps its topology: same triangle count and UVs in every message, a colour and a
# UV per corner.
first = rec.messages["/tissue/surface"][0][1]
check(len(surface.points) == len(first.points)
      and [(c.u, c.v) for c in surface.uv_coordinates] == [(c.u, c.v) for c in first.uv_coordinates]
      and len(surface.colors) == len(surface.points) == len(surface.uv_coordinates),
      f"surface mesh of constant topology ({len(rec.messages['/tissue/surface'])} messages)")
rec.close()
