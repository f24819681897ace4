"""Many MuJoCo environments of the hexapod walking on sand, one step of all at once: the wall
time per step with terzaghi's forces on every leg (terzaghi.mujoco.BatchCoupling) against the
same step without them, and the coupling's own cost per environment against the LegBatch call
inside it, in one run.

    python python/benchmarks/mujoco_envs.py --envs 4096 --threads 2

Each round times, alternating: the step without forces, the step with them, the coupling's
one call (apply: reading the legs, the leg model's kernel and writing the wrenches, a chunk of
environments at a time), and, alone, the LegBatch call on the same legs (with each
environment's medium, and with one medium for all). Medians over the rounds.
"""

import argparse
import math
import os
import statistics
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--envs", type=int, default=4096, help="environments (default 4096)")
    ap.add_argument("--threads", type=int, default=os.cpu_count(),
                    help="threads for MuJoCo and terzaghi (default: every core)")
    ap.add_argument("--rounds", type=int, default=7, help="alternating rounds (default 7)")
    ap.add_argument("--steps", type=int, default=20, help="steps per round and contestant")
    args = ap.parse_args()
    if args.envs < 1 or args.threads < 1 or args.rounds < 1 or args.steps < 1:
        ap.error("--envs, --threads, --rounds and --steps must each be at least 1")
    os.environ["RAYON_NUM_THREADS"] = str(args.threads)
    import mujoco
    import numpy as np

    import terzaghi.mujoco as tm
    from terzaghi.batch import LegBatch

    model = mujoco.MjModel.from_xml_string(tm.hexapod_xml())
    legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
    rng = np.random.default_rng(1)

    def walking(n):
        """Environments already walking: each its own 0.4 s of the tripod gait (so legs are
        in the sand, in the air, and coming out of it, as in training)."""
        c = tm.BatchCoupling(model, tm.hexapod_legs(), legs, n_envs=n, torso="torso",
                             threads=args.threads)
        for i, leg in enumerate(tm.hexapod_legs()):
            c.state[:, 8 + i] = (0.8 if leg.name in tm.TRIPOD_A else 0.8 + math.pi) + rng.uniform(-0.3, 0.3, n)
        c.set_media(rng.uniform(24.0, 40.0, n), rng.uniform(2.0, 2.6, n))
        c.ctrl[:] = rng.uniform(3.0, 5.0, (n, model.nu))
        for _ in range(200):
            c.step()
        return c

    c = walking(args.envs)
    in_sand = float((c.lift_n != 0).mean())
    x = c._in

    def step_with():
        c.step(coupled=True)

    def step_without():
        c.step(coupled=False)

    def legbatch():
        legs.forces(x["beta"], x["h"], pitch_rad=x["pitch"], omega_rad_s=x["omega"],
                    forward_m_s=x["fwd"], up_m_s=x["up"], b_k=c._media[0], a=c._media[1],
                    out=(c.drag_n, c.lift_n, c.hip_torque_nm))

    def legbatch_one_medium():
        legs.forces(x["beta"], x["h"], pitch_rad=x["pitch"], omega_rad_s=x["omega"],
                    forward_m_s=x["fwd"], up_m_s=x["up"], out=(c.drag_n, c.lift_n, c.hip_torque_nm))

    def coupling():
        c.apply()

    contestants = {"step without forces": step_without, "step with terzaghi": step_with,
                   "coupling (apply)": coupling, "  LegBatch.forces alone": legbatch,
                   "  the same, one medium": legbatch_one_medium}
    times = {k: [] for k in contestants}
    for _ in range(args.rounds):
        for name, fn in contestants.items():
            fn()
            t0 = time.perf_counter()
            for _ in range(args.steps):
                fn()
            times[name].append((time.perf_counter() - t0) / args.steps * 1e3)
    med = {k: statistics.median(v) for k, v in times.items()}
    load = os.getloadavg()
    print(f"{args.envs} environments x 6 legs, {args.threads} thread(s), medians of "
          f"{args.rounds} rounds of {args.steps} steps; {100 * in_sand:.0f}% of legs in the sand; "
          f"load {load[0]:.2f}")
    print(f"{'':26s} {'ms per step':>12s} {'us per env':>11s}")
    for k, v in med.items():
        print(f"{k:26s} {v:12.3f} {1e3 * v / args.envs:11.3f}")
    lb = med["  LegBatch.forces alone"]
    over = med["coupling (apply)"] - lb
    print(f"the coupling's cost beside LegBatch: {over:.3f} ms, {over / lb:.2f}x the LegBatch call")
    print(f"the coupling in all: {med['coupling (apply)'] / lb:.2f}x the "
          f"LegBatch call; the step with it {med['step with terzaghi'] / med['step without forces']:.2f}x "
          "the step without")
    c.close()


if __name__ == "__main__":
    main()
