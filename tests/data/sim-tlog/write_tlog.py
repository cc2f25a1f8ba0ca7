"""Writes a simulated recording (`magcal simulate`) as a MAVLink telemetry
log the way an ArduSub vehicle's topside records one, with pymavlink's
encoder: for the round trip `magcal import` → `magcal fit` against the CSV.

    magcal simulate swing --seed 1 --rate-hz 2 --out swing.csv
    python3 write_tlog.py swing.csv swing.tlog

The log: the autopilot's HEARTBEAT (sysid 1, compid 1, ArduPilot,
submarine) once a second; its compass parameters (offsets 0, DIA 1, ODI 0,
SCALE 1: the field it sends is then the raw field, so the round trip is
exact); per row a RAW_IMU (the simulator's raw counts as the field, the
sensor's own integers; time_usec on a boot clock starting at 100 s) and an
ATTITUDE (roll, pitch in rad; yaw the simulator's true heading), each after
the 8-byte big-endian µs time of a tlog record. MAVLink 2 frames.
"""
import csv
import math
import struct
import sys

from pymavlink.dialects.v20 import ardupilotmega as mav

BOOT_S = 100.0
UNIX0_US = 1_700_000_000_000_000


class Sink:
    def __init__(self):
        self.buf = bytearray()

    def write(self, b):
        self.buf += b


def main(src, dst):
    rows = list(csv.DictReader(open(src)))
    sink = Sink()
    m = mav.MAVLink(sink, srcSystem=1, srcComponent=1)
    out = bytearray()

    def send(t_s, msg):
        sink.buf = bytearray()
        m.send(msg)
        out.extend(struct.pack(">Q", UNIX0_US + round(t_s * 1e6)))
        out.extend(sink.buf)

    hb = lambda: mav.MAVLink_heartbeat_message(mav.MAV_TYPE_SUBMARINE, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0, 3)
    send(0.0, hb())
    params = [(f"COMPASS_OFS_{a}", 0.0) for a in "XYZ"] + [(f"COMPASS_DIA_{a}", 1.0) for a in "XYZ"]
    params += [(f"COMPASS_ODI_{a}", 0.0) for a in "XYZ"] + [("COMPASS_SCALE", 1.0)]
    for i, (name, value) in enumerate(params):
        send(0.001 * (i + 1), mav.MAVLink_param_value_message(name.encode(), value, mav.MAV_PARAM_TYPE_REAL32, len(params), i))
    last_hb = 0.0
    for r in rows:
        t = float(r["t"])
        if t - last_hb >= 1.0:
            send(t, hb())
            last_hb = t
        boot_us = round((BOOT_S + t) * 1e6)
        field = [int(float(r[k])) for k in ("mx", "my", "mz")]
        send(t + 0.01, mav.MAVLink_raw_imu_message(boot_us, 0, 0, 0, 0, 0, 0, *field, 0, 0))
        rad = lambda k: math.radians(float(r[k])) if r[k] else float("nan")
        yaw = math.radians(float(r["true_heading_deg"]))
        yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        send(t + 0.02, mav.MAVLink_attitude_message(boot_us // 1000, rad("roll_deg"), rad("pitch_deg"), yaw, 0.0, 0.0, 0.0))
    open(dst, "wb").write(out)
    print(f"{dst}: {len(rows)} rows, {len(out)} bytes")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
