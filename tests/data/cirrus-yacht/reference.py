"""The independent reference for the heading-only swing on the Cirrus
yacht's circles: a plain 5-term least squares (numpy) of course − compass
against the compass heading, at the best course delay on a 0.05 s grid over
±5 s, and the same fit judged on held-out halves.

The compass log is built by the rule of host-tools' test (README.md here):
the k-th of n compass readings stamped with one second is at that second
+ k/n; each course is at its own stamp; the compass heading at a course's
time less the delay is interpolated along the shorter arc between the two
neighbouring readings when they are at most 1 s apart.

It also writes that compass log, `compass_log.csv` (`t`,
`compass_heading_deg`, `ref_heading_deg`: one row per reading, in time
order), which the Rust tests and the bench read.

Rerun: `python3 tests/data/cirrus-yacht/reference.py > tests/data/cirrus-yacht/reference.json`
(numpy; the outputs are committed, CI does not run this).
"""
import csv
import datetime as dt
import json
import os
from collections import OrderedDict

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def stamp(text):
    return dt.datetime.fromisoformat(text).replace(tzinfo=dt.timezone.utc).timestamp()


def load():
    compass = list(csv.DictReader(open(os.path.join(HERE, "Calibration_Cirrus_v3_compass.csv"))))
    cog = list(csv.DictReader(open(os.path.join(HERE, "Calibration_Cirrus_v3_cog.csv"))))
    t0 = stamp(compass[0]["timestamp_utc"])
    by = OrderedDict()
    for r in compass:
        by.setdefault(r["timestamp_utc"], []).append(float(r["hdm_compass_deg"]))
    ct, ch = [], []
    for k, v in by.items():
        for i, h in enumerate(v):
            ct.append(stamp(k) - t0 + i / len(v))
            ch.append(h)
    gt = np.array([stamp(r["timestamp_utc"]) - t0 for r in cog])
    gc = np.array([float(r["cog_true_deg"]) for r in cog])
    rows = [(t, "%.1f" % h, "") for t, h in zip(ct, ch)] + [(t, "", "%.1f" % c) for t, c in zip(gt, gc)]
    rows.sort(key=lambda r: r[0])
    with open(os.path.join(HERE, "compass_log.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["t", "compass_heading_deg", "ref_heading_deg"])
        w.writerows([("%.4f" % t, h, c) for t, h, c in rows])
    return np.array(ct), np.radians(ch), gt, np.radians(gc)


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def compass_at(ct, ch, t, gap=1.0):
    j = np.searchsorted(ct, t, side="right")
    out = np.full(len(t), np.nan)
    for n, (tt, k) in enumerate(zip(t, j)):
        if k == 0 or k >= len(ct):
            continue
        a, b = k - 1, k
        if ct[b] - ct[a] > gap:
            continue
        f = (tt - ct[a]) / (ct[b] - ct[a]) if ct[b] > ct[a] else 0.0
        out[n] = (ch[a] + f * wrap(ch[b] - ch[a])) % (2 * np.pi)
    return out


def design(h):
    return np.c_[np.ones_like(h), np.sin(h), np.cos(h), np.sin(2 * h), np.cos(2 * h)]


def fit(h, e):
    return np.linalg.lstsq(design(h), e, rcond=None)[0]


def main(declination_deg=3.0):
    ct, ch, gt, gc = load()
    ref = gc - np.radians(declination_deg)
    best = None
    for d in np.arange(-5.0, 5.0001, 0.05):
        h = compass_at(ct, ch, gt - d)
        ok = np.isfinite(h)
        e = wrap(ref[ok] - h[ok])
        c = fit(h[ok], e)
        r = wrap(e - design(h[ok]) @ c)
        rms = np.degrees(np.sqrt(np.mean(r ** 2)))
        if best is None or rms < best[0]:
            best = (rms, d, c, int(ok.sum()))
    rms, d, c, n = best
    # Held out at that delay: each half (split at the median course time)
    # corrected by the other half's fit.
    h = compass_at(ct, ch, gt - d)
    ok = np.isfinite(h)
    t, hh, e = gt[ok], h[ok], wrap(ref[ok] - h[ok])
    split = t[len(t) // 2]
    before, after = [], []
    for first in (True, False):
        train, test = (t < split) == first, (t < split) != first
        cc = fit(hh[train], e[train])
        before.extend(e[test])
        after.extend(wrap(e[test] - design(hh[test]) @ cc))
    rms_deg = lambda v: float(np.degrees(np.sqrt(np.mean(np.square(v)))))
    print(json.dumps({
        "source": "numpy 5-term least squares, best delay on a 0.05 s grid over ±5 s (reference.py)",
        "declination_deg": declination_deg,
        "best_delay_s": round(float(d), 3),
        "pairs": n,
        "residual_rms_deg": round(float(rms), 4),
        "terms_deg": [round(float(v), 4) for v in np.degrees(c)],
        "before_rms_deg": round(rms_deg(wrap(ref[ok] - h[ok])), 4),
        "held_out_before_rms_deg": round(rms_deg(before), 4),
        "held_out_after_rms_deg": round(rms_deg(after), 4),
    }, indent=2))


if __name__ == "__main__":
    main()
