//! REP 103's frames to this project's: ROS's FLU body and ENU world to an
//! FRD body and an NED world.

use super::super::rules;

/// A body vector from ROS's FLU to this project's FRD.
pub fn flu_to_frd(v: [f64; 3]) -> [f64; 3] {
    [v[0], -v[1], -v[2]]
}

/// Hamilton product of quaternions `[w, x, y, z]`.
pub(super) fn qmul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw]
}

/// Roll, pitch and heading (degrees; heading on 0–360°) of the FRD body in
/// the NED world, from a ROS orientation: the quaternion `[x, y, z, w]` (ROS's
/// order) of the FLU body in the ENU world. `None` when it is not finite or
/// near zero.
pub fn enu_flu_to_ned_frd_euler_deg(q_xyzw: [f64; 4]) -> Option<[f64; 3]> {
    let [x, y, z, w] = q_xyzw;
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // NED ← ENU: 180° about (1, 1, 0)/√2; FLU ← FRD: 180° about x.
    let ned_from_enu = [0.0, h, h, 0.0];
    let flu_from_frd = [0.0, 1.0, 0.0, 0.0];
    rules::quaternion_to_euler_deg(qmul(qmul(ned_from_enu, [w, x, y, z]), flu_from_frd))
}
