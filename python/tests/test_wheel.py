"""A wheel under load from Python: the same steady states as ``terzaghi steady``, arrays that
broadcast, and values refused by name."""

import csv

import numpy as np
import pytest

import terzaghi
from test_api import REPO, run

RUNS = REPO / "tests" / "data" / "real-wheel" / "slip_sweep_runs.csv"
MEDIUM = REPO / "tests" / "data" / "medium_without_shape.yaml"
WHEEL = dict(radius_m=0.058, width_m=0.05, medium_file=MEDIUM)


def _columns(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0] if k not in ("date", "file")}


@pytest.mark.parametrize("held", [False, True])
def test_the_real_sweep_is_what_the_command_gives(tmp_path, held):
    runs = _columns(RUNS)
    out = tmp_path / "steady.csv"
    extra = ["--at-sinkage", "sinkage_m"] if held else []
    run("steady", RUNS, "--radius-m", "0.058", "--width-m", "0.05", "--medium-file", MEDIUM,
        "-o", out, *extra)
    cli = _columns(out)
    kinds = dict(sinkage_m=runs["sinkage_m"]) if held else dict(load_n=runs["load_n"])
    py = terzaghi.steady(hub_vx_m_s=runs["hub_vx_m_s"], omega_rad_s=runs["omega_rad_s"],
                         slip_angle_deg=runs["slip_angle_deg"], **kinds, **WHEEL)
    for k in ("sinkage_m", "drawbar_n", "side_n", "torque_nm", "load_borne_n"):
        assert py[k].shape == (27,)
        np.testing.assert_allclose(py[k], cli[k], rtol=1e-12, atol=1e-12, err_msg=k)


def test_arrays_broadcast_and_a_yawed_wheel_is_pushed_back_either_way():
    r = terzaghi.steady(np.array([[10.0], [20.0]]), 0.01, 0.172, [-10.0, 0.0, 10.0], **WHEEL)
    assert r["sinkage_m"].shape == (2, 3)
    # Heavier sinks deeper; a yaw either way pushes back as much.
    assert np.all(r["sinkage_m"][1] > r["sinkage_m"][0])
    np.testing.assert_allclose(r["side_n"][:, 0], r["side_n"][:, 2], rtol=1e-9)
    assert np.all(r["side_n"][:, 0] > 0.1) and np.all(r["side_n"][:, 1] == 0.0)


def test_what_is_no_run_is_refused_by_name():
    with pytest.raises(terzaghi.TerzaghiError, match=r"shapes do not broadcast: hub_vx_m_s \(2,\)"):
        terzaghi.steady([20.0, 20.0, 20.0], [0.01, 0.01], 0.1, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match=r"run 1 \(flat index\): load \(N\) is NaN"):
        terzaghi.steady([20.0, np.nan], 0.01, 0.1, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match=r"bears at most .* 1000000 N"):
        terzaghi.steady(1e6, 0.01, 0.1, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="load_n is needed"):
        terzaghi.steady(hub_vx_m_s=0.01, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="not both"):
        terzaghi.steady(20.0, sinkage_m=0.02, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="grouser_count, grouser_height_m"):
        terzaghi.steady(20.0, grouser_count=12, **WHEEL)
    # A count that is no whole number is refused, not cut to one.
    with pytest.raises(terzaghi.TerzaghiError, match="grouser_count 2.5"):
        terzaghi.steady(20.0, grouser_count=2.5, grouser_height_m=0.005,
                        grouser_thickness_m=0.003, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match=r"wheel radius \(m\)"):
        terzaghi.steady(20.0, radius_m=-1.0, width_m=0.05, medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match="must be numbers"):
        terzaghi.steady("heavy", **WHEEL)
