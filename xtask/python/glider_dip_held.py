"""Independent reference for the levelled fits' world-model constraint: a
plain fit of a symmetric matrix and a hard iron to a glider's levelled
vertical and horizontal field components with the dip held at IGRF's.

    h = S·(raw − b),  S symmetric (6 unknowns), b (3)
    residuals per row:  V − F sin I,  H − F cos I   (levelled with roll, pitch)

solved by scipy's least_squares (plain squares) from a sphere fit's start,
on the calibration rows below 3 m. Judged as the gliders' READMEs say: on the
validation rows below 3 m, the 1σ scatter of the calibrated field's dip and
its mean against IGRF.

Usage: glider_dip_held.py CALIB.csv VALIDATE.csv INCLINATION_DEG FIELD_NT
       [--dives A-B] (keep the calibration's dives A..B, 1-based, a dive being
       a stretch between gaps longer than 600 s). Prints one JSON line.
"""
import json
import sys

import numpy as np
from scipy.optimize import least_squares

JUDGE_DEPTH_M = 3.0
DIVE_GAP_S = 600.0


def read(path):
    d = np.genfromtxt(path, delimiter=",", names=True)
    raw = np.column_stack([d["mx"], d["my"], d["mz"]])
    return d, raw


def dives(t):
    """1-based dive number of each row (a new dive after a gap > 600 s)."""
    return 1 + np.concatenate([[0], np.cumsum(np.diff(t) > DIVE_GAP_S)])


def level(h, roll_deg, pitch_deg):
    """The field in the level frame (Z-Y-X Euler, x forward, z down)."""
    r, p = np.radians(roll_deg), np.radians(pitch_deg)
    sr, cr, sp, cp = np.sin(r), np.cos(r), np.sin(p), np.cos(p)
    x, y, z = h.T
    # C = C2ᵀ(θ) C1ᵀ(φ): undo roll, then pitch.
    y1 = cr * y - sr * z
    z1 = sr * y + cr * z
    x2 = cp * x + sp * z1
    z2 = -sp * x + cp * z1
    return np.column_stack([x2, y1, z2])


def calibrate(params, raw):
    s = params[:6]
    S = np.array([[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]])
    return (raw - params[6:9]) @ S.T


def fit(raw, roll, pitch, incl_deg, field_nt):
    c = raw.mean(axis=0)
    # Sphere start: |raw − c|² = r², linear in (2c, r² − |c|²).
    A = np.column_stack([2 * raw, np.ones(len(raw))])
    sol, *_ = np.linalg.lstsq(A, (raw ** 2).sum(axis=1), rcond=None)
    c = sol[:3]
    r = np.sqrt(sol[3] + c @ c)
    g = field_nt / r
    x0 = np.array([g, 0, 0, g, 0, g, *c])
    sv, ch = field_nt * np.sin(np.radians(incl_deg)), field_nt * np.cos(np.radians(incl_deg))

    def res(p):
        l = level(calibrate(p, raw), roll, pitch)
        return np.concatenate([l[:, 2] - sv, np.hypot(l[:, 0], l[:, 1]) - ch]) / field_nt

    return least_squares(res, x0, x_scale="jac").x


def judge(params, d, raw, igrf_deg):
    keep = d["depth_m"] > JUDGE_DEPTH_M
    l = level(calibrate(params, raw[keep]), d["roll_deg"][keep], d["pitch_deg"][keep])
    dip = np.degrees(np.arctan2(l[:, 2], np.hypot(l[:, 0], l[:, 1])))
    return float(np.std(dip, ddof=1)), float(dip.mean() - igrf_deg)


def main():
    calib_path, val_path, incl, field = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
    d, raw = read(calib_path)
    keep = d["depth_m"] > JUDGE_DEPTH_M
    if "--dives" in sys.argv:
        a, b = (int(v) for v in sys.argv[sys.argv.index("--dives") + 1].split("-"))
        n = dives(d["t"])
        keep &= (n >= a) & (n <= b)
    p = fit(raw[keep], d["roll_deg"][keep], d["pitch_deg"][keep], incl, field)
    vd, vraw = read(val_path)
    scatter, mean_off = judge(p, vd, vraw, incl)
    print(json.dumps({"rows": int(keep.sum()), "dip_scatter_deg": scatter, "dip_mean_minus_igrf_deg": mean_off, "numpy": np.__version__}))


if __name__ == "__main__":
    main()
