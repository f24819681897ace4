"""A hostile DDS peer (Cyclone DDS) for the terzaghi node: raw bytes on each of its topics.

It starts `terzaghi node`, then, for a few seconds and as fast as Cyclone writes, sends on
JointState, the leg's F/T, /tf and /tf_static samples that are garbage (random bytes of random
length under the topic's type name), truncated (a header, then a sequence that claims more than
the sample holds) and oversized (JointStates of a million names). Meanwhile it sends well-formed
JointStates (each sent again until answered: the node drops inputs when its queue is full, and
counts them) and checks each prediction against `terzaghi predict` for the same angle. It reads
the node's peak memory (VmHWM) before and after, and what the node says it skipped when it
stops. Prints a JSON summary; exits 0 only if every check holds. Run it in a private network
namespace.
"""
import argparse
import json
import math
import os
import random
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros_types import Header, JointState, WrenchStamped, stamp, wait_matched

TYPES = {
    "joint_states": "sensor_msgs::msg::dds_::JointState_",
    "leg/ft": "geometry_msgs::msg::dds_::WrenchStamped_",
    "tf": "tf2_msgs::msg::dds_::TFMessage_",
    "tf_static": "tf2_msgs::msg::dds_::TFMessage_",
}


def raw_type(typename):
    """A struct of one byte sequence under another type's name: its CDR is a length and bytes,
    which the node reads as that type."""

    @dataclass
    class Raw(IdlStruct, typename=typename):
        data: sequence[uint8] = field(default_factory=list)

    return Raw


def truncated_type(typename):
    """A header, then a count that promises more elements than follow."""

    @dataclass
    class Truncated(IdlStruct, typename=typename):
        header: Header = field(default_factory=Header)
        count: uint32 = 1_000_000

    return Truncated


