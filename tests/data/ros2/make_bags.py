#!/usr/bin/env python3
"""Writes the ROS 2 bag fixtures from a recording written by `magcal simulate`.

    python3 -m pip install --break-system-packages rosbags mcap mcap-ros2-support
    magcal simulate swing --gyro --rate-hz 0.2 --seed 1 --out swing.csv
    rm -rf swing.mcap swing_db3 nomag.mcap nomag_db3
    python3 make_bags.py swing.csv .

Writes, beside the recording:
- swing.mcap      MCAP storage, by mcap-ros2-support (its own CDR encoder),
                  zstd-compressed chunks (its default, as rosbag2's);
- swing_db3/      sqlite3 storage (rosbag2 version 9: `topics` and
                  `message_definitions` tables), by rosbags (its own encoder);
- nomag.mcap, nomag_db3/   the same without a magnetometer topic (hostile case).

Every row of the recording becomes, at header.stamp = 1 700 000 000 s + t
(the bag's receive time 5 ms later, so that the two clocks differ):
- /imu/mag      sensor_msgs/msg/MagneticField: the field (the recording's
                mx, my, mz read as nT; the project's body frame is FRD) in
                tesla in ROS's FLU body frame (REP 103): (x, -y, -z) * 1e-9;
- /imu/data     sensor_msgs/msg/Imu: the orientation of the FLU body in the
                ENU world from the recording's roll, pitch (the simulated
                AHRS) and its true heading (the simulator writes no AHRS
                yaw), built from the body's axes (below); angular_velocity
                from gx, gy, gz, FRD -> FLU;
- /gnss/fix     sensor_msgs/msg/NavSatFix: lat, lon;
- /gnss/heading geometry_msgs/msg/QuaternionStamped: a GNSS compass's
                heading (the true heading, level);
and, every second row, /payload/mag (a second magnetometer: half the field),
so that /imu/mag is the busiest magnetometer topic. Two corrupt /imu/mag messages (CDR cut to 20 bytes) are written after
rows 10 and 20: a reader must skip and count them (rosbags cannot decode them
either: reference.py counts them).

The frame conversion here is the physical one, written apart from the
importer's quaternion algebra: the body's forward, right and down axes in the
NED world from the aerospace Z-Y-X angles, each axis then written in ENU
(east, north, up) = (y, x, -z) of NED, the FLU body's axes being
forward, -right, -down; the quaternion from that rotation matrix.
"""

import csv
import math
import shutil
import sys
from pathlib import Path

from mcap.writer import CompressionType
from mcap_ros2.writer import Writer as McapWriter
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_HUMBLE)
BASE_S = 1_700_000_000
RECEIVE_DELAY_NS = 5_000_000
TYPES = {
    '/imu/mag': 'sensor_msgs/msg/MagneticField',
    '/imu/data': 'sensor_msgs/msg/Imu',
    '/gnss/fix': 'sensor_msgs/msg/NavSatFix',
    '/gnss/heading': 'geometry_msgs/msg/QuaternionStamped',
    '/payload/mag': 'sensor_msgs/msg/MagneticField',
}
CORRUPT_AFTER_ROWS = (10, 20)


def rot_ned_frd(roll_deg, pitch_deg, heading_deg):
    """Columns: the FRD body's forward, right, down axes in NED (Z-Y-X)."""
    r, p, y = (math.radians(a) for a in (roll_deg, pitch_deg, heading_deg))
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    forward = (cp * cy, cp * sy, -sp)
    right = (sr * sp * cy - cr * sy, sr * sp * sy + cr * cy, sr * cp)
    down = (cr * sp * cy + sr * sy, cr * sp * sy - sr * cy, cr * cp)
    return forward, right, down


def ned_to_enu(v):
    n, e, d = v
    return (e, n, -d)


