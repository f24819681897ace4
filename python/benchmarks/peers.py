"""terzaghi.batch against the peers an RL user would write instead, in one run.

4,096 environments x 6 legs, one step: plate legs (the improved Terzaghi model) and RHex's
C-legs (RFT with Li et al.'s fitted poppy-seed coefficients, a half circle in 96 elements, the
hip moving). Each peer is checked equal to terzaghi.batch first (1e-9 of the largest force);
then every contestant is timed in turn, alternating, and the medians and ratios printed.

The peers are the same equations written as a careful lab would:
  numpy   plates: only the legs within reach of the sand, in place, no double branches;
          C-legs: per chunk of legs, only the (leg, element) pairs below the surface;
  numba   a plain parallel loop over legs (numba.prange), fastmath, compiled before timing;
  torch   2D RFT over (legs, elements) tensors as Isaac Lab's terrains write it, and the
          improved model over legs (both regimes, torch.where): eager, and under
          torch.compile (inductor, CPU); in float64 and float32.

    python python/benchmarks/peers.py --threads 1     # one core
    python python/benchmarks/peers.py --threads 2     # all of this machine's

It needs numba and torch beside the package (python/benchmarks/requirements-peers.txt).
"""

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path

SHAPE = (4096, 6)
LEG = dict(length_m=0.1, width_m=0.025)
MEDIUM = dict(unit_weight_n_m3=13000.0, phi_deg=30.0, delta_deg=20.0)
B_K, A = 30.0, 2.3
# Li, Zhang & Goldman's poppy seeds (loosely packed), N/cm^3, as terzaghi's RftFit::POPPY_LP.
POPPY_LP = dict(a00=0.051, a10=0.047, b11=0.053, b01=0.083, bm11=0.020, c11=-0.026, c01=0.057,
                cm11=0.0, d10=0.025)
C_LEG_SEGMENTS, C_LEG_ELEMENTS = 32, 96


def c_leg_elements(chord_m, width_m):
    """A half-circle C-leg's elements in the leg's frame (s along the chord, q toward the
    travel): their middles, 1e6 width length (N/cm^3 to N/m of depth), cos and sin of twice the
    segment's angle."""
    import numpy as np

    r = chord_m / 2
    alpha = math.pi / 2 + math.pi / 2 - math.pi * np.arange(C_LEG_SEGMENTS + 1) / C_LEG_SEGMENTS
    pts = np.stack([r + r * np.cos(alpha), r * np.sin(alpha)], axis=1)
    per = C_LEG_ELEMENTS // C_LEG_SEGMENTS
    d = np.diff(pts, axis=0)
    t = (np.arange(per) + 0.5) / per
    s = (pts[:-1, None, 0] + t * d[:, None, 0]).ravel()
    q = (pts[:-1, None, 1] + t * d[:, None, 1]).ravel()
    length = np.repeat(np.hypot(d[:, 0], d[:, 1]) / per, per)
    l2 = d[:, 0] ** 2 + d[:, 1] ** 2
    c2 = np.repeat((d[:, 0] ** 2 - d[:, 1] ** 2) / l2, per)
    s2 = np.repeat(2 * d[:, 0] * d[:, 1] / l2, per)
    return s, q, 1e6 * width_m * length, c2, s2


def medium_constants():
    phi = math.radians(MEDIUM["phi_deg"])
    k = math.tan(phi)
    alpha = math.pi / 4 - phi / 2
    return dict(lam=MEDIUM["unit_weight_n_m3"], k=k, theta_end=3 * math.pi / 4 + phi / 2,
                cos_phi=math.cos(phi), sin_alpha=math.sin(alpha), cos_alpha=math.cos(alpha),
                k_p=math.tan(math.pi / 4 + phi / 2) ** 2, spiral_den=3 * (1 + 9 * k * k),
                tan_delta=math.tan(math.radians(MEDIUM["delta_deg"])))


def rft_alpha(c2e, sm, x, sg):
    """RFT's stresses (alpha_x, alpha_z; N/cm^3, poppy seeds) of elements whose tangent is at
    twice-angle (c2e, sm) and which move along (x, -sg), the mirror of a motion toward -x
    cancelled out (it multiplies alpha_x and the drag it gives): numpy arrays or torch tensors.
    """
    k = POPPY_LP
    az = k["a00"] + k["a10"] * c2e + (k["b11"] - k["bm11"]) * (sm * x) \
        + (k["b11"] + k["bm11"]) * (c2e * sg) + k["b01"] * sg
    ax = (k["c11"] + k["cm11"]) * (c2e * x) + (k["cm11"] - k["c11"]) * (sm * sg) \
        + k["c01"] * x + k["d10"] * sm
    return ax, az


