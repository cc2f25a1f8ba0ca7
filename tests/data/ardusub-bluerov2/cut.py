"""Cuts the first records of a MAVLink telemetry log (an 8-byte big-endian
time, then one MAVLink v1 or v2 frame) at a record boundary: the largest
prefix of at most LIMIT bytes that ends where a record ends.

    python3 cut.py FULL.tlog OUT.tlog [LIMIT]
"""
import sys

src, dst = sys.argv[1], sys.argv[2]
limit = int(sys.argv[3]) if len(sys.argv) > 3 else 300_000
data = open(src, "rb").read()
o = 0
end = 0
while o + 11 <= len(data):
    stx, n = data[o + 8], data[o + 9]
    if stx == 0xFE:
        size = 8 + 6 + n + 2
    elif stx == 0xFD:
        size = 8 + 10 + n + 2 + (13 if data[o + 10] & 1 else 0)
    else:
        raise SystemExit(f"no start byte at {o + 8}: cut by hand")
    if o + size > limit:
        break
    o += size
    end = o
open(dst, "wb").write(data[:end])
print(f"{end} bytes ({end} of {len(data)}) written to {dst}")
