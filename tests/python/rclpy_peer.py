"""ROS 2's own client library (rclpy, over Fast DDS) as a peer of `terzaghi node`.

It starts the node with `-p use_sim_time:=true` and checks, as a ROS 2 user's code sees them:
- predicted wrenches for JointStates from a best-effort and from a reliable publisher, against
  `terzaghi predict` for the same angles; `leg_force` (terzaghi_msgs/LegForce, the classes
  colcon generated from msgs/) against the same table;
- F/T generated with known b_k, a: `model_params` (terzaghi_msgs/ModelParams) converging to
  them, and a transient-local subscriber created afterwards receiving the latest estimate;
- the parameter services from rclpy's own client: list, get, describe, a set that is refused
  (a negative width) and one that takes effect;
- `/rosout`: the node's log lines under its logger name, the refused set among them;
- simulated time: `/diagnostics` stamped with the time `/clock` gives (from 1000 s on), and a
  `/clock` that jumps back followed, counted and warned about.
Prints a JSON summary; exits 0 only if every check holds. Run it inside a private network
namespace, with the environment of build_msgs.sh's env.sh.
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import threading
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter_client import AsyncParameterClient
from rclpy.parameter import Parameter

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import Log
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from terzaghi_msgs.msg import LegForce, ModelParams

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
      ft_topic: leg/ft
"""
GEOM = ["--length-m", "0.25", "--width-m", "0.06", "--hip-height-m", "0.15", "--unit-weight-n-m3", "16170",
        "--phi-deg", "32", "--delta-deg", "19"]