# ---------------------------------------------------------------- numpy, careful

def numpy_plates(beta, hip, pitch, out):
    """The improved model for the legs whose plate reaches the sand; the rest are zero."""
    import numpy as np

    c = medium_constants()
    drag, lift, torque = out
    drag.fill(0.0), lift.fill(0.0), torque.fill(0.0)
    b = np.mod(beta + pitch, 2 * math.pi)
    h = np.maximum(hip, 0.0)
    idx = np.flatnonzero((b < math.pi) & (h < LEG["length_m"]))
    b, h = b.ravel()[idx], h.ravel()[idx]
    s, co = np.sin(b), np.cos(b)
    with np.errstate(divide="ignore"):
        l_s = np.maximum(LEG["length_m"] - h / s, 0.0)
    keep = l_s > 0
    idx, b, s, co, l_s = idx[keep], b[keep], s[keep], co[keep], l_s[keep]
    w = (LEG["width_m"] * B_K * c["lam"]) * np.exp(-math.log(A) * b)
    theta = c["theta_end"] - b
    spiral = theta > 0
    moment = np.empty_like(b)
    # the spiral regime
    sp = np.flatnonzero(spiral)
    tk = theta[sp] * c["k"]
    e1 = np.exp(tk)
    ls, ws = l_s[sp], w[sp]
    r_b = ls * e1
    e2m1 = np.where(tk < 1e-3, np.expm1(2 * tk), e1 * e1 - 1)
    g_lg = ws * ls * ls * e2m1 / (4 * c["k"])
    f = s[sp] + 3 * c["k"] * co[sp] + e1 ** 3 * (3 * c["k"] * c["cos_alpha"] - c["sin_alpha"])
    m_lg = np.where(g_lg > 0, ws * ls ** 3 * f / c["spiral_den"], 0.0)
    moment[sp] = (0.25 * ws * r_b * r_b * c["cos_phi"] * (2 / 3 * r_b * c["cos_alpha"])
                  + 0.5 * ws * (r_b * c["sin_alpha"]) ** 2 * c["k_p"] * (2 / 3 * r_b * c["sin_alpha"])
                  + m_lg)
    # the triangle regime
    tr = np.flatnonzero(~spiral)
    lt, wt, st, ct = l_s[tr], w[tr], s[tr], co[tr]
    moment[tr] = ((-0.5 * wt * lt * lt * st * ct) * (-2 / 3 * lt * ct)
                  + 0.5 * wt * (lt * st) ** 2 * c["k_p"] * (2 / 3 * lt * st))
    d_perp = 2 / 3 * l_s
    normal = moment / d_perp
    tang = normal * c["tan_delta"]
    drag.ravel()[idx] = normal * s - tang * co
    lift.ravel()[idx] = normal * co + tang * s
    torque.ravel()[idx] = normal * (LEG["length_m"] - l_s + d_perp)


