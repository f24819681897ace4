"""rclpy (Fast DDS) moving a robot's body on /tf, as a ROS 2 robot's own code does.

ROS 2's PyPI wheels carry neither tf2_ros nor tf2_msgs, so this peer publishes
tf2_msgs/msg/TFMessage (built by build_msgs.sh from its definition) with plain rclpy publishers
under tf2_ros's QoS: /tf_static reliable, transient local, depth 1 (published before the node
starts, so the node gets it as a late joiner), /tf reliable, volatile, depth 100.

The hip `leg_hip` sits 0.1 m ahead of base_link. The body is held at three heights above the
surface, level, and then pitched; at each, the leg sweeps 40..140 deg (a JointState stamped like
the /tf before it). Checks, per answer of the node (`leg/leg_force`):
- `tf_hip_height`: the hip height and pitch the node reports are the ones this peer placed;
- `tf_matches_predict`: drag, lift and torque equal `terzaghi predict --hip-height-m H` at that
  height (level body);
- `tf_pitch`: with the body pitched, the hip height is the body's height less the hip's offset
  turned by the pitch.
Prints a JSON summary; exits 0 only if every check holds. Run it inside a private network
namespace, with the environment of build_msgs.sh's env.sh.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time

import rclpy
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import JointState
from terzaghi_msgs.msg import LegForce
from tf2_msgs.msg import TFMessage

from rclpy_peer import (GEOM as LEG_GEOM, PARAMS as LEG_PARAMS, predict_table, shut_down,
                        stamp_of, wait_until)

# The rclpy peer's leg, placed by /tf instead of measured by F/T.
PARAMS = LEG_PARAMS.replace("      ft_topic: leg/ft\n", "      hip_frame: leg_hip\n")
assert "hip_frame" in PARAMS
HIP_X_M = 0.1


def geometry_at(hip_height_m):
    """`terzaghi predict`'s flags for the leg with its hip at `hip_height_m`."""
    g = list(LEG_GEOM)
    g[g.index("--hip-height-m") + 1] = repr(hip_height_m)
    return [*g, "--bk", "2.0", "--a", "1.5"]


def transform(parent, child, t_s, x, z, pitch):
    m = TransformStamped()
    m.header.stamp = stamp_of(t_s)
    m.header.frame_id = parent
    m.child_frame_id = child
    m.transform.translation.x = x
    m.transform.translation.z = z
    m.transform.rotation.y = math.sin(pitch / 2)
    m.transform.rotation.w = math.cos(pitch / 2)
    return m


