"""Time from `terzaghi node`'s start to the first prediction a ROS 2 peer receives.

The peer publishes JointState at 200 Hz on /joint_states and subscribes to
/leg/predicted_wrench, as a controller launched with the node does. It is either Python
`cyclonedds` (Cyclone DDS) or rclpy (ROS 2's own client library, over Fast DDS). With
`--order before` the peer is up and publishing before the node starts; with `--order after`
the node starts first and the peer is created right after. The time is measured from the
node's process start to the first predicted wrench taken by the peer. Prints JSON:
{"peer", "order", "starts", "times_s", "p50_s", "p90_s", "failures"}. Run it inside a private
network namespace (tests/netns-run).
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

PARAMS = """/**:
  ros__parameters:
    legs: [leg]
    leg:
      joint: hip
      length_m: 0.25
      width_m: 0.06
      hip_height_m: 0.15
      unit_weight_n_m3: 16170
      phi_deg: 32.0
      delta_deg: 19.0
      b_k: 2.0
      a: 1.5
"""


class CyclonePeer:
    def __init__(self, domain):
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration
        from ros_types import Header, JointState, WrenchStamped, stamp

        self.JointState, self.Header, self.stamp, self.WrenchStamped = JointState, Header, stamp, WrenchStamped
        self.dp = DomainParticipant(domain)
        rel = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10))
        self.js = DataWriter(self.dp, Topic(self.dp, "rt/joint_states", JointState), qos=rel)
        self.wr = DataReader(self.dp, Topic(self.dp, "rt/leg/predicted_wrench", WrenchStamped), qos=rel)

    def publish(self, i):
        self.js.write(self.JointState(header=self.Header(stamp=self.stamp(100.0 + 0.005 * i)), name=["hip"],
                                      position=[math.radians(60)]))

    def received(self):
        return any(isinstance(s, self.WrenchStamped) for s in self.wr.take(N=100))

    def close(self):
        del self.js, self.wr, self.dp


class RclpyPeer:
    def __init__(self, domain):
        import rclpy
        from geometry_msgs.msg import WrenchStamped
        from sensor_msgs.msg import JointState

        self.rclpy = rclpy
        self.JointState = JointState
        self.ctx = rclpy.context.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("discovery_peer", context=self.ctx)
        self.js = self.node.create_publisher(JointState, "/joint_states", 10)
        self.got = threading.Event()
        self.node.create_subscription(WrenchStamped, "/leg/predicted_wrench", lambda m: self.got.set(), 10)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def publish(self, i):
        m = self.JointState()
        t = 100.0 + 0.005 * i
        m.header.stamp.sec = int(t)
        m.header.stamp.nanosec = int((t - int(t)) * 1e9)
        m.name = ["hip"]
        m.position = [math.radians(60)]
        self.js.publish(m)

    def received(self):
        self.executor.spin_once(timeout_sec=0)
        return self.got.is_set()

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.ctx)


def one_start(args, params, domain):
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    peer_cls = CyclonePeer if args.peer == "cyclone" else RclpyPeer
    peer = None
    if args.order == "before":
        peer = peer_cls(domain)
        # Already publishing when the node starts, as a running robot is.
        for i in range(20):
            peer.publish(i)
            time.sleep(0.005)
    t0 = time.monotonic()
    node = subprocess.Popen([args.terzaghi, "node", "--ros-args", "--params-file", params],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    try:
        if peer is None:
            peer = peer_cls(domain)
        i = 0
        while time.monotonic() - t0 < args.timeout:
            peer.publish(i)
            i += 1
            if peer.received():
                return time.monotonic() - t0
            # 200 Hz
            time.sleep(max(0.0, t0 + i * 0.005 - time.monotonic()))
        return None
    finally:
        node.terminate()
        try:
            node.wait(timeout=10)
        except subprocess.TimeoutExpired:
            node.kill()
            node.wait()
        if peer is not None:
            peer.close()


def quantile(xs, q):
    xs = sorted(xs)
    if not xs:
        return None
    k = q * (len(xs) - 1)
    lo = math.floor(k)
    hi = min(lo + 1, len(xs) - 1)
    return xs[lo] + (xs[hi] - xs[lo]) * (k - lo)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--peer", choices=["cyclone", "rclpy"], required=True)
    ap.add_argument("--order", choices=["before", "after"], required=True,
                    help="the peer starts before or after the node")
    ap.add_argument("--starts", type=int, default=20)
    ap.add_argument("--timeout", type=float, default=15.0, help="seconds a start may take before it counts as failed")
    ap.add_argument("--domain", type=int, default=40, help="first DDS domain; each start uses the next one")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        params = os.path.join(d, "leg.yaml")
        with open(params, "w") as f:
            f.write(PARAMS)
        times, failures = [], 0
        for k in range(args.starts):
            # A domain per start: no participant of an earlier start is heard.
            # Domains stay at or below 101, as ROS 2 advises: above it their ports fall in
            # Linux's ephemeral range, where another socket may already hold one.
            t = one_start(args, params, args.domain + k % max(1, 102 - args.domain))
            if t is None:
                failures += 1
            else:
                times.append(t)
            print(f"start {k}: {t}", file=sys.stderr)
    print(json.dumps({"peer": args.peer, "order": args.order, "starts": args.starts,
                      "times_s": [round(t, 3) for t in times],
                      "p50_s": quantile(times, 0.5), "p90_s": quantile(times, 0.9), "failures": failures}))


if __name__ == "__main__":
    main()
