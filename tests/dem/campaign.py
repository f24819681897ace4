#!/usr/bin/env python3
"""The DEM testbed's campaign: a flat plate (and a C-shaped leg) rotating through a bed of
polydisperse spheres simulated by LIGGGHTS, with the checks that make it believable, the RFT
calibration from intrusions in the same medium, and controlled variations of the physics.

Every run is an input to the engine (the .in scenes beside this file); this script only writes
those inputs, runs the engine, and turns its outputs into the project's conventions (drag, lift
and hip torque in the hip frame, the attack angle beta) as one CSV per run, which
`terzaghi import-dem` turns into a ROS 2 MCAP session.

    python3 tests/dem/campaign.py --out tests/dem/campaign           # the whole campaign
    python3 tests/dem/campaign.py --out /tmp/small --scene small      # the small scene of the test
    python3 tests/dem/campaign.py --out tests/dem/campaign --rft      # the RFT calibration again
    python3 tests/dem/campaign.py --out tests/dem/campaign --rft-speed  # its intrusions at speed
    python3 tests/dem/campaign.py --out tests/dem/campaign --rft-entry  # ... into, across and out of the bed
    python3 tests/dem/campaign.py --out tests/dem/campaign --intrusion-tests  # the same as calibration tests
    python3 tests/dem/campaign.py --out tests/dem/campaign --side-force  # a box foot at slip angles

Needs `liggghts` (Debian: apt-get install liggghts) and, for the sessions, the terzaghi binary
(--terzaghi, default target/release/terzaghi). Standard library only.
"""

import argparse
import concurrent.futures as cf
import json
import math
import os
import random
import shutil
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
G = 9.81

# The grains and the contact law (material.in). Soft grains (E = 5 MPa) keep the time step
# large; the checks below show what halving it does.
MATERIAL = {
    "E": 5e6,
    "nu": 0.3,
    "e_rest": 0.3,
    "mu": 0.5,
    "mu_wall": 0.35,
    "mu_roll": 0.1,
    "ced": 0.0,
    "rho": 2500.0,
}

SCENES = {
    # The campaign's scene.
    "full": {
        "r": 0.003,
        "dt": 6e-5,
        "length_m": 0.10,
        "width_m": 0.03,
        "hip_height_m": 0.04,
        "widths_m": [0.02, 0.03, 0.04],
        "hips_m": [0.04, 0.055],
        "hx": 0.13,
        "hy": 0.045,
        "depth": 0.09,
        "omega": 1.0,
        "settle_s": 0.25,
        "thickness": 0.003,
    },
    # The test's scene: big grains, a short plate, a fast stroke; about ten seconds.
    "small": {
        "r": 0.005,
        "dt": 8e-5,
        "length_m": 0.06,
        "width_m": 0.03,
        "hip_height_m": 0.02,
        "widths_m": [0.03],
        "hips_m": [0.02],
        "hx": 0.08,
        "hy": 0.04,
        "depth": 0.06,
        "omega": 4.0,
        "settle_s": 0.15,
        "thickness": 0.003,
    },
}

SAMPLE_HZ = 500.0
# A bed is settled when its kinetic energy is below this fraction of N m g d (every grain's
# weight lifted by one diameter).
SETTLED_KE_RATIO = 1e-4


