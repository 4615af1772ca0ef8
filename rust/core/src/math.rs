//! The one place that names the scalar and small-vector types of the core.

/// The scalar used for poses, velocities and the QP: always `f64`.
pub type Real = f64;

/// A 3-vector `[x, y, z]`. Planar quantities keep `z = 0`.
pub type Vec3 = [Real; 3];

/// A 3x3 matrix, row-major: `m[row][col]`.
pub type Mat3 = [[Real; 3]; 3];

/// The identity rotation.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `m * v`.
#[inline]
pub fn mat_vec(m: &Mat3, v: &Vec3) -> Vec3 {
    [m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2], m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]]
}

/// `mᵀ * v`.
#[inline]
pub fn mat_t_vec(m: &Mat3, v: &Vec3) -> Vec3 {
    [m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2], m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2], m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2]]
}

/// `a · b`.
#[inline]
pub fn dot(a: &Vec3, b: &Vec3) -> Real {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
#[inline]
pub fn cross(a: &Vec3, b: &Vec3) -> Vec3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The rotation about `z` by `yaw` radians (body-to-world for a planar robot).
#[inline]
pub fn rot_z(yaw: Real) -> Mat3 {
    let (s, c) = yaw.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// Largest entry of `|mᵀm − I|`: how far `m` is from a rotation's orthonormality.
pub fn orthonormality_error(m: &Mat3) -> Real {
    let mut worst: Real = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            let mut s = 0.0;
            for row in m {
                s += row[i] * row[j];
            }
            let target = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((s - target).abs());
        }
    }
    worst
}

/// Determinant of `m`.
pub fn det(m: &Mat3) -> Real {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// `a * b`.
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `[w]×`, the cross-product matrix: `[w]× v = w × v`.
pub fn skew(w: &Vec3) -> Mat3 {
    [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
}

/// The rotation after turning at constant body rate `omega` (rad/s) for `dt` seconds:
/// `R exp([ω]× dt)`, by Rodrigues' formula.
pub fn integrate_rotation(r: &Mat3, omega: &Vec3, dt: Real) -> Mat3 {
    let n = dot(omega, omega).sqrt();
    if n == 0.0 {
        return *r;
    }
    let th = n * dt;
    let k = skew(&[omega[0] / n, omega[1] / n, omega[2] / n]);
    let k2 = mat_mul(&k, &k);
    let mut e = IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            e[i][j] += th.sin() * k[i][j] + (1.0 - th.cos()) * k2[i][j];
        }
    }
    mat_mul(r, &e)
}
