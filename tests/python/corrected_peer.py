"""An independent ROS 2 peer (Cyclone DDS) for a node that predicts with a corrected model.

It starts `terzaghi node --ros-args --params-file CORRECTED.yaml -p record:=SESSION.mcap`,
publishes the joint angles of a CSV log (t_s,beta_rad,...) as JointState, and collects the
node's `leg_force` and `predicted_wrench` for each of them; then it stops the node (Ctrl-C), so
that the recording is finished, and prints what it received as JSON. The caller compares it with
`terzaghi replay SESSION.mcap --reevaluate --params-file CORRECTED.yaml`. Run it inside a private
network namespace.
"""
import argparse
import csv
import json
import os
import signal
import subprocess
import time

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros_types import JointState, LegForce, WrenchStamped, Header, stamp, wait_matched


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--params", required=True, help="the corrected.yaml terzaghi diagnose wrote")
    ap.add_argument("--log", required=True, help="CSV log whose angles are published")
    ap.add_argument("--leg", required=True)
    ap.add_argument("--record", required=True, help="where the node records its session")
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--offset-s", type=float, default=100.0, help="added to the log's times")
    ap.add_argument("--domain", type=int, default=0)
    args = ap.parse_args()

    with open(args.log) as f:
        rows = [(float(r["t_s"]), float(r["beta_rad"])) for r in csv.DictReader(f)][: args.samples]

    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    node = subprocess.Popen([args.terzaghi, "node", "--ros-args", "--params-file", args.params,
                             "-p", "record:=" + args.record],
                            stderr=subprocess.PIPE, text=True, env=env)
    out = {"sent": 0, "leg_force": {}, "predicted_wrench": {}}

    def key(st):
        return str(st.sec * 1_000_000_000 + st.nanosec)

    try:
        dp = DomainParticipant(args.domain)
        rel = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10000))
        js_w = DataWriter(dp, Topic(dp, "rt/joint_states", JointState), qos=rel)
        lf_r = DataReader(dp, Topic(dp, "rt/" + args.leg + "/leg_force", LegForce), qos=rel)
        wr_r = DataReader(dp, Topic(dp, "rt/" + args.leg + "/predicted_wrench", WrenchStamped), qos=rel)
        if not wait_matched([js_w, lf_r, wr_r]):
            raise SystemExit("the node's topics never matched (discovery failed)")

        def take():
            for s in lf_r.take(N=1000):
                if isinstance(s, LegForce):
                    out["leg_force"][key(s.header.stamp)] = {
                        "drag_n": s.drag_n, "lift_n": s.lift_n,
                        "bare_drag_n": s.bare_drag_n, "bare_lift_n": s.bare_lift_n,
                        "sensor_drag_n": s.sensor_drag_n, "sensor_lift_n": s.sensor_lift_n,
                        "correction_names": list(s.correction_names),
                        "correction_drag_n": list(s.correction_drag_n),
                    }
            for s in wr_r.take(N=1000):
                if isinstance(s, WrenchStamped):
                    out["predicted_wrench"][key(s.header.stamp)] = [s.wrench.force.x, s.wrench.force.z]

        # Discovery is not symmetric: joint states go out (stamped before the log's) until a
        # prediction comes back, so that none of the log's is written before the node listens.
        answered = False
        end = time.time() + 20
        i = 0
        while not answered and time.time() < end:
            js_w.write(JointState(header=Header(stamp=stamp(1.0 + 0.01 * i)), name=[args.leg],
                                  position=[rows[0][1]]))
            i += 1
            time.sleep(0.05)
            take()
            answered = bool(out["leg_force"])
        if not answered:
            raise SystemExit("the node never answered a joint state (discovery failed)")
        time.sleep(0.3)
        take()
        warmup = set(out["leg_force"])

        for k, (t, beta) in enumerate(rows):
            js_w.write(JointState(header=Header(stamp=stamp(args.offset_s + t)), name=[args.leg],
                                  position=[beta]))
            out["sent"] += 1
            if k % 10 == 9:
                time.sleep(0.01)
                take()
        end = time.time() + 15
        while len(out["leg_force"]) - len(warmup) < len(rows) and time.time() < end:
            time.sleep(0.05)
            take()
        for k in warmup:
            out["leg_force"].pop(k, None)
            out["predicted_wrench"].pop(k, None)
    finally:
        node.send_signal(signal.SIGINT)
        try:
            _, err = node.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            node.kill()
            _, err = node.communicate()
        out["node_exit_code"] = node.returncode
        out["node_stderr_tail"] = err.splitlines()[-5:]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
