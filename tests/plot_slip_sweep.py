#!/usr/bin/env python3
"""The shared slip sweep's drawbar and sinkage against slip, measured and predicted by
`terzaghi steady` in three media (the plate runs alone, the physics alone, the sweep's two
coefficients): docs/bodies_slip_sweep.png. Needs matplotlib and a built terzaghi
(target/release/terzaghi, or TERZAGHI=path).

    python3 tests/plot_slip_sweep.py
"""
import csv
import os
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.environ.get("TERZAGHI", os.path.join(ROOT, "target", "release", "terzaghi"))
RUNS = "tests/data/real-wheel/slip_sweep_runs.csv"
MEDIA = [
    ("plate runs alone (RFT at rest)", "tests/data/medium_without_shape.yaml", "tab:gray"),
    ("physics alone (tan 2/3 phi, m 2)", "tests/data/medium_sheared_physics.yaml", "tab:blue"),
    ("the sweep's two coefficients", "tests/data/medium_slip_sweep.yaml", "tab:red"),
]


def steady(medium, out):
    subprocess.run(
        [EXE, "steady", RUNS, "--shape", "wheel", "--radius-m", "0.058", "--width-m", "0.05",
         "--medium-file", medium, "-o", out],
        cwd=ROOT, check=True, stderr=subprocess.DEVNULL)
    with open(out) as f:
        return list(csv.DictReader(f))


def main():
    fig, (ax_d, ax_s) = plt.subplots(1, 2, figsize=(10, 4))
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, medium, colour) in enumerate(MEDIA):
            rows = sorted(steady(medium, os.path.join(tmp, "s.csv")), key=lambda r: float(r["slip"]))
            slip = [float(r["slip"]) for r in rows]
            if k == 0:
                ax_d.scatter(slip, [float(r["measured_drawbar_n"]) for r in rows], c="k",
                             label="measured (27 runs)", zorder=3)
                ax_s.scatter(slip, [1e3 * float(r["measured_sinkage_m"]) for r in rows], c="k",
                             label="measured (27 runs)", zorder=3)
            ax_d.plot(slip, [float(r["drawbar_n"]) for r in rows], "o", mfc="none", c=colour, label=label)
            ax_s.plot(slip, [1e3 * float(r["sinkage_m"]) for r in rows], "o", mfc="none", c=colour, label=label)
    ax_d.set(xlabel="slip (-1 locked, 0 free, 0.9 spinning)", ylabel="drawbar pull (N)")
    ax_s.set(xlabel="slip (-1 locked, 0 free, 0.9 spinning)", ylabel="sinkage (mm)")
    ax_s.legend(fontsize=8)
    fig.suptitle("The real wheel's slip sweep (r 58 mm, b 50 mm, 18-26 N) in the plate runs' sand")
    fig.tight_layout()
    out = os.path.join(ROOT, "docs", "bodies_slip_sweep.png")
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    sys.exit(main())
