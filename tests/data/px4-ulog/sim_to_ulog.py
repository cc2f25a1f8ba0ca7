#!/usr/bin/env python3
"""Writes a magcal recording (CSV: t, mx, my, mz, roll_deg, pitch_deg,
true_heading_deg) as a PX4 ULog, written here from the PX4 documentation's
"ULog File Format" with the standard library only: header, flag bits, the
version information, the formats of PX4 v1.14's sensor_mag and
vehicle_attitude, the CAL_MAG0 parameters (no correction: offsets 0, scales
1, rotation 0), the subscriptions and one sensor_mag and one vehicle_attitude
message a row at the row's time.

The field: the recording's numbers as nT, written in gauss (x·1e-5), so
`magcal import` gives them back in gauss and `--columns mx=mx:gauss,…` turns
them back into the recording's numbers. The attitude: roll_deg, pitch_deg and
true_heading_deg as PX4's quaternion (Hamilton w, x, y, z, body FRD to NED,
Z-Y-X).

Made by: magcal simulate swing --seed 1 --rate-hz 0.5 --out sim_swing.csv
         python3 sim_to_ulog.py sim_swing.csv sim_swing.ulg
"""
import csv
import math
import struct
import sys

DEVICE_ID = 396825  # an internal magnetometer's id as PX4 writes it
VER_SW_RELEASE = 0x010E00FF  # v1.14.0, release


def msg(kind, payload):
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def quaternion(roll_deg, pitch_deg, yaw_deg):
    r, p, y = (math.radians(a) / 2 for a in (roll_deg, pitch_deg, yaw_deg))
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


def main(src, dst):
    rows = list(csv.DictReader(open(src)))
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += msg("B", bytes(40))
    for key, value in [("uint32_t ver_sw_release", struct.pack("<I", VER_SW_RELEASE)), ("char[3] sys_name", b"PX4")]:
        out += msg("I", bytes([len(key)]) + key.encode() + value)
    out += msg("F", b"sensor_mag:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;float y;"
                    b"float z;float temperature;uint32_t error_count;bool is_external;uint8_t[7] _padding0;")
    out += msg("F", b"vehicle_attitude:uint64_t timestamp;uint64_t timestamp_sample;float[4] q;"
                    b"float[4] delta_q_reset;uint8_t quat_reset_counter;uint8_t[7] _padding0;")
    for name, value in [("int32_t CAL_MAG0_ID", struct.pack("<i", DEVICE_ID)), ("int32_t CAL_MAG0_ROT", struct.pack("<i", 0))] + [
            (f"float CAL_MAG0_{a}{k}", struct.pack("<f", v)) for a in "XYZ" for k, v in (("OFF", 0.0), ("SCALE", 1.0))]:
        out += msg("P", bytes([len(name)]) + name.encode() + value)
    out += msg("A", struct.pack("<BH", 0, 0) + b"sensor_mag")
    out += msg("A", struct.pack("<BH", 0, 1) + b"vehicle_attitude")
    for r in rows:
        t_us = round(float(r["t"]) * 1e6) + 1_000_000
        m = [float(r[k]) * 1e-5 for k in ("mx", "my", "mz")]
        # Written without the trailing padding, as PX4's logger does.
        out += msg("D", struct.pack("<HQQI4fIB", 0, t_us, t_us, DEVICE_ID, *m, math.nan, 0, 0))
        q = quaternion(float(r["roll_deg"]), float(r["pitch_deg"]), float(r["true_heading_deg"]))
        out += msg("D", struct.pack("<HQQ4f4fB", 1, t_us, t_us, *q, 0, 0, 0, 0, 0))
    open(dst, "wb").write(bytes(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
