"""terzaghi.mujoco in real MuJoCo: one leg through a stroke against terzaghi predict, the wrench's
point of application, and the hexapod walking on the model's forces."""

import json
import math

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import terzaghi  # noqa: E402
import terzaghi.mujoco as tm  # noqa: E402
from terzaghi.batch import LegBatch  # noqa: E402

from test_api import run  # noqa: E402

LEG = dict(length_m=0.1, width_m=0.025, medium="poppy_lp")
HIP_M = 0.03

ONE_LEG = f"""
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="hip" pos="0 0 {HIP_M}">
      <body name="leg">
        <joint name="leg_joint" type="hinge" axis="0 1 0"/>
        <geom type="box" pos="0.05 0 0" size="0.05 0.0125 0.004" mass="0.1" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_one_leg_through_a_stroke_feels_what_terzaghi_predict_gives():
    model = mujoco.MjModel.from_xml_string(ONE_LEG)
    data = mujoco.MjData(model)
    c = tm.Coupling(model, [tm.LegMap("leg", "leg_joint", "leg")], LegBatch(**LEG), torso="hip")
    leg = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "leg")
    beta, got, qfrc_hinge = [], [], []
    qfrc = np.zeros(model.nv)
    # Driven through the stroke at 2 rad/s: the joint's angle and rate set, the kinematics
    # computed by MuJoCo, every 2 ms.
    for k in range(int(math.pi / (2.0 * 0.002)) + 1):
        data.qpos[0] = 2.0 * 0.002 * k
        data.qvel[0] = 2.0
        mujoco.mj_forward(model, data)
        c.apply(data)
        beta.append(data.qpos[0])
        got.append((c.drag_n[0], c.lift_n[0], c.hip_torque_nm[0]))
        # The wrench written at the body's centre of mass, as MuJoCo maps it onto the hinge.
        qfrc[:] = 0
        mujoco.mj_applyFT(model, data, data.xfrc_applied[leg, :3].copy(),
                          data.xfrc_applied[leg, 3:].copy(), data.xipos[leg].copy(), leg, qfrc)
        qfrc_hinge.append(qfrc[0])
        # The force is the drag forward (+x here) and the lift up.
        np.testing.assert_allclose(data.xfrc_applied[leg, :3], [c.drag_n[0], 0.0, c.lift_n[0]],
                                   atol=1e-12)
    beta = np.array(beta)
    got = np.array(got)
    assert len(beta) > 500 and np.count_nonzero(got[:, 1]) > 100
    want = terzaghi.predict(beta, hip_height_m=HIP_M, **LEG)
    np.testing.assert_allclose(got[:, 0], want["drag_n"], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(got[:, 1], want["lift_n"], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(got[:, 2], want["hip_torque_nm"], rtol=1e-6, atol=1e-6)
    # About the hinge, the wrench is the model's torque, resisting the turn.
    np.testing.assert_allclose(qfrc_hinge, -got[:, 2], rtol=1e-9, atol=1e-9)
    # And the binary's own predict, at a few of the stroke's angles.
    for i in np.linspace(0, len(beta) - 1, 7).astype(int):
        deg = math.degrees(beta[i])
        (row,) = json.loads(run("predict", "--length-m", "0.1", "--width-m", "0.025", "--hip-height-m",
                                HIP_M, "--medium", "poppy_lp", "--beta-deg", repr(deg), "--format", "json"))
        assert abs(row["drag_n"] - got[i, 0]) <= 1e-6 * max(1.0, abs(row["drag_n"]))
        assert abs(row["lift_n"] - got[i, 1]) <= 1e-6 * max(1.0, abs(row["lift_n"]))


def test_the_hexapod_walks_ten_seconds_on_the_models_forces():
    lifts, heights = [], []

    def watch(model, data, c):
        assert np.all(np.isfinite(data.xfrc_applied)) and np.all(np.isfinite(data.qpos))
        lifts.append(c.lift_n.sum())
        heights.append(data.qpos[2])

    model, data = tm.walk(10.0, on_step=watch)
    assert data.time == pytest.approx(10.0, abs=1e-9)
    assert len(lifts) == 5000
    # It moves forward on the sand's drag, and the sand lifts it off the floor at times.
    assert data.qpos[0] > 0.3, data.qpos[0]
    assert max(lifts) > 50.0 and max(heights) > 0.04
    # Without the coupling the legs turn in the air: it stays where it lies.
    _, still = tm.walk(2.0, coupling=False)
    assert abs(still.qpos[0]) < 0.01


def test_a_bad_map_is_refused_by_name():
    model = mujoco.MjModel.from_xml_string(ONE_LEG)
    with pytest.raises(ValueError, match="no joint 'knee'"):
        tm.Coupling(model, [tm.LegMap("leg", "knee", "leg")], LegBatch(**LEG), torso="hip")
    with pytest.raises(ValueError, match="does not move body 'hip'"):
        tm.Coupling(model, [tm.LegMap("leg", "leg_joint", "hip")], LegBatch(**LEG), torso="hip")
    with pytest.raises(ValueError, match="torso 'body'"):
        tm.Coupling(model, [tm.LegMap("leg", "leg_joint", "leg")], LegBatch(**LEG), torso="body")


def test_the_walk_recorded_in_the_nodes_topics_is_read_by_the_binary(tmp_path):
    path = tmp_path / "walk.mcap"
    recording = tm.WalkRecording(path, tm.hexapod_params())
    tm.walk(10.0, on_step=recording.on_step)
    assert recording.close() == 5000 * (1 + 6 + 1)
    info = run("info", path)
    assert "complete:  yes" in info and "/body_pose" in info
    # The node's own code, re-evaluating the recording, predicts what MuJoCo applied: the
    # hips placed from /body_pose as the coupling placed them.
    rows = terzaghi.session_rows(path, params={"use_identified": False})
    assert sorted(rows) == sorted(tm.HEXAPOD_HIPS)
    for leg, r in rows.items():
        m = ~np.isnan(r["measured_lift_n"])
        assert m.sum() > 4000
        err = np.abs(r["predicted_lift_n"][m] - r["measured_lift_n"][m])
        assert np.max(err) < 1e-6 * max(1.0, np.max(np.abs(r["measured_lift_n"][m]))), (leg, np.max(err))
    # And terzaghi diagnose reads it with no conversion: six legs, the model as simulated (its
    # F/T with a real sensor's noise, 0.1 N).
    noisy = tmp_path / "noisy.mcap"
    recording = tm.WalkRecording(noisy, tm.hexapod_params(), noise_n=0.1)
    tm.walk(10.0, on_step=recording.on_step)
    recording.close()
    reports = json.loads(run("diagnose", noisy, "--out", tmp_path / "diagnosis", "--json"))
    assert sorted(r["leg"] for r in reports) == sorted(tm.HEXAPOD_HIPS)
    simulated = terzaghi.fit(*_stroke_forces(), **LEG, hip_height_m=0.0)
    for r in reports:
        # Every sample's hip placed from the recorded pose; the medium as simulated; the
        # model's error on held-out strokes at the sensor's noise (0.1 N, within 5 %); no effect
        # named where the forces are the model's own.
        assert r["hip_placed_points"] == r["samples"] == 5000, r["leg"]
        assert r["baseline"]["b_k"] == pytest.approx(simulated["b_k"], rel=0.005), r["leg"]
        assert r["baseline"]["a"] == pytest.approx(simulated["a"], rel=0.005), r["leg"]
        noise = max(r["noise"]["drag_n"], r["noise"]["lift_n"])
        assert r["baseline"]["rmse_n"] < 1.05 * noise, (r["leg"], r["baseline"], r["noise"])
        assert r["verdict"]["effect"] == "none", (r["leg"], r["verdict"])
    # The walk recorded without noise (what `hexapod_walk.py --record` writes): thousandths of a
    # newton of misfit are no finding. Every leg: none, no gap to explain.
    clean = json.loads(run("diagnose", path, "--out", tmp_path / "clean", "--json"))
    assert len(clean) == 6
    for r in clean:
        assert r["verdict"]["effect"] == "none", (r["leg"], r["verdict"])
        assert r["verdict"]["claim"].startswith("no gap to explain"), (r["leg"], r["verdict"])
        assert r["gap"]["below_resolution"] and not r["steps"], (r["leg"], r["gap"])


def _stroke_forces():
    """The leg model's own forces over a stroke: its b_k and a, as the batch fit finds them."""
    beta = np.radians(np.arange(1.0, 90.0, 0.5))
    f = terzaghi.predict(beta, hip_height_m=0.0, **LEG)
    return beta, f["drag_n"], f["lift_n"]


