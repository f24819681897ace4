"""The improved Terzaghi model of a flat leg, vectorised in numpy: the paper's equations (Eqs.
11-25, as docs/model.md resolves them) written out for arrays of legs, every leg and both
branches evaluated. python/tests/test_batch.py checks terzaghi.batch against it to 1e-9; the
benchmark's peers (python/benchmarks/peers.py) are the same equations written for speed.
"""

import math

import numpy as np


def plate_forces(beta_rad, hip_height_m, *, length_m, width_m, unit_weight_n_m3, phi_deg,
                 delta_deg, b_k, a, pitch_rad=None):
    """Drag, lift (N) and hip torque (N m) of flat legs at attack angles ``beta_rad`` (+ the
    body's pitch) with their hips ``hip_height_m`` above the surface; arrays of one shape."""
    phi = math.radians(phi_deg)
    k = math.tan(phi)
    alpha = math.pi / 4 - phi / 2
    theta_end = 3 * math.pi / 4 + phi / 2
    k_p = math.tan(math.pi / 4 + phi / 2) ** 2
    spiral_den = 3 * (1 + 9 * k * k)
    tan_delta = math.tan(math.radians(delta_deg))
    cos_a, sin_a = math.cos(alpha), math.sin(alpha)

    beta = np.asarray(beta_rad, dtype=np.float64)
    if pitch_rad is not None:
        beta = beta + pitch_rad
    beta = np.mod(beta, 2 * math.pi)
    h = np.maximum(np.asarray(hip_height_m, dtype=np.float64), 0.0)
    inside = beta <= math.pi
    s = np.where(inside, np.sin(beta), 0.0)
    c = np.where(inside, np.cos(beta), 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        l_s = np.where(s > 0, np.maximum(length_m - h / s, 0.0), 0.0)
    w = width_m * b_k * np.exp(-beta * math.log(a)) * unit_weight_n_m3  # b_e lambda, Eq. (11)
    theta = theta_end - beta  # Eq. (13)
    spiral = theta > 0
    tk = np.where(spiral, theta * k, 0.0)
    e1 = np.exp(tk)
    r_b = l_s * e1
    e2_m1 = np.where(tk < 1e-3, np.expm1(2 * tk), e1 * e1 - 1)
    g_lg = w * l_s * l_s * e2_m1 / (4 * k)  # Eq. (14)
    f = s + 3 * k * c + e1 ** 3 * (3 * k * cos_a - sin_a)
    moment_lg = w * l_s ** 3 * f / spiral_den  # Eqs. (15)-(16)
    with np.errstate(divide="ignore", invalid="ignore"):
        d_lg = np.where(g_lg > 0, moment_lg / g_lg, 0.0)
    g_t = np.where(spiral, 0.25 * w * r_b * r_b * math.cos(phi), -0.5 * w * l_s * l_s * s * c)
    d_tg = np.where(spiral, 2 / 3 * r_b * cos_a, -2 / 3 * l_s * c)
    f_l = np.where(spiral, 0.5 * w * (r_b * sin_a) ** 2 * k_p, 0.5 * w * (l_s * s) ** 2 * k_p)
    d_l = np.where(spiral, 2 / 3 * r_b * sin_a, 2 / 3 * l_s * s)
    moment = g_t * d_tg + f_l * d_l + np.where(spiral, g_lg * d_lg, 0.0)
    d_perp = 2 / 3 * l_s  # Eq. (21)
    with np.errstate(divide="ignore", invalid="ignore"):
        normal = np.where(l_s > 0, moment / d_perp, 0.0)
    tangential = normal * tan_delta  # Eq. (22a)
    drag = normal * s - tangential * c  # Eq. (22b)
    lift = normal * c + tangential * s
    torque = normal * (length_m - l_s + d_perp)
    return drag, lift, torque
