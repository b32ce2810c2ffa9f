"""Rotation conversions used by the readers and writers, batched over any leading shape.

Conventions
-----------
* **Rotation matrices** ``(..., 3, 3)`` act on column vectors: ``v_parent = R @ v_child``.
* **Euler angles** ``(..., 3)`` are in **radians** and **intrinsic**: the order string
  names the axes in the order the angles are listed and the matrices are multiplied,
  ``order = "ZXY"`` means ``R = Rz(a0) @ Rx(a1) @ Ry(a2)``. This is the BVH convention
  (``CHANNELS ... Zrotation Xrotation Yrotation``). Orders are three distinct upper-case
  axes (Tait-Bryan); ``scipy.spatial.transform.Rotation.from_euler(order, ...)`` with an
  upper-case order string is the same convention.
* **Quaternions** ``(..., 4)`` are **(w, x, y, z)**, scalar first (DeepMimic's order;
  scipy's ``Rotation.from_quat`` is scalar *last* by default).

Why not scipy here: these functions sit in the BVH read/write hot path (10,000 frames x
31 joints = 310,000 rotations). ``Rotation.from_euler`` takes about 0.4 s for that many
on the reference machine, ``Rotation.from_matrix`` about 0.3 s; the closed forms below
take a few tens of milliseconds. The tests check them against scipy.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "axis_rotation",
    "euler_to_matrix",
    "matrix_to_euler",
    "matrix_to_quaternion",
    "nearest_euler",
    "quaternion_slerp",
    "quaternion_to_matrix",
    "valid_euler_order",
]

_AXIS = {"X": 0, "Y": 1, "Z": 2}


def valid_euler_order(order: str) -> bool:
    """True for a string of three distinct axes from ``"XYZ"`` (e.g. ``"ZXY"``)."""
    return isinstance(order, str) and len(order) == 3 and sorted(order) == ["X", "Y", "Z"]


def _check_order(order: str) -> str:
    if not valid_euler_order(order):
        raise ValueError(f"order: expected three distinct axes from 'XYZ' (e.g. 'ZYX'); got {order!r}")
    return order


def _quat_mul(a: tuple, b: tuple) -> tuple:
    """Hamilton product of quaternions given as (w, x, y, z) tuples of arrays."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def _quat_parts_to_matrix(w, x, y, z) -> np.ndarray:
    """Rotation matrix of a unit quaternion given as four arrays of one shape."""
    out = np.empty(np.shape(w) + (3, 3))
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    out[..., 0, 0] = 1.0 - 2.0 * (yy + zz)
    out[..., 0, 1] = 2.0 * (xy - wz)
    out[..., 0, 2] = 2.0 * (xz + wy)
    out[..., 1, 0] = 2.0 * (xy + wz)
    out[..., 1, 1] = 1.0 - 2.0 * (xx + zz)
    out[..., 1, 2] = 2.0 * (yz - wx)
    out[..., 2, 0] = 2.0 * (xz - wy)
    out[..., 2, 1] = 2.0 * (yz + wx)
    out[..., 2, 2] = 1.0 - 2.0 * (xx + yy)
    return out


