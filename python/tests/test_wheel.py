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
    cols = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]
            if k not in ("date", "file", "borne")}
    if "borne" in rows[0]:
        cols["borne"] = np.array([r["borne"] == "true" for r in rows])
    return cols


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
    np.testing.assert_array_equal(py["borne"], cli["borne"])


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
    # A load the sand cannot bear is a row all the same: not borne, the body buried to its top,
    # the most the sand bears there as its load; the other runs answered beside it.
    r = terzaghi.steady([20.0, 1e6], 0.01, 0.1, **WHEEL)
    assert r["borne"].tolist() == [True, False]
    assert r["load_borne_n"][1] < 1e6 and r["load_borne_n"][1] > r["load_borne_n"][0]
    assert abs(r["sinkage_m"][1] - 2 * WHEEL["radius_m"]) < 1e-9
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
    # A body's value that is no number is named, not a bare conversion error.
    with pytest.raises(terzaghi.TerzaghiError, match=r"size_m 'a' is not a number"):
        terzaghi.steady(8.0, shape="box", size_m=["a", 0.02, 0.05], medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match=r"size_m 0.05 is not three sizes"):
        terzaghi.steady(8.0, shape="box", size_m=0.05, medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match=r"radius_m 'wide' is not a number"):
        terzaghi.steady(8.0, radius_m="wide", width_m=0.05, medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match=r"rim_elements 'many' is not a number"):
        terzaghi.steady(8.0, rim_elements="many", **WHEEL)
    # A value the shape does not take is refused, defaults or not.
    with pytest.raises(terzaghi.TerzaghiError, match="shape wheel takes no mesh_scale"):
        terzaghi.steady(8.0, mesh_scale=0.001, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="shape sphere takes no rim_elements"):
        terzaghi.steady(8.0, shape="sphere", radius_m=0.03, rim_elements=720, medium_file=MEDIUM)


@pytest.mark.parametrize("shape,args,cli_args", [
    ("sphere", dict(radius_m=0.03), ["--radius-m", "0.03"]),
    ("box", dict(size_m=[0.06, 0.04, 0.06]), ["--size-m", "0.06,0.04,0.06"]),
    ("disc", dict(radius_m=0.03, thickness_m=0.04), ["--radius-m", "0.03", "--thickness-m", "0.04"]),
])
def test_a_foot_is_what_the_command_gives(tmp_path, shape, args, cli_args):
    runs_path = REPO / "tests" / "data" / "feet" / "runs.csv"
    runs = _columns(runs_path)
    out = tmp_path / "steady.csv"
    run("steady", runs_path, "--shape", shape, *cli_args, "--medium-file", MEDIUM, "-o", out)
    cli = _columns(out)
    py = terzaghi.steady(runs["load_n"], runs["hub_vx_m_s"], runs["omega_rad_s"],
                         runs["slip_angle_deg"], shape=shape, medium_file=MEDIUM, **args)
    for k in ("sinkage_m", "drawbar_n", "side_n", "torque_nm", "load_borne_n"):
        np.testing.assert_allclose(py[k], cli[k], rtol=1e-12, atol=1e-12, err_msg=k)


def test_a_mesh_foot_and_a_foot_given_what_it_does_not_take(tmp_path):
    # A box drawn as ASCII STL in millimetres settles as the box shape does.
    stl = tmp_path / "foot.stl"
    hx, hy, hz = 25.0, 10.0, 25.0
    v = [(sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    quads = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    lines = ["solid foot"]
    for q in quads:
        for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])):
            lines += [" facet normal 0 0 0", "  outer loop"]
            lines += ["   vertex %g %g %g" % v[i] for i in t]
            lines += ["  endloop", " endfacet"]
    stl.write_text("\n".join(lines + ["endsolid foot", ""]))
    boxed = terzaghi.steady(8.0, 0.01, 0.0, 15.0, shape="box", size_m=[0.05, 0.02, 0.05],
                            medium_file=MEDIUM)
    meshed = terzaghi.steady(8.0, 0.01, 0.0, 15.0, shape="mesh", mesh_file=stl,
                             mesh_scale=0.001, medium_file=MEDIUM)
    for k in boxed:
        np.testing.assert_allclose(meshed[k], boxed[k], rtol=1e-6, atol=1e-9, err_msg=k)
    with pytest.raises(terzaghi.TerzaghiError, match="shape sphere takes no width_m"):
        terzaghi.steady(8.0, shape="sphere", radius_m=0.03, width_m=0.05, medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match="shape disc needs thickness_m"):
        terzaghi.steady(8.0, shape="disc", radius_m=0.03, medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match="no body shape \"cone\""):
        terzaghi.steady(8.0, shape="cone", medium_file=MEDIUM)


