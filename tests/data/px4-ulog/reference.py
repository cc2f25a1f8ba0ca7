#!/usr/bin/env python3
"""The independent reading of the ULog fixtures: pyulog (PX4's own Python
reader, `python3 -m pip install pyulog`; 1.3.0 was used) writes reference.json,
which magcal's tests compare `magcal import` against:

* counts: data messages per topic and instance (multi_id), dropouts, appended
  data sections;
* cases: for each import the tests run (its magcal arguments), every row's
  time and columns, computed here from pyulog's arrays: the field (with PX4's
  pre-v1.12 driver correction undone, `field/SCALE + OFF`, for sensor_mag),
  roll, pitch and yaw from vehicle_attitude's quaternion (aerospace Z-Y-X), the
  gyro from sensor_combined, the GNSS from vehicle_gps_position, each carried to
  the compass's times as magcal's import documents it (interpolated between
  the two samples around a row when both are within 1 s, else the latest
  within 1 s; angles the short way).

Usage: python3 reference.py            writes reference.json from the *_cut.ulg
       python3 reference.py FILE.ulg…  prints the counts of other files (the
                                       full samples in /work/shared/data/px4-ulog)
"""
import bisect
import json
import math
import sys

from pyulog import ULog

MAX_AGE_S = 1.0
MIN_COURSE_SPEED_MPS = 0.5


def counts(u):
    return {f"{d.name}/{d.multi_id}": len(d.data["timestamp"]) for d in u.data_list}


def euler_deg(w, x, y, z):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return [math.degrees(roll), math.degrees(pitch), math.degrees(yaw) % 360.0]


def wrap180(a):
    w = a % 360.0
    return w - 360.0 if w > 180.0 else w


def at(ts, vals, kinds, t):
    """vals[i] (lists) at time t as magcal's import carries a message to a row."""
    i = bisect.bisect_right(ts, t)
    if i == 0 or t - ts[i - 1] > MAX_AGE_S:
        return [None] * len(kinds)
    t0, v0 = ts[i - 1], vals[i - 1]
    if i == len(ts) or ts[i] - t > MAX_AGE_S or ts[i] <= t0:
        return list(v0)
    t1, v1 = ts[i], vals[i]
    w = (t - t0) / (t1 - t0)
    out = []
    for k, kind in enumerate(kinds):
        a, b = v0[k], v1[k]
        if kind == "linear":
            out.append(a + w * (b - a))
        elif kind == "angle":
            out.append(wrap180(a + w * wrap180(b - a)))
        else:  # heading
            out.append((a + w * wrap180(b - a)) % 360.0)
    return out


def clean(v):
    """JSON's value: null for none or NaN, else 12 significant digits (far
    below the tests' tolerances)."""
    return None if v is None or not math.isfinite(v) else float(f"{v:.12g}")


def case(u, args, topic, instance):
    p = u.initial_parameters
    d = u.get_dataset(topic, instance).data
    t_s, field = [], []
    if topic == "sensor_combined":
        for k in range(len(d["timestamp"])):
            t = (int(d["timestamp"][k]) + int(d["magnetometer_timestamp_relative"][k])) * 1e-6
            if t_s and t_s[-1] == t:
                continue
            t_s.append(t)
            field.append([float(d[f"magnetometer_ga[{a}]"][k]) for a in range(3)])
    elif topic == "vehicle_magnetometer":
        t_s = [int(v) * 1e-6 for v in d["timestamp"]]
        field = [[float(d[f"magnetometer_ga[{a}]"][k]) for a in range(3)] for k in range(len(t_s))]
    else:
        t_s = [int(v) * 1e-6 for v in d["timestamp"]]
        field = [[float(d[a][k]) for a in "xyz"] for k in range(len(t_s))]
        version = u.get_version_info()
        if version is not None and version[:2] < (1, 12):
            cal = next(k for k in range(10) if p.get(f"CAL_MAG{k}_ID") == int(d["device_id"][0]))
            off = [p[f"CAL_MAG{cal}_{a}OFF"] for a in "XYZ"]
            scale = [p[f"CAL_MAG{cal}_{a}SCALE"] for a in "XYZ"]
            field = [[m[a] / scale[a] + off[a] for a in range(3)] for m in field]
    rows = {"t": [clean(t) for t in t_s]}
    for a, name in enumerate(["mx", "my", "mz"]):
        rows[name] = [clean(m[a]) for m in field]

    att = u.get_dataset("vehicle_attitude").data
    ts = [int(v) * 1e-6 for v in att["timestamp"]]
    vals = [euler_deg(*(float(att[f"q[{i}]"][k]) for i in range(4))) for k in range(len(ts))]
    e = [at(ts, vals, ["angle", "angle", "heading"], t) for t in t_s]
    for k, name in enumerate(["roll_deg", "pitch_deg", "ahrs_yaw_deg"]):
        rows[name] = [clean(r[k]) for r in e]

    sc = u.get_dataset("sensor_combined").data
    ts = [int(v) * 1e-6 for v in sc["timestamp"]]
    vals = [[float(sc[f"gyro_rad[{a}]"][k]) for a in range(3)] for k in range(len(ts))]
    g = [at(ts, vals, ["linear"] * 3, t) for t in t_s]
    for k, name in enumerate(["gx", "gy", "gz"]):
        rows[name] = [clean(r[k]) for r in g]

    names = {d.name for d in u.data_list}
    if "vehicle_gps_position" in names:
        gp = u.get_dataset("vehicle_gps_position").data
        ts, vals = [], []
        for k in range(len(gp["timestamp"])):
            if gp["fix_type"][k] < 2:
                continue
            course = math.degrees(float(gp["cog_rad"][k])) % 360.0
            speed = float(gp["vel_m_s"][k])
            ref = course if speed >= MIN_COURSE_SPEED_MPS else math.nan
            ts.append(int(gp["timestamp"][k]) * 1e-6)
            vals.append([int(gp["lat"][k]) * 1e-7, int(gp["lon"][k]) * 1e-7, course, speed, ref])
        r = [at(ts, vals, ["linear", "linear", "heading", "linear", "heading"], t) for t in t_s]
        for k, name in enumerate(["lat_deg", "lon_deg", "course_deg", "gps_speed_mps", "ref_heading_deg"]):
            rows[name] = [clean(x[k]) for x in r]
    return {"args": args, "rows": len(t_s), "columns": rows}


def reference(path, cases):
    u = ULog(path)
    return {
        "pyulog_counts": counts(u),
        "dropouts": len(u.dropouts),
        "appended_sections": len(u._appended_offsets),  # pylint: disable=protected-access
        "cases": [case(u, *c) for c in cases],
    }


def main():
    if len(sys.argv) > 1:
        for path in sys.argv[1:]:
            u = ULog(path)
            print(path, json.dumps(counts(u), sort_keys=True), "dropouts", len(u.dropouts))
        return
    out = {
        "sample_log_small_cut.ulg": reference("sample_log_small_cut.ulg", [
            ([], "sensor_mag", 0),
            (["--instance", "1"], "sensor_mag", 1),
            (["--topic", "vehicle_magnetometer"], "vehicle_magnetometer", 0),
        ]),
        "sample_appended_multiple_cut.ulg": reference("sample_appended_multiple_cut.ulg", [
            ([], "sensor_combined", 0),
        ]),
    }
    with open("reference.json", "w") as f:
        json.dump(out, f, sort_keys=True)
        f.write("\n")


if __name__ == "__main__":
    main()
