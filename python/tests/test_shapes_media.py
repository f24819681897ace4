"""Polyline legs and medium files from Python, against the binary's node on the same inputs."""

import csv
import json

import numpy as np
import pytest

import terzaghi
from terzaghi.batch import LegBatch
from test_api import REPO, run

RUNS = sorted((REPO / "tests" / "data" / "real-plate-sinkage").glob("plate_smallbox_run*_D*mm.csv"))


def half_circle(chord_m, segments=32):
    """A half circle on the chord from the hip to the tip, its convex side toward the travel:
    the points the node's ``shape: c_leg`` integrates (written here from the geometry)."""
    r = chord_m / 2
    ang = np.pi - np.pi * np.arange(segments + 1) / segments
    return np.column_stack([r + r * np.cos(ang), r * np.sin(ang)])


def test_a_polyline_leg_is_the_c_leg_when_its_points_are():
    beta = np.radians(np.arange(-60.0, 240.0, 7.0))
    leg = dict(length_m=0.1, width_m=0.025, hip_height_m=0.02, medium="poppy_lp", model="rft",
               rft_elements=96)
    c = terzaghi.predict(beta, shape="c_leg", **leg)
    p = terzaghi.predict(beta, shape="polyline", profile=half_circle(0.1), **leg)
    assert np.count_nonzero(c["lift_n"]) > 10
    for k in ("drag_n", "lift_n", "hip_torque_nm"):
        np.testing.assert_allclose(p[k], c[k], rtol=1e-9, atol=1e-12)
    # The batch takes it too.
    b = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp", model="rft", rft_elements=96,
                 shape="polyline", profile=half_circle(0.1))
    d, l, t = b.forces(beta, np.full(beta.shape, 0.02))
    np.testing.assert_allclose(l, c["lift_n"], rtol=1e-9, atol=1e-12)


def test_a_polyline_leg_predicts_what_the_node_predicts():
    # The node's own code for a leg of shape polyline, at its configured hip height.
    line = np.array([[0.0, 0.0], [0.04, 0.012], [0.08, 0.01], [0.1, -0.005]])
    params = {"model": "rft", "legs": ["leg"], "leg.joint": "hip", "leg.length_m": 0.1,
              "leg.width_m": 0.03, "leg.hip_height_m": 0.03, "leg.medium": "poppy_lp",
              "leg.shape": "polyline", "leg.profile": [float(v) for v in line.ravel()],
              "rft_elements": 90}
    node = terzaghi.Node(params=params)
    beta = np.radians(np.arange(10.0, 170.0, 5.0))
    mine = terzaghi.predict(beta, length_m=0.1, width_m=0.03, hip_height_m=0.03, medium="poppy_lp",
                            model="rft", shape="polyline", profile=line, rft_elements=90)
    lift = []
    for k, b in enumerate(beta):
        # Turning forward at 2 rad/s about a still hip: each element moves along its own normal,
        # as the quasi-static prediction has it.
        f = node.joint_state(10**9 + k * 10**7, ["hip"], [b], [2.0])
        lift.append(f["lift_n"][0])
    assert np.count_nonzero(mine["lift_n"]) > 10
    np.testing.assert_allclose(lift, mine["lift_n"], rtol=1e-9, atol=1e-12)
    # A leg the node does not have is refused by name or index, never an IndexError.
    for bad in ("nope", -1, 1):
        with pytest.raises(terzaghi.TerzaghiError, match="leg"):
            node.wrench(bad, 10**9, (0.0, 0.0, 1.0))


def test_a_bad_profile_is_refused_by_name():
    leg = dict(length_m=0.1, width_m=0.025, hip_height_m=0.02, medium="poppy_lp", model="rft")
    with pytest.raises(terzaghi.TerzaghiError, match="profile"):
        terzaghi.predict(0.5, shape="polyline", **leg)
    with pytest.raises(terzaghi.TerzaghiError, match="coincide"):
        terzaghi.predict(0.5, shape="polyline", profile=[(0, 0), (0, 0), (0.1, 0)], **leg)
    with pytest.raises(terzaghi.TerzaghiError, match="RFT only"):
        terzaghi.predict(0.5, shape="polyline", profile=half_circle(0.1),
                         **{**leg, "model": "improved"})


@pytest.fixture(scope="module")
def medium_file(tmp_path_factory):
    """The medium calibrated on the shared runs of the 60 and 100 mm plates."""
    path = tmp_path_factory.mktemp("medium") / "without_80.yaml"
    run("calibrate", *[r for r in RUNS if "D80mm" not in r.name], "--law", "depth_width_power",
        "-o", path)
    return path


