#!/usr/bin/env python3
"""Writes cirrus-fast.all: the real readings of the yacht "Cirrus"
(tests/data/cirrus-yacht: the magnetic compass's heading and the GPS course
over ground with their UTC timestamps, MIT licence) re-encoded as canboat
FAST lines, as a heading-only NMEA 2000 log. It is NOT a captured log: the
values are real, the lines are written here.

- `# format=FAST` first;
- one PGN 127250 Vessel Heading per compass reading from source 1: SID 0xff
  (not available), heading = round(radians(hdm) / 0.0001) (unsigned 16
  bits), deviation and variation 0x7fff (not available), reference magnetic
  (byte 7 = 0xfd: bits 0-1 = 1, reserved bits set); the k-th of n readings
  stamped with one second at that second + k/n (to the millisecond);
- one PGN 129026 COG & SOG Rapid Update per course reading from source 2,
  at its stamp: SID 0xff, COG reference true (byte 1 = 0xfc), COG =
  round(radians(cog) / 0.0001), SOG 0xffff (not available: not stored);
- all in time order (the source stores some readings a second or two out
  of order; a logger's lines are in time order).

Rerun from the repository root:
  python3 tests/data/nmea2000-canboat/cirrus_to_canboat.py
"""
import csv
import math
import os
from datetime import datetime, timedelta, timezone

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.join(HERE, "..", "cirrus-yacht")


def rows(name, column):
    with open(os.path.join(SRC, name), newline="") as f:
        return [(r["timestamp_utc"], float(r[column])) for r in csv.DictReader(f)]


def stamp(text, offset_s):
    t = datetime.fromisoformat(text).replace(tzinfo=timezone.utc) + timedelta(milliseconds=round(offset_s * 1000))
    return t.strftime("%Y-%m-%dT%H:%M:%S.") + "%03dZ" % (t.microsecond // 1000)


def angle(deg):
    raw = round(math.radians(deg % 360.0) / 0.0001)
    return [raw & 0xFF, raw >> 8]


events = []
compass = rows("Calibration_Cirrus_v3_compass.csv", "hdm_compass_deg")
per_second = {}
for s, _ in compass:
    per_second[s] = per_second.get(s, 0) + 1
seen = {}
for s, hdm in compass:
    k = seen.get(s, 0)
    seen[s] = k + 1
    t = stamp(s, k / per_second[s])
    events.append((t, len(events), "%s,2,127250,1,255,8,%s" % (t, ",".join("%02x" % b for b in [0xFF] + angle(hdm) + [0xFF, 0x7F, 0xFF, 0x7F, 0xFD]))))
for s, cog in rows("Calibration_Cirrus_v3_cog.csv", "cog_true_deg"):
    t = stamp(s, 0)
    events.append((t, len(events), "%s,2,129026,2,255,8,%s" % (t, ",".join("%02x" % b for b in [0xFF, 0xFC] + angle(cog) + [0xFF, 0xFF, 0xFF, 0xFF]))))
events.sort()
with open(os.path.join(HERE, "cirrus-fast.all"), "w", newline="\n") as f:
    f.write("# format=FAST\n" + "".join(e[2] + "\n" for e in events))
