"""A RHex-like hexapod walking on poppy seeds in MuJoCo, its legs feeling terzaghi's forces.

With the improved model of its legs (the default), or with the model a diagnosis corrected
(``--corrected corrected.yaml``, the node's core predicting each leg); optionally recorded to
MCAP in the node's topics (``--record walk.mcap``), which ``terzaghi diagnose`` and ``replay
--reevaluate`` read as they read a robot's recording. The robot's MJCF, with the default legs,
is ``hexapod.xml`` beside this file; ``terzaghi.mujoco.hexapod_xml(width_m=...)`` writes it for
any leg width, and ``walk`` builds the model from it.

    python python/examples/hexapod_walk.py --seconds 10
    python python/examples/hexapod_walk.py --corrected diagnosis/corrected.yaml --width-m 0.04 --record walk.mcap
"""

import argparse
import sys

import mujoco

import terzaghi
import terzaghi.mujoco as tm


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=10.0, help="simulated time (s), default 10")
    p.add_argument("--width-m", type=float, default=0.025, help="the legs' width (m), default 0.025")
    p.add_argument("--corrected", metavar="FILE",
                   help="a corrected.yaml of terzaghi diagnose: the legs feel its corrected model")
    p.add_argument("--record", metavar="OUT.mcap", help="record the walk in the node's topics")
    p.add_argument("--noise-n", type=float, default=0.0, help="the recorded F/T's noise (N), default 0")
    a = p.parse_args(argv)
    if not (a.seconds > 0 and a.width_m > 0):
        p.error("--seconds and --width-m must be > 0")
    params = tm.hexapod_params(width_m=a.width_m)
    node = None
    if a.corrected:
        # The robot's corrected parameters, with this model's joints, hips and F/T frame.
        keep = ("joint", "direction", "angle_offset_rad", "hip_offset_m", "ft_frame")
        over = {k: v for k, v in params.items()
                if k == "robot_state.pose_topic" or k.split(".")[-1] in keep}
        try:
            node = terzaghi.Node(a.corrected, params=over)
        except terzaghi.TerzaghiError as e:
            sys.exit(f"error: {a.corrected}: {e}")
        params = node.params
    recording = None
    if a.record:
        try:
            recording = tm.WalkRecording(a.record, params, noise_n=a.noise_n)
        except (terzaghi.TerzaghiError, ValueError) as e:
            sys.exit(f"error: {e}")
    model, data = tm.walk(a.seconds, node=node, width_m=a.width_m,
                          on_step=None if recording is None else recording.on_step)
    torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")
    x, y, _ = data.xpos[torso]
    how = f"the corrected model of {a.corrected}" if a.corrected else "the improved model"
    print(f"walked {a.seconds:g} s on {how}: {x:.2f} m forward, {y:+.2f} m sideways")
    if recording is not None:
        print(f"{recording.close()} messages written to {a.record}")


if __name__ == "__main__":
    main()