def _corrected_yaml(tmp_path):
    """A robot's corrected.yaml: the shipped six-legged robot (legs 0.1 x 0.04 m) walking on a
    medium with a surcharge the model leaves out, diagnosed."""
    robot = tmp_path / "robot.mcap"
    run("simulate-robot", "--seconds", "20", "--hidden", "surcharge", "--magnitude", "1",
        "-o", robot)
    reports = terzaghi.diagnose(robot, tmp_path / "diagnosis")
    assert all(r["verdict"]["effect"] == "surcharge" for r in reports), [r["verdict"] for r in reports]
    return tmp_path / "diagnosis" / "corrected.yaml"


def _hexapod_over(params_file_legs):
    """What the MuJoCo hexapod changes of a robot's parameters: its joints, its hips placed in
    the torso whose pose /body_pose carries, its F/T in the hip frame."""
    p = tm.hexapod_params(width_m=0.04)
    keep = {"robot_state.pose_topic"}
    for leg in params_file_legs:
        keep |= {f"{leg}.{k}" for k in ("joint", "direction", "angle_offset_rad", "hip_offset_m", "ft_frame")}
    return {k: v for k, v in p.items() if k in keep}


def test_a_node_couples_as_the_leg_model_does():
    # The node's core with the hexapod's parameters gives each step the forces the batch model
    # gives for the state the coupling read: its hips placed from the torso's pose.
    node = terzaghi.Node(params=tm.hexapod_params())
    batch = LegBatch(**LEG)
    out = tuple(np.empty(6) for _ in range(3))
    worst = [0.0, 0]

    def check(model, data, c):
        x = c._in
        batch.forces(x["beta"], x["h"], pitch_rad=x["pitch"], out=out)
        worst[0] = max(worst[0], float(np.max(np.abs(c.lift_n - out[1]))), float(np.max(np.abs(c.drag_n - out[0]))))
        worst[1] += int(np.count_nonzero(out[1]))

    tm.walk(2.0, node=node, on_step=check)
    assert worst[1] > 1000
    assert worst[0] < 1e-6, worst


