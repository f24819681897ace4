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
    with pytest.raises(terzaghi.TerzaghiError, match="element 20"):
        legs.forces(bad, hip)
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
    with pytest.raises(terzaghi.TerzaghiError, match="drag_n has shape"):
        legs.forces(beta, hip, out=(np.empty(48), out[1], out[2]))
    with pytest.raises(terzaghi.TerzaghiError, match="C-contiguous"):
        legs.forces(beta, hip, out=(np.empty((6, 8)).T, out[1], out[2]))
    with pytest.raises(terzaghi.TerzaghiError, match="radius_m 0.03"):
        LegBatch(**LEG, model="rft", medium="poppy_lp", shape="c_leg", c_leg_radius_m=0.03)
    with pytest.raises(terzaghi.TerzaghiError, match="RFT only"):
        LegBatch(**LEG, **MEDIUM, b_k=30.0, a=2.3, shape="c_leg")
