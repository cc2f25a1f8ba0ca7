#!/usr/bin/env python3
"""The expected value of every sentence of the NMEA test logs, read by
pynmea2 (PyPI, an independent NMEA 0183 reader), for host-tools' `nmea`
unit tests (`cargo test -p host-tools --lib nmea`). CI has no pynmea2: the
output, reference.json, is committed; this script is how it was made.

Rerun from the repository root (pynmea2 1.19.0 was used):
    pip install pynmea2
    python3 tests/data/nmea/reference.py
and commit tests/data/nmea/reference.json.

For every non-blank line (lines end at CR or LF, as in the Rust reader; `n`
counts the non-blank lines from 1) the line is cut to its first `$` or `!`
(our rule for a logger's prefix: pynmea2 itself reads only from the start
of a line) and given to `pynmea2.parse(line, check=True)`:
- `status` "ok": parsed, checksum verified; "ok_no_checksum": no `*hh`,
  parsed with check=False; "bad_checksum": pynmea2 raised ChecksumError for
  a mismatch; "parse_error": pynmea2 raised ParseError (not a sentence it
  can read, e.g. `!AIVDM`); "no_sentence": no `$`/`!` on the line.
- `type` the three-letter type (talker sentences) or `P` + manufacturer.
- For HDG, HDM, HDT, RMC, VTG, GGA, GLL, ZDA the values, converted here to
  the import's conventions, which pynmea2 does not apply itself:
  variation and deviation signed (pynmea2 gives the number and the E/W
  letter apart; here W is negative), latitude/longitude from pynmea2's
  `.latitude`/`.longitude` (decimal degrees, S/W negative) but `null` when
  the field is empty (pynmea2 then returns 0.0), time as seconds of the day
  from pynmea2's `.timestamp` (microseconds), speed in knots as given
  (`speed_kn`; the import converts to m/s with 1852/3600), `null` for an
  empty field. A field pynmea2 could not convert (it then returns the text)
  is listed in `unparsable`.
"""
import datetime
import decimal
import json
import os
import re

import pynmea2

HERE = os.path.dirname(os.path.abspath(__file__))
LOGS = ["mixed.nmea", "gofree-merrimac-head.nmea", "n2kd-183-merrimac-head.nmea"]
READ = {"HDG", "HDM", "HDT", "RMC", "VTG", "VHW", "GGA", "GLL", "ZDA"}


def num(msg, name, unparsable):
    """A numeric field as a float, None when empty."""
    v = getattr(msg, name)
    if v is None or v == "":
        return None
    if isinstance(v, (int, float, decimal.Decimal)):
        return float(v)
    unparsable.append(name)
    return None


def signed(value, letter, unparsable, name):
    if value in (None, ""):
        return None
    try:
        v = float(value)
    except ValueError:
        unparsable.append(name)
        return None
    return -v if letter == "W" else v


def seconds(t):
    if not isinstance(t, datetime.time):
        return None
    return t.hour * 3600 + t.minute * 60 + t.second + t.microsecond / 1e6


def position(msg, unparsable):
    lat = lon = None
    try:
        if msg.lat:
            lat = msg.latitude
        if msg.lon:
            lon = msg.longitude
    except ValueError:
        unparsable.append("position")
    return lat, lon


def values(msg, kind):
    u = []
    if kind == "HDG":
        v = {
            "heading": num(msg, "heading", u),
            "deviation": signed(msg.deviation, msg.dev_dir, u, "deviation"),
            "variation": signed(msg.variation, msg.var_dir, u, "variation"),
        }
    elif kind in ("HDM", "HDT"):
        v = {"heading": num(msg, "heading", u)}
    elif kind == "RMC":
        lat, lon = position(msg, u)
        date = None
        try:
            d = msg.datestamp
            if isinstance(d, datetime.date):
                date = [d.year, d.month, d.day]
            elif d:
                u.append("date")
        except ValueError:
            u.append("date")
        v = {
            "time": seconds(msg.timestamp),
            "fix_status": msg.status,
            "lat": lat,
            "lon": lon,
            "speed_kn": num(msg, "spd_over_grnd", u),
            "course": num(msg, "true_course", u),
            "date": date,
            "variation": signed(msg.mag_variation, msg.mag_var_dir, u, "variation"),
            "mode": msg.mode_indicator,
        }
    elif kind == "VTG":
        v = {
            "course": num(msg, "true_track", u),
            "speed_kn": num(msg, "spd_over_grnd_kts", u),
            "speed_kmh": num(msg, "spd_over_grnd_kmph", u),
            "mode": msg.faa_mode,
        }
    elif kind == "VHW":
        v = {
            "speed_kn": num(msg, "water_speed_knots", u),
            "speed_kmh": num(msg, "water_speed_km", u),
        }
    elif kind == "GGA":
        lat, lon = position(msg, u)
        q = msg.gps_qual
        v = {"time": seconds(msg.timestamp), "lat": lat, "lon": lon, "quality": q if isinstance(q, int) else None}
    elif kind == "GLL":
        lat, lon = position(msg, u)
        v = {"time": seconds(msg.timestamp), "lat": lat, "lon": lon, "fix_status": msg.status, "mode": msg.faa_mode}
    else:  # ZDA
        v = {"time": seconds(msg.timestamp), "day": msg.day, "month": msg.month, "year": msg.year}
    if u:
        v["unparsable"] = u
    return v


def entry(n, raw):
    text = raw.decode("latin-1")
    m = re.search(r"[$!]", text)
    if not m:
        return {"n": n, "status": "no_sentence"}
    line = text[m.start():].rstrip(" \t")
    status = "ok"
    try:
        msg = pynmea2.parse(line, check=True)
    except pynmea2.ChecksumError as e:
        if "missing" not in str(e):
            return {"n": n, "status": "bad_checksum"}
        status = "ok_no_checksum"
        try:
            msg = pynmea2.parse(line, check=False)
        except pynmea2.ParseError:
            return {"n": n, "status": "parse_error"}
    except pynmea2.ParseError:
        return {"n": n, "status": "parse_error"}
    if isinstance(msg, pynmea2.TalkerSentence):
        kind, talker = msg.sentence_type, msg.talker
    elif isinstance(msg, pynmea2.ProprietarySentence):
        kind, talker = "P" + msg.manufacturer, None
    else:
        kind, talker = type(msg).__name__, None
    e = {"n": n, "status": status, "type": kind}
    if kind in READ:
        e["talker"] = talker
        e["fields"] = len(msg.data)
        e.update(values(msg, kind))
    return e


def main():
    out = {"pynmea2": pynmea2.version if hasattr(pynmea2, "version") else pynmea2.__version__, "logs": {}}
    for name in LOGS:
        data = open(os.path.join(HERE, name), "rb").read()
        raws = [r for r in re.split(rb"[\r\n]", data) if r.strip()]
        out["logs"][name] = [entry(n, r) for n, r in enumerate(raws, 1)]
    with open(os.path.join(HERE, "reference.json"), "w") as f:
        f.write("{\n")
        f.write('"pynmea2": %s,\n"logs": {\n' % json.dumps(out["pynmea2"]))
        logs = list(out["logs"].items())
        for i, (name, entries) in enumerate(logs):
            f.write("%s: [\n" % json.dumps(name))
            f.write(",\n".join(json.dumps(e, separators=(",", ":")) for e in entries))
            f.write("\n]%s\n" % ("," if i + 1 < len(logs) else ""))
        f.write("}\n}\n")


if __name__ == "__main__":
    main()
