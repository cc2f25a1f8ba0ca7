#!/usr/bin/env python3
"""Writes mixed.nmea: a hand-made NMEA 0183 log (not a real capture) with one
line for each case `magcal import --nmea` must handle: every sentence type
read, several talkers, S/W signs, a logger's prefix, a midnight rollover, CRLF
and LF endings, a lower-case checksum, a missing checksum, a bad checksum,
truncated and malformed sentences, void fixes, unknown types, a NUL byte.

Rerun from the repository root: python3 tests/data/nmea/make_mixed.py
(then python3 tests/data/nmea/reference.py for the pynmea2 fixture).
"""
import functools
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def cs(body):
    return "%02X" % functools.reduce(lambda a, b: a ^ b, body.encode("latin-1"), 0)


def s(body, checksum="ok", end="\r\n", prefix=""):
    """A sentence: `checksum` "ok" (upper hex), "lower", "none", or the text to put after '*'."""
    lead = "!" if body.startswith("!") else "$"
    body = body.lstrip("!$")
    if checksum == "ok":
        tail = "*" + cs(body)
    elif checksum == "lower":
        tail = "*" + cs(body).lower()
    elif checksum == "none":
        tail = ""
    else:
        tail = "*" + checksum
    return prefix + lead + body + tail + end


LINES = [
    # 1: a logger's prefix before the $; 2021-02-28 23:59:58.5, 22.4 kn, course 84.4, variation 3.1 W
    s("GPRMC,235958.50,A,4807.038,N,01131.000,E,022.4,084.4,280221,003.1,W", prefix="2021-02-28 23:59:58.6 "),
    s("HCHDG,98.3,0.0,E,12.6,W"),                     # 2: sensor heading, deviation 0, variation 12.6 W
    s("HCHDG,101.5,2.5,W,3.0,E", end="\n"),           # 3: deviation 2.5 W (not applied), variation 3.0 E
    s("HEHDT,100.1,T"),                               # 4: true heading
    s("GNGGA,235959.00,3351.4560,S,15112.3450,W,2,08,0.9,10.0,M,,M,,"),  # 5: S and W negative, time of day only
    s("HCHDM,237.5,M", checksum="lower"),             # 6: a lower-case checksum (*2a)
    s("GPRMC,000000.00,A,4807.039,N,01131.001,E,021.0,085.0,010321,003.1,W"),  # 7: after midnight: 2021-03-01
    s("HCHDG,99.0,,,,", end="\n"),                    # 8: no deviation, no variation
    s("GPGLL,4807.040,N,01131.010,E,000001.00,A,A"),  # 9: GLL with time of day
    s("HCHDG,99.5,0.0,E,12.6,W", checksum="none"),    # 10: no checksum: read unverified
    s("GPVTG,054.7,T,034.4,M,005.5,N,010.2,K,A"),     # 11: VTG, knots
    s("GPVTG,054.7,T,,M,,N,010.2,K"),                 # 12: VTG, km/h only
    s("GPZDA,000002.00,01,03,2021,00,00"),            # 13: ZDA with a four-digit year
    s("HCHDG,100.0,0.0,E,12.6,W", checksum="00"),     # 14: bad checksum
    "$GPRMC,000003.00,A,4807.0\r\n",                  # 15: truncated line (no checksum)
    s("HCHDG,98.3,0.0,E"),                            # 16: too few fields (its checksum is right)
    s("HCHDM,abc,M"),                                 # 17: not a number
    s("GPRMC,000004.00,V,,,,,,,010321,,,N"),          # 18: void RMC
    s("GPGGA,000005.00,,,,,0,00,99.99,,,,,,"),        # 19: GGA without a fix
    s("IIMWV,271.0,R,000.2,N,A"),                     # 20: a type not read here (wind)
    s("PMAGI,1.58,ok"),                               # 21: proprietary
    s("!AIVDM,1,1,,A,14eG;o@034o8sd<L9i:a;WF>062D,0"),  # 22: AIS
    s("HCHDT,,T"),                                    # 23: an empty heading
    s("GPZDA,000006.00,01,03,21,00,00"),              # 24: a two-digit year (not used as a date)
    s("24HDG,182.1,00.0,E,00.0,E"),                   # 25: a numeric talker: a second compass
    s("HCHDM,1\x002.0,M"),                            # 26: a NUL byte inside
    s("GPRMC,000007.00,A,4807.041,N,01131.020,E,,,010321,,"),  # 27: no speed, no course
    s("HCHDG,370.0,0.0,E,12.6,W"),                    # 28: heading out of range
    s("HCHDM,102.0,M"),                               # 29
    s("GPRMC,000008.00,A,4807.042,N,01131.030,E,000.3,090.0,010321,003.1,W"),  # 30: slow
    s("GPRMC,000009.00,A,4807.043,N,01131.040,E,010.0,359.9,010321,,,D"),  # 31: mode D (differential)
    s("GPGLL,4807.044,N,01131.050,E,000010.00,V,N"),  # 32: void GLL
    s("HCHDM,103.0,M", checksum=cs("HCHDM,103.0,M") + "*55"),  # 33: junk after the checksum
    "garbage line without a dollar\r\n",              # 34
    "\r\n",                                           # blank (not counted)
    s("GPRMC,000011.00,A,4807.045,N,01131.060,E,010.0,010.0,320321,,"),  # 35: 32 March
    s("GPGGA,000012.5,4807.046,N,01131.070,E,1,08,0.9,545.4,M,46.9,M,,"),  # 36: GGA, time to 0.1 s
    s("HCHDM,104.0,M"),                               # 37
    s("GPRMC,000013.00,A,4807.047,N,01131.080,E,010.0,010.0,010321,003.1,W"),  # 38
]

with open(os.path.join(HERE, "mixed.nmea"), "w", encoding="latin-1", newline="") as f:
    f.write("".join(LINES))
