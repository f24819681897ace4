"""terzaghi.batch for 4,096 environments of 6 legs, one step, against the numpy peer, in one run.

Plate legs (the improved model) and C-legs (RFT, a 96-element half circle, the hip moving):
the median time of a step over many steps each, and the plate's ratio to the numpy peer
(python/benchmarks/numpy_peer.py), which is first checked against ours to 1e-9.

    python python/benchmarks/batch.py
"""

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from numpy_peer import plate_forces  # noqa: E402

from terzaghi.batch import LegBatch  # noqa: E402

MEDIUM = dict(unit_weight_n_m3=13000.0, phi_deg=30.0, delta_deg=20.0)
LEG = dict(length_m=0.1, width_m=0.025)
SHAPE = (4096, 6)


def median_ms(step, n):
    times = []
    for _ in range(n):
        t = time.perf_counter()
        step()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def main():
    rng = np.random.default_rng(1)
    # A stride's angles and a walking body's hips: about half the legs in the sand.
    beta = rng.uniform(0.0, 2 * np.pi, SHAPE)
    hip = rng.uniform(0.0, 0.06, SHAPE)
    pitch = rng.uniform(-0.05, 0.05, SHAPE)
    omega = rng.uniform(2.0, 8.0, SHAPE)
    fwd = rng.uniform(0.0, 0.3, SHAPE)
    up = rng.uniform(-0.05, 0.05, SHAPE)
    out = tuple(np.empty(SHAPE) for _ in range(3))

    plates = LegBatch(**LEG, **MEDIUM, b_k=30.0, a=2.3)
    peer = lambda: plate_forces(beta, hip, **LEG, **MEDIUM, b_k=30.0, a=2.3, pitch_rad=pitch)
    ours = plates.forces(beta, hip, pitch_rad=pitch, out=out)
    for o, p in zip(ours, peer()):
        np.testing.assert_allclose(o, p, rtol=1e-9, atol=1e-9)
    in_sand = np.count_nonzero(out[1]) / out[1].size
    step = lambda: plates.forces(beta, hip, pitch_rad=pitch, out=out)
    for _ in range(20):
        step()
    t_ours = median_ms(step, 500)
    t_peer = median_ms(peer, 100)
    print(f"plate legs, {SHAPE[0]} x {SHAPE[1]} ({100 * in_sand:.0f} % in the sand): "
          f"terzaghi.batch {t_ours:.3f} ms, numpy peer {t_peer:.3f} ms per step "
          f"({t_peer / t_ours:.1f}x); target 1 ms and 10x")

    clegs = LegBatch(**LEG, model="rft", medium="poppy_lp", shape="c_leg", rft_elements=96)
    cstep = lambda: clegs.forces(beta, hip, pitch_rad=pitch, omega_rad_s=omega,
                                 forward_m_s=fwd, up_m_s=up, out=out)
    for _ in range(3):
        cstep()
    t_c = median_ms(cstep, 50)
    in_sand = np.count_nonzero(out[1]) / out[1].size
    print(f"C-legs (RFT, 96 elements), {SHAPE[0]} x {SHAPE[1]} ({100 * in_sand:.0f} % in the sand): "
          f"terzaghi.batch {t_c:.2f} ms per step; target 10 ms")


if __name__ == "__main__":
    main()
