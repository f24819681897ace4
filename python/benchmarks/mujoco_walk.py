"""Wall time per simulated second of the MuJoCo hexapod (terzaghi.mujoco.walk), with terzaghi's
forces on its six legs and without (legs turning in the air), alternating, in one run.

    python python/benchmarks/mujoco_walk.py [--rounds 5] [--seconds 10]
"""

import argparse
import statistics
import time

import terzaghi.mujoco as tm


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--seconds", type=float, default=10.0)
    a = p.parse_args()
    per = {True: [], False: []}
    for r in range(a.rounds):
        for coupled in (True, False):
            t = time.perf_counter()
            tm.walk(a.seconds, coupling=coupled)
            per[coupled].append((time.perf_counter() - t) / a.seconds)
    on, off = statistics.median(per[True]), statistics.median(per[False])
    print(f"wall time per simulated second (2 ms steps, 6 legs), medians of {a.rounds}: "
          f"with the coupling {on * 1e3:.1f} ms, without {off * 1e3:.1f} ms ({on / off:.2f}x)")


if __name__ == "__main__":
    main()
