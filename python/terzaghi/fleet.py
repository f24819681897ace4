"""A fleet's recordings diagnosed on a Dask cluster, gathered into one table, and watched for drift.

Each recording (an MCAP session of a robot, as the node records it) is diagnosed as
``terzaghi diagnose`` would, one task per recording on a ``dask.distributed`` cluster: a
``LocalCluster`` on this machine (``scheduler="local"``), or a running scheduler's address.
Every leg of every recording is a row of one table (:func:`diagnose_fleet`); a recording that
fails to read is a row with its error, and a worker that dies has its tasks run again by Dask.
:func:`flag_drifts` finds, per robot, a sensor offset that grows and a medium that changed, with
the day each began; :func:`write_report` draws them in an HTML page.

From a shell::

    python -m terzaghi.fleet RECORDINGS_DIR --scheduler local --table fleet.parquet --report fleet.html

Needs ``dask[distributed]``, ``pandas`` and ``pyarrow`` (``pip install './python[fleet]'``).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import html
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _terzaghi, diagnose

__all__ = [
    "find_recordings",
    "diagnose_recording",
    "diagnose_fleet",
    "flag_drifts",
    "judge_drifts",
    "write_report",
    "main",
]

PathLike = Union[str, "os.PathLike[str]"]

#: The table's columns, in order.
COLUMNS = [
    "robot",
    "recording",
    "start_unix_s",
    "start_utc",
    "leg",
    "error",
    "verdict",
    "claim",
    "basis",
    "gap_closed_pct",
    "baseline_rmse_n",
    "baseline_b_k",
    "baseline_a",
    "corrected_b_k",
    "corrected_b_k_std",
    "corrected_a",
    "corrected_a_std",
    "corrected_terms",
    "corrected_terms_std",
    "sensor_offset_drag_n",
    "sensor_offset_lift_n",
    "sensor_offset_significant",
    "sensor_update_rate_hz",
    "samples",
]


def find_recordings(root: PathLike) -> List[Tuple[str, Path]]:
    """The ``.mcap`` files under ``root``, each with its robot: the name of the folder it sits
    in directly under ``root`` (``root/<robot>/.../*.mcap``), else its own file's stem."""
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such directory of recordings")
    found = []
    for path in sorted(root.rglob("*.mcap")):
        rel = path.relative_to(root)
        robot = rel.parts[0] if len(rel.parts) > 1 else path.stem
        found.append((robot, path))
    return found


def _row(robot: str, path: Path, start_s: Optional[float]) -> Dict[str, Any]:
    row: Dict[str, Any] = {c: None for c in COLUMNS}
    row.update(robot=robot, recording=str(path), start_unix_s=start_s)
    if start_s is not None:
        row["start_utc"] = _dt.datetime.fromtimestamp(start_s, _dt.timezone.utc).isoformat()
    return row


def _terms_text(terms) -> str:
    """Terms as ``effect=c1,c2;effect=c1``, each coefficient to six significant digits."""
    return ";".join(
        f"{t['effect']}=" + ",".join(f"{c:.6g}" for c in t.get("coefficients", [])) for t in terms
    )


def diagnose_recording(path: PathLike, robot: str, out: Optional[PathLike] = None) -> List[Dict[str, Any]]:
    """One recording's rows, one per leg; on any failure one row whose ``error`` says why.

    ``out`` keeps the reports (``report.json``, ``report.html``, ``corrected.yaml`` per leg);
    by default they go to a temporary directory that is removed.
    """
    path = Path(path)
    start_s = None
    try:
        start_ns, _, _ = _terzaghi.recording_info(os.fspath(path))
        start_s = None if start_ns is None else start_ns * 1e-9
        if out is None:
            with tempfile.TemporaryDirectory() as tmp:
                reports = diagnose(path, tmp)
        else:
            reports = diagnose(path, out)
    except Exception as e:  # a recording that fails is a row, never a lost batch
        row = _row(robot, path, start_s)
        row["error"] = f"{type(e).__name__}: {e}"
        return [row]
    rows = []
    for r in reports:
        row = _row(robot, path, start_s)
        verdict = r.get("verdict") or {}
        baseline = r.get("baseline") or {}
        corrected = r.get("corrected_model") or {}
        corrected_std = r.get("corrected_model_std") or {}
        offset = (r.get("signatures") or {}).get("sensor_offset") or {}
        row.update(
            leg=r.get("leg"),
            verdict=verdict.get("effect"),
            claim=verdict.get("claim"),
            basis=verdict.get("basis"),
            gap_closed_pct=verdict.get("gap_closed_pct"),
            baseline_rmse_n=baseline.get("rmse_n"),
            baseline_b_k=baseline.get("b_k"),
            baseline_a=baseline.get("a"),
            corrected_b_k=corrected.get("b_k"),
            corrected_a=corrected.get("a"),
            corrected_terms=_terms_text(corrected.get("terms", [])),
            corrected_b_k_std=corrected_std.get("b_k"),
            corrected_a_std=corrected_std.get("a"),
            corrected_terms_std=_terms_text(corrected_std.get("terms", [])),
            sensor_offset_drag_n=offset.get("drag_n"),
            sensor_offset_lift_n=offset.get("lift_n"),
            sensor_offset_significant=offset.get("significant"),
            sensor_update_rate_hz=(r.get("sensor") or {}).get("update_rate_hz"),
            samples=r.get("samples"),
        )
        rows.append(row)
    return rows


def _client(scheduler: str, workers: int, threads_per_recording: Optional[int]):
    from distributed import Client, LocalCluster

    if scheduler == "local":
        env = {}
        if threads_per_recording is not None:
            # The diagnosis runs a recording's legs in parallel on a rayon pool, by default
            # of every core: one thread per worker gives the cores to the workers instead.
            env["RAYON_NUM_THREADS"] = str(threads_per_recording)
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            env=env,
        )
        return Client(cluster), cluster
    return Client(scheduler), None


def diagnose_fleet(
    recordings: Union[PathLike, Sequence[Tuple[str, PathLike]]],
    *,
    scheduler: str = "local",
    workers: int = 2,
    table: Optional[PathLike] = None,
    client: Any = None,
    threads_per_recording: Optional[int] = None,
):
    """Diagnoses every recording as a task on a Dask cluster; returns the table (a pandas
    DataFrame, one row per recording and leg, in :data:`COLUMNS`).

    Args:
        recordings: a directory (see :func:`find_recordings`) or ``(robot, path)`` pairs.
        scheduler: ``"local"`` for a ``LocalCluster`` of ``workers`` processes on loopback, or
            a scheduler's address (``tcp://host:8786``).
        table: a Parquet file the rows are appended to (rows of a recording already in it are
            replaced); written atomically.
        client: a ``distributed.Client`` to use instead (``scheduler`` and ``workers`` unused).
        threads_per_recording: for a local cluster, the threads each worker gives one
            recording's legs (default: every core, as ``terzaghi diagnose`` does).
    """
    import pandas as pd

    if isinstance(recordings, (str, os.PathLike)):
        pairs = find_recordings(recordings)
    else:
        pairs = [(str(r), Path(p)) for r, p in recordings]
    if isinstance(workers, bool) or int(workers) != workers or workers < 1:
        raise ValueError(f"workers = {workers!r}: must be a positive whole number")
    if threads_per_recording is not None and (
        isinstance(threads_per_recording, bool)
        or int(threads_per_recording) != threads_per_recording
        or threads_per_recording < 1
    ):
        raise ValueError(
            f"threads_per_recording = {threads_per_recording!r}: must be a positive whole number"
        )
    own = client is None
    cluster = None
    if own:
        client, cluster = _client(scheduler, int(workers), threads_per_recording)
    try:
        futures = client.map(
            diagnose_recording,
            [os.fspath(p) for _, p in pairs],
            [r for r, _ in pairs],
            pure=False,
            retries=2,
        )
        results = client.gather(futures)
    finally:
        if own:
            client.close()
        if cluster is not None:
            cluster.close()
    rows = [row for rs in results for row in rs]
    df = pd.DataFrame(rows, columns=COLUMNS)
    if table is not None:
        df = append_table(df, table)
    return df


def append_table(df, table: PathLike):
    """Appends ``df`` to the Parquet file ``table`` (replacing the rows of recordings it holds
    again) and returns the whole table."""
    import pandas as pd

    table = Path(table)
    if table.exists():
        old = pd.read_parquet(table)
        old = old[~old["recording"].isin(set(df["recording"]))]
        df = pd.concat([old, df], ignore_index=True)
    df = df.sort_values(["robot", "start_unix_s", "recording", "leg"], na_position="last")
    df = df.reset_index(drop=True)
    tmp = table.with_name(table.name + ".part")
    df.to_parquet(tmp, index=False)
    os.replace(tmp, table)
    return df


def _per_recording(df, robot: str):
    """Per recording of ``robot`` (time order): its day, the median over its legs of the
    offset's size and of the medium's strength ``b_k a^(-pi/4)``."""
    d = df[(df["robot"] == robot) & df["error"].isna() & df["start_unix_s"].notna()].copy()
    if d.empty:
        return []
    d["offset_n"] = np.hypot(d["sensor_offset_drag_n"].astype(float), d["sensor_offset_lift_n"].astype(float))
    d["strength"] = d["corrected_b_k"].astype(float) * d["corrected_a"].astype(float) ** (-math.pi / 4)
    out = []
    for rec, g in d.groupby("recording"):
        out.append((float(g["start_unix_s"].iloc[0]), float(g["offset_n"].median()), float(g["strength"].median())))
    out.sort()
    return out


def _robust_sigma(x: np.ndarray) -> float:
    if len(x) < 2:
        return 0.0
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


def judge_drifts(
    df,
    *,
    min_before: int = 1,
    offset_floor_n: float = 0.05,
    strength_floor_rel: float = 0.05,
    z: float = 6.0,
) -> Dict[str, List[Dict[str, Any]]]:
    """Drifts per robot, from its recordings in time order (the median over its legs of each):

    - ``offset_grows``: the sensor offset's size (out of the medium) leaves its level of the
      recordings before, by more than ``z`` robust deviations of them and at least
      ``offset_floor_n``, and stays out; flagged at the first such recording.
    - ``medium_changed``: the medium's strength ``b_k a^(-pi/4)`` steps to another level (the
      two-level split of its logarithm with the least squared deviation), by more than ``z``
      robust deviations of the levels and ``strength_floor_rel`` of the earlier one; flagged at
      the first recording after the step.

    A change is judged with ``min_before`` recordings (at least 1) before it and two from it on
    (one to see it, one to see it stay): a robot with fewer than ``min_before + 2`` recordings is
    too short to judge, and a change found with fewer before it than ``min_before`` is not
    flagged. Neither is silent: each is a note.

    Returns ``{"flags": [...], "notes": [...]}``. A flag: robot, kind, day (UTC date of the
    recording it starts at), start_unix_s, before, after. A note: robot, kind (``too_short``
    or ``too_early``), recordings, needed, day (of a change too early to judge, else None),
    text.
    """
    if not (isinstance(min_before, int) and min_before >= 1):
        raise ValueError(f"min_before must be a whole number >= 1, got {min_before!r}")
    flags: List[Dict[str, Any]] = []
    notes: List[Dict[str, Any]] = []
    needed = min_before + 2
    for robot in sorted(set(df["robot"].dropna())):
        recs = _per_recording(df, robot)
        n = len(recs)
        if n < needed:
            notes.append(dict(
                robot=robot, kind="too_short", recordings=n, needed=needed, day=None,
                text=f"{robot}: {n} recording{'s' if n != 1 else ''}, too short to judge: a change "
                f"needs {min_before} before it and 2 from it on ({needed} in all, --min-before {min_before})",
            ))
            continue
        t = np.array([r[0] for r in recs])
        off = np.array([r[1] for r in recs])
        strength = np.array([r[2] for r in recs])
        day = lambda i: _dt.datetime.fromtimestamp(t[i], _dt.timezone.utc).date().isoformat()

        def early(kind: str, i: int) -> None:
            notes.append(dict(
                robot=robot, kind="too_early", recordings=n, needed=needed, day=day(i),
                text=f"{robot}: a {kind} from {day(i)} is not judged: {i} recording{'s' if i != 1 else ''} "
                f"before it, --min-before {min_before}",
            ))

        # An offset that grows: from the first recording that leaves the earlier level and
        # never comes back to it, with two recordings from it on.
        for i in range(1, n - 1):
            base = off[:i]
            level = float(np.median(base))
            limit = max(z * _robust_sigma(base), offset_floor_n)
            after = off[i:]
            if np.all(after - level > limit):
                if i < min_before:
                    early("offset_grows", i)
                else:
                    flags.append(dict(robot=robot, kind="offset_grows", day=day(i),
                                      start_unix_s=float(t[i]), before=level, after=float(after[-1])))
                break
        # A medium that changed: the two-level split of log strength that leaves the least
        # squared deviation (two recordings from it on), judged by its contrast against the
        # levels' own scatter.
        ls = np.log(strength)
        best = None
        for i in range(1, n - 1):
            a, b = ls[:i], ls[i:]
            sse = float(((a - a.mean()) ** 2).sum() + ((b - b.mean()) ** 2).sum())
            if best is None or sse < best[0]:
                best = (sse, i)
        if best is not None:
            _, i = best
            a, b = ls[:i], ls[i:]
            spread = math.sqrt((_robust_sigma(a) ** 2 + _robust_sigma(b) ** 2) / 2) + 1e-12
            step = float(np.median(b) - np.median(a))
            if abs(step) / spread > z and abs(math.expm1(step)) > strength_floor_rel:
                if i < min_before:
                    early("medium_changed", i)
                else:
                    flags.append(dict(robot=robot, kind="medium_changed", day=day(i),
                                      start_unix_s=float(t[i]), before=float(np.exp(np.median(a))),
                                      after=float(np.exp(np.median(b)))))
    return dict(flags=flags, notes=notes)


def flag_drifts(df, **kwargs) -> List[Dict[str, Any]]:
    """The flags of :func:`judge_drifts` (same arguments); its notes say what it could not
    judge."""
    return judge_drifts(df, **kwargs)["flags"]


def _svg_series(points: List[Tuple[float, float]], flags_t: List[float], title: str, unit: str) -> str:
    w, h, pad = 520, 160, 40
    if not points:
        return ""
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    x0, x1 = min(xs), max(xs) if max(xs) > min(xs) else min(xs) + 1
    y0, y1 = min(ys + [0.0]), max(ys)
    if y1 <= y0:
        y1 = y0 + 1
    sx = lambda x: pad + (x - x0) / (x1 - x0) * (w - 2 * pad)
    sy = lambda y: h - pad / 2 - (y - y0) / (y1 - y0) * (h - pad)
    line = " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in points)
    marks = "".join(
        f'<line x1="{sx(x):.1f}" y1="{pad / 2}" x2="{sx(x):.1f}" y2="{h - pad / 2}" stroke="#c00" stroke-dasharray="4"/>'
        for x in flags_t
    )
    dots = "".join(f'<circle cx="{sx(x):.1f}" cy="{sy(y):.1f}" r="2.5"/>' for x, y in points)
    return (
        f'<svg width="{w}" height="{h}" xmlns="http://www.w3.org/2000/svg" font-size="11">'
        f'<text x="{pad}" y="12">{html.escape(title)} ({html.escape(unit)}): {y0:.3g} to {y1:.3g}</text>'
        f'<polyline fill="none" stroke="#246" points="{line}"/>{dots}{marks}</svg>'
    )


def write_report(df, flags: List[Dict[str, Any]], path: PathLike,
                 notes: Optional[List[Dict[str, Any]]] = None) -> Path:
    """An HTML page: the flags, what could not be judged (``notes`` of :func:`judge_drifts`),
    each robot's offset and medium over time (flags marked), each leg's verdicts, and the
    recordings that failed."""
    path = Path(path)
    parts = ["<!doctype html><meta charset='utf-8'><title>terzaghi fleet report</title>",
             "<h1>Fleet report</h1>"]
    ok = df[df["error"].isna()]
    parts.append(
        f"<p>{df['recording'].nunique()} recordings of {df['robot'].nunique()} robots; "
        f"{len(ok)} legs diagnosed; {int(df['error'].notna().sum())} recordings failed.</p>"
    )
    parts.append("<h2>Flags</h2>")
    if flags:
        parts.append("<table border=1><tr><th>robot</th><th>drift</th><th>from</th><th>before</th><th>after</th></tr>")
        for f in flags:
            parts.append(
                f"<tr><td>{html.escape(f['robot'])}</td><td>{f['kind']}</td><td>{f['day']}</td>"
                f"<td>{f['before']:.4g}</td><td>{f['after']:.4g}</td></tr>"
            )
        parts.append("</table>")
    else:
        parts.append("<p>No drift.</p>")
    if notes:
        parts.append("<h2>Not judged</h2><ul>")
        for note in notes:
            parts.append(f"<li>{html.escape(note['text'])}</li>")
        parts.append("</ul>")
    for robot in sorted(set(df["robot"].dropna())):
        recs = _per_recording(df, robot)
        parts.append(f"<h2>{html.escape(robot)}</h2>")
        days = [(r[0] - recs[0][0]) / 86400.0 for r in recs] if recs else []
        ft = [(f["start_unix_s"] - recs[0][0]) / 86400.0 for f in flags if f["robot"] == robot] if recs else []
        parts.append(_svg_series(list(zip(days, [r[1] for r in recs])), ft, "F/T offset, median over legs, by day", "N"))
        parts.append(_svg_series(list(zip(days, [r[2] for r in recs])), ft, "medium strength b_k a^(-pi/4), by day", "1"))
        legs = ok[ok["robot"] == robot].groupby(["leg", "verdict"]).size().reset_index(name="recordings")
        parts.append(legs.to_html(index=False))
    bad = df[df["error"].notna()]
    if not bad.empty:
        parts.append("<h2>Recordings that failed</h2>")
        parts.append(bad[["robot", "recording", "error"]].to_html(index=False))
    tmp = path.with_name(path.name + ".part")
    tmp.write_text("\n".join(parts), encoding="utf-8")
    os.replace(tmp, path)
    return path


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m terzaghi.fleet``: diagnose a directory of recordings on Dask."""
    p = argparse.ArgumentParser(
        prog="python -m terzaghi.fleet",
        description="Diagnose every MCAP recording under DIR (DIR/<robot>/*.mcap) on a Dask cluster, "
        "append the rows to a Parquet table, and write a fleet report that flags drifts.",
    )
    p.add_argument("dir", help="directory of recordings, one folder per robot")
    p.add_argument("--scheduler", default="local",
                   help="'local' (a LocalCluster on loopback) or a scheduler's address (tcp://host:8786)")
    p.add_argument("--workers", type=int, default=2, help="workers of the local cluster (default 2)")
    p.add_argument("--threads-per-recording", type=int, default=None,
                   help="threads each local worker gives one recording's legs (default: every core)")
    p.add_argument("--table", default="fleet.parquet", help="Parquet table to append to (default fleet.parquet)")
    p.add_argument("--report", default="fleet.html", help="HTML report to write (default fleet.html)")
    p.add_argument("--min-before", type=int, default=1,
                   help="recordings a robot needs before a change to judge it (default 1; "
                   "a robot needs this many plus 2)")
    a = p.parse_args(argv)
    if a.min_before < 1:
        p.error(f"--min-before must be at least 1, got {a.min_before}")
    try:
        df = diagnose_fleet(a.dir, scheduler=a.scheduler, workers=a.workers, table=a.table,
                            threads_per_recording=a.threads_per_recording)
    except (FileNotFoundError, ValueError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    judged = judge_drifts(df, min_before=a.min_before)
    flags, notes = judged["flags"], judged["notes"]
    write_report(df, flags, a.report, notes)
    failed = int(df["error"].notna().sum())
    print(f"{df['recording'].nunique()} recordings, {len(df)} rows ({failed} failed) -> {a.table}; report {a.report}")
    for f in flags:
        print(f"flag: {f['robot']}: {f['kind']} from {f['day']} ({f['before']:.4g} -> {f['after']:.4g})")
    for note in notes:
        print(f"not judged: {note['text']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
