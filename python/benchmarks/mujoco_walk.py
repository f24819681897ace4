"""Wall time per simulated second of the MuJoCo hexapod (terzaghi.mujoco.walk): with terzaghi's
forces on its six legs from the batch model, from the node's core (terzaghi.Node, as a
corrected.yaml is run), and without (legs turning in the air), alternating, in one run.

    python python/benchmarks/mujoco_walk.py [--rounds 5] [--seconds 10]
"""

import argparse
import statistics
import time

import terzaghi
import terzaghi.mujoco as tm


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--seconds", type=float, default=10.0)
    a = p.parse_args()
    runs = {
        "batch": lambda: tm.walk(a.seconds),
        "node": lambda: tm.walk(a.seconds, node=terzaghi.Node(params=tm.hexapod_params())),
        "none": lambda: tm.walk(a.seconds, coupling=False),
    }
    per = {k: [] for k in runs}
    for _ in range(a.rounds):
        for k, run in runs.items():
            t = time.perf_counter()
            run()
            per[k].append((time.perf_counter() - t) / a.seconds)
    med = {k: statistics.median(v) * 1e3 for k, v in per.items()}
    print(f"wall time per simulated second (2 ms steps, 6 legs), medians of {a.rounds}: "
          f"with the batch coupling {med['batch']:.1f} ms ({med['batch'] / med['none']:.2f}x), "
          f"through the node's core {med['node']:.1f} ms ({med['node'] / med['none']:.2f}x), "
          f"without {med['none']:.1f} ms")


if __name__ == "__main__":
    main()
