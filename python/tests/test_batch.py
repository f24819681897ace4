"""terzaghi.batch against the numpy peer (the paper's equations vectorised) and terzaghi.predict."""

import sys
from pathlib import Path

import numpy as np
import pytest

import terzaghi
from terzaghi.batch import LegBatch

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from numpy_peer import plate_forces  # noqa: E402

MEDIUM = dict(unit_weight_n_m3=13000.0, phi_deg=30.0, delta_deg=20.0)
LEG = dict(length_m=0.1, width_m=0.025)


def test_plate_legs_equal_the_numpy_peer_to_1e_9():
    rng = np.random.default_rng(7)
    shape = (4096, 6)
    beta = rng.uniform(-np.pi, 3 * np.pi, shape)
    hip = rng.uniform(-0.01, 0.12, shape)
    pitch = rng.uniform(-0.2, 0.2, shape)
    legs = LegBatch(**LEG, **MEDIUM, b_k=30.0, a=2.3)
    ours = legs.forces(beta, hip, pitch_rad=pitch)
    peer = plate_forces(beta, hip, **LEG, **MEDIUM, b_k=30.0, a=2.3, pitch_rad=pitch)
    for o, p in zip(ours, peer):
        np.testing.assert_allclose(o, p, rtol=1e-9, atol=1e-9)
    assert np.count_nonzero(ours[1]) > shape[0]  # legs in the medium, not only zeros


