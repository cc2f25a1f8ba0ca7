"""Independent reference for the gyro-aided fit: a plain gyro-aided least
squares written with scipy.optimize.least_squares, on a BROAD trial's
calibration rows (optionally a slice of them), judged on the trial's
validation part against the optical heading after one constant offset.

The model (written from the physics, not from calib-core): the calibrated
field h = M (raw - b) of a constant world field turns in the body frame as
the gyro says, so over a window of K steps h_j = R_ij h_i with R_ij the
product of the steps' exp(-[(w - w_bias) dt]x); with the AHRS roll and
pitch the levelled vertical of h is one constant Z. Unknowns: the general
3x3 M, b, the gyro bias, Z and the
magnetometer's lag behind the gyro (each step's rotation to first order
(w0 + w1)/2 dt - lag (w1 - w0)). Residuals (nT): every window's h_j - R_ij h_i,
the vertical rows (weight 0.1, as the product's default), and one row that
sets the overall scale (RMS |h| = F: the heading does not depend on it).

usage: gyro_lsq.py DIR NN FIELD_NT [LO HI]   (DIR holds NN_calib.csv,
NN_validate.csv, NN.truth.json). Prints one JSON line."""
import json
import sys

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

WINDOW_STEPS = 30  # 1.05 s at BROAD's 28.57 Hz
VERTICAL_WEIGHT = 0.1
MAX_STEP_FACTOR = 1.5


def read(path):
    with open(path) as f:
        names = f.readline().strip().split(",")
    data = np.genfromtxt(path, delimiter=",", skip_header=1)
    return {n: data[:, k] for k, n in enumerate(names)}


def level(h, roll, pitch):
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    x, y, z = h[:, 0], h[:, 1], h[:, 2]
    zr = sr * y + cr * z
    return np.column_stack([cp * x + sp * zr, cr * y - sr * z, -sp * x + cp * zr])


def heading_rms_after_offset_deg(cal_m, cal_b, v):
    raw = np.column_stack([v["mx"], v["my"], v["mz"]])
    h = (raw - cal_b) @ cal_m.T
    lv = level(h, np.radians(v["roll_deg"]), np.radians(v["pitch_deg"]))
    psi = np.arctan2(-lv[:, 1], lv[:, 0])
    d = psi - np.radians(v["truth_heading_deg"])
    off = np.arctan2(np.sin(d).mean(), np.cos(d).mean())
    e = np.arctan2(np.sin(d - off), np.cos(d - off))
    return float(np.degrees(np.sqrt(np.mean(e * e))))


def windows(t, k):
    """Pairs (i, i + k) within unbroken stretches."""
    step = np.median(np.diff(t)[np.diff(t) > 0])
    ok = (np.diff(t) > 0) & (np.diff(t) <= MAX_STEP_FACTOR * step)
    brk = np.concatenate([[0], np.cumsum(~ok)])
    i = np.arange(len(t) - k)
    return i[brk[i] == brk[i + k]]


def fit(c, field_nt):
    t = c["t"]
    raw = np.column_stack([c["mx"], c["my"], c["mz"]])
    w = np.column_stack([c["gx"], c["gy"], c["gz"]])
    roll, pitch = np.radians(c["roll_deg"]), np.radians(c["pitch_deg"])
    starts = windows(t, WINDOW_STEPS)
    dt = np.diff(t)
    n = len(t)

    def rotations(bias, lag):
        # Body-frame vectors of a constant world vector across each step:
        # exp(-[theta]x) = Rotation.from_rotvec(theta).inv(). With P the
        # running product of the steps, the window's R = P_j P_i^T.
        theta = 0.5 * (w[:-1] + w[1:]) * dt[:, None] - bias * dt[:, None] - lag * (w[1:] - w[:-1])
        steps = Rotation.from_rotvec(theta).inv().as_matrix()
        p = np.empty((n, 3, 3))
        p[0] = np.eye(3)
        for k in range(n - 1):
            p[k + 1] = steps[k] @ p[k]
        return np.einsum("nij,nkj->nik", p[starts + WINDOW_STEPS], p[starts])

    # Start: the centroid and a sphere's radius (a plain start, no other fit).
    b0 = raw.mean(axis=0)
    radius = np.sqrt(((raw - b0) ** 2).sum(axis=1).mean())
    m0 = np.eye(3) * field_nt / radius
    x0 = np.concatenate([m0.ravel(), b0, np.zeros(3), [field_nt * 0.9], [0.0]])

    def residuals(x):
        m = x[:9].reshape(3, 3)
        b, bias, z = x[9:12], x[12:15], x[15]
        h = (raw - b) @ m.T
        rot = rotations(bias, x[16])
        kin = h[starts + WINDOW_STEPS] - np.einsum("nij,nj->ni", rot, h[starts])
        vert = VERTICAL_WEIGHT * (level(h, roll, pitch)[:, 2] - z)
        scale = 10.0 * np.sqrt(n) * (np.sqrt((h * h).sum(axis=1).mean()) - field_nt)
        return np.concatenate([kin.ravel(), vert, [scale]]) / field_nt

    sol = least_squares(residuals, x0, method="lm", x_scale="jac", max_nfev=400)
    return sol.x[:9].reshape(3, 3), sol.x[9:12], sol


def main():
    d, nn, field_nt = sys.argv[1], sys.argv[2], float(sys.argv[3])
    c = read(f"{d}/{nn}_calib.csv")
    if len(sys.argv) > 5:
        lo, hi = int(sys.argv[4]), int(sys.argv[5])
        c = {k: v[lo:hi] for k, v in c.items()}
    v = read(f"{d}/{nn}_validate.csv")
    truth = json.load(open(f"{d}/{nn}.truth.json"))
    m, b, sol = fit(c, field_nt)
    out = {
        "rows": int(len(c["t"])),
        "heading_rms_deg": heading_rms_after_offset_deg(m, b, v),
        "floor_deg": heading_rms_after_offset_deg(np.array(truth["matrix"]), np.array(truth["bias"]), v),
        "gyro_bias_rad_s": sol.x[12:15].tolist(),
        "gyro_lag_s": float(sol.x[16]),
        "nfev": int(sol.nfev),
        "scipy": __import__("scipy").__version__,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
