#!/usr/bin/env python3
"""scipy's least_squares on the attitude-aided model, for `cargo xtask
bench`'s fit-speed section: reads a recording (CSV with mx, my, mz,
roll_deg, pitch_deg), fits the model once and prints
{"seconds_read": …, "seconds_fit": …, "rows": …, "bias": […], "matrix": […],
"dip_deg": …, "nfev": …}.

    python3 xtask/python/fit_speed.py FILE FIELD_NT

The model, written from its equations (not from the Rust code): the raw
reading `raw`, normalised `u = (raw − c)/s` (c the readings' mean, s their
RMS distance from it), is calibrated as `g = A·u − d` (A a general 3×3
matrix, d a vector: 12 unknowns), levelled with the AHRS roll φ and pitch θ,
`l = R_y(θ)·R_x(φ)·g`, and its vertical and horizontal parts must be the
field's at dip δ (the 13th unknown), in units of the field:

    r_v = l_z − sin δ,    r_h = |(l_x, l_y)| − cos δ

plus a Gaussian prior of 0.2° on the misalignment, `(A_ij − A_ji)/(2·gain)`
for the three pairs. The loss is Huber's at 0.8 times the residuals' robust
scale (their median |r| / 0.6745), the scale taken from a plain
least-squares pass started from a sphere fit; both passes are timed (the
fit), the CSV read apart. Jacobians are analytic (from the equations above).
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import least_squares

MISALIGNMENT_SIGMA_RAD = np.radians(0.2)
HUBER_K = 0.8


def read(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    cols = [header.index(c) for c in ("mx", "my", "mz", "roll_deg", "pitch_deg")]
    # np.loadtxt is several times faster than genfromtxt on plain numbers;
    # empty cells (a missing reading) become NaN through the converter.
    conv = {i: (lambda s: float(s) if s else np.nan) for i in cols}
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, converters=conv, dtype=float, ndmin=2)
    ok = np.all(np.isfinite(data), axis=1)
    return data[ok, :3], np.radians(data[ok, 3]), np.radians(data[ok, 4])


def level_matrices(roll, pitch):
    """R_y(θ)·R_x(φ) per sample (body to level, NED), shape (n, 3, 3)."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    z = np.zeros_like(sr)
    return np.stack([np.stack([cp, sp * sr, sp * cr], -1), np.stack([z, cr, -sr], -1), np.stack([-sp, cp * sr, cp * cr], -1)], -2)


def model(raw, roll, pitch):
    c = raw.mean(axis=0)
    s = np.sqrt(((raw - c) ** 2).sum(axis=1).mean())
    u = (raw - c) / s
    C = level_matrices(roll, pitch)
    n = len(u)

    def parts(x):
        A, d, dip = x[:9].reshape(3, 3), x[9:12], x[12]
        g = u @ A.T - d
        l = np.einsum("nij,nj->ni", C, g)
        hh = np.hypot(l[:, 0], l[:, 1])
        return A, dip, l, hh

    def prior(x):
        A = x[:9].reshape(3, 3)
        gain = np.trace(A) / 3.0
        w = 1.0 / (2.0 * gain * MISALIGNMENT_SIGMA_RAD)
        return np.array([(A[0, 1] - A[1, 0]) * w, (A[0, 2] - A[2, 0]) * w, (A[1, 2] - A[2, 1]) * w])

    def residuals(x, sigma):
        _, dip, l, hh = parts(x)
        return np.concatenate([(l[:, 2] - np.sin(dip)) / sigma, (hh - np.cos(dip)) / sigma, prior(x)])

    def jacobian(x, sigma):
        A, dip, l, hh = parts(x)
        nx, ny = l[:, 0] / hh, l[:, 1] / hh
        cv = C[:, 2, :]  # ∂l_z/∂g
        ch = nx[:, None] * C[:, 0, :] + ny[:, None] * C[:, 1, :]  # ∂|l_xy|/∂g
        J = np.zeros((2 * n + 3, 13))
        for rows, cg, ddip in ((slice(0, n), cv, -np.cos(dip)), (slice(n, 2 * n), ch, np.sin(dip))):
            J[rows, :9] = (cg[:, :, None] * u[:, None, :]).reshape(n, 9) / sigma
            J[rows, 9:12] = -cg / sigma
            J[rows, 12] = ddip / sigma
        gain = np.trace(A) / 3.0
        w = 1.0 / (2.0 * gain * MISALIGNMENT_SIGMA_RAD)
        for k, (i, j) in enumerate(((0, 1), (0, 2), (1, 2))):
            J[2 * n + k, 3 * i + j] = w
            J[2 * n + k, 3 * j + i] = -w
            # The prior's weight depends on the gain (through the trace).
            diff = A[i, j] - A[j, i]
            for m in (0, 4, 8):
                J[2 * n + k, m] += -diff * w / (3.0 * gain)
        return J

    return u, s, c, n, residuals, jacobian


def sphere_start(u):
    # |u − b|² = r²: linear in (2b, r² − |b|²).
    M = np.column_stack([2 * u, np.ones(len(u))])
    y = (u ** 2).sum(axis=1)
    p, *_ = np.linalg.lstsq(M, y, rcond=None)
    b = p[:3]
    r = np.sqrt(p[3] + b @ b)
    return 1.0 / r, b


def fit(raw, roll, pitch):
    u, s, c, n, residuals, jacobian = model(raw, roll, pitch)
    gain, centre = sphere_start(u)
    x0 = np.zeros(13)
    x0[[0, 4, 8]] = gain
    x0[9:12] = gain * centre
    g = u @ np.diag([gain] * 3).T - x0[9:12]
    C = level_matrices(roll, pitch)
    l = np.einsum("nij,nj->ni", C, g)
    x0[12] = np.arctan2(l[:, 2].sum(), np.hypot(l[:, 0], l[:, 1]).sum())
    plain = least_squares(residuals, x0, jac=jacobian, args=(0.01,), method="trf", x_scale="jac")
    r = residuals(plain.x, 1.0)[: 2 * n]
    sigma = np.median(np.abs(r)) / 0.6745
    robust = least_squares(residuals, plain.x, jac=jacobian, args=(sigma,), method="trf", loss="huber", f_scale=HUBER_K, x_scale="jac")
    x = robust.x
    A, d = x[:9].reshape(3, 3), x[9:12]
    # h = (F/s)·A·(raw − c) − F·d = M·(raw − b): M = (F/s)·A, b = c + s·A⁻¹d.
    bias = c + s * np.linalg.solve(A, d)
    return A / s, bias, np.degrees(x[12]), plain.nfev + robust.nfev


def main():
    path, field_nt = sys.argv[1], float(sys.argv[2])
    t0 = time.perf_counter()
    raw, roll, pitch = read(path)
    t1 = time.perf_counter()
    matrix, bias, dip_deg, nfev = fit(raw, roll, pitch)
    t2 = time.perf_counter()
    print(json.dumps({"seconds_read": t1 - t0, "seconds_fit": t2 - t1, "rows": len(raw), "bias": bias.tolist(), "matrix": (matrix * field_nt).tolist(), "dip_deg": dip_deg, "nfev": nfev}))


if __name__ == "__main__":
    main()