def test_the_hexapod_walks_again_with_a_corrected_yaml(tmp_path):
    corrected = _corrected_yaml(tmp_path)
    node = terzaghi.Node(corrected, params=_hexapod_over(tm.HEXAPOD_HIPS))
    assert sorted(node.legs) == sorted(tm.HEXAPOD_HIPS)
    path = tmp_path / "corrected_walk.mcap"
    recording = tm.WalkRecording(path, node.params)
    heights = []

    def step(model, data, c):
        recording.on_step(model, data, c)
        heights.append(data.qpos[2])

    model, data = tm.walk(10.0, node=node, width_m=0.04, on_step=step)
    recording.close()
    # It walks on the corrected model's forces: forward, lifted off the floor at times.
    assert data.qpos[0] > 0.3 and max(heights) > 0.04, (data.qpos[:3], max(heights))
    # The recording replayed through the node's own code, with the parameters recorded (the
    # corrections among them): it predicts what the legs felt, to 1e-6, and the surcharge is
    # part of it.
    rows = terzaghi.session_rows(path, params={"use_identified": False})
    assert sorted(rows) == sorted(tm.HEXAPOD_HIPS)
    for leg, r in rows.items():
        m = ~np.isnan(r["measured_lift_n"])
        assert m.sum() > 4000
        err = np.abs(r["predicted_lift_n"][m] - r["measured_lift_n"][m])
        assert np.max(err) < 1e-6 * max(1.0, np.max(np.abs(r["measured_lift_n"][m]))), (leg, np.max(err))
        # The surcharge adds lift where the leg is in the sand: the bare model's is less.
        loaded = m & (r["measured_lift_n"] > 1.0)
        assert np.mean(r["predicted_lift_n"][loaded] - r["bare_lift_n"][loaded]) > 0.05, leg