class Peer(Node):
    def __init__(self):
        super().__init__("rclpy_tf_peer")
        self.lock = threading.Lock()
        self.forces = {}
        reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        # tf2_ros's StaticTransformBroadcaster and TransformBroadcaster QoS.
        self.tf_static = self.create_publisher(TFMessage, "/tf_static", QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.tf = self.create_publisher(TFMessage, "/tf", QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE))
        self.js = self.create_publisher(JointState, "/joint_states", reliable)
        self.create_subscription(LegForce, "/leg/leg_force", self.on_force, reliable)

    def on_force(self, m):
        with self.lock:
            self.forces[(m.header.stamp.sec, m.header.stamp.nanosec)] = m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--domain", type=int, default=22)
    args = ap.parse_args()
    summary = {"checks": {}}
    failures = []

    def check(name, ok, detail):
        summary["checks"][name] = {"ok": bool(ok), "detail": detail}
        if not ok:
            failures.append(f"{name}: {detail}")

    os.environ["ROS_DOMAIN_ID"] = str(args.domain)
    rclpy.init()
    peer = Peer()
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(peer)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()
    peer.tf_static.publish(TFMessage(transforms=[transform("base_link", "leg_hip", 0.0, HIP_X_M, 0.0, 0.0)]))

    d = tempfile.mkdtemp()
    params_file = os.path.join(d, "leg.yaml")
    with open(params_file, "w") as f:
        f.write(PARAMS)
    node = subprocess.Popen([args.terzaghi, "node", "--ros-args", "--params-file", params_file],
                            stderr=subprocess.PIPE, text=True)
    t = {"now": 100.0}

    def send_pose(z, pitch):
        peer.tf.publish(TFMessage(transforms=[transform("odom", "base_link", t["now"], 0.0, z, pitch)]))

    def send_angle(beta_rad):
        m = JointState(name=["hip"], position=[beta_rad])
        m.header.stamp = stamp_of(t["now"])
        peer.js.publish(m)

    try:
        # The node answers a JointState placed by /tf: discovery is done both ways, and the
        # node holds /tf_static.
        def answered():
            send_pose(0.15, 0.0)
            time.sleep(0.002)
            send_angle(math.radians(60))
            t["now"] += 0.01
            with peer.lock:
                return any(f.robot_state for f in peer.forces.values())

        if not wait_until(answered, 30):
            raise SystemExit("the node never answered a joint state placed by /tf (discovery failed)")
        time.sleep(0.3)
        with peer.lock:
            peer.forces.clear()

        spec = "40:140:5"
        segments = [(0.12, 0.0), (0.15, 0.0), (0.18, 0.0), (0.15, math.radians(4.0))]
        sent = []
        for z, pitch in segments:
            # The body moves to its new pose first, so that no answer holds the last one.
            for _ in range(5):
                send_pose(z, pitch)
                t["now"] += 0.01
                time.sleep(0.005)
            time.sleep(0.1)
            hip_h = z - HIP_X_M * math.sin(pitch)
            for row in predict_table(args.terzaghi, geometry_at(hip_h), spec):
                send_pose(z, pitch)
                time.sleep(0.002)
                send_angle(math.radians(row["beta_deg"]))
                st = stamp_of(t["now"])
                sent.append(((st.sec, st.nanosec), hip_h, pitch, row))
                t["now"] += 0.01
                time.sleep(0.005)
        wait_until(lambda: all(k in peer.forces for k, *_ in sent), 10)

        got, worst_h, worst_f, worst_pitch_h, pitched = 0, 0.0, 0.0, 0.0, 0
        with peer.lock:
            for k, hip_h, pitch, row in sent:
                f = peer.forces.get(k)
                if f is None:
                    continue
                got += 1
                err_h = max(abs(f.hip_height_m - hip_h), abs(f.body_pitch_rad - pitch),
                            0.0 if f.robot_state else 1.0)
                if pitch == 0.0:
                    worst_h = max(worst_h, err_h)
                    for want, have in ((row["drag_n"], f.drag_n), (row["lift_n"], f.lift_n),
                                       (row["hip_torque_nm"], f.hip_torque_nm)):
                        worst_f = max(worst_f, abs(want - have) / max(1.0, abs(want)))
                else:
                    pitched += 1
                    worst_pitch_h = max(worst_pitch_h, err_h)
        level = sum(1 for _, _, p, _ in sent if p == 0.0)
        check("tf_hip_height", got == len(sent) and worst_h < 1e-9,
              {"sent": len(sent), "received": got, "worst_error": worst_h})
        check("tf_matches_predict", got == len(sent) and worst_f < 1e-9,
              {"level_samples": level, "worst_rel_error": worst_f})
        check("tf_pitch", pitched == len(sent) - level and pitched > 0 and worst_pitch_h < 1e-9,
              {"pitched_samples": pitched, "worst_error": worst_pitch_h})
    finally:
        node.send_signal(2)
        try:
            _, err = node.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            node.kill()
            _, err = node.communicate()
        summary["node_exit_code"] = node.returncode
        summary["node_stderr_tail"] = err.splitlines()[-5:]
        shut_down(executor, spin, peer)
    print(json.dumps(summary))
    if failures:
        print("\n".join(failures), file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