def numpy_c_legs(el, beta, hip, pitch, omega, fwd, up, out, chunk=512):
    """RFT over the elements in the sand only: per chunk of legs (its temporaries in cache),
    the (leg, element) pairs below the surface are found first and every other quantity is
    computed over those pairs alone, in place, then summed per leg (np.bincount)."""
    import numpy as np

    s, q, wl, c2, s2 = el
    drag, lift, torque = out
    drag.fill(0.0), lift.fill(0.0), torque.fill(0.0)
    b_all = (beta + pitch).ravel()
    h_all, om_all = hip.ravel(), omega.ravel()
    fwd_all, up_all = fwd.ravel(), up.ravel()
    d_out, l_out, t_out = drag.ravel(), lift.ravel(), torque.ravel()
    for start in range(0, b_all.size, chunk):
        sl = slice(start, min(start + chunk, b_all.size))
        b = b_all[sl]
        sb, cb = np.sin(b), np.cos(b)
        # depth = -(h + p1), p1 = -s sin - q cos
        depth = np.multiply.outer(sb, s)
        depth += np.multiply.outer(cb, q)
        depth -= h_all[sl, None]
        leg, e = np.nonzero(depth > 0)
        if leg.size == 0:
            continue
        k = depth[leg, e]
        k *= wl[e]
        sbp, cbp, se, qe = sb[leg], cb[leg], s[e], q[e]
        om = om_all[sl][leg]
        # velocity = omega (s n - q u) + v_hip, u = (-cos, -sin), n = (sin, -cos)
        vx = se * sbp
        vx += qe * cbp
        vx *= om
        vx -= fwd_all[sl][leg]
        vz = qe * sbp
        vz -= se * cbp
        vz *= om
        vz += up_all[sl][leg]
        inv = vx * vx
        inv += vz * vz
        np.sqrt(inv, out=inv)
        with np.errstate(divide="ignore"):
            np.divide(1.0, inv, out=inv)
        inv[~np.isfinite(inv)] = 0.0
        vx *= inv
        vz *= inv
        np.negative(vz, out=vz)
        c2b = cbp * cbp
        c2b -= sbp * sbp
        s2b = sbp * cbp
        s2b *= 2
        c2p, s2p = c2[e], s2[e]
        c2e = c2p * c2b
        c2e -= s2p * s2b
        sm = c2p * s2b
        sm += s2p * c2b
        ax, az = rft_alpha(c2e, sm, vx, vz)
        ax *= k
        az *= k
        n = b.size
        d_out[sl] = np.bincount(leg, weights=ax, minlength=n)
        l_out[sl] = np.bincount(leg, weights=az, minlength=n)
        # torque = -(p1 ax + p0 az) k, p0 = -s cos + q sin, p1 = -s sin - q cos
        p1 = se * sbp
        p1 += qe * cbp
        p1 *= ax
        p0 = qe * sbp
        p0 -= se * cbp
        p0 *= az
        p1 -= p0
        t_out[sl] = np.bincount(leg, weights=p1, minlength=n)


# ---------------------------------------------------------------- numba

def numba_kernels():
    import numba
    from numba import njit, prange

    c = medium_constants()
    L, W = LEG["length_m"], LEG["width_m"]
    LN_A = math.log(A)
    K = POPPY_LP
    BD, BS = K["b11"] - K["bm11"], K["b11"] + K["bm11"]
    CS, CD = K["c11"] + K["cm11"], K["cm11"] - K["c11"]
    A00, A10, B01, C01, D10 = K["a00"], K["a10"], K["b01"], K["c01"], K["d10"]
    lam, kk, th_end, cos_phi = c["lam"], c["k"], c["theta_end"], c["cos_phi"]
    sa, ca, kp, sden, td = c["sin_alpha"], c["cos_alpha"], c["k_p"], c["spiral_den"], c["tan_delta"]
    TWO_PI = 2 * math.pi

    @njit(parallel=True, fastmath=True, cache=False)
    def plates(beta, hip, pitch, drag, lift, torque):
        for i in prange(beta.size):
            b = (beta.flat[i] + pitch.flat[i]) % TWO_PI
            h = max(hip.flat[i], 0.0)
            d = l_ = t = 0.0
            if b < math.pi:
                s, co = math.sin(b), math.cos(b)
                l_s = max(L - h / s, 0.0) if s > 0 else 0.0
                if l_s > 0:
                    w = W * B_K * math.exp(-b * LN_A) * lam
                    theta = th_end - b
                    if theta > 0:
                        tk = theta * kk
                        e1 = math.exp(tk)
                        r_b = l_s * e1
                        e2m1 = math.expm1(2 * tk) if tk < 1e-3 else e1 * e1 - 1
                        g_lg = w * l_s * l_s * e2m1 / (4 * kk)
                        f = s + 3 * kk * co + e1 * e1 * e1 * (3 * kk * ca - sa)
                        m_lg = w * l_s ** 3 * f / sden if g_lg > 0 else 0.0
                        moment = (0.25 * w * r_b * r_b * cos_phi * (2 / 3 * r_b * ca)
                                  + 0.5 * w * (r_b * sa) ** 2 * kp * (2 / 3 * r_b * sa) + m_lg)
                    else:
                        moment = ((-0.5 * w * l_s * l_s * s * co) * (-2 / 3 * l_s * co)
                                  + 0.5 * w * (l_s * s) ** 2 * kp * (2 / 3 * l_s * s))
                    d_perp = 2 / 3 * l_s
                    normal = moment / d_perp
                    tang = normal * td
                    d = normal * s - tang * co
                    l_ = normal * co + tang * s
                    t = normal * (L - l_s + d_perp)
            drag.flat[i] = d
            lift.flat[i] = l_
            torque.flat[i] = t

    @njit(parallel=True, fastmath=True, cache=False)
    def c_legs(s_, q_, wl_, c2_, s2_, reach, beta, hip, pitch, omega, fwd, up, drag, lift, torque):
        n_el = s_.size
        for i in prange(beta.size):
            h = hip.flat[i]
            d = l_ = t = 0.0
            if h < reach:
                b = beta.flat[i] + pitch.flat[i]
                sb, cb = math.sin(b), math.cos(b)
                om, vhx, vhz = omega.flat[i], -fwd.flat[i], up.flat[i]
                if om == 0.0 and vhx == 0.0 and vhz == 0.0:
                    om = 1.0
                c2b, s2b = cb * cb - sb * sb, 2 * sb * cb
                for j in range(n_el):
                    s, q = s_[j], q_[j]
                    p0 = -s * cb + q * sb
                    p1 = -s * sb - q * cb
                    depth = -(h + p1)
                    if depth <= 0.0:
                        continue
                    vx = om * (s * sb + q * cb) + vhx
                    vz = om * (-s * cb + q * sb) + vhz
                    v2 = vx * vx + vz * vz
                    if v2 == 0.0:
                        continue
                    inv = 1.0 / math.sqrt(v2)
                    x, sg = vx * inv, -vz * inv
                    c2e = c2_[j] * c2b - s2_[j] * s2b
                    sm = c2_[j] * s2b + s2_[j] * c2b
                    az = A00 + A10 * c2e + BD * (sm * x) + BS * (c2e * sg) + B01 * sg
                    ax = CS * (c2e * x) + CD * (sm * sg) + C01 * x + D10 * sm
                    k = depth * wl_[j]
                    d += ax * k
                    l_ += az * k
                    t -= (p1 * ax + p0 * az) * k
            drag.flat[i] = d
            lift.flat[i] = l_
            torque.flat[i] = t

    return numba, plates, c_legs


