"""30k-point clouds at 30 Hz arrive whole in rclpy (with config/fastdds_large_data.xml)."""

import time

from sensor_msgs.msg import PointCloud2

from common import Recorder, check

EXPECTED_POINTS = 30000
rec = Recorder("cloud_probe")
rec.subscribe(PointCloud2, "/tissue/points")
rec.wait_for(lambda: rec.count("/tissue/points") >= 3, 20.0, "point clouds")
start_count = rec.count("/tissue/points")
t0 = time.monotonic()
rec.spin_for(5.0)
elapsed = time.monotonic() - t0
msgs = [m for _, m in rec.messages["/tissue/points"][start_count:]]
whole = [m for m in msgs if m.width == EXPECTED_POINTS and len(m.data) == EXPECTED_POINTS * 16]
rate = len(msgs) / elapsed
points_per_s = sum(m.width for m in whole) / elapsed
print(f"RESULT clouds={len(msgs)} whole={len(whole)} rate_hz={rate:.1f} "
      f"points_per_s={points_per_s:.0f} bytes_per_s={points_per_s * 16:.0f}")
check(len(msgs) == len(whole), f"every cloud whole ({EXPECTED_POINTS} points, 16 bytes each)")
check(rate >= 25.0, f"clouds arrive at {rate:.1f} Hz (30 Hz published)")
rec.close()