def quat_enu_flu(roll_deg, pitch_deg, heading_deg):
    """(x, y, z, w) of the FLU body's orientation in the ENU world."""
    forward, right, down = rot_ned_frd(roll_deg, pitch_deg, heading_deg)
    cols = [ned_to_enu(forward), ned_to_enu(tuple(-c for c in right)), ned_to_enu(tuple(-c for c in down))]
    m = [[cols[j][i] for j in range(3)] for i in range(3)]  # m[row][col]
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        w, x, y, z = 0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
        w, x, y, z = (m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s
    elif m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
        w, x, y, z = (m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s
    else:
        s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
        w, x, y, z = (m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s
    return (x, y, z, w)


def header(t_s, frame):
    ns = BASE_S * 1_000_000_000 + round(t_s * 1e9)
    return {'stamp': {'sec': ns // 1_000_000_000, 'nanosec': ns % 1_000_000_000}, 'frame_id': frame}, ns


def messages(rows, with_mag=True):
    """(topic, receive time ns, message as a dict) in time order."""
    out = []
    for i, row in enumerate(rows):
        t = float(row['t'])
        h, ns = header(t, 'imu_link')
        recv = ns + RECEIVE_DELAY_NS
        mag_frd_nt = [float(row[k]) for k in ('mx', 'my', 'mz')]
        mag_flu_t = [mag_frd_nt[0] * 1e-9, -mag_frd_nt[1] * 1e-9, -mag_frd_nt[2] * 1e-9]
        cov = [0.0] * 9
        if with_mag:
            out.append(('/imu/mag', recv, {'header': h, 'magnetic_field': dict(zip('xyz', mag_flu_t)), 'magnetic_field_covariance': cov}))
        q = quat_enu_flu(float(row['roll_deg']), float(row['pitch_deg']), float(row['true_heading_deg']))
        g_frd = [float(row[k]) for k in ('gx', 'gy', 'gz')]
        g_flu = [g_frd[0], -g_frd[1], -g_frd[2]]
        out.append(('/imu/data', recv, {
            'header': h,
            'orientation': dict(zip('xyzw', q)),
            'orientation_covariance': cov,
            'angular_velocity': dict(zip('xyz', g_flu)),
            'angular_velocity_covariance': cov,
            'linear_acceleration': {'x': 0.0, 'y': 0.0, 'z': 9.81},
            'linear_acceleration_covariance': [-1.0] + [0.0] * 8,
        }))
        hg, _ = header(t, 'gnss')
        out.append(('/gnss/fix', recv, {
            'header': hg,
            'status': {'status': 0, 'service': 1},
            'latitude': float(row['lat_deg']),
            'longitude': float(row['lon_deg']),
            'altitude': 0.0,
            'position_covariance': cov,
            'position_covariance_type': 0,
        }))
        out.append(('/gnss/heading', recv, {'header': hg, 'quaternion': dict(zip('xyzw', quat_enu_flu(0.0, 0.0, float(row['true_heading_deg']))))}))
        if i % 2 == 0:
            if with_mag:
                half = [v / 2 for v in mag_flu_t]
                hp, _ = header(t, 'payload_mag')
                out.append(('/payload/mag', recv, {'header': hp, 'magnetic_field': dict(zip('xyz', half)), 'magnetic_field_covariance': cov}))
        if with_mag and i + 1 in CORRUPT_AFTER_ROWS:
            out.append(('/imu/mag', recv + 1, None))  # corrupt: written as raw bytes below
    return out


def to_rosbags_msg(typename, d):
    """A rosbags message object from nested dicts."""
    cls = TS.types[typename]
    fields = {}
    for name, value in d.items():
        ftype = cls.__dataclass_fields__[name].type if hasattr(cls, '__dataclass_fields__') else None
        if isinstance(value, dict):
            sub = {'header': 'std_msgs/msg/Header', 'stamp': 'builtin_interfaces/msg/Time', 'status': 'sensor_msgs/msg/NavSatStatus',
                   'orientation': 'geometry_msgs/msg/Quaternion', 'quaternion': 'geometry_msgs/msg/Quaternion'}.get(name, 'geometry_msgs/msg/Vector3')
            fields[name] = to_rosbags_msg(sub, value)
        elif isinstance(value, list):
            import numpy as np
            fields[name] = np.array(value, dtype=np.float64)
        else:
            fields[name] = value
    del ftype
    return cls(**fields)


def corrupt_bytes():
    """A MagneticField cut short: the encapsulation header, the stamp and a
    frame_id length that runs past the end."""
    return bytes([0, 1, 0, 0]) + (BASE_S).to_bytes(4, 'little') + bytes(4) + (9).to_bytes(4, 'little') + b'imu_'


def write_mcap(path, msgs):
    with open(path, 'wb') as f:
        w = McapWriter(f, compression=CompressionType.ZSTD)
        schemas = {}
        for topic, typename in TYPES.items():
            if typename not in schemas:
                text, _ = TS.generate_msgdef(typename, ros_version=2)
                schemas[typename] = w.register_msgdef(typename, text)
        for topic, recv, d in msgs:
            schema = schemas[TYPES[topic]]
            if d is None:
                # The raw writer beneath, on the topic's channel (registered by the first message).
                w._writer.add_message(channel_id=w._channel_ids[topic], log_time=recv, publish_time=recv, sequence=0, data=corrupt_bytes())
            else:
                w.write_message(topic, schema, d, log_time=recv, publish_time=recv)
        w.finish()


def write_db3(folder, msgs):
    if folder.exists():
        shutil.rmtree(folder)
    with Writer(folder, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        conns = {}
        for topic, _recv, _d in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, TYPES[topic], typestore=TS)
        for topic, recv, d in msgs:
            data = corrupt_bytes() if d is None else bytes(TS.serialize_cdr(to_rosbags_msg(TYPES[topic], d), TYPES[topic]))
            w.write(conns[topic], recv, data)


def main():
    csv_path, out = Path(sys.argv[1]), Path(sys.argv[2])
    with open(csv_path, newline='') as f:
        rows = list(csv.DictReader(f))
    stem = csv_path.stem
    all_msgs = messages(rows)
    write_mcap(out / f'{stem}.mcap', all_msgs)
    write_db3(out / f'{stem}_db3', all_msgs)
    nomag = messages(rows[:20], with_mag=False)
    write_mcap(out / 'nomag.mcap', nomag)
    write_db3(out / 'nomag_db3', nomag)


if __name__ == '__main__':
    main()
