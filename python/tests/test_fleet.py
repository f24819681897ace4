"""terzaghi.fleet on a real Dask LocalCluster (on loopback) over generated recordings.

Three robots record one 20 s walk a day for 8 days (`terzaghi simulate-robot`): alpha's F/T
offset grows from zero from day 2, bravo walks on a medium 1.3 times as strong from day 3,
charlie stays as it was. The fleet is generated and diagnosed once; the other tests take a few
of its recordings.
"""

import datetime as dt
import json
import os
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

pd = pytest.importorskip("pandas")
pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

import terzaghi.fleet as fleet  # noqa: E402

from test_api import BIN, run  # noqa: E402

T0 = 1_780_000_000  # 2026-05-28 20:26:40 UTC
ROBOTS = ["alpha", "bravo", "charlie"]


def day_of(k_day):
    return dt.datetime.fromtimestamp(T0 + (k_day - 1) * 86400, dt.timezone.utc).date().isoformat()


def generate(root: Path, days=8):
    """A fleet of ``days`` days: alpha's F/T offset grows from zero from day 2 (0.15 N a day),
    bravo's medium is 1.3 times as strong from day 3, charlie stays as it was."""
    for k, robot in enumerate(ROBOTS):
        (root / robot).mkdir(parents=True, exist_ok=True)
        for day in range(1, days + 1):
            args = ["simulate-robot", "--seconds", "20", "--seed", 1000 + 100 * k + day,
                    "--start-unix-s", T0 + (day - 1) * 86400 + 3600 * k,
                    "-o", root / robot / f"{robot}_day{day:02d}.mcap"]
            if robot == "alpha" and day >= 2:
                args += ["--offset-n", f"{0.15 * (day - 1):.2f}"]
            if robot == "bravo" and day >= 3:
                args += ["--medium-scale", "1.3"]
            run(*args)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    root = tmp_path_factory.mktemp("fleet")
    generate(root)
    return root


@pytest.fixture(scope="module")
def fleet_rows(recordings):
    return fleet.diagnose_fleet(recordings, scheduler="local", workers=2,
                                table=recordings / "fleet.parquet")


def test_fleets_of_four_and_eight_days_place_each_change_on_its_day(fleet_rows):
    df = fleet_rows
    assert df["error"].isna().all() and df["recording"].nunique() == 24
    first = lambda n: df[df["start_unix_s"] < T0 + n * 86400]
    for days in (4, 8):
        judged = fleet.judge_drifts(first(days))
        got = sorted((f["robot"], f["kind"], f["day"]) for f in judged["flags"])
        assert got == [("alpha", "offset_grows", day_of(2)), ("bravo", "medium_changed", day_of(3))], (days, judged)
        assert judged["notes"] == [], (days, judged["notes"])
    # A history longer than the fleet's start allows: the changes are said to be too early to
    # judge, on their days, and never flagged a day or two late.
    judged = fleet.judge_drifts(df, min_before=3)
    assert judged["flags"] == [], judged
    early = sorted((n["robot"], n["kind"], n["day"]) for n in judged["notes"])
    assert early == [("alpha", "too_early", day_of(2)), ("bravo", "too_early", day_of(3))], judged["notes"]
    with pytest.raises(ValueError, match="min_before"):
        fleet.judge_drifts(df, min_before=0)


def test_a_fleet_of_two_days_is_too_short_and_says_so(fleet_rows, tmp_path):
    two = fleet_rows[fleet_rows["start_unix_s"] < T0 + 2 * 86400]
    judged = fleet.judge_drifts(two)
    assert judged["flags"] == []
    assert [n["robot"] for n in judged["notes"]] == ROBOTS
    for n in judged["notes"]:
        assert n["kind"] == "too_short" and n["recordings"] == 2 and n["needed"] == 3, n
        assert "2 recordings, too short to judge" in n["text"] and "3 in all" in n["text"], n
    report = fleet.write_report(two, judged["flags"], tmp_path / "two.html", judged["notes"])
    assert "too short to judge" in report.read_text()


def test_the_report_and_the_table_on_disk(fleet_rows, recordings, tmp_path):
    df = fleet_rows
    assert len(df) == 24 * 6
    flags = fleet.flag_drifts(df)
    got = sorted((f["robot"], f["kind"], f["day"]) for f in flags)
    assert got == [("alpha", "offset_grows", day_of(2)), ("bravo", "medium_changed", day_of(3))], flags
    report = fleet.write_report(df, flags, tmp_path / "fleet.html")
    text = report.read_text()
    assert "offset_grows" in text and day_of(3) in text and "<svg" in text
    # The table on disk is the table returned; appending a recording again replaces its rows.
    table = tmp_path / "fleet.parquet"
    shutil.copy(recordings / "fleet.parquet", table)
    assert len(pd.read_parquet(table)) == len(df)
    again = fleet.diagnose_fleet([("charlie", sorted((recordings / "charlie").glob("*.mcap"))[0])],
                                 workers=1, table=table)
    assert len(again) == len(df)