def test_a_medium_file_predicts_a_plate_pushed_down_as_the_node_does(medium_file, tmp_path):
    # A plate of 80 mm pushed down 30 mm at 1 mm/s, then held: through the binary's replay of a
    # CSV force log with a moving hip (the node's code), and through predict.
    t = np.arange(0.0, 40.0, 0.1)
    depth = np.minimum(t * 1e-3, 0.03)
    log = tmp_path / "push.csv"
    np.savetxt(log, np.column_stack([t, 0 * t, 0 * t, 0 * t, -depth]), delimiter=",",
               header="t_s,beta_rad,drag_n,lift_n,hip_height_m", comments="", fmt="%.9g")
    params = tmp_path / "plate.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    model: sinkage\n    legs: [plate]\n    plate:\n"
        "      joint: plate_joint\n      width_m: 0.08\n      hip_height_m: 0.0\n"
        f"      medium: {medium_file}\n      ft_topic: /plate/ft\n")
    rows = terzaghi.session_rows(log, params_file=params, params={"use_identified": False})["plate"]
    up = np.gradient(-depth, t)
    mine = terzaghi.predict(0.0, width_m=0.08, hip_height_m=-depth, up_m_s=up, model="sinkage",
                            medium_file=medium_file)
    assert mine["lift_n"].shape == t.shape and mine["lift_n"].max() > 50.0
    np.testing.assert_allclose(mine["lift_n"], rows["predicted_lift_n"], rtol=1e-9, atol=1e-9)
    # Loading while it moves down, unloading once held.
    names = [terzaghi.REGIMES[c] for c in mine["regime"]]
    assert names[100] == "penetration" and names[-1] == "unloading"
    # The batch takes the medium file too.
    b = LegBatch(length_m=0.08, width_m=0.08, model="sinkage", medium_file=medium_file)
    _, l, _ = b.forces(np.zeros_like(t), -depth, up_m_s=up)
    np.testing.assert_allclose(l, mine["lift_n"], rtol=1e-12)


def test_a_medium_file_is_refused_where_it_does_not_apply(medium_file, tmp_path):
    with pytest.raises(terzaghi.TerzaghiError, match="plate-sinkage law"):
        terzaghi.predict(0.5, length_m=0.1, width_m=0.025, hip_height_m=0.0,
                         medium_file=medium_file)
    with pytest.raises(terzaghi.TerzaghiError, match="needs a medium file"):
        terzaghi.predict(0.0, width_m=0.08, hip_height_m=-0.01, model="sinkage")
    bad = tmp_path / "bad.yaml"
    bad.write_text(medium_file.read_text().replace("unit_weight_n_m3:", "unit_weight_n_m3: .nan #", 1))
    with pytest.raises(terzaghi.TerzaghiError, match="unit weight .* NaN"):
        terzaghi.predict(0.0, width_m=0.08, hip_height_m=-0.01, model="sinkage", medium_file=bad)


