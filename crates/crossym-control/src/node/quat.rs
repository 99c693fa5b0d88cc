//! Quaternions as ROS writes them, `[x, y, z, w]`, for the pose map's bearings and sides
//! (rigid transforms between frames are nalgebra's `Isometry3`, see [`super::tf`]).

/// A quaternion `[x, y, z, w]`.
pub(crate) type Quat = [f64; 4];

/// Hamilton product `a b`.
pub(crate) fn q_mul(a: Quat, b: Quat) -> Quat {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// The conjugate (the inverse of a unit quaternion).
pub(crate) fn q_conj(q: Quat) -> Quat {
    [-q[0], -q[1], -q[2], q[3]]
}

/// `R(q) v` for a unit `q`.
pub(crate) fn q_rotate(q: Quat, v: [f64; 3]) -> [f64; 3] {
    let p = q_mul(q_mul(q, [v[0], v[1], v[2], 0.0]), q_conj(q));
    [p[0], p[1], p[2]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `v / |v|`; `None` for a (near) zero or non-finite `v`.
pub(crate) fn normalised(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(v, v).sqrt();
    (n.is_finite() && n > 1e-12).then(|| [v[0] / n, v[1] / n, v[2] / n])
}

/// `q / |q|`; `None` for a (near) zero or non-finite `q`.
pub(crate) fn unit_quat(q: Quat) -> Option<Quat> {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    (n.is_finite() && n > 1e-9).then(|| [q[0] / n, q[1] / n, q[2] / n, q[3] / n])
}