def test_the_table_matches_terzaghi_diagnose_per_file(fleet_rows, recordings, tmp_path):
    # One recording a robot, after its change where it has one.
    picks = [sorted((recordings / r).glob("*.mcap"))[i] for r, i in zip(ROBOTS, (4, 5, 1))]
    df = fleet_rows
    for p in picks:
        cli = json.loads(run("diagnose", p, "--out", tmp_path / p.stem, "--json"))
        rows = df[df["recording"] == str(p)].set_index("leg")
        assert sorted(rows.index) == sorted(r["leg"] for r in cli)
        for r in cli:
            row = rows.loc[r["leg"]]
            assert row["verdict"] == r["verdict"]["effect"]
            assert row["corrected_b_k"] == r["corrected_model"]["b_k"]
            assert row["corrected_a"] == r["corrected_model"]["a"]
            # The corrected values' standard deviations, from the diagnosis's folds.
            assert row["corrected_b_k_std"] == r["corrected_model_std"]["b_k"] > 0
            assert row["corrected_a_std"] == r["corrected_model_std"]["a"] > 0
            assert row["corrected_terms_std"].count("=") == row["corrected_terms"].count("=")
            assert row["sensor_offset_lift_n"] == r["signatures"]["sensor_offset"]["lift_n"]
            assert row["baseline_rmse_n"] == r["baseline"]["rmse_n"]


def test_a_corrupt_recording_is_one_error_row_and_the_rest_completes(recordings, tmp_path):
    root = tmp_path / "batch"
    (root / "alpha").mkdir(parents=True)
    for p in sorted((recordings / "alpha").glob("*.mcap"))[:2]:
        shutil.copy(p, root / "alpha" / p.name)
    bad = root / "alpha" / "alpha_broken.mcap"
    data = (recordings / "alpha" / "alpha_day05.mcap").read_bytes()
    bad.write_bytes(data[:16] + b"\x00" * 4096)
    df = fleet.diagnose_fleet(root, workers=1)
    errors = df[df["error"].notna()]
    assert len(errors) == 1 and errors.iloc[0]["recording"] == str(bad), errors
    assert "alpha_broken.mcap" in errors.iloc[0]["error"]
    assert len(df) == 2 * 6 + 1


def test_a_worker_killed_mid_run_loses_nothing(recordings):
    from distributed import Client, LocalCluster

    pairs = [(r, p) for r in ROBOTS for p in sorted((recordings / r).glob("*.mcap"))[:2]]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        killed = []

        def kill_one():
            # Once the first tasks are done, one worker dies without a word.
            deadline = time.time() + 120
            while time.time() < deadline:
                finished = client.run_on_scheduler(
                    lambda dask_scheduler: sum(
                        ts.state == "memory" for ts in dask_scheduler.tasks.values()))
                if finished >= 2:
                    os.kill(pids[0], signal.SIGKILL)
                    killed.append(pids[0])
                    return
                time.sleep(0.05)

        t = threading.Thread(target=kill_one)
        t.start()
        df = fleet.diagnose_fleet(pairs, client=client)
        t.join()
    assert killed, "no worker was killed"
    assert df["error"].isna().all() and len(df) == len(pairs) * 6
    assert df["recording"].nunique() == len(pairs)


def test_the_command_line_face_runs_the_same_code(recordings, tmp_path):
    root = tmp_path / "two"
    (root / "charlie").mkdir(parents=True)
    for p in sorted((recordings / "charlie").glob("*.mcap"))[:2]:
        shutil.copy(p, root / "charlie" / p.name)
    import sys

    out = subprocess.run(
        [sys.executable, "-m", "terzaghi.fleet", root, "--workers", "1",
         "--table", tmp_path / "t.parquet", "--report", tmp_path / "r.html"],
        capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "2 recordings, 12 rows (0 failed)" in out.stdout
    assert "not judged: charlie: 2 recordings, too short to judge" in out.stdout, out.stdout
    bad = subprocess.run([sys.executable, "-m", "terzaghi.fleet", root, "--min-before", "0"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "--min-before must be at least 1, got 0" in bad.stderr
    assert len(pd.read_parquet(tmp_path / "t.parquet")) == 12
    missing = subprocess.run([sys.executable, "-m", "terzaghi.fleet", tmp_path / "nowhere"],
                             capture_output=True, text=True)
    assert missing.returncode == 2 and "nowhere" in missing.stderr
