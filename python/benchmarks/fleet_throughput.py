"""Throughput of terzaghi.fleet on a LocalCluster of 1 and of 2 workers, in one run.

Generates the fleet of the tests (3 robots, 20 days, one 20 s walk a day: 60 recordings) with
the `terzaghi` binary, then diagnoses it ROUNDS times with 1 worker and with 2, alternating,
each with a recording's legs on every core (the default) and on one thread per worker, and
prints each round's recordings per second, the medians and their ratios.

    python python/benchmarks/fleet_throughput.py [--bin target/release/terzaghi] [--rounds 3]
"""

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", default=str(HERE.parents[1] / "target" / "release" / "terzaghi"))
    p.add_argument("--rounds", type=int, default=3)
    a = p.parse_args()
    import os

    os.environ["TERZAGHI_BIN"] = a.bin
    import terzaghi.fleet as fleet
    from test_fleet import generate

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        generate(root)
        n = len(fleet.find_recordings(root))
        # Each worker's recording on every core (the default), then on one thread each.
        configs = [(1, None), (2, None), (1, 1), (2, 1)]
        rates = {c: [] for c in configs}
        for r in range(a.rounds):
            for workers, threads in configs:
                t = time.perf_counter()
                df = fleet.diagnose_fleet(root, workers=workers, threads_per_recording=threads)
                dt = time.perf_counter() - t
                assert df["error"].isna().all()
                rates[(workers, threads)].append(n / dt)
                print(f"round {r + 1}, {workers} worker(s), {threads or 'all'} thread(s) per recording: "
                      f"{n} recordings in {dt:.1f} s, {n / dt:.2f} recordings/s")
        for threads in (None, 1):
            m1, m2 = statistics.median(rates[(1, threads)]), statistics.median(rates[(2, threads)])
            print(f"median, {threads or 'all'} thread(s) per recording: 1 worker {m1:.2f}, "
                  f"2 workers {m2:.2f} recordings/s ({m2 / m1:.2f}x)")
        print(f"{n} recordings of 20 s walking, 6 legs each; cluster start included")


if __name__ == "__main__":
    main()
