#!/usr/bin/env python3
"""The independent reading of the ROS 2 bag fixtures: rosbags (its own MCAP
and sqlite3 readers and CDR decoder) writes reference.json, which the Rust
tests compare `magcal import` against.

    python3 -m pip install --break-system-packages rosbags
    python3 reference.py            # in this folder

For each bag: the messages per topic (every message the bag holds, decoded or
not), the messages rosbags cannot decode per topic, the types, and the values
the importer's columns must equal, in the project's conventions (written here
apart from the importer): the field in nT in the FRD body (FLU (x, y, z) ->
(x, -y, -z) * 1e9); the gyro FRD; roll, pitch and heading of the FRD body in
the NED world, from the rotation matrix R of the ROS quaternion (FLU body in
the ENU world): R_ned_frd = T R S with T swapping east/north and negating up,
S = diag(1, -1, -1), the angles by the aerospace Z-Y-X convention from the
matrix; t in s since the first /imu/mag header.stamp.
"""

import json
import math
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

HERE = Path(__file__).parent
BAGS = {'swing.mcap': HERE / 'swing.mcap', 'swing_db3': HERE / 'swing_db3', 'nomag.mcap': HERE / 'nomag.mcap', 'nomag_db3': HERE / 'nomag_db3'}


def matrix(q):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def ned_frd_angles_deg(q):
    r = matrix(q)
    t = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]
    s = [1, -1, -1]
    tr = [[sum(t[i][k] * r[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    m = [[tr[i][j] * s[j] for j in range(3)] for i in range(3)]
    roll = math.degrees(math.atan2(m[2][1], m[2][2]))
    pitch = math.degrees(math.asin(max(-1.0, min(1.0, -m[2][0]))))
    heading = math.degrees(math.atan2(m[1][0], m[0][0])) % 360.0
    return roll, pitch, heading


def stamp_ns(msg):
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def read(path):
    counts, undecodable, types = {}, {}, {}
    decoded = []
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        for conn in reader.connections:
            types[conn.topic] = conn.msgtype
        for conn, recv_ns, raw in reader.messages():
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
            try:
                msg = reader.deserialize(raw, conn.msgtype)
            except Exception:  # noqa: BLE001 - a corrupt message: counted, as the importer must
                undecodable[conn.topic] = undecodable.get(conn.topic, 0) + 1
                continue
            decoded.append((conn.topic, recv_ns, msg))
    mag_stamps = [stamp_ns(m) for topic, _, m in decoded if topic == '/imu/mag']
    out = {'counts': counts, 'undecodable': undecodable, 'types': types}
    if not mag_stamps:
        return out
    t0 = mag_stamps[0]
    t = lambda m: (stamp_ns(m) - t0) / 1e9  # noqa: E731
    vals = {'/imu/mag': [], '/payload/mag': [], '/imu/data': [], '/gnss/fix': [], '/gnss/heading': []}
    for topic, _, m in decoded:
        if topic in ('/imu/mag', '/payload/mag'):
            f = m.magnetic_field
            vals[topic].append([t(m), f.x * 1e9, -f.y * 1e9, -f.z * 1e9])
        elif topic == '/imu/data':
            o, g = m.orientation, m.angular_velocity
            vals[topic].append([t(m), *ned_frd_angles_deg((o.x, o.y, o.z, o.w)), g.x, -g.y, -g.z])
        elif topic == '/gnss/fix':
            vals[topic].append([t(m), m.latitude, m.longitude])
        elif topic == '/gnss/heading':
            q = m.quaternion
            vals[topic].append([t(m), ned_frd_angles_deg((q.x, q.y, q.z, q.w))[2]])
    out['first_mag_stamp_ns'] = t0
    out['columns'] = {
        '/imu/mag': 't, mx, my, mz (nT, FRD)',
        '/payload/mag': 't, mx, my, mz (nT, FRD)',
        '/imu/data': 't, roll_deg, pitch_deg, heading_deg (NED/FRD), gx, gy, gz (rad/s, FRD)',
        '/gnss/fix': 't, lat_deg, lon_deg',
        '/gnss/heading': 't, heading_deg (NED)',
    }
    out['values'] = vals
    return out


def main():
    ref = {name: read(path) for name, path in BAGS.items()}
    with open(HERE / 'reference.json', 'w') as f:
        json.dump(ref, f, indent=1)
        f.write('\n')


if __name__ == '__main__':
    main()
