"""Counts the messages of a bag with two independent standard readers, the PyPI `rosbags`
package and the PyPI `mcap` package, and prints one line each:
`READER total=N upto=M last_ns=T` (M: messages with log time <= UPTO_NS; T: the largest
log time). Exits non-zero if either reader refuses the file.

usage: count_bag.py BAG UPTO_NS
"""

import sys
from pathlib import Path

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

bag, upto = Path(sys.argv[1]), int(sys.argv[2])


def report(reader, times):
    upto_count = sum(1 for t in times if t <= upto)
    last = max(times) if times else 0
    print(f"{reader} total={len(times)} upto={upto_count} last_ns={last}", flush=True)


with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
    times = []
    for connection, timestamp, rawdata in reader.messages():
        # Decoding proves the payloads are whole, not just the records around them.
        reader.deserialize(rawdata, connection.msgtype)
        times.append(timestamp)
    report("rosbags", times)

with open(bag, "rb") as f:
    times = [message.log_time for _, _, message in make_reader(f).iter_messages()]
    report("mcap", times)