def euler_to_matrix(angles: np.ndarray, order: str) -> np.ndarray:
    """Rotation matrices of intrinsic Euler angles.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Radians, listed in the order of ``order``.
    order : str
        Three distinct axes, e.g. ``"ZYX"`` for ``R = Rz(a0) @ Ry(a1) @ Rx(a2)``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    _check_order(order)
    a = np.asarray(angles, dtype=np.float64)
    if a.shape[-1:] != (3,):
        raise ValueError(f"angles: expected shape (..., 3); got {a.shape}")
    half = 0.5 * a
    c = np.cos(half)
    s = np.sin(half)
    zero = np.zeros(a.shape[:-1])
    q = None
    for k, axis in enumerate(order):
        parts = [c[..., k], zero, zero, zero]
        parts[1 + _AXIS[axis]] = s[..., k]
        q = tuple(parts) if q is None else _quat_mul(q, tuple(parts))
    return _quat_parts_to_matrix(*q)


def axis_rotation(angle: np.ndarray, axis: str) -> np.ndarray:
    """Rotation matrices about one coordinate axis.

    Parameters
    ----------
    angle : array_like, shape (...)
        Radians (right-handed: positive turns ``y`` towards ``z`` about ``"X"``).
    axis : {"X", "Y", "Z"}

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    if axis not in _AXIS:
        raise ValueError(f"axis: expected 'X', 'Y' or 'Z'; got {axis!r}")
    t = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    i = _AXIS[axis]
    p, q = (i + 1) % 3, (i + 2) % 3
    out = np.zeros(t.shape + (3, 3))
    out[..., i, i] = 1.0
    out[..., p, p] = c
    out[..., q, q] = c
    out[..., q, p] = s
    out[..., p, q] = -s
    return out


def _basis(axis: int, shape: tuple[int, ...]) -> np.ndarray:
    e = np.zeros(shape + (3,))
    e[..., axis] = 1.0
    return e


def _rotate_about(angle: np.ndarray, axis: int, v: np.ndarray) -> np.ndarray:
    """``R_axis(angle) @ v`` for vectors ``v`` of shape (..., 3), elementwise."""
    c, s = np.cos(angle), np.sin(angle)
    p, q = (axis + 1) % 3, (axis + 2) % 3
    out = v.copy()
    out[..., p] = c * v[..., p] - s * v[..., q]
    out[..., q] = s * v[..., p] + c * v[..., q]
    return out


