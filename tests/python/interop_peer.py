"""An independent ROS 2 peer (Cyclone DDS) for the terzaghi node.

It starts `terzaghi node` with a params file, publishes JointState, receives the predicted
wrenches and checks them against `terzaghi predict` for the same angles; then it publishes F/T
data generated with known b_k, a and waits for `model_params` to converge to them. It prints a
JSON summary and exits 0 only if every check holds. Run it inside a private network namespace.
"""
import argparse
import json
import os
import math
import random
import signal
import subprocess
import sys
import time

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ros_types import JointState, ModelParams, WrenchStamped, Header, Wrench, Vector3, stamp, wait_matched

def predict_table(binary, flags, spec):
    out = subprocess.run([binary, "predict", *flags, "--beta-deg", spec, "--format", "json"],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--node-args", required=True, help="JSON list: arguments after `terzaghi node`")
    ap.add_argument("--predict-flags", required=True, help="JSON list: `terzaghi predict` flags giving the node's model")
    ap.add_argument("--ns", default="", help="namespace the node runs in, e.g. /robot")
    ap.add_argument("--leg", default="leg")
    ap.add_argument("--joint", default="hip")
    ap.add_argument("--identify", action="store_true", help="also check identification from F/T on <leg>/ft")
    ap.add_argument("--set-param", default="", help="NAME=VALUE to set through the parameter services")
    ap.add_argument("--after-set-flags", default="[]", help="JSON list: predict flags once it is set")
    ap.add_argument("--domain", type=int, default=0, help="DDS domain (the node gets ROS_DOMAIN_ID)")
    ap.add_argument("--dump", default="", help="write what was sent and received to this JSON file")
    ap.add_argument("--kill-after", type=float, default=0.0,
                    help="SIGKILL the node this many seconds into the F/T phase (crash test)")
    ap.add_argument("--truth-bk", type=float, default=3.0)
    ap.add_argument("--truth-a", type=float, default=1.8)
    ap.add_argument("--strokes", type=int, default=8)
    args = ap.parse_args()
    summary = {"checks": {}}
    failures = []
    dump = {"joint_states": {}, "ft": {}, "predicted_wrench": {}, "model_params": [], "sent_wall": {},
            "kill_wall": None}

    def key(st):
        return str(st.sec * 1_000_000_000 + st.nanosec)

    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    node = subprocess.Popen([args.terzaghi, "node", *json.loads(args.node_args)],
                            stderr=subprocess.PIPE, text=True, env=env)
    flags = json.loads(args.predict_flags)
    pre = "rt" + args.ns.rstrip("/") + "/"
    try:
        dp = DomainParticipant(args.domain)
        rel = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(2000))
        js_w = DataWriter(dp, Topic(dp, pre + "joint_states", JointState), qos=rel)
        ft_w = DataWriter(dp, Topic(dp, pre + args.leg + "/ft", WrenchStamped), qos=rel)
        wr_r = DataReader(dp, Topic(dp, pre + args.leg + "/predicted_wrench", WrenchStamped), qos=rel)
        mp_r = DataReader(dp, Topic(dp, pre + args.leg + "/model_params", ModelParams), qos=rel)
        if not wait_matched([js_w, wr_r] + ([ft_w, mp_r] if args.identify else [])):
            raise SystemExit("the node's topics never matched (discovery failed)")

        # Discovery is not symmetric: this reader can match the node's writer before the node's
        # writer has matched this reader, and what the node writes before that reaches nobody
        # (volatile durability), as for any ROS 2 subscriber. So joint states go out (stamped
        # before every checked one) until a prediction comes back.
        answered = False
        end = time.time() + 20
        i = 0
        while not answered and time.time() < end:
            js_w.write(JointState(header=Header(stamp=stamp(500.0 + 0.01 * i)), name=[args.joint],
                                  position=[math.radians(60)]))
            i += 1
            time.sleep(0.05)
            answered = any(isinstance(s, WrenchStamped) for s in wr_r.take(N=100))
        if not answered:
            raise SystemExit("the node never answered a joint state (discovery failed)")
        time.sleep(0.3)
        wr_r.take(N=1000)  # the answers to the other warm-up joint states

        # 1. Predictions against `terzaghi predict` for the same angles.
        def check_predictions(flags, t0, label):
            expected = predict_table(args.terzaghi, flags, "40:140:5")
            for i, row in enumerate(expected):
                beta = math.radians(row["beta_deg"])
                js_w.write(JointState(header=Header(stamp=stamp(t0 + 0.01 * i)), name=["other", args.joint],
                                      position=[0.3, beta]))
                dump["joint_states"][key(stamp(t0 + 0.01 * i))] = [0.3, beta]
                time.sleep(0.005)
            got = {}
            end = time.time() + 10
            while len(got) < len(expected) and time.time() < end:
                for s in wr_r.take(N=100):
                    if isinstance(s, WrenchStamped):
                        got[(s.header.stamp.sec, s.header.stamp.nanosec)] = s
                        dump["predicted_wrench"][key(s.header.stamp)] = [s.wrench.force.x, s.wrench.force.z, s.wrench.torque.y]
                time.sleep(0.02)
            worst = 0.0
            for i, row in enumerate(expected):
                st = stamp(t0 + 0.01 * i)
                s = got.get((st.sec, st.nanosec))
                if s is None:
                    failures.append(f"{label}: no prediction for beta {row['beta_deg']}")
                    continue
                if s.header.frame_id != args.leg + "_hip":
                    failures.append(f"{label}: frame {s.header.frame_id!r}")
                for want, have in [(-row["drag_n"], s.wrench.force.x), (row["lift_n"], s.wrench.force.z),
                                   (row["hip_torque_nm"], s.wrench.torque.y)]:
                    worst = max(worst, abs(want - have) / max(1.0, abs(want)))
            summary["checks"][label] = {"sent": len(expected), "received": len(got), "worst_rel_error": worst}
            if worst > 1e-9:
                failures.append(f"{label}: prediction differs from terzaghi predict by {worst}")

        check_predictions(flags, 1000.0, "predictions")

        # 1b. A parameter changed at run time through the parameter services.
        if args.set_param:
            name, value = args.set_param.split("=", 1)
            fqn = args.ns.rstrip("/") + "/terzaghi"
            bad = subprocess.run([args.terzaghi, "param", "set", fqn, args.leg + ".width_m", "-0.5"],
                                 capture_output=True, text=True, env=env)
            summary["checks"]["refused_set"] = {"exit_code": bad.returncode, "stderr": bad.stderr.strip()}
            if bad.returncode != 2 or "width" not in bad.stderr:
                failures.append(f"an invalid width was not refused: {bad.returncode} {bad.stderr}")
            ok = subprocess.run([args.terzaghi, "param", "set", fqn, name, value], capture_output=True, text=True,
                                env=env)
            if ok.returncode != 0:
                failures.append(f"param set {name} {value} failed: {ok.stderr}")
            time.sleep(0.2)
            check_predictions(json.loads(args.after_set_flags), 1500.0, "predictions_after_set")

        # 2. Identification from F/T generated with known b_k, a.
        if not args.identify:
            return
        truth = [f for f in flags]
        for flag, value in (("--bk", args.truth_bk), ("--a", args.truth_a)):
            if flag in truth:
                truth[truth.index(flag) + 1] = str(value)
            else:
                truth += [flag, str(value)]
        table = predict_table(args.terzaghi, truth, "0:360:0.05")
        peak = max(max(abs(r["drag_n"]), abs(r["lift_n"])) for r in table)
        rng = random.Random(7)

        def force(beta):
            x = math.degrees(beta % (2 * math.pi)) / 0.05
            i = min(int(x), len(table) - 2)
            f = x - i
            d = table[i]["drag_n"] * (1 - f) + table[i + 1]["drag_n"] * f
            l = table[i]["lift_n"] * (1 - f) + table[i + 1]["lift_n"] * f
            return d, l

        rate, omega = 250.0, 4.0
        n = int(args.strokes * 2 * math.pi / omega * rate)
        t1 = 2000.0
        start = time.time()
        for k in range(n):
            t = t1 + k / rate
            beta = omega * k / rate
            d, l = force(beta)
            d += rng.gauss(0, 0.02 * peak)
            l += rng.gauss(0, 0.02 * peak)
            js_w.write(JointState(header=Header(stamp=stamp(t)), name=[args.joint], position=[beta]))
            ft_w.write(WrenchStamped(header=Header(stamp=stamp(t), frame_id="ft"),
                                     wrench=Wrench(force=Vector3(x=-d, z=l))))
            dump["joint_states"][key(stamp(t))] = [beta]
            dump["ft"][key(stamp(t))] = [-d, l]
            dump["sent_wall"][key(stamp(t))] = time.time()
            if args.kill_after and time.time() - start >= args.kill_after:
                node.kill()
                dump["kill_wall"] = time.time()
                break
            lag = start + (k + 1) / rate - time.time()
            if lag > 0:
                time.sleep(lag)
        last = None
        end = time.time() + 5
        while time.time() < end:
            for s in mp_r.take(N=1000):
                if isinstance(s, ModelParams):
                    last = s
                    dump["model_params"].append([key(s.header.stamp), s.b_k, s.a, s.samples_used])
            time.sleep(0.05)
        if args.kill_after:
            pass  # the node was killed on purpose: nothing more to check here
        elif last is None:
            failures.append("no model_params received")
        else:
            eb, ea = last.b_k / args.truth_bk - 1, last.a / args.truth_a - 1
            summary["checks"]["identification"] = {
                "b_k": last.b_k, "a": last.a, "std_b_k": last.std_b_k, "std_a": last.std_a,
                "converged": last.converged, "samples_used": last.samples_used,
                "rel_error_b_k": eb, "rel_error_a": ea}
            if not last.converged or abs(eb) > 0.03 or abs(ea) > 0.03:
                failures.append(f"model_params b_k {last.b_k} a {last.a} converged {last.converged}")
    finally:
        node.send_signal(signal.SIGINT)
        try:
            _, err = node.communicate(timeout=15)
        except subprocess.TimeoutExpired:
            node.kill()
            _, err = node.communicate()
            failures.append("the node did not stop on SIGINT")
        summary["node_exit_code"] = node.returncode
        summary["node_stderr"] = err[-2000:]
        if node.returncode != 0 and not args.kill_after:
            failures.append(f"node exit code {node.returncode}")
        if args.dump:
            # Predicted wrenches that arrived during the identification phase count too.
            for s in wr_r.take(N=100000):
                if isinstance(s, WrenchStamped):
                    dump["predicted_wrench"][key(s.header.stamp)] = [s.wrench.force.x, s.wrench.force.z, s.wrench.torque.y]
            with open(args.dump, "w") as f:
                json.dump(dump, f)
        summary["failures"] = failures
        print(json.dumps(summary, indent=2))
        sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