def engine_version():
    try:
        out = subprocess.run(
            ["dpkg-query", "-W", "-f=${Version}", "liggghts"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        return "LIGGGHTS-PUBLIC (Debian package liggghts %s)" % out
    except (OSError, subprocess.CalledProcessError):
        return "LIGGGHTS (version unknown)"


# ---------------------------------------------------------------------------------------------
# Meshes


def panel(a, b_pt, width, thick):
    """The 12 triangles of a thin box whose mid-line runs from a to b (points in the x-z plane),
    `width` along y and `thick` across the line."""
    ax, az = a
    bx, bz = b_pt
    lx, lz = bx - ax, bz - az
    n = math.hypot(lx, lz)
    nx, nz = -lz / n * thick / 2, lx / n * thick / 2
    v = []
    for (px, pz) in ((ax, az), (bx, bz)):
        for s in (-1, 1):
            for y in (-width / 2, width / 2):
                v.append((px + s * nx, y, pz + s * nz))
    # v index: end*4 + side*2 + y
    quads = [
        (0, 1, 3, 2),  # hip end
        (4, 6, 7, 5),  # tip end
        (0, 4, 5, 1),  # side -
        (2, 3, 7, 6),  # side +
        (0, 2, 6, 4),  # y -
        (1, 5, 7, 3),  # y +
    ]
    tris = []
    for q in quads:
        tris.append((v[q[0]], v[q[1]], v[q[2]]))
        tris.append((v[q[0]], v[q[2]], v[q[3]]))
    return tris


def write_stl(path, tris):
    with open(path, "w") as f:
        f.write("solid leg\n")
        for t in tris:
            f.write(" facet normal 0 0 0\n  outer loop\n")
            for p in t:
                f.write("   vertex %.9g %.9g %.9g\n" % p)
            f.write("  endloop\n endfacet\n")
        f.write("endsolid leg\n")


def leg_polyline(shape, length, beta, hip_z):
    """The leg's mid-line at attack angle beta, hip at (0, hip_z). A flat plate runs from the hip
    along u = (-cos beta, -sin beta); a C-leg is a half circle on the chord u * length, its
    convex side toward the travel n = (sin beta, -cos beta)."""
    ux, uz = -math.cos(beta), -math.sin(beta)
    nx, nz = math.sin(beta), -math.cos(beta)
    if shape == "flat":
        pts = [(0.0, 0.0), (length, 0.0)]
    else:
        k = 16
        pts = [
            (length / 2 * (1 - math.cos(math.pi * i / k)), length / 2 * math.sin(math.pi * i / k))
            for i in range(k + 1)
        ]
    return [(s * ux + q * nx, hip_z + s * uz + q * nz) for (s, q) in pts]


def leg_tris(shape, length, width, thick, beta, hip_z):
    pts = leg_polyline(shape, length, beta, hip_z)
    tris = []
    for a, b_pt in zip(pts, pts[1:]):
        tris += panel(a, b_pt, width, thick)
    return tris


# ---------------------------------------------------------------------------------------------
# Running the engine


class EngineError(Exception):
    pass


def run_engine(scene, variables, workdir, name, raw_lines=()):
    """Writes `name`.in (the variables, then the scene) and runs LIGGGHTS on it. Returns the
    lines its print commands wrote, as {KEY: value}."""
    lines = ["variable dir string %s" % HERE]
    for k, v in variables.items():
        if isinstance(v, str):
            lines.append("variable %s string %s" % (k, v))
        else:
            lines.append("variable %s equal %.12g" % (k, v))
    lines += list(raw_lines)
    with open(os.path.join(HERE, scene)) as f:
        body = f.read()
    path = os.path.join(workdir, name + ".in")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n" + body)
    log = os.path.join(workdir, name + ".log")
    p = subprocess.run(
        # Not `-screen none`: this build crashes in write_restart without a screen.
        ["liggghts", "-in", path, "-log", log, "-echo", "none"],
        cwd=workdir,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        errors="replace",
    )
    text = open(log, errors="replace").read() if os.path.exists(log) else ""
    if p.returncode != 0 or "ERROR" in text:
        err = [l for l in text.splitlines() if "ERROR" in l] or [p.stderr.strip()[-500:]]
        raise EngineError("%s: LIGGGHTS failed: %s (log: %s)" % (name, err[0], log))
    out = {}
    for line in text.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0].isupper() and "_" in parts[0]:
            out[parts[0]] = parts[1]
    return out


def read_dump(path):
    """id radius x y z ... rows of a LIGGGHTS custom dump."""
    rows = []
    with open(path) as f:
        lines = f.read().splitlines()
    i = lines.index(next(l for l in lines if l.startswith("ITEM: ATOMS")))
    for l in lines[i + 1 :]:
        if l.strip():
            rows.append([float(x) for x in l.split()])
    return rows


def read_ave_time(path):
    """Rows of a fix ave/time file: step, then the values."""
    rows = []
    with open(path) as f:
        for l in f:
            if l.startswith("#") or not l.strip():
                continue
            rows.append([float(x) for x in l.split()])
    return rows


# ---------------------------------------------------------------------------------------------
# The bed


# The fill seed of the campaign's beds; the diagnosis part levels the bed again with others.
BED_SEED = 86028121


def make_bed(cfg, name, workdir, hx=None, hy=None, depth=None, mu_fill=None, seed=BED_SEED):
    hx = hx or cfg["hx"]
    hy = hy or cfg["hy"]
    depth = depth or cfg["depth"]
    r = cfg["r"]
    v = engine_vars(
        cfg,
        seed=seed,
        hx=hx,
        hy=hy,
        depth=depth,
        fill_h=depth * 2.0,
        # Room above the bed for a leg swinging back over the top between strokes.
        zmax=max(depth * 2.1, depth + max(cfg["hips_m"]) + cfg["length_m"] + 0.03),
        mu_fill=MATERIAL["mu"] if mu_fill is None else mu_fill,
        settle_s=cfg["settle_s"],
        out=name,
    )
    t0 = time.time()
    printed = run_engine("bed.in", v, workdir, name)
    grains = read_dump(os.path.join(workdir, name + ".grains"))
    bed = measure_bed(grains, hx, hy, r)
    ke = float(printed["BED_KE_J"])
    n = len(grains)
    mean_mass = sum(MATERIAL["rho"] * 4 / 3 * math.pi * g[1] ** 3 for g in grains) / n
    bed.update(
        name=name,
        restart=os.path.join(workdir, name + ".restart"),
        hx=hx,
        hy=hy,
        depth=depth,
        mu_fill=v["mu_fill"],
        seed=seed,
        grains=n,
        kinetic_energy_j=ke,
        settled_ke_ratio=ke / (n * mean_mass * G * 2 * r),
        seconds=round(time.time() - t0, 1),
    )
    return bed


def measure_bed(grains, hx, hy, r):
    """Surface height (median over 1 cm cells of the highest grain top, away from the walls) and
    the solid fraction of the interior (2 diameters from every wall, the floor and the surface)."""
    cell = 0.01
    tops = {}
    for g in grains:
        _, rad, x, y, z = g[:5]
        if abs(x) > hx - 4 * r or abs(y) > hy - 4 * r:
            continue
        key = (int((x + hx) / cell), int((y + hy) / cell))
        tops[key] = max(tops.get(key, -1.0), z + rad)
    surf = sorted(tops.values())
    surface_z = surf[len(surf) // 2]
    m = 4 * r
    x0, x1, y0, y1, z0, z1 = -hx + m, hx - m, -hy + m, hy - m, m, surface_z - m
    vol = 0.0
    for g in grains:
        _, rad, x, y, z = g[:5]
        if x0 < x < x1 and y0 < y < y1 and z0 < z < z1:
            vol += 4 / 3 * math.pi * rad ** 3
    frac = vol / ((x1 - x0) * (y1 - y0) * (z1 - z0))
    return {
        "surface_z_m": surface_z,
        "surface_spread_m": surf[int(len(surf) * 0.9)] - surf[int(len(surf) * 0.1)],
        "solid_fraction": frac,
        "unit_weight_n_m3": MATERIAL["rho"] * G * frac,
    }


def surface_slope(grains, r, what, x_max=float("inf")):
    """The slope of a heap's free surface: the highest grain top in columns two radii wide (left
    of x_max), fitted by least squares between 20 % and 80 % of the heap's height. Returns the
    slope and the number of columns fitted."""
    bins = {}
    w = 2 * r
    for g in grains:
        _, rad, x, _, z = g[:5]
        k = int(x / w)
        bins[k] = max(bins.get(k, 0.0), z + rad)
    prof = sorted((k, h) for k, h in bins.items() if (k + 0.5) * w < x_max)
    top = max((h for _, h in prof), default=0.0)
    pts = [((k + 0.5) * w, h) for k, h in prof if 0.2 * top < h < 0.8 * top]
    n = len(pts)
    if n < 3:
        raise EngineError("%s: only %d surface columns on its slope, too few to fit an angle" % (what, n))
    mx = sum(p[0] for p in pts) / n
    mz = sum(p[1] for p in pts) / n
    slope = sum((p[0] - mx) * (p[1] - mz) for p in pts) / sum((p[0] - mx) ** 2 for p in pts)
    return slope, n


def engine_vars(cfg, dt=None, material=None, **scene):
    """The variables of a scene: the grains' material (with overrides), the time step, the
    neighbour skin, then the scene's own."""
    v = dict(MATERIAL)
    v.update(material or {})
    v.update(dt=dt or cfg["dt"], skin=0.5 * cfg["r"], r=cfg["r"])
    v.update(scene)
    return v


def make_repose(cfg, workdir):
    """Angle of repose of a slumped column: the slope of the free surface between 20 % and 80 %
    of the heap's height, fitted by least squares."""
    r = cfg["r"]
    v = engine_vars(
        cfg,
        seed=67867967,
        col_w=0.08 if r < 0.004 else 0.1,
        col_h=0.12 if r < 0.004 else 0.15,
        len=0.30,
        wy=max(0.03, 8 * r),
        zmax=0.2,
        settle_s=0.4,
        flow_s=1.5,
        out="repose",
    )
    t0 = time.time()
    printed = run_engine("repose.in", v, workdir, "repose")
    grains = read_dump(os.path.join(workdir, "repose.grains"))
    slope, n = surface_slope(grains, r, "slumped column")
    return {
        "angle_deg": math.degrees(math.atan(abs(slope))),
        "profile_points": n,
        "kinetic_energy_j": float(printed["REPOSE_KE_J"]),
        "grains": len(grains),
        "seconds": round(time.time() - t0, 1),
    }


def make_drain(cfg, workdir):
    """The static angle of repose: a bed drained through a slot in the floor (the last 25 % of
    the box's length); the slope of the grains left behind, fitted by least squares between
    20 % and 80 % of their height."""
    r = cfg["r"]
    length, slot_x, wy = 0.24, 0.18, max(0.03, 8 * r)
    write_stl(os.path.join(workdir, "drain_floor.stl"),
              panel((0.0005, -0.0015), (slot_x, -0.0015), 0.9999 * wy, 0.003))
    v = engine_vars(
        cfg,
        seed=67867967,
        len=length,
        hwy=wy / 2,
        fill_h=0.2,
        zmax=0.22,
        floor_stl="drain_floor.stl",
        settle_s=0.4,
        drain_s=2.5,
        out="drain",
    )
    t0 = time.time()
    printed = run_engine("drain.in", v, workdir, "drain")
    grains = [g for g in read_dump(os.path.join(workdir, "drain.grains")) if g[4] > 0.0]
    slope, n = surface_slope(grains, r, "drained bed", x_max=slot_x)
    return {
        "angle_deg": math.degrees(math.atan(abs(slope))),
        "profile_points": n,
        "kinetic_energy_j": float(printed["DRAIN_KE_J"]),
        "grains_left": len(grains),
        "seconds": round(time.time() - t0, 1),
    }


# ---------------------------------------------------------------------------------------------
# Strokes


def entry_exit(shape, h_actual, length):
    """The attack angles at which the leg's lowest point reaches the surface, h_actual below the
    hip, and leaves it. A flat plate's tip enters at asin(h / L) and leaves at pi - asin(h / L).
    A C-leg's arc (a half circle on the chord, convex toward the travel) reaches
    L/2 (1 + sin beta) below the hip up to beta = pi/2, past it L sin beta (the tip): it enters at
    asin(2 h / L - 1), about -11.5 deg for the testbed's C-leg, well before the chord's tip
    would, and leaves as the flat plate does."""
    exit_ = math.pi - math.asin(min(1.0, h_actual / length))
    if shape == "flat":
        return math.asin(min(1.0, h_actual / length)), exit_
    return math.asin(max(-1.0, min(1.0, 2.0 * h_actual / length - 1.0))), exit_


def stroke_schedule(h_actual, length, omega, strokes, shape="flat", margin=0.08, return_omega=10.0):
    """The rotation: from just before the leg touches the surface to just after it leaves,
    at omega; between strokes the leg swings back over the top at return_omega (as a wheel-leg
    does), so that the next stroke passes through the same trough. Returns the start angle and
    the segments (omega, duration)."""
    b_in, b_out = entry_exit(shape, h_actual, length)
    beta0 = b_in - margin
    sweep = b_out - b_in + 2 * margin
    segs = []
    for k in range(strokes):
        if k:
            segs.append((return_omega, (2 * math.pi - sweep) / return_omega))
        segs.append((omega, sweep / omega))
    return beta0, segs


def run_stroke(cfg, name, workdir, bed, width_m, hip_height_m, omega, shape="flat",
               strokes=1, overrides=None, hip_offset_m=0.0, forward_m_s=0.0, heave_m=0.0,
               heave_phase_deg=0.0):
    """One run: the leg's hip at hip_height_m + hip_offset_m above the measured surface
    (hip_height_m is what the model is told). Returns the run's record and its samples.

    With forward_m_s or heave_m the hip moves too, as a walking robot's does: forward (the
    engine's -x, against the tip's travel through the bed) at forward_m_s, and up and down by
    heave_m once per stroke, -heave_m cos(2 pi t / T + phase) with T the stroke's period, the
    sweep and the swing back over the top (at phase 0 lowest where each stroke starts). The engine moves the mesh by a translation with the rotation
    superposed on it (its rotation axis travels with the hip); each sample then carries the
    hip's forward travel and height above the surface."""
    length = cfg["length_m"]
    dt = cfg["dt"] * (overrides or {}).get("dt_factor", 1.0)
    moving = forward_m_s != 0.0 or heave_m != 0.0
    h_actual = hip_height_m + hip_offset_m
    # The schedule's sweep from the lowest hip: it enters earliest and leaves latest there.
    beta0, segs = stroke_schedule(h_actual - abs(heave_m), length, omega, strokes, shape)
    nav = max(1, round(1.0 / SAMPLE_HZ / dt))
    lines = []
    step_segments = []
    for (w, dur) in segs:
        step_segments.append((w, max(1, round(dur / dt))))
    total_steps = sum(n for _, n in step_segments)
    # The hip's travel: centred on the bed, so that it stays as far from the walls as a
    # standing hip's leg does.
    x0 = forward_m_s * total_steps * dt / 2.0
    phase = math.radians(heave_phase_deg)
    hip_z = bed["surface_z_m"] + h_actual - heave_m * math.cos(phase)
    write_stl(os.path.join(workdir, name + ".stl"),
              [tuple((px + x0, py, pz) for (px, py, pz) in tri)
               for tri in leg_tris(shape, length, width_m, cfg["thickness"], beta0, hip_z)])
    if moving:
        n_sweep = step_segments[0][1]
        return_omega = 10.0
        sweep_rad = omega * n_sweep * dt
        # The swing back as stroke_schedule makes it, a single stroke's too.
        n_cycle = n_sweep + max(1, round((2 * math.pi - sweep_rad) / return_omega / dt))
        if len(step_segments) > 1:
            n_cycle = n_sweep + step_segments[1][1]
        w_heave = 2 * math.pi / (n_cycle * dt)
        lines += [
            "variable k0 equal ${s0}",
            "variable k equal step-v_k0",
            "variable zero equal 0",
            "variable hip_vx equal %.9g" % -forward_m_s,
            "variable hip_vz equal %.9g*sin(%.9g*v_k*dt+%.9g)" % (heave_m * w_heave, w_heave, phase),
            "variable phase equal v_k-floor(v_k/%d)*%d" % (n_cycle, n_cycle),
            'variable om equal "(v_phase<%d)*%.9g+(v_phase>=%d)*%.9g"'
            % (n_sweep, omega, n_sweep, return_omega),
            # The translation first: the rotation superposed on it turns about an axis that
            # travels with the mesh.
            "fix hip all move/mesh mesh leg linear/variable v_hip_vx v_zero v_hip_vz",
            "fix rot all move/mesh mesh leg rotate/variable origin %.9g 0.0 %.9g axis 0 -1 0 omega v_om"
            % (x0, hip_z),
            "run %d" % total_steps,
        ]
    else:
        for i, (w, n) in enumerate(step_segments):
            lines += [
                "fix rot%d all move/mesh mesh leg rotate origin 0.0 0.0 %.9g axis 0 -1 0 period %.9g"
                % (i, hip_z, 2 * math.pi / w),
                "run %d" % n,
                "unfix rot%d" % i,
            ]
    seg_path = os.path.join(workdir, name + ".segments.in")
    with open(seg_path, "w") as f:
        f.write("\n".join(lines) + "\n")
    v = engine_vars(
        cfg,
        dt=dt,
        material=(overrides or {}).get("material"),
        bed=bed["restart"],
        hx=bed["hx"],
        hy=bed["hy"],
        stl=name + ".stl",
        hip_x=x0,
        hip_z=hip_z,
        nav=nav,
        segments=seg_path,
        out=name,
    )
    t0 = time.time()
    printed = run_engine("stroke.in", v, workdir, name)
    start_step = int(printed["START_STEP"])
    rows = read_ave_time(os.path.join(workdir, name + ".forces"))
    samples = []
    # The angle at the middle of each averaging window, from the schedule.
    bounds = []
    step0, ang0 = 0, beta0
    for w, n in step_segments:
        bounds.append((step0, step0 + n, ang0, w))
        step0 += n
        ang0 += w * n * dt
    for row in rows:
        step = row[0] - start_step - nav / 2.0
        for (s0, s1, a0, w) in bounds:
            if step <= s1:
                beta = a0 + w * (step - s0) * dt
                break
        fx, fy, fz, tx, ty, tz = row[1:7]
        # The hip frame: drag = -F_x, lift = F_z, hip torque = M_y about the hip (resisting a
        # rotation that increases beta, which turns about -y; the engine moves its reference
        # point with the mesh).
        sample = (step * dt, beta, -fx, fz, ty)
        if moving:
            t = step * dt
            sample += (forward_m_s * t, h_actual - heave_m * math.cos(w_heave * t + phase))
        samples.append(sample)
    run = {
        "name": name,
        "shape": shape,
        "length_m": length,
        "width_m": width_m,
        "hip_height_m": hip_height_m,
        "hip_offset_m": hip_offset_m,
        "omega_rad_s": omega,
        "strokes": strokes,
        "forward_m_s": forward_m_s,
        "heave_m": heave_m,
        "heave_phase_deg": heave_phase_deg,
        "dt_s": dt,
        "sample_hz": 1.0 / (nav * dt),
        "bed": bed["name"],
        "material": {k: v[k] for k in MATERIAL},
        "seconds": round(time.time() - t0, 1),
    }
    return run, samples


def write_run_csv(path, run, bed, medium, samples, engine):
    """The run as the project's DEM run CSV: '# key: value' lines, then
    t_s,beta_rad,drag_n,lift_n,hip_torque_nm."""
    meta = [
        ("engine", engine),
        ("run", run["name"]),
        ("shape", run["shape"]),
        ("length_m", run["length_m"]),
        ("width_m", run["width_m"]),
        ("hip_height_m", run["hip_height_m"]),
        ("hip_offset_m", run["hip_offset_m"]),
        ("omega_rad_s", run["omega_rad_s"]),
        ("strokes", run["strokes"]),
        ("unit_weight_n_m3", round(medium["unit_weight_n_m3"], 3)),
        ("phi_deg", round(medium["phi_deg"], 3)),
        ("delta_deg", round(medium["delta_deg"], 3)),
        ("bed", bed["name"]),
        ("bed_grains", bed["grains"]),
        ("bed_solid_fraction", round(bed["solid_fraction"], 5)),
        ("bed_surface_spread_m", round(bed["surface_spread_m"], 5)),
        ("bed_settled_ke_ratio", "%.3g" % bed["settled_ke_ratio"]),
        ("grain_radius_m", medium["grain_radius_m"]),
        ("sample_hz", run["sample_hz"]),
    ] + [(k, v) for k, v in run.get("sensor", {}).items()]
    moving = bool(samples) and len(samples[0]) > 5
    if moving:
        meta += [("forward_m_s", run["forward_m_s"]), ("heave_m", run["heave_m"]),
                 ("heave_phase_deg", run["heave_phase_deg"])]
    with open(path, "w") as f:
        for k, v in meta:
            f.write("# %s: %s\n" % (k, v))
        if moving:
            # The hip's forward travel from its start and its height above the surface.
            f.write("t_s,beta_rad,drag_n,lift_n,hip_torque_nm,hip_x_m,hip_z_m\n")
            for s in samples:
                f.write("%.6f,%.6f,%.6g,%.6g,%.6g,%.6f,%.6f\n" % s)
        else:
            f.write("t_s,beta_rad,drag_n,lift_n,hip_torque_nm\n")
            for s in samples:
                f.write("%.6f,%.6f,%.6g,%.6g,%.6g\n" % s)


def sensor_variant(samples, kind, peak, seed=7):
    """A sensor effect applied to the recorded signal: a constant bias of 10 % of the peak
    drag and lift, a delay of 30 ms, or white noise of 2 % of the peak on every sample."""
    rng = random.Random(seed)
    if kind == "bias":
        b = 0.1 * peak
        return [(t, be, d + b, l + b, tq) for (t, be, d, l, tq) in samples], {"sensor_bias_n": round(b, 4)}
    if kind == "delay":
        dt = samples[1][0] - samples[0][0]
        k = round(0.030 / dt)
        out = []
        for i, (t, be, d, l, tq) in enumerate(samples):
            j = max(0, i - k)
            out.append((t, be, samples[j][2], samples[j][3], samples[j][4]))
        return out, {"sensor_delay_s": round(k * dt, 4)}
    if kind == "noise":
        s = 0.02 * peak
        return [(t, be, d + rng.gauss(0, s), l + rng.gauss(0, s), tq + rng.gauss(0, s * 0.05))
                for (t, be, d, l, tq) in samples], {"sensor_noise_n": round(s, 4)}
    raise ValueError(kind)


# ---------------------------------------------------------------------------------------------
# RFT calibration


# The RFT calibration's bed and intrusions. The element starts in the hole cut for it, and the
# stress on it builds as it travels, until the grains ahead of it have jammed: moving down, its
# stress per depth over 15-30 mm of travel is 1.2-1.6 times that over 3.75-15 mm (a drag
# element's levels off within 7.5 mm). The element travels 30 mm and alpha is fitted over the
# second half, in a bed 0.18 x 0.10 m and 0.11 m deep, whose walls and floor stay 47 mm (8 grain
# diameters) or more from it: in the first calibration's bed (0.12 x 0.08 m, 0.08 m deep, 15 mm
# of travel) a drag element's stress rose by half over its last 10 mm, toward a wall.
RFT_BED = {"hx": 0.09, "hy": 0.05, "depth": 0.11}
RFT_TRAVEL_M = 0.03
RFT_FIT_FROM = 0.5
# The grid's intrusions move at RFT_SPEED_M_S. The same intrusions at higher speeds give RFT's
# speed law: a C-leg's tip moves at up to 0.75 m/s at 7.5 rad/s.
RFT_SPEED_M_S = 0.05
RFT_SPEEDS_M_S = (0.2, 0.4, 0.8)
RFT_SPEED_BETAS_DEG = (-60, -30, 0, 30, 60, 90)
RFT_SPEED_GAMMAS_DEG = (-45, 0, 45, 90)


def intrude(cfg, name, workdir, bed, beta_r, gamma, plate_len=0.025, width=0.025,
            depth0=0.03, travel=RFT_TRAVEL_M, speed=RFT_SPEED_M_S, cx0=0.0):
    """A plate element (plate_len x width) at attack angle beta_r, its centre at depth0 below
    the surface (negative: above it) and cx0 along x, moved `travel` in the direction gamma
    below the horizontal at `speed`. Returns its force as rows (travel m, depth of the centre m,
    F_x N, F_z N), F_x along +x (the motion's horizontal direction, or +x for a motion straight
    down) and F_z up."""
    dt = cfg["dt"]
    surface = bed["surface_z_m"]
    cx, cz = cx0, surface - depth0
    tx, tz = math.cos(beta_r), math.sin(beta_r)
    a = (cx - tx * plate_len / 2, cz - tz * plate_len / 2)
    b_pt = (cx + tx * plate_len / 2, cz + tz * plate_len / 2)
    write_stl(os.path.join(workdir, name + ".stl"), panel(a, b_pt, width, cfg["thickness"]))
    vx, vz = speed * math.cos(gamma), -speed * math.sin(gamma)
    # The hole: grains closer to the element's plane than their radius plus half its thickness,
    # within its extent (plus a radius).
    rmax = 1.2 * cfg["r"]
    along = "((x-%.9g)*%.9g+(z-%.9g)*%.9g)" % (cx, tx, cz, tz)
    across = "((x-%.9g)*%.9g-(z-%.9g)*%.9g)" % (cx, tz, cz, tx)
    hole = "(abs(%s)<%.9g)*(abs(%s)<%.9g)*(abs(y)<%.9g)" % (
        across, cfg["thickness"] / 2 + rmax, along, plate_len / 2 + rmax, width / 2 + rmax)
    nav = max(1, round(1.0 / SAMPLE_HZ / dt))
    v = engine_vars(
        cfg,
        dt=dt,
        bed=bed["restart"],
        hx=bed["hx"],
        hy=bed["hy"],
        stl=name + ".stl",
        cx=cx,
        cz=cz,
        vx=vx,
        vz=vz,
        relax_steps=round(0.05 / dt),
        move_steps=round(travel / speed / dt),
        nav=nav,
        out=name,
    )
    printed = run_engine("intrude.in", v, workdir, name, raw_lines=['variable inhole atom "%s"' % hole])
    start_step = int(printed["START_STEP"])
    out = []
    for row in read_ave_time(os.path.join(workdir, name + ".forces")):
        moved = (row[0] - start_step - nav / 2.0) * dt * speed
        out.append((moved, surface - (cz + vz / speed * moved), row[1], row[3]))
    return out


def run_intrusion(cfg, name, workdir, bed, beta_r, gamma, plate_len=0.025, width=0.025,
                  depth0=0.03, travel=RFT_TRAVEL_M, speed=RFT_SPEED_M_S, fit_from=RFT_FIT_FROM):
    """An intrusion of `intrude`, its centre buried at depth0. Returns (alpha_x, alpha_z) in
    N/cm^3 from F = alpha |z| A, fitted over the travel past the fraction `fit_from` of it
    (depth |z| of the element's centre)."""
    rows = intrude(cfg, name, workdir, bed, beta_r, gamma, plate_len, width, depth0, travel, speed)
    sxz = szz = sxx = 0.0
    for moved, depth, fx, fz in rows:
        if moved < travel * fit_from or depth <= 0:
            continue
        sxx += -fx * depth
        sxz += fz * depth
        szz += depth * depth
    k = 1e-6 / (plate_len * width * szz)  # N/m^3 -> N/cm^3
    return {"name": name, "beta_rad": beta_r, "gamma_rad": gamma, "alpha_x": sxx * k,
            "alpha_z": sxz * k}


# Intrusions from the surface: the grid's element starts with its lowest point 2 mm above the
# bed and moves 50 mm into it, as each element of a leg enters the medium. These show how stress
# grows over the first centimetres, where the grid's buried intrusions do not reach, and at
# which depths a faster element's extra stress appears.
RFT_ENTRY_TRAVEL_M = 0.05
# The element's side (m): 25 x 25 mm, as the grid's.
RFT_ELEMENT_M = 0.025
RFT_ENTRY_BETAS_DEG = (0, 45, 90)
RFT_ENTRY_GAMMAS_DEG = (45, 90)
# The same element at the same speeds moving across the bed (gamma 0, its centre 30 mm deep,
# as the grid's) and out of it (gamma -45 and -90, ending with its centre 2 mm deep), as a
# leg's elements move past the bottom of a stroke: whether the extra force of speed depends
# on the direction of motion. Each path is centred on the box's middle, away from its walls.
RFT_ACROSS_DEPTH_M = 0.03
RFT_OUT_GAMMAS_DEG = (0, -45, -90)


def out_start(gamma_r, travel=RFT_ENTRY_TRAVEL_M):
    """(depth of the centre, x of the centre) where an element moving `travel` at gamma_r (0 or
    upward) starts: across at RFT_ACROSS_DEPTH_M, or out to 2 mm below the surface."""
    dx = travel * math.cos(gamma_r)
    if gamma_r == 0:
        return RFT_ACROSS_DEPTH_M, -dx / 2
    return travel * math.sin(-gamma_r) + 0.002, -dx / 2


# A foot yawed to its travel, for the side force of a body (docs/bodies.md): a box foot
# (FOOT_SIZE_M: along its heading, across it, up) in the RFT bed, its bottom at each of
# FOOT_DEPTHS_M below the surface and its top above it, dragged FOOT_TRAVEL_M along +x at the
# grid's speed with its heading at each of FOOT_SLIPS_DEG from the travel (+: the travel toward
# the foot's left, as `terzaghi steady` counts a slip angle). Its steady force is the mean past
# FOOT_MEAN_FROM of the travel.
FOOT_SIZE_M = (0.05, 0.02, 0.05)
FOOT_DEPTHS_M = (0.02, 0.03, 0.04)
FOOT_SLIPS_DEG = (20, 40)
FOOT_TRAVEL_M = 0.07
FOOT_MEAN_FROM = 0.5


def yawed_box(size, centre, slip_r):
    """The 12 triangles of a box of `size` (along its heading, across it, up) about `centre`,
    its heading at slip_r from +x toward -y (so that motion along +x is toward its left)."""
    c, s = math.cos(slip_r), math.sin(slip_r)
    hx, hy, hz = (v / 2 for v in size)

    def world(bx, by, bz):
        return (centre[0] + bx * c + by * s, centre[1] - bx * s + by * c, centre[2] + bz)

    v = [world(sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    # v index: 4 * (x > 0) + 2 * (y > 0) + (z > 0)
    quads = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    tris = []
    for q in quads:
        tris.append((v[q[0]], v[q[1]], v[q[2]]))
        tris.append((v[q[0]], v[q[2]], v[q[3]]))
    return tris


def drag_foot(cfg, name, workdir, bed, depth, slip_r, size=FOOT_SIZE_M, travel=FOOT_TRAVEL_M,
              speed=RFT_SPEED_M_S):
    """The box foot of FOOT_SIZE_M, its bottom `depth` below the surface, its heading at slip_r
    from the travel, dragged `travel` along +x at `speed` (its centre from -travel/2 to
    +travel/2). Returns its force as rows (travel m, F_x, F_y, F_z N: the grains' force on the
    foot in the bed's frame)."""
    dt = cfg["dt"]
    surface = bed["surface_z_m"]
    cx, cz = -travel / 2, surface - depth + size[2] / 2
    write_stl(os.path.join(workdir, name + ".stl"), yawed_box(size, (cx, 0.0, cz), slip_r))
    # The hole: grains within a radius of the box, in its own frame.
    rmax = 1.2 * cfg["r"]
    c, s = math.cos(slip_r), math.sin(slip_r)
    u = "((x-%.9g)*%.9g-y*%.9g)" % (cx, c, s)
    w = "((x-%.9g)*%.9g+y*%.9g)" % (cx, s, c)
    hole = "(abs(%s)<%.9g)*(abs(%s)<%.9g)*(abs(z-%.9g)<%.9g)" % (
        u, size[0] / 2 + rmax, w, size[1] / 2 + rmax, cz, size[2] / 2 + rmax)
    nav = max(1, round(1.0 / SAMPLE_HZ / dt))
    v = engine_vars(cfg, dt=dt, bed=bed["restart"], hx=bed["hx"], hy=bed["hy"], stl=name + ".stl",
                    cx=cx, cz=cz, vx=speed, vz=0.0, relax_steps=round(0.05 / dt),
                    move_steps=round(travel / speed / dt), nav=nav, out=name)
    printed = run_engine("intrude.in", v, workdir, name, raw_lines=['variable inhole atom "%s"' % hole])
    start_step = int(printed["START_STEP"])
    return [((row[0] - start_step - nav / 2.0) * dt * speed, row[1], row[2], row[3])
            for row in read_ave_time(os.path.join(workdir, name + ".forces"))]


# ---------------------------------------------------------------------------------------------
# The campaign


def measure_friction(cfg, workdir):
    """The internal friction angle: the static angle of repose of a drained bed (used as phi),
    and, beside it, the run-out angle of a slumped column (a dynamic angle, lower)."""
    drain = make_drain(cfg, workdir)
    column = make_repose(cfg, workdir)
    return {"phi_deg": drain["angle_deg"], "drained": drain, "slumped_column": column}


def medium_of(base_bed, friction, cfg):
    return {
        "unit_weight_n_m3": base_bed["unit_weight_n_m3"],
        "phi_deg": friction["phi_deg"],
        "delta_deg": math.degrees(math.atan(MATERIAL["mu_wall"])),
        "grain_radius_m": cfg["r"],
    }


class Campaign:
    def __init__(self, args):
        self.args = args
        self.cfg = dict(SCENES[args.scene])
        self.out = os.path.abspath(args.out)
        self.work = os.path.join(self.out, "work")
        os.makedirs(self.work, exist_ok=True)
        os.makedirs(os.path.join(self.out, "runs"), exist_ok=True)
        self.engine = engine_version()
        self.lock = threading.Lock()
        self.runs = []
        self.beds = {}
        self.refused = []
        self.medium = None
        self.terzaghi = args.terzaghi

    def log(self, text):
        with self.lock:
            print("[%6.0f s] %s" % (time.time() - self.t0, text), flush=True)

    def log_friction(self):
        f = self.friction
        self.log("friction: static angle of repose %.1f deg (drained, %d grains left, %.0f s); slumped column %.1f deg (%.0f s)"
                 % (f["drained"]["angle_deg"], f["drained"]["grains_left"], f["drained"]["seconds"],
                    f["slumped_column"]["angle_deg"], f["slumped_column"]["seconds"]))

    def remeasure_medium(self):
        """Measures the friction again and rewrites phi_deg in an existing campaign's runs and
        manifest (the strokes do not depend on it: it is what the model is told)."""
        self.t0 = time.time()
        path = os.path.join(self.out, "campaign.json")
        with open(path) as f:
            manifest = json.load(f)
        self.friction = measure_friction(self.cfg, self.work)
        self.log_friction()
        manifest.pop("repose", None)
        manifest["friction"] = self.friction
        manifest["medium"]["phi_deg"] = self.friction["phi_deg"]
        runs = os.path.join(self.out, "runs")
        for name in sorted(os.listdir(runs)):
            if name.endswith(".csv"):
                p = os.path.join(runs, name)
                with open(p) as f:
                    lines = f.read().splitlines(True)
                lines = ["# phi_deg: %s\n" % round(self.friction["phi_deg"], 3) if l.startswith("# phi_deg:") else l
                         for l in lines]
                with open(p, "w") as f:
                    f.writelines(lines)
        with open(path, "w") as f:
            json.dump(manifest, f, indent=1, sort_keys=True)
        import_sessions(self.out, self.terzaghi, self.log)
        if not self.args.keep_work:
            shutil.rmtree(self.work, ignore_errors=True)

    def bed(self, name, **kw):
        b = make_bed(self.cfg, name, self.work, **kw)
        ok = b["settled_ke_ratio"] < SETTLED_KE_RATIO
        self.log("bed %s: %d grains, surface %.4f m (spread %.4f), solid fraction %.3f, KE ratio %.2g%s (%.0f s)"
                 % (name, b["grains"], b["surface_z_m"], b["surface_spread_m"], b["solid_fraction"],
                    b["settled_ke_ratio"], "" if ok else " NOT SETTLED", b["seconds"]))
        b["settled"] = ok
        with self.lock:
            self.beds[name] = b
        return b

    def rft_bed(self):
        """The RFT calibration's bed, settled; exits (nothing written) when it did not settle."""
        bd = self.bed("bed_rft", **RFT_BED)
        if not bd["settled"]:
            raise SystemExit("the RFT bed did not settle (KE ratio %.2g): nothing is written" % bd["settled_ke_ratio"])
        return bd

    def rft_grid(self, jobs):
        """The RFT calibration: a bed of its own, and 6 attack angles times 5 intrusion angles,
        `jobs` engine processes at once."""
        bd = self.rft_bed()
        plan = [("rft_b%+03d_g%+03d" % (b, g), b, g)
                for b in (-60, -30, 0, 30, 60, 90) for g in (-90, -45, 0, 45, 90)]
        with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
            out = list(pool.map(lambda p: run_intrusion(self.cfg, p[0], self.work, bd, math.radians(p[1]),
                                                        math.radians(p[2])), plan))
        self.log("RFT grid: %d intrusions" % len(out))
        return out

    def rft_speed(self, jobs):
        """The grid's intrusions again at each of RFT_SPEEDS_M_S, in the same bed, for a subset of
        attack and intrusion angles (`jobs` engine processes at once)."""
        bd = self.rft_bed()
        plan = [("rfts_v%03d_b%+03d_g%+03d" % (round(v * 100), b, g), v, b, g)
                for v in RFT_SPEEDS_M_S for b in RFT_SPEED_BETAS_DEG for g in RFT_SPEED_GAMMAS_DEG]

        def one(p):
            r = run_intrusion(self.cfg, p[0], self.work, bd, math.radians(p[2]), math.radians(p[3]), speed=p[1])
            r["speed_m_s"] = p[1]
            return r

        with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
            out = list(pool.map(one, plan))
        self.log("RFT at speed: %d intrusions" % len(out))
        return out

    def rft_entry(self, jobs):
        """The grid's element intruded from the surface, and moved across and out of the bed, at
        the grid's speed and at each of RFT_SPEEDS_M_S, in the same bed (`jobs` engine processes
        at once)."""
        bd = self.rft_bed()
        plan = [("rfte_v%03d_b%+03d_g%+03d" % (round(v * 100), b, g), v, b, g)
                for v in (RFT_SPEED_M_S,) + RFT_SPEEDS_M_S for b in RFT_ENTRY_BETAS_DEG
                for g in RFT_ENTRY_GAMMAS_DEG + RFT_OUT_GAMMAS_DEG]

        def one(p):
            beta, gamma = math.radians(p[2]), math.radians(p[3])
            if p[3] > 0:
                depth0, cx0 = -(0.0125 * abs(math.sin(beta)) + 0.002), 0.0
            else:
                depth0, cx0 = out_start(gamma)
            rows = intrude(self.cfg, p[0], self.work, bd, beta, gamma, depth0=depth0,
                           travel=RFT_ENTRY_TRAVEL_M, speed=p[1], cx0=cx0)
            return {"speed_m_s": p[1], "beta_rad": beta, "gamma_rad": math.radians(p[3]), "rows": rows}

        with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
            out = list(pool.map(one, plan))
        self.log("RFT from the surface: %d intrusions" % len(out))
        return out

    def side_force(self, jobs):
        """The box foot dragged through the RFT bed at each depth and slip angle (`jobs` engine
        processes at once). Returns one row per drag: its depth, slip angle and steady force in
        the foot's frame, as `terzaghi steady` names them."""
        bd = self.rft_bed()
        plan = [("foot_d%02d_s%+03d" % (round(d * 1e3), a), d, a) for d in FOOT_DEPTHS_M for a in FOOT_SLIPS_DEG]

        def one(p):
            name, depth, slip = p
            slip_r = math.radians(slip)
            rows = [r for r in drag_foot(self.cfg, name, self.work, bd, depth, slip_r)
                    if r[0] >= FOOT_TRAVEL_M * FOOT_MEAN_FROM]
            fx, fy, fz = (sum(r[i] for r in rows) / len(rows) for i in (1, 2, 3))
            c, s = math.cos(slip_r), math.sin(slip_r)
            # Heading (c, -s), left (s, c); the foot moves toward its left, the side force is +
            # against that motion.
            return {"name": name, "sinkage_m": depth, "slip_angle_deg": slip, "samples": len(rows),
                    "drawbar_n": fx * c - fy * s, "side_n": -(fx * s + fy * c), "load_n": fz}

        with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
            out = list(pool.map(one, plan))
        self.log("side force: %d drags" % len(out))
        return out

    def write_side_force(self, drags):
        """side_force_runs.csv: each drag's steady force, as the runs file of `terzaghi steady`
        (load_n is the vertical force the bed bore, hub_vx_m_s the drag's speed)."""
        with open(os.path.join(self.out, "side_force_runs.csv"), "w") as f:
            f.write("name,load_n,hub_vx_m_s,omega_rad_s,slip_angle_deg,sinkage_m,drawbar_n,side_n,samples\n")
            for d in sorted(drags, key=lambda d: (d["slip_angle_deg"], d["sinkage_m"])):
                f.write("%s,%.6g,%.3f,0,%g,%.4f,%.6g,%.6g,%d\n" % (
                    d["name"], d["load_n"], RFT_SPEED_M_S, d["slip_angle_deg"], d["sinkage_m"], d["drawbar_n"],
                    d["side_n"], d["samples"]))

    def write_rft_entry(self, intrusions):
        """rft_entry.csv: every sample of the intrusions from the surface."""
        with open(os.path.join(self.out, "rft_entry.csv"), "w") as f:
            f.write("# The 25 x 25 mm plate element of rft_grid.csv moved %.0f mm through the same bed at\n" % (RFT_ENTRY_TRAVEL_M * 1e3))
            f.write("# speed_m_s in the direction gamma below the horizontal (tests/dem/campaign.py --rft-entry):\n")
            f.write("# into it from the surface (gamma > 0: its lowest point starts 2 mm above the bed),\n")
            f.write("# across it (gamma 0, its centre %.0f mm deep) and out of it (gamma < 0, to its centre 2 mm\n" % (RFT_ACROSS_DEPTH_M * 1e3))
            f.write("# deep). One row per sample, from the start of the motion: the element's length (at\n")
            f.write("# attack angle beta) and width, its centre's depth below the surface (negative above it);\n")
            f.write("# drag_n resists the motion's horizontal part, lift_n is up. Angles as in rft_grid.csv.\n")
            f.write("speed_m_s,beta_rad,gamma_rad,length_m,width_m,depth_m,drag_n,lift_n\n")
            for i in sorted(intrusions, key=lambda r: (r["speed_m_s"], r["gamma_rad"], r["beta_rad"])):
                for moved, depth, fx, fz in i["rows"]:
                    if moved < 0:
                        continue
                    f.write("%.3f,%.6f,%.6f,%.3f,%.3f,%.6f,%.6g,%.6g\n" % (
                        i["speed_m_s"], i["beta_rad"], i["gamma_rad"], RFT_ELEMENT_M, RFT_ELEMENT_M, depth, -fx, fz))

    def intrusion_tests(self, jobs):
        """A medium's calibration as a lab would run it, in the RFT bed: the grid's element buried
        at 30 mm and pushed 30 mm at the grid's speed at 6 attack angles times 5 directions (down,
        obliquely, across, up), and the same element into the bed from its surface, across it and
        out of it at the grid's speed and each of RFT_SPEEDS_M_S (the plan of --rft and
        --rft-entry). Each intrusion is kept whole, as `terzaghi calibrate` reads it."""
        bd = self.rft_bed()
        plan = [("it_buried_v%03d_b%+03d_g%+03d" % (round(RFT_SPEED_M_S * 100), b, g), RFT_SPEED_M_S, b, g, True)
                for b in (-60, -30, 0, 30, 60, 90) for g in (-90, -45, 0, 45, 90)]
        plan += [("it_surface_v%03d_b%+03d_g%+03d" % (round(v * 100), b, g), v, b, g, False)
                 for v in (RFT_SPEED_M_S,) + RFT_SPEEDS_M_S for b in RFT_ENTRY_BETAS_DEG
                 for g in RFT_ENTRY_GAMMAS_DEG + RFT_OUT_GAMMAS_DEG]

        def one(p):
            name, v, b, g, buried = p
            beta, gamma = math.radians(b), math.radians(g)
            if buried:
                depth0, cx0, travel = 0.03, 0.0, RFT_TRAVEL_M
            elif g > 0:
                depth0, cx0, travel = -(0.0125 * abs(math.sin(beta)) + 0.002), 0.0, RFT_ENTRY_TRAVEL_M
            else:
                (depth0, cx0), travel = out_start(gamma), RFT_ENTRY_TRAVEL_M
            rows = intrude(self.cfg, name, self.work, bd, beta, gamma, depth0=depth0,
                           travel=travel, speed=v, cx0=cx0)
            return {"name": name, "speed_m_s": v, "chord_angle_deg": b, "gamma_deg": g,
                    "cx0": cx0, "depth0": depth0, "rows": rows}

        with cf.ThreadPoolExecutor(max_workers=jobs) as pool:
            out = list(pool.map(one, plan))
        self.log("intrusion tests: %d" % len(out))
        return out

    def write_intrusion_tests(self, tests, bed):
        """intrusions/<name>.csv and .json: each test in the format `terzaghi calibrate` reads
        (the plate centre's x and depth, the force of the medium on the plate along +x and up)."""
        d = os.path.join(self.out, "intrusions")
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        for t in tests:
            gamma = math.radians(t["gamma_deg"])
            with open(os.path.join(d, t["name"] + ".csv"), "w") as f:
                f.write("t_s,x_m,depth_m,fx_n,fz_n\n")
                for moved, depth, fx, fz in t["rows"]:
                    if moved < 0:
                        continue
                    f.write("%.5f,%.6f,%.6f,%.6g,%.6g\n" % (moved / t["speed_m_s"], t["cx0"] + moved * math.cos(gamma),
                                                          depth, fx, fz))
            meta = {
                "plate_chord_m": RFT_ELEMENT_M,
                "plate_width_m": RFT_ELEMENT_M,
                "chord_angle_deg": t["chord_angle_deg"],
                "unit_weight_n_m3": round(bed["unit_weight_n_m3"], 3),
                "speed_m_s": t["speed_m_s"],
                "description": "DEM (%s): a %.0f x %.0f mm plate element moved at %.2f m/s, %d deg below the horizontal, "
                               "in the testbed's RFT bed (%d grains), tests/dem/campaign.py --intrusion-tests"
                               % (self.engine, RFT_ELEMENT_M * 1e3, RFT_ELEMENT_M * 1e3, t["speed_m_s"], t["gamma_deg"],
                                  bed["grains"]),
            }
            with open(os.path.join(d, t["name"] + ".json"), "w") as f:
                json.dump(meta, f, indent=1)
                f.write("\n")

    def write_rft_speed(self, rows):
        """rft_speed.csv: the intrusions at speed, and the same angles' rows of rft_grid.csv at
        the grid's speed, so that the file holds its own reference."""
        with open(os.path.join(self.out, "rft_grid.csv")) as f:
            grid = {(round(float(c[0]), 6), round(float(c[1]), 6)): (float(c[2]), float(c[3]))
                    for c in (l.strip().split(",") for l in f if l[:1] not in "#b" and l.strip())}
        rows = list(rows)
        for key in sorted({(round(r["beta_rad"], 6), round(r["gamma_rad"], 6)) for r in rows}):
            if key not in grid:
                raise SystemExit("rft_grid.csv has no intrusion at beta %.6f, gamma %.6f rad: run --rft first" % key)
            rows.append({"speed_m_s": RFT_SPEED_M_S, "beta_rad": key[0], "gamma_rad": key[1],
                         "alpha_x": grid[key][0], "alpha_z": grid[key][1]})
        with open(os.path.join(self.out, "rft_speed.csv"), "w") as f:
            f.write("# RFT stress per depth of the 25 x 25 mm plate element of rft_grid.csv, intruded at several\n")
            f.write("# speeds in the same bed (tests/dem/campaign.py --rft-speed); the rows at %.2f m/s, the\n" % RFT_SPEED_M_S)
            f.write("# slowest, are rft_grid.csv's. Units and angles as in rft_grid.csv; speed in m/s.\n")
            f.write("speed_m_s,beta_rad,gamma_rad,alpha_x,alpha_z\n")
            for r in sorted(rows, key=lambda r: (r["speed_m_s"], r["gamma_rad"], r["beta_rad"])):
                f.write("%.3f,%.6f,%.6f,%.6g,%.6g\n" % (r["speed_m_s"], r["beta_rad"], r["gamma_rad"],
                                                      r["alpha_x"], r["alpha_z"]))

    def write_rft_grid(self, grid):
        with open(os.path.join(self.out, "rft_grid.csv"), "w") as f:
            f.write("# RFT stress per depth measured by intruding a 25 x 25 mm plate element in the DEM bed\n")
            f.write("# (tests/dem/campaign.py). Units: alpha in N/cm^3; beta = attack angle, gamma = intrusion\n")
            f.write("# angle below the horizontal (gamma > 0: moving down), radians; alpha_x resists the motion's\n")
            f.write("# horizontal component, alpha_z is up.\n")
            f.write("beta_rad,gamma_rad,alpha_x,alpha_z\n")
            for r in sorted(grid, key=lambda r: (r["gamma_rad"], r["beta_rad"])):
                f.write("%.6f,%.6f,%.6g,%.6g\n" % (r["beta_rad"], r["gamma_rad"], r["alpha_x"], r["alpha_z"]))

    def save(self, run, samples, bed):
        """Writes the run's CSV (its session is written at the end, by import_sessions)."""
        run = dict(run)
        csv_path = os.path.join(self.out, "runs", run["name"] + ".csv")
        write_run_csv(csv_path, run, bed, self.medium, samples, self.engine)
        peak = max(abs(s[2]) for s in samples) if samples else 0.0
        self.log("run %s: %d samples, peak drag %.2f N (%.0f s)"
                 % (run["name"], len(samples), peak, run.get("seconds", 0)))
        run["samples"] = len(samples)
        run["peak_drag_n"] = round(peak, 4)
        with self.lock:
            self.runs.append(run)
        return run

    def run(self):
        self.t0 = time.time()
        c = self.cfg
        small = self.args.scene == "small"
        self.log("engine: %s; scene %s" % (self.engine, self.args.scene))
        pool = cf.ThreadPoolExecutor(max_workers=self.args.jobs)

        # The medium's own constants: packing of the baseline bed, internal friction from the
        # static angle of repose (a drained bed); delta from the grain-plate contact friction
        # (fitted where the model is fitted).
        f_medium = None if small else pool.submit(measure_friction, c, self.work)
        base = self.bed("bed_base")
        self.friction = f_medium.result() if f_medium else {"phi_deg": 30.0, "note": "not measured in the small scene"}
        if f_medium:
            self.log_friction()
        self.medium = medium_of(base, self.friction, c)
        if not base["settled"]:
            raise SystemExit("the baseline bed did not settle (KE ratio %.2g): no run is written" % base["settled_ke_ratio"])

        jobs = []

        def stroke(name, bed, **kw):
            def go():
                bd = self.beds[bed] if isinstance(bed, str) else bed
                if not bd["settled"]:
                    self.refused.append({"name": name, "reason": "bed %s did not settle" % bd["name"]})
                    self.log("run %s refused: bed %s did not settle" % (name, bd["name"]))
                    return None
                run, samples = run_stroke(c, name, self.work, bd, **kw)
                return self.save(run, samples, bd), samples
            return go

        b0, h0, w0 = c["width_m"], c["hip_height_m"], c["omega"]
        base_name = "qs_b%03d_h%03d" % (round(b0 * 1000), round(h0 * 1000))
        f_base = pool.submit(stroke(base_name, base, width_m=b0, hip_height_m=h0, omega=w0))
        if small:
            f_base.result()
            pool.shutdown()
            return self.finish()
        std = dict(width_m=b0, hip_height_m=h0)

        def bed_then(name, bed_kw, run_name, **kw):
            def go():
                bd = self.bed(name, **bed_kw)
                return stroke(run_name, bd, **kw)()
            return go

        # Longest first, so that the two engine processes finish together.
        jobs.append(pool.submit(bed_then("bed_big", {"hx": 1.5 * c["hx"], "hy": 1.5 * c["hy"]}, "check_big_box",
                                         omega=w0, **std)))
        jobs.append(pool.submit(bed_then("bed_deep", {"depth": 1.5 * c["depth"]}, "check_deep", omega=w0, **std)))
        jobs.append(pool.submit(stroke("var_disturbed", base, omega=w0, strokes=2, **std)))
        jobs.append(pool.submit(stroke("check_slow", base, omega=w0 / 2, **std)))
        jobs.append(pool.submit(stroke("check_dt_half", base, omega=w0, overrides={"dt_factor": 0.5}, **std)))
        for b in c["widths_m"]:
            for h in c["hips_m"]:
                name = "qs_b%03d_h%03d" % (round(b * 1000), round(h * 1000))
                if name != base_name:
                    jobs.append(pool.submit(stroke(name, base, width_m=b, hip_height_m=h, omega=w0)))
        # Half the damping ratio: restitution 0.3 (ratio 0.358) -> 0.565 (ratio 0.179).
        jobs.append(pool.submit(stroke("check_damping_half", base, omega=w0,
                                       overrides={"material": {"e_rest": 0.565}}, **std)))
        jobs.append(pool.submit(stroke("var_cohesive", base, omega=w0,
                                       overrides={"material": {"ced": self.args.cohesion}}, **std)))
        jobs.append(pool.submit(stroke("var_surface_10mm", base, omega=w0, hip_offset_m=-0.010, **std)))
        jobs.append(pool.submit(bed_then("bed_dense", {"mu_fill": 0.05}, "var_dense", omega=w0, **std)))
        jobs.append(pool.submit(stroke("cleg", base, omega=w0, shape="c", **std)))
        jobs.append(pool.submit(stroke("var_fast", base, omega=10 * w0, **std)))

        # RFT from the same medium: a smaller bed, a grid of intrusions.
        f_rft = pool.submit(self.rft_grid, 1)
        base_run, base_samples = f_base.result()
        peak = max(max(abs(s[2]), abs(s[3])) for s in base_samples)
        for kind in ("bias", "delay", "noise"):
            samples, extra = sensor_variant(base_samples, kind, peak)
            run = dict(base_run)
            run["name"] = "var_sensor_" + kind
            run["sensor"] = extra
            run["seconds"] = 0
            self.save(run, samples, base)
        for j in jobs:
            j.result()
        self.rft = f_rft.result()
        pool.shutdown()
        return self.finish()

    def finish(self):
        ok = os.path.exists(self.terzaghi) and subprocess.run(
            [self.terzaghi, "import-dem", "--help"], capture_output=True).returncode == 0
        if ok:
            self.refused += import_sessions(self.out, self.terzaghi, self.log)
        else:
            self.log("%s has no import-dem: sessions not written (rerun with --import-only)" % self.terzaghi)
        grid = getattr(self, "rft", [])
        if grid:
            self.write_rft_grid(grid)
        manifest = {
            "engine": self.engine,
            "command": "python3 tests/dem/campaign.py --out %s --scene %s --jobs %d" % (
                os.path.relpath(self.out, os.path.dirname(os.path.dirname(HERE))), self.args.scene, self.args.jobs),
            "scene": self.cfg,
            "material": MATERIAL,
            "medium": self.medium,
            "friction": getattr(self, "friction", None),
            "beds": {k: {kk: vv for kk, vv in v.items() if kk != "restart"} for k, v in self.beds.items()},
            "runs": sorted(self.runs, key=lambda r: r["name"]),
            "refused": self.refused,
            "seconds": round(time.time() - self.t0, 1),
        }
        with open(os.path.join(self.out, "campaign.json"), "w") as f:
            json.dump(manifest, f, indent=1, sort_keys=True)
        if not self.args.keep_work:
            shutil.rmtree(self.work, ignore_errors=True)
        self.log("campaign done in %.0f s (%.1f min): %d runs in %s"
                 % (manifest["seconds"], manifest["seconds"] / 60, len(self.runs), self.out))
        return manifest


# The diagnosis part: the same bed levelled again from other fill seeds (LIGGGHTS takes primes
# above 10,000), so that every condition has several independent strokes, as a testbed's sand
# differs a little each time it is levelled. Seed 0 is the campaign's own bed (BED_SEED).
DIAGNOSIS_SEEDS = [BED_SEED, 86028157, 86028221, 86028223]


def diagnosis_plan(cohesion):
    """The diagnosis part's runs: (name, bed kind, seed index, stroke keywords). Runs the
    campaign already has (the baseline stroke, var_cohesive, var_dense, var_fast on seed 0)
    are not run again."""
    plan = []
    for k in (1, 2, 3):
        plan.append(("dx_base_s%d" % k, "base", k, {}))
        plan.append(("dx_cohesive_s%d" % k, "base", k, {"overrides": {"material": {"ced": cohesion}}}))
    for k in (1, 2):
        plan.append(("dx_dense_s%d" % k, "dense", k, {}))
    # A robot that speeds up: strokes at 2.5, 5 and 7.5 rad/s (var_fast is 10 rad/s).
    for k, w in ((1, 2.5), (2, 5.0), (3, 7.5)):
        plan.append(("dx_fast_w%03d_s%d" % (round(w * 10), k), "base", k, {"omega": w}))
    # Four passes through the same trough, never levelled between them.
    plan.append(("dx_disturbed_s1", "base", 1, {"strokes": 4}))
    # The C-leg at 1 rad/s on the independent beds, as `dx_base_s*` is the flat plate: a
    # session of C-leg strokes needs strokes of its own, not `cleg` again (a stroke the
    # diagnosis holds out must not have its twin among the strokes it fits).
    for k in (1, 2, 3):
        plan.append(("dx_cleg_s%d" % k, "base", k, {"shape": "c"}))
    # The C-leg speeding up the same way (the campaign's `cleg` is its stroke at 1 rad/s): a
    # large misfit of the flat-plate model at several speeds.
    for k, w in ((1, 2.5), (2, 5.0), (3, 7.5)):
        plan.append(("dx_cleg_w%03d_s%d" % (round(w * 10), k), "base", k, {"omega": w, "shape": "c"}))
    # The campaign's own C-leg stroke at 1 rad/s, on its bed levelled again from the same seed:
    # its first runs started at the flat plate's entry angle, the arc already inside the bed.
    plan.append(("cleg", "base", 0, {"shape": "c"}))
    # A walking robot's hip: heaving +-1 cm once per stroke, and moving forward at 2 cm/s as
    # well, two strokes at 2.5 rad/s, the flat plate and the C-leg; what the node is told by
    # the session's /tf against its fixed hip height.
    for name, shape, fwd in (("mv_heave", "flat", 0.0), ("mv_walk", "flat", 0.02),
                             ("mv_cleg_walk", "c", 0.02)):
        plan.append((name, "base", 0, {"omega": 2.5, "strokes": 2, "shape": shape,
                                       "forward_m_s": fwd, "heave_m": 0.01}))
    # The C-leg with its hip higher and lower than the campaign's 40 mm, at 1 rad/s as `cleg`.
    for k, h in ((1, 0.030), (2, 0.055)):
        plan.append(("dx_cleg_h%03d_s%d" % (round(h * 1000), k), "base", k,
                     {"shape": "c", "hip_height_m": h}))
    # The second of those strokes passes through the first one's trough (the hip moves 3 cm
    # between them; the trough is 18 cm long): single strokes into the settled bed, the hip
    # walking forward and heaving at four phases of the stroke (the flat leg) and two (the
    # C-leg), so that every stroke meets the surface the runs' hip height is measured from.
    for shape, tag, phases in (("flat", "", (0, 90, 180, 270)), ("c", "_cleg", (0, 180))):
        for ph in phases:
            plan.append(("mv%s_phase%03d" % (tag, ph), "base", 0,
                         {"omega": 2.5, "shape": shape, "forward_m_s": 0.02, "heave_m": 0.01,
                          "heave_phase_deg": float(ph)}))
    return plan


def run_diagnosis_part(args):
    """Adds the diagnosis part's runs to an existing campaign (its manifest gives the medium),
    writes their sessions, and records them in the manifest under `diagnosis`."""
    out = os.path.abspath(args.out)
    path = os.path.join(out, "campaign.json")
    with open(path) as f:
        manifest = json.load(f)
    if args.only and "diagnosis" not in manifest:
        sys.exit("--only adds runs to a diagnosis part: %s has none yet (run --diagnosis first)" % path)
    camp = Campaign(args)
    camp.t0 = time.time()
    camp.medium = manifest["medium"]
    c = camp.cfg
    b0, h0, w0 = c["width_m"], c["hip_height_m"], c["omega"]
    plan = diagnosis_plan(args.cohesion)
    if args.only:
        wanted = set(args.only.split(","))
        unknown = sorted(wanted - {r[0] for r in plan})
        if unknown:
            sys.exit("--only: no run %s in the diagnosis part (its runs: %s)"
                     % (", ".join(unknown), ", ".join(r[0] for r in plan)))
        plan = [r for r in plan if r[0] in wanted]
    beds = {}
    bed_lock = threading.Lock()
    bed_events = {}

    def bed(kind, k):
        # Each bed is built once, by whichever run needs it first; the other runs wait for it.
        key = (kind, k)
        with bed_lock:
            ev = bed_events.get(key)
            first = ev is None
            if first:
                ev = bed_events[key] = threading.Event()
        if first:
            name = "bed_%s_s%d" % (kind, k)
            kw = {"mu_fill": 0.05} if kind == "dense" else {}
            beds[key] = camp.bed(name, seed=DIAGNOSIS_SEEDS[k], **kw)
            ev.set()
        ev.wait()
        return beds[key]

    def go(name, kind, k, kw):
        bd = bed(kind, k)
        if not bd["settled"]:
            camp.refused.append({"name": name, "reason": "bed %s did not settle" % bd["name"]})
            return
        kw = dict(kw)
        run, samples = run_stroke(c, name, camp.work, bd, width_m=b0,
                                  hip_height_m=kw.pop("hip_height_m", h0),
                                  omega=kw.pop("omega", w0), **kw)
        run["seed"] = DIAGNOSIS_SEEDS[k]
        camp.save(run, samples, bd)

    camp.log("engine: %s; diagnosis part, %d runs" % (camp.engine, len(plan)))
    # Longest first, so that the engine processes finish together.
    order = sorted(plan, key=lambda r: -r[3].get("strokes", 1) / r[3].get("omega", w0))
    with cf.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for f in [pool.submit(go, *r) for r in order]:
            f.result()
    names = {r["name"] for r in camp.runs}
    # A run on the campaign's own bed (seed index 0) is the campaign's, run again: not the part's.
    own = {r[0] for r in plan if r[2] == 0}
    refused = import_sessions(out, camp.terzaghi, camp.log, only=names)
    manifest["runs"] = sorted([r for r in manifest["runs"] if r["name"] not in names] + camp.runs,
                              key=lambda r: r["name"])
    for k, v in camp.beds.items():
        manifest["beds"][k] = {kk: vv for kk, vv in v.items() if kk != "restart"}
    manifest["refused"] = manifest.get("refused", []) + camp.refused + refused
    command = "python3 tests/dem/campaign.py --out %s --diagnosis --jobs %d" % (
        os.path.relpath(out, os.path.dirname(os.path.dirname(HERE))), args.jobs)
    seconds = round(time.time() - camp.t0, 1)
    if args.only:
        # Runs added to an existing diagnosis part: recorded beside it, the part's run list
        # grown by them.
        part = manifest["diagnosis"]
        part["runs"] = sorted(set(part["runs"]) | (names - own))
        part.setdefault("added", []).append({
            "command": command + " --only " + args.only,
            "engine": camp.engine,
            "runs": sorted(names),
            "seconds": seconds,
        })
    else:
        manifest["diagnosis"] = {
            "command": command,
            "engine": camp.engine,
            "seeds": DIAGNOSIS_SEEDS,
            "runs": sorted(names - own),
            "seconds": seconds,
        }
    close_part(camp, args, path, manifest,
               "diagnosis part done in %.0f s (%.1f min): %d runs" % (seconds, seconds / 60, len(names)))


def close_part(camp, args, path, manifest, done):
    """Writes the manifest a part of the campaign added to, removes the engine's work (unless
    --keep-work) and logs `done`."""
    with open(path, "w") as f:
        json.dump(manifest, f, indent=1, sort_keys=True)
    if not args.keep_work:
        shutil.rmtree(camp.work, ignore_errors=True)
    camp.log(done)


def open_part(args, flag, what):
    """An existing campaign's directory, manifest path, manifest and Campaign, its clock started
    and `what` logged, for a part that `flag` adds to it; exits naming the directory when it has
    no campaign."""
    out = os.path.abspath(args.out)
    path = os.path.join(out, "campaign.json")
    if not os.path.exists(path):
        sys.exit("%s adds to a campaign: %s has none (run the campaign first)" % (flag, path))
    with open(path) as f:
        manifest = json.load(f)
    camp = Campaign(args)
    camp.t0 = time.time()
    camp.log("engine: %s; %s, %d jobs" % (camp.engine, what, args.jobs))
    return out, path, manifest, camp


def finish_part(camp, args, out, path, manifest, key, flag, done, intrusions, **fields):
    """Records a part in the manifest under `key` (the command that remakes it, the engine, its
    duration, its intrusions and `fields`), writes the manifest and logs `done`."""
    seconds = round(time.time() - camp.t0, 1)
    manifest[key] = dict(
        command="python3 tests/dem/campaign.py --out %s %s --jobs %d" % (
            os.path.relpath(out, os.path.dirname(os.path.dirname(HERE))), flag, args.jobs),
        engine=camp.engine, intrusions=intrusions, seconds=seconds, **fields)
    close_part(camp, args, path, manifest,
               "%s done in %.0f s (%.1f min): %d intrusions" % (done, seconds, seconds / 60, intrusions))


def run_rft_part(args):
    """Runs the RFT calibration again in an existing campaign: its bed and grid of intrusions,
    rft_grid.csv rewritten, and the calibration recorded in the manifest under `rft`."""
    out, path, manifest, camp = open_part(args, "--rft", "RFT calibration")
    grid = camp.rft_grid(args.jobs)
    camp.write_rft_grid(grid)
    manifest["beds"]["bed_rft"] = {k: v for k, v in camp.beds["bed_rft"].items() if k != "restart"}
    finish_part(camp, args, out, path, manifest, "rft", "--rft", "RFT calibration", len(grid),
                travel_m=RFT_TRAVEL_M, fitted_over_travel_from_m=RFT_TRAVEL_M * RFT_FIT_FROM)


def run_rft_speed_part(args):
    """Runs the RFT intrusions at speed in an existing campaign: rft_speed.csv written, and the
    run recorded in the manifest under `rft_speed`."""
    # Its reference rows are the grid's: refused before any intrusion, not after them.
    grid_path = os.path.join(os.path.abspath(args.out), "rft_grid.csv")
    if os.path.exists(os.path.join(os.path.abspath(args.out), "campaign.json")) and not os.path.exists(grid_path):
        sys.exit("--rft-speed compares with the RFT grid: %s is missing (run --rft first)" % grid_path)
    out, path, manifest, camp = open_part(args, "--rft-speed", "RFT intrusions at speed")
    rows = camp.rft_speed(args.jobs)
    camp.write_rft_speed(rows)
    finish_part(camp, args, out, path, manifest, "rft_speed", "--rft-speed", "RFT at speed", len(rows),
                speeds_m_s=[RFT_SPEED_M_S] + list(RFT_SPEEDS_M_S), travel_m=RFT_TRAVEL_M,
                fitted_over_travel_from_m=RFT_TRAVEL_M * RFT_FIT_FROM)


def run_rft_entry_part(args):
    """Runs the intrusions from the surface in an existing campaign: rft_entry.csv written, and
    the run recorded in the manifest under `rft_entry`."""
    out, path, manifest, camp = open_part(args, "--rft-entry", "RFT intrusions from the surface")
    intrusions = camp.rft_entry(args.jobs)
    camp.write_rft_entry(intrusions)
    finish_part(camp, args, out, path, manifest, "rft_entry", "--rft-entry", "RFT from the surface",
                len(intrusions), speeds_m_s=[RFT_SPEED_M_S] + list(RFT_SPEEDS_M_S),
                travel_m=RFT_ENTRY_TRAVEL_M)


def run_intrusion_tests_part(args):
    """Runs the intrusion tests in an existing campaign: intrusions/ written, and the run
    recorded in the manifest under `intrusion_tests`."""
    out, path, manifest, camp = open_part(args, "--intrusion-tests", "intrusion tests for calibration")
    tests = camp.intrusion_tests(args.jobs)
    camp.write_intrusion_tests(tests, camp.beds["bed_rft"])
    finish_part(camp, args, out, path, manifest, "intrusion_tests", "--intrusion-tests", "intrusion tests",
                len(tests), speeds_m_s=[RFT_SPEED_M_S] + list(RFT_SPEEDS_M_S),
                bed={k: v for k, v in camp.beds["bed_rft"].items() if k != "restart"})


def run_side_force_part(args):
    """Drags the box foot at two slip angles in an existing campaign: side_force_runs.csv
    written, and the drags recorded in the manifest under `side_force`."""
    out, path, manifest, camp = open_part(args, "--side-force", "a box foot dragged at slip angles")
    drags = camp.side_force(args.jobs)
    camp.write_side_force(drags)
    finish_part(camp, args, out, path, manifest, "side_force", "--side-force", "side force", len(drags),
                foot_size_m=list(FOOT_SIZE_M), depths_m=list(FOOT_DEPTHS_M), slips_deg=list(FOOT_SLIPS_DEG),
                travel_m=FOOT_TRAVEL_M, speed_m_s=RFT_SPEED_M_S, mean_from_travel_m=FOOT_TRAVEL_M * FOOT_MEAN_FROM,
                bed={k: v for k, v in camp.beds["bed_rft"].items() if k != "restart"})


def import_sessions(out, terzaghi, log=print, only=None):
    """Writes every run's CSV in out/runs (or those named in `only`) as a ROS 2 MCAP session
    beside it, through `terzaghi import-dem`, which refuses a run that made no contact, has a
    non-finite force or whose bed did not settle. A refused run's CSV moves to out/refused.
    Returns the refusals."""
    refused = []
    runs = os.path.join(out, "runs")
    for name in sorted(os.listdir(runs)):
        if not name.endswith(".csv") or (only is not None and name[:-4] not in only):
            continue
        csv_path = os.path.join(runs, name)
        mcap_path = csv_path[:-4] + ".mcap"
        if os.path.exists(mcap_path):
            os.remove(mcap_path)
        p = subprocess.run([terzaghi, "import-dem", csv_path, "-o", mcap_path],
                           capture_output=True, text=True)
        if p.returncode != 0:
            refused.append({"name": name[:-4], "reason": p.stderr.strip()})
            log("run %s refused: %s" % (name[:-4], p.stderr.strip()))
            os.makedirs(os.path.join(out, "refused"), exist_ok=True)
            os.replace(csv_path, os.path.join(out, "refused", name))
    return refused


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="directory for runs/, rft_grid.csv and campaign.json")
    ap.add_argument("--scene", choices=sorted(SCENES), default="full")
    ap.add_argument("--jobs", type=int, default=2, help="engine processes at once (default 2)")
    ap.add_argument("--cohesion", type=float, default=1e5,
                    help="cohesion energy density of the cohesive variation, J/m^3 (default 1e5)")
    ap.add_argument("--terzaghi", default=os.path.join(os.path.dirname(os.path.dirname(HERE)), "target", "release", "terzaghi"))
    ap.add_argument("--keep-work", action="store_true", help="keep the engine's inputs, logs and restarts")
    ap.add_argument("--remeasure-medium", action="store_true",
                    help="measure the friction angle again and rewrite it in the runs already in --out")
    ap.add_argument("--diagnosis", action="store_true",
                    help="add the diagnosis part (independent beds and strokes per condition) to the campaign in --out")
    ap.add_argument("--only", metavar="RUN[,RUN...]",
                    help="with --diagnosis: run only these runs of the diagnosis part and add them to the campaign")
    ap.add_argument("--rft", action="store_true",
                    help="run the RFT calibration (its bed and intrusions) again in the campaign in --out, "
                         "rewriting rft_grid.csv")
    ap.add_argument("--rft-speed", action="store_true",
                    help="run the RFT intrusions at higher speeds in the campaign in --out, writing rft_speed.csv")
    ap.add_argument("--rft-entry", action="store_true",
                    help="run the RFT element into the bed from its surface, across it and out of it at the grid's "
                         "and higher speeds in the campaign in --out, writing rft_entry.csv")
    ap.add_argument("--intrusion-tests", action="store_true",
                    help="run a medium's calibration tests (a plate element buried and pushed in 30 directions, and "
                         "into, across and out of the bed at four speeds) in the campaign in --out, writing intrusions/")
    ap.add_argument("--side-force", action="store_true",
                    help="drag a box foot through the RFT bed at two slip angles and three depths in the campaign in "
                         "--out, writing side_force_runs.csv (the runs file of `terzaghi steady`)")
    ap.add_argument("--import-only", action="store_true",
                    help="only write the sessions of the CSV runs already in --out (no engine)")
    args = ap.parse_args()
    if args.import_only:
        refused = import_sessions(os.path.abspath(args.out), args.terzaghi)
        sys.exit(1 if refused else 0)
    if shutil.which("liggghts") is None:
        sys.exit("liggghts not found: install it with `apt-get install liggghts` (Debian)")
    if args.jobs < 1:
        sys.exit("--jobs must be at least 1")
    if args.remeasure_medium:
        Campaign(args).remeasure_medium()
        return
    if args.only and not args.diagnosis:
        sys.exit("--only goes with --diagnosis")
    if args.diagnosis:
        run_diagnosis_part(args)
        return
    if args.rft:
        run_rft_part(args)
        return
    if args.rft_speed:
        run_rft_speed_part(args)
        return
    if args.rft_entry:
        run_rft_entry_part(args)
        return
    if args.intrusion_tests:
        run_intrusion_tests_part(args)
        return
    if args.side_force:
        run_side_force_part(args)
        return
    Campaign(args).run()


if __name__ == "__main__":
    main()
