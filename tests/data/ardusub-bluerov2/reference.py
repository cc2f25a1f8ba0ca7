"""The independent reading of this folder's logs, by pymavlink (2.4.x):
message counts and the values the Rust tests compare against, written to
reference.json. Run again only when the logs change:

    python3 -m pip install pymavlink numpy
    python3 reference.py [small.tlog small.BIN [reference.json]]

What is computed here besides pymavlink's decoding, written from the rules
the importers document (not from their code):
- the tlog's raw field: ArduPilot sends its corrected field
  (field = Mat·(s·(raw + Ofs)), AP_Compass_Backend::correct_field), so
  raw = (s·Mat)⁻¹·field − Ofs with the COMPASS_* PARAM_VALUEs in force at
  each sample in log order (before a parameter is first sent, its first
  value in the log);
- ATTITUDE at each RAW_IMU time and the first IMU's gyro at each MAG time:
  linear between the samples around it when both are within 1 s, else the
  latest within 1 s (headings the short way).
"""
import json
import math
import sys
from collections import Counter

import numpy as np
from importlib.metadata import version
from pymavlink import DFReader, mavutil

MAX_AGE_S = 1.0


def carried(ts, vs, t, angle=False):
    """The value at t from samples (ts ascending), as rules::Series::at."""
    i = int(np.searchsorted(ts, t, side="right"))
    if i == 0 or t - ts[i - 1] > MAX_AGE_S:
        return None
    t0, v0 = ts[i - 1], vs[i - 1]
    if i == len(ts) or ts[i] - t > MAX_AGE_S or ts[i] <= t0:
        return list(v0)
    w = (t - t0) / (ts[i] - t0)
    out = []
    for k, (a, b) in enumerate(zip(v0, vs[i])):
        if angle and k == 2:
            d = (b - a + 180.0) % 360.0 - 180.0
            out.append((a + w * d) % 360.0)
        else:
            out.append(a + w * (b - a))
    return out


def tlog(path):
    m = mavutil.mavlink_connection(path, dialect="ardupilotmega")
    counts = Counter()
    msgs = []
    while True:
        msg = m.recv_msg()
        if msg is None:
            break
        counts[msg.get_type()] += 1
        if msg.get_type() != "BAD_DATA":
            msgs.append(msg)
    pilot = next((x.get_srcSystem(), x.get_srcComponent()) for x in msgs if x.get_type() == "HEARTBEAT" and x.autopilot != 8)
    ours = [x for x in msgs if (x.get_srcSystem(), x.get_srcComponent()) == pilot]
    first = {}
    for x in ours:
        if x.get_type() == "PARAM_VALUE" and x.param_id.startswith("COMPASS_"):
            first.setdefault(x.param_id, x.param_value)

    def raw(field, params, inst):
        sfx = "" if inst == 0 else str(inst + 1)
        p = lambda n, d: params.get(f"COMPASS_{n}", first.get(f"COMPASS_{n}", d))
        dia = [p(f"DIA{sfx}_{a}", 1.0) for a in "XYZ"]
        odi = [p(f"ODI{sfx}_{a}", 0.0) for a in "XYZ"]
        ofs = np.array([p(f"OFS{sfx}_{a}", math.nan) for a in "XYZ"])
        if dia == [0.0, 0.0, 0.0]:
            dia = [1.0, 1.0, 1.0]
        s = p(f"SCALE{sfx}", 1.0)
        s = s if 1 / 1.5 <= s <= 1.5 else 1.0
        mat = s * np.array([[dia[0], odi[0], odi[1]], [odi[0], dia[1], odi[2]], [odi[1], odi[2], dia[2]]])
        return list(np.linalg.solve(mat, np.array(field, dtype=float)) - ofs)

    params = {}
    raw_imu, scaled2, att, gps = [], [], [], []
    for x in ours:
        t = x.get_type()
        if t == "PARAM_VALUE" and x.param_id.startswith("COMPASS_"):
            params[x.param_id] = x.param_value
        elif t == "RAW_IMU":
            f = [x.xmag, x.ymag, x.zmag]
            raw_imu.append({"time_usec": x.time_usec, "mag": f, "gyro": [x.xgyro, x.ygyro, x.zgyro], "raw": raw(f, params, 0)})
        elif t == "SCALED_IMU2":
            f = [x.xmag, x.ymag, x.zmag]
            scaled2.append({"time_boot_ms": x.time_boot_ms, "mag": f, "raw": raw(f, params, 1)})
        elif t == "ATTITUDE":
            att.append([x.time_boot_ms, x.roll, x.pitch, x.yaw])
        elif t == "GPS_RAW_INT":
            gps.append({"time_usec": x.time_usec, "lat": x.lat, "lon": x.lon, "vel": x.vel, "cog": x.cog, "fix_type": x.fix_type, "yaw": x.yaw})
    ts = np.array([a[0] * 1e-3 for a in att])
    vs = [[math.degrees(a[1]), math.degrees(a[2]), math.degrees(a[3]) % 360.0] for a in att]
    for r in raw_imu:
        r["attitude_deg"] = carried(ts, vs, r["time_usec"] * 1e-6, angle=True)
    return {
        "reader": "pymavlink " + version("pymavlink"),
        "autopilot": list(pilot),
        "counts": dict(sorted(counts.items())),
        "RAW_IMU": raw_imu,
        "SCALED_IMU2": scaled2,
        "ATTITUDE": att,
        "GPS_RAW_INT": gps,
    }


def dataflash(path):
    log = DFReader.DFReader_binary(path, zero_time_base=True)
    counts = Counter()
    mag, imu = [], []
    while True:
        m = log.recv_msg()
        if m is None:
            break
        t = m.get_type()
        counts[t] += 1
        if t == "MAG" and getattr(m, "I", 0) == 0:
            mag.append(m.TimeUS)
        elif t == "IMU" and getattr(m, "I", 0) == 0:
            imu.append([m.TimeUS, m.GyrX, m.GyrY, m.GyrZ])
    ts = np.array([i[0] * 1e-6 for i in imu])
    vs = [i[1:] for i in imu]
    gyro = [carried(ts, vs, t * 1e-6) for t in mag]
    return {"counts": dict(sorted(counts.items())), "MAG0_TimeUS": mag, "IMU0": imu, "gyro_at_MAG0": gyro}


if __name__ == "__main__":
    args = sys.argv[1:] or ["small.tlog", "small.BIN", "reference.json"]
    out = {"tlog": tlog(args[0]), "dataflash": dataflash(args[1])}
    dst = args[2] if len(args) > 2 else "reference.json"
    with open(dst, "w") as f:
        json.dump(out, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(dst, "tlog counts:", out["tlog"]["counts"])
    print(dst, "dataflash counts:", out["dataflash"]["counts"])
