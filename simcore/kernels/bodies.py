"""Planar rigid bodies: world points of body-fixed points, angular velocities, and the
two-point Jacobian helpers that joints, springs and contact elements share.

Conventions: ``q``, ``v`` hold 3 entries per body, (x [m], y [m], phi [rad]) and
(vx [m/s], vy [m/s], omega [rad/s]); body index -1 is the ground, whose "local" points are world
points. An element between bodies a and b has 3 + 3 Jacobian entries (``w[0:3]`` for a,
``w[3:6]`` for b); :func:`scatter_row` and :func:`row_dot` map them to generalized rows.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def body_point(q, body, px, py):
    """World position (x, y) and lever arm (ax, ay) = R(phi) p of a body-fixed point [m]."""
    if body < 0:
        return px, py, 0.0, 0.0
    if px == 0.0 and py == 0.0:
        # the body's reference point (a ball's centre): no rotation to evaluate
        return q[3 * body], q[3 * body + 1], 0.0, 0.0
    phi = q[3 * body + 2]
    c = np.cos(phi)
    s = np.sin(phi)
    ax = c * px - s * py
    ay = s * px + c * py
    return q[3 * body] + ax, q[3 * body + 1] + ay, ax, ay


@njit(cache=True, error_model="numpy")
def body_omega(v, body):
    """Angular velocity of a body [rad/s] (0 for the ground)."""
    if body < 0:
        return 0.0
    return v[3 * body + 2]


@njit(cache=True, error_model="numpy")
def unit_direction(dx, dy):
    """Length of (dx, dy) and its unit vector ((1, 0) for a zero vector)."""
    length = np.sqrt(dx * dx + dy * dy)
    if length > 1e-300:
        return length, dx / length, dy / length
    return length, 1.0, 0.0


@njit(cache=True, error_model="numpy")
def pair_point_jacobians(P, aix, aiy, ajx, ajy):
    """P (2 x 6) = d(c_j - c_i)/d(q_i, q_j) for body points with lever arms a_i, a_j."""
    P[:, :] = 0.0
    P[0, 0] = -1.0
    P[1, 1] = -1.0
    P[0, 2] = aiy
    P[1, 2] = -aix
    P[0, 3] = 1.0
    P[1, 4] = 1.0
    P[0, 5] = -ajy
    P[1, 5] = ajx


@njit(cache=True, error_model="numpy")
def point_pair_row(w, ux, uy, aix, aiy, ajx, ajy, sign):
    """w (6) = sign * d[u.(c_j - c_i)]/d(q_i, q_j) for a fixed direction u and body points with
    lever arms a_i, a_j: the row of a spring's length, of a contact's normal or tangent."""
    w[0] = -sign * ux
    w[1] = -sign * uy
    w[2] = -sign * (aix * uy - aiy * ux)
    w[3] = sign * ux
    w[4] = sign * uy
    w[5] = sign * (ajx * uy - ajy * ux)


@njit(cache=True, error_model="numpy")
def transverse_form(P, nx, ny, a, c):
    """Entry (a, c) of P^T (I - n n^T) P: the change of direction of a two-point distance."""
    return (P[0, a] * ((1.0 - nx * nx) * P[0, c] - nx * ny * P[1, c])
            + P[1, a] * (-nx * ny * P[0, c] + (1.0 - ny * ny) * P[1, c]))


@njit(cache=True, error_model="numpy")
def scatter_row(row, w, ia, ib):
    """Write the 6 element entries of ``w`` into a dense generalized row."""
    row[:] = 0.0
    if ia >= 0:
        for a in range(3):
            row[3 * ia + a] += w[a]
    if ib >= 0:
        for a in range(3):
            row[3 * ib + a] += w[3 + a]


@njit(cache=True, error_model="numpy")
def row_dot(w, ia, ib, x):
    s = 0.0
    if ia >= 0:
        for a in range(3):
            s += w[a] * x[3 * ia + a]
    if ib >= 0:
        for a in range(3):
            s += w[3 + a] * x[3 * ib + a]
    return s