def matrix_to_euler(m: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles of rotation matrices (inverse of :func:`euler_to_matrix`).

    For ``R = R_i(a) R_j(b) R_k(c)`` with ``s = +1`` when ``(i, j, k)`` is a cyclic
    permutation of ``(x, y, z)`` and ``-1`` otherwise: ``b = atan2(s R_ik,
    sqrt(R_ii^2 + R_ij^2))`` and ``a = atan2(-s R_jk, R_kk)``; the last angle is then read
    from the residual ``R_k(c) = R_j(b)^T R_i(a)^T R``, so that the angles reproduce
    ``R`` to rounding error even near gimbal lock, where ``a`` alone is ill-conditioned.

    Parameters
    ----------
    m : array_like, shape (..., 3, 3)
        Rotation matrices.
    order : str
        Three distinct axes, as in :func:`euler_to_matrix`.

    Returns
    -------
    ndarray, shape (..., 3)
        Radians; ``a0, a2`` in ``[-pi, pi]``, the middle angle in ``[-pi/2, pi/2]``. At
        gimbal lock (middle angle ``+-pi/2``, where only ``a0 +- a2`` is defined) the
        first angle is set to 0 and the last one carries the rotation.
    """
    _check_order(order)
    r = np.asarray(m, dtype=np.float64)
    if r.shape[-2:] != (3, 3):
        raise ValueError(f"m: expected shape (..., 3, 3); got {r.shape}")
    i, j, k = (_AXIS[ax] for ax in order)
    s = 1.0 if (j - i) % 3 == 1 else -1.0
    rii, rij, rik = r[..., i, i], r[..., i, j], r[..., i, k]
    cos_b = np.hypot(rii, rij)
    out = np.empty(r.shape[:-2] + (3,))
    b = np.arctan2(s * rik, cos_b)
    a = np.arctan2(-s * r[..., j, k], r[..., k, k])
    a[cos_b < 1e-12] = 0.0  # gimbal lock: only a +- c is defined; put it all in c
    # Residual R_k(c) = R_j(b)^T R_i(a)^T R = A^T R with A = R_i(a) R_j(b). For a rotation
    # about axis k with cyclic successors p, q: sin c = [q, p] = A e_q . R e_p and
    # cos c = [p, p] = A e_p . R e_p; A e_v is computed as two plane rotations of e_v.
    p, q = (k + 1) % 3, (k + 2) % 3
    col_p = r[..., :, p]
    a_ep = _rotate_about(a, i, _rotate_about(b, j, _basis(p, a.shape)))
    a_eq = _rotate_about(a, i, _rotate_about(b, j, _basis(q, a.shape)))
    sin_c = np.einsum("...j,...j->...", a_eq, col_p)
    cos_c = np.einsum("...j,...j->...", a_ep, col_p)
    out[..., 0] = a
    out[..., 1] = b
    out[..., 2] = np.arctan2(sin_c, cos_c)
    return out


def _nearest_about(m: np.ndarray, k: int) -> np.ndarray:
    """Angle of the rotation about axis ``k`` nearest to ``m`` (..., 3, 3): the maximiser of
    ``trace(R_k(t)^T m) = m_kk + cos t (m_pp + m_qq) + sin t (m_qp - m_pq)``."""
    p, q = (k + 1) % 3, (k + 2) % 3
    return np.arctan2(m[..., q, p] - m[..., p, q], m[..., p, p] + m[..., q, q])


def nearest_euler(m: np.ndarray, axes: str) -> np.ndarray:
    """Angles of the rotation ``R_axes[0](t0) @ R_axes[1](t1) ...`` nearest to ``m``.

    The rotations one or two rotation channels can hold (a BVH joint with ``Xrotation
    Zrotation`` holds ``Rx(t0) @ Rz(t1)``): for a rotation of that family, the angles that
    reproduce it exactly (to rounding error, at any angle: no gimbal lock, no branch to
    choose: they are unique modulo ``2 pi``); for any other rotation, the angles of the
    family member nearest to it (smallest rotation angle between the two). Three axes:
    :func:`matrix_to_euler`, which reproduces every rotation.

    Two axes ``i, j``: the row ``i`` of ``R_i(t0) R_j(t1)`` is that of ``R_j(t1)`` (``R_i``
    keeps ``e_i``), which gives ``t1`` from the row ``i`` of ``m``; ``t0`` is then the nearest
    rotation about ``i`` to ``m R_j(t1)^T``, and one more round of the two one-axis fits
    (``t1`` given ``t0``, ``t0`` given ``t1``) settles the pair (the tests check the result
    against a numerical minimisation).

    Parameters
    ----------
    m : array_like, shape (..., 3, 3)
        Rotation matrices.
    axes : str
        One to three distinct axes from ``"XYZ"``, in the order the rotations are
        multiplied (e.g. ``"XZ"``).

    Returns
    -------
    ndarray, shape (..., len(axes))
        Radians in ``[-pi, pi]`` (three axes: as :func:`matrix_to_euler`).
    """
    if not (isinstance(axes, str) and 1 <= len(axes) <= 3 and len(set(axes)) == len(axes)):
        raise ValueError(f"axes: expected one to three distinct axes from 'XYZ' (e.g. 'XZ'); got {axes!r}")
    if any(a not in _AXIS for a in axes):
        raise ValueError(f"axes: expected one to three distinct axes from 'XYZ' (e.g. 'XZ'); got {axes!r}")
    r = np.asarray(m, dtype=np.float64)
    if r.shape[-2:] != (3, 3):
        raise ValueError(f"m: expected shape (..., 3, 3); got {r.shape}")
    if len(axes) == 3:
        return matrix_to_euler(r, axes)
    i = _AXIS[axes[0]]
    if len(axes) == 1:
        return _nearest_about(r, i)[..., None]
    j = _AXIS[axes[1]]
    # row i of R_i(t0) R_j(t1) is e_i^T R_j(t1), i.e. v = R_j(-t1) e_i: the angle from e_i
    # to v about e_j is -t1
    v = r[..., i, :]
    t1 = np.arctan2(np.cross(v, _basis(i, ()))[..., j], v[..., i])
    t0 = _nearest_about(r @ np.swapaxes(axis_rotation(t1, axes[1]), -1, -2), i)
    t1 = _nearest_about(np.swapaxes(axis_rotation(t0, axes[0]), -1, -2) @ r, j)
    t0 = _nearest_about(r @ np.swapaxes(axis_rotation(t1, axes[1]), -1, -2), i)
    return np.stack([t0, t1], axis=-1)


def quaternion_to_matrix(q: np.ndarray, *, normalise: bool = True) -> np.ndarray:
    """Rotation matrices of quaternions in **(w, x, y, z)** order.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar first. Need not be unit length when ``normalise`` is true.
    normalise : bool, default True
        Divide by the norm first (files store quaternions with a few digits, some far
        from unit length).

    Returns
    -------
    ndarray, shape (..., 3, 3)

    Raises
    ------
    ValueError
        If a quaternion has zero (or non-finite) norm.
    """
    q = np.asarray(q, dtype=np.float64)
    if q.shape[-1:] != (4,):
        raise ValueError(f"q: expected quaternions of shape (..., 4) in (w, x, y, z); got {q.shape}")
    if normalise:
        n = np.linalg.norm(q, axis=-1, keepdims=True)
        bad = ~(np.isfinite(n) & (n > 0))
        if bad.any():
            idx = tuple(int(v) for v in np.argwhere(bad[..., 0])[0])
            raise ValueError(f"q: expected non-zero finite quaternions; q{list(idx)} = {q[idx]}")
        q = q / n
    return _quat_parts_to_matrix(q[..., 0], q[..., 1], q[..., 2], q[..., 3])


def matrix_to_quaternion(m: np.ndarray) -> np.ndarray:
    """Unit quaternions **(w, x, y, z)** of rotation matrices, with ``w >= 0``.

    Parameters
    ----------
    m : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 4)
        ``quaternion_to_matrix`` of it gives ``m`` back to rounding (about 1e-16).

    Notes
    -----
    Shepperd's method: the largest of ``4 w^2, 4 x^2, 4 y^2, 4 z^2`` (read off the trace
    and the diagonal) is taken as the pivot, so no division is by a small number.
    """
    m = np.asarray(m, dtype=np.float64)
    if m.shape[-2:] != (3, 3):
        raise ValueError(f"m: expected rotation matrices of shape (..., 3, 3); got {m.shape}")
    d0, d1, d2 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    cand = np.stack([1 + d0 + d1 + d2, 1 + d0 - d1 - d2, 1 - d0 + d1 - d2, 1 - d0 - d1 + d2], axis=-1)
    k = np.argmax(cand, axis=-1)
    s = np.sqrt(np.maximum(np.take_along_axis(cand, k[..., None], axis=-1)[..., 0], 1e-300)) * 2
    r21, r12 = m[..., 2, 1], m[..., 1, 2]
    r02, r20 = m[..., 0, 2], m[..., 2, 0]
    r10, r01 = m[..., 1, 0], m[..., 0, 1]
    rows = [
        np.stack([s / 4, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s], axis=-1),
        np.stack([(r21 - r12) / s, s / 4, (r01 + r10) / s, (r02 + r20) / s], axis=-1),
        np.stack([(r02 - r20) / s, (r01 + r10) / s, s / 4, (r12 + r21) / s], axis=-1),
        np.stack([(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, s / 4], axis=-1),
    ]
    q = np.choose(k[..., None], rows)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def quaternion_slerp(q0: np.ndarray, q1: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions along the shorter arc.

    Parameters
    ----------
    q0, q1 : array_like, shape (..., 4)
        Unit quaternions (any component order: the formula is the same).
    u : array_like, shape (...)
        Interpolation parameter in ``[0, 1]`` (0 gives ``q0``).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions; a normalised linear blend where the two are within 1e-6 rad.
    """
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.clip(np.abs(dot), 0.0, 1.0)
    theta = np.arccos(dot)
    sin = np.sin(theta)
    near = sin < 1e-6
    safe = np.where(near, 1.0, sin)
    w0 = np.where(near, 1 - u, np.sin((1 - u) * theta) / safe)
    w1 = np.where(near, u, np.sin(u * theta) / safe)
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)
