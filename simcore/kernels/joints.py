"""Bilateral joints: revolute, prismatic (with locked rotation) and the prescribed rotation
(rheonomic drive)."""

from __future__ import annotations

import numpy as np
from numba import njit

from .bodies import body_omega, body_point

JOINT_REVOLUTE = 0
JOINT_PRISMATIC = 1
JOINT_ANGLE = 2



@njit(cache=True, error_model="numpy")
def joint_row_count(jt_type):
    """Number of constraint rows of each joint and in total."""
    n = 0
    for j in range(jt_type.shape[0]):
        n += 1 if jt_type[j] == JOINT_ANGLE else 2
    return n


@njit(cache=True, error_model="numpy")
def bilateral(q, v, t, ma, g, G, gamma, dgdt):
    """Evaluate all bilateral constraints.

    Fills ``g`` (position residual [m or rad]), ``G`` (rows x ndof Jacobian), ``gamma``
    (the velocity-squared term of the acceleration constraint, G a + gamma = 0) and ``dgdt``
    (explicit time derivative, rheonomic joints) in place. ``ma``: :class:`ModelArrays`.
    """
    jt_type = ma.jt_type
    jt_body = ma.jt_body
    jt_geom = ma.jt_geom
    G[:, :] = 0.0
    row = 0
    for j in range(jt_type.shape[0]):
        bi = jt_body[j, 0]
        bj = jt_body[j, 1]
        p = jt_geom[j]
        kind = jt_type[j]
        if kind == JOINT_REVOLUTE:
            xi, yi, aix, aiy = body_point(q, bi, p[0], p[1])
            xj, yj, ajx, ajy = body_point(q, bj, p[2], p[3])
            wi = body_omega(v, bi)
            wj = body_omega(v, bj)
            g[row] = xi - xj
            g[row + 1] = yi - yj
            gamma[row] = -aix * wi * wi + ajx * wj * wj
            gamma[row + 1] = -aiy * wi * wi + ajy * wj * wj
            dgdt[row] = 0.0
            dgdt[row + 1] = 0.0
            if bi >= 0:
                G[row, 3 * bi] += 1.0
                G[row, 3 * bi + 2] += -aiy
                G[row + 1, 3 * bi + 1] += 1.0
                G[row + 1, 3 * bi + 2] += aix
            if bj >= 0:
                G[row, 3 * bj] -= 1.0
                G[row, 3 * bj + 2] -= -ajy
                G[row + 1, 3 * bj + 1] -= 1.0
                G[row + 1, 3 * bj + 2] -= ajx
            row += 2
        elif kind == JOINT_PRISMATIC:
            # body bi slides along the ground axis through (p[2], p[3]) at angle p[4];
            # its rotation is locked at p[5]
            xi, yi, aix, aiy = body_point(q, bi, p[0], p[1])
            nx = -np.sin(p[4])
            ny = np.cos(p[4])
            wi = body_omega(v, bi)
            g[row] = nx * (xi - p[2]) + ny * (yi - p[3])
            g[row + 1] = q[3 * bi + 2] - p[5]
            gamma[row] = -(nx * aix + ny * aiy) * wi * wi
            gamma[row + 1] = 0.0
            dgdt[row] = 0.0
            dgdt[row + 1] = 0.0
            G[row, 3 * bi] = nx
            G[row, 3 * bi + 1] = ny
            G[row, 3 * bi + 2] = aix * ny - aiy * nx
            G[row + 1, 3 * bi + 2] = 1.0
            row += 2
        else:
            # prescribed rotation phi = p[0] + p[1] t (rheonomic)
            g[row] = q[3 * bi + 2] - p[0] - p[1] * t
            gamma[row] = 0.0
            dgdt[row] = -p[1]
            G[row, 3 * bi + 2] = 1.0
            row += 1
