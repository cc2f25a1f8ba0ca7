#!/usr/bin/env python3
"""The independent reading of the NMEA 2000 test logs: a decode written from
canboat's published PGN definitions (canboat-extract.json, an unchanged
extract of canboat.json v6.0.1 from the npm package @canboat/pgns 6.0.2),
not from the importer's code. Writes reference.json, which the Rust tests
compare against (host-tools data::import::nmea2000, magcal's
import_formats::nmea2000).

How it reads:
- lines `timestamp,priority,PGN,source,destination,length,hex...`; `#` lines
  are comments (`# format=FAST|PLAIN` names the format); a line whose byte
  count differs from its length, whose bytes are not hex, or whose header is
  not numbers is refused and counted;
- the format: as the header names it, else FAST when a line holds more than
  8 bytes, else PLAIN; in PLAIN, a PGN of canboat's FastPGNs list (or
  130816-131071) is reassembled from its frames (byte 0: sequence << 5 |
  index; first frame: length, 6 bytes; later frames: 7 bytes; a frame out
  of sequence drops its packet);
- a field's value = raw * Resolution when RangeMin <= raw * Resolution <=
  RangeMax (canboat's range; the not-available codes fall outside), else
  None; BitOffset, BitLength, Signed from the definition;
- PGN 65350: canboat's definition is incomplete ("Missing": Fields, ...);
  its A/B/C/D layout is not used. x, y, z are read as little-endian int16 at
  bytes 0, 2, 4 with NMEA 2000's rule for an undefined int16 (0x7ffd-0x7fff
  not values): the layout the importer documents, checked here only for
  the byte arithmetic, not for its meaning.
- timestamps: datetime.fromisoformat (UTC with Z) -> s since 1970.

Output, per file: format, message lines, CAN frames (PLAIN), whole messages
by "PGN/source", refusals by kind, and every decoded message of the six
PGNs read ("PGN/source": [[t, values...], ...], angles in degrees, None for
not available); for triton: the magnetic minus the true heading (each
magnetic heading of source 27 with the true heading of source 52 nearest in
time, within 0.1 s).

Rerun from the repository root:
  python3 tests/data/nmea2000-canboat/reference.py
and on the full shared files (counts only, printed):
  python3 tests/data/nmea2000-canboat/reference.py --full ../shared/data/nmea2000-canboat
"""
import json
import math
import os
import sys
from datetime import datetime

HERE = os.path.dirname(os.path.abspath(__file__))
EXTRACT = json.load(open(os.path.join(HERE, "canboat-extract.json")))
DEFS = {p["PGN"]: p for p in EXTRACT["PGNs"]}
FAST = set(EXTRACT["FastPGNs"])
READ = (127250, 127251, 127257, 129025, 129026, 65350)
FILES = ("triton-head.all", "triton-head-plain.raw", "furuno-wide-turn-head.raw")


def stamp(s):
    return datetime.fromisoformat(s).timestamp()


def field(data, f):
    """A canboat field's value, or None outside its range."""
    off, n = f["BitOffset"], f["BitLength"]
    if (off + n + 7) // 8 > len(data):
        return None
    raw = (int.from_bytes(bytes(data), "little") >> off) & ((1 << n) - 1)
    if f.get("Signed") and raw >> (n - 1):
        raw -= 1 << n
    if f["FieldType"] == "LOOKUP":
        return raw
    res = f["Resolution"]
    lo = math.ceil(f["RangeMin"] / res - 1e-6)
    hi = math.floor(f["RangeMax"] / res + 1e-6)
    return raw * res if lo <= raw <= hi else None


def by_id(pgn, data):
    return {f["Id"]: field(data, f) for f in DEFS[pgn]["Fields"] if f["FieldType"] != "RESERVED"}


def deg(v):
    return None if v is None else math.degrees(v)


def decode(pgn, data):
    if len(data) < 8:
        return None
    if pgn == 65350:
        out = []
        for at in (0, 2, 4):
            r = int.from_bytes(bytes(data[at:at + 2]), "little", signed=True)
            out.append(float(r) if r <= 0x7FFC else None)
        return out
    v = by_id(pgn, data)
    if pgn == 127250:
        return [deg(v["heading"]), deg(v["deviation"]), deg(v["variation"]), v["reference"]]
    if pgn == 127251:
        return [v["rate"]]
    if pgn == 127257:
        return [deg(v["yaw"]), deg(v["pitch"]), deg(v["roll"])]
    if pgn == 129025:
        return [v["latitude"], v["longitude"]]
    if pgn == 129026:
        return [v["cogReference"], deg(v["cog"]), v["sog"]]
    return None