def _predict_rows(text):
    rows = list(csv.DictReader(text.splitlines()))
    return {k: np.array([float(r[k]) if k != "regime" else 0.0 for r in rows]) for k in rows[0]}


@pytest.mark.parametrize("shape,args,cli_args", [
    ("wheel", dict(radius_m=0.058, width_m=0.05, grouser_count=8, grouser_height_m=0.01,
                   grouser_thickness_m=0.004),
     ["--radius-m", "0.058", "--width-m", "0.05", "--grouser-count", "8",
      "--grouser-height-m", "0.01", "--grouser-thickness-m", "0.004"]),
    ("box", dict(size_m=[0.05, 0.02, 0.05]), ["--size-m", "0.05,0.02,0.05"]),
])
def test_predict_gives_a_body_what_the_command_gives(shape, args, cli_args):
    # A body turning through its angles with its hub 20 mm over the surface (the wheel's rim
    # 38 mm deep), moving forward and to the left and rolling; then held, its hub 5 mm deep.
    common = ["predict", "--model", "rft", "--shape", shape, *cli_args, "--medium-file", MEDIUM,
              "--beta-deg", "0:90:30"]
    beta = np.radians([0.0, 30.0, 60.0, 90.0])
    for hub, motion in [(0.02, dict(forward_m_s=0.01, lateral_m_s=0.004, omega_rad_s=0.2)),
                        (-0.005, {})]:
        flags = [f"--{k.replace('_', '-')}={v}" for k, v in motion.items()]
        cli = _predict_rows(run(*common, f"--hip-height-m={hub}", *flags))
        py = terzaghi.predict(beta, model="rft", shape=shape, hip_height_m=hub,
                              medium_file=MEDIUM, **args, **motion)
        assert py["lift_n"].max() > 1.0, py  # the sand is pressed: no comparison of zeros
        for k in ("drag_n", "lift_n", "hip_torque_nm", "side_n", "roll_moment_nm",
                  "yaw_moment_nm", "submerged_m", "depth_m"):
            np.testing.assert_allclose(py[k], cli[k], rtol=1e-6, atol=1e-6, err_msg=(k, hub))
    # Arrays of hubs and motions broadcast with the angles, each sample its own.
    hubs = np.array([[0.02], [0.0]])
    both = terzaghi.predict(beta, model="rft", shape=shape, hip_height_m=hubs,
                            forward_m_s=0.01, medium_file=MEDIUM, **args)
    assert both["side_n"].shape == (2, 4)
    one = terzaghi.predict(beta, model="rft", shape=shape, hip_height_m=0.0, forward_m_s=0.01,
                           medium_file=MEDIUM, **args)
    np.testing.assert_array_equal(both["lift_n"][1], one["lift_n"])


def test_predict_refuses_what_a_body_or_a_leg_does_not_take():
    with pytest.raises(terzaghi.TerzaghiError, match="length_m is not given for a body"):
        terzaghi.predict(0.0, model="rft", shape="wheel", length_m=0.1, hip_height_m=0.02, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="radius_m is for a body"):
        terzaghi.predict(0.5, length_m=0.25, width_m=0.06, hip_height_m=0.1, radius_m=0.05,
                         medium="hit_sand")
    with pytest.raises(terzaghi.TerzaghiError, match="element_m is for a body"):
        terzaghi.predict(0.5, length_m=0.25, width_m=0.06, hip_height_m=0.1, element_m=0.01,
                         medium="hit_sand")
    with pytest.raises(terzaghi.TerzaghiError, match="rft_elements is for a leg"):
        terzaghi.predict(0.0, model="rft", shape="wheel", rft_elements=50, hip_height_m=0.02,
                         **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="RFT only"):
        terzaghi.predict(0.0, shape="wheel", hip_height_m=0.02, **WHEEL)
    with pytest.raises(terzaghi.TerzaghiError, match="size_m"):
        terzaghi.predict(0.0, model="rft", shape="box", size_m=0.05, hip_height_m=0.0,
                         medium_file=MEDIUM)
    with pytest.raises(terzaghi.TerzaghiError, match="omega_rad_s"):
        terzaghi.predict([0.0, 1.0], model="rft", shape="wheel", hip_height_m=0.02,
                         omega_rad_s=[np.nan, 0.0], **WHEEL)
    # A plate moving sideways carries the side columns; one that does not, none.
    plate = dict(length_m=0.25, width_m=0.06, hip_height_m=0.15, medium="hit_sand")
    assert "side_n" in terzaghi.predict(1.0, lateral_m_s=0.01, **plate)
    assert "side_n" not in terzaghi.predict(1.0, **plate)