def test_each_leg_feels_its_own_shape():
    # The front legs are RHex's C-legs (RFT), the others flat plates (the improved model):
    # every step, each leg's force is its own model's for the state the coupling read.
    plates = LegBatch(**LEG)
    clegs = LegBatch(**LEG, model="rft", shape="c_leg", rft_elements=96)
    legs = [tm.LegMap(m.name, m.joint, m.body, clegs if m.name.startswith("front") else None)
            for m in tm.hexapod_legs()]
    front = np.array([m.name.startswith("front") for m in legs])
    worst, loaded = [0.0], [0, 0]

    def check(model, data, c):
        x = c._in
        for batch, which in ((plates, ~front), (clegs, front)):
            d, l, t = batch.forces(x["beta"][which], x["h"][which], pitch_rad=x["pitch"][which],
                                   omega_rad_s=x["omega"][which], forward_m_s=x["fwd"][which],
                                   up_m_s=x["up"][which])
            worst[0] = max(worst[0], float(np.max(np.abs(c.lift_n[which] - l))),
                           float(np.max(np.abs(c.hip_torque_nm[which] - t))))
        loaded[0] += int(np.count_nonzero(c.lift_n[front]))
        loaded[1] += int(np.count_nonzero(c.lift_n[~front]))

    tm.walk(2.0, leg_model=plates, legs=legs, on_step=check)
    assert min(loaded) > 200, loaded
    assert worst[0] < 1e-9, worst
    with pytest.raises(ValueError, match="no leg model"):
        tm.Coupling(mujoco.MjModel.from_xml_string(tm.hexapod_xml()),
                    [tm.LegMap("front_left", "front_left_joint", "front_left")], torso="torso")


def test_the_example_runs_and_its_mjcf_is_the_hexapods(tmp_path):
    import runpy
    import sys
    from pathlib import Path

    examples = Path(__file__).resolve().parents[1] / "examples"
    assert (examples / "hexapod.xml").read_text() == tm.hexapod_xml()
    out = tmp_path / "walk.mcap"
    argv = sys.argv
    try:
        sys.argv = ["hexapod_walk.py", "--seconds", "1", "--record", str(out)]
        runpy.run_path(str(examples / "hexapod_walk.py"), run_name="__main__")
    finally:
        sys.argv = argv
    tables = terzaghi.read_topics(out)
    assert len(tables["/joint_states"]["stamp_s"]) == 500
    assert len(tables["/body_pose"]["z_m"]) == 500


# ---------------------------------------------------------------- many environments at once

def _each_env_against_one(model, legs, leg_model, n, seed):
    """A ``BatchCoupling`` of ``n`` random states (``_random_states``), applied; then, for each
    environment ``e``, one ``Coupling`` applied to the same state: yields ``(e, batch, one, data,
    xfrc, bodies)``, ``xfrc`` the batch's applied forces per environment and body, ``bodies`` the
    legs' body ids."""
    batch = tm.BatchCoupling(model, legs, leg_model, n_envs=n, torso="torso", threads=2)
    batch.state[:] = _random_states(model, n, seed)
    batch.apply()
    one = tm.Coupling(model, legs, leg_model, torso="torso")
    data = mujoco.MjData(model)
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, leg.body) for leg in legs]
    xfrc = batch.control[:, model.nu:].reshape(n, model.nbody, 6)
    for e in range(n):
        mujoco.mj_setState(model, data, batch.state[e], mujoco.mjtState.mjSTATE_FULLPHYSICS)
        mujoco.mj_forward(model, data)
        one.apply(data)
        yield e, batch, one, data, xfrc, bodies


def _random_states(model, n, seed):
    """``n`` states of the hexapod, each tilted, turning and moving its own way, as
    ``mjSTATE_FULLPHYSICS`` rows."""
    rng = np.random.default_rng(seed)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    data = mujoco.MjData(model)
    rows = []
    for _ in range(n):
        mujoco.mj_resetData(model, data)
        q = rng.normal(size=4)
        data.qpos[:3] = [rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.0, 0.1)]
        data.qpos[3:7] = q / np.linalg.norm(q) if rng.uniform() < 0.5 else [1, 0, 0, 0]
        data.qpos[7:] = rng.uniform(-4, 8, model.nq - 7)
        data.qvel[:] = rng.normal(0.0, 0.5, model.nv)
        data.qvel[6:] = rng.uniform(-6, 8, model.nv - 6)
        row = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, row, spec)
        rows.append(row)
    return np.array(rows)


