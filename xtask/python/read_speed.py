#!/usr/bin/env python3
"""The independent readers' speed for `cargo xtask bench`'s import section:
reads every message of one log with the reader the import's tests compare
against, and prints {"seconds": …, "messages": …} (the read only, best of
three, without Python's start or the imports).

    python3 xtask/python/read_speed.py FORMAT FILE

FORMAT: dataflash, tlog (pymavlink), ulog (pyulog), mcap, sqlite3 (rosbags,
every message deserialised), nmea2000 (the canboat-definition decoder of
tests/data/nmea2000-canboat/reference.py), nmea0183 (pynmea2). A reader
that is not installed: exit status 3 and the reason on stderr.
"""
import importlib.util
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")


def mavlink_match(path):
    from pymavlink import mavutil

    def read():
        m = mavutil.mavlink_connection(path, dialect="ardupilotmega")
        n = 0
        while m.recv_match() is not None:
            n += 1
        return n

    return read


def ulog(path):
    from pyulog import ULog

    def read():
        u = ULog(path)
        return sum(len(d.data["timestamp"]) for d in u.data_list)

    return read


def rosbag(path):
    from rosbags.highlevel import AnyReader
    from pathlib import Path

    # A sqlite3 bag is its folder (metadata.yaml beside the .db3).
    bag = Path(path).parent if path.endswith(".db3") else Path(path)

    def read():
        n = 0
        with AnyReader([bag]) as r:
            for conn, _t, raw in r.messages():
                try:
                    r.deserialize(raw, conn.msgtype)
                    n += 1
                except Exception:  # a damaged message: counted out, as the import skips it
                    pass
        return n

    return read


def module(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def nmea2000(path):
    ref = module(os.path.join(ROOT, "tests/data/nmea2000-canboat/reference.py"), "n2k_reference")
    return lambda: ref.read(path)[0]["messages"]


def nmea0183(path):
    import pynmea2

    def read():
        n = 0
        with open(path, encoding="ascii", errors="replace") as f:
            for line in f:
                try:
                    pynmea2.parse(line.strip())
                    n += 1
                except pynmea2.ParseError:
                    pass
        return n

    return read


READERS = {"dataflash": mavlink_match, "tlog": mavlink_match, "ulog": ulog, "mcap": rosbag, "sqlite3": rosbag, "nmea2000": nmea2000, "nmea0183": nmea0183}


def main():
    fmt, path = sys.argv[1], sys.argv[2]
    try:
        read = READERS[fmt](path)
    except (ImportError, AttributeError, FileNotFoundError) as e:
        print(f"{fmt}: the independent reader is not available: {e}", file=sys.stderr)
        sys.exit(3)
    best, n = float("inf"), 0
    for _ in range(3):
        t0 = time.perf_counter()
        n = read()
        n = n if isinstance(n, int) else len(n)
        best = min(best, time.perf_counter() - t0)
    print(json.dumps({"seconds": best, "messages": n}))


if __name__ == "__main__":
    main()