def test_polylines_and_medium_files_equal_the_binarys_predict(medium_file):
    import json

    line = [(0.0, 0.0), (0.05, 0.02), (0.1, 0.0)]
    flat = ",".join(f"{v}" for p in line for v in p)
    cli = json.loads(run("predict", "--model", "rft", "--medium", "poppy_lp", "--shape", "polyline",
                         "--profile", flat, "--length-m", "0.1", "--width-m", "0.03",
                         "--hip-height-m", "0.02", "--beta-deg", "0:180:5", "--format", "json"))
    mine = terzaghi.predict(np.radians([r["beta_deg"] for r in cli]), length_m=0.1, width_m=0.03,
                            hip_height_m=0.02, medium="poppy_lp", model="rft", shape="polyline",
                            profile=line)
    assert sum(r["lift_n"] != 0 for r in cli) > 10
    np.testing.assert_allclose(mine["lift_n"], [r["lift_n"] for r in cli], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(mine["drag_n"], [r["drag_n"] for r in cli], rtol=1e-12, atol=1e-12)
    cli = json.loads(run("predict", "--model", "sinkage", "--medium-file", medium_file,
                         "--length-m", "0.08", "--width-m", "0.08", "--hip-height-m", "0",
                         "--depth-m", "0:0.03:0.001", "--format", "json"))
    depth = np.array([r["depth_m"] for r in cli])
    mine = terzaghi.predict(0.0, width_m=0.08, hip_height_m=-depth, up_m_s=-1e-3, model="sinkage",
                            medium_file=medium_file)
    np.testing.assert_allclose(mine["lift_n"], [r["lift_n"] for r in cli], rtol=1e-12, atol=1e-12)
    assert [terzaghi.REGIMES[c] for c in mine["regime"]] == [r["regime"] for r in cli]


def test_an_rft_leg_takes_a_medium_files_law_in_depth(tmp_path):
    import json

    law = tmp_path / "rft_law.yaml"
    run("calibrate", *RUNS, "--law", "rft_depth_power", "-o", law)
    leg = dict(length_m=0.1, width_m=0.03, hip_height_m=0.02, model="rft", shape="c_leg")
    beta = np.radians(np.arange(0.0, 181.0, 5.0))
    mine = terzaghi.predict(beta, medium_file=law, **leg)
    cli = json.loads(run("predict", "--model", "rft", "--medium-file", law, "--shape", "c-leg",
                         "--length-m", "0.1", "--width-m", "0.03", "--hip-height-m", "0.02",
                         "--beta-deg", "0:180:5", "--format", "json"))
    np.testing.assert_allclose(mine["lift_n"], [r["lift_n"] for r in cli], rtol=1e-12, atol=1e-12)
    # The calibrated sand is several times RFT's poppy_lp at these depths.
    plain = terzaghi.predict(beta, medium="poppy_lp", **leg)
    deep = plain["lift_n"] > 1.0
    assert deep.sum() > 5
    assert np.all(mine["lift_n"][deep] > 2.0 * plain["lift_n"][deep])
    with pytest.raises(terzaghi.TerzaghiError, match="rft_depth_power"):
        other = tmp_path / "power.yaml"
        run("calibrate", *RUNS, "--law", "depth_width_power", "-o", other)
        terzaghi.predict(beta, medium_file=other, **leg)


DEM_MEDIUM = REPO / "tests" / "dem" / "campaign" / "medium_from_intrusions.yaml"


def test_a_medium_files_measured_rft_shape_reaches_predict_and_the_batch():
    """A medium file calibrated from the DEM bed's intrusion tests carries its own RFT shape:
    predict and LegBatch use it, equal to the binary to 1e-12, and it is not poppy_lp's shape."""
    import json

    leg = dict(length_m=0.1, width_m=0.03, hip_height_m=0.04, model="rft", shape="c_leg")
    beta = np.radians(np.arange(-20.0, 200.0, 5.0))
    mine = terzaghi.predict(beta, medium_file=DEM_MEDIUM, **leg)
    cli = json.loads(run("predict", "--model", "rft", "--medium-file", DEM_MEDIUM, "--shape", "c-leg",
                         "--length-m", "0.1", "--width-m", "0.03", "--hip-height-m", "0.04",
                         "--beta-deg", "-20:195:5", "--format", "json"))
    assert len(cli) == beta.size
    for k in ("drag_n", "lift_n", "hip_torque_nm"):
        np.testing.assert_allclose(mine[k], [r[k] for r in cli], rtol=1e-12, atol=1e-12)
    b = LegBatch(length_m=0.1, width_m=0.03, model="rft", shape="c_leg", medium_file=DEM_MEDIUM)
    d, l, t = b.forces(beta, np.full(beta.shape, 0.04))
    np.testing.assert_allclose(d, mine["drag_n"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(l, mine["lift_n"], rtol=1e-12, atol=1e-12)
    # The node's core naming the file: turning slower than the shape's reference speed (0.2
    # rad/s, at most 0.02 m/s at the tip), it predicts the quasi-static forces.
    params = {"model": "rft", "legs": ["leg"], "leg.joint": "hip", "leg.length_m": 0.1,
              "leg.width_m": 0.03, "leg.hip_height_m": 0.04, "leg.medium": str(DEM_MEDIUM),
              "leg.shape": "c_leg"}
    node = terzaghi.Node(params=params)
    # 5 deg apart at 0.2 rad/s: the stamps agree with the rate given.
    step_ns = int(round(np.radians(5.0) / 0.2 * 1e9))
    got = [node.joint_state(10**9 + k * step_ns, ["hip"], [b], [0.2]) for k, b in enumerate(beta)]
    np.testing.assert_allclose([g["drag_n"][0] for g in got], mine["drag_n"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([g["lift_n"][0] for g in got], mine["lift_n"], rtol=1e-12, atol=1e-12)
    # A coefficient set named beside a measured shape is refused, naming both.
    with pytest.raises(terzaghi.TerzaghiError, match="carries its own RFT shape"):
        terzaghi.predict(beta, medium_file=DEM_MEDIUM, rft_coeffs="poppy_lp", **leg)


LAWS = ["terzaghi_footing", "bekker", "reece", "rft_depth_power", "depth_width_power"]


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("runs", ["all", "60mm"])
def test_every_law_calibrate_writes_is_read_with_its_band(law, runs, tmp_path):
    """Each law ``terzaghi calibrate`` fits (on the shared runs, where Bekker's ``k_c`` and
    Terzaghi's ``N_gamma`` sit on their bound 0, and on the three 60 mm runs alone) is read by
    Python's predict, by the node's code replaying a log with it as the leg's medium, and, for
    the RFT law, by Python's steady: the forces and their band are the binary's."""
    tests = RUNS if runs == "all" else [r for r in RUNS if "D60mm" in r.name]
    path = tmp_path / f"{law}.yaml"
    run("calibrate", *tests, "--law", law, "-o", path)
    depth = np.array([0.005, 0.01, 0.02])
    mine = terzaghi.predict(0.0, width_m=0.06, hip_height_m=-depth, up_m_s=-1e-3, model="sinkage",
                            medium_file=path, band=True)
    cli = json.loads(run("predict", "--model", "sinkage", "--medium-file", path, "--length-m",
                         "0.06", "--width-m", "0.06", "--hip-height-m", "0", "--depth-m",
                         "0.005:0.02:0.005", "--band", "--format", "json"))
    cli = [r for r in cli if any(abs(r["depth_m"] - d) < 1e-9 for d in depth)]
    for k in ("lift_n", "lift_low_n", "lift_high_n"):
        np.testing.assert_allclose(mine[k], [r[k] for r in cli], rtol=1e-9, err_msg=k)
    assert np.all(mine["lift_low_n"] < mine["lift_n"]) and np.all(mine["lift_n"] < mine["lift_high_n"])
    # Replayed through the node's code (a CSV force log of a plate pushed down, as
    # terzaghi replay --reevaluate takes it), with the file as the leg's medium.
    t = np.arange(0.0, 20.0, 0.1)
    d = np.minimum(t * 1e-3, 0.015)
    log = tmp_path / "push.csv"
    np.savetxt(log, np.column_stack([t, 0 * t, 0 * t, 0 * t, -d]), delimiter=",",
               header="t_s,beta_rad,drag_n,lift_n,hip_height_m", comments="", fmt="%.9g")
    params = tmp_path / "plate.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    model: sinkage\n    legs: [plate]\n    plate:\n"
        "      joint: plate_joint\n      width_m: 0.06\n      hip_height_m: 0.0\n"
        f"      medium: {path}\n      ft_topic: /plate/ft\n")
    rows = terzaghi.session_rows(log, params_file=params, params={"use_identified": False})["plate"]
    assert np.all(np.isfinite(rows["predicted_lift_n"])) and rows["predicted_lift_n"].max() > 10.0
    if law == "rft_depth_power":
        runs_csv = tmp_path / "runs.csv"
        runs_csv.write_text("load_n,hub_vx_m_s,omega_rad_s,slip_angle_deg\n20,0.01,0.1,0\n")
        out = tmp_path / "steady.csv"
        run("steady", runs_csv, "--radius-m", "0.058", "--width-m", "0.05", "--medium-file", path,
            "--band", "-o", out)
        with open(out) as f:
            row = next(csv.DictReader(f))
        py = terzaghi.steady(20.0, 0.01, 0.1, 0.0, radius_m=0.058, width_m=0.05,
                             medium_file=path, band=True)
        for k in ("sinkage_m", "sinkage_low_m", "sinkage_high_m", "drawbar_low_n", "drawbar_high_n"):
            np.testing.assert_allclose(py[k], float(row[k]), rtol=1e-12, err_msg=k)
        # The softer sand of the band's low end sinks deeper.
        assert py["sinkage_low_m"] > py["sinkage_m"] > py["sinkage_high_m"]


def test_a_band_needs_a_file_that_has_one(tmp_path):
    """Two trials tell no band: asked for one, Python refuses, naming the file and why."""
    path = tmp_path / "two.yaml"
    run("calibrate", *[r for r in RUNS if "D60mm" in r.name][:2], "--law", "rft_depth_power",
        "-o", path)
    with pytest.raises(terzaghi.TerzaghiError, match=r"two.yaml has no trial-to-trial scatter"):
        terzaghi.predict(0.0, width_m=0.06, hip_height_m=-0.01, model="sinkage",
                         medium_file=path, band=True)
    with pytest.raises(terzaghi.TerzaghiError, match="goes with medium_file"):
        terzaghi.predict(0.5, length_m=0.1, width_m=0.02, hip_height_m=0.0, medium="poppy_lp",
                         band=True)