def vm_hwm_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    return -1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--params-file", required=True)
    ap.add_argument("--predict-flags", required=True, help="JSON list: `terzaghi predict` flags of the node's leg")
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--seconds", type=float, default=4.0, help="how long the hostile traffic lasts")
    ap.add_argument("--oversized", type=int, default=3, help="JointStates of a million names to send")
    args = ap.parse_args()
    failures, summary = [], {"sent": {}}
    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    node = subprocess.Popen([args.terzaghi, "node", "--ros-args", "--params-file", args.params_file],
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        rel = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(2000))
        latched = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(100),
                      Policy.Durability.TransientLocal)
        fast = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(100))
        good = DomainParticipant(args.domain)
        js_w = DataWriter(good, Topic(good, "rt/joint_states", JointState), qos=rel)
        wr_r = DataReader(good, Topic(good, "rt/leg/predicted_wrench", WrenchStamped), qos=rel)
        # One participant per wrong type: a participant holds one type per topic name.
        raw_dp, trunc_dp = DomainParticipant(args.domain), DomainParticipant(args.domain)
        raw_w, trunc_w, raw_t, trunc_t = {}, {}, {}, {}
        for topic, typename in TYPES.items():
            qos = latched if topic == "tf_static" else fast
            raw_t[topic], trunc_t[topic] = raw_type(typename), truncated_type(typename)
            raw_w[topic] = DataWriter(raw_dp, Topic(raw_dp, "rt/" + topic, raw_t[topic]), qos=qos)
            trunc_w[topic] = DataWriter(trunc_dp, Topic(trunc_dp, "rt/" + topic, trunc_t[topic]), qos=qos)
        if not wait_matched([js_w, wr_r, *raw_w.values(), *trunc_w.values()]):
            raise SystemExit("the node's topics never matched (discovery failed)")
        # Warm up until the node answers (its writer may match this reader late).
        answered, end, i = False, time.time() + 20, 0
        while not answered and time.time() < end:
            js_w.write(JointState(header=Header(stamp=stamp(500.0 + 0.01 * i)), name=["hip"],
                                  position=[math.radians(60)]))
            i += 1
            time.sleep(0.05)
            answered = any(isinstance(s, WrenchStamped) for s in wr_r.take(N=100))
        if not answered:
            raise SystemExit("the node never answered a joint state")
        time.sleep(0.3)
        wr_r.take(N=1000)
        hwm_before = vm_hwm_kb(node.pid)

        flags = json.loads(args.predict_flags)
        out = subprocess.run([args.terzaghi, "predict", *flags, "--beta-deg", "40:140:5", "--format", "json"],
                             check=True, capture_output=True, text=True)
        expected = json.loads(out.stdout)

        rng = random.Random(11)
        sent = {f"{kind}:{t}": 0 for kind in ("garbage", "truncated") for t in TYPES}
        sent["oversized:joint_states"] = 0
        # Each well-formed JointState is sent, and sent again under a new stamp if no prediction
        # comes within RETRY_S (the node drops inputs when its queue is full, and counts them):
        # a row is answered once, or missing after MAX_ATTEMPTS; every unanswered attempt is
        # one input the node must have counted as dropped.
        RETRY_S, MAX_ATTEMPTS = 0.25, 40
        got = {}
        attempt_of = {}
        attempts, answered_rows, answered_keys = 0, set(), set()
        start = time.time()
        k = 0
        row, tries, sent_at = 0, 0, None
        big_names = [f"j{i}" for i in range(1_000_000)]

        def take_answers():
            for s in wr_r.take(N=100):
                if isinstance(s, WrenchStamped):
                    key = (s.header.stamp.sec, s.header.stamp.nanosec)
                    if key in attempt_of:
                        answered_keys.add(key)
                    if key in attempt_of and attempt_of[key][0] not in answered_rows:
                        got[attempt_of[key][0]] = s
                        answered_rows.add(attempt_of[key][0])

        while time.time() - start < args.seconds or row < len(expected):
            for topic in TYPES:
                n = rng.choice([0, 1, 3, 7, 12, 40, 200, 1500])
                raw_w[topic].write(raw_t[topic](data=[rng.randrange(256) for _ in range(n)]))
                sent[f"garbage:{topic}"] += 1
                trunc_w[topic].write(trunc_t[topic](header=Header(stamp=stamp(600.0 + k * 1e-3))))
                sent[f"truncated:{topic}"] += 1
            if k % 200 == 100 and sent["oversized:joint_states"] < args.oversized:
                # A million names and no positions: a message no leg can be read from.
                js_w.write(JointState(header=Header(stamp=stamp(700.0 + k * 1e-3)), name=big_names))
                sent["oversized:joint_states"] += 1
            take_answers()
            now = time.time()
            if row < len(expected) and (row in answered_rows or tries >= MAX_ATTEMPTS):
                row, tries, sent_at = row + 1, 0, None
            if (row < len(expected) and now - start > 0.5
                    and (sent_at is None or now - sent_at > RETRY_S)):
                st = stamp(1000.0 + 0.1 * row + 0.001 * tries)
                attempt_of[(st.sec, st.nanosec)] = (row, tries)
                js_w.write(JointState(header=Header(stamp=st), name=["other", "hip"],
                                      position=[0.3, math.radians(expected[row]["beta_deg"])]))
                tries, sent_at, attempts = tries + 1, now, attempts + 1
            k += 1
        end = time.time() + 5
        while time.time() < end:
            take_answers()
            time.sleep(0.05)
        worst, missing = 0.0, 0
        for i, want_row in enumerate(expected):
            s = got.get(i)
            if s is None:
                missing += 1
                continue
            for want, have in [(-want_row["drag_n"], s.wrench.force.x), (want_row["lift_n"], s.wrench.force.z),
                               (want_row["hip_torque_nm"], s.wrench.torque.y)]:
                worst = max(worst, abs(want - have) / max(1.0, abs(want)))
        summary["sent"] = sent
        summary["hostile_seconds"] = time.time() - start
        summary["predictions"] = {"rows": len(expected), "answered": len(expected) - missing,
                                  "attempts": attempts, "unanswered_attempts": attempts - len(answered_keys),
                                  "worst_rel_error": worst}
        if missing:
            failures.append(f"{missing} of {len(expected)} well-formed joint states got no prediction "
                            f"in {MAX_ATTEMPTS} attempts each")
        if worst > 1e-9:
            failures.append(f"a prediction differs from terzaghi predict by {worst}")
        time.sleep(1.0)
        summary["vm_hwm_kb"] = {"before": hwm_before, "after": vm_hwm_kb(node.pid)}
    finally:
        node.send_signal(signal.SIGINT)
        try:
            _, err = node.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            node.kill()
            _, err = node.communicate()
            failures.append("the node did not stop on SIGINT")
        summary["node_exit_code"] = node.returncode
        summary["node_stopped_line"] = next((l for l in err.splitlines() if "terzaghi node stopped" in l), "")
        if node.returncode != 0:
            failures.append(f"node exit code {node.returncode}: {err[-1500:]}")
        summary["failures"] = failures
        print(json.dumps(summary, indent=2))
        sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