# ---------------------------------------------------------------- torch

def torch_plates(torch, beta, hip, pitch):
    """The improved model of every leg in torch tensors, both regimes computed and chosen with
    torch.where, as a simulator's tensor code writes it."""
    c = medium_constants()
    L, W = LEG["length_m"], LEG["width_m"]
    k = c["k"]
    b = torch.remainder(beta + pitch, 2 * math.pi)
    h = torch.clamp(hip, min=0.0)
    down = b < math.pi
    s = torch.where(down, torch.sin(b), torch.zeros_like(b))
    co = torch.where(down, torch.cos(b), torch.ones_like(b))
    safe_s = torch.where(s > 0, s, torch.ones_like(s))
    l_s = torch.where(s > 0, torch.clamp(L - h / safe_s, min=0.0), torch.zeros_like(s))
    w = (W * B_K * c["lam"]) * torch.exp(-math.log(A) * b)
    theta = c["theta_end"] - b
    spiral = theta > 0
    tk = theta * k
    e1 = torch.exp(tk)
    r_b = l_s * e1
    e2m1 = torch.where(tk < 1e-3, torch.expm1(2 * tk), e1 * e1 - 1)
    g_lg = w * l_s * l_s * e2m1 / (4 * k)
    f = s + 3 * k * co + e1 ** 3 * (3 * k * c["cos_alpha"] - c["sin_alpha"])
    m_lg = torch.where(spiral & (g_lg > 0), w * l_s ** 3 * f / c["spiral_den"],
                       torch.zeros_like(w))
    m_spiral = (0.25 * w * r_b * r_b * c["cos_phi"] * (2 / 3 * r_b * c["cos_alpha"])
                + 0.5 * w * (r_b * c["sin_alpha"]) ** 2 * c["k_p"] * (2 / 3 * r_b * c["sin_alpha"]))
    m_triangle = ((-0.5 * w * l_s * l_s * s * co) * (-2 / 3 * l_s * co)
                  + 0.5 * w * (l_s * s) ** 2 * c["k_p"] * (2 / 3 * l_s * s))
    moment = torch.where(spiral, m_spiral, m_triangle) + m_lg
    d_perp = 2 / 3 * l_s
    inside = l_s > 0
    normal = torch.where(inside, moment / torch.where(inside, d_perp, torch.ones_like(d_perp)),
                         torch.zeros_like(moment))
    tang = normal * c["tan_delta"]
    return (normal * s - tang * co, normal * co + tang * s, normal * (L - l_s + d_perp))