def predict_table(binary, flags, spec):
    out = subprocess.run([binary, "predict", *flags, "--beta-deg", spec, "--format", "json"],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def stamp_of(t):
    from builtin_interfaces.msg import Time
    ns = int(round(t * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def secs(st):
    return st.sec + st.nanosec * 1e-9


class Peer(Node):
    def __init__(self):
        super().__init__("rclpy_peer")
        self.lock = threading.Lock()
        self.wrenches, self.forces, self.params, self.logs, self.diags = {}, {}, [], [], []
        reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        best_effort = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.js_best_effort = self.create_publisher(JointState, "/joint_states", best_effort)
        self.js_reliable = self.create_publisher(JointState, "/joint_states", reliable)
        self.ft = self.create_publisher(WrenchStamped, "/leg/ft", reliable)
        self.clock = self.create_publisher(Clock, "/clock", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.create_subscription(WrenchStamped, "/leg/predicted_wrench", self.on_wrench, reliable)
        self.create_subscription(LegForce, "/leg/leg_force", self.on_force, reliable)
        self.create_subscription(ModelParams, "/leg/model_params", self.on_params, reliable)
        # As `ros2 topic echo /rosout` subscribes.
        self.create_subscription(Log, "/rosout", self.on_log, QoSProfile(
            depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.create_subscription(DiagnosticArray, "/diagnostics", self.on_diag, reliable)

    def on_wrench(self, m):
        with self.lock:
            self.wrenches[(m.header.stamp.sec, m.header.stamp.nanosec)] = m

    def on_force(self, m):
        with self.lock:
            self.forces[(m.header.stamp.sec, m.header.stamp.nanosec)] = m

    def on_params(self, m):
        with self.lock:
            self.params.append(m)

    def on_log(self, m):
        with self.lock:
            self.logs.append(m)

    def on_diag(self, m):
        with self.lock:
            self.diags.append((time.monotonic(), m))


def wait_until(pred, timeout_s):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.02)
    return False


def shut_down(executor, spin, peer):
    """Stops spinning and waits for the spin thread before the node and the context go: torn
    down under a spinning executor, rclpy's C++ layer aborts the process ("terminate called
    without an active exception"), which fails the peer after its checks passed."""
    executor.shutdown(timeout_sec=5)
    spin.join(timeout=5)
    peer.destroy_node()
    rclpy.shutdown()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--terzaghi", required=True)
    ap.add_argument("--domain", type=int, default=21)
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

    # Simulated time from 1000 s, 100 Hz, as `ros2 bag play --clock` or a simulator gives it.
    sim = {"t": 1000.0, "run": True}

    def clock_loop():
        while sim["run"]:
            peer.clock.publish(Clock(clock=stamp_of(sim["t"])))
            sim["t"] += 0.01
            time.sleep(0.01)

    clock_thread = threading.Thread(target=clock_loop, daemon=True)
    clock_thread.start()

    d = tempfile.mkdtemp()
    params_file = os.path.join(d, "leg.yaml")
    with open(params_file, "w") as f:
        f.write(PARAMS)
    node = subprocess.Popen([args.terzaghi, "node", "--ros-args", "--params-file", params_file,
                             "-p", "use_sim_time:=true", "-p", "diagnostics_period_s:=0.2"],
                            stderr=subprocess.PIPE, text=True)
    try:
        # The node answers a JointState: discovery is done both ways.
        i = 0

        def answered():
            nonlocal i
            m = JointState(name=["hip"], position=[math.radians(60)])
            m.header.stamp = stamp_of(100.0 + 0.001 * i)
            peer.js_reliable.publish(m)
            i += 1
            with peer.lock:
                return len(peer.wrenches) > 0

        if not wait_until(answered, 20):
            raise SystemExit("the node never answered a joint state (discovery failed)")
        time.sleep(0.3)

        # 1. Predictions for JointStates from a best-effort and from a reliable publisher.
        flags = GEOM + ["--bk", "2.0", "--a", "1.5"]
        table = predict_table(args.terzaghi, flags, "40:140:5")
        for label, pub, t0 in (("best_effort", peer.js_best_effort, 1000.0), ("reliable", peer.js_reliable, 1100.0)):
            for k, row in enumerate(table):
                m = JointState(name=["other", "hip"], position=[0.3, math.radians(row["beta_deg"])])
                m.header.stamp = stamp_of(t0 + 0.01 * k)
                pub.publish(m)
                time.sleep(0.005)
            keys = [(stamp_of(t0 + 0.01 * k).sec, stamp_of(t0 + 0.01 * k).nanosec) for k in range(len(table))]
            wait_until(lambda: all(k in peer.wrenches and k in peer.forces for k in keys), 10)
            worst_w, worst_f, got_w, got_f = 0.0, 0.0, 0, 0
            with peer.lock:
                for k, row in zip(keys, table):
                    w, lf = peer.wrenches.get(k), peer.forces.get(k)
                    if w is not None:
                        got_w += 1
                        for want, have in ((-row["drag_n"], w.wrench.force.x), (row["lift_n"], w.wrench.force.z),
                                           (row["hip_torque_nm"], w.wrench.torque.y)):
                            worst_w = max(worst_w, abs(want - have) / max(1.0, abs(want)))
                    if lf is not None:
                        got_f += 1
                        for want, have in ((row["drag_n"], lf.drag_n), (row["lift_n"], lf.lift_n),
                                           (row["hip_torque_nm"], lf.hip_torque_nm),
                                           (math.radians(row["beta_deg"]), lf.attack_angle_rad)):
                            worst_f = max(worst_f, abs(want - have) / max(1.0, abs(want)))
            check(f"predicted_wrench_{label}", got_w == len(table) and worst_w < 1e-9,
                  {"sent": len(table), "received": got_w, "worst_rel_error": worst_w})
            check(f"leg_force_{label}", got_f == len(table) and worst_f < 1e-9,
                  {"sent": len(table), "received": got_f, "worst_rel_error": worst_f})

        # 2. Parameter services, from rclpy's own client.
        client = AsyncParameterClient(peer, "terzaghi")
        if not client.wait_for_services(timeout_sec=10.0):
            check("parameter_services", False, "the node's parameter services never appeared")
        else:
            def call(fut):
                wait_until(fut.done, 10)
                return fut.result() if fut.done() else None

            listed = call(client.list_parameters())
            names = list(listed.result.names) if listed else []
            check("param_list", "leg.b_k" in names and "use_sim_time" in names, {"count": len(names)})
            got = call(client.get_parameters(["leg.b_k", "use_sim_time"]))
            values = [(v.double_value, v.bool_value) for v in got.values] if got else []
            check("param_get", bool(values) and values[0][0] == 2.0 and values[1][1] is True, values)
            desc = call(client.describe_parameters(["leg.b_k"]))
            check("param_describe", bool(desc) and desc.descriptors[0].name == "leg.b_k",
                  [x.name for x in desc.descriptors] if desc else None)
            bad = call(client.set_parameters([Parameter("leg.width_m", value=-0.5)]))
            bad_result = bad.results[0] if bad else None
            check("param_set_refused", bad_result is not None and not bad_result.successful
                  and "width" in bad_result.reason,
                  {"successful": getattr(bad_result, "successful", None), "reason": getattr(bad_result, "reason", None)})
            ok = call(client.set_parameters([Parameter("leg.b_k", value=2.5)]))
            ok_result = ok.results[0] if ok else None
            check("param_set", ok_result is not None and ok_result.successful, getattr(ok_result, "reason", None))
            # The new b_k takes effect at once.
            table_after = predict_table(args.terzaghi, GEOM + ["--bk", "2.5", "--a", "1.5"], "60:60:1")
            m = JointState(name=["hip"], position=[math.radians(60)])
            m.header.stamp = stamp_of(1200.0)
            peer.js_reliable.publish(m)
            key = (1200, 0)
            wait_until(lambda: key in peer.wrenches, 5)
            w = peer.wrenches.get(key)
            check("param_set_takes_effect", w is not None and abs(w.wrench.force.z - table_after[0]["lift_n"]) < 1e-9,
                  {"lift_n": getattr(getattr(w, "wrench", None), "force", None) and w.wrench.force.z,
                   "expected": table_after[0]["lift_n"]})

        # 3. Identification from F/T generated with known b_k, a.
        truth = predict_table(args.terzaghi, GEOM + ["--bk", "3.0", "--a", "1.8"], "0:360:0.05")
        peak = max(max(abs(r["drag_n"]), abs(r["lift_n"])) for r in truth)
        rng = random.Random(7)
        rate, omega, strokes = 250.0, 4.0, 8
        n = int(strokes * 2 * math.pi / omega * rate)
        start = time.monotonic()
        for k in range(n):
            t = 2000.0 + k / rate
            beta = omega * k / rate
            x = math.degrees(beta % (2 * math.pi)) / 0.05
            j = min(int(x), len(truth) - 2)
            fr = x - j
            drag = truth[j]["drag_n"] * (1 - fr) + truth[j + 1]["drag_n"] * fr + rng.gauss(0, 0.02 * peak)
            lift = truth[j]["lift_n"] * (1 - fr) + truth[j + 1]["lift_n"] * fr + rng.gauss(0, 0.02 * peak)
            js = JointState(name=["hip"], position=[beta])
            js.header.stamp = stamp_of(t)
            peer.js_reliable.publish(js)
            ft = WrenchStamped()
            ft.header.stamp = stamp_of(t)
            ft.header.frame_id = "ft"
            ft.wrench.force.x = -drag
            ft.wrench.force.z = lift
            peer.ft.publish(ft)
            lag = start + (k + 1) / rate - time.monotonic()
            if lag > 0:
                time.sleep(lag)
        time.sleep(1.0)
        with peer.lock:
            last = peer.params[-1] if peer.params else None
        check("model_params_converge",
              last is not None and last.converged and abs(last.b_k / 3.0 - 1) < 0.03 and abs(last.a / 1.8 - 1) < 0.03,
              # Why it did not converge, if it did not: the deviations, the samples taken and
              # refused, and the changes detected (each re-opens the estimate).
              {k: getattr(last, k, None) for k in ("b_k", "a", "converged", "std_b_k", "std_a",
                                                   "samples_used", "samples_rejected",
                                                   "changes_detected", "innovation_rms_n")}
              | {"messages": len(peer.params)})

        # A subscriber that joins late, transient-local, gets the latest estimate at once.
        late = []
        peer.create_subscription(ModelParams, "/leg/model_params", late.append, QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        wait_until(lambda: len(late) > 0, 5)
        # What the late subscriber gets at once holds the latest estimate published before it
        # joined (no F/T flows any more, so nothing new is published): a message the node
        # published, no older than the last one seen. Under load the writer's history may hand
        # an older one first.
        time.sleep(0.3)
        with peer.lock:
            seen = [(secs(m.header.stamp), m.b_k) for m in peer.params]
        got = [(secs(m.header.stamp), m.b_k) for m in late]
        check("model_params_transient_local",
              last is not None and any(g in seen and g[0] >= secs(last.header.stamp) for g in got),
              {"received": len(late), "got": got, "last_before_joining": (secs(last.header.stamp), last.b_k) if last else None})

        # 4. Simulated time: diagnostics stamped with /clock's time.
        def fresh_diagnostics():
            """The stamps (s) and values of the next two /diagnostics or more."""
            with peer.lock:
                peer.diags.clear()
            wait_until(lambda: len(peer.diags) >= 2, 5)
            with peer.lock:
                stamps = [secs(m.header.stamp) for _, m in peer.diags]
                values = {kv.key: kv.value for _, m in peer.diags for st in m.status for kv in st.values}
            return stamps, values

        t_sent = sim["t"]
        stamps, values = fresh_diagnostics()
        check("diagnostics_follow_clock", bool(stamps) and all(abs(s - t_sent) < 5.0 for s in stamps)
              and values.get("clock") == "/clock (use_sim_time)" and values.get("clock_jumps_back") == "0",
              {"clock_s": t_sent, "diagnostics_stamps_s": stamps[:3], "wall_s": time.time(),
               "clock": values.get("clock"), "clock_jumps_back": values.get("clock_jumps_back")})

        # A /clock that jumps back (a log played again from its start): followed and counted.
        sim["t"] = 500.0
        time.sleep(1.0)
        stamps, values = fresh_diagnostics()
        check("clock_jump_back_followed",
              bool(stamps) and all(500.0 <= s < 520.0 for s in stamps) and values.get("clock_jumps_back") == "1",
              {"diagnostics_stamps_s": stamps[:3], "clock_jumps_back": values.get("clock_jumps_back")})

        # 5. /rosout: the node's lines under its logger name.
        time.sleep(0.5)
        with peer.lock:
            mine = [m for m in peer.logs if m.name == "terzaghi"]
        texts = [(m.level, m.msg) for m in mine]
        check("rosout_startup", any(l == Log.INFO and "terzaghi node" in t for l, t in texts), texts[:5])
        check("rosout_refused_param", any(l == Log.WARN and "leg.width_m" in t for l, t in texts), texts[:10])
        check("rosout_param_set", any(l == Log.INFO and "leg.b_k set to 2.5" in t for l, t in texts), texts[:10])
        check("rosout_clock_back", any(l == Log.WARN and "went back" in t for l, t in texts), texts[-5:])
        check("rosout_source", all(m.file.endswith(".rs") and m.line > 0 for m in mine) and bool(mine),
              [(m.file, m.function, m.line) for m in mine[:3]])
        summary["rosout_lines"] = len(mine)
    finally:
        # The clock thread stops publishing before anything is torn down.
        sim["run"] = False
        clock_thread.join(timeout=5)
        node.send_signal(2)
        try:
            _, err = node.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            node.kill()
            _, err = node.communicate()
        summary["node_exit_code"] = node.returncode
        summary["node_stderr_tail"] = err.strip().splitlines()[-5:]
        shut_down(executor, spin, peer)
    if node.returncode != 0:
        failures.append(f"node exit code {node.returncode}")
    summary["failures"] = failures
    print(json.dumps(summary, default=str))
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
