"""Rotations for the BVH conversions, vectorised over frames with numpy.

The same formulas as the library's format/rotation_matrix.cpp, so that
a BVH this package reads or writes agrees with the server's own conversion
to rounding. Column-vector matrices (BVH's convention) unless a name says
otherwise; angles in radians unless a name says degrees. Every function takes
arrays of any leading shape and is pure.
"""

import numpy as np


def expmap_to_matrix(expmap):
    """Rodrigues' formula, I + sin(t)/t K + (1 - cos t)/t^2 K^2 with K the
    cross-product matrix of `expmap` (..., 3); exact near zero (Taylor).
    Returns (..., 3, 3)."""
    e = np.asarray(expmap, dtype=np.float64)
    theta2 = np.sum(e * e, axis=-1)
    small = theta2 < 1e-12
    theta = np.sqrt(np.where(small, 1.0, theta2))
    a = np.where(small, 1.0 - theta2 / 6.0, np.sin(theta) / theta)
    b = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta2))
    x, y, z = e[..., 0], e[..., 1], e[..., 2]
    zero = np.zeros_like(x)
    k = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)
    return np.eye(3) + a[..., None, None] * k + b[..., None, None] * (k @ k)


def matrix_to_expmap(m):
    """The exponential map (angle in [0, pi]) of rotation matrices (..., 3, 3),
    through a quaternion by Shepperd's method (accurate at every angle).
    Returns (..., 3)."""
    m = np.asarray(m, dtype=np.float64)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    # The largest of w, x, y, z comes from the diagonal, where it cannot lose
    # precision; the branch conditions are the library's, in its order.
    use_w = (trace >= m00) & (trace >= m11) & (trace >= m22)
    use_x = ~use_w & (m00 >= m11) & (m00 >= m22)
    use_y = ~use_w & ~use_x & (m11 >= m22)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = 2.0 * np.sqrt(np.maximum(0.0, 1.0 + trace))
        qw = np.stack([0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s], -1)
        s = 2.0 * np.sqrt(np.maximum(0.0, 1.0 + m00 - m11 - m22))
        qx = np.stack([(m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s], -1)
        s = 2.0 * np.sqrt(np.maximum(0.0, 1.0 + m11 - m00 - m22))
        qy = np.stack([(m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s], -1)
        s = 2.0 * np.sqrt(np.maximum(0.0, 1.0 + m22 - m00 - m11))
        qz = np.stack([(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s], -1)
    q = np.where(use_w[..., None], qw, np.where(use_x[..., None], qx, np.where(use_y[..., None], qy, qz)))
    q = np.where(q[..., :1] < 0, -q, q)  # the same rotation, its angle in [0, pi]
    sin_half = np.linalg.norm(q[..., 1:], axis=-1)
    angle = 2.0 * np.arctan2(sin_half, q[..., 0])
    scale = np.where(sin_half < 1e-300, 0.0, angle / np.where(sin_half < 1e-300, 1.0, sin_half))
    return q[..., 1:] * scale[..., None]


def axis_rotation(axis, radians):
    """Rotations by `radians` (...) about axis 0 (x), 1 (y) or 2 (z): (..., 3, 3)."""
    c, s = np.cos(radians), np.sin(radians)
    one, zero = np.ones_like(c), np.zeros_like(c)
    rows = {
        0: [[one, zero, zero], [zero, c, -s], [zero, s, c]],
        1: [[c, zero, s], [zero, one, zero], [-s, zero, c]],
        2: [[c, -s, zero], [s, c, zero], [zero, zero, one]],
    }[axis]
    return np.stack([np.stack(row, -1) for row in rows], -2)


def matrix_to_euler_degrees(axes, m):
    """Angles (..., 3) in degrees with R_axes[0](a0) R_axes[1](a1) R_axes[2](a2) = m,
    the middle angle in [-90, 90]; at gimbal lock the last angle is 0."""
    i, j, k = axes
    m = np.asarray(m, dtype=np.float64)
    # +1 for the cyclic orders (XYZ, YZX, ZXY): the sign of sin(b) at m[i][k].
    s = 1.0 if (j - i + 3) % 3 == 1 else -1.0
    cos_b = np.hypot(m[..., i, i], m[..., i, j])
    b = np.arctan2(s * m[..., i, k], cos_b)
    locked = cos_b <= 1e-12
    a = np.where(locked, np.arctan2(s * m[..., k, j], m[..., j, j]), np.arctan2(-s * m[..., j, k], m[..., k, k]))
    c = np.where(locked, 0.0, np.arctan2(-s * m[..., i, j], m[..., i, i]))
    return np.degrees(np.stack([a, b, c], -1))