def test_batch_equals_predict_for_plates_and_c_legs():
    beta = np.radians(np.arange(-20.0, 200.0, 3.0))
    for kw in [dict(model="improved", **MEDIUM, b_k=30.0, a=2.3),
               dict(model="rft", medium="poppy_lp", shape="c_leg", rft_elements=96)]:
        legs = LegBatch(**LEG, **kw)
        for h in [0.0, 0.03]:
            drag, lift, torque = legs.forces(beta, np.full_like(beta, h))
            f = terzaghi.predict(beta, **LEG, hip_height_m=h, **kw)
            np.testing.assert_allclose(drag, f["drag_n"], rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(lift, f["lift_n"], rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(torque, f["hip_torque_nm"], rtol=1e-12, atol=1e-12)


def test_out_arrays_are_written_in_place_and_bad_inputs_are_named():
    legs = LegBatch(**LEG, **MEDIUM, b_k=30.0, a=2.3)
    beta = np.full((8, 6), 0.5)
    hip = np.zeros((8, 6))
    out = tuple(np.empty((8, 6)) for _ in range(3))
    got = legs.forces(beta, hip, out=out)
    assert all(g is o for g, o in zip(got, out))
    bad = beta.copy()
    bad[3, 2] = np.nan
    with pytest.raises(terzaghi.TerzaghiError, match=r"leg 20 \(flat index\)"):
        legs.forces(bad, hip)
    # Across the chunks the threads share, the first bad leg is the one named, every time.
    many = np.full((4096, 6), 0.5)
    many.flat[20000] = np.nan
    many.flat[5000] = np.inf
    for _ in range(10):
        with pytest.raises(terzaghi.TerzaghiError, match=r"leg 5000 \(flat index\)"):
            legs.forces(many, 0.01)
    with pytest.raises(terzaghi.TerzaghiError, match=r"hip_height_m has shape \(47,\)"):
        legs.forces(beta, np.zeros(47))
    # Shapes, not counts: as many values in another shape are refused, a transposed array named
    # as such; a scalar is broadcast.
    with pytest.raises(terzaghi.TerzaghiError, match=r"hip_height_m has shape \(48,\), beta_rad \(8, 6\)"):
        legs.forces(beta, np.zeros(48))
    with pytest.raises(terzaghi.TerzaghiError, match=r"omega_rad_s has shape \(6, 8\), beta_rad \(8, 6\) \(transposed\?\)"):
        legs.forces(beta, hip, omega_rad_s=np.zeros((6, 8)))
    varied = np.linspace(0.2, 1.4, 48).reshape(8, 6)
    for k, (a, b) in enumerate(zip(legs.forces(varied, 0.01), legs.forces(varied, np.full((8, 6), 0.01)))):
        np.testing.assert_array_equal(a, b, err_msg=f"output {k}")
    with pytest.raises(terzaghi.TerzaghiError, match=r"drag_n is float64 \(48,\), the batch float64 \(8, 6\)"):
        legs.forces(beta, hip, out=(np.empty(48), out[1], out[2]))
    with pytest.raises(terzaghi.TerzaghiError, match="C-contiguous"):
        legs.forces(beta, hip, out=(np.empty((6, 8)).T, out[1], out[2]))
    with pytest.raises(terzaghi.TerzaghiError, match="radius_m 0.03"):
        LegBatch(**LEG, model="rft", medium="poppy_lp", shape="c_leg", c_leg_radius_m=0.03)
    with pytest.raises(terzaghi.TerzaghiError, match="RFT only"):
        LegBatch(**LEG, **MEDIUM, b_k=30.0, a=2.3, shape="c_leg")


def _rand_legs(shape, seed):
    rng = np.random.default_rng(seed)
    return dict(beta=rng.uniform(-np.pi, 3 * np.pi, shape), hip=rng.uniform(-0.01, 0.08, shape),
                pitch=rng.uniform(-0.1, 0.1, shape), omega=rng.uniform(-6.0, 8.0, shape),
                fwd=rng.uniform(-0.2, 0.3, shape), up=rng.uniform(-0.05, 0.05, shape))


C_LEG = dict(model="rft", medium="poppy_lp", shape="c_leg", rft_elements=96)


def test_a_float32_batch_runs_in_float32_within_the_documented_accuracy():
    # docs/python.md: float32 forces within 1e-4 of the largest force of the batch in float64.
    x = _rand_legs((512, 6), 3)
    for kw in [C_LEG, dict(model="rft", medium="poppy_lp"), dict(**MEDIUM, b_k=30.0, a=2.3)]:
        legs = LegBatch(**LEG, **kw)
        motion = dict(pitch_rad=x["pitch"], omega_rad_s=x["omega"], forward_m_s=x["fwd"],
                      up_m_s=x["up"])
        f64 = legs.forces(x["beta"], x["hip"], **motion)
        f32 = legs.forces(x["beta"].astype(np.float32), x["hip"].astype(np.float32),
                          **{k: v.astype(np.float32) for k, v in motion.items()})
        scale = max(np.abs(f64[0]).max(), np.abs(f64[1]).max())
        assert scale > 1.0
        for k, (a, b) in enumerate(zip(f32, f64)):
            assert a.dtype == np.float32 and b.dtype == np.float64
            err = np.abs(a.astype(np.float64) - b).max()
            assert err <= 1e-4 * scale, f"{kw}, output {k}: {err} of {scale}"


def test_each_environment_s_medium_equals_its_own_predict_to_1e_12():
    envs, legs_per_env = 16, 6
    x = _rand_legs((envs, legs_per_env), 5)
    rng = np.random.default_rng(11)
    b_k = rng.uniform(5.0, 60.0, envs)[:, None] * np.ones((1, legs_per_env))
    a = rng.uniform(1.1, 4.0, envs)[:, None] * np.ones((1, legs_per_env))
    legs = LegBatch(**LEG, **MEDIUM, b_k=30.0, a=2.3)
    drag, lift, torque = legs.forces(x["beta"], x["hip"], pitch_rad=x["pitch"], b_k=b_k, a=a)
    in_sand = 0
    for e in range(envs):
        for j in range(legs_per_env):
            p = terzaghi.predict(x["beta"][e, j] + x["pitch"][e, j], **LEG, **MEDIUM,
                                 hip_height_m=max(x["hip"][e, j], 0.0), b_k=b_k[e, 0],
                                 a=a[e, 0])
            for got, key in [(drag, "drag_n"), (lift, "lift_n"), (torque, "hip_torque_nm")]:
                want = float(np.asarray(p[key]).reshape(-1)[0])
                assert abs(got[e, j] - want) <= 1e-12 * max(1.0, abs(want)), (e, j, key)
            in_sand += lift[e, j] != 0
    assert in_sand > 10
    # A fitting width that is not positive is named with its leg; a model without one refuses.
    bad = b_k.copy()
    bad[2, 3] = -1.0
    with pytest.raises(terzaghi.TerzaghiError, match=r"leg 15 \(flat index\).*b_k.*-1"):
        legs.forces(x["beta"], x["hip"], b_k=bad)
    for model_kw in (C_LEG, dict(model="conventional", **MEDIUM)):
        with pytest.raises(terzaghi.TerzaghiError,
                           match=r"^a: a fitting width per leg is the improved model's"):
            LegBatch(**LEG, **model_kw).forces(x["beta"], x["hip"], a=a)


def test_shapes_and_dtypes_are_checked_and_named():
    legs = LegBatch(**LEG, **C_LEG)
    beta = np.full((4, 6), 0.5)
    with pytest.raises(terzaghi.TerzaghiError, match=r"hip_height_m has shape \(24,\), beta_rad \(4, 6\)"):
        legs.forces(beta, np.zeros(24))
    with pytest.raises(terzaghi.TerzaghiError,
                       match=r"forward_m_s has shape \(6, 4\), beta_rad \(4, 6\) \(transposed\?\)"):
        legs.forces(beta, 0.01, forward_m_s=np.zeros((6, 4)))
    out32 = tuple(np.empty((4, 6), np.float32) for _ in range(3))
    with pytest.raises(terzaghi.TerzaghiError,
                       match=r"drag_n is float32 \(4, 6\), the batch float64 \(4, 6\)"):
        legs.forces(beta, 0.01, out=out32)
    with pytest.raises(terzaghi.TerzaghiError,
                       match=r"lift_n is float64 \(6, 4\), the batch float32 \(4, 6\)"):
        legs.forces(beta.astype(np.float32), 0.01,
                    out=(out32[0], np.empty((6, 4)), out32[2]))
    # The native layer checks as well, naming the argument and both.
    with pytest.raises(terzaghi.TerzaghiError, match=r"hip_torque_nm is float32 \[4, 6\]"):
        legs._inner.forces_into(beta, np.zeros((4, 6)), None, None, None, None, None, None,
                                np.empty((4, 6)), np.empty((4, 6)), out32[2])


WHEEL_MEDIUM = Path(__file__).resolve().parents[2] / "tests" / "data" / "medium_without_shape.yaml"
WHEEL = dict(model="rft", shape="wheel", radius_m=0.058, width_m=0.05, medium_file=WHEEL_MEDIUM)


def test_a_batch_of_wheels_and_feet_gives_predict_s_whole_wrench():
    rng = np.random.default_rng(3)
    shape = (40, 6)
    x = dict(beta=rng.uniform(0.0, 6.3, shape), hip=rng.uniform(-0.01, 0.07, shape),
             omega=rng.uniform(-1.0, 1.0, shape), fwd=rng.uniform(-0.02, 0.05, shape),
             up=rng.uniform(-0.01, 0.01, shape), lat=rng.uniform(-0.02, 0.02, shape))
    bodies = [WHEEL,
              dict(WHEEL, grouser_count=8, grouser_height_m=0.01, grouser_thickness_m=0.004),
              dict(model="rft", shape="box", size_m=(0.05, 0.02, 0.05), medium_file=WHEEL_MEDIUM)]
    for kw in bodies:
        legs = LegBatch(**kw)
        assert legs.is_body and not legs.vectorised
        got = legs.wrenches(x["beta"], x["hip"], omega_rad_s=x["omega"], forward_m_s=x["fwd"],
                            up_m_s=x["up"], lateral_m_s=x["lat"])
        want = terzaghi.predict(x["beta"], hip_height_m=x["hip"], omega_rad_s=x["omega"],
                                forward_m_s=x["fwd"], up_m_s=x["up"], lateral_m_s=x["lat"], **kw)
        for name, g in zip(terzaghi.batch.WRENCH, got):
            np.testing.assert_array_equal(g, want[name], err_msg=f"{kw['shape']} {name}")
        assert np.count_nonzero(np.abs(got[3]) > 1e-3) > 20, kw  # bodies pushed sideways
        # forces() is the wrench's first three, the hips moving in their plane.
        three = legs.forces(x["beta"], x["hip"], omega_rad_s=x["omega"], forward_m_s=x["fwd"])
        plane = legs.wrenches(x["beta"], x["hip"], omega_rad_s=x["omega"], forward_m_s=x["fwd"])
        for a, b in zip(three, plane):
            np.testing.assert_array_equal(a, b)
    # float32 in, float32 out, to float32's rounding of the same wrench.
    legs = LegBatch(**WHEEL)
    w64 = legs.wrenches(x["beta"], x["hip"], omega_rad_s=x["omega"], forward_m_s=x["fwd"],
                        lateral_m_s=x["lat"])
    w32 = legs.wrenches(x["beta"].astype(np.float32), x["hip"], omega_rad_s=x["omega"],
                        forward_m_s=x["fwd"], lateral_m_s=x["lat"])
    for a, b in zip(w64, w32):
        assert b.dtype == np.float32
        np.testing.assert_allclose(b, a, rtol=1e-4, atol=1e-4 * np.abs(a).max())


def test_a_plate_batch_moving_sideways_and_a_body_s_bad_values_are_named():
    beta = np.radians(np.arange(10.0, 170.0, 5.0))
    lat = np.linspace(-0.05, 0.05, beta.size)
    plate = LegBatch(**LEG, model="rft", medium="poppy_lp")
    got = plate.wrenches(beta, 0.03, forward_m_s=0.1, lateral_m_s=lat)
    want = terzaghi.predict(beta, **LEG, model="rft", medium="poppy_lp", hip_height_m=0.03,
                            forward_m_s=0.1, lateral_m_s=lat)
    for name, g in zip(terzaghi.batch.WRENCH, got):
        np.testing.assert_allclose(g, want[name], rtol=1e-12, atol=1e-12, err_msg=name)
    # A leg in the sand moving left is pushed to its right (+), as the docs give.
    moving = (lat != 0) & (want["depth_m"] > 0)
    assert moving.sum() > 10 and (np.sign(got[3][moving]) == np.sign(lat[moving])).all()
    # In its plane: forces' values, no side force, no moments.
    d, l, t, s, r, y = plate.wrenches(beta, 0.03, forward_m_s=0.1)
    np.testing.assert_array_equal(d, plate.forces(beta, 0.03, forward_m_s=0.1)[0])
    assert not s.any() and not r.any() and not y.any()
    bad = lat.copy()
    bad[7] = np.inf
    with pytest.raises(terzaghi.TerzaghiError, match=r"leg 7 \(flat index\).*lateral velocity"):
        plate.wrenches(beta, 0.03, lateral_m_s=bad)
    with pytest.raises(terzaghi.TerzaghiError, match=r"out: 6 arrays"):
        plate.wrenches(beta, 0.03, out=tuple(np.empty(beta.shape) for _ in range(3)))
    with pytest.raises(terzaghi.TerzaghiError, match="length_m is not given for a body"):
        LegBatch(**WHEEL, length_m=0.1)
    with pytest.raises(terzaghi.TerzaghiError, match=r"a body \(wheel\) is RFT's"):
        LegBatch(**dict(WHEEL, model="improved"))
    with pytest.raises(terzaghi.TerzaghiError, match="rft_elements is for a leg's mid-line"):
        LegBatch(**WHEEL, rft_elements=50)
    with pytest.raises(terzaghi.TerzaghiError, match="radius_m is for a body"):
        LegBatch(**LEG, model="rft", medium="poppy_lp", radius_m=0.05)
    with pytest.raises(terzaghi.TerzaghiError, match="wheel radius"):
        LegBatch(**dict(WHEEL, radius_m=-0.058))
    with pytest.raises(terzaghi.TerzaghiError, match=r"leg 3 \(flat index\).*hip height"):
        LegBatch(**WHEEL).wrenches(np.zeros(5), np.array([0.03, 0.03, 0.03, np.nan, 0.03]))