def parse(path):
    lines, declared = [], None
    skipped = {}
    for raw in open(path, "rb").read().replace(b"\r", b"\n").split(b"\n"):
        text = raw.decode("ascii").strip()
        if not text:
            continue
        if text.startswith("#"):
            if text[1:].strip().startswith("format="):
                declared = text[1:].strip()[7:].strip().upper()
            continue
        f = text.split(",")
        try:
            prio, pgn, src, dst, length = (int(x) for x in f[1:6])
            data = [int(x, 16) for x in f[6:]]
            assert len(data) == length and all(0 <= b <= 255 for b in data)
            t = stamp(f[0])
        except (ValueError, AssertionError):
            skipped["line"] = skipped.get("line", 0) + 1
            continue
        lines.append((t, pgn, src, data))
    fmt = declared or ("FAST" if any(len(l[3]) > 8 for l in lines) else "PLAIN")
    messages, pending = [], {}
    for t, pgn, src, data in lines:
        if fmt == "PLAIN" and (pgn in FAST or 130816 <= pgn <= 131071):
            seq, index = data[0] >> 5, data[0] & 0x1F
            key = (src, pgn)
            if index == 0:
                if key in pending:
                    skipped["fast_packet_incomplete"] = skipped.get("fast_packet_incomplete", 0) + 1
                pending[key] = [seq, 1, data[1], data[2:]]
            else:
                p = pending.get(key)
                if p is None or p[0] != seq or p[1] != index:
                    if p is not None:
                        del pending[key]
                        skipped["fast_packet_incomplete"] = skipped.get("fast_packet_incomplete", 0) + 1
                    skipped["fast_packet_frame_without_start"] = skipped.get("fast_packet_frame_without_start", 0) + 1
                    continue
                p[3] = p[3] + data[1:]
                p[1] += 1
            p = pending[key]
            if len(p[3]) >= p[2]:
                messages.append((t, pgn, src, p[3][:p[2]]))
                del pending[key]
            continue
        messages.append((t, pgn, src, data))
    if pending:
        skipped["fast_packet_incomplete"] = skipped.get("fast_packet_incomplete", 0) + len(pending)
    return fmt, len(lines), messages, skipped


def read(path, values=True):
    fmt, n_lines, messages, skipped = parse(path)
    counts, decoded = {}, {}
    for t, pgn, src, data in messages:
        key = "%d/%d" % (pgn, src)
        counts[key] = counts.get(key, 0) + 1
        if pgn in READ and values:
            d = decode(pgn, data)
            if d is not None:
                decoded.setdefault(key, []).append([t] + d)
    out = {"format": fmt, "lines": n_lines, "messages": len(messages), "by_pgn_source": dict(sorted(counts.items())), "skipped": skipped}
    if values:
        out["decoded"] = decoded
    return out, messages


def magnetic_minus_true(decoded):
    mag = [(r[0], r[1]) for r in decoded.get("127250/27", []) if r[4] == 1 and r[1] is not None]
    tru = [(r[0], r[1]) for r in decoded.get("127250/52", []) if r[4] == 0 and r[1] is not None]
    diffs = []
    for t, h in mag:
        near = min(tru, key=lambda x: abs(x[0] - t))
        if abs(near[0] - t) <= 0.1:
            diffs.append((h - near[1] + 180.0) % 360.0 - 180.0)
    mean = sum(diffs) / len(diffs)
    std = math.sqrt(sum((d - mean) ** 2 for d in diffs) / len(diffs))
    return {"pairs": len(diffs), "mean_deg": mean, "std_deg": std, "min_deg": min(diffs), "max_deg": max(diffs)}


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--full":
        for name in sorted(os.listdir(sys.argv[2])):
            if name.endswith((".all", ".raw")):
                out, _ = read(os.path.join(sys.argv[2], name), values=True)
                six = {k: v for k, v in out["by_pgn_source"].items() if int(k.split("/")[0]) in READ}
                print(name, out["format"], "lines", out["lines"], "messages", out["messages"], "skipped", out["skipped"])
                print("  read PGNs by source:", six)
                if "127250/27" in out["decoded"] and "127250/52" in out["decoded"]:
                    print("  magnetic - true:", magnetic_minus_true(out["decoded"]))
        return
    ref = {"canboat": EXTRACT["Version"], "files": {}}
    for name in FILES:
        out, _ = read(os.path.join(HERE, name))
        if name.startswith("triton"):
            out["magnetic_minus_true"] = magnetic_minus_true(out["decoded"])
        ref["files"][name] = out
    with open(os.path.join(HERE, "reference.json"), "w") as w:
        json.dump(ref, w, separators=(",", ":"))
        w.write("\n")


if __name__ == "__main__":
    main()