def test_a_batch_of_environments_feels_what_one_coupling_gives_each():
    model = mujoco.MjModel.from_xml_string(tm.hexapod_xml())
    legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
    n = 64
    in_sand = 0
    for e, batch, one, data, xfrc, bodies in _each_env_against_one(model, tm.hexapod_legs(),
                                                                   legs, n, seed=3):
        scale = max(1.0, np.abs(one.drag_n).max(), np.abs(one.lift_n).max())
        for got, want in ((batch.drag_n[e], one.drag_n), (batch.lift_n[e], one.lift_n),
                          (batch.hip_torque_nm[e], one.hip_torque_nm)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(xfrc[e, bodies], data.xfrc_applied[bodies], rtol=0, atol=1e-12 * scale)
        in_sand += int((np.abs(one.lift_n) > 0).sum())
    # The states put a good share of the legs in the sand.
    assert in_sand > n, in_sand


def test_a_batch_of_environments_steps_as_each_would_alone():
    model = mujoco.MjModel.from_xml_string(tm.hexapod_xml())
    legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
    n, steps = 4, 600
    batch = tm.BatchCoupling(model, tm.hexapod_legs(), legs, n_envs=n, torso="torso", threads=2)
    start = batch.state.copy()
    for e in range(n):
        start[e, 8:14] = 0.8 + (e % 2) * np.pi  # the legs' angles (after time and the free joint)
    batch.state[:] = start
    act = np.arange(model.nu)
    speeds = np.array([[4.0 + e, 3.0, 5.0, 4.0, 6.0 - e, 4.0] for e in range(n)])
    for _ in range(steps):
        batch.ctrl[:] = speeds
        batch.step()
    # Each environment on its own: one MjData, the one-robot coupling, mj_step.
    one = tm.Coupling(model, tm.hexapod_legs(), legs, torso="torso")
    for e in range(n):
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, start[e], mujoco.mjtState.mjSTATE_FULLPHYSICS)
        mujoco.mj_forward(model, data)
        for _ in range(steps):
            data.ctrl[act] = speeds[e]
            one.apply(data)
            mujoco.mj_step(model, data)
        np.testing.assert_allclose(batch.state[e, 1:1 + model.nq], data.qpos, atol=1e-6)
        # The robot walked: its torso moved forward on the sand's forces.
        assert data.qpos[0] - start[e, 1] > 0.005, data.qpos[0]
    # A step without the coupling applies no force, not the last step's.
    before = batch.state.copy()
    batch.step(coupled=False)
    for e in range(n):
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, before[e], mujoco.mjtState.mjSTATE_FULLPHYSICS)
        data.ctrl[act] = speeds[e]
        mujoco.mj_step(model, data)
        np.testing.assert_allclose(batch.state[e, 1:1 + model.nq], data.qpos, atol=1e-9)


def test_a_medium_per_environment_changes_only_its_own_legs():
    model = mujoco.MjModel.from_xml_string(tm.hexapod_xml())
    legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
    n = 8
    batch = tm.BatchCoupling(model, tm.hexapod_legs(), legs, n_envs=n, torso="torso", threads=1)
    batch.state[:] = _random_states(model, 1, 5)[0]
    b_k = np.linspace(0.5, 2.0, n)
    a = np.linspace(1.05, 1.6, n)
    batch.set_media(b_k, a)
    batch.apply()
    x = batch._in
    for e in range(n):
        own = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp", b_k=b_k[e], a=a[e])
        d, l, t = own.forces(x["beta"][e], x["h"][e], pitch_rad=x["pitch"][e],
                             omega_rad_s=x["omega"][e], forward_m_s=x["fwd"][e], up_m_s=x["up"][e])
        np.testing.assert_allclose(batch.lift_n[e], l, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(batch.drag_n[e], d, rtol=1e-12, atol=1e-12)
    assert len({round(float(v), 9) for v in batch.lift_n.sum(axis=1)}) == n
    with pytest.raises(ValueError, match=r"b_k has shape \(3,\), the environments \(8,\)"):
        batch.set_media(np.ones(3))
    # A value that is no medium is refused when it is set, naming its environment, and the
    # media are left as they were.
    for bad, what in ((np.nan, "nan"), (-1.0, "-1.0"), (0.0, "0.0")):
        wrong = a.copy()
        wrong[5] = bad
        with pytest.raises(ValueError, match=rf"^a\[5\] = {what}: a positive number"):
            batch.set_media(b_k, wrong)
    np.testing.assert_array_equal(batch.a, a)
    # A leg model without a fitting width refuses media when they are set.
    rft = tm.BatchCoupling(model, tm.hexapod_legs(), LegBatch(length_m=0.1, width_m=0.025,
                                                              model="rft", medium="poppy_lp"),
                           n_envs=n, torso="torso", threads=1)
    with pytest.raises(ValueError, match="b_k: a fitting width per environment is the improved"):
        rft.set_media(b_k, a)


def test_a_model_the_batch_cannot_couple_is_refused_by_name():
    legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
    model = mujoco.MjModel.from_xml_string(ONE_LEG)
    with pytest.raises(ValueError, match="torso 'hip': needs one joint, a free joint"):
        tm.BatchCoupling(model, [tm.LegMap("leg", "leg_joint", "leg")], legs, n_envs=2, torso="hip")
    tilted = tm.hexapod_xml().replace('<joint name="front_left_joint" type="hinge" axis="0 1 0"',
                                      '<joint name="front_left_joint" type="hinge" axis="1 0 0"')
    model = mujoco.MjModel.from_xml_string(tilted)
    with pytest.raises(ValueError, match=r"leg front_left: its hinge must turn about the torso's \+y"):
        tm.BatchCoupling(model, tm.hexapod_legs(), legs, n_envs=2, torso="torso")
    model = mujoco.MjModel.from_xml_string(tm.hexapod_xml())
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="n_envs"):
            tm.BatchCoupling(model, tm.hexapod_legs(), legs, n_envs=bad, torso="torso")
    # A leg that names a model of its own would be evaluated as leg_model: refused.
    own = [tm.LegMap(m.name, m.joint, m.body,
                     LegBatch(length_m=0.1, width_m=0.025, model="rft", medium="poppy_lp",
                              shape="c_leg") if m.name == "middle_left" else None)
           for m in tm.hexapod_legs()]
    with pytest.raises(ValueError, match="leg middle_left: names its own leg model"):
        tm.BatchCoupling(model, own, legs, n_envs=2, torso="torso")


