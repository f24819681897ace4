"""The Python API against the `terzaghi` binary on the same inputs.

The binary is $TERZAGHI_BIN (tests/python.rs sets it), else target/release/terzaghi.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import terzaghi

REPO = Path(__file__).resolve().parents[2]
BIN = os.environ.get("TERZAGHI_BIN", str(REPO / "target" / "release" / "terzaghi"))
PLATE = dict(length_m=0.1, width_m=0.025, hip_height_m=0.0)
PLATE_FLAGS = ["--length-m", "0.1", "--width-m", "0.025", "--hip-height-m", "0"]


def run(*args):
    out = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout


@pytest.fixture(scope="module")
def session_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("sim") / "session.csv"
    run("simulate", *PLATE_FLAGS, "--medium", "poppy_lp", "--strokes", "6", "--seed", "3", "-o", path)
    return path


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True)
    return d["t_s"], d["beta_rad"], d["drag_n"], d["lift_n"]


@pytest.mark.parametrize(
    "model, extra, flags",
    [
        ("improved", {}, []),
        ("conventional", {}, []),
        ("improved", dict(b_k=1.3, a=2.5), ["--bk", "1.3", "--a", "2.5"]),
        ("rft", dict(rft_elements=50), ["--rft-elements", "50"]),
    ],
)
def test_predict_equals_the_binary(model, extra, flags):
    deg = np.arange(-10.0, 181.0, 7.5)
    rows = json.loads(
        run("predict", "--model", model, *PLATE_FLAGS, "--medium", "poppy_lp", *flags,
            "--beta-deg", "-10:180:7.5", "--format", "json")
    )
    f = terzaghi.predict(np.radians(deg), model=model, medium="poppy_lp", **PLATE, **extra)
    for key in ["drag_n", "lift_n", "hip_torque_nm", "submerged_m", "depth_m"]:
        np.testing.assert_allclose(f[key], [r[key] for r in rows], rtol=1e-12, atol=1e-12)
    assert [terzaghi.REGIMES[c] for c in f["regime"]] == [r["regime"] for r in rows]


def test_predict_keeps_the_shape_and_takes_numbers_and_lists():
    beta = np.radians(np.linspace(0, 150, 24)).reshape(2, 3, 4)
    f = terzaghi.predict(beta, medium="poppy_lp", **PLATE)
    assert all(v.shape == (2, 3, 4) for v in f.values())
    flat = terzaghi.predict(beta.ravel().tolist(), medium="poppy_lp", **PLATE)
    np.testing.assert_array_equal(f["lift_n"].ravel(), flat["lift_n"])
    one = terzaghi.predict(0.5, medium="poppy_lp", **PLATE)
    assert one["drag_n"].shape == ()


def test_bad_values_raise_with_their_words():
    cases = [
        (dict(beta_rad=[0.1, np.nan], medium="poppy_lp", **PLATE), "beta_rad[1]"),
        (dict(beta_rad=0.1, medium="poppy_lq", **PLATE), "poppy_lq"),
        (dict(beta_rad=0.1, medium="poppy_lp", length_m=0.1, width_m=0.025, hip_height_m=0.2),
         "never enters the medium"),
        (dict(beta_rad=0.1, medium="poppy_lp", b_k=1.0, **PLATE), "go together"),
        (dict(beta_rad=0.1, medium="poppy_lp", model="improvd", **PLATE), "improvd"),
        (dict(beta_rad=0.1, unit_weight_n_m3=1e4, phi_deg=30.0, **PLATE), "unit_weight_n_m3"),
        (dict(beta_rad=0.1, medium="poppy_lp", b_k=float("inf"), a=1.0, **PLATE), "b_k"),
        (dict(beta_rad=0.1, medium="poppy_lp", model="rft", rft_elements=0, **PLATE),
         "rft_elements"),
    ]
    for kwargs, words in cases:
        with pytest.raises(terzaghi.TerzaghiError, match=words.replace("[", r"\[")):
            terzaghi.predict(**kwargs)
    with pytest.raises(ValueError):
        terzaghi.predict("not an angle", medium="poppy_lp", **PLATE)


def test_fit_equals_the_binary(session_csv):
    want = json.loads(run("fit", session_csv, *PLATE_FLAGS, "--medium", "poppy_lp", "--json"))
    _, beta, drag, lift = load(session_csv)
    got = terzaghi.fit(beta, drag, lift, medium="poppy_lp", **PLATE)
    assert got.keys() == want.keys()
    for k in ["b_k", "a", "delta_deg", "samples"]:
        assert got[k] == pytest.approx(want[k], rel=1e-12), k
    with pytest.raises(terzaghi.TerzaghiError, match="one shape"):
        terzaghi.fit(beta, drag[:-1], lift, medium="poppy_lp", **PLATE)


def test_the_online_estimate_equals_the_binary(session_csv):
    want = json.loads(
        run("identify", "--online", session_csv, *PLATE_FLAGS, "--medium", "poppy_lp", "--json")
    )
    t, beta, drag, lift = load(session_csv)
    est = terzaghi.OnlineEstimator(medium="poppy_lp", **PLATE)
    # Fed in two parts: the estimator is an object that keeps its state.
    half = len(t) // 2
    used = est.update(beta[:half], drag[:half], lift[:half], t[:half])
    used += est.update(beta[half:], drag[half:], lift[half:], t[half:])
    got = est.estimate
    assert used == want["samples_used"] == got["samples_used"]
    for k in ["b_k", "a", "std_b_k", "std_a", "converged"]:
        assert got[k] == pytest.approx(want[k], rel=1e-12), k
    # A NaN sample is skipped and counted, never passed on.
    est.update(np.nan, 1.0, 1.0, t[-1] + 0.01)
    assert est.estimate["samples_non_finite"] == got["samples_non_finite"] + 1
    assert np.isfinite(est.estimate["b_k"])


def test_diagnose_equals_the_binary(tmp_path):
    rec = tmp_path / "walk.mcap"
    run("simulate-robot", "--seconds", "20", "--hidden", "sensor_bias", "-o", rec)
    want = json.loads(run("diagnose", rec, "--out", tmp_path / "cli", "--json"))
    got = terzaghi.diagnose(rec, tmp_path / "py")
    assert isinstance(want, list) and len(got) == len(want) == 6
    assert got == want
    assert (tmp_path / "py" / got[0]["leg"] / "report.html").exists()
    with pytest.raises(terzaghi.TerzaghiError, match="nothing.mcap"):
        terzaghi.diagnose(tmp_path / "nothing.mcap", tmp_path / "none")


def test_a_plate_sinkage_test_is_diagnosed_as_the_binary_does(tmp_path):
    runs = REPO / "tests" / "data" / "real-plate-sinkage"
    others = sorted(runs.glob("*D60mm.csv")) + sorted(runs.glob("*D100mm.csv"))
    medium = tmp_path / "without_80.yaml"
    run("calibrate", *others, "--law", "depth_width_power", "-o", medium)
    test = runs / "plate_smallbox_run7_D80mm.csv"
    want = json.loads(run("diagnose", test, "--medium-file", medium, "--out", tmp_path / "cli", "--json"))
    (got,) = terzaghi.diagnose(test, tmp_path / "py", medium_file=medium)
    assert got == want
    with pytest.raises(terzaghi.TerzaghiError, match="medium_file"):
        terzaghi.diagnose(test, tmp_path / "none")


def test_session_rows_equal_the_binarys_reevaluation(tmp_path):
    rec = tmp_path / "walk.mcap"
    run("simulate-robot", "--seconds", "5", "-o", rec)
    rows_csv = tmp_path / "rows.csv"
    run("replay", "--reevaluate", rec, "-p", "use_identified:=false", "-o", rows_csv)
    import csv

    want = {}
    with open(rows_csv) as f:
        for r in csv.DictReader(f):
            want.setdefault(r["leg"], []).append(r)
    got = terzaghi.session_rows(rec, params={"use_identified": False})
    assert sorted(got) == sorted(want)
    for leg, rows in want.items():
        g = got[leg]
        assert len(g["t_s"]) == len(rows)
        for col in ["t_s", "beta_rad", "predicted_drag_n", "predicted_lift_n", "b_k", "a",
                    "predicted_side_n", "predicted_yaw_moment_nm"]:
            np.testing.assert_allclose(g[col], [float(r[col]) for r in rows], rtol=1e-9, atol=1e-9)
        measured = [float(r["measured_lift_n"]) if r["measured_lift_n"] else np.nan for r in rows]
        np.testing.assert_allclose(g["measured_lift_n"], measured, rtol=1e-9, atol=1e-9)
        assert [terzaghi.REGIMES[c] for c in g["regime"]] == [r["regime"] for r in rows]
    frames = terzaghi.session_rows(rec, pandas=True)
    assert set(frames) == set(want) and "regime" in frames[leg].columns
    with pytest.raises(terzaghi.TerzaghiError, match="nothing.mcap"):
        terzaghi.session_rows(tmp_path / "nothing.mcap")
    with pytest.raises(terzaghi.TerzaghiError, match="use_identified"):
        terzaghi.session_rows(rec, params={"use_identified": {"no": 1}})


def test_every_array_call_checks_shapes_not_counts(tmp_path):
    """Each call that takes arrays refuses a shape that does not fit, naming it, even where the
    count of values would fit; scalars are broadcast where :func:`predict` broadcasts them."""
    from terzaghi.batch import LegBatch

    leg = dict(length_m=0.25, width_m=0.06, medium="hit_sand", b_k=30.0, a=2.3)
    batch = LegBatch(**leg)
    beta = np.full((4, 6), 0.8)
    # The two cases: a (24,) for a (4, 6), and a transposed (6, 4096) for a (4096, 6).
    with pytest.raises(terzaghi.TerzaghiError, match=r"hip_height_m has shape \(24,\), beta_rad \(4, 6\)"):
        batch.forces(beta, np.full(24, 0.15))
    with pytest.raises(terzaghi.TerzaghiError,
                       match=r"hip_height_m has shape \(6, 4096\), beta_rad \(4096, 6\) \(transposed\?\)"):
        batch.forces(np.full((4096, 6), 0.8), np.full((6, 4096), 0.15))
    # predict broadcasts as numpy does, and names every shape where numpy would not.
    moving = terzaghi.predict(np.full((4, 6), 0.8), model="improved", hip_height_m=np.full(6, 0.15), **leg)
    assert moving["drag_n"].shape == (4, 6)
    with pytest.raises(terzaghi.TerzaghiError,
                       match=r"do not broadcast: beta_rad \(4, 6\), hip_height_m \(24,\), up_m_s \(\)"):
        terzaghi.predict(np.full((4, 6), 0.8), model="improved", hip_height_m=np.full(24, 0.15), **leg)
    # A JointState's positions are one per name; a wrench and a pose are vectors of 3 and 4.
    node = terzaghi.Node(params=terzaghi.rhex_params())
    names = ["hip_" + l for l in ("fl", "fr")]
    with pytest.raises(terzaghi.TerzaghiError, match=r"position has shape \(1, 2\), expected \(2,\)"):
        node.joint_state(1, names, [[0.1, 0.2]])
    with pytest.raises(terzaghi.TerzaghiError, match=r"velocity has shape \(3,\), expected \(2,\)"):
        node.joint_state(1, names, [0.1, 0.2], velocity=[1.0, 1.0, 1.0])
    with pytest.raises(terzaghi.TerzaghiError, match=r"force has shape \(1, 3\), expected \(3,\)"):
        node.wrench(0, 1, [[1.0, 2.0, 3.0]])
    with pytest.raises(terzaghi.TerzaghiError, match=r"orientation_xyzw has shape \(3,\), expected \(4,\)"):
        node.pose(1, [0.0, 0.0, 0.2], [0.0, 0.0, 1.0])
    with terzaghi.Recorder(tmp_path / "r.mcap", terzaghi.rhex_params()) as rec:
        with pytest.raises(terzaghi.TerzaghiError, match=r"position has shape \(3,\), expected \(2,\)"):
            rec.joint_state(1, names, [0.1, 0.2, 0.3])
        with pytest.raises(terzaghi.TerzaghiError, match=r"torque has shape \(2,\), expected \(3,\)"):
            rec.wrench("/ft", 1, [1.0, 2.0, 3.0], torque=[0.0, 0.0])
