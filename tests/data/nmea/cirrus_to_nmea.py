#!/usr/bin/env python3
"""Writes cirrus-hdm-rmc.nmea: the real readings of the yacht "Cirrus"
(tests/data/cirrus-yacht: the magnetic compass's HDM heading and the GPS
course over ground, with their UTC timestamps, MIT licence) re-encoded as
NMEA 0183 sentences. It is NOT a captured log: the values are real, the
sentences are written here.

- one `$GPRMC,hhmmss.00,A,,,,,,COG,250821,,*hh` per course reading, at its
  timestamp (status A; position, speed and variation empty: not stored);
- one `$HCHDM,HDG,M*hh` per compass reading, in the order stored, after the
  RMC of the same second (a GPS sends its epoch at the start of a second;
  the compass readings stamped with that second came during it);
- all in timestamp order (stable within a second): the source stores some
  readings out of order (117 compass and 12 course readings step back by a
  second or two), a receiver's log would not;
- CRLF line ends, checksums computed.

Rerun from the repository root: python3 tests/data/nmea/cirrus_to_nmea.py
"""
import csv
import functools
import os

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.join(HERE, "..", "cirrus-yacht")


def sentence(body):
    return "$%s*%02X\r\n" % (body, functools.reduce(lambda a, b: a ^ b, body.encode("ascii"), 0))


def rows(name, column):
    with open(os.path.join(SRC, name), newline="") as f:
        return [(r["timestamp_utc"], r[column]) for r in csv.DictReader(f)]


events = []
for stamp, cog in rows("Calibration_Cirrus_v3_cog.csv", "cog_true_deg"):
    events.append((stamp, 0, len(events), "GPRMC,%s.00,A,,,,,,%s,%s,," % (stamp[11:19].replace(":", ""), cog, stamp[8:10] + stamp[5:7] + stamp[2:4])))
for stamp, hdm in rows("Calibration_Cirrus_v3_compass.csv", "hdm_compass_deg"):
    events.append((stamp, 1, len(events), "HCHDM,%s,M" % hdm))
events.sort()
with open(os.path.join(HERE, "cirrus-hdm-rmc.nmea"), "w", newline="") as f:
    f.write("".join(sentence(e[3]) for e in events))
