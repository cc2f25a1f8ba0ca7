"""Peers on broad-05 for `cargo xtask bench`: MAGYC (Rodríguez-Martínez &
Troni) and the benchmark methods shipped with the `magyc` package (PyPI,
MIT): TWOSTEP (Alonso & Shuster), SAR-LS (Troni & Whitcomb), ellipsoid fit.

Reads the calibration part, prints one JSON object: for each method the
calibration in magcal's convention (`h = matrix · (raw − bias)`), or the
error it raised. The bench applies each to the validation part with the
same heading evaluation as magcal's own."""
import csv
import json
import sys
import warnings

import numpy as np

warnings.filterwarnings("ignore")
import magyc  # noqa: E402


def load(path):
    rows = list(csv.DictReader(open(path)))
    col = lambda k: np.array([float(r[k]) for r in rows])
    t = col("t")
    m = np.stack([col("mx"), col("my"), col("mz")], 1)
    w = np.stack([col("gx"), col("gy"), col("gz")], 1)
    return t, m, w


def as_cal(hard_iron, soft_iron):
    # magyc's convention: calibrated = inv(soft_iron) @ (m - hard_iron).
    bias = np.asarray(hard_iron, float).flatten()
    soft = np.asarray(soft_iron, float)
    if not (np.all(np.isfinite(bias)) and np.all(np.isfinite(soft))):
        return {"error": "no answer (NaN coefficients)"}
    return {"bias": bias.tolist(), "matrix": np.linalg.inv(soft).tolist()}


def main():
    t, m, w = load(sys.argv[1])
    field = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    out = {"magyc_version": getattr(magyc, "__version__", "unknown")}
    runs = {
        "MAGYC-LS": lambda: as_cal(*magyc.magyc_ls(m, w, t)[:2]),
        "MAGYC-NLS": lambda: as_cal(*magyc.magyc_nls(m, w, t)[:2]),
        # TWOSTEP needs the reference field in the readings' units and their
        # noise (broad-05: 0.1 µT counts, about 4 counts of noise).
        "TWOSTEP": lambda: as_cal(*magyc.twostep_hsi(m, np.array([field, 0.0, 0.0]), measurement_noise_std=4.0)[:2]),
        "SAR-LS": lambda: as_cal(magyc.sar_ls(m, w, t)[0], np.eye(3)),
        "ellipsoid fit": lambda: as_cal(*magyc.ellipsoid_fit(m)[:2]),
    }
    for name, run in runs.items():
        try:
            cal = run()
            out[name] = cal
        except Exception as e:  # a peer's failure is a result, not a crash
            out[name] = {"error": f"{type(e).__name__}: {e}"}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
