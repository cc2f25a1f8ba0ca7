#!/usr/bin/env python3
"""Cuts the two PX4 ULog samples (pyulog's test/ files, /work/shared/data/px4-ulog/)
into the small fixtures committed here, each still a valid ULog.

The ULog framing by hand (no pyulog): a 16-byte header, then messages of
`u16 size, u8 type, payload`; a cut is made only at a message boundary.

* sample_log_small_cut.ulg: the header, the definitions and every message of
  the data section except the data ('D') of topics the importer does not read
  (a cut by the first CUT bytes would keep 1 of the 6 sensor_mag samples of
  each instance: the log's first 20 s hold most of its bytes). Every
  subscription ('A') stays, so the dropped topics are subscribed and without
  data, as a topic that never published is; every parameter, information,
  logged string, dropout and sync message stays.
* sample_appended_multiple_cut.ulg: the header, the definitions and the main
  data section up to the last boundary at or before CUT_MAIN bytes, then the
  three appended data sections byte for byte, their offsets in the flag bits
  message ('B', the first message) rewritten to where they now start.

Usage: python3 cut.py [SOURCE_DIR]   (default /work/shared/data/px4-ulog)
"""
import struct
import sys

SRC = sys.argv[1] if len(sys.argv) > 1 else "/work/shared/data/px4-ulog"
KEEP = {"sensor_mag", "vehicle_magnetometer", "sensor_combined", "sensor_gyro",
        "vehicle_attitude", "vehicle_gps_position"}
CUT_MAIN = 190_000


def boundary(b, limit):
    """The last message boundary at or before `limit` (after the header)."""
    pos = 16
    while pos + 3 <= len(b):
        size, = struct.unpack("<H", b[pos:pos + 2])
        end = pos + 3 + size
        if end > limit:
            break
        pos = end
    return pos


def only_read_topics(b):
    """The log without the data messages of topics not in KEEP."""
    out = bytearray(b[:16])
    pos = 16
    names = {}
    while pos + 3 <= len(b):
        size, kind = struct.unpack("<HB", b[pos:pos + 3])
        payload = b[pos + 3:pos + 3 + size]
        if kind == ord("A"):
            names[struct.unpack("<H", payload[1:3])[0]] = payload[3:].decode()
        keep = kind != ord("D") or names.get(struct.unpack("<H", payload[:2])[0]) in KEEP
        if keep:
            out += b[pos:pos + 3 + size]
        pos += 3 + size
    assert pos == len(b)
    return bytes(out)


def flag_bits(b):
    """(payload start, appended offsets) of the flag bits message."""
    size, kind = struct.unpack("<HB", b[16:19])
    assert kind == ord("B") and size >= 40
    return 19, list(struct.unpack("<3Q", b[19 + 16:19 + 40]))


def main():
    b = open(f"{SRC}/sample_log_small.ulg", "rb").read()
    _, offsets = flag_bits(b)
    assert not any(offsets)
    open("sample_log_small_cut.ulg", "wb").write(only_read_topics(b))

    b = open(f"{SRC}/sample_appended_multiple.ulg", "rb").read()
    start, offsets = flag_bits(b)
    first = offsets[0]
    main_end = boundary(b, min(CUT_MAIN, first))
    shift = first - main_end
    new = [o - shift if o else 0 for o in offsets]
    out = bytearray(b[:main_end]) + b[first:]
    out[start + 16:start + 40] = struct.pack("<3Q", *new)
    open("sample_appended_multiple_cut.ulg", "wb").write(bytes(out))


if __name__ == "__main__":
    main()
