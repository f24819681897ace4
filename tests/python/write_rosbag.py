"""Writes a rosbag2 bag (MCAP storage) with rosbags, an independent writer: JointState on
/joint_states and WrenchStamped on /leg/ft, from forces of `terzaghi predict`, plus a topic of a
type terzaghi does not know. Prints the path of the .mcap file and what it wrote, as JSON."""
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

terzaghi, out_dir = sys.argv[1], Path(sys.argv[2])
flags = ["--length-m", "0.25", "--width-m", "0.06", "--hip-height-m", "0.15", "--unit-weight-n-m3", "16170",
         "--phi-deg", "32", "--delta-deg", "19", "--bk", "2", "--a", "1.5"]
table = json.loads(subprocess.run([terzaghi, "predict", *flags, "--beta-deg", "0:360:0.5", "--format", "json"],
                                  check=True, capture_output=True, text=True).stdout)

store = get_typestore(Stores.ROS2_JAZZY)
JointState = store.types["sensor_msgs/msg/JointState"]
WrenchStamped = store.types["geometry_msgs/msg/WrenchStamped"]
Wrench = store.types["geometry_msgs/msg/Wrench"]
Vector3 = store.types["geometry_msgs/msg/Vector3"]
Header = store.types["std_msgs/msg/Header"]
Time = store.types["builtin_interfaces/msg/Time"]
String = store.types["std_msgs/msg/String"]

written = {"ft": {}, "joint_states": 0}
with Writer(out_dir, version=9, storage_plugin=StoragePlugin.MCAP) as w:
    js_c = w.add_connection("/joint_states", JointState.__msgtype__, typestore=store)
    ft_c = w.add_connection("/leg/ft", WrenchStamped.__msgtype__, typestore=store)
    other = w.add_connection("/chatter", String.__msgtype__, typestore=store)
    for k, row in enumerate(table):
        t_ns = 1_700_000_000_000_000_000 + k * 4_000_000
        stamp = Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)
        beta = math.radians(row["beta_deg"])
        js = JointState(header=Header(stamp=stamp, frame_id=""), name=["hip"], position=np.array([beta]),
                        velocity=np.array([], dtype=np.float64), effort=np.array([], dtype=np.float64))
        w.write(js_c, t_ns, store.serialize_cdr(js, JointState.__msgtype__))
        ft = WrenchStamped(header=Header(stamp=stamp, frame_id="ft"),
                           wrench=Wrench(force=Vector3(x=-row["drag_n"], y=0.0, z=row["lift_n"]),
                                         torque=Vector3(x=0.0, y=0.0, z=0.0)))
        w.write(ft_c, t_ns + 1000, store.serialize_cdr(ft, WrenchStamped.__msgtype__))
        w.write(other, t_ns, store.serialize_cdr(String(data="hello"), String.__msgtype__))
        written["joint_states"] += 1
        written["ft"][f"{t_ns // 1_000_000_000}.{t_ns % 1_000_000_000:09d}"] = [row["drag_n"], row["lift_n"]]
mcap = next(out_dir.glob("*.mcap"))
print(json.dumps({"mcap": str(mcap), "written": written}))
