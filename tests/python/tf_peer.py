"""An independent ROS 2 peer (Cyclone DDS) that moves a robot's body on /tf.

As a robot's own tf2 broadcasters would, it publishes the hip's place in the body on
/tf_static (reliable, transient local) before the node starts, then starts
`terzaghi node --ros-args --params-file PARAMS -p record:=SESSION.mcap`, and publishes, sample by
sample, the body's pose on /tf (odom to base_link: heaving and pitching) and the leg's angle as
JointState with the same stamp. It collects the node's `leg_force` for each, stops the node
(Ctrl-C) so that its recording is finished, and prints as JSON what it sent and received. Run it
inside a private network namespace.
"""
import argparse
import json
import math
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

from ros_types import (Header, JointState, LegForce, Quaternion, TFMessage, Transform,
                       TransformStamped, Vector3, stamp, wait_matched)


def transform(parent, child, t_s, x, z, pitch):
    return TransformStamped(
        header=Header(stamp=stamp(t_s), frame_id=parent), child_frame_id=child,
        transform=Transform(translation=Vector3(x=x, y=0.0, z=z),
                            rotation=Quaternion(x=0.0, y=math.sin(pitch / 2), z=0.0,
                                                w=math.cos(pitch / 2))))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--params", required=True)
    ap.add_argument("--leg", required=True)
    ap.add_argument("--record", required=True)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--domain", type=int, default=0)
    args = ap.parse_args()

    # The body: 0.15 m up, heaving 1 cm and pitching 3 deg; the hip 0.1 m ahead of its origin.
    hip_x, body_z, heave, pitch_amp = 0.1, 0.15, 0.01, math.radians(3.0)
    t0 = 100.0
    motion = []
    for k in range(args.samples):
        t = t0 + 0.002 * k
        ph = 2 * math.pi * 2.0 * (t - t0)
        motion.append((t, 0.2 + 3.0 * (t - t0), body_z + heave * math.sin(ph),
                       pitch_amp * math.cos(ph)))

    dp = DomainParticipant(args.domain)
    latched = Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                  Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
    static_w = DataWriter(dp, Topic(dp, "rt/tf_static", TFMessage), qos=latched)
    static_w.write(TFMessage(transforms=[transform("base_link", args.leg + "_hip", t0, hip_x, 0.0, 0.0)]))

    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    node = subprocess.Popen([args.terzaghi, "node", "--ros-args", "--params-file", args.params,
                             "-p", "record:=" + args.record],
                            stderr=subprocess.PIPE, text=True, env=env)
    out = {"sent": [], "leg_force": {}}

    def key(st):
        return str(st.sec * 1_000_000_000 + st.nanosec)

    try:
        rel = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10000))
        tf_w = DataWriter(dp, Topic(dp, "rt/tf", TFMessage), qos=rel)
        js_w = DataWriter(dp, Topic(dp, "rt/joint_states", JointState), qos=rel)
        lf_r = DataReader(dp, Topic(dp, "rt/" + args.leg + "/leg_force", LegForce), qos=rel)
        if not wait_matched([tf_w, js_w, lf_r, static_w]):
            raise SystemExit("the node's topics never matched (discovery failed)")

        def take():
            for s in lf_r.take(N=1000):
                if isinstance(s, LegForce):
                    out["leg_force"][key(s.header.stamp)] = {
                        "drag_n": s.drag_n, "lift_n": s.lift_n, "hip_height_m": s.hip_height_m,
                        "body_pitch_rad": s.body_pitch_rad, "robot_state": s.robot_state,
                    }

        # Joint states stamped before the walk until the node answers, so that none of the
        # walk's is sent before it listens.
        end = time.time() + 20
        i = 0
        while not out["leg_force"] and time.time() < end:
            js_w.write(JointState(header=Header(stamp=stamp(1.0 + 0.01 * i)), name=[args.leg],
                                  position=[0.2]))
            i += 1
            time.sleep(0.05)
            take()
        if not out["leg_force"]:
            raise SystemExit("the node never answered a joint state (discovery failed)")
        time.sleep(0.3)
        take()
        out["leg_force"].clear()

        for k, (t, beta, z, pitch) in enumerate(motion):
            tf_w.write(TFMessage(transforms=[transform("odom", "base_link", t, 0.05 * (t - t0), z, pitch)]))
            time.sleep(0.0005)
            js_w.write(JointState(header=Header(stamp=stamp(t)), name=[args.leg], position=[beta]))
            # The hip: the body's height less the hip's offset turned by the pitch.
            out["sent"].append({"stamp": key(stamp(t)), "hip_height_m": z - hip_x * math.sin(pitch),
                                "pitch_rad": pitch})
            if k % 10 == 9:
                time.sleep(0.005)
                take()
        end = time.time() + 15
        while len(out["leg_force"]) < len(motion) and time.time() < end:
            time.sleep(0.05)
            take()
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