def torch_c_legs_fn(torch, el, dtype):
    """2D RFT over (legs, elements) tensors, every element computed and masked, as Isaac Lab's
    RFT terrains write it."""
    s, q, wl, c2, s2 = (torch.as_tensor(a, dtype=dtype) for a in el)

    def c_legs(beta, hip, pitch, omega, fwd, up):
        b = (beta + pitch).reshape(-1, 1)
        h = hip.reshape(-1, 1)
        om = omega.reshape(-1, 1)
        vhx, vhz = -fwd.reshape(-1, 1), up.reshape(-1, 1)
        still = (om == 0) & (vhx == 0) & (vhz == 0)
        om = torch.where(still, torch.ones_like(om), om)
        sb, cb = torch.sin(b), torch.cos(b)
        p0 = -s * cb + q * sb
        p1 = -s * sb - q * cb
        depth = torch.clamp(-(h + p1), min=0)
        vx = om * (s * sb + q * cb) + vhx
        vz = om * (-s * cb + q * sb) + vhz
        v2 = vx * vx + vz * vz
        inv = torch.where(v2 > 0, torch.rsqrt(v2), torch.zeros_like(v2))
        x, sg = vx * inv, -vz * inv
        c2b, s2b = cb * cb - sb * sb, 2 * sb * cb
        c2e = c2 * c2b - s2 * s2b
        sm = c2 * s2b + s2 * c2b
        ax, az = rft_alpha(c2e, sm, x, sg)
        k = depth * wl
        shape = beta.shape
        return ((ax * k).sum(1).reshape(shape), (az * k).sum(1).reshape(shape),
                (-(p1 * ax + p0 * az) * k).sum(1).reshape(shape))

    return c_legs


# ---------------------------------------------------------------- the run