def test_a_wheels_runs_are_diagnosed_and_the_bearing_found_goes_into_a_medium_file(tmp_path):
    runs = REPO / "tests" / "data" / "real-wheel" / "slip_sweep_runs.csv"
    plates = REPO / "tests" / "data" / "medium_plate_runs_rft.yaml"
    [r] = terzaghi.diagnose(runs, tmp_path / "d", medium_file=plates, shape="wheel",
                            radius_m=0.058, width_m=0.05)
    assert r["verdict"]["effect"] == "sheared_bearing", r["verdict"]
    best = r["candidates"][0]
    assert [c["name"] for c in best["coefficients"]] == ["interface_tan", "exponent"]
    # The bearing the sweep gives through `calibrate --slip-sweep`, found here by the diagnosis.
    assert abs(best["coefficients"][0]["value"] - 0.3457) < 0.01, best
    assert best["held_out"]["r2_sinkage"] > 0.85 and best["held_out"]["r2_drawbar"] > 0.9, best
    # The medium file written with it is one steady reads, and it bears the locked wheel less.
    corrected = tmp_path / "d" / "corrected_medium.yaml"
    locked = dict(radius_m=0.058, width_m=0.05)
    before = terzaghi.steady(22.0, 0.01, 0.0, medium_file=plates, **locked)
    after = terzaghi.steady(22.0, 0.01, 0.0, medium_file=corrected, **locked)
    assert after["sinkage_m"] > before["sinkage_m"] + 0.01
    with pytest.raises(terzaghi.TerzaghiError, match="give its body"):
        terzaghi.diagnose(runs, tmp_path / "e", medium_file=plates)
    with pytest.raises(terzaghi.TerzaghiError, match="give its shape too"):
        terzaghi.diagnose(runs, tmp_path / "e", medium_file=plates, radius_m=0.058)


def test_a_planar_leg_takes_the_sheared_bearing_only_when_asked_in_predict_and_legbatch():
    from terzaghi.batch import LegBatch
    sweep = REPO / "tests" / "data" / "medium_slip_sweep.yaml"
    plates = REPO / "tests" / "data" / "medium_plate_runs_rft.yaml"
    leg = dict(model="rft", shape="c_leg", length_m=0.1, width_m=0.03)
    beta = np.radians(np.arange(20.0, 170.0, 10.0))
    at_rest = terzaghi.predict(beta, hip_height_m=0.04, medium_file=plates, **leg)
    unasked = terzaghi.predict(beta, hip_height_m=0.04, medium_file=sweep, **leg)
    asked = terzaghi.predict(beta, hip_height_m=0.04, medium_file=sweep,
                             planar_sheared_bearing=True, **leg)
    np.testing.assert_array_equal(unasked["lift_n"], at_rest["lift_n"])
    np.testing.assert_array_equal(asked["drag_n"], at_rest["drag_n"])
    assert np.all(asked["lift_n"] <= at_rest["lift_n"] + 1e-12)
    assert np.any(asked["lift_n"] < at_rest["lift_n"] - 1e-3)
    batch = LegBatch(medium_file=sweep, planar_sheared_bearing=True, **leg)
    assert not batch.vectorised
    drag, lift, torque = batch.forces(beta, np.full_like(beta, 0.04))
    np.testing.assert_allclose(lift, asked["lift_n"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(torque, asked["hip_torque_nm"], rtol=1e-12, atol=1e-12)