def test_the_vectorised_environment_walks_each_copy_on_its_own_medium():
    gymnasium = pytest.importorskip("gymnasium")
    from terzaghi.envs import HexapodSandVecEnv

    env = HexapodSandVecEnv(num_envs=8, max_steps=60, threads=2)
    assert isinstance(env, gymnasium.vector.VectorEnv)
    obs, info = env.reset(seed=0)
    assert obs.shape == (8, 29) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    assert ((info["b_k"] >= 24.0) & (info["b_k"] <= 40.0)).all() and len(set(info["b_k"])) == 8
    first_media = info["b_k"].copy()
    rewards = []
    for k in range(60):
        obs, reward, terminated, truncated, info = env.step(np.full((8, 6), 4.0))
        assert reward.shape == (8,) and np.isfinite(reward).all()
        assert not terminated.any()
        if k < 59:
            assert not truncated.any()
            rewards.append(reward)
    # Every copy walks forward on the sand's forces, each at its own pace (its own medium).
    speed = np.mean(rewards[20:], axis=0)
    assert (speed > 0.0).all(), speed
    assert len({round(float(v), 6) for v in speed}) == 8
    # The last step truncated every episode and began the next on newly drawn media.
    assert truncated.all() and info["_final_obs"].all()
    assert info["final_obs"].shape == (8, 29)
    assert (info["b_k"] != first_media).all()
    np.testing.assert_array_equal(info["final_info"]["b_k"], first_media)
    np.testing.assert_allclose(obs[:, 0], 0.09, atol=1e-9)  # back at the start
    with pytest.raises(ValueError, match=r"actions has shape \(6,\), expected \(8, 6\)"):
        env.step(np.zeros(6))
    with pytest.raises(ValueError, match=r"actions\[2, 3\] = nan"):
        bad = np.zeros((8, 6))
        bad[2, 3] = np.nan
        env.step(bad)
    env.close()


def _wheels_on_a_torso(wheels) -> str:
    """A 2 kg torso on a free joint, its origin 35 mm up, with the real wheel (radius 58 mm,
    width 50 mm, colliding with nothing) hinged about its +y at each of ``wheels``' places:
    ``{name: (x, y)}`` in the torso (m)."""
    bodies = "".join(
        f"""
      <body name="{name}" pos="{x} {y} 0">
        <joint name="{name}_joint" type="hinge" axis="0 1 0"/>
        <geom type="cylinder" size="0.058 0.025" zaxis="0 1 0" mass="0.3" contype="0" conaffinity="0"/>
      </body>""" for name, (x, y) in wheels.items())
    return f"""
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="torso" pos="0 0 0.035">
      <freejoint name="root"/>
      <geom type="box" size="0.1 0.05 0.01" mass="2" contype="0" conaffinity="0"/>{bodies}
    </body>
  </worldbody>
</mujoco>
"""


