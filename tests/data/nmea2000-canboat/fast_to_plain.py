#!/usr/bin/env python3
"""Writes triton-head-plain.raw: the first lines of triton-head.all (canboat
FAST: one line per whole PGN) re-encoded as canboat PLAIN (one line per CAN
frame), as a logger on the bus would have written them.

- `# format=PLAIN` first;
- a PGN canboat marks "Fast" (canboat-extract.json's FastPGNs, or the
  proprietary fast-packet range 130816-131071) becomes fast-packet frames of
  8 bytes: byte 0 = sequence counter (bits 5-7, one counter per source and
  PGN, counting 0..7 from 0) | frame index (bits 0-4); the first frame's
  byte 1 = the payload's length, then its first 6 bytes; each later frame
  the next 7; the last frame padded with 0xff; every frame with the line's
  timestamp, priority, addresses;
- any other PGN is written as it is (one frame);
- a message longer than 223 bytes (a fast packet's most; the logger had
  it by another transport) cannot be written as frames and is left out;
- whole messages only, up to 300 000 bytes of output (the file's last line
  is a message's last frame).

Not a capture: the values are the real log's, the framing is written here.
Rerun from the repository root: python3 tests/data/nmea2000-canboat/fast_to_plain.py
"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
FAST = set(json.load(open(os.path.join(HERE, "canboat-extract.json")))["FastPGNs"])
LIMIT = 300_000


def is_fast(pgn):
    return pgn in FAST or 130816 <= pgn <= 131071


def frames(payload, seq):
    out = [[seq << 5, len(payload)] + payload[:6]]
    rest = payload[6:]
    index = 1
    while rest:
        out.append([(seq << 5) | index] + rest[:7])
        rest = rest[7:]
        index += 1
    return [f + [0xFF] * (8 - len(f)) for f in out]


def main():
    seqs = {}
    out = ["# format=PLAIN\n"]
    size = len(out[0])
    for line in open(os.path.join(HERE, "triton-head.all")):
        if line.startswith("#") or not line.strip():
            continue
        f = line.strip().split(",")
        stamp, prio, pgn, src, dst, length = f[0], f[1], int(f[2]), f[3], f[4], int(f[5])
        payload = [int(x, 16) for x in f[6:6 + length]]
        if is_fast(pgn) and length > 223:
            continue
        if is_fast(pgn):
            key = (src, pgn)
            seq = seqs.get(key, 0)
            seqs[key] = (seq + 1) % 8
            chunk = frames(payload, seq)
        else:
            chunk = [payload]
        text = "".join("%s,%s,%d,%s,%s,%d,%s\n" % (stamp, prio, pgn, src, dst, len(c), ",".join("%02x" % b for b in c)) for c in chunk)
        if size + len(text) > LIMIT:
            break
        out.append(text)
        size += len(text)
    with open(os.path.join(HERE, "triton-head-plain.raw"), "w", newline="\n") as w:
        w.write("".join(out))


if __name__ == "__main__":
    main()