def median_ms(fn, n):
    times = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, default=os.cpu_count(),
                    help="threads for every contestant (default: every core)")
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds of timing")
    ap.add_argument("--no-compile", action="store_true", help="leave torch.compile out")
    ap.add_argument("--check-only", action="store_true",
                    help="check every peer against terzaghi.batch, and time nothing")
    args = ap.parse_args()
    for v in ("RAYON_NUM_THREADS", "NUMBA_NUM_THREADS", "OMP_NUM_THREADS"):
        os.environ[v] = str(args.threads)
    # The contestants take turns in one process: one runtime's idle threads must not spin on
    # the cores while another is timed (OpenMP's, torch's, spin after each parallel region by
    # default; numpy's OpenBLAS threads, which no contestant uses, poll).
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    import numpy as np
    import torch

    torch.set_num_threads(args.threads)
    numba, numba_plates, numba_c_legs = numba_kernels()
    from terzaghi.batch import LegBatch

    rng = np.random.default_rng(1)
    # A stride's angles and a walking body's hips: about half the legs in the sand.
    beta = rng.uniform(0.0, 2 * np.pi, SHAPE)
    hip = rng.uniform(0.0, 0.06, SHAPE)
    pitch = rng.uniform(-0.05, 0.05, SHAPE)
    omega = rng.uniform(2.0, 8.0, SHAPE)
    fwd = rng.uniform(0.0, 0.3, SHAPE)
    up = rng.uniform(-0.05, 0.05, SHAPE)
    motion = (pitch, omega, fwd, up)
    el = c_leg_elements(LEG["length_m"], LEG["width_m"])
    reach = float(np.hypot(el[0], el[1]).max())

    def outs(dtype=np.float64):
        return tuple(np.empty(SHAPE, dtype) for _ in range(3))

    plates = LegBatch(**LEG, **MEDIUM, b_k=B_K, a=A)
    clegs = LegBatch(**LEG, model="rft", medium="poppy_lp", shape="c_leg",
                     rft_elements=C_LEG_ELEMENTS)
    o_ours, o_peer = outs(), outs()
    b32 = [a.astype(np.float32) for a in (beta, hip, *motion)]
    o32 = outs(np.float32)
    tt = [torch.from_numpy(a) for a in (beta, hip, *motion)]
    tt32 = [torch.from_numpy(a) for a in b32]
    t_eager = torch_c_legs_fn(torch, el, torch.float64)
    t_eager32 = torch_c_legs_fn(torch, el, torch.float32)

    contestants = {
        "plates: terzaghi.batch": lambda: plates.forces(beta, hip, pitch_rad=pitch, out=o_ours),
        "plates: terzaghi.batch float32": lambda: plates.forces(
            b32[0], b32[1], pitch_rad=b32[2], out=o32),
        "plates: numpy (careful)": lambda: numpy_plates(beta, hip, pitch, o_peer),
        "plates: numba": lambda: numba_plates(beta, hip, pitch, *o_peer),
        "C-legs: terzaghi.batch": lambda: clegs.forces(
            beta, hip, pitch_rad=pitch, omega_rad_s=omega, forward_m_s=fwd, up_m_s=up,
            out=o_ours),
        "C-legs: terzaghi.batch float32": lambda: clegs.forces(
            b32[0], b32[1], pitch_rad=b32[2], omega_rad_s=b32[3], forward_m_s=b32[4],
            up_m_s=b32[5], out=o32),
        "C-legs: numpy (careful)": lambda: numpy_c_legs(el, beta, hip, *motion, o_peer),
        "C-legs: numba": lambda: numba_c_legs(*el, reach, beta, hip, *motion, *o_peer),
        "plates: torch eager": lambda: torch_plates(torch, tt[0], tt[1], tt[2]),
        "C-legs: torch eager": lambda: t_eager(*tt),
        "C-legs: torch eager float32": lambda: t_eager32(*tt32),
    }
    if not args.no_compile:
        t_comp = torch.compile(torch_c_legs_fn(torch, el, torch.float64))
        t_comp32 = torch.compile(torch_c_legs_fn(torch, el, torch.float32))
        p_comp = torch.compile(lambda b, h, p: torch_plates(torch, b, h, p))
        contestants["plates: torch.compile"] = lambda: p_comp(tt[0], tt[1], tt[2])
        contestants["plates: torch.compile float32"] = lambda: p_comp(tt32[0], tt32[1], tt32[2])
        contestants["C-legs: torch.compile"] = lambda: t_comp(*tt)
        contestants["C-legs: torch.compile float32"] = lambda: t_comp32(*tt32)

    # Every peer equal to ours first.
    def check(name, ours, theirs, rtol):
        scale = max(float(np.abs(np.asarray(ours[0])).max()), float(np.abs(np.asarray(ours[1])).max()))
        for k, (a, b) in enumerate(zip(ours, theirs)):
            err = float(np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)).max())
            if err > rtol * scale:
                sys.exit(f"{name} differs from terzaghi.batch in output {k}: {err} of {scale}")

    ref_p = [a.copy() for a in plates.forces(beta, hip, pitch_rad=pitch)]
    ref_c = [a.copy() for a in clegs.forces(beta, hip, pitch_rad=pitch, omega_rad_s=omega,
                                            forward_m_s=fwd, up_m_s=up)]
    for name, fn in contestants.items():
        got = fn()
        if got is None:
            got = o_peer
        ref = ref_p if name.startswith("plates") else ref_c
        check(name, ref, [a.numpy() if hasattr(a, "numpy") else a for a in got],
              1e-4 if "float32" in name else 1e-9)
    in_sand = [np.count_nonzero(r[1]) / r[1].size for r in (ref_p, ref_c)]
    if args.check_only:
        print(f"every peer equals terzaghi.batch ({len(contestants)} contestants)")
        return

    times = {name: [] for name in contestants}
    for _ in range(args.rounds):
        for name, fn in contestants.items():
            for _ in range(3):
                fn()
            times[name].append(median_ms(fn, 20))
    med = {name: statistics.median(v) for name, v in times.items()}
    load = os.getloadavg()[0]
    print(f"{SHAPE[0]} x {SHAPE[1]} legs, {args.threads} thread(s), load {load:.2f} at the end; "
          f"in the sand: plates {100 * in_sand[0]:.0f} %, C-legs {100 * in_sand[1]:.0f} %; "
          f"numba {numba.__version__}, torch {torch.__version__}, numpy {np.__version__}")
    # Each peer against the batch in its own dtype; the batch's float32 against its float64.
    for group in ("plates", "C-legs"):
        ours, ours32 = med[f"{group}: terzaghi.batch"], med[f"{group}: terzaghi.batch float32"]
        for name, t in med.items():
            if not name.startswith(group):
                continue
            if name == f"{group}: terzaghi.batch float32":
                note = f"float64 takes {ours / t:.2f}x its time"
            elif "float32" in name:
                note = f"{t / ours32:5.2f}x terzaghi.batch float32's time"
            else:
                note = f"{t / ours:5.2f}x terzaghi.batch's time"
            print(f"  {name:34s} {t:8.3f} ms  ({note})")


if __name__ == "__main__":
    main()