WHEEL_ON_A_TORSO = _wheels_on_a_torso({"wheel": (0.0, 0.0)})


def test_a_wheel_moving_sideways_feels_its_whole_wrench_in_the_world():
    from pathlib import Path

    medium = Path(__file__).resolve().parents[2] / "tests" / "data" / "medium_without_shape.yaml"
    wheel = dict(model="rft", shape="wheel", radius_m=0.058, width_m=0.05, medium_file=medium)
    model = mujoco.MjModel.from_xml_string(WHEEL_ON_A_TORSO)
    data = mujoco.MjData(model)
    c = tm.Coupling(model, [tm.LegMap("wheel", "wheel_joint", "wheel")], LegBatch(**wheel),
                    torso="torso")
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "wheel")
    # The torso headed 30 degrees left of the world's x; the hub moving 10 mm/s along the
    # heading and 5 mm/s to its left, the wheel rolling at 0.345 rad/s, turned 0.2 rad.
    yaw = math.radians(30.0)
    fwd = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    left = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    data.qpos[3:7] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    data.qvel[0:3] = 0.01 * fwd + 0.005 * left
    data.qpos[7], data.qvel[6] = 0.2, 0.345
    mujoco.mj_forward(model, data)
    c.apply(data)
    want = terzaghi.predict(0.2, hip_height_m=0.035, forward_m_s=0.01, lateral_m_s=0.005,
                            omega_rad_s=0.345, **wheel)
    got = dict(drag_n=c.drag_n[0], lift_n=c.lift_n[0], hip_torque_nm=c.hip_torque_nm[0],
               side_n=c.side_n[0], roll_moment_nm=c.roll_moment_nm[0],
               yaw_moment_nm=c.yaw_moment_nm[0])
    for k, v in got.items():
        assert abs(v - float(want[k])) <= 1e-9 * max(1.0, abs(float(want[k]))), (k, v, want[k])
    assert got["lift_n"] > 5 and got["side_n"] > 0.5  # borne, and pushed to its right
    # In the world: drag along the heading, the side force to the right, lift up; about the
    # hub (the wheel's centre of mass) the torque about the axle, the roll moment about the
    # heading's backward and the yaw moment about the vertical.
    right = -left
    np.testing.assert_allclose(
        data.xfrc_applied[body, :3],
        got["drag_n"] * fwd + got["side_n"] * right + [0.0, 0.0, got["lift_n"]], atol=1e-12)
    np.testing.assert_allclose(
        data.xfrc_applied[body, 3:],
        -got["hip_torque_nm"] * left - got["roll_moment_nm"] * fwd
        + [0.0, 0.0, got["yaw_moment_nm"]], atol=1e-12)


TWO_WHEELS = _wheels_on_a_torso({"left": (0.02, 0.08), "right": (0.02, -0.08)})


def test_a_batch_of_wheeled_environments_feels_what_one_coupling_gives_each():
    from pathlib import Path

    medium = Path(__file__).resolve().parents[2] / "tests" / "data" / "medium_without_shape.yaml"
    wheel = LegBatch(model="rft", shape="wheel", radius_m=0.058, width_m=0.05, medium_file=medium)
    model = mujoco.MjModel.from_xml_string(TWO_WHEELS)
    legs = [tm.LegMap(n, f"{n}_joint", n) for n in ("left", "right")]
    n = 32
    sideways = 0
    for e, batch, one, data, xfrc, bodies in _each_env_against_one(model, legs, wheel, n, seed=5):
        scale = max(1.0, np.abs(one.lift_n).max(), np.abs(one.drag_n).max())
        for name in ("drag_n", "lift_n", "hip_torque_nm", "side_n", "roll_moment_nm",
                     "yaw_moment_nm"):
            np.testing.assert_allclose(getattr(batch, name)[e], getattr(one, name), rtol=0,
                                       atol=1e-12 * scale, err_msg=name)
        np.testing.assert_allclose(xfrc[e, bodies], data.xfrc_applied[bodies], rtol=0,
                                   atol=1e-12 * scale)
        sideways += int((np.abs(one.side_n) > 1e-3).sum())
    # The states move the wheels every way: many are pushed sideways.
    assert sideways > n // 2, sideways
